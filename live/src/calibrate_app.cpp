// `dentar calibrate live`: see calibrate_app.h.
#include "dentar/live/calibrate_app.h"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <deque>
#include <future>
#include <ctime>
#include <filesystem>
#include <functional>
#include <fstream>
#include <iomanip>
#include <limits>
#include <mutex>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <random>
#include <sstream>
#include <thread>

#include "dentar/ar/calib_board.h"
#include "dentar/ar/capture_thread.h"
#include "dentar/ar/frame_source.h"
#include "dentar/ar/stereo_source.h"
#include "dentar/ar/station_scene.h"
#include "dentar/calibration/camera_file.h"
#include "dentar/calibration/camera_model.h"
#include "dentar/calibration/co_location.h"
#include "dentar/calibration/guided.h"
#include "dentar/calibration/landmarks.h"
#include "dentar/haptics/open_device.h"
#include "dentar/haptics/scripts.h"
#include "dentar/haptics/simulated_device.h"
#include "dentar/ar/bundle_pose.h"
#include "dentar/calibration/mirror.h"
#include "dentar/live/hud_window.h"
#include "dentar/live/station_health.h"

namespace dentar::live {
namespace fs = std::filesystem;
namespace cal = dentar::calibration;
using Clock = std::chrono::steady_clock;

namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr int kMirrorRimPoints = 8;  // rim touches, then the centre
std::atomic<int> g_cal_signal{0};
extern "C" void on_cal_signal(int sig) { g_cal_signal.store(sig); }

double wall_s() { return std::chrono::duration<double>(Clock::now().time_since_epoch()).count(); }

std::string iso_now() {
  const std::time_t t = std::time(nullptr);
  char b[32];
  std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return b;
}

std::string fmt(double v, int prec = 2) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(prec) << v;
  return os.str();
}

// The device, polled at 1 kHz on its own thread with zero force (a calibration renders no
// force); the main thread reads the latest pose. The simulated instructor's device is swapped
// per step (each step's motions start where the last one ended).
class Poller {
 public:
  struct Sample {
    double t_s = 0;  // the device's own time (simulated devices: simulated time), s
    Eigen::Isometry3d T_dev_sty = Eigen::Isometry3d::Identity();
    std::uint32_t buttons = 0;
    bool valid = false;
  };
  // simulated: step the device as often as wall time asks (it advances 1 ms per step), so a
  // delayed thread does not slow the simulated hand down.
  Poller(std::unique_ptr<haptics::HapticDevice> d, bool simulated) : dev_(std::move(d)), simulated_(simulated) {
    thread_ = std::thread([this] { main(); });
  }
  ~Poller() {
    stop_.store(true);
    if (thread_.joinable()) thread_.join();
  }
  void swap(std::unique_ptr<haptics::HapticDevice> d) {
    std::lock_guard<std::mutex> lock(m_);
    dev_ = std::move(d);
    steps_ = 0;
    t0_ = Clock::now();
    last_ = Sample{};
    history_.clear();
  }
  Sample latest() const {
    std::lock_guard<std::mutex> lock(m_);
    return last_;
  }
  // The samples after device time t_s (100 Hz, the last 3 s): the steps see every sample even
  // when the window redraws slowly (a loaded machine, a software renderer).
  std::vector<Sample> since(double t_s) const {
    std::lock_guard<std::mutex> lock(m_);
    std::vector<Sample> out;
    for (const auto& x : history_)
      if (x.t_s > t_s) out.push_back(x);
    return out;
  }
  std::string name() const {
    std::lock_guard<std::mutex> lock(m_);
    return dev_ ? dev_->name() : std::string("none");
  }
  // Simulated: the hand's clock does not pass t_s (the instructor waits in the point until the
  // HUD says it is taken, however late a starved or paused process sees it); inf = no limit.
  void hold_at(double t_s) { limit_s_.store(t_s); }

 private:
  void main() {
    auto next = Clock::now();
    while (!stop_.load()) {
      next += std::chrono::milliseconds(1);
      {
        std::lock_guard<std::mutex> lock(m_);
        if (dev_ && simulated_ && last_.valid && last_.t_s >= limit_s_.load()) {
          t0_ += std::chrono::milliseconds(1);  // held: the device clock waits with the hand
        } else if (dev_) {
          const std::int64_t due =
              simulated_ ? std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - t0_).count() + 1
                         : steps_ + 1;
          for (int i = 0; i < 200 && steps_ < due; ++i, ++steps_) {
            haptics::DeviceState s;
            const bool ok = dev_->read(s);
            dev_->write_force(Eigen::Vector3d::Zero());
            last_.t_s = s.time_s;
            last_.T_dev_sty = s.T_dev_sty;
            last_.buttons = s.buttons;
            last_.valid = ok && !s.fault && s.T_dev_sty.matrix().allFinite();
            if (steps_ % 10 == 0) {
              history_.push_back(last_);
              if (history_.size() > 300) history_.pop_front();
            }
          }
        }
      }
      if (Clock::now() - next > std::chrono::milliseconds(50)) next = Clock::now();
      std::this_thread::sleep_until(next);
    }
  }
  mutable std::mutex m_;
  std::unique_ptr<haptics::HapticDevice> dev_;
  Sample last_;
  std::deque<Sample> history_;
  bool simulated_ = false;
  std::int64_t steps_ = 0;
  Clock::time_point t0_ = Clock::now();
  std::atomic<bool> stop_{false};
  std::atomic<double> limit_s_{std::numeric_limits<double>::infinity()};
  std::thread thread_;
};

// ---- the simulated instructor ---------------------------------------------------------------
struct Press {
  double t_s;  // device time (the plan starts at 0)
  int target;  // the point the instructor is holding (-1: any); a press whose point is not the
               // HUD's next one is not made (the instructor reads the HUD)
};
struct Plan {
  std::vector<haptics::HandWaypoint> script;  // times relative to the step start
  std::vector<Press> presses;
  // Touch steps: per target, when the tip rests in it (device time). The instructor presses
  // while the HUD asks for that target and shows the stylus still, again every 0.5 s until it
  // is taken (a starved or paused process may see a scripted press only after the hand moved).
  std::vector<std::pair<double, double>> rest;
};

Eigen::Quaterniond pointing(const Eigen::Vector3d& dir, double spin) {
  // A rotation whose +z (the stylus axis toward the tip) is `dir`.
  const Eigen::Vector3d z = dir.normalized();
  Eigen::Vector3d x = z.unitOrthogonal();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = y;
  R.col(2) = z;
  return Eigen::Quaterniond(R * Eigen::AngleAxisd(spin, Eigen::Vector3d::UnitZ()).toRotationMatrix());
}

class SimInstructor {
 public:
  SimInstructor(const cal::StationCalibration& truth, std::uint64_t seed, double pace)
      : truth_(truth), rng_(seed * 7919 + 3), pace_(pace) {}

  // Rocking in the pivot divot: the tip stays seated (0.05 mm jitter), the stylus tilts 11-25
  // degrees around a cone whose azimuth turns every 6 s, for up to 3 minutes.
  Plan pivot(const Eigen::Isometry3d& from) {
    Plan p;
    const Eigen::Vector3d divot = cal::simulated_pivot_divot_dev();
    const Eigen::Vector3d down(0, -1, 0), tip = truth_.T_sty_tip.translation();
    std::normal_distribution<double> j(0, 0.05e-3);
    add(p, 0, from);
    const double arrive = 2.0 / pace_;
    for (double t = 0; t <= 180; t += 0.1) {
      const double phi = 2 * M_PI * t / 6.0, a = (18 + 7 * std::sin(2 * M_PI * t / 11.0)) * kDeg;
      const Eigen::Vector3d axis(std::cos(phi), 0, std::sin(phi));
      const Eigen::Quaterniond q =
          Eigen::Quaterniond(Eigen::AngleAxisd(a, axis)) * pointing(down, 0.3 * std::sin(2 * M_PI * t / 9.0));
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.linear() = q.toRotationMatrix();
      T.translation() = divot + Eigen::Vector3d(j(rng_), j(rng_), j(rng_)) - T.linear() * tip;
      add(p, arrive + t, T);
    }
    p.presses.push_back({arrive + 0.5, -1});  // seated: start collecting
    return p;
  }

