// Assessment and scoring speed: forward (classify) and one Baum-Welch
// iteration (train) against sequence length up to 10^6 steps, DTW, k-means,
// and outcome scoring of one session's volume.
//   build-training/training/training_assess_bench --benchmark_repetitions=5
#include <benchmark/benchmark.h>

#include <algorithm>
#include <random>

#include "dentar/training/models.h"
#include "dentar/training/outcome.h"

namespace dentar::training {
namespace {

std::vector<int> symbols(std::size_t n) {
  std::vector<int> o(n);
  std::mt19937 rng(1);
  for (auto& x : o) x = static_cast<int>(rng() % 13);
  return o;
}

Sequence frames(Eigen::Index n, Eigen::Index d) {
  std::mt19937 rng(2);
  std::normal_distribution<double> g(0, 1);
  Sequence x(n, d);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j < d; ++j) x(i, j) = g(rng) + ((i / 500) % 3);
  return x;
}

void BM_DiscreteHmmClassify(benchmark::State& st) {
  const DiscreteHmm h = DiscreteHmm::random(13, 13, 1);
  const auto o = symbols(static_cast<std::size_t>(st.range(0)));
  for (auto _ : st) benchmark::DoNotOptimize(h.log_likelihood(o).value());
  st.SetItemsProcessed(st.iterations() * st.range(0));
}
BENCHMARK(BM_DiscreteHmmClassify)->RangeMultiplier(10)->Range(1000, 1000000)->Unit(benchmark::kMillisecond);

void BM_DiscreteHmmTrainIteration(benchmark::State& st) {
  const auto o = symbols(static_cast<std::size_t>(st.range(0)));
  for (auto _ : st) {
    DiscreteHmm h = DiscreteHmm::random(13, 13, 1);
    benchmark::DoNotOptimize(h.train({o}, 1).value().iterations);
  }
  st.SetItemsProcessed(st.iterations() * st.range(0));
}
BENCHMARK(BM_DiscreteHmmTrainIteration)->RangeMultiplier(10)->Range(1000, 1000000)->Unit(benchmark::kMillisecond);

GaussianHmm ghmm(int n, int d) {
  GaussianHmm g;
  g.pi = Eigen::VectorXd::Constant(n, 1.0 / n);
  g.A = Eigen::MatrixXd::Constant(n, n, 1.0 / n);
  g.mean = Eigen::MatrixXd::Random(n, d);
  g.var = Eigen::MatrixXd::Ones(n, d);
  return g;
}

void BM_GaussianHmmClassify(benchmark::State& st) {
  const GaussianHmm g = ghmm(13, 10);
  const Sequence x = frames(st.range(0), 10);
  for (auto _ : st) benchmark::DoNotOptimize(g.log_likelihood(x).value());
  st.SetItemsProcessed(st.iterations() * st.range(0));
}
BENCHMARK(BM_GaussianHmmClassify)->RangeMultiplier(10)->Range(1000, 1000000)->Unit(benchmark::kMillisecond);

void BM_GaussianHmmTrainIteration(benchmark::State& st) {
  const Sequence x = frames(st.range(0), 10);
  for (auto _ : st) {
    GaussianHmm g = ghmm(13, 10);
    benchmark::DoNotOptimize(g.train({x}, 1).value().iterations);
  }
  st.SetItemsProcessed(st.iterations() * st.range(0));
}
BENCHMARK(BM_GaussianHmmTrainIteration)->RangeMultiplier(10)->Range(1000, 1000000)->Unit(benchmark::kMillisecond);

// DTW as classify() runs it: both sequences resampled to 200 rows, band 20;
// and unbanded at the raw length.
void BM_DtwResampled(benchmark::State& st) {
  const Sequence a = resample(frames(st.range(0), 10), 200), b = resample(frames(st.range(0) / 2 + 2, 10), 200);
  for (auto _ : st) benchmark::DoNotOptimize(dtw_distance(a, b, 20));
}
BENCHMARK(BM_DtwResampled)->Arg(1000000)->Unit(benchmark::kMillisecond);
void BM_DtwFull(benchmark::State& st) {
  const Sequence a = frames(st.range(0), 10), b = frames(st.range(0), 10);
  for (auto _ : st) benchmark::DoNotOptimize(dtw_distance(a, b));
}
BENCHMARK(BM_DtwFull)->Arg(1000)->Arg(3000)->Unit(benchmark::kMillisecond);

void BM_KMeans13(benchmark::State& st) {
  const Sequence x = frames(st.range(0), 10);
  for (auto _ : st) benchmark::DoNotOptimize(KMeans::fit(x, 13, 1).value().centroids(0, 0));
}
BENCHMARK(BM_KMeans13)->Arg(10000)->Arg(1000000)->Unit(benchmark::kMillisecond);

// Outcome scoring of the shipped molar access opening (0.1 mm tooth) on an
// ideal cut: masks once per exercise, then the score of one session.
struct Scoring {
  Exercise ex;
  volume::VoxelVolume start, cut;
  RegionMasks masks;
};
Scoring& scoring() {
  static Scoring s = [] {
    auto ex = load_builtin_exercise("molar_access_opening");
    auto tooth = make_tooth(ex->tooth_json);
    auto m = build_masks(*ex, *tooth);
    volume::VoxelVolume cut = tooth->clone();
    const auto d = cut.dims();
    for (int k = 0; k < d.z(); ++k)
      for (int j = 0; j < d.y(); ++j)
        for (int i = 0; i < d.x(); ++i)
          if (m->bits[m->index(i, j, k)] & m->target_bits) cut.set(i, j, k, 0, cut.material(i, j, k));
    return Scoring{*ex, std::move(*tooth), std::move(cut), std::move(*m)};
  }();
  return s;
}
void BM_BuildMasksMolarAccess(benchmark::State& st) {
  Scoring& s = scoring();
  for (auto _ : st) benchmark::DoNotOptimize(build_masks(s.ex, s.start).value().bits.size());
}
BENCHMARK(BM_BuildMasksMolarAccess)->Unit(benchmark::kMillisecond);
void BM_ScoreOutcomeMolarAccess(benchmark::State& st) {
  Scoring& s = scoring();
  for (auto _ : st) benchmark::DoNotOptimize(score_outcome(s.ex, s.masks, s.start, s.cut).value().points);
}
BENCHMARK(BM_ScoreOutcomeMolarAccess)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace dentar::training

BENCHMARK_MAIN();
