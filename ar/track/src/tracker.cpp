#include "dentar/ar/tracker.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <ctime>
#include <condition_variable>
#include <fstream>
#include <map>
#include <set>
#include <mutex>
#include <thread>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <utility>

#include "dentar/ar/apriltags.h"
#include "dentar/ar/camera_model.h"
#include "dentar/ar/frame_gray.h"
#include "dentar/ar/image_motion.h"
#include "dentar/ar/pose_uncertainty.h"
#include "dentar/ar/tag_edge_fit.h"
#include "dentar/calibration/camera_file.h"
#include "track_rules.h"

namespace dentar::ar {

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

bool finite_positive(double v) { return std::isfinite(v) && v > 0; }

// One rigid body's tracking state.
struct Body {
  TagBundle bundle;
  PoseFilter filter;
  bool has_measurement = false;  // a measurement younger than the stale limit exists
  double last_meas_time_s = 0;
  Eigen::Isometry3d last_meas = Eigen::Isometry3d::Identity();
  int frames_since_meas = 0;
  int meas_in_track = 0;  // measurements since the filter was last reset (found again)
  TrackState state = TrackState::kLost;
  double max_sigma_m = 0;  // position uncertainty gate (0 = off)
  // The point whose position sigma is gated, in the body frame: the body
  // origin, or the mirror's centre (what the reflection is drawn from).
  Eigen::Vector3d gate_point = Eigen::Vector3d::Zero();
  bool static_in_world = false;  // the mannequin: its image motion is the camera's
  cv::Mat thumb_at_meas;         // ImageMotion thumbnail of its last measured frame
};

// Integer pixel box [x0, x1) x [y0, y1).
struct Box {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  double min_side_px = 1e9;  // smallest predicted tag side inside
  std::vector<std::pair<int, int>> tags;  // (family, id) of the tags predicted inside
  int area() const { return std::max(0, x1 - x0) * std::max(0, y1 - y0); }
  bool overlaps(const Box& o) const {
    return x0 < o.x1 && o.x0 < x1 && y0 < o.y1 && o.y0 < y1;
  }
  void unite(const Box& o) {
    x0 = std::min(x0, o.x0);
    y0 = std::min(y0, o.y0);
    x1 = std::max(x1, o.x1);
    y1 = std::max(y1, o.y1);
    min_side_px = std::min(min_side_px, o.min_side_px);
    tags.insert(tags.end(), o.tags.begin(), o.tags.end());
  }
};

// Merges boxes whose union costs no more pixels than the two apart (a
// union of two far-apart boxes would search the gap between them). Each tag
// lies wholly inside its own box, so merging is only about not searching
// shared pixels twice; a tag found in two crops is deduplicated later.
std::vector<Box> merge_boxes(std::vector<Box> boxes) {
  bool merged = true;
  while (merged) {
    merged = false;
    for (std::size_t i = 0; i < boxes.size() && !merged; ++i)
      for (std::size_t j = i + 1; j < boxes.size() && !merged; ++j) {
        if (!boxes[i].overlaps(boxes[j])) continue;
        Box u = boxes[i];
        u.unite(boxes[j]);
        if (u.area() > boxes[i].area() + boxes[j].area()) continue;
        boxes[i] = u;
        boxes.erase(boxes.begin() + static_cast<std::ptrdiff_t>(j));
        merged = true;
      }
  }
  return boxes;
}

// Keeps one detection per (family, id): the most confident.
std::vector<DetectedTag> dedup(std::vector<DetectedTag> tags) {
  std::map<std::pair<int, int>, DetectedTag> best;
  for (const DetectedTag& t : tags) {
    auto key = std::make_pair(static_cast<int>(t.family), t.id);
    auto it = best.find(key);
    if (it == best.end() || t.decision_margin > it->second.decision_margin) best[key] = t;
  }
  std::vector<DetectedTag> out;
  out.reserve(best.size());
  for (auto& [k, t] : best) out.push_back(t);
  return out;
}

}  // namespace

const char* track_state_name(TrackState s) {
  switch (s) {
    case TrackState::kTracking:
      return "tracking";
    case TrackState::kPredicted:
      return "predicted";
    case TrackState::kLost:
      return "lost";
  }
  return "?";
}

std::string TrackerOptions::validate() const {
  {
    TagDetectorOptions d = detector;  // auto is resolved at create() from the station
    if (d.response == CameraResponse::kAuto) d.response = CameraResponse::kLinear;
    if (auto e = d.validate(); !e.empty()) return "detector." + e;
  }
  if (auto e = pose.validate(); !e.empty()) return "pose." + e;
  if (auto e = filter.validate(); !e.empty()) return "filter." + e;
  std::ostringstream os;
  if (full_frame_interval < 1 || full_frame_interval > 100000)
    os << "full_frame_interval = " << full_frame_interval << " frames must be in 1..100000";
  else if (!std::isfinite(roi_margin) || roi_margin < 0 || roi_margin > 10)
    os << "roi_margin = " << roi_margin << " must be in [0, 10] (times the tag side)";
  else if (!std::isfinite(roi_min_margin_px) || roi_min_margin_px < 0 || roi_min_margin_px > 1000)
    os << "roi_min_margin_px = " << roi_min_margin_px << " must be in [0, 1000]";
  else if (!std::isfinite(roi_motion_across) || roi_motion_across < 0 || roi_motion_across > 1)
    os << "roi_motion_across = " << roi_motion_across << " must be in [0, 1] (1 = pad the motion in every direction)";
  else if (!std::isfinite(roi_decimation) || roi_decimation < 1 || roi_decimation > 16)
    os << "roi_decimation = " << roi_decimation << " must be in [1, 16]";
  else if (!std::isfinite(roi_decimate_above_px) || roi_decimate_above_px < 0)
    os << "roi_decimate_above_px = " << roi_decimate_above_px << " must be >= 0";
  else if (!(std::isfinite(edge_fit_min_side_px) && edge_fit_min_side_px >= 4 && edge_fit_min_side_px <= 1000))
    os << "edge_fit_min_side_px = " << edge_fit_min_side_px << " must be in [4, 1000] px";
  else if (!(std::isfinite(edge_fit_max_reach_sides) && edge_fit_max_reach_sides > 0 && edge_fit_max_reach_sides <= 10))
    os << "edge_fit_max_reach_sides = " << edge_fit_max_reach_sides << " must be in (0, 10] (times the tag side)";
  else if (!(std::isfinite(edge_fit_max_reproj_px) && edge_fit_max_reproj_px > 0 && edge_fit_max_reproj_px <= 10))
    os << "edge_fit_max_reproj_px = " << edge_fit_max_reproj_px << " must be in (0, 10] px";
  else if (auto e = edge_fit_border.validate(); !e.empty())
    os << "edge_fit_border." << e;
  else if (!(std::isfinite(pattern_fit_exposure_s) && pattern_fit_exposure_s >= 0 && pattern_fit_exposure_s <= 1))
    os << "pattern_fit_exposure_s = " << pattern_fit_exposure_s << " must be in [0, 1] s (0: half the frame interval)";
  else if (!(std::isfinite(pattern_fit_max_reproj_px) && pattern_fit_max_reproj_px > 0 && pattern_fit_max_reproj_px <= 10))
    os << "pattern_fit_max_reproj_px = " << pattern_fit_max_reproj_px << " must be in (0, 10] px";
  else if (auto e2 = pattern_fit_cells.validate(); !e2.empty())
    os << "pattern_fit_cells." << e2;
  else if (roi_decimation_max < 0 || roi_decimation_max > 8)
    os << "roi_decimation_max = " << roi_decimation_max << " must be in 0..8 (0 = off)";
  else if (!finite_positive(max_rms_px))
    os << "max_rms_px = " << max_rms_px << " must be finite and > 0";
  else if (!(std::isfinite(mannequin_max_sigma_m) && mannequin_max_sigma_m >= 0))
    os << "mannequin_max_sigma_m = " << mannequin_max_sigma_m << " must be finite and >= 0 (0 = off)";
  else if (!(std::isfinite(mirror_max_sigma_m) && mirror_max_sigma_m >= 0))
    os << "mirror_max_sigma_m = " << mirror_max_sigma_m << " must be finite and >= 0 (0 = off)";
  else if (!(std::isfinite(max_prediction_drift_m) && max_prediction_drift_m >= 0))
    os << "max_prediction_drift_m = " << max_prediction_drift_m << " must be finite and >= 0 (0 = off)";
  else if (hand_held_measurements_to_predict < 1 || hand_held_measurements_to_predict > 100)
    os << "hand_held_measurements_to_predict = " << hand_held_measurements_to_predict << " must be in [1, 100]";
  else if (mannequin_measurements_to_predict < 1 || mannequin_measurements_to_predict > 100)
    os << "mannequin_measurements_to_predict = " << mannequin_measurements_to_predict << " must be in [1, 100]";
  else if (!(std::isfinite(max_prediction_turn_rad) && max_prediction_turn_rad >= 0))
    os << "max_prediction_turn_rad = " << max_prediction_turn_rad << " must be finite and >= 0 (0 = off)";
  else if (!(std::isfinite(min_motion_response) && min_motion_response >= 0 && min_motion_response < 1))
    os << "min_motion_response = " << min_motion_response << " must be in [0, 1)";
  else if (!(std::isfinite(sigma_floor_px) && sigma_floor_px >= 0))
    os << "sigma_floor_px = " << sigma_floor_px << " must be finite and >= 0";
  else if (!std::isfinite(stale_limit_s) || stale_limit_s < 0 || stale_limit_s > 10)
    os << "stale_limit_s = " << stale_limit_s << " must be in [0, 10] s";
  else if (auto e = mirror_rim.validate(); !e.empty())
    os << "mirror_rim." << e;
  else if (!(std::isfinite(stereo_mirror_rim_effective_points) && stereo_mirror_rim_effective_points >= 1))
    os << "stereo_mirror_rim_effective_points = " << stereo_mirror_rim_effective_points << " must be >= 1";
  else if (stereo_mirror_rim_min_tags < 1 || stereo_mirror_rim_min_tags > 100)
    os << "stereo_mirror_rim_min_tags = " << stereo_mirror_rim_min_tags << " must be in [1, 100]";
  else if (!(std::isfinite(stereo_mirror_rim_one_tag_chi2) && stereo_mirror_rim_one_tag_chi2 >= 0))
    os << "stereo_mirror_rim_one_tag_chi2 = " << stereo_mirror_rim_one_tag_chi2 << " must be finite and >= 0 (0 = off)";
  else if (!(std::isfinite(stereo_mirror_outline_sigma) && stereo_mirror_outline_sigma >= 0 &&
             stereo_mirror_outline_sigma <= 100))
    os << "stereo_mirror_outline_sigma = " << stereo_mirror_outline_sigma << " must be in [0, 100] (0 = off)";
  else if (!(std::isfinite(mirror_min_unexplained_speed_m_s) && mirror_min_unexplained_speed_m_s >= 0))
    os << "mirror_min_unexplained_speed_m_s = " << mirror_min_unexplained_speed_m_s << " must be finite and >= 0";
  else if (discovery != DiscoveryMode::kInline && !predicted_regions)
    os << "discovery = " << discovery_mode_name(discovery)
       << " needs predicted_regions (without them every frame is a full-frame search)";
  return os.str();
}