  // Touches of targets (device frame, truth) in order, each approached along `approach` (the
  // stylus axis, device frame) tilted by up to 20 degrees; the tip rests within the fixture's
  // localisation error (0.2 mm RMS) for 1.7 s, during which the instructor presses (Plan::rest,
  // pressed once the HUD shows the stylus still, again if the HUD still asks). With
  // moving_press_at = i, the instructor first presses while still arriving at target i.
  Plan touches(const std::vector<Eigen::Vector3d>& targets, const Eigen::Vector3d& approach,
               const Eigen::Isometry3d& from, int moving_press_at) {
    Plan p;
    std::normal_distribution<double> fle(0, 0.2e-3 / std::sqrt(3.0));
    std::uniform_real_distribution<double> u(-1, 1);
    const Eigen::Vector3d tip = truth_.T_sty_tip.translation();
    double t = 0;
    add(p, t, from);
    const double travel = 2.0 / pace_, descend = 0.8 / pace_, hold = 1.7;
    for (std::size_t i = 0; i < targets.size(); ++i) {
      const Eigen::Vector3d tilt(u(rng_), u(rng_), u(rng_));
      const Eigen::Quaterniond q =
          Eigen::Quaterniond(Eigen::AngleAxisd(20 * kDeg * std::abs(u(rng_)), tilt.normalized())) *
          pointing(approach, u(rng_) * M_PI);
      const Eigen::Matrix3d R = q.toRotationMatrix();
      const Eigen::Vector3d rest = targets[i] + Eigen::Vector3d(fle(rng_), fle(rng_), fle(rng_));
      auto pose = [&](const Eigen::Vector3d& tip_at) {
        Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
        T.linear() = R;
        T.translation() = tip_at - R * tip;
        return T;
      };
      const Eigen::Vector3d above = rest - 12e-3 * R.col(2);
      t += travel;
      add(p, t, pose(above));
      t += descend;
      add(p, t, pose(rest));
      const int ti = static_cast<int>(i);
      if (ti == moving_press_at) p.presses.push_back({t - 0.3 * descend, ti});
      p.rest.emplace_back(t, t + hold);
      t += hold;
      add(p, t, pose(rest));
      t += 0.4 / pace_;
      add(p, t, pose(above));
    }
    add(p, t + 30, p.script.back().position_m, p.script.back().orientation);
    return p;
  }

  Result<std::unique_ptr<haptics::HapticDevice>> device(const Plan& plan) const {
    haptics::HandParams hand;
    hand.stiffness_N_per_m = haptics::kFingerRestStiffness_N_per_m;  // fingers rested
    haptics::DeviceLimits limits;
    limits.workspace_min_m = Eigen::Vector3d::Constant(-1);
    limits.workspace_max_m = Eigen::Vector3d::Constant(1);
    auto d = haptics::SimulatedDevice::create(plan.script, limits, hand);
    if (!d) return Error{d.error()};
    return std::unique_ptr<haptics::HapticDevice>(std::move(*d));
  }

 private:
  static void add(Plan& p, double t, const Eigen::Isometry3d& T) {
    add(p, t, T.translation(), Eigen::Quaterniond(T.linear()));
  }
  static void add(Plan& p, double t, const Eigen::Vector3d& x, const Eigen::Quaterniond& q) {
    if (!p.script.empty() && t <= p.script.back().time_s) t = p.script.back().time_s + 1e-3;
    haptics::HandWaypoint w;
    w.time_s = t;
    w.position_m = x;
    w.orientation = q;
    p.script.push_back(w);
  }
  cal::StationCalibration truth_;
  std::mt19937_64 rng_;
  double pace_;
};

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return -1;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::min<double>(v.size() - 1, std::ceil(q * (v.size() - 1))))];
}

}  // namespace

std::string CalibrateLiveOptions::validate() const {
  if (station.empty()) return "station is empty: give --station FILE";
  if (device.empty()) return "device is empty: give sim or a device kind (touch, omega, hd, ...)";
  if (pedal.empty()) return "pedal is empty: give keyboard, auto, vec, usb:VID:PID or evdev:/dev/input/eventN";
  if (steps.empty()) return "steps is empty: give camera, pivot, register, tooth, mirror and/or check";
  for (const auto& s : steps) {
    if (s != "camera" && s != "pivot" && s != "register" && s != "tooth" && s != "mirror" && s != "check")
      return "step \"" + s + "\" is not a live step: the live steps are camera, pivot, register, tooth, mirror and "
             "check (hand_eye runs with `dentar calibrate hand_eye`)";
    if (s == "camera" && camera.empty())
      return "the camera step needs the camera: give --camera camera:N, /dev/videoN or live:FOOTAGE";
    if (s == "mirror" && camera.empty() && device != "sim")
      return "the mirror step needs the camera (the mirror's pose is tracked at each touch): give --camera";
  }
  if (auto b = ar::parse_board_spec(board); !b) return "board: " + b.error();
  if (camera_views < 6 || camera_views > 30) return "camera_views must be in [6, 30]";
  if (!(std::isfinite(pace) && pace >= 0.25 && pace <= 20)) return "pace must be in [0.25, 20]";
  if (!(std::isfinite(seconds) && seconds >= 0)) return "seconds must be >= 0";
  if (display < -1 || display > 16) return "display must be -1 (a window) or a monitor 0..16";
  return {};
}

std::string CalibrateLiveSummary::json() const {
  nlohmann::ordered_json j;
  nlohmann::ordered_json st = nlohmann::ordered_json::array();
  for (const auto& s : steps) {
    nlohmann::ordered_json f = nlohmann::ordered_json::object();
    for (const auto& [k, v] : s.figures) f[k] = v;
    st.push_back({{"step", s.step}, {"pass", s.pass}, {"seconds", s.seconds}, {"items", s.items},
                  {"refused", s.refused}, {"figures", f}, {"message", s.message}});
  }
  j["steps"] = st;
  j["written"] = written;
  j["stop_reason"] = stop_reason;
  j["total_s"] = total_s;
  j["truth"] = {{"tip_error_mm", truth_tip_error_mm},
                {"tooth_error_mm", truth_tooth_error_mm},
                {"static_colocation_mean_mm", truth_static_colocation_mean_mm},
                {"static_colocation_p99_mm", truth_static_colocation_p99_mm},
                {"camera_fx_error_px", truth_camera_fx_error_px},
                {"camera_max_error_px", truth_camera_max_px},
                {"camera_tooth_max_error_px", truth_camera_tooth_max_px}};
  j["log"] = log;
  return j.dump(2) + "\n";
}

namespace {

// Camera step, per new frame: detect the board, feed the step, draw the overlay (coverage or
// trust map, the suggested place, the detected points) into the frame shown.
// Every board kind goes through the one detector of ar/calib_board.h (chessboard, our AprilTag
// grid, Kalibr's AprilGrid, ChArUco), as the image-based steps do.
// The board's focus measure in a grey image: the variance of the Laplacian over the bounding
// box of its detected points (0: no points, or a box too small to tell).
double board_focus(const cv::Mat& gray, const cal::BoardView& v) {
  if (v.image_points.empty()) return 0.0;
  cv::Rect2d bb(v.image_points[0].x(), v.image_points[0].y(), 0, 0);
  for (const auto& p : v.image_points) bb |= cv::Rect2d(p.x(), p.y(), 1, 1);
  const cv::Rect box = cv::Rect(bb) & cv::Rect(0, 0, gray.cols, gray.rows);
  if (box.area() <= 16) return 0.0;
  cv::Mat lap;
  cv::Laplacian(gray(box), lap, CV_32F);
  cv::Scalar mu, sd;
  cv::meanStdDev(lap, mu, sd);
  return sd[0] * sd[0];
}

// One frame into a live camera step's bookkeeping: the board searched, its focus measured.
void feed_board_views(const cv::Mat& image, double t_s, ar::BoardDetector& det, cal::LiveCameraViews& c) {
  cv::Mat gray;
  if (image.channels() == 3) cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  else gray = image;
  Result<cal::BoardView> v = det.detect(gray, "the live view");
  c.add_frame(t_s, v ? &*v : nullptr, v ? std::string() : v.error(), v ? board_focus(gray, *v) : 0.0);
}

cv::Mat camera_view(const ar::Frame& f, cal::LiveCameraViews& c, ar::BoardDetector& det) {
  feed_board_views(f.image, f.time_s, det, c);
  cv::Mat img = f.image.clone(), tint = f.image.clone();
  const cal::CoverageMap cm = c.coverage();
  const bool trust = c.trust_views() > 0 && c.trust().cols == cm.cols && c.trust().rows == cm.rows;
  for (int r = 0; r < cm.rows; ++r)
    for (int k = 0; k < cm.cols; ++k) {
      const int i = r * cm.cols + k;
      const cv::Rect cell(k * img.cols / cm.cols, r * img.rows / cm.rows, img.cols / cm.cols, img.rows / cm.rows);
      cv::Scalar col(-1, 0, 0);
      if (trust) col = c.trust().trusted[i] ? cv::Scalar(0, 200, 0) : c.trust().extrapolated[i] ? cv::Scalar(128, 128, 128) : cv::Scalar(0, 0, 220);
      else if (cm.counts[i] >= 5) col = cv::Scalar(0, 200, 0);
      else if (cm.counts[i] > 0) col = cv::Scalar(0, 200, 220);
      if (col[0] >= 0) cv::rectangle(tint, cell, col, cv::FILLED);
      cv::rectangle(img, cell, cv::Scalar(90, 90, 90), 1);
    }
  cv::addWeighted(tint, 0.25, img, 0.75, 0, img);
  int sc = 0, sr = 0;
  std::string sug;
  if (c.suggestion(sc, sr, sug)) {
    const cv::Rect cell(sc * img.cols / cm.cols, sr * img.rows / cm.rows, img.cols / cm.cols, img.rows / cm.rows);
    cv::rectangle(img, cell, cv::Scalar(255, 230, 0), 3);
    cv::putText(img, "board here", cell.tl() + cv::Point(4, 16), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(255, 230, 0), 1);
  }
  const cv::Scalar pc = !c.last_layout_ok() ? cv::Scalar(0, 0, 255) : c.still() ? cv::Scalar(0, 255, 0) : cv::Scalar(0, 220, 255);
  for (const auto& p : c.last_view().image_points) cv::circle(img, cv::Point(cvRound(p.x()), cvRound(p.y())), 3, pc, 1);
  return img;
}


// The station to calibrate: the file, or the built-in default when it does not exist yet
// (with the default calibration fixtures when it has none); refused when it was
// calibrated with another camera than --camera and this run does not redo the camera.
Result<ar::StationScene> calibration_station(const CalibrateLiveOptions& o,
                                             const std::function<void(const std::string&)>& say) {
  ar::StationScene st;
  if (fs::exists(o.station)) {
    auto r = ar::read_station_scene(o.station);
    if (!r) return Error{"calibrate live: " + r.error()};
    st = std::move(*r);
  } else {
    st = ar::default_station_scene();
    say("station " + o.station + " does not exist yet: starting from the built-in default station");
  }
  if (st.fixtures.divots_man.empty() || st.fixtures.landmarks_tooth.empty())
    st.fixtures = ar::default_calibration_fixtures();
  // A station file made with another camera: its intrinsics and placement are not this one's
  // (unless this run calibrates the camera first).
  if (!o.camera.empty() && std::find(o.steps.begin(), o.steps.end(), "camera") == o.steps.end() &&
      !st.camera_provenance.device_id.empty()) {
    const std::string have = camera_identity(o.camera);
    if (!have.empty() && have != st.camera_provenance.device_id)
      return Error{"calibrate live: " + o.station + ": calibrated with camera \"" + st.camera_provenance.device_id +
                   "\", but --camera " + o.camera + " is \"" + have +
                   "\": add the camera step (--steps camera,...) for this camera, or use the station file made for it"};
  }
  return st;
}


// A live calibration's state over its steps (main thread; the poller and the
// capture thread feed it): the station being calibrated, the devices, the
// window, and what one step hands the next.
struct CalSession {
  const CalibrateLiveOptions& o;
  CalibrateLiveSummary& sum;
  std::function<void(const std::string&)> say;
  ar::StationScene st;
  bool sim = false;
  cal::StationCalibration truth;  // sim: the hidden truth
  std::unique_ptr<SimInstructor> instructor;
  std::unique_ptr<Poller> poller;
  haptics::DeviceLimits real_limits;  // the connected device's (reach check after register)
  std::string real_name;
  std::unique_ptr<haptics::Pedal> pedal;
  std::unique_ptr<ar::CaptureThread> capture;  // the camera (background only)
  int vw = 1280, vh = 720;
  std::unique_ptr<HudWindow> window;
  double t_start = 0;
  Eigen::Isometry3d last_pose = Eigen::Isometry3d::Identity();
  bool all_pass = true, aborted = false;
  std::uint32_t last_buttons = 0;
  bool last_pedal = false;
  bool record_failure = false;                 // a failed check is written (dated FAIL)
  std::optional<cal::CameraFile> camera_file;  // the camera step's result
  std::string camera_id;
  ar::BoardSpec board_spec;
  std::mt19937_64 mirror_rng;
  // Mirror step with a real camera: the mirror tag's pose against the mannequin's, per frame.
  struct {
    bool valid = false;
    double when_s = 0;
    Eigen::Isometry3d T_mtag_man = Eigen::Isometry3d::Identity();
  } mirror_track;
  std::unique_ptr<ar::TagDetector> station_det;

