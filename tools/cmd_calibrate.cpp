// dentar calibrate: the guided station calibration for instructors (issue 7).
// Steps: camera, pivot, register, tooth, mirror, check, all. Each step prompts, prints live
// quality figures while its data comes in, and updates ONE station file only when its gates
// pass. Data: real files (--images, --poses, --import) or --simulate (the footage generator
// stands in for the camera, a simulated stylus for the device; the hidden truth is the
// built-in station perturbed by --seed).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>
#include <random>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "commands.h"
#include "dentar/ar/bundle_pose.h"
#include "dentar/ar/calib_board.h"
#include "dentar/ar/egl_context.h"
#include "dentar/ar/station_scene.h"
#include "dentar/ar/stereo_source.h"
#include "dentar/ar/synth.h"
#include "dentar/ar/tag_detector.h"
#include "dentar/calibration/camera_file.h"
#include "dentar/calibration/camera_model.h"
#include "dentar/calibration/co_location.h"
#include "dentar/calibration/guided.h"
#include "dentar/calibration/intrinsics.h"
#include "dentar/calibration/landmarks.h"
#include "dentar/calibration/mirror.h"
#include "dentar/calibration/pivot.h"
#include "dentar/calibration/registration.h"
#include "dentar/calibration/response.h"
#include "dentar/calibration/stereo.h"
#include "dentar/calibration/stylus_poses.h"
#include "dentar/calibration/hand_eye.h"
#include "dentar/live/calibrate_app.h"
#include "dentar/haptics/device_profiles.h"
#include "dentar/haptics/pose_history.h"
#include "dentar/live/station_health.h"

