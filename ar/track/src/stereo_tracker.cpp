#include "dentar/ar/stereo_tracker.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <map>
#include <optional>
#include <opencv2/imgproc.hpp>
#include <string>
#include <utility>
#include <vector>

#include "dentar/ar/bundle_pose.h"
#include "dentar/ar/camera_model.h"
#include "dentar/ar/image_motion.h"
#include "dentar/ar/mirror_rim.h"
#include "dentar/ar/pose_filter.h"
#include "dentar/ar/pose_uncertainty.h"
#include "track_rules.h"

namespace dentar::ar {

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// One body in the rig frame (the mono tracker's Body, for the joint fit).
struct RigBody {
  TagBundle bundle;
  PoseFilter filter;
  bool has_measurement = false;
  double last_meas_time_s = 0;
  Eigen::Isometry3d last_meas = Eigen::Isometry3d::Identity();
  int meas_in_track = 0;
  TrackState state = TrackState::kLost;
  double max_sigma_m = 0;
  Eigen::Vector3d gate_point = Eigen::Vector3d::Zero();
  bool static_in_world = false;
  cv::Mat thumb_at_meas;
  // TrackerOptions::mirror_prediction_sigma: the gate point's sigma at the
  // last measurement (m) and the mean square of the speed the filter did not
  // predict there ((m/s)^2, over the track's measurements; n of them).
  double last_sigma_m = 0;
  double unexplained_speed2 = 0;
  int unexplained_n = 0;
};

using Mat6 = Eigen::Matrix<double, 6, 6>;

// Tags in a joint fit, each counted once however many eyes saw it.
int distinct_tags(const BundlePose& p) {
  std::vector<int> ids = p.tag_ids;
  std::sort(ids.begin(), ids.end());
  return static_cast<int>(std::unique(ids.begin(), ids.end()) - ids.begin());
}

// A (w, v) covariance in frame a (bundle_pose.h) expressed in frame b, for
// T_b_a: both halves rotate with R_b_a.
Mat6 rotate_covariance(const Mat6& C, const Eigen::Matrix3d& R_b_a) {
  Mat6 A = Mat6::Zero();
  A.topLeftCorner<3, 3>() = R_b_a;
  A.bottomRightCorner<3, 3>() = R_b_a;
  return A * C * A.transpose();
}

}  // namespace

struct StereoTracker::Impl {
  TrackerOptions o;  // as resolved by the left eye's tracker
  std::optional<Tracker> left, right;
  calibration::CameraIntrinsics cam_l, cam_r;
  Eigen::Isometry3d T_camr_caml = Eigen::Isometry3d::Identity();
  CameraModel model_l{calibration::CameraIntrinsics{}};
  CameraModel model_r{calibration::CameraIntrinsics{}};
  // The mirror disc (TrackerOptions::stereo_mirror_rim).
  Eigen::Isometry3d T_mtag_mir = Eigen::Isometry3d::Identity();
  double mirror_radius_m = 0, mirror_thickness_m = 0;
  cv::Mat image_l, image_r;  // this frame's images (headers; empty = the eye has none)
  cv::Mat rim_gray_l, rim_gray_r;
  RigBody mannequin, mirror, pen;
  std::optional<BundlePose> noise_ref;  // the mannequin's joint fit this frame
  ImageMotion motion;
  bool motion_set = false;
  bool motion_frame = false;                        // this frame's left image is in `motion`
  bool left_missing = false, right_missing = false;  // the eye had no image last frame
  StereoTracker::EyeRunner run_eyes;                 // empty: the eyes one after the other
  double noise_px2(const RigBody& b, const BundlePose& p) const {
    if (!o.pool_noise || &b == &mannequin || !noise_ref) return p.noise_px2;
    return pooled_noise_px2(p, &*noise_ref, o.pool_comparable_tags);
  }
  double uniform_sigma(const RigBody& b, const BundlePose& p) const {
    return point_sigma_m(covariance_with_noise(p, noise_px2(b, p), o.sigma_floor_px), p.T_cam_body, b.gate_point);
  }
  double per_tag_sigma(const RigBody& b, const BundlePose& p) const {
    const double floor = point_sigma_m(p.covariance_per_px2 * (o.sigma_floor_px * o.sigma_floor_px),
                                       p.T_cam_body, b.gate_point);
    return std::max(floor, point_sigma_m(p.covariance_per_tag, p.T_cam_body, b.gate_point));
  }
  bool precise_enough(const RigBody& b, const BundlePose& p) const {
    const double s = o.sigma_per_tag ? per_tag_sigma(b, p) : uniform_sigma(b, p);
    return b.max_sigma_m <= 0 || s <= b.max_sigma_m;
  }

