// dentar track: fiducial tracking of the mannequin and the mirror on a video,
// an image folder or a live camera; one JSON line per frame (poses.jsonl,
// docs/formats.md "Tracking output"). --tags: every tag's own pose instead.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <vector>

#include "commands.h"
#include "dentar/ar/frame_source.h"
#include "dentar/ar/stereo_source.h"
#include "dentar/ar/stereo_tracker.h"
#include "dentar/ar/synth.h"
#include "dentar/ar/tracker.h"

namespace dentar::tools {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct TrackCli {
  std::string input, calib, layout, out;
  std::string family;
  double decimate = 2.0;
  int threads = 1;
  std::string camera_response;  // "" = auto
  bool mirror_rim = false;
  std::string stereo_mirror_rim;  // on|off, empty = the default
  bool no_roi = false;
  int full_every = 15;
  bool no_filter = false;
  double stale_ms = 200;
  double display_delay_ms = 0;
  bool scale_calib = false;
  long long max_frames = 0;
  bool tags = false;
  double tag_size_mm = 0;
  int width = 0, height = 0;
  double fps = 0, folder_fps = 30;
  bool stereo = false;  // side-by-side footage of the station's stereo rig (issue 28)
  std::string input_right;  // the right eye (a second camera or recording): stereo from two sources
  std::string stall_right;  // test hook: AFTER_FRAMES:SECONDS, the right camera goes quiet
};

json matrix_json(const Eigen::Isometry3d& T) {
  json a = json::array();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) a.push_back(T.matrix()(r, c));
  return a;
}

double round_to(double v, double q) { return std::round(v / q) * q; }

json body_json(const ar::BodyTrack& b) {
  json j;
  j["state"] = ar::track_state_name(b.state);
  j["measured"] = b.measured;
  j["T_cam_body"] = b.state == ar::TrackState::kLost ? json(nullptr) : matrix_json(b.T_cam_body);
  if (b.measured) {
    j["T_cam_body_measured"] = matrix_json(b.T_cam_body_measured);
    j["rms_px"] = round_to(b.rms_px, 1e-4);
    j["tags_used"] = b.tags_used;
    j["tag_ids"] = b.tag_ids;
    // 1-sigma of the measurement: rotation (deg) and translation (mm) per
    // camera axis, from the covariance's diagonal.
    json sr = json::array(), st = json::array();
    for (int i = 0; i < 3; ++i) {
      sr.push_back(round_to(std::sqrt(std::max(0.0, b.covariance(i, i))) * 180 / M_PI, 1e-5));
      st.push_back(round_to(std::sqrt(std::max(0.0, b.covariance(i + 3, i + 3))) * 1e3, 1e-5));
    }
    j["sigma_rot_deg"] = sr;
    j["sigma_t_mm"] = st;
  } else {
    j["tags_used"] = 0;
  }
  j["since_measurement_ms"] = round_to(b.since_measurement_s * 1e3, 1e-3);
  return j;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::min<double>(v.size() - 1, std::floor(p * v.size())))];
}

