// SimulatedDevice: a stylus held by a virtual hand that follows a scripted
// path. The hand is a mass-spring-damper pulled toward the scripted target
// and pushed by the rendered force, so force models are tested in a closed
// loop, as with a real hand and device (not open loop).
//
// Simulated time: each write_force() advances the hand by one step dt.
#pragma once

#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <vector>

#include "dentar/haptics/device.h"
#include "dentar/volume/result.h"

namespace dentar::haptics {

// A keyframe of the script, in the device base frame.
struct HandWaypoint {
  double time_s = 0;
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  // target stylus position
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  // stylus orientation
  bool pedal = false;  // held from this waypoint until the next
  std::uint32_t buttons = 0;
};

struct HandParams {
  double mass_kg = 0.12;             // stylus + fingers, effective
  double stiffness_N_per_m = 400.0;  // fingertip grip stiffness
  double damping_ratio = 0.7;        // of the hand's spring-mass
  std::string validate() const;
};

class SimulatedDevice final : public HapticDevice {
 public:
  // Waypoints must be in increasing time; the target is linearly
  // interpolated (slerp for orientation) and held after the last one.
  static Result<std::unique_ptr<SimulatedDevice>> create(std::vector<HandWaypoint> script,
                                                         const DeviceLimits& limits,
                                                         const HandParams& hand = {},
                                                         double dt_s = 1e-3);

  std::string name() const override { return "simulated-hand"; }
  const DeviceLimits& limits() const override { return limits_; }
  bool read(DeviceState& out) noexcept override;
  void write_force(const Eigen::Vector3d& force_dev_N) noexcept override;

  // Test hooks: inject a device fault; see the last force received.
  void set_fault(bool f) { fault_ = f; }
  const Eigen::Vector3d& last_force() const { return last_force_; }
  double time_s() const { return t_; }
  double script_end_s() const { return script_.empty() ? 0 : script_.back().time_s; }
  // Target (scripted) position at time t.
  Eigen::Vector3d target_at(double t) const;

 private:
  SimulatedDevice() = default;
  std::size_t segment_at(double t) const;

  std::vector<HandWaypoint> script_;
  DeviceLimits limits_;
  HandParams hand_;
  double dt_s_ = 1e-3;
  double t_ = 0;
  Eigen::Vector3d x_ = Eigen::Vector3d::Zero(), v_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d last_force_ = Eigen::Vector3d::Zero();
  bool fault_ = false;
};

}  // namespace dentar::haptics
