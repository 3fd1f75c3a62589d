// Closed-loop runs of the engine (proxy model, guard) against a
// ProfileSimDevice pressing a bur onto an enamel half-space: used by the
// stability suite (stability_test.cpp) and the stiffness sweep
// (bench/devices_bench.cpp). Header-only so both can include it.
#pragma once

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "dentar/haptics/device_profiles.h"
#include "dentar/haptics/engine.h"
#include "dentar/haptics/profile_sim_device.h"
#include "dentar/volume/bur.h"
#include "dentar/volume/voxel_volume.h"

namespace dentar::haptics::closed_loop {

inline constexpr double kVoxel = 1e-4;
// Enamel (255) for voxel centres z <= 0: the interpolated density crosses the
// iso level 127.5 at z = 0.1 mm * (1 - 127.5/255) = 0.05 mm.
inline constexpr double kSurfaceZ = kVoxel * (1.0 - 127.5 / 255.0);

inline const volume::VoxelVolume& enamel_half_space() {
  static const volume::VoxelVolume v = [] {
    volume::VolumeGeometry g;
    g.dims = Eigen::Vector3i(64, 64, 64);
    g.spacing = Eigen::Vector3d::Constant(kVoxel);
    g.origin = Eigen::Vector3d(-3.2e-3, -3.2e-3, -3.2e-3);
    volume::VoxelVolume vol(g);
    for (int k = 0; k < 64; ++k)
      for (int j = 0; j < 64; ++j)
        for (int i = 0; i < 64; ++i)
          if (vol.voxel_center(i, j, k).z() <= 1e-9) vol.set(i, j, k, 255, volume::Material::kEnamel);
    return vol;
  }();
  return v;
}

inline volume::BurParams bur_of(volume::BurShape s) {
  switch (s) {
    case volume::BurShape::kSphere: return volume::BurParams::sphere(0.5);
    case volume::BurShape::kCylinder: return volume::BurParams::cylinder(0.5, 3.0);
    case volume::BurShape::kCapsule: return volume::BurParams::capsule(0.5, 3.0);
    case volume::BurShape::kCone: return volume::BurParams::cone(0.2, 0.5, 3.0);
  }
  return {};
}

enum class Scenario {
  kPress,        // approach, then hold asking for press_N (0.4 x max force, at most 1.5 N)
  kPushThrough,  // ask for twice the max force, then withdraw
};

struct Config {
  const DeviceProfile* profile = nullptr;
  volume::BurShape shape = volume::BurShape::kSphere;
  Scenario scenario = Scenario::kPress;
  double jitter_s = 0;
  int delay_steps = 0;
  double stiffness_N_per_m = 0;  // 0: the profile's default (0.8 x max); else forced (sweep)
  int bur_samples = 2000;
};

struct Result {
  std::string error;                 // setup failure
  std::vector<double> force_N;       // |f| sent, per step
  std::vector<double> force_z_N;     // f_z sent, per step
  std::vector<double> display_z_m;   // proxy tip z, per step
  std::vector<double> time_s;        // device (simulated) time, per step
  double force_z_at_hold_end_N = 0;  // f_z at 1.45 s (the end of the hold)
  double press_N = 0;                // what the hand asks for (press)
  double contact_s = -1;             // first step in contact (s)
  double steady_N = 0;               // mean |f| over the last 0.5 s of the hold
  double buzz_N = 0;                 // (max - min) / 2 of |f| over that window
  double peak_N = 0;                 // largest |f|
  double max_step_N = 0;             // largest per-step change of |f|
  double min_display_z_m = 1;        // lowest proxy tip (pop-through check)
  double end_force_N = 0;            // |f| at the end (after withdrawal)
};

inline Result run(const Config& c) {
  Result r;
  const DeviceProfile& p = *c.profile;
  DeviceLimits limits;
  ForceModelParams params;
  if (Status s = apply_profile(p, {}, limits, params); !s.ok()) {
    r.error = s.error();
    return r;
  }
  if (c.stiffness_N_per_m > 0) {
    limits.max_stiffness_N_per_m = std::max(limits.max_stiffness_N_per_m, c.stiffness_N_per_m);
    params.proxy.stiffness_N_per_m = c.stiffness_N_per_m;
  }
  const double k_p = params.proxy.stiffness_N_per_m;
  ProfileSimParams sim;
  sim.jitter_s = c.jitter_s;
  sim.delay_steps = c.delay_steps;
  const double k_h = sim.hand_stiffness_N_per_m;
  r.press_N = std::min(1.5, 0.4 * limits.max_force_N);
  const double ask = c.scenario == Scenario::kPress ? r.press_N : 2.0 * limits.max_force_N;
  const double offset = ask / k_h + ask / k_p;
  // Tip frame: bur axis +z pointing down into the tooth.
  const Eigen::Quaterniond down(Eigen::AngleAxisd(std::numbers::pi, Eigen::Vector3d::UnitX()));
  auto wp = [&](double t, double z) {
    HandWaypoint w;
    w.time_s = t;
    w.position_m = Eigen::Vector3d(0, 0, z);
    w.orientation = down;
    return w;
  };
  std::vector<HandWaypoint> script = {wp(0.0, 3e-3), wp(0.3, kSurfaceZ - offset),
                                      wp(1.5, kSurfaceZ - offset)};
  if (c.scenario == Scenario::kPushThrough) {
    script.push_back(wp(1.8, 3e-3));
    script.push_back(wp(2.2, 3e-3));
  }
  auto dev = ProfileSimDevice::create(p, limits, script, sim);
  if (!dev.ok()) {
    r.error = dev.error();
    return r;
  }
  auto bur = volume::sample_bur(bur_of(c.shape), static_cast<std::size_t>(c.bur_samples));
  if (!bur.ok()) {
    r.error = bur.error();
    return r;
  }
  volume::VoxelVolume vol = enamel_half_space().clone();
  EngineConfig cfg;
  cfg.model = "proxy";
  cfg.model_params = params;
  cfg.try_realtime = false;
  auto eng = Engine::create(cfg, **dev, vol, *bur);
  if (!eng.ok()) {
    r.error = eng.error();
    return r;
  }
  // Run in simulated time (with jitter a step lasts 1..3 ms).
  const double end_s = c.scenario == Scenario::kPress ? 1.5 : 2.2;
  double prev = 0;
  for (int i = 0; (*dev)->time_s() < end_s && i < 100000; ++i) {
    if ((*eng)->run_steps(1) != 1) break;
    const HapticSnapshot s = (*eng)->snapshot();
    r.time_s.push_back(s.time_s);
    if (s.time_s <= 1.45) r.force_z_at_hold_end_N = s.force_dev_N[2];
    const Eigen::Vector3d f(s.force_dev_N[0], s.force_dev_N[1], s.force_dev_N[2]);
    r.force_N.push_back(f.norm());
    r.force_z_N.push_back(f.z());
    const double dz = s.T_tooth_tip_display[14];  // column-major (2, 3)
    r.display_z_m.push_back(dz);
    if (s.in_contact && r.contact_s < 0) r.contact_s = s.time_s;
    r.peak_N = std::max(r.peak_N, f.norm());
    r.max_step_N = std::max(r.max_step_N, std::abs(f.norm() - prev));
    r.min_display_z_m = std::min(r.min_display_z_m, dz);
    prev = f.norm();
  }
  // Hold window: 1.0 .. 1.5 s (at least 0.7 s after the approach ends).
  double lo = 1e9, hi = -1e9, sum = 0;
  int n = 0;
  for (std::size_t i = 0; i < r.force_N.size(); ++i) {
    if (r.time_s[i] < 1.0 || r.time_s[i] >= 1.5) continue;
    lo = std::min(lo, r.force_N[i]);
    hi = std::max(hi, r.force_N[i]);
    sum += r.force_N[i];
    ++n;
  }
  if (n > 0) {
    r.steady_N = sum / n;
    r.buzz_N = (hi - lo) / 2;
  }
  r.end_force_N = r.force_N.empty() ? 0 : r.force_N.back();
  return r;
}

}  // namespace dentar::haptics::closed_loop
