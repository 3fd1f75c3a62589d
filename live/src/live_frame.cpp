// dentar live's frame thread: its GL context, the run's pipeline, and the
// work on each camera frame. See live_run.h.
#include <pthread.h>
#include <sched.h>

#include <chrono>
#include <cstdlib>
#include <exception>
#include <string>
#include <thread>

#include "dentar/ar/egl_context.h"
#include "dentar/haptics/engine.h"
#include "dentar/live/eye_switches.h"
#include "dentar/live/freshest_pair.h"
#include "dentar/training/lesson.h"
#include "live_run.h"

namespace dentar::live {
namespace {
using Clock = std::chrono::steady_clock;

// This thread's CPU time, ms (the per-frame figures: CPU beside the wall clock).
double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}

// The frame thread's GL context and display path: a context on the window's
// EGL display sharing its objects (the GPU path), otherwise (or when that
// fails) a headless one of our own; then the run's pipeline, warmed up.
class FrameThread {
 public:
  FrameThread(const LiveContext& c, LiveShared& sh, FrameFigures& fig) : c_(c), sh_(sh), fig_(fig) {
    for (const char* stage : {"pickup", "pair_wait", "process_cpu", "mesh_sync", "track", "compose_left", "compose_right"})
      fig_.stage_ms[stage];  // made now: no allocation while the run lasts
  }

  // false: the pipeline could not come up (sh.pipeline_error says why).
  bool open() {
    // llvmpipe starts its rasteriser thread when the context is made, with
    // this thread's CPU mask: with the background threads on the engine's
    // CPU, it goes there too (it is the largest GL cost; the frame thread
    // then only records the draw calls and waits, and CPU 0 keeps the
    // tracking, the blend and the display).
    cpu_set_t frame_mask;
    const bool raster_moved =
        c_.to_engine_cpu && pthread_getaffinity_np(pthread_self(), sizeof frame_mask, &frame_mask) == 0;
    if (raster_moved) c_.to_engine_cpu();
    use_gl_ = c_.want_gl && c_.hw.gles_egl();
    if (use_gl_) {
      ar::EglContextOptions eo;
      eo.share_display = c_.hw.egl_display();
      eo.share_context = c_.hw.egl_context();
      egl_ = ar::EglContext::create(eo);
      if (!egl_) {
        sh_.display_note = egl_.error();
        use_gl_ = false;
      }
    }
    if (!use_gl_) egl_ = ar::EglContext::create();
    if (raster_moved) pthread_setaffinity_np(pthread_self(), sizeof frame_mask, &frame_mask);
    if (!egl_ || !egl_->make_current())
      return fail("headless rendering: " + (egl_ ? std::string("make_current failed") : egl_.error()));
    if (auto s = c_.run.create_pipeline(c_.st, c_.popt); !s) return fail(s.error());
    // The right eye's own thread could not be made (no GL context for it): one eye thread.
    fig_.eye_threads = c_.run.pipeline().options().eye_threads;
    fig_.eye_thread_note = c_.run.pipeline().eye_thread_note();
    if (!fig_.eye_thread_note.empty()) {
      c_.say("warning: " + fig_.eye_thread_note);
      if (session::Recorder* rec = c_.run.recorder()) rec->log("warning: " + fig_.eye_thread_note);
    }
    if (use_gl_) {
      if (std::string e = c_.run.pipeline().compositor().gpu_path_error(); !e.empty()) {
        sh_.display_note = "the compositor's GPU path cannot run here: " + e;
        use_gl_ = false;
      } else if (auto r = ar::SharedFrameRing::create(c_.W, c_.H); !r) {
        sh_.display_note = r.error();
        use_gl_ = false;
      } else {
        sh_.ring = std::move(*r);
      }
    }
    if (auto s = c_.run.warm_up(use_gl_ ? sh_.ring->target(0) : ar::GlFrameTarget{}); !s) return fail(s.error());
    // A stereo rig into the headset's side-by-side view: each eye its own composite.
    want_right_ = c_.run.pipeline().stereo() && c_.o.output == "sbs";
    sh_.gl_path.store(use_gl_);
    c_.run.meshes().start_mesher(1.0 / 120.0, [init = c_.to_engine_cpu, cpus = c_.layout.of(CpuLayout::kMesher)] {
      pthread_setname_np(pthread_self(), "dentar-mesher");
      if (!cpus.empty()) pin_this_thread(cpus);  // --cpu-layout mesher=
      else if (init) init();
    });
    sh_.pipeline_ready.store(1);
    return true;
  }

