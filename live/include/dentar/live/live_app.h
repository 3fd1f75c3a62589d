// `dentar live`: the student's trainer. A camera (or footage paced as one),
// the shared FramePipeline, the 1 kHz haptic engine on its own core, and a
// window with a HUD, all running at once:
//
//   capture thread ──latest frame wins──▶ frame thread: FramePipeline (track, register,
//     (CaptureThread)                       mesh swap, composite, occlusion)
//                                              │ composite + record
//   mesher thread (ToothMeshes) ──meshes──▶    ├──▶ main thread: window, HUD, vsync swap
//   engine thread (1 kHz, pinned, FIFO) ──▶    └──▶ recorder thread: frames, CSV, logs
//     snapshot (seqlock) ──▶ frame thread, HUD
//   session-log thread (SessionLogWriter) ◀── engine
//
// Faults: a camera that stops delivering hides the overlay within 200 ms
// (the HUD says why) and is reopened when it returns; SIGINT, SIGTERM or a
// window close stop the engine first (zero force), then flush the logs and
// finalise the recording; a stage that throws shows on the HUD while the
// window keeps drawing. The engine keeps its own watchdog.
//
// Recording (--record DIR, docs/formats.md "Live recording"): recording.json,
// station.json, session.dlog, frames/frame_NNNNNN.png (lossless, the frames
// the pipeline processed), frames.csv (one row per frame, written after its
// image: a truncated recording still replays) and live.log. `dentar offline
// --footage DIR` replays it: same poses, same final cut (volume hash).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <map>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "dentar/ar/frame_pipeline.h"
#include "dentar/live/headset.h"
#include "dentar/volume/result.h"

