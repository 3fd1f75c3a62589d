// Test volumes shared by the force-model tests.
#pragma once

#include <Eigen/Core>
#include <functional>

#include "dentar/volume/voxel_volume.h"

namespace dentar::haptics::test_blocks {

inline constexpr double kVoxel = 1e-4;  // 0.1 mm

// 64^3 voxels of 0.1 mm around the origin; voxels whose centre satisfies
// `solid` get `density` of material `m` (default dentin, 200).
inline volume::VoxelVolume make_block(const std::function<bool(const Eigen::Vector3d&)>& solid,
                                      std::uint8_t density = 200,
                                      volume::Material m = volume::Material::kDentin) {
  volume::VolumeGeometry g;
  g.dims = Eigen::Vector3i(64, 64, 64);
  g.spacing = Eigen::Vector3d::Constant(kVoxel);
  g.origin = Eigen::Vector3d(-3.2e-3, -3.2e-3, -3.2e-3);
  volume::VoxelVolume v(g);
  for (int k = 0; k < 64; ++k)
    for (int j = 0; j < 64; ++j)
      for (int i = 0; i < 64; ++i)
        if (solid(v.voxel_center(i, j, k))) v.set(i, j, k, density, m);
  return v;
}

}  // namespace dentar::haptics::test_blocks