  CalSession(const CalibrateLiveOptions& o_, CalibrateLiveSummary& sum_) : o(o_), sum(sum_) {
    say = [this](const std::string& s) {
      sum.log.push_back(s);
      if (!o.quiet) std::fprintf(stderr, "dentar calibrate live: %s\n", s.c_str());
    };
  }

  // The device (the simulated instructor, or a haptic device), the pedal, the camera and the window.
  Status open() {
    const cal::StationCalibration nominal = st.calibration;
    sim = o.device == "sim";
    if (sim) {
      truth = cal::simulated_truth(nominal, o.seed);
      instructor = std::make_unique<SimInstructor>(truth, o.seed, o.pace);
      say("simulated instructor: the hidden truth is the station perturbed with seed " + std::to_string(o.seed));
    } else {
      haptics::DeviceOpenOptions dopt;
      dopt.name_or_serial = o.device_name;
      auto d = haptics::open_haptic_device(o.device, dopt);
      if (!d) return Error{"calibrate live: haptic device " + o.device + ": " + d.error()};
      real_limits = (*d)->limits();
      real_name = (*d)->name();
      poller = std::make_unique<Poller>(std::move(*d), false);
    }
    if (o.pedal != "keyboard") {
      auto p = haptics::open_pedal(o.pedal);
      if (!p) return Error{"calibrate live: --pedal " + o.pedal + ": " + p.error()};
      pedal = std::move(*p);
    }
    if (!o.camera.empty()) {
      ar::FrameSourceOptions so;
      auto src = ar::FrameSource::open(o.camera, so);
      if (!src) return Error{"calibrate live: --camera " + o.camera + ": " + src.error()};
      vw = (*src)->width();
      vh = (*src)->height();
      ar::CaptureThreadOptions cto;
      cto.reopen = true;  // footage loops, a camera comes back
      capture = std::make_unique<ar::CaptureThread>(std::move(*src), o.camera, so, cto);
      capture->start();
    }
    // A small camera image is shown enlarged (to 1024 px wide) so the HUD's text leaves the view visible.
    const int win_w = std::max(vw, 1024), win_h = static_cast<int>(std::lround(double(vh) * win_w / std::max(vw, 1)));
    auto win_r = HudWindow::open("DentAR station calibration", vw, vh, win_w, win_h, o.display, o.vsync);
    if (!win_r) return Error{"calibrate live: " + win_r.error()};
    window = std::move(*win_r);
    last_pose.translation() = cal::simulated_pivot_divot_dev() + Eigen::Vector3d(0, 0.05, 0);
    camera_id = o.camera.empty() ? std::string() : camera_identity(o.camera);
    board_spec = *ar::parse_board_spec(o.board);
    mirror_rng.seed(o.seed * 131 + 7);
    return {};
  }

  void track_mirror(const ar::Frame& f) {
    if (!station_det) {
      ar::TagDetectorOptions dopt;
      dopt.response = ar::CameraResponse::kSrgb;  // as dentar live's tracker decodes the camera
      dopt.families = {st.family};
      auto d = ar::TagDetector::create(dopt);
      if (!d) return;
      station_det = std::make_unique<ar::TagDetector>(std::move(*d));
    }
    cv::Mat gray;
    cv::cvtColor(f.image, gray, cv::COLOR_BGR2GRAY);
    auto d = station_det->detect(gray);
    if (!d) return;
    const auto man = ar::estimate_bundle_pose(ar::mannequin_bundle(st), st.calibration.camera, *d);
    const auto mir = ar::estimate_bundle_pose(ar::mirror_bundle(st), st.calibration.camera, *d);
    mirror_track.valid = man.ok() && mir.ok();
    if (mirror_track.valid) {
      mirror_track.T_mtag_man = mir.T_cam_body.inverse() * man.T_cam_body;
      mirror_track.when_s = wall_s();
    }
  }

  // sim: the result against the hidden truth (the summary's truth_* figures).
  void truth_figures();
  // The station file (and the camera file) written when every step passed or a
  // check failed (dated); the summary JSON.
  Status write_results();
};

const Eigen::Vector3d kCrownTooth(0, 0, 4e-3);  // where the TRE is predicted: the crown, tooth frame

// One step of a live calibration: its targets and text, the simulated
// instructor's plan, the window loop (takes, HUD), and its result with the
// step's real gates. The references name the session's parts as the steps use them.
class StepRun {
 public:
  StepRun(CalSession& session, const std::string& step_name)
      : S(session), o(S.o), sum(S.sum), say(S.say), st(S.st), sim(S.sim), truth(S.truth), instructor(S.instructor),
        poller(S.poller), real_limits(S.real_limits), real_name(S.real_name), pedal(S.pedal), capture(S.capture),
        vw(S.vw), vh(S.vh), win(*S.window), t_start(S.t_start), last_pose(S.last_pose), all_pass(S.all_pass),
        aborted(S.aborted), last_buttons(S.last_buttons), last_pedal(S.last_pedal), record_failure(S.record_failure),
        camera_file(S.camera_file), camera_id(S.camera_id), board_spec(S.board_spec), mirror_rng(S.mirror_rng),
        mirror_track(S.mirror_track), step(step_name),
        n_landmarks(static_cast<int>(st.fixtures.landmarks_tooth.size())) {
    rec.step = step;
  }

  // Runs the step. false: the run stops here (aborted, a step that did not
  // pass); errors are the run's (exit 2).
  Result<bool> run() {
    describe();
    if (auto s = plan_instructor(); !s) return Error{s.error()};
    say("step " + step + ": " + title);
    what = step == "register" ? "divot" : step == "tooth" ? "landmark" : step == "mirror" ? "mirror point" : "check point";
    touches = cal::LiveTouches(what, static_cast<int>(known.size()));
    if (step == "camera")
      if (auto s = camera_state(); !s) return Error{s.error()};
    t0 = wall_s();
    loop();
    rec.seconds = wall_s() - t0;
    if (aborted) {
      rec.message = "stopped (" + sum.stop_reason + ")";
      sum.steps.push_back(rec);
      all_pass = false;
      return false;
    }
    if (!shot.empty()) cv::imwrite((fs::path(o.screenshot_dir) / (step + ".png")).string(), shot);
    // ---- the step's result, with its real gates ----
    ar::CalibrationStepReport rep{step, iso_now(), false, "", {}};
    if (auto s = result(rep); !s) return Error{s.error()};
    rep.pass = rec.pass;
    rep.figures.emplace_back("instructor_s", rec.seconds);
    rec.figures = rep.figures;
    say("step " + step + (rec.pass ? " passed" : " did NOT pass") + " after " + fmt(rec.seconds, 1) + " s: " + rec.message);
    sum.steps.push_back(rec);
    if (!rec.pass) {
      if (record_failure) st.set_step_report(rep);  // the failed check, dated, so the station is not handed out
      all_pass = false;
      return false;
    }
    st.set_step_report(rep);
    return true;
  }

