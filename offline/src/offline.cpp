// The offline run: footage + session log through tracking, haptic replay,
// meshing and compositing; CSV, summary JSON and HTML report. See offline.h.
#include "dentar/offline/offline.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <sstream>
#include <stdexcept>

#include "dentar/ar/egl_context.h"
#include "dentar/ar/frame_pipeline.h"
#include "dentar/ar/frame_source.h"
#include "dentar/ar/report.h"
#include "dentar/ar/stereo_source.h"
#include "dentar/haptics/engine.h"
#include "dentar/haptics/replay.h"
#include "dentar/haptics/replay_device.h"
#include "dentar/haptics/session_log.h"
#include "dentar/training/exercise.h"
#include "dentar/training/lesson.h"
#include "dentar/volume/bur.h"
#include "dentar/volume/material.h"
#include "dentar/volume/procedural_tooth.h"
#include "dentar/volume/surface.h"
#include "dentar/session/frames_csv.h"
#include "dentar/session/recording.h"
#include "dentar/session/run.h"

namespace dentar::offline {
using namespace dentar::ar;
namespace fs = std::filesystem;
using Iso = Eigen::Isometry3d;
using Clock = std::chrono::steady_clock;

namespace {

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

const double kNaN = std::numeric_limits<double>::quiet_NaN();

Stat make_stat(const std::vector<double>& v) {
  Stat s;
  std::vector<double> f;
  for (double x : v)
    if (std::isfinite(x)) f.push_back(x);
  s.n = static_cast<int>(f.size());
  if (f.empty()) {
    s.median = s.p95 = s.p99 = s.max = s.mean = kNaN;
    return s;
  }
  s.median = percentile(f, 50);
  s.p95 = percentile(f, 95);
  s.p99 = percentile(f, 99);
  s.max = *std::max_element(f.begin(), f.end());
  double sum = 0;
  for (double x : f) sum += x;
  s.mean = sum / static_cast<double>(f.size());
  return s;
}

nlohmann::json stat_json(const Stat& s) {
  auto num = [](double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); };
  return {{"median", num(s.median)}, {"p95", num(s.p95)}, {"p99", num(s.p99)},
          {"max", num(s.max)},       {"mean", num(s.mean)}, {"n", s.n}};
}

Iso from_rowmajor(const nlohmann::json& j) {
  // 16 numbers, row-major (docs/formats.md, truth.jsonl).
  if (!j.is_array() || j.size() != 16) throw std::runtime_error("a pose is not 16 numbers");
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = j.at(static_cast<std::size_t>(4 * r + c)).get<double>();
  Iso T = Iso::Identity();
  T.matrix() = m;
  return T;
}


double rotation_deg(const Iso& a, const Iso& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle() * 180.0 / M_PI;
}

struct TruthFrame {
  bool present = false;
  bool has_mirror = false;  // T_cam_mir present (older truth files lack it)
  bool mirror_in_view = false;
  Iso T_cam_man, T_cam_tooth, T_cam_tip, T_cam_mir;
};

// Reads truth.jsonl (generator format). Errors name the file and line.
Result<std::vector<TruthFrame>> read_truth(const std::string& path) {
  std::ifstream in(path);
  if (!in) return Error{path + ": cannot open the ground truth (pass --truth none to run without it)"};
  std::vector<TruthFrame> out;
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (line.empty()) continue;
    auto j = nlohmann::json::parse(line, nullptr, false);
    if (j.is_discarded() || !j.is_object())
      return Error{path + ":" + std::to_string(n) + ": not a JSON object (is this a truth.jsonl from `dentar synth`?)"};
    try {
      const int frame = j.at("frame").get<int>();
      if (frame < 0 || frame > 10'000'000)
        return Error{path + ":" + std::to_string(n) + ": frame = " + std::to_string(frame) + " is out of range"};
      if (static_cast<int>(out.size()) <= frame) out.resize(static_cast<std::size_t>(frame) + 1);
      TruthFrame& t = out[static_cast<std::size_t>(frame)];
      t.present = true;
      t.T_cam_man = from_rowmajor(j.at("T_cam_man"));
      t.T_cam_tooth = from_rowmajor(j.at("T_cam_tooth"));
      t.T_cam_tip = from_rowmajor(j.at("T_cam_tip"));
      if (j.contains("T_cam_mir")) {
        t.T_cam_mir = from_rowmajor(j.at("T_cam_mir"));
        t.has_mirror = true;
        t.mirror_in_view = j.value("mirror_in_view", true);
      }
    } catch (const std::exception& e) {
      return Error{path + ":" + std::to_string(n) + ": " + e.what() +
                   " (expected frame, T_cam_man, T_cam_tooth, T_cam_tip as 16 numbers, row-major)"};
    }
  }
  return out;
}

// Writes text to path via a temporary file and a rename (never half a file).
Status write_atomic(const fs::path& path, const std::string& text) {
  const fs::path tmp = path.string() + ".partial";
  {
    std::ofstream out(tmp, std::ios::binary);
    out << text;
    if (!out) return Error{tmp.string() + ": cannot write (disk full or no permission?)"};
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) return Error{path.string() + ": cannot rename into place: " + ec.message()};
  return {};
}

// Per-frame record (one CSV row; also feeds the plots).
using Row = session::OfflineFrameRow;

std::string fmt(double v, int prec = 3) {
  if (!std::isfinite(v)) return "–";
  std::ostringstream s;
  s << std::setprecision(prec) << v;
  return s.str();
}

