// Cutting step and storage benchmarks (see docs/BENCHMARKS.md).
//   ./build/volume/volume_cutter_bench --benchmark_repetitions=5
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "dentar/volume/cutter.h"
#include "dentar/volume/procedural_tooth.h"

namespace dentar::volume {
namespace {

const VoxelVolume& default_tooth() {
  static const VoxelVolume v = std::move(make_molar({})).value();
  return v;
}

// Bur axis tilted 20 deg from vertical, tip in the occlusal enamel/dentin,
// sweeping slowly: a realistic mid-preparation step.
Eigen::Isometry3d stroke_pose(std::int64_t i) {
  const double t = static_cast<double>(i % 2000) / 2000.0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()) *
                Eigen::AngleAxisd(0.35, Eigen::Vector3d::UnitY()))
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(-2.0e-3 + 4.0e-3 * t, 0.5e-3, 5.6e-3);
  return T;
}

// One cutting step with a 3 mm capsule bur (radius 0.5 mm) at N samples.
// Reports p50/p99 of per-step wall time as counters (us).
void BM_CutStepCapsule3mm(benchmark::State& state) {
  VoxelVolume vol = default_tooth().clone();
  auto bur = sample_bur(BurParams::capsule(0.5, 3.0), static_cast<int>(state.range(0)));
  Cutter cutter(vol);
  std::vector<double> us;
  us.reserve(1 << 20);
  std::int64_t i = 0;
  std::vector<int> drained;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    auto r = cutter.step(*bur, stroke_pose(i++), 2.0, 1e-3);
    const auto t1 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(r);
    us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
    if ((i & 1023) == 0) {  // keep the dirty set small, as the mesher would
      state.PauseTiming();
      drained.clear();
      vol.drain_dirty(drained);
      state.ResumeTiming();
    }
  }
  std::sort(us.begin(), us.end());
  state.counters["p50_us"] = us[us.size() / 2];
  state.counters["p99_us"] = us[us.size() * 99 / 100];
  state.counters["removed_mm3"] = cutter.metrics().removed_total_mm3;
}
BENCHMARK(BM_CutStepCapsule3mm)->Arg(1000)->Arg(3000)->Arg(10000)->Arg(30000)
    ->Unit(benchmark::kMicrosecond);

// Building the default procedural molar (0.08 mm voxels), and its memory.
void BM_MakeDefaultMolar(benchmark::State& state) {
  std::size_t mem = 0, dense = 0;
  int chunks = 0, total = 0;
  for (auto _ : state) {
    auto v = make_molar({});
    mem = v->memory_bytes();
    dense = v->dense_bytes();
    chunks = v->allocated_chunks();
    total = v->num_chunks();
  }
  state.counters["sparse_MB"] = static_cast<double>(mem) / 1e6;
  state.counters["dense_MB"] = static_cast<double>(dense) / 1e6;
  state.counters["chunks_alloc"] = chunks;
  state.counters["chunks_total"] = total;
}
BENCHMARK(BM_MakeDefaultMolar)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace
}  // namespace dentar::volume

BENCHMARK_MAIN();
