#include "dentar/ar/frame_pipeline.h"

#include <chrono>
#include <cmath>
#include <limits>

namespace dentar::ar {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}
int state_index(TrackState s) { return s == TrackState::kTracking ? 0 : s == TrackState::kPredicted ? 1 : 2; }

}  // namespace

Eigen::Isometry3d isometry_from_colmajor(const double* a) {
  Eigen::Matrix4d m;
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) m(r, c) = a[c * 4 + r];
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = m.topLeftCorner<3, 3>();
  T.translation() = m.topRightCorner<3, 1>();
  return T;
}

std::string PipelineOptions::validate() const {
  if (!(std::isfinite(predict_s) && predict_s >= 0 && predict_s <= 0.5)) return "predict_s must be in 0..0.5 s";
  if (auto v = tracker.validate(); !v.empty()) return "tracker: " + v;
  if (auto v = compositor.validate(); !v.empty()) return "compositor: " + v;
  if (auto v = expert.validate(); !v.empty()) return "expert." + v;
  return {};
}

std::string ExpertStyle::validate() const {
  if (!(std::isfinite(opacity) && opacity > 0 && opacity <= 1))
    return "opacity = " + std::to_string(opacity) + " must be in (0, 1]";
  const std::pair<const char*, const Eigen::Vector3f*> tints[] = {
      {"tint", &tint}, {"drilling_tint", &drilling_tint}, {"tooth_drilling_tint", &tooth_drilling_tint}};
  for (const auto& [name, t] : tints)
    for (int i = 0; i < 3; ++i)
      if (!((*t)[i] >= 0 && (*t)[i] <= 2))
        return std::string(name) + "[" + std::to_string(i) + "] = " + std::to_string((*t)[i]) + " must be in [0, 2]";
  return {};
}

// ---- ToothMeshes ----

ToothMeshes::ToothMeshes(const volume::VoxelVolume& volume) : volume_(&volume), display_(volume) {
  display_.extract_all();
}

ToothMeshes::~ToothMeshes() { stop_mesher(); }

void ToothMeshes::start_mesher(double period_s, std::function<void()> init) {
  if (mesher_.joinable()) return;
  back_ = std::make_unique<volume::Surface>(*volume_);
  back_->extract_all();
  stop_.store(false);
  mesher_ = std::thread([this, period_s, init = std::move(init)] {
    if (init) init();
    mesher_main(period_s);
  });
}

void ToothMeshes::stop_mesher() {
  stop_.store(true);
  if (mesher_.joinable()) mesher_.join();
}

void ToothMeshes::mesher_main(double period_s) {
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(period_s));
  auto next = Clock::now();
  while (!stop_.load(std::memory_order_acquire)) {
    const auto t0 = Clock::now();
    const std::vector<int> changed = back_->update();
    if (!changed.empty()) {
      std::vector<std::pair<int, volume::ChunkMesh>> batch;
      batch.reserve(changed.size());
      for (int id : changed) batch.emplace_back(id, back_->chunks()[static_cast<std::size_t>(id)]);
      const double ms = ms_since(t0);
      std::lock_guard<std::mutex> lock(mutex_);
      // Later passes replace earlier ones for the same chunk.
      for (auto& b : batch) {
        bool replaced = false;
        for (auto& p : pending_)
          if (p.first == b.first) {
            p.second = std::move(b.second);
            replaced = true;
            break;
          }
        if (!replaced) pending_.push_back(std::move(b));
      }
      stats_.chunks += changed.size();
      stats_.max_pass_ms = std::max(stats_.max_pass_ms, ms);
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.passes;
    }
    next += period;
    const auto now = Clock::now();
    if (next < now) next = now;
    std::this_thread::sleep_until(next);
  }
}

int ToothMeshes::sync() {
  if (!mesher_.joinable()) {
    const auto changed = display_.update();
    std::lock_guard<std::mutex> lock(mutex_);
    ++stats_.passes;
    stats_.chunks += changed.size();
    return static_cast<int>(changed.size());
  }
  std::vector<std::pair<int, volume::ChunkMesh>> got;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    got.swap(pending_);
  }
  for (auto& p : got) display_.replace_chunk(p.first, std::move(p.second));
  return static_cast<int>(got.size());
}

ToothMeshes::Stats ToothMeshes::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

// ---- FramePipeline ----

Result<std::unique_ptr<FramePipeline>> FramePipeline::create(const StationScene& station,
                                                             const PipelineOptions& options) {
  if (auto v = options.validate(); !v.empty()) return Error{"FramePipeline: " + v};
  auto tracker = Tracker::create(station, options.tracker);
  if (!tracker) return Error{"tracker: " + tracker.error()};
  auto comp = Compositor::create(station, options.compositor);
  if (!comp) return Error{"compositor: " + comp.error()};
  std::unique_ptr<StereoTracker> stereo;
  if (options.stereo) {
    auto st = StereoTracker::create(station, options.tracker);
    if (!st) return Error{"stereo tracker: " + st.error()};
    stereo = std::make_unique<StereoTracker>(std::move(*st));
  }
  auto p = std::unique_ptr<FramePipeline>(
      new FramePipeline(station, options, std::move(*tracker), std::move(*comp)));
  p->stereo_ = std::move(stereo);
  return p;
}