  // The mono tracker's image-motion check on the left eye's image
  // (TrackerOptions::max_prediction_turn_rad).
  bool prediction_matches_image(const RigBody& b, double capture_s) {
    if (o.max_prediction_turn_rad <= 0 || !motion_frame || b.thumb_at_meas.empty()) return true;
    const ImageMotion::Shift sh = motion.shift_since(b.thumb_at_meas);
    if (!sh.valid || sh.response < o.min_motion_response) return false;
    Eigen::Vector2d expect = Eigen::Vector2d::Zero();
    if (o.filter_enabled && b.filter.initialised()) {
      auto a = model_l.project(b.filter.predict(capture_s).translation());
      auto c = model_l.project(b.last_meas.translation());
      if (a && c) expect = *a - *c;
    }
    const double unexplained = b.static_in_world ? (sh.px - expect).norm()
                                                 : std::max(0.0, sh.px.norm() - expect.norm());
    return unexplained / cam_l.fx <= o.max_prediction_turn_rad;
  }

  // The rim's grey image (CV_8UC1): BGR as COLOR_BGR2GRAY; YUYV 4:2:2 (CV_8UC2, a UVC
  // camera's own format) as its luma stretched from 16..235 to full range (the same grey
  // levels within one as BGR2GRAY of the decoded colour); grey as given. Anything else:
  // empty (the rim is skipped for that eye).
  // Only the rectangle `roi` (clipped to the image; x and width even for YUYV) is converted:
  // the rim reads the pixels around the disc, and the frame's cost should follow what is
  // drawn, not the camera's resolution. Pixels outside it are zero.
  static cv::Mat to_gray(const cv::Mat& image, cv::Rect roi, cv::Mat& scratch) {
    if (image.type() == CV_8UC1) return image;
    if (image.type() != CV_8UC3 && image.type() != CV_8UC2) return cv::Mat();
    if (image.type() == CV_8UC2) {  // whole pixel pairs
      const int x0 = roi.x & ~1;
      roi.width = ((roi.x + roi.width - x0) + 1) & ~1;
      roi.x = x0;
    }
    roi &= cv::Rect(0, 0, image.cols, image.rows);
    scratch.create(image.size(), CV_8UC1);
    scratch.setTo(0);
    if (roi.area() <= 0) return scratch;
    cv::Mat out = scratch(roi);
    if (image.type() == CV_8UC3) {
      cv::cvtColor(image(roi), out, cv::COLOR_BGR2GRAY);
    } else {
      cv::Mat y;
      cv::cvtColor(image(roi), y, cv::COLOR_YUV2GRAY_YUYV);
      y.convertTo(out, CV_8U, 255.0 / 219.0, -16.0 * 255.0 / 219.0);
    }
    return scratch;
  }

  // The disc's outline in an eye (T_cam_mir), grown by a margin for the rim's edge search
  // and its correction.
  cv::Rect disc_box(const CameraModel& model, const Eigen::Isometry3d& T_cam_mir) const {
    double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
    for (int k = 0; k < 16; ++k) {
      const double a = 2 * M_PI * k / 16;
      for (double z : {0.0, -mirror_thickness_m}) {
        const auto q = model.project(T_cam_mir * Eigen::Vector3d(mirror_radius_m * std::cos(a),
                                                                 mirror_radius_m * std::sin(a), z));
        if (!q) continue;
        x0 = std::min(x0, q->x());
        y0 = std::min(y0, q->y());
        x1 = std::max(x1, q->x());
        y1 = std::max(y1, q->y());
      }
    }
    if (x1 < x0) return cv::Rect();
    const double m = 4 * o.mirror_rim.search_px + 16;  // px
    x0 = std::clamp(x0 - m, -1.0, 1e5);
    y0 = std::clamp(y0 - m, -1.0, 1e5);
    x1 = std::clamp(x1 + m, -1.0, 1e5);
    y1 = std::clamp(y1 + m, -1.0, 1e5);
    return cv::Rect(cv::Point(static_cast<int>(std::floor(x0)), static_cast<int>(std::floor(y0))),
                    cv::Point(static_cast<int>(std::ceil(x1)) + 1, static_cast<int>(std::ceil(y1)) + 1));
  }