namespace dentar::tools {
namespace {

namespace fs = std::filesystem;
namespace cal = dentar::calibration;
constexpr double kDeg = M_PI / 180.0;
constexpr const char* kCmd = "calibrate";

struct CalibCli {
  std::string step;
  std::string station = "station.json";
  bool simulate = false;
  std::uint64_t seed = 1;
  std::string images, board = "chessboard:9x6:20", poses, import_camera, camera_out, export_ros;
  std::string device = "head camera";
  int count = 0;              // 0: the step's default amount of data
  double max_tilt_deg = 25;   // simulated pivot tilt
  int bad_view = 3;           // simulated camera step: the warped-board view (-1: none)
  double sim_board_area = 100;
  bool board_given = false;  // --board on the command line (live: else its AprilTag grid default)
  int camera_views = 12;     // live camera step  // simulated camera step: boards inside this % of the image
  int check_frames = 20;
  double latency_ms = 33;  // check: the camera's latency against the haptic pose drawn with its frame
  double latency_jitter_ms = 2;  // check: its per-frame spread (1 sigma)
  double camera_latency_ms = -1;  // any step: record the station camera's measured latency (< 0: keep)
  bool rational = false;
  std::string model = "auto";  // camera: auto, k1, k1k2, radtan5, rational8
  std::string corners = "sb-subpix";  // camera, chessboards: sb-subpix, sb, classic
  bool instructor_time = false;
  std::string camera;  // --camera SPEC: which physical camera (camera.device_id)
  std::string left_dir, right_dir;  // stereo: one folder per eye (else --images: side-by-side photos)
  bool stereo_live = false;         // stereo --live: --left/--right (or --side-by-side) are video sources
  std::string side_by_side;         // stereo --live: one side-by-side device
  double stall_timeout_s = 5;       // stereo --live: an eye silent this long ends the capture
  std::string stall_left, stall_right;  // stereo --live test hooks: AFTER_FRAMES:SECONDS, the eye goes quiet
  std::string hand = "HMD";  // hand_eye: what carries the camera
  double he_spread_deg = 170;  // --simulate hand_eye: rotation spread of the motions
  // live
  std::string haptic = "sim", haptic_name, pedal = "keyboard", live_steps;  // empty: every live step (camera only with --camera)
  std::string screenshots, summary;
  double pace = 1.0, seconds = 0;
  int display = -1;
  bool quiet = false;
};

// Thrown for bad input (exit 2); gate failures return 1 instead.
struct BadInput {
  std::string message;
};

std::string now_iso() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

std::string fmt(double v, int prec = 2) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(prec) << v;
  return os.str();
}

// ---- stylus poses file (CSV): calibration/stylus_poses.h --------------------------------------
using PoseRow = cal::StylusPoseRow;

std::vector<PoseRow> read_poses(const std::string& path) {
  auto r = cal::read_stylus_poses(path);
  if (!r) throw BadInput{r.error()};
  return std::move(r).value();
}

std::vector<PoseRow> rows_with(const std::vector<PoseRow>& rows, const std::string& prefix) {
  return cal::stylus_rows_with(rows, prefix);
}

int label_index(const PoseRow& r, const std::string& path, std::size_t limit) {
  auto i = cal::stylus_label_index(r, path, limit);
  if (!i) throw BadInput{i.error()};
  return *i;
}

// ---- the session ------------------------------------------------------------------------------
struct Session {
  const CalibCli& cli;
  ar::StationScene st;       // being calibrated
  cal::StationCalibration truth;  // simulation only
  std::mt19937_64 rng;
  std::string camera_yaml;   // written after the camera step (when it ran)
  cal::CameraFile camera_file;
  bool wrote_camera = false;
  bool record_failure = false;  // a failed check is still written (its date and FAIL)
  explicit Session(const CalibCli& c) : cli(c), rng(c.seed * 1000003 + 11) {}
};

void print_prompt(const std::string& title, const std::string& text) {
  std::cout << "\n== " << title << " ==\n" << text << "\n";
}

cal::StylusNoise sim_noise() { return cal::StylusNoise{}; }

// The image files of a folder of board photos (camera and stereo steps), in name order.
std::vector<fs::path> board_photo_files(const std::string& dir) {
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir)) {
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    if (ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".bmp" || ext == ".tif" || ext == ".tiff")
      files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

// Each step returns 0 (gates passed, station updated in memory), 1 (a gate failed).
int step_camera(Session& s) {
  const CalibCli& c = s.cli;
  print_prompt("camera intrinsics",
               "Hold the printed board in front of the head camera and take about 12 photos:\n"
               "board tilted 15-45 degrees toward the left, right, top and bottom, near the image\n"
               "edges and in the middle (where the tooth is drawn). Needs >= 6 usable views.");
  cal::CameraFile cf;
  std::optional<cal::ModelSelection> selection;  // when calibrated here (not imported)
  // The camera's response (issue 24), measured from chessboard views; unknown otherwise.
  cal::CameraResponseCurve response;
  std::string response_summary = "response not measured (imported camera)";
  if (!c.import_camera.empty()) {
    auto r = cal::read_camera_file(c.import_camera);
    if (!r) throw BadInput{r.error()};
    cf = *r;
    std::cout << "imported " << c.import_camera << " (" << cf.source_format << "): fx fy "
              << fmt(cf.camera.fx) << " " << fmt(cf.camera.fy) << " px, " << cf.camera.width << "x"
              << cf.camera.height << (cf.rms_px >= 0 ? ", RMS " + fmt(cf.rms_px, 3) + " px" : "")
              << "\n";
    if (!cf.warning.empty()) std::cout << "WARNING: " << cf.warning << "\n";
    std::cout << "camera " << response_summary << "\n";
  } else {
    auto spec = ar::parse_board_spec(c.board);
    if (!spec) throw BadInput{spec.error()};
    if (auto* cb = std::get_if<cal::ChessboardSpec>(&*spec))
      cb->detector = c.corners == "sb" ? cal::ChessboardDetector::kSectorBasedUnrefined
                     : c.corners == "classic" ? cal::ChessboardDetector::kClassic
                                              : cal::ChessboardDetector::kSectorBased;
    std::vector<cal::BoardView> views;
    std::vector<cv::Mat> view_images;  // chessboard views' grey images, for the response
    const bool chessboard = std::holds_alternative<cal::ChessboardSpec>(*spec);
    int width = 0, height = 0;
    int photos_skipped = 0;  // photos where the board was not found
    cal::IntrinsicsOptions io;  // live figures: the 5-coefficient fit
    cal::ModelSelectionOptions mo;
    if (c.rational || c.model == "rational8") mo.force = cal::DistortionModel::kRational8;
    else if (c.model == "k1") mo.force = cal::DistortionModel::kK1;
    else if (c.model == "k1k2") mo.force = cal::DistortionModel::kK1K2;
    else if (c.model == "radtan5") mo.force = cal::DistortionModel::kRadTan5;
    else if (c.model != "auto")
      throw BadInput{"camera: --model " + c.model + " is not one of auto, k1, k1k2, radtan5, rational8"};
    auto live = [&](const std::string& what) {
      std::cout << "  [" << views.size() << "] " << what;
      if (static_cast<int>(views.size()) >= io.min_views) {
        const auto r = cal::calibrate_intrinsics(views, width, height, io);
        if (r.calibrations_run > 0)
          std::cout << "; running RMS " << fmt(r.rms_px, 3) << " px, fx " << fmt(r.camera.fx, 1)
                    << " +- " << fmt(r.std_devs.empty() ? 0 : r.std_devs[0], 2) << " px, "
                    << r.rejected.size() << " rejected, tooth-region coverage "
                    << fmt(r.coverage.tooth_fraction * 100, 0) << "%";
      } else {
        std::cout << "; " << io.min_views - static_cast<int>(views.size()) << " more views needed";
      }
      std::cout << "\n" << std::flush;
    };
    if (c.simulate) {
      const cal::CameraIntrinsics& k = s.truth.camera;
      width = k.width;
      height = k.height;
      const int n = c.count > 0 ? c.count : 12;
      std::cout << "simulated camera: rendering " << n << " board views (" << c.board << ")"
                << (c.bad_view >= 0 && c.bad_view < n
                        ? ", view " + std::to_string(c.bad_view) + " with a warped board"
                        : "")
                << "\n";
      const ar::BoardTexture tex = ar::make_board_texture(*spec);
      const auto poses = cal::plan_board_poses_in_region(
          k, ar::board_width_m(*spec), ar::board_height_m(*spec), n, c.seed, c.sim_board_area / 100);
      if (c.sim_board_area < 100)
        std::cout << "simulated photos keep the board inside the middle " << fmt(c.sim_board_area, 0)
                  << "% of the image\n";
      for (int i = 0; i < n; ++i) {
        ar::BoardRenderOptions ro;
        ro.supersample = 2;
        ro.seed = c.seed * 1000 + i;
        if (i == c.bad_view) ro.warp_m = 0.006;
        const cv::Mat img = ar::render_board_view(tex, k, poses[i], ro);
        const std::string name = "sim-view-" + std::to_string(i);
        auto v = ar::detect_board(img, *spec, name);
        if (!v) {
          std::cout << "  " << v.error() << "\n";
          continue;
        }
        views.push_back(*v);
        if (chessboard) view_images.push_back(img);
        live(name + ": " + std::to_string(v->image_points.size()) + " points");
      }
    } else {
      if (c.images.empty())
        throw BadInput{"camera: give --images DIR (board photos), --import FILE (a camera YAML) "
                       "or --simulate"};
      if (!fs::is_directory(c.images)) throw BadInput{c.images + ": not a directory of board photos"};
      const std::vector<fs::path> files = board_photo_files(c.images);
      if (files.empty()) throw BadInput{c.images + ": no .png/.jpg/.bmp/.tif images in it"};
      for (const auto& f : files) {
        int w = 0, h = 0;
        auto v = ar::detect_board_file(f.string(), *spec, w, h);
        if (!v) {
          std::cout << "  skipped: " << v.error() << "\n";
          ++photos_skipped;
          continue;
        }
        if (width == 0) {
          width = w;
          height = h;
        } else if (w != width || h != height) {
          throw BadInput{f.string() + ": image is " + std::to_string(w) + "x" + std::to_string(h) +
                         ", the others " + std::to_string(width) + "x" + std::to_string(height) +
                         "; all photos must come from the same camera mode"};
        }
        v->name = f.filename().string();
        views.push_back(*v);
        if (chessboard) view_images.push_back(cv::imread(f.string(), cv::IMREAD_GRAYSCALE));
        live(f.filename().string() + ": " + std::to_string(v->image_points.size()) + " points");
      }
      if (views.empty())
        throw BadInput{c.images + ": the board (" + c.board +
                       ") was not found in any photo; check --board"};
    }
    std::cout << "choosing the distortion model (k1, k1k2, radtan5, rational8 where warranted) "
                 "on held-out views...\n";
    const cal::ModelSelection sel = cal::select_camera_model(views, width, height, mo);
    std::cout << sel.report();
    if (!sel.ok) {
      if (photos_skipped > 0 && photos_skipped >= static_cast<int>(views.size()))
        std::cout << "note: the board was not found in " << photos_skipped << " of "
                  << photos_skipped + static_cast<int>(views.size()) << " photos: check that --board "
                  << c.board << " matches the printed board (count its INNER corners: a chessboard "
                  << "of 10x7 squares has 9x6) and its square size\n";
      return 1;
    }
    const cal::IntrinsicsSummary& r = sel.chosen;
    if (c.simulate)
      std::cout << "simulation truth: fx " << fmt(s.truth.camera.fx) << " fy " << fmt(s.truth.camera.fy)
                << " cx " << fmt(s.truth.camera.cx) << " cy " << fmt(s.truth.camera.cy)
                << " px; error fx " << fmt(r.camera.fx - s.truth.camera.fx) << " px\n";
    cf = sel.to_camera_file(c.simulate ? "simulated head camera" : c.device);
    selection = sel;
    if (!chessboard) {
      response_summary = "response not measured (measured on chessboards only)";
    } else {
      std::vector<cal::ResponseView> rv;
      for (std::size_t i = 0; i < views.size() && i < view_images.size(); ++i) {
        const cv::Mat& g = view_images[i];
        if (g.empty() || g.type() != CV_8UC1) continue;
        cal::ResponseView v{g.data, g.cols, g.rows, static_cast<int>(g.step), {}, views[i].name};
        for (const auto& p : views[i].image_points) {
          v.corners_xy.push_back(p.x());
          v.corners_xy.push_back(p.y());
        }
        rv.push_back(std::move(v));
      }
      const auto& cb = std::get<cal::ChessboardSpec>(*spec);
      const cal::ResponseEstimate est = cal::estimate_response_chessboard(rv, cb.cols, cb.rows);
      if (est.ok) {
        response = cal::response_from_estimate(est);
        response_summary = "response " + response.kind + ": gamma " + fmt(est.gamma, 2) + " +- " +
                           fmt(est.gamma_sigma, 2) + " over " + std::to_string(est.edges) +
                           " edges in " + std::to_string(est.views) + " views (edge-level rms: fitted " +
                           fmt(est.rms_gamma, 3) + ", sRGB " + fmt(est.rms_srgb, 3) + ", linear " +
                           fmt(est.rms_linear, 3) + ")";
      } else {
        response_summary = "response not measured: " + est.message;
      }
    }
    std::cout << "camera " << response_summary << "\n";
  }
  s.st.calibration.camera = cf.camera;
  const std::string keep_id = s.st.camera_provenance.device_id;
  s.st.camera_provenance = ar::CameraProvenance{};
  s.st.camera_provenance.model = cf.model;
  s.st.camera_provenance.response = response;
  s.st.camera_provenance.rms_px = cf.rms_px;
  s.st.camera_provenance.std_devs = cf.std_devs;
  s.st.camera_provenance.date = cf.date;
  s.st.camera_provenance.device = cf.device;
  // The camera this calibration belongs to (--camera); kept from the file otherwise.
  s.st.camera_provenance.device_id = c.camera.empty() ? keep_id : live::camera_identity(c.camera);
  s.camera_file = cf;
  s.wrote_camera = true;
  ar::CalibrationStepReport rep{"camera", now_iso(), true, "", {}};
  rep.summary = "fx " + fmt(cf.camera.fx) + " fy " + fmt(cf.camera.fy) + " px, model " + cf.model;
  if (selection)
    rep.summary += " (distortion terms " + std::string(cal::distortion_model_name(selection->model)) +
                   ", chosen on held-out views; trustworthy to " +
                   fmt(selection->trust.max_error_px, 1) + " px over " +
                   fmt(selection->trust.trusted_fraction * 100, 0) + "% of the image)";
  else
    rep.summary += " (imported from " + c.import_camera + ")";
  rep.summary += "; " + response_summary;
  if (response.gamma > 0) {
    rep.figures.emplace_back("response_gamma", response.gamma);
    rep.figures.emplace_back("response_gamma_sd", response.gamma_sigma);
  }
  if (cf.rms_px >= 0) rep.figures.emplace_back("rms_px", cf.rms_px);
  if (cf.std_devs.size() >= 4) {
    rep.figures.emplace_back("fx_sd_px", cf.std_devs[0]);
    rep.figures.emplace_back("fy_sd_px", cf.std_devs[1]);
    rep.figures.emplace_back("cx_sd_px", cf.std_devs[2]);
    rep.figures.emplace_back("cy_sd_px", cf.std_devs[3]);
  }
  rep.figures.emplace_back("views", cf.views_used);
  if (selection) {
    const auto& ch = selection->candidates;
    for (const auto& cand : ch)
      if (cand.model == selection->model) rep.figures.emplace_back("heldout_rms_px", cand.heldout_rms_px);
    rep.figures.emplace_back("distortion_terms", static_cast<double>(cal::free_coefficient_count(selection->model)));
    rep.figures.emplace_back("trusted_image_pct", selection->trust.trusted_fraction * 100);
    rep.figures.emplace_back("trusted_tooth_pct", selection->trust.tooth_trusted_fraction * 100);
    double worst_tooth = 0;
    const auto& tr = cal::IntrinsicsOptions{}.tooth_region;
    for (int rr = 0; rr < selection->trust.rows; ++rr)
      for (int cc = 0; cc < selection->trust.cols; ++cc) {
        const double x = (cc + 0.5) / selection->trust.cols, y = (rr + 0.5) / selection->trust.rows;
        if (x >= tr[0] && x <= tr[2] && y >= tr[1] && y <= tr[3])
          worst_tooth = std::max(worst_tooth, selection->trust.bound_px[rr * selection->trust.cols + cc]);
      }
    rep.figures.emplace_back("tooth_error_bound_px", worst_tooth);
  }
  s.st.set_step_report(rep);
  return 0;
}

std::vector<Eigen::Isometry3d> pivot_data(Session& s) {
  const CalibCli& c = s.cli;
  if (c.simulate) {
    const int n = c.count > 0 ? c.count : 20;
    std::cout << "simulated stylus: " << n << " poses pivoting up to " << c.max_tilt_deg
              << " deg, tip noise 0.1 mm\n";
    return cal::simulate_pivot_poses(s.truth, cal::simulated_pivot_divot_dev(), n,
                                     c.max_tilt_deg * kDeg, sim_noise(), s.rng);
  }
  if (c.poses.empty()) throw BadInput{"pivot: give --poses FILE (stylus poses CSV) or --simulate"};
  std::vector<Eigen::Isometry3d> out;
  for (const auto& r : rows_with(read_poses(c.poses), "pivot")) out.push_back(r.T_dev_sty);
  return out;
}

int step_pivot(Session& s) {
  print_prompt("stylus tip (pivot)",
               "Seat the bur tip in the pivot divot on the bench and rock the stylus slowly in all\n"
               "directions (15-30 degrees), keeping the tip in the divot. Needs >= 10 poses and\n"
               ">= 15 degrees of orientation spread; about 20 poses take 30 s.");
  const auto poses = pivot_data(s);
  cal::PivotOptions live;
  live.min_poses = 3;
  live.min_spread_rad = 0;
  live.min_weakest_tilt_rad = 0;
  std::vector<Eigen::Isometry3d> sofar;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    sofar.push_back(poses[i]);
    std::cout << "  pose " << i + 1;
    if (sofar.size() >= 3) {
      const auto r = cal::calibrate_pivot(sofar, live);
      std::cout << ": spread " << fmt(r.spread_rad / kDeg, 1) << " deg, weakest tilt "
                << fmt(r.weakest_tilt_rad / kDeg, 1) << " deg";
      if (r.ok) std::cout << ", RMSE " << fmt(r.rmse_m * 1e3, 3) << " mm";
    }
    std::cout << "\n";
  }
  const auto r = cal::calibrate_pivot(poses);
  std::cout << r.report() << "\n";
  if (!r.ok) return 1;
  if (s.cli.simulate)
    std::cout << "simulation truth: tip error "
              << fmt((r.p_tip_sty - s.truth.T_sty_tip.translation()).norm() * 1e3, 3) << " mm\n";
  s.st.calibration.T_sty_tip = r.T_sty_tip;
  ar::CalibrationStepReport rep{"pivot", now_iso(), true, "", {}};
  rep.summary = "tip at " + fmt(r.p_tip_sty.norm() * 1e3, 2) + " mm from the stylus origin";
  rep.figures = {{"rmse_mm", r.rmse_m * 1e3},
                 {"tip_sd_mm", std::sqrt(r.cov_tip_sty.trace()) * 1e3},
                 {"spread_deg", r.spread_rad / kDeg},
                 {"poses", r.num_poses}};
  s.st.set_step_report(rep);
  return 0;
}