 private:
  // Targets and the instructor's text.
  void describe() {
    if (step == "pivot") {
      title = "Stylus tip (pivot)";
      instruction = "Seat the bur tip in the pivot divot and rock the stylus slowly in all directions\n"
                    "(15-30 degrees), keeping the tip seated. The step stops by itself.";
    } else if (step == "register") {
      title = "Station registration (divots)";
      known = st.fixtures.divots_man;
      target_fit = st.calibration.T_man_tooth * crown_tooth;
      instruction = "Touch the divots on the mannequin in the order shown. Hold the tip still in each,\n"
                    "then press SPACE (or the pedal, or the stylus button).";
    } else if (step == "tooth") {
      title = "Tooth placement (landmarks)";
      known = st.fixtures.landmarks_tooth;
      target_fit = crown_tooth;
      instruction = "Touch the landmarks on the mounted tooth in the order shown (cusp tips, then the\n"
                    "buccal and lingual cervical points). Hold still, then press SPACE.";
    } else if (step == "camera") {
      title = "Camera (board views)";
      instruction = "Hold the printed board in front of the head camera, tilted 15-45 degrees. Hold it still and\n"
                    "press SPACE (or the pedal) for each view; put it where the cyan box asks. The step stops\n"
                    "by itself when the lens model is trusted over the image; F finishes early (>= 6 views).";
    } else if (step == "mirror") {
      title = "Mirror (rim and centre)";
      // The mirror frame: the reflecting face in z = 0, its centre at the origin.
      for (int i = 0; i < kMirrorRimPoints; ++i) {
        const double a = 2 * M_PI * i / kMirrorRimPoints;
        known.emplace_back(st.calibration.mirror_radius_m * std::cos(a), st.calibration.mirror_radius_m * std::sin(a), 0);
      }
      known.emplace_back(0, 0, 0);
      instruction = "Clamp the mirror where the camera sees the mannequin's tags and the mirror's tag. Touch the\n"
                    "rim of the reflecting face at the points shown (going round), then its centre; hold still\n"
                    "and press SPACE for each.";
    } else {
      title = "Check (known points)";
      // Check points in the mannequin frame: the tooth's landmarks (through the calibrated tooth
      // placement) and the first and last divots.
      for (const auto& p : st.fixtures.landmarks_tooth) known.push_back(st.calibration.T_man_tooth * p);
      known.push_back(st.fixtures.divots_man.front());
      known.push_back(st.fixtures.divots_man.back());
      instruction = "Touch each known point in the order shown; the HUD shows how far the calibrated bur tip is\n"
                    "from it. The station passes when the mean error is within its threshold.";
    }
  }

