// Per-step DTW (step_align.h) on a hand-made pair with a known warp that differs per step:
// b plays step 1 1.5x slower, step 2 twice as fast, step 3 twice as slow as a. The map must
// recover each step's own warp, keep the step boundaries on each other, and run straight
// across a step that only one recording has. (training::dtw_align itself is tested on a
// known warp in training/test/align_test.cpp; this tests the per-step composition.)
#include "dentar/replay/step_align.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace dentar::replay {
namespace {

// The procedure: a tip path as a function of the procedure's progress u in [0, 3) (step k =
// floor(u)); a wiggle so that DTW has something to lock on.
Eigen::Vector3d path(double u) {
  return {3 * std::sin(2.1 * u) + std::sin(9.0 * u), 2 * std::cos(1.3 * u) + 0.5 * std::sin(7.0 * u), 0.8 * u};
}

struct Pair {
  training::Series a, b;
  std::vector<int> sa, sb;
  std::vector<double> truth;  // per row of a: the row of b at the same progress
};

// a: steps of 100, 200, 150 rows; b: 150, 100, 300 rows (x1.5, x0.5, x2).
Pair make_pair() {
  const int na[3] = {100, 200, 150}, nb[3] = {150, 100, 300};
  Pair p;
  auto fill = [](const int* n, training::Series& x, std::vector<int>& s, std::vector<double>* starts) {
    const int total = n[0] + n[1] + n[2];
    x.resize(total, 3);
    int r = 0;
    for (int k = 0; k < 3; ++k)
      for (int i = 0; i < n[k]; ++i, ++r) {
        x.row(r) = path(k + static_cast<double>(i) / n[k]).transpose();
        s.push_back(k);
      }
    if (starts) *starts = {0.0, double(n[0]), double(n[0] + n[1])};
  };
  std::vector<double> a0, b0;
  fill(na, p.a, p.sa, &a0);
  fill(nb, p.b, p.sb, &b0);
  for (int k = 0, r = 0; k < 3; ++k)
    for (int i = 0; i < na[k]; ++i, ++r) p.truth.push_back(b0[static_cast<std::size_t>(k)] + double(i) * nb[k] / na[k]);
  return p;
}

TEST(StepAlign, RecoversADifferentWarpInEachStep) {
  const Pair p = make_pair();
  auto w = align_by_step(p.a, p.sa, p.b, p.sb, 8);
  ASSERT_TRUE(w.ok()) << w.error();
  ASSERT_EQ(w->b_row.size(), p.truth.size());
  EXPECT_EQ(w->steps_aligned, (std::vector<int>{0, 1, 2}));
  std::vector<double> err;
  for (std::size_t i = 0; i < p.truth.size(); ++i) {
    err.push_back(std::abs(w->b_row[i] - p.truth[i]));
    if (i > 0) {
      EXPECT_GE(w->b_row[i], w->b_row[i - 1]) << "monotone at row " << i;
    }
  }
  std::sort(err.begin(), err.end());
  // Bounds in rows of b: a DTW path is integer and b is sampled up to 2x denser than a in
  // step 3, so a map within a couple of rows is exact up to that.
  EXPECT_LE(err[err.size() * 95 / 100], 2.0) << "p95 error";
  EXPECT_LE(err.back(), 4.0) << "worst error";
  // Each step starts where the other recording's step starts.
  EXPECT_NEAR(w->b_row[100], 150.0, 1.0);
  EXPECT_NEAR(w->b_row[300], 250.0, 1.0);
  EXPECT_DOUBLE_EQ(w->b_row.front(), 0.0);
  // a's last row shows b where its last step is as far along (row 548 of 550).
  EXPECT_NEAR(w->b_row.back(), p.truth.back(), 1.0);
}

// A step that b never reached (the student stopped after step 2; step 3 absent): the
// aligned steps keep their warps and the rest of a runs straight to b's end.
TEST(StepAlign, AStepOnlyOneRecordingHasRunsStraight) {
  Pair p = make_pair();
  const int nb = 250;  // b's steps 1 and 2 only
  training::Series b = p.b.topRows(nb);
  std::vector<int> sb(p.sb.begin(), p.sb.begin() + nb);
  auto w = align_by_step(p.a, p.sa, b, sb, 8);
  ASSERT_TRUE(w.ok()) << w.error();
  EXPECT_EQ(w->steps_aligned, (std::vector<int>{0, 1}));
  for (int i = 0; i < 300; ++i) EXPECT_NEAR(w->b_row[static_cast<std::size_t>(i)], p.truth[static_cast<std::size_t>(i)], 4.0) << i;
  // Rows 300..449 of a: straight from b's last aligned row to its end.
  const double v0 = w->b_row[299], v1 = nb - 1;
  for (int i = 300; i < 450; ++i)
    EXPECT_NEAR(w->b_row[static_cast<std::size_t>(i)], v0 + (v1 - v0) * (i - 299) / 150.0, 1e-9) << i;
}

TEST(StepAlign, BadInputIsNamed) {
  const Pair p = make_pair();
  auto w = align_by_step(p.a, std::vector<int>(3, 0), p.b, p.sb);
  ASSERT_FALSE(w.ok());
  EXPECT_NE(w.error().find("a step label is needed for every row (a: 450 rows, 3 labels"), std::string::npos) << w.error();
  training::Series bad = p.b;
  bad(160, 1) = std::nan("");
  w = align_by_step(p.a, p.sa, bad, p.sb);
  ASSERT_FALSE(w.ok());
  EXPECT_NE(w.error().find("step 2: "), std::string::npos) << w.error();
  w = align_by_step(training::Series(0, 3), {}, p.b, p.sb);
  ASSERT_FALSE(w.ok());
}

}  // namespace
}  // namespace dentar::replay