// Tip positions in the device frame for touches of `points` (truth positions in dev) or the
// rows labelled prefix:<i> of the poses file; index[i] says which fixture was touched.
std::vector<Eigen::Vector3d> touched_tips(Session& s, const std::string& prefix,
                                          const std::vector<Eigen::Vector3d>& truth_dev,
                                          std::vector<int>& index) {
  std::vector<Eigen::Isometry3d> poses;
  index.clear();
  if (s.cli.simulate) {
    poses = cal::simulate_touches(s.truth, truth_dev, sim_noise(), s.rng);
    for (std::size_t i = 0; i < truth_dev.size(); ++i) index.push_back(static_cast<int>(i));
  } else {
    if (s.cli.poses.empty())
      throw BadInput{prefix + ": give --poses FILE (stylus poses CSV) or --simulate"};
    for (const auto& r : rows_with(read_poses(s.cli.poses), prefix + ":")) {
      index.push_back(label_index(r, s.cli.poses, truth_dev.size()));
      poses.push_back(r.T_dev_sty);
    }
  }
  std::vector<Eigen::Vector3d> tips;
  for (const auto& T : poses) tips.push_back((T * s.st.calibration.T_sty_tip).translation());
  return tips;
}

int step_register(Session& s) {
  const auto& divots = s.st.fixtures.divots_man;
  print_prompt("station registration",
               "With the calibrated stylus, touch each of the " + std::to_string(divots.size()) +
                   " divots on the mannequin in the listed order,\nholding the tip still in each "
                   "for a second. Needs >= 6 divots; the TRE at the tooth must be <= 0.5 mm.");
  if (!s.st.step_report("pivot") && !s.cli.simulate)
    std::cout << "note: this station has no pivot calibration on record; the stylus tip from the "
                 "file is used\n";
  std::vector<Eigen::Vector3d> truth_dev;
  for (const auto& p : divots) truth_dev.push_back(s.truth.T_man_dev.inverse() * p);
  if (s.cli.simulate && s.cli.count > 0 && s.cli.count < static_cast<int>(truth_dev.size()))
    truth_dev.resize(s.cli.count);
  std::vector<int> idx;
  const auto tips = touched_tips(s, "divot", truth_dev, idx);
  const Eigen::Vector3d target = s.st.calibration.T_man_tooth * Eigen::Vector3d(0, 0, 4e-3);
  std::vector<Eigen::Vector3d> p_dev, p_man;
  cal::RegistrationOptions live;
  live.min_points = 3;
  live.max_tre_m = 1.0;
  live.min_thickness_m = 0;
  live.thickness_fle_factor = 0;
  live.max_residual_m = 1.0;
  for (std::size_t i = 0; i < tips.size(); ++i) {
    p_dev.push_back(tips[i]);
    p_man.push_back(divots[idx[i]]);
    std::cout << "  divot " << idx[i] << " touched (" << i + 1 << " so far)";
    if (p_dev.size() >= 4) {
      const auto r = cal::register_divots(p_dev, p_man, target, live);
      if (!r.residuals_m.empty())
        std::cout << ": running FRE " << fmt(r.fre_m * 1e3, 3) << " mm, predicted TRE "
                  << fmt(r.tre_m * 1e3, 3) << " mm";
    }
    std::cout << "\n";
  }
  const auto r = cal::register_divots(p_dev, p_man, target);
  std::cout << r.report() << "\n";
  if (!r.ok) return 1;
  if (s.cli.simulate)
    std::cout << "simulation truth: error at the tooth "
              << fmt((r.T_man_dev * (s.truth.T_man_dev.inverse() * target) - target).norm() * 1e3, 3)
              << " mm\n";
  s.st.calibration.T_man_dev = r.T_man_dev;
  ar::CalibrationStepReport rep{"register", now_iso(), true, "", {}};
  rep.summary = std::to_string(r.num_points) + " divots";
  rep.figures = {{"fre_mm", r.fre_m * 1e3}, {"tre_mm", r.tre_m * 1e3}, {"fle_mm", r.fle_m * 1e3},
                 {"divots", r.num_points}};
  // Where the device now stands: can the stylus reach the whole crown? For the profile named by
  // --haptic, else for the common desktop devices (station_health.h, check_station_reach).
  auto box = live::crown_box_tooth(s.st);
  if (!box) throw BadInput{box.error()};
  const haptics::DeviceProfile* chosen = haptics::find_device_profile(s.cli.haptic);
  std::vector<const haptics::DeviceProfile*> profiles;
  if (chosen) profiles.push_back(chosen);
  else
    for (const char* id : {"touch", "omni", "falcon"}) profiles.push_back(haptics::find_device_profile(id));
  std::cout << "stylus reach from the registered device placement"
            << (chosen ? "" : " (no --haptic profile given: the common devices)") << ":\n";
  for (const auto* p : profiles) {
    const live::StationReach reach =
        live::check_station_reach(s.st, haptics::limits_from_profile(*p), p->display_name, *box);
    std::cout << "  " << (reach.reach.reachable ? "OK       " : "WARNING  ") << reach.item.message << "\n";
    if (p == chosen)
      rep.figures.emplace_back("reach_margin_mm", (reach.reach.reach_m - reach.reach.worst_distance_m) * 1e3);
  }
  s.st.set_step_report(rep);
  return 0;
}

int step_tooth(Session& s) {
  const auto& marks = s.st.fixtures.landmarks_tooth;
  print_prompt("tooth placement",
               "Touch each of the " + std::to_string(marks.size()) +
                   " landmarks on the mounted tooth (cusp tips, then the buccal and lingual\n"
                   "cervical points) in the listed order. Needs >= 4 landmarks.");
  // Truth: landmark positions in the device frame.
  std::vector<Eigen::Vector3d> truth_dev;
  for (const auto& l : marks)
    truth_dev.push_back(s.truth.T_man_dev.inverse() * (s.truth.T_man_tooth * l));
  if (s.cli.simulate && s.cli.count > 0 && s.cli.count < static_cast<int>(truth_dev.size()))
    truth_dev.resize(s.cli.count);
  std::vector<int> idx;
  const auto tips = touched_tips(s, "landmark", truth_dev, idx);
  std::vector<Eigen::Vector3d> p_tooth, p_man;
  for (std::size_t i = 0; i < tips.size(); ++i) {
    p_tooth.push_back(marks[idx[i]]);
    p_man.push_back(s.st.calibration.T_man_dev * tips[i]);
    std::cout << "  landmark " << idx[i] << " touched (" << i + 1 << " so far)\n";
  }
  const auto r = cal::refine_tooth_placement(p_tooth, p_man, s.st.calibration.T_man_tooth);
  std::cout << r.report() << "\n";
  if (!r.ok) return 1;
  if (s.cli.simulate) {
    const Eigen::Vector3d q(0, 0, 4e-3);
    std::cout << "simulation truth: crown error "
              << fmt((r.T_man_tooth * q - s.truth.T_man_tooth * q).norm() * 1e3, 3) << " mm\n";
  }
  s.st.calibration.T_man_tooth = r.T_man_tooth;
  ar::CalibrationStepReport rep{"tooth", now_iso(), true, "", {}};
  rep.summary = std::to_string(r.fit.num_points) + " landmarks";
  rep.figures = {{"fre_mm", r.fit.fre_m * 1e3},
                 {"tre_mm", r.fit.tre_m * 1e3},
                 {"shift_mm", r.shift_m * 1e3},
                 {"rotation_deg", r.rotation_rad / kDeg}};
  s.st.set_step_report(rep);
  return 0;
}

int step_mirror(Session& s) {
  print_prompt("mirror",
               "Clamp the mirror where the camera sees both the mannequin's tags and the mirror's\n"
               "tag. With the stylus touch >= 5 points spread around the rim of the reflecting\n"
               "face, then its centre.");
  std::vector<Eigen::Vector3d> rim;
  Eigen::Vector3d centre = Eigen::Vector3d::Constant(NAN);
  const auto& cal_now = s.st.calibration;
  auto to_mtag = [&](const Eigen::Isometry3d& T_dev_sty,
                     const Eigen::Isometry3d& T_mtag_man) -> Eigen::Vector3d {
    return (T_mtag_man * cal_now.T_man_dev * T_dev_sty * cal_now.T_sty_tip).translation();
  };
  if (s.cli.simulate) {
    const int n = s.cli.count > 0 ? s.cli.count : 8;
    const Eigen::Isometry3d T_man_mtag = cal::simulated_mirror_clamp_man();
    std::vector<Eigen::Vector3d> pts_dev;
    for (int i = 0; i < n; ++i) {
      const double a = 2 * M_PI * i / n;
      const Eigen::Vector3d p_mir(s.truth.mirror_radius_m * std::cos(a),
                                  s.truth.mirror_radius_m * std::sin(a), 0);
      pts_dev.push_back(s.truth.T_man_dev.inverse() * (T_man_mtag * (s.truth.T_mtag_mir * p_mir)));
    }
    pts_dev.push_back(s.truth.T_man_dev.inverse() * (T_man_mtag * s.truth.T_mtag_mir.translation()));
    const auto poses = cal::simulate_touches(s.truth, pts_dev, sim_noise(), s.rng);
    const auto noise = sim_noise();
    for (std::size_t i = 0; i < poses.size(); ++i) {
      // The tracked mirror-to-mannequin pose of that moment (two tag bundles: sqrt(2) x noise).
      const Eigen::Isometry3d T_mtag_man_meas =
          (T_man_mtag * cal::random_perturbation(noise.tracking_sigma_rad * std::sqrt(2.0),
                                                 noise.tracking_sigma_m * std::sqrt(2.0), s.rng))
              .inverse();
      const Eigen::Vector3d p = to_mtag(poses[i], T_mtag_man_meas);
      if (i + 1 < poses.size()) {
        rim.push_back(p);
        std::cout << "  rim point " << rim.size() << "\n";
      } else {
        centre = p;
        std::cout << "  centre\n";
      }
    }
  } else {
    if (s.cli.poses.empty()) throw BadInput{"mirror: give --poses FILE (stylus poses CSV) or --simulate"};
    for (const auto& r : read_poses(s.cli.poses)) {
      if (r.label != "rim" && r.label != "centre") continue;
      if (!r.T_mtag_man)
        throw BadInput{s.cli.poses + ":" + std::to_string(r.line) +
                       ": mirror rows need the 6 mtag_* columns (T_mtag_man from the tracker)"};
      const Eigen::Vector3d p = to_mtag(r.T_dev_sty, *r.T_mtag_man);
      if (r.label == "rim") {
        rim.push_back(p);
        std::cout << "  rim point " << rim.size() << "\n";
      } else {
        centre = p;
        std::cout << "  centre\n";
      }
    }
    if (!centre.allFinite()) throw BadInput{s.cli.poses + ": no row labelled centre"};
  }
  const auto r = cal::calibrate_mirror(rim, centre, cal_now.T_mtag_mir);
  std::cout << r.report() << "\n";
  if (!r.ok) return 1;
  if (s.cli.simulate)
    std::cout << "simulation truth: centre error "
              << fmt((r.T_mtag_mir.translation() - s.truth.T_mtag_mir.translation()).norm() * 1e3, 3)
              << " mm, radius error " << fmt((r.radius_m - s.truth.mirror_radius_m) * 1e3, 3) << " mm\n";
  s.st.calibration.T_mtag_mir = r.T_mtag_mir;
  s.st.calibration.mirror_radius_m = r.radius_m;
  ar::CalibrationStepReport rep{"mirror", now_iso(), true, "", {}};
  rep.summary = "radius " + fmt(r.radius_m * 1e3) + " mm";
  rep.figures = {{"radius_mm", r.radius_m * 1e3},
                 {"plane_rms_mm", r.plane_rms_m * 1e3},
                 {"circle_rms_mm", r.circle_rms_m * 1e3},
                 {"centre_error_mm", r.centre_error_m * 1e3}};
  s.st.set_step_report(rep);
  return 0;
}

