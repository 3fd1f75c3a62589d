// Force Dimension DHD backend (omega.x, sigma.x, delta.x, Novint Falcon).
// libdrd.so (a superset of DHD with the calibration calls) or libdhd.so is
// loaded with dlopen at run time; the build needs neither.
//
// Threads: DHD has no scheduler of its own; every call is one USB exchange.
// read() and write_force() call dhdGetPosition/... and dhdSetForce directly
// on the engine's haptic thread, once per step (the engine's thread is the
// servo). A call that takes longer than stale_limit_s is a kStalled fault.
//
// Units: DHD reports m and m/s already. The dev frame is DHD's (x toward the
// user, y right, z up, origin at the workspace centre).
#pragma once

#include <memory>
#include <string>

#include "dentar/haptics/device.h"
#include "dentar/haptics/device_profiles.h"
#include "dentar/haptics/vendor_device.h"
#include "dentar/volume/result.h"

namespace dentar::haptics {

RuntimeInfo probe_dhd_runtime(const std::string& library = "");

class DhdDevice final : public HapticDevice {
 public:
  // name_or_serial: "" = the first device; digits = a serial number; else a
  // system name ("omega.3", "Falcon").
  static Result<std::unique_ptr<DhdDevice>> open(const DeviceOpenOptions& options);
  ~DhdDevice() override;  // zero force, forces off, close

  std::string name() const override;
  const DeviceLimits& limits() const override { return limits_; }
  bool read(DeviceState& out) noexcept override;
  void write_force(const Eigen::Vector3d& force_dev_N) noexcept override;
  std::string status() const override;

  const VendorDeviceInfo& info() const { return info_; }
  const DeviceProfile& profile() const { return *profile_; }
  const FaultMonitor& faults() const { return monitor_; }

  // Devices the runtime sees (for `dentar devices`): one line each, or the
  // reason there are none.
  static std::vector<std::string> list(const std::string& library, std::string& why_none);

  struct Impl;

 private:
  DhdDevice() = default;
  std::unique_ptr<Impl> impl_;
  DeviceLimits limits_;
  VendorDeviceInfo info_;
  const DeviceProfile* profile_ = nullptr;
  FaultMonitor monitor_;
};

}  // namespace dentar::haptics