// The HTML report: summary tables, then plots. Self-contained (inline SVG,
// stills as relative PNG links).
std::string make_report(const OfflineOptions& o, const OfflineSummary& sum, const std::vector<Row>& rows,
                        const std::vector<std::string>& stills, const nlohmann::json& inputs,
                        const std::string& extra_html) {
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
    << "<title>DentAR offline run</title><style>"
    << "body{font-family:sans-serif;max-width:1100px;margin:1em auto;color:#222}"
    << "table{border-collapse:collapse;margin:.5em 0}td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}"
    << "th{background:#f2f2f2}td:first-child,th:first-child{text-align:left}"
    << ".ok{color:#060}.bad{color:#b00}.figs svg{margin:4px}img{max-width:540px;margin:4px;border:1px solid #ccc}"
    << "</style></head><body>\n";
  h << "<h1>DentAR offline run</h1>\n<p>" << sum.frames << " frames, " << fmt(sum.footage_s, 4)
    << " s of footage, processed in " << fmt(sum.wall_s, 3) << " s ("
    << fmt(sum.frames / std::max(1e-9, sum.wall_s), 3) << " frames/s). Output folder: <code>"
    << html_escape(sum.out_dir) << "</code>.</p>\n";
  if (!sum.warnings.empty()) {
    h << "<h2>Warnings</h2><ul>";
    for (const auto& w : sum.warnings) h << "<li class=\"bad\">" << html_escape(w) << "</li>";
    h << "</ul>\n";
  }
  if (!extra_html.empty()) h << "<h2>Session score</h2>\n" << extra_html << "\n";
  h << "<h2>Tracking</h2><table><tr><th>mannequin state</th><th>frames</th><th>share</th></tr>";
  for (auto [name, n] : {std::pair{"tracking", sum.tracking}, std::pair{"predicted", sum.predicted},
                         std::pair{"lost (no overlay)", sum.lost}})
    h << "<tr><td>" << name << "</td><td>" << n << "</td><td>"
      << fmt(100.0 * n / std::max(1, sum.frames), 3) << " %</td></tr>";
  h << "<tr><td>mirror tracked</td><td>" << sum.mirror_tracking << "</td><td>"
    << fmt(100.0 * sum.mirror_tracking / std::max(1, sum.frames), 3) << " %</td></tr></table>\n";

  auto stat_row = [&](const char* name, const Stat& s, const char* unit, double goal = kNaN) {
    h << "<tr><td>" << name << "</td><td>" << fmt(s.median) << "</td><td>" << fmt(s.p95) << "</td><td>"
      << fmt(s.p99) << "</td><td>" << fmt(s.max) << "</td><td>" << s.n << "</td><td>" << unit << "</td><td";
    if (std::isfinite(goal) && s.n > 0)
      h << " class=\"" << (s.p95 <= goal ? "ok" : "bad") << "\">p95 ≤ " << fmt(goal);
    else
      h << ">";
    h << "</td></tr>";
  };
  const char* head =
      "<table><tr><th>quantity</th><th>median</th><th>p95</th><th>p99</th><th>max</th><th>frames</th>"
      "<th>unit</th><th>goal</th></tr>";
  if (sum.has_truth) {
    h << "<h2>Accuracy against ground truth</h2>" << head;
    stat_row("mannequin pose, translation", sum.man_err_mm, "mm", 0.3);
    stat_row("mannequin pose, rotation", sum.man_err_deg, "deg", 0.1);
    stat_row("registration: tooth box corners, drawn vs true", sum.tooth_err_px, "px");
    stat_row("co-location: drawn bur tip vs true tip", sum.tip_err_mm, "mm", 0.5);
    stat_row("occlusion: visible-tooth IoU", sum.silhouette_iou, "");
    stat_row("mirror plane pose, translation", sum.mir_err_mm, "mm", 0.5);
    stat_row("mirror plane pose, rotation", sum.mir_err_deg, "deg", 0.3);
    h << "</table><p>Errors use the frames with an overlay (tracking or predicted); lost frames draw "
         "nothing. The mirror's rows use the frames where the mirror is tracked or predicted "
         "(its reflection may be drawn); its pose is the mirror plane frame <code>mir</code>, "
         "from which the reflection is computed.</p>\n";
  } else {
    h << "<h2>Accuracy</h2><p>No ground truth with this footage: errors are not measured.</p>\n";
  }
  h << "<h2>Time per frame</h2>" << head;
  stat_row("read + decode", sum.read_ms, "ms");
  stat_row("tracking (detect + pose + filter)", sum.track_ms, "ms");
  stat_row("haptic replay to the frame time", sum.haptics_ms, "ms");
  stat_row("re-meshing dirty chunks", sum.mesh_ms, "ms");
  stat_row("compositing (render + occlusion + blend)", sum.composite_ms, "ms", 33.0);
  stat_row("video encode", sum.write_ms, "ms");
  stat_row("capture-to-composite latency", sum.latency_ms, "ms");
  h << "</table><p>Latency runs from the moment the decoded frame is in memory (where a live "
       "camera delivers it) until its composited image is ready, before encoding; decoding the "
       "recorded footage is the read time.</p>\n";
  h << "<h2>Drilling</h2><p>" << sum.haptic_steps << " haptic steps replayed; removed volume: ";
  for (int m = 1; m < volume::kNumMaterials && m < static_cast<int>(sum.removed_mm3.size()); ++m)
    if (sum.removed_mm3[static_cast<std::size_t>(m)] > 0)
      h << volume::material_info(m).name << " " << fmt(sum.removed_mm3[static_cast<std::size_t>(m)], 4)
        << " mm³; ";
  h << (sum.pulp_exposed ? "<b class=\"bad\">pulp exposed at " + fmt(sum.pulp_exposed_at_s, 4) + " s</b>"
                         : std::string("pulp not exposed"))
    << ".</p>\n";

  // Plots.
  std::vector<double> t;
  for (const auto& r : rows) t.push_back(r.time_s);
  auto column = [&](auto get) {
    std::vector<double> v;
    for (const auto& r : rows) v.push_back(get(r));
    return v;
  };
  h << "<h2>Plots</h2><div class=\"figs\">\n";
  if (sum.has_truth) {
    LinePlot p;
    p.title = "Mannequin pose error against time";
    p.x_label = "time (s)";
    p.y_label = "error";
    p.series = {{"translation (mm)", t, column([](const Row& r) { return r.man_err_mm; }), ""},
                {"rotation (deg)", t, column([](const Row& r) { return r.man_err_deg; }), ""}};
    p.goal_y = 0.3;
    p.goal_label = "0.3 mm goal";
    h << svg_line_plot(p);
    LinePlot q;
    q.title = "Registration and co-location error against time";
    q.x_label = "time (s)";
    q.y_label = "error";
    q.series = {{"tooth, drawn vs true (px)", t, column([](const Row& r) { return r.tooth_err_px; }), ""},
                {"bur tip, drawn vs true (mm)", t, column([](const Row& r) { return r.tip_err_mm; }), ""}};
    h << svg_line_plot(q);
    if (sum.mir_err_mm.n > 0) {
      LinePlot m;
      m.title = "Mirror pose error against time (frames with a mirror pose)";
      m.x_label = "time (s)";
      m.y_label = "error";
      m.series = {{"translation (mm)", t, column([](const Row& r) { return r.mir_err_mm; }), ""},
                  {"rotation (deg)", t, column([](const Row& r) { return r.mir_err_deg; }), ""}};
      m.goal_y = 0.5;
      m.goal_label = "0.5 mm goal";
      h << svg_line_plot(m);
    }
    if (sum.silhouette_iou.n > 0) {
      LinePlot u;
      u.title = "Visible-tooth IoU against the true mask";
      u.x_label = "time (s)";
      u.y_label = "IoU";
      u.series = {{"IoU", t, column([](const Row& r) { return r.iou; }), ""}};
      u.goal_y = 0.95;
      u.goal_label = "0.95 goal";
      h << svg_line_plot(u);
    }
  }
  {
    LinePlot p;
    p.title = "Tracking state: 0 tracking, 1 predicted, 2 lost (no overlay)";
    p.x_label = "time (s)";
    p.y_label = "state";
    p.series = {{"mannequin", t, column([](const Row& r) { return double(r.man_state); }), ""},
                {"mirror", t, column([](const Row& r) { return double(r.mir_state); }), ""}};
    p.height_px = 200;
    h << svg_line_plot(p);
    LinePlot q;
    q.title = "Tags used in the pose";
    q.x_label = "time (s)";
    q.y_label = "tags";
    q.series = {{"mannequin", t, column([](const Row& r) { return double(r.man_tags); }), ""},
                {"mirror", t, column([](const Row& r) { return double(r.mir_tags); }), ""},
                {"detected in frame", t, column([](const Row& r) { return double(r.tags_detected); }), ""}};
    q.height_px = 220;
    h << svg_line_plot(q);
  }
  {
    LinePlot p;
    p.title = "Removed volume per material against time";
    p.x_label = "time (s)";
    p.y_label = "removed (mm³)";
    for (int m = 1; m < volume::kNumMaterials; ++m) {
      auto v = column([m](const Row& r) { return r.removed_mm3[m]; });
      if (*std::max_element(v.begin(), v.end()) <= 0) continue;
      const auto& rgb = volume::material_info(m).rgb;
      char c[16];
      std::snprintf(c, sizeof c, "#%02x%02x%02x", rgb[0] * 3 / 4, rgb[1] * 3 / 4, rgb[2] * 3 / 4);
      p.series.push_back({std::string(volume::material_info(m).name), t, v, c});
    }
    h << svg_line_plot(p);
  }
  h << "</div><h3>Stage times</h3><div class=\"figs\">\n";
  for (auto [name, get] : std::initializer_list<std::pair<const char*, double (*)(const Row&)>>{
           {"read + decode", [](const Row& r) { return r.read_ms; }},
           {"tracking", [](const Row& r) { return r.track_ms; }},
           {"haptic replay", [](const Row& r) { return r.haptics_ms; }},
           {"re-meshing", [](const Row& r) { return r.mesh_ms; }},
           {"compositing", [](const Row& r) { return r.composite_ms; }},
           {"video encode", [](const Row& r) { return r.write_ms; }},
           {"capture-to-composite latency", [](const Row& r) { return r.latency_ms; }}}) {
    Histogram hg;
    hg.title = name;
    hg.x_label = "time (ms)";
    hg.samples = column(get);
    h << svg_histogram(hg);
  }
  h << "</div>\n";
  if (!stills.empty()) {
    h << "<h2>Composited frames</h2><div>";
    for (const auto& s : stills) h << "<img src=\"" << html_escape(s) << "\" alt=\"" << html_escape(s) << "\">";
    h << "</div>\n";
  }
  h << "<h2>Inputs</h2><pre>" << html_escape(inputs.dump(2)) << "</pre>\n";
  h << "<p>Per-frame values: <a href=\"frames.csv\">frames.csv</a>; totals: <a href=\"summary.json\">"
       "summary.json</a>"
    << (o.write_video ? "; video: <a href=\"composite.mkv\">composite.mkv</a>" : "")
    << (o.write_video && sum.both_eyes ? ", the right eye's: <a href=\"composite_right.mkv\">composite_right.mkv</a>" : "")
    << ".</p>\n";
  h << "</body></html>\n";
  return h.str();
}

}  // namespace