int step_check(Session& s) {
  print_prompt("end-to-end check",
               "Work at the tooth for a few seconds while the camera tracks the mannequin: the\n"
               "bur tip the calibrated chain draws is compared with the true tip. Goal: mean\n"
               "error <= 0.5 mm.");
  if (!s.cli.simulate)
    throw BadInput{"check: only --simulate is built so far (the generator's scene has the true "
                   "tip; a live check needs a touch-probe fixture, not built yet)"};
  ar::StationScene truth_scene = ar::default_station_scene();
  truth_scene.calibration = s.truth;
  auto ctx = ar::EglContext::create();
  if (!ctx) throw BadInput{"check: no headless EGL context: " + ctx.error()};
  ar::SynthOptions so = ar::synth_preset(ar::SynthPreset::kStandard);
  so.frames = s.cli.check_frames;
  so.seed = s.cli.seed;
  so.mirror_in_mouth_fraction = 0;
  auto gen = ar::SynthGenerator::create(truth_scene, so);
  if (!gen) throw BadInput{"check: " + gen.error()};
  ar::TagDetectorOptions dopt;
  dopt.response = ar::CameraResponse::kSrgb;  // the generator encodes sRGB, as the tracker assumes
  dopt.families = {s.st.family};
  dopt.decimation = 1.0;
  auto det = ar::TagDetector::create(dopt);
  if (!det) throw BadInput{"check: " + det.error()};
  const ar::TagBundle bundle = ar::mannequin_bundle(s.st);
  const cal::StationCalibration nominal = ar::default_station_scene().calibration;
  std::vector<double> err, err_nom, err_static;
  // What the eye sees: the drawn tip (the chain through the calibrated camera) against the real
  // tip in the image (the true camera), px, and that distance in mm at the tip's depth. A
  // calibrated camera turned slightly against the true one (a principal point shifted to absorb
  // tangential terms) turns the tracked poses with it: the camera-frame error grows, the image
  // does not.
  std::vector<double> err_img_px, err_img_mm;
  // The camera-frame error broken down by putting the truth in place of one part at a time
  // (issue 24): tracking alone (the true camera and the true station: detector noise and the
  // bundle fit), + the camera calibration (the calibrated camera, the true station), + the
  // station calibration (both calibrated: the total above).
  std::vector<double> err_track, err_track_cam, err_track_station;
  // Timing (issue 24): the image shows the stylus at its exposure, but the frame reaches the
  // frame path the camera's latency later (exposure -> readout -> USB -> grab). Drawn with the
  // newest haptic pose (the live path before session 12), the bur leads the real handpiece by
  // the stylus's motion over that latency. Simulated here with the generator's own 1 kHz haptic
  // engine: each frame is grabbed --latency-ms (+ a per-frame jitter, --latency-jitter-ms, 1 σ)
  // after its exposure; uncompensated = the pose at the grab, compensated = the engine's pose
  // history sampled at the grab minus the station's camera latency (camera.latency_ms, or the
  // assumed 33 ms), as dentar live now draws it.
  struct FrameKeep {
    double t = 0, t_grab = 0;
    Eigen::Isometry3d T_dev_sty, T_cam_man_true, T_cam_man_cal;
    Eigen::Vector3d tip_true_cam;
    bool tracked = false, timed = false;
  };
  std::vector<FrameKeep> keep;
  const double lat = s.cli.latency_ms * 1e-3;
  const bool lat_known = s.st.camera_provenance.latency_ms >= 0;
  const double lat_est =
      (lat_known ? s.st.camera_provenance.latency_ms : ar::kAssumedCameraLatency_ms) * 1e-3;
  std::mt19937_64 lat_rng(s.cli.seed * 2654435761ULL + 24);
  std::normal_distribution<double> lat_jitter(0.0, s.cli.latency_jitter_ms * 1e-3);
  std::vector<double> err_timing, err_total_timing, err_timing_comp, err_total_comp, tip_speed;
  int comp_not_usable = 0;
  const haptics::PoseHistory& history = (*gen)->haptic_history();
  // Frames whose grab time the generator's haptic clock has passed get both poses.
  auto time_frames = [&] {
    const double newest = history.latest().t1_s;
    for (auto& k : keep) {
      if (k.timed || !k.tracked || lat <= 0 || k.t_grab > newest) continue;
      k.timed = true;
      const auto at_grab = history.sample(k.t_grab);
      const auto at_exposure = history.sample(k.t_grab - lat_est);
      if (!at_grab.usable()) continue;
      if (!at_exposure.usable()) {  // the clip's first frames: no pose before the engine's first step
        ++comp_not_usable;
        continue;
      }
      // Both over the same frames.
      err_timing.push_back((cal::chain_tip_cam(k.T_cam_man_true, s.truth, at_grab.T_dev_sty) - k.tip_true_cam).norm());
      err_total_timing.push_back(
          (cal::chain_tip_cam(k.T_cam_man_cal, s.st.calibration, at_grab.T_dev_sty) - k.tip_true_cam).norm());
      err_timing_comp.push_back(
          (cal::chain_tip_cam(k.T_cam_man_true, s.truth, at_exposure.T_dev_sty) - k.tip_true_cam).norm());
      err_total_comp.push_back(
          (cal::chain_tip_cam(k.T_cam_man_cal, s.st.calibration, at_exposure.T_dev_sty) - k.tip_true_cam).norm());
    }
  };
  for (int f = 0; f < so.frames; ++f) {
    ar::SynthFrame fr;
    if (Status st = (*gen)->next(fr); !st) throw BadInput{"check: " + st.error()};
    time_frames();
    cv::Mat gray;
    cv::cvtColor(fr.image, gray, cv::COLOR_BGR2GRAY);
    auto d = det->detect(gray);
    if (!d) continue;
    const auto pose = ar::estimate_bundle_pose(bundle, s.st.calibration.camera, *d);
    const auto pose_nom = ar::estimate_bundle_pose(bundle, nominal.camera, *d);
    const Eigen::Vector3d tip_true = fr.truth.T_cam_tip.translation();
    keep.push_back({fr.truth.time_s, fr.truth.time_s + std::max(0.0, lat + lat_jitter(lat_rng)), fr.truth.T_dev_sty,
                    fr.truth.T_cam_man, pose.T_cam_body, tip_true, pose.ok(), false});
    std::cout << "  frame " << f;
    if (pose.ok()) {
      const Eigen::Vector3d tip_drawn = cal::chain_tip_cam(pose.T_cam_body, s.st.calibration, fr.truth.T_dev_sty);
      err.push_back((tip_drawn - tip_true).norm());
      err_track_cam.push_back((cal::chain_tip_cam(pose.T_cam_body, s.truth, fr.truth.T_dev_sty) - tip_true).norm());
      const auto pose_true_cam = ar::estimate_bundle_pose(bundle, s.truth.camera, *d);
      if (pose_true_cam.ok()) {
        err_track.push_back((cal::chain_tip_cam(pose_true_cam.T_cam_body, s.truth, fr.truth.T_dev_sty) - tip_true).norm());
        // The other order (session 12): the true camera with the calibrated station.
        err_track_station.push_back(
            (cal::chain_tip_cam(pose_true_cam.T_cam_body, s.st.calibration, fr.truth.T_dev_sty) - tip_true).norm());
      }
      Eigen::Vector2d px_drawn, px_true;
      if (cal::project_point(s.st.calibration.camera, tip_drawn, px_drawn) && cal::project_point(s.truth.camera, tip_true, px_true)) {
        err_img_px.push_back((px_drawn - px_true).norm());
        err_img_mm.push_back(err_img_px.back() * tip_true.z() / s.truth.camera.fx);
      }
      // Bur tip relative to the drawn tooth (tracking-free part of the chain).
      const auto& c = s.st.calibration;
      const Eigen::Vector3d a = (c.T_man_tooth.inverse() * c.T_man_dev * fr.truth.T_dev_sty * c.T_sty_tip).translation();
      const Eigen::Vector3d b = (s.truth.T_man_tooth.inverse() * s.truth.T_man_dev * fr.truth.T_dev_sty *
                                 s.truth.T_sty_tip).translation();
      err_static.push_back((a - b).norm());
      std::cout << ": " << pose.tags_used << " tags, bur tip error " << fmt(err.back() * 1e3, 3) << " mm";
    } else {
      std::cout << ": mannequin not tracked (" << pose.message << ")";
    }
    if (pose_nom.ok())
      err_nom.push_back((cal::chain_tip_cam(pose_nom.T_cam_body, nominal, fr.truth.T_dev_sty) - tip_true).norm());
    std::cout << "\n" << std::flush;
  }
  auto mean = [](const std::vector<double>& v) {
    double m = 0;
    for (double x : v) m += x;
    return v.empty() ? NAN : m / v.size();
  };
  auto maxv = [](const std::vector<double>& v) { return v.empty() ? NAN : *std::max_element(v.begin(), v.end()); };
  if (err.size() < static_cast<std::size_t>(std::max(3, so.frames / 2))) {
    std::cout << "check FAILED: the mannequin was tracked in only " << err.size() << " of "
              << so.frames << " frames; check the camera calibration and tag layout\n";
    return 1;
  }
  // The timing term (frames grabbed after the clip's last haptic step are left out of both);
  // the stylus tip's speed between frames.
  time_frames();
  for (std::size_t i = 0; i + 1 < keep.size(); ++i) {
    const double dt = keep[i + 1].t - keep[i].t;
    const auto tip_man = [&](const FrameKeep& k) -> Eigen::Vector3d {
      return (s.truth.T_man_dev * k.T_dev_sty * s.truth.T_sty_tip).translation();
    };
    if (dt > 0) tip_speed.push_back((tip_man(keep[i + 1]) - tip_man(keep[i])).norm() / dt);
  }
  const double m = mean(err), mx = maxv(err);
  std::cout << "co-location at the tooth over " << err.size() << " frames: bur tip error mean "
            << fmt(m * 1e3, 3) << " mm, max " << fmt(mx * 1e3, 3) << " mm (goal: mean <= 0.5 mm)\n"
            << "  of which the static chain (tooth vs bur, no tracking): mean "
            << fmt(mean(err_static) * 1e3, 3) << " mm\n"
            << "  in the image (drawn tip vs the real tip as the true camera sees it): mean "
            << fmt(mean(err_img_px), 2) << " px = " << fmt(mean(err_img_mm) * 1e3, 3) << " mm at the tip's depth, max "
            << fmt(maxv(err_img_mm) * 1e3, 3) << " mm\n"
            << "  uncalibrated (nominal station file values): mean " << fmt(mean(err_nom) * 1e3, 2)
            << " mm\n"
            << "  breakdown (camera frame, the truth put in place of the rest): tracking alone (true camera, "
               "true station) mean "
            << fmt(mean(err_track) * 1e3, 3) << " mm; + camera calibration (calibrated camera, true station) "
            << fmt(mean(err_track_cam) * 1e3, 3) << " mm; + station calibration (pivot, register, tooth) = the "
               "total " << fmt(m * 1e3, 3) << " mm; the other order: + station calibration alone (true camera, "
               "calibrated station) " << fmt(mean(err_track_station) * 1e3, 3) << " mm. Hand-eye is not in this "
               "chain (the camera is tracked against the mannequin directly)\n";
  if (lat > 0 && !err_timing.empty()) {
    std::cout << "  timing (each frame grabbed " << fmt(s.cli.latency_ms, 0) << " ms +- "
              << fmt(s.cli.latency_jitter_ms, 1) << " ms (1 sigma) after its exposure; --latency-ms, "
              << "--latency-jitter-ms): uncompensated (the haptic pose at the grab drawn on it): timing alone mean "
              << fmt(mean(err_timing) * 1e3, 3) << " mm; the total with timing " << fmt(mean(err_total_timing) * 1e3, 3)
              << " mm over " << err_timing.size() << " frames; the stylus tip moved at " << fmt(mean(tip_speed) * 1e3, 1)
              << " mm/s mean, " << fmt(maxv(tip_speed) * 1e3, 1) << " max (at 50 mm/s, " << fmt(s.cli.latency_ms, 0)
              << " ms is " << fmt(50 * s.cli.latency_ms * 1e-3, 2) << " mm)\n";
    std::cout << "  compensated (the 1 kHz pose history sampled at the grab minus the station's camera latency, "
              << fmt(lat_est * 1e3, 1) << " ms, "
              << (lat_known ? "measured (camera.latency_ms)" : "assumed: not measured for this station")
              << "): timing alone mean " << fmt(mean(err_timing_comp) * 1e3, 3) << " mm; the total with timing "
              << fmt(mean(err_total_comp) * 1e3, 3) << " mm over " << err_timing_comp.size() << " frames";
    if (comp_not_usable > 0)
      std::cout << " (" << comp_not_usable << " frames left out of both: no pose at their exposure, before the "
                << "engine's first step)";
    std::cout << "\n";
  } else
    std::cout << "  timing: not simulated (--latency-ms 0: the haptic pose drawn is the one of the frame's exposure)\n";
  const double threshold = s.st.policy.check_threshold_m;
  const bool pass = m <= threshold;
  std::cout << (pass ? "check PASSED" : "check FAILED") << " against this station's threshold: mean "
            << fmt(m * 1e3, 3) << " mm " << (pass ? "<=" : ">") << " " << fmt(threshold * 1e3, 2)
            << " mm (station_policy.check_threshold_mm); the date and the result go into the station file\n";
  ar::CalibrationStepReport rep{"check", now_iso(), pass, "", {}};
  rep.summary = "simulated end-to-end co-location, " + std::to_string(err.size()) + " frames";
  rep.figures = {{"tip_error_mean_mm", m * 1e3},
                 {"tip_error_max_mm", mx * 1e3},
                 {"static_error_mean_mm", mean(err_static) * 1e3},
                 {"image_error_mean_px", mean(err_img_px)},
                 {"image_error_mean_mm", mean(err_img_mm) * 1e3},
                 {"uncalibrated_mean_mm", mean(err_nom) * 1e3},
                 {"tracking_only_mean_mm", mean(err_track) * 1e3},
                 {"tracking_camera_mean_mm", mean(err_track_cam) * 1e3},
                 {"tracking_station_mean_mm", mean(err_track_station) * 1e3},
                 {"latency_ms", s.cli.latency_ms},
                 {"tip_speed_mean_mm_s", mean(tip_speed) * 1e3},
                 {"frames", static_cast<double>(err.size())},
                 {"threshold_mm", threshold * 1e3}};
  if (!err_timing.empty()) {
    rep.figures.push_back({"timing_only_mean_mm", mean(err_timing) * 1e3});
    rep.figures.push_back({"total_with_timing_mean_mm", mean(err_total_timing) * 1e3});
    rep.figures.push_back({"latency_jitter_ms", s.cli.latency_jitter_ms});
    rep.figures.push_back({"compensation_latency_ms", lat_est * 1e3});
  }
  if (!err_timing_comp.empty()) {
    rep.figures.push_back({"timing_compensated_mean_mm", mean(err_timing_comp) * 1e3});
    rep.figures.push_back({"total_compensated_mean_mm", mean(err_total_comp) * 1e3});
  }
  s.st.set_step_report(rep);
  if (!pass) {
    std::cout << "check FAILED: mean error above the threshold; repeat the steps with the worst "
                 "figures. The failed check is recorded: dentar live will ask for an instructor.\n";
    s.record_failure = true;
    return 1;
  }
  return 0;
}