  // TrackerOptions::stereo_mirror_rim: the rim in the left eye on the joint
  // fit as the prior, then in the right eye on the left's result. The pose
  // and its covariances stay in `rig`; an eye without an image, or whose rim
  // is not found, leaves the pose as it was. Returns the rim edges used.
  int refine_rim_both_eyes(BundlePose& p, const RigBody& b) {
    const double floor2 = o.sigma_floor_px * o.sigma_floor_px;
    const double noise2 = std::max(noise_px2(b, p), floor2);
    const bool srgb = o.detector.response == CameraResponse::kSrgb;
    MirrorRimOptions ro = o.mirror_rim;
    ro.rim_effective_points = o.stereo_mirror_rim_effective_points;  // per eye
    // Tags from one eye only (the other sees none: the mirror at its frame's
    // edge): the depth is the one camera's, as in mono (offframe dev clip,
    // seed 1: a free depth moved such frames 1.4-2.1 mm along the line of
    // sight).
    ro.keep_depth = o.stereo_mirror_rim_keep_depth || p.views_used < 2;
    // ... and only that eye's rim is used (the other eye's rim on a one-eye
    // prior moves the centre in depth: offframe seed 5, frames 20-21).
    bool tags_l = p.views_used >= 2, tags_r = p.views_used >= 2;
    for (const BundlePose::TagResidual& t : p.tag_residuals) (t.view == 0 ? tags_l : tags_r) = true;
    int points = 0;
    const Eigen::Isometry3d T_caml_mir = p.T_cam_body * T_mtag_mir;
    const cv::Mat gray_l =
        !image_l.empty() && tags_l ? to_gray(image_l, disc_box(model_l, T_caml_mir), rim_gray_l) : cv::Mat();
    const cv::Mat gray_r = !image_r.empty() && tags_r
                               ? to_gray(image_r, disc_box(model_r, T_camr_caml * T_caml_mir), rim_gray_r)
                               : cv::Mat();
    if (!gray_l.empty()) {
      const MirrorRimResult r = refine_mirror_rim(gray_l, srgb, model_l, p, noise2, T_mtag_mir,
                                                  mirror_radius_m, mirror_thickness_m, ro);
      if (r.refined) {
        p.T_cam_body = r.T_cam_body;
        p.covariance_per_px2 = r.covariance_per_px2;
        p.covariance_per_tag = r.covariance_per_tag;
        points += r.points;
      }
    }
    if (!gray_r.empty()) {
      BundlePose pr = p;  // the prior, in the right eye's frame
      pr.T_cam_body = T_camr_caml * p.T_cam_body;
      pr.covariance_per_px2 = rotate_covariance(p.covariance_per_px2, T_camr_caml.linear());
      pr.covariance_per_tag = rotate_covariance(p.covariance_per_tag, T_camr_caml.linear());
      const MirrorRimResult r = refine_mirror_rim(gray_r, srgb, model_r, pr, noise2, T_mtag_mir,
                                                  mirror_radius_m, mirror_thickness_m, ro);
      if (r.refined) {
        const Eigen::Matrix3d R_caml_camr = T_camr_caml.linear().transpose();
        p.T_cam_body = T_camr_caml.inverse() * r.T_cam_body;
        p.covariance_per_px2 = rotate_covariance(r.covariance_per_px2, R_caml_camr);
        p.covariance_per_tag = rotate_covariance(r.covariance_per_tag, R_caml_camr);
        points += r.points;
      }
    }
    p.covariance = p.covariance_per_px2 * p.noise_px2;
    return points;
  }

  // TrackerOptions::mirror_prediction_sigma, on a measurement: the speed at
  // the gate point that the filter's prediction did not explain.
  void note_unexplained_motion(RigBody& b, const std::optional<Eigen::Isometry3d>& predicted,
                               const Eigen::Isometry3d& measured, double capture_s) {
    if (b.state == TrackState::kLost || !predicted || !o.filter_enabled) {
      b.unexplained_speed2 = 0;
      b.unexplained_n = 0;
      return;
    }
    const double dt = std::max(capture_s - b.last_meas_time_s, 1e-3);
    const double speed = ((measured * b.gate_point) - (*predicted * b.gate_point)).norm() / dt;
    ++b.unexplained_n;
    b.unexplained_speed2 += (speed * speed - b.unexplained_speed2) / std::min(b.unexplained_n, 8);
  }