const char* discovery_mode_name(DiscoveryMode m) {
  switch (m) {
    case DiscoveryMode::kInline:
      return "inline";
    case DiscoveryMode::kDeferred:
      return "deferred";
    case DiscoveryMode::kAsync:
      return "async";
    case DiscoveryMode::kScheduled:
      return "scheduled";
  }
  return "?";
}

Result<DiscoveryMode> parse_discovery_mode(const std::string& name) {
  for (DiscoveryMode m : {DiscoveryMode::kInline, DiscoveryMode::kDeferred, DiscoveryMode::kAsync,
                          DiscoveryMode::kScheduled})
    if (name == discovery_mode_name(m)) return m;
  return Error{"discovery mode '" + name + "' is not one of inline, deferred, async, scheduled"};
}

namespace {

// One full-frame search's result.
struct Discovered {
  std::int64_t frame = -1;
  double capture_s = 0;
  std::vector<DetectedTag> tags;
  double ms = 0;
  std::string error;  // the detector failed (tags empty)
};

// The full-frame search off the frame path: its own detector (libapriltag's
// is single-threaded), one job at a time. kAsync runs it on `thread`; the
// other modes call run() on the frame thread. The frame thread and the
// worker share only `job`/`done` under `mutex` (held for swaps, never
// during a search).
class DiscoveryWorker {
 public:
  DiscoveryWorker(TagDetector det, double decimation) : det_(std::move(det)), decimation_(decimation) {}
  ~DiscoveryWorker() { stop(); }

  void start(std::function<void()> init) {
    thread_ = std::thread([this, init = std::move(init)] {
      if (init) init();
      main();
    });
  }
  void stop() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
    if (thread_.joinable()) thread_.join();
  }
  bool threaded() const { return thread_.joinable(); }

  // Frame thread. Idle = no search queued or running and no result waiting.
  bool idle() {
    std::lock_guard<std::mutex> lock(mutex_);
    return !queued_ && !running_ && !has_done_;
  }
  // Frame thread: copies `gray` (the caller's buffer may be reused) and
  // queues the search (threaded) or runs it now (not threaded).
  void post(const cv::Mat& gray, std::int64_t frame, double capture_s) {
    std::unique_lock<std::mutex> lock(mutex_);
    gray.copyTo(job_gray_);  // reuses the buffer after the first frame
    job_frame_ = frame;
    job_capture_s_ = capture_s;
    queued_ = true;
    if (!threaded()) {
      lock.unlock();
      run_one();
      return;
    }
    lock.unlock();
    cv_.notify_one();
  }
  // Frame thread: the finished search, if any (never waits).
  std::optional<Discovered> take() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!has_done_) return std::nullopt;
    has_done_ = false;
    return std::move(done_);
  }
  // Frame thread: drops queued and finished work, waiting for a running
  // search to end (reset()).
  void drop() {
    std::unique_lock<std::mutex> lock(mutex_);
    queued_ = false;
    idle_cv_.wait(lock, [this] { return !running_; });
    has_done_ = false;
  }
  // Synchronous search (kScheduled), on the caller's thread.
  Discovered search(const cv::Mat& gray, std::int64_t frame, double capture_s) {
    Discovered d;
    d.frame = frame;
    d.capture_s = capture_s;
    const auto t0 = Clock::now();
    if (Status s = det_.set_decimation(decimation_); !s) {
      d.error = s.error();
    } else if (auto r = det_.detect(gray); !r) {
      d.error = r.error();
    } else {
      d.tags = dedup(std::move(r).value());
    }
    d.ms = ms_since(t0);
    return d;
  }

 private:
  void run_one() {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!queued_) return;
    queued_ = false;
    running_ = true;
    const std::int64_t frame = job_frame_;
    const double cap = job_capture_s_;
    lock.unlock();
    // job_gray_ is not touched by post() while running_ (post is only called
    // when idle()).
    Discovered d = search(job_gray_, frame, cap);
    lock.lock();
    running_ = false;
    done_ = std::move(d);
    has_done_ = true;
    lock.unlock();
    idle_cv_.notify_all();
  }
  void main() {
    for (;;) {
      {
        std::unique_lock<std::mutex> lock(mutex_);
        cv_.wait(lock, [this] { return stop_ || queued_; });
        if (stop_) return;
      }
      run_one();
    }
  }

  TagDetector det_;
  double decimation_ = 2;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable cv_, idle_cv_;
  bool stop_ = false, queued_ = false, running_ = false, has_done_ = false;
  cv::Mat job_gray_;
  std::int64_t job_frame_ = -1;
  double job_capture_s_ = 0;
  Discovered done_;
};

}  // namespace