// Hand-eye: the camera on the HMD (or a tracked frame). --simulate: generated motions of the
// body with large rotations (the case where OpenCV 4.6's TSAI and DANIILIDIS fail).
int step_hand_eye(Session& s) {
  print_prompt("hand-eye (camera on the " + s.cli.hand + ")",
               "Keep the board (or the mannequin) still. Turn the head about at least two different\n"
               "axes (left-right AND up-down or tilt) while both the " + s.cli.hand +
                   " tracker and the camera see\ntheir targets; about 12 poses.");
  if (!s.cli.simulate)
    throw BadInput{"hand_eye: only --simulate is built so far (the live route needs the headset's own "
                   "tracker, which no DentAR station has yet)"};
  const int n = s.cli.count > 0 ? s.cli.count : 12;
  const Eigen::Isometry3d T_hand_cam_true =
      Eigen::Translation3d(0.012, -0.035, 0.07) * Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 1, 0.1).normalized());
  const Eigen::Isometry3d T_base_target = Eigen::Translation3d(0.1, -0.3, 0.5) * Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitX());
  const auto obs = cal::simulate_hand_eye(T_hand_cam_true, T_base_target, n, s.cli.he_spread_deg * kDeg, 1e-3, 0.5e-3, s.rng);
  std::cout << "simulated " << n << " pose pairs, rotations spread up to " << fmt(s.cli.he_spread_deg, 0)
            << " deg, noise 0.06 deg / 0.5 mm\n";
  const cal::HandEyeResult r = cal::calibrate_hand_eye(obs);
  std::cout << r.report() << "\n";
  for (cal::HandEyeMethod m : {cal::HandEyeMethod::kTsai, cal::HandEyeMethod::kPark, cal::HandEyeMethod::kHoraud,
                               cal::HandEyeMethod::kAndreff, cal::HandEyeMethod::kDaniilidis}) {
    const cal::HandEyeResult o = cal::calibrate_hand_eye_opencv(obs, m);
    std::cout << "  for comparison, OpenCV " << cal::hand_eye_method_name(m) << ": "
              << (o.ok ? "error " + fmt(cal::rotation_error_rad(o.T_hand_cam, T_hand_cam_true) / kDeg, 2) + " deg, " +
                             fmt(cal::translation_error_m(o.T_hand_cam, T_hand_cam_true) * 1e3, 2) + " mm"
                       : "failed: " + o.message);
    for (const auto& w : o.warnings) std::cout << " (" << w << ")";
    std::cout << "\n";
  }
  if (!r.ok) return 1;
  std::cout << "simulation truth: error " << fmt(cal::rotation_error_rad(r.T_hand_cam, T_hand_cam_true) / kDeg, 3)
            << " deg, " << fmt(cal::translation_error_m(r.T_hand_cam, T_hand_cam_true) * 1e3, 3) << " mm\n";
  ar::HandEyeRecord& h = s.st.hand_eye;
  h.present = true;
  h.T_hand_cam = r.T_hand_cam;
  h.hand = s.cli.hand;
  h.method = cal::hand_eye_method_name(r.method);
  h.rot_sd_rad = r.rot_sd_rad;
  h.trans_sd_m = r.trans_sd_m;
  h.rms_rot_rad = r.rms_rot_rad;
  h.rms_m = r.rms_m;
  h.observations = static_cast<int>(obs.size());
  h.date = now_iso();
  ar::CalibrationStepReport rep{"hand_eye", h.date, true, "camera on the " + h.hand + ", " + std::to_string(n) + " poses", {}};
  rep.figures = {{"rotation_sd_deg", r.rot_sd_rad / kDeg},
                 {"translation_sd_mm", r.trans_sd_m * 1e3},
                 {"rms_rotation_deg", r.rms_rot_rad / kDeg},
                 {"rms_mm", r.rms_m * 1e3},
                 {"spread_deg", r.rotation_spread_rad / kDeg},
                 {"poses", static_cast<double>(n)}};
  s.st.set_step_report(rep);
  return 0;
}

void print_instructor_time() {
  std::cout
      << "\nInstructor time (estimated from the data each step needs and a time per action;\n"
         "not yet measured with instructors):\n"
         "  step      data needed                               estimate\n"
         "  camera    12 board photos (>= 6 usable)             12 x 10 s + 60 s setup = 3.0 min\n"
         "  pivot     20 stylus poses in the pivot divot        20 x 1.5 s + 30 s      = 1.0 min\n"
         "  register  8 divot touches                           8 x 8 s + 20 s         = 1.4 min\n"
         "  tooth     6 landmark touches                        6 x 8 s + 20 s         = 1.1 min\n"
         "  mirror    8 rim points + 1 centre, mirror clamped   9 x 8 s + 60 s         = 2.2 min\n"
         "  check     a few seconds of work at the tooth        30 s                   = 0.5 min\n"
         "  total     6 steps, 55 recorded items                                       = 9.2 min\n"
         "  (goal <= 10 min; the computation of each step takes well under a second except\n"
         "   the camera step's detection, about 0.5 s per photo)\n"
         "Measured with `dentar calibrate live --haptic sim` at human pace (the simulated\n"
         "instructor, tools/bench_calibrate_live.sh): about 3.5 min for the six steps\n"
         "(docs/BENCHMARKS.md, \"the whole station live\"); plan with the estimate.\n";
}

// ---- stereo (issue 28) -------------------------------------------------------------------------
// Board photos of a stereo head: --left DIR --right DIR (photo i of each folder, in name order, is
// one capture) or --images DIR of side-by-side photos (left | right, even width). Writes the left
// eye as the station's camera and the rig (right eye, T_left_right) as its "stereo" block.
std::vector<fs::path> image_files(const std::string& dir, const std::string& what) {
  if (dir.empty()) throw BadInput{"stereo: " + what + " folder not given"};
  if (!fs::is_directory(dir)) throw BadInput{dir + ": no such folder (" + what + " photos)"};
  const std::vector<fs::path> files = board_photo_files(dir);
  if (files.empty()) throw BadInput{dir + ": no .png/.jpg/.bmp/.tif images in it (" + what + " photos)"};
  return files;
}

