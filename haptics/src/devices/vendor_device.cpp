#include "dentar/haptics/vendor_device.h"

#include <cmath>

namespace dentar::haptics {

const char* device_fault_name(DeviceFault f) {
  switch (f) {
    case DeviceFault::kNone: return "none";
    case DeviceFault::kUnplugged: return "device unplugged";
    case DeviceFault::kRuntimeError: return "runtime error";
    case DeviceFault::kNonFinite: return "NaN in the device pose";
    case DeviceFault::kPoseJump: return "pose jump";
    case DeviceFault::kStalled: return "servo stalled";
    case DeviceFault::kNotCalibrated: return "not calibrated";
  }
  return "unknown";
}

const char* device_fault_advice(DeviceFault f) {
  switch (f) {
    case DeviceFault::kNone: return "";
    case DeviceFault::kUnplugged:
      return "check the USB/FireWire cable and the device's power, then restart the session";
    case DeviceFault::kRuntimeError:
      return "forces are off; if it repeats, run the vendor's diagnostic tool (Touch_Diagnostic, Force Dimension's HapticDesk)";
    case DeviceFault::kNonFinite:
    case DeviceFault::kPoseJump:
      return "the encoder reading is implausible; forces resume after 0.1 s of steady readings, "
             "recalibrate the device if it repeats";
    case DeviceFault::kStalled:
      return "the machine is overloaded or the device stopped answering; close other programs";
    case DeviceFault::kNotCalibrated:
      return "put the stylus in the inkwell (Touch) or run the vendor's calibration, then go on";
  }
  return "";
}

bool FaultMonitor::check(const Eigen::Isometry3d& T, const Eigen::Vector3d& v, DeviceFault external,
                         int runtime_error, double jump_m) noexcept {
  DeviceFault f = external;
  const Eigen::Vector3d p = T.translation();
  const bool finite = T.matrix().allFinite() && v.allFinite();
  if (f == DeviceFault::kPoseJump) jump_m_.store(jump_m, std::memory_order_release);
  if (f == DeviceFault::kNone && !finite) f = DeviceFault::kNonFinite;
  if (f == DeviceFault::kNone && have_prev_ && reading_jumps_) {
    const double d = (p - prev_).norm();
    if (d > max_jump_m_) {
      f = DeviceFault::kPoseJump;
      jump_m_.store(d, std::memory_order_release);
    }
  }
  // The newest finite position is the reference for the next reading, so a
  // lasting offset faults once, not forever. A reading the runtime flagged
  // (error, stall) carries no trustworthy pose and is not a reference.
  if (finite && external == DeviceFault::kNone) {
    prev_ = p;
    have_prev_ = true;
  }
  if (f != DeviceFault::kNone) {
    if (!faulted_.load(std::memory_order_relaxed) || latest() != f)
      count_.fetch_add(1, std::memory_order_acq_rel);
    latest_.store(static_cast<std::uint8_t>(f), std::memory_order_release);
    if (f == DeviceFault::kRuntimeError || f == DeviceFault::kUnplugged)
      runtime_error_.store(runtime_error, std::memory_order_release);
    faulted_.store(true, std::memory_order_release);
    good_ = 0;
    return false;
  }
  if (faulted_.load(std::memory_order_relaxed)) {
    if (++good_ < clear_steps_) return false;
    faulted_.store(false, std::memory_order_release);
  }
  return true;
}

}  // namespace dentar::haptics