struct Tracker::Impl {
  TrackerOptions o;
  std::string response_note;  // Tracker::response_note()
  calibration::CameraIntrinsics camera;
  CameraModel model{calibration::CameraIntrinsics{}};
  std::optional<TagDetector> detector;
  Body mannequin, mirror, pen;
  std::int64_t frames = 0;
  int frames_since_full = 0;
  // How far a tag's printed cells reach beyond its border square (the
  // detected corners), as a fraction of the square's side: tagStandard41h12
  // has data bits and a dark ring outside it (0.4), tag36h11 a white ring
  // (0.125). The quad search needs all of it inside the crop.
  double outer_extent = 0.4;
  // The border square's ring just inside its edge is white, the one outside black (reversed-border
  // families: tagStandard41h12); else black inside, white outside (tag36h11).
  bool reversed_border = true;
  int border_cells = 5;  // cells along the border square's side (TagFamily::width_at_border)
  // TrackerOptions::pattern_fit: the mannequin's family (its codes' cells) and each tag's cells.
  std::optional<TagFamily> pattern_family;
  std::map<int, cv::Mat> pattern_cells;
  bool have_last_capture = false;
  double last_capture_s = 0;
  // The frame's grey levels, converted only where they are read (frame_gray.h):
  // the predicted regions on most frames, the whole frame for a full-frame search.
  FrameGray gray;
  // The mirror disc (TrackerOptions::mirror_rim_refine).
  Eigen::Isometry3d T_mtag_mir = Eigen::Isometry3d::Identity();
  double mirror_radius_m = 0, mirror_thickness_m = 0;
  // Discovery off the frame path (not kInline).
  std::unique_ptr<DiscoveryWorker> discovery;
  std::map<std::int64_t, Discovered> scheduled;  // kScheduled: started, not merged yet
  int frames_since_discovery = 0;

  // Merges a full-frame search's tags as measurements at its capture time
  // (see tracker.h, "Discovery"); now = this frame's index.
  void merge(const Discovered& d, std::int64_t now) {
    noise_ref.reset();
    for (Body* b : {&mannequin, &mirror, &pen}) {
      if (b->bundle.tags.empty()) continue;
      if (b->has_measurement && b->last_meas_time_s >= d.capture_s) continue;  // fresher already
      std::optional<Eigen::Isometry3d> prev;
      if (b->state != TrackState::kLost)
        prev = o.filter_enabled && b->filter.initialised() ? b->filter.predict(d.capture_s)
                                                            : b->last_meas;
      const BundlePose p = estimate_bundle_pose(b->bundle, camera, d.tags, track_rules::pose_options_for(o, b == &mannequin), prev);
      if (b == &mannequin) noise_ref = p;
      if (!(p.ok() && p.rms_px <= o.max_rms_px && precise_enough(*b, p))) continue;
      if (b->state == TrackState::kLost) {
        b->filter.reset();
        b->meas_in_track = 0;
      }
      b->filter.update(p.T_cam_body, d.capture_s);
      ++b->meas_in_track;
      b->has_measurement = true;
      b->last_meas = p.T_cam_body;
      b->last_meas_time_s = d.capture_s;
      b->frames_since_meas = static_cast<int>(std::max<std::int64_t>(0, now - d.frame));
      b->state = TrackState::kPredicted;
      // No thumbnail of that frame: the image-motion check waits for the
      // next direct measurement.
      b->thumb_at_meas.release();
    }
  }

  ImageMotion motion;            // thumbnails for the prediction check
  std::int64_t motion_frame = -1;  // frame whose thumbnail `motion` holds

  void ensure_motion() {
    if (motion_frame == frames) return;
    motion.set_frame_from_image(gray.image());
    motion_frame = frames;
  }

  // The prediction check (TrackerOptions::max_prediction_turn_rad): false
  // when the image moved since b's last measurement by more than its
  // prediction explains, or no longer correlates with that frame.
  bool prediction_matches_image(Body& b, double capture_s) {
    if (o.max_prediction_turn_rad <= 0 || b.thumb_at_meas.empty()) return true;
    ensure_motion();
    const ImageMotion::Shift sh = motion.shift_since(b.thumb_at_meas);
    if (!sh.valid || sh.response < o.min_motion_response) return false;
    Eigen::Vector2d expect = Eigen::Vector2d::Zero();
    if (o.filter_enabled && b.filter.initialised()) {
      auto a = model.project(b.filter.predict(capture_s).translation());
      auto c = model.project(b.last_meas.translation());
      if (a && c) expect = *a - *c;
    }
    const double unexplained = b.static_in_world ? (sh.px - expect).norm()
                                                 : std::max(0.0, sh.px.norm() - expect.norm());
    return unexplained / camera.fx <= o.max_prediction_turn_rad;
  }

  // One tag at a body pose T_cam_body: its four corners projected (distorted px, libapriltag's
  // order), the square's side (sqrt of its area, px) and its corners' bounding box padded by
  // side_frac x side + pad_px, plus mx (my) along x (y), and clipped to the image,
  // [x0, x1) x [y0, y1). nullopt when
  // the tag does not face the camera (its z points into the tag) or grazes it, or a corner
  // does not project. The predicted regions and the edge fit both use it.
  struct PredictedTag {
    std::array<Eigen::Vector2d, 4> px;
    double side_px = 0;
    int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  };
  std::optional<PredictedTag> predicted_tag_box(const Eigen::Isometry3d& T_cam_body, const TagPlacement& t,
                                                double side_frac, double pad_px, double mx, double my) const {
    const Eigen::Isometry3d T_cam_tag = T_cam_body * t.T_parent_tag;
    const Eigen::Vector3d c = T_cam_tag.translation();
    if (!(c.z() > 0.01) || T_cam_tag.linear().col(2).dot(c.normalized()) < 0.12) return std::nullopt;
    PredictedTag out;
    for (int k = 0; k < 4; ++k) {
      auto p = model.project(T_cam_body * t.corner(k));
      if (!p) return std::nullopt;
      out.px[static_cast<std::size_t>(k)] = *p;
    }
    double area2 = 0;
    for (std::size_t k = 0; k < 4; ++k) {
      const Eigen::Vector2d& a = out.px[k];
      const Eigen::Vector2d& bq = out.px[(k + 1) % 4];
      area2 += a.x() * bq.y() - bq.x() * a.y();
    }
    out.side_px = std::sqrt(std::abs(area2) / 2);
    const double margin = side_frac * out.side_px + pad_px;
    double x0 = 1e18, y0 = 1e18, x1 = -1e18, y1 = -1e18;
    for (const auto& p : out.px) {
      x0 = std::min(x0, p.x());
      y0 = std::min(y0, p.y());
      x1 = std::max(x1, p.x());
      y1 = std::max(y1, p.y());
    }
    out.x0 = std::max(0, static_cast<int>(std::floor(x0 - margin - mx)));
    out.y0 = std::max(0, static_cast<int>(std::floor(y0 - margin - my)));
    out.x1 = std::min(camera.width, static_cast<int>(std::ceil(x1 + margin + mx)) + 1);
    out.y1 = std::min(camera.height, static_cast<int>(std::ceil(y1 + margin + my)) + 1);
    return out;
  }

  // How far the prediction of tag t's centre may be off (px) and along which direction: the
  // image motion since b's last measurement plus (1 + frames since it) x one frame's motion
  // (T_prev = the prediction one frame earlier).
  std::pair<double, Eigen::Vector2d> predicted_motion(const Body& b, const Eigen::Isometry3d& T_pred,
                                                      const Eigen::Isometry3d& T_prev, const TagPlacement& t) const {
    const double grow = 1.0 + b.frames_since_meas;
    double motion = 0;
    Eigen::Vector2d dir = Eigen::Vector2d::Zero();
    auto p_now = model.project(T_pred * t.T_parent_tag.translation());
    auto p_last = model.project(b.last_meas * t.T_parent_tag.translation());
    auto p_prev = model.project(T_prev * t.T_parent_tag.translation());
    if (p_now && p_last) {
      motion += (*p_now - *p_last).norm();
      dir += *p_now - *p_last;
    }
    if (p_now && p_prev) {
      motion += grow * (*p_now - *p_prev).norm();
      dir += grow * (*p_now - *p_prev);
    }
    return {motion, dir};
  }