// A live stereo head (issue 28): live::capture_stereo_live (live/calibrate_app.h) takes the
// captures by themselves; the test hooks' "AFTER_FRAMES:SECONDS" (an eye goes quiet) parsed here.
ar::CaptureThreadOptions stall_hook(const std::string& hook, const char* flag) {
  ar::CaptureThreadOptions o;
  if (hook.empty()) return o;
  const auto k = hook.find(':');
  try {
    if (k == std::string::npos) throw std::invalid_argument("no colon");
    o.stall_after_frames = std::stoll(hook.substr(0, k));
    o.stall_s = std::stod(hook.substr(k + 1));
  } catch (const std::exception&) {
    throw BadInput{std::string(flag) + " " + hook + ": give AFTER_FRAMES:SECONDS"};
  }
  if (o.stall_after_frames < 1 || !(o.stall_s > 0)) throw BadInput{std::string(flag) + " " + hook + ": both must be > 0"};
  return o;
}

int step_stereo(Session& s) {
  const CalibCli& c = s.cli;
  print_prompt("stereo head",
               "Hold the printed board where BOTH cameras see it and take about 15 captures (both eyes\n"
               "at once): tilted 15-45 degrees, near the edges and in the middle. The cameras must not\n"
               "move against each other between captures.");
  auto spec = ar::parse_board_spec(c.board);
  if (!spec) throw BadInput{spec.error()};
  std::vector<cal::BoardView> left, right;
  int width = 0, height = 0;
  std::string stall;  // --live: an eye stopped delivering (which, how long, what to do)
  auto check_size = [&](const fs::path& f, int w, int h) {
    if (width == 0) {
      width = w;
      height = h;
    } else if (w != width || h != height) {
      throw BadInput{f.string() + ": eye image is " + std::to_string(w) + "x" + std::to_string(h) + ", the others " +
                     std::to_string(width) + "x" + std::to_string(height) + "; both eyes, all photos, one camera mode"};
    }
  };
  auto add = [&](std::vector<cal::BoardView>& eye, Result<cal::BoardView> v, const std::string& name, const char* side) {
    if (v) {
      v->name = name;
      eye.push_back(*v);
      std::cout << "  " << side << " " << name << ": " << v->image_points.size() << " points\n";
    } else {
      eye.push_back(cal::BoardView{name, {}, {}});
      std::cout << "  " << side << " " << name << ": board not found\n";
    }
  };
  // --simulate: the hidden truth is the simulated station camera as the left eye, a right eye
  // with its own lens 63 mm to its right, turned by up to 1 degree (seeded); the board renderer
  // stands in for both cameras.
  std::optional<ar::StereoRig> truth;
  if (c.simulate) {
    const cal::CameraIntrinsics& kl = s.truth.camera;
    std::mt19937_64 rng(c.seed * 7 + 5);
    std::uniform_real_distribution<double> u(-1, 1);
    cal::CameraIntrinsics kr = kl;
    kr.fx *= 1 + 0.01 * u(rng);
    kr.fy = kr.fx * kl.fy / kl.fx;
    kr.cx += 4 * u(rng);
    kr.cy += 4 * u(rng);
    ar::StereoRig rig = ar::make_stereo_rig(kl, 0.063, kr);
    rig.T_caml_camr.linear() = (Eigen::AngleAxisd(kDeg * u(rng), Eigen::Vector3d::UnitY()) *
                                Eigen::AngleAxisd(0.5 * kDeg * u(rng), Eigen::Vector3d::UnitX()))
                                   .toRotationMatrix();
    rig.T_caml_camr.translation() += Eigen::Vector3d(0, 0.5e-3 * u(rng), 0.5e-3 * u(rng));
    truth = rig;
    width = kl.width;
    height = kl.height;
    const int n = c.count > 0 ? c.count : 15;
    std::cout << "simulated stereo head: rendering " << n << " captures of " << c.board << " for both eyes\n";
    const ar::BoardTexture tex = ar::make_board_texture(*spec);
    const auto poses = cal::plan_board_poses(kl, ar::board_width_m(*spec), ar::board_height_m(*spec), n, c.seed);
    for (int i = 0; i < n; ++i) {
      ar::BoardRenderOptions ro;
      ro.supersample = 2;
      ro.seed = c.seed * 1000 + i;
      const std::string name = "sim-capture-" + std::to_string(i);
      add(left, ar::detect_board(ar::render_board_view(tex, kl, poses[i], ro), *spec, name), name, "left ");
      ro.seed += 500;
      add(right, ar::detect_board(ar::render_board_view(tex, kr, rig.T_caml_camr.inverse() * poses[i], ro), *spec, name),
          name, "right");
    }
  } else if (c.stereo_live || !c.side_by_side.empty() || live::is_live_camera_spec(c.left_dir) ||
             live::is_live_camera_spec(c.right_dir)) {
    live::StereoLiveOptions lo;
    lo.left = c.left_dir;
    lo.right = c.right_dir;
    lo.side_by_side = c.side_by_side;
    lo.board = c.board;
    lo.count = c.count > 0 ? c.count : 15;
    lo.seconds = c.seconds;
    lo.stall_timeout_s = c.stall_timeout_s;
    lo.left_capture = stall_hook(c.stall_left, "--inject-stall-left");
    lo.right_capture = stall_hook(c.stall_right, "--inject-stall-right");
    lo.say = [](const std::string& line) { std::cout << line << "\n"; };
    auto cap = live::capture_stereo_live(lo);
    if (!cap) throw BadInput{"stereo --live: " + cap.error()};
    left = std::move(cap->left);
    right = std::move(cap->right);
    width = cap->width;
    height = cap->height;
    // An eye that stopped delivering ends the capture; the captures taken before it are kept and
    // calibrated (as after --seconds): the rig is written when they pass the gates, and the
    // device's fault is exit 2 with nothing written when they do not.
    if (!cap->stall.empty()) {
      stall = cap->stall;
      std::cout << "stereo --live: " << stall << "\nthe " << left.size()
                << " captures taken before it are kept and calibrated below\n";
    }
  } else if (!c.left_dir.empty() || !c.right_dir.empty()) {
    const auto lf = image_files(c.left_dir, "--left (left eye)");
    const auto rf = image_files(c.right_dir, "--right (right eye)");
    if (lf.size() != rf.size())
      throw BadInput{"stereo: " + c.left_dir + " has " + std::to_string(lf.size()) + " photos but " + c.right_dir +
                     " has " + std::to_string(rf.size()) + "; photo i of each folder (in name order) must be one "
                     "capture of both eyes"};
    for (std::size_t i = 0; i < lf.size(); ++i) {
      int w = 0, h = 0;
      auto vl = ar::detect_board_file(lf[i].string(), *spec, w, h);
      if (w > 0) check_size(lf[i], w, h);
      add(left, vl, lf[i].filename().string(), "left ");
      auto vr = ar::detect_board_file(rf[i].string(), *spec, w, h);
      if (w > 0) check_size(rf[i], w, h);
      add(right, vr, rf[i].filename().string(), "right");
    }
  } else {
    if (c.images.empty())
      throw BadInput{"stereo: give --left DIR --right DIR (one folder per eye), --images DIR (side-by-side photos) "
                     "or --simulate"};
    for (const auto& f : image_files(c.images, "--images (side-by-side)")) {
      const cv::Mat img = cv::imread(f.string(), cv::IMREAD_GRAYSCALE);
      if (img.empty()) throw BadInput{f.string() + ": cannot be decoded as an image"};
      if (img.cols % 2 != 0)
        throw BadInput{f.string() + ": a side-by-side photo must have an even width (left eye | right eye); it is " +
                       std::to_string(img.cols) + "x" + std::to_string(img.rows) +
                       ". One folder per eye? Use --left and --right"};
      check_size(f, img.cols / 2, img.rows);
      const std::string name = f.filename().string();
      add(left, ar::detect_board(img(cv::Rect(0, 0, width, height)).clone(), *spec, name), name, "left ");
      add(right, ar::detect_board(img(cv::Rect(width, 0, width, height)).clone(), *spec, name), name, "right");
    }
  }
  if (width == 0) throw BadInput{"stereo: no photo could be read"};
  cal::StereoCalibrationOptions so;
  so.seed = c.seed;
  if (c.model == "k1") so.model.force = cal::DistortionModel::kK1;
  else if (c.model == "k1k2") so.model.force = cal::DistortionModel::kK1K2;
  else if (c.model == "radtan5") so.model.force = cal::DistortionModel::kRadTan5;
  else if (c.model == "rational8" || c.rational) so.model.force = cal::DistortionModel::kRational8;
  std::cout << "choosing each eye's distortion model on held-out views, then the extrinsics (their 1-sigma "
               "by leaving each capture out once)...\n";
  const cal::StereoCalibration r = cal::calibrate_stereo(left, right, width, height, so);
  std::cout << r.report();
  if (truth && r.ok) {
    const Eigen::Vector3d dt = (r.T_caml_camr.translation() - truth->T_caml_camr.translation()) * 1e3;
    const Eigen::AngleAxisd dr(truth->T_caml_camr.linear().transpose() * r.T_caml_camr.linear());
    std::cout << "simulation truth: baseline " << fmt(truth->baseline_m() * 1e3, 3) << " mm; error t ("
              << fmt(dt.x(), 3) << ", " << fmt(dt.y(), 3) << ", " << fmt(dt.z(), 3) << ") mm, rotation "
              << fmt(dr.angle() / kDeg, 3) << " deg, baseline "
              << fmt((r.baseline_m() - truth->baseline_m()) * 1e3, 3) << " mm ("
              << fmt(std::abs(r.baseline_m() - truth->baseline_m()) / std::max(1e-12, r.sigma_baseline_m), 1)
              << " sigma)\n";
  }
  if (!r.ok && !stall.empty())
    throw BadInput{"stereo --live: " + stall + "; the " + std::to_string(left.size()) +
                   " captures taken before it do not give the rig (" + r.message + ")"};
  if (!r.ok) return 1;
  if (!stall.empty()) std::cout << "calibrated from the " << left.size() << " captures taken before the eye stopped\n";
  ar::StereoRig rig;
  rig.present = true;
  rig.camera_right = r.camera_right;
  rig.T_caml_camr = r.T_caml_camr;
  if (std::string e = rig.validate(r.camera_left); !e.empty()) {
    std::cout << "the calibrated rig is not a usable stereo head: " << e << "\n";
    return 1;
  }
  s.st.calibration.camera = r.camera_left;
  s.st.stereo = rig;
  const std::string keep_id = s.st.camera_provenance.device_id;
  s.st.camera_provenance = ar::CameraProvenance{};
  s.st.camera_provenance.model = r.left.chosen.model;
  s.st.camera_provenance.rms_px = r.rms_px;
  s.st.camera_provenance.device = c.device + " (left eye of a stereo head)";
  s.st.camera_provenance.date = now_iso();
  s.st.camera_provenance.device_id = keep_id;
  ar::CalibrationStepReport rep{"stereo", now_iso(), true, r.message, {}};
  rep.figures = {{"baseline_mm", r.baseline_m() * 1e3},
                 {"baseline_sd_mm", r.sigma_baseline_m * 1e3},
                 {"tx_sd_mm", r.sigma_t_m.x() * 1e3},
                 {"ty_sd_mm", r.sigma_t_m.y() * 1e3},
                 {"tz_sd_mm", r.sigma_t_m.z() * 1e3},
                 {"rx_sd_deg", r.sigma_r_rad.x() / kDeg},
                 {"ry_sd_deg", r.sigma_r_rad.y() / kDeg},
                 {"rz_sd_deg", r.sigma_r_rad.z() / kDeg},
                 {"rotation_scatter_deg", r.rotation_scatter_rad / kDeg},
                 {"translation_scatter_mm", r.translation_scatter_m * 1e3},
                 {"rms_px", r.rms_px},
                 {"views", static_cast<double>(r.views.size())},
                 {"left_trusted_image_pct", r.left.trust.trusted_fraction * 100},
                 {"right_trusted_image_pct", r.right.trust.trusted_fraction * 100}};
  s.st.set_step_report(rep);
  return 0;
}

