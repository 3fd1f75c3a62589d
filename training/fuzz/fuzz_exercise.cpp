// Fuzz target: the exercise parser, then rasterising its regions on a small
// block (shapes, overlap check) and scoring an untouched cut.
#include <cstdint>
#include <string>

#include "dentar/training/outcome.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dentar;
  const std::string text(reinterpret_cast<const char*>(data), size);
  auto ex = training::parse_exercise(text, "fuzz.json");
  if (!ex) return 0;
  static const volume::VoxelVolume block = [] {
    volume::VolumeGeometry g;
    g.dims = Eigen::Vector3i(20, 20, 24);
    g.spacing = Eigen::Vector3d::Constant(0.5e-3);
    g.origin = Eigen::Vector3d(-5e-3, -5e-3, -2e-3);
    volume::VoxelVolume v(g);
    for (int k = 0; k < 24; ++k)
      for (int j = 0; j < 20; ++j)
        for (int i = 0; i < 20; ++i)
          v.set(i, j, k, k < 4 ? 70 : 200, k < 4 ? volume::Material::kPulp : volume::Material::kDentin);
    return v;
  }();
  auto m = training::build_masks(*ex, block);
  if (!m) return 0;
  auto o = training::score_outcome(*ex, *m, block, block);
  if (o && o->removed_total_mm3 != 0) __builtin_trap();  // nothing was cut
  return 0;
}