  // Boxes around `b`'s tags at its predicted pose; false when the body has
  // no usable prediction (then only a full frame can find it).
  bool add_regions(const Body& b, double capture_s, double frame_dt_s, std::vector<Box>& boxes) {
    if (b.state == TrackState::kLost) return false;
    const bool filt = o.filter_enabled && b.filter.initialised();
    const Eigen::Isometry3d T_pred = filt ? b.filter.predict(capture_s) : b.last_meas;
    // One frame earlier along the prediction: the motion a frame brings,
    // which is what the prediction may be wrong by.
    const Eigen::Isometry3d T_prev =
        filt ? b.filter.predict(capture_s - frame_dt_s) : b.last_meas;
    for (const TagPlacement& t : b.bundle.tags) {
      // The padding for the prediction's error: the motion since the last
      // measurement plus (1 + frames since it) x one frame's motion, as an
      // ellipse with that semi-axis along the motion and roi_motion_across
      // of it across; (mx, my) = its bounding box's half sides.
      const auto [motion, dir] = predicted_motion(b, T_pred, T_prev, t);
      double mx = motion, my = motion;
      if (const double n = dir.norm(); o.roi_motion_across < 1 && n > 1e-9) {
        const Eigen::Vector2d u = dir / n;
        const double c = o.roi_motion_across;
        mx = motion * std::hypot(u.x(), c * u.y());
        my = motion * std::hypot(u.y(), c * u.x());
      }
      const std::optional<PredictedTag> pt =
          predicted_tag_box(T_pred, t, outer_extent + o.roi_margin, o.roi_min_margin_px, mx, my);
      if (!pt) continue;
      Box box;
      box.x0 = pt->x0;
      box.y0 = pt->y0;
      box.x1 = pt->x1;
      box.y1 = pt->y1;
      const double side = pt->side_px;
      box.min_side_px = side;
      box.tags.emplace_back(static_cast<int>(b.bundle.family), t.id);
      if (box.x1 - box.x0 < 16 || box.y1 - box.y0 < 16) continue;  // (almost) off the image
      boxes.push_back(box);
    }
    return true;
  }

  Status detect_full(std::vector<DetectedTag>& out) {
    if (Status s = detector->set_decimation(o.detector.decimation); !s) return s;
    auto r = detector->detect(gray.whole());
    if (!r) return Error{r.error()};
    out = std::move(r).value();
    return {};
  }

  // The tags in one box, corners in full-image pixels: on the image as delivered, or
  // (second look) on its linear-light copy. Large boxes are searched decimated.
  Result<std::vector<DetectedTag>> detect_box(const Box& b, bool linear_light) {
    double dec = b.min_side_px > o.roi_decimate_above_px ? std::max(2.0, o.roi_decimation)
                                                          : o.roi_decimation;
    // Issue 28 (off by default): the decimation follows the tags' predicted size.
    if (o.roi_decimation_max > 2 && o.roi_decimate_above_px > 0 && b.min_side_px > o.roi_decimate_above_px)
      dec = std::max(dec, std::min<double>(o.roi_decimation_max,
                                           std::floor(2 * b.min_side_px / o.roi_decimate_above_px)));
    if (Status s = detector->set_decimation(dec); !s) return Error{s.error()};
    const cv::Rect rect(b.x0, b.y0, b.x1 - b.x0, b.y1 - b.y0);
    const cv::Mat crop = gray.region(rect)(rect);
    auto r = linear_light ? detector->detect_in_linear_light(crop) : detector->detect(crop);
    if (!r) return Error{r.error()};
    for (DetectedTag& t : *r)
      for (auto& c : t.corners_px) c += Eigen::Vector2d(b.x0, b.y0);
    return r;
  }

  Status detect_regions(const std::vector<Box>& boxes, std::vector<DetectedTag>& out) {
    std::vector<DetectedTag> all;
    for (const Box& b : boxes) {
      auto r = detect_box(b, false);
      if (!r) return Error{r.error()};
      all.insert(all.end(), r->begin(), r->end());
    }
    out = dedup(std::move(all));
    return second_look(boxes, out);
  }

  // Where a tag predicted inside a box was not found, libapriltag looks again
  // at that box in linear light (TagDetector::detect_in_linear_light; only
  // with a known response, TrackerOptions::linear_second_look); tags found
  // there are added when not already found. `boxes` are merged boxes.
  Status second_look(const std::vector<Box>& boxes, std::vector<DetectedTag>& tags) {
    if (!o.linear_second_look || o.detector.response == CameraResponse::kLinear) return {};
    std::set<std::pair<int, int>> have;
    for (const DetectedTag& t : tags) have.emplace(static_cast<int>(t.family), t.id);
    std::vector<DetectedTag> more;
    for (const Box& b : boxes) {
      bool missing = false;
      for (const auto& k : b.tags) missing = missing || (!have.count(k) && !is_mirror_tag(k));
      if (!missing) continue;
      auto r = detect_box(b, true);
      if (!r) return Error{r.error()};
      for (const DetectedTag& t : *r) {
        // Only the tags predicted in this box (the linear copy can show
        // false quads elsewhere: 15 on the real photographs of issue 24).
        const std::pair<int, int> key(static_cast<int>(t.family), t.id);
        if (have.count(key) || is_mirror_tag(key) ||
            std::find(b.tags.begin(), b.tags.end(), key) == b.tags.end())
          continue;
        more.push_back(t);
      }
      ++second_looks;
    }
    if (more.empty()) return {};
    more = dedup(std::move(more));
    tags.insert(tags.end(), more.begin(), more.end());
    std::sort(tags.begin(), tags.end(), [](const DetectedTag& a, const DetectedTag& b) {
      return a.family != b.family ? a.family < b.family : a.id < b.id;
    });
    return {};
  }
  int second_looks = 0;  // boxes searched again in the frame being processed

