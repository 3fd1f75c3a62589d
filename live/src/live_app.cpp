// dentar live: threads, engine, window and recording. See live_app.h.
#include "dentar/live/live_app.h"

#include "dentar/live/cpu_layout.h"
#include "dentar/live/eye_output.h"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <pthread.h>
#include <sched.h>
#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cctype>
#include <cmath>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <mutex>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <thread>

#include "dentar/ar/capture_thread.h"
#include "dentar/ar/egl_context.h"
#include "dentar/ar/gl_handoff.h"
#include "dentar/ar/frame_source.h"
#include "dentar/ar/stereo_source.h"
#include "dentar/ar/tracker.h"
#include "dentar/haptics/engine.h"
#include "dentar/haptics/open_device.h"
#include "dentar/haptics/pedal.h"
#include "dentar/haptics/replay.h"
#include "dentar/haptics/replay_device.h"
#include "dentar/haptics/scripts.h"
#include "dentar/haptics/session_log.h"
#include "dentar/haptics/simulated_device.h"
#include "dentar/live/hud_window.h"
#include "dentar/live/pen_device.h"
#include "dentar/live/station_health.h"
#include "live_run.h"
#include "dentar/training/exercise.h"
#include "dentar/training/hand_script.h"
#include "dentar/session/frames_csv.h"
#include "dentar/session/lesson_clock.h"
#include "dentar/session/recorder.h"
#include "dentar/session/run.h"
#include "dentar/volume/bur.h"
#include "dentar/volume/material.h"
#include "dentar/volume/procedural_tooth.h"

namespace dentar::live {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

std::atomic<int> g_signal{0};
extern "C" void on_signal(int sig) { g_signal.store(sig); }

std::string iso_now() {
  const std::time_t t = std::time(nullptr);
  char b[32];
  std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return b;
}

// A PM QoS request on the CPUs' wake-up latency from idle, held while it lives
// (the kernel drops it when the file closes). Linux: /dev/cpu_dma_latency takes
// a binary int32 in microseconds.
class WakeLatencyHold {
 public:
  explicit WakeLatencyHold(int latency_us) {
    if (latency_us < 0) {
      note_ = "";  // not asked (--cpu-wake-latency-us -1, the default): the system's idle states
      return;
    }
    fd_ = ::open("/dev/cpu_dma_latency", O_WRONLY | O_CLOEXEC);
    if (fd_ < 0) {
      note_ = std::string("refused: /dev/cpu_dma_latency: ") + std::strerror(errno) +
              " (run as root or give write access to it); idle CPUs may halt and wake the engine late";
      return;
    }
    const std::int32_t v = latency_us;
    if (::write(fd_, &v, sizeof v) != static_cast<ssize_t>(sizeof v)) {
      note_ = std::string("refused: writing /dev/cpu_dma_latency: ") + std::strerror(errno);
      ::close(fd_);
      fd_ = -1;
      return;
    }
    note_ = "CPU wake-up latency held at " + std::to_string(latency_us) + " us (/dev/cpu_dma_latency)";
  }
  ~WakeLatencyHold() {
    if (fd_ >= 0) ::close(fd_);
  }
  WakeLatencyHold(const WakeLatencyHold&) = delete;
  WakeLatencyHold& operator=(const WakeLatencyHold&) = delete;
  bool held() const { return fd_ >= 0; }
  const std::string& note() const { return note_; }

 private:
  int fd_ = -1;
  std::string note_;
};

// Idle entries of one CPU so far (cpuidle's per-state usage counters): polling
// (the POLL state) and halting (every other state); -1 when not readable.
std::pair<long long, long long> cpu_idle_entries(int cpu) {
  long long poll = 0, halt = 0;
  bool any = false;
  const fs::path dir = "/sys/devices/system/cpu/cpu" + std::to_string(cpu) + "/cpuidle";
  for (int i = 0; i < 16; ++i) {
    const fs::path st = dir / ("state" + std::to_string(i));
    std::ifstream name(st / "name"), usage(st / "usage");
    std::string n;
    long long u = 0;
    if (!(name >> n) || !(usage >> u)) break;
    any = true;
    (n == "POLL" ? poll : halt) += u;
  }
  if (!any) return {-1, -1};
  return {poll, halt};
}

}  // namespace

std::string LiveOptions::validate() const {
  if (camera.empty()) return "camera is empty: give --camera camera:N, /dev/videoN or live:PATH";
  if (side_by_side && !camera_right.empty())
    return "side_by_side (--stereo: one side-by-side camera) and camera_right (--camera-right: a second camera) "
           "are two kinds of stereo head: give one";
  if (stall_right_after_frames > 0 && camera_right.empty()) return "the right eye's stall hook needs camera_right";
  if (width < 0 || height < 0 || fps < 0) return "camera mode (--width/--height/--fps) must be >= 0";
  if (pedal.empty()) return "pedal is empty: give keyboard, auto, vec, usb:VID:PID or evdev:/dev/input/eventN";
  if (!(stylus == "sim" || stylus == "pen" || stylus == "none" || stylus.rfind("replay:", 0) == 0))
    return "stylus = \"" + stylus + "\" must be sim, pen, none or replay:FILE.dlog";
  if (stylus == "replay:") return "stylus = replay: needs a session log path (replay:FILE.dlog)";
  if (display < -1 || display > 16) return "display = " + std::to_string(display) + " must be -1 (window) or a monitor 0..16";
  if (output != "mono" && output != "sbs") return "output = \"" + output + "\" must be mono or sbs";
  if (output == "sbs" && !headset) return "output sbs needs a headset profile (--headset FILE, docs/formats.md)";
  if (!(loupe == 0 || (loupe >= 1.5 && loupe <= 8)))
    return "loupe = " + std::to_string(loupe) + " must be 0 (off) or a magnification in 1.5..8 (dentists' loupes: 2.5-4)";
  if (loupe_view != "inset" && loupe_view != "full") return "loupe_view = \"" + loupe_view + "\" must be inset or full";
  if (window_width < 0 || window_height < 0 || window_width > 8192 || window_height > 8192)
    return "window size must be within 0..8192";
  if (WarpPass p; !parse_warp_pass(warp_pass, p))
    return "warp_pass = \"" + warp_pass + "\" must be exact, mesh, full or lut";
  if (warp_cell_px < 4 || warp_cell_px > 128)
    return "warp_cell_px = " + std::to_string(warp_cell_px) + " must be in 4..128 panel px";
  if (jpeg_decode != "eager" && jpeg_decode != "on-demand" && jpeg_decode != "every-frame")
    return "jpeg_decode = \"" + jpeg_decode + "\" must be eager, on-demand or every-frame";
  if (display_texture != "auto" && display_texture != "full" && display_texture != "half")
    return "display_texture = \"" + display_texture + "\" must be auto, full or half";
  if (cpu_display_yuyv != "keep" && cpu_display_yuyv != "convert")
    return "cpu_display_yuyv = \"" + cpu_display_yuyv + "\" must be keep or convert";
  if (bur_samples != 0 && (bur_samples < volume::kMinBurSamples || bur_samples > volume::kMaxBurSamples))
    return "bur_samples = " + std::to_string(bur_samples) + " must be 0 (the default) or in 1.." +
           std::to_string(volume::kMaxBurSamples);
  if (bur_samples != 0 && stylus.rfind("replay:", 0) == 0)
    return "bur_samples = " + std::to_string(bur_samples) + ": a replayed log keeps its header's bur.samples";
  if (!(std::isfinite(idle_redraw_ms) && idle_redraw_ms >= 0 && idle_redraw_ms <= 1000))
    return "idle_redraw_ms = " + std::to_string(idle_redraw_ms) + " must be in 0..1000 ms (0: redraw at every wake)";
  if (!(std::isfinite(seconds) && seconds >= 0)) return "seconds must be >= 0";
  if (frames < 0) return "frames = " + std::to_string(frames) + " must be >= 0 (0 = no limit)";
  if (!(std::isfinite(camera_latency_ms) && camera_latency_ms <= 1000))
    return "camera_latency_ms must be <= 1000 ms (< 0: the station's, 0: no compensation)";
  if (cpu_wake_latency_us < -1 || cpu_wake_latency_us > 1000000)
    return "cpu_wake_latency_us = " + std::to_string(cpu_wake_latency_us) +
           " must be -1 (the system's) or a latency in 0..1000000 us";
  if (engine_cpu < -2 || engine_cpu > 1023) return "engine_cpu must be -2 (last CPU), -1 (none) or a CPU index";
  if (stall_after_frames < 0 || !(stall_s >= 0)) return "stall hook values must be >= 0";
  if (eye_threads != 1 && eye_threads != 2) return "eye_threads = " + std::to_string(eye_threads) + " must be 1 or 2";
  if (capture_right_cpu != "any" && capture_right_cpu != "engine" && capture_right_cpu != "frame")
    return "capture_right_cpu = \"" + capture_right_cpu + "\" must be any, engine or frame";
  if (display_half_convert != "direct" && display_half_convert != "box")
    return "display_half_convert = \"" + display_half_convert + "\" must be direct or box";
  if (CpuLayout lay; !cpu_layout.empty())
    if (std::string e = parse_cpu_layout(cpu_layout, 0, lay); !e.empty()) return e;
  if (eye_thread_cpu != "any" && eye_thread_cpu != "engine" && eye_thread_cpu != "frame")
    return "eye_thread_cpu = \"" + eye_thread_cpu + "\" must be any, engine or frame";
  if (window_raster_cpu != "any" && window_raster_cpu != "frame" && window_raster_cpu != "auto")
    return "window_raster_cpu = \"" + window_raster_cpu + "\" must be auto, any or frame";
  if (display_path != "gl" && display_path != "cpu" && display_path != "auto")
    return "display_path = \"" + display_path + "\" must be auto, gl or cpu";
  if (background_cpu != "others" && background_cpu != "engine")
    return "background_cpu = \"" + background_cpu + "\" must be others or engine";
  if (hand_skill != 1.0 || hand_style != 0.0 || hand_seed != 1) {
    if (stylus != "sim" || exercise.empty())
      return "--hand-skill, --hand-style and --hand-seed shape the simulated hand of an exercise: give --stylus sim and "
             "--exercise";
    if (!(hand_skill >= 0 && hand_skill <= 1))
      return "--hand-skill " + std::to_string(hand_skill) + ": must be in [0, 1] (1 = expert, 0 = novice)";
    if (!(hand_style >= 0 && hand_style <= 3))
      return "--hand-style " + std::to_string(hand_style) + ": must be in [0, 3] (0 = no personal style)";
  }
  if (!lesson.empty()) {
    if (lesson_mode < 1 || lesson_mode > 5)
      return "--lesson needs --mode 1..5 (1 visual replay, 2 passive guidance, 3 active following, 4 force reversal, "
             "5 hints)";
    if (!exercise.empty()) return "--exercise with --lesson: the lesson names its exercise (dentar lesson show LESSON)";
    if (device.empty() && stylus != "sim" && stylus != "pen")
      return "--lesson with --stylus " + stylus + ": a lesson is trained with --stylus sim (a simulated student), pen, "
             "or a --device";
  } else if (lesson_mode != 0) {
    return "--mode " + std::to_string(lesson_mode) + " needs --lesson LESSON";
  }
  if (passthrough && !record_dir.empty())
    return "--passthrough shows the camera's frames without AR and records nothing: leave out --record";
  if (passthrough && !lesson.empty()) return "--passthrough shows no AR: leave out --lesson";
  if (pipeline.tracker.discovery == ar::DiscoveryMode::kScheduled)
    return "pipeline.tracker.discovery = scheduled is for replays (dentar offline), not a live run";
  if (auto v = pipeline.validate(); !v.empty()) return "pipeline: " + v;
  return {};
}

