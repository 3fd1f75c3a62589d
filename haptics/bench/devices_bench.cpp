// Device benchmarks (docs/BENCHMARKS.md, "Devices"):
//  1. read + write overhead per step through the stand-in runtimes
//     (HdDevice: SeqLock mailbox to the HD servo thread; DhdDevice: direct
//     calls), p50 / p99 / p99.9, and how old the HD servo sample is when a
//     1 kHz engine-like thread reads it (the two loops are not synchronised);
//  2. per profile: the largest stiffness the closed loop (stability suite's
//     press, sphere bur) renders without buzz or kick, against the profile's
//     (vendor) figure, without and with 2 ms jitter;
//  3. foot pedal press -> drill on (and release/unplug -> drill off), in
//     engine steps, with the engine's real-time thread and the evdev reader
//     thread (fed through a pipe).
// Usage: haptics_devices_bench [--quick]
#include <dlfcn.h>
#include <fcntl.h>
#include <linux/input.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "../test/closed_loop.h"
#include "dentar/haptics/dhd_device.h"
#include "dentar/haptics/engine.h"
#include "dentar/haptics/evdev_pedal.h"
#include "dentar/haptics/hd_device.h"
#include "dentar/haptics/pedal.h"
#include "dentar/haptics/simulated_device.h"
#include "dentar/volume/procedural_tooth.h"

using namespace dentar;
using namespace dentar::haptics;

namespace {

double now_s() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

double pct(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5))];
}

void print_pct(const char* what, const std::vector<double>& v, double scale, const char* unit) {
  std::printf("  %-44s n=%zu  p50 %.3f  p99 %.3f  p99.9 %.3f  max %.3f %s\n", what, v.size(),
              scale * pct(v, 0.5), scale * pct(v, 0.99), scale * pct(v, 0.999),
              scale * pct(v, 1.0), unit);
}

// An engine-like 1 kHz loop (absolute deadlines) over a device for `seconds`.
// `clock0` turns DeviceState::time_s (s since open) into CLOCK_MONOTONIC time.
void paced_loop(HapticDevice& d, double seconds, std::vector<double>& cost, std::vector<double>* age,
                double clock0 = 0) {
  timespec next;
  clock_gettime(CLOCK_MONOTONIC, &next);
  const int n = static_cast<int>(seconds * 1000);
  DeviceState st;
  for (int i = 0; i < n; ++i) {
    next.tv_nsec += 1000000;
    if (next.tv_nsec >= 1000000000) {
      next.tv_nsec -= 1000000000;
      ++next.tv_sec;
    }
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr);
    const double t0 = now_s();
    const bool ok = d.read(st);
    d.write_force(ok ? Eigen::Vector3d(0.1, 0, 0) : Eigen::Vector3d::Zero());
    const double t1 = now_s();
    cost.push_back(t1 - t0);
    if (age && ok) age->push_back(t0 - (clock0 + st.time_s));
  }
}

void bench_overhead(double seconds) {
  std::printf("== device read + write per step, 1 kHz paced loop, %.0f s each\n", seconds);
  {
    DeviceOpenOptions o;
    o.library = std::string(DENTAR_STANDIN_DIR) + "/libHD.so";
    o.stale_limit_s = 0.02;
    auto d = HdDevice::open(o);
    if (!d.ok()) {
      std::printf("  HD stand-in: %s\n", d.error().c_str());
    } else {
      std::vector<double> cost, age;
      paced_loop(**d, seconds, cost, &age, (*d)->opened_at_s());
      print_pct("HD (SeqLock mailbox) read+write", cost, 1e6, "us");
      print_pct("HD servo sample age at read", age, 1e3, "ms");
      std::printf("  HD faults during the run: %llu\n",
                  static_cast<unsigned long long>((*d)->faults().fault_count()));
    }
  }
  {
    DeviceOpenOptions o;
    o.library = std::string(DENTAR_STANDIN_DIR) + "/libdhd.so";
    auto d = DhdDevice::open(o);
    if (!d.ok()) {
      std::printf("  DHD stand-in: %s\n", d.error().c_str());
    } else {
      std::vector<double> cost;
      paced_loop(**d, seconds, cost, nullptr);
      print_pct("DHD (direct calls into stand-in) read+write", cost, 1e6, "us");
    }
  }
}

