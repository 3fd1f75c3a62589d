// See board_clip.h.
#include "dentar/ar/board_clip.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <random>

#include "dentar/ar/calib_board.h"

namespace dentar::ar {
namespace fs = std::filesystem;

std::string BoardClipOptions::validate() const {
  if (auto s = parse_board_spec(board); !s) return "board: " + s.error();
  if (holds < 1 || holds > 200) return "holds must be in [1, 200]";
  if (!(hold_s >= 0.2 && hold_s <= 60)) return "hold_s must be in [0.2, 60] s";
  if (!(move_s >= 0.1 && move_s <= 60)) return "move_s must be in [0.1, 60] s";
  if (!(fps >= 1 && fps <= 120)) return "fps must be in [1, 120]";
  if (!(shutter >= 0 && shutter <= 1)) return "shutter must be in [0, 1]";
  if (!(noise_dn >= 0 && noise_dn <= 50)) return "noise_dn must be in [0, 50]";
  return {};
}

namespace {
Eigen::Isometry3d blend(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double s) {
  const double w = s * s * (3 - 2 * s);  // smoothstep: a hand starts and stops gently
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(a.linear()).slerp(w, Eigen::Quaterniond(b.linear())).toRotationMatrix();
  T.translation() = (1 - w) * a.translation() + w * b.translation();
  return T;
}

// The pose at time t: a lead-in from below the image to hold 0, then hold, move, hold, ...
struct Path {
  std::vector<Eigen::Isometry3d> holds;
  Eigen::Isometry3d start;
  double hold_s, move_s;
  double duration() const { return holds.size() * (hold_s + move_s); }
  Eigen::Isometry3d at(double t, int& hold) const {
    const double period = hold_s + move_s;
    const int i = std::min(static_cast<int>(holds.size()) - 1, std::max(0, static_cast<int>(std::floor(t / period))));
    const double r = t - i * period;
    if (r >= move_s) {
      hold = i;
      return holds[static_cast<std::size_t>(i)];
    }
    hold = -1;
    const Eigen::Isometry3d& from = i == 0 ? start : holds[static_cast<std::size_t>(i - 1)];
    return blend(from, holds[static_cast<std::size_t>(i)], r / move_s);
  }
};

Path make_path(const calibration::CameraIntrinsics& k, const BoardClipOptions& o, const BoardSpec& spec) {
  Path p;
  p.holds = calibration::plan_board_poses(k, board_width_m(spec), board_height_m(spec), o.holds, o.seed);
  // From the 11th hold on, the board is pushed toward the image's corners and edges (partly out
  // of view, as an instructor covering the corners does): the poses plan_board_poses gives stay
  // within the middle 94 %, and a lens model is only trusted where the boards reached.
  const double targets[][2] = {{0.16, 0.16}, {0.84, 0.16}, {0.84, 0.84}, {0.16, 0.84}, {0.5, 0.12}, {0.5, 0.88}, {0.1, 0.5}, {0.9, 0.5}};
  const Eigen::Vector3d centre(board_width_m(spec) / 2, board_height_m(spec) / 2, 0);
  for (int i = 10; i < o.holds; ++i) {
    Eigen::Isometry3d& T = p.holds[static_cast<std::size_t>(i)];
    const double* t = targets[(i - 10) % 8];
    const double d = (T * centre).z();
    const Eigen::Vector3d ray((t[0] * k.width - k.cx) / k.fx, (t[1] * k.height - k.cy) / k.fy, 1.0);
    T.translation() = ray * d - T.linear() * centre;
  }
  p.hold_s = o.hold_s;
  p.move_s = o.move_s;
  p.start = p.holds.front();
  // Brought up from below the image (camera +y is down in the image).
  p.start.translation() += Eigen::Vector3d(0, 0.6 * p.holds.front().translation().z(), 0);
  return p;
}
}  // namespace

std::vector<BoardClipFrame> plan_board_clip(const calibration::CameraIntrinsics& k, const BoardClipOptions& o) {
  std::vector<BoardClipFrame> out;
  auto spec = parse_board_spec(o.board);
  if (!spec || !o.validate().empty()) return out;
  const Path p = make_path(k, o, *spec);
  const int n = static_cast<int>(std::ceil(p.duration() * o.fps));
  for (int f = 0; f < n; ++f) {
    BoardClipFrame fr;
    fr.t_s = f / o.fps;
    fr.T_cam_board = p.at(fr.t_s, fr.hold);
    out.push_back(fr);
  }
  return out;
}

Result<BoardClipSummary> write_board_clip(const calibration::CameraIntrinsics& k, const BoardClipOptions& o,
                                          const std::string& out_dir, const std::function<void(int)>& progress) {
  if (std::string e = o.validate(); !e.empty()) return Error{"board clip: " + e};
  auto spec = parse_board_spec(o.board);
  const auto t_begin = std::chrono::steady_clock::now();
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) return Error{out_dir + ": cannot create the folder: " + ec.message()};
  const fs::path dir(out_dir);
  const Path path = make_path(k, o, *spec);
  const std::vector<BoardClipFrame> frames = plan_board_clip(k, o);
  const BoardTexture tex = make_board_texture(*spec);

