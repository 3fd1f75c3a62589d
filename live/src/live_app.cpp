// dentar live: threads, engine, window and recording. See live_app.h.
#include "dentar/live/live_app.h"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <pthread.h>
#include <sched.h>
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
#include "dentar/training/exercise.h"
#include "dentar/training/hand_script.h"
#include "dentar/session/frames_csv.h"
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

double now_s() { return ar::steady_now_s(); }

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(std::min<double>(v.size() - 1, std::ceil(q * (v.size() - 1))));
  return v[i];
}

double rss_mb() {
  std::ifstream f("/proc/self/statm");
  long pages = 0, rss = 0;
  f >> pages >> rss;
  return static_cast<double>(rss) * static_cast<double>(sysconf(_SC_PAGESIZE)) / 1e6;
}

std::string iso_now() {
  const std::time_t t = std::time(nullptr);
  char b[32];
  std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return b;
}

// What the frame thread hands the window: the newest composite and its raw
// frame (shown without overlay when the camera stalls).
struct Shown {
  cv::Mat composite, raw;  // composite empty when the GPU path drew it (gpu)
  bool gpu = false;
  std::int64_t index = -1;  // recording index (frames processed)
  double steady_s = 0;      // capture time
  ar::FrameRecord rec;
  std::string error;
};

}  // namespace

std::string LiveOptions::validate() const {
  if (camera.empty()) return "camera is empty: give --camera camera:N, /dev/videoN or live:PATH";
  if (width < 0 || height < 0 || fps < 0) return "camera mode (--width/--height/--fps) must be >= 0";
  if (pedal.empty()) return "pedal is empty: give keyboard, auto, vec, usb:VID:PID or evdev:/dev/input/eventN";
  if (!(stylus == "sim" || stylus == "pen" || stylus == "none" || stylus.rfind("replay:", 0) == 0))
    return "stylus = \"" + stylus + "\" must be sim, pen, none or replay:FILE.dlog";
  if (stylus == "replay:") return "stylus = replay: needs a session log path (replay:FILE.dlog)";
  if (display < -1 || display > 16) return "display = " + std::to_string(display) + " must be -1 (window) or a monitor 0..16";
  if (window_width < 0 || window_height < 0 || window_width > 8192 || window_height > 8192)
    return "window size must be within 0..8192";
  if (!(std::isfinite(seconds) && seconds >= 0)) return "seconds must be >= 0";
  if (frames < 0) return "frames = " + std::to_string(frames) + " must be >= 0 (0 = no limit)";
  if (!(std::isfinite(camera_latency_ms) && camera_latency_ms <= 1000))
    return "camera_latency_ms must be <= 1000 ms (< 0: the station's, 0: no compensation)";
  if (engine_cpu < -2 || engine_cpu > 1023) return "engine_cpu must be -2 (last CPU), -1 (none) or a CPU index";
  if (stall_after_frames < 0 || !(stall_s >= 0)) return "stall hook values must be >= 0";
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
  if (pipeline.tracker.discovery == ar::DiscoveryMode::kScheduled)
    return "pipeline.tracker.discovery = scheduled is for replays (dentar offline), not a live run";
  if (auto v = pipeline.validate(); !v.empty()) return "pipeline: " + v;
  return {};
}

