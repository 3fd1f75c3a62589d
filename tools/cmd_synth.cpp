// dentar synth: recorded footage of the phantom-head station with exact
// ground truth (camera, mirror and bur poses, tag corners, occlusion masks)
// and the matching haptic session log, rendered headless (EGL).
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "commands.h"
#include "dentar/ar/board_clip.h"
#include "dentar/ar/egl_context.h"
#include "dentar/ar/frame_gray.h"
#include "dentar/ar/frame_source.h"
#include "dentar/calibration/co_location.h"
#include "dentar/ar/synth.h"

namespace dentar::tools {
namespace {

std::string write_webcam_video(const std::filesystem::path& dir, double fps, bool stereo);

struct SynthCli {
  std::string preset = "standard";
  int frames = 150;
  double fps = 30;
  std::string resolution = "640x480";
  std::uint64_t seed = 1;
  std::string out = "out/synth";
  bool png = false;
  bool webcam = false;        // --webcam: also camera.avi (Motion JPEG)
  bool yuyv = false;          // --yuyv: also camera_yuyv.avi (raw YUY2, a UVC camera's own format)
  std::string station;        // --station FILE
  std::string write_station;  // --write-default-station FILE
  std::string family;         // --tag-family
  // Overrides; applied only when given (CLI11 count()).
  bool no_distortion = false;
  double noise_dn = 0, occluders = 0, exposure = 0, shutter = 0;
  bool blur = false, no_blur = false, jumps = false;
  double mirror_fraction = 0;
  // --board: a calibration board moved in front of the camera instead of the station.
  std::string board;
  int holds = 16;
  double hold_s = 2.0, move_s = 1.2;
  // Stereo (issue 28): both eyes of a head, side by side in one video.
  bool stereo = false;
  double baseline_mm = 63;
};

// `dentar synth --board SPEC`: the hand-held board clip (ar/board_clip.h). The camera is the
// built-in station's camera at --resolution, perturbed by --seed exactly as the hidden truth of
// `dentar calibrate --simulate` / `calibrate live --haptic sim` with the same seed.
int run_board(const SynthCli& c, const CLI::App& app) {
  ar::BoardClipOptions o;
  o.board = c.board;
  o.holds = c.holds;
  o.hold_s = c.hold_s;
  o.move_s = c.move_s;
  o.fps = app.count("--fps") > 0 ? c.fps : 10.0;
  o.seed = c.seed;
  if (app.count("--noise") > 0) o.noise_dn = c.noise_dn;
  if (std::string e = o.validate(); !e.empty()) {
    print_error("synth", "--board: " + e);
    return 2;
  }
  const auto x = c.resolution.find('x');
  ar::StationScene st = ar::default_station_scene();
  st.calibration.camera = ar::default_camera(std::stoi(c.resolution.substr(0, x)), std::stoi(c.resolution.substr(x + 1)));
  calibration::CameraIntrinsics k = calibration::simulated_truth(st.calibration, c.seed).camera;
  if (c.no_distortion) k.dist = {};
  std::cout << "synth: board clip " << o.board << ", " << o.holds << " poses held " << o.hold_s << " s, moved in "
            << o.move_s << " s, " << o.fps << " fps, " << k.width << "x" << k.height << ", true fx " << k.fx
            << " k1 " << k.dist[0] << " (seed " << o.seed << ")\n";
  auto sum = ar::write_board_clip(k, o, c.out);
  if (!sum) {
    print_error("synth", sum.error());
    return 1;
  }
  std::cout << std::fixed << std::setprecision(1) << "wrote " << c.out
            << ": video.mkv (FFV1), camera.yaml (the true camera), board_truth.jsonl, clip.json; " << sum->frames
            << " frames (" << sum->duration_s << " s of footage) in " << sum->render_s << " s\n";
  return 0;
}

int run(const SynthCli& c, const CLI::App& app) {
  if (!c.write_station.empty()) {
    if (Status s = ar::write_station_scene(ar::default_station_scene(), c.write_station); !s) {
      print_error("synth", s.error());
      return 1;
    }
    std::cout << "wrote the built-in station to " << c.write_station << "\n";
    return 0;
  }
  if (!c.board.empty()) return run_board(c, app);
  auto preset = ar::parse_synth_preset(c.preset);
  ar::SynthOptions o = ar::synth_preset(*preset);
  o.frames = c.frames;
  o.fps = c.fps;
  o.seed = c.seed;
  const auto x = c.resolution.find('x');
  o.width = std::stoi(c.resolution.substr(0, x));
  o.height = std::stoi(c.resolution.substr(x + 1));
  if (c.no_distortion) o.distortion = false;
  if (app.count("--noise") > 0 && o.camera.enabled) {
    print_error("synth", "--noise sets the classic sensor model's noise (DN); --preset " + c.preset +
                             " models the camera's sensor instead (shot and read noise in electrons, "
                             "docs/synth_camera.md): leave --noise out or use a classic preset");
    return 2;
  }
  if (app.count("--noise") > 0) {
    o.read_noise_dn = c.noise_dn;
    o.shot_noise_gain = c.noise_dn > 0 ? 0.03 * c.noise_dn : 0.0;
  }
  if (app.count("--motion-blur") > 0) o.motion_blur = true;
  if (app.count("--no-motion-blur") > 0) o.motion_blur = false;
  if (app.count("--shutter") > 0) o.shutter_fraction = c.shutter;
  if (app.count("--exposure-variation") > 0) o.exposure_variation = c.exposure;
  if (app.count("--exposure-jumps") > 0) o.exposure_jumps = true;
  if (app.count("--occluders") > 0) o.tag_occluders = static_cast<int>(c.occluders);
  if (app.count("--mirror-fraction") > 0) o.mirror_in_mouth_fraction = c.mirror_fraction;
  if (std::string e = o.validate(); !e.empty()) {
    print_error("synth", e);
    return 2;
  }
  ar::StationScene station = ar::default_station_scene();
  if (!c.station.empty() && !std::filesystem::is_regular_file(c.station) && ar::builtin_station_scene(c.station)) {
    station = *ar::builtin_station_scene(c.station);  // `--station box`, as dentar live and dentar tags
  } else if (!c.station.empty()) {
    auto s = ar::read_station_scene(c.station);
    if (!s) {
      print_error("synth", s.error());
      return 2;
    }
    station = std::move(s).value();
  }
  if (!c.family.empty()) station.family = *ar::parse_tag_family(c.family);
  if (app.count("--baseline-mm") > 0 && !c.stereo) {
    print_error("synth", "--baseline-mm " + std::to_string(c.baseline_mm) + " needs --stereo");
    return 2;
  }
  if (c.stereo) {
    o.stereo = true;
    o.stereo_baseline_m = c.baseline_mm * 1e-3;
    // The station's own rig unless --baseline-mm replaces its baseline (the right eye's intrinsics kept).
    if (!station.stereo.present || app.count("--baseline-mm") > 0)
      station.stereo = ar::make_stereo_rig(
          station.calibration.camera, o.stereo_baseline_m,
          station.stereo.present ? std::optional(station.stereo.camera_right) : std::nullopt);
    if (std::string e = o.validate(); !e.empty()) {
      print_error("synth", "--baseline-mm: " + e);
      return 2;
    }
    if (std::string e = station.validate(); !e.empty()) {
      print_error("synth", (c.station.empty() ? std::string("station") : c.station) + ": " + e);
      return 2;
    }
  }

  auto ctx = ar::EglContext::create();
  if (!ctx) {
    print_error("synth", "no headless EGL context: " + ctx.error());
    return 1;
  }
  std::cout << "synth: preset " << c.preset << ", " << o.frames << " frames at " << o.fps
            << " fps, " << o.width << "x" << o.height << ", seed " << o.seed
            << (o.distortion ? "" : ", no distortion") << (o.motion_blur ? ", motion blur" : "")
            << (o.stereo ? ", stereo side by side, baseline " + std::to_string(station.stereo.baseline_m() * 1e3).substr(0, 5) + " mm" : "")
            << "; " << ctx->description() << "\n";
  const int every = std::max(1, o.frames / 10);
  auto sum = ar::run_synth(station, o, c.out, c.png, [&](int n) {
    if (n % every == 0 || n == o.frames)
      std::cout << "  " << n << "/" << o.frames << " frames\n" << std::flush;
  });
  if (!sum) {
    print_error("synth", sum.error());
    return 1;
  }
  if (c.webcam) {
    if (std::string e = write_webcam_video(c.out, o.fps, c.stereo); !e.empty()) {
      print_error("synth", "--webcam: " + e);
      return 1;
    }
  }
  if (c.yuyv) {
    // camera_yuyv.avi: the footage as a YUYV camera sends it (issue 28), streamed from video.mkv.
    const std::string in_path = (std::filesystem::path(c.out) / "video.mkv").string();
    const std::string out_path = (std::filesystem::path(c.out) / "camera_yuyv.avi").string();
    cv::VideoCapture in(in_path, cv::CAP_FFMPEG);
    cv::Mat bgr;
    const auto st = ar::write_yuyv_avi(
        out_path,
        [&](cv::Mat& f) {
          if (!in.read(bgr) || bgr.empty()) return false;
          ar::bgr_to_yuyv(bgr, f);
          return true;
        },
        o.fps);
    if (!st) {
      print_error("synth", "--yuyv: " + st.error());
      return 1;
    }
    std::cout << "wrote " << out_path << " (YUYV, what a UVC camera sends)\n";
  }
  std::cout << std::fixed << std::setprecision(1) << "wrote " << c.out << ": "
            << (c.png ? "frames/*.png"
                     : c.webcam ? (c.stereo ? "video.mkv (FFV1), camera.avi, camera_left.avi, camera_right.avi (Motion JPEG)"
                                            : "video.mkv (FFV1), camera.avi (Motion JPEG)")
                                : "video.mkv (FFV1)")
            << (c.stereo ? " (left | right)" : "")
            << ", truth.jsonl, masks/" << (c.stereo ? ", truth_right.jsonl, masks_right/" : "")
            << ", station.json, session.dlog, synth.json\n"
            << sum->frames << " frames in " << sum->seconds << " s ("
            << sum->frames / std::max(sum->seconds, 1e-9) << " fps); mirror in view in "
            << sum->frames_with_mirror << " frames; " << sum->mean_visible_tags
            << " head tags visible per frame (mean)\n";
  return 0;
}

// camera.avi beside video.mkv: the same frames as Motion JPEG (OpenCV's own
// AVI writer, quality 90), what a UVC webcam delivers at 720p. A live
// stand-in must decode a frame in well under a frame period; FFV1 at 720p
// takes ~47 ms here, MJPG ~10 ms. Stereo (side-by-side footage): camera.avi
// is the side-by-side device (dentar live --stereo), camera_left.avi and
// camera_right.avi the two eyes as two cameras (--camera-right). Returns an
// error message or "".
std::string write_webcam_video(const std::filesystem::path& dir, double fps, bool stereo) {
  const std::string in_path = (dir / "video.mkv").string();
  cv::VideoCapture in(in_path, cv::CAP_FFMPEG);
  cv::Mat f;
  if (!in.isOpened() || !in.read(f) || f.empty()) return in_path + ": cannot read the footage back";
  if (stereo && f.cols % 2 != 0) return in_path + ": side-by-side footage of odd width " + std::to_string(f.cols);
  struct Out {
    std::string path;
    cv::Rect crop;
  };
  std::vector<Out> outs;
  const cv::Rect whole(0, 0, f.cols, f.rows), left(0, 0, f.cols / 2, f.rows), right(f.cols / 2, 0, f.cols / 2, f.rows);
  outs.push_back({(dir / "camera.avi").string(), whole});
  if (stereo) {
    outs.push_back({(dir / "camera_left.avi").string(), left});
    outs.push_back({(dir / "camera_right.avi").string(), right});
  }
  // Each frame a JPEG from libjpeg (cv::imencode, quality 90, 4:2:0) in our own AVI writer.
  // Session 20: OpenCV's built-in MJPEG writer (CAP_OPENCV_MJPEG, sessions 17-19) left the
  // entropy data of ~3 % of its frames short (libjpeg: "premature end of data segment"), so
  // the live stand-ins counted good footage as corrupt camera frames (docs/BENCHMARKS.md).
  for (const Out& o : outs) {
    cv::VideoCapture src(in_path, cv::CAP_FFMPEG);
    if (!src.isOpened()) return in_path + ": cannot read the footage back";
    std::string err;
    auto s = ar::write_mjpeg_avi(
        o.path,
        [&](std::vector<std::uint8_t>& bytes) {
          cv::Mat g;
          if (!src.read(g) || g.empty()) return false;
          if (g.cols != f.cols || g.rows != f.rows) {
            err = in_path + ": a frame of another size";
            return false;
          }
          if (!cv::imencode(".jpg", g(o.crop), bytes, {cv::IMWRITE_JPEG_QUALITY, 90})) {
            err = o.path + ": JPEG encoding failed (OpenCV imencode)";
            return false;
          }
          return true;
        },
        o.crop.width, o.crop.height, fps);
    if (!err.empty()) return err;
    if (!s) return s.error();
  }
  return {};
}

}  // namespace

void add_synth(CLI::App& app, int& exit_code) {
  auto c = std::make_shared<SynthCli>();
  CLI::App* s = app.add_subcommand(
      "synth",
      "Render footage of the phantom-head station with exact ground truth: video, per-frame\n"
      "poses and tag corners (truth.jsonl), tooth occlusion masks, the station file and the\n"
      "haptic session log of the scripted drilling. Headless (EGL); deterministic per seed.\n"
      "Synopsis: dentar synth [--preset standard|hard|mirror|hand|glare|lowlight|fast|offframe|webcam|headset]\n"
      "                       [--frames N] [--fps F]\n"
      "                       [--resolution 640x480|1280x720|1920x1080] [--seed S] [--out DIR]\n"
      "                       [--png | --webcam] [--no-distortion] [--noise DN] [--motion-blur]\n"
      "                       [--exposure-variation A] [--exposure-jumps] [--occluders N]\n"
      "                       [--station FILE] [--tag-family tagStandard41h12|tag36h11]\n"
      "                       [--stereo [--baseline-mm MM]]\n"
      "       dentar synth --board SPEC [--holds N] [--hold S] [--move S] [--fps F] [--seed S] [--out DIR]");
  s->add_option("--preset", c->preset,
                "standard, hard (fast motion, blur, grazing/small tags, occlusion), mirror "
                "(mirror in view), or one failure mode on standard: hand (a finger crosses the "
                "tooth), glare (on the mirror), lowlight (dim and noisy), fast (head turns "
                ">= 200 deg/s), offframe (tags cut by the frame edge); or standard through a real camera's "
                "model (docs/synth_camera.md): webcam (rolling shutter, MJPG, small pixels, auto-exposure "
                "steps) or headset (global shutter, fixed focus, cos^4 vignetting)")
      ->check(CLI::IsMember({"standard", "hard", "mirror", "hand", "glare", "lowlight", "fast", "offframe", "webcam", "headset"}))
      ->capture_default_str();
  s->add_option("--frames", c->frames, "Number of frames")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  s->add_option("--fps", c->fps, "Frame rate (Hz)")
      ->check(CLI::Range(1.0, 240.0))
      ->capture_default_str();
  s->add_option("--resolution", c->resolution, "Image size")
      ->check(CLI::IsMember({"640x480", "1280x720", "1920x1080"}))
      ->capture_default_str();
  s->add_option("--seed", c->seed, "Random seed (same seed, same footage)")->capture_default_str();
  s->add_option("--out", c->out, "Output folder")->capture_default_str();
  s->add_flag("--png", c->png, "Write frames/frame_NNNNNN.png instead of video.mkv");
  s->add_flag("--webcam", c->webcam,
              "Also write camera.avi: the footage as Motion JPEG, what a webcam delivers at 720p "
              "(for dentar live --camera live:DIR/camera.avi); with --stereo also camera_left.avi and "
              "camera_right.avi, the eyes as two cameras (--camera-right)")
      ->excludes("--png");
  s->add_flag("--yuyv", c->yuyv,
              "Also write camera_yuyv.avi: the footage as raw YUYV 4:2:2, what a UVC camera sends uncompressed "
              "(for dentar live --camera live:DIR/camera_yuyv.avi; 4 MB a 1080p frame)")
      ->excludes("--png");
  s->add_flag("--no-distortion", c->no_distortion, "Pinhole camera (no lens distortion)");
  s->add_option("--noise", c->noise_dn,
                "Sensor read noise (8-bit DN; shot noise scales with it; 0 = off)")
      ->check(CLI::Range(0.0, 50.0));
  s->add_flag("--motion-blur", c->blur, "Average sub-frames over the exposure");
  s->add_flag("--no-motion-blur", c->no_blur, "No motion blur (even for --preset hard)");
  s->add_option("--shutter", c->shutter, "Exposure time / frame period for motion blur")
      ->check(CLI::Range(0.01, 1.0));
  s->add_option("--exposure-variation", c->exposure, "Slow exposure drift, relative amplitude")
      ->check(CLI::Range(0.0, 0.5));
  s->add_flag("--exposure-jumps", c->jumps, "Sudden +-25 % exposure steps (auto-exposure)");
  s->add_option("--occluders", c->occluders, "Skin-coloured occluders hovering over tags")
      ->check(CLI::Range(0, 32));
  s->add_option("--mirror-fraction", c->mirror_fraction,
                "Fraction of time the mirror is in the mouth")
      ->check(CLI::Range(0.0, 1.0));
  s->add_option("--station", c->station,
                "Station file, or a built-in station: default (the phantom head), box (the flat tag board of "
                "`dentar tags --station box`, drawn on a box)");
  s->add_flag("--stereo", c->stereo,
             "Both eyes of a stereo head (issue 28): video.mkv side by side (left | right), truth.jsonl "
             "and masks/ of the left eye (the rig frame), truth_right.jsonl and masks_right/ of the right, "
             "the rig in station.json (\"stereo\"); docs/formats.md");
  s->add_option("--baseline-mm", c->baseline_mm, "--stereo: the distance between the eyes (mm)")
      ->capture_default_str();
  s->add_option("--tag-family", c->family, "Override the station's tag family")
      ->check(CLI::IsMember({"tagStandard41h12", "tag36h11"}));
  s->add_option("--board", c->board,
                "Instead of the station: a calibration board (aprilgrid:6x5:24:8:tag36h11, chessboard:9x6:20) "
                "moved by hand in front of the camera, held still at --holds poses (the stand-in camera "
                "for `dentar calibrate live --steps camera`); writes camera.yaml with the true camera");
  s->add_option("--holds", c->holds, "--board: poses the board is held at")->check(CLI::Range(1, 200))->capture_default_str();
  s->add_option("--hold", c->hold_s, "--board: seconds held still at each pose")->check(CLI::Range(0.2, 60.0))->capture_default_str();
  s->add_option("--move", c->move_s, "--board: seconds moving between poses")->check(CLI::Range(0.1, 60.0))->capture_default_str();
  s->add_option("--write-default-station", c->write_station,
                "Only write the built-in station JSON to FILE and exit");
  s->footer(
      "Example:\n"
      "  dentar synth --preset standard --frames 300 --fps 30 --resolution 1280x720 --seed 7 \\\n"
      "               --out out/synth_std\n"
      "  dentar synth --preset hard --frames 60 --png --out out/synth_hard\n"
      "  dentar synth --preset mirror --stereo --baseline-mm 63 --frames 60 --out out/synth_stereo\n"
      "  dentar synth --board aprilgrid:6x5:24:8 --holds 16 --seed 3 --out out/board_clip");
  s->callback([c, s, &exit_code] { exit_code = run(*c, *s); });
}

}  // namespace dentar::tools