int run(const CalibCli& c) {
  if (c.instructor_time && c.step.empty()) {
    print_instructor_time();
    return 0;
  }
  static const std::vector<std::string> kSteps = {"camera", "pivot", "register", "tooth", "mirror", "check"};
  if (c.step == "live") {
    live::CalibrateLiveOptions lo;
    lo.station = c.station;
    lo.camera = c.camera;
    lo.device = c.haptic;
    lo.device_name = c.haptic_name;
    lo.pedal = c.pedal;
    lo.steps.clear();
    std::stringstream ss(!c.live_steps.empty() ? c.live_steps
                         : c.camera.empty() ? "pivot,register,tooth,mirror,check"
                                            : "camera,pivot,register,tooth,mirror,check");
    for (std::string w; std::getline(ss, w, ',');)
      if (!w.empty()) lo.steps.push_back(w);
    if (c.board_given) lo.board = c.board;
    lo.camera_views = c.camera_views;
    lo.seed = c.seed;
    lo.pace = c.pace;
    lo.seconds = c.seconds;
    lo.screenshot_dir = c.screenshots;
    lo.summary_path = c.summary;
    lo.display = c.display;
    lo.quiet = c.quiet;
    if (std::string v = lo.validate(); !v.empty()) {
      print_error(kCmd, "live: " + v);
      return 2;
    }
    auto r = live::run_calibrate_live(lo);
    if (!r) {
      print_error(kCmd, r.error());
      return 2;
    }
    for (const auto& st : r->steps)
      std::cout << "step " << st.step << ": " << (st.pass ? "passed" : "did NOT pass") << " in " << fmt(st.seconds, 1)
                << " s (" << st.items << " items, " << st.refused << " touches refused)\n";
    if (r->truth_tip_error_mm >= 0)
      std::cout << "simulation truth: tip error " << fmt(r->truth_tip_error_mm, 3) << " mm, error at the crown "
                << fmt(r->truth_tooth_error_mm, 3) << " mm, bur tip vs tooth mean "
                << fmt(r->truth_static_colocation_mean_mm, 3) << " mm (p99 " << fmt(r->truth_static_colocation_p99_mm, 3)
                << " mm)\n";
    std::cout << (r->written ? "updated " + c.station : c.station + " was NOT written (" + r->stop_reason + ")") << "\n";
    return r->written ? 0 : 1;
  }
  if (c.step != "all" && c.step != "hand_eye" && c.step != "migrate" && c.step != "stereo" &&
      std::find(kSteps.begin(), kSteps.end(), c.step) == kSteps.end()) {
    print_error(kCmd, "unknown step \"" + c.step + "\"; use camera, hand_eye, pivot, register, tooth, "
                      "mirror, check, all, stereo or migrate");
    return 2;
  }
  if (c.step == "migrate") {
    // Rewrites an older station file in the current version; the original is kept beside it.
    auto r = ar::read_station_scene(c.station);
    if (!r) {
      print_error(kCmd, r.error());
      return 2;
    }
    if (r->migrated_from == 0) {
      std::cout << c.station << " is already version " << ar::kStationFileVersion << ": nothing to do\n";
      return 0;
    }
    const std::string backup = c.station + ".v" + std::to_string(r->migrated_from) + ".bak";
    std::error_code ec;
    fs::copy_file(c.station, backup, fs::copy_options::overwrite_existing, ec);
    if (ec) {
      print_error(kCmd, c.station + ": cannot keep the original as " + backup + ": " + ec.message() + "; nothing written");
      return 1;
    }
    if (Status st = ar::write_station_scene(*r, c.station); !st) {
      print_error(kCmd, st.error());
      return 1;
    }
    std::cout << "migrated " << c.station << " from version " << r->migrated_from << " to "
              << ar::kStationFileVersion << " (the original is kept as " << backup << ")\n";
    return 0;
  }
  Session s(c);
  try {
    if (fs::exists(c.station)) {
      auto r = ar::read_station_scene(c.station);
      if (!r) throw BadInput{r.error()};
      s.st = std::move(r).value();
      std::cout << "station " << c.station << " (file version " << s.st.version
                << (s.st.migrated_from ? ", migrated to " + std::to_string(ar::kStationFileVersion) + " on writing" : "")
                << ")\n";
      // A station file made with another camera: its intrinsics and placement are not this one's.
      const std::string& want = s.st.camera_provenance.device_id;
      if (!c.camera.empty() && c.step != "camera" && c.step != "all" && !want.empty()) {
        const std::string have = live::camera_identity(c.camera);
        if (!have.empty() && have != want)
          throw BadInput{c.station + ": calibrated with camera \"" + want + "\", but --camera " + c.camera +
                         " is \"" + have + "\": run `dentar calibrate camera` for this camera first, or use "
                         "the station file made for it"};
      }
    } else {
      s.st = ar::default_station_scene();
      std::cout << "station " << c.station << " does not exist yet: starting from the built-in "
                   "default station\n";
    }
    if (s.st.fixtures.divots_man.empty() || s.st.fixtures.landmarks_tooth.empty()) {
      std::cout << "note: the station file lists no calibration fixtures (a version 1 file); "
                   "using the default divots and tooth landmarks\n";
      s.st.fixtures = ar::default_calibration_fixtures();
    }
    if (c.camera_latency_ms >= 0) {
      s.st.camera_provenance.latency_ms = c.camera_latency_ms;
      std::cout << "camera latency " << fmt(c.camera_latency_ms, 1)
                << " ms (mid-exposure to grab, as measured) recorded for this station (camera.latency_ms)\n";
    }
    if (c.simulate) {
      s.truth = cal::simulated_truth(ar::default_station_scene().calibration, c.seed);
      std::cout << "simulation: the hidden truth is the built-in station perturbed with seed "
                << c.seed << "\n";
    }
    const std::vector<std::string> steps = c.step == "all" ? kSteps : std::vector<std::string>{c.step};
    for (const auto& step : steps) {
      const auto t0 = std::chrono::steady_clock::now();
      int rc = 0;
      if (step == "camera") rc = step_camera(s);
      else if (step == "hand_eye") rc = step_hand_eye(s);
      else if (step == "stereo") rc = step_stereo(s);
      else if (step == "pivot") rc = step_pivot(s);
      else if (step == "register") rc = step_register(s);
      else if (step == "tooth") rc = step_tooth(s);
      else if (step == "mirror") rc = step_mirror(s);
      else rc = step_check(s);
      const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::cout << "(step " << step << ": " << fmt(secs * 1e3, 1)
                << " ms wall time: data (simulated or read), live figures and the final solve)\n";
      if (rc != 0 && s.record_failure) {
        // The failed check is recorded (date, FAIL, figures) so the station is not handed out.
        s.st.version = ar::kStationFileVersion;
        if (Status st = ar::write_station_scene(s.st, c.station); !st) print_error(kCmd, st.error());
        else std::cout << "recorded the FAILED " << step << " in " << c.station << "\n";
        return rc;
      }
      if (rc != 0) {
        std::cout << "step " << step << " did not pass its gates: " << c.station
                  << " was NOT written. Fix what the message says and run `dentar calibrate "
                  << step << "` again.\n";
        return rc;
      }
    }
    if (std::string e = s.st.validate(); !e.empty())
      throw BadInput{"the calibrated station is invalid (" + e + "); nothing written"};
    if (const fs::path dir = fs::path(c.station).parent_path(); !dir.empty()) {
      std::error_code ec;
      fs::create_directories(dir, ec);  // a new user's --station out/station.json
    }
    if (s.wrote_camera) {
      std::string yaml = c.camera_out;
      if (yaml.empty()) yaml = (fs::path(c.station).parent_path() / (fs::path(c.station).stem().string() + ".camera.yaml")).string();
      if (Status st = cal::write_camera_file(yaml, s.camera_file); !st) {
        print_error(kCmd, st.error());
        return 1;
      }
      std::cout << "wrote the camera file " << yaml << "\n";
      if (!c.export_ros.empty()) {
        if (Status st = cal::write_ros_camera_info(c.export_ros, s.camera_file); !st) {
          print_error(kCmd, st.error());
          return 1;
        }
        std::cout << "wrote the ROS camera_info " << c.export_ros << "\n";
      }
    }
    s.st.version = ar::kStationFileVersion;
    if (Status st = ar::write_station_scene(s.st, c.station); !st) {
      print_error(kCmd, st.error());
      return 1;
    }
    std::cout << "updated " << c.station << " (version " << ar::kStationFileVersion << "):";
    for (const auto& r : s.st.calibration_report) std::cout << " " << r.step << (r.pass ? "=pass" : "=FAIL");
    std::cout << "\n";
    if (c.step == "all" || c.instructor_time) print_instructor_time();
    return 0;
  } catch (const BadInput& e) {
    print_error(kCmd, e.message);
    std::cout << c.station << " was NOT written.\n";
    return 2;
  }
}

}  // namespace