namespace dentar::live {

struct LiveOptions {
  std::string camera = "camera:0";  // FrameSource spec (camera:N, /dev/videoN, live:PATH)
  int width = 0, height = 0;        // camera mode request (0 = driver default)
  double fps = 0;
  // The camera's format (issue 28): "auto" (the driver's; YUYV is carried as the camera sent
  // it, converted only where used), "yuyv" / "mjpg" (asked of the camera; refused, naming what
  // it gives, when it cannot), "bgr" (the whole-frame BGR path: the backend converts every frame).
  std::string camera_format = "auto";
  // Motion JPEG cameras (session 20): "every-frame" (every captured frame decoded on its
  // capture thread, as sessions 18-19) or "on-demand" (a frame is decoded only when the frame
  // thread takes it; frames replaced unseen are never decoded, capture_thread.h). On-demand saves
  // CPU on a loaded machine but, quiet, puts the decode on the frame path: mono 1080p capture to
  // swap p50 73-89 -> 102-105 ms, consumer drops 1-4 -> 81-83 (docs/BENCHMARKS.md, session 20 lead).
  // Session 21: "eager": the newest packet decoded on the capture side as soon as nothing decoded
  // waits (never one superseded before its decode started); the frame thread never decodes
  // (CaptureThreadOptions::eager_decode, capture_thread.h). The default since session 21: the
  // frame thread's CPU per frame shown as with every-frame, decodes per frame shown as on demand
  // (docs/BENCHMARKS.md, "Issue 28 session 21 — eager decode and peek pairing"; under load).
  std::string jpeg_decode = "eager";
  // The CPU display path's composites of a YUYV camera (session 20, an option since session 21):
  // "keep" (default: the frame stays YUYV outside the overlay, only the overlay's patch is BGR;
  // ar::FrameInput::keep_yuyv) or "convert" (the whole frame converted to BGR, as before session
  // 20: the bench's A/B arm). Was the environment variable DENTAR_KEEP_YUYV=0|1.
  std::string cpu_display_yuyv = "keep";
  // The bur's sample count (--bur-samples, session 22): 0 = the default (10000, or a lesson's
  // own count); else 1..100000 (volume::kMaxBurSamples). With the overlap cutter the count
  // changes only the seed force model and the header, not the cut. A replayed log keeps its own.
  int bur_samples = 0;
  // Stereo (issue 28): the station's rig ("stereo") tracks from both eyes (StereoTracker), the
  // window shows the left eye. camera_right: the right eye's camera (two cameras; `camera` is
  // the left), one size and rate as the left; side_by_side: `camera` delivers both eyes in one
  // frame (left | right). Either camera silent for 0.1 s leaves the other eye alone (the
  // single-view path, its own composite shown to both eyes of a headset) until it delivers
  // again (session 17: also the left one; both silent is the camera stall of one camera).
  std::string camera_right;
  bool side_by_side = false;
  std::int64_t stall_right_after_frames = 0;  // test hook: the right eye delivers nothing for
  double stall_right_s = 0;                   // stall_right_s after this many frames
  std::string station;       // station file, or a built-in station ("default", "box"); empty = "default"
  bool scale_calib = false;  // accept a camera of another size (intrinsics scaled)
  // Stylus: "sim" (the simulated hand drilling the access script), "pen"
  // (the printed pen tag), "replay:FILE.dlog" (a session log in real time),
  // "none" (no bur).
  std::string stylus = "sim";
  // Latency compensation (issue 24): each frame is drawn with the stylus pose of its exposure,
  // sampled from the engine's 1 kHz pose history at Frame::steady_s minus the camera's latency
  // (mid-exposure to grab), ms. < 0: the station's camera.latency_ms, or
  // ar::kAssumedCameraLatency_ms (33) when the station has none measured; 0: no compensation
  // (the newest pose, as before). Not applied to --stylus pen: its pose comes from the camera
  // image itself.
  double camera_latency_ms = -1;
  // A real haptic device instead of the stylus stand-ins: a kind of
  // haptics::open_haptic_device ("touch", "omega", "hd", "dhd", ...); empty =
  // use `stylus`. device_name: its configuration name or serial ("" = first).
  std::string device, device_name;
  // Foot pedal: "keyboard" (the space bar), or a spec of haptics::open_pedal
  // ("auto", "vec", "usb:VID:PID", "evdev:/dev/input/eventN").
  std::string pedal = "keyboard";
  std::string model = "proxy";  // force model
  int display = -1;             // monitor for fullscreen (HMD input); -1 = a desktop window
  // Issue 28: the output (eye_output.h, docs/headset.md). "mono": the window as before;
  // "sbs": a headset's side-by-side view through `headset` (read and validated by the
  // caller; --headset FILE). loupe: the digital loupe's magnification (0 = off; 1.5..8,
  // dentists' loupes are 2.5-4), loupe_view "inset" (picture in picture) or "full".
  std::string output = "mono";
  std::shared_ptr<const HeadsetProfile> headset;
  double loupe = 0;
  std::string loupe_view = "inset";
  // Issue 28 session 18: the headset's pre-warp pass (eye_output.h WarpPass): "exact"
  // (default: the exact mapping on the grid cells where the camera is seen), "mesh" (the
  // grid's per-vertex warp), "full" (sessions 15-17: the exact mapping over every pixel),
  // "lut" (a lookup texture); warp_cell_px: the grid's cell size, panel px (4..128).
  std::string warp_pass = "exact";
  int warp_cell_px = 16;
  // Issue 28 session 22: the headset view's camera textures (CPU display path): "full" (the
  // camera's size), "half" (each eye's frame box-averaged 2x2 before the upload: a quarter of
  // the bytes converted, copied and sampled), "auto" (half when the loupe is off and a
  // half-size texel still covers no more than one window pixel at the lens centre, the
  // panel's densest point; full otherwise).
  std::string display_texture = "auto";
  // Session 19 (redraw_policy.h): the window's redraw without a new frame (the HUD's refresh
  // while no frame comes), ms, 0..1000; 0 redraws at every wake of the loop (~30 ms), as
  // sessions 13-18 did.
  double idle_redraw_ms = 100;
  int window_width = 0, window_height = 0;  // windowed size (0 = the camera's)
  bool hud = true;
  bool vsync = true;
  // How the composite reaches the window. "gl": it stays on the GPU (the
  // compositor draws into a texture shared with the window's context:
  // compositor.h compose_gl, gl_handoff.h; no readback, no CPU blend), or
  // falls back to "cpu" when shared contexts are unavailable (logged, and in
  // the summary's display.note). "cpu": the CPU composite (compose) uploaded
  // into the window each frame, as `dentar offline` makes it.
  // "auto" (default): "gl" on a hardware renderer, "cpu" on a software one
  // (llvmpipe, softpipe, SwiftShader: there the GL path measured slower and
  // cost the engine deadlines, docs/BENCHMARKS.md); the renderer is read
  // from a throw-away EGL context before the window opens.
  std::string display_path = "auto";
  std::string record_dir;  // empty = no recording
  // A bare passthrough viewer (issue 28, the latency benchmarks' rival): each camera frame is
  // decoded, uploaded and swapped as it came, with no tracking, compositing, occlusion or HUD
  // overlay work on the frame (the frame pipeline is never called; the engine still runs, on
  // its core, as in an AR run). The CPU display path is used; nothing is recorded. The
  // summary's latency is then what the camera, the decode, the upload and the swap cost alone.
  bool passthrough = false;
  // Issue 28 (session 17): a stereo pair into the headset (--output sbs): 2 = the right eye's
  // tag tracking and composite on a thread of its own beside the left eye's
  // (ar::PipelineOptions::eye_threads; same pixels), 1 = both eyes on the frame thread.
  // eye_thread_cpu: where that thread (and its GL rasteriser) may run: "any" CPU (the engine's
  // too, below its SCHED_FIFO: the engine preempts it), or "engine" (only beside the engine,
  // as the capture threads), or "frame" (the frame thread's CPUs, off the engine's).
  int eye_threads = 2;
  std::string eye_thread_cpu = "any";
  // Issue 28 session 22: where the right camera's capture thread (and, eager, its decode) may
  // run with two cameras: "engine" (default: beside the engine, as the left camera's, so the two
  // eyes' decodes share one core), "frame" (the frame thread's CPUs: the two decodes on
  // different cores) or "any" (every CPU; on the engine's below its SCHED_FIFO).
  std::string capture_right_cpu = "engine";
  // Issue 28 session 23 (--cpu-layout, cpu_layout.h): each thread's CPUs given by hand,
  // "ROLE=CPUS,..." (roles engine, frame, eye, capture, capture-l, capture-r, display, raster,
  // mesher); a role named replaces its default and the options above for it; "" = the defaults.
  std::string cpu_layout;
  // Issue 28 session 23: the half-size camera textures (--display-texture) of a YUYV frame:
  // "direct" (default: converted at half size from the YUYV, hud_window.h upload_pixels_half) or
  // "box" (converted at full size, then the 2x2 mean: session 22's; the A/B arm).
  std::string display_half_convert = "direct";
  // Where the window's GL rasteriser (llvmpipe: one thread per display, made when the window
  // opens; it draws the headset's pre-warp pass) may run: "frame" (the frame thread's CPUs, off
  // the engine's; the default), "any" (the engine's CPU too, below its SCHED_FIFO), "auto" (any
  // with --output sbs, frame otherwise). The pre-warp pass measured 12 ms CPU a frame on
  // llvmpipe beside the frame thread's 8; "any" is not the default: under load it went with
  // more missed engine deadlines (docs/BENCHMARKS.md, issue 28 session 17).
  std::string window_raster_cpu = "frame";
  // Exercise the session is for (a built-in name or a .json file; recorded in recording.json,
  // scored by the driver). Its tooth is the tooth drilled (live_tooth_json); "" = the station's
  // procedural molar.
  std::string exercise;
  // The simulated hand (--stylus sim with an exercise) as a person: skill in [0, 1] (1 = the
  // expert), personal style strength in [0, 3] (0 = none), and the person's seed
  // (training/hand_script.h, hand_tip_script). The defaults are the expert script of seed 1.
  // The run stops by itself once the engine has stepped through the hand's whole script
  // (stop_reason "the simulated hand finished the exercise"), or earlier at `seconds`.
  // A lesson (issue 27; training/lesson.h: a folder, or builtin:EXERCISE) trained in
  // lesson_mode 1..5: the expert's tool replayed in the engine with the mode's forces
  // (session::LessonClock), recorded in the session log's training section. The lesson names
  // the exercise and the tooth (--exercise is refused beside it). --stylus sim: a simulated
  // student (training::SimStudentDevice on the "touch" profile) follows the expert; pen: no
  // force, modes 2 and 4 fall back to 3; a --device renders the mode's force. The run stops
  // by itself when the expert's recording ends.
  std::string lesson;
  int lesson_mode = 0;
  double hand_skill = 1.0;
  double hand_style = 0.0;
  std::uint64_t hand_seed = 1;
  double seconds = 0;      // stop after this long (0 = until closed)
  // Stop once this many new frames have been shown (0 = no limit). A run
  // sized in frames does the same work on a fast or a slow machine (tests,
  // benchmarks); `seconds` still bounds it when both are given.
  std::int64_t frames = 0;
  bool loop = false;       // live:PATH footage: play it again at its end (long runs, benchmarks)
  int engine_cpu = -2;     // -2 = the last CPU; -1 = no pinning
  bool realtime = true;    // SCHED_FIFO + mlockall
  // Wake-up latency the CPUs may take from idle while the run lasts, us (Linux PM QoS,
  // /dev/cpu_dma_latency, held open for the run; needs root or write access to it). 0: idle
  // CPUs poll instead of halting, so the engine's timer finds its CPU awake. An idle core that
  // halts (a deep C-state on bare metal, a halted vCPU in a VM) can take long to wake; with the
  // engine nearly alone on its core, that is the likely cause of the GL display path's missed
  // deadlines (docs/BENCHMARKS.md, "Issue 28 session 16"). -1 (default): the system's setting;
  // the hold is not the default until a quiet-machine run shows it helps (under load it raised
  // the engine's p99 wake-up lateness). Costs power: the cores never sleep while it is held.
  int cpu_wake_latency_us = -1;
  // A monitor thread (normal priority, off the engine's CPU) that names the cause of each late
  // wake-up of the engine from the scheduler's counters (haptics/wake_monitor.h); results in
  // the summary's engine.wake. Off: --no-wake-monitor.
  bool wake_monitor = true;
  // Where the background threads run (the tracker's full-frame tag search
  // when pipeline.tracker.discovery = kAsync, the default here; the capture
  // thread with its decoding; the mesher): "engine" (on the engine's CPU at
  // normal priority: they get only the time the FIFO engine leaves, and it
  // preempts them at once) or "others" (with the frame thread and the
  // display, off the engine's CPU). "engine" falls back to "others" when
  // SCHED_FIFO is not granted (or --no-realtime): the engine could not
  // preempt them, and would share its core with them.
  std::string background_cpu = "engine";
  ar::PipelineOptions pipeline;
  // Test hooks.
  std::vector<std::pair<std::int64_t, std::string>> screenshots;  // (frame, PNG path) of the window
  std::vector<std::pair<std::int64_t, int>> inject_keys;  // (frame, GLFW key): pressed when a frame >= it shows
  std::int64_t stall_after_frames = 0;  // the camera delivers nothing for stall_s after this many frames
  double stall_s = 0;
  std::string summary_path;  // also write the summary JSON here
  bool window_glx_for_test = false;  // make the window's context with GLX (cannot share): the fallback
  bool quiet = false;
  // The drill's sound (issue 29; tools/ supplies it, live/ does not depend on sound/): called
  // once the engine runs, with a lock-free snapshot reader; what it returns (the player) is
  // kept until the run ends. Empty: no sound.
  std::function<std::shared_ptr<void>(std::function<haptics::HapticSnapshot()>)> start_sound;
  // For the HUD's sound line: --mute was given (then start_sound is empty), and what to show
  // beside "on" (the volume, the teacher's limit).
  bool sound_muted = false;
  std::string sound_detail;
  std::string validate() const;
};

struct LiveSummary {
  std::int64_t frames_captured = 0, frames_processed = 0, frames_displayed = 0;
  // Stereo (issue 28): frames processed from both eyes, and from the left eye alone (the
  // right one lost); the summary JSON's "stereo" (absent for one camera).
  bool stereo = false;
  std::int64_t stereo_both = 0, stereo_left_only = 0, right_eye_dropped = 0, right_eye_reopens = 0;
  std::int64_t right_composited = 0;  // frames whose right eye got its own composite (--output sbs)
  std::int64_t stereo_right_only = 0;  // two cameras, the left one lost: frames from the right eye alone
  // --output sbs with a stereo rig: frames whose lesson note label went into both eyes'
  // composites, and frames where an eye anchored the note beside its tooth without drawing it.
  std::int64_t note_both_eyes = 0, note_missing_eye = 0;
  // Two cameras: each change of the eyes tracked from (a camera lost, or back), in order: what
  // happened ("left camera lost (SPEC)", "right camera back (SPEC)" ...), the eyes after it
  // ("left", "right", "both"), and the time from the capture of the lost camera's last frame
  // (or of the returning camera's first frame back) to the swap of the first frame drawn in the
  // new mode, ms (the live loop's own steady-clock times); frame_ms: that frame's own capture
  // to swap (the machine's share of drawn_ms).
  struct EyeSwitch {
    std::string what, eyes;
    double drawn_ms = 0, frame_ms = 0;
  };
  std::vector<EyeSwitch> eye_switches;
  // Switches the frame thread could not queue for the window (eye_switches.h: more than 8
  // between two frames the window took): counted, so a missing one is never silent.
  std::int64_t eye_switches_dropped = 0;

