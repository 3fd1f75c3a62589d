// DTW alignment of two recordings (issue 27): a hand-made pair with a known warp, the
// multi-resolution aligner against exact DTW, and bad input.
#include "dentar/training/align.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace dentar::training {
namespace {

// A tip path (mm): three incommensurate sines per axis, t in [0, 1].
Eigen::RowVector3d path(double t) {
  const double w = 2 * std::numbers::pi;
  return {3 * std::sin(w * 1.3 * t) + std::sin(w * 4.1 * t), 2 * std::cos(w * 0.7 * t) + 0.5 * std::sin(w * 5.3 * t),
          std::sin(w * 2.2 * t + 0.4)};
}
// The warp: the second recording's time s maps to the first's w(s), monotone (w' >= 0.30).
double warp(double s) { return s + 0.12 * std::sin(2 * std::numbers::pi * s) * (1 - s) + 0.05 * std::sin(6 * std::numbers::pi * s) / 3; }

Series sample(int n, bool warped) {
  Series x(n, 3);
  for (int i = 0; i < n; ++i) {
    const double s = static_cast<double>(i) / (n - 1);
    x.row(i) = path(warped ? warp(s) : s);
  }
  return x;
}

TEST(Align, RecoversAKnownWarp) {
  const int n = 1000, m = 1300;
  const Series a = sample(n, false), b = sample(m, true);
  auto al = dtw_align(a, b, 8);
  ASSERT_TRUE(al.ok()) << al.error();
  ASSERT_EQ(al->path.front(), std::make_pair(0, 0));
  ASSERT_EQ(al->path.back(), std::make_pair(n - 1, m - 1));
  std::vector<double> err;
  for (std::size_t k = 1; k < al->path.size(); ++k) {
    const auto [i, j] = al->path[k];
    const auto [pi, pj] = al->path[k - 1];
    ASSERT_TRUE((i - pi == 1 || i == pi) && (j - pj == 1 || j == pj) && (i != pi || j != pj)) << k;
    // Where b's sample j truly is in a (in a's samples).
    err.push_back(std::abs(i - warp(static_cast<double>(j) / (m - 1)) * (n - 1)));
  }
  std::sort(err.begin(), err.end());
  EXPECT_LT(err[err.size() * 95 / 100], 1.5) << "p95 in a's samples";
  EXPECT_LT(err.back(), 4.0) << "worst, in a's samples";
  // The map for playing b beside a follows the inverse warp.
  const std::vector<double> map = warp_map(*al, n);
  ASSERT_EQ(map.size(), static_cast<std::size_t>(n));
  EXPECT_TRUE(std::is_sorted(map.begin(), map.end()));
}

TEST(Align, MultiResolutionFindsTheExactPathForAFractionOfTheWork) {
  const Series a = sample(800, false), b = sample(1100, true);
  auto exact = dtw_align(a, b, 0);
  auto fast = dtw_align(a, b, 8);
  ASSERT_TRUE(exact.ok() && fast.ok());
  EXPECT_EQ(exact->cells, 800u * 1100u);
  EXPECT_LE(fast->cost, exact->cost * 1.001) << "exact " << exact->cost << " multi-resolution " << fast->cost;
  EXPECT_GE(fast->cost, exact->cost - 1e-9) << "exact DTW is the minimum";
  EXPECT_LT(fast->cells * 5, exact->cells);
  // Itself: the diagonal at no cost.
  auto self = dtw_align(a, a, 4);
  ASSERT_TRUE(self.ok());
  EXPECT_EQ(self->cost, 0.0);
  for (const auto& [i, j] : self->path) EXPECT_EQ(i, j);
}

TEST(Align, BadInputIsNamed) {
  const Series a = sample(50, false);
  Series two(10, 2);
  two.setZero();
  auto w = dtw_align(a, two);
  ASSERT_FALSE(w.ok());
  EXPECT_NE(w.error().find("3 and 2 values per sample"), std::string::npos) << w.error();
  auto e = dtw_align(a, Series(0, 3));
  ASSERT_FALSE(e.ok());
  EXPECT_NE(e.error().find("empty"), std::string::npos) << e.error();
  Series bad = a;
  bad(17, 1) = NAN;
  auto n = dtw_align(a, bad);
  ASSERT_FALSE(n.ok());
  EXPECT_NE(n.error().find("series b has a non-finite value at sample 17"), std::string::npos) << n.error();
  auto big = dtw_align(Series::Zero(20000, 1), Series::Zero(20000, 1), 0);
  ASSERT_FALSE(big.ok());
  EXPECT_NE(big.error().find("use a radius > 0"), std::string::npos) << big.error();
}

}  // namespace
}  // namespace dentar::training
