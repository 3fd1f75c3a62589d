#include "dentar/ar/frame_pipeline.h"

#include <pthread.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdlib>
#include <exception>
#include <limits>
#include <optional>

#include "dentar/ar/egl_context.h"

namespace dentar::ar {

// The right eye's thread (PipelineOptions::eye_threads = 2): one job at a time, posted by the
// pipeline's thread and waited for before process() returns. It makes a headless GL context
// of its own (after `init`, so llvmpipe's rasteriser inherits its CPU mask), where the right
// eye's compositor is created, used and destroyed.
class EyeWorker {
 public:
  static Result<std::unique_ptr<EyeWorker>> start(std::function<void()> init) {
    auto w = std::unique_ptr<EyeWorker>(new EyeWorker);
    w->thread_ = std::thread([p = w.get(), init = std::move(init)] { p->main(init); });
    std::unique_lock<std::mutex> lock(w->m_);
    w->cv_.wait(lock, [&] { return w->started_; });
    if (!w->start_error_.empty()) {
      lock.unlock();
      const std::string e = w->start_error_;
      w->stop();
      return Error{"the right eye's thread: " + e};
    }
    return w;
  }
  ~EyeWorker() { stop(); }

  // Starts `job` on the worker (none may be pending).
  void post(std::function<void()> job) {
    {
      std::lock_guard<std::mutex> lock(m_);
      job_ = std::move(job);
      has_job_ = true;
      done_ = false;
      error_.clear();
    }
    cv_.notify_all();
  }
  // Waits for the posted job; its exception, if it threw, as an error.
  Status wait() {
    std::unique_lock<std::mutex> lock(m_);
    cv_.wait(lock, [&] { return done_; });
    if (!error_.empty()) return Error{error_};
    return {};
  }
  Status run(std::function<void()> job) {
    post(std::move(job));
    return wait();
  }

