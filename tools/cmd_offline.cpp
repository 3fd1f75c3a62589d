// dentar offline: recorded footage through the whole trainer pipeline
// (tracking, haptic replay, meshing, compositing) for testers; writes the
// composited video, per-frame CSV, summary JSON and an HTML report. With no
// footage it first generates the built-in footage (the README's main job).
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

#include "commands.h"
#include "db_util.h"
#include "dentar/offline/offline.h"
#include "dentar/ar/station_scene.h"
#include "dentar/sound/mux.h"
#include "dentar/session/finish.h"
#include "sound_cli.h"

namespace dentar::tools {
namespace {

struct OfflineCli {
  std::string footage, station, session, truth, masks;
  std::string out = "out/offline";
  std::string preset = "standard";
  int frames = 90;
  std::string resolution = "1280x720";
  std::uint64_t seed = 1;
  int max_frames = 0;
  bool no_video = false, scale_calib = false, quiet = false;
  std::string video_codec = "mjpg";
  double decimate = 2.0;
  bool no_roi = false, no_filter = false, no_occlusion = false, no_segmentation = false,
       no_mirror = false;
  double expert_opacity = 0.45;
  int full_every = 15;
  double predict_ms = -1, stale_ms = 200;  // predict_ms -1: not given (0, or a recording's)
  double mirror_sigma_mm = 1.0;
  std::string camera_response;  // "" = the recording's, else auto|srgb|linear
  bool mirror_rim = false;
  std::string stereo_mirror_rim;  // on|off, empty = the default (a recording: as recorded)
  std::size_t triangle_budget = 0;
  std::string exercise;  // scoring: exercise name or file ("" = recorded / by the tooth)
  bool no_score = false;
  SoundCli sound;  // --audio FILE.wav: the session's drill sound (issue 29)
  bool audio_mux = false;  // --audio-mux: also composite_audio.mkv (the video with the sound)
  // Stereo footage (issue 28): both eyes (--stereo, --footage-right), or one eye (--eye).
  bool stereo = false;
  std::string footage_right, eye;
};

// One progress line: a bar on a terminal (redrawn in place), else a line
// every 10 % so logs stay short.
class ProgressBar {
 public:
  explicit ProgressBar(bool quiet) : quiet_(quiet), tty_(isatty(STDERR_FILENO) != 0) {}
  void update(const std::string& phase, int done, int total) {
    if (quiet_) return;
    if (phase != phase_) {
      if (tty_ && !phase_.empty()) std::cerr << "\n";
      phase_ = phase;
      last_decile_ = -1;
    }
    if (tty_) {
      const int width = 30;
      const int fill = total > 0 ? width * done / total : 0;
      std::cerr << "\r" << std::setw(8) << std::left << phase << " [" << std::string(fill, '#')
                << std::string(width - fill, ' ') << "] " << done;
      if (total > 0) std::cerr << "/" << total;
      std::cerr << " frames" << std::flush;
      if (total > 0 && done == total) std::cerr << "\n";
    } else if (total > 0) {
      const int decile = 10 * done / total;
      if (decile != last_decile_) {
        last_decile_ = decile;
        std::cerr << phase << ": " << done << "/" << total << " frames\n";
      }
    }
  }

