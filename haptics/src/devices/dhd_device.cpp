// Force Dimension DHD backend. The DHD C API subset used here is declared
// locally (signatures and constants as in the DHD SDK 3.x dhdc.h), so no
// vendor header is needed to build.
#include "dentar/haptics/dhd_device.h"

#include <cctype>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "dl_library.h"

namespace dentar::haptics {
namespace {

constexpr int kDhdErrorCom = 2, kDhdErrorNoDriver = 4, kDhdErrorNoDevice = 5, kDhdErrorTimeout = 7,
              kDhdErrorNotReady = 12, kDhdErrorInUse = 20;
constexpr int kDhdStatusError = 9;

struct DhdApi {
  int (*dhdGetDeviceCount)() = nullptr;
  int (*dhdOpenID)(char) = nullptr;
  int (*dhdOpenSerial)(int) = nullptr;  // optional
  int (*dhdClose)(char) = nullptr;
  int (*dhdGetSystemType)(char) = nullptr;
  const char* (*dhdGetSystemName)(char) = nullptr;  // optional (SDK >= 3.2)
  int (*dhdGetSerialNumber)(unsigned short*, char) = nullptr;  // optional
  void (*dhdGetSDKVersion)(int*, int*, int*, int*) = nullptr;
  int (*dhdGetStatus)(int*, char) = nullptr;  // optional
  int (*dhdGetPosition)(double*, double*, double*, char) = nullptr;
  int (*dhdGetLinearVelocity)(double*, double*, double*, char) = nullptr;
  int (*dhdGetOrientationFrame)(double[3][3], char) = nullptr;  // optional
  bool (*dhdHasWrist)(char) = nullptr;                          // optional
  unsigned int (*dhdGetButtonMask)(char) = nullptr;
  int (*dhdSetForce)(double, double, double, char) = nullptr;
  int (*dhdEnableForce)(unsigned char, char) = nullptr;
  int (*dhdErrorGetLast)() = nullptr;
  const char* (*dhdErrorGetStr)(int) = nullptr;
  bool (*drdIsInitialized)(char) = nullptr;  // optional (libdrd only)