std::string LiveSummary::json() const {
  char hash[20];
  std::snprintf(hash, sizeof hash, "%016llx", static_cast<unsigned long long>(volume_hash));
  // Session 21: a camera's Motion JPEG decodes per frame shown (0 when none was shown).
  const auto per_shown = [this](std::int64_t n) {
    return frames_displayed > 0 ? static_cast<double>(n) / static_cast<double>(frames_displayed) : 0.0;
  };
  nlohmann::json j = {
      {"frames", {{"captured", frames_captured}, {"processed", frames_processed}, {"displayed", frames_displayed},
                  {"dropped_source", dropped_source}, {"dropped_consumer", dropped_consumer},
                  {"camera_reopens", camera_reopens}, {"corrupt_jpeg", corrupt_frames},
                  {"last_corrupt_jpeg", last_corrupt}, {"jpeg_decode", jpeg_decode},
                  {"jpeg_decodes", jpeg_decodes}, {"jpeg_skipped_undecoded", jpeg_skipped_undecoded},
                  {"jpeg_decodes_per_frame_shown", per_shown(jpeg_decodes)}}},
      {"wall_s", wall_s},
      {"stop_reason", stop_reason},
      {"displayed_fps", displayed_fps},
      {"latency_ms", {{"p50", latency_p50_ms}, {"p99", latency_p99_ms}, {"max", latency_max_ms}}},
      {"latency_compensation", {{"camera_latency_ms", compensation_latency_ms}, {"source", compensation_source},
                                {"frames_pose_at_exposure", frames_pose_at_exposure},
                                {"frames_pose_newest", frames_pose_newest}}},
      {"process_ms", {{"p50", process_p50_ms}, {"p99", process_p99_ms}}},
      {"stages_ms", nlohmann::json::object()},
      {"engine", {{"steps", engine_steps}, {"missed_deadlines", missed_deadlines}, {"periods_skipped", periods_skipped}, {"watchdog_trips", watchdog_trips},
                  {"step_us", {{"p50", step_p50_us}, {"p99", step_p99_us}, {"p999", step_p999_us}, {"max", step_max_us}}},
                  {"jitter_us", {{"p99", jitter_p99_us}, {"max", jitter_max_us}}},
                  {"realtime_granted", realtime_granted}, {"cpu_pinned", cpu_pinned},
                  {"memory_locked", memory_locked}, {"isolation", isolation_note},
                  {"wake_latency", {{"held", wake_latency_held}, {"note", wake_latency_note},
                                    {"cpu_halts_per_s", engine_cpu_halts_per_s},
                                    {"cpu_polls_per_s", engine_cpu_polls_per_s}}},
                  {"wake", engine_wake_json.empty() ? nlohmann::json::object()
                                                    : nlohmann::json::parse(engine_wake_json, nullptr, false)}}},
      {"volume_hash", hash},
      {"removed_mm3", {{"enamel", removed_enamel_mm3}, {"dentin", removed_dentin_mm3},
                       {"pulp", removed_pulp_mm3}, {"total", removed_total_mm3}}},
      {"rss_mb", {{"start", rss_start_mb}, {"after_10s", rss_warm_mb}, {"end", rss_end_mb},
                  {"growth_after_10s", rss_warm_mb > 0 ? rss_end_mb - rss_warm_mb : 0.0},
                  {"after_60s", rss_60s_mb}, {"max_after_60s", rss_max_after_60s_mb},
                  {"growth_after_60s", rss_60s_mb > 0 ? rss_end_mb - rss_60s_mb : 0.0}}},
      {"overlay_hidden_ms_after_stall", overlay_hidden_ms_after_stall},
      {"stall_previous_check_ms", stall_previous_check_ms},
      {"display", {{"path", display_path}, {"requested", display_requested}, {"cpu_display_yuyv", cpu_display_yuyv}, {"note", display_note}, {"gpu_frames", gpu_frames},
                   {"readback_px", readback_px}, {"cpu_blend_px", cpu_blend_px},
                   {"gl_frames_replaced", gl_frames_replaced}, {"gl_ready_timeouts", gl_ready_timeouts},
                   {"gl_release_timeouts", gl_release_timeouts}, {"idle_draws", idle_draws},
                   {"idle_skipped", idle_skipped}, {"warp_grid_builds", warp_grid_builds}}},
      {"station_health", {{"instructor_needed", instructor_needed}, {"items", station_health}}},
      {"warnings", warnings}};
  if (cpu_frames > 0)  // session 19: CPU per frame shown
    j["cpu"] = {{"window_s", cpu_window_s}, {"frames", cpu_frames}, {"process_ms_per_frame", cpu_process_ms_per_frame},
                {"threads_ms_per_frame", cpu_threads_ms_per_frame}};
    if (!cpu_layout.empty()) j["cpu"]["layout"] = cpu_layout;  // session 23
  if (!warp_pass.empty()) {  // session 18: which pre-warp pass drew the headset view
    j["display"]["warp_pass"] = warp_pass;
    j["display"]["warp_cell_px"] = warp_cell_px;
    j["display"]["texture"] = display_texture;
    j["display"]["texture_scale"] = display_texture_scale;
    if (!display_half_convert.empty()) j["display"]["half_convert"] = display_half_convert;  // session 23
    if (display_texture_ratio > 0) j["display"]["texture_camera_px_per_window_px"] = display_texture_ratio;
  }
  if (stereo)
    j["stereo"] = {{"frames_both_eyes", stereo_both}, {"frames_left_eye_only", stereo_left_only},
                   {"frames_right_eye_composited", right_composited},
                   {"right_eye_dropped", right_eye_dropped}, {"right_eye_reopens", right_eye_reopens},
                   {"right_eye_jpeg_decodes", right_jpeg_decodes},
                   {"right_eye_jpeg_skipped_undecoded", right_jpeg_skipped_undecoded},
                   {"right_eye_jpeg_decodes_per_frame_shown", per_shown(right_jpeg_decodes)},
                   {"fallbacks", stereo_fallbacks}, {"recoveries", stereo_recoveries},
                   {"fallback_ms_max", stereo_fallback_ms_max}, {"fallback_frame_ms", stereo_fallback_frame_ms},
                   {"fallback_wait_ms", stereo_fallback_wait_ms}, {"recovery_ms_max", stereo_recovery_ms_max},
                   {"stale_pairs_skipped", stale_pairs_skipped},
                   {"stale_pairs_untaken", stale_pairs_untaken}, {"eye_threads", eye_threads}};
  if (stereo) {  // issue 28, session 17: either camera lost and back, timed to the frame drawn
    j["stereo"]["frames_right_eye_only"] = stereo_right_only;
    j["stereo"]["frames_note_both_eyes"] = note_both_eyes;
    j["stereo"]["frames_note_missing_in_an_eye"] = note_missing_eye;
    j["stereo"]["mode_switches"] = eye_switches.size();
    j["stereo"]["switches_dropped"] = eye_switches_dropped;
    if (!capture_right_cpu.empty()) j["stereo"]["capture_right_cpu"] = capture_right_cpu;  // session 22
    auto& sw = j["stereo"]["switches"] = nlohmann::json::array();
    for (const EyeSwitch& e : eye_switches) sw.push_back({{"what", e.what}, {"eyes", e.eyes}, {"drawn_ms", e.drawn_ms}, {"frame_ms", e.frame_ms}});
  }
  for (const auto& [name, p50, p99] : stage_ms) j["stages_ms"][name] = {{"p50", p50}, {"p99", p99}};
  if (lesson_mode != 0)
    j["lesson"] = {{"lesson", lesson}, {"mode_asked", lesson_mode_asked}, {"mode", lesson_mode},
                   {"mode_name", haptics::training_mode_name(static_cast<haptics::TrainingModeKind>(lesson_mode))},
                   {"fallback", lesson_fallback}, {"expert_s", lesson_expert_s}, {"expert_end_s", lesson_expert_end_s},
                   {"expert_waiting_pct", lesson_waiting_pct},
                   {"follow_error_mm", {{"samples", follow_samples}, {"mean", follow_mean_mm}, {"p95", follow_p95_mm},
                                        {"max", follow_max_mm}}},
                   {"pauses", {{"taken", lesson_pauses_taken}, {"paused_s", lesson_paused_s},
                               {"resumed_by_button", lesson_pauses_resumed_by_button},
                               {"resumed_by_key", lesson_pauses_resumed_by_key}}}};
  if (lesson_mode != 0) {
    nlohmann::json notes = nlohmann::json::array();
    for (const LessonNote& n : lesson_notes)
      notes.push_back({{"time_s", n.time_s}, {"expert_s", n.expert_s}, {"expert_s_before", n.expert_s_before},
                       {"run_s", n.run_s}, {"text", n.text}});
    j["lesson"]["notes_shown"] = notes;
    j["lesson"]["note_frames_in_view"] = lesson_note_frames;
  }
  return j.dump(2) + "\n";
}

