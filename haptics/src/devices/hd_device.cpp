// OpenHaptics HD backend. The HD C API subset used here is declared locally
// (types and constants as documented for OpenHaptics 3.x), so no vendor
// header is needed to build.
#include "dentar/haptics/hd_device.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iomanip>
#include <sstream>
#include <thread>

#include "dentar/haptics/seqlock.h"
#include "dl_library.h"

namespace dentar::haptics {
namespace {

// --- OpenHaptics HD API subset (hdDefines.h / hd.h / hdScheduler.h values) ---
using HHD = unsigned int;
using HDenum = unsigned int;
using HDerror = unsigned int;
using HDCallbackCode = unsigned int;
using HDSchedulerHandle = unsigned long;
using HDSchedulerCallback = HDCallbackCode (*)(void*);
struct HDErrorInfo {
  HDerror errorCode;
  int internalErrorCode;
  HHD hHD;
};
constexpr HHD kHdInvalidHandle = 0xFFFFFFFFu;
constexpr HDerror kHdSuccess = 0x0000;
constexpr HDerror kHdExceededMaxForce = 0x0201, kHdExceededMaxForceImpulse = 0x0202,
                  kHdExceededMaxVelocity = 0x0203, kHdForceError = 0x0204, kHdWarmMotors = 0x0200;
constexpr HDerror kHdDeviceFault = 0x0300, kHdDeviceAlreadyInitiated = 0x0301,
                  kHdCommError = 0x0302, kHdCommConfigError = 0x0303, kHdTimerError = 0x0304;
constexpr HDerror kHdInvalidLicense = 0x0600;
constexpr HDenum kHdCurrentButtons = 0x2000, kHdCurrentVelocity = 0x2051,
                 kHdCurrentTransform = 0x2052;
constexpr HDenum kHdVersion = 0x2500, kHdDeviceModelType = 0x2501, kHdDeviceSerialNumber = 0x2504;
constexpr HDenum kHdCalibrationStyle = 0x2555;
constexpr HDenum kHdNominalMaxStiffness = 0x2602, kHdNominalMaxForce = 0x2603;
constexpr HDenum kHdCurrentForce = 0x2700;
constexpr HDenum kHdForceOutput = 0x4000;
constexpr HDenum kHdCalibrationOk = 0x5000, kHdCalibrationNeedsUpdate = 0x5001,
                 kHdCalibrationNeedsManualInput = 0x5002;
constexpr int kHdCalEncoderReset = 1 << 0, kHdCalAuto = 1 << 1, kHdCalInkwell = 1 << 2;
constexpr HDCallbackCode kHdCallbackContinue = 1;  // HD_CALLBACK_DONE is 0
constexpr unsigned short kHdMaxSchedulerPriority = 0xFFFF;

struct HdApi {
  HHD (*hdInitDevice)(const char*) = nullptr;
  void (*hdDisableDevice)(HHD) = nullptr;
  void (*hdMakeCurrentDevice)(HHD) = nullptr;
  HDErrorInfo (*hdGetError)() = nullptr;
  const char* (*hdGetErrorString)(HDerror) = nullptr;
  void (*hdEnable)(HDenum) = nullptr;
  void (*hdDisable)(HDenum) = nullptr;
  void (*hdStartScheduler)() = nullptr;
  void (*hdStopScheduler)() = nullptr;
  HDSchedulerHandle (*hdScheduleAsynchronous)(HDSchedulerCallback, void*, unsigned short) = nullptr;
  void (*hdScheduleSynchronous)(HDSchedulerCallback, void*, unsigned short) = nullptr;
  void (*hdUnschedule)(HDSchedulerHandle) = nullptr;
  void (*hdBeginFrame)(HHD) = nullptr;
  void (*hdEndFrame)(HHD) = nullptr;
  void (*hdGetDoublev)(HDenum, double*) = nullptr;
  void (*hdGetIntegerv)(HDenum, int*) = nullptr;
  const char* (*hdGetString)(HDenum) = nullptr;
  void (*hdSetDoublev)(HDenum, const double*) = nullptr;
  HDenum (*hdCheckCalibration)() = nullptr;
  void (*hdUpdateCalibration)(HDenum) = nullptr;

