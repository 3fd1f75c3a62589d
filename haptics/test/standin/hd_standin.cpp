// Stand-in for OpenHaptics' libHD.so, built in the test tree (never
// installed): the subset of the HD C API that HdDevice calls, with a 1 kHz
// scheduler thread, scripted stylus motion, recorded forces and injected
// faults. Tests drive it through the standin_hd_* functions below; `dentar
// devices` and `dentar live` find it through LD_LIBRARY_PATH exactly as they
// would find the real runtime.
//
// Motion: the stylus tip circles (mm, HD frame) around `centre` with radius
// `amp` at `freq` Hz in the x-y plane; velocity is the analytic derivative.
// Everything is in mm, mm/s and N, as the real runtime reports.
#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace {

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

enum Fault { kUnplug = 1, kErrorOnce = 2, kNaNOnce = 3, kJump = 4, kLateTick = 5, kInitFails = 6 };

struct Injection {
  int kind;
  long tick;
  double arg;
  bool done;
};

struct Callback {
  HDSchedulerCallback fn;
  void* data;
  HDSchedulerHandle handle;
};

struct State {
  std::mutex mu;  // guards everything below except the atomics
  std::string model = "Touch", serial = "STANDIN-HD-0001", version = "3.4.0";
  unsigned calibration = 0x5000;
  int cal_style = 1 << 1;  // HD_CALIBRATION_AUTO
  double centre[3] = {0, 0, 0}, amp = 10, freq = 0.5;
  std::vector<Injection> faults;
  // HD's error stack, one per thread (each error is read by the thread whose call raised it:
  // the opener's in HdDevice::open, the servo's in its callback). Session 22: one stack for the
  // process let a running device's servo callback, draining its errors every tick, take a second
  // open's HD_DEVICE_ALREADY_INITIATED before the opener read it when the opener was held off
  // (stress -c 2 beside two runs: 1 failure in 3 of SecondOpenSaysAnotherProgramHoldsIt).
  struct Err {
    HDErrorInfo info;
    std::thread::id by;
  };
  std::vector<Err> errors;
  std::vector<double> forces;  // 3 per tick
  std::vector<Callback> callbacks;
  HDSchedulerHandle next_handle = 1;
  bool inited = false, force_enabled = false;
  double transform[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  double velocity[3] = {0, 0, 0};
  int buttons = 0;
  bool unplugged = false;
  double jump[3] = {0, 0, 0};
  std::thread sched;
  std::atomic<bool> run{false};
  std::atomic<long> tick{0};
  std::atomic<long> late_ticks{0};
};

State& S() {
  static State* s = new State();  // never destroyed: the scheduler may outlive static teardown
  return *s;
}

void push_error(State& s, HDerror e, int internal = 0) {
  s.errors.push_back({{e, internal, 0}, std::this_thread::get_id()});
}

// One servo tick's device update (mutex held).
void update_device(State& s, long t) {
  const double ts = static_cast<double>(t) * 1e-3;
  const double w = 2 * M_PI * s.freq;
  double p[3] = {s.centre[0] + s.amp * std::cos(w * ts), s.centre[1] + s.amp * std::sin(w * ts), s.centre[2]};
  double v[3] = {-s.amp * w * std::sin(w * ts), s.amp * w * std::cos(w * ts), 0};
  for (auto& f : s.faults) {
    if (f.tick > t) continue;
    switch (f.kind) {
      case kUnplug: s.unplugged = true; break;
      case kErrorOnce:
        if (!f.done) push_error(s, static_cast<HDerror>(f.arg), 7);
        f.done = true;
        break;
      case kNaNOnce:  // for max(1, arg) ticks
        if (!f.done) p[0] = std::nan("");
        f.done = t + 1 >= f.tick + std::max(1L, static_cast<long>(f.arg));
        break;
      case kJump:
        if (!f.done) s.jump[0] += f.arg;
        f.done = true;
        break;
      default: break;
    }
  }
  if (s.unplugged) {
    push_error(s, 0x0302, -1);  // HD_COMM_ERROR every frame, pose frozen
    return;
  }
  for (int i = 0; i < 3; ++i) {
    s.transform[12 + i] = p[i] + s.jump[i];
    s.velocity[i] = v[i];
  }
}

void scheduler_main() {
  State& s = S();
  // Like the real HD scheduler: a real-time thread when the system allows it.
  sched_param sp{};
  sp.sched_priority = 90;
  pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
  auto next = std::chrono::steady_clock::now();
  while (s.run.load()) {
    next += std::chrono::microseconds(1000);
    // Held off longer than a tick (a loaded machine, TSan): skip the missed
    // ticks as a servo loop does, rather than running them back to back (a
    // burst of ticks would pass an injected fault before any reader saw it).
    if (const auto now = std::chrono::steady_clock::now(); now > next) next = now;
    std::this_thread::sleep_until(next);
    const long t = s.tick.load();
    double late_ms = 0;
    std::vector<Callback> cbs;
    {
      std::lock_guard<std::mutex> l(s.mu);
      for (auto& f : s.faults)
        if (f.kind == kLateTick && !f.done && f.tick <= t) {
          late_ms = f.arg;
          f.done = true;
        }
      cbs = s.callbacks;
    }
    if (late_ms > 0) {
      std::this_thread::sleep_for(std::chrono::microseconds(static_cast<long>(late_ms * 1e3)));
      s.late_ticks.fetch_add(1);
      next = std::chrono::steady_clock::now();
    }
    for (const auto& c : cbs) c.fn(c.data);
    s.tick.fetch_add(1);
  }
}

}  // namespace