  // Until stop, or the footage ends.
  void loop() {
    while (sh_.capture.load() == nullptr && !sh_.stop.load()) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    if (!sh_.stop.load()) {
      ar::CaptureThread& capture = *sh_.capture.load();
      ar::CaptureThread* right = sh_.capture_right.load();
      ar::Frame f;
      while (!sh_.stop.load()) {
        // Two cameras, the left one silent: the right eye alone until the left delivers again.
        if (right != nullptr && left_lost_ && !capture.wait_take(f, 0)) {
          if (!right_alone(*right, f)) {
            if (capture.ended()) break;
            continue;
          }
          process_frame(f);
          right_only_ = false;
          continue;
        }
        if (right != nullptr && left_lost_) left_back(f);
        else if (!capture.wait_take(f, right != nullptr ? 0.02 : 0.05)) {
          if (capture.ended()) break;
          if (right != nullptr) check_left_lost(capture, *right);
          continue;
        }
        fig_.stage_ms["pickup"].add((ar::steady_now_s() - f.steady_s) * 1e3);  // in the capture slot
        if (c_.o.side_by_side) {
          // One side-by-side frame: the left half is the frame shown, the right half the right eye.
          const int w = f.image.cols / 2;
          right_image_ = f.image(cv::Rect(w, 0, w, f.image.rows)).clone();
          right_encoded_.release();
          f.image = f.image(cv::Rect(0, 0, w, f.image.rows)).clone();
          f.encoded = cv::Mat();  // the device's JPEG holds both eyes
        } else if (right != nullptr) {
          // Freshest pair wins (freshest_pair.h): never a pair gone stale while it was made.
          const auto t_pair = Clock::now();
          fig_.stale_pairs_skipped += take_freshest_pair(
              capture, f, [&](ar::Frame& l, const auto& stale) { pair_right(*right, l, stale); });
          fig_.stage_ms["pair_wait"].add(std::chrono::duration<double, std::milli>(Clock::now() - t_pair).count());
        }
        process_frame(f);
      }
    }
    c_.run.meshes().stop_mesher();
    // The window may still draw from (and release) the ring until the main
    // loop ends (the footage can end first): the ring goes only after that.
    while (sh_.ring && !sh_.stop.load()) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    if (sh_.ring) {
      const auto rs = sh_.ring->stats();
      fig_.ring_replaced = rs.replaced;
      fig_.ring_ready_timeouts = rs.ready_timeouts;
      fig_.ring_release_timeouts = rs.release_timeouts;
    }
    close();
  }

  // The GL objects go before the context.
  void close() {
    sh_.ring.reset();
    c_.run.drop_pipeline();
  }

 private:
  bool fail(const std::string& e) {
    sh_.pipeline_error = e;
    sh_.pipeline_ready.store(-1);
    return false;
  }

