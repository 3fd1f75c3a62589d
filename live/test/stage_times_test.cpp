// The live summary's per-stage times (issue 28, session 17; live_run.h StageTimes): a fixed
// histogram gives the same p50 / p99 as the exact percentile of the samples, within its
// 0.1 ms bin, and the largest time for a quantile above its 2 s range.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "../src/live_run.h"

namespace dentar::live {
namespace {

TEST(StageTimes, PercentilesMatchTheExactOnesWithinABin) {
  std::mt19937 rng(7);
  std::lognormal_distribution<double> ms(2.5, 0.6);  // ~12 ms with a long tail, as a frame's stages
  StageTimes t;
  std::vector<double> v;
  for (int i = 0; i < 5000; ++i) {
    const double x = ms(rng);
    t.add(x);
    v.push_back(x);
  }
  for (const double q : {0.5, 0.9, 0.99}) {
    SCOPED_TRACE(q);
    EXPECT_NEAR(t.percentile(q), percentile(v, q), StageTimes::kBinMs);
  }
  EXPECT_EQ(t.n, 5000u);
}

TEST(StageTimes, BeyondTheRangeGivesTheLargestTime) {
  StageTimes t;
  EXPECT_EQ(t.percentile(0.5), 0.0) << "no samples";
  t.add(1.0);
  t.add(2500.0);
  t.add(3100.0);
  EXPECT_NEAR(t.percentile(0.0), 1.0, StageTimes::kBinMs);
  EXPECT_EQ(t.percentile(0.99), 3100.0);
  const std::size_t before = t.bins.size();
  for (int i = 0; i < 1000; ++i) t.add(i * 0.37);
  EXPECT_EQ(t.bins.size(), before) << "a run's figures must not grow memory";
}

}  // namespace
}  // namespace dentar::live
