// Stand-in for Force Dimension's libdhd.so (with drdIsInitialized, as
// libdrd.so has it), built in the test tree: the DHD C API subset DhdDevice
// calls, scripted motion, recorded forces and injected faults. DHD has no
// scheduler: each dhdGetPosition() is one servo tick here, as each call is
// one USB exchange on the real device.
//
// Motion: a circle in the x-y plane (m) around `centre`, radius `amp`, `freq` Hz,
// timed by the tick count at 1 kHz. Units m, m/s, N, as the real runtime.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace {

enum Fault { kUnplug = 1, kErrorOnce = 2, kNaNOnce = 3, kJump = 4, kLateCall = 5, kNoDevice = 6 };
struct Injection {
  int kind;
  long tick;
  double arg;
  bool done;
};

struct State {
  std::mutex mu;
  int type = 33;  // DHD_DEVICE_OMEGA3
  std::string name = "omega.3";
  int serial = 12345;
  int sdk[4] = {3, 7, 2, 1234};
  bool initialised = true;
  int count = 1;
  double centre[3] = {0, 0, 0}, amp = 0.01, freq = 0.5;
  std::vector<Injection> faults;
  std::vector<double> forces;
  bool open = false, force_on = false, unplugged = false;
  double jump = 0;
  int last_error = 0;
  long tick = 0;
  double p[3] = {0, 0, 0}, v[3] = {0, 0, 0};
  unsigned buttons = 0;
};
State& S() {
  static State* s = new State();
  return *s;
}

bool device_gone(State& s) {
  if (s.unplugged) {
    s.last_error = 2;  // DHD_ERROR_COM
    return true;
  }
  return false;
}

}  // namespace