  // TrackerOptions::mirror_prediction_sigma: the prediction's stated sigma at
  // the gate point at time t_s.
  double predicted_sigma(const RigBody& b, double t_s) const {
    const double q = std::max(std::sqrt(b.unexplained_speed2), o.mirror_min_unexplained_speed_m_s);
    const double age = std::max(0.0, t_s - b.last_meas_time_s);
    return std::hypot(b.last_sigma_m, q * age);
  }

  // TrackerOptions::mirror_prediction_sigma, on a predicted frame: the stated
  // sigma at display time; lost once it exceeds the gate.
  double predicted_sigma_or_lose(RigBody& b, double display_s) {
    const double sigma = predicted_sigma(b, display_s);
    if (b.max_sigma_m > 0 && sigma > b.max_sigma_m) {
      b.state = TrackState::kLost;
      b.has_measurement = false;
      b.filter.reset();
    }
    return sigma;
  }

  void update_body(RigBody& b, const std::vector<DetectedTag>& tags_l, const std::vector<DetectedTag>& tags_r,
                   double capture_s, double display_s, StereoBodyTrack& out) {
    out = StereoBodyTrack{};
    out.track.name = b.bundle.name;
    std::optional<Eigen::Isometry3d> prev;
    if (b.state != TrackState::kLost)
      prev = o.filter_enabled && b.filter.initialised() ? b.filter.predict(capture_s) : b.last_meas;
    bool measured = false;
    if (!tags_l.empty() || !tags_r.empty()) {
      BundlePoseOptions po = track_rules::pose_options_for(o, &b == &mannequin);
      if (&b == &mirror) po.tag_outline_sigma = o.stereo_mirror_outline_sigma;
      BundlePose p = estimate_bundle_pose_views(
          b.bundle, {BundleView{&cam_l, Eigen::Isometry3d::Identity(), &tags_l},
                     BundleView{&cam_r, T_camr_caml, &tags_r}},
          po, prev);
      if (&b == &mannequin) noise_ref = p;
      int rim_points = 0;
      if (&b == &mirror && o.stereo_mirror_rim && p.ok() && p.rms_px <= o.max_rms_px && mirror_radius_m > 0 &&
          (o.stereo_mirror_rim_count_sightings ? p.tags_used : distinct_tags(p)) >= o.stereo_mirror_rim_min_tags) {
        // TrackerOptions::stereo_mirror_rim_one_tag_chi2: with one distinct tag the rim's two-fold
        // tilt can pick the wrong branch; its centre must stay within the tags' own stated error.
        const bool one_tag = distinct_tags(p) < 2;
        const BundlePose p_tags = one_tag ? p : BundlePose{};
        rim_points = refine_rim_both_eyes(p, b);
        if (one_tag && rim_points > 0 && o.stereo_mirror_rim_one_tag_chi2 > 0) {
          const Eigen::Matrix3d C = point_covariance(
              covariance_with_noise(p_tags, noise_px2(b, p_tags), o.sigma_floor_px), p_tags.T_cam_body, b.gate_point);
          const Eigen::Vector3d d = p.T_cam_body * b.gate_point - p_tags.T_cam_body * b.gate_point;
          const double m2 = d.dot(C.ldlt().solve(d));
          if (!(m2 <= o.stereo_mirror_rim_one_tag_chi2)) {
            p = p_tags;
            rim_points = 0;
          }
        }
      }
      // TrackerOptions::stereo_mirror_outline_sigma: a fit whose tags one eye alone saw
      // states the error a common outline offset of each tag observation makes in its depth
      // (the rim keeps that depth: refine_rim_both_eyes); the pose is the fit's either way.
      // Two eyes' fits are left as they are: adding the tags-only fit's outline part to a
      // rim-refined two-eye covariance hid good frames (issue 28 session 18, `mirror` 6:
      // 48 -> 27 drawn).
      if (&b == &mirror && po.tag_outline_sigma > 0 && p.ok() && p.views_used == 1) {
        p.covariance_per_tag += p.outline_covariance_per_px2 * noise_px2(b, p);
        p.covariance_per_px2 += p.outline_covariance_per_px2;
        p.covariance = p.covariance_per_px2 * p.noise_px2;
      }
      if (p.ok() && p.rms_px <= o.max_rms_px && precise_enough(b, p)) {
        measured = true;
        BodyTrack& t = out.track;
        t.T_cam_body_measured = p.T_cam_body;
        t.rms_px = p.rms_px;
        t.tags_used = p.tags_used;
        t.tag_ids = p.tag_ids;
        t.rejected_id = p.rejected_id;
        t.covariance = p.covariance_per_px2 * noise_px2(b, p);
        t.sigma_m = uniform_sigma(b, p);
        t.sigma_per_tag_m = per_tag_sigma(b, p);
        t.rim_points = rim_points;
        out.views_used = p.views_used;
      }
    }
    const bool stated_prediction = &b == &mirror && o.mirror_prediction_sigma;
    if (measured) {
      if (stated_prediction) {
        note_unexplained_motion(b, prev, out.track.T_cam_body_measured, capture_s);
        b.last_sigma_m = o.sigma_per_tag ? out.track.sigma_per_tag_m : out.track.sigma_m;
      }
      track_rules::accept_measurement(b, out.track.T_cam_body_measured, capture_s);
      if (motion_frame)
        motion.keep(b.thumb_at_meas);
      else
        b.thumb_at_meas.release();  // measured without the left image: nothing to compare later
    } else {
      track_rules::predict_or_lose(b, o, capture_s, [&] { return prediction_matches_image(b, capture_s); });
      if (stated_prediction && b.state == TrackState::kPredicted) {
        out.track.sigma_m = predicted_sigma_or_lose(b, display_s);
        out.track.sigma_per_tag_m = out.track.sigma_m;
      }
    }
    out.track.measured = measured;
    out.track.state = b.state;
    out.track.since_measurement_s = b.has_measurement ? capture_s - b.last_meas_time_s : 0;
    if (b.state != TrackState::kLost)
      out.track.T_cam_body = o.filter_enabled ? b.filter.predict(display_s) : b.last_meas;
  }
};