std::string OfflineOptions::validate() const {
  if (out_dir.empty()) return "out_dir is empty: give an output folder (--out DIR)";
  if (!footage.empty() && station.empty() &&
      !(fs::is_directory(footage) && fs::exists(fs::path(footage) / "recording.json")))
    return "station is empty: footage needs the station file it was recorded with (--station FILE)";
  if (builtin_frames < 2 || builtin_frames > 100000)
    return "builtin_frames = " + std::to_string(builtin_frames) + " must be in 2..100000";
  if (builtin_width < 64 || builtin_height < 48 || builtin_width > 4096 || builtin_height > 4096)
    return "builtin size " + std::to_string(builtin_width) + "x" + std::to_string(builtin_height) +
           " must be within 64x48..4096x4096";
  if (!(predict_s >= 0 && predict_s <= 0.5)) return "predict_s must be in 0..0.5 s";
  if (max_frames < 0) return "max_frames must be >= 0";
  if (stills < 0 || stills > 32) return "stills must be in 0..32";
  if (video_codec != "mjpg" && video_codec != "ffv1")
    return "video_codec = \"" + video_codec + "\" must be mjpg or ffv1";
  if (auto v = tracker.validate(); !v.empty()) return "tracker: " + v;
  if (auto v = compositor.validate(); !v.empty()) return "compositor: " + v;
  if (!eye.empty() && eye != "left" && eye != "right" && eye != "both")
    return "eye = \"" + eye + "\" must be left, right or both";
  if (eye == "both" && !stereo)
    return "eye = both writes each eye's composite of a stereo run: it needs stereo (--stereo)";
  if (!eye.empty() && eye != "both" && stereo)
    return "eye = " + eye + " runs one eye of stereo footage through the mono path; stereo tracks both: give one";
  if (!footage_right.empty() && !stereo) return "footage_right (the right eye's recording) needs stereo";
  if ((stereo || !eye.empty()) && footage.empty())
    return std::string(stereo ? "stereo" : "eye") + " needs footage (the stereo recording, `dentar synth --stereo`)";
  if ((stereo || !eye.empty()) && scale_calib)
    return "scale_calib is for one camera: stereo footage must be of the rig's calibrated size";
  return {};
}

namespace {

bool is_live_recording(const std::string& footage) {
  return !footage.empty() && fs::is_directory(footage) && fs::exists(fs::path(footage) / "recording.json");
}

// The station's rig for `what` (the stereo input): present, both eyes of one size. Empty when fine.
std::string check_rig(const StationScene& station, const std::string& station_path, const std::string& what) {
  if (!station.stereo.present)
    return what + ": the station " + station_path +
           " has no stereo rig (station file \"stereo\": camera_right, T_left_right): calibrate the rig with "
           "`dentar calibrate stereo`, or give the station.json that `dentar synth --stereo` wrote";
  const auto& cam = station.calibration.camera;
  const auto& cr = station.stereo.camera_right;
  if (cr.width != cam.width || cr.height != cam.height)
    return station_path + ": the rig's eyes are calibrated for different sizes (camera " + std::to_string(cam.width) +
           "x" + std::to_string(cam.height) + ", stereo.camera_right " + std::to_string(cr.width) + "x" +
           std::to_string(cr.height) + "): both eyes must deliver one size";
  return {};
}

}  // namespace

std::string check_stereo_inputs(const OfflineOptions& o) {
  if (!o.stereo && o.eye.empty()) return {};
  if (auto v = o.validate(); !v.empty()) return v;
  // A `dentar live --record` folder replays as it was recorded: from both eyes when the run was
  // stereo (recording.json "stereo", the right eye in frames_right/), else from its one camera.
  if (is_live_recording(o.footage)) {
    if ((!o.eye.empty() && o.eye != "both") || !o.footage_right.empty())
      return o.footage + " is a `dentar live --record` folder: it replays as the live run tracked it (from both "
             "eyes when it was stereo): drop --eye " + o.eye + " and --footage-right (--eye both may stay: it also "
             "writes the right eye's composite)";
    std::ifstream mj(fs::path(o.footage) / "recording.json");
    const nlohmann::json j = nlohmann::json::parse(mj, nullptr, false);
    if (!j.is_object() || !j.contains("stereo"))
      return o.footage + ": " + (o.stereo ? std::string("--stereo") : "--eye " + o.eye) +
             ", but the recording is of one camera (its recording.json has no \"stereo\"): replay it without it";
    return {};
  }
  auto station = read_station_scene(o.station);
  if (!station) return station.error();
  const std::string what = o.stereo ? "stereo footage" : "--eye " + o.eye;  // (--eye both is stereo)
  if (auto e = check_rig(*station, o.station, what); !e.empty()) return e;
  const auto& cam = station->calibration.camera;
  auto src = o.footage_right.empty() ? StereoSource::open_side_by_side(o.footage)
                                     : StereoSource::open_pair(o.footage, o.footage_right);
  if (!src) return src.error();
  if ((*src)->width() != cam.width || (*src)->height() != cam.height)
    return o.footage + ": each eye is " + std::to_string((*src)->width()) + "x" + std::to_string((*src)->height()) +
           " but the rig (" + o.station + ", camera.width/height) is calibrated for " + std::to_string(cam.width) + "x" +
           std::to_string(cam.height) + " per eye: use the station file of this rig and camera mode";
  return {};
}

// One `dentar offline` job: its inputs, the run, the outputs being written
// and the per-frame rows. Each step returns the error that fails the job
// (fail() has written FAILED.txt).
struct Job {
  OfflineOptions o;
  std::function<void(const std::string&, int, int)> progress;
  fs::path out;
  Clock::time_point wall0;
  OfflineSummary sum;
  session::Recording rec;
  StationScene st;
  std::unique_ptr<FrameSource> src;  // the footage (stereo: the left eye's or the side-by-side file, for its length)
  std::unique_ptr<StereoSource> stereo_src;  // stereo: the eyes, read in step
  StereoFrame sframe;
  cv::Mat right_image;  // stereo: this frame's right eye (empty: lost)
  // --eye both (issue 28, session 16): the right eye's composite, its video, truth and masks,
  // and its per-frame agreement with that truth.
  bool both_eyes = false;
  CompositeResult cres_right;
  fs::path video_right_tmp;
  cv::VideoWriter writer_right;
  std::vector<TruthFrame> truth_right;
  std::string mask_right_dir;
  cv::Mat K_right, D_right;
  std::vector<double> right_tooth_err_px, right_iou;

  fs::path rec_right_dir;  // a stereo live recording: the right eye's frames (frames_right/)
  double fps = 30.0;
  std::vector<TruthFrame> truth;
  std::string mask_dir;
  std::unique_ptr<session::Run> run;
  volume::VoxelVolume* vol = nullptr;
  haptics::Engine* engine = nullptr;
  haptics::ReplayDevice* device = nullptr;
  double rate_hz = 1000.0;
  std::size_t session_steps = 0;
  FramePipeline* pipe = nullptr;
  ToothMeshes* meshes = nullptr;
  std::vector<Eigen::Vector3d> box;  // the tooth's box corners in its frame
  cv::Mat K, D;
  fs::path video_tmp;
  cv::VideoWriter writer;
  std::ofstream csv;
  std::vector<Row> rows;
  int total = 0;
  Frame frame;
  CompositeResult cres;
  std::vector<std::string> stills;
  std::vector<int> still_frames;
  haptics::HapticSnapshot snap{};

  Error fail(const std::string& msg) {
    std::ofstream(out / "FAILED.txt") << msg << "\n";
    return Error{msg};
  }
  // The tooth's box corners projected into the image (registration error in pixels).
  std::vector<cv::Point2d> project(const Iso& T_cam_tooth) const {
    std::vector<cv::Point3d> p;
    for (const auto& b : box) {
      const Eigen::Vector3d c = T_cam_tooth * b;
      p.emplace_back(c.x(), c.y(), c.z());
    }
    std::vector<cv::Point2d> uv;
    cv::projectPoints(p, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D, uv);
    return uv;
  }