  // TrackerOptions::edge_fit: b's tags predicted in view and missing from `tags`, their border
  // squares fitted to the image's edges around the predicted corners (fit_tag_border, which
  // refuses a square with another predicted or decoded square within its reach), then (c): a
  // pose fitted to the frame's decoded tags of b (at least one) and the fitted squares must put
  // each fitted square within edge_fit_max_reproj_px RMS. Accepted squares join `tags`
  // (DetectedTag::edge_fit). Counts in f (TrackFrame::edge_fit_*).
  Status edge_fit_look(const Body& b, double capture_s, double frame_dt_s, std::vector<DetectedTag>& tags,
                       TrackFrame& f) {
    if (b.state == TrackState::kLost || b.bundle.tags.empty()) return {};
    const bool filt = o.filter_enabled && b.filter.initialised();
    const Eigen::Isometry3d T_pred = filt ? b.filter.predict(capture_s) : b.last_meas;
    const Eigen::Isometry3d T_prev = filt ? b.filter.predict(capture_s - frame_dt_s) : b.last_meas;
    auto have = [&](TagFamilyId fam, int id) {
      for (const DetectedTag& d : tags)
        if (d.family == fam && d.id == id) return true;
      return false;
    };
    int decoded = 0;
    for (const TagPlacement& t : b.bundle.tags) decoded += have(b.bundle.family, t.id);
    if (decoded < 1) return {};
    // Every square predicted in view (every body) and every decoded one, for the ambiguity test.
    // Built once per frame: `others` holds every square, own[k] = (id, index) for b's own
    // squares; a tag's own square is moved out of the list for its fits and back after (the
    // fits' overlap tests do not depend on the order).
    std::vector<std::array<Eigen::Vector2d, 4>> others;
    std::vector<std::pair<int, std::size_t>> own;
    for (const Body* ob : {&mannequin, &mirror, &pen}) {
      if (ob->state == TrackState::kLost || ob->bundle.tags.empty()) continue;
      const bool f2 = o.filter_enabled && ob->filter.initialised();
      const Eigen::Isometry3d Tp = f2 ? ob->filter.predict(capture_s) : ob->last_meas;
      for (const TagPlacement& t : ob->bundle.tags)
        if (auto pt = predicted_tag_box(Tp, t, 0.0, 0.0, 0.0, 0.0)) {
          if (ob == &b) own.emplace_back(t.id, others.size());
          others.push_back(pt->px);
        }
    }
    for (const DetectedTag& d : tags) others.push_back(d.corners_px);
    std::vector<DetectedTag> cands;
    auto candidate = [&](int id, bool pattern, const std::array<Eigen::Vector2d, 4>& corners) {
      DetectedTag d;
      d.family = b.bundle.family;
      d.id = id;
      (pattern ? d.pattern_fit : d.edge_fit) = true;
      d.corners_px = corners;
      cands.push_back(d);
    };
    for (const TagPlacement& t : b.bundle.tags) {
      if (have(b.bundle.family, t.id)) continue;
      const double reach = predicted_motion(b, T_pred, T_prev, t).first + o.roi_min_margin_px;
      const std::optional<PredictedTag> pt = predicted_tag_box(T_pred, t, outer_extent, reach + 3, 0.0, 0.0);
      if (!pt || pt->side_px < o.edge_fit_min_side_px) continue;
      if (reach > o.edge_fit_max_reach_sides * pt->side_px) continue;  // too unsure to pick an edge
      // This tag's own square out of `others` for its fits (swapped back at the end of the pass).
      const auto mine = std::find_if(own.begin(), own.end(), [&](const auto& k) { return k.first == t.id; });
      const bool has_own = mine != own.end();
      const std::size_t own_at = has_own ? mine->second : 0;
      std::array<Eigen::Vector2d, 4> own_px;
      if (has_own) {
        std::swap(others[own_at], others.back());
        own_px = others.back();
        others.pop_back();
      }
      struct PutBack {
        std::vector<std::array<Eigen::Vector2d, 4>>& v;
        bool on;
        std::size_t at;
        const std::array<Eigen::Vector2d, 4>& px;
        ~PutBack() {
          if (!on) return;
          v.push_back(px);
          std::swap(v[at], v.back());
        }
      } put_back{others, has_own, own_at, own_px};
      if (o.edge_fit) {
        ++f.edge_fit_tried;
        const cv::Mat& g = gray.region(cv::Rect(pt->x0, pt->y0, pt->x1 - pt->x0, pt->y1 - pt->y0));
        const TagEdgeFit fit = fit_tag_border(g, pt->px, reversed_border, border_cells, reach, outer_extent, others,
                                              o.edge_fit_border, &detector->to_linear());
        if (fit.status == TagEdgeFitStatus::kBadInput) return Error{"Tracker: " + fit.message};
        if (fit.status == TagEdgeFitStatus::kFitted) {
          candidate(t.id, false, fit.corners_px);
          continue;
        }
        ++f.edge_fit_refused[static_cast<std::size_t>(fit.status) - 1];
      }
      if (o.pattern_fit && pattern_family) {
        // The blur: each corner's image path over the exposure, the filter's poses at its ends.
        const double e = o.pattern_fit_exposure_s > 0 ? o.pattern_fit_exposure_s : 0.5 * frame_dt_s;
        std::array<Eigen::Vector2d, 4> blur;  // Eigen's vectors start uninitialised
        for (auto& v : blur) v.setZero();
        double blur_len = 0;
        if (filt) {
          const Eigen::Isometry3d T_a = b.filter.predict(capture_s - 0.5 * e), T_b = b.filter.predict(capture_s + 0.5 * e);
          bool ok = true;
          for (int k = 0; k < 4 && ok; ++k) {
            auto qa = model.project(T_a * t.corner(k));
            auto qb = model.project(T_b * t.corner(k));
            ok = qa && qb;
            if (ok) blur[static_cast<std::size_t>(k)] = *qb - *qa;
          }
          if (!ok)
            for (auto& v : blur) v.setZero();
          for (const auto& v : blur) blur_len = std::max(blur_len, v.norm());
        }
        const std::optional<PredictedTag> pr =
            predicted_tag_box(T_pred, t, outer_extent + 1.0 / border_cells, reach + 0.5 * blur_len + 4, 0.0, 0.0);
        if (!pr) continue;
        auto it = pattern_cells.find(t.id);
        if (it == pattern_cells.end()) {
          if (t.id < 0 || t.id >= pattern_family->code_count())
            return Error{"Tracker: the mannequin's tag id " + std::to_string(t.id) + " is not a code of its family"};
          it = pattern_cells.emplace(t.id, pattern_family->cells(t.id)).first;
        }
        ++f.pattern_fit_tried;
        timespec c0{}, c1{};
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c0);
        const cv::Mat& g = gray.region(cv::Rect(pr->x0, pr->y0, pr->x1 - pr->x0, pr->y1 - pr->y0));
        const TagPatternFit fit = fit_tag_pattern(g, it->second, pattern_family->border_start(), pattern_family->width_at_border(),
                                                  pt->px, blur, reach, outer_extent, others, o.pattern_fit_cells,
                                                  &detector->to_linear());
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c1);
        f.pattern_fit_ms += 1e3 * double(c1.tv_sec - c0.tv_sec) + 1e-6 * double(c1.tv_nsec - c0.tv_nsec);
        if (fit.status == TagPatternFitStatus::kBadInput) return Error{"Tracker: " + fit.message};
        if (fit.status != TagPatternFitStatus::kFitted) {
          ++f.pattern_fit_refused[static_cast<std::size_t>(fit.status) - 1];
          continue;
        }
        candidate(t.id, true, fit.corners_px);
      }
    }
    if (cands.empty()) return {};
    auto refuse = [&](const DetectedTag& d) {
      if (d.pattern_fit)
        ++f.pattern_fit_refused[4];
      else
        ++f.edge_fit_refused[3];
    };
    // (c) the pose with them: each fitted square within the gate under the joint fit.
    std::vector<DetectedTag> all = tags;
    all.insert(all.end(), cands.begin(), cands.end());
    const BundlePose p = estimate_bundle_pose(b.bundle, camera, all, track_rules::pose_options_for(o, &b == &mannequin),
                                              std::optional<Eigen::Isometry3d>(T_pred));
    if (!p.ok() || p.rms_px > o.max_rms_px) {
      for (const DetectedTag& d : cands) refuse(d);
      return {};
    }
    for (const DetectedTag& d : cands) {
      const TagPlacement* tp = nullptr;
      for (const TagPlacement& t : b.bundle.tags)
        if (t.id == d.id) tp = &t;
      double ss = 0;
      bool ok = tp != nullptr && p.rejected_id != d.id;
      for (int k = 0; k < 4 && ok; ++k) {
        auto q = model.project(p.T_cam_body * tp->corner(k));
        ok = q.has_value();
        if (ok) ss += (*q - d.corners_px[static_cast<std::size_t>(k)]).squaredNorm();
      }
      if (!ok || std::sqrt(ss / 4) > (d.pattern_fit ? o.pattern_fit_max_reproj_px : o.edge_fit_max_reproj_px)) {
        refuse(d);
        continue;
      }
      tags.push_back(d);
      ++(d.pattern_fit ? f.pattern_fit_accepted : f.edge_fit_accepted);
    }
    std::sort(tags.begin(), tags.end(), [](const DetectedTag& x, const DetectedTag& y) {
      return x.family != y.family ? x.family < y.family : x.id < y.id;
    });
    return {};
  }
  // The mirror's tags get no second look: its small tags found on the linear
  // copy made its ungated pose worse (p95 1.85 -> 3.25 mm on `standard`,
  // docs/BENCHMARKS.md issue 24 session 11).
  bool is_mirror_tag(const std::pair<int, int>& k) const {
    if (k.first != static_cast<int>(mirror.bundle.family)) return false;
    for (const TagPlacement& p : mirror.bundle.tags)
      if (p.id == k.second) return true;
    return false;
  }

  // The mannequin's fit in the frame being processed (its corner noise is
  // pooled into the other bodies', TrackerOptions::pool_noise); reset per
  // frame and per merged search.
  std::optional<BundlePose> noise_ref;

  // The corner noise (px^2) behind b's covariance: its own residual
  // estimate, or pooled with the mannequin's of the same frame.
  double noise_px2(const Body& b, const BundlePose& p) const {
    if (!o.pool_noise || &b == &mannequin || !noise_ref) return p.noise_px2;
    return pooled_noise_px2(p, &*noise_ref, o.pool_comparable_tags);
  }
  // Position sigma of the body's gate point (pose_uncertainty.h), the
  // corner noise floored at sigma_floor_px.
  double gate_sigma(const Body& b, const BundlePose& p) const {
    return o.sigma_per_tag ? per_tag_sigma(b, p) : uniform_sigma(b, p);
  }
  double uniform_sigma(const Body& b, const BundlePose& p) const {
    return point_sigma_m(covariance_with_noise(p, noise_px2(b, p), o.sigma_floor_px), p.T_cam_body,
                         b.gate_point);
  }
  double per_tag_sigma(const Body& b, const BundlePose& p) const {
    const double floor = point_sigma_m(p.covariance_per_px2 * (o.sigma_floor_px * o.sigma_floor_px),
                                       p.T_cam_body, b.gate_point);
    return std::max(floor, point_sigma_m(p.covariance_per_tag, p.T_cam_body, b.gate_point));
  }
  // Position uncertainty gate (TrackerOptions::mannequin_max_sigma_m).
  bool precise_enough(const Body& b, const BundlePose& p) const {
    return b.max_sigma_m <= 0 || gate_sigma(b, p) <= b.max_sigma_m;
  }

  // Pose + filter + state of one body.
  void update_body(Body& b, const std::vector<DetectedTag>& tags, double capture_s,
                   double display_s, BodyTrack& out, double& pose_ms, double& filter_ms) {
    out = BodyTrack{};
    out.name = b.bundle.name;
    const auto t0 = Clock::now();
    std::optional<Eigen::Isometry3d> prev;
    if (b.state != TrackState::kLost)
      prev = o.filter_enabled && b.filter.initialised() ? b.filter.predict(capture_s)
                                                         : b.last_meas;
    bool measured = false;
    if (!tags.empty()) {
      BundlePose p = estimate_bundle_pose(b.bundle, camera, tags, track_rules::pose_options_for(o, &b == &mannequin), prev);
      if (&b == &mannequin) noise_ref = p;
      if (&b == &mirror && o.mirror_rim_refine && p.ok() && p.rms_px <= o.max_rms_px &&
          mirror_radius_m > 0) {
        const double floor2 = o.sigma_floor_px * o.sigma_floor_px;
        const MirrorRimResult rr = refine_mirror_rim(
            gray.whole(), o.detector.response == CameraResponse::kSrgb, model, p,
            std::max(noise_px2(b, p), floor2), T_mtag_mir, mirror_radius_m, mirror_thickness_m,
            o.mirror_rim);
        if (rr.refined) {
          p.T_cam_body = rr.T_cam_body;
          p.covariance_per_px2 = rr.covariance_per_px2;
          p.covariance_per_tag = rr.covariance_per_tag;
          p.covariance = rr.covariance_per_px2 * p.noise_px2;
          out.rim_points = rr.points;
        }
      }
      if (p.ok() && p.rms_px <= o.max_rms_px && precise_enough(b, p)) {
        measured = true;
        out.T_cam_body_measured = p.T_cam_body;
        out.rms_px = p.rms_px;
        out.tags_used = p.tags_used;
        out.tag_ids = p.tag_ids;
        out.rejected_id = p.rejected_id;
        out.covariance = p.covariance_per_px2 * noise_px2(b, p);
        out.sigma_m = uniform_sigma(b, p);
        out.sigma_per_tag_m = per_tag_sigma(b, p);
      }
    }
    if (!measured) out.rim_points = 0;
    pose_ms += ms_since(t0);
    const auto t1 = Clock::now();
    if (measured) {
      track_rules::accept_measurement(b, out.T_cam_body_measured, capture_s);
      b.frames_since_meas = 0;
      if (o.max_prediction_turn_rad > 0) {
        ensure_motion();
        motion.keep(b.thumb_at_meas);
      }
    } else {
      ++b.frames_since_meas;
      track_rules::predict_or_lose(b, o, capture_s, [&] { return prediction_matches_image(b, capture_s); });
    }
    out.measured = measured;
    out.state = b.state;
    out.since_measurement_s = b.has_measurement ? capture_s - b.last_meas_time_s : 0;
    if (b.state != TrackState::kLost)
      out.T_cam_body = o.filter_enabled ? b.filter.predict(display_s) : b.last_meas;
    filter_ms += ms_since(t1);
  }
};