  BoardClipSummary sum;
  sum.video_path = (dir / "video.mkv").string();
  cv::VideoWriter video(sum.video_path, cv::CAP_FFMPEG, cv::VideoWriter::fourcc('F', 'F', 'V', '1'), o.fps,
                        cv::Size(k.width, k.height), true);
  if (!video.isOpened()) return Error{sum.video_path + ": cannot open an FFV1 video writer (OpenCV without FFmpeg?)"};
  std::ofstream truth(dir / "board_truth.jsonl", std::ios::trunc);
  if (!truth) return Error{(dir / "board_truth.jsonl").string() + ": cannot open for writing"};

  std::mt19937_64 rng(o.seed * 31 + 5);
  std::normal_distribution<float> noise(0.0f, static_cast<float>(o.noise_dn));
  int cached_hold = -2;
  cv::Mat cached;  // the noise-free render of the current hold (CV_32F)
  for (std::size_t f = 0; f < frames.size(); ++f) {
    const BoardClipFrame& fr = frames[f];
    cv::Mat acc;
    BoardRenderOptions ro;
    ro.noise_sigma_dn = 0;
    ro.seed = o.seed;
    if (fr.hold >= 0) {
      if (fr.hold != cached_hold) {
        ro.supersample = 2;
        render_board_view(tex, k, fr.T_cam_board, ro).convertTo(cached, CV_32F);
        cached_hold = fr.hold;
      }
      acc = cached.clone();
    } else {
      // Motion blur: 2 sub-frames at the ends of the exposure (cheap; enough to smear the tags).
      ro.supersample = 1;
      acc = cv::Mat(k.height, k.width, CV_32F, cv::Scalar(0));
      const int subs = o.shutter > 0 ? 2 : 1;
      for (int j = 0; j < subs; ++j) {
        const double dt = subs == 1 ? 0 : (j - 0.5) * o.shutter / o.fps;
        int h = 0;
        cv::Mat one;
        render_board_view(tex, k, path.at(std::max(0.0, fr.t_s + dt), h), ro).convertTo(one, CV_32F);
        acc += one / subs;
      }
    }
    if (o.noise_dn > 0)
      for (int v = 0; v < acc.rows; ++v) {
        float* row = acc.ptr<float>(v);
        for (int u = 0; u < acc.cols; ++u) row[u] += noise(rng);
      }
    cv::Mat gray, bgr;
    acc.convertTo(gray, CV_8U);
    cv::cvtColor(gray, bgr, cv::COLOR_GRAY2BGR);
    video.write(bgr);
    const Eigen::Matrix4d m = fr.T_cam_board.matrix();
    nlohmann::json row = {{"frame", f}, {"t_s", fr.t_s}, {"hold", fr.hold}, {"still", fr.hold >= 0}};
    std::vector<double> T;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) T.push_back(m(r, c));
    row["T_cam_board"] = T;
    truth << row.dump() << "\n";
    if (progress) progress(static_cast<int>(f) + 1);
  }
  video.release();
  if (!truth) return Error{(dir / "board_truth.jsonl").string() + ": write failed"};
  calibration::CameraFile cf;
  cf.camera = k;
  cf.dist = {k.dist[0], k.dist[1], k.dist[2], k.dist[3], k.dist[4]};
  cf.device = "board clip true camera (seed " + std::to_string(o.seed) + ")";
  if (Status s = calibration::write_camera_file((dir / "camera.yaml").string(), cf); !s) return Error{s.error()};
  nlohmann::ordered_json meta = {{"kind", "board_clip"},
                                 {"board", o.board},
                                 {"holds", o.holds},
                                 {"hold_s", o.hold_s},
                                 {"move_s", o.move_s},
                                 {"fps", o.fps},
                                 {"frames", frames.size()},
                                 {"seed", o.seed},
                                 {"width", k.width},
                                 {"height", k.height},
                                 {"video", "video.mkv"},
                                 {"camera", "camera.yaml"},
                                 {"truth", "board_truth.jsonl"}};
  std::ofstream(dir / "clip.json") << meta.dump(2) << "\n";
  sum.frames = static_cast<int>(frames.size());
  sum.duration_s = frames.size() / o.fps;
  sum.render_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_begin).count();
  return sum;
}

}  // namespace dentar::ar