std::string LiveSummary::json() const {
  char hash[20];
  std::snprintf(hash, sizeof hash, "%016llx", static_cast<unsigned long long>(volume_hash));
  nlohmann::json j = {
      {"frames", {{"captured", frames_captured}, {"processed", frames_processed}, {"displayed", frames_displayed},
                  {"dropped_source", dropped_source}, {"dropped_consumer", dropped_consumer},
                  {"camera_reopens", camera_reopens}}},
      {"wall_s", wall_s},
      {"stop_reason", stop_reason},
      {"displayed_fps", displayed_fps},
      {"latency_ms", {{"p50", latency_p50_ms}, {"p99", latency_p99_ms}, {"max", latency_max_ms}}},
      {"latency_compensation", {{"camera_latency_ms", compensation_latency_ms}, {"source", compensation_source},
                                {"frames_pose_at_exposure", frames_pose_at_exposure},
                                {"frames_pose_newest", frames_pose_newest}}},
      {"process_ms", {{"p50", process_p50_ms}, {"p99", process_p99_ms}}},
      {"engine", {{"steps", engine_steps}, {"missed_deadlines", missed_deadlines}, {"watchdog_trips", watchdog_trips},
                  {"step_us", {{"p50", step_p50_us}, {"p99", step_p99_us}, {"p999", step_p999_us}, {"max", step_max_us}}},
                  {"jitter_us", {{"p99", jitter_p99_us}, {"max", jitter_max_us}}},
                  {"realtime_granted", realtime_granted}, {"cpu_pinned", cpu_pinned},
                  {"memory_locked", memory_locked}, {"isolation", isolation_note}}},
      {"volume_hash", hash},
      {"removed_mm3", {{"enamel", removed_enamel_mm3}, {"dentin", removed_dentin_mm3},
                       {"pulp", removed_pulp_mm3}, {"total", removed_total_mm3}}},
      {"rss_mb", {{"start", rss_start_mb}, {"after_10s", rss_warm_mb}, {"end", rss_end_mb},
                  {"growth_after_10s", rss_warm_mb > 0 ? rss_end_mb - rss_warm_mb : 0.0},
                  {"after_60s", rss_60s_mb}, {"max_after_60s", rss_max_after_60s_mb},
                  {"growth_after_60s", rss_60s_mb > 0 ? rss_end_mb - rss_60s_mb : 0.0}}},
      {"overlay_hidden_ms_after_stall", overlay_hidden_ms_after_stall},
      {"stall_previous_check_ms", stall_previous_check_ms},
      {"display", {{"path", display_path}, {"requested", display_requested}, {"note", display_note}, {"gpu_frames", gpu_frames},
                   {"readback_px", readback_px}, {"cpu_blend_px", cpu_blend_px},
                   {"gl_frames_replaced", gl_frames_replaced}, {"gl_ready_timeouts", gl_ready_timeouts},
                   {"gl_release_timeouts", gl_release_timeouts}}},
      {"station_health", {{"instructor_needed", instructor_needed}, {"items", station_health}}},
      {"warnings", warnings}};
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
  {
    auto& cam = st.calibration.camera;
    const int W = (*src)->width(), H = (*src)->height();
    // Side-by-side stereo (a station with a stereo rig, two eyes of its camera's size in one
    // frame): live tracks one camera; scaling that frame as one image would be wrong.
    if (st.stereo.present && W == 2 * cam.width && H == cam.height)
      return Error{"live: " + o.camera + " delivers side-by-side stereo frames (" + std::to_string(W) + "x" +
                   std::to_string(H) + ", two " + std::to_string(cam.width) + "x" + std::to_string(cam.height) +
                   " eyes, the station's \"stereo\" rig): dentar live tracks one camera; stereo footage is read by "
                   "`dentar track --stereo` (issue 28). Play mono footage here (dentar synth without --stereo)"};
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
};
Result<StylusSetup> make_stylus(const LiveOptions& o, const ar::StationScene& st, StationHealthMonitor& health,
                                const std::function<void(const std::string&)>& say) {
  // ---- tooth, stylus, engine ----
  StylusSetup ss;
  std::optional<volume::VoxelVolume>& vol = ss.vol;
  volume::BurParams& bur_params = ss.bur_params;
  int& bur_samples = ss.bur_samples;
  std::unique_ptr<haptics::HapticDevice>& device = ss.device;
  PenDevice*& pen = ss.pen;
  haptics::EngineConfig& cfg = ss.cfg;
  cfg.model = o.model;
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
      if (o.exercise.empty()) {
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
  sum.watchdog_trips = es.watchdog_trips;
  sum.step_p50_us = es.compute.percentile_s(0.5) * 1e6;
  sum.step_p99_us = es.compute.percentile_s(0.99) * 1e6;
  sum.step_p999_us = es.compute.percentile_s(0.999) * 1e6;
  sum.step_max_us = es.compute.max_s() * 1e6;
  sum.jitter_p99_us = es.jitter.percentile_s(0.99) * 1e6;
  sum.jitter_max_us = es.jitter.max_s() * 1e6;
  sum.realtime_granted = es.realtime_granted;
  sum.cpu_pinned = es.cpu_pinned;
}

// The recording closed: its writer joined, recording.json completed (written
// aside, then renamed), and the run's summary beside it.
void finish_recording(session::Recorder& rec, const nlohmann::json& rec_meta, const std::string& stop_reason,
                      const haptics::EngineStats& es, const fs::path& rdir, LiveSummary& sum) {
  session::Recorder* recorder = &rec;
  recorder->log("stopped: " + stop_reason);
  recorder->close();
  if (recorder->dropped() > 0)
    sum.warnings.push_back("recording: " + std::to_string(recorder->dropped()) +
                           " frames not written (the writer fell more than " + std::to_string(session::Recorder::kMaxQueued) +
                           " frames behind, or the disk refused them): offline replay stops at the first gap");
  char hash[20];
  std::snprintf(hash, sizeof hash, "%016llx", static_cast<unsigned long long>(sum.volume_hash));
  nlohmann::json meta = rec_meta;  // its "started" is the run's start
  meta["complete"] = true;
  meta["frames"] = recorder->written();
  meta["frames_not_written"] = recorder->dropped();
  meta["frame_files"] = {{"jpg", recorder->written_jpg()}, {"png", recorder->written_png()},
                         {"ppm", recorder->written_ppm()}};
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

// A recording's start (`--record DIR`): the writer, the station as used, and
// recording.json as at the start (completed by finish_recording).
Status start_recording(const LiveOptions& o, const ar::StationScene& st, const ar::PipelineOptions& popt,
                       const std::string& discovery_name, std::unique_ptr<session::Recorder>& recorder,
                       nlohmann::json& rec_meta) {
  const fs::path rdir = o.record_dir;
  auto r = session::Recorder::open(rdir);
  if (!r) return Error{"live: " + r.error()};
  recorder = std::move(*r);
  if (auto s = ar::write_station_scene(st, (rdir / "station.json").string()); !s)
    return Error{"live: " + s.error()};
  rec_meta = {{"format", "dentar-recording"}, {"version", 1}, {"started", iso_now()},
              {"camera", o.camera}, {"stylus", o.stylus}, {"discovery", discovery_name},
              {"camera_response", ar::camera_response_name(popt.tracker.detector.response)},
              {"mirror_rim", popt.tracker.mirror_rim_refine}, {"complete", false}};
  if (!o.exercise.empty()) rec_meta["exercise"] = o.exercise;
  if (o.stylus == "sim" && !o.exercise.empty())
    rec_meta["hand"] = {{"skill", o.hand_skill}, {"style", o.hand_style}, {"seed", o.hand_seed}};
  std::ofstream(rdir / "recording.json") << rec_meta.dump(2) << "\n";
  return {};
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

  // ---- station, camera ----
  auto scr = open_station_and_camera(o, sum, say);
  if (!scr) return Error{scr.error()};
  ar::StationScene& st = scr->st;
  const bool builtin = scr->builtin;
  const ar::FrameSourceOptions so = scr->so;
  std::unique_ptr<ar::FrameSource>& src = scr->src;

  // ---- station health (station_health.h): file checks now, tags and stylus tip per frame ----
  StationHealthMonitor health(st, builtin, static_cast<double>(std::time(nullptr)), camera_identity(o.camera));
  if (auto r = health.refusal()) return Error{"live: " + o.station + ": " + r->message};
  for (const auto& it : health.health().items)
    if (it.level != HealthLevel::kOk) say("station health: " + it.check + ": " + it.message);

  // ---- tooth, stylus, engine ----
  auto ssr = make_stylus(o, st, health, say);
  if (!ssr) return Error{ssr.error()};
  StylusSetup& ss = *ssr;
  std::optional<volume::VoxelVolume>& vol = ss.vol;
  volume::BurParams& bur_params = ss.bur_params;
  std::unique_ptr<haptics::HapticDevice>& device = ss.device;
  PenDevice* pen = ss.pen;
  haptics::EngineConfig& cfg = ss.cfg;
  const std::string& tooth_desc = ss.tooth_desc;
  const bool pedal_from_device = ss.pedal_from_device;
  const double hand_end_s = ss.hand_end_s;
  haptics::ManualPedal key_pedal;
  auto bur = volume::sample_bur(bur_params, ss.bur_samples);
  if (!bur) return Error{"live: bur: " + bur.error()};
  std::unique_ptr<haptics::Pedal> usb_pedal;
  if (o.pedal != "keyboard") {
    auto p = haptics::open_pedal(o.pedal);
    if (!p) return Error{"live: --pedal " + o.pedal + ": " + p.error()};
    usb_pedal = std::move(*p);
  }
  const haptics::Pedal& pedal = usb_pedal ? *usb_pedal : static_cast<const haptics::Pedal&>(key_pedal);
  haptics::PedalDevice pedal_device(*device, pedal, pedal_from_device);
  haptics::HapticDevice& engine_device = pedal_device;
  const int ncpu = static_cast<int>(std::max(1L, sysconf(_SC_NPROCESSORS_ONLN)));
  cfg.cpu = o.engine_cpu == -2 ? (ncpu > 1 ? ncpu - 1 : -1) : o.engine_cpu;
  cfg.try_realtime = o.realtime;

  // ---- isolation: everything but the engine off its core; memory locked ----
  const std::string iso = isolate_engine(o, cfg, ncpu, sum);

  // Background threads (the tracker's full-frame search, tracker.h
  // "Discovery"; capture with its decoding; the mesher) on the engine's CPU,
  // at normal priority: the FIFO engine preempts them at once, and they use
  // the ~85 % of that core the engine leaves idle instead of queueing with
  // the frame thread and the display on the others.
  ar::PipelineOptions popt = o.pipeline;
  popt.compositor.bur = bur_params;  // draw the bur the engine cuts with
  const std::string discovery_name = ar::discovery_mode_name(popt.tracker.discovery);
  std::atomic<int> bg_placed{0}, bg_refused{0};  // background threads pinned / refused
  std::function<void()> to_engine_cpu;
  // Beside the engine only when the engine will preempt them: without
  // SCHED_FIFO they would share its core equally and it would miss deadlines
  // (seen on a CI machine without CAP_SYS_NICE: 3 watchdog trips in 2 s).
  std::string bg_note;
  bool bg_beside_engine = o.background_cpu == "engine" && cfg.cpu >= 0 && ncpu > 1;
  if (bg_beside_engine) {
    std::string why;
    if (!o.realtime) {
      bg_beside_engine = false;
      bg_note = "background threads kept off the engine CPU (--no-realtime: the engine could not preempt them)";
    } else if (!haptics::realtime_available(cfg.realtime_priority, &why)) {
      bg_beside_engine = false;
      bg_note = "background threads kept off the engine CPU (SCHED_FIFO refused: " + why +
                "; the engine could not preempt them)";
    }
  }
  if (bg_beside_engine) {
    const int cpu = cfg.cpu;
    to_engine_cpu = [cpu, &bg_placed, &bg_refused] {
      cpu_set_t one;
      CPU_ZERO(&one);
      CPU_SET(cpu, &one);
      // Normal (CFS) priority: below the FIFO engine whatever it is (SCHED_IDLE
      // would starve them whenever another process uses that core).
      if (pthread_setaffinity_np(pthread_self(), sizeof one, &one) == 0) ++bg_placed;
      else ++bg_refused;
    };
    popt.tracker.discovery_thread_init = to_engine_cpu;
  }

  std::unique_ptr<haptics::SessionLogWriter> log;
  std::unique_ptr<session::Recorder> recorder;
  const fs::path rdir = o.record_dir;
  nlohmann::json rec_meta;  // recording.json as written at the start; completed at the end
  if (!o.record_dir.empty())
    if (auto s = start_recording(o, st, popt, discovery_name, recorder, rec_meta); !s) return Error{s.error()};
  std::string header;
  {
    auto probe = haptics::Engine::create(cfg, engine_device, *vol, *bur, nullptr);
    if (!probe) return Error{"live: engine: " + probe.error()};
    header = (*probe)->header_json(tooth_desc);
  }
  if (recorder) {
    auto w = haptics::SessionLogWriter::open((rdir / "session.dlog").string(), header);
    if (!w) return Error{"live: " + w.error()};
    log = std::move(*w);
  }
  auto engine_r = haptics::Engine::create(cfg, engine_device, *vol, *bur, log.get());
  if (!engine_r) return Error{"live: engine: " + engine_r.error()};
  haptics::Engine& engine = **engine_r;

  // ---- window ----
  const int W = src->width(), H = src->height();
  // "auto": ask the renderer first (a throw-away context on the default EGL
  // platform, the one the compositor would get).
  std::string auto_note;
  bool want_gl = o.display_path == "gl";
  if (o.display_path == "auto") {
    if (auto probe = ar::EglContext::create(); !probe) {
      auto_note = "--display-path auto: no EGL context to ask the renderer (" + probe.error() + ")";
    } else if (software_renderer(probe->gl_renderer())) {
      auto_note = "--display-path auto: " + probe->gl_renderer() +
                  " is a software rasteriser, where the CPU path measured faster (docs/BENCHMARKS.md)";
    } else {
      want_gl = true;
      auto_note = "--display-path auto: " + probe->gl_renderer() + " is a hardware renderer";
    }
  }
  // GPU path: the window's EGL display is the one the compositor shares, so
  // llvmpipe's rasteriser threads (one set per display, started when GLFW
  // initialises it here) serve both contexts and run with the main thread,
  // off the engine's CPU: measured faster than putting them beside the engine,
  // where the capture thread's decoding already runs (docs/BENCHMARKS.md,
  // "The GL-resident display path").
  auto hw_r = HudWindow::open("DentAR live", W, H, o.window_width, o.window_height, o.display, o.vsync,
                              want_gl && !o.window_glx_for_test);
  if (!hw_r) return Error{"live: " + hw_r.error()};
  HudWindow& hw = **hw_r;
  // The display path is settled on the frame thread (the shared context is
  // made there); these hold its outcome once pipeline_ready is set.
  std::atomic<bool> gl_path{false};
  std::string display_note;
  if (!want_gl) display_note = auto_note.empty() ? "--display-path cpu" : auto_note;
  else if (o.window_glx_for_test) display_note = "the window's context is desktop OpenGL through GLX (test hook), which cannot share with EGL";
  else if (!hw.gles_egl()) display_note = hw.context_note();
  else display_note = auto_note;  // empty unless chosen by auto; a fallback below replaces it
  std::unique_ptr<ar::SharedFrameRing> ring;  // made and destroyed on the frame thread

  // ---- threads ----
  ar::CaptureThreadOptions cto;
  cto.reopen = o.loop || o.camera.rfind("live:", 0) != 0;  // footage ends (unless looped); a camera comes back
  cto.stall_after_frames = o.stall_after_frames;
  cto.stall_s = o.stall_s;
  cto.thread_init = to_engine_cpu;
  // Reopen the source now, after the slow set-up (tooth, window): a paced
  // stand-in starts its clock at open, and a camera's first frames would be stale.
  src.reset();
  std::unique_ptr<ar::CaptureThread> capture_holder;  // made once the pipeline is ready
  std::atomic<ar::CaptureThread*> capture_ptr{nullptr};
  std::string cam_desc = o.camera;

  std::mutex shown_m;
  std::condition_variable shown_cv;
  Shown shown;
  bool shown_new = false;
  std::atomic<bool> stop{false};
  std::atomic<int> pipeline_ready{0};  // 1 ok, -1 failed
  std::string pipeline_error;
  std::vector<double> process_ms;
  std::int64_t processed = 0;
  std::int64_t gpu_frames = 0, readback_px = 0, cpu_blend_px = 0;  // frame thread; read after join
  std::int64_t ring_stats[3] = {0, 0, 0};
  // Latency compensation (issue 24): the camera's latency (mid-exposure to Frame::steady_s).
  double comp_latency_s = 0;
  std::string comp_source;
  if (o.stylus == "pen" && o.device.empty()) {
    comp_source = "pen";  // the pen's pose is measured in the camera's own frames
  } else if (o.camera_latency_ms == 0) {
    comp_source = "off";
  } else if (o.camera_latency_ms > 0) {
    comp_source = "option";
    comp_latency_s = o.camera_latency_ms * 1e-3;
  } else if (st.camera_provenance.latency_ms >= 0) {
    comp_source = st.camera_provenance.latency_ms > 0 ? "measured" : "off";
    comp_latency_s = st.camera_provenance.latency_ms * 1e-3;
  } else {
    comp_source = "assumed";
    comp_latency_s = ar::kAssumedCameraLatency_ms * 1e-3;
  }
  std::int64_t comp_at_exposure = 0, comp_newest = 0;  // frame thread; read after join

  std::thread frame_thread([&] {
    // llvmpipe starts its rasteriser thread when the context is made, with
    // this thread's CPU mask: with the background threads on the engine's
    // CPU, it goes there too (it is the largest GL cost; the frame thread
    // then only records the draw calls and waits, and CPU 0 keeps the
    // tracking, the blend and the display).
    cpu_set_t frame_mask;
    const bool raster_moved = to_engine_cpu && pthread_getaffinity_np(pthread_self(), sizeof frame_mask, &frame_mask) == 0;
    if (raster_moved) to_engine_cpu();
    // The GPU display path: a context on the window's EGL display sharing its
    // objects; otherwise (or when that fails) a headless one of our own.
    Result<ar::EglContext> egl = Error{"not made"};
    bool use_gl = want_gl && hw.gles_egl();
    if (use_gl) {
      ar::EglContextOptions eo;
      eo.share_display = hw.egl_display();
      eo.share_context = hw.egl_context();
      egl = ar::EglContext::create(eo);
      if (!egl) {
        display_note = egl.error();
        use_gl = false;
      }
    }
    if (!use_gl) egl = ar::EglContext::create();
    if (raster_moved) pthread_setaffinity_np(pthread_self(), sizeof frame_mask, &frame_mask);
    if (!egl || !egl->make_current()) {
      pipeline_error = "headless rendering: " + (egl ? std::string("make_current failed") : egl.error());
      pipeline_ready.store(-1);
      return;
    }
    auto pipe = ar::FramePipeline::create(st, popt);
    if (!pipe) {
      pipeline_error = pipe.error();
      pipeline_ready.store(-1);
      return;
    }
    if (use_gl) {
      if (std::string e = pipe->get()->compositor().gpu_path_error(); !e.empty()) {
        display_note = "the compositor's GPU path cannot run here: " + e;
        use_gl = false;
      } else if (auto r = ar::SharedFrameRing::create(W, H); !r) {
        display_note = r.error();
        use_gl = false;
      } else {
        ring = std::move(*r);
      }
    }
    ar::ToothMeshes meshes(*vol);
    if (auto s = pipe->get()->warm_up(meshes, use_gl ? ring->target(0) : ar::GlFrameTarget{}); !s) {
      pipeline_error = s.error();
      pipeline_ready.store(-1);
      return;
    }
    gl_path.store(use_gl);
    meshes.start_mesher(1.0 / 120.0, to_engine_cpu);
    pipeline_ready.store(1);
    while (capture_ptr.load() == nullptr && !stop.load()) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    if (stop.load()) {
      meshes.stop_mesher();
      ring.reset();
      pipe->reset();
      return;
    }
    ar::CaptureThread& capture = *capture_ptr.load();
    ar::Frame f;
    ar::CompositeResult cres;
    ar::FrameRecord rec;
    while (!stop.load()) {
      if (!capture.wait_take(f, 0.05)) {
        if (capture.ended()) break;
        continue;
      }
      haptics::HapticSnapshot snap = engine.snapshot();
      double pose_step = -1;
      if (comp_latency_s > 0) {
        // The stylus as it was when this frame was exposed, not as it is now (issue 24).
        const auto h = engine.pose_history().sample(f.steady_s - comp_latency_s);
        if (h.usable() && h.index >= 0) {
          Eigen::Map<Eigen::Matrix4d>(snap.T_dev_sty) = h.T_dev_sty.matrix();
          pose_step = h.index;
          ++comp_at_exposure;
        } else {
          ++comp_newest;
        }
      }
      ar::FrameInput in;
      in.image = &f.image;
      in.index = processed;
      in.capture_time_s = f.time_s;
      in.haptic = o.stylus == "none" ? nullptr : &snap;
      in.stylus_valid = o.stylus != "none" && !snap.fault;
      const auto t0 = Clock::now();
      // GPU path: a texture the window is not showing, free of its draws.
      const int slot = use_gl ? ring->acquire() : -1;
      if (use_gl) in.gl_target = ring->target(slot);
      std::string err;
      try {
        if (auto s = pipe->get()->process(in, meshes, cres, rec); !s) err = s.error();
      } catch (const std::exception& e) {
        err = std::string("pipeline threw: ") + e.what();
      }
      process_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
      rec.pose_step = pose_step;
      for (const auto& it : health.on_frame(pipe->get()->last_detections(), f.steady_s, rec.T_dev_sty,
                                            in.stylus_valid)) {
        say("station health: " + it.check + ": " + health_level_name(it.level) + ": " + it.message);
        if (recorder) recorder->log("station health: " + it.check + ": " + health_level_name(it.level) + ": " + it.message);
      }
      if (pen != nullptr) {
        const bool ok = rec.man_state != 2 && rec.pen_state != 2;
        const Eigen::Isometry3d T_dev_sty = (rec.T_cam_man * st.calibration.T_man_dev).inverse() * rec.T_cam_ptag *
                                            st.pen.T_ptag_tip * st.calibration.T_sty_tip.inverse();
        pen->publish(T_dev_sty, ok, f.steady_s);
      }
      {
        std::lock_guard<std::mutex> lock(shown_m);
        shown.raw = f.image;
        shown.gpu = use_gl && err.empty();
        // Buffers change hands, never copied (2.7 MB a 720p frame): the
        // compositor's, the shown slot and the display's each own one.
        // GPU path: the texture is published (fence) under the same lock as
        // the record, so the window takes the two together.
        if (shown.gpu) {
          ring->publish(slot, processed, cres.region.x, cres.region.y, cres.region.width, cres.region.height);
          shown.composite.release();
        } else if (err.empty()) {
          cv::swap(cres.image, shown.composite);
        } else {
          f.image.copyTo(shown.composite);
        }
        shown.index = processed;
        shown.steady_s = f.steady_s;
        shown.rec = rec;
        shown.error = err;
        shown_new = true;
      }
      shown_cv.notify_one();
      if (recorder && err.empty()) recorder->push(f.image, f.encoded, rec, processed, f.index, f.steady_s);
      if (err.empty()) {
        gpu_frames += rec.gpu_composite ? 1 : 0;
        readback_px += rec.readback_px;
        cpu_blend_px += rec.cpu_blend_px;
      }
      ++processed;
    }
    meshes.stop_mesher();
    // The window may still draw from (and release) the ring until the main
    // loop ends (the footage can end first): the ring goes only after that.
    while (ring && !stop.load()) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    if (ring) {
      const auto rs = ring->stats();
      ring_stats[0] = rs.replaced;
      ring_stats[1] = rs.ready_timeouts;
      ring_stats[2] = rs.release_timeouts;
    }
    // The GL objects go before the context.
    ring.reset();
    pipe->reset();
  });
  while (pipeline_ready.load() == 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  if (pipeline_ready.load() < 0) {
    frame_thread.join();
    return Error{"live: " + pipeline_error};
  }
  {
    auto src2 = ar::FrameSource::open(o.camera, so);
    if (!src2) {
      stop.store(true);
      frame_thread.join();
      return Error{"live: " + src2.error()};
    }
    capture_holder = std::make_unique<ar::CaptureThread>(std::move(*src2), o.camera, so, cto);
  }
  ar::CaptureThread& capture = *capture_holder;
  cam_desc = capture.description();
  if (recorder)
    recorder->log("camera " + cam_desc + "; " + (o.device.empty() ? "stylus " + o.stylus : "device " + engine_device.name()) +
                  "; pedal " + pedal.name() + "; engine CPU " + std::to_string(cfg.cpu));
  capture.start();
  capture_ptr.store(&capture);
  if (auto s = engine.start(); !s) {
    stop.store(true);
    capture.stop();
    frame_thread.join();
    return Error{"live: engine: " + s.error()};
  }
  // The drill's sound reads the snapshot on its own thread (off the engine's CPU, as this one).
  std::shared_ptr<void> sound;
  if (o.start_sound) sound = o.start_sound([&engine] { return engine.snapshot(); });
  const std::string sound_line = hud_sound_line(static_cast<bool>(o.start_sound), sound != nullptr, o.sound_muted, o.sound_detail);
  // What the system granted, and what to do when it did not.
  for (int i = 0; i < 100 && engine.snapshot().step == 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  std::string grant = "engine: ";
  if (!o.realtime) grant += "real time not asked (--no-realtime); ";
  else if (engine.realtime_granted_now()) grant += "SCHED_FIFO granted; ";
  else grant += "SCHED_FIFO refused: run as root, or `sudo setcap cap_sys_nice,cap_ipc_lock+ep dentar`, or an rtprio limit in /etc/security/limits.conf; ";
  if (cfg.cpu >= 0) grant += engine.cpu_pinned_now() ? "pinned to CPU " + std::to_string(cfg.cpu) + "; " : "not pinned (CPU " + std::to_string(cfg.cpu) + " refused); ";
  else grant += "not pinned; ";
  if (o.realtime) grant += sum.memory_locked ? "memory locked" : "memory not locked (raise `ulimit -l`)";
  grant += "; " + iso;
  grant += "; tag discovery " + discovery_name;
  if (to_engine_cpu)
    grant += "; " + std::to_string(bg_placed.load()) + " background threads (tag search, capture, mesher, GL rasteriser) on CPU " +
             std::to_string(cfg.cpu) + " below the engine" +
             (bg_refused.load() > 0 ? " (" + std::to_string(bg_refused.load()) + " refused)" : std::string());
  else if (!bg_note.empty())
    grant += "; " + bg_note;
  else
    grant += "; background threads with the frame thread";
  const std::string stylus_desc = o.device.empty() ? "stylus " + o.stylus : "device " + engine_device.name();
  say("camera " + cam_desc + "; " + stylus_desc + "; pedal " + pedal.name());
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
  {
    ar::TagDetectorOptions d = popt.tracker.detector;  // auto: the station's measured response
    if (const std::string note = ar::resolve_camera_response(d, st); !note.empty()) say("note: " + note);
  }
  say(grant);
  if (recorder) recorder->log(grant);
  const bool rt_ok = !o.realtime || (engine.realtime_granted_now() && sum.memory_locked);

  // ---- display loop (main thread) ----
  const double t_start = now_s();
  std::vector<double> latency_ms;
  std::int64_t displayed = 0, last_index = -1;
  Shown cur;
  std::vector<std::pair<std::int64_t, std::string>> shots = o.screenshots;
  double stall_seen_at = -1;
  double prev_check_age_s = 0;  // the camera's silence at the previous window check, s
  std::string stop_reason = "window closed";
  double fps_t0 = t_start;
  int fps_n = 0;
  double fps_now = 0;
  int shown_slot = -1;  // GPU path: the ring texture the window draws from, or -1
  const bool gpu_display = gl_path.load();
  {
    const std::string path_msg = gpu_display
        ? "display path gl: the composite stays on the GPU (window: OpenGL ES 3 over EGL; compositor's "
          "context shared with it; fenced hand-off; no readback)" + (auto_note.empty() ? "" : "; " + auto_note)
        : "display path cpu: the CPU composite is uploaded each frame (" + display_note + ")";
    say(path_msg);
    if (recorder) recorder->log(path_msg);
    if (want_gl && !gpu_display) sum.warnings.push_back("display: GPU path unavailable, CPU path used: " + display_note);
  }
  sum.display_path = gpu_display ? "gl" : "cpu";
  sum.display_requested = o.display_path;
  sum.display_note = display_note;
  while (true) {
    if (hw.should_close()) break;
    if (g_signal.load() != 0) {
      stop_reason = g_signal.load() == SIGINT ? "SIGINT" : "SIGTERM";
      break;
    }
    if (o.seconds > 0 && now_s() - t_start >= o.seconds) {
      stop_reason = "time limit";
      break;
    }
    if (hand_end_s > 0 && static_cast<double>(engine.stats().steps) / cfg.rate_hz >= hand_end_s + 1.0) {
      stop_reason = "the simulated hand finished the exercise";
      break;
    }
    if (o.frames > 0 && displayed >= o.frames) {
      stop_reason = "frame limit";
      break;
    }
    if (capture.ended() && !shown_new && processed > 0 && now_s() - capture.last_frame_steady_s() > 0.5) {
      stop_reason = "footage ended";
      break;
    }
    bool fresh = false;
    int new_slot = -1;  // GPU path: the texture published with this frame
    {
      // Draw when a frame arrives; otherwise redraw the HUD at ~30 Hz (an
      // idle loop must not spin: under Xvfb there is no vsync to pace it).
      std::unique_lock<std::mutex> lock(shown_m);
      shown_cv.wait_for(lock, std::chrono::milliseconds(30), [&] { return shown_new; });
      if (shown_new) {
        cv::swap(cur.composite, shown.composite);
        cur.gpu = shown.gpu;
        if (cur.gpu) new_slot = ring->take();
        cur.raw = shown.raw;
        cur.index = shown.index;
        cur.steady_s = shown.steady_s;
        cur.rec = shown.rec;
        cur.error = shown.error;
        shown_new = false;
        fresh = true;
      }
    }
    hw.poll();
    for (const int key : hw.take_presses())
      if (key == GLFW_KEY_ESCAPE) hw.request_close();
    key_pedal.set_pressed(hw.held(GLFW_KEY_SPACE));
    // The camera went quiet: show the video without the overlay within 200 ms.
    // One read of the capture time per check: a frame may land before the
    // swap, and the figure below must be about the silence this check saw.
    const double last_frame_s = capture.last_frame_steady_s();
    const double age = cur.index >= 0 ? now_s() - last_frame_s : 0;
    const bool stalled = cur.index >= 0 && age > 0.15;
    if (stalled && stall_seen_at < 0) stall_seen_at = now_s();
    if (!stalled) stall_seen_at = -1;
    const cv::Mat& img = stalled ? cur.raw : cur.composite;
    if (fresh && new_slot >= 0) {
      // The composite on the GPU: wait for its fence, then draw from it.
      ring->wait_ready(new_slot);
      const ar::GlFrameTarget t = ring->target(new_slot);
      hw.set_frame(t.video_texture, t.overlay_texture, ring->region(new_slot));
      shown_slot = new_slot;
    }
    if (!img.empty() && (fresh || stalled)) {
      hw.set_video(img);
      shown_slot = -1;
    }
    hw.begin_frame();
    if (o.hud) {
      const ar::FrameRecord& r = cur.rec;
      const haptics::HapticSnapshot snap = engine.snapshot();
      ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_Always);
      ImGui::SetNextWindowBgAlpha(0.6f);
      ImGui::Begin("DentAR", nullptr, ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoMove);
      const ImVec4 col[] = {ImVec4(0.3f, 1, 0.3f, 1), ImVec4(1, 0.85f, 0.2f, 1), ImVec4(1, 0.3f, 0.3f, 1)};
      {
        // ok green, note grey-blue (not an alarm), warning yellow, instructor needed red.
        const ImVec4 health_col[] = {col[0], ImVec4(0.75f, 0.82f, 0.95f, 1), col[1], col[2]};
        const StationHealth h = health.health();
        ImGui::TextColored(health_col[static_cast<int>(h.worst())], "%s", h.headline().c_str());
      }
      ImGui::TextColored(col[r.man_state], "mannequin: %s", session::state_name(r.man_state));
      ImGui::SameLine();
      ImGui::TextColored(col[r.mir_state], "  mirror: %s", session::state_name(r.mir_state));
      if (pen) {
        ImGui::SameLine();
        ImGui::TextColored(col[r.pen_state], "  pen: %s", session::state_name(r.pen_state));
      }
      const double f = std::sqrt(snap.force_dev_N[0] * snap.force_dev_N[0] + snap.force_dev_N[1] * snap.force_dev_N[1] +
                                 snap.force_dev_N[2] * snap.force_dev_N[2]);
      const double fmax = engine_device.limits().max_force_N;
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.2f N", f);
      ImGui::Text("force");
      ImGui::SameLine();
      ImGui::ProgressBar(static_cast<float>(std::min(1.0, f / fmax)), ImVec2(200, 0), buf);
      ImGui::TextUnformatted(
          hud_drill_line(snap.pedal, snap.in_contact, pedal.status(), pedal.pressed(), pedal_from_device, o.stylus)
              .c_str());
      if (const std::string ds = engine_device.status(); !ds.empty()) ImGui::TextColored(col[1], "device: %s", ds.c_str());
      if (!sound_line.empty()) {
        if (sound_line == "sound: no device (silent)") ImGui::TextColored(col[1], "%s", sound_line.c_str());
        else ImGui::TextUnformatted(sound_line.c_str());
      }
      ImGui::Text("removed mm3: enamel %.2f  dentin %.2f  pulp %.2f",
                  snap.removed_mm3[static_cast<int>(volume::Material::kEnamel)],
                  snap.removed_mm3[static_cast<int>(volume::Material::kDentin)],
                  snap.removed_mm3[static_cast<int>(volume::Material::kPulp)]);
      ImGui::Text("%.1f fps  latency %.0f ms  (display %s)", fps_now, latency_ms.empty() ? 0.0 : latency_ms.back(),
                  gpu_display ? "gl" : "cpu");
      if (stalled)
        ImGui::TextColored(col[2], "camera: no frame for %.0f ms, overlay hidden%s", age * 1e3,
                           capture.status().empty() ? "" : (" (" + capture.status() + ")").c_str());
      if (!cur.error.empty()) ImGui::TextColored(col[2], "pipeline: %s", cur.error.c_str());
      if (snap.watchdog) ImGui::TextColored(col[2], "haptics: watchdog: zero force");
      if (snap.fault) ImGui::TextColored(col[2], "haptics: device fault: zero force%s", pen ? " (pen not seen)" : "");
      if (snap.pulp_exposed) ImGui::TextColored(col[2], "PULP EXPOSED");
      if (pen) ImGui::TextColored(col[1], "pen mode: no force on the hand; space bar = pedal");
      if (!rt_ok) ImGui::TextColored(col[1], "haptics not real-time: %s", grant.c_str());
      if (!stalled && cur.index >= 0 && now_s() - cur.steady_s > 0.5)
        ImGui::TextColored(col[2], "frame pipeline stalled: no composite for %.0f ms", (now_s() - cur.steady_s) * 1e3);
      ImGui::End();
    }
    // Test hook: the window's pixels for frame N (read before the swap).
    const auto shot = fresh ? std::find_if(shots.begin(), shots.end(), [&](const auto& x) { return x.first == cur.index; })
                            : shots.end();
    const cv::Mat px = hw.end_frame(shot != shots.end());
    if (shown_slot >= 0) ring->release(shown_slot);  // the producer may draw into it once this completes
    if (shot != shots.end()) {
      cv::imwrite(shot->second, px);
      shots.erase(shot);
    }
    const double t_swap = now_s();
    if (fresh && cur.index != last_index) {
      latency_ms.push_back((t_swap - cur.steady_s) * 1e3);
      last_index = cur.index;
      ++displayed;
      ++fps_n;
    }
    if (stalled && stall_seen_at > 0 && sum.overlay_hidden_ms_after_stall < 0) {
      sum.overlay_hidden_ms_after_stall = static_cast<int>(std::lround((t_swap - last_frame_s) * 1e3));
      sum.stall_previous_check_ms = static_cast<int>(std::lround(prev_check_age_s * 1e3));
    }
    prev_check_age_s = age;
    if (sum.rss_warm_mb == 0 && t_swap - t_start >= 10.0) sum.rss_warm_mb = rss_mb();
    if (t_swap - fps_t0 >= 1.0) {
      if (t_swap - t_start >= 60.0) {
        const double r = rss_mb();
        if (sum.rss_60s_mb == 0) sum.rss_60s_mb = r;
        sum.rss_max_after_60s_mb = std::max(sum.rss_max_after_60s_mb, r);
      }
      fps_now = fps_n / (t_swap - fps_t0);
      fps_t0 = t_swap;
      fps_n = 0;
    }
  }

  // ---- shutdown: zero force first, then the logs, then the recording ----
  engine.stop();  // the engine's last act is a zero force
  if (recorder) recorder->log("engine stopped: zero force sent (" + stop_reason + ")");
  say("stopping (" + stop_reason + "): force zeroed");
  stop.store(true);
  capture.stop();
  frame_thread.join();
  const haptics::EngineStats es = engine.stats();
  if (log) {
    if (auto s = log->close(); !s) sum.warnings.push_back("session log: " + s.error());
  }
  sum.wall_s = now_s() - t_start;
  sum.stop_reason = stop_reason;
  sum.frames_captured = capture.delivered();
  sum.frames_processed = processed;
  sum.frames_displayed = displayed;
  sum.gpu_frames = gpu_frames;
  sum.compensation_latency_ms = comp_latency_s * 1e3;
  sum.compensation_source = comp_source;
  sum.frames_pose_at_exposure = comp_at_exposure;
  sum.frames_pose_newest = comp_newest;
  sum.readback_px = readback_px;
  sum.cpu_blend_px = cpu_blend_px;
  sum.gl_frames_replaced = ring_stats[0];
  sum.gl_ready_timeouts = ring_stats[1];
  sum.gl_release_timeouts = ring_stats[2];
  sum.dropped_source = capture.dropped_source();
  sum.dropped_consumer = capture.dropped_consumer();
  sum.camera_reopens = capture.reopens();
  sum.displayed_fps = sum.wall_s > 0 ? displayed / sum.wall_s : 0;
  sum.latency_p50_ms = percentile(latency_ms, 0.5);
  sum.latency_p99_ms = percentile(latency_ms, 0.99);
  sum.latency_max_ms = latency_ms.empty() ? 0 : *std::max_element(latency_ms.begin(), latency_ms.end());
  sum.process_p50_ms = percentile(process_ms, 0.5);
  sum.process_p99_ms = percentile(process_ms, 0.99);
  engine_figures(es, sum);
  sum.isolation_note = iso + es.realtime_note + (bg_note.empty() ? std::string() : "; " + bg_note);
  sum.volume_hash = vol->content_hash();
  {
    const haptics::HapticSnapshot last = engine.snapshot();
    sum.removed_enamel_mm3 = last.removed_mm3[static_cast<int>(volume::Material::kEnamel)];
    sum.removed_dentin_mm3 = last.removed_mm3[static_cast<int>(volume::Material::kDentin)];
    sum.removed_pulp_mm3 = last.removed_mm3[static_cast<int>(volume::Material::kPulp)];
    for (double v : last.removed_mm3) sum.removed_total_mm3 += v;
  }
  sum.rss_end_mb = rss_mb();
  if (!sum.realtime_granted && o.realtime)
    sum.warnings.push_back("engine: " + es.realtime_note);
  for (const auto& it : health.health().items) {
    sum.station_health.push_back(std::string(health_level_name(it.level)) + ": " + it.check + ": " + it.message);
    if (it.level != HealthLevel::kOk) sum.warnings.push_back("station health: " + it.check + ": " + it.message);
  }
  sum.instructor_needed = health.health().instructor_needed();
  if (recorder) finish_recording(*recorder, rec_meta, stop_reason, es, rdir, sum);
  if (!o.summary_path.empty()) std::ofstream(o.summary_path) << sum.json();
  return sum;
}

}  // namespace dentar::live