  // Returns the first missing symbol's name, or "" when all are there.
  std::string load(const detail::DlLibrary& l) {
#define DENTAR_HD_SYM(s) \
  if (!l.sym(#s, s)) return #s;
    DENTAR_HD_SYM(hdInitDevice)
    DENTAR_HD_SYM(hdDisableDevice)
    DENTAR_HD_SYM(hdMakeCurrentDevice)
    DENTAR_HD_SYM(hdGetError)
    DENTAR_HD_SYM(hdGetErrorString)
    DENTAR_HD_SYM(hdEnable)
    DENTAR_HD_SYM(hdDisable)
    DENTAR_HD_SYM(hdStartScheduler)
    DENTAR_HD_SYM(hdStopScheduler)
    DENTAR_HD_SYM(hdScheduleAsynchronous)
    DENTAR_HD_SYM(hdScheduleSynchronous)
    DENTAR_HD_SYM(hdUnschedule)
    DENTAR_HD_SYM(hdBeginFrame)
    DENTAR_HD_SYM(hdEndFrame)
    DENTAR_HD_SYM(hdGetDoublev)
    DENTAR_HD_SYM(hdGetIntegerv)
    DENTAR_HD_SYM(hdGetString)
    DENTAR_HD_SYM(hdSetDoublev)
    DENTAR_HD_SYM(hdCheckCalibration)
    DENTAR_HD_SYM(hdUpdateCalibration)
#undef DENTAR_HD_SYM
    return {};
  }
};

const char* hd_error_name(HDerror e) {
  switch (e) {
    case kHdWarmMotors: return "HD_WARM_MOTORS";
    case kHdExceededMaxForce: return "HD_EXCEEDED_MAX_FORCE";
    case kHdExceededMaxForceImpulse: return "HD_EXCEEDED_MAX_FORCE_IMPULSE";
    case kHdExceededMaxVelocity: return "HD_EXCEEDED_MAX_VELOCITY";
    case kHdForceError: return "HD_FORCE_ERROR";
    case kHdDeviceFault: return "HD_DEVICE_FAULT";
    case kHdDeviceAlreadyInitiated: return "HD_DEVICE_ALREADY_INITIATED";
    case kHdCommError: return "HD_COMM_ERROR";
    case kHdCommConfigError: return "HD_COMM_CONFIG_ERROR";
    case kHdTimerError: return "HD_TIMER_ERROR";
    case kHdInvalidLicense: return "HD_INVALID_LICENSE";
    default: return "HD error";
  }
}

// What to do about an HD error code.
const char* hd_error_advice(HDerror e) {
  switch (e) {
    case kHdCommError:
    case kHdCommConfigError:
    case kHdDeviceFault:
      return "check the device's cable and power, then run Touch_Setup to see that the "
             "configuration finds it";
    case kHdDeviceAlreadyInitiated:
      return "another program holds the device: close it (or the other dentar) and start again";
    case kHdInvalidLicense: return "the OpenHaptics licence is not valid on this machine";
    case kHdWarmMotors: return "the motors are hot: let the device rest a few minutes";
    case kHdExceededMaxForce:
    case kHdExceededMaxForceImpulse:
    case kHdExceededMaxVelocity:
    case kHdForceError:
      return "the device's own safety limit tripped; forces resume after steady readings";
    case kHdTimerError:
      return "the HD servo missed its deadline: the machine is overloaded";
    default: return "see the OpenHaptics error list";
  }
}

bool hd_error_means_unplugged(HDerror e) {
  return e == kHdCommError || e == kHdCommConfigError || e == kHdDeviceFault;
}

struct ServoState {
  double T_mm[16];      // column-major 4x4, translation in mm
  double v_mm_s[3];
  int buttons;
  unsigned calibration;  // HD_CALIBRATION_*
  HDerror last_error;
  int last_internal;
  std::uint64_t error_seq;  // errors seen so far (sticky, so read() cannot miss one)
  // Session 21: samples with NaN/Inf and pose jumps, judged tick to tick by the servo (sticky
  // as errors are); jump_m: the latest jump, m.
  std::uint64_t nonfinite_seq, jump_seq;
  double jump_m;
  std::uint64_t tick;
  double stamp_s;           // CLOCK_MONOTONIC at the tick
};
struct ForceCmd {
  double f[3];
  double stamp_s;  // when the engine wrote it
};

std::string make_hd_message(const HdApi& api, HDErrorInfo e) {
  std::ostringstream os;
  const char* s = api.hdGetErrorString ? api.hdGetErrorString(e.errorCode) : nullptr;
  char code[16];
  std::snprintf(code, sizeof code, "0x%04x", e.errorCode);
  os << hd_error_name(e.errorCode) << " (" << code;
  if (e.internalErrorCode) os << ", internal " << e.internalErrorCode;
  os << ")";
  if (s && *s) os << ": " << s;
  os << "; " << hd_error_advice(e.errorCode);
  return os.str();
}

// Empties HD's error stack (bounded: a broken runtime cannot hang us).
void drain_errors(const HdApi& a) {
  for (int i = 0; i < 64 && a.hdGetError().errorCode != kHdSuccess; ++i) {
  }
}

int leading_int(const std::string& s) {
  std::size_t i = 0;
  while (i < s.size() && !std::isdigit(static_cast<unsigned char>(s[i]))) ++i;
  int v = -1;
  if (i < s.size()) v = std::atoi(s.c_str() + i);
  return v;
}

}  // namespace

struct HdDevice::Impl {
  detail::DlLibrary lib;
  HdApi api;
  HHD hhd = kHdInvalidHandle;
  HDSchedulerHandle sched = 0;
  bool scheduler_started = false;
  DeviceOpenOptions opts;
  double max_force_N = 3.3;
  double t0_s = 0;  // CLOCK_MONOTONIC at open: DeviceState::time_s counts from here
  SeqLock<ServoState> state;
  SeqLock<ForceCmd> force;
  std::atomic<bool> closing{false};
  // Servo-thread only.
  std::uint64_t tick = 0;
  std::uint64_t error_seq = 0;
  HDerror last_error = kHdSuccess;
  int last_internal = 0;
  unsigned calibration = kHdCalibrationOk;
  int cal_style = 0;
  std::uint64_t ticks_since_error = 1u << 30;
  std::uint64_t nonfinite_seq = 0, jump_seq = 0;
  double jump_m = 0;
  bool have_prev = false;
  double prev_mm[3] = {0, 0, 0};  // the last finite sample's position
  // Engine-thread only.
  std::uint64_t seen_error_seq = 0, seen_nonfinite_seq = 0, seen_jump_seq = 0;