// Both eyes (or the one that had an image) through the StereoTracker; poses in the rig frame.
Status FramePipeline::track_stereo(const FrameInput& in, FrameRecord& r) {
  static const cv::Mat kNone;
  const cv::Mat& left = in.image != nullptr ? *in.image : kNone;
  const cv::Mat& right = in.right_image != nullptr ? *in.right_image : kNone;
  auto tf = stereo_->track(left, right, in.capture_time_s, in.capture_time_s + options_.predict_s);
  if (!tf) return Error{"tracking frame " + std::to_string(in.index) + ": " + tf.error()};
  r.eyes = (left.empty() ? 0 : FrameRecord::kEyesLeft) | (right.empty() ? 0 : FrameRecord::kEyesRight);
  last_tags_ = left.empty() ? tf->right.tags : tf->left.tags;
  r.detect_ms = tf->left.timing.detect_ms + tf->right.timing.detect_ms;
  r.pose_ms = tf->pose_ms;
  r.filter_ms = 0;
  r.man_state = state_index(tf->mannequin.track.state);
  r.mir_state = state_index(tf->mirror.track.state);
  r.pen_state = state_index(tf->pen.track.state);
  r.T_cam_man = tf->mannequin.track.T_cam_body;
  r.T_cam_mtag = tf->mirror.track.T_cam_body;
  r.T_cam_ptag = tf->pen.track.T_cam_body;
  r.man_rms_px = tf->mannequin.track.measured ? tf->mannequin.track.rms_px : std::numeric_limits<double>::quiet_NaN();
  r.man_tags = tf->mannequin.track.tags_used;
  r.mir_tags = tf->mirror.track.tags_used;
  r.pen_tags = tf->pen.track.tags_used;
  r.man_views = tf->mannequin.views_used;
  r.mir_views = tf->mirror.views_used;
  r.tags_detected = tf->left.tags_detected + tf->right.tags_detected;
  r.full_frame = tf->left.full_frame || tf->right.full_frame;
  return {};
}

