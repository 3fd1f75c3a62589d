#include "contact.h"

#include <algorithm>
#include <cmath>

namespace dentar::haptics::detail {

VoxelMap VoxelMap::make(const volume::VolumeGeometry& g, const Eigen::Isometry3d& T_tooth_tip) {
  const Eigen::Vector3d inv_s = g.spacing.cwiseInverse();
  VoxelMap m;
  m.M = (inv_s.asDiagonal() * T_tooth_tip.linear()).cast<float>();
  m.b = inv_s.cwiseProduct(T_tooth_tip.translation() - g.origin).cast<float>();
  return m;
}

bool gather_cell_slow(const volume::VoxelVolume& vol, int i, int j, int k, float c[8]) {
  // The cell straddles a chunk boundary or the volume's edge: read each
  // corner from its own chunk (air outside the volume and in absent chunks).
  bool any = false;
  for (int n = 0; n < 8; ++n) {
    const int x = i + (n & 1), y = j + ((n >> 1) & 1), z = k + (n >> 2);
    std::uint8_t d = 0;
    if (vol.in_bounds(x, y, z))
      if (const auto* ch = vol.chunk(vol.chunk_id(x >> 4, y >> 4, z >> 4)))
        d = ch->density[static_cast<std::size_t>(volume::chunk_local_index(x & 15, y & 15, z & 15))];
    c[n] = d;
    any |= d != 0;
  }
  return any;
}

void bur_bounding_sphere(const volume::BurParams& p, Eigen::Vector3d& centre_tip, double& radius) {
  const double L = p.shape == volume::BurShape::kSphere ? 2 * p.radius_m : p.length_m;
  centre_tip = Eigen::Vector3d(0, 0, -0.5 * L);
  radius = p.shape == volume::BurShape::kSphere ? p.radius_m : std::hypot(0.5 * L, p.radius_m);
}

bool region_is_empty(const volume::VoxelVolume& vol, const Eigen::Vector3d& centre_tooth,
                     double radius_m) {
  if (!centre_tooth.allFinite() || !std::isfinite(radius_m)) return false;
  const volume::VolumeGeometry& g = vol.geometry();
  const Eigen::Vector3d lo = (centre_tooth - g.origin - Eigen::Vector3d::Constant(radius_m))
                                 .cwiseQuotient(g.spacing) - Eigen::Vector3d::Ones();
  const Eigen::Vector3d hi = (centre_tooth - g.origin + Eigen::Vector3d::Constant(radius_m))
                                 .cwiseQuotient(g.spacing) + Eigen::Vector3d::Ones();
  Eigen::Vector3i clo, chi;
  for (int a = 0; a < 3; ++a) {
    // Clamp in double before converting: the box may be far outside.
    const double l = std::clamp(std::floor(lo[a]), 0.0, static_cast<double>(g.dims[a] - 1));
    const double h = std::clamp(std::ceil(hi[a]), 0.0, static_cast<double>(g.dims[a] - 1));
    if (hi[a] < 0 || lo[a] > g.dims[a] - 1) return true;  // box misses the volume
    clo[a] = static_cast<int>(l) >> volume::VoxelVolume::kChunkBits;
    chi[a] = static_cast<int>(h) >> volume::VoxelVolume::kChunkBits;
  }
  for (int ck = clo.z(); ck <= chi.z(); ++ck)
    for (int cj = clo.y(); cj <= chi.y(); ++cj)
      for (int ci = clo.x(); ci <= chi.x(); ++ci)
        if (vol.chunk(vol.chunk_id(ci, cj, ck))) return false;
  return true;
}

}  // namespace dentar::haptics::detail
