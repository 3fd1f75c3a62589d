// ForceGuard: the last stage before a force reaches the haptic device.
// Always compiled in (not debug-only): NaN/Inf -> zero force and a latched
// fault; magnitude clamped to the device maximum; per-step change limited so
// the device never sees a spike.
//
// Thread: the 1 kHz haptic thread. No allocation, no locks.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>

namespace dentar::haptics {

struct ForceLimits {
  double max_force_N = 3.3;          // maximum continuous force of the device
  double max_force_rate_N_per_s = 2000.0;  // largest allowed change of force per second
  std::string validate() const;      // empty when valid, else names the field
};

enum class GuardFault : std::uint8_t { kNone = 0, kNonFinite = 1 };

class ForceGuard {
 public:
  explicit ForceGuard(const ForceLimits& limits);

  // Returns the force to send (N, device frame) for the requested force and
  // the step length dt_s. After a non-finite input the guard stays faulted
  // and returns zero until reset(); a non-finite or non-positive dt_s is
  // treated as a fault too.
  Eigen::Vector3d apply(const Eigen::Vector3d& requested_N, double dt_s) noexcept;
  void reset() noexcept;
  // Sends zero at once (watchdog): no ramp down; the next apply() ramps up
  // from zero. Does not clear a latched fault.
  Eigen::Vector3d zero() noexcept { return last_ = Eigen::Vector3d::Zero(); }

  GuardFault fault() const { return fault_; }
  std::uint64_t clamped_steps() const { return clamped_; }     // magnitude clamps
  std::uint64_t rate_limited_steps() const { return limited_; }  // spike limits
  const Eigen::Vector3d& last() const { return last_; }

 private:
  ForceLimits limits_;
  Eigen::Vector3d last_ = Eigen::Vector3d::Zero();
  GuardFault fault_ = GuardFault::kNone;
  std::uint64_t clamped_ = 0, limited_ = 0;
};

}  // namespace dentar::haptics