Tracker::Tracker(Tracker&&) noexcept = default;
Tracker& Tracker::operator=(Tracker&&) noexcept = default;
Tracker::~Tracker() = default;

std::string resolve_camera_response(TagDetectorOptions& d, const StationScene& station) {
  if (d.response != CameraResponse::kAuto) return {};
  const calibration::CameraResponseCurve& r = station.camera_provenance.response;
  if (r.kind == "srgb") {
    d.response = CameraResponse::kSrgb;
  } else if (r.kind == "linear") {
    d.response = CameraResponse::kLinear;
  } else if (r.kind == "curve" && r.validate().empty()) {
    d.response = CameraResponse::kCurve;
    d.response_curve = r.table;
  } else {
    d.response = CameraResponse::kLinear;
    return "camera response unknown (the station has no camera.response; dentar calibrate camera "
           "measures it): tag corners as libapriltag finds them, no linear-light refit";
  }
  return {};
}

Result<Tracker> Tracker::create(const StationScene& station, const TrackerOptions& options_in) {
  TrackerOptions options = options_in;
  std::string response_note = resolve_camera_response(options.detector, station);
  if (auto e = options.validate(); !e.empty()) return Error{"TrackerOptions: " + e};
  if (auto e = station.calibration.camera.validate(); !e.empty())
    return Error{"Tracker: station calibration.camera: " + e};
  if (std::find(options.detector.families.begin(), options.detector.families.end(),
                station.family) == options.detector.families.end())
    return Error{std::string("TrackerOptions: detector.families does not include the station's "
                             "tag family ") +
                 tag_family_name(station.family)};
  if (station.mannequin_tags.empty()) return Error{"Tracker: the station has no mannequin tags"};
  auto det = TagDetector::create(options.detector);
  if (!det) return Error{det.error()};
  Tracker t;
  t.impl_ = std::make_unique<Impl>();
  Impl& m = *t.impl_;
  m.o = options;
  m.response_note = std::move(response_note);
  m.camera = station.calibration.camera;
  m.model = CameraModel(m.camera);
  m.detector.emplace(std::move(det).value());
  {
    const TagFamily fam = TagFamily::create(station.family);
    m.reversed_border = fam.raw() == nullptr || fam.reversed_border();
    m.border_cells = fam.raw() == nullptr ? 5 : fam.width_at_border();
    if (options.pattern_fit && fam.raw() != nullptr) m.pattern_family.emplace(TagFamily::create(station.family));
    m.outer_extent = fam.raw() == nullptr ? 0.5
                                          : 0.5 * (fam.total_width() - fam.width_at_border()) /
                                                    double(fam.width_at_border());
  }
  if (options.discovery != DiscoveryMode::kInline) {
    auto ddet = TagDetector::create(options.detector);
    if (!ddet) return Error{ddet.error()};
    m.discovery = std::make_unique<DiscoveryWorker>(std::move(ddet).value(), options.detector.decimation);
    if (options.discovery == DiscoveryMode::kAsync) m.discovery->start(options.discovery_thread_init);
  }
  m.mannequin.bundle = mannequin_bundle(station);
  m.mirror.bundle = mirror_bundle(station);
  m.mannequin.max_sigma_m = options.mannequin_max_sigma_m;
  m.mannequin.static_in_world = true;
  m.mirror.max_sigma_m = options.mirror_max_sigma_m;
  m.mirror.gate_point = station.calibration.T_mtag_mir.translation();  // mirror centre in mtag
  m.T_mtag_mir = station.calibration.T_mtag_mir;
  m.mirror_radius_m = station.calibration.mirror_radius_m;
  m.mirror_thickness_m = station.mirror.thickness_m;
  m.mannequin.filter = PoseFilter(options.filter);
  m.mirror.filter = PoseFilter(options.filter);
  if (options.track_pen) {
    if (station.pen.tags.empty())
      return Error{"Tracker: track_pen is set but the station has no pen (station file \"pen\".tags)"};
    m.pen.bundle = TagBundle{"pen", station.family, station.pen.tags};
    m.pen.max_sigma_m = options.pen_max_sigma_m;
    m.pen.filter = PoseFilter(options.filter);
  }
  return t;
}