  // Two cameras (issue 28): the right eye's frame captured with `left` (within half a frame
  // period, waiting up to that long for it), else none: the single-view path. A right eye
  // silent for 0.1 s is not waited for (StereoSource's rule), so a lost eye costs no time.
  // Session 21: `stale()` true: a newer left frame waits (peeked, not taken) and this pair will
  // be skipped (freshest_pair.h): take no right frame for it.
  template <class Stale>
  void pair_right(ar::CaptureThread& right, const ar::Frame& left, const Stale& stale) {
    const double half = 0.5 / (right.fps() > 0 ? right.fps() : 30.0);
    const double silent_s = 0.1;
    const auto t_enter = Clock::now();
    ar::Frame r;
    // Session 20: a right frame too old to pair with `left` is passed over in its capture
    // thread, never decoded (decode on demand). Session 22: the eye's last-seen time and its
    // returns are the capture thread's (every frame the camera delivered: note_right_seen).
    const double oldest = left.steady_s - half;
    const bool give_up = stale();  // peeked: a newer left frame is already waiting
    if (give_up) ++fig_.stale_pairs_untaken;
    note_right_seen(right);
    const bool got = !give_up && right.wait_take_since(r, 0, oldest);  // the newest (latest wins)
    if (got) take_right(right, std::move(r));
    const auto deadline = Clock::now() + std::chrono::duration<double>(half);
    while (!give_up && (right_pending_.image.empty() || right_pending_.steady_s < oldest)) {
      if (stale()) {  // a newer left frame came while this one waited for its partner
        ++fig_.stale_pairs_untaken;
        break;
      }
      const double last = right.last_frame_steady_s();
      if (last <= 0 || left.steady_s - last > silent_s) break;  // lost (or not started): do not wait
      const double left_s = std::chrono::duration<double>(deadline - Clock::now()).count();
      if (left_s <= 0) break;
      // Session 21: wait for the partner without taking it; once there, take it only if this
      // pair is still the freshest (a newer left frame may have come meanwhile).
      if (!right.wait_ready(left_s, oldest)) break;
      if (stale()) {
        ++fig_.stale_pairs_untaken;
        break;
      }
      const bool more = right.wait_take_since(r, 0, oldest);
      note_right_seen(right);
      if (!more) break;
      take_right(right, std::move(r));
    }
    right_image_.release();
    right_encoded_.release();
    if (!right_pending_.image.empty() && std::abs(right_pending_.steady_s - left.steady_s) <= half) {
      right_pair_s_ = right_pending_.steady_s;
      right_image_ = right_pending_.image;
      right_encoded_ = right_pending_.encoded;  // its camera's JPEG bytes, for the recording
      right_pending_ = ar::Frame{};
    }
    pair_wait_ms_ = std::chrono::duration<double, std::milli>(Clock::now() - t_enter).count();
    // The right camera silent (lost) for this frame, not just unpaired once.
    const double rl = right.last_frame_steady_s();
    right_silent_ = rl > 0 && left.steady_s - rl > silent_s;
    if (right_silent_) right_silent_from_s_ = rl, right_was_silent_ = true;
  }

  // A right-eye frame taken from its capture thread: the newest.
  void take_right(const ar::CaptureThread& right, ar::Frame&& r) {
    note_right_seen(right);
    right_pending_ = std::move(r);
  }
  // The right eye's last-seen time and, when a silence (issue 28's fallback) ended, the time
  // the eye came back: the capture thread's, which sees every frame the camera delivered
  // (session 22; they were the frames this thread took or passed over, so a frame skipped
  // undecoded or left waiting counted for neither, and a slow loop taking the eye's frames
  // > 0.1 s apart, or the left camera's loss leaving them unread, looked like a silence).
  void note_right_seen(const ar::CaptureThread& right) {
    right_last_s_ = std::max(right_last_s_, right.last_frame_steady_s());
    const double back = right.last_silence().first_after_s;
    if (back > right_silence_seen_s_) {
      right_silence_seen_s_ = back;
      right_back_s_ = right_first_back_s_ = back;
    }
  }

  // Two cameras (issue 28): the left camera silent for kSilentS while the right one delivers
  // (the right eye's rule in pair_right): from now on each right-eye frame is a single-view
  // frame on its own (right_alone), timed from the left camera's last frame.
  static constexpr double kSilentS = 0.1;
  void check_left_lost(const ar::CaptureThread& left, const ar::CaptureThread& right) {
    const double now = ar::steady_now_s(), last = left.last_frame_steady_s();
    if (last <= 0 || now - last <= kSilentS || now - right.last_frame_steady_s() > kSilentS) return;
    left_lost_ = true;
    left_last_s_ = last;
    say_eye("left camera lost (" + c_.o.camera + "): no frame for " + std::to_string(std::lround((now - last) * 1e3)) +
            " ms; tracking and drawing from the right eye (" + c_.o.camera_right + ") alone until it returns");
  }

  // The left camera's first frame after its silence: pairs again (the message; the frame is
  // paired and processed as any other).
  void left_back(const ar::Frame& f) {
    left_lost_ = false;
    left_back_s_ = f.steady_s;
    say_eye("left camera back (" + c_.o.camera + ") after " +
            std::to_string(std::lround((f.steady_s - left_last_s_) * 1e3)) + " ms: both eyes again");
  }