bool software_renderer(const std::string& gl_renderer) {
  std::string r = gl_renderer;
  for (char& ch : r) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  for (const char* s : {"llvmpipe", "softpipe", "swiftshader", "swrast", "basic render driver"})
    if (r.find(s) != std::string::npos) return true;
  return false;
}

// Intrinsics for an image of another aspect ratio, at the same horizontal field of view: the
// calibrated image scaled by width / k.width, then cropped (or extended) top and bottom about
// the same principal-point offset from the centre. Most webcams make their 16:9 modes this way
// from a 4:3 sensor (full width, top and bottom cut), and `dentar synth` renders footage of
// another size with the same model (ar/synth), so built-in stations match generated footage.
// For the same aspect ratio it equals ar::scale_intrinsics.
static calibration::CameraIntrinsics crop_intrinsics(const calibration::CameraIntrinsics& k, int width, int height) {
  const double s = double(width) / k.width;
  calibration::CameraIntrinsics out = k;
  out.width = width;
  out.height = height;
  out.fx = k.fx * s;
  out.fy = k.fy * s;
  out.cx = 0.5 * (width - 1) + (k.cx - 0.5 * (k.width - 1)) * s;
  out.cy = 0.5 * (height - 1) + (k.cy - 0.5 * (k.height - 1)) * s;
  return out;
}

std::string hud_sound_line(bool hooked, bool started, bool muted, const std::string& detail) {
  if (muted) return "sound: muted";
  if (!hooked) return {};
  if (!started) return "sound: no device (silent)";
  return detail.empty() ? "sound: on" : "sound: on (" + detail + ")";
}

std::string hud_drill_line(bool drill_on, bool in_contact, const std::string& pedal_status, bool pedal_pressed,
                           bool device_pedal, const std::string& stylus) {
  std::string s = std::string("drill: ") + (drill_on ? "ON" : "off") + (in_contact ? "  (contact)" : "") +
                  "   pedal: " + pedal_status;
  if (drill_on && !pedal_pressed && device_pedal)
    s += stylus.rfind("replay:", 0) == 0 ? "  (the replayed session drills with its recorded pedal)"
                                         : "  (the simulated hand drills without the pedal)";
  return s;
}

namespace {
// The exercise named as the drivers name it (tools/session_score.cpp check_exercise).
Result<training::Exercise> named_exercise(const std::string& exercise) {
  auto ex = training::load_named_exercise(exercise);
  if (!ex) return Error{"--exercise " + exercise + ": " + ex.error()};
  return ex;
}
}  // namespace

Result<std::string> live_tooth_json(const std::string& exercise, const std::string& replayed_tooth_json,
                                    double station_voxel_mm) {
  auto kind_of = [](const nlohmann::json& j) { return j.is_object() ? j.value("kind", std::string()) : std::string(); };
  std::string ex_kind, ex_name = exercise;
  if (!exercise.empty()) {
    auto ex = named_exercise(exercise);
    if (!ex) return Error{ex.error()};
    ex_kind = kind_of(nlohmann::json::parse(ex->tooth_json, nullptr, false));
    ex_name = ex->name;
  }
  if (!replayed_tooth_json.empty()) {
    const std::string log_kind = kind_of(nlohmann::json::parse(replayed_tooth_json, nullptr, false));
    if (!ex_kind.empty() && ex_kind != log_kind)
      return Error{"--exercise " + exercise + ": exercise '" + ex_name + "' is for a" +
                   (ex_kind == "incisor" ? "n " : " ") + ex_kind + ", but the replayed session log's tooth is " +
                   replayed_tooth_json + ": replay a session of that exercise, or give an exercise for the log's tooth "
                   "(or none: the log's tooth is drilled)"};
    return replayed_tooth_json;
  }
  // nlohmann::json keeps keys sorted: a molar here dumps to the bytes earlier live runs wrote.
  nlohmann::json d = {{"kind", ex_kind.empty() ? "molar" : ex_kind}, {"voxel_mm", station_voxel_mm}};
  return d.dump();
}