  Status builtin_footage() {
    // Built-in footage: the generator's scene, session log and truth.
    if (o.footage.empty()) {
      SynthOptions so = synth_preset(o.preset);
      so.frames = o.builtin_frames;
      so.width = o.builtin_width;
      so.height = o.builtin_height;
      so.seed = o.seed;
      const fs::path fdir = out / "footage";
      auto synth = run_synth(default_station_scene(), so, fdir.string(), false, [&](int k) {
        if (progress) progress("footage", k, so.frames);
      });
      if (!synth) return fail("offline: generating the built-in footage: " + synth.error());
      o.footage = (fdir / "video.mkv").string();
      o.station = (fdir / "station.json").string();
      if (o.session.empty()) o.session = (fdir / "session.dlog").string();
    }

    return {};
  }

  Status live_recording() {
    // A live recording folder: its frames, station, session and timing.
    if (!o.footage.empty() && fs::is_directory(o.footage) && fs::exists(fs::path(o.footage) / "recording.json")) {
      const fs::path rdir = o.footage;
      auto r = session::read_recording(rdir);
      if (!r) return fail("offline: " + r.error());
      rec = std::move(*r);
      o.footage = (rdir / "frames").string();
      // A stereo run (issue 28): both eyes, as the live run tracked them.
      if (rec.stereo) {
        if (o.scale_calib)
          return fail("offline: " + rdir.string() + " is a stereo recording: --scale-calib is for one camera (the "
                      "recording's station.json holds the rig it was tracked with)");
        o.stereo = true;
        sum.stereo = true;
        sum.stereo_capture = "the live run's pairs, replayed from frames/ and frames_right/ (" + rec.stereo_head + ")";
        rec_right_dir = rdir / "frames_right";
      }
      if (o.station.empty() || o.station == (rdir / "station.json").string()) o.station = (rdir / "station.json").string();
      if (o.session.empty() && fs::exists(rdir / "session.dlog")) o.session = (rdir / "session.dlog").string();
      if (o.truth.empty()) o.truth = "none";
      if (o.masks.empty()) o.masks = "none";
      // Track as the live run did, unless told otherwise.
      if (!o.camera_response_given) {
        o.tracker.detector.response = rec.camera_response;
      } else if (o.tracker.detector.response != rec.camera_response) {
        sum.warnings.push_back(std::string("the recording was tracked with camera response ") +
                               camera_response_name(rec.camera_response) + ", this replay uses " +
                               camera_response_name(o.tracker.detector.response) +
                               ": its poses are not the live run's");
      }
      if (!o.predict_given)
        o.predict_s = rec.predict_ms * 1e-3;
      else if (std::abs(o.predict_s - rec.predict_ms * 1e-3) > 1e-9) {
        char w[160];
        std::snprintf(w, sizeof w, "the recording predicted poses %.1f ms ahead, this replay %.1f ms: its poses are not the live run's",
                      rec.predict_ms, o.predict_s * 1e3);
        sum.warnings.push_back(w);
      }
      if (!o.mirror_rim_given)
        o.tracker.mirror_rim_refine = rec.mirror_rim;
      else if (o.tracker.mirror_rim_refine != rec.mirror_rim)
        sum.warnings.push_back(std::string("the recording was tracked with the mirror rim refinement ") +
                               (rec.mirror_rim ? "on" : "off") + ", this replay has it " +
                               (o.tracker.mirror_rim_refine ? "on" : "off") + ": its poses are not the live run's");
      if (!o.stereo_mirror_rim_given)
        o.tracker.stereo_mirror_rim = rec.stereo_mirror_rim;
      else if (o.tracker.stereo_mirror_rim != rec.stereo_mirror_rim)
        sum.warnings.push_back(std::string("the recording was tracked with the stereo mirror rim ") +
                               (rec.stereo_mirror_rim ? "on" : "off") + ", this replay has it " +
                               (o.tracker.stereo_mirror_rim ? "on" : "off") + ": its poses are not the live run's");
    }
    return {};
  }

  Status open_footage() {
    auto station = read_station_scene(o.station);
    if (!station) return fail("offline: " + station.error());
    sum.session = o.session;
    sum.station = o.station;
    st = std::move(*station);

    // A `dentar synth` folder holds its footage as video.mkv, not as images: say which file to give.
    if (fs::is_directory(o.footage) && fs::exists(fs::path(o.footage) / "video.mkv") &&
        !fs::exists(fs::path(o.footage) / "frames")) {
      const fs::path d = o.footage;
      return fail("offline: " + o.footage + " is a `dentar synth` folder: give its video, --footage " +
                  (d / "video.mkv").string() + " --station " + (d / "station.json").string() + " --session " +
                  (d / "session.dlog").string());
    }
    if (rec.stereo) {
      if (auto e = check_rig(st, o.station, "the stereo recording " + fs::path(o.footage).parent_path().string());
          !e.empty())
        return fail("offline: " + e);
    } else if (auto e = check_stereo_inputs(o); !e.empty()) {
      return fail("offline: " + e);
    }
    // A live recording of a Motion JPEG camera: its frames decoded as the live run decoded them.
    FrameSourceOptions fso;
    if (rec.present && rec.jpeg_decode == "yuyv") fso.pixel_format = "native";
    auto opened = FrameSource::open(o.footage, fso);
    if (!opened) return fail("offline: " + opened.error());
    src = std::move(*opened);
    FrameSource& source = *src;
    if (o.stereo && !rec.stereo) {
      auto s = o.footage_right.empty() ? StereoSource::open_side_by_side(o.footage)
                                       : StereoSource::open_pair(o.footage, o.footage_right);
      if (!s) return fail("offline: " + s.error());
      stereo_src = std::move(*s);
      sum.stereo = true;
    }
    if (o.eye == "right") st.calibration.camera = st.stereo.camera_right;  // that eye's frame and truth
    const auto& cam = st.calibration.camera;
    if (!o.stereo && o.eye.empty() && st.stereo.present && source.width() == 2 * cam.width && source.height() == cam.height)
      return fail("offline: " + o.footage + " is side-by-side stereo footage (two " + std::to_string(cam.width) + "x" +
                  std::to_string(cam.height) + " eyes, the station's \"stereo\" rig): track it from both eyes with "
                  "--stereo, or one eye through the mono path with --eye left|right");
    if ((!o.stereo || rec.stereo) && o.eye.empty() && (source.width() != cam.width || source.height() != cam.height)) {
      const std::string sizes = o.footage + " is " + std::to_string(source.width()) + "x" +
                                std::to_string(source.height()) + " but the station camera (" + o.station +
                                ", camera.width/height) is calibrated for " + std::to_string(cam.width) + "x" +
                                std::to_string(cam.height);
      if (!o.scale_calib)
        return fail("offline: " + sizes +
                    ": use the station file calibrated for this camera mode, or pass --scale-calib if "
                    "the footage is the same camera scaled");
      auto scaled = scale_intrinsics(cam, source.width(), source.height());
      if (!scaled) return fail("offline: " + sizes + ": " + scaled.error());
      st.calibration.camera = *scaled;
      sum.warnings.push_back(sizes + "; intrinsics scaled (--scale-calib)");
    }
    if (source.frame_count() == 0) return fail("offline: " + o.footage + ": the video holds no frames");
    fps = source.fps() > 0 ? source.fps() : 30.0;

    return {};
  }

  Status truth_and_masks() {
    // Ground truth beside the footage, if any.
    const fs::path fdir = fs::is_directory(o.footage) ? fs::path(o.footage) : fs::path(o.footage).parent_path();
    const bool right_eye = o.eye == "right";  // one eye of stereo footage: that eye's truth and masks
    if (o.truth != "none") {
      const std::string tpath = o.truth.empty() ? (fdir / (right_eye ? "truth_right.jsonl" : "truth.jsonl")).string() : o.truth;
      if (!o.truth.empty() || fs::exists(tpath)) {
        auto t = read_truth(tpath);
        if (!t) return fail("offline: " + t.error());
        truth = std::move(*t);
        sum.has_truth = !truth.empty();
      }
    }
    if (o.masks != "none") {
      const std::string m = o.masks.empty() ? (fdir / (right_eye ? "masks_right" : "masks")).string() : o.masks;
      if (fs::is_directory(m)) mask_dir = m;
      else if (!o.masks.empty()) return fail("offline: " + m + ": the masks folder does not exist");
    }
    both_eyes = o.eye == "both";
    if (both_eyes) {
      // The right eye's truth and masks beside the footage (`dentar synth --stereo`), if any.
      const fs::path tr = fdir / "truth_right.jsonl";
      if (o.truth != "none" && fs::exists(tr)) {
        auto t = read_truth(tr.string());
        if (!t) return fail("offline: " + t.error());
        truth_right = std::move(*t);
      }
      if (o.masks != "none" && fs::is_directory(fdir / "masks_right")) mask_right_dir = (fdir / "masks_right").string();
    }

    return {};
  }

