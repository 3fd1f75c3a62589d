#include "dentar/haptics/profile_sim_device.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace dentar::haptics {

std::string ProfileSimParams::validate() const {
  std::ostringstream os;
  if (!std::isfinite(hand_mass_kg) || hand_mass_kg < 0 || hand_mass_kg > 5)
    os << "hand_mass_kg = " << hand_mass_kg << " must be in [0, 5]";
  else if (!std::isfinite(hand_stiffness_N_per_m) || hand_stiffness_N_per_m <= 0)
    os << "hand_stiffness_N_per_m = " << hand_stiffness_N_per_m << " must be > 0";
  else if (!std::isfinite(hand_damping_ratio) || hand_damping_ratio < 0)
    os << "hand_damping_ratio = " << hand_damping_ratio << " must be >= 0";
  else if (!std::isfinite(dt_s) || dt_s <= 0 || dt_s > 0.01)
    os << "dt_s = " << dt_s << " must be in (0, 0.01]";
  else if (substeps < 1 || substeps > 1000)
    os << "substeps = " << substeps << " must be in [1, 1000]";
  else if (!std::isfinite(jitter_s) || jitter_s < 0 || jitter_s > 0.05)
    os << "jitter_s = " << jitter_s << " must be in [0, 0.05]";
  else if (delay_steps < 0 || delay_steps > 8)
    os << "delay_steps = " << delay_steps << " must be in [0, 8]";
  return os.str();
}

Result<std::unique_ptr<ProfileSimDevice>> ProfileSimDevice::create(const DeviceProfile& profile,
                                                                   const DeviceLimits& limits,
                                                                   std::vector<HandWaypoint> script,
                                                                   const ProfileSimParams& params) {
  if (std::string e = params.validate(); !e.empty()) return Error{"profile sim: " + e};
  if (std::string e = limits.validate(); !e.empty()) return Error{"profile sim: " + e};
  if (script.empty()) return Error{"profile sim: the script has no waypoints"};
  for (std::size_t i = 0; i < script.size(); ++i) {
    if (!std::isfinite(script[i].time_s) || !script[i].position_m.allFinite())
      return Error{"profile sim: waypoint " + std::to_string(i) + " has non-finite values"};
    if (i > 0 && !(script[i].time_s > script[i - 1].time_s))
      return Error{"profile sim: waypoint " + std::to_string(i) + " time must be after the previous one"};
  }
  std::unique_ptr<ProfileSimDevice> d(new ProfileSimDevice());
  d->profile_id_ = profile.id;
  d->limits_ = limits;
  d->p_ = params;
  d->script_ = std::move(script);
  for (auto& w : d->script_) w.orientation.normalize();
  d->mass_ = profile.tip_mass_kg + params.hand_mass_kg;
  d->t_ = d->script_.front().time_s;
  d->x_ = d->script_.front().position_m;
  for (auto& f : d->delay_) f.setZero();
  d->rng_.seed(params.seed);
  d->last_period_ = params.dt_s;
  return d;
}

std::size_t ProfileSimDevice::segment_at(double t) const {
  const auto it = std::upper_bound(script_.begin(), script_.end(), t,
                                   [](double v, const HandWaypoint& w) { return v < w.time_s; });
  return it == script_.begin() ? 0 : static_cast<std::size_t>(it - script_.begin()) - 1;
}

Eigen::Vector3d ProfileSimDevice::target_at(double t) const {
  const std::size_t i = segment_at(t);
  if (i + 1 >= script_.size()) return script_.back().position_m;
  const auto& a = script_[i];
  const auto& b = script_[i + 1];
  const double s = std::clamp((t - a.time_s) / (b.time_s - a.time_s), 0.0, 1.0);
  return a.position_m + s * (b.position_m - a.position_m);
}

bool ProfileSimDevice::read(DeviceState& out) noexcept {
  const std::size_t i = segment_at(t_);
  const auto& a = script_[i];
  Eigen::Quaterniond q = a.orientation;
  if (i + 1 < script_.size()) {
    const auto& b = script_[i + 1];
    q = a.orientation.slerp(std::clamp((t_ - a.time_s) / (b.time_s - a.time_s), 0.0, 1.0), b.orientation);
  }
  out.time_s = t_;
  out.T_dev_sty = Eigen::Isometry3d::Identity();
  out.T_dev_sty.linear() = q.toRotationMatrix();
  out.T_dev_sty.translation() = x_;
  out.velocity_m_per_s = v_;
  out.pedal = a.pedal;
  out.buttons = a.buttons;
  out.fault = false;
  return true;
}

void ProfileSimDevice::write_force(const Eigen::Vector3d& f) noexcept {
  last_force_ = f.allFinite() ? f : Eigen::Vector3d::Zero();
  // Delay line: the force applied this period was written delay_steps ago.
  delay_[delay_head_] = last_force_;
  const int n = p_.delay_steps + 1;
  const Eigen::Vector3d applied = delay_[(delay_head_ + 1) % n];
  delay_head_ = (delay_head_ + 1) % n;
  double period = p_.dt_s;
  if (p_.jitter_s > 0) period += std::uniform_real_distribution<double>(0.0, p_.jitter_s)(rng_);
  last_period_ = period;
  const double h = period / p_.substeps;
  const double k = p_.hand_stiffness_N_per_m;
  const double b = 2.0 * p_.hand_damping_ratio * std::sqrt(k * mass_);
  for (int s = 0; s < p_.substeps; ++s) {
    const Eigen::Vector3d xt = target_at(t_);
    const Eigen::Vector3d vt = (target_at(t_ + h) - xt) / h;
    const Eigen::Vector3d acc = (k * (xt - x_) + b * (vt - v_) + applied) / mass_;
    v_ += acc * h;
    x_ += v_ * h;
    t_ += h;
  }
}

}  // namespace dentar::haptics