 private:
  EyeWorker() = default;
  void stop() {
    if (!thread_.joinable()) return;
    {
      std::lock_guard<std::mutex> lock(m_);
      stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  void main(const std::function<void()>& init) {
    pthread_setname_np(pthread_self(), "dentar-eye-r");
    if (init) init();
    // Test hook (session 18): DENTAR_TEST_FAIL_EYE_CONTEXT=1 refuses this thread's context, as a
    // driver out of contexts would: the pipeline falls back to one eye thread (create()).
    const char* refuse = std::getenv("DENTAR_TEST_FAIL_EYE_CONTEXT");
    auto egl = refuse != nullptr && *refuse != '\0' && std::string(refuse) != "0"
                   ? Result<EglContext>(Error{"refused by the test hook DENTAR_TEST_FAIL_EYE_CONTEXT"})
                   : EglContext::create();
    {
      std::lock_guard<std::mutex> lock(m_);
      started_ = true;
      if (!egl) start_error_ = "headless GL context: " + egl.error();
      done_ = true;
    }
    cv_.notify_all();
    if (!egl) return;
    for (;;) {
      std::function<void()> job;
      {
        std::unique_lock<std::mutex> lock(m_);
        cv_.wait(lock, [&] { return stop_ || has_job_; });
        if (!has_job_) break;  // stop_, nothing pending
        job = std::move(job_);
        has_job_ = false;
      }
      std::string err;
      try {
        job();
      } catch (const std::exception& e) {
        err = std::string("the right eye's thread: ") + e.what();
      }
      {
        std::lock_guard<std::mutex> lock(m_);
        error_ = err;
        done_ = true;
      }
      cv_.notify_all();
    }
  }

  std::thread thread_;
  std::mutex m_;
  std::condition_variable cv_;
  std::function<void()> job_;
  bool has_job_ = false, done_ = true, stop_ = false, started_ = false;
  std::string error_, start_error_;
};

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
  if (eye_threads != 1 && eye_threads != 2)
    return "eye_threads = " + std::to_string(eye_threads) + " must be 1 (both eyes on one thread) or 2";
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
  auto p = std::unique_ptr<FramePipeline>(
      new FramePipeline(station, options, std::move(*tracker), std::move(*comp)));
  if (options.stereo) {
    auto st = StereoTracker::create(station, options.tracker);
    if (!st) return Error{"stereo tracker: " + st.error()};
    p->stereo_ = std::make_unique<StereoTracker>(std::move(*st));
    // The right eye: the same scene through its own camera (the rig's camera_right).
    p->station_right_ = station;
    p->station_right_.calibration.camera = station.stereo.camera_right;
    std::optional<Result<Compositor>> c;
    std::optional<Result<std::unique_ptr<EyeWorker>>> w;
    if (options.eye_threads == 2) {
      // Its own thread and GL context: the compositor is made (and later used) there. A thread
      // whose context cannot be made (a driver out of contexts): both eyes on this thread, as
      // eye_threads = 1 (the same pixels), said in eye_thread_note().
      w.emplace(EyeWorker::start(options.eye_thread_init));
      if (!*w) {
        p->eye_thread_note_ = "the right eye's own thread could not start (" + w->error() +
                              "): both eyes on one thread (eye_threads 1)";
        p->options_.eye_threads = 1;
      }
    }
    if (w && *w) {
      p->worker_ = std::move(**w);
      if (auto s = p->worker_->run([&] { c.emplace(Compositor::create(p->station_right_, options.compositor)); }); !s)
        return Error{"compositor (right eye): " + s.error()};
      EyeWorker* wk = p->worker_.get();
      p->stereo_->set_eye_runner([wk](const std::function<void()>& left, const std::function<void()>& right) {
        wk->post(right);
        try {
          left();
        } catch (...) {
          (void)wk->wait();  // never leave the right eye's job running on the caller's frame
          throw;
        }
        (void)wk->wait();  // the job reports its own errors (StereoTracker::track)
      });
    } else {
      c.emplace(Compositor::create(p->station_right_, options.compositor));
    }
    if (!*c) return Error{"compositor (right eye, station stereo.camera_right): " + c->error()};
    p->right_compositor_ = std::make_unique<Compositor>(std::move(**c));
  }
  return p;
}

FramePipeline::FramePipeline(StationScene st, PipelineOptions o, Tracker t, Compositor c)
    : station_(std::move(st)), options_(std::move(o)), tracker_(std::move(t)), compositor_(std::move(c)) {}

FramePipeline::~FramePipeline() {
  // The right eye's GL objects on the thread where its context is current, then the thread.
  if (worker_) (void)worker_->run([this] { right_compositor_.reset(); });
  worker_.reset();
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
                              FrameRecord& r, CompositeResult* right_out) {
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

  // Registration and compositing: the poses in the rig frame (= the camera's for one camera),
  // then each eye through compose_eye.
  CompositeInput rig;
  rig.man_valid = r.man_state != 2;
  rig.T_cam_man = r.T_cam_man;
  rig.mirror_valid = r.mir_state != 2;
  rig.T_cam_mtag = r.T_cam_mtag;
  rig.stylus_valid = in.haptic != nullptr && in.stylus_valid;
  rig.T_dev_sty = r.T_dev_sty;
  const ExpertStyle& ex = options_.expert;
  if (ex.draw && in.haptic != nullptr && in.haptic->mode != 0) {
    rig.expert.valid = true;
    rig.expert.T_tooth_exp = isometry_from_colmajor(in.haptic->T_tooth_expert_tip);
    rig.expert.opacity = ex.opacity;
    rig.expert.depth_tested = ex.depth_tested;
    const bool hint = in.haptic->mode == 5 && in.haptic->expert_drilling != 0;
    rig.expert.tint = hint ? ex.drilling_tint : ex.tint;
    if (hint) rig.tooth_tint = ex.tooth_drilling_tint;
    r.expert_drilling_shown = hint && rig.man_valid;
  }
  EyeView right;
  if (stereo_) {
    right.image = in.right_image;
    right.compositor = right_compositor_.get();
    right.station = &station_right_;
    right.T_eye_rig = station_.stereo.T_caml_camr.inverse();
  }
  // The main composite: the left eye (or the one camera); with the left eye lost, the right.
  EyeView main;
  if (has_left) {
    main.image = in.image;
    main.compositor = &compositor_;
    main.station = &station_;
  } else {
    main = right;
  }
  main.gl_target = in.gl_target;  // the GPU path draws the main composite (the right eye's own: CPU)
  // eye_threads = 2: the right eye's own composite on its thread while the left eye's is drawn
  // here (both read the meshes and the rig's poses only; each writes its own output).
  Status right_status;
  const bool right_async = worker_ && right_out != nullptr && has_left && has_right;
  if (right_async)
    worker_->post([&] { right_status = compose_eye(right, rig, in, meshes, *right_out, r.right); });
  EyeRecord er;
  Status left_status;
  try {
    left_status = compose_eye(main, rig, in, meshes, out, er);
  } catch (...) {
    if (right_async) (void)worker_->wait();  // it draws into our outputs: never left running
    throw;
  }
  if (!left_status) {
    if (right_async) (void)worker_->wait();  // never leave it drawing into our outputs
    return left_status;
  }
  r.composite_ms = er.composite_ms;
  r.stylus_drawn = rig.stylus_valid && rig.man_valid;
  r.overlay = er.overlay;
  r.mirror_drawn = er.mirror_drawn;
  r.expert_drawn = er.expert_drawn;
  r.triangles = out.triangles_drawn;
  r.gpu_composite = out.gpu_output;
  r.readback_px = out.readback_px;
  r.cpu_blend_px = out.cpu_blend_px;
  r.note_anchored = er.note_anchored;
  r.note_drawn = er.note_drawn;
  r.note_anchor_px = er.note_anchor_px;
  // The right eye's own composite (both eyes present and asked for), else none: mono.
  if (right_out != nullptr) {
    if (has_left && has_right) {
      if (worker_) {
        // Started before the left eye's below, waited for here (eye_threads = 2).
        if (Status s = worker_->wait(); !s) return s;
        if (!right_status) return right_status;
      } else if (Status s = compose_eye(right, rig, in, meshes, *right_out, r.right); !s) {
        return s;
      }
    } else {
      right_out->image.release();
      right_out->patch.release();
      right_out->patch_rect = cv::Rect();
      right_out->tooth_visible.release();
      right_out->overlay_drawn = right_out->mirror_drawn = right_out->expert_drawn = false;
      right_out->region = cv::Rect();
    }
  }
  return {};
}

Status FramePipeline::compose_eye(const EyeView& eye, const CompositeInput& rig, const FrameInput& in,
                                  ToothMeshes& meshes, CompositeResult& out, EyeRecord& er) {
  const auto t0 = Clock::now();
  const bool is_right = eye.compositor != &compositor_;
  const std::string what = is_right ? " (right eye)" : "";
  CompositeInput ci = rig;
  ci.video_bgr = eye.image;
  ci.T_cam_man = eye.T_eye_rig * rig.T_cam_man;
  ci.T_cam_mtag = eye.T_eye_rig * rig.T_cam_mtag;
  ci.keep_yuyv = in.keep_yuyv && (in.note == nullptr || in.note->empty());
  if (auto cs = eye.gl_target.video_texture != 0 ? eye.compositor->compose_gl(meshes.display(), ci, eye.gl_target, out)
                                                 : eye.compositor->compose(meshes.display(), ci, out);
      !cs)
    return Error{"compositing frame " + std::to_string(in.index) + what + ": " + cs.error()};
  er = EyeRecord{};
  er.composited = true;
  er.composite_ms = ms_since(t0);
  er.overlay = out.overlay_drawn;
  er.mirror_drawn = out.mirror_drawn;
  er.expert_drawn = out.expert_drawn;
  er.triangles = out.triangles_drawn;
  er.region = out.region;
  er.readback_px = out.readback_px;
  er.cpu_blend_px = out.cpu_blend_px;
  if (in.note != nullptr && !in.note->empty() && er.overlay) {
    if (const auto c = tooth_centre_px(*eye.station, ci.T_cam_man)) {
      er.note_anchored = true;
      er.note_anchor_px = *c;
      if (!out.image.empty() && out.image.type() == CV_8UC3) {
        draw_note_label(out.image, layout_note_label(*in.note, *c, out.image.size()));
        er.note_drawn = true;
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
  if (right_compositor_) {
    // The right eye's compositor (stereo): its own uploads and levels of detail.
    const auto& cr = station_right_.calibration.camera;
    const cv::Mat grey_r(cr.height, cr.width, CV_8UC3, cv::Scalar(128, 128, 128));
    ci.video_bgr = &grey_r;
    Status rs;
    const auto warm = [&] {
      if (auto s = right_compositor_->compose(meshes.display(), ci, out); !s) rs = Error{"warm-up (right eye): " + s.error()};
      else if (auto s2 = right_compositor_->set_options(right_compositor_->options()); !s2) rs = Error{"warm-up: " + s2.error()};
    };
    if (worker_) {
      if (auto s = worker_->run(warm); !s) return s;
    } else {
      warm();
    }
    if (!rs) return rs;
  }
  tracker_.reset();
  if (stereo_) stereo_->reset();
  return {};
}

}  // namespace dentar::ar