  Status make_run() {
    // The run: the tooth and the haptic replay (a session log), or an uncut tooth.
    if (!o.session.empty()) {
      auto log = session::read_session_setup(o.session);
      if (!log) return fail("offline: " + log.error());
      if (!log->warning.empty()) sum.warnings.push_back(log->warning);
      const double session_s = static_cast<double>(log->records.size()) / log->setup.engine.rate_hz;
      const double footage_s = src->frame_count() > 0 ? static_cast<double>(src->frame_count()) / fps : -1;
      if (!rec.present && footage_s >= 0 && session_s > footage_s + 1.0 / fps + 1e-9) {
        std::ostringstream m;
        m << std::setprecision(4) << "offline: the footage " << o.footage << " (" << src->frame_count()
          << " frames, " << footage_s << " s) is shorter than the session log " << o.session << " ("
          << log->records.size() << " steps, " << session_s
          << " s): the cuts after the last frame would never be shown. Use the footage recorded with "
             "this session, or trim the log";
        return fail(m.str());
      }
      o.compositor.bur = log->setup.bur;  // draw the bur the session cut with
      auto r = session::Run::from_session_log(std::move(*log), st, o.station);
      if (!r) return fail("offline: " + r.error());
      run = std::move(*r);
    } else {
      auto r = session::Run::from_station(st);
      if (!r) return fail("offline: " + r.error());
      run = std::move(*r);
      sum.warnings.push_back("no session log: the tooth is shown uncut and no bur is drawn");
    }
    for (const auto& w : run->warnings()) sum.warnings.push_back(w);
    vol = &run->volume();
    engine = run->engine();
    device = run->replay_device();
    rate_hz = run->rate_hz();
    session_steps = run->session_steps();
    // The shared per-frame pipeline, meshing inline (deterministic).
    PipelineOptions po;
    po.tracker = o.tracker;
    // A live run whose tag search ran off the frame path: replay its decisions.
    if (!rec.cues.empty()) {
      po.tracker.discovery = DiscoveryMode::kScheduled;
      if (!rec.cues_exact)
        sum.warnings.push_back(rec.frames_csv + ": a tag search merged in the live run started on a frame the "
                               "recording lacks; poses near it may differ from the live run's");
    }
    po.compositor = o.compositor;
    po.expert = o.expert;
    po.predict_s = o.predict_s;
    po.stereo = o.stereo;
    if (auto w = run->make_pipeline(st, po); !w) return fail("offline: " + w.error());
    pipe = &run->pipeline();
    meshes = &run->meshes();
    if (!pipe->tracker().response_note().empty()) sum.warnings.push_back(pipe->tracker().response_note());

    return {};
  }

  Status open_outputs() {
    // The tooth's box corners in its frame (registration error in pixels).
    {
      const Eigen::Vector3d lo = vol->origin(),
                            hi = vol->origin() + vol->spacing().cwiseProduct(vol->dims().cast<double>());
      for (int k = 0; k < 8; ++k)
        box.emplace_back(k & 1 ? hi.x() : lo.x(), k & 2 ? hi.y() : lo.y(), k & 4 ? hi.z() : lo.z());
    }
    K = (cv::Mat_<double>(3, 3) << st.calibration.camera.fx, 0, st.calibration.camera.cx, 0,
                       st.calibration.camera.fy, st.calibration.camera.cy, 0, 0, 1);
    D = cv::Mat(1, 5, CV_64F, const_cast<double*>(st.calibration.camera.dist.data()));

    video_tmp = out / "composite.partial.mkv";
    if (o.write_video) {
      const bool ffv1 = o.video_codec == "ffv1";
      const int fourcc = ffv1 ? cv::VideoWriter::fourcc('F', 'F', 'V', '1') : cv::VideoWriter::fourcc('M', 'J', 'P', 'G');
      writer.open(video_tmp.string(), cv::CAP_FFMPEG, fourcc, fps,
                  cv::Size(st.calibration.camera.width, st.calibration.camera.height));
      if (!writer.isOpened())
        return fail("offline: " + video_tmp.string() + ": OpenCV cannot open a " + o.video_codec +
                    " video writer here (use --no-video)");
      if (!ffv1) writer.set(cv::VIDEOWRITER_PROP_QUALITY, 95);
      if (both_eyes) {
        // The right eye's composite, frame for frame with composite.mkv.
        const auto& cr = st.stereo.camera_right;
        video_right_tmp = out / "composite_right.partial.mkv";
        writer_right.open(video_right_tmp.string(), cv::CAP_FFMPEG, fourcc, fps, cv::Size(cr.width, cr.height));
        if (!writer_right.isOpened())
          return fail("offline: " + video_right_tmp.string() + ": OpenCV cannot open a " + o.video_codec +
                      " video writer here (use --no-video)");
        if (!ffv1) writer_right.set(cv::VIDEOWRITER_PROP_QUALITY, 95);
      }
    }
    if (both_eyes) {
      const auto& cr = st.stereo.camera_right;
      K_right = (cv::Mat_<double>(3, 3) << cr.fx, 0, cr.cx, 0, cr.fy, cr.cy, 0, 0, 1);
      D_right = cv::Mat(1, 5, CV_64F, const_cast<double*>(cr.dist.data())).clone();
    }
    csv.open(out / "frames.csv.partial");
    if (!csv) return fail("offline: " + (out / "frames.csv.partial").string() + ": cannot write");
    csv << session::offline_csv_header(o.stereo);

    total = o.max_frames > 0 && src->frame_count() > 0
                          ? static_cast<int>(std::min<std::int64_t>(o.max_frames, src->frame_count()))
                          : (o.max_frames > 0 ? o.max_frames : static_cast<int>(src->frame_count()));
    std::error_code ec;
    fs::create_directories(out / "stills", ec);
    for (int k = 0; k < o.stills && total > 0; ++k) still_frames.push_back((2 * k + 1) * total / (2 * o.stills));

    return {};
  }

  // A stereo live recording: frame `index`'s right eye from frames_right/ when the live run had
  // it (frames.csv eyes "both"), else none (the single-view path, as live). Eyes "right" (the
  // left camera lost, session 17): frames/ holds the right eye's image, tracked alone.
  Status recorded_right_eye(std::int64_t index) {
    right_image.release();
    const int eyes = rec.eyes[static_cast<std::size_t>(index)];
    if (eyes == FrameRecord::kEyesLeft) return {};
    if (eyes == FrameRecord::kEyesRight) {
      right_image = std::move(frame.image);
      frame.image = cv::Mat();
      return {};
    }
    char stem[32];
    std::snprintf(stem, sizeof stem, "frame_%06lld", static_cast<long long>(index));
    for (const char* ext : {".jpg", ".png", ".ppm"}) {
      const fs::path p = rec_right_dir / (stem + std::string(ext));
      if (!fs::exists(p)) continue;
      auto img = read_frame_image(p.string(), rec.jpeg_decode == "yuyv" ? "native" : "bgr");
      if (!img) return fail("offline: " + img.error());
      right_image = std::move(*img);
      if (right_image.cols != st.calibration.camera.width || right_image.rows != st.calibration.camera.height)
        return fail("offline: " + p.string() + " is " + std::to_string(right_image.cols) + "x" +
                    std::to_string(right_image.rows) + ", not the rig's eye size " +
                    std::to_string(st.calibration.camera.width) + "x" + std::to_string(st.calibration.camera.height));
      return {};
    }
    return fail("offline: " + (rec_right_dir / stem).string() + ".{jpg,png,ppm}: missing, but " + rec.frames_csv +
                " says frame " + std::to_string(index) + " had both eyes: the recording is damaged");
  }

