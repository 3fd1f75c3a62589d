// Force-step time of each force model against bur sample count, per bur
// shape, on the default molar in contact (see docs/BENCHMARKS.md).
//   ./build/haptics/haptics_force_model_bench
// Counters: p50_us, p99_us, p999_us from per-step steady_clock timings;
// contacts and force_N of the last step (to show the bur really is in contact).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <vector>

#include "dentar/haptics/force_model.h"
#include "dentar/volume/procedural_tooth.h"

namespace dentar::haptics {
namespace {

using volume::BurParams;
using volume::BurShape;

const volume::VoxelVolume& default_tooth() {
  static const volume::VoxelVolume v = std::move(volume::make_molar({})).value();
  return v;
}

// Height (m) of the occlusal surface above (x, y): the first voxel from the
// top whose density exceeds the iso level.
double surface_z(const volume::VoxelVolume& v, double x, double y) {
  const Eigen::Vector3d o = v.origin(), s = v.spacing();
  const int i = static_cast<int>(std::lround((x - o.x()) / s.x()));
  const int j = static_cast<int>(std::lround((y - o.y()) / s.y()));
  for (int k = v.dims().z() - 1; k >= 0; --k)
    if (v.density(i, j, k) > volume::kIsoDensity) return o.z() + s.z() * k;
  return 0;
}

BurParams bur_of(int shape) {
  switch (static_cast<BurShape>(shape)) {
    case BurShape::kSphere: return BurParams::sphere(0.5);
    case BurShape::kCylinder: return BurParams::cylinder(0.5, 3.0);
    case BurShape::kCapsule: return BurParams::capsule(0.5, 3.0);
    case BurShape::kCone: return BurParams::cone(0.2, 0.5, 3.0);
  }
  return {};
}

// Bur pointing down, tilted 10 deg, its tip 0.3 mm under the occlusal
// surface near the central fossa, sweeping +-0.25 mm in x at 2 mm/s.
void BM_ForceStep(benchmark::State& state) {
  const int shape = static_cast<int>(state.range(0));
  const int samples = static_cast<int>(state.range(1));
  const char* model_name = state.range(2) == 0 ? "seed" : "proxy";
  const volume::VoxelVolume& vol = default_tooth();
  const auto bur = volume::sample_bur(bur_of(shape), samples);
  auto model = make_force_model(model_name, {}, DeviceLimits{}, volume::kMaxBurSamples);
  if (!bur.ok() || !model.ok()) {
    state.SkipWithError("setup failed");
    return;
  }
  ForceModel& m = **model;
  const double x0 = 0.5e-3, y0 = 0.5e-3;
  const double z_surface = surface_z(vol, x0, y0);
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(0.17, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(std::numbers::pi, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  ForceInput in;
  in.volume = &vol;
  in.bur = &*bur;
  in.T_tooth_tip.linear() = R;
  in.dt_s = 1e-3;
  const auto pose_at = [&](std::int64_t step) {
    // Triangle wave, period 500 steps: +-0.25 mm at 2 mm/s.
    const double ph = static_cast<double>(step % 500) / 500.0;
    const double tri = ph < 0.5 ? 4 * ph - 1 : 3 - 4 * ph;
    const double x = x0 + 0.25e-3 * tri;
    in.velocity_m_per_s = Eigen::Vector3d(ph < 0.5 ? 2e-3 : -2e-3, 0, 0);
    in.T_tooth_tip.translation() = Eigen::Vector3d(x, y0, surface_z(vol, x, y0) - 0.3e-3);
  };
  // Approach from above so the proxy starts free, then settle in contact.
  in.T_tooth_tip.translation() = Eigen::Vector3d(x0 - 0.25e-3, y0, z_surface + 1e-3);
  for (int i = 0; i < 200; ++i) {
    in.T_tooth_tip.translation().z() -= (1.3e-3 / 200);
    m.compute(in);
  }
  for (int i = 0; i < 100; ++i) {
    pose_at(0);
    m.compute(in);
  }
  std::vector<double> us;
  us.reserve(1 << 16);
  std::int64_t step = 0;
  ForceOutput out;
  for (auto _ : state) {
    pose_at(step++);
    const auto t0 = std::chrono::steady_clock::now();
    out = m.compute(in);
    const auto t1 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(out);
    us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
  }
  std::sort(us.begin(), us.end());
  const auto pct = [&](double q) {
    return us[std::min(us.size() - 1, static_cast<std::size_t>(q * static_cast<double>(us.size())))];
  };
  state.counters["p50_us"] = pct(0.5);
  state.counters["p99_us"] = pct(0.99);
  state.counters["p999_us"] = pct(0.999);
  state.counters["contacts"] = out.contacts;
  state.counters["force_N"] = out.force_N.norm();
  state.SetLabel(std::string(volume::bur_shape_name(static_cast<BurShape>(shape))) + "/" +
                 model_name);
}
BENCHMARK(BM_ForceStep)
    ->ArgNames({"shape", "samples", "model"})
    ->ArgsProduct({{0, 1, 2, 3}, {1000, 3000, 10000, 30000}, {0, 1}})
    ->Iterations(20000)
    ->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace dentar::haptics

BENCHMARK_MAIN();