  // A right-eye frame while the left camera is lost: the newest, waiting up to 20 ms for it
  // (then the loop looks at the left camera again). false: none.
  bool right_alone(ar::CaptureThread& right, ar::Frame& f) {
    ar::Frame r;
    if (!right.wait_take(r, 0.02)) return false;
    take_right(right, std::move(r));
    f = std::move(right_pending_);
    right_pending_ = ar::Frame{};
    right_image_.release();
    right_encoded_.release();
    right_only_ = true;
    return true;
  }

  void say_eye(const std::string& m) {
    c_.say(m);
    if (session::Recorder* rec = c_.run.recorder()) rec->log(m);
  }

  // Two cameras: a camera lost (silent for kSilentS: the left one in check_left_lost, the right
  // one in pair_right) or back changes the run's mode; the first frame drawn in the new mode
  // (its eyes those of the mode) gives the window the switches it is timed from
  // (Shown::switches): the lost camera's last frame, or the returning camera's first frame
  // back, to this frame's swap. A single frame without a partner (pairing skew) is no switch.
  // Session 22: each camera's change is its own switch (left only straight to right only: the
  // right camera back and the left one lost), queued (eye_switches.h) until drawn.
  void note_switch(int eyes, double capture_steady_s) {
    frame_switches_.clear();
    if (c_.o.camera_right.empty()) return;
    using FR = ar::FrameRecord;
    const int mode = left_lost_ ? FR::kEyesRight : right_silent_ ? FR::kEyesLeft : FR::kEyesBoth;
    // Session 23: the right eye alone (the left camera lost) and its camera silent and back in
    // between (a silence begun after the left camera's last frame, not yet seen): neither camera
    // delivered, then the right one again; the mode is the same, the right camera's loss and
    // return are switches (eye_switches_between's right_gap) and the return a recovery.
    bool right_gap = false;
    double gap_last_s = 0, gap_back_s = 0;
    if (const ar::CaptureThread* rc = sh_.capture_right.load();
        rc != nullptr && mode == FR::kEyesRight && mode_ == FR::kEyesRight && right_only_) {
      const ar::CaptureThread::Silence sil = rc->last_silence();
      if (sil.first_after_s > right_gap_seen_s_ && sil.last_before_s >= left_last_s_) {
        right_gap = true;
        gap_last_s = sil.last_before_s;
        gap_back_s = sil.first_after_s;
        right_gap_seen_s_ = sil.first_after_s;
      }
    }
    if (mode != mode_ || right_gap) {
      const EyeSwitchTimes t{left_last_s_, left_back_s_, right_gap ? gap_last_s : right_silent_from_s_,
                             right_gap ? gap_back_s
                                       : right_first_back_s_ > 0 ? right_first_back_s_ : right_pair_s_};
      const int first = pending_switches_.size();
      eye_switches_between(mode_, mode, t, pending_switches_, right_gap);
      // Every right camera's return is a recovery (the summary's recoveries: its "right camera
      // back" switches). Pairs again (eyes both) are timed in count_fallback, with the
      // composite; a return to the right eye alone here.
      const int back = right_camera_returns(pending_switches_, first);
      fig_.stereo_recoveries += back;
      if (back > 0 && mode == FR::kEyesRight) {
        fig_.stereo_recovery_ms_max = std::max(fig_.stereo_recovery_ms_max, (ar::steady_now_s() - t.right_back_s) * 1e3);
        right_was_silent_ = false;
        right_back_s_ = 0;
      }
      for (int i = first; i < pending_switches_.size(); ++i) {  // the left camera's are said where found
        const EyeSwitchEvent& e = pending_switches_[i];
        if (e.kind == EyeSwitchKind::kRightLost && right_gap)
          say_eye(eye_switch_what(e.kind, c_.o.camera, c_.o.camera_right) + ": no frame for " +
                  std::to_string(std::lround((gap_back_s - gap_last_s) * 1e3)) +
                  " ms while the left camera (" + c_.o.camera + ") was lost: neither camera delivered");
        else if (e.kind == EyeSwitchKind::kRightLost)
          say_eye(eye_switch_what(e.kind, c_.o.camera, c_.o.camera_right) + ": no frame for " +
                  std::to_string(std::lround((ar::steady_now_s() - right_silent_from_s_) * 1e3)) +
                  " ms; tracking and drawing from the left eye (" + c_.o.camera + ") alone until it returns");
        else if (e.kind == EyeSwitchKind::kRightBack)
          say_eye(eye_switch_what(e.kind, c_.o.camera, c_.o.camera_right) +
                  (mode == FR::kEyesBoth ? std::string(": both eyes again")
                                         : ": the right eye alone while the left camera (" + c_.o.camera + ") is lost"));
      }
      mode_ = mode;
    }
    // The first frame captured after the right eye's last one, without a partner (the right
    // camera may be going silent): the window keeps its swap time, the switch's own if the
    // camera turns out lost (same last frame). An older frame (a queue on a busy machine) is not it.
    unpaired_from_s_ = 0;
    if (const ar::CaptureThread* rc = sh_.capture_right.load();
        rc != nullptr && mode_ == FR::kEyesBoth && eyes == FR::kEyesLeft && capture_steady_s > rc->last_frame_steady_s())
      unpaired_from_s_ = rc->last_frame_steady_s();
    if (!pending_switches_.empty() && eyes == mode_) {  // drawn in its mode: to the window with this frame
      frame_switches_.append(pending_switches_);
      pending_switches_.clear();
      pending_switches_.reset_dropped();
    }
  }

