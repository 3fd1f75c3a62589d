// The parts of `dentar live` behind run_live (private to live/): what the
// set-up hands the threads, the state the frame thread and the display loop
// share, the per-frame work (frame thread) and the display loop (main thread).
//
//   run_live (live_app.cpp): set-up, threads started, display_loop, shutdown, summary
//   frame_thread_main (live_frame.cpp): GL context, session::Run's pipeline, one
//     process_frame per camera frame, handing each composite to the window (LiveShared)
//   display_loop (live_display.cpp): window, HUD, stop conditions
#pragma once

#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "dentar/ar/capture_thread.h"
#include "dentar/ar/frame_pipeline.h"
#include "dentar/ar/gl_handoff.h"
#include "dentar/ar/station_scene.h"
#include "dentar/haptics/device.h"
#include "dentar/haptics/pedal.h"
#include "dentar/live/cpu_layout.h"
#include "dentar/live/eye_switches.h"
#include "dentar/live/hud_window.h"
#include "dentar/live/live_app.h"
#include "dentar/live/pen_device.h"
#include "dentar/live/station_health.h"
#include "dentar/session/run.h"

namespace dentar::live {

// Set before the threads start, read-only while they run (what it refers to
// outlives them). The engine, the tooth and the recorder are the run's.
struct LiveContext {
  const LiveOptions& o;
  const ar::StationScene& st;
  const ar::PipelineOptions& popt;
  session::Run& run;
  StationHealthMonitor& health;
  HudWindow& hw;
  haptics::HapticDevice& device;  // the engine's (stylus with its pedal)
  const haptics::Pedal& pedal;
  haptics::ManualPedal& key_pedal;  // the space bar
  PenDevice* pen = nullptr;
  bool pedal_from_device = false;
  int W = 0, H = 0;     // the camera's frame size
  bool want_gl = false;  // the GPU display path asked for
  // Threads made with it run on the engine's CPU below the engine (empty: with the frame thread).
  std::function<void()> to_engine_cpu;
  double comp_latency_s = 0;  // latency compensation (issue 24); 0 = the newest pose
  std::function<void(const std::string&)> say;
  session::LessonPauseDevice* lesson_pauses = nullptr;  // a lesson: its pause points (the engine's device)
  const CpuLayout& layout;  // --cpu-layout (session 23): the frame thread and mesher pin themselves by it
};

// What the frame thread hands the window: the newest composite and its raw
// frame (shown without overlay when the camera stalls).
struct Shown {
  cv::Mat composite, raw;  // composite empty when the GPU path drew it (gpu)
  // A stereo pair for the headset (issue 28): the right eye's composite (always the CPU
  // path's) and its raw frame; empty: mono (both eyes shown the one composite).
  cv::Mat composite_right, raw_right;
  // Issue 28 session 20: a keep_yuyv composite (ar::CompositeResult::patch): the composite
  // above is the camera's YUYV frame and these the BGR overlay inside their rectangles
  // (empty: none); the window converts both in its upload.
  cv::Mat patch, patch_right;
  cv::Rect patch_rect, patch_rect_right;
  bool gpu = false;
  std::int64_t index = -1;  // recording index (frames processed)
  double steady_s = 0;      // capture time
  double handed_s = 0;      // when the frame thread handed it over (steady s)
  ar::FrameRecord rec;
  std::string error;
  std::string note;  // a lesson's note given with the frame (rec.note_anchored: the GPU path draws it)
  // Two cameras (issue 28): the cameras lost or back since the window last took a frame
  // (eye_switches.h; session 22: a queue, where one slot lost a switch on a frame the window
  // never took): what happened, the eyes of the mode switched to and the capture time the switch
  // is timed from (the lost camera's last frame, or the returning camera's first frame back;
  // steady s). The window times each to the swap of the frame it takes them with, empties the
  // queue and adds its dropped() count to the summary.
  EyeSwitchQueue switches;
  // A frame from the left eye alone while both cameras were delivering (the right one may be
  // going silent): the right camera's last frame (steady s), else 0. When that camera is found
  // lost (no frame for 0.1 s) the switch is timed to the first such frame's swap.
  double unpaired_from_s = 0;
};

// The frame thread and the display loop: the hand-over of each frame, the stop
// flag, and how the pipeline came up.
struct LiveShared {
  std::mutex shown_m;
  std::condition_variable shown_cv;
  Shown shown;            // under shown_m
  bool shown_new = false;  // under shown_m
  std::atomic<bool> stop{false};
  std::atomic<int> pipeline_ready{0};  // 1 ok, -1 failed (pipeline_error says why)
  std::string pipeline_error;
  // The display path settled on the frame thread (written before pipeline_ready).
  std::atomic<bool> gl_path{false};
  std::string display_note;
  std::unique_ptr<ar::SharedFrameRing> ring;  // GPU path; made and destroyed on the frame thread
  std::atomic<ar::CaptureThread*> capture{nullptr};  // set once the pipeline is ready
  // Stereo with two cameras (issue 28): the right eye's, set with `capture` (null otherwise).
  std::atomic<ar::CaptureThread*> capture_right{nullptr};
  std::atomic<std::int64_t> processed{0};
};

// One stage's times over a run, ms (the summary's stages_ms): a histogram of fixed size made
// up front (0.1 ms bins to 2 s, one bin above), so a long run's figures never grow memory.
struct StageTimes {
  static constexpr double kBinMs = 0.1;
  static constexpr int kBins = 20000;
  std::vector<std::uint32_t> bins = std::vector<std::uint32_t>(kBins + 1, 0);
  std::uint64_t n = 0;
  double max_ms = 0;
  void add(double ms) {
    const double b = ms / kBinMs;
    ++bins[b >= kBins ? kBins : b > 0 ? static_cast<std::size_t>(b) : 0];
    ++n;
    if (ms > max_ms) max_ms = ms;
  }
  // The q-quantile (0..1): the middle of its bin, or the largest time when it lies above 2 s.
  double percentile(double q) const {
    if (n == 0) return 0;
    const auto want = static_cast<std::uint64_t>(std::ceil(q * static_cast<double>(n - 1))) + 1;
    std::uint64_t seen = 0;
    for (int i = 0; i < kBins; ++i)
      if ((seen += bins[static_cast<std::size_t>(i)]) >= want) return std::min(max_ms, (i + 0.5) * kBinMs);
    return max_ms;
  }
};

// The frame thread's figures, read after it joined.
struct FrameFigures {
  std::vector<double> process_ms;
  std::int64_t gpu_frames = 0, readback_px = 0, cpu_blend_px = 0;
  std::int64_t note_frames = 0;  // a lesson's note beside the tooth (drawn, or anchored for the GPU path's window)
  std::int64_t ring_replaced = 0, ring_ready_timeouts = 0, ring_release_timeouts = 0;
  std::int64_t comp_at_exposure = 0, comp_newest = 0;
  std::int64_t stereo_both = 0, stereo_left_only = 0;  // stereo: frames by the eyes they had
  std::int64_t stereo_right_only = 0;                   // two cameras, the left one lost
  // The headset's pair (--output sbs): frames with a lesson's note label drawn into both eyes'
  // composites, and frames where an eye placed the note beside its tooth but did not draw it.
  std::int64_t note_both_eyes = 0, note_missing_eye = 0;
  std::int64_t right_composited = 0;  // stereo into the headset: frames with the right eye's own composite
  std::int64_t stale_pairs_skipped = 0;  // two cameras: pairs skipped for a newer one (freshest_pair.h)
  std::int64_t stale_pairs_untaken = 0;  // session 21: of those, pairings that stopped before taking a right frame (peek)
  // The pipeline's eye threads in use (0: no pipeline made) and why fewer than asked ("" none).
  int eye_threads = 0;
  std::string eye_thread_note;
  // Per-frame stage times, ms (the summary's stages_ms): pickup (capture to the frame thread),
  // pair_wait, mesh_sync, track, compose_left, compose_right (wall; concurrent with the left
  // eye's on the right eye's thread), process_cpu (the frame thread's own CPU per frame).
  std::map<std::string, StageTimes> stage_ms;