 private:
  bool quiet_, tty_;
  std::string phase_;
  int last_decile_ = -1;
};

std::string f3(double v) {
  std::ostringstream s;
  s << std::setprecision(3) << v;
  return s.str();
}

int run(const OfflineCli& c) {
  offline::OfflineOptions o;
  o.footage = c.footage;
  o.station = c.station;
  o.session = c.session;
  o.truth = c.truth;
  o.masks = c.masks;
  o.out_dir = c.out;
  o.preset = *ar::parse_synth_preset(c.preset);
  o.builtin_frames = c.frames;
  const auto x = c.resolution.find('x');
  o.builtin_width = std::stoi(c.resolution.substr(0, x));
  o.builtin_height = std::stoi(c.resolution.substr(x + 1));
  o.seed = c.seed;
  o.max_frames = c.max_frames;
  o.write_video = !c.no_video;
  o.video_codec = c.video_codec;
  o.scale_calib = c.scale_calib;
  o.stereo = c.stereo || !c.footage_right.empty() || c.eye == "both";
  o.footage_right = c.footage_right;
  o.eye = c.eye;
  o.predict_s = std::max(0.0, c.predict_ms) * 1e-3;
  o.predict_given = c.predict_ms >= 0;
  o.tracker.detector.decimation = c.decimate;
  o.tracker.predicted_regions = !c.no_roi;
  o.tracker.full_frame_interval = c.full_every;
  o.tracker.filter_enabled = !c.no_filter;
  o.tracker.stale_limit_s = c.stale_ms * 1e-3;
  o.tracker.mirror_max_sigma_m = c.mirror_sigma_mm * 1e-3;
  o.tracker.mirror_rim_refine = c.mirror_rim;
  o.mirror_rim_given = c.mirror_rim;
  if (!c.stereo_mirror_rim.empty()) {
    o.tracker.stereo_mirror_rim = c.stereo_mirror_rim == "on";
    o.stereo_mirror_rim_given = true;
  }
  if (!c.camera_response.empty()) {
    auto r = ar::parse_camera_response(c.camera_response);
    if (!r) {
      print_error("offline", "--camera-response: " + r.error());
      return 2;
    }
    o.tracker.detector.response = *r;
    o.camera_response_given = true;
  }
  o.compositor.phantoms = !c.no_occlusion;
  o.compositor.segmentation = !c.no_occlusion && !c.no_segmentation;
  o.compositor.mirror = !c.no_mirror;
  o.expert.draw = c.expert_opacity > 0;
  if (c.expert_opacity > 0) o.expert.opacity = c.expert_opacity;
  o.compositor.triangle_budget = c.triangle_budget;
  if (std::string e = o.validate(); !e.empty()) {
    print_error("offline", e);
    return 2;
  }
  // Stereo inputs that do not fit (no rig, odd width, eyes of different sizes or rates): bad input.
  if (std::string e = offline::check_stereo_inputs(o); !e.empty()) {
    print_error("offline", e);
    return 2;
  }
  if (o.footage.empty())
    std::cout << "offline: no --footage given: generating the built-in footage (" << c.preset << ", "
              << c.frames << " frames, " << c.resolution << ") into " << c.out << "/footage\n";
  // Score the replayed session into the same folder (score.json, score.html,
  // linked from report.html). A failure to score is a warning, not a failed run.
  std::string score_line;
  if (!c.no_score) session::remove_old_score(c.out);
  if (c.audio_mux) {  // a muxed file from an earlier run must not pass for this run's
    std::error_code ec;
    std::filesystem::remove(std::filesystem::path(c.out) / "composite_audio.mkv", ec);
  }
  if (!c.no_score)
    o.after_run = [&](offline::OfflineSummary& s) -> std::string {
      if (s.session.empty()) return {};
      session::DriverScoreInput in;
      in.session = s.session;
      in.out_dir = s.out_dir;
      in.exercise = c.exercise;
      if (std::filesystem::exists(std::filesystem::path(c.footage) / "recording.json")) in.recording = c.footage;
      in.frames_csv = (std::filesystem::path(s.out_dir) / "frames.csv").string();
      in.station = s.station;
      // Built-in footage drills for a few seconds: its score is shown beside
      // a whole generated expert and novice session of the same exercise.
      in.compare = c.footage.empty();
      if (!c.quiet) std::cerr << "scoring the session ...\n";
      const session::DriverScore d = session::score_after_run(in);
      if (!d.ok) {
        s.warnings.push_back(d.warning);
        return "<p class=\"bad\">" + d.warning + "</p>";
      }
      score_line = d.line;
      return d.html;
    };
  ProgressBar bar(c.quiet);
  auto sum = offline::run_offline(o, [&](const std::string& phase, int done, int total) {
    bar.update(phase, done, total);
  });
  if (!sum) {
    print_error("offline", sum.error());
    // Bad input (files, sizes, lengths) and job failures both end here; the
    // message says which input. Inputs that cannot be opened are exit 2.
    return 1;
  }
  const auto& s = *sum;
  std::cout << "offline: " << s.frames << " frames (" << f3(s.footage_s) << " s of footage) in "
            << f3(s.wall_s) << " s; mannequin tracking " << s.tracking << ", predicted " << s.predicted
            << ", lost " << s.lost << "; overlay drawn in " << s.overlays << " frames\n";
  if (s.stereo)
    std::cout << "  stereo: both eyes " << s.eyes_both << " frames, left eye alone " << s.eyes_left
              << ", right eye alone " << s.eyes_right << "; mannequin fitted to both eyes in " << s.man_two_views
              << " frames; " << s.stereo_capture << "\n";
  if (s.both_eyes)
    std::cout << "  right eye: its own composite in " << s.right_composited << " frames (tooth drawn in "
              << s.right_overlays << ")"
              << (s.right_tooth_err_px.n > 0 ? "; tooth against its truth p95 " + f3(s.right_tooth_err_px.p95) + " px" : "")
              << (s.right_silhouette_iou.n > 0 ? ", silhouette IoU median " + f3(s.right_silhouette_iou.median) : "")
              << "\n";
  if (s.expert_frames > 0)
    std::cout << "  expert's tool drawn in " << s.expert_frames << " frames (" << s.expert_drilling_frames
              << " with mode 5's drilling colours)\n";
  if (s.note_frames > 0) std::cout << "  lesson notes drawn beside the tooth in " << s.note_frames << " frames\n";
  if (s.has_truth)
    std::cout << "  errors (median / p95): pose " << f3(s.man_err_mm.median) << " / " << f3(s.man_err_mm.p95)
              << " mm, " << f3(s.man_err_deg.median) << " / " << f3(s.man_err_deg.p95)
              << " deg; tooth " << f3(s.tooth_err_px.median) << " / " << f3(s.tooth_err_px.p95)
              << " px; bur tip " << f3(s.tip_err_mm.median) << " / " << f3(s.tip_err_mm.p95)
              << " mm; visible-tooth IoU " << f3(s.silhouette_iou.median) << " / "
              << f3(s.silhouette_iou.p95) << "\n";
  std::cout << "  time per frame (median / p99 ms): track " << f3(s.track_ms.median) << " / "
            << f3(s.track_ms.p99) << ", composite " << f3(s.composite_ms.median) << " / "
            << f3(s.composite_ms.p99) << ", capture-to-composite latency " << f3(s.latency_ms.median)
            << " / " << f3(s.latency_ms.p99) << "\n";
  for (const auto& w : s.warnings) std::cout << "  warning: " << w << "\n";
  if (!score_line.empty()) std::cout << score_line << "\n";
  if (!c.sound.audio.empty()) {
    // The replayed session's drill sound, time-aligned with composite.mkv (step n at n / rate_hz).
    if (s.session.empty()) {
      std::cout << "  warning: --audio " << c.sound.audio << ": no session log was replayed (no drilling): no sound written\n";
    } else if (int rc = render_session_wav("offline", s.session, c.sound.audio, c.sound, c.quiet,
                                         s.haptic_steps); rc != 0) {
      return rc == 2 ? 1 : rc;  // the session was read once already: a failure here is the job's
    } else if (c.audio_mux) {
      // composite.mkv stays as it was (silent); the copy with the sound is composite_audio.mkv.
      const std::string video = (std::filesystem::path(s.out_dir) / "composite.mkv").string();
      const std::string muxed = (std::filesystem::path(s.out_dir) / "composite_audio.mkv").string();
      auto m = sound::mux_wav_into_video(video, c.sound.audio, muxed);
      if (!m) {
        print_error("offline", "--audio-mux: " + m.error());
        return 1;
      }
      if (!c.quiet)
        std::cout << "wrote " << muxed << " (composite.mkv's " << m->video_frames << " frames, not re-encoded, "
                  << "with the drill sound as 16-bit PCM, " << f3(m->video_s) << " s"
                  << (m->padded_samples > 0 ? ", the sound padded with silence to the video's end" : "")
                  << (m->trimmed_samples > 0 ? ", the sound cut at the video's end" : "") << ")\n";
    }
  }
  std::cout << "wrote " << s.out_dir << "/report.html, summary.json, frames.csv"
            << (o.write_video ? ", composite.mkv" : "") << (o.write_video && s.both_eyes ? ", composite_right.mkv" : "")
            << "\n";
  return 0;
}

}  // namespace

void add_offline(CLI::App& app, int& exit_code) {
  auto c = std::make_shared<OfflineCli>();
  auto db = std::make_shared<DbCli>();  // --db: score and store the replayed session
  CLI::App* s = app.add_subcommand(
      "offline",
      "Run recorded footage through the whole trainer pipeline, as testers do: tracking of the\n"
      "mannequin and mirror, haptic replay of the session log at 1 kHz in step with the video,\n"
      "re-meshing of the cut tooth and compositing (tooth, bur, mirror reflection, occlusion).\n"
      "Writes composite.mkv, frames.csv, summary.json and report.html (plots) into --out, and\n"
      "scores the session (score.json, score.html, linked from report.html; see dentar score).\n"
      "With no --footage it generates built-in footage first (dentar synth) and runs on that;\n"
      "ground truth beside the footage (truth.jsonl, masks/) is used to measure errors.\n"
      "Synopsis: dentar offline [--footage VIDEO|DIR --station FILE [--session LOG]]\n"
      "                         [--truth FILE|none] [--masks DIR|none] [--out DIR]\n"
      "                         [--preset P] [--frames N] [--resolution WxH] [--seed S]\n"
      "                         [--max-frames N] [--no-video] [--video-codec mjpg|ffv1]\n"
      "                         [--scale-calib] [--quiet] [--stereo [--footage-right VIDEO] [--eye both] | --eye left|right]\n"
      "                         [--decimate D] [--no-roi] [--full-every N] [--no-filter]\n"
      "                         [--predict-ms MS] [--stale-ms MS] [--mirror-sigma-mm MM] [--no-occlusion]\n"
      "                         [--camera-response auto|srgb|linear] [--mirror-rim]\n"
      "                         [--stereo-mirror-rim on|off] [--no-segmentation] [--no-mirror] [--triangle-budget N]\n"
      "                         [--exercise NAME|FILE] [--no-score]\n"
      "                         [--audio FILE.wav [--audio-mux] [--volume PCT] [--mute] [--drill-sample FILE]]");
  s->add_option("--footage", c->footage, "Video file, image folder or `dentar live --record` folder (default: generate built-in footage)");
  s->add_option("--station", c->station, "Station file (JSON) the footage was recorded with");
  s->add_flag("--stereo", c->stereo,
              "Stereo footage of the station's rig (issue 28): side by side (left | right, dentar synth "
              "--stereo), or --footage the left eye and --footage-right the right; each body fitted to both "
              "eyes' corners; an eye that ends first leaves the other alone (frames.csv column eyes)");
  s->add_option("--footage-right", c->footage_right, "The right eye's recording (implies --stereo)");
  s->add_option("--eye", c->eye,
                "left|right: one eye of side-by-side stereo footage through the one-camera path, against "
                "that eye's truth (the mono anchor on the same frames); both: a stereo run (implies --stereo) "
                "that also composites the right eye, into composite_right.mkv")
      ->check(CLI::IsMember({"left", "right", "both"}));
  s->add_option("--session", c->session, "Haptic session log (.dlog) to replay in step with the video");
  s->add_option("--truth", c->truth, "Ground truth truth.jsonl (default: beside the footage; none = ignore)");
  s->add_option("--masks", c->masks, "Ground-truth masks folder (default: beside the footage; none = ignore)");
  s->add_option("--out", c->out, "Output folder")->capture_default_str();
  s->add_option("--preset", c->preset, "Built-in footage preset (dentar synth --help)")
      ->check(CLI::IsMember({"standard", "hard", "mirror", "hand", "glare", "lowlight", "fast", "offframe", "webcam", "headset"}))
      ->capture_default_str();
  s->add_option("--frames", c->frames, "Built-in footage length (frames at 30 fps)")
      ->check(CLI::Range(2, 100000))
      ->capture_default_str();
  s->add_option("--resolution", c->resolution, "Built-in footage size")
      ->check(CLI::IsMember({"640x480", "1280x720", "1920x1080"}))
      ->capture_default_str();
  s->add_option("--seed", c->seed, "Built-in footage seed")->capture_default_str();
  s->add_option("--max-frames", c->max_frames, "Stop after N frames (0 = all)")->check(CLI::Range(0, 10000000));
  s->add_flag("--no-video", c->no_video, "Do not write composite.mkv");
  s->add_option("--video-codec", c->video_codec, "composite.mkv codec: mjpg (fast) or ffv1 (lossless)")
      ->check(CLI::IsMember({"mjpg", "ffv1"}))
      ->capture_default_str();
  s->add_flag("--scale-calib", c->scale_calib,
              "Accept footage of another size with the same aspect ratio (intrinsics scaled)");
  s->add_flag("--quiet", c->quiet, "No progress bar");
  s->add_option("--decimate", c->decimate, "AprilTag quad decimation")->check(CLI::Range(1.0, 8.0))->capture_default_str();
  s->add_flag("--no-roi", c->no_roi, "Full-frame tag search every frame (no predicted regions)");
  s->add_option("--full-every", c->full_every, "Full-frame search interval (frames)")
      ->check(CLI::Range(1, 10000))
      ->capture_default_str();
  s->add_flag("--no-filter", c->no_filter, "No temporal pose filter");
  s->add_option("--predict-ms", c->predict_ms, "Predict poses this far past the capture time (default 0; a live recording: as it was recorded)")
      ->check(CLI::Range(0.0, 500.0));
  s->add_option("--mirror-sigma-mm", c->mirror_sigma_mm,
                "Hide the mirror's reflection when its centre's position sigma exceeds this "
                "(mm; 0 = always draw it)")
      ->check(CLI::Range(0.0, 1000.0))
      ->capture_default_str();
  add_tracker_image_options(s, c->camera_response, c->mirror_rim);
  add_stereo_mirror_rim_option(s, c->stereo_mirror_rim);
  s->add_option("--stale-ms", c->stale_ms, "Drop the overlay this long after tracking is lost")
      ->check(CLI::Range(0.0, 5000.0))
      ->capture_default_str();
  s->add_flag("--no-occlusion", c->no_occlusion, "Draw the tooth over everything (no occlusion)");
  s->add_flag("--no-segmentation", c->no_segmentation, "Occlusion by known geometry only (no hand segmentation)");
  s->add_flag("--no-mirror", c->no_mirror, "No reflection in the mirror");
  s->add_option("--expert-opacity", c->expert_opacity,
                "A session from `dentar lesson run`: the expert's tool drawn with this opacity (0 = not drawn)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  s->add_option("--triangle-budget", c->triangle_budget, "Tooth triangles drawn per frame (0 = no limit)");
  s->add_option("--exercise", c->exercise,
                "Exercise the session is scored against: built-in name (molar_access_opening, molar_class1_cavity,\n"
                "incisor_partial_crown) or a JSON file; default: the recording's, else by the tooth (the\n"
                "built-in footage drills the molar access opening)");
  s->add_flag("--no-score", c->no_score, "Do not score the session (no score.json / score.html)");
  s->add_option("--audio", c->sound.audio,
                "Also render the session's drill sound to this WAV file, time-aligned with composite.mkv "
                "(docs/sound.md)");
  s->add_flag("--audio-mux", c->audio_mux,
              "With --audio: also write composite_audio.mkv, composite.mkv (not re-encoded) with the sound "
              "as a 16-bit PCM track, cut or padded to the video's length");
  add_sound_options(s, c->sound, false);
  s->footer(
      "Examples:\n"
      "  dentar offline --out out/offline                 # built-in footage, the README job\n"
      "  dentar synth --preset hard --resolution 1280x720 --out out/hard\n"
      "  dentar offline --footage out/hard/video.mkv --station out/hard/station.json \\\n"
      "                 --session out/hard/session.dlog --out out/hard-run\n"
      "  dentar offline --footage out/rec --out out/rec-run   # a `dentar live --record` folder\n"
      "  dentar synth --preset mirror --stereo --frames 60 --out out/st\n"
      "  dentar offline --stereo --footage out/st/video.mkv --station out/st/station.json \\\n"
      "                 --session out/st/session.dlog --out out/st-run      # both eyes\n"
      "  dentar offline --eye left --footage out/st/video.mkv --station out/st/station.json \\\n"
      "                 --session out/st/session.dlog --out out/st-mono     # the left eye alone");
  add_db_options(s, *db, false);
  s->callback([c, db, &exit_code] {
    if (!check_db_options("offline", *db)) {
      exit_code = 2;
      return;
    }
    const bool recording = !c->footage.empty() && std::filesystem::exists(std::filesystem::path(c->footage) / "recording.json");
    if (!c->footage.empty() && c->station.empty() && !recording) {
      print_error("offline", "--footage needs --station (the station file the footage was recorded with), "
                             "unless it is a `dentar live --record` folder");
      exit_code = 2;
      return;
    }
    // Inputs that do not exist are bad input (exit 2), caught before any work.
    for (auto [flag, path] : {std::pair{"--footage", c->footage}, std::pair{"--station", c->station},
                              std::pair{"--session", c->session}, std::pair{"--footage-right", c->footage_right}}) {
      if (!path.empty() && !std::filesystem::exists(path)) {
        print_error("offline", std::string(flag) + " " + path + ": no such file or folder");
        exit_code = 2;
        return;
      }
    }
    if (!c->station.empty()) {  // a station file that cannot be read is bad input, as in calibrate and live
      if (auto st = ar::read_station_scene(c->station); !st) {
        print_error("offline", "--station: " + st.error());
        exit_code = 2;
        return;
      }
    }
    if (std::string e = session::check_exercise(c->exercise); !e.empty()) {
      print_error("offline", e);
      exit_code = 2;
      return;
    }
    if (c->audio_mux && (c->sound.audio.empty() || c->no_video)) {
      print_error("offline", c->no_video ? "--audio-mux needs the video: drop --no-video"
                                         : "--audio-mux needs --audio FILE.wav (the sound track to mux)");
      exit_code = 2;
      return;
    }
    // --teach-force-limit exercise: the exercise the session is scored against (given, or the recording's).
    c->sound.exercise = !c->exercise.empty() ? c->exercise : recording ? session::recorded_exercise(c->footage) : "";
    if (!c->sound.audio.empty()) {  // a user sample that is not audio is bad input, caught first
      if (auto p = drill_params_from(c->sound); !p) {
        print_error("offline", p.error());
        exit_code = 2;
        return;
      }
    }
    exit_code = run(*c);
    if (exit_code == 0 && !db->db.empty()) {  // the session log the run replayed
      namespace fs = std::filesystem;
      const std::string log = !c->session.empty() ? c->session
                              : c->footage.empty() ? (fs::path(c->out) / "footage" / "session.dlog").string()
                                                   : (fs::path(c->footage) / "session.dlog").string();
      exit_code = store_finished_session("offline", *db, log, c->out, c->quiet);
    }
  });
}

}  // namespace dentar::tools
