// Stereo footage (issue 28): both eyes of a head over one scene, and the
// side-by-side frame form (docs/formats.md).
#include <opencv2/core.hpp>

#include "dentar/ar/synth.h"

namespace dentar::ar {

Result<std::unique_ptr<StereoSynthGenerator>> StereoSynthGenerator::create(const StationScene& station,
                                                                           const SynthOptions& options,
                                                                           const std::string& session_log_path) {
  if (!station.stereo.present)
    return Error{"StereoSynthGenerator: the station has no stereo rig (station file \"stereo\"; "
                 "dentar synth --stereo adds one with --baseline-mm)"};
  SynthOptions ol = options, orr = options;
  ol.eye = 0;
  ol.T_rig_eye = Eigen::Isometry3d::Identity();
  orr.eye = 1;
  orr.T_rig_eye = station.stereo.T_caml_camr;
  auto l = SynthGenerator::create(station, ol, session_log_path);
  if (!l) return Error{"left eye: " + l.error()};
  // The right eye renders through its own camera; its "other eye" is the left.
  StationScene sr = station;
  sr.calibration.camera = station.stereo.camera_right;
  sr.stereo.camera_right = station.calibration.camera;
  sr.stereo.T_caml_camr = station.stereo.T_caml_camr.inverse();
  auto r = SynthGenerator::create(sr, orr);
  if (!r) return Error{"right eye: " + r.error()};
  std::unique_ptr<StereoSynthGenerator> g(new StereoSynthGenerator);
  g->left_ = std::move(l).value();
  g->right_ = std::move(r).value();
  g->station_ = g->left_->station();
  g->station_.stereo.camera_right = g->right_->station().calibration.camera;
  return g;
}

Status StereoSynthGenerator::next(StereoSynthFrame& out) {
  if (Status s = left_->next(out.left); !s) return Error{"left eye: " + s.error()};
  if (Status s = right_->next(out.right); !s) return Error{"right eye: " + s.error()};
  return {};
}

Status StereoSynthGenerator::finish() {
  if (Status s = left_->finish(); !s) return s;
  return right_->finish();
}

Result<cv::Mat> side_by_side(const cv::Mat& left, const cv::Mat& right) {
  if (left.empty() || right.empty()) return Error{"side_by_side: an eye's image is empty"};
  if (left.size() != right.size() || left.type() != right.type())
    return Error{"side_by_side: the left eye's image is " + std::to_string(left.cols) + "x" +
                 std::to_string(left.rows) + " px (" + cv::typeToString(left.type()) + "), the right eye's " +
                 std::to_string(right.cols) + "x" + std::to_string(right.rows) + " px (" +
                 cv::typeToString(right.type()) + "): both eyes must be the same size and type"};
  cv::Mat out;
  cv::hconcat(left, right, out);
  return out;
}

Status split_side_by_side(const cv::Mat& frame, cv::Mat& left, cv::Mat& right, const std::string& what) {
  if (frame.empty()) return Error{what + ": the side-by-side frame is empty"};
  if (frame.cols % 2 != 0)
    return Error{what + ": a side-by-side frame must have an even width (left eye | right eye), this one is " +
                 std::to_string(frame.cols) + "x" + std::to_string(frame.rows) +
                 " px; is it a single camera's frame? (drop --stereo)"};
  const int w = frame.cols / 2;
  left = frame(cv::Rect(0, 0, w, frame.rows));
  right = frame(cv::Rect(w, 0, w, frame.rows));
  return {};
}

}  // namespace dentar::ar
