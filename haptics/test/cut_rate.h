// The bur pressed with a constant force into a flat block through the proxy
// force model and the cutter, at 1 kHz (shared by cut_rate_test and
// haptics_cut_rate_bench). The "hand" holds the device so that the proxy's
// spring pulls with `force_N`: device = proxy + force / (k * felt hardness)
// along the bur axis, every step.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <memory>

#include "dentar/haptics/force_model.h"
#include "dentar/volume/bur.h"
#include "dentar/volume/cutter.h"
#include "dentar/volume/voxel_volume.h"

namespace dentar::haptics::cut_rate {

struct Press {
  double voxel_m = 1e-4;
  volume::Material material = volume::Material::kDentin;
  double force_N = 1.0;
  double seconds = 1.0;
  double grid_phase = 0.0;  // surface offset against the voxel grid, in voxels [0, 1)
  double lateral_phase = 0.0;  // bur axis offset against the grid, in voxels
  bool shape_constraint = false;  // ProxyParams::shape_constraint
};

struct PressResult {
  double removed_mm3 = 0;          // cutter metrics after the run
  double rate_mm3_s = 0;           // removed over the second half / its duration
  double depth_mm = 0;             // proxy tip below the original surface at the end
  double depth_rate_mm_s = 0;      // over the second half
  double mean_force_N = 0;         // |force| the model returned, second half
  double mean_penetration_mm = 0;  // the model's penetration (proxy - device), second half
  double max_force_N = 0;
  double mean_overlap_mm3 = 0;     // CutResult::overlap_m3 (samples: in solid x sample volume), second half
  bool finite = true;
};

// Block: solid (full density of `material`) below z = 0, 6 x 6 mm wide, 5 mm deep.
inline volume::VoxelVolume make_slab(double h, volume::Material m, double phase) {
  volume::VolumeGeometry g;
  const int nxy = static_cast<int>(std::ceil(6e-3 / h));
  const int nz = static_cast<int>(std::ceil(6e-3 / h));
  g.dims = Eigen::Vector3i(nxy, nxy, nz);
  g.spacing = Eigen::Vector3d::Constant(h);
  // Surface z = 0 lies `phase` voxels above a cell boundary: voxel centres at
  // origin.z + k h; the top solid voxel's cell ends at z = 0 when phase = 0.
  g.origin = Eigen::Vector3d(-0.5 * nxy * h, -0.5 * nxy * h, -5e-3 - 0.5 * h + phase * h);
  volume::VoxelVolume v(g);
  const std::uint8_t full = volume::material_info(m).full_density;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < nxy; ++j)
      for (int i = 0; i < nxy; ++i)
        if (v.voxel_center(i, j, k).z() < 0) v.set(i, j, k, full, m);
  return v;
}

// model_bur: the samples the force model constrains with (default: the cutter's own `bur`).
inline PressResult press(const Press& p, const volume::BurSamples& bur,
                         const volume::CutParams& cut = {},
                         const volume::BurSamples* model_bur = nullptr) {
  const volume::BurSamples& mbur = model_bur ? *model_bur : bur;
  PressResult r;
  volume::VoxelVolume vol = make_slab(p.voxel_m, p.material, p.grid_phase);
  const DeviceLimits limits{};
  ForceModelParams fp;
  fp.proxy.shape_constraint = p.shape_constraint;
  auto model = std::move(make_force_model("proxy", fp, limits, mbur.size())).value();
  volume::Cutter cutter(vol, cut);
  const double k = 0.8 * limits.max_stiffness_N_per_m *
                   fp.proxy.material_stiffness_scale[static_cast<std::size_t>(p.material)];
  // Tip frame +z (the bur's tip) points down (-z in the tooth).
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Vector3d down(0, 0, -1);
  const Eigen::Vector3d lat(p.lateral_phase * p.voxel_m, 0.37 * p.lateral_phase * p.voxel_m, 0);
  Eigen::Vector3d proxy = lat + Eigen::Vector3d(0, 0, 0.3e-3);
  Eigen::Vector3d dev = proxy, dev_prev = dev;
  const double dt = 1e-3;
  const int steps = static_cast<int>(std::lround(p.seconds / dt));
  const int half = steps / 2;
  double removed_half = 0, depth_half = 0, fsum = 0, psum = 0, osum = 0;
  for (int s = 0; s < steps; ++s) {
    // Step 0 places the device at the free start (the proxy starts only there).
    if (s > 0) dev = proxy + (p.force_N / k) * down;
    ForceInput in;
    in.volume = &vol;
    in.bur = &mbur;
    T.translation() = dev;
    in.T_tooth_tip = T;
    in.velocity_m_per_s = (dev - dev_prev) / dt;
    in.dt_s = dt;
    dev_prev = dev;
    const ForceOutput out = model->compute(in);
    if (!out.force_N.allFinite()) r.finite = false;
    const volume::CutResult cr = cutter.step(bur, out.T_tooth_tip_cut, out.force_N.norm(), dt);
    proxy = out.T_tooth_tip_display.translation();
    const double f = out.force_N.norm();
    r.max_force_N = std::max(r.max_force_N, f);
    if (s == half) {
      removed_half = cutter.metrics().removed_total_mm3;
      depth_half = -proxy.z() * 1e3;
    }
    if (s >= half) {
      fsum += f;
      psum += out.penetration_m * 1e3;
      osum += cr.overlap_m3 * 1e9;
    }
  }
  const double t2 = (steps - half) * dt;
  r.removed_mm3 = cutter.metrics().removed_total_mm3;
  r.rate_mm3_s = (r.removed_mm3 - removed_half) / t2;
  r.depth_mm = -proxy.z() * 1e3;
  r.depth_rate_mm_s = (r.depth_mm - depth_half) / t2;
  r.mean_force_N = fsum / (steps - half);
  r.mean_penetration_mm = psum / (steps - half);
  r.mean_overlap_mm3 = osum / (steps - half);
  return r;
}

}  // namespace dentar::haptics::cut_rate