  // One frame: false when the footage (or the recording's table) ended.
  Result<bool> next_frame(int k) {
    Row r;
    const auto t_req = Clock::now();
    if (stereo_src) {
      // Stereo: a pair, or one eye alone when the other's recording has ended (single view).
      if (!stereo_src->read(sframe, 10.0)) {
        if (!stereo_src->error().empty()) return fail("offline: " + stereo_src->error());
        return false;
      }
      const bool has_left = sframe.has_left();
      right_image = sframe.right.image;
      frame = has_left ? std::move(sframe.left) : std::move(sframe.right);
      if (!has_left) frame.image = cv::Mat();
    } else {
      auto got = src->read(frame);
      if (!got) return fail("offline: " + got.error());
      if (!*got) return false;
      if (o.eye == "left" || o.eye == "right") {  // one eye of side-by-side footage
        cv::Mat left, right;
        if (Status s = split_side_by_side(frame.image, left, right, o.footage); !s) return fail("offline: " + s.error());
        frame.image = (o.eye == "right" ? right : left).clone();
      }
    }
    r.read_ms = ms_since(t_req);
    const auto t_frame = Clock::now();  // the frame is in memory: latency starts here
    if (rec.present) {
      const auto fi = static_cast<std::size_t>(frame.index);
      if (fi >= rec.capture_s.size()) return false;  // frames beyond the table (a crash mid-row): stop
      frame.time_s = rec.capture_s[fi];
      if (rec.stereo)
        if (Status s = recorded_right_eye(frame.index); !s) return Error{s.error()};
    }
    r.frame = static_cast<int>(frame.index);
    r.time_s = frame.time_s;
    if (!(o.stereo && frame.image.empty()) &&
        (frame.image.cols != st.calibration.camera.width || frame.image.rows != st.calibration.camera.height))
      return fail("offline: " + o.footage + ": frame " + std::to_string(frame.index) + " is " +
                  std::to_string(frame.image.cols) + "x" + std::to_string(frame.image.rows) +
                  ", not the size of the earlier frames");

    // Haptics: every step not after the capture time, or, for a live
    // recording, exactly the steps the live run had made when it drew the frame.
    auto t0 = Clock::now();
    if (engine) {
      std::uint64_t want = static_cast<std::uint64_t>(std::floor(frame.time_s * rate_hz + 1e-9)) + 1;
      if (!rec.haptic_steps.empty()) {
        const auto fi = static_cast<std::size_t>(frame.index);
        if (fi >= rec.haptic_steps.size())
          return fail("offline: " + rec.frames_csv + " has no row for frame " + std::to_string(frame.index));
        want = rec.haptic_steps[fi];
      }
      const std::uint64_t done = engine->stats().steps;
      if (want > done) engine->run_steps(want - done);
      snap = engine->snapshot();
      // The live run drew the stylus pose of the frame's exposure (issue 24): the same one.
      const auto fi = static_cast<std::size_t>(frame.index);
      if (fi < rec.pose_step.size() && rec.pose_step[fi] >= 0) {
        const auto h = engine->pose_history().at_index(rec.pose_step[fi]);
        if (h.usable()) Eigen::Map<Eigen::Matrix4d>(snap.T_dev_sty) = h.T_dev_sty.matrix();
      }
    }
    r.haptics_ms = ms_since(t0);

    FrameInput fin;
    fin.image = &frame.image;
    fin.right_image = &right_image;
    fin.index = frame.index;
    fin.capture_time_s = frame.time_s;
    if (!rec.cues.empty()) fin.discovery = &rec.cues[static_cast<std::size_t>(frame.index)];
    fin.haptic = engine ? &snap : nullptr;
    fin.stylus_valid = engine && device && device->position() < device->size();
    if (!rec.haptic_steps.empty()) fin.stylus_valid = engine != nullptr && !snap.fault;
    // A lesson's session: the note on show at the expert's clock, beside the tooth.
    if (const session::LessonClock* l = run->lesson(); l != nullptr && engine && snap.mode != 0) {
      const auto& ann = l->lesson().annotations;
      if (const int a = training::active_note(ann, snap.expert_time_s); a >= 0) fin.note = &ann[static_cast<std::size_t>(a)].text;
    }
    FrameRecord fr;
    if (auto ps = pipe->process(fin, *meshes, cres, fr, both_eyes ? &cres_right : nullptr); !ps)
      return fail("offline: " + ps.error());
    if (both_eyes) right_eye_frame(fr, static_cast<std::size_t>(frame.index), r);
    r.haptic_step = fr.haptic_step;
    r.pedal = fr.pedal;
    for (int m = 0; m < volume::kNumMaterials; ++m) r.removed_mm3[m] = fr.removed_mm3[m];
    r.mesh_ms = fr.mesh_ms;
    r.track_ms = fr.track_ms;
    r.detect_ms = fr.detect_ms;
    r.pose_ms = fr.pose_ms;
    r.filter_ms = fr.filter_ms;
    r.man_state = fr.man_state;
    r.mir_state = fr.mir_state;
    r.T_cam_man = fr.T_cam_man;
    r.T_cam_mtag = fr.T_cam_mtag;
    r.man_rms_px = fr.man_rms_px;
    r.man_tags = fr.man_tags;
    r.mir_tags = fr.mir_tags;
    r.tags_detected = fr.tags_detected;
    r.full_frame = fr.full_frame;
    r.composite_ms = fr.composite_ms;
    r.latency_ms = ms_since(t_frame);
    r.overlay = fr.overlay;
    r.mirror_drawn = fr.mirror_drawn;
    r.triangles = fr.triangles;
    r.eyes = fr.eyes;
    r.man_views = fr.man_views;
    r.mir_views = fr.mir_views;
    if (fr.expert_drawn) ++sum.expert_frames;
    if (fr.expert_drilling_shown) ++sum.expert_drilling_frames;
    if (fr.note_drawn) ++sum.note_frames;
    CompositeInput in;
    in.man_valid = r.man_state != 2;
    in.stylus_valid = fin.stylus_valid;
    in.T_dev_sty = fr.T_dev_sty;

    // Errors against the truth.
    const std::size_t fi = static_cast<std::size_t>(frame.index);
    if (fi < truth.size() && truth[fi].present && in.man_valid) {
      const TruthFrame& tr = truth[fi];
      r.man_err_mm = (r.T_cam_man.translation() - tr.T_cam_man.translation()).norm() * 1e3;
      r.man_err_deg = rotation_deg(r.T_cam_man, tr.T_cam_man);
      const auto a = project(r.T_cam_man * st.calibration.T_man_tooth), b = project(tr.T_cam_tooth);
      double e = 0;
      for (std::size_t i = 0; i < a.size(); ++i) e += std::hypot(a[i].x - b[i].x, a[i].y - b[i].y);
      r.tooth_err_px = e / static_cast<double>(a.size());
      if (in.stylus_valid) {
        const Iso T_cam_tip =
            r.T_cam_man * st.calibration.T_man_dev * in.T_dev_sty * st.calibration.T_sty_tip;
        r.tip_err_mm = (T_cam_tip.translation() - tr.T_cam_tip.translation()).norm() * 1e3;
      }
    }
    if (fi < truth.size() && truth[fi].present && truth[fi].has_mirror && r.mir_state != 2) {
      const Iso T_cam_mir = r.T_cam_mtag * st.calibration.T_mtag_mir;
      r.mir_err_mm = (T_cam_mir.translation() - truth[fi].T_cam_mir.translation()).norm() * 1e3;
      r.mir_err_deg = rotation_deg(T_cam_mir, truth[fi].T_cam_mir);
    }
    if (!mask_dir.empty()) {
      char name[32];
      std::snprintf(name, sizeof name, "mask_%06d.png", static_cast<int>(frame.index));
      const cv::Mat mask = cv::imread((fs::path(mask_dir) / name).string(), cv::IMREAD_GRAYSCALE);
      // (With the left eye lost the composite is the right eye's: not comparable to the left's mask.)
      if (!mask.empty() && mask.size() == cres.tooth_visible.size() && r.eyes != FrameRecord::kEyesRight) {
        const cv::Mat truth_vis = mask == 64, drawn = cres.tooth_visible > 127;
        const int inter = cv::countNonZero(truth_vis & drawn), uni = cv::countNonZero(truth_vis | drawn);
        if (uni > 0) r.iou = static_cast<double>(inter) / uni;
      }
    }

    t0 = Clock::now();
    if (o.write_video) writer.write(cres.image);
    if (std::find(still_frames.begin(), still_frames.end(), k) != still_frames.end()) {
      char name[48];
      std::snprintf(name, sizeof name, "stills/frame_%06d.png", static_cast<int>(frame.index));
      if (cv::imwrite((out / name).string(), cres.image)) stills.push_back(name);
      // The tooth is small in a head-camera view: a 4x close-up of the
      // overlay's region, beside the frame.
      cv::Rect roi = cres.region;
      if (roi.area() > 0) {
        const int pad = std::max(roi.width, roi.height) / 2 + 8;
        roi = cv::Rect(roi.x - pad, roi.y - pad, roi.width + 2 * pad, roi.height + 2 * pad) &
              cv::Rect(0, 0, cres.image.cols, cres.image.rows);
        cv::Mat zoom;
        const double scale = std::min(4.0, 480.0 / std::max(roi.width, roi.height));
        cv::resize(cres.image(roi), zoom, cv::Size(), scale, scale, cv::INTER_CUBIC);
        std::snprintf(name, sizeof name, "stills/frame_%06d_zoom.png", static_cast<int>(frame.index));
        if (cv::imwrite((out / name).string(), zoom)) stills.push_back(name);
      }
    }
    r.write_ms = ms_since(t0);
    csv << session::offline_csv_row(r, o.stereo);
    rows.push_back(r);
    if (progress) progress("pipeline", k + 1, total);
  return true;
  }

