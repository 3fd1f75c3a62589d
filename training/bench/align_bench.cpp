// DTW alignment of two 10-minute recordings (issue 27; docs/BENCHMARKS.md): the tip
// path (3-D) of an expert and a student, the student's timing warped, at 50 Hz, 250 Hz and
// 1 kHz (30,000 / 150,000 / 600,000 samples each), multi-resolution radius 8. Goal: <= 1 s.
//   ./build/training/training_align_bench
#include <benchmark/benchmark.h>

#include <cmath>
#include <numbers>

#include "dentar/training/align.h"

namespace dentar::training {
namespace {

Series session(int n, bool warped) {
  Series x(n, 3);
  const double w = 2 * std::numbers::pi;
  for (int i = 0; i < n; ++i) {
    double s = static_cast<double>(i) / (n - 1);
    if (warped) s = s + 0.12 * std::sin(w * s) * (1 - s) + 0.05 * std::sin(3 * w * s) / 3;
    const double t = 600 * s;  // seconds into the session
    x(i, 0) = 3 * std::sin(w * 0.011 * t) + std::sin(w * 0.23 * t);
    x(i, 1) = 2 * std::cos(w * 0.007 * t) + 0.5 * std::sin(w * 0.31 * t);
    x(i, 2) = std::sin(w * 0.05 * t + 0.4) + 0.2 * std::sin(w * 1.7 * t);
  }
  return x;
}

void BM_DtwTenMinutes(benchmark::State& state) {
  const int hz = static_cast<int>(state.range(0));
  const Series a = session(600 * hz, false), b = session(600 * hz * 11 / 10, true);  // the student took 10 % longer
  std::size_t cells = 0;
  for (auto _ : state) {
    auto al = dtw_align(a, b, 8);
    if (!al.ok()) {
      state.SkipWithError(al.error().c_str());
      return;
    }
    cells = al->cells;
    benchmark::DoNotOptimize(al->cost);
  }
  state.counters["cells"] = static_cast<double>(cells);
  state.counters["samples"] = static_cast<double>(a.rows());
}
BENCHMARK(BM_DtwTenMinutes)->Arg(50)->Arg(250)->Arg(1000)->Unit(benchmark::kMillisecond)->Repetitions(5)
    ->ReportAggregatesOnly(true);

}  // namespace
}  // namespace dentar::training

BENCHMARK_MAIN();