  // Two cameras: how long the single-view path took to take over when the right eye went
  // silent, and pairs to come back when it returned (from the right eye's last frame, and
  // from its first frame back, to the composite of the first frame on the new path); for the
  // slowest fallback, that frame's own capture-to-composite time and its wait for a partner.
  void count_fallback(int eyes, double capture_steady_s) {
    if (c_.o.camera_right.empty()) return;
    const double now = ar::steady_now_s();
    if (eyes == ar::FrameRecord::kEyesLeft && prev_eyes_ == ar::FrameRecord::kEyesBoth && right_last_s_ > 0) {
      const double ms = (now - right_last_s_) * 1e3;
      ++fig_.stereo_fallbacks;
      right_back_s_ = 0;  // a return counts from the eye's first frame after this
      if (ms > fig_.stereo_fallback_ms_max) {
        fig_.stereo_fallback_ms_max = ms;
        fig_.stereo_fallback_frame_ms = (now - capture_steady_s) * 1e3;
        fig_.stereo_fallback_wait_ms = pair_wait_ms_;
      }
    }
    // Only after the right camera was lost (silent, as the mode switch sees it): the left
    // camera's return or a slow loop (right frames taken > 0.1 s apart) is no right-eye return.
    if (eyes == ar::FrameRecord::kEyesBoth && prev_eyes_ == ar::FrameRecord::kEyesLeft && right_back_s_ > 0 &&
        right_was_silent_) {
      right_was_silent_ = false;  // counted with its "right camera back" switch (note_switch)
      fig_.stereo_recovery_ms_max = std::max(fig_.stereo_recovery_ms_max, (now - right_back_s_) * 1e3);
      right_back_s_ = 0;  // counted: a later unpaired frame and pair is no second return
    }
    prev_eyes_ = eyes;
  }

  // Two cameras: one capture timeline for the tracker and the recording (frames.csv time_s
  // never goes back). A right-eye frame alone (the left camera lost) continues it by the
  // steady clock; a left frame back after a silence (a reopened camera counts from its last
  // time) is moved on past it, and the left frames after it by as much.
  void one_timeline(ar::Frame& f) {
    const double dt = last_steady_s_ > 0 ? std::max(1e-4, f.steady_s - last_steady_s_) : 0;
    if (right_only_ && last_steady_s_ > 0) {
      f.time_s = last_time_s_ + dt;
    } else if (!right_only_) {
      f.time_s += left_shift_s_;
      if (last_steady_s_ > 0 && f.time_s <= last_time_s_) {
        left_shift_s_ += last_time_s_ + dt - f.time_s;
        f.time_s = last_time_s_ + dt;
      }
    }
    last_time_s_ = f.time_s;
    last_steady_s_ = f.steady_s;
  }

  // The stylus as it was when this frame was exposed, not as it is now (issue 24).
  // Returns the engine step of the pose drawn (-1: the newest).
  double pose_at_exposure(const ar::Frame& f, haptics::HapticSnapshot& snap) {
    if (c_.comp_latency_s <= 0) return -1;
    const auto h = c_.run.engine()->pose_history().sample(f.steady_s - c_.comp_latency_s);
    if (h.usable() && h.index >= 0) {
      Eigen::Map<Eigen::Matrix4d>(snap.T_dev_sty) = h.T_dev_sty.matrix();
      ++fig_.comp_at_exposure;
      return h.index;
    }
    ++fig_.comp_newest;
    return -1;
  }

