// OpenHaptics HD backend (3D Systems Touch, Touch X, PHANTOM Omni, Desktop,
// Premium). libHD.so is loaded with dlopen at run time: the build needs no
// vendor file, and a missing or too old runtime is a clear error, not a crash.
//
// Threads (docs/devices.md, "How the HD servo meets the engine"): the HD
// scheduler runs its own 1 kHz servo thread. Our servo callback, once per
// tick, reads the pose, velocity and buttons into a SeqLock and sends the
// newest force the engine wrote (a second SeqLock). The engine thread's
// read() and write_force() only touch those SeqLocks (no lock, no wait).
// Safety on the servo side: a force older than stale_limit_s (the engine
// stopped or stalled) or not finite is replaced by zero; on the engine side a
// servo state older than stale_limit_s is a kStalled fault (zero force).
//
// Units: HD reports mm and mm/s; this class converts to m and m/s. The dev
// frame is HD's (x right, y up, z toward the user, origin at the workspace centre).
#pragma once

#include <memory>
#include <string>

#include "dentar/haptics/device.h"
#include "dentar/haptics/device_profiles.h"
#include "dentar/haptics/vendor_device.h"
#include "dentar/volume/result.h"

namespace dentar::haptics {

// Loads libHD (without opening a device) and says whether it is usable.
RuntimeInfo probe_hd_runtime(const std::string& library = "");

class HdDevice final : public HapticDevice {
 public:
  // Opens the device (by configuration name, or the default device then
  // compared by serial), checks calibration, starts the HD scheduler.
  static Result<std::unique_ptr<HdDevice>> open(const DeviceOpenOptions& options);
  ~HdDevice() override;  // zero force, unschedule, stop the scheduler, disable the device

  std::string name() const override;
  const DeviceLimits& limits() const override { return limits_; }
  bool read(DeviceState& out) noexcept override;
  void write_force(const Eigen::Vector3d& force_dev_N) noexcept override;
  std::string status() const override;

  const VendorDeviceInfo& info() const { return info_; }
  const DeviceProfile& profile() const { return *profile_; }
  const FaultMonitor& faults() const { return monitor_; }
  // Servo ticks seen so far (any thread).
  std::uint64_t servo_ticks() const noexcept;
  // CLOCK_MONOTONIC (s) at open: DeviceState::time_s + this = the tick's clock time.
  double opened_at_s() const noexcept;

  struct Impl;

 private:
  HdDevice() = default;
  std::unique_ptr<Impl> impl_;
  DeviceLimits limits_;
  VendorDeviceInfo info_;
  const DeviceProfile* profile_ = nullptr;
  FaultMonitor monitor_;
};

}  // namespace dentar::haptics
