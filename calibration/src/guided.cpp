#include "dentar/calibration/guided.h"

#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>

namespace dentar::calibration {

std::string LivePivotOptions::validate() const {
  if (!(min_turn_rad >= 0 && min_turn_rad < 0.5)) return "min_turn_rad must be in [0, 0.5) rad";
  if (!(target_tip_sd_m > 0 && target_tip_sd_m < 0.01)) return "target_tip_sd_m must be in (0, 10) mm";
  if (max_poses < gates.min_poses) return "max_poses must be >= gates.min_poses";
  return gates.validate();
}

LivePivot::LivePivot(const LivePivotOptions& options) : options_(options) {}

bool LivePivot::add(const Eigen::Isometry3d& T) {
  if (!T.matrix().allFinite() || poses() >= options_.max_poses) return false;
  if (!poses_.empty()) {
    const Eigen::AngleAxisd d(poses_.back().linear().transpose() * T.linear());
    if (std::abs(d.angle()) < options_.min_turn_rad) return false;
  }
  poses_.push_back(T);
  if (poses_.size() >= 3) {
    PivotOptions relaxed;
    relaxed.min_poses = 3;
    relaxed.min_spread_rad = 0;
    relaxed.min_weakest_tilt_rad = 0;
    current_ = calibrate_pivot(poses_, relaxed);
  }
  return true;
}

double LivePivot::tip_sd_m() const {
  if (poses_.size() < 4 || !current_.ok) return std::numeric_limits<double>::infinity();
  return std::sqrt(current_.cov_tip_sty.trace());
}

bool LivePivot::done() const {
  const auto& g = options_.gates;
  return poses() >= g.min_poses && current_.ok && current_.spread_rad >= g.min_spread_rad &&
         current_.weakest_tilt_rad >= g.min_weakest_tilt_rad && tip_sd_m() <= options_.target_tip_sd_m;
}

PivotSummary LivePivot::final_result() const { return calibrate_pivot(poses_, options_.gates); }

std::string LivePivot::hint() const {
  std::ostringstream os;
  os << std::fixed << std::setprecision(1);
  const auto& g = options_.gates;
  constexpr double kDeg = 180.0 / 3.14159265358979;
  if (poses() < 3) return "seat the bur tip in the pivot divot and rock the stylus slowly";
  if (current_.spread_rad < g.min_spread_rad)
    os << "rock further in all directions: " << current_.spread_rad * kDeg << " of " << g.min_spread_rad * kDeg
       << " deg";
  else if (current_.weakest_tilt_rad < g.min_weakest_tilt_rad)
    os << "rock across as well, not only in one plane: weakest direction " << current_.weakest_tilt_rad * kDeg
       << " of " << g.min_weakest_tilt_rad * kDeg << " deg";
  else if (poses() < g.min_poses)
    os << "keep rocking: " << poses() << " of " << g.min_poses << " poses";
  else if (tip_sd_m() > options_.target_tip_sd_m)
    os << "keep rocking, keeping the tip seated: tip known to " << std::setprecision(2) << tip_sd_m() * 1e3
       << " mm, stops at " << options_.target_tip_sd_m * 1e3 << " mm";
  else
    os << "done: the tip is known to " << std::setprecision(2) << tip_sd_m() * 1e3 << " mm";
  return os.str();
}

LiveTouches::LiveTouches(std::string what, int count, const TouchOptions& touch)
    : what_(std::move(what)), count_(count), detector_(touch) {}

void LiveTouches::add_sample(double t_s, const Eigen::Vector3d& tip_dev) { detector_.add(t_s, tip_dev); }

TouchResult LiveTouches::take() {
  if (done()) {
    TouchResult r;
    r.message = what_ + ": all " + std::to_string(count_) + " are touched";
    return r;
  }
  TouchResult r = detector_.take(what_ + " " + std::to_string(next()));
  if (r.ok) {
    taken_.push_back(r.tip);
    last_message_.clear();
  } else {
    ++refused_;
    last_message_ = r.message;
  }
  return r;
}

RegistrationSummary running_fit(const std::vector<Eigen::Vector3d>& touched,
                                const std::vector<Eigen::Vector3d>& known, const Eigen::Vector3d& target) {
  RegistrationOptions o;
  o.min_points = 4;
  o.max_tre_m = 1.0;
  o.min_thickness_m = 0;
  o.thickness_fle_factor = 0;
  o.max_residual_m = 1.0;
  const std::size_t n = std::min(touched.size(), known.size());
  if (n < 4) return {};  // three points always lie in a plane: nothing to predict a TRE from
  return register_divots(std::vector<Eigen::Vector3d>(touched.begin(), touched.begin() + n),
                         std::vector<Eigen::Vector3d>(known.begin(), known.begin() + n), target, o);
}

}  // namespace dentar::calibration