  // One camera frame: the pipeline (track, register, mesh swap, composite,
  // occlusion), station health, the pen's pose, the hand-over to the window
  // and the recorder. The snapshot handed to the pipeline carries the engine's
  // training state too (HapticSnapshot::mode, T_tooth_expert_tip: a lesson's
  // expert tool, for its second handpiece).
  void process_frame(ar::Frame& f) {
    const LiveOptions& o = c_.o;
    if (o.passthrough) {  // no AR: the frame itself goes to the window (a header, not a copy)
      const std::int64_t processed = sh_.processed.load();
      fig_.process_ms.push_back(0.0);
      cres_.image = f.image;
      hand_over(f, -1, {}, processed, nullptr);
      sh_.processed.store(processed + 1);
      return;
    }
    if (!o.camera_right.empty()) one_timeline(f);
    session::Recorder* recorder = c_.run.recorder();
    const std::int64_t processed = sh_.processed.load();
    haptics::HapticSnapshot snap = c_.run.engine()->snapshot();
    const double pose_step = pose_at_exposure(f, snap);
    ar::FrameInput in;
    // The left camera lost: f is the right eye's frame, the single-view path from the right eye.
    static const cv::Mat kNoImage;
    in.image = right_only_ ? &kNoImage : &f.image;
    in.right_image = right_only_ ? &f.image : &right_image_;
    in.index = processed;
    in.capture_time_s = f.time_s;
    in.haptic = o.stylus == "none" ? nullptr : &snap;
    in.stylus_valid = o.stylus != "none" && !snap.fault;
    // A lesson's note on show at the expert's clock: drawn beside the tooth (note_label.h).
    if (session::LessonClock* l = c_.run.lesson(); l != nullptr && snap.mode != 0) {
      const auto& ann = l->lesson().annotations;
      if (const int a = training::active_note(ann, snap.expert_time_s); a >= 0)
        in.note = &ann[static_cast<std::size_t>(a)].text;
    }
    const auto t0 = Clock::now();
    const double cpu0 = thread_cpu_ms();
    // GPU path: a texture the window is not showing, free of its draws.
    // The right eye alone (its camera's own composite) is the CPU path's, as its pair composite.
    // The headset's view with a lesson's note on show: the CPU path too, so the left eye's
    // label is drawn into its composite (and pre-warped with it) as the right eye's is; the
    // GPU path's label is the mono window's (drawn by the window, not through the lens).
    const bool note_on = in.note != nullptr && !in.note->empty();
    const bool gl = use_gl_ && !right_only_ && !(note_on && o.output == "sbs");
    const int slot = gl ? sh_.ring->acquire() : -1;
    if (gl) in.gl_target = sh_.ring->target(slot);
    // The CPU path's composites go to the window's upload, which converts the camera's
    // YUYV itself: the frame path converts only the overlay's region (session 20).
    in.keep_yuyv = !gl && keep_yuyv_;
    std::string err;
    try {
      if (auto s = c_.run.pipeline().process(in, c_.run.meshes(), cres_, rec_, want_right_ ? &cres_right_ : nullptr); !s)
        err = s.error();
    } catch (const std::exception& e) {
      err = std::string("pipeline threw: ") + e.what();
    }
    fig_.process_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    if (err.empty()) {  // where the frame's time went (the summary's stages_ms)
      fig_.stage_ms["process_cpu"].add(thread_cpu_ms() - cpu0);  // the frame thread's own CPU
      fig_.stage_ms["mesh_sync"].add(rec_.mesh_ms);
      fig_.stage_ms["track"].add(rec_.track_ms);
      fig_.stage_ms["compose_left"].add(rec_.composite_ms);
      if (rec_.right.composited) fig_.stage_ms["compose_right"].add(rec_.right.composite_ms);
    }
    if (err.empty() && rec_.eyes == ar::FrameRecord::kEyesBoth) ++fig_.stereo_both;
    if (err.empty() && rec_.eyes == ar::FrameRecord::kEyesLeft) ++fig_.stereo_left_only;
    if (err.empty() && rec_.eyes == ar::FrameRecord::kEyesRight) ++fig_.stereo_right_only;
    if (err.empty()) note_switch(rec_.eyes, f.steady_s);
    if (err.empty() && want_right_) {  // the headset's pair: a lesson's note label in each eye that anchored it
      fig_.note_both_eyes += rec_.note_drawn && rec_.right.note_drawn ? 1 : 0;
      fig_.note_missing_eye +=
          (rec_.note_anchored && !rec_.note_drawn) || (rec_.right.note_anchored && !rec_.right.note_drawn) ? 1 : 0;
    }
    if (err.empty() && rec_.right.composited) ++fig_.right_composited;
    if (err.empty()) count_fallback(rec_.eyes, f.steady_s);
    rec_.pose_step = pose_step;
    for (const auto& it : c_.health.on_frame(c_.run.pipeline().last_detections(), f.steady_s, rec_.T_dev_sty,
                                             in.stylus_valid)) {
      c_.say("station health: " + it.check + ": " + health_level_name(it.level) + ": " + it.message);
      if (recorder) recorder->log("station health: " + it.check + ": " + health_level_name(it.level) + ": " + it.message);
    }
    if (c_.pen != nullptr) {
      const bool ok = rec_.man_state != 2 && rec_.pen_state != 2;
      const Eigen::Isometry3d T_dev_sty = (rec_.T_cam_man * c_.st.calibration.T_man_dev).inverse() * rec_.T_cam_ptag *
                                          c_.st.pen.T_ptag_tip * c_.st.calibration.T_sty_tip.inverse();
      c_.pen->publish(T_dev_sty, ok, f.steady_s);
    }
    hand_over(f, slot, err, processed, in.note);
    if (recorder && err.empty())
      recorder->push(f.image, f.encoded, rec_, processed, f.index, f.steady_s, right_image_, right_encoded_);
    if (err.empty()) {
      fig_.gpu_frames += rec_.gpu_composite ? 1 : 0;
      fig_.note_frames += rec_.note_anchored ? 1 : 0;
      // The right eye's own composite (a stereo pair for the headset) is always the CPU path's.
      fig_.readback_px += rec_.readback_px + rec_.right.readback_px;
      fig_.cpu_blend_px += rec_.cpu_blend_px + rec_.right.cpu_blend_px;
    }
    sh_.processed.store(processed + 1);
  }