  // Two cameras: the right eye lost and back (LiveSummary::stereo_fallbacks ...), ms; -1 none.
  std::int64_t stereo_fallbacks = 0, stereo_recoveries = 0;
  double stereo_fallback_ms_max = -1, stereo_fallback_frame_ms = -1, stereo_fallback_wait_ms = -1;
  double stereo_recovery_ms_max = -1;
};

// The frame thread: until LiveShared::stop or the footage ends.
void frame_thread_main(const LiveContext& c, LiveShared& sh, FrameFigures& fig);

// The display loop's inputs beside the context.
struct DisplayInputs {
  ar::CaptureThread& capture;
  std::string sound_line;  // hud_sound_line
  std::string grant;       // what the system granted the engine (shown when not real time)
  bool rt_ok = true;
  double hand_end_s = 0;  // the simulated hand's script length (0 = none)
  double lesson_end_s = 0;  // a lesson: the expert recording's length, s (0 = none)
  double rate_hz = 1000;
  const std::atomic<int>* signal = nullptr;  // SIGINT / SIGTERM seen
};

// The display loop's figures, for the summary.
struct DisplayFigures {
  std::string stop_reason;
  double t_start = 0;
  std::vector<double> latency_ms;
  // Per frame shown: hand-over to the display loop's take (wait), take to swap (display), ms.
  StageTimes to_display_ms, display_ms;
  // DENTAR_DISPLAY_PROFILE=1 (hud_window.h DisplayProfile): the display stage's parts per frame
  // shown, "disp_<part>" wall and "disp_<part>_cpu" the display thread's CPU, ms.
  std::map<std::string, StageTimes> display_parts_ms;
  std::int64_t displayed = 0;
  // Wakes of the loop without a new frame: redrawn (the stall state, a key, the HUD's idle
  // refresh) and not redrawn (redraw_policy.h).
  std::int64_t idle_draws = 0, idle_skipped = 0;
  // A lesson: the student's tip against the expert's at each pass of the loop (>= 30 Hz,
  // whatever the camera's rate) after the expert's first 0.5 s, m; passes while the expert
  // waited for the student.
  std::vector<double> follow_m;
  std::int64_t passes = 0, passes_expert_waiting = 0;
  // A lesson's text annotations shown on the HUD (with the HUD on), in the order the expert's
  // clock reached them: the annotation, the expert's clock and the run's time (s) when shown,
  // and the expert's clock at the pass before (-1: none), when the note was not yet due.
  struct Note {
    int annotation = -1;
    double expert_s = 0, expert_s_before = -1, run_s = 0;
  };
  std::vector<Note> notes;
};

// Runs the window until a stop condition; the summary gets the stall and memory figures.
DisplayFigures display_loop(const LiveContext& c, LiveShared& sh, const DisplayInputs& in, LiveSummary& sum);

double percentile(std::vector<double> v, double q);
double rss_mb();

// The process's CPU time (getrusage: every thread, ended ones too) and each live thread's
// (/proc/self/task: tid, name, user + system), ms. Session 19: the summary's CPU per frame.
struct CpuSnapshot {
  struct Thread {
    long tid = 0;
    std::string name;
    double ms = 0;
  };
  double process_ms = 0;
  std::vector<Thread> threads;
};
CpuSnapshot cpu_snapshot();
// CPU between two snapshots summed per thread name (a thread born after `a` counts from 0;
// one ended before `b` is left out: only the process figure holds it), ms.
std::map<std::string, double> cpu_per_name_ms(const CpuSnapshot& a, const CpuSnapshot& b);

}  // namespace dentar::live