void bench_stiffness() {
  std::printf("== largest stable stiffness per profile (closed loop, press, sphere bur; buzz < 0.05 N, "
              "no kick; HD with its 1-period mailbox delay)\n");
  std::printf("  %-9s %10s %14s %16s\n", "profile", "vendor N/m", "stable N/m", "stable@2ms N/m");
  for (const DeviceProfile& p : device_profiles()) {
    double best[2] = {0, 0};
    for (int j = 0; j < 2; ++j) {
      // Geometric grid from 1/4 to 64 x the vendor figure, step 2^(1/4).
      for (double k = 0.25 * p.max_stiffness_N_per_m; k <= 64 * p.max_stiffness_N_per_m;
           k *= std::pow(2.0, 0.25)) {
        closed_loop::Config c;
        c.profile = &p;
        c.stiffness_N_per_m = k;
        c.jitter_s = j ? 2e-3 : 0;
        c.delay_steps = p.backend == "hd" ? 1 : 0;
        const auto r = closed_loop::run(c);
        const double m = p.tip_mass_kg + ProfileSimParams{}.hand_mass_kg;
        const double offset = r.press_N / ProfileSimParams{}.hand_stiffness_N_per_m + r.press_N / k;
        const double v = (3e-3 - closed_loop::kSurfaceZ + offset) / 0.3;
        const bool stable = r.error.empty() && r.buzz_N < 0.05 &&
                            r.peak_N <= r.steady_N + v * std::sqrt(m * k) + 0.05 &&
                            std::abs(r.steady_N - r.press_N) < 0.05 * r.press_N;
        if (!stable) break;
        best[j] = k;
      }
    }
    std::printf("  %-9s %10.0f %14.0f %16.0f\n", p.id.c_str(), p.max_stiffness_N_per_m, best[0], best[1]);
  }
}

void bench_pedal(int presses) {
  std::printf("== pedal press -> drill on, engine real-time thread + evdev reader (pipe), %d presses\n",
              presses);
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) return;
  auto pedal = EvdevPedal::from_fd(fds[0], {KEY_B}, "bench pedal");
  HandWaypoint w;
  w.position_m = Eigen::Vector3d(0, 0.2, 0);  // far from the tooth
  auto hand = SimulatedDevice::create({w}, DeviceLimits{});
  PedalDevice dev(**hand, *pedal);
  volume::MolarParams mp;
  mp.voxel_mm = 0.2;
  auto tooth = volume::make_molar(mp);
  auto bur = volume::sample_bur(volume::BurParams::sphere(0.5), 200);
  EngineConfig cfg;
  cfg.try_realtime = true;
  auto eng = Engine::create(cfg, dev, *tooth, *bur);
  if (!eng.ok()) {
    std::printf("  %s\n", eng.error().c_str());
    return;
  }
  (void)(*eng)->start();
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  auto key = [&](int v) {
    input_event ev[2]{};
    ev[0].type = EV_KEY;
    ev[0].code = KEY_B;
    ev[0].value = v;
    ev[1].type = EV_SYN;
    if (write(fds[1], ev, sizeof ev) != static_cast<ssize_t>(sizeof ev)) std::perror("write");
  };
  std::vector<double> on_steps, off_steps, on_ms, off_ms;
  auto wait_pedal = [&](int want, std::vector<double>& steps, std::vector<double>& ms) {
    const std::uint64_t s0 = (*eng)->snapshot().step;
    const double t0 = now_s();
    key(want);
    for (;;) {
      const HapticSnapshot s = (*eng)->snapshot();
      if (s.pedal == want) {
        steps.push_back(static_cast<double>(s.step - s0));
        ms.push_back(1e3 * (now_s() - t0));
        return;
      }
      if (now_s() - t0 > 1.0) return;
      std::this_thread::sleep_for(std::chrono::microseconds(50));
    }
  };
  for (int i = 0; i < presses; ++i) {
    wait_pedal(1, on_steps, on_ms);
    std::this_thread::sleep_for(std::chrono::milliseconds(7));
    wait_pedal(0, off_steps, off_ms);
    std::this_thread::sleep_for(std::chrono::milliseconds(7));
  }
  // Unplug while drilling.
  std::vector<double> unplug_steps, unplug_ms;
  key(1);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  {
    const std::uint64_t s0 = (*eng)->snapshot().step;
    const double t0 = now_s();
    close(fds[1]);
    while (now_s() - t0 < 1.0) {
      const HapticSnapshot s = (*eng)->snapshot();
      if (!s.pedal) {
        unplug_steps.push_back(static_cast<double>(s.step - s0));
        unplug_ms.push_back(1e3 * (now_s() - t0));
        break;
      }
      std::this_thread::sleep_for(std::chrono::microseconds(50));
    }
  }
  (*eng)->stop();
  const EngineStats st = (*eng)->stats();
  std::printf("  real-time priority: %s\n", st.realtime_granted ? "granted" : st.realtime_note.c_str());
  print_pct("press -> drill on (engine steps)", on_steps, 1, "steps");
  print_pct("press -> drill on (wall time)", on_ms, 1, "ms");
  print_pct("release -> drill off (engine steps)", off_steps, 1, "steps");
  print_pct("unplug while drilling -> drill off (steps)", unplug_steps, 1, "steps");
}

}  // namespace

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
  char host[256] = {};
  gethostname(host, sizeof host - 1);
  std::printf("haptics_devices_bench on %s, %u hardware threads\n", host, std::thread::hardware_concurrency());
  bench_overhead(quick ? 1.0 : 10.0);
  bench_pedal(quick ? 20 : 200);
  bench_stiffness();
  return 0;
}
