#include "dentar/haptics/simulated_device.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace dentar::haptics {

std::string DeviceLimits::validate() const {
  std::ostringstream os;
  if (!std::isfinite(max_force_N) || max_force_N <= 0 || max_force_N > 50)
    os << "max_force_N = " << max_force_N << " must be in (0, 50] N";
  else if (!std::isfinite(max_stiffness_N_per_m) || max_stiffness_N_per_m <= 0 ||
           max_stiffness_N_per_m > 1e5)
    os << "max_stiffness_N_per_m = " << max_stiffness_N_per_m << " must be in (0, 1e5]";
  else if (!workspace_min_m.allFinite() || !workspace_max_m.allFinite() ||
           (workspace_max_m - workspace_min_m).minCoeff() <= 0)
    os << "workspace box must be finite with max > min on every axis";
  else if (!std::isfinite(max_damping_N_s_per_m) || max_damping_N_s_per_m <= 0 ||
           max_damping_N_s_per_m > 1e3)
    os << "max_damping_N_s_per_m = " << max_damping_N_s_per_m << " must be in (0, 1e3]";
  else if (!std::isfinite(workspace_radius_m) || workspace_radius_m < 0 || workspace_radius_m > 2)
    os << "workspace_radius_m = " << workspace_radius_m << " must be in [0, 2] m (0 = unknown)";
  return os.str();
}

std::string HandParams::validate() const {
  std::ostringstream os;
  if (!std::isfinite(mass_kg) || mass_kg <= 0 || mass_kg > 5)
    os << "hand mass_kg = " << mass_kg << " must be in (0, 5]";
  else if (!std::isfinite(stiffness_N_per_m) || stiffness_N_per_m <= 0)
    os << "hand stiffness_N_per_m = " << stiffness_N_per_m << " must be > 0";
  else if (!std::isfinite(damping_ratio) || damping_ratio < 0)
    os << "hand damping_ratio = " << damping_ratio << " must be >= 0";
  return os.str();
}

Result<std::unique_ptr<SimulatedDevice>> SimulatedDevice::create(std::vector<HandWaypoint> script,
                                                                 const DeviceLimits& limits,
                                                                 const HandParams& hand,
                                                                 double dt_s) {
  if (script.empty()) return Error{"simulated device: the script has no waypoints"};
  for (std::size_t i = 0; i < script.size(); ++i) {
    const auto& w = script[i];
    if (!std::isfinite(w.time_s) || !w.position_m.allFinite() || !w.orientation.coeffs().allFinite())
      return Error{"simulated device: waypoint " + std::to_string(i) + " has non-finite values"};
    if (i > 0 && !(w.time_s > script[i - 1].time_s))
      return Error{"simulated device: waypoint " + std::to_string(i) +
                   " time must be after the previous waypoint's"};
  }
  if (std::string e = limits.validate(); !e.empty()) return Error{"simulated device: " + e};
  if (std::string e = hand.validate(); !e.empty()) return Error{"simulated device: " + e};
  if (!std::isfinite(dt_s) || dt_s <= 0 || dt_s > 0.01)
    return Error{"simulated device: dt_s must be in (0, 0.01] s"};
  std::unique_ptr<SimulatedDevice> d(new SimulatedDevice());
  d->script_ = std::move(script);
  for (auto& w : d->script_) w.orientation.normalize();
  d->limits_ = limits;
  d->hand_ = hand;
  d->dt_s_ = dt_s;
  d->t_ = d->script_.front().time_s;
  d->x_ = d->script_.front().position_m;
  return d;
}

std::size_t SimulatedDevice::segment_at(double t) const {
  // Index i with script[i].time <= t < script[i+1].time (clamped).
  const auto it = std::upper_bound(script_.begin(), script_.end(), t,
                                   [](double v, const HandWaypoint& w) { return v < w.time_s; });
  return it == script_.begin() ? 0 : static_cast<std::size_t>(it - script_.begin()) - 1;
}

Eigen::Vector3d SimulatedDevice::target_at(double t) const {
  const std::size_t i = segment_at(t);
  if (i + 1 >= script_.size()) return script_.back().position_m;
  const auto& a = script_[i];
  const auto& b = script_[i + 1];
  const double s = std::clamp((t - a.time_s) / (b.time_s - a.time_s), 0.0, 1.0);
  return a.position_m + s * (b.position_m - a.position_m);
}

bool SimulatedDevice::read(DeviceState& out) noexcept {
  const std::size_t i = segment_at(t_);
  const auto& a = script_[i];
  Eigen::Quaterniond q = a.orientation;
  if (i + 1 < script_.size()) {
    const auto& b = script_[i + 1];
    const double s = std::clamp((t_ - a.time_s) / (b.time_s - a.time_s), 0.0, 1.0);
    q = a.orientation.slerp(s, b.orientation);
  }
  out.time_s = t_;
  out.T_dev_sty = Eigen::Isometry3d::Identity();
  out.T_dev_sty.linear() = q.toRotationMatrix();
  out.T_dev_sty.translation() = x_;
  out.velocity_m_per_s = v_;
  out.pedal = a.pedal;
  out.buttons = a.buttons;
  out.fault = fault_;
  return !fault_;
}

void SimulatedDevice::write_force(const Eigen::Vector3d& f) noexcept {
  last_force_ = f.allFinite() ? f : Eigen::Vector3d::Zero();
  // Hand: m a = k (x_target - x) + b (v_target - v) + f, semi-implicit Euler
  // (stable for dt * sqrt(k/m) << 2; here ~0.06).
  const double k = hand_.stiffness_N_per_m, m = hand_.mass_kg;
  const double b = 2.0 * hand_.damping_ratio * std::sqrt(k * m);
  const Eigen::Vector3d xt = target_at(t_);
  const Eigen::Vector3d vt = (target_at(t_ + dt_s_) - xt) / dt_s_;
  const Eigen::Vector3d a = (k * (xt - x_) + b * (vt - v_) + last_force_) / m;
  v_ += a * dt_s_;
  x_ += v_ * dt_s_;
  t_ += dt_s_;
}

}  // namespace dentar::haptics