  // Two cameras: the right eye lost (a run of single-view frames begun) and back (pairs again
  // after its silence of > 0.1 s); the longest time from its last frame to the first
  // single-view composite, with that frame's own capture-to-composite time (part of it: the
  // machine's share) and its wait for a right-eye partner (the pairing's share, at most half a
  // frame period); and from its first frame back to the first two-eye composite; ms, -1: none.
  std::int64_t stereo_fallbacks = 0, stereo_recoveries = 0;
  double stereo_fallback_ms_max = -1, stereo_fallback_frame_ms = -1, stereo_fallback_wait_ms = -1;
  double stereo_recovery_ms_max = -1;
  std::int64_t dropped_source = 0, dropped_consumer = 0, camera_reopens = 0;
  // Motion JPEG frames dropped as corrupt or truncated (part of dropped_source), and why the last was.
  std::int64_t corrupt_frames = 0;
  // Session 20: Motion JPEG decodes (tries) of the (left) camera and the right eye's camera, and
  // the packets dropped before anyone took them without being decoded; jpeg_decode's mode.
  std::int64_t jpeg_decodes = 0, jpeg_skipped_undecoded = 0;
  std::int64_t right_jpeg_decodes = 0, right_jpeg_skipped_undecoded = 0;
  std::string jpeg_decode;
  std::string last_corrupt;
  double wall_s = 0, displayed_fps = 0;
  // Why the run ended: "window closed", "SIGINT", "SIGTERM", "time limit",
  // "frame limit" or "footage ended" (as recording.json's stop_reason).
  std::string stop_reason;
  // Capture (Frame::steady_s) to buffer swap, per frame on its first display, ms.
  double latency_p50_ms = 0, latency_p99_ms = 0, latency_max_ms = 0;
  // Issue 28 (session 17), where the latency goes: per stage {name, p50, p99} ms (summary JSON
  // "stages_ms"): pickup, pair_wait, mesh_sync, track, compose_left, compose_right, process,
  // process_cpu (the frame thread's CPU), to_display (hand-over to the display's take),
  // display (take to swap). Stereo: stale pairs skipped (freshest_pair.h) and the eye threads.
  std::vector<std::tuple<std::string, double, double>> stage_ms;
  std::int64_t stale_pairs_skipped = 0;
  std::int64_t stale_pairs_untaken = 0;  // session 21: stale pairings that took no right frame (peeked)
  int eye_threads = 1;
  // Latency compensation (LiveOptions::camera_latency_ms): the latency used, ms; where it came
  // from ("measured" (the station file), "option", "assumed", "off", "pen"); frames drawn with the
  // pose of their exposure, and frames that fell back to the newest pose (the history had no
  // usable pose at the exposure: the engine faulted, or had not run that long).
  double compensation_latency_ms = 0;
  std::string compensation_source = "off";
  std::int64_t frames_pose_at_exposure = 0, frames_pose_newest = 0;
  double process_p50_ms = 0, process_p99_ms = 0;
  std::uint64_t engine_steps = 0, missed_deadlines = 0, watchdog_trips = 0;
  std::uint64_t periods_skipped = 0;  // engine grid points with no step (EngineStats::periods_skipped)
  double step_p50_us = 0, step_p99_us = 0, step_p999_us = 0, step_max_us = 0;
  double jitter_p99_us = 0, jitter_max_us = 0;
  bool realtime_granted = false, cpu_pinned = false, memory_locked = false;
  std::string isolation_note;
  // LiveOptions::cpu_wake_latency_us: held (the value), or why not; and how often the engine's
  // CPU entered an idle state other than polling (cpuidle, /sys/devices/system/cpu/cpuN/cpuidle)
  // and polled, per second over the run (-1: not readable).
  bool wake_latency_held = false;
  std::string wake_latency_note;
  double engine_cpu_halts_per_s = -1, engine_cpu_polls_per_s = -1;
  // The engine's late wake-ups attributed to a cause, with the engine CPU's steal (issue 28):
  // a JSON object (haptics::wake_stats_json, docs/formats.md "engine.wake"); empty: not monitored.
  std::string engine_wake_json;
  std::uint64_t volume_hash = 0;
  // Removed by the end of the run, mm^3 (engine snapshot; total = all materials).
  double removed_enamel_mm3 = 0, removed_dentin_mm3 = 0, removed_pulp_mm3 = 0, removed_total_mm3 = 0;
  // Resident memory: at start, 10 s in (after warm-up), at the end, MB.
  double rss_start_mb = 0, rss_warm_mb = 0, rss_end_mb = 0;
  // 60 s in (start-up buffers returned by then) and the largest seen after it
  // (sampled once a second), MB; 0 in runs shorter than a minute.
  double rss_60s_mb = 0, rss_max_after_60s_mb = 0;
  int overlay_hidden_ms_after_stall = -1;  // measured with the stall hook
  // The camera's silence at the window check before the one that hid the
  // overlay, ms: below the 150 ms threshold when the overlay was hidden at
  // the first check after it (how far past 200 ms a held-off window loop
  // went is then the machine's, not the logic's).
  int stall_previous_check_ms = -1;
  // Station health at the end (station_health.h): "level: check: message" per item.
  std::vector<std::string> station_health;
  bool instructor_needed = false;
  std::vector<std::string> warnings;
  // A lesson's run (LiveOptions::lesson; mode 0: none): the mode asked and run (a fallback
  // says why they differ), the expert's clock at the end and the recording's length, the
  // share of the run the expert waited for the student (mode 3), and the student's tip
  // against the expert's, sampled by the display loop (>= 30 Hz) after the expert's first
  // 0.5 s, mm.
  std::string lesson;
  int lesson_mode_asked = 0, lesson_mode = 0;
  std::string lesson_fallback;
  double lesson_expert_s = 0, lesson_expert_end_s = 0;
  double lesson_waiting_pct = 0;
  std::int64_t follow_samples = 0;
  double follow_mean_mm = 0, follow_p95_mm = 0, follow_max_mm = 0;
  // The lesson's pause points taken (the expert's clock held, device time, s; how many the
  // student ended early with the pause button) and its text annotations shown on the HUD
  // (annotation time, expert's clock and run time when shown, s; the text).
  int lesson_pauses_taken = 0, lesson_pauses_resumed_by_button = 0, lesson_pauses_resumed_by_key = 0;
  double lesson_paused_s = 0;
  struct LessonNote {
    // The annotation's time, the expert's clock when shown and at the display pass before (-1:
    // none; the note was not due then), the run's time when shown; s.
    double time_s = 0, expert_s = 0, expert_s_before = -1, run_s = 0;
    std::string text;
  };
  std::vector<LessonNote> lesson_notes;
  std::int64_t lesson_note_frames = 0;  // frames with a note beside the tooth in the AR view
  // The display path used ("gl" or "cpu"), why (the fallback's reason), and
  // what crossed between GPU and CPU over the run (compositor counters).
  std::string display_path, display_note;
  std::string display_requested;  // --display-path as given: auto, gl or cpu
  std::string cpu_display_yuyv;   // --cpu-display-yuyv: keep or convert
  std::string warp_pass;          // --output sbs: the headset pre-warp pass (--warp-pass); empty otherwise
  int warp_cell_px = 0;           // its grid's cell size (px), with exact and mesh
  // Session 22: the headset view's camera texture (--display-texture) and the scale used at
  // the last frame shown (1 full, 2 half; 0 not the CPU path's headset view).
  std::string display_texture;
  int display_texture_scale = 0;
  std::string display_half_convert;  // --display-half-convert (session 23), with a headset view's textures
  std::string capture_right_cpu;  // two cameras: --capture-right-cpu (session 22)
  std::string cpu_layout;         // --cpu-layout as applied (session 23; "" = the defaults)
  double display_texture_ratio = 0;  // auto: camera px per window px at the lens centre (0: not computed)
  std::int64_t gpu_frames = 0, readback_px = 0, cpu_blend_px = 0;
  std::int64_t gl_frames_replaced = 0, gl_ready_timeouts = 0, gl_release_timeouts = 0;
  // Session 19: the window's draws without a new frame and the wakes it skipped
  // (redraw_policy.h), and how many times an eye's pre-warp grid was made (eye_output.h).
  std::int64_t idle_draws = 0, idle_skipped = 0, warp_grid_builds = 0;
  // Session 19: CPU per frame shown, from 5 s after the start to the end: the process's
  // (every thread) and per thread name (threads alive at the end), ms; the window, s.
  double cpu_window_s = 0, cpu_process_ms_per_frame = 0;
  std::int64_t cpu_frames = 0;
  std::map<std::string, double> cpu_threads_ms_per_frame;
  std::string json() const;
};

// Runs until the window closes, a signal arrives, `seconds` pass, `frames`
// frames have been shown, or the footage ends. Errors: no camera (the message lists the V4L2 cameras and
// their modes and suggests --camera live:PATH), no display, bad station.
Result<LiveSummary> run_live(const LiveOptions& options);

// The tooth a live run drills, as its session header's "tooth" object describes it
// ({"kind": "molar"|"incisor", "voxel_mm": ...}, rebuilt by training::make_tooth):
// - replayed_tooth_json non-empty (--stylus replay:LOG): the log's own tooth; an exercise, when
//   given, must be for the same tooth kind;
// - otherwise the exercise's tooth kind ("" = the procedural molar) at the station's voxel size
//   (station_voxel_mm), as the cohort generator builds an exercise's tooth at its own voxel size.
//   Without an exercise, or with a molar exercise, this is the molar every earlier live run drilled.
// Errors (bad input): an exercise that cannot be loaded; an exercise for another tooth kind than
// the replayed log's (the message names both and what to do).
Result<std::string> live_tooth_json(const std::string& exercise, const std::string& replayed_tooth_json,
                                    double station_voxel_mm);

// Whether an OpenGL renderer string names a software rasteriser (Mesa's
// llvmpipe or softpipe, SwiftShader, Microsoft's Basic Render Driver).
bool software_renderer(const std::string& gl_renderer);

// The HUD's drill line: "drill: ON  (contact)   pedal: released" and, when the drill runs
// while the pedal is up because the stylus brings its own pedal (stylus "sim": the simulated
// hand; "replay:FILE": the recorded pedal), the reason in brackets, so the two never disagree
// silently. pedal_status = haptics::Pedal::status(); device_pedal = the stylus's own pedal
// drives the drill too.
std::string hud_drill_line(bool drill_on, bool in_contact, const std::string& pedal_status, bool pedal_pressed,
                           bool device_pedal, const std::string& stylus);

// The HUD's sound line: "sound: on (detail)", "sound: muted", or "sound: no device (silent)"
// when the hook ran and opened no output (a warning, never an error); "" when the run has no
// sound hook and is not muted (nothing to say).
std::string hud_sound_line(bool hooked, bool started, bool muted, const std::string& detail);

// The V4L2 cameras on this machine with their modes, one line each
// ("/dev/video0 (HD Webcam): MJPG 1280x720, YUYV 640x480"); or why none.
std::string list_cameras();

}  // namespace dentar::live