void add_calibrate(CLI::App& app, int& exit_code) {
  auto c = std::make_shared<CalibCli>();
  CLI::App* s = app.add_subcommand(
      "calibrate",
      "Guided station calibration for instructors: camera intrinsics, stylus tip (pivot),\n"
      "station registration (divots), tooth placement (landmarks), mirror, and an end-to-end\n"
      "co-location check. Each step prompts, prints live quality figures, and updates ONE\n"
      "station file only when its gates pass (docs/calibration.md).\n"
      "Synopsis: dentar calibrate <camera|hand_eye|pivot|register|tooth|mirror|check|all|live|stereo|migrate>\n"
      "            [--station FILE] [--simulate [--seed S]] [--images DIR --board SPEC]\n"
      "            [--model auto|k1|k1k2|radtan5|rational8]\n"
      "            [--import CAMERA.yaml] [--camera-out FILE] [--export-ros FILE]\n"
      "            [--poses FILE.csv] [--count N] [--camera SPEC] [--instructor-time]\n"
      "       dentar calibrate stereo --left DIR --right DIR | --images DIR | --live --left SPEC --right SPEC |\n"
      "            --live --side-by-side SPEC  --board SPEC [--count N] [--seconds S]\n"
      "Example: dentar calibrate stereo --live --left camera:0 --right camera:1 --board charuco:5x7:40:30:DICT_4X4_50");
  s->add_option("step", c->step,
                "camera, hand_eye, pivot, register, tooth, mirror, check, all (camera to check), live, stereo (a stereo head from --left/--right or side-by-side --images photos, or live cameras with --live), "
                "(the station's steps in a window: camera, pivot, register, tooth, mirror, check), or migrate (rewrite an older "
                "station file in the current version, keeping the original)");
  s->add_option("--camera", c->camera,
                "the camera this station belongs to (camera:N, /dev/videoN, live:FILE): the camera step "
                "records it (camera.device_id); the other steps refuse a station file of another camera");
  s->add_option("--haptic", c->haptic,
                "live: the stylus: sim (the simulated instructor) or a device kind (touch, omni, omega, hd, "
                "dhd, ...; see `dentar devices`). register: the device profile whose reach is checked "
                "(default: touch, omni and falcon)")
      ->capture_default_str();
  s->add_option("--haptic-name", c->haptic_name, "live: the device's configuration name or serial");
  s->add_option("--pedal", c->pedal, "live: keyboard (space bar) or a pedal spec (auto, vec, usb:VID:PID, evdev:PATH)")
      ->capture_default_str();
  s->add_option("--camera-views", c->camera_views,
                "live camera step: views after which the step stops itself once the lens model is trusted over the image")
      ->check(CLI::Range(6, 30))
      ->capture_default_str();
  s->add_option("--steps", c->live_steps,
                "live: the steps to run, in order, from camera,pivot,register,tooth,mirror,check")
      ->capture_default_str();
  s->add_option("--pace", c->pace, "live --haptic sim: the instructor's travel speed (1 = human pace)")
      ->check(CLI::Range(0.25, 20.0))
      ->capture_default_str();
  s->add_option("--seconds", c->seconds, "live: give up after S seconds (0 = no limit)")->check(at_least(0));
  s->add_option("--screenshots", c->screenshots, "live: save the window at the end of each step into DIR/<step>.png");
  s->add_option("--summary", c->summary, "live: write the run's summary JSON here");
  s->add_option("--display", c->display, "live: monitor for fullscreen (-1 = a window)");
  s->add_flag("--quiet", c->quiet, "live: no progress lines");
  s->add_option("--hand", c->hand, "hand_eye: what carries the camera (HMD, tracked frame)")->capture_default_str();
  s->add_option("--he-spread", c->he_spread_deg, "--simulate hand_eye: rotation spread of the head motions, degrees")
      ->check(CLI::Range(10.0, 180.0))
      ->capture_default_str();
  s->add_option("--station", c->station, "Station file to read and update")->capture_default_str();
  s->add_flag("--simulate", c->simulate,
              "Generated data: the footage generator stands in for the camera, a simulated "
              "stylus for the device (hidden truth: the built-in station perturbed by --seed)");
  s->add_option("--seed", c->seed, "Simulation seed")->capture_default_str();
  s->add_option("--images", c->images, "camera: folder of board photos (PNG/JPEG); stereo: side-by-side photos (left | right)");
  s->add_option("--left", c->left_dir, "stereo: folder of the left eye's board photos (photo i of --left and --right: one capture)");
  s->add_option("--right", c->right_dir, "stereo: folder of the right eye's board photos");
  s->add_flag("--live", c->stereo_live,
              "stereo: --left/--right are the two cameras (camera:N, /dev/videoN, live:FILE stand-ins, or "
              "recorded video files / frame folders), or --side-by-side one device; captures are taken by "
              "themselves whenever the board is held still and new (--count of them, default 15; --seconds "
              "limit). A camera spec (camera:N, /dev/videoN, live:FILE) in --left/--right implies --live");
  s->add_option("--side-by-side", c->side_by_side,
                "stereo --live: one device delivering both eyes side by side (left | right, even width)");
  s->add_option("--stall-timeout", c->stall_timeout_s,
                "stereo --live: an eye that delivers no frame for S seconds (unplugged, stalled) ends the capture, "
                "saying which; the captures taken before it are calibrated (written if they pass the gates, else "
                "exit 2)")
      ->check(CLI::Range(0.1, 3600.0))
      ->capture_default_str();
  s->add_option("--inject-stall-left", c->stall_left, "stereo --live test hook: AFTER_FRAMES:SECONDS, the left eye goes quiet");
  s->add_option("--inject-stall-right", c->stall_right,
                "stereo --live test hook: AFTER_FRAMES:SECONDS, the right eye goes quiet");
  s->add_option("--board", c->board,
                "camera, stereo, live: chessboard:COLSxROWS:SQUARE_MM (inner corners), "
                "aprilgrid:COLSxROWS:TAG_MM:GAP_MM[:FAMILY[:FIRST_ID]], Kalibr's "
                "kalibr:COLSxROWS:TAG_MM:SPACING_RATIO[:FIRST_ID] or "
                "charuco:COLSxROWS:SQUARE_MM:MARKER_MM:DICT[:FIRST_ID] (squares; e.g. charuco:5x7:40:30:DICT_4X4_50); "
                "docs/formats.md. live: default aprilgrid:6x5:24:8:tag36h11, which is detected fast enough for video")
      ->capture_default_str();
  s->add_option("--import", c->import_camera,
                "camera: take the intrinsics from an OpenCV FileStorage or ROS camera_info YAML");
  s->add_option("--camera-out", c->camera_out,
                "camera: where to save the camera YAML (default: <station>.camera.yaml)");
  s->add_option("--export-ros", c->export_ros, "camera: also write a ROS camera_info YAML");
  s->add_option("--device", c->device, "camera: device name recorded in the camera file")
      ->capture_default_str();
  s->add_option("--model", c->model,
                "camera: distortion model: auto (default: the simplest model as good as the best on "
                "held-out views; folding models refused), k1, k1k2, radtan5 or rational8 (a "
                "requested model that folds over is refused and auto is used)")
      ->check(CLI::IsMember({"auto", "k1", "k1k2", "radtan5", "rational8"}))
      ->capture_default_str();
  s->add_option("--corners", c->corners,
                "camera, chessboards: how the corners are placed: sb-subpix (default: OpenCV's "
                "sector-based detector finds the board, cornerSubPix places the corners), sb (the "
                "sector-based corners alone, the default before issue 24 session 11) or classic "
                "(findChessboardCorners + cornerSubPix)")
      ->check(CLI::IsMember({"sb-subpix", "sb", "classic"}))
      ->capture_default_str();
  s->add_flag("--rational", c->rational,
              "camera: same as --model rational8 (the tracker uses only k1 k2 p1 p2 k3)");
  s->add_option("--poses", c->poses,
                "pivot/register/tooth/mirror: stylus poses CSV (label,tx_mm,ty_mm,tz_mm,rx_deg,"
                "ry_deg,rz_deg[,mtag_...]; see docs/formats.md)");
  s->add_option("--count", c->count,
                "--simulate: number of views/poses/touches (default per step; fewer to see the "
                "gates refuse)")
      ->check(CLI::Range(1, 500));
  s->add_option("--max-tilt", c->max_tilt_deg, "--simulate pivot: largest stylus tilt, degrees")
      ->check(CLI::Range(0.0, 60.0))
      ->capture_default_str();
  s->add_option("--bad-view", c->bad_view,
                "--simulate camera: index of the warped-board (outlier) view, -1 for none")
      ->capture_default_str();
  s->add_option("--sim-board-area", c->sim_board_area,
                "--simulate camera: keep every board inside the centred part of the image holding "
                "this % of it (a user who never moved the board to the edges)")
      ->check(CLI::Range(10.0, 100.0))
      ->capture_default_str();
  s->add_option("--latency-ms", c->latency_ms,
                "check: the camera's latency against the haptic pose drawn on its frame, ms (the "
                "live path draws the pose of the moment it takes the frame; reported as the timing "
                "term, beside the total; 0: not simulated)")
      ->check(CLI::Range(0.0, 500.0))
      ->capture_default_str();
  s->add_option("--latency-jitter-ms", c->latency_jitter_ms,
                "check: the per-frame spread of that latency, ms, 1 sigma (USB transfer and grab "
                "scheduling; assumed, not measured)")
      ->check(CLI::Range(0.0, 100.0))
      ->capture_default_str();
  s->add_option("--camera-latency-ms", c->camera_latency_ms,
                "Record this station camera's latency in the station file (camera.latency_ms: "
                "mid-exposure to the grab, ms, as measured at the station); dentar live draws each "
                "frame with the stylus pose of its exposure from it (unset: 33 ms assumed)")
      ->check(CLI::Range(0.0, 1000.0));
  s->add_option("--frames", c->check_frames, "check: generated frames")
      ->check(CLI::Range(3, 1000))
      ->capture_default_str();
  s->add_flag("--instructor-time", c->instructor_time,
              "Print the steps, the data each needs and the estimated instructor time");
  s->footer(
      "Examples (a new user, generated data):\n"
      "  dentar calibrate all --simulate --station out/station.json\n"
      "  dentar calibrate camera --images photos/ --board chessboard:9x6:25 --station station.json\n"
      "  dentar calibrate pivot --poses pivot.csv --station station.json\n"
      "  dentar calibrate live --haptic touch --pedal auto --station station.json   # in a window\n"
      "  dentar calibrate live --camera camera:0 --haptic touch --pedal auto --station station.json\n"
      "  dentar synth --board aprilgrid:6x5:24:8 --seed 3 --out out/clip   # a hand-held board clip\n"
      "  dentar calibrate live --haptic sim --seed 3 --camera live:out/clip/video.mkv --station out/s.json\n"
      "  dentar calibrate stereo --left photos/left --right photos/right --board chessboard:9x6:25 --station station.json\n"
      "  dentar calibrate migrate --station old_station.json\n"
      "  dentar calibrate --instructor-time");
  s->callback([c, s, &exit_code] {
    c->board_given = s->count("--board") > 0;
    if (c->step.empty() && !c->instructor_time) {
      print_error(kCmd, "give a step: camera, pivot, register, tooth, mirror, check or all");
      exit_code = 2;
      return;
    }
    exit_code = run(*c);
  });
}

}  // namespace dentar::tools
