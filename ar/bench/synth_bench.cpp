// Footage generator throughput (frames per second) for the standard preset:
// video pass, two id passes (masks, tag visibility), post-processing and the
// haptic engine in step, at 640x480 and 1280x720 on whatever EGL gives
// (llvmpipe on CI). Setup (molar, meshes, textures) is outside the timing.
#include <benchmark/benchmark.h>

#include "dentar/ar/egl_context.h"
#include "dentar/ar/synth.h"

namespace {

dentar::ar::EglContext* context() {
  static dentar::ar::EglContext* c = [] {
    auto r = dentar::ar::EglContext::create();
    return r ? new dentar::ar::EglContext(std::move(r).value()) : nullptr;
  }();
  return c;
}

void BM_SynthStandard(benchmark::State& state) {
  if (context() == nullptr) {
    state.SkipWithError("no headless EGL context");
    return;
  }
  dentar::ar::SynthOptions o = dentar::ar::synth_preset(dentar::ar::SynthPreset::kStandard);
  o.width = static_cast<int>(state.range(0));
  o.height = static_cast<int>(state.range(1));
  o.frames = 100000;
  auto g = dentar::ar::SynthGenerator::create(dentar::ar::default_station_scene(), o);
  if (!g) {
    state.SkipWithError(g.error().c_str());
    return;
  }
  dentar::ar::SynthFrame f;
  for (auto _ : state) {
    if (!(*g)->next(f).ok()) {
      state.SkipWithError("next() failed");
      break;
    }
    benchmark::DoNotOptimize(f.image.data);
  }
  state.counters["fps"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SynthStandard)
    ->Args({640, 480})
    ->Args({1280, 720})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(5.0);

}  // namespace

BENCHMARK_MAIN();