  std::string load(const detail::DlLibrary& l) {
#define DENTAR_DHD_SYM(s) \
  if (!l.sym(#s, s)) return #s;
    DENTAR_DHD_SYM(dhdGetDeviceCount)
    DENTAR_DHD_SYM(dhdOpenID)
    DENTAR_DHD_SYM(dhdClose)
    DENTAR_DHD_SYM(dhdGetSystemType)
    DENTAR_DHD_SYM(dhdGetSDKVersion)
    DENTAR_DHD_SYM(dhdGetPosition)
    DENTAR_DHD_SYM(dhdGetLinearVelocity)
    DENTAR_DHD_SYM(dhdGetButtonMask)
    DENTAR_DHD_SYM(dhdSetForce)
    DENTAR_DHD_SYM(dhdEnableForce)
    DENTAR_DHD_SYM(dhdErrorGetLast)
    DENTAR_DHD_SYM(dhdErrorGetStr)
#undef DENTAR_DHD_SYM
    l.sym("dhdOpenSerial", dhdOpenSerial);
    l.sym("dhdGetSystemName", dhdGetSystemName);
    l.sym("dhdGetSerialNumber", dhdGetSerialNumber);
    l.sym("dhdGetStatus", dhdGetStatus);
    l.sym("dhdGetOrientationFrame", dhdGetOrientationFrame);
    l.sym("dhdHasWrist", dhdHasWrist);
    l.sym("drdIsInitialized", drdIsInitialized);
    return {};
  }
  std::string error_text(int code) const {
    const char* s = dhdErrorGetStr ? dhdErrorGetStr(code) : nullptr;
    std::ostringstream os;
    os << "DHD error " << code;
    if (s && *s) os << " (" << s << ")";
    os << "; ";
    switch (code) {
      case kDhdErrorCom:
      case kDhdErrorNoDevice:
      case kDhdErrorTimeout:
        os << "check the USB cable and the device's power switch";
        break;
      case kDhdErrorNoDriver:
        os << "the Force Dimension USB driver is missing: install the SDK's udev rule and driver";
        break;
      case kDhdErrorNotReady: os << "the device is not ready: release the force button and wait"; break;
      case kDhdErrorInUse: os << "another program holds the device: close it"; break;
      default: os << "see the Force Dimension SDK error list"; break;
    }
    return os.str();
  }
};

const char* profile_for_type(int t) {
  switch (t) {
    case 31: case 61: case 62: case 63: case 64: return "delta";
    case 32: case 33: case 34: case 35: case 36: case 37: return "omega";
    case 60: return "falcon";
    case 104: case 105: case 106: case 107: return "sigma";
    default: return nullptr;
  }
}

bool all_digits(const std::string& s) {
  if (s.empty()) return false;
  for (char c : s)
    if (!std::isdigit(static_cast<unsigned char>(c))) return false;
  return true;
}

std::string sdk_version(const DhdApi& a) {
  int ma = 0, mi = 0, re = 0, rv = 0;
  a.dhdGetSDKVersion(&ma, &mi, &re, &rv);
  std::ostringstream os;
  os << ma << "." << mi << "." << re << "-" << rv;
  return os.str();
}

bool load_dhd(detail::DlLibrary& lib, const std::string& requested, std::string& err) {
  if (!requested.empty()) return lib.open(requested, err);
  if (const char* e = std::getenv("DENTAR_DHD_LIBRARY"); e && *e) return lib.open(e, err);
  std::string e1;
  if (lib.open("libdrd.so", e1)) return true;
  return lib.open("libdhd.so", err);
}

}  // namespace

struct DhdDevice::Impl {
  detail::DlLibrary lib;
  DhdApi api;
  char id = -1;
  bool open = false;
  bool wrist = false;
  DeviceOpenOptions opts;
  double max_force_N = 12.0;
  double t0_s = 0;  // CLOCK_MONOTONIC at open: DeviceState::time_s counts from here
  // Haptic thread.
  int pending_error = 0;   // from write_force, reported by the next read
  bool pending_stall = false;
};

RuntimeInfo probe_dhd_runtime(const std::string& library) {
  RuntimeInfo r;
  r.runtime = "Force Dimension DHD";
  detail::DlLibrary lib;
  std::string err;
  r.requested = library.empty() ? "libdrd.so or libdhd.so" : library;
  if (!load_dhd(lib, library, err)) {
    r.message = "not found: " + err +
                ". Install the Force Dimension SDK (its lib/ holds libdhd.so and libdrd.so) or set "
                "DENTAR_DHD_LIBRARY to the library's path";
    return r;
  }
  r.path = lib.path();
  DhdApi api;
  if (const std::string missing = api.load(lib); !missing.empty()) {
    r.message = r.path + " has no " + missing + ": install Force Dimension SDK 3.x";
    return r;
  }
  r.version = sdk_version(api);
  int major = 0, d1, d2, d3;
  api.dhdGetSDKVersion(&major, &d1, &d2, &d3);
  if (major < 3) {
    r.message = "SDK " + r.version + " is too old: version 3.0 or newer is needed";
    return r;
  }
  r.present = true;
  r.message = "ok";
  return r;
}

std::vector<std::string> DhdDevice::list(const std::string& library, std::string& why_none) {
  std::vector<std::string> out;
  detail::DlLibrary lib;
  std::string err;
  if (!load_dhd(lib, library, err)) {
    why_none = "no DHD runtime: " + err;
    return out;
  }
  DhdApi api;
  if (const std::string missing = api.load(lib); !missing.empty()) {
    why_none = "the DHD runtime lacks " + missing;
    return out;
  }
  const int n = api.dhdGetDeviceCount();
  if (n <= 0) {
    why_none = n < 0 ? "dhdGetDeviceCount failed: " + api.error_text(api.dhdErrorGetLast())
                     : "the DHD runtime sees no device (plugged in? powered? udev rule installed?)";
    return out;
  }
  for (int i = 0; i < n; ++i) {
    std::ostringstream os;
    os << "DHD #" << i << ": ";
    const int h = api.dhdOpenID(static_cast<char>(i));
    if (h < 0) {
      os << "cannot open: " << api.error_text(api.dhdErrorGetLast());
    } else {
      const int type = api.dhdGetSystemType(static_cast<char>(h));
      const char* nm = api.dhdGetSystemName ? api.dhdGetSystemName(static_cast<char>(h)) : nullptr;
      os << (nm ? nm : "type " + std::to_string(type));
      unsigned short sn = 0;
      if (api.dhdGetSerialNumber && api.dhdGetSerialNumber(&sn, static_cast<char>(h)) >= 0)
        os << ", serial " << sn;
      const char* prof = profile_for_type(type);
      os << ", profile " << (prof ? prof : "unknown");
      if (api.drdIsInitialized)
        os << ", calibration " << (api.drdIsInitialized(static_cast<char>(h)) ? "ok" : "NOT initialised (run autoinit)");
      else
        os << ", calibration not reported (libdhd without libdrd)";
      api.dhdClose(static_cast<char>(h));
    }
    out.push_back(os.str());
  }
  return out;
}

Result<std::unique_ptr<DhdDevice>> DhdDevice::open(const DeviceOpenOptions& o) {
  std::unique_ptr<DhdDevice> d(new DhdDevice());
  d->impl_ = std::make_unique<Impl>();
  Impl& m = *d->impl_;
  m.opts = o;
  std::string err;
  if (!load_dhd(m.lib, o.library, err))
    return Error{"Force Dimension runtime not found: " + err +
                 ". Install the Force Dimension SDK or set DENTAR_DHD_LIBRARY to libdhd.so's path"};
  if (const std::string missing = m.api.load(m.lib); !missing.empty())
    return Error{"Force Dimension runtime " + m.lib.path() + " has no " + missing +
                 ": install Force Dimension SDK 3.x"};
  const DhdApi& a = m.api;
  d->info_.backend = "dhd";
  d->info_.runtime_version = sdk_version(a);
  {
    int major = 0, x1, x2, x3;
    a.dhdGetSDKVersion(&major, &x1, &x2, &x3);
    if (major < 3)
      return Error{"Force Dimension SDK " + d->info_.runtime_version + " at " + m.lib.path() +
                   " is too old: version 3.0 or newer is needed"};
  }
  const int n = a.dhdGetDeviceCount();
  if (n < 0) return Error{"dhdGetDeviceCount failed: " + a.error_text(a.dhdErrorGetLast())};
  if (n == 0)
    return Error{"no Force Dimension device found: is it plugged in and switched on, and is the "
                 "udev rule (assets/udev/70-dentar.rules) installed?"};
  const std::string& want = o.name_or_serial;
  int h = -1;
  auto name_of = [&](int hh) {
    const char* nm = a.dhdGetSystemName ? a.dhdGetSystemName(static_cast<char>(hh)) : nullptr;
    return std::string(nm ? nm : "");
  };
  if (want.empty()) {
    h = a.dhdOpenID(0);
    if (h < 0) return Error{"cannot open the Force Dimension device #0: " + a.error_text(a.dhdErrorGetLast())};
  } else {
    for (int i = 0; i < n && h < 0; ++i) {
      const int hh = a.dhdOpenID(static_cast<char>(i));
      if (hh < 0) continue;
      unsigned short sn = 0;
      const bool sn_ok = a.dhdGetSerialNumber && a.dhdGetSerialNumber(&sn, static_cast<char>(hh)) >= 0;
      const bool match = all_digits(want) ? (sn_ok && std::to_string(sn) == want)
                                          : (name_of(hh) == want || (find_device_profile(want) &&
                                             find_device_profile(want) == find_device_profile(name_of(hh))));
      if (match)
        h = hh;
      else
        a.dhdClose(static_cast<char>(hh));
    }
    if (h < 0)
      return Error{"no Force Dimension device matches '" + want + "' among " + std::to_string(n) +
                   " found; give a serial number or a system name such as omega.3 (dentar devices lists them)"};
  }
  m.id = static_cast<char>(h);
  m.open = true;
  const int type = a.dhdGetSystemType(m.id);
  d->info_.model = name_of(h);
  if (d->info_.model.empty()) d->info_.model = "type " + std::to_string(type);
  unsigned short sn = 0;
  if (a.dhdGetSerialNumber && a.dhdGetSerialNumber(&sn, m.id) >= 0) d->info_.serial = std::to_string(sn);
  const char* prof = profile_for_type(type);
  d->profile_ = find_device_profile(!o.profile.empty() ? o.profile : prof ? prof : d->info_.model);
  auto fail = [&](const std::string& msg) -> Result<std::unique_ptr<DhdDevice>> {
    a.dhdClose(m.id);
    m.open = false;
    return Error{msg};
  };
  if (!d->profile_)
    return fail("no profile for the Force Dimension device '" + d->info_.model + "' (type " +
                std::to_string(type) + "); pass one with --device omega|sigma|delta|falcon");
  if (d->profile_->backend != "dhd")
    return fail("profile '" + d->profile_->id + "' is an OpenHaptics device, not a Force Dimension one");
  d->info_.profile_id = d->profile_->id;
  if (a.drdIsInitialized) {
    const bool init = a.drdIsInitialized(m.id);
    d->info_.calibration = init ? "ok" : "not initialised";
    if (!init && !o.allow_uncalibrated)
      return fail(d->info_.model + " is not initialised (drdIsInitialized is false): run Force "
                  "Dimension's autoinit tool (the device moves by itself), then start again");
  } else {
    d->info_.calibration = "not reported (libdhd without libdrd)";
  }
  m.wrist = a.dhdGetOrientationFrame && a.dhdHasWrist && a.dhdHasWrist(m.id);
  d->limits_ = limits_from_profile(*d->profile_);
  m.max_force_N = d->limits_.max_force_N;
  d->monitor_.configure(o);
  m.t0_s = detail::monotonic_s();
  a.dhdSetForce(0, 0, 0, m.id);
  if (a.dhdEnableForce(1, m.id) < 0)
    return fail("cannot enable forces on " + d->info_.model + ": " + a.error_text(a.dhdErrorGetLast()));
  return d;
}

DhdDevice::~DhdDevice() {
  if (!impl_ || !impl_->open) return;
  const DhdApi& a = impl_->api;
  a.dhdSetForce(0, 0, 0, impl_->id);
  a.dhdEnableForce(0, impl_->id);
  a.dhdClose(impl_->id);
}

std::string DhdDevice::name() const {
  return "DHD " + info_.model + (info_.serial.empty() ? "" : " #" + info_.serial);
}

bool DhdDevice::read(DeviceState& out) noexcept {
  Impl& m = *impl_;
  const DhdApi& a = m.api;
  const double t0 = detail::monotonic_s();
  double p[3] = {0, 0, 0}, v[3] = {0, 0, 0};
  int code = 0;
  DeviceFault ext = DeviceFault::kNone;
  int rc = a.dhdGetPosition(&p[0], &p[1], &p[2], m.id);
  if (rc >= 0) rc = a.dhdGetLinearVelocity(&v[0], &v[1], &v[2], m.id);
  double R[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  if (rc >= 0 && m.wrist) rc = a.dhdGetOrientationFrame(R, m.id);
  const unsigned buttons = rc >= 0 ? a.dhdGetButtonMask(m.id) : 0u;
  const double t1 = detail::monotonic_s();
  if (rc < 0 || m.pending_error) {
    code = rc < 0 ? a.dhdErrorGetLast() : m.pending_error;
    ext = (code == kDhdErrorCom || code == kDhdErrorNoDevice || code == kDhdErrorTimeout)
              ? DeviceFault::kUnplugged
              : DeviceFault::kRuntimeError;
  } else if (t1 - t0 > m.opts.stale_limit_s || m.pending_stall) {
    ext = DeviceFault::kStalled;
  }
  m.pending_error = 0;
  m.pending_stall = false;
  out.T_dev_sty = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out.T_dev_sty.linear()(r, c) = R[r][c];
  out.T_dev_sty.translation() = Eigen::Vector3d(p[0], p[1], p[2]);
  out.velocity_m_per_s = Eigen::Vector3d(v[0], v[1], v[2]);
  out.time_s = t1 - m.t0_s;  // s since open
  out.buttons = (buttons & 1u ? kButtonPrimary : 0u) | (buttons & 2u ? kButtonSecondary : 0u);
  const bool ok = monitor_.check(out.T_dev_sty, out.velocity_m_per_s, ext, code);
  out.fault = !ok;
  return ok;
}

void DhdDevice::write_force(const Eigen::Vector3d& f_in) noexcept {
  Impl& m = *impl_;
  Eigen::Vector3d f = (f_in.allFinite() && !monitor_.faulted()) ? f_in : Eigen::Vector3d::Zero();
  const double n = f.norm();
  if (n > m.max_force_N) f *= m.max_force_N / n;
  const double t0 = detail::monotonic_s();
  if (m.api.dhdSetForce(f.x(), f.y(), f.z(), m.id) < 0) m.pending_error = m.api.dhdErrorGetLast();
  if (detail::monotonic_s() - t0 > m.opts.stale_limit_s) m.pending_stall = true;
}

std::string DhdDevice::status() const {
  std::ostringstream os;
  os << name() << " [" << info_.profile_id << "]: ";
  if (!monitor_.faulted()) {
    os << "ok";
    return os.str();
  }
  const DeviceFault f = monitor_.latest();
  os << "zero force: " << device_fault_name(f);
  if (f == DeviceFault::kRuntimeError || f == DeviceFault::kUnplugged)
    os << ", " << impl_->api.error_text(monitor_.runtime_error());
  else if (f == DeviceFault::kPoseJump)
    os << " of " << std::fixed << std::setprecision(1) << 1e3 * monitor_.last_jump_m()
       << " mm in one reading; " << device_fault_advice(f);
  else
    os << "; " << device_fault_advice(f);
  return os.str();
}

}  // namespace dentar::haptics
