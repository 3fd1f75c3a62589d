#include "dentar/volume/material.h"

#include <cassert>

namespace dentar::volume {
namespace {
// Removal rates relative to dentin: enamel is roughly 3-4x harder to cut than
// dentin with a diamond/carbide bur; carious dentin and pulp soft tissue cut
// several times faster. Densities put enamel above dentin (as in CT) and pulp
// below the iso level, so an opened pulp chamber shows as a cavity surface.
constexpr std::array<MaterialInfo, kMaxMaterials> kTable = {{
    {"air", 0, 0.0, {0, 0, 0}},
    {"enamel", 250, 0.3, {240, 236, 222}},
    {"dentin", 200, 1.0, {222, 200, 150}},
    {"pulp", 70, 6.0, {200, 60, 70}},
    {"caries", 150, 4.0, {120, 90, 50}},
    {"restoration", 255, 0.5, {170, 175, 185}},
    {"unknown6", 200, 1.0, {255, 0, 255}},
    {"unknown7", 200, 1.0, {255, 0, 255}},
    {"unknown8", 200, 1.0, {255, 0, 255}},
    {"unknown9", 200, 1.0, {255, 0, 255}},
    {"unknown10", 200, 1.0, {255, 0, 255}},
    {"unknown11", 200, 1.0, {255, 0, 255}},
    {"unknown12", 200, 1.0, {255, 0, 255}},
    {"unknown13", 200, 1.0, {255, 0, 255}},
    {"unknown14", 200, 1.0, {255, 0, 255}},
    {"unknown15", 200, 1.0, {255, 0, 255}},
}};
}  // namespace

const MaterialInfo& material_info(Material m) {
  const auto i = static_cast<std::size_t>(m);
  assert(i < kTable.size() && "dentar::volume::material_info: label out of range");
  return kTable[i < kTable.size() ? i : 0];
}

std::string_view material_name(Material m) { return material_info(m).name; }

}  // namespace dentar::volume
