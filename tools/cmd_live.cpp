// dentar live: the student's trainer with a camera, a window and the 1 kHz
// engine (live/live_app.h). A thin driver over the shared FramePipeline.
#include <cctype>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <tuple>

#include "commands.h"
#include "db_util.h"
#include "dentar/volume/bur.h"
#include "dentar/ar/station_scene.h"
#include "dentar/ar/stereo_source.h"
#include "dentar/haptics/replay.h"
#include "dentar/haptics/session_log.h"
#include "dentar/live/live_app.h"
#include "dentar/session/finish.h"
#include "dentar/training/lesson.h"
#include "sound_cli.h"

namespace dentar::tools {

void add_live(CLI::App& app, int& exit_code) {
  struct Cli {
    live::LiveOptions o;
    std::vector<std::string> shots;
    double predict_ms = 0;
    bool no_hud = false, no_vsync = false, no_realtime = false, no_occlusion = false, no_segmentation = false,
         no_mirror = false, list = false;
    std::string stall, stall_right;
    std::string discovery = "async";
    std::string camera_response;  // "" = auto (the station's)
    bool mirror_rim = false;
    std::string stereo_mirror_rim;  // on|off, empty = the default
    bool no_score = false;
    std::string headset;  // --headset FILE
    std::vector<std::string> keys;  // --inject-key FRAME:KEY
    DbCli db;  // --db: store the finished session (needs --record)
    SoundCli sound;  // the drill's sound (issue 29)
  };
  auto c = std::make_shared<Cli>();
  auto* sub = app.add_subcommand(
      "live",
      "The live trainer: camera -> tracking -> virtual tooth in the video, in a window with a HUD,\n"
      "while the 1 kHz haptic engine cuts the tooth.\n"
      "Synopsis: dentar live [--camera SPEC [--camera-right SPEC | --stereo]] [--station FILE] [--stylus sim|pen|replay:LOG|none]\n"
      "                      [--display N] [--record DIR] [--seconds S] [--frames N] [--exercise NAME|FILE] [...]");
  sub->footer(
      "Examples:\n"
      "  dentar live --camera camera:0 --stylus pen --scale-calib     # webcam, printed kit (dentar tags)\n"
      "  dentar synth --frames 150 --resolution 1280x720 --webcam --out out/clip   # camera.avi: Motion JPEG\n"
      "  dentar live --camera live:out/clip/camera.avi --station out/clip/station.json \\\n"
      "              --stylus replay:out/clip/session.dlog --record out/rec\n"
      "  dentar offline --footage out/rec --out out/rec_offline      # replays the recording\n"
      "  dentar live --camera live:out/clip/camera.avi --station out/clip/station.json --loop --stylus sim \\\n"
      "              --exercise incisor_partial_crown --hand-skill 0.5 --hand-style 1 --hand-seed 7 --record out/inc\n"
      "  dentar live --camera live:out/clip/camera.avi --station out/clip/station.json --stylus sim \\\n"
      "              --lesson builtin:molar_access_opening --mode 2 --record out/lesson   # a lesson, mode 2\n"
      "Keys: space = pedal (drill), Esc or closing the window = stop.");
  sub->add_option("--camera", c->o.camera, "camera:N, /dev/videoN, or live:VIDEO (footage paced as a camera)");
  sub->add_option("--camera-right", c->o.camera_right,
                  "stereo head of two cameras (issue 28): the right eye (--camera is the left), one size and rate; "
                  "the station needs its rig (dentar calibrate stereo). Both eyes' tags are fitted together; a right "
                  "eye silent for 0.1 s leaves the left alone until it returns");
  sub->add_flag("--stereo", c->o.side_by_side,
                "--camera delivers side-by-side stereo frames (left eye | right eye), as passthrough headsets do; "
                "the station needs its rig");
  sub->add_option("--camera-format", c->o.camera_format,
                  "auto (the driver's format; YUYV carried as the camera sent it, Motion JPEG decoded to its own "
                  "YUV planes and carried as YUYV), yuyv or mjpg (asked of the camera), bgr (every frame converted "
                  "to BGR on capture, the whole-frame path)")
      ->check(CLI::IsMember({"auto", "yuyv", "mjpg", "bgr"}));
  sub->add_option("--jpeg-decode", c->o.jpeg_decode,
                  "Motion JPEG cameras: every-frame (each captured frame decoded on its capture thread) "
                  "or on-demand (a frame is decoded only when the frame thread takes it; frames replaced before "
                  "that are never decoded: less CPU on a loaded machine, more latency on a quiet one) or eager "
                  "(default: the newest packet decoded on the capture side as soon as the frame thread took the "
                  "previous one; packets superseded before that are never decoded, and the frame thread never decodes)")
      ->check(CLI::IsMember({"eager", "on-demand", "every-frame"}));
  sub->add_option("--cpu-display-yuyv", c->o.cpu_display_yuyv,
                  "a YUYV camera on the CPU display path: keep (default: the composite stays YUYV outside the "
                  "overlay, only the overlay's patch is converted) or convert (the whole frame converted to BGR, "
                  "as before session 20)")
      ->check(CLI::IsMember({"keep", "convert"}));
  sub->add_option("--display-texture", c->o.display_texture,
                  "the headset view's camera textures (CPU display path): auto (default: half size when the "
                  "loupe is off and a half-size texel still covers at most one window pixel at the lens centre), "
                  "full (the camera's size) or half (each eye's frame box-averaged 2x2 before the upload)")
      ->check(CLI::IsMember({"auto", "full", "half"}));
  sub->add_option("--bur-samples", c->o.bur_samples,
                  "the bur's sample count (default 10000, or a lesson's own; 1..100000); written to the session "
                  "header's bur.samples. The cut does not depend on it (the overlap cutter, session 22)")
      ->check(CLI::Range(volume::kMinBurSamples, volume::kMaxBurSamples));
  sub->add_option("--width", c->o.width, "requested camera width (px)")->check(at_least(0));
  sub->add_option("--height", c->o.height, "requested camera height (px)")->check(at_least(0));
  sub->add_option("--fps", c->o.fps, "requested camera rate (Hz)")->check(at_least(0));
  sub->add_option("--station", c->o.station,
                  "station file, or a built-in station: default (phantom head), box (flat tag board)");
  sub->add_flag("--scale-calib", c->o.scale_calib, "accept a camera of another size (intrinsics scaled)");
  sub->add_option("--stylus", c->o.stylus, "sim (simulated hand), pen (printed pen tag), replay:FILE.dlog, none (no bur: the engine runs, nothing cuts)");
  sub->add_option("--camera-latency-ms", c->o.camera_latency_ms,
                  "the camera's latency, mid-exposure to grab, ms: each frame is drawn with the stylus "
                  "pose of its exposure from the engine's 1 kHz pose history (default: the station's "
                  "camera.latency_ms, else 33 ms assumed; 0: the newest pose, no compensation)")
      ->check(CLI::Range(0.0, 1000.0));
  sub->add_option("--model", c->o.model, "force model: proxy or seed");
  sub->add_option("--device", c->o.device,
                  "a real haptic device instead of --stylus: touch, omni, desktop, premium, premium3, hd, "
                  "omega, sigma, delta, falcon, dhd (see `dentar devices`); sim = the simulated hand");
  sub->add_option("--device-name", c->o.device_name, "the device's configuration name or serial (default: the first)");
  sub->add_option("--pedal", c->o.pedal, "keyboard (space bar, default), auto, vec, usb:VID:PID, evdev:/dev/input/eventN");
  sub->add_option("--display", c->o.display, "monitor index for fullscreen (the HMD's input); -1 = a window");
  sub->add_option("--output", c->o.output,
                  "mono (the window, default) or sbs: a headset's side-by-side view through --headset "
                  "(docs/headset.md; with --display N, full screen on that monitor)")
      ->check(CLI::IsMember({"mono", "sbs"}));
  sub->add_option("--headset", c->headset, "headset profile (JSON, docs/formats.md): panel, eyes, field of view, IPD, "
                                             "lens pre-warp; assets/headsets/ has examples");
  sub->add_option("--loupe", c->o.loupe,
                  "digital loupe: magnification (dentists' loupes: 2.5-4; 1.5..8), centred on the tracked tooth; "
                  "0 = off (key L cycles off / inset / full)");
  sub->add_option("--loupe-view", c->o.loupe_view, "inset (picture in picture, default) or full (the whole eye view)")
      ->check(CLI::IsMember({"inset", "full"}));
  sub->add_option("--warp-pass", c->o.warp_pass,
                  "the headset's lens pre-warp pass (--output sbs): exact (default: the exact mapping, drawn only "
                  "where the camera is seen), mesh (a grid's per-vertex warp: within 1 camera px at 16 px cells, 0.2 at 8; docs/headset.md), "
                  "full (every pixel, as before), lut (a lookup texture)")
      ->check(CLI::IsMember({"exact", "mesh", "full", "lut"}));
  sub->add_option("--warp-cell-px", c->o.warp_cell_px, "the pre-warp grid's cell size, panel px (4..128, default 16)")
      ->check(CLI::Range(4, 128));
  sub->add_option("--idle-redraw-ms", c->o.idle_redraw_ms,
                  "without a new camera frame, redraw the window (the HUD) at most this often, ms (0..1000, "
                  "default 100; 0: at every wake of the display loop, ~30 ms, as before); a camera going quiet "
                  "and a key press are drawn at once")
      ->check(CLI::Range(0.0, 1000.0));
  sub->add_option("--window-width", c->o.window_width, "window width (px, default: the camera's)");
  sub->add_option("--window-height", c->o.window_height, "window height (px)");
  sub->add_flag("--no-hud", c->no_hud, "video only, no HUD");
  sub->add_flag("--no-vsync", c->no_vsync, "swap without waiting for vertical sync");
  sub->add_option("--display-path", c->o.display_path,
                  "auto (default): gl on a hardware renderer, cpu on a software one (llvmpipe); "
                  "cpu: the CPU composite uploaded each frame; gl: the composite stays on the GPU, "
                  "drawn from a texture shared with the window, nothing read back (on a software rasteriser "
                  "it measured slower and disturbed the engine; falls back to cpu when contexts cannot be "
                  "shared, and the log says why)")
      ->check(CLI::IsMember({"auto", "gl", "cpu"}));
  sub->add_flag("--window-glx", c->o.window_glx_for_test,
                "test hook: make the window's context with GLX, which cannot share with the compositor (the fallback)");
  sub->add_option("--predict-ms", c->predict_ms,
                  "draw each frame with poses predicted this far past its capture time, ms (default 0: the "
                  "overlay is drawn on the very frame it was tracked in; docs/BENCHMARKS.md, Issue 28 session 16)")
      ->check(CLI::Range(0.0, 500.0));
  sub->add_flag("--passthrough", c->o.passthrough,
                "a bare viewer for latency comparisons: the camera's frames decoded, uploaded and swapped, no AR "
                "(no tracking, compositing or occlusion; nothing recorded)");
  sub->add_option("--eye-threads", c->o.eye_threads,
                  "a stereo pair into the headset (--output sbs): 2 (default) = the right eye's tracking and "
                  "composite on a thread of its own (1, with a warning, when that thread gets no GL context), "
                  "1 = both eyes on the frame thread")
      ->check(CLI::IsMember({1, 2}));
  sub->add_option("--eye-thread-cpu", c->o.eye_thread_cpu,
                  "where the right eye's thread may run: any (default; on the engine's CPU below it), engine "
                  "(only beside the engine), frame (the frame thread's CPUs)")
      ->check(CLI::IsMember({"any", "engine", "frame"}));
  sub->add_option("--capture-right-cpu", c->o.capture_right_cpu,
                  "two cameras: where the right camera's capture and decode may run: engine (default; beside the "
                  "engine, as the left camera's: the two decodes share a core), frame (the frame thread's CPUs: "
                  "the decodes on different cores), any")
      ->check(CLI::IsMember({"engine", "frame", "any"}));
  sub->add_option("--display-half-convert", c->o.display_half_convert,
                  "half-size camera textures of a YUYV camera: direct (default; converted at half size) or box "
                  "(converted at full size, then averaged 2x2: the session 22 path)")
      ->check(CLI::IsMember({"direct", "box"}));
  sub->add_option("--cpu-layout", c->o.cpu_layout,
                  "each thread's CPUs by hand (measuring placement): ROLE=CPUS,... with roles engine, frame, eye, "
                  "capture (capture-l, capture-r), display, raster (the window's GL rasteriser), mesher and CPUS "
                  "such as 0, 0-1, 0+2 or all; a role not named keeps its default (e.g. "
                  "engine=1,frame=0,eye=0,capture=1,display=0,raster=0)");
  sub->add_option("--window-raster-cpu", c->o.window_raster_cpu,
                  "where the window's GL rasteriser (llvmpipe; the headset's pre-warp) may run: frame (default; off "
                  "the engine's CPU), any (the engine's CPU too, below it), auto (any with --output sbs)")
      ->check(CLI::IsMember({"auto", "any", "frame"}));
  sub->add_option("--record", c->o.record_dir, "record footage, session log, station and per-frame CSV into DIR");
  sub->add_flag("--loop", c->o.loop, "live:PATH footage: play it again from the start at its end");
  sub->add_option("--seconds", c->o.seconds, "stop after S seconds (default: until closed)")->check(at_least(0));
  sub->add_option("--frames", c->o.frames, "stop after N new frames have been shown (default: no limit)")
      ->check(at_least(0));
  sub->add_option("--engine-cpu", c->o.engine_cpu, "CPU for the haptic engine (-2 = the last, -1 = no pinning)");
  sub->add_flag("--no-realtime", c->no_realtime, "no SCHED_FIFO, no mlockall");
  sub->add_option("--cpu-wake-latency-us", c->o.cpu_wake_latency_us,
                  "the CPUs' wake-up latency from idle held while the run lasts, us (/dev/cpu_dma_latency; "
                  "0 = idle CPUs poll instead of halting; -1 = the system's setting, the default)")
      ->capture_default_str();
  sub->add_flag("--no-wake-monitor", [c](std::int64_t) { c->o.wake_monitor = false; },
                "do not attribute the engine's late wake-ups (summary engine.wake; docs/formats.md)");
  add_tracker_image_options(sub, c->camera_response, c->mirror_rim);
  add_stereo_mirror_rim_option(sub, c->stereo_mirror_rim);
  sub->add_option("--discovery", c->discovery,
                  "full-frame tag search: async (off the frame path, default) or inline (in the frame that needs it)");
  sub->add_option("--background-cpu", c->o.background_cpu,
                  "tag search, capture and mesher threads: engine (the engine's CPU, below the engine; default) "
                  "or others (with the frame thread); engine needs SCHED_FIFO and falls back to others without it");
  sub->add_flag("--no-occlusion", c->no_occlusion, "no depth phantoms (lips, mirror, handpiece)");
  sub->add_flag("--no-segmentation", c->no_segmentation, "no foreground (hand) segmentation");
  sub->add_flag("--no-mirror", c->no_mirror, "no reflection in the mouth mirror");
  sub->add_option("--summary", c->o.summary_path, "also write the run's summary JSON here");
  sub->add_option("--screenshot", c->shots, "test hook: FRAME:FILE.png saves the window when frame FRAME shows");
  sub->add_option("--inject-key", c->keys, "test hook: FRAME:KEY presses KEY (a letter) when frame FRAME (or the first after it) shows");
  sub->add_option("--inject-stall", c->stall, "test hook: AFTER_FRAMES:SECONDS, the camera (with --camera-right: the left eye) goes quiet");
  sub->add_option("--inject-stall-right", c->stall_right,
                  "test hook: AFTER_FRAMES:SECONDS, the right eye (--camera-right) goes quiet");
  sub->add_flag("--list-cameras", c->list, "list the V4L2 cameras and their modes, then exit");
  sub->add_flag("--quiet", c->o.quiet, "no progress lines");
  sub->add_option("--exercise", c->o.exercise,
                  "exercise of the session: its tooth is drilled (incisor_partial_crown: the incisor) and\n"
                  "--stylus sim works its steps; recorded in recording.json; with --record the session is scored\n"
                  "against it into DIR/score.json and score.html; a built-in name or a JSON file; default: the molar");
  sub->add_option("--lesson", c->o.lesson,
                  "train on a lesson (a folder made by `dentar lesson make`, or builtin:EXERCISE): the expert's tool\n"
                  "is replayed in the engine in --mode; --stylus sim is a simulated student following it");
  sub->add_option("--mode", c->o.lesson_mode,
                  "the lesson's training mode: 1 visual replay, 2 passive guidance, 3 active following, 4 force "
                  "reversal, 5 hints (docs/training_modes.md)")
      ->check(CLI::Range(1, 5));
  sub->add_option("--hand-skill", c->o.hand_skill,
                  "--stylus sim with --exercise: the simulated person's skill, 1 = expert (default) .. 0 = novice");
  sub->add_option("--hand-style", c->o.hand_style,
                  "--stylus sim with --exercise: personal style strength (speed, tremor, force, posture, tilt), 0 = none (default) .. 3");
  sub->add_option("--hand-seed", c->o.hand_seed, "--stylus sim with --exercise: the simulated person (default 1)");
  sub->add_flag("--no-score", c->no_score, "with --record: do not score the session");
  add_db_options(sub, c->db, false);
  add_sound_options(sub, c->sound, true);
  sub->callback([c, &exit_code] {
    if (c->list) {
      std::cout << live::list_cameras() << "\n";
      exit_code = 0;
      return;
    }
    live::LiveOptions o = c->o;
    if (o.device == "sim") {  // --device sim: the simulated hand, as --stylus sim
      o.device.clear();
      o.stylus = "sim";
    }
    c->sound.exercise = o.exercise;  // --teach-force-limit exercise
    if (auto p = drill_params_from(c->sound); !p) {  // a user sample that is not audio: bad input
      print_error("live", p.error());
      exit_code = 2;
      return;
    }
    o.sound_muted = c->sound.mute;
    if (!c->sound.mute) {
      std::ostringstream d;
      d << "volume " << c->sound.volume_pct << " %";
      if (auto lim = teacher_force_limit(c->sound); lim && lim->first > 0) d << ", teacher above " << lim->first << " N";
      o.sound_detail = d.str();
      const SoundCli sc = c->sound;
      o.start_sound = [sc](std::function<haptics::HapticSnapshot()> snap) -> std::shared_ptr<void> {
        return start_live_sound("live", sc, std::move(snap));
      };
    }
    o.hud = !c->no_hud;
    o.vsync = !c->no_vsync;
    o.realtime = !c->no_realtime;
    o.pipeline.predict_s = c->predict_ms * 1e-3;
    o.pipeline.compositor.phantoms = !c->no_occlusion;
    o.pipeline.compositor.segmentation = !c->no_segmentation;
    o.pipeline.compositor.mirror = !c->no_mirror;
    if (o.stylus == "pen") o.pipeline.tracker.track_pen = true;
    if (c->discovery != "async" && c->discovery != "inline") {
      print_error("live", "--discovery " + c->discovery + ": must be async or inline");
      exit_code = 2;
      return;
    }
    o.pipeline.tracker.discovery = c->discovery == "async" ? ar::DiscoveryMode::kAsync : ar::DiscoveryMode::kInline;
    o.pipeline.tracker.mirror_rim_refine = c->mirror_rim;
    if (!c->stereo_mirror_rim.empty()) o.pipeline.tracker.stereo_mirror_rim = c->stereo_mirror_rim == "on";
    if (auto r = ar::parse_camera_response(c->camera_response.empty() ? "auto" : c->camera_response); !r) {
      print_error("live", "--camera-response: " + r.error());
      exit_code = 2;
      return;
    } else {
      o.pipeline.tracker.detector.response = *r;
    }
    for (const auto& s : c->shots) {
      const auto k = s.find(':');
      try {
        if (k == std::string::npos) throw std::invalid_argument("no colon");
        o.screenshots.emplace_back(std::stoll(s.substr(0, k)), s.substr(k + 1));
      } catch (const std::exception&) {
        print_error("live", "--screenshot " + s + ": must be FRAME:FILE.png");
        exit_code = 2;
        return;
      }
    }
    for (const auto& s : c->keys) {
      const auto k = s.find(':');
      try {
        if (k == std::string::npos || s.size() != k + 2 || !std::isalpha(static_cast<unsigned char>(s[k + 1])))
          throw std::invalid_argument("bad");
        o.inject_keys.emplace_back(std::stoll(s.substr(0, k)), std::toupper(static_cast<unsigned char>(s[k + 1])));
      } catch (const std::exception&) {
        print_error("live", "--inject-key " + s + ": must be FRAME:KEY (a letter)");
        exit_code = 2;
        return;
      }
    }
    if (!c->stall.empty()) {
      const auto k = c->stall.find(':');
      try {
        if (k == std::string::npos) throw std::invalid_argument("no colon");
        o.stall_after_frames = std::stoll(c->stall.substr(0, k));
        o.stall_s = std::stod(c->stall.substr(k + 1));
      } catch (const std::exception&) {
        print_error("live", "--inject-stall " + c->stall + ": must be AFTER_FRAMES:SECONDS");
        exit_code = 2;
        return;
      }
    }
    if (!c->stall_right.empty()) {
      const auto k = c->stall_right.find(':');
      try {
        if (k == std::string::npos) throw std::invalid_argument("no colon");
        o.stall_right_after_frames = std::stoll(c->stall_right.substr(0, k));
        o.stall_right_s = std::stod(c->stall_right.substr(k + 1));
      } catch (const std::exception&) {
        print_error("live", "--inject-stall-right " + c->stall_right + ": must be AFTER_FRAMES:SECONDS");
        exit_code = 2;
        return;
      }
    }
    if (!c->headset.empty()) {  // a bad headset profile is bad input (exit 2), before any window
      auto h = live::read_headset_profile(c->headset);
      if (!h) {
        print_error("live", "--headset: " + h.error());
        exit_code = 2;
        return;
      }
      o.headset = std::make_shared<const live::HeadsetProfile>(*h);
      // A window (no --display) is the panel's size unless given.
      if (o.output == "sbs" && o.display < 0 && o.window_width == 0 && o.window_height == 0) {
        o.window_width = h->panel_w;
        o.window_height = h->panel_h;
      }
    }
    if (auto v = o.validate(); !v.empty()) {
      print_error("live", v);
      exit_code = 2;
      return;
    }
    if (std::string e = session::check_exercise(o.exercise); !e.empty()) {
      print_error("live", e);
      exit_code = 2;
      return;
    }
    // Inputs named on the command line that are missing or unreadable are bad input (exit 2),
    // caught before anything starts, as in `dentar offline` and `dentar calibrate`.
    {
      namespace fs = std::filesystem;
      std::error_code ec;
      if (!o.station.empty() && (fs::is_regular_file(o.station, ec) || !ar::builtin_station_scene(o.station))) {
        if (auto st = ar::read_station_scene(o.station); !st) {
          print_error("live", "--station: " + st.error() + " (or a built-in station: default, box)");
          exit_code = 2;
          return;
        }
      }
      for (auto [flag, prefix, value] : {std::tuple{"--camera", "live:", o.camera},
                                         std::tuple{"--camera-right", "live:", o.camera_right},
                                         std::tuple{"--stylus", "replay:", o.stylus}}) {
        const std::string v = value, pre = prefix;
        if (v.rfind(pre, 0) == 0 && !fs::is_regular_file(v.substr(pre.size()), ec)) {
          print_error("live", std::string(flag) + " " + v + ": " + v.substr(pre.size()) + ": no such file");
          exit_code = 2;
          return;
        }
      }
    }
    // An exercise for another tooth than the replayed log drilled is bad input (exit 2).
    if (!o.exercise.empty() && o.stylus.rfind("replay:", 0) == 0 && o.device.empty()) {
      const std::string path = o.stylus.substr(7);
      auto log = haptics::read_session_log(path);
      auto setup = log ? haptics::parse_session_header(log->header_json) : Result<haptics::SessionSetup>(Error{log.error()});
      if (!setup) {
        print_error("live", "--stylus " + o.stylus + ": " + setup.error());
        exit_code = 2;
        return;
      }
      if (auto t = live::live_tooth_json(o.exercise, setup->tooth_json, 0); !t) {
        print_error("live", "--stylus " + o.stylus + ": " + t.error());
        exit_code = 2;
        return;
      }
    }
    if (!o.lesson.empty()) {  // a lesson that does not load is bad input (exit 2), before any window
      auto p = training::resolve_lesson_path(o.lesson);
      auto l = p ? training::load_lesson(*p) : Result<training::Lesson>(Error{p.error()});
      if (!l) {
        print_error("live", "--lesson " + o.lesson + ": " + l.error());
        exit_code = 2;
        return;
      }
    }
    if (!o.record_dir.empty() && !c->no_score) session::remove_old_score(o.record_dir);
    if (!c->db.db.empty() && o.record_dir.empty()) {
      print_error("live", "--db needs --record DIR: the recorded session folder is what is scored and stored");
      exit_code = 2;
      return;
    }
    if (!check_db_options("live", c->db)) {
      exit_code = 2;
      return;
    }
    // Stereo (issue 28): a station without a rig, a side-by-side frame of odd width, two eyes of
    // different sizes or rates are bad input (exit 2), found before the window opens.
    if (o.side_by_side || !o.camera_right.empty()) {
      std::error_code ec;
      const bool builtin = o.station.empty() || (!std::filesystem::is_regular_file(o.station, ec) &&
                                                 ar::builtin_station_scene(o.station));
      auto st = builtin ? Result<ar::StationScene>(*ar::builtin_station_scene(o.station.empty() ? "default" : o.station))
                        : ar::read_station_scene(o.station);
      const std::string what = o.side_by_side ? "--stereo" : "--camera-right";
      if (st && !st->stereo.present) {
        print_error("live", what + ": the station " + (o.station.empty() ? "default" : o.station) +
                                " has no stereo rig (station file \"stereo\": camera_right, T_left_right): calibrate "
                                "the rig with `dentar calibrate stereo`, or give the station.json that `dentar synth "
                                "--stereo` wrote");
        exit_code = 2;
        return;
      }
      ar::StereoSourceOptions so;
      so.source.width = o.width;
      so.source.height = o.height;
      so.source.fps = o.fps;
      auto pair = o.side_by_side ? ar::StereoSource::open_side_by_side(o.camera, so)
                                 : ar::StereoSource::open_pair(o.camera, o.camera_right, so);
      if (!pair) {
        print_error("live", what + ": " + pair.error());
        exit_code = 2;
        return;
      }
    }
    auto r = live::run_live(o);
    if (!r) {
      print_error("live", r.error());
      exit_code = 1;
      return;
    }
    const live::LiveSummary& s = *r;
    if (!o.quiet) {
      std::cout << "frames: " << s.frames_captured << " captured, " << s.frames_processed << " processed, "
                << s.frames_displayed << " displayed (" << s.displayed_fps << " fps); dropped: "
                << s.dropped_source << " by the source, " << s.dropped_consumer << " replaced before use\n"
                << "capture-to-display latency: p50 " << s.latency_p50_ms << " ms, p99 " << s.latency_p99_ms
                << " ms\n"
                << "engine: " << s.engine_steps << " steps, step p99.9 " << s.step_p999_us << " us, max "
                << s.step_max_us << " us, " << s.missed_deadlines << " missed deadlines, " << s.watchdog_trips
                << " watchdog trips; " << (s.realtime_granted ? "SCHED_FIFO" : "no SCHED_FIFO") << ", "
                << (s.cpu_pinned ? "pinned" : "not pinned") << ", " << (s.memory_locked ? "mlockall" : "no mlockall")
                << "\n";
      for (const auto& w : s.warnings) std::cout << "warning: " << w << "\n";
    }
    // The finish step (session/finish.h): a finished recorded session is scored
    // (the recording is complete before this; a failure to score is a warning,
    // never a failed run), then stored with --db.
    namespace fs = std::filesystem;
    session::DriverScoreInput in;
    in.session = (fs::path(o.record_dir) / "session.dlog").string();
    in.out_dir = o.record_dir;
    in.exercise = o.exercise;
    in.frames_csv = (fs::path(o.record_dir) / "frames.csv").string();
    in.station = (fs::path(o.record_dir) / "station.json").string();
    const bool score = !o.record_dir.empty() && !c->no_score;
    if (o.record_dir.empty() && !o.quiet)
      std::cout << "not scored: the session is kept only with --record DIR (then DIR/score.html)\n";
    if (!c->db.db.empty()) announce_lock_waits("live");
    const session::StoreTarget target{c->db.db, c->db.station_db, c->db.student, c->db.station_id, c->db.move};
    const session::FinishOutcome f = session::finish_run(score ? &in : nullptr, target, o.record_dir, "",
                                                         [&](const std::string& s) {
                                                           if (!o.quiet) std::cout << "live: " << s << "\n";
                                                         });
    if (f.scored) std::cout << (f.score.ok ? f.score.line : "warning: " + f.score.warning) << "\n";
    exit_code = 0;
    if (f.stored) {
      if (f.store.exit_code != 0) print_error("live", f.store.error);
      else if (!f.store.warning.empty()) print_error("live", "warning: " + f.store.warning);
      if (f.store.exit_code == 0) std::cout << "live: " << f.store.line << "\n";
      exit_code = f.store.exit_code;
    }
  });
}

}  // namespace dentar::tools