StereoTracker::StereoTracker(StereoTracker&&) noexcept = default;
StereoTracker& StereoTracker::operator=(StereoTracker&&) noexcept = default;
StereoTracker::~StereoTracker() = default;

Result<StereoTracker> StereoTracker::create(const StationScene& station, const TrackerOptions& options) {
  if (!station.stereo.present)
    return Error{"StereoTracker: the station has no stereo rig (station file \"stereo\": camera_right, "
                 "T_left_right); use Tracker for one camera"};
  if (auto e = station.stereo.validate(station.calibration.camera); !e.empty())
    return Error{"StereoTracker: station " + e};
  if (options.discovery != DiscoveryMode::kInline)
    return Error{std::string("StereoTracker: TrackerOptions.discovery = ") + discovery_mode_name(options.discovery) +
                 ": only inline discovery is supported with two eyes"};
  if (options.track_pen && station.pen.tags.empty())
    return Error{"StereoTracker: track_pen is set but the station has no pen (station file \"pen\".tags)"};
  // The eyes' trackers find the tags; the gates act on the joint fit.
  TrackerOptions eye = options;
  eye.mannequin_max_sigma_m = 0;
  eye.mirror_max_sigma_m = 0;
  eye.pen_max_sigma_m = 0;
  eye.mirror_rim_refine = false;
  auto l = Tracker::create(station, eye);
  if (!l) return Error{"StereoTracker (left eye): " + l.error()};
  StationScene sr = station;
  sr.calibration.camera = station.stereo.camera_right;
  auto r = Tracker::create(sr, eye);
  if (!r) return Error{"StereoTracker (right eye): " + r.error()};
  StereoTracker t;
  t.impl_ = std::make_unique<Impl>();
  Impl& m = *t.impl_;
  m.o = options;
  m.o.detector = l->options().detector;  // the response as resolved
  m.left.emplace(std::move(l).value());
  m.right.emplace(std::move(r).value());
  m.cam_l = station.calibration.camera;
  m.cam_r = station.stereo.camera_right;
  m.T_camr_caml = station.stereo.T_caml_camr.inverse();
  m.model_l = CameraModel(m.cam_l);
  m.model_r = CameraModel(m.cam_r);
  m.T_mtag_mir = station.calibration.T_mtag_mir;
  m.mirror_radius_m = station.calibration.mirror_radius_m;
  m.mirror_thickness_m = station.mirror.thickness_m;
  m.mannequin.bundle = mannequin_bundle(station);
  m.mannequin.max_sigma_m = options.mannequin_max_sigma_m;
  m.mannequin.static_in_world = true;
  m.mirror.bundle = mirror_bundle(station);
  m.mirror.max_sigma_m = options.mirror_max_sigma_m;
  m.mirror.gate_point = station.calibration.T_mtag_mir.translation();
  if (options.track_pen) {
    m.pen.bundle = TagBundle{"pen", station.family, station.pen.tags};
    m.pen.max_sigma_m = options.pen_max_sigma_m;
  }
  for (RigBody* b : {&m.mannequin, &m.mirror, &m.pen}) b->filter = PoseFilter(options.filter);
  return t;
}

