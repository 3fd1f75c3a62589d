// ProfileSimDevice: a simulated haptic device with a profile's limits and
// apparent tip mass, held by a scripted hand, for the closed-loop stability
// suite and `--device sim:<profile>`.
//
// Unlike SimulatedDevice (which advances the hand by exactly one engine step
// per write), the plant here is integrated in `substeps` per engine period
// with the force held constant over the period (zero-order hold, as a real
// device's amplifier holds it), optionally delayed by `delay_steps` periods
// (HD's servo mailbox: 1), and each period may last dt + U[0, jitter_s]
// (a late engine thread). So 1 kHz quantisation, delay and jitter act on
// the loop as they would on the hardware.
//
// Plant (per axis, SI): (m_dev + m_hand) a = k_h (x_t - x) + b_h (v_t - v) + f
// with b_h = 2 zeta sqrt(k_h (m_dev + m_hand)); semi-implicit Euler per substep.
#pragma once

#include <memory>
#include <random>
#include <vector>

#include "dentar/haptics/device_profiles.h"
#include "dentar/haptics/simulated_device.h"

namespace dentar::haptics {

struct ProfileSimParams {
  double hand_mass_kg = 0.10;             // fingers and hand on the stylus
  double hand_stiffness_N_per_m = 300.0;  // a light pen grip
  double hand_damping_ratio = 0.3;        // lightly damped grip (harder for stability than 0.7)
  double dt_s = 1e-3;                     // nominal engine period
  int substeps = 20;                      // plant integration steps per period
  double jitter_s = 0.0;                  // extra period length, uniform in [0, jitter_s]
  int delay_steps = 0;                    // force transport delay, in periods (<= 8)
  std::uint64_t seed = 1;
  std::string validate() const;
};

class ProfileSimDevice final : public HapticDevice {
 public:
  // `limits` are the device's (normally limits_from_profile(profile)); the
  // profile gives the tip mass and the name.
  static Result<std::unique_ptr<ProfileSimDevice>> create(const DeviceProfile& profile,
                                                          const DeviceLimits& limits,
                                                          std::vector<HandWaypoint> script,
                                                          const ProfileSimParams& params = {});
  std::string name() const override { return "sim:" + profile_id_; }
  const DeviceLimits& limits() const override { return limits_; }
  bool read(DeviceState& out) noexcept override;
  void write_force(const Eigen::Vector3d& force_dev_N) noexcept override;

  double time_s() const { return t_; }
  const Eigen::Vector3d& position() const { return x_; }
  const Eigen::Vector3d& last_force() const { return last_force_; }
  // Length of the last period (s): dt_s plus its jitter.
  double last_period_s() const { return last_period_; }

 private:
  ProfileSimDevice() = default;
  Eigen::Vector3d target_at(double t) const;
  std::size_t segment_at(double t) const;

  std::string profile_id_;
  DeviceLimits limits_;
  ProfileSimParams p_;
  std::vector<HandWaypoint> script_;
  double mass_ = 0.1;
  double t_ = 0, last_period_ = 1e-3;
  Eigen::Vector3d x_ = Eigen::Vector3d::Zero(), v_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d last_force_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d delay_[9];
  int delay_head_ = 0;
  std::mt19937_64 rng_;
};

}  // namespace dentar::haptics