  // One eye's CPU composite to the shown slot: the image and the overlay patch change hands
  // (swapped, never copied), the patch's rectangle is copied.
  static void hand_over_composite(ar::CompositeResult& from, cv::Mat& image, cv::Mat& patch, cv::Rect& rect) {
    cv::swap(from.image, image);
    cv::swap(from.patch, patch);
    rect = from.patch_rect;
  }

  // The frame to the window (LiveShared::shown).
  void hand_over(ar::Frame& f, int slot, const std::string& err, std::int64_t processed, const std::string* note) {
    {
      std::lock_guard<std::mutex> lock(sh_.shown_m);
      Shown& shown = sh_.shown;
      shown.raw = f.image;
      shown.gpu = slot >= 0 && err.empty();
      // The right eye (a stereo pair for the headset): its composite, or none (mono).
      shown.raw_right = want_right_ ? right_image_ : cv::Mat();
      if (err.empty() && want_right_ && rec_.right.composited) {
        hand_over_composite(cres_right_, shown.composite_right, shown.patch_right, shown.patch_rect_right);
      } else {
        shown.composite_right.release();
        shown.patch_right.release();
      }
      // Buffers change hands, never copied (2.7 MB a 720p frame): the
      // compositor's, the shown slot and the display's each own one.
      // GPU path: the texture is published (fence) under the same lock as
      // the record, so the window takes the two together.
      if (shown.gpu) {
        sh_.ring->publish(slot, processed, cres_.region.x, cres_.region.y, cres_.region.width, cres_.region.height);
        shown.composite.release();
        shown.patch.release();
      } else if (err.empty()) {
        hand_over_composite(cres_, shown.composite, shown.patch, shown.patch_rect);
      } else {
        // Released first: the buffer may be a camera frame another holder still reads (keep_yuyv).
        shown.composite.release();
        shown.patch.release();
        f.image.copyTo(shown.composite);
      }
      shown.index = processed;
      shown.steady_s = f.steady_s;
      shown.handed_s = ar::steady_now_s();
      shown.rec = rec_;
      shown.error = err;
      // Cameras lost or back (note_switch): timed to the swap of the first frame the window
      // draws in the new mode. Queued: switches on a frame replaced before the window took it
      // stay for the frame replacing it, beside its own (the window empties the queue).
      const bool untaken = sh_.shown_new;
      if (err.empty() && (!frame_switches_.empty() || frame_switches_.dropped() > 0)) {
        shown.switches.append(frame_switches_);
        frame_switches_.clear();
        frame_switches_.reset_dropped();
      }
      if (err.empty() && unpaired_from_s_ > 0) shown.unpaired_from_s = unpaired_from_s_;
      else if (!untaken) shown.unpaired_from_s = 0;
      if (note != nullptr) shown.note = *note;
      else shown.note.clear();
      sh_.shown_new = true;
    }
    sh_.shown_cv.notify_one();
  }

