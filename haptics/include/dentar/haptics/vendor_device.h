// What the vendor-runtime backends (OpenHaptics HD, Force Dimension DHD)
// share: open options, runtime probing results, and the fault monitor that
// turns NaN, pose jumps, stalls and runtime errors into zero force.
//
// DeviceState::time_s of these devices: seconds since the device was opened
// (CLOCK_MONOTONIC; HD: the servo tick that took the sample).
//
// Fault policy (all backends): on any fault read() returns false with
// DeviceState::fault set (the engine sends zero force at once and marks the
// step in the session log), status() says what happened and what to do, and
// the fault clears only after `fault_clear_steps` consecutive good readings,
// from where the engine's ForceGuard ramps the force back up.
#pragma once

#include <Eigen/Geometry>
#include <atomic>
#include <cstdint>
#include <string>

namespace dentar::haptics {

struct DeviceOpenOptions {
  std::string name_or_serial;  // "" = first device; else the HD configuration name, or a serial number
  // Vendor runtime to load; "" = the default name (libHD.so; libdrd.so then
  // libdhd.so), found through the loader's path (LD_LIBRARY_PATH, ld.so.conf)
  // or the DENTAR_HD_LIBRARY / DENTAR_DHD_LIBRARY environment variables.
  std::string library;
  std::string profile;              // "" = from the model the device reports
  double max_pose_jump_m = 0.005;   // a larger move in one reading is a fault
  double stale_limit_s = 0.005;     // servo (HD) or a runtime call (DHD) older/longer: fault
  int fault_clear_steps = 100;      // good readings before a fault clears
  bool allow_uncalibrated = false;  // open a device that reports it is not calibrated
};

// The result of looking for a vendor runtime library (dentar devices).
struct RuntimeInfo {
  std::string runtime;    // "OpenHaptics HD" / "Force Dimension DHD"
  std::string requested;  // the name or path passed to dlopen
  bool present = false;
  std::string path;       // resolved file, when present
  std::string version;    // when the library tells without a device ("" = unknown)
  std::string message;    // why absent, or what is missing, and what to do
};

// What an open device reports about itself.
struct VendorDeviceInfo {
  std::string backend;      // "hd" / "dhd"
  std::string model;        // as the runtime reports it ("Touch", "omega.3")
  std::string serial;
  std::string runtime_version;
  std::string calibration;  // "ok", "needs update", "needs manual input: ...", "not reported"
  std::string profile_id;   // the profile in use
};

enum class DeviceFault : std::uint8_t {
  kNone = 0,
  kUnplugged,      // the runtime reports the device gone (communication error)
  kRuntimeError,   // the runtime returned an error code (see runtime_error())
  kNonFinite,      // NaN/Inf in the pose or velocity
  kPoseJump,       // moved more than max_pose_jump_m in one reading
  kStalled,        // servo tick late / runtime call too long
  kNotCalibrated,  // the device reports it needs calibration
};
const char* device_fault_name(DeviceFault f);
// What the user should do about it (one sentence).
const char* device_fault_advice(DeviceFault f);

// Haptic-thread fault bookkeeping for one device. check() is allocation-free;
// the atomics let status() (any thread) describe the latest fault.
class FaultMonitor {
 public:
  FaultMonitor() = default;
  explicit FaultMonitor(const DeviceOpenOptions& o) { configure(o); }
  // Before use (not while another thread reads).
  void configure(const DeviceOpenOptions& o) {
    max_jump_m_ = o.max_pose_jump_m;
    clear_steps_ = o.fault_clear_steps;
  }
  // Before use: the backend judges pose jumps itself, between the device's consecutive samples
  // (HD: the servo thread, tick to tick), and passes them in as `external` kPoseJump with the
  // jump. Without it, jumps are judged between readings, which also counts the stylus's own
  // motion over a reader's gap (a reader held off 10 ticks sees 10 ticks of motion).
  void jumps_judged_by_backend() { reading_jumps_ = false; }
  // Haptic thread: one reading. `external` is a fault the backend detected
  // (runtime error, stall, unplug, and with jumps_judged_by_backend() a NaN sample or a pose
  // jump of `jump_m` between samples it saw); kNone if none. Returns true when the reading may
  // be used (no fault now and none pending clearance).
  bool check(const Eigen::Isometry3d& T_dev_sty, const Eigen::Vector3d& v, DeviceFault external,
             int runtime_error = 0, double jump_m = 0) noexcept;
  DeviceFault latest() const noexcept { return static_cast<DeviceFault>(latest_.load(std::memory_order_acquire)); }
  bool faulted() const noexcept { return faulted_.load(std::memory_order_acquire); }
  int runtime_error() const noexcept { return runtime_error_.load(std::memory_order_acquire); }
  std::uint64_t fault_count() const noexcept { return count_.load(std::memory_order_acquire); }
  double last_jump_m() const noexcept { return jump_m_.load(std::memory_order_acquire); }

 private:
  double max_jump_m_ = 0.005;
  int clear_steps_ = 100;
  bool have_prev_ = false;
  bool reading_jumps_ = true;
  Eigen::Vector3d prev_ = Eigen::Vector3d::Zero();
  int good_ = 0;
  std::atomic<std::uint8_t> latest_{0};
  std::atomic<bool> faulted_{false};
  std::atomic<int> runtime_error_{0};
  std::atomic<std::uint64_t> count_{0};
  std::atomic<double> jump_m_{0};
};

}  // namespace dentar::haptics