int run(const TrackCli& c) {
  // Station (layout) and camera.
  ar::StationScene station = ar::default_station_scene();
  if (!c.layout.empty()) {
    auto s = ar::read_station_scene(c.layout);
    if (!s) {
      print_error("track", s.error());
      return 2;
    }
    station = std::move(s).value();
  }
  if (!c.family.empty()) station.family = *ar::parse_tag_family(c.family);
  std::string calib_source = c.layout.empty() ? "built-in station" : c.layout;
  if (!c.calib.empty()) {
    auto k = ar::read_camera_calibration(c.calib);
    if (!k) {
      print_error("track", k.error());
      return 2;
    }
    station.calibration.camera = *k;
    calib_source = c.calib;
  } else if (!c.tags && c.layout.empty()) {
    print_error("track", "give --calib FILE (or --layout with the station's camera)");
    return 2;
  }
  if (c.tags && c.tag_size_mm <= 0) {
    print_error("track", "--tags needs --tag-size-mm (the side of the tag's border square)");
    return 2;
  }

  ar::FrameSourceOptions so;
  so.width = c.width;
  so.height = c.height;
  so.fps = c.fps;
  so.folder_fps = c.folder_fps;
  const bool stereo_run = c.stereo || !c.input_right.empty();
  std::unique_ptr<ar::FrameSource> mono_src;
  std::unique_ptr<ar::StereoSource> stereo_src;
  int eye_w = 0, eye_h = 0;
  std::string source_text;
  if (stereo_run) {
    // Both eyes (issue 28): side by side (left eye | right eye, docs/formats.md), or two
    // sources (--input left, --input-right right), paired by capture time; an eye lost for
    // 0.1 s leaves the other's frames alone (the single-view path) until it returns.
    if (c.tags) {
      print_error("track", "--stereo tracks the station's bodies from both eyes; leave out --tags");
      return 2;
    }
    if (!station.stereo.present) {
      print_error("track", "--stereo: " + calib_source +
                               " has no stereo rig (station file \"stereo\": camera_right, T_left_right); "
                               "give --layout with the rig (dentar synth --stereo writes one, dentar calibrate stereo "
                               "calibrates one)");
      return 2;
    }
    ar::StereoSourceOptions sso;
    sso.source = so;
    // Footage played as a camera (live:) ends; a camera that stops is reopened.
    sso.left_capture.reopen = c.input.rfind("live:", 0) != 0;
    sso.right_capture.reopen = c.input_right.rfind("live:", 0) != 0;
    if (!c.stall_right.empty()) {
      const auto k = c.stall_right.find(':');
      try {
        if (k == std::string::npos) throw std::invalid_argument("no colon");
        sso.right_capture.stall_after_frames = std::stoll(c.stall_right.substr(0, k));
        sso.right_capture.stall_s = std::stod(c.stall_right.substr(k + 1));
      } catch (const std::exception&) {
        print_error("track", "--inject-stall-right " + c.stall_right + ": must be AFTER_FRAMES:SECONDS");
        return 2;
      }
    }
    auto s = c.input_right.empty() ? ar::StereoSource::open_side_by_side(c.input, sso)
                                   : ar::StereoSource::open_pair(c.input, c.input_right, sso);
    if (!s) {
      print_error("track", "--stereo: " + s.error());
      return 2;
    }
    stereo_src = std::move(*s);
    eye_w = stereo_src->width();
    eye_h = stereo_src->height();
    source_text = stereo_src->description();
  } else {
    auto src = ar::FrameSource::open(c.input, so);
    if (!src) {
      print_error("track", src.error());
      return 2;
    }
    mono_src = std::move(*src);
    eye_w = mono_src->width();
    eye_h = mono_src->height();
    source_text = mono_src->description();
  }
  auto cam = ar::camera_for_image(station.calibration.camera, eye_w, eye_h, c.scale_calib, calib_source);
  if (!cam) {
    print_error("track", cam.error());
    return 2;
  }
  station.calibration.camera = *cam;
  if (stereo_run) {
    auto cr = ar::camera_for_image(station.stereo.camera_right, eye_w, eye_h, c.scale_calib,
                                   calib_source + " (stereo.camera_right)");
    if (!cr) {
      print_error("track", cr.error());
      return 2;
    }
    station.stereo.camera_right = *cr;
  }

  ar::TrackerOptions to;
  to.detector.families = {station.family};
  to.detector.decimation = c.decimate;
  to.detector.threads = c.threads;
  to.mirror_rim_refine = c.mirror_rim;
  if (!c.stereo_mirror_rim.empty()) to.stereo_mirror_rim = c.stereo_mirror_rim == "on";
  if (auto r = ar::parse_camera_response(c.camera_response.empty() ? "auto" : c.camera_response); !r) {
    print_error("track", "--camera-response: " + r.error());
    return 2;
  } else {
    to.detector.response = *r;
  }
  // auto: the station's measured response; unknown -> no linear-light refit, said once.
  if (const std::string note = ar::resolve_camera_response(to.detector, station); !note.empty())
    std::cerr << "dentar track: note: " << note << "\n";
  to.predicted_regions = !c.no_roi;
  to.full_frame_interval = c.full_every;
  to.filter_enabled = !c.no_filter;
  to.stale_limit_s = c.stale_ms * 1e-3;
  std::optional<ar::Tracker> tracker;
  std::optional<ar::StereoTracker> stereo;
  std::optional<ar::TagDetector> detector;
  if (stereo_run) {
    auto t = ar::StereoTracker::create(station, to);
    if (!t) {
      print_error("track", t.error());
      return 2;
    }
    stereo.emplace(std::move(t).value());
  } else if (c.tags) {
    auto d = ar::TagDetector::create(to.detector);
    if (!d) {
      print_error("track", d.error());
      return 2;
    }
    detector.emplace(std::move(d).value());
  } else {
    auto t = ar::Tracker::create(station, to);
    if (!t) {
      print_error("track", t.error());
      return 2;
    }
    tracker.emplace(std::move(t).value());
  }

  // Written to a temporary name and renamed at the end: a failed run leaves
  // no half-written poses file.
  const fs::path out = c.out, tmp = c.out + ".partial";
  if (out.has_parent_path()) {
    std::error_code ec;
    fs::create_directories(out.parent_path(), ec);
  }
  std::ofstream os(tmp);
  if (!os) {
    print_error("track", tmp.string() + ": cannot write (check the folder exists and is writable)");
    return 1;
  }
  auto abandon = [&](const std::string& msg, int code) {
    os.close();
    std::error_code ec;
    fs::remove(tmp, ec);
    print_error("track", msg);
    return code;
  };
  std::cout << "track: " << source_text << "; camera from " << calib_source << " ("
            << station.calibration.camera.width << "x" << station.calibration.camera.height
            << (c.scale_calib ? ", scaled if needed" : "") << "); "
            << (stereo_run ? std::string(c.input_right.empty() ? "stereo side by side" : "stereo, two sources") +
                                 ", baseline " + std::to_string(station.stereo.baseline_m() * 1e3).substr(0, 5) + " mm; "
                           : "")
            << (c.tags ? "per-tag poses" : (c.no_roi ? "full-frame search" : "predicted regions"))
            << ", decimate " << c.decimate << ", " << c.threads << " thread(s)\n";

  std::vector<double> total_ms, detect_ms;
  std::int64_t frames = 0, dropped = 0;
  int man_counts[3] = {0, 0, 0}, mir_counts[3] = {0, 0, 0};
  ar::Frame fr;
  ar::StereoFrame sf;
  cv::Mat gray;
  int eye_counts[4] = {0, 0, 0, 0};  // by FrameRecord::eyes: -, left, right, both
  while (c.max_frames <= 0 || frames < c.max_frames) {
    if (stereo_src) {
      if (!stereo_src->read(sf, 5.0)) {
        if (!stereo_src->error().empty()) return abandon(stereo_src->error(), 2);
        if (stereo_src->ended()) break;
        return abandon(source_text + ": no frame from either eye for 5 s", 1);
      }
      fr = sf.has_left() ? sf.left : sf.right;
    } else {
      auto r = mono_src->read(fr);
      if (!r) return abandon(r.error(), 2);
      if (!*r) break;
    }
    dropped += fr.dropped_before;
    json line;
    line["frame"] = fr.index;
    line["time_s"] = fr.time_s;
    line["dropped_before"] = fr.dropped_before;
    if (stereo_src) {
      // Capture times: the eyes' own (a recording's timestamps, or a camera's grab on one clock).
      const double t = fr.time_s;
      auto f = stereo->track(sf.left.image, sf.right.image, t, t + c.display_delay_ms * 1e-3);
      if (!f) return abandon(f.error(), 1);
      const int eyes = (sf.has_left() ? 1 : 0) | (sf.has_right() ? 2 : 0);
      ++eye_counts[eyes];
      line["eyes"] = eyes == 3 ? "both" : eyes == 1 ? "left" : "right";
      if (sf.paired()) line["skew_ms"] = round_to(sf.skew_s * 1e3, 1e-3);
      line["steady_s"] = fr.steady_s;
      line["display_time_s"] = t + c.display_delay_ms * 1e-3;
      line["tags_detected"] = {f->left.tags_detected, f->right.tags_detected};
      json man = body_json(f->mannequin.track), mir = body_json(f->mirror.track);
      man["views"] = f->mannequin.views_used;
      mir["views"] = f->mirror.views_used;
      line["bodies"] = {{"mannequin", man}, {"mirror", mir}};
      line["timing_ms"] = {{"pose", round_to(f->pose_ms, 1e-4)}, {"total", round_to(f->total_ms, 1e-4)}};
      ++man_counts[static_cast<int>(f->mannequin.track.state)];
      ++mir_counts[static_cast<int>(f->mirror.track.state)];
      total_ms.push_back(f->total_ms);
      detect_ms.push_back(f->left.timing.detect_ms + f->right.timing.detect_ms);
    } else if (c.tags) {
      const auto t0 = std::chrono::steady_clock::now();
      cv::cvtColor(fr.image, gray, cv::COLOR_BGR2GRAY);
      auto d = detector->detect(gray);
      if (!d) return abandon(d.error(), 1);
      const auto t1 = std::chrono::steady_clock::now();
      const auto poses =
          ar::estimate_tag_poses(*d, station.calibration.camera, c.tag_size_mm * 1e-3);
      const auto t2 = std::chrono::steady_clock::now();
      json tags = json::array();
      for (std::size_t i = 0; i < poses.size(); ++i) {
        const ar::TagPose& p = poses[i];
        json t;
        t["family"] = ar::tag_family_name(p.family);
        t["id"] = p.id;
        t["hamming"] = (*d)[i].hamming;
        t["decision_margin"] = round_to((*d)[i].decision_margin, 1e-3);
        json corners = json::array();
        for (const auto& q : p.corners_px)
          corners.push_back({round_to(q.x(), 1e-4), round_to(q.y(), 1e-4)});
        t["corners_px"] = corners;
        t["ok"] = p.ok;
        if (p.ok) {
          t["T_cam_tag"] = matrix_json(p.T_cam_tag);
          t["rms_px"] = round_to(p.rms_px, 1e-5);
          t["T_cam_tag_alt"] = matrix_json(p.T_cam_tag_alt);
          t["alt_rms_px"] = round_to(p.alt_rms_px, 1e-5);
        }
        tags.push_back(t);
      }
      const double dms = std::chrono::duration<double, std::milli>(t1 - t0).count();
      const double pms = std::chrono::duration<double, std::milli>(t2 - t1).count();
      line["tags"] = tags;
      line["timing_ms"] = {{"detect", round_to(dms, 1e-4)},
                           {"pose", round_to(pms, 1e-4)},
                           {"total", round_to(dms + pms, 1e-4)}};
      total_ms.push_back(dms + pms);
      detect_ms.push_back(dms);
    } else {
      auto f = tracker->track(fr.image, fr.time_s, fr.time_s + c.display_delay_ms * 1e-3);
      if (!f) return abandon(f.error(), 1);
      line["display_time_s"] = f->display_time_s;
      line["full_frame"] = f->full_frame;
      line["regions"] = f->regions;
      line["searched_fraction"] = round_to(f->searched_fraction, 1e-4);
      line["tags_detected"] = f->tags_detected;
      line["bodies"] = {{"mannequin", body_json(f->mannequin)},
                        {"mirror", body_json(f->mirror)}};
      line["timing_ms"] = {{"detect", round_to(f->timing.detect_ms, 1e-4)},
                           {"pose", round_to(f->timing.pose_ms, 1e-4)},
                           {"filter", round_to(f->timing.filter_ms, 1e-4)},
                           {"total", round_to(f->timing.total_ms, 1e-4)}};
      ++man_counts[static_cast<int>(f->mannequin.state)];
      ++mir_counts[static_cast<int>(f->mirror.state)];
      total_ms.push_back(f->timing.total_ms);
      detect_ms.push_back(f->timing.detect_ms);
    }
    os << line.dump() << "\n";
    ++frames;
  }
  os.close();
  if (!os) return abandon(tmp.string() + ": write failed (disk full?)", 1);
  if (frames == 0) return abandon(c.input + ": no frame was read", 2);
  std::error_code ec;
  fs::rename(tmp, out, ec);
  if (ec) return abandon(out.string() + ": cannot rename the output: " + ec.message(), 1);

  std::cout << std::fixed << std::setprecision(2) << "track: " << frames << " frames, "
            << std::max<std::int64_t>(dropped, mono_src ? mono_src->dropped_total() : 0) << " dropped";
  if (stereo_src)
    std::cout << "; eyes: both " << eye_counts[3] << ", left alone " << eye_counts[1] << ", right alone "
              << eye_counts[2] << " (" << stereo_src->stats().summary() << ")";
  if (!c.tags)
    std::cout << "; mannequin tracking " << man_counts[0] << " / predicted " << man_counts[1]
              << " / lost " << man_counts[2] << "; mirror tracking " << mir_counts[0]
              << " / predicted " << mir_counts[1] << " / lost " << mir_counts[2];
  std::cout << "; time per frame median " << percentile(total_ms, 0.5) << " ms, p99 "
            << percentile(total_ms, 0.99) << " ms (detect median " << percentile(detect_ms, 0.5)
            << " ms); wrote " << out.string() << "\n";
  return 0;
}

}  // namespace