  const LiveContext& c_;
  LiveShared& sh_;
  FrameFigures& fig_;
  Result<ar::EglContext> egl_ = Error{"not made"};
  bool use_gl_ = false;
  // Session 20: the CPU composites stay YUYV outside the overlay (FrameInput::keep_yuyv);
  // --cpu-display-yuyv convert converts the whole frame as before (the A/B arm of the bench).
  const bool keep_yuyv_ = c_.o.cpu_display_yuyv != "convert";
  ar::CompositeResult cres_, cres_right_;  // cres_right_: the right eye's (want_right_)
  ar::FrameRecord rec_;
  bool want_right_ = false;  // stereo pipeline and the headset's output: composite the right eye too
  cv::Mat right_image_;       // stereo: this frame's right eye (empty: none, the single-view path)
  cv::Mat right_encoded_;     // two cameras: its camera's JPEG bytes (empty: none)
  ar::Frame right_pending_;   // two cameras: the right eye's newest frame not yet used
  double right_last_s_ = 0, right_back_s_ = 0;  // the right eye's newest frame, its first after a silence (steady s)
  double right_silence_seen_s_ = 0;             // the newest silence's end already noted (CaptureThread::last_silence)
  int prev_eyes_ = 0;                           // the eyes of the frame before
  double pair_wait_ms_ = 0;                     // this frame's wait for the right eye's partner
  // Two cameras, the left one lost (issue 28, session 17): the right eye's frames alone.
  bool left_lost_ = false, right_only_ = false;   // right_only_: this frame is the right eye's alone
  double left_last_s_ = 0, left_back_s_ = 0;      // the left camera's last frame, its first back (steady s)
  double right_pair_s_ = 0;                       // the right frame of the newest pair (steady s)
  double last_time_s_ = 0, last_steady_s_ = 0, left_shift_s_ = 0;  // one_timeline
  double unpaired_from_s_ = 0;  // this frame lacks the right eye's partner: the right camera's last frame (steady s)
  bool right_silent_ = false;                     // pair_right: the right camera silent (lost)
  bool right_was_silent_ = false;                 // ... since the last recovery counted
  double right_silent_from_s_ = 0, right_first_back_s_ = 0;  // its last frame; its first after a silence
  double right_gap_seen_s_ = 0;  // the right camera's last silence while the left was lost, seen (its end)
  int mode_ = ar::FrameRecord::kEyesBoth;         // note_switch: the cameras delivering (kEyes*)
  EyeSwitchQueue pending_switches_;  // switches not yet drawn in their mode
  EyeSwitchQueue frame_switches_;    // this frame's, for the window (hand_over)
};

}  // namespace

void frame_thread_main(const LiveContext& c, LiveShared& sh, FrameFigures& fig) {
  pthread_setname_np(pthread_self(), "dentar-frame");  // the summary's CPU per thread (session 19)
  pin_this_thread(c.layout.of(CpuLayout::kFrame));      // --cpu-layout frame= (session 23; none: inherited)
  FrameThread t(c, sh, fig);
  if (!t.open()) {
    t.close();
    return;
  }
  t.loop();
}

}  // namespace dentar::live