void Tracker::reset() {
  for (Body* b : {&impl_->mannequin, &impl_->mirror, &impl_->pen}) {
    b->filter.reset();
    b->has_measurement = false;
    b->state = TrackState::kLost;
    b->frames_since_meas = 0;
    b->thumb_at_meas.release();
  }
  impl_->motion_frame = -1;
  impl_->frames = 0;
  impl_->frames_since_full = 0;
  impl_->have_last_capture = false;
  impl_->frames_since_discovery = 0;
  impl_->scheduled.clear();
  if (impl_->discovery) impl_->discovery->drop();
}

const TrackerOptions& Tracker::options() const { return impl_->o; }
const std::string& Tracker::response_note() const { return impl_->response_note; }
const calibration::CameraIntrinsics& Tracker::camera() const { return impl_->camera; }

Result<TrackFrame> Tracker::track(const cv::Mat& image, double capture_time_s,
                                  double display_time_s, const DiscoveryCue* cue,
                                  std::int64_t frame_id) {
  Impl& m = *impl_;
  const auto t_start = Clock::now();
  if (image.empty()) return Error{"Tracker::track: empty image"};
  if (image.cols != m.camera.width || image.rows != m.camera.height)
    return Error{"Tracker::track: image is " + std::to_string(image.cols) + "x" +
                 std::to_string(image.rows) + " px but the calibration is for " +
                 std::to_string(m.camera.width) + "x" + std::to_string(m.camera.height) +
                 " px; use a calibration for this size (or scale it: scale_intrinsics)"};
  if (!std::isfinite(capture_time_s) || !std::isfinite(display_time_s))
    return Error{"Tracker::track: capture/display time is not finite"};
  const DiscoveryMode mode = m.o.discovery;
  if (cue != nullptr && mode != DiscoveryMode::kScheduled)
    return Error{std::string("Tracker::track: a discovery cue was given but the tracker's discovery "
                             "mode is ") + discovery_mode_name(mode) + ", not scheduled"};
  if (std::string e = frame_gray_error(image); !e.empty()) return Error{"Tracker::track: " + e};
  m.gray.reset(image);
  display_time_s = std::max(display_time_s, capture_time_s);

  TrackFrame f;
  const std::int64_t id = frame_id >= 0 ? frame_id : m.frames;
  f.index = id;
  f.capture_time_s = capture_time_s;
  f.display_time_s = display_time_s;
  const double frame_dt =
      m.have_last_capture ? std::clamp(capture_time_s - m.last_capture_s, 1e-3, 0.2) : 1.0 / 30;
  const bool off_path = mode != DiscoveryMode::kInline;

  // A finished full-frame search first: its bodies then have regions here.
  if (off_path) {
    std::optional<Discovered> d;
    if (mode == DiscoveryMode::kScheduled) {
      if (cue != nullptr && cue->merge >= 0) {
        auto it = m.scheduled.find(cue->merge);
        if (it == m.scheduled.end())
          return Error{"Tracker::track: frame " + std::to_string(id) +
                       " merges the discovery started on frame " + std::to_string(cue->merge) +
                       ", which was never started (a recording with rows missing?)"};
        d = std::move(it->second);
        m.scheduled.erase(it);
      }
    } else {
      d = m.discovery->take();
    }
    if (d) {
      if (!d->error.empty())
        return Error{"Tracker::track: full-frame search of frame " + std::to_string(d->frame) +
                     ": " + d->error};
      m.merge(*d, id);
      f.discovery_merged = d->frame;
      f.discovery_tags = static_cast<int>(d->tags.size());
      f.discovery_ms = d->ms;
    }
  }

  // Region-of-interest or full-frame search.
  std::vector<Box> boxes;
  bool man_ok = false;
  bool full = !off_path && (!m.o.predicted_regions || m.frames == 0 ||
                            m.frames_since_full + 1 >= m.o.full_frame_interval);
  bool mir_ok = false, pen_ok = false;
  if (!full) {
    man_ok = m.add_regions(m.mannequin, capture_time_s, frame_dt, boxes);
    mir_ok = m.add_regions(m.mirror, capture_time_s, frame_dt, boxes);
    if (!m.pen.bundle.tags.empty()) pen_ok = m.add_regions(m.pen, capture_time_s, frame_dt, boxes);
    if (!off_path) full = !man_ok || (m.o.full_frame_when_any_lost && !mir_ok) || boxes.empty();
  }
  const auto t_det = Clock::now();
  m.second_looks = 0;
  std::vector<DetectedTag> tags;
  bool man_missed = false;  // the mannequin was expected in its regions but not found
  if (!full && !boxes.empty()) {
    boxes = merge_boxes(std::move(boxes));
    if (Status s = m.detect_regions(boxes, tags); !s) return Error{s.error()};
    int area = 0;
    for (const Box& b : boxes) area += b.area();
    f.regions = static_cast<int>(boxes.size());
    f.searched_fraction = double(area) / (double(m.camera.width) * m.camera.height);
    bool man_found = false;
    for (const DetectedTag& t : tags)
      for (const TagPlacement& p : m.mannequin.bundle.tags)
        man_found = man_found || (t.family == m.mannequin.bundle.family && t.id == p.id);
    man_missed = man_ok && !man_found;
    // Inline: look at the whole frame now rather than coast on a prediction
    // (recall first). Off the path: a search is posted below instead.
    if (man_missed && !off_path) full = true;
  } else if (!full) {
    f.regions = 0;
    f.searched_fraction = 0;
  }
  if (full) {
    if (Status s = m.detect_full(tags); !s) return Error{s.error()};
    // The mannequin lost, or none of its tags found: the whole frame again
    // in linear light (TrackerOptions::linear_second_look); a frame whose
    // delivered image shows the mannequin costs nothing more.
    if (m.o.linear_second_look && m.o.detector.response != CameraResponse::kLinear && !off_path) {
      bool any_man = false;
      for (const DetectedTag& t : tags)
        for (const TagPlacement& p : m.mannequin.bundle.tags)
          any_man = any_man || (t.family == m.mannequin.bundle.family && t.id == p.id);
      if (!any_man || m.mannequin.state == TrackState::kLost) {
        auto r = m.detector->detect_in_linear_light(m.gray.whole());
        if (!r) return Error{r.error()};
        std::set<std::pair<int, int>> have;
        for (const DetectedTag& t : tags) have.emplace(static_cast<int>(t.family), t.id);
        // Only the mannequin's and the pen's tags (the linear copy can show
        // false quads: 15 on the real photographs of issue 24; the mirror's:
        // see is_mirror_tag).
        auto ours = [&](const DetectedTag& t) {
          for (const Body* b : {&m.mannequin, &m.pen})
            for (const TagPlacement& p : b->bundle.tags)
              if (t.family == b->bundle.family && t.id == p.id) return true;
          return false;
        };
        for (const DetectedTag& t : *r)
          if (!have.count({static_cast<int>(t.family), t.id}) && ours(t)) tags.push_back(t);
        std::sort(tags.begin(), tags.end(), [](const DetectedTag& a, const DetectedTag& b) {
          return a.family != b.family ? a.family < b.family : a.id < b.id;
        });
        ++m.second_looks;
      }
    }
    // The bodies still predicted: a second look where their tags were missed.
    if (m.o.linear_second_look && !off_path) {
      std::vector<Box> pb;
      m.add_regions(m.mannequin, capture_time_s, frame_dt, pb);
      if (!m.pen.bundle.tags.empty()) m.add_regions(m.pen, capture_time_s, frame_dt, pb);
      if (!pb.empty())
        if (Status s = m.second_look(merge_boxes(std::move(pb)), tags); !s) return Error{s.error()};
    }
    f.regions = 0;
    f.searched_fraction = 1;
    m.frames_since_full = 0;
  } else if (!off_path) {
    ++m.frames_since_full;
  }
  if ((m.o.edge_fit || m.o.pattern_fit) && !off_path)
    if (Status s = m.edge_fit_look(m.mannequin, capture_time_s, frame_dt, tags, f); !s) return Error{s.error()};
  f.timing.detect_ms = ms_since(t_det);
  f.full_frame = full;
  f.tags_detected = static_cast<int>(tags.size());
  f.second_looks = m.second_looks;

  m.noise_ref.reset();
  m.update_body(m.mannequin, tags, capture_time_s, display_time_s, f.mannequin, f.timing.pose_ms,
                f.timing.filter_ms);
  if (!m.mirror.bundle.tags.empty())
    m.update_body(m.mirror, tags, capture_time_s, display_time_s, f.mirror, f.timing.pose_ms,
                  f.timing.filter_ms);
  else
    f.mirror.name = "mirror";
  if (!m.pen.bundle.tags.empty())
    m.update_body(m.pen, tags, capture_time_s, display_time_s, f.pen, f.timing.pose_ms,
                  f.timing.filter_ms);
  f.pen.name = "pen";

  // Off the path: hand this frame to a full-frame search when a body needs
  // finding or the interval is up, and the previous search is merged.
  if (off_path) {
    bool start = false;
    if (mode == DiscoveryMode::kScheduled) {
      start = cue != nullptr && cue->start;
      if (start) m.scheduled[id] = m.discovery->search(m.gray.whole(), id, capture_time_s);
    } else {
      const bool any_lost = (!m.mirror.bundle.tags.empty() && !mir_ok &&
                             f.mirror.state == TrackState::kLost) ||
                            (!m.pen.bundle.tags.empty() && !pen_ok && f.pen.state == TrackState::kLost);
      const bool want = m.frames == 0 || f.mannequin.state == TrackState::kLost || man_missed ||
                        (m.o.full_frame_when_any_lost && any_lost) ||
                        m.frames_since_discovery + 1 >= m.o.full_frame_interval;
      if (want && m.discovery->idle()) {
        m.discovery->post(m.gray.whole(), id, capture_time_s);
        start = true;
      }
    }
    f.discovery_started = start;
    m.frames_since_discovery = start ? 0 : m.frames_since_discovery + 1;
  }
  f.gray_fraction = m.gray.converted_fraction();
  f.tags = std::move(tags);
  ++m.frames;
  m.have_last_capture = true;
  m.last_capture_s = capture_time_s;
  f.timing.total_ms = ms_since(t_start);
  return f;
}