  static HDCallbackCode servo(void* user) noexcept {
    auto* self = static_cast<Impl*>(user);
    self->servo_tick();
    return kHdCallbackContinue;
  }

  void servo_tick() noexcept {
    const HdApi& a = api;
    const double now = detail::monotonic_s();
    ServoState s{};
    a.hdBeginFrame(hhd);
    a.hdGetDoublev(kHdCurrentTransform, s.T_mm);
    a.hdGetDoublev(kHdCurrentVelocity, s.v_mm_s);
    a.hdGetIntegerv(kHdCurrentButtons, &s.buttons);
    // NaN and pose jumps are judged here, sample to sample (1 ms apart), and latched like errors:
    // an engine read held off for several ticks (a loaded machine) neither misses a short NaN
    // burst nor counts the stylus's own motion over its gap as a jump (session 21: a reader 10
    // ticks late measured an 8 mm jump as 7.7 mm; at 0.5 m/s a 10 ms gap is a false 5 mm jump).
    bool finite = std::isfinite(s.v_mm_s[0]) && std::isfinite(s.v_mm_s[1]) && std::isfinite(s.v_mm_s[2]);
    for (const double x : s.T_mm) finite = finite && std::isfinite(x);
    if (!finite) {
      ++nonfinite_seq;
    } else {
      const double* p = s.T_mm + 12;
      if (have_prev) {
        const double dx = p[0] - prev_mm[0], dy = p[1] - prev_mm[1], dz = p[2] - prev_mm[2];
        const double d_m = 1e-3 * std::sqrt(dx * dx + dy * dy + dz * dz);
        if (d_m > opts.max_pose_jump_m) {
          ++jump_seq;
          jump_m = d_m;
        }
      }
      for (int i = 0; i < 3; ++i) prev_mm[i] = p[i];
      have_prev = true;
    }
    // Calibration: checked at start and every 0.25 s; an automatic update is
    // done here, a manual one (inkwell) waits for the user.
    if (tick % 250 == 0) {
      calibration = a.hdCheckCalibration();
      if (calibration == kHdCalibrationNeedsUpdate && (cal_style & (kHdCalAuto | kHdCalEncoderReset))) {
        a.hdUpdateCalibration((cal_style & kHdCalAuto) ? kHdCalAuto : kHdCalEncoderReset);
        calibration = a.hdCheckCalibration();
      }
    }
    const ForceCmd cmd = force.load();
    double f[3] = {0, 0, 0};
    const bool fresh = !closing.load(std::memory_order_acquire) && now - cmd.stamp_s <= opts.stale_limit_s &&
                       std::isfinite(cmd.f[0]) && std::isfinite(cmd.f[1]) && std::isfinite(cmd.f[2]);
    const bool cal_ok = calibration == kHdCalibrationOk || opts.allow_uncalibrated;
    // After a runtime error the servo itself sends zero (at once, not a step
    // later through the engine) until the engine's fault has cleared.
    const bool quiet = ++ticks_since_error > static_cast<std::uint64_t>(opts.fault_clear_steps);
    if (fresh && cal_ok && quiet) {
      const double n = std::sqrt(cmd.f[0] * cmd.f[0] + cmd.f[1] * cmd.f[1] + cmd.f[2] * cmd.f[2]);
      const double scale = n > max_force_N ? max_force_N / n : 1.0;
      for (int i = 0; i < 3; ++i) f[i] = cmd.f[i] * scale;
    }
    a.hdSetDoublev(kHdCurrentForce, f);
    a.hdEndFrame(hhd);
    for (int guard = 0; guard < 8; ++guard) {  // drain the error stack
      const HDErrorInfo e = a.hdGetError();
      if (e.errorCode == kHdSuccess) break;
      last_error = e.errorCode;
      last_internal = e.internalErrorCode;
      ++error_seq;
      ticks_since_error = 0;
    }
    s.calibration = calibration;
    s.last_error = last_error;
    s.last_internal = last_internal;
    s.error_seq = error_seq;
    s.nonfinite_seq = nonfinite_seq;
    s.jump_seq = jump_seq;
    s.jump_m = jump_m;
    s.tick = ++tick;
    s.stamp_s = now;
    state.store(s);
  }
};

RuntimeInfo probe_hd_runtime(const std::string& library) {
  RuntimeInfo r;
  r.runtime = "OpenHaptics HD";
  r.requested = detail::library_or_env(library, "DENTAR_HD_LIBRARY", "libHD.so");
  detail::DlLibrary lib;
  std::string err;
  if (!lib.open(r.requested, err)) {
    r.message = "not found: " + err +
                ". Install OpenHaptics for Linux and the Touch device driver from 3D Systems, or "
                "set DENTAR_HD_LIBRARY to libHD.so's path";
    return r;
  }
  r.path = lib.path();
  r.version = detail::version_from_filename(r.path);
  HdApi api;
  if (const std::string missing = api.load(lib); !missing.empty()) {
    r.message = r.path + " has no " + missing +
                ": not an OpenHaptics 3.x runtime; install OpenHaptics 3.4 or newer";
    return r;
  }
  r.present = true;
  r.message = "ok";
  return r;
}

Result<std::unique_ptr<HdDevice>> HdDevice::open(const DeviceOpenOptions& o) {
  std::unique_ptr<HdDevice> d(new HdDevice());
  d->impl_ = std::make_unique<Impl>();
  Impl& m = *d->impl_;
  m.opts = o;
  const std::string libname = detail::library_or_env(o.library, "DENTAR_HD_LIBRARY", "libHD.so");
  std::string err;
  if (!m.lib.open(libname, err))
    return Error{"OpenHaptics runtime not found: " + err +
                 ". Install OpenHaptics for Linux and the Touch device driver (3D Systems), or set "
                 "DENTAR_HD_LIBRARY to libHD.so's path"};
  if (const std::string missing = m.api.load(m.lib); !missing.empty())
    return Error{"OpenHaptics runtime " + m.lib.path() + " has no " + missing +
                 ": it is not OpenHaptics 3.x; install OpenHaptics 3.4 or newer"};
  const HdApi& a = m.api;
  drain_errors(a);

  // Open: by configuration name; else the default device, matched by serial.
  const std::string& want = o.name_or_serial;
  m.hhd = a.hdInitDevice(want.empty() ? nullptr : want.c_str());
  HDErrorInfo e = a.hdGetError();
  bool by_serial = false;
  if ((m.hhd == kHdInvalidHandle || e.errorCode != kHdSuccess) && !want.empty()) {
    if (m.hhd != kHdInvalidHandle) a.hdDisableDevice(m.hhd);
    drain_errors(a);  // the failed attempt's errors
    m.hhd = a.hdInitDevice(nullptr);
    e = a.hdGetError();
    by_serial = true;
  }
  if (m.hhd == kHdInvalidHandle || e.errorCode != kHdSuccess) {
    if (m.hhd != kHdInvalidHandle) a.hdDisableDevice(m.hhd);
    m.hhd = kHdInvalidHandle;
    return Error{"cannot open the HD device '" + (want.empty() ? std::string("Default Device") : want) +
                 "': " + make_hd_message(a, e)};
  }
  a.hdMakeCurrentDevice(m.hhd);
  auto str = [&](HDenum what) {
    const char* s = a.hdGetString(what);
    return std::string(s ? s : "");
  };
  d->info_.backend = "hd";
  d->info_.model = str(kHdDeviceModelType);
  d->info_.serial = str(kHdDeviceSerialNumber);
  d->info_.runtime_version = str(kHdVersion);
  if (d->info_.runtime_version.empty()) d->info_.runtime_version = detail::version_from_filename(m.lib.path());
  auto fail = [&](const std::string& msg) -> Result<std::unique_ptr<HdDevice>> {
    a.hdDisableDevice(m.hhd);
    m.hhd = kHdInvalidHandle;
    return Error{msg};
  };
  if (by_serial && d->info_.serial != want)
    return fail("no HD device is configured as '" + want + "' and the default device's serial is '" +
                d->info_.serial + "'; give the configuration name from Touch_Setup or the serial");
  if (const int major = leading_int(d->info_.runtime_version); major >= 0 && major < 3)
    return fail("OpenHaptics " + d->info_.runtime_version + " at " + m.lib.path() +
                " is too old: version 3.0 or newer is needed (3.4 for the Touch)");

  // Profile: asked for, else from the model name.
  d->profile_ = find_device_profile(o.profile.empty() ? d->info_.model : o.profile);
  if (!d->profile_ && o.profile.empty()) d->profile_ = find_device_profile("touch");
  if (!d->profile_) return fail("unknown device profile '" + o.profile + "'");
  if (d->profile_->backend != "hd")
    return fail("profile '" + d->profile_->id + "' is a Force Dimension device, not an HD one");
  d->info_.profile_id = d->profile_->id;
  d->limits_ = limits_from_profile(*d->profile_);
  // Never above what the device itself reports (HD gives N/mm and N).
  double nominal_k = 0, nominal_f = 0;
  a.hdGetDoublev(kHdNominalMaxStiffness, &nominal_k);
  a.hdGetDoublev(kHdNominalMaxForce, &nominal_f);
  if (std::isfinite(nominal_k) && nominal_k > 0)
    d->limits_.max_stiffness_N_per_m = std::min(d->limits_.max_stiffness_N_per_m, 1e3 * nominal_k);
  if (std::isfinite(nominal_f) && nominal_f > 0)
    d->limits_.max_force_N = std::min(d->limits_.max_force_N, nominal_f);
  m.max_force_N = d->limits_.max_force_N;
  a.hdGetIntegerv(kHdCalibrationStyle, &m.cal_style);
  drain_errors(a);

  d->monitor_.configure(o);
  d->monitor_.jumps_judged_by_backend();  // the servo, tick to tick (servo_tick)
  ForceCmd zero{};
  zero.stamp_s = -1e9;  // stale: the servo sends zero until the engine writes
  m.force.store(zero);
  m.t0_s = detail::monotonic_s();
  a.hdEnable(kHdForceOutput);
  a.hdStartScheduler();
  m.scheduler_started = true;
  e = a.hdGetError();
  if (e.errorCode != kHdSuccess) return fail("cannot start the HD scheduler: " + make_hd_message(a, e));
  m.sched = a.hdScheduleAsynchronous(&Impl::servo, &m, kHdMaxSchedulerPriority);
  e = a.hdGetError();
  if (e.errorCode != kHdSuccess) {
    a.hdStopScheduler();
    m.scheduler_started = false;
    return fail("cannot schedule the servo callback: " + make_hd_message(a, e));
  }
  // Wait for the first tick (the scheduler runs at 1 kHz).
  const auto t0 = std::chrono::steady_clock::now();
  while (m.state.load().tick == 0) {
    if (std::chrono::steady_clock::now() - t0 > std::chrono::milliseconds(500)) {
      a.hdStopScheduler();
      a.hdUnschedule(m.sched);
      m.scheduler_started = false;
      return fail("the HD servo did not tick within 0.5 s after hdStartScheduler");
    }
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  const unsigned cal = m.state.load().calibration;
  d->info_.calibration = cal == kHdCalibrationOk ? "ok"
                         : cal == kHdCalibrationNeedsUpdate
                             ? "needs update (automatic)"
                             : "needs manual input: put the stylus in the inkwell";
  // A device that needs the inkwell is not an error: it stays open, reads as
  // faulted (zero force), status() asks for the inkwell, and it clears by
  // itself once calibrated.
  return d;
}

HdDevice::~HdDevice() {
  if (!impl_) return;
  Impl& m = *impl_;
  const HdApi& a = m.api;
  if (m.hhd == kHdInvalidHandle) return;
  m.closing.store(true, std::memory_order_release);  // the servo sends zero from now on
  if (m.scheduler_started) {
    std::this_thread::sleep_for(std::chrono::milliseconds(3));
    a.hdStopScheduler();
    a.hdUnschedule(m.sched);
  }
  a.hdDisable(kHdForceOutput);
  a.hdDisableDevice(m.hhd);
}

std::string HdDevice::name() const {
  return "HD " + (info_.model.empty() ? std::string("device") : info_.model) +
         (info_.serial.empty() ? "" : " #" + info_.serial);
}

std::uint64_t HdDevice::servo_ticks() const noexcept { return impl_->state.load().tick; }
double HdDevice::opened_at_s() const noexcept { return impl_->t0_s; }

bool HdDevice::read(DeviceState& out) noexcept {
  Impl& m = *impl_;
  const ServoState s = m.state.load();
  const double now = detail::monotonic_s();
  DeviceFault ext = DeviceFault::kNone;
  int code = 0;
  double jump_m = 0;
  if (s.tick == 0 || now - s.stamp_s > m.opts.stale_limit_s) {
    ext = DeviceFault::kStalled;
  } else if (s.error_seq != m.seen_error_seq) {
    m.seen_error_seq = s.error_seq;
    code = static_cast<int>(s.last_error);
    ext = hd_error_means_unplugged(s.last_error) ? DeviceFault::kUnplugged : DeviceFault::kRuntimeError;
  } else if (s.nonfinite_seq != m.seen_nonfinite_seq) {
    m.seen_nonfinite_seq = s.nonfinite_seq;
    ext = DeviceFault::kNonFinite;
  } else if (s.jump_seq != m.seen_jump_seq) {
    m.seen_jump_seq = s.jump_seq;
    ext = DeviceFault::kPoseJump;
    jump_m = s.jump_m;
  } else if (s.calibration != kHdCalibrationOk && !m.opts.allow_uncalibrated) {
    ext = DeviceFault::kNotCalibrated;
  }
  Eigen::Matrix4d M = Eigen::Map<const Eigen::Matrix4d>(s.T_mm);
  out.T_dev_sty = Eigen::Isometry3d::Identity();
  out.T_dev_sty.linear() = M.topLeftCorner<3, 3>();
  out.T_dev_sty.translation() = 1e-3 * M.topRightCorner<3, 1>();
  out.velocity_m_per_s = 1e-3 * Eigen::Vector3d(s.v_mm_s[0], s.v_mm_s[1], s.v_mm_s[2]);
  out.time_s = s.stamp_s - m.t0_s;  // the servo tick's time, s since open
  out.buttons = (s.buttons & 1 ? kButtonPrimary : 0u) | (s.buttons & 2 ? kButtonSecondary : 0u);
  const bool ok = monitor_.check(out.T_dev_sty, out.velocity_m_per_s, ext, code, jump_m);
  out.fault = !ok;
  return ok;
}

void HdDevice::write_force(const Eigen::Vector3d& f) noexcept {
  ForceCmd c;
  const bool ok = f.allFinite() && !monitor_.faulted();
  for (int i = 0; i < 3; ++i) c.f[i] = ok ? f[i] : 0.0;
  c.stamp_s = detail::monotonic_s();
  impl_->force.store(c);
}

std::string HdDevice::status() const {
  std::ostringstream os;
  os << name() << " [" << info_.profile_id << "]: ";
  if (!monitor_.faulted()) {
    os << "ok";
    return os.str();
  }
  const DeviceFault f = monitor_.latest();
  os << "zero force: " << device_fault_name(f);
  if (f == DeviceFault::kRuntimeError || f == DeviceFault::kUnplugged) {
    HDErrorInfo e{static_cast<HDerror>(monitor_.runtime_error()), 0, 0};
    os << ", " << make_hd_message(impl_->api, e);
  } else if (f == DeviceFault::kPoseJump) {
    os << " of " << std::fixed << std::setprecision(1) << 1e3 * monitor_.last_jump_m()
       << " mm in one reading; " << device_fault_advice(f);
  } else {
    os << "; " << device_fault_advice(f);
  }
  return os.str();
}

}  // namespace dentar::haptics