extern "C" {

// ---- HD API subset ----
HHD hdInitDevice(const char* name) {
  State& s = S();
  std::lock_guard<std::mutex> l(s.mu);
  for (auto& f : s.faults)
    if (f.kind == kInitFails) {
      push_error(s, static_cast<HDerror>(f.arg), -2);
      return 0xFFFFFFFFu;
    }
  if (name && std::strcmp(name, "Default Device") != 0 && std::strcmp(name, "standin") != 0) {
    push_error(s, 0x0303);  // HD_COMM_CONFIG_ERROR: no such configuration
    return 0xFFFFFFFFu;
  }
  if (s.inited) {
    push_error(s, 0x0301);  // HD_DEVICE_ALREADY_INITIATED
    return 0xFFFFFFFFu;
  }
  s.inited = true;
  return 0;
}
void hdDisableDevice(HHD) {
  State& s = S();
  std::lock_guard<std::mutex> l(s.mu);
  s.inited = false;
}
void hdMakeCurrentDevice(HHD) {}
HDErrorInfo hdGetError() {
  State& s = S();
  std::lock_guard<std::mutex> l(s.mu);
  const auto it = std::find_if(s.errors.begin(), s.errors.end(),
                               [](const State::Err& e) { return e.by == std::this_thread::get_id(); });
  if (it == s.errors.end()) return {0, 0, 0};
  const HDErrorInfo e = it->info;
  s.errors.erase(it);
  return e;
}
const char* hdGetErrorString(HDerror e) {
  switch (e) {
    case 0x0302: return "Communication error (stand-in)";
    case 0x0303: return "Communication configuration error (stand-in)";
    case 0x0203: return "Velocity exceeded (stand-in)";
    default: return "stand-in error";
  }
}
void hdEnable(HDenum cap) {
  if (cap == 0x4000) {
    std::lock_guard<std::mutex> l(S().mu);
    S().force_enabled = true;
  }
}
void hdDisable(HDenum cap) {
  if (cap == 0x4000) {
    std::lock_guard<std::mutex> l(S().mu);
    S().force_enabled = false;
  }
}
void hdStartScheduler() {
  State& s = S();
  if (s.run.exchange(true)) return;
  s.sched = std::thread(scheduler_main);
}
void hdStopScheduler() {
  State& s = S();
  if (!s.run.exchange(false)) return;
  if (s.sched.joinable()) s.sched.join();
}
HDSchedulerHandle hdScheduleAsynchronous(HDSchedulerCallback fn, void* data, unsigned short) {
  State& s = S();
  std::lock_guard<std::mutex> l(s.mu);
  s.callbacks.push_back({fn, data, s.next_handle});
  return s.next_handle++;
}
void hdScheduleSynchronous(HDSchedulerCallback fn, void* data, unsigned short) { fn(data); }
void hdUnschedule(HDSchedulerHandle h) {
  State& s = S();
  std::lock_guard<std::mutex> l(s.mu);
  for (std::size_t i = 0; i < s.callbacks.size(); ++i)
    if (s.callbacks[i].handle == h) {
      s.callbacks.erase(s.callbacks.begin() + static_cast<long>(i));
      break;
    }
}
void hdBeginFrame(HHD) {
  State& s = S();
  std::lock_guard<std::mutex> l(s.mu);
  update_device(s, s.tick.load());
}
void hdEndFrame(HHD) {}
void hdGetDoublev(HDenum what, double* out) {
  State& s = S();
  std::lock_guard<std::mutex> l(s.mu);
  switch (what) {
    case 0x2052: std::memcpy(out, s.transform, sizeof s.transform); break;
    case 0x2050: for (int i = 0; i < 3; ++i) out[i] = s.transform[12 + i]; break;
    case 0x2051: for (int i = 0; i < 3; ++i) out[i] = s.velocity[i]; break;
    case 0x2602: out[0] = 0.8; break;  // HD_NOMINAL_MAX_STIFFNESS, N/mm
    case 0x2603: out[0] = 3.3; break;  // HD_NOMINAL_MAX_FORCE, N
    default: out[0] = 0; break;
  }
}
void hdGetIntegerv(HDenum what, int* out) {
  State& s = S();
  std::lock_guard<std::mutex> l(s.mu);
  switch (what) {
    case 0x2000: out[0] = s.buttons; break;
    case 0x2555: out[0] = s.cal_style; break;
    default: out[0] = 0; break;
  }
}
const char* hdGetString(HDenum what) {
  State& s = S();
  std::lock_guard<std::mutex> l(s.mu);
  switch (what) {
    case 0x2500: return s.version.c_str();
    case 0x2501: return s.model.c_str();
    case 0x2503: return "Stand-in Haptics";
    case 0x2504: return s.serial.c_str();
    default: return "";
  }
}
void hdSetDoublev(HDenum what, const double* v) {
  State& s = S();
  std::lock_guard<std::mutex> l(s.mu);
  if (what != 0x2700) return;
  if (s.forces.size() < 3u * 2000000u) s.forces.insert(s.forces.end(), v, v + 3);
}
HDenum hdCheckCalibration() {
  std::lock_guard<std::mutex> l(S().mu);
  return S().calibration;
}
void hdUpdateCalibration(HDenum) {
  std::lock_guard<std::mutex> l(S().mu);
  if (S().calibration == 0x5001) S().calibration = 0x5000;
}

// ---- test control ----
void standin_hd_reset() {
  hdStopScheduler();
  State& s = S();
  std::lock_guard<std::mutex> l(s.mu);
  s.model = "Touch";
  s.serial = "STANDIN-HD-0001";
  s.version = "3.4.0";
  s.calibration = 0x5000;
  s.cal_style = 1 << 1;
  s.centre[0] = s.centre[1] = s.centre[2] = 0;
  s.amp = 10;
  s.freq = 0.5;
  s.faults.clear();
  s.errors.clear();
  s.forces.clear();
  s.callbacks.clear();
  s.inited = false;
  s.force_enabled = false;
  s.unplugged = false;
  s.buttons = 0;
  s.jump[0] = s.jump[1] = s.jump[2] = 0;
  s.tick = 0;
  s.late_ticks = 0;
}
void standin_hd_set_device(const char* model, const char* serial, const char* version,
                           unsigned calibration, int cal_style) {
  State& s = S();
  std::lock_guard<std::mutex> l(s.mu);
  s.model = model;
  s.serial = serial;
  s.version = version;
  s.calibration = calibration;
  s.cal_style = cal_style;
}
void standin_hd_set_motion(double cx_mm, double cy_mm, double cz_mm, double amp_mm, double freq_hz) {
  State& s = S();
  std::lock_guard<std::mutex> l(s.mu);
  s.centre[0] = cx_mm;
  s.centre[1] = cy_mm;
  s.centre[2] = cz_mm;
  s.amp = amp_mm;
  s.freq = freq_hz;
}
void standin_hd_set_buttons(int b) {
  std::lock_guard<std::mutex> l(S().mu);
  S().buttons = b;
}
// kind: 1 unplug from tick on, 2 error code `arg` once, 3 NaN for `arg` ticks (>= 1), 4 jump by
// `arg` mm once (lasting offset), 5 one tick late by `arg` ms, 6 hdInitDevice fails with `arg`.
void standin_hd_inject(int kind, long tick, double arg) {
  std::lock_guard<std::mutex> l(S().mu);
  S().faults.push_back({kind, tick, arg, false});
}
long standin_hd_ticks() { return S().tick.load(); }
long standin_hd_late_ticks() { return S().late_ticks.load(); }
int standin_hd_force_enabled() {
  std::lock_guard<std::mutex> l(S().mu);
  return S().force_enabled ? 1 : 0;
}
// Copies up to `max` recorded forces (3 doubles each, oldest first); returns
// how many exist.
long standin_hd_forces(double* out, long max) {
  State& s = S();
  std::lock_guard<std::mutex> l(s.mu);
  const long n = static_cast<long>(s.forces.size() / 3);
  if (out)
    std::memcpy(out, s.forces.data(), sizeof(double) * 3 * static_cast<std::size_t>(std::min(n, max)));
  return n;
}

}  // extern "C"