  // --eye both: the right eye's composite into composite_right.mkv (the main composite when
  // the left eye was missing: it is the right eye's; black when the right eye was), and its
  // tooth against the right eye's truth: the projected box corners (px) and the silhouette.
  void right_eye_frame(const FrameRecord& fr, std::size_t fi, Row& row) {
    const auto& cr = st.stereo.camera_right;
    const bool own = fr.right.composited, main_is_right = fr.eyes == FrameRecord::kEyesRight;
    if (own) {
      ++sum.right_composited;
      sum.right_overlays += fr.right.overlay ? 1 : 0;
      row.right_composited = true;
      row.right_overlay = fr.right.overlay;
      row.right_mirror_drawn = fr.right.mirror_drawn;
      row.right_composite_ms = fr.right.composite_ms;
    }
    if (o.write_video) {
      if (own) writer_right.write(cres_right.image);
      else if (main_is_right) writer_right.write(cres.image);
      else writer_right.write(cv::Mat(cr.height, cr.width, CV_8UC3, cv::Scalar::all(0)));
    }
    if (!own || fr.man_state == 2) return;
    const Iso T_camr_man = st.stereo.T_caml_camr.inverse() * fr.T_cam_man;
    if (fi < truth_right.size() && truth_right[fi].present) {
      auto proj = [&](const Iso& T) {
        std::vector<cv::Point3d> p;
        for (const auto& b : box) {
          const Eigen::Vector3d c = T * b;
          p.emplace_back(c.x(), c.y(), c.z());
        }
        std::vector<cv::Point2d> uv;
        cv::projectPoints(p, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K_right, D_right, uv);
        return uv;
      };
      const auto a = proj(T_camr_man * st.calibration.T_man_tooth), b = proj(truth_right[fi].T_cam_tooth);
      double e = 0;
      for (std::size_t i = 0; i < a.size(); ++i) e += std::hypot(a[i].x - b[i].x, a[i].y - b[i].y);
      right_tooth_err_px.push_back(e / static_cast<double>(a.size()));
      row.right_tooth_err_px = right_tooth_err_px.back();
    }
    if (!mask_right_dir.empty()) {
      char name[32];
      std::snprintf(name, sizeof name, "mask_%06d.png", static_cast<int>(fi));
      const cv::Mat mask = cv::imread((fs::path(mask_right_dir) / name).string(), cv::IMREAD_GRAYSCALE);
      if (!mask.empty() && mask.size() == cres_right.tooth_visible.size()) {
        const cv::Mat truth_vis = mask == 64, drawn = cres_right.tooth_visible > 127;
        const int inter = cv::countNonZero(truth_vis & drawn), uni = cv::countNonZero(truth_vis | drawn);
        if (uni > 0) right_iou.push_back(static_cast<double>(inter) / uni);
        if (uni > 0) row.right_iou = right_iou.back();
      }
    }
  }

  Status totals() {
    if (rows.empty()) return fail("offline: " + o.footage + ": no frame could be read (empty video?)");
    if (o.write_video) writer.release();
    if (writer_right.isOpened()) writer_right.release();
    sum.both_eyes = both_eyes;
    sum.right_tooth_err_px = make_stat(right_tooth_err_px);
    sum.right_silhouette_iou = make_stat(right_iou);
    csv.close();
    if (!csv) return fail("offline: frames.csv: write failed (disk full?)");

    // Totals.
    sum.frames = static_cast<int>(rows.size());
    sum.footage_s = rows.back().time_s - rows.front().time_s + 1.0 / fps;
    auto col = [&](auto get) {
      std::vector<double> v;
      for (const auto& r : rows) v.push_back(get(r));
      return v;
    };
    for (const auto& r : rows) {
      (r.man_state == 0 ? sum.tracking : r.man_state == 1 ? sum.predicted : sum.lost)++;
      if (r.mir_state == 0) ++sum.mirror_tracking;
      if (r.overlay) ++sum.overlays;
      sum.eyes_both += r.eyes == FrameRecord::kEyesBoth;
      sum.eyes_left += r.eyes == FrameRecord::kEyesLeft;
      sum.eyes_right += r.eyes == FrameRecord::kEyesRight;
      sum.man_two_views += r.man_views == 2;
    }
    if (stereo_src) sum.stereo_capture = stereo_src->stats().summary();
    sum.man_err_mm = make_stat(col([](const Row& r) { return r.man_err_mm; }));
    sum.man_err_deg = make_stat(col([](const Row& r) { return r.man_err_deg; }));
    sum.tooth_err_px = make_stat(col([](const Row& r) { return r.tooth_err_px; }));
    sum.tip_err_mm = make_stat(col([](const Row& r) { return r.tip_err_mm; }));
    sum.silhouette_iou = make_stat(col([](const Row& r) { return r.iou; }));
    sum.mir_err_mm = make_stat(col([](const Row& r) { return r.mir_err_mm; }));
    sum.mir_err_deg = make_stat(col([](const Row& r) { return r.mir_err_deg; }));
    sum.read_ms = make_stat(col([](const Row& r) { return r.read_ms; }));
    sum.track_ms = make_stat(col([](const Row& r) { return r.track_ms; }));
    sum.haptics_ms = make_stat(col([](const Row& r) { return r.haptics_ms; }));
    sum.mesh_ms = make_stat(col([](const Row& r) { return r.mesh_ms; }));
    sum.composite_ms = make_stat(col([](const Row& r) { return r.composite_ms; }));
    sum.write_ms = make_stat(col([](const Row& r) { return r.write_ms; }));
    sum.latency_ms = make_stat(col([](const Row& r) { return r.latency_ms; }));
    // A live recording: the rest of the session log after the last frame, so
    // the final cut is the one the student made.
    if (engine && rec.present) {
      const std::uint64_t done = engine->stats().steps;
      if (session_steps > done) engine->run_steps(session_steps - done);
    }
    if (engine) {
      sum.haptic_steps = engine->stats().steps;
      snap = engine->snapshot();
      sum.pulp_exposed = snap.pulp_exposed != 0;
      sum.pulp_exposed_at_s = snap.pulp_exposed_at_s;
      // Up to one frame period of steps may follow the last frame (exposure
      // time); more means the footage stopped early (--max-frames).
      if (static_cast<double>(session_steps - std::min<std::uint64_t>(session_steps, sum.haptic_steps)) >
          rate_hz / fps + 1)
        sum.warnings.push_back("the footage ended " + std::to_string(session_steps - sum.haptic_steps) +
                               " haptic steps before the session log did (--max-frames?)");
    }
    sum.removed_mm3.assign(volume::kNumMaterials, 0.0);
    for (int m = 0; m < volume::kNumMaterials; ++m) sum.removed_mm3[static_cast<std::size_t>(m)] = snap.removed_mm3[m];
    sum.volume_hash = vol->content_hash();
    sum.wall_s = std::chrono::duration<double>(Clock::now() - wall0).count();

    return {};
  }

