// Private helpers shared by the force models: mapping bur samples into voxel
// coordinates and reading the tooth there (nearest voxel, trilinear density
// with gradient), and a chunk-level early-out.
//
// Thread: haptic thread; everything here is allocation-free and lock-free.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <memory>

#include "dentar/haptics/force_model.h"
#include "dentar/volume/bur.h"
#include "dentar/volume/voxel_volume.h"

namespace dentar::haptics::detail {

// Continuous voxel coordinates of tip-frame points: v = M p + b, where the
// voxel (i,j,k) centre is at v = (i,j,k). Float: the tooth spans < 1000
// voxels, so float keeps ~1e-4 voxel precision and halves the work.
struct VoxelMap {
  Eigen::Matrix3f M;
  Eigen::Vector3f b;
  static VoxelMap make(const volume::VolumeGeometry& g, const Eigen::Isometry3d& T_tooth_tip);
  Eigen::Vector3f operator()(const Eigen::Vector3f& p_tip) const { return M * p_tip + b; }
};

// Density and material of the voxel whose centre is nearest to v (the same
// rule as volume::Cutter). Returns false outside the volume or in an absent
// chunk (air).
inline bool nearest_voxel(const volume::VoxelVolume& vol, const Eigen::Vector3f& v,
                          std::uint8_t& density, std::uint8_t& material) {
  const Eigen::Vector3i& d = vol.dims();
  const float x = v.x() + 0.5f, y = v.y() + 0.5f, z = v.z() + 0.5f;
  // In-bounds coordinates are >= 0, where truncation equals floor. NaN fails too.
  if (!(x >= 0.f && y >= 0.f && z >= 0.f && x < static_cast<float>(d.x()) &&
        y < static_cast<float>(d.y()) && z < static_cast<float>(d.z())))
    return false;
  const int i = static_cast<int>(x), j = static_cast<int>(y), k = static_cast<int>(z);
  const volume::VoxelVolume::Chunk* c = vol.chunk(vol.chunk_id(i >> 4, j >> 4, k >> 4));
  if (!c) return false;
  const auto li = static_cast<std::size_t>(volume::chunk_local_index(i & 15, j & 15, k & 15));
  density = c->density[li];
  material = c->material[li];
  return true;
}

// Densities (0..255) of the 8 voxels around continuous voxel coordinates v,
// corner order c[dx + 2*dy + 4*dz], and the fractional position in that cell.
// Returns false when all 8 are air (density 0), including far outside.
bool gather_cell_slow(const volume::VoxelVolume& vol, int i, int j, int k, float c[8]);
inline bool gather_cell(const volume::VoxelVolume& vol, const Eigen::Vector3f& v, float c[8],
                        Eigen::Vector3f& frac) {
  const Eigen::Vector3i& d = vol.dims();
  // Cells touching the volume have base corners in [-1, dims-1]; anything
  // else (and NaN) is air.
  if (!(v.x() > -1.f && v.y() > -1.f && v.z() > -1.f && v.x() < static_cast<float>(d.x()) &&
        v.y() < static_cast<float>(d.y()) && v.z() < static_cast<float>(d.z())))
    return false;
  // +1 then -1: truncation equals floor for the shifted, positive value.
  const int i = static_cast<int>(v.x() + 1.f) - 1, j = static_cast<int>(v.y() + 1.f) - 1,
            k = static_cast<int>(v.z() + 1.f) - 1;
  frac = Eigen::Vector3f(v.x() - static_cast<float>(i), v.y() - static_cast<float>(j),
                         v.z() - static_cast<float>(k));
  const int li = i & 15, lj = j & 15, lk = k & 15;
  // Fast path (~82% of cells): all 8 corners in one chunk, inside the volume.
  if (i >= 0 && j >= 0 && k >= 0 && li < 15 && lj < 15 && lk < 15 && i + 1 < d.x() &&
      j + 1 < d.y() && k + 1 < d.z()) {
    const volume::VoxelVolume::Chunk* ch = vol.chunk(vol.chunk_id(i >> 4, j >> 4, k >> 4));
    if (!ch) return false;
    const std::uint8_t* p = ch->density.data() + volume::chunk_local_index(li, lj, lk);
    constexpr int sy = volume::VoxelVolume::kChunkSize;
    constexpr int sz = sy * sy;
    const std::uint8_t a0 = p[0], a1 = p[1], a2 = p[sy], a3 = p[sy + 1], a4 = p[sz],
                       a5 = p[sz + 1], a6 = p[sz + sy], a7 = p[sz + sy + 1];
    if ((a0 | a1 | a2 | a3 | a4 | a5 | a6 | a7) == 0) return false;
    c[0] = a0, c[1] = a1, c[2] = a2, c[3] = a3, c[4] = a4, c[5] = a5, c[6] = a6, c[7] = a7;
    return true;
  }
  return gather_cell_slow(vol, i, j, k, c);
}

// Trilinear density at the cell position `f` and its gradient in density
// units per voxel.
inline float trilinear(const float c[8], const Eigen::Vector3f& f, Eigen::Vector3f& grad_vox) {
  const float fx = f.x(), fy = f.y(), fz = f.z();
  const float gx = 1.f - fx, gy = 1.f - fy, gz = 1.f - fz;
  // Interpolate along x on the four x-edges, then y, then z.
  const float e00 = c[0] * gx + c[1] * fx, e10 = c[2] * gx + c[3] * fx;
  const float e01 = c[4] * gx + c[5] * fx, e11 = c[6] * gx + c[7] * fx;
  const float f0 = e00 * gy + e10 * fy, f1 = e01 * gy + e11 * fy;
  const float dx00 = c[1] - c[0], dx10 = c[3] - c[2], dx01 = c[5] - c[4], dx11 = c[7] - c[6];
  grad_vox.x() = (dx00 * gy + dx10 * fy) * gz + (dx01 * gy + dx11 * fy) * fz;
  grad_vox.y() = (e10 - e00) * gz + (e11 - e01) * fz;
  grad_vox.z() = f1 - f0;
  return f0 * gz + f1 * fz;
}

// Bounding sphere of a bur in the tip frame (centre, radius in m).
void bur_bounding_sphere(const volume::BurParams& p, Eigen::Vector3d& centre_tip, double& radius);

// True when every voxel within `radius_m` (plus one voxel, for interpolation)
// of `centre_tooth` lies in an absent (all-air) chunk or outside the volume.
bool region_is_empty(const volume::VoxelVolume& vol, const Eigen::Vector3d& centre_tooth,
                     double radius_m);

// Model constructors behind make_force_model (parameters already validated).
std::unique_ptr<ForceModel> make_seed_model(const SeedParams& p, std::size_t max_samples);
std::unique_ptr<ForceModel> make_proxy_model(const ProxyParams& p, const DeviceLimits& limits,
                                             std::size_t max_samples);

}  // namespace dentar::haptics::detail
