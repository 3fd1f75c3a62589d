// Per-step DTW alignment of two 10-minute recordings (issue 27, `dentar replay --against`;
// docs/BENCHMARKS.md "Issue 27 (session 13): the replay window"): the bur tip tracks (mm,
// 3 columns) at the replay's 100 Hz track rate, 60,000 frames against 66,000 (the student
// took 10 % longer, with a smooth warp), four steps found in each, aligned step by step
// (replay::align_by_step, multi-resolution DTW radius 8). Goal: <= 1 s.
//   ./build/replay/replay_align_bench
#include <benchmark/benchmark.h>

#include <cmath>
#include <numbers>

#include "dentar/replay/step_align.h"

namespace dentar::replay {
namespace {

// A tip path over a 600 s procedure; `warped` bends time (slope 0.3..1.7). Step k covers
// procedure time [150 k, 150 (k + 1)) s, so the step labels follow the warp.
void session(int n, bool warped, training::Series& x, std::vector<int>& steps) {
  x.resize(n, 3);
  steps.resize(static_cast<std::size_t>(n));
  const double w = 2 * std::numbers::pi;
  for (int i = 0; i < n; ++i) {
    double s = static_cast<double>(i) / (n - 1);
    if (warped) s = s + 0.12 * std::sin(w * s) * (1 - s) + 0.05 * std::sin(3 * w * s) / 3;
    const double t = 600 * s;
    x(i, 0) = 3 * std::sin(w * 0.011 * t) + std::sin(w * 0.23 * t);
    x(i, 1) = 2 * std::cos(w * 0.007 * t) + 0.5 * std::sin(w * 0.31 * t);
    x(i, 2) = std::sin(w * 0.05 * t + 0.4) + 0.2 * std::sin(w * 1.7 * t);
    steps[static_cast<std::size_t>(i)] = std::min(3, static_cast<int>(t / 150));
  }
}

void BM_StepDtwTenMinutes(benchmark::State& state) {
  const int hz = static_cast<int>(state.range(0));
  training::Series a, b;
  std::vector<int> sa, sb;
  session(600 * hz, false, a, sa);
  session(600 * hz * 11 / 10, true, b, sb);
  std::size_t cells = 0, aligned = 0;
  for (auto _ : state) {
    auto w = align_by_step(a, sa, b, sb, 8);
    if (!w.ok()) {
      state.SkipWithError(w.error().c_str());
      return;
    }
    cells = w->cells;
    aligned = w->steps_aligned.size();
    benchmark::DoNotOptimize(w->b_row.data());
  }
  state.counters["cells"] = static_cast<double>(cells);
  state.counters["frames"] = static_cast<double>(a.rows());
  state.counters["steps"] = static_cast<double>(aligned);
}
BENCHMARK(BM_StepDtwTenMinutes)->Arg(100)->Arg(1000)->Unit(benchmark::kMillisecond)->Repetitions(5)
    ->ReportAggregatesOnly(true);

}  // namespace
}  // namespace dentar::replay

BENCHMARK_MAIN();