void add_track(CLI::App& app, int& exit_code) {
  auto c = std::make_shared<TrackCli>();
  CLI::App* s = app.add_subcommand(
      "track",
      "Track the mannequin's tag bundle and the mirror's tags (AprilTag 3, bundle PnP, SE(3)\n"
      "One Euro filter) on a video, an image folder or a live camera; one JSON line per frame\n"
      "with each body's T_cam_body, state (tracking/predicted/lost), reprojection RMS, tags\n"
      "used, uncertainty and per-stage timing. --tags: every tag's own pose instead.\n"
      "Synopsis: dentar track --input <video|image folder|camera:N|/dev/videoN|live:VIDEO>\n"
      "                       --calib <camera yaml|station json> --layout <station json>\n"
      "                       --out poses.jsonl [--family F] [--decimate D] [--threads N]\n"
      "                       [--camera-response auto|srgb|linear] [--mirror-rim]\n"
      "                       [--no-roi] [--full-every N] [--no-filter] [--stale-ms MS]\n"
      "                       [--display-delay-ms MS] [--scale-calib] [--max-frames N]\n"
      "                       [--tags --tag-size-mm S] [--width W --height H --fps F]\n"
      "                       [--stereo [--input-right <left eye's partner>] [--stereo-mirror-rim on|off]]");
  s->add_option("--input", c->input,
                "Video file, image folder, camera:N, /dev/videoN, or live:VIDEO (a video played "
                "as a live camera)")
      ->required();
  s->add_option("--calib", c->calib,
                "Camera calibration: OpenCV FileStorage YAML/XML, ROS camera_info YAML, or a "
                "station JSON (default: the --layout station's camera)");
  s->add_option("--layout", c->layout,
                "Station JSON with the tag layout (default: the built-in station)");
  s->add_option("--out", c->out, "Output JSON lines file")->required();
  s->add_option("--family", c->family, "Tag family (default: the layout's)")
      ->check(CLI::IsMember({"tagStandard41h12", "tag36h11"}));
  s->add_option("--decimate", c->decimate, "Full-frame quad search decimation")
      ->check(CLI::Range(1.0, 16.0))
      ->capture_default_str();
  add_tracker_image_options(s, c->camera_response, c->mirror_rim);
  add_stereo_mirror_rim_option(s, c->stereo_mirror_rim);
  s->add_option("--threads", c->threads, "libapriltag threads")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  s->add_flag("--stereo", c->stereo,
             "Side-by-side footage of a stereo head (left eye | right eye, docs/formats.md): each body fitted "
             "once to both eyes' corners; poses in the left eye's frame (the rig), \"views\" per body. "
             "Needs --layout with the station's rig (\"stereo\"). Each line gets \"eyes\": both, or left / right "
             "alone when the other eye is lost (its camera silent for 0.1 s, its recording ended)");
  s->add_option("--input-right", c->input_right,
                "Stereo from two sources (implies --stereo): --input is the left eye, this the right (a second "
                "camera, live: stand-in or recording; one size and rate), paired by capture time");
  s->add_option("--inject-stall-right", c->stall_right,
                "test hook: AFTER_FRAMES:SECONDS, the right camera (a live eye) goes quiet");
  s->add_flag("--no-roi", c->no_roi, "Search the full frame every frame (no predicted regions)");
  s->add_option("--full-every", c->full_every, "Full-frame search interval, frames")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  s->add_flag("--no-filter", c->no_filter, "Report the raw measured poses (no One Euro filter)");
  s->add_option("--stale-ms", c->stale_ms,
                "How long a body stays 'predicted' without a measurement before 'lost', ms")
      ->check(CLI::Range(0.0, 10000.0))
      ->capture_default_str();
  s->add_option("--display-delay-ms", c->display_delay_ms,
                "Predict poses this far past the capture time (the display latency), ms")
      ->check(CLI::Range(0.0, 100.0))
      ->capture_default_str();
  s->add_flag("--scale-calib", c->scale_calib,
              "Scale fx, fy, cx, cy when the images' size differs from the calibration's "
              "(same aspect ratio only); without it a size mismatch is refused");
  s->add_option("--max-frames", c->max_frames, "Stop after N frames (0 = all)")
      ->check(CLI::Range(0LL, 1000000000LL));
  s->add_flag("--tags", c->tags, "Report every tag's own pose (IPPE_SQUARE, both solutions)");
  s->add_option("--tag-size-mm", c->tag_size_mm, "Tag border-square side for --tags, mm")
      ->check(CLI::Range(0.1, 10000.0));
  s->add_option("--width", c->width, "Camera: requested width, px")->check(CLI::Range(0, 16384));
  s->add_option("--height", c->height, "Camera: requested height, px")
      ->check(CLI::Range(0, 16384));
  s->add_option("--fps", c->fps, "Camera: requested frame rate, Hz")->check(CLI::Range(0.0, 1000.0));
  s->add_option("--folder-fps", c->folder_fps, "Image folder: frame rate for timestamps, Hz")
      ->check(CLI::Range(0.001, 1000.0))
      ->capture_default_str();
  s->footer(
      "Example:\n"
      "  dentar synth --preset standard --frames 120 --out out/std\n"
      "  dentar track --input out/std/video.mkv --calib out/std/station.json \\\n"
      "               --layout out/std/station.json --out out/std/poses.jsonl\n"
      "  dentar track --input photos/ --calib cam.yaml --tags --family tag36h11 \\\n"
      "               --tag-size-mm 53 --out tags.jsonl\n"
      "  dentar synth --preset mirror --stereo --frames 60 --out out/st\n"
      "  dentar track --input out/st/video.mkv --layout out/st/station.json --stereo --out out/st/poses.jsonl\n"
      "  dentar track --input camera:0 --input-right camera:1 --layout station.json --out poses.jsonl\n"
      "Exit status: 0 ok, 1 the job failed, 2 bad input or arguments.");
  s->callback([c, &exit_code] { exit_code = run(*c); });
}

}  // namespace dentar::tools
