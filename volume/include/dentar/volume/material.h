// Material labels of the voxel tooth and their physical properties.
#pragma once

#include <array>
#include <cstdint>
#include <string_view>

namespace dentar::volume {

// Per-voxel label (uint8). Values are stable: they are stored in files and
// session logs. New materials are appended; kMaxMaterials bounds the tables.
enum class Material : std::uint8_t {
  kAir = 0,
  kEnamel = 1,
  kDentin = 2,
  kPulp = 3,
  kCaries = 4,
  kRestoration = 5,
};
inline constexpr int kNumMaterials = 6;   // labels defined above
inline constexpr int kMaxMaterials = 16;  // table size; labels >= this are invalid

struct MaterialInfo {
  std::string_view name;
  // Density (0..255) a voxel of this material has when fully present. It is
  // both the surface scalar (iso level kIsoDensity) and the force model's
  // "density of touched voxels".
  std::uint8_t full_density;
  // Relative removal rate while cutting (dentin = 1). Enamel is slowest.
  double removal_rate;
  std::array<std::uint8_t, 3> rgb;  // display colour, sRGB
};

// Surface iso level on the density scale: solid where density > kIsoDensity.
inline constexpr float kIsoDensity = 127.5f;

const MaterialInfo& material_info(Material m);
inline const MaterialInfo& material_info(int label) {
  return material_info(static_cast<Material>(label));
}
std::string_view material_name(Material m);

}  // namespace dentar::volume