extern "C" {

int dhdGetDeviceCount() {
  std::lock_guard<std::mutex> l(S().mu);
  for (const auto& f : S().faults)
    if (f.kind == kNoDevice) return 0;
  return S().count;
}
int dhdOpenID(char id) {
  State& s = S();
  std::lock_guard<std::mutex> l(s.mu);
  if (id < 0 || id >= s.count) {
    s.last_error = 15;  // DHD_ERROR_INVALID_INDEX
    return -1;
  }
  if (s.open) {
    s.last_error = 20;  // DHD_ERROR_DEVICE_IN_USE
    return -1;
  }
  s.open = true;
  return id;
}
int dhdClose(char) {
  std::lock_guard<std::mutex> l(S().mu);
  S().open = false;
  S().force_on = false;
  return 0;
}
int dhdGetSystemType(char) {
  std::lock_guard<std::mutex> l(S().mu);
  return S().type;
}
const char* dhdGetSystemName(char) {
  std::lock_guard<std::mutex> l(S().mu);
  return S().name.c_str();
}
int dhdGetSerialNumber(unsigned short* sn, char) {
  std::lock_guard<std::mutex> l(S().mu);
  *sn = static_cast<unsigned short>(S().serial);
  return 0;
}
void dhdGetSDKVersion(int* a, int* b, int* c, int* d) {
  std::lock_guard<std::mutex> l(S().mu);
  *a = S().sdk[0];
  *b = S().sdk[1];
  *c = S().sdk[2];
  *d = S().sdk[3];
}
bool dhdHasWrist(char) { return false; }
bool drdIsInitialized(char) {
  std::lock_guard<std::mutex> l(S().mu);
  return S().initialised;
}
int dhdGetPosition(double* x, double* y, double* z, char) {
  State& s = S();
  double late_ms = 0;
  {
    std::lock_guard<std::mutex> l(s.mu);
    const long t = s.tick++;
    const double ts = static_cast<double>(t) * 1e-3, w = 2 * M_PI * s.freq;
    double p[3] = {s.centre[0] + s.amp * std::cos(w * ts), s.centre[1] + s.amp * std::sin(w * ts), s.centre[2]};
    s.v[0] = -s.amp * w * std::sin(w * ts);
    s.v[1] = s.amp * w * std::cos(w * ts);
    s.v[2] = 0;
    int err_once = 0;
    for (auto& f : s.faults) {
      if (f.tick > t) continue;
      if (f.kind == kUnplug) s.unplugged = true;
      if (f.done) continue;
      if (f.kind == kErrorOnce) err_once = static_cast<int>(f.arg);
      if (f.kind == kNaNOnce) p[2] = std::nan("");
      if (f.kind == kJump) s.jump += f.arg;
      if (f.kind == kLateCall) late_ms = f.arg;
      if (f.kind != kUnplug) f.done = true;
    }
    if (device_gone(s)) return -1;
    if (err_once) {
      s.last_error = err_once;
      return -1;
    }
    p[0] += s.jump;
    for (int i = 0; i < 3; ++i) s.p[i] = p[i];
    *x = p[0];
    *y = p[1];
    *z = p[2];
  }
  if (late_ms > 0) std::this_thread::sleep_for(std::chrono::microseconds(static_cast<long>(late_ms * 1e3)));
  return 0;
}
int dhdGetLinearVelocity(double* x, double* y, double* z, char) {
  State& s = S();
  std::lock_guard<std::mutex> l(s.mu);
  if (device_gone(s)) return -1;
  *x = s.v[0];
  *y = s.v[1];
  *z = s.v[2];
  return 0;
}
unsigned dhdGetButtonMask(char) {
  std::lock_guard<std::mutex> l(S().mu);
  return S().buttons;
}
int dhdSetForce(double fx, double fy, double fz, char) {
  State& s = S();
  std::lock_guard<std::mutex> l(s.mu);
  if (device_gone(s)) return -1;
  if (s.forces.size() < 3u * 2000000u) {
    s.forces.push_back(fx);
    s.forces.push_back(fy);
    s.forces.push_back(fz);
  }
  return 0;
}
int dhdEnableForce(unsigned char on, char) {
  State& s = S();
  std::lock_guard<std::mutex> l(s.mu);
  if (device_gone(s)) return -1;
  s.force_on = on != 0;
  return 0;
}
int dhdErrorGetLast() {
  std::lock_guard<std::mutex> l(S().mu);
  return S().last_error;
}
const char* dhdErrorGetStr(int e) {
  switch (e) {
    case 2: return "communication error (stand-in)";
    case 12: return "device not ready (stand-in)";
    case 20: return "device in use (stand-in)";
    default: return "stand-in error";
  }
}

// ---- test control ----
void standin_dhd_reset() {
  State& s = S();
  std::lock_guard<std::mutex> l(s.mu);
  s.type = 33;
  s.name = "omega.3";
  s.serial = 12345;
  s.sdk[0] = 3;
  s.sdk[1] = 7;
  s.sdk[2] = 2;
  s.sdk[3] = 1234;
  s.initialised = true;
  s.count = 1;
  s.centre[0] = s.centre[1] = s.centre[2] = 0;
  s.amp = 0.01;
  s.freq = 0.5;
  s.faults.clear();
  s.forces.clear();
  s.open = s.force_on = s.unplugged = false;
  s.jump = 0;
  s.last_error = 0;
  s.tick = 0;
  s.buttons = 0;
}
void standin_dhd_set_device(int type, const char* name, int serial, int sdk_major, int initialised) {
  State& s = S();
  std::lock_guard<std::mutex> l(s.mu);
  s.type = type;
  s.name = name;
  s.serial = serial;
  s.sdk[0] = sdk_major;
  s.initialised = initialised != 0;
}
void standin_dhd_set_buttons(unsigned b) {
  std::lock_guard<std::mutex> l(S().mu);
  S().buttons = b;
}
// kind: 1 unplug from tick on, 2 error `arg` once, 3 NaN once, 4 jump by `arg`
// m (lasting), 5 one call late by `arg` ms, 6 no device found.
void standin_dhd_inject(int kind, long tick, double arg) {
  std::lock_guard<std::mutex> l(S().mu);
  S().faults.push_back({kind, tick, arg, false});
}
int standin_dhd_force_enabled() {
  std::lock_guard<std::mutex> l(S().mu);
  return S().force_on ? 1 : 0;
}
long standin_dhd_forces(double* out, long max) {
  State& s = S();
  std::lock_guard<std::mutex> l(s.mu);
  const long n = static_cast<long>(s.forces.size() / 3);
  if (out) std::memcpy(out, s.forces.data(), sizeof(double) * 3 * static_cast<std::size_t>(std::min(n, max)));
  return n;
}

}  // extern "C"