void StereoTracker::reset() {
  impl_->left->reset();
  impl_->right->reset();
  impl_->left_missing = impl_->right_missing = false;
  for (RigBody* b : {&impl_->mannequin, &impl_->mirror, &impl_->pen}) {
    b->filter.reset();
    b->has_measurement = false;
    b->state = TrackState::kLost;
    b->meas_in_track = 0;
    b->thumb_at_meas.release();
    b->unexplained_speed2 = 0;
    b->unexplained_n = 0;
  }
}

const TrackerOptions& StereoTracker::options() const { return impl_->o; }

void StereoTracker::set_eye_runner(EyeRunner run) { impl_->run_eyes = std::move(run); }

Result<StereoTrackFrame> StereoTracker::track(const cv::Mat& left, const cv::Mat& right, double capture_time_s,
                                              double display_time_s) {
  Impl& m = *impl_;
  const auto t0 = Clock::now();
  if (left.empty() && right.empty())
    return Error{"StereoTracker::track: both eyes' images are empty (give at least one eye)"};
  if (!left.empty() && !right.empty() && left.size() != right.size())
    return Error{"StereoTracker::track: the eyes' images differ in size (left " + std::to_string(left.cols) + "x" +
                 std::to_string(left.rows) + ", right " + std::to_string(right.cols) + "x" +
                 std::to_string(right.rows) + " px): a stereo pair must be two images of one size"};
  StereoTrackFrame f;
  // An eye without an image this frame (lost: unplugged, stalled): its tracker is not run and
  // the joint fit has the other eye's corners only (the single-view path). An eye that comes
  // back starts afresh (its own regions predate the loss).
  // Each eye's own tracker (they share nothing: set_eye_runner may run them in parallel).
  std::string err_l, err_r;
  const auto eye_job = [&](bool is_left) {
    const cv::Mat& image = is_left ? left : right;
    if (image.empty()) return;
    Tracker& t = is_left ? *m.left : *m.right;
    if (is_left ? m.left_missing : m.right_missing) t.reset();
    auto fe = t.track(image, capture_time_s, display_time_s);
    if (!fe) (is_left ? err_l : err_r) = fe.error();
    else (is_left ? f.left : f.right) = std::move(fe).value();
  };
  const std::function<void()> job_l = [&] { eye_job(true); }, job_r = [&] { eye_job(false); };
  if (m.run_eyes && !left.empty() && !right.empty()) {
    m.run_eyes(job_l, job_r);
  } else {
    job_l();
    job_r();
  }
  if (!err_l.empty()) return Error{"left eye: " + err_l};
  if (!err_r.empty()) return Error{"right eye: " + err_r};
  m.left_missing = left.empty();
  m.right_missing = right.empty();
  display_time_s = std::max(display_time_s, capture_time_s);
  const auto t1 = Clock::now();
  // The image-motion check compares the left eye's images: without one this frame, the
  // prediction is not checked against the image (the stale limit still applies).
  m.motion_frame = !left.empty() && m.o.max_prediction_turn_rad > 0;
  if (m.motion_frame) m.motion.set_frame_from_image(left);  // decimated: frame_gray.h
  m.noise_ref.reset();
  m.image_l = left;
  m.image_r = right;
  m.update_body(m.mannequin, f.left.tags, f.right.tags, capture_time_s, display_time_s, f.mannequin);
  if (!m.mirror.bundle.tags.empty())
    m.update_body(m.mirror, f.left.tags, f.right.tags, capture_time_s, display_time_s, f.mirror);
  f.mirror.track.name = "mirror";
  if (!m.pen.bundle.tags.empty())
    m.update_body(m.pen, f.left.tags, f.right.tags, capture_time_s, display_time_s, f.pen);
  f.pen.track.name = "pen";
  m.image_l.release();  // the caller's buffers: not kept past the call
  m.image_r.release();
  f.pose_ms = ms_since(t1);
  f.total_ms = ms_since(t0);
  return f;
}

}  // namespace dentar::ar
