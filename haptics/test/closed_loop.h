// Closed-loop runs of the engine (proxy model, guard) against a
// ProfileSimDevice pressing a bur onto an enamel half-space: used by the
// stability suite (stability_test.cpp) and the stiffness sweep
// (bench/devices_bench.cpp). Header-only so both can include it.
#pragma once

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <string>
#include <vector>

#include "dentar/haptics/device_profiles.h"
#include "dentar/haptics/engine.h"
#include "dentar/haptics/guidance.h"
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

// ---- Training mode 2 (issue 27): the expert's tip drags a relaxed hand ----

// Tip pointing down (bur axis -z of the tooth).
inline const Eigen::Quaterniond kDown(Eigen::AngleAxisd(std::numbers::pi, Eigen::Vector3d::UnitX()));

inline double smoothstep(double a, double b, double t) {
  const double x = std::clamp((t - a) / (b - a), 0.0, 1.0);
  return x * x * (3 - 2 * x);
}

// The expert's path (tooth frame = device frame, tip = stylus origin): still for 0.5 s,
// along an 8 mm S over 2 s (up to 11 mm/s), still again until 3.5 s, at height z (above
// the enamel half-space's surface, 0.05 mm, it touches nothing).
inline Eigen::Vector3d expert_path(double t, double z) {
  const double s = smoothstep(0.5, 2.5, t);
  return {8e-3 * s - 4e-3, 2e-3 * std::sin(2 * std::numbers::pi * s), z};
}

// A 1 kHz recording of that path: force (0.3, -0.2, 0.8) N scaled by the progress, pedal
// down in [1.0, 2.0) s, on a device clock starting at 10 s.
inline std::vector<StepRecord> expert_recording(double z, double seconds = 3.5) {
  std::vector<StepRecord> out;
  const Eigen::Matrix3d R = kDown.toRotationMatrix();
  for (int i = 0; i <= static_cast<int>(seconds * 1000); ++i) {
    const double t = i * 1e-3;
    StepRecord r;
    r.step = static_cast<std::uint64_t>(i);
    r.time_s = 10.0 + t;
    const Eigen::Vector3d p = expert_path(t, z), v = (expert_path(t + 1e-4, z) - expert_path(t - 1e-4, z)) / 2e-4;
    for (int a = 0; a < 3; ++a) {
      r.position_m[a] = p[a];
      r.velocity_m_per_s[a] = v[a];
      for (int b = 0; b < 3; ++b) r.rotation[3 * a + b] = R(a, b);
    }
    const double g = smoothstep(0.5, 2.5, t);
    r.force_dev_N[0] = 0.3 * g;
    r.force_dev_N[1] = -0.2 * g;
    r.force_dev_N[2] = 0.8 * g;
    r.pedal = t >= 1.0 && t < 2.0;
    out.push_back(r);
  }
  return out;
}

struct GuidanceResult {
  std::string error;
  double mean_m = 0, p95_m = 0;  // following error while the expert moves and after
  double start_peak_N = 0;       // largest force in the expert's first 0.5 s (the start)
  double rest_ripple_N = 0;      // (max - min) / 2 of |f| while both rest (3.0 .. 3.45 s)
  double max_step_N = 0;         // largest per-step change of |f|
};

// Mode 2 on a ProfileSimDevice: a relaxed hand (10 N/m to where it started, 1 mm beside
// the expert's start), `jitter_s` on every period, HD's one-period delay.
// `lift_limit`: raise the device's stiffness limit so that the engine accepts g.k above the
// guidance limit (the bench's sweep past it; a real device keeps its limit).
inline GuidanceResult guidance_run(const DeviceProfile& prof, const GuidanceParams& g, double jitter_s,
                                   bool lift_limit = false) {
  GuidanceResult r;
  TrainingParams p;
  p.mode = TrainingModeKind::kPassiveGuidance;
  p.guidance = g;
  ProfileSimParams sim;
  sim.hand_stiffness_N_per_m = 10;
  sim.hand_damping_ratio = 0.3;
  sim.jitter_s = jitter_s;
  sim.delay_steps = prof.backend == "hd" ? 1 : 0;
  HandWaypoint w;
  w.position_m = expert_path(0, 2e-3) + Eigen::Vector3d(0, 1e-3, 0);
  w.orientation = kDown;
  DeviceLimits limits = limits_from_profile(prof);
  if (lift_limit) limits.max_stiffness_N_per_m = std::max(limits.max_stiffness_N_per_m, g.k_N_per_m / 0.4);
  auto dev = ProfileSimDevice::create(prof, limits, {w}, sim);
  const std::vector<StepRecord> rec = expert_recording(2e-3);
  auto track = ExpertTrack::from_records(rec, Eigen::Isometry3d::Identity(), Eigen::Isometry3d::Identity(), "expert");
  if (!dev.ok() || !track.ok()) {
    r.error = !dev.ok() ? dev.error() : track.error();
    return r;
  }
  auto mode = TrainingMode::create(p, *track);
  if (!mode.ok()) {
    r.error = mode.error();
    return r;
  }
  volume::VoxelVolume vol = enamel_half_space().clone();
  auto bur = volume::sample_bur(volume::BurParams::sphere(0.5), 2000);
  EngineConfig cfg;
  cfg.try_realtime = false;
  cfg.training = &*mode;
  auto eng = Engine::create(cfg, **dev, vol, *bur);
  if (!eng.ok()) {
    r.error = eng.error();
    return r;
  }
  std::vector<double> err;
  double prev = 0, lo = 1e9, hi = -1e9;
  for (int i = 0; i < 5000 && !mode->finished(); ++i) {
    if ((*eng)->run_steps(1) != 1) break;
    const HapticSnapshot s = (*eng)->snapshot();
    const double f = Eigen::Vector3d(s.force_dev_N[0], s.force_dev_N[1], s.force_dev_N[2]).norm();
    r.max_step_N = std::max(r.max_step_N, std::abs(f - prev));
    prev = f;
    if (s.expert_time_s < 0.5) r.start_peak_N = std::max(r.start_peak_N, f);
    if (s.expert_time_s >= 0.6) err.push_back(s.follow_error_m);
    if (s.expert_time_s >= 3.0 && s.expert_time_s < 3.45) {
      lo = std::min(lo, f);
      hi = std::max(hi, f);
    }
  }
  if (err.empty() || hi < lo) {
    r.error = "the run ended early";
    return r;
  }
  std::sort(err.begin(), err.end());
  r.mean_m = std::accumulate(err.begin(), err.end(), 0.0) / static_cast<double>(err.size());
  r.p95_m = err[err.size() * 95 / 100];
  r.rest_ripple_N = (hi - lo) / 2;
  return r;
}

}  // namespace dentar::haptics::closed_loop
