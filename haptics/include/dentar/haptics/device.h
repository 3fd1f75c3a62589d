// Haptic device interface. Real USB devices, the simulated hand and the
// session-log replay all implement it, so the engine does not know which one
// it drives.
//
// Thread: read() and write_force() are called only from the haptic thread,
// once per step, and must not block, allocate or lock.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <string>

namespace dentar::haptics {

struct DeviceLimits {
  double max_force_N = 3.3;                // maximum continuous force
  double max_stiffness_N_per_m = 2000.0;   // largest stable stiffness at 1 kHz
  Eigen::Vector3d workspace_min_m{-0.08, -0.06, -0.05};  // device frame box
  Eigen::Vector3d workspace_max_m{0.08, 0.06, 0.05};
  std::string validate() const;  // empty when valid, else names the field
  // Largest virtual damping the device renders stably (N s/m); force models
  // refuse a damping above it. Device profiles (device_profiles.h) set it.
  double max_damping_N_s_per_m = 30.0;
  // Radius of the device's usable workspace sphere around the dev-frame
  // origin (m); 0 = only the box above is known.
  double workspace_radius_m = 0.0;
};

// Button bits in DeviceState::buttons.
inline constexpr std::uint32_t kButtonPrimary = 1u << 0;
inline constexpr std::uint32_t kButtonSecondary = 1u << 1;

struct DeviceState {
  double time_s = 0.0;  // device timestamp, monotonic (simulated devices: simulated time)
  Eigen::Isometry3d T_dev_sty = Eigen::Isometry3d::Identity();  // stylus pose in the base frame
  Eigen::Vector3d velocity_m_per_s = Eigen::Vector3d::Zero();   // stylus origin velocity, dev frame
  std::uint32_t buttons = 0;  // kButton* bits
  bool pedal = false;         // foot pedal pressed: the drill runs
  bool fault = false;         // the device reports a fault (engine sends zero force)
};

class HapticDevice {
 public:
  virtual ~HapticDevice() = default;
  virtual std::string name() const = 0;
  virtual const DeviceLimits& limits() const = 0;
  // Latest state. Returns false (and sets out.fault) when the device failed;
  // returns false with out.fault == false when a finite source (a replayed
  // log) has ended.
  virtual bool read(DeviceState& out) noexcept = 0;
  // Force on the stylus (N, device frame), already checked by ForceGuard.
  // Simulated devices advance their simulated time by one step here.
  virtual void write_force(const Eigen::Vector3d& force_dev_N) noexcept = 0;
  // Replayed sources: whether the live engine's watchdog zeroed the force
  // at the step just read, so a replay sends the same forces. Live devices: false.
  virtual bool recorded_watchdog() const noexcept { return false; }
  // One line for the HUD and the log: what the device is doing or why it
  // faulted ("HD servo stalled for 12 ms: zero force"). Any thread; may
  // allocate, so never from the haptic thread. Empty when there is nothing to say.
  virtual std::string status() const { return {}; }
};

}  // namespace dentar::haptics