Status FramePipeline::process(const FrameInput& in, ToothMeshes& meshes, CompositeResult& out,
                              FrameRecord& r) {
  const bool has_left = in.image != nullptr && !in.image->empty();
  const bool has_right = stereo_ && in.right_image != nullptr && !in.right_image->empty();
  if (!has_left && !has_right)
    return Error{"frame " + std::to_string(in.index) + (stereo_ ? ": no image from either eye" : ": no image")};
  r = FrameRecord{};
  r.frame = in.index;
  r.time_s = in.capture_time_s;

  // Haptics as of this frame (the snapshot the caller took).
  if (in.haptic != nullptr) {
    const haptics::HapticSnapshot& s = *in.haptic;
    r.haptic_step = s.step;
    r.haptic_steps_done = s.steps_done;
    r.pedal = s.pedal != 0;
    r.force_N = std::sqrt(s.force_dev_N[0] * s.force_dev_N[0] + s.force_dev_N[1] * s.force_dev_N[1] +
                          s.force_dev_N[2] * s.force_dev_N[2]);
    for (int m = 0; m < 8; ++m) r.removed_mm3[m] = s.removed_mm3[m];
    r.T_dev_sty = isometry_from_colmajor(s.T_dev_sty);
  }

  // Cutting-mesh update.
  auto t0 = Clock::now();
  r.mesh_chunks = meshes.sync();
  r.mesh_ms = ms_since(t0);

  // Tracking.
  t0 = Clock::now();
  if (stereo_) {
    if (Status s = track_stereo(in, r); !s) return s;
    r.track_ms = ms_since(t0);
  } else {
    auto tf = tracker_.track(*in.image, in.capture_time_s, in.capture_time_s + options_.predict_s,
                             in.discovery, in.index);
    if (!tf) return Error{"tracking frame " + std::to_string(in.index) + ": " + tf.error()};
    last_tags_ = tf->tags;
    r.track_ms = ms_since(t0);
    r.detect_ms = tf->timing.detect_ms;
    r.pose_ms = tf->timing.pose_ms;
    r.filter_ms = tf->timing.filter_ms;
    r.man_state = state_index(tf->mannequin.state);
    r.mir_state = state_index(tf->mirror.state);
    r.pen_state = state_index(tf->pen.state);
    r.T_cam_man = tf->mannequin.T_cam_body;
    r.T_cam_mtag = tf->mirror.T_cam_body;
    r.T_cam_ptag = tf->pen.T_cam_body;
    r.man_rms_px = tf->mannequin.measured ? tf->mannequin.rms_px : std::numeric_limits<double>::quiet_NaN();
    r.man_tags = tf->mannequin.tags_used;
    r.mir_tags = tf->mirror.tags_used;
    r.pen_tags = tf->pen.tags_used;
    r.tags_detected = tf->tags_detected;
    r.full_frame = tf->full_frame;
    r.disc_start = tf->discovery_started;
    r.disc_merged = tf->discovery_merged;
    r.disc_ms = tf->discovery_ms;
  }

  // Registration and compositing.
  t0 = Clock::now();
  CompositeInput ci;
  ci.video_bgr = in.image;
  ci.man_valid = r.man_state != 2;
  ci.T_cam_man = r.T_cam_man;
  ci.mirror_valid = r.mir_state != 2;
  ci.T_cam_mtag = r.T_cam_mtag;
  Compositor* compositor = &compositor_;
  if (!has_left) {
    // Stereo with the left eye lost: the right eye's image, the poses seen from the right eye.
    if (!right_compositor_) {
      StationScene sr = station_;
      sr.calibration.camera = station_.stereo.camera_right;
      auto c = Compositor::create(sr, compositor_.options());
      if (!c) return Error{"compositing frame " + std::to_string(in.index) + " (right eye): " + c.error()};
      right_compositor_ = std::make_unique<Compositor>(std::move(*c));
    }
    compositor = right_compositor_.get();
    const Eigen::Isometry3d T_camr_rig = station_.stereo.T_caml_camr.inverse();
    ci.video_bgr = in.right_image;
    ci.T_cam_man = T_camr_rig * r.T_cam_man;
    ci.T_cam_mtag = T_camr_rig * r.T_cam_mtag;
  }
  ci.stylus_valid = in.haptic != nullptr && in.stylus_valid;
  ci.T_dev_sty = r.T_dev_sty;
  const ExpertStyle& ex = options_.expert;
  if (ex.draw && in.haptic != nullptr && in.haptic->mode != 0) {
    ci.expert.valid = true;
    ci.expert.T_tooth_exp = isometry_from_colmajor(in.haptic->T_tooth_expert_tip);
    ci.expert.opacity = ex.opacity;
    ci.expert.depth_tested = ex.depth_tested;
    const bool hint = in.haptic->mode == 5 && in.haptic->expert_drilling != 0;
    ci.expert.tint = hint ? ex.drilling_tint : ex.tint;
    if (hint) ci.tooth_tint = ex.tooth_drilling_tint;
    r.expert_drilling_shown = hint && ci.man_valid;
  }
  if (auto cs = in.gl_target.video_texture != 0 ? compositor->compose_gl(meshes.display(), ci, in.gl_target, out)
                                  : compositor->compose(meshes.display(), ci, out);
      !cs)
    return Error{"compositing frame " + std::to_string(in.index) + ": " + cs.error()};
  r.composite_ms = ms_since(t0);
  r.stylus_drawn = ci.stylus_valid && ci.man_valid;
  r.overlay = out.overlay_drawn;
  r.mirror_drawn = out.mirror_drawn;
  r.expert_drawn = out.expert_drawn;
  r.triangles = out.triangles_drawn;
  r.gpu_composite = out.gpu_output;
  r.readback_px = out.readback_px;
  r.cpu_blend_px = out.cpu_blend_px;
  if (in.note != nullptr && !in.note->empty() && r.overlay) {
    if (const auto c = tooth_centre_px(station_, r.T_cam_man)) {
      r.note_anchored = true;
      r.note_anchor_px = *c;
      if (!out.image.empty()) {
        draw_note_label(out.image, layout_note_label(*in.note, *c, out.image.size()));
        r.note_drawn = true;
      }
    }
  }
  return {};
}

Status FramePipeline::warm_up(ToothMeshes& meshes, const GlFrameTarget& gl_target) {
  const auto& cam = station_.calibration.camera;
  const cv::Mat grey(cam.height, cam.width, CV_8UC3, cv::Scalar(128, 128, 128));
  Eigen::Isometry3d T_cam_tooth = Eigen::Isometry3d::Identity();
  T_cam_tooth.translation() = Eigen::Vector3d(0, 0, 0.25);
  CompositeInput ci;
  ci.video_bgr = &grey;
  ci.man_valid = true;
  ci.T_cam_man = T_cam_tooth * station_.calibration.T_man_tooth.inverse();
  CompositeResult out;
  if (auto s = compositor_.compose(meshes.display(), ci, out); !s) return Error{"warm-up: " + s.error()};
  if (gl_target.video_texture != 0)
    if (auto s = compositor_.compose_gl(meshes.display(), ci, gl_target, out); !s)
      return Error{"warm-up (GPU path): " + s.error()};
  if (auto s = compositor_.set_options(compositor_.options()); !s) return Error{"warm-up: " + s.error()};
  tracker_.reset();
  if (stereo_) stereo_->reset();
  return {};
}

}  // namespace dentar::ar
