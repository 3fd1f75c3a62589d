#include "dentar/haptics/force_guard.h"

#include <cmath>
#include <sstream>

namespace dentar::haptics {

std::string ForceLimits::validate() const {
  std::ostringstream os;
  if (!std::isfinite(max_force_N) || max_force_N <= 0 || max_force_N > 50)
    os << "max_force_N = " << max_force_N << " must be in (0, 50] N";
  else if (!std::isfinite(max_force_rate_N_per_s) || max_force_rate_N_per_s <= 0)
    os << "max_force_rate_N_per_s = " << max_force_rate_N_per_s << " must be > 0";
  return os.str();
}

ForceGuard::ForceGuard(const ForceLimits& limits) : limits_(limits) {}

Eigen::Vector3d ForceGuard::apply(const Eigen::Vector3d& requested, double dt_s) noexcept {
  if (fault_ != GuardFault::kNone) return last_ = Eigen::Vector3d::Zero();
  if (!requested.allFinite() || !std::isfinite(dt_s) || dt_s <= 0) {
    fault_ = GuardFault::kNonFinite;
    return last_ = Eigen::Vector3d::Zero();
  }
  Eigen::Vector3d f = requested;
  const double n = f.norm();
  if (n > limits_.max_force_N) {
    f *= limits_.max_force_N / n;
    ++clamped_;
  }
  // Limit the change per step; stepping toward zero is limited too, so a
  // release is a ramp, but the ramp is at most max_force / rate long.
  const Eigen::Vector3d d = f - last_;
  const double max_step = limits_.max_force_rate_N_per_s * dt_s;
  if (d.norm() > max_step) {
    f = last_ + d * (max_step / d.norm());
    ++limited_;
  }
  return last_ = f;
}

void ForceGuard::reset() noexcept {
  fault_ = GuardFault::kNone;
  last_.setZero();
}

}  // namespace dentar::haptics