// ---- Camera model / image size ----

Result<calibration::CameraIntrinsics> scale_intrinsics(const calibration::CameraIntrinsics& k,
                                                       int width, int height) {
  if (k.width <= 0 || k.height <= 0 || width <= 0 || height <= 0)
    return Error{"scale_intrinsics: sizes must be positive (calibration " +
                 std::to_string(k.width) + "x" + std::to_string(k.height) + ", image " +
                 std::to_string(width) + "x" + std::to_string(height) + ")"};
  const double sx = double(width) / k.width, sy = double(height) / k.height;
  if (std::abs(sx / sy - 1.0) > 0.005)
    return Error{"scale_intrinsics: image " + std::to_string(width) + "x" +
                 std::to_string(height) + " has another aspect ratio than the calibration's " +
                 std::to_string(k.width) + "x" + std::to_string(k.height) +
                 " (a crop, not a scale): calibrate the camera at this size"};
  calibration::CameraIntrinsics out = k;
  out.width = width;
  out.height = height;
  out.fx = k.fx * sx;
  out.fy = k.fy * sy;
  out.cx = (k.cx + 0.5) * sx - 0.5;
  out.cy = (k.cy + 0.5) * sy - 0.5;
  return out;
}

Result<calibration::CameraIntrinsics> camera_for_image(const calibration::CameraIntrinsics& k,
                                                       int width, int height, bool allow_scale,
                                                       const std::string& source) {
  if (k.width == width && k.height == height) return k;
  if (!allow_scale)
    return Error{source + ": the calibration is for " + std::to_string(k.width) + "x" +
                 std::to_string(k.height) + " px images but the input is " +
                 std::to_string(width) + "x" + std::to_string(height) +
                 " px; use a calibration made at this size, or pass --scale-calib to scale "
                 "fx, fy, cx, cy (same aspect ratio only)"};
  auto s = scale_intrinsics(k, width, height);
  if (!s) return Error{source + ": " + s.error()};
  return s;
}

Result<calibration::CameraIntrinsics> read_camera_calibration(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Error{path + ": cannot open the calibration file (missing or unreadable)"};
  char c = 0;
  while (in.get(c) && std::isspace(static_cast<unsigned char>(c))) {
  }
  if (c == '{') {  // a station JSON
    auto s = read_station_scene(path);
    if (!s) return Error{s.error()};
    return s->calibration.camera;
  }
  auto f = calibration::read_camera_file(path);
  if (!f) return Error{f.error()};
  if (auto e = f->camera.validate(); !e.empty()) return Error{path + ": " + e};
  return f->camera;
}

// ---- Per-tag poses ----

std::vector<TagPose> estimate_tag_poses(const std::vector<DetectedTag>& tags,
                                        const calibration::CameraIntrinsics& camera,
                                        double tag_size_m) {
  std::vector<TagPose> out;
  if (!finite_positive(tag_size_m) || !camera.validate().empty()) return out;
  const cv::Matx33d K(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  const std::vector<double> dist(camera.dist.begin(), camera.dist.end());
  const double h = tag_size_m / 2;
  const std::vector<cv::Point3d> obj = {{-h, h, 0}, {h, h, 0}, {h, -h, 0}, {-h, -h, 0}};
  for (const DetectedTag& t : tags) {
    TagPose p;
    p.family = t.family;
    p.id = t.id;
    p.corners_px = t.corners_px;
    std::vector<cv::Point2d> d, u;
    for (const auto& c : t.corners_px) d.emplace_back(c.x(), c.y());
    std::vector<cv::Mat> rvecs, tvecs;
    cv::Mat errs;
    try {
      cv::undistortPoints(d, u, K, dist, cv::noArray(), K);
      cv::solvePnPGeneric(obj, u, K, cv::noArray(), rvecs, tvecs, false, cv::SOLVEPNP_IPPE_SQUARE,
                          cv::noArray(), cv::noArray(), errs);
    } catch (const cv::Exception&) {
      out.push_back(p);  // degenerate quad: ok = false
      continue;
    }
    auto to_iso = [](const cv::Mat& r, const cv::Mat& tv) {
      cv::Mat R;
      cv::Rodrigues(r, R);
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) T.linear()(i, j) = R.at<double>(i, j);
        T.translation()(i) = tv.at<double>(i);
      }
      return T;
    };
    std::vector<std::pair<double, Eigen::Isometry3d>> sol;
    for (std::size_t s = 0; s < rvecs.size(); ++s) {
      const double e = errs.empty() ? 0.0 : errs.at<double>(static_cast<int>(s));
      sol.emplace_back(e, to_iso(rvecs[s], tvecs[s]));
    }
    std::sort(sol.begin(), sol.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    if (!sol.empty()) {
      p.ok = sol[0].second.matrix().allFinite();
      p.rms_px = sol[0].first;
      p.T_cam_tag = sol[0].second;
      p.T_cam_tag_alt = sol.size() > 1 ? sol[1].second : sol[0].second;
      p.alt_rms_px = sol.size() > 1 ? sol[1].first : sol[0].first;
    }
    out.push_back(p);
  }
  return out;
}

}  // namespace dentar::ar
