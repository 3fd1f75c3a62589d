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
#include <string>
#include <utility>
#include <vector>

#include "dentar/ar/frame_pipeline.h"
#include "dentar/volume/result.h"

namespace dentar::live {

struct LiveOptions {
  std::string camera = "camera:0";  // FrameSource spec (camera:N, /dev/videoN, live:PATH)
  int width = 0, height = 0;        // camera mode request (0 = driver default)
  double fps = 0;
  std::string station;       // station file, or a built-in station ("default", "box"); empty = "default"
  bool scale_calib = false;  // accept a camera of another size (intrinsics scaled)
  // Stylus: "sim" (the simulated hand drilling the access script), "pen"
  // (the printed pen tag), "replay:FILE.dlog" (a session log in real time),
  // "none" (no bur).
  std::string stylus = "sim";
  // A real haptic device instead of the stylus stand-ins: a kind of
  // haptics::open_haptic_device ("touch", "omega", "hd", "dhd", ...); empty =
  // use `stylus`. device_name: its configuration name or serial ("" = first).
  std::string device, device_name;
  // Foot pedal: "keyboard" (the space bar), or a spec of haptics::open_pedal
  // ("auto", "vec", "usb:VID:PID", "evdev:/dev/input/eventN").
  std::string pedal = "keyboard";
  std::string model = "proxy";  // force model
  int display = -1;             // monitor for fullscreen (HMD input); -1 = a desktop window
  int window_width = 0, window_height = 0;  // windowed size (0 = the camera's)
  bool hud = true;
  bool vsync = true;
  std::string record_dir;  // empty = no recording
  std::string exercise;    // exercise the session is for (recorded in recording.json; scored by the driver)
  double seconds = 0;      // stop after this long (0 = until closed)
  bool loop = false;       // live:PATH footage: play it again at its end (long runs, benchmarks)
  int engine_cpu = -2;     // -2 = the last CPU; -1 = no pinning
  bool realtime = true;    // SCHED_FIFO + mlockall
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
  std::int64_t stall_after_frames = 0;  // the camera delivers nothing for stall_s after this many frames
  double stall_s = 0;
  std::string summary_path;  // also write the summary JSON here
  bool quiet = false;
  std::string validate() const;
};

struct LiveSummary {
  std::int64_t frames_captured = 0, frames_processed = 0, frames_displayed = 0;
  std::int64_t dropped_source = 0, dropped_consumer = 0, camera_reopens = 0;
  double wall_s = 0, displayed_fps = 0;
  // Capture (Frame::steady_s) to buffer swap, per frame on its first display, ms.
  double latency_p50_ms = 0, latency_p99_ms = 0, latency_max_ms = 0;
  double process_p50_ms = 0, process_p99_ms = 0;
  std::uint64_t engine_steps = 0, missed_deadlines = 0, watchdog_trips = 0;
  double step_p50_us = 0, step_p99_us = 0, step_p999_us = 0, step_max_us = 0;
  double jitter_p99_us = 0, jitter_max_us = 0;
  bool realtime_granted = false, cpu_pinned = false, memory_locked = false;
  std::string isolation_note;
  std::uint64_t volume_hash = 0;
  // Removed by the end of the run, mm^3 (engine snapshot; total = all materials).
  double removed_enamel_mm3 = 0, removed_dentin_mm3 = 0, removed_pulp_mm3 = 0, removed_total_mm3 = 0;
  // Resident memory: at start, 10 s in (after warm-up), at the end, MB.
  double rss_start_mb = 0, rss_warm_mb = 0, rss_end_mb = 0;
  // 60 s in (start-up buffers returned by then) and the largest seen after it
  // (sampled once a second), MB; 0 in runs shorter than a minute.
  double rss_60s_mb = 0, rss_max_after_60s_mb = 0;
  int overlay_hidden_ms_after_stall = -1;  // measured with the stall hook
  // Station health at the end (station_health.h): "level: check: message" per item.
  std::vector<std::string> station_health;
  bool instructor_needed = false;
  std::vector<std::string> warnings;
  std::string json() const;
};

// Runs until the window closes, a signal arrives, `seconds` pass, or the
// footage ends. Errors: no camera (the message lists the V4L2 cameras and
// their modes and suggests --camera live:PATH), no display, bad station.
Result<LiveSummary> run_live(const LiveOptions& options);

// The V4L2 cameras on this machine with their modes, one line each
// ("/dev/video0 (HD Webcam): MJPG 1280x720, YUYV 640x480"); or why none.
std::string list_cameras();

}  // namespace dentar::live