  Status write_files() {
    // Files: CSV and video into place, then the summary, the report last.
    std::error_code ec;
    fs::rename(out / "frames.csv.partial", out / "frames.csv", ec);
    if (ec) return fail("offline: frames.csv: " + ec.message());
    if (o.write_video) {
      fs::rename(video_tmp, out / "composite.mkv", ec);
      if (ec) return fail("offline: composite.mkv: " + ec.message());
      if (both_eyes) {
        fs::rename(video_right_tmp, out / "composite_right.mkv", ec);
        if (ec) return fail("offline: composite_right.mkv: " + ec.message());
      }
    }
    // The drivers' hook (scoring): its HTML goes into the report, its warnings into both files.
    std::string extra_html;
    if (o.after_run) extra_html = o.after_run(sum);
    nlohmann::json inputs = {{"footage", o.footage},
                             {"station", o.station},
                             {"session", o.session.empty() ? nlohmann::json(nullptr) : nlohmann::json(o.session)},
                             {"truth", sum.has_truth},
                             {"masks", mask_dir.empty() ? nlohmann::json(nullptr) : nlohmann::json(mask_dir)},
                             {"camera", {st.calibration.camera.width, st.calibration.camera.height}},
                             {"fps", fps},
                             {"predict_ms", o.predict_s * 1e3},
                             {"tracker",
                              {{"decimation", o.tracker.detector.decimation},
                               {"predicted_regions", o.tracker.predicted_regions},
                               {"full_frame_interval", o.tracker.full_frame_interval},
                               {"filter", o.tracker.filter_enabled},
                               {"stale_limit_ms", o.tracker.stale_limit_s * 1e3},
                               {"mirror_max_sigma_mm", o.tracker.mirror_max_sigma_m * 1e3}}}};
    char hash[20];
    std::snprintf(hash, sizeof hash, "%016llx", static_cast<unsigned long long>(sum.volume_hash));
    nlohmann::json removed = nlohmann::json::object();
    for (int m = 1; m < volume::kNumMaterials; ++m)
      removed[std::string(volume::material_info(m).name)] = sum.removed_mm3[static_cast<std::size_t>(m)];
    nlohmann::json js = {
        {"complete", true},
        {"frames", sum.frames},
        {"footage_s", sum.footage_s},
        {"wall_s", sum.wall_s},
        {"states", {{"tracking", sum.tracking}, {"predicted", sum.predicted}, {"lost", sum.lost}}},
        {"mirror_tracking", sum.mirror_tracking},
        {"overlays", sum.overlays},
        {"has_truth", sum.has_truth},
        {"errors",
         {{"man_mm", stat_json(sum.man_err_mm)},
          {"man_deg", stat_json(sum.man_err_deg)},
          {"tooth_px", stat_json(sum.tooth_err_px)},
          {"tip_mm", stat_json(sum.tip_err_mm)},
          {"silhouette_iou", stat_json(sum.silhouette_iou)},
          {"mir_mm", stat_json(sum.mir_err_mm)},
          {"mir_deg", stat_json(sum.mir_err_deg)}}},
        {"stage_ms",
         {{"read", stat_json(sum.read_ms)},
          {"track", stat_json(sum.track_ms)},
          {"haptics", stat_json(sum.haptics_ms)},
          {"mesh", stat_json(sum.mesh_ms)},
          {"composite", stat_json(sum.composite_ms)},
          {"write", stat_json(sum.write_ms)}}},
        {"latency_ms", stat_json(sum.latency_ms)},
        {"haptic_steps", sum.haptic_steps},
        {"volume_hash", hash},
        {"removed_mm3", removed},
        {"pulp_exposed", sum.pulp_exposed},
        {"pulp_exposed_at_s", sum.pulp_exposed ? nlohmann::json(sum.pulp_exposed_at_s) : nlohmann::json(nullptr)},
        {"warnings", sum.warnings},
        {"inputs", inputs}};
    // A session trained in a mode (issue 27); absent otherwise, so older outputs are unchanged.
    if (sum.expert_frames > 0)
      js["expert"] = {{"frames", sum.expert_frames}, {"drilling_frames", sum.expert_drilling_frames}};
    // Stereo runs (issue 28); absent otherwise, so mono outputs are unchanged.
    if (sum.stereo)
      js["stereo"] = {{"eyes", {{"both", sum.eyes_both}, {"left", sum.eyes_left}, {"right", sum.eyes_right}}},
                      {"mannequin_two_views", sum.man_two_views},
                      {"baseline_mm", st.stereo.baseline_m() * 1e3},
                      {"capture", sum.stereo_capture}};
    if (!o.eye.empty()) js["eye"] = o.eye;
    if (sum.both_eyes) {
      auto stat_js = [](const Stat& x) {
        return nlohmann::json{{"n", x.n}, {"median", x.median}, {"p95", x.p95}, {"max", x.max}, {"mean", x.mean}};
      };
      js["right_eye"] = {{"frames_composited", sum.right_composited},
                         {"overlays", sum.right_overlays},
                         {"tooth_err_px", stat_js(sum.right_tooth_err_px)},
                         {"silhouette_iou", stat_js(sum.right_silhouette_iou)},
                         {"video", o.write_video ? nlohmann::json("composite_right.mkv") : nlohmann::json(nullptr)}};
    }
    if (sum.note_frames > 0) js["lesson_notes"] = {{"frames", sum.note_frames}};
    if (auto s = write_atomic(out / "summary.json", js.dump(2) + "\n"); !s) return fail("offline: " + s.error());
    if (auto s = write_atomic(out / "report.html", make_report(o, sum, rows, stills, inputs, extra_html)); !s)
      return fail("offline: " + s.error());
    return {};
  }
};

Result<OfflineSummary> run_offline(const OfflineOptions& o_in,
                                   const std::function<void(const std::string&, int, int)>& progress) {
  Job job;
  job.wall0 = Clock::now();
  job.o = o_in;
  job.progress = progress;
  if (auto v = job.o.validate(); !v.empty()) return Error{"offline: " + v};
  const fs::path out = job.o.out_dir;
  job.out = out;
  std::error_code ec;
  fs::create_directories(out, ec);
  if (ec) return Error{out.string() + ": cannot create the output folder: " + ec.message()};
  // Nothing from an earlier run may pass for this run's result.
  for (const char* f : {"summary.json", "report.html", "FAILED.txt", "frames.csv", "composite.mkv", "composite_right.mkv"})
    fs::remove(out / f, ec);

  auto egl = EglContext::create();
  if (!egl) return job.fail("offline: headless rendering: " + egl.error());
  if (auto st = egl->make_current(); !st) return job.fail("offline: " + st.error());
  // The run's GL objects go while the context is current (before egl).
  struct ReleaseRun {
    Job& job;
    ~ReleaseRun() { job.run.reset(); }
  } release_run{job};
  job.sum.out_dir = out.string();

  // Inputs: the built-in footage (generated first) or the given one; a live
  // recording folder's frames, station, session and timing; truth and masks.
  if (auto s = job.builtin_footage(); !s) return Error{s.error()};
  if (auto s = job.live_recording(); !s) return Error{s.error()};
  if (auto s = job.open_footage(); !s) return Error{s.error()};
  if (auto s = job.truth_and_masks(); !s) return Error{s.error()};
  // The run (session::Run): tooth, replayed engine, meshes, pipeline.
  if (auto s = job.make_run(); !s) return Error{s.error()};
  if (auto s = job.open_outputs(); !s) return Error{s.error()};
  for (int k = 0; job.o.max_frames == 0 || k < job.o.max_frames; ++k) {
    auto more = job.next_frame(k);
    if (!more) return Error{more.error()};
    if (!*more) break;
  }
  if (auto s = job.totals(); !s) return Error{s.error()};
  if (auto s = job.write_files(); !s) return Error{s.error()};
  return job.sum;
}

}  // namespace dentar::offline