  // The simulated instructor's motions and presses for this step.
  Status plan_instructor() {
    if (sim && step != "camera") {
      if (step == "pivot") {
        plan = instructor->pivot(last_pose);
      } else {
        std::vector<Eigen::Vector3d> tdev;
        Eigen::Vector3d approach;
        if (step == "register") {
          for (const auto& p : known) tdev.push_back(truth.T_man_dev.inverse() * p);
          approach = truth.T_man_dev.inverse().linear() * Eigen::Vector3d(0, 0, -1);  // into the face
        } else if (step == "mirror") {
          const Eigen::Isometry3d T_man_mir = cal::simulated_mirror_clamp_man() * truth.T_mtag_mir;
          for (int i = 0; i < kMirrorRimPoints; ++i) {
            const double a = 2 * M_PI * i / kMirrorRimPoints;
            tdev.push_back(truth.T_man_dev.inverse() *
                           (T_man_mir * Eigen::Vector3d(truth.mirror_radius_m * std::cos(a), truth.mirror_radius_m * std::sin(a), 0)));
          }
          tdev.push_back(truth.T_man_dev.inverse() * T_man_mir.translation());
          approach = truth.T_man_dev.inverse().linear() * (T_man_mir.linear() * Eigen::Vector3d(0, 0, -1));
        } else if (step == "check") {
          // The true places of the check points (the calibrated ones are what the HUD compares).
          for (const auto& p : st.fixtures.landmarks_tooth) tdev.push_back(truth.T_man_dev.inverse() * (truth.T_man_tooth * p));
          tdev.push_back(truth.T_man_dev.inverse() * st.fixtures.divots_man.front());
          tdev.push_back(truth.T_man_dev.inverse() * st.fixtures.divots_man.back());
          approach = truth.T_man_dev.inverse().linear() * (truth.T_man_tooth.linear() * Eigen::Vector3d(0, 0, -1));
        } else {
          for (const auto& p : known) tdev.push_back(truth.T_man_dev.inverse() * (truth.T_man_tooth * p));
          approach = truth.T_man_dev.inverse().linear() * (truth.T_man_tooth.linear() * Eigen::Vector3d(0, 0, -1));
        }
        plan = instructor->touches(tdev, approach, last_pose, step == "register" ? 2 : -1);
      }
      auto d = instructor->device(plan);
      if (!d) return Error{"calibrate live: simulated instructor: " + d.error()};
      if (!poller) poller = std::make_unique<Poller>(std::move(*d), true);
      else poller->swap(std::move(*d));
      poller->hold_at(std::numeric_limits<double>::infinity());
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return {};
  }

  // The camera step's views and board detector.
  Status camera_state() {
    cal::LiveCameraOptions lco;
    lco.target_views = o.camera_views;
    cam = std::make_unique<cal::LiveCameraViews>(vw, vh, lco);
    auto d = ar::BoardDetector::create(board_spec);
    if (!d) return Error{"calibrate live: " + d.error()};
    board_det = std::make_unique<ar::BoardDetector>(std::move(*d));
    return {};
  }

  void loop() {
    while (!step_done) {
      if (win.should_close()) {
        sum.stop_reason = "window closed";
        aborted = true;
        break;
      }
      if (g_cal_signal.load() != 0) {
        sum.stop_reason = g_cal_signal.load() == SIGINT ? "SIGINT" : "SIGTERM";
        aborted = true;
        break;
      }
      if (o.seconds > 0 && wall_s() - t_start > o.seconds) {
        sum.stop_reason = "time limit";
        aborted = true;
        break;
      }
      win.poll();
      const double now = wall_s();
      const Poller::Sample s = poller ? poller->latest() : Poller::Sample{};
      const std::vector<Poller::Sample> fresh = poller ? poller->since(last_seen) : std::vector<Poller::Sample>{};
      if (!fresh.empty()) last_seen = fresh.back().t_s;
      // The scripted instructor's key, through the window's key queue, on the hand's own clock.
      while (sim && s.valid && next_press < plan.presses.size() && s.t_s >= plan.presses[next_press].t_s) {
        const int want = plan.presses[next_press].target;
        if (want < 0 || (step != "pivot" && want == touches.next())) {
          win.inject_key(GLFW_KEY_SPACE);
        }
        ++next_press;
      }
      if (sim && step != "pivot" && step != "camera") {
        const auto i = static_cast<std::size_t>(touches.next());
        poller->hold_at(i < plan.rest.size() ? plan.rest[i].second - 0.05 : std::numeric_limits<double>::infinity());
        if (s.valid && i < plan.rest.size() && s.t_s >= plan.rest[i].first + 0.6 && s.t_s <= plan.rest[i].second &&
            touches.still() && now - last_sim_press_wall >= 0.5) {
          win.inject_key(GLFW_KEY_SPACE);
          last_sim_press_wall = now;
        }
      }
      if (capture) {
        ar::Frame f;
        if (capture->wait_take(f, 0.0)) {
          if (cam) win.set_video(camera_view(f, *cam, *board_det));
          else {
            if (step == "mirror" && !sim) track_mirror(f);
            win.set_video(f.image);
          }
        }
      }
      // The simulated instructor with the board: presses once the board has been still 0.8 s
      // (as the HUD shows it), once per hold; once while the board still moves (refused); F
      // when the footage came round again (three views in a row too similar)
      if (sim && cam) {
        const double still = cam->still_for_s();
        if (still <= 0) press_latch = false;
        if (!moving_press_done && cam->views() >= 2 && cam->board_seen() && still <= 0) {
          win.inject_key(GLFW_KEY_SPACE);
          moving_press_done = true;
        } else if (!press_latch && still >= 0.8) {
          win.inject_key(GLFW_KEY_SPACE);
          press_latch = true;
        }
        // (from the target number of views on: a slow machine that missed holds goes round again)
        if (similar_in_row >= 3 && cam->views() >= cam->options().target_views) win.inject_key(GLFW_KEY_F);
      }
      if (s.valid) last_pose = s.T_dev_sty;
      // A take: a key press, a pedal press or a stylus button press (edges).
      bool take = false;
      for (int k : win.take_presses()) {
        if (k == GLFW_KEY_SPACE || k == GLFW_KEY_ENTER || k == GLFW_KEY_KP_ENTER) take = true;
        if (k == GLFW_KEY_F) finish = true;
        if (k == GLFW_KEY_ESCAPE) {
          sum.stop_reason = "Esc";
          aborted = true;
        }
      }
      if (aborted) break;
      const bool pedal_now = pedal && pedal->pressed();
      if (pedal_now && !last_pedal) take = true;
      last_pedal = pedal_now;
      if (s.valid && (s.buttons & ~last_buttons) != 0) take = true;
      last_buttons = s.valid ? s.buttons : 0;
      if (step == "camera") camera_tick(take);
      else if (step == "pivot") pivot_tick(take, fresh, s.valid ? s.t_s : -1e300);
      else touch_tick(take, fresh, now);
      draw_hud(s, now);
      const cv::Mat px = win.end_frame(step_done && !o.screenshot_dir.empty());
      if (!px.empty()) shot = px;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }

  void track_mirror(const ar::Frame& f) { S.track_mirror(f); }

  void camera_tick(bool take) {
    if (take) {
      const cal::CameraTake r = cam->take();
      say(r.message);
      if (r.ok) {
        refusal.clear();
        similar_in_row = 0;
      } else {
        refusal = r.message;
        if (r.message.find("too similar") != std::string::npos) ++similar_in_row;
      }
    }
    // The model selection (seconds) runs beside the window; its trust map drives the
    // suggestion and the stop.
    if (pending.valid() && pending.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
      last_sel = pending.get();
      cam->set_trust(last_sel.trust, pending_views);
    }
    const int min_views = cam->options().intrinsics.min_views;
    if (!pending.valid() && cam->views() >= min_views && cam->views() != cam->trust_views()) {
      pending_views = cam->views();
      pending = std::async(std::launch::async, [v = cam->taken(), w = vw, h = vh] {
        return cal::select_camera_model(v, w, h, cal::ModelSelectionOptions{});
      });
    }
    if (finish) {
      if (cam->views() >= min_views) step_done = true;
      else refusal = "F: at least " + std::to_string(min_views) + " views are needed (" + std::to_string(cam->views()) + " taken)";
      finish = false;
    }
    if (cam->done()) step_done = true;
  }

  // `newest_s`: the device time of the newest sample when the press was seen. Session 23: the
  // poses are collected from it on. `fresh` holds every sample since the window's last pass (up
  // to 3 s): on a loaded machine a pass came seconds after the last, and the poses of the stylus
  // still arriving at the divot before the press went into the fit; the tip was never known to
  // 0.2 mm and the step never ended (CI at load 28: pivot not passed in 400 s).
  void pivot_tick(bool take, const std::vector<Poller::Sample>& fresh, double newest_s) {
    if (take) {  // the tip is seated: (re)start collecting
      pivot = cal::LivePivot();
      collecting = true;
      collect_from_s = newest_s;
      say("pivot: collecting poses");
    }
    if (collecting)
      for (const auto& x : fresh)
        if (x.valid && x.t_s >= collect_from_s) pivot.add(x.T_dev_sty);
    if (pivot.done()) step_done = true;
  }

  void touch_tick(bool take, const std::vector<Poller::Sample>& fresh, double now) {
    for (const auto& x : fresh) {
      const Eigen::Vector3d tip_dev = (x.T_dev_sty * st.calibration.T_sty_tip).translation();
      // register: device frame; the others: mannequin frame (through the registration).
      const Eigen::Vector3d tip = step == "register" ? tip_dev : Eigen::Vector3d(st.calibration.T_man_dev * tip_dev);
      touches.add_sample(x.t_s, x.valid ? tip : Eigen::Vector3d::Constant(NAN));
    }
    // The mirror's pose at the touch: tracked (the mirror tag and the mannequin's tags in
    // the latest frame) or, simulated, the clamp's true pose with the tracking noise.
    std::optional<Eigen::Isometry3d> T_mtag_man_now;
    if (step == "mirror" && take) {
      if (sim) {
        const cal::StylusNoise noise;
        T_mtag_man_now = (cal::simulated_mirror_clamp_man() *
                          cal::random_perturbation(noise.tracking_sigma_rad * std::sqrt(2.0),
                                                   noise.tracking_sigma_m * std::sqrt(2.0), mirror_rng))
                             .inverse();
      } else if (mirror_track.valid && now - mirror_track.when_s < 0.3) {
        T_mtag_man_now = mirror_track.T_mtag_man;
      } else {
        take = false;
        refusal = "touch refused: the camera does not see both the mirror's tag and the mannequin's tags "
                  "(turn the camera or the mirror so both are in view)";
        say(refusal);
      }
    }
    if (take) {
      const int which = touches.next();
      const cal::TouchResult r = touches.take();
      if (r.ok) {
        refusal.clear();
        std::string line = what + " " + std::to_string(which) + " taken";
        if (step == "register" || step == "tooth") {
          fit = cal::running_fit(touches.taken_dev(), known, target_fit);
          if (!fit.residuals_m.empty())
            line += ": FRE " + fmt(fit.fre_m * 1e3, 3) + " mm, predicted TRE at the tooth " + fmt(fit.tre_m * 1e3, 3) + " mm";
        } else if (step == "mirror") {
          mirror_mtag.push_back(*T_mtag_man_now * touches.taken_dev().back());
        } else {
          const Eigen::Vector3d& p = touches.taken_dev().back();
          Eigen::Vector3d err = p - known[static_cast<std::size_t>(which)];
          if (which < n_landmarks)  // the error at the tooth, in the tooth frame
            err = st.calibration.T_man_tooth.linear().transpose() * err;
          check_err.push_back(err.norm());
          double m = 0;
          for (double e : check_err) m += e;
          line += ": error " + fmt(check_err.back() * 1e3, 3) + " mm (mean so far " + fmt(m / check_err.size() * 1e3, 3) + " mm)";
        }
        say(line);
      } else if (!touches.done()) {
        refusal = r.message;
        say(r.message);
      }
    }
    if (touches.done()) step_done = true;
  }

  void draw_hud(const Poller::Sample& s, double now) {
    win.begin_frame();
    ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_Always);
    ImGui::SetNextWindowBgAlpha(0.7f);
    ImGui::Begin("Station calibration", nullptr, ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoMove);
    ImGui::Text("step %d of %zu: %s   (%.0f s)", static_cast<int>(sum.steps.size()) + 1, o.steps.size(), title.c_str(),
                now - t0);
    ImGui::TextUnformatted(instruction.c_str());
    ImGui::Separator();
    if (step != "camera")
      ImGui::TextColored(s.valid ? green : red, "stylus: %s", s.valid ? poller->name().c_str() : "no pose (device fault?)");
    if (step == "camera") {
      const cal::CoverageMap cm = cam->coverage();
      ImGui::Text("views %d (stops itself from %d when the image is trusted)   refused %d", cam->views(),
                  cam->options().target_views, cam->refused());
      ImGui::TextColored(!cam->board_seen() ? red : !cam->last_layout_ok() ? red : cam->still() ? green : yellow, "%s",
                         cam->status().c_str());
      const cal::IntrinsicsSummary& run = cam->running();
      if (run.calibrations_run > 0 && run.std_devs.size() >= 4)
        ImGui::Text("RMS %.3f px   fx %.1f +- %.2f   fy %.1f +- %.2f   cx %.1f +- %.2f   cy %.1f +- %.2f px (1 sigma)",
                    run.rms_px, run.camera.fx, run.std_devs[0], run.camera.fy, run.std_devs[1], run.camera.cx,
                    run.std_devs[2], run.camera.cy, run.std_devs[3]);
      else
        ImGui::Text("RMS and the uncertainty of fx fy cx cy appear from view %d on", cam->options().intrinsics.min_views);
      ImGui::Text("coverage: board points in %.0f%% of the image, %.0f%% of the tooth region", cm.image_fraction * 100,
                  cm.tooth_fraction * 100);
      if (cam->trust_views() > 0)
        ImGui::Text("lens model (%d views, %s): trusted to %.1f px over %.0f%% of the image, %.0f%% of the tooth region",
                    cam->trust_views(), last_sel.ok ? cal::distortion_model_name(last_sel.model) : "no model yet",
                    cam->trust().max_error_px, cam->trust().trusted_fraction * 100, cam->trust().tooth_trusted_fraction * 100);
      if (pending.valid()) ImGui::TextUnformatted("choosing the lens model on held-out views...");
      int sc = 0, sr = 0;
      std::string sug;
      if (cam->suggestion(sc, sr, sug)) ImGui::TextColored(ImVec4(0.3f, 0.9f, 1, 1), "%s", sug.c_str());
      if (!refusal.empty()) ImGui::TextColored(red, "%s", refusal.c_str());
      ImGui::TextUnformatted("keys: SPACE / pedal take a view   F finish   Esc stop");
    } else if (step == "pivot") {
      const cal::PivotSummary& c = pivot.current();
      ImGui::Text("poses %d   spread %.1f deg   weakest %.1f deg", pivot.poses(), c.spread_rad / kDeg,
                  c.weakest_tilt_rad / kDeg);
      if (c.ok) ImGui::Text("RMSE %.3f mm   predicted tip error %.3f mm (stops at %.2f mm)", c.rmse_m * 1e3,
                            std::isfinite(pivot.tip_sd_m()) ? pivot.tip_sd_m() * 1e3 : 99.0,
                            pivot.options().target_tip_sd_m * 1e3);
      if (!collecting)
        ImGui::TextColored(yellow, "seat the bur tip in the pivot divot, then press SPACE and start rocking");
      else if (c.ok && c.rmse_m > 1e-3)
        ImGui::TextColored(red, "the tip slipped out of the divot (RMSE %.2f mm): seat it and press SPACE to restart",
                           c.rmse_m * 1e3);
      else
        ImGui::TextColored(pivot.done() ? green : yellow, "%s", pivot.hint().c_str());
    } else {
      for (int i = 0; i < touches.count(); ++i) {
        const bool taken = i < touches.next(), current = i == touches.next();
        const Eigen::Vector3d& k = known[static_cast<std::size_t>(i)];
        ImGui::TextColored(taken ? green : current ? yellow : ImVec4(0.8f, 0.8f, 0.8f, 1), "%s %s %d  (%.1f, %.1f, %.1f) mm%s",
                           taken ? "[x]" : current ? "[>]" : "[ ]", what.c_str(), i,
                           k.x() * 1e3, k.y() * 1e3, k.z() * 1e3,
                           step == "check" && taken && static_cast<std::size_t>(i) < check_err.size()
                               ? ("   error " + fmt(check_err[static_cast<std::size_t>(i)] * 1e3, 3) + " mm").c_str()
                           : step == "mirror" && i == touches.count() - 1 ? "   (centre)"
                           : taken && !fit.residuals_m.empty() && static_cast<std::size_t>(i) < fit.residuals_m.size()
                               ? ("   residual " + fmt(fit.residuals_m[static_cast<std::size_t>(i)] * 1e3, 2) + " mm").c_str()
                               : "");
      }
      if (step == "check" && !check_err.empty()) {
        double m = 0;
        for (double e : check_err) m += e;
        m /= check_err.size();
        const double thr = st.policy.check_threshold_m;
        ImGui::TextColored(m <= thr ? green : red, "mean error %.3f mm (station threshold %.2f mm): %s so far", m * 1e3,
                           thr * 1e3, m <= thr ? "PASS" : "FAIL");
      }
      if (!fit.residuals_m.empty())
        ImGui::Text("FRE %.3f mm   predicted TRE at the tooth %.3f mm", fit.fre_m * 1e3, fit.tre_m * 1e3);
      ImGui::TextColored(touches.still() ? green : yellow, "%s",
                         touches.still() ? "stylus still: press SPACE to take the touch" : "stylus moving");
      if (!refusal.empty()) ImGui::TextColored(red, "%s", refusal.c_str());
    }
    ImGui::End();
  }

  // The step's result into rec and rep.
  Status result(ar::CalibrationStepReport& rep) {
    if (step == "pivot") {
      const cal::PivotSummary r = pivot.final_result();
      rec.items = r.num_poses;
      rec.pass = r.ok;
      rec.message = r.report();
      if (r.ok) {
        st.calibration.T_sty_tip = r.T_sty_tip;
        rep.summary = "live: tip at " + fmt(r.p_tip_sty.norm() * 1e3) + " mm from the stylus origin";
        rep.figures = {{"rmse_mm", r.rmse_m * 1e3},
                       {"tip_sd_mm", std::sqrt(r.cov_tip_sty.trace()) * 1e3},
                       {"spread_deg", r.spread_rad / kDeg},
                       {"poses", r.num_poses}};
      }
    } else if (step == "register") {
      const cal::RegistrationSummary r = cal::register_divots(touches.taken_dev(), known, target_fit);
      rec.items = touches.next();
      rec.refused = touches.refused();
      rec.pass = r.ok;
      rec.message = r.report();
      if (r.ok) {
        st.calibration.T_man_dev = r.T_man_dev;
        rep.summary = "live: " + std::to_string(r.num_points) + " divots";
        rep.figures = {{"fre_mm", r.fre_m * 1e3}, {"tre_mm", r.tre_m * 1e3}, {"fle_mm", r.fle_m * 1e3},
                       {"divots", r.num_points}, {"refused_touches", touches.refused()}};
        // Where the device now stands: can its stylus reach the whole crown (station_health.h)?
        if (!sim) {
          auto box = crown_box_tooth(st);
          if (!box) return Error{"calibrate live: " + box.error()};
          const StationReach reach = check_station_reach(st, real_limits, real_name, *box);
          say("stylus reach: " + reach.item.message);
          rep.figures.emplace_back("reach_margin_mm", (reach.reach.reach_m - reach.reach.worst_distance_m) * 1e3);
        }
      }
    } else if (step == "camera") {
      if (pending.valid()) pending.wait();
      say("choosing the lens model on held-out views (" + std::to_string(cam->views()) + " views)...");
      const cal::ModelSelection sel = cal::select_camera_model(cam->taken(), vw, vh, cal::ModelSelectionOptions{});
      {
        std::istringstream lines(sel.report());
        for (std::string l; std::getline(lines, l);) say(l);
      }
      rec.items = cam->views();
      rec.refused = cam->refused();
      rec.pass = sel.ok;
      rec.message = sel.message;
      if (sel.ok) {
        const cal::CameraFile cf = sel.to_camera_file(camera_id.empty() ? o.camera : camera_id);
        st.calibration.camera = cf.camera;
        st.camera_provenance = ar::CameraProvenance{};
        st.camera_provenance.model = cf.model;
        st.camera_provenance.rms_px = cf.rms_px;
        st.camera_provenance.std_devs = cf.std_devs;
        st.camera_provenance.date = cf.date;
        st.camera_provenance.device = cf.device;
        st.camera_provenance.device_id = camera_id;
        camera_file = cf;
        rep.summary = "live: fx " + fmt(cf.camera.fx) + " fy " + fmt(cf.camera.fy) + " px, distortion terms " +
                      cal::distortion_model_name(sel.model) + " (chosen on held-out views), trustworthy to " +
                      fmt(sel.trust.max_error_px, 1) + " px over " + fmt(sel.trust.trusted_fraction * 100, 0) + "% of the image";
        rep.figures = {{"rms_px", cf.rms_px}};
        if (cf.std_devs.size() >= 4)
          rep.figures.insert(rep.figures.end(), {{"fx_sd_px", cf.std_devs[0]}, {"fy_sd_px", cf.std_devs[1]},
                                                 {"cx_sd_px", cf.std_devs[2]}, {"cy_sd_px", cf.std_devs[3]}});
        rep.figures.emplace_back("views", cf.views_used);
        rep.figures.emplace_back("refused_views", cam->refused());
        for (const auto& c : sel.candidates)
          if (c.model == sel.model) rep.figures.emplace_back("heldout_rms_px", c.heldout_rms_px);
        rep.figures.emplace_back("distortion_terms", cal::free_coefficient_count(sel.model));
        rep.figures.emplace_back("trusted_image_pct", sel.trust.trusted_fraction * 100);
        rep.figures.emplace_back("trusted_tooth_pct", sel.trust.tooth_trusted_fraction * 100);
        // Footage from `dentar synth --board` carries its true camera: the chosen model against it.
        if (o.camera.rfind("live:", 0) == 0) {
          const fs::path truth_yaml = fs::path(o.camera.substr(5)).parent_path() / "camera.yaml";
          if (fs::exists(truth_yaml)) {
            if (auto t = cal::read_camera_file(truth_yaml.string()); t && t->camera.width == vw && t->camera.height == vh) {
              const cal::Lens ref = cal::Lens::from(t->camera), est = cal::Lens::from(sel.chosen);
              std::vector<Eigen::Vector2d> fit_px;
              for (const auto& v : cam->taken()) fit_px.insert(fit_px.end(), v.image_points.begin(), v.image_points.end());
              const Eigen::Matrix3d R = cal::align_rotation(ref, est, fit_px);
              double worst = 0, worst_tooth = 0;
              const auto& tr = cal::IntrinsicsOptions{}.tooth_region;
              for (int v = 0; v < vh; v += 8)
                for (int u = 0; u < vw; u += 8) {
                  const double e = cal::projection_error_px(ref, est, R, u, v);
                  if (!std::isfinite(e)) continue;
                  worst = std::max(worst, e);
                  if (u >= tr[0] * vw && u <= tr[2] * vw && v >= tr[1] * vh && v <= tr[3] * vh) worst_tooth = std::max(worst_tooth, e);
                }
              sum.truth_camera_fx_error_px = std::abs(sel.chosen.camera.fx - t->camera.fx);
              sum.truth_camera_max_px = worst;
              sum.truth_camera_tooth_max_px = worst_tooth;
              say("footage truth (" + truth_yaml.string() + "): fx error " + fmt(sum.truth_camera_fx_error_px, 2) +
                  " px; projection error over the whole image at most " + fmt(worst, 2) + " px, over the tooth region " +
                  fmt(worst_tooth, 2) + " px");
            }
          }
        }
      }
    } else if (step == "mirror") {
      rec.items = touches.next();
      rec.refused = touches.refused();
      std::vector<Eigen::Vector3d> rim(mirror_mtag.begin(), mirror_mtag.end() - (mirror_mtag.empty() ? 0 : 1));
      const Eigen::Vector3d centre = mirror_mtag.empty() ? Eigen::Vector3d::Constant(NAN) : mirror_mtag.back();
      const cal::MirrorSummary r = cal::calibrate_mirror(rim, centre, st.calibration.T_mtag_mir);
      rec.pass = r.ok;
      rec.message = r.report();
      if (r.ok) {
        if (sim)
          say("simulation truth: mirror centre error " +
              fmt((r.T_mtag_mir.translation() - truth.T_mtag_mir.translation()).norm() * 1e3, 3) + " mm, radius error " +
              fmt((r.radius_m - truth.mirror_radius_m) * 1e3, 3) + " mm");
        st.calibration.T_mtag_mir = r.T_mtag_mir;
        st.calibration.mirror_radius_m = r.radius_m;
        rep.summary = "live: radius " + fmt(r.radius_m * 1e3) + " mm";
        rep.figures = {{"radius_mm", r.radius_m * 1e3},
                       {"plane_rms_mm", r.plane_rms_m * 1e3},
                       {"circle_rms_mm", r.circle_rms_m * 1e3},
                       {"centre_error_mm", r.centre_error_m * 1e3},
                       {"refused_touches", touches.refused()}};
      }
    } else if (step == "check") {
      rec.items = touches.next();
      rec.refused = touches.refused();
      double m = 0, mx = 0;
      for (double e : check_err) {
        m += e;
        mx = std::max(mx, e);
      }
      m = check_err.empty() ? NAN : m / check_err.size();
      const double thr = st.policy.check_threshold_m;
      rec.pass = std::isfinite(m) && m <= thr;
      rec.message = std::string(rec.pass ? "check PASSED" : "check FAILED") + ": mean error at the " +
                    std::to_string(check_err.size()) + " known points " + fmt(m * 1e3, 3) + " mm, max " + fmt(mx * 1e3, 3) +
                    " mm; station threshold " + fmt(thr * 1e3, 2) + " mm" +
                    (rec.pass ? "" : ": repeat the steps with the worst figures (the failed check is recorded)");
      rep.summary = "live: " + std::to_string(check_err.size()) + " known points touched";
      rep.figures = {{"error_mean_mm", m * 1e3}, {"error_max_mm", mx * 1e3}, {"points", static_cast<double>(check_err.size())},
                     {"threshold_mm", thr * 1e3}, {"refused_touches", touches.refused()}};
      if (!rec.pass && all_pass) record_failure = true;
    } else {
      const cal::LandmarkSummary r = cal::refine_tooth_placement(known, touches.taken_dev(), st.calibration.T_man_tooth);
      rec.items = touches.next();
      rec.refused = touches.refused();
      rec.pass = r.ok;
      rec.message = r.report();
      if (r.ok) {
        st.calibration.T_man_tooth = r.T_man_tooth;
        rep.summary = "live: " + std::to_string(r.fit.num_points) + " landmarks";
        rep.figures = {{"fre_mm", r.fit.fre_m * 1e3}, {"tre_mm", r.fit.tre_m * 1e3}, {"shift_mm", r.shift_m * 1e3},
                       {"rotation_deg", r.rotation_rad / kDeg}, {"refused_touches", touches.refused()}};
      }
    }
    return {};
  }

  CalSession& S;
  const CalibrateLiveOptions& o;
  CalibrateLiveSummary& sum;
  const std::function<void(const std::string&)>& say;
  ar::StationScene& st;
  const bool sim;
  const cal::StationCalibration& truth;
  std::unique_ptr<SimInstructor>& instructor;
  std::unique_ptr<Poller>& poller;
  const haptics::DeviceLimits& real_limits;
  const std::string& real_name;
  std::unique_ptr<haptics::Pedal>& pedal;
  std::unique_ptr<ar::CaptureThread>& capture;
  const int vw, vh;
  HudWindow& win;
  const double& t_start;
  Eigen::Isometry3d& last_pose;
  bool &all_pass, &aborted;
  std::uint32_t& last_buttons;
  bool &last_pedal, &record_failure;
  std::optional<cal::CameraFile>& camera_file;
  const std::string& camera_id;
  const ar::BoardSpec& board_spec;
  std::mt19937_64& mirror_rng;
  decltype(CalSession::mirror_track)& mirror_track;
  const Eigen::Vector3d crown_tooth = kCrownTooth;
  const ImVec4 green{0.3f, 1, 0.3f, 1}, yellow{1, 0.85f, 0.2f, 1}, red{1, 0.35f, 0.35f, 1};

  const std::string step;
  const int n_landmarks;
  CalibrateLiveStep rec;
  std::vector<Eigen::Vector3d> known;  // register: divots (man); tooth: landmarks (tooth)
  std::string title, instruction;
  Eigen::Vector3d target_fit = Eigen::Vector3d::Zero();  // where the TRE is predicted, in the known points' frame
  Plan plan;
  cal::LivePivot pivot;
  bool collecting = false;
  double collect_from_s = -1e300;  // pivot: device time of the press (poses from it on)
  std::string what;
  cal::LiveTouches touches{"", 0};
  std::vector<Eigen::Vector3d> mirror_mtag;  // mirror: the touches in the mirror tag's frame
  std::vector<double> check_err;             // check: error at each point, m
  // ---- camera step state ----
  std::unique_ptr<cal::LiveCameraViews> cam;
  std::unique_ptr<ar::BoardDetector> board_det;  // the camera step's board, any kind
  std::future<cal::ModelSelection> pending;
  int pending_views = 0;
  cal::ModelSelection last_sel;
  bool finish = false, press_latch = false, moving_press_done = false;
  int similar_in_row = 0;
  cal::RegistrationSummary fit;
  std::string refusal;
  std::size_t next_press = 0;
  double last_sim_press_wall = -1e300;  // wall time of the simulated instructor's last press
  double last_seen = -1e300;
  double t0 = 0;
  bool step_done = false;
  cv::Mat shot;
};

void CalSession::truth_figures() {
  const Eigen::Vector3d& crown_tooth = kCrownTooth;

  bool stylus_steps = false;
  for (const auto& r : sum.steps) stylus_steps |= r.step != "camera";
  if (sim && stylus_steps) {
    sum.truth_tip_error_mm = (st.calibration.T_sty_tip.translation() - truth.T_sty_tip.translation()).norm() * 1e3;
    const Eigen::Vector3d q_dev_cal = st.calibration.T_man_dev.inverse() * (st.calibration.T_man_tooth * crown_tooth);
    const Eigen::Vector3d q_dev_true = truth.T_man_dev.inverse() * (truth.T_man_tooth * crown_tooth);
    sum.truth_tooth_error_mm = (q_dev_cal - q_dev_true).norm() * 1e3;
    // The static chain at working poses: the bur tip within 3 mm of the crown, the stylus
    // tilted up to 25 degrees: where the calibrated chain draws the tip on the tooth vs truth.
    std::mt19937_64 rng(o.seed + 17);
    std::uniform_real_distribution<double> u(-1, 1);
    std::vector<double> err;
    const Eigen::Vector3d approach = truth.T_man_dev.inverse().linear() * (truth.T_man_tooth.linear() * Eigen::Vector3d(0, 0, -1));
    for (int i = 0; i < 500; ++i) {
      const Eigen::Vector3d tip_tooth = crown_tooth + 3e-3 * Eigen::Vector3d(u(rng), u(rng), u(rng));
      const Eigen::Matrix3d R = (Eigen::AngleAxisd(25 * kDeg * std::abs(u(rng)),
                                                   Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized()) *
                                 pointing(approach, u(rng) * M_PI))
                                    .toRotationMatrix();
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.linear() = R;
      T.translation() = truth.T_man_dev.inverse() * (truth.T_man_tooth * tip_tooth) - R * truth.T_sty_tip.translation();
      const Eigen::Vector3d drawn = (st.calibration.T_tooth_dev() * T * st.calibration.T_sty_tip).translation();
      const Eigen::Vector3d real = (truth.T_tooth_dev() * T * truth.T_sty_tip).translation();
      err.push_back((drawn - real).norm() * 1e3);
    }
    double m = 0;
    for (double e : err) m += e;
    sum.truth_static_colocation_mean_mm = m / err.size();
    sum.truth_static_colocation_p99_mm = percentile(err, 0.99);
    say("simulation truth: tip error " + fmt(sum.truth_tip_error_mm, 3) + " mm; error at the crown " +
        fmt(sum.truth_tooth_error_mm, 3) + " mm; bur tip vs tooth at working poses mean " +
        fmt(sum.truth_static_colocation_mean_mm, 3) + " mm, p99 " + fmt(sum.truth_static_colocation_p99_mm, 3) + " mm");
  }
}

Status CalSession::write_results() {
  if ((all_pass || record_failure) && !aborted) {
    st.version = ar::kStationFileVersion;
    if (const fs::path dir = fs::path(o.station).parent_path(); !dir.empty()) fs::create_directories(dir);
    if (camera_file) {
      const std::string yaml = (fs::path(o.station).parent_path() / (fs::path(o.station).stem().string() + ".camera.yaml")).string();
      if (Status w = cal::write_camera_file(yaml, *camera_file); !w) return Error{"calibrate live: " + w.error()};
      say("wrote the camera file " + yaml);
    }
    if (auto w = ar::write_station_scene(st, o.station); !w) return Error{"calibrate live: " + w.error()};
    sum.written = true;
    say(record_failure ? "recorded the FAILED check in " + o.station + " (dentar live will ask for an instructor)"
                       : "updated " + o.station);
  } else {
    say(o.station + " was NOT written (" + sum.stop_reason + ")");
  }
  if (!o.summary_path.empty()) {
    if (const fs::path dir = fs::path(o.summary_path).parent_path(); !dir.empty()) fs::create_directories(dir);
    std::ofstream f(o.summary_path);
    f << sum.json();
    if (!f) say("cannot write the summary " + o.summary_path);
  }
  return {};
}

}  // namespace

Result<CalibrateLiveSummary> run_calibrate_live(const CalibrateLiveOptions& o) {
  if (auto v = o.validate(); !v.empty()) return Error{"calibrate live: " + v};
  CalibrateLiveSummary sum;
  CalSession S(o, sum);
  // ---- station, device, camera, window ----
  auto str = calibration_station(o, S.say);
  if (!str) return Error{str.error()};
  S.st = std::move(*str);
  if (auto s = S.open(); !s) return Error{s.error()};
  std::signal(SIGINT, on_cal_signal);
  std::signal(SIGTERM, on_cal_signal);
  g_cal_signal.store(0);
  if (!o.screenshot_dir.empty()) fs::create_directories(o.screenshot_dir);
  S.t_start = wall_s();
  // ---- the steps, in order, until one does not pass ----
  for (const std::string& step : o.steps) {
    auto r = StepRun(S, step).run();
    if (!r) return Error{r.error()};
    if (!*r) break;
  }
  if (S.capture) S.capture->stop();
  S.poller.reset();
  sum.total_s = wall_s() - S.t_start;
  if (sum.stop_reason.empty()) sum.stop_reason = S.all_pass ? "all steps passed" : "a step did not pass";
  S.truth_figures();
  if (auto s = S.write_results(); !s) return Error{s.error()};
  return sum;
}



// ---- `dentar calibrate stereo --live` (issue 28) ----

bool is_live_camera_spec(const std::string& s) {
  return s.rfind("camera:", 0) == 0 || s.rfind("/dev/video", 0) == 0 || s.rfind("live:", 0) == 0;
}

std::string StereoLiveOptions::validate() const {
  if (side_by_side.empty() && (left.empty() || right.empty()))
    return "give --left SPEC --right SPEC (two cameras: camera:N, /dev/videoN, live:FILE, a video file or a frames "
           "folder) or --side-by-side SPEC (one device)";
  if (!side_by_side.empty() && (!left.empty() || !right.empty()))
    return "give either --side-by-side SPEC or --left/--right, not both";
  if (count < 1 || count > 500) return "count = " + std::to_string(count) + " must be in 1..500";
  if (!(std::isfinite(seconds) && seconds >= 0)) return "seconds must be >= 0";
  if (!(std::isfinite(stall_timeout_s) && stall_timeout_s > 0))
    return "stall_timeout_s (--stall-timeout) must be > 0 s";
  return {};
}

namespace {

// Which eye of the head went quiet, for the stall message.
std::string silent_eyes(const StereoLiveOptions& o, bool left_silent, bool right_silent) {
  if (!o.side_by_side.empty()) return "the side-by-side camera (" + o.side_by_side + ")";
  if (left_silent && right_silent) return "both eyes (" + o.left + ", " + o.right + ")";
  return left_silent ? "the left eye (" + o.left + ")" : "the right eye (" + o.right + ")";
}

}  // namespace

Result<StereoLiveCaptures> capture_stereo_live(const StereoLiveOptions& o) {
  if (std::string v = o.validate(); !v.empty()) return Error{v};
  auto say = [&](const std::string& line) {
    if (o.say) o.say(line);
  };
  ar::StereoSourceOptions so;
  so.left_capture = o.left_capture;
  so.right_capture = o.right_capture;
  Result<std::unique_ptr<ar::StereoSource>> src = !o.side_by_side.empty()
                                                      ? ar::StereoSource::open_side_by_side(o.side_by_side, so)
                                                      : ar::StereoSource::open_pair(o.left, o.right, so);
  if (!src) return Error{src.error()};
  ar::StereoSource& eyes = **src;
  const bool live = !o.side_by_side.empty() ? is_live_camera_spec(o.side_by_side)
                                            : is_live_camera_spec(o.left) || is_live_camera_spec(o.right);
  StereoLiveCaptures out;
  out.width = eyes.width();
  out.height = eyes.height();
  auto spec = ar::parse_board_spec(o.board);
  if (!spec) return Error{spec.error()};
  auto dl = ar::BoardDetector::create(*spec), dr = ar::BoardDetector::create(*spec);
  if (!dl || !dr) return Error{dl ? dr.error() : dl.error()};
  cal::LiveCameraOptions lo;
  lo.target_views = std::min(o.count, lo.max_views);
  cal::LiveCameraViews vl(out.width, out.height, lo), vr(out.width, out.height, lo);
  say("live stereo head: " + eyes.description() + ", " + std::to_string(out.width) + "x" + std::to_string(out.height) +
      " per eye; hold the board still where both eyes see it: a capture is taken by itself when it is still and new (" +
      std::to_string(o.count) + " wanted)");
  const double t0 = ar::steady_now_s();
  // Each eye's newest frame, steady clock (the open time before its first): a live eye quiet
  // for stall_timeout_s ends the capture. Recordings are read in step and cannot stall.
  double last_left = t0, last_right = t0;
  bool left_seen = false, right_seen = false;
  std::string last_refusal;
  double last_try_s = -1e300;
  ar::StereoFrame f;
  out.stop_reason = "captures taken";
  while (static_cast<int>(out.left.size()) < o.count) {
    const double now = ar::steady_now_s();
    if (o.seconds > 0 && now - t0 > o.seconds) {
      say("time limit (--seconds " + fmt(o.seconds, 0) + ") reached");
      out.stop_reason = "time limit";
      break;
    }
    if (live && (now - last_left > o.stall_timeout_s || now - last_right > o.stall_timeout_s)) {
      const bool ls = now - last_left > o.stall_timeout_s, rs = now - last_right > o.stall_timeout_s;
      const bool seen = (ls ? left_seen : true) && (rs ? right_seen : true);
      const double quiet = std::max(ls ? now - last_left : 0.0, rs ? now - last_right : 0.0);
      const std::string status = eyes.status();
      out.stall = silent_eyes(o, ls, rs) + (seen ? " has delivered no frame for " : " has delivered no frame since it was opened, ") +
                  fmt(quiet, 1) + " s" + (status.empty() ? std::string() : " (" + status + ")") +
                  ": check that it is plugged in, its cable, that no other program holds it and that the USB bus "
                  "has the bandwidth for both cameras, then run again (--stall-timeout S waits longer)";
      out.stop_reason = "stall";
      break;
    }
    if (!eyes.read(f, 0.5)) {
      if (eyes.ended()) {
        out.stop_reason = "footage ended";
        break;
      }
      if (!eyes.error().empty()) return Error{eyes.error()};
      continue;
    }
    ++out.frames;
    const double got = ar::steady_now_s();
    if (f.has_left()) last_left = got, left_seen = true;
    if (f.has_right()) last_right = got, right_seen = true;
    if (!f.has_left()) continue;  // the left eye carries the capture (the station's camera)
    feed_board_views(f.left.image, f.left.time_s, *dl, vl);
    if (f.has_right()) feed_board_views(f.right.image, f.right.time_s, *dr, vr);
    else vr.add_frame(f.left.time_s, nullptr, "the right eye delivered no frame", 0);
    if (!vl.still() || f.left.time_s - last_try_s < 0.25) continue;
    last_try_s = f.left.time_s;
    const cal::CameraTake tk = vl.take();
    if (!tk.ok) {
      if (tk.message != last_refusal) say("  (not taken: " + tk.message + ")");
      last_refusal = tk.message;
      continue;
    }
    last_refusal.clear();
    const std::string name = "live-capture-" + std::to_string(out.left.size());
    cal::BoardView l = vl.taken().back();
    l.name = name;
    out.left.push_back(l);
    cal::BoardView r{name, {}, {}};
    if (f.has_right() && vr.board_seen() && vr.still() && vr.last_layout_ok()) {
      r = vr.last_view();
      r.name = name;
    }
    out.right.push_back(r);
    say("  capture " + std::to_string(out.left.size()) + "/" + std::to_string(o.count) + " at " +
        fmt(f.left.time_s, 1) + " s: left " + std::to_string(l.image_points.size()) + " points, right " +
        (r.image_points.empty() ? std::string("board not seen still") : std::to_string(r.image_points.size()) + " points"));
  }
  out.pairing = eyes.stats().summary();
  say("live stereo head: " + std::to_string(out.left.size()) + " captures from " + std::to_string(out.frames) +
      " frames; " + out.pairing);
  if (out.left.empty()) {
    if (!out.stall.empty()) return Error{out.stall + "; no capture had been taken"};
    return Error{"no capture was taken (the board was never seen still and new by the left eye): check --board, hold "
                 "the board still for half a second at each place"};
  }
  return out;
}

}  // namespace dentar::live