namespace {

// The station (a file, or a built-in one by name) and the camera, opened;
// intrinsics scaled (or cropped) to the camera's mode when allowed.
struct StationCamera {
  ar::StationScene st;
  bool builtin = false;
  ar::FrameSourceOptions so;
  std::unique_ptr<ar::FrameSource> src;
  int eye_w = 0, eye_h = 0;  // one eye's frame (the camera's, or half a side-by-side frame)
};
Result<StationCamera> open_station_and_camera(const LiveOptions& o, LiveSummary& sum,
                                              const std::function<void(const std::string&)>& say) {
  // ---- station ----
  StationCamera sc;
  ar::StationScene& st = sc.st;
  const bool builtin = sc.builtin = o.station.empty() || (!fs::is_regular_file(o.station) && ar::builtin_station_scene(o.station));
  if (builtin) {
    st = *ar::builtin_station_scene(o.station.empty() ? "default" : o.station);
  } else {
    auto s = ar::read_station_scene(o.station);
    if (!s) return Error{"live: " + s.error()};
    st = std::move(*s);
  }

  // ---- camera ----
  ar::FrameSourceOptions& so = sc.so;
  so.width = o.width;
  so.height = o.height;
  so.fps = o.fps;
  if (o.camera_format != "auto" && o.camera_format != "yuyv" && o.camera_format != "mjpg" && o.camera_format != "bgr")
    return Error{"live: --camera-format " + o.camera_format + ": must be auto, yuyv, mjpg or bgr"};
  so.pixel_format = o.camera_format == "bgr" ? "bgr" : "native";
  so.fourcc = o.camera_format == "yuyv" ? "YUYV" : o.camera_format == "mjpg" ? "MJPG" : "";
  so.defer_jpeg_decode = o.jpeg_decode == "on-demand" || o.jpeg_decode == "eager";
  auto src = ar::FrameSource::open(o.camera, so);
  if (!src) {
    const bool is_cam = o.camera.rfind("camera:", 0) == 0 || o.camera.rfind("/dev/video", 0) == 0;
    return Error{"live: " + src.error() +
                 (is_cam ? "\nCameras found:\n" + list_cameras() : std::string()) +
                 "\nTo try without a camera, play recorded footage as a camera: --camera live:PATH "
                 "(for example footage made by `dentar synth --webcam --resolution 1280x720 --out out/clip`: "
                 "--camera live:out/clip/camera.avi --station out/clip/station.json; camera.avi is Motion JPEG, "
                 "which decodes in real time, as a webcam delivers it)"};
  }
  {
    // The generator's lossless FFV1 (video.mkv) decodes slower than a 30 fps camera at 720p
    // and more (docs/BENCHMARKS.md, issue 26): say what plays in real time.
    const int W = (*src)->width(), H = (*src)->height();
    const std::string ext = fs::path(o.camera).extension().string();
    if (o.camera.rfind("live:", 0) == 0 && ext == ".mkv" && W * H >= 1280 * 720) {
      const std::string w = o.camera + ": lossless footage decodes slower than real time at " + std::to_string(W) + "x" +
                            std::to_string(H) + " on a small machine (frames are dropped, latency grows); play "
                            "the Motion JPEG copy instead: `dentar synth --webcam` writes camera.avi beside video.mkv";
      say("warning: " + w);
      sum.warnings.push_back(w);
    }
  }
  sc.eye_w = (*src)->width();
  sc.eye_h = (*src)->height();
  if (o.side_by_side || !o.camera_right.empty()) {
    // Stereo (issue 28): the rig's eyes, each of the calibrated size (no scaling).
    const auto& cam = st.calibration.camera;
    const std::string what = o.side_by_side ? "--stereo" : "--camera-right";
    if (!st.stereo.present)
      return Error{"live: " + what + ": the station " + (o.station.empty() ? "default" : o.station) +
                   " has no stereo rig (station file \"stereo\": camera_right, T_left_right): calibrate the rig "
                   "with `dentar calibrate stereo`, or give the station.json that `dentar synth --stereo` wrote"};
    ar::StereoSourceOptions sso;
    sso.source = so;
    src->reset();  // a camera is opened once at a time: the pair opens it again (checked, then closed)
    auto pair = o.side_by_side ? ar::StereoSource::open_side_by_side(o.camera, sso)
                               : ar::StereoSource::open_pair(o.camera, o.camera_right, sso);
    if (!pair) return Error{"live: " + what + ": " + pair.error()};
    sc.eye_w = (*pair)->width();
    sc.eye_h = (*pair)->height();
    if (sc.eye_w != cam.width || sc.eye_h != cam.height || st.stereo.camera_right.width != cam.width ||
        st.stereo.camera_right.height != cam.height)
      return Error{"live: " + what + ": each eye delivers " + std::to_string(sc.eye_w) + "x" + std::to_string(sc.eye_h) +
                   " but the rig is calibrated for " + std::to_string(cam.width) + "x" + std::to_string(cam.height) +
                   " (camera) and " + std::to_string(st.stereo.camera_right.width) + "x" +
                   std::to_string(st.stereo.camera_right.height) +
                   " (stereo.camera_right): ask for the calibrated mode with --width/--height, or calibrate this "
                   "mode (dentar calibrate stereo)"};
    return sc;  // sc.src empty: the capture threads open the eyes when the run starts
  }
  {
    auto& cam = st.calibration.camera;
    const int W = (*src)->width(), H = (*src)->height();
    // Side-by-side stereo (a station with a stereo rig, two eyes of its camera's size in one
    // frame) without --stereo: scaling that frame as one image would be wrong.
    if (st.stereo.present && W == 2 * cam.width && H == cam.height)
      return Error{"live: " + o.camera + " delivers side-by-side stereo frames (" + std::to_string(W) + "x" +
                   std::to_string(H) + ", two " + std::to_string(cam.width) + "x" + std::to_string(cam.height) +
                   " eyes, the station's \"stereo\" rig): track it from both eyes with --stereo, or play mono "
                   "footage (dentar synth without --stereo)"};
    if (W != cam.width || H != cam.height) {
      const std::string sizes = o.camera + " delivers " + std::to_string(W) + "x" + std::to_string(H) +
                                " but the station camera is calibrated for " + std::to_string(cam.width) + "x" +
                                std::to_string(cam.height);
      if (!o.scale_calib && !builtin)
        return Error{"live: " + sizes + ": use the station calibrated for this camera mode (dentar calibrate camera), "
                     "ask for its mode with --width/--height, or pass --scale-calib"};
      // Same aspect ratio: scaled. Another one (a 4:3 calibration, a 720p or 1080p webcam):
      // the same horizontal field of view with top and bottom cropped, as most webcams make
      // their 16:9 modes (crop_intrinsics above; the model synth renders other sizes with).
      auto scaled = ar::scale_intrinsics(cam, W, H);
      const bool cropped = !scaled;
      if (cropped && W > 0 && H > 0 && cam.width > 0 && cam.height > 0) scaled = crop_intrinsics(cam, W, H);
      if (!scaled) return Error{"live: " + sizes + ": " + scaled.error()};
      cam = *scaled;
      say("warning: " + sizes + (cropped ? "; another aspect ratio: intrinsics scaled to the width and cropped" : "; intrinsics scaled"));
      sum.warnings.push_back(sizes + (cropped ? "; another aspect ratio: intrinsics scaled to the width and cropped "
                                                "top and bottom (same horizontal field of view)"
                                              : "; intrinsics scaled") +
                             ": calibrate this camera for accurate placement (dentar calibrate camera)");
    }
  }
  sc.src = std::move(*src);
  return sc;
}

// The tooth (by exercise, or the replayed log's), the stylus device (a
// haptic device, a replayed session log, the simulated hand, or the pen) and
// the engine's configuration from the station.
struct StylusSetup {
  std::optional<volume::VoxelVolume> vol;
  volume::BurParams bur_params = volume::BurParams::capsule(0.5, 3.0);
  int bur_samples = 10000;
  std::unique_ptr<haptics::HapticDevice> device;
  PenDevice* pen = nullptr;
  haptics::EngineConfig cfg;
  std::string tooth_desc;  // the session header's "tooth" (live_tooth_json)
  bool pedal_from_device = false;
  // The simulated hand's script length with an exercise (s of engine time; 0 = none): the run
  // ends once the engine has stepped through it, as a student stops when the preparation is done.
  double hand_end_s = 0;
  // A lesson (LiveOptions::lesson): its clock (handed to the run) and the simulated student.
  std::unique_ptr<session::LessonClock> lesson;
  session::LessonStudentDevice* student = nullptr;
};

// The stylus of a lesson: a real device, the pen, or the simulated student following the
// expert; the lesson's tooth and the recording's bur.
Result<StylusSetup> lesson_stylus(const LiveOptions& o, const ar::StationScene& st, StationHealthMonitor& health,
                                  const std::function<void(const std::string&)>& say) {
  StylusSetup ss;
  ss.cfg.model = o.model;
  ss.cfg.T_tooth_dev = st.calibration.T_tooth_dev();
  ss.cfg.T_sty_tip = st.calibration.T_sty_tip;
  haptics::DeviceLimits limits;
  bool renders_force = true;
  if (!o.device.empty()) {
    haptics::DeviceOpenOptions dopt;
    dopt.name_or_serial = o.device_name;
    auto d = haptics::open_haptic_device(o.device, dopt);
    if (!d) return Error{"live: --device " + o.device + ": " + d.error()};
    ss.device = std::move(*d);
    limits = ss.device->limits();
  } else if (o.stylus == "pen") {
    if (st.pen.tags.empty())
      return Error{"live: --stylus pen: the station file has no pen (\"pen\".tags); print the kit with `dentar tags`"};
    auto p = std::make_unique<PenDevice>(limits);
    ss.pen = p.get();
    ss.device = std::move(p);
    renders_force = false;
  } else {
    auto l = session::lesson_student_limits();
    if (!l) return Error{"live: --lesson: " + l.error()};
    limits = *l;
  }
  auto lesson = session::LessonClock::open(o.lesson, o.lesson_mode, limits, renders_force);
  if (!lesson) return Error{"live: " + lesson.error()};
  if (!(*lesson)->fallback().empty()) say("lesson: " + (*lesson)->fallback());
  for (const auto& n : (*lesson)->notes()) say("lesson: " + n);
  ss.tooth_desc = (*lesson)->lesson().tooth_json;
  auto t = training::make_tooth(ss.tooth_desc);
  if (!t) return Error{"live: --lesson " + o.lesson + ": tooth " + ss.tooth_desc + ": " + t.error()};
  ss.vol.emplace(std::move(*t));
  ss.bur_params = (*lesson)->bur();
  ss.bur_samples = o.bur_samples > 0 ? o.bur_samples : (*lesson)->bur_samples();
  // Lessons drill as live does (session 22): the overlap cutter, sample-count independent.
  haptics::use_overlap_cut(ss.cfg);
  if (!ss.device) {  // the simulated student
    auto d = session::make_lesson_student(ss.cfg.T_tooth_dev, ss.cfg.T_sty_tip, (*lesson)->expert_start());
    if (!d) return Error{"live: --lesson: " + d.error()};
    ss.student = d->get();
    ss.device = std::move(*d);
    ss.pedal_from_device = true;
  } else if (!o.device.empty()) {
    auto box = crown_box_tooth(ss.tooth_desc);
    if (!box) return Error{"live: " + box.error()};
    const HealthItem reach = check_station_reach(st, ss.device->limits(), ss.device->name(), *box).item;
    health.set(reach);
    if (reach.level != HealthLevel::kOk) say("station health: " + reach.check + ": " + reach.message);
  }
  ss.lesson = std::move(*lesson);
  return ss;
}

Result<StylusSetup> make_stylus(const LiveOptions& o, const ar::StationScene& st, StationHealthMonitor& health,
                                const std::function<void(const std::string&)>& say) {
  if (!o.lesson.empty()) return lesson_stylus(o, st, health, say);
  // ---- tooth, stylus, engine ----
  StylusSetup ss;
  std::optional<volume::VoxelVolume>& vol = ss.vol;
  volume::BurParams& bur_params = ss.bur_params;
  int& bur_samples = ss.bur_samples;
  std::unique_ptr<haptics::HapticDevice>& device = ss.device;
  PenDevice*& pen = ss.pen;
  haptics::EngineConfig& cfg = ss.cfg;
  cfg.model = o.model;
  // The station drills with the sample jitter on (session 21): without it a bur whose samples are
  // sparser than the tooth's voxels stalls when held still (0.000 mm3/s at 0.1 mm voxels with 500
  // samples, docs/BENCHMARKS.md "Haptics session 21"). A replayed log keeps its header's cutter.
  cfg.cut.sample_jitter = true;
  // Session 22: cut by overlap volume with the shape-constrained proxy, so the cut rate does not
  // depend on the bur's sample count (the jitter is then unused; docs/BENCHMARKS.md "Haptics
  // session 22").
  haptics::use_overlap_cut(cfg);
  if (o.bur_samples > 0) bur_samples = o.bur_samples;
  cfg.T_tooth_dev = st.calibration.T_tooth_dev();
  cfg.T_sty_tip = st.calibration.T_sty_tip;
  std::string& tooth_desc = ss.tooth_desc;
  bool& pedal_from_device = ss.pedal_from_device;
  double& hand_end_s = ss.hand_end_s;
  // The tooth named by tooth_desc, built by training::make_tooth (as the scorer and the
  // cohort generator build it).
  auto build_tooth = [&]() -> Status {
    auto t = training::make_tooth(tooth_desc);
    if (!t) return Error{"live: tooth " + tooth_desc + ": " + t.error()};
    vol.emplace(std::move(*t));
    return {};
  };
  if (!o.device.empty()) {
    auto td = live_tooth_json(o.exercise, "", st.tooth_voxel_m * 1e3);
    if (!td) return Error{"live: " + td.error()};
    tooth_desc = *td;
    if (auto b = build_tooth(); !b) return Error{b.error()};
    haptics::DeviceOpenOptions dopt;
    dopt.name_or_serial = o.device_name;
    auto d = haptics::open_haptic_device(o.device, dopt);
    if (!d) return Error{"live: --device " + o.device + ": " + d.error()};
    device = std::move(*d);
    pedal_from_device = false;
    // Station health 4: can this device's stylus reach the crown of the tooth drilled from where
    // the station puts it?
    auto box = crown_box_tooth(tooth_desc);
    if (!box) return Error{"live: " + box.error()};
    const HealthItem reach = check_station_reach(st, device->limits(), device->name(), *box).item;
    health.set(reach);
    if (reach.level != HealthLevel::kOk) say("station health: " + reach.check + ": " + reach.message);
  } else if (o.stylus.rfind("replay:", 0) == 0) {
    const std::string path = o.stylus.substr(7);
    auto log = session::read_session_setup(path);
    if (!log) return Error{"live: --stylus: " + log.error()};
    const haptics::SessionSetup* setup = &log->setup;
    auto td = live_tooth_json(o.exercise, setup->tooth_json, st.tooth_voxel_m * 1e3);
    if (!td) return Error{"live: --stylus " + o.stylus + ": " + td.error()};
    tooth_desc = *td;
    if (auto t = training::make_tooth(tooth_desc); !t)
      return Error{"live: --stylus: " + path + ": header field tooth: " + t.error()};
    else
      vol.emplace(std::move(*t));
    if (vol->content_hash() != setup->volume_hash_start)
      return Error{"live: --stylus: " + path + ": the rebuilt tooth does not match the log's volume_hash_start"};
    bur_params = setup->bur;
    bur_samples = setup->bur_samples;
    cfg = setup->engine;
    device = std::make_unique<haptics::ReplayDevice>(std::move(log->records), setup->limits);
    pedal_from_device = true;
  } else {
    auto td = live_tooth_json(o.exercise, "", st.tooth_voxel_m * 1e3);
    if (!td) return Error{"live: " + td.error()};
    tooth_desc = *td;
    if (auto b = build_tooth(); !b) return Error{b.error()};
    haptics::DeviceLimits limits;
    if (o.stylus == "sim" || o.stylus == "none") {
      haptics::HandParams hand;
      hand.stiffness_N_per_m = haptics::kFingerRestStiffness_N_per_m;
      const haptics::Station hs{cfg.T_tooth_dev, cfg.T_sty_tip};
      // The simulated hand: without an exercise the molar's scripted access preparation
      // (haptics/scripts.h, as before); with one, an expert session of that exercise's steps
      // on its tooth, as the cohort generator scripts it (training/hand_script.h).
      std::vector<haptics::TipWaypoint> tips;
      if (o.stylus == "none") {
        // No stylus: the hand rests 25 mm above the tooth's origin, clear of every
        // exercise's crown, with the pedal up: the engine runs (and is timed), nothing cuts.
        // One waypoint, the bur pointing down the tooth's axis (-z of the tooth: the scripts' axis).
        tips = {haptics::TipWaypoint{0.0, Eigen::Vector3d(0, 0, 25e-3), Eigen::Vector3d(0, 0, -1), false}};
      } else if (o.exercise.empty()) {
        tips = haptics::tip_script("access", 3.0, 0);
      } else {
        auto ex = named_exercise(o.exercise);
        if (!ex) return Error{"live: " + ex.error()};
        training::HandOptions ho;
        ho.skill = o.hand_skill;
        ho.style = o.hand_style;
        ho.seed = o.hand_seed;
        auto t = training::hand_tip_script(*ex, *vol, ho);
        if (!t) return Error{"live: simulated hand: " + t.error()};
        tips = std::move(*t);
        if (!tips.empty()) hand_end_s = tips.back().time_s;
        if (!tips.empty() && !o.quiet)
          std::fprintf(stderr, "dentar live: the simulated hand (skill %.2f, style %.2f, seed %llu) works the exercise for %.1f s\n",
                       o.hand_skill, o.hand_style, static_cast<unsigned long long>(o.hand_seed), tips.back().time_s);
      }
      auto d = haptics::SimulatedDevice::create(haptics::to_hand_script(tips, hs), limits, hand);
      if (!d) return Error{"live: simulated hand: " + d.error()};
      device = std::move(*d);
      pedal_from_device = true;
    } else {  // pen
      if (st.pen.tags.empty())
        return Error{"live: --stylus pen: the station file has no pen (\"pen\".tags); print the kit with `dentar tags`"};
      auto p = std::make_unique<PenDevice>(limits);
      pen = p.get();
      device = std::move(p);
    }
  }
  // The exercise names its bur (the incisor's is a cone); a replay keeps the log's.
  if (!o.exercise.empty() && o.stylus.rfind("replay:", 0) != 0) {
    auto ex = named_exercise(o.exercise);
    if (!ex) return Error{"live: " + ex.error()};
    bur_params = ex->bur;
  }
  return ss;
}

// The engine's figures at the end of a run, into the summary.
void engine_figures(const haptics::EngineStats& es, LiveSummary& sum) {
  sum.engine_steps = es.steps;
  sum.missed_deadlines = es.missed_deadlines;
  sum.periods_skipped = es.periods_skipped;
  sum.watchdog_trips = es.watchdog_trips;
  sum.step_p50_us = es.compute.percentile_s(0.5) * 1e6;
  sum.step_p99_us = es.compute.percentile_s(0.99) * 1e6;
  sum.step_p999_us = es.compute.percentile_s(0.999) * 1e6;
  sum.step_max_us = es.compute.max_s() * 1e6;
  sum.jitter_p99_us = es.jitter.percentile_s(0.99) * 1e6;
  sum.jitter_max_us = es.jitter.max_s() * 1e6;
  sum.realtime_granted = es.realtime_granted;
  sum.cpu_pinned = es.cpu_pinned;
  if (es.wake.available || !es.wake.note.empty())
    sum.engine_wake_json = haptics::wake_stats_json(es.wake, haptics::WakeMonitor::Options{}.late_threshold_s);
}

// The recording closed: its writer joined, recording.json (as written at the
// start) completed (written aside, then renamed), and the run's summary beside it.
void finish_recording(session::Recorder& rec, const std::string& stop_reason, const haptics::EngineStats& es,
                      LiveSummary& sum) {
  session::Recorder* recorder = &rec;
  const fs::path rdir = rec.dir();
  recorder->log("stopped: " + stop_reason);
  recorder->close();
  if (recorder->dropped() > 0)
    sum.warnings.push_back("recording: " + std::to_string(recorder->dropped()) +
                           " frames not written (the writer fell more than " + std::to_string(session::Recorder::kMaxQueued) +
                           " frames behind, or the disk refused them): offline replay stops at the first gap");
  char hash[20];
  std::snprintf(hash, sizeof hash, "%016llx", static_cast<unsigned long long>(sum.volume_hash));
  nlohmann::json meta = nlohmann::json::parse(std::ifstream(rdir / "recording.json"), nullptr, false);
  if (!meta.is_object()) meta = nlohmann::json::object();  // its "started" is the run's start
  meta["complete"] = true;
  meta["frames"] = recorder->written();
  meta["frames_not_written"] = recorder->dropped();
  meta["frame_files"] = {{"jpg", recorder->written_jpg()}, {"png", recorder->written_png()},
                         {"ppm", recorder->written_ppm()}};
  if (meta.contains("stereo"))
    meta["frame_files_right"] = {{"jpg", recorder->written_right_jpg()}, {"png", recorder->written_right_png()},
                                 {"ppm", recorder->written_right_ppm()}};
  meta["volume_hash"] = hash;
  meta["engine_steps"] = es.steps;
  meta["stop_reason"] = stop_reason;
  std::ofstream(rdir / "recording.json.tmp") << meta.dump(2) << "\n";
  std::error_code ec;
  fs::rename(rdir / "recording.json.tmp", rdir / "recording.json", ec);
  std::ofstream(rdir / "summary.json") << sum.json();
}

// Everything but the engine off its CPU (threads made from now on inherit the
// mask), and memory locked with real time: what was done, for the summary.
std::string isolate_engine(const LiveOptions& o, const haptics::EngineConfig& cfg, int ncpu, LiveSummary& sum) {
  std::string iso;
  if (cfg.cpu >= 0 && ncpu > 1) {
    cpu_set_t others;
    CPU_ZERO(&others);
    for (int c = 0; c < ncpu; ++c)
      if (c != cfg.cpu) CPU_SET(c, &others);
    // Threads created from now on (capture, frame, mesher, recorder, llvmpipe's
    // rasteriser threads inside EGL) inherit this mask.
    if (pthread_setaffinity_np(pthread_self(), sizeof others, &others) == 0)
      iso += "other threads kept off CPU " + std::to_string(cfg.cpu) + "; ";
    if (!getenv("LP_NUM_THREADS")) setenv("LP_NUM_THREADS", std::to_string(std::max(1, ncpu - 1)).c_str(), 1);
  }
  if (o.realtime) {
    sum.memory_locked = mlockall(MCL_CURRENT | MCL_FUTURE) == 0;
    if (!sum.memory_locked)
      iso += std::string("mlockall refused (") + std::strerror(errno) +
             "): raise the memlock limit (ulimit -l unlimited, or memlock in /etc/security/limits.conf); ";
  }
  return iso;
}

// A recording's start (`--record DIR`): the run's recorder, the station as
// used, and recording.json as at the start (completed by finish_recording).
Status start_recording(const LiveOptions& o, const ar::StationScene& st, const ar::PipelineOptions& popt,
                       const std::string& discovery_name, session::Run& run) {
  const fs::path rdir = o.record_dir;
  if (auto r = run.record_to(rdir.string(), popt.stereo); !r) return Error{"live: " + r.error()};
  if (auto s = ar::write_station_scene(st, (rdir / "station.json").string()); !s)
    return Error{"live: " + s.error()};
  nlohmann::json rec_meta = {{"format", "dentar-recording"}, {"version", 1}, {"started", iso_now()},
              {"camera", o.camera}, {"stylus", o.stylus}, {"discovery", discovery_name},
              {"camera_response", ar::camera_response_name(popt.tracker.detector.response)},
              {"mirror_rim", popt.tracker.mirror_rim_refine}, {"predict_ms", popt.predict_s * 1e3},
              {"stereo_mirror_rim", popt.tracker.stereo_mirror_rim},
              {"jpeg_decode", o.camera_format == "bgr" ? "bgr" : "yuyv"},
              {"complete", false}};
  if (!o.exercise.empty()) rec_meta["exercise"] = o.exercise;
  // Stereo (issue 28): both eyes kept (frames_right/), replayed from both by `dentar offline`.
  if (popt.stereo) {
    rec_meta["stereo"] = {{"head", o.side_by_side ? "side_by_side" : "two_cameras"}};
    if (!o.side_by_side) rec_meta["stereo"]["camera_right"] = o.camera_right;
  }
  if (session::LessonClock* l = run.lesson()) {  // the lesson's exercise is the session's (the finish step scores it)
    rec_meta["exercise"] = l->lesson().exercise;
    rec_meta["lesson"] = {{"lesson", o.lesson}, {"path", l->lesson().path}, {"mode_asked", l->mode_asked()},
                          {"mode", l->mode_run()}, {"fallback", l->fallback()}};
  }
  if (o.stylus == "sim" && !o.exercise.empty())
    rec_meta["hand"] = {{"skill", o.hand_skill}, {"style", o.hand_style}, {"seed", o.hand_seed}};
  std::ofstream(rdir / "recording.json") << rec_meta.dump(2) << "\n";
  return {};
}

// Background threads (the tracker's full-frame search, tracker.h
// "Discovery"; capture with its decoding; the mesher) on the engine's CPU,
// at normal priority: the FIFO engine preempts them at once, and they use
// the ~85 % of that core the engine leaves idle instead of queueing with
// the frame thread and the display on the others.
struct Background {
  std::function<void()> to_engine_cpu;  // empty: with the frame thread
  std::string note;                     // why not beside the engine
  std::shared_ptr<std::atomic<int>> placed = std::make_shared<std::atomic<int>>(0);
  std::shared_ptr<std::atomic<int>> refused = std::make_shared<std::atomic<int>>(0);
};
Background place_background(const LiveOptions& o, const haptics::EngineConfig& cfg, int ncpu) {
  Background bg;
  // Beside the engine only when the engine will preempt them: without
  // SCHED_FIFO they would share its core equally and it would miss deadlines
  // (seen on a CI machine without CAP_SYS_NICE: 3 watchdog trips in 2 s).
  bool beside = o.background_cpu == "engine" && cfg.cpu >= 0 && ncpu > 1;
  if (beside) {
    std::string why;
    if (!o.realtime) {
      beside = false;
      bg.note = "background threads kept off the engine CPU (--no-realtime: the engine could not preempt them)";
    } else if (!haptics::realtime_available(cfg.realtime_priority, &why)) {
      beside = false;
      bg.note = "background threads kept off the engine CPU (SCHED_FIFO refused: " + why +
                "; the engine could not preempt them)";
    }
  }
  if (beside) {
    const int cpu = cfg.cpu;
    bg.to_engine_cpu = [cpu, placed = bg.placed, refused = bg.refused] {
      cpu_set_t one;
      CPU_ZERO(&one);
      CPU_SET(cpu, &one);
      // Normal (CFS) priority: below the FIFO engine whatever it is (SCHED_IDLE
      // would starve them whenever another process uses that core).
      if (pthread_setaffinity_np(pthread_self(), sizeof one, &one) == 0) ++*placed;
      else ++*refused;
    };
  }
  return bg;
}

// The display path asked for: "auto" asks the renderer first (a throw-away
// context on the default EGL platform, the one the compositor would get).
struct DisplayChoice {
  bool want_gl = false;
  std::string auto_note;
};
DisplayChoice choose_display(const LiveOptions& o) {
  DisplayChoice d;
  if (o.passthrough) {  // the frame itself is uploaded and swapped: there is no composite to keep on the GPU
    d.auto_note = "--passthrough: the camera's frame is uploaded as it came (no AR)";
    return d;
  }
  d.want_gl = o.display_path == "gl";
  if (o.display_path != "auto") return d;
  if (auto probe = ar::EglContext::create(); !probe) {
    d.auto_note = "--display-path auto: no EGL context to ask the renderer (" + probe.error() + ")";
  } else if (software_renderer(probe->gl_renderer())) {
    d.auto_note = "--display-path auto: " + probe->gl_renderer() +
                  " is a software rasteriser, where the CPU path measured faster (docs/BENCHMARKS.md)";
  } else {
    d.want_gl = true;
    d.auto_note = "--display-path auto: " + probe->gl_renderer() + " is a hardware renderer";
  }
  return d;
}

// Latency compensation (issue 24): the camera's latency (mid-exposure to
// Frame::steady_s) and where it came from.
std::pair<double, std::string> compensation(const LiveOptions& o, const ar::StationScene& st) {
  if (o.stylus == "pen" && o.device.empty()) return {0.0, "pen"};  // measured in the camera's own frames
  if (o.camera_latency_ms == 0) return {0.0, "off"};
  if (o.camera_latency_ms > 0) return {o.camera_latency_ms * 1e-3, "option"};
  if (st.camera_provenance.latency_ms >= 0)
    return {st.camera_provenance.latency_ms * 1e-3, st.camera_provenance.latency_ms > 0 ? "measured" : "off"};
  return {ar::kAssumedCameraLatency_ms * 1e-3, "assumed"};
}

// What the system granted the engine, and what to do when it did not.
std::string grant_message(const LiveOptions& o, const haptics::EngineConfig& cfg, haptics::Engine& engine,
                          const LiveSummary& sum, const std::string& iso, const std::string& discovery_name,
                          const Background& bg) {
  for (int i = 0; i < 100 && engine.snapshot().step == 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  std::string grant = "engine: ";
  if (!o.realtime) grant += "real time not asked (--no-realtime); ";
  else if (engine.realtime_granted_now()) grant += "SCHED_FIFO granted; ";
  else grant += "SCHED_FIFO refused: run as root, or `sudo setcap cap_sys_nice,cap_ipc_lock+ep dentar`, or an rtprio limit in /etc/security/limits.conf; ";
  if (cfg.cpu >= 0) grant += engine.cpu_pinned_now() ? "pinned to CPU " + std::to_string(cfg.cpu) + "; " : "not pinned (CPU " + std::to_string(cfg.cpu) + " refused); ";
  else grant += "not pinned; ";
  if (o.realtime) grant += sum.memory_locked ? "memory locked" : "memory not locked (raise `ulimit -l`)";
  grant += "; " + iso;
  grant += sum.wake_latency_note.empty() ? std::string() : "; " + sum.wake_latency_note;
  grant += "; tag discovery " + discovery_name;
  if (bg.to_engine_cpu)
    grant += "; " + std::to_string(bg.placed->load()) + " background threads (tag search, capture, mesher, GL rasteriser) on CPU " +
             std::to_string(cfg.cpu) + " below the engine" +
             (bg.refused->load() > 0 ? " (" + std::to_string(bg.refused->load()) + " refused)" : std::string());
  else if (!bg.note.empty())
    grant += "; " + bg.note;
  else
    grant += "; background threads with the frame thread";
  return grant;
}

// The start-up lines about the stylus pose and the camera response.
void say_stylus_pose(const LiveOptions& o, const ar::StationScene& st, const ar::PipelineOptions& popt, double comp_latency_s,
                     const std::string& comp_source, const std::function<void(const std::string&)>& say) {
  if (o.stylus != "none" || !o.device.empty()) {
    if (comp_source == "pen")
      say("stylus pose: the pen's, tracked in the camera's own frames (no latency compensation)");
    else if (comp_latency_s > 0)
      say("stylus pose drawn at each frame's exposure: capture time minus a camera latency of " +
          std::to_string(static_cast<int>(std::lround(comp_latency_s * 1e3))) + " ms (" +
          (comp_source == "measured" ? std::string("measured: the station's camera.latency_ms")
           : comp_source == "option" ? std::string("--camera-latency-ms")
                                     : std::string("assumed: not measured for this station; record it with "
                                                   "`dentar calibrate --camera-latency-ms MS`")) +
          ")");
    else
      say("stylus pose: the newest at each frame (latency compensation off)");
  }
  ar::TagDetectorOptions d = popt.tracker.detector;  // auto: the station's measured response
  if (const std::string note = ar::resolve_camera_response(d, st); !note.empty()) say("note: " + note);
}

// The display path's line for the terminal, the recording's log and the summary.
void report_display_path(const LiveOptions& o, bool gpu_display, bool want_gl, const std::string& auto_note,
                         const std::string& display_note, session::Recorder* recorder,
                         const std::function<void(const std::string&)>& say, LiveSummary& sum) {
  const std::string path_msg = gpu_display
      ? "display path gl: the composite stays on the GPU (window: OpenGL ES 3 over EGL; compositor's "
        "context shared with it; fenced hand-off; no readback)" + (auto_note.empty() ? "" : "; " + auto_note)
      : "display path cpu: the CPU composite is uploaded each frame (" + display_note + ")";
  say(path_msg);
  if (recorder) recorder->log(path_msg);
  if (want_gl && !gpu_display) sum.warnings.push_back("display: GPU path unavailable, CPU path used: " + display_note);
  sum.display_path = gpu_display ? "gl" : "cpu";
  sum.display_requested = o.display_path;
  sum.cpu_display_yuyv = o.cpu_display_yuyv;
  if (!o.camera_right.empty()) sum.capture_right_cpu = o.capture_right_cpu;
  sum.display_note = display_note;
}

// The run's figures into the summary, after the threads stopped.
void fill_summary(const LiveContext& c, const ar::CaptureThread& capture, std::int64_t processed, const FrameFigures& ff,
                  const DisplayFigures& df, const std::pair<double, std::string>& comp, const std::string& iso,
                  const Background& bg, LiveSummary& sum) {
  haptics::Engine& engine = *c.run.engine();
  const haptics::EngineStats es = engine.stats();
  sum.wall_s = ar::steady_now_s() - df.t_start;
  sum.stop_reason = df.stop_reason;
  sum.frames_captured = capture.delivered();
  sum.frames_processed = processed;
  sum.frames_displayed = df.displayed;
  sum.gpu_frames = ff.gpu_frames;
  sum.lesson_note_frames = ff.note_frames;
  sum.compensation_latency_ms = comp.first * 1e3;
  sum.compensation_source = comp.second;
  sum.frames_pose_at_exposure = ff.comp_at_exposure;
  sum.frames_pose_newest = ff.comp_newest;
  sum.stereo = c.popt.stereo;
  sum.stereo_both = ff.stereo_both;
  sum.stereo_left_only = ff.stereo_left_only;
  sum.stereo_right_only = ff.stereo_right_only;
  sum.note_both_eyes = ff.note_both_eyes;
  sum.note_missing_eye = ff.note_missing_eye;
  sum.right_composited = ff.right_composited;
  sum.stale_pairs_skipped = ff.stale_pairs_skipped;
  sum.stale_pairs_untaken = ff.stale_pairs_untaken;
  sum.eye_threads = ff.eye_threads > 0 ? ff.eye_threads : c.popt.eye_threads;  // after any fallback
  if (!ff.eye_thread_note.empty()) sum.warnings.push_back("stereo: " + ff.eye_thread_note);

  sum.stereo_fallbacks = ff.stereo_fallbacks;
  sum.stereo_recoveries = ff.stereo_recoveries;
  sum.stereo_fallback_ms_max = ff.stereo_fallback_ms_max;
  sum.stereo_fallback_frame_ms = ff.stereo_fallback_frame_ms;
  sum.stereo_fallback_wait_ms = ff.stereo_fallback_wait_ms;
  sum.stereo_recovery_ms_max = ff.stereo_recovery_ms_max;
  sum.readback_px = ff.readback_px;
  sum.cpu_blend_px = ff.cpu_blend_px;
  sum.gl_frames_replaced = ff.ring_replaced;
  sum.gl_ready_timeouts = ff.ring_ready_timeouts;
  sum.gl_release_timeouts = ff.ring_release_timeouts;
  sum.dropped_source = capture.dropped_source();
  sum.dropped_consumer = capture.dropped_consumer();
  sum.camera_reopens = capture.reopens();
  sum.corrupt_frames = capture.corrupt();
  sum.last_corrupt = capture.last_corrupt();
  sum.jpeg_decodes = capture.decodes();
  sum.jpeg_skipped_undecoded = capture.skipped_undecoded();
  sum.jpeg_decode = c.o.jpeg_decode;
  sum.displayed_fps = sum.wall_s > 0 ? df.displayed / sum.wall_s : 0;
  sum.idle_draws = df.idle_draws;
  sum.idle_skipped = df.idle_skipped;
  sum.latency_p50_ms = percentile(df.latency_ms, 0.5);
  sum.latency_p99_ms = percentile(df.latency_ms, 0.99);
  sum.latency_max_ms = df.latency_ms.empty() ? 0 : *std::max_element(df.latency_ms.begin(), df.latency_ms.end());
  sum.process_p50_ms = percentile(ff.process_ms, 0.5);
  sum.process_p99_ms = percentile(ff.process_ms, 0.99);
  sum.stage_ms.emplace_back("process", sum.process_p50_ms, sum.process_p99_ms);
  for (const auto& [name, t] : ff.stage_ms)
    if (t.n > 0) sum.stage_ms.emplace_back(name, t.percentile(0.5), t.percentile(0.99));
  for (const auto& [name, t] : {std::pair<const char*, const StageTimes*>{"to_display", &df.to_display_ms},
                                {"display", &df.display_ms}})
    if (t->n > 0) sum.stage_ms.emplace_back(name, t->percentile(0.5), t->percentile(0.99));
  for (const auto& [name, t] : df.display_parts_ms)
    if (t.n > 0) sum.stage_ms.emplace_back(name, t.percentile(0.5), t.percentile(0.99));
  engine_figures(es, sum);
  sum.isolation_note = iso + es.realtime_note + (bg.note.empty() ? std::string() : "; " + bg.note);
  sum.volume_hash = c.run.volume().content_hash();
  const haptics::HapticSnapshot last = engine.snapshot();
  sum.removed_enamel_mm3 = last.removed_mm3[static_cast<int>(volume::Material::kEnamel)];
  sum.removed_dentin_mm3 = last.removed_mm3[static_cast<int>(volume::Material::kDentin)];
  sum.removed_pulp_mm3 = last.removed_mm3[static_cast<int>(volume::Material::kPulp)];
  for (double v : last.removed_mm3) sum.removed_total_mm3 += v;
  sum.rss_end_mb = rss_mb();
  if (!sum.realtime_granted && c.o.realtime) sum.warnings.push_back("engine: " + es.realtime_note);
  for (const auto& it : c.health.health().items) {
    sum.station_health.push_back(std::string(health_level_name(it.level)) + ": " + it.check + ": " + it.message);
    if (it.level != HealthLevel::kOk) sum.warnings.push_back("station health: " + it.check + ": " + it.message);
  }
  sum.instructor_needed = c.health.health().instructor_needed();
  if (session::LessonClock* l = c.run.lesson()) {
    sum.lesson = c.o.lesson;
    sum.lesson_mode_asked = l->mode_asked();
    sum.lesson_mode = l->mode_run();
    sum.lesson_fallback = l->fallback();
    if (!l->fallback().empty()) sum.warnings.push_back("lesson: " + l->fallback());
    sum.lesson_expert_s = last.expert_time_s;
    sum.lesson_expert_end_s = l->track().duration_s();
    sum.lesson_waiting_pct = df.passes > 0 ? 100.0 * df.passes_expert_waiting / df.passes : 0.0;
    if (c.lesson_pauses) {
      sum.lesson_pauses_taken = c.lesson_pauses->pauses_taken();
      sum.lesson_paused_s = c.lesson_pauses->paused_s();
      sum.lesson_pauses_resumed_by_button = c.lesson_pauses->resumed_by_button();
      sum.lesson_pauses_resumed_by_key = c.lesson_pauses->resumed_by_key();
    }
    for (const DisplayFigures::Note& n : df.notes) {
      const training::Annotation& a = l->lesson().annotations[static_cast<std::size_t>(n.annotation)];
      sum.lesson_notes.push_back({a.time_s, n.expert_s, n.expert_s_before, n.run_s, a.text});
    }
    sum.follow_samples = static_cast<std::int64_t>(df.follow_m.size());
    if (!df.follow_m.empty()) {
      double m = 0;
      for (double e : df.follow_m) m += e;
      sum.follow_mean_mm = m / df.follow_m.size() * 1e3;
      sum.follow_p95_mm = percentile(df.follow_m, 0.95) * 1e3;
      sum.follow_max_mm = *std::max_element(df.follow_m.begin(), df.follow_m.end()) * 1e3;
    }
  }
}

}  // namespace

Result<LiveSummary> run_live(const LiveOptions& o) {
  if (auto v = o.validate(); !v.empty()) return Error{"live: " + v};
  // SIGINT/SIGTERM from here on end the run cleanly (zero force, logs,
  // recording), also when they arrive during the set-up below.
  g_signal.store(0);
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  LiveSummary sum;
  sum.rss_start_mb = rss_mb();
  auto say = [&](const std::string& s) {
    if (!o.quiet) std::fprintf(stderr, "dentar live: %s\n", s.c_str());
  };
  // ---- station, camera, station health (file checks now, tags and stylus tip per frame) ----
  auto scr = open_station_and_camera(o, sum, say);
  if (!scr) return Error{scr.error()};
  const ar::StationScene& st = scr->st;
  StationHealthMonitor health(st, scr->builtin, static_cast<double>(std::time(nullptr)), camera_identity(o.camera));
  if (auto r = health.refusal()) return Error{"live: " + o.station + ": " + r->message};
  for (const auto& it : health.health().items)
    if (it.level != HealthLevel::kOk) say("station health: " + it.check + ": " + it.message);
  // ---- tooth, stylus, pedal: the run ----
  auto ssr = make_stylus(o, st, health, say);
  if (!ssr) return Error{ssr.error()};
  StylusSetup& ss = *ssr;
  auto bur = volume::sample_bur(ss.bur_params, ss.bur_samples);
  if (!bur) return Error{"live: bur: " + bur.error()};
  haptics::ManualPedal key_pedal;
  std::unique_ptr<haptics::Pedal> usb_pedal;
  if (o.pedal != "keyboard") {
    auto p = haptics::open_pedal(o.pedal);
    if (!p) return Error{"live: --pedal " + o.pedal + ": " + p.error()};
    usb_pedal = std::move(*p);
  }
  const haptics::Pedal& pedal = usb_pedal ? *usb_pedal : static_cast<const haptics::Pedal&>(key_pedal);
  haptics::PedalDevice pedal_device(*ss.device, pedal, ss.pedal_from_device);
  std::unique_ptr<session::Run> run = session::Run::from_tooth(std::move(*ss.vol), std::move(*bur));
  run->set_lesson(std::move(ss.lesson));  // its training mode becomes the engine's
  // A lesson's pause points hold the pause button in front of the engine (recorded, replayed).
  std::optional<session::LessonPauseDevice> lesson_pauses;
  if (run->lesson()) lesson_pauses.emplace(pedal_device, run->lesson()->lesson().annotations);
  haptics::HapticDevice& engine_device =
      lesson_pauses ? static_cast<haptics::HapticDevice&>(*lesson_pauses) : static_cast<haptics::HapticDevice&>(pedal_device);
  haptics::EngineConfig& cfg = ss.cfg;
  const int ncpu = static_cast<int>(std::max(1L, sysconf(_SC_NPROCESSORS_ONLN)));
  cfg.cpu = o.engine_cpu == -2 ? (ncpu > 1 ? ncpu - 1 : -1) : o.engine_cpu;
  // Issue 28 session 23: the threads' CPUs by hand (cpu_layout.h), checked against this machine.
  CpuLayout lay;
  if (std::string e = parse_cpu_layout(o.cpu_layout, ncpu, lay); !e.empty())
    return Error{"live: --cpu-layout" + e.substr(std::string("cpu_layout").size())};
  using CL = CpuLayout;
  if (lay.set(CL::kEngine)) cfg.cpu = lay.of(CL::kEngine)[0];
  if (!lay.empty() && cfg.cpu >= 0) {
    // A thread placed on the engine's CPU must be one the engine preempts (place_background's rule).
    for (int r = CL::kFrame; r < CL::kRoles; ++r) {
      const auto& cpus = lay.of(static_cast<CL::Role>(r));
      if (std::find(cpus.begin(), cpus.end(), cfg.cpu) == cpus.end()) continue;
      std::string why = "--no-realtime";
      if (!o.realtime || !haptics::realtime_available(cfg.realtime_priority, &why))
        return Error{std::string("live: --cpu-layout: ") + CL::name(static_cast<CL::Role>(r)) +
                     " shares the engine's CPU " + std::to_string(cfg.cpu) + ", but the engine cannot run SCHED_FIFO (" +
                     why + "): it could not preempt that thread"};
    }
  }
  sum.cpu_layout = lay.text();
  cfg.try_realtime = o.realtime;
  cfg.monitor_wakes = o.wake_monitor;
  // ---- isolation: everything but the engine off its core; memory locked ----
  const std::string iso = isolate_engine(o, cfg, ncpu, sum);
  // The engine's wake-ups: idle CPUs poll rather than halt while the run lasts (see LiveOptions).
  WakeLatencyHold wake_hold(o.cpu_wake_latency_us);
  sum.wake_latency_held = wake_hold.held();
  sum.wake_latency_note = wake_hold.note();
  if (o.cpu_wake_latency_us >= 0 && !wake_hold.held()) sum.warnings.push_back("engine: " + wake_hold.note());
  const int idle_cpu = cfg.cpu >= 0 ? cfg.cpu : 0;
  const auto idle0 = cpu_idle_entries(idle_cpu);
  const double idle_t0 = ar::steady_now_s();
  ar::PipelineOptions popt = o.pipeline;
  popt.compositor.bur = ss.bur_params;  // draw the bur the engine cuts with
  // Stereo (issue 28): both eyes through the StereoTracker, whose tag search runs inside the frame.
  popt.stereo = o.side_by_side || !o.camera_right.empty();
  if (popt.stereo) popt.tracker.discovery = ar::DiscoveryMode::kInline;
  const std::string discovery_name = ar::discovery_mode_name(popt.tracker.discovery);
  const Background bg = place_background(o, cfg, ncpu);
  if (bg.to_engine_cpu) popt.tracker.discovery_thread_init = bg.to_engine_cpu;
  // Issue 28 (session 17): a stereo pair into the headset, the right eye on a thread of its own.
  popt.eye_threads = popt.stereo && o.output == "sbs" ? o.eye_threads : 1;
  if (lay.set(CL::kEye)) {
    popt.eye_thread_init = [cpus = lay.of(CL::kEye)] { pin_this_thread(cpus); };
  } else if (o.eye_thread_cpu == "engine") {
    popt.eye_thread_init = bg.to_engine_cpu;  // empty (not beside the engine): the frame thread's CPUs
  } else if (o.eye_thread_cpu == "any" && bg.to_engine_cpu) {  // only where the FIFO engine preempts it
    popt.eye_thread_init = [ncpu] {
      cpu_set_t all;
      CPU_ZERO(&all);
      for (int c = 0; c < ncpu; ++c) CPU_SET(c, &all);
      pthread_setaffinity_np(pthread_self(), sizeof all, &all);
    };
  }
  // ---- recording, engine ----
  if (!o.record_dir.empty())
    if (auto s = start_recording(o, st, popt, discovery_name, *run); !s) return Error{s.error()};
  const std::string log_path = run->recorder() ? (fs::path(o.record_dir) / "session.dlog").string() : std::string();
  if (auto s = run->make_engine(cfg, engine_device, ss.tooth_desc, log_path); !s) return Error{"live: " + s.error()};
  haptics::Engine& engine = *run->engine();
  if (ss.student) ss.student->attach(&engine);  // the simulated student sees the expert's tool
  if (lesson_pauses) lesson_pauses->attach(&engine);  // the pause points follow the expert's clock
  // ---- window ----
  const DisplayChoice dc = choose_display(o);
  // GPU path: the window's EGL display is the one the compositor shares, so
  // llvmpipe's rasteriser threads (one set per display, started when GLFW
  // initialises it here) serve both contexts and run with the main thread,
  // off the engine's CPU (docs/BENCHMARKS.md, "The GL-resident display path").
  // --window-raster-cpu any (auto: with --output sbs; issue 28, session 17): that rasteriser made with every CPU in its
  // mask (only where the FIFO engine preempts it), the main thread's mask restored after.
  cpu_set_t main_mask;
  const bool raster_any = o.window_raster_cpu == "any" || (o.window_raster_cpu == "auto" && o.output == "sbs");
  const bool widen = (lay.set(CL::kRaster) || (raster_any && bg.to_engine_cpu)) &&
                     pthread_getaffinity_np(pthread_self(), sizeof main_mask, &main_mask) == 0;
  if (widen && lay.set(CL::kRaster)) {
    pin_this_thread(lay.of(CL::kRaster));  // --cpu-layout raster=: the rasteriser inherits it
  } else if (widen) {
    cpu_set_t all;
    CPU_ZERO(&all);
    for (int cpu = 0; cpu < ncpu; ++cpu) CPU_SET(cpu, &all);
    pthread_setaffinity_np(pthread_self(), sizeof all, &all);
  }
  auto hw_r = HudWindow::open("DentAR live", scr->eye_w, scr->eye_h, o.window_width, o.window_height,
                              o.display, o.vsync, dc.want_gl && !o.window_glx_for_test);
  if (widen) pthread_setaffinity_np(pthread_self(), sizeof main_mask, &main_mask);
  if (!hw_r) return Error{"live: " + hw_r.error()};
  HudWindow& hw = **hw_r;
  const auto comp = compensation(o, st);
  const LiveContext ctx{o, st, popt, *run, health, hw, engine_device, pedal, key_pedal, ss.pen, ss.pedal_from_device,
                        scr->eye_w, scr->eye_h, dc.want_gl, bg.to_engine_cpu, comp.first, say,
                        lesson_pauses ? &*lesson_pauses : nullptr, lay};
  LiveShared sh;
  // The display path is settled on the frame thread (the shared context is made there).
  if (!dc.want_gl) sh.display_note = dc.auto_note.empty() ? "--display-path cpu" : dc.auto_note;
  else if (o.window_glx_for_test) sh.display_note = "the window's context is desktop OpenGL through GLX (test hook), which cannot share with EGL";
  else if (!hw.gles_egl()) sh.display_note = hw.context_note();
  else sh.display_note = dc.auto_note;  // empty unless chosen by auto; a fallback replaces it
  // ---- threads ----
  // Reopen the source after the slow set-up (tooth, window): a paced stand-in
  // starts its clock at open, and a camera's first frames would be stale.
  scr->src.reset();
  FrameFigures ff;
  std::thread frame_thread([&] { frame_thread_main(ctx, sh, ff); });
  while (sh.pipeline_ready.load() == 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  if (sh.pipeline_ready.load() < 0) {
    frame_thread.join();
    return Error{"live: " + sh.pipeline_error};
  }
  auto src2 = ar::FrameSource::open(o.camera, scr->so);
  if (!src2) {
    sh.stop.store(true);
    frame_thread.join();
    return Error{"live: " + src2.error()};
  }
  ar::CaptureThreadOptions cto;
  cto.reopen = o.loop || o.camera.rfind("live:", 0) != 0;  // footage ends (unless looped); a camera comes back
  cto.stall_after_frames = o.stall_after_frames;
  cto.stall_s = o.stall_s;
  cto.eager_decode = o.jpeg_decode == "eager";  // session 21: the newest packet, on the capture side
  // Named for the summary's CPU per thread (session 19).
  cto.thread_init = [init = bg.to_engine_cpu, cpus = lay.of(CL::kCaptureLeft)] {
    pthread_setname_np(pthread_self(), "dentar-cap-l");
    if (!cpus.empty()) pin_this_thread(cpus);  // --cpu-layout capture-l=
    else if (init) init();
  };
  ar::CaptureThread capture(std::move(*src2), o.camera, scr->so, cto);
  // Stereo with two cameras (issue 28): the right eye on its own capture thread; the frame
  // thread pairs its newest frame with each left frame by capture time.
  std::unique_ptr<ar::CaptureThread> capture_right;
  if (!o.camera_right.empty()) {
    auto src_r = ar::FrameSource::open(o.camera_right, scr->so);
    if (!src_r) {
      sh.stop.store(true);
      frame_thread.join();
      return Error{"live: --camera-right: " + src_r.error()};
    }
    ar::CaptureThreadOptions cto_r = cto;
    cto_r.reopen = o.loop || o.camera_right.rfind("live:", 0) != 0;
    cto_r.stall_after_frames = o.stall_right_after_frames;
    cto_r.stall_s = o.stall_right_s;
    // Session 22 (--capture-right-cpu): beside the engine as the left camera's (default), or on
    // the frame thread's CPUs (the mask this thread was made with), or on any.
    cto_r.thread_init = [init = bg.to_engine_cpu, where = o.capture_right_cpu, ncpu, cpus = lay.of(CL::kCaptureRight)] {
      pthread_setname_np(pthread_self(), "dentar-cap-r");
      if (!cpus.empty()) {
        pin_this_thread(cpus);  // --cpu-layout capture-r=
      } else if (where == "engine" && init) {
        init();
      } else if (where == "any" && init) {
        cpu_set_t all;
        CPU_ZERO(&all);
        for (int c = 0; c < ncpu; ++c) CPU_SET(c, &all);
        pthread_setaffinity_np(pthread_self(), sizeof all, &all);
      }
    };
    capture_right = std::make_unique<ar::CaptureThread>(std::move(*src_r), o.camera_right, scr->so, cto_r);
  }
  const std::string stylus_desc = o.device.empty() ? "stylus " + o.stylus : "device " + pedal_device.name();
  if (run->recorder())
    run->recorder()->log("camera " + capture.description() + "; " + stylus_desc + "; pedal " + pedal.name() +
                         "; engine CPU " + std::to_string(cfg.cpu));
  capture.start();
  if (capture_right) {
    capture_right->start();
    sh.capture_right.store(capture_right.get());
  }
  sh.capture.store(&capture);
  if (auto s = engine.start(); !s) {
    sh.stop.store(true);
    capture.stop();
    frame_thread.join();
    return Error{"live: engine: " + s.error()};
  }
  // The drill's sound reads the snapshot on its own thread (off the engine's CPU, as this one).
  std::shared_ptr<void> sound;
  if (o.start_sound) sound = o.start_sound([&engine] { return engine.snapshot(); });
  // --cpu-layout display= (session 23): the main thread last, so no thread made above inherits it.
  if (lay.set(CL::kDisplay)) pin_this_thread(lay.of(CL::kDisplay));
  DisplayInputs din{capture, hud_sound_line(static_cast<bool>(o.start_sound), sound != nullptr, o.sound_muted, o.sound_detail),
                    grant_message(o, cfg, engine, sum, iso, discovery_name, bg)};
  say("camera " + capture.description() + "; " + stylus_desc + "; pedal " + pedal.name());
  say_stylus_pose(o, st, popt, comp.first, comp.second, say);
  say(din.grant);
  if (run->recorder()) run->recorder()->log(din.grant);
  din.rt_ok = !o.realtime || (engine.realtime_granted_now() && sum.memory_locked);
  din.hand_end_s = ss.hand_end_s;
  din.lesson_end_s = run->lesson() ? run->lesson()->track().duration_s() : 0;
  din.rate_hz = cfg.rate_hz;
  din.signal = &g_signal;
  report_display_path(o, sh.gl_path.load(), dc.want_gl, dc.auto_note, sh.display_note, run->recorder(), say, sum);
  // ---- display loop (main thread) ----
  const DisplayFigures df = display_loop(ctx, sh, din, sum);
  // ---- shutdown: zero force first, then the logs, then the recording ----
  engine.stop();  // the engine's last act is a zero force
  if (run->recorder()) run->recorder()->log("engine stopped: zero force sent (" + df.stop_reason + ")");
  say("stopping (" + df.stop_reason + "): force zeroed");
  sh.stop.store(true);
  capture.stop();
  if (capture_right) capture_right->stop();
  frame_thread.join();
  if (capture_right) {
    sum.right_eye_dropped = capture_right->dropped_source() + capture_right->dropped_consumer();
    sum.right_eye_reopens = capture_right->reopens();
    sum.right_jpeg_decodes = capture_right->decodes();
    sum.right_jpeg_skipped_undecoded = capture_right->skipped_undecoded();
  }
  if (auto s = run->close_session_log(); !s) sum.warnings.push_back("session log: " + s.error());
  fill_summary(ctx, capture, sh.processed.load(), ff, df, comp, iso, bg, sum);
  if (const auto idle1 = cpu_idle_entries(idle_cpu); idle0.first >= 0 && idle1.first >= 0) {
    const double dt = std::max(1e-3, ar::steady_now_s() - idle_t0);
    sum.engine_cpu_polls_per_s = (idle1.first - idle0.first) / dt;
    sum.engine_cpu_halts_per_s = (idle1.second - idle0.second) / dt;
  }
  if (run->recorder()) finish_recording(*run->recorder(), df.stop_reason, engine.stats(), sum);
  if (!o.summary_path.empty()) std::ofstream(o.summary_path) << sum.json();
  return sum;
}

}  // namespace dentar::live
