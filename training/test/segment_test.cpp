// training::segment_steps on hand-made tracks: three steps 5 mm apart along x, the bur
// cutting straight down (-z) at a step's focus.
#include <gtest/gtest.h>

#include <algorithm>

#include "dentar/training/exercise.h"
#include "dentar/training/session.h"

namespace {

using namespace dentar::training;

Exercise three_steps() {
  Exercise ex;
  ex.name = "three";
  for (int k = 0; k < 3; ++k) {
    ExerciseStep s;
    s.name = "step " + std::to_string(k);
    s.focus_m = Eigen::Vector3d(5e-3 * k, 0, 0);
    ex.steps.push_back(s);
  }
  return ex;
}

// `plan`: (step whose focus the bur cuts at, seconds; step -1 = idle above the tooth).
SessionTrack track(const std::vector<std::pair<int, double>>& plan) {
  SessionTrack t;
  t.rate_hz = 100;
  double now = 0;
  for (const auto& [step, seconds] : plan) {
    const int n = static_cast<int>(seconds * t.rate_hz + 0.5);
    for (int i = 0; i < n; ++i) {
      t.t_s.push_back(now);
      now += 1.0 / t.rate_hz;
      const Eigen::Vector3d at = step >= 0 ? Eigen::Vector3d(5e-3 * step, 0, 0) : Eigen::Vector3d(0, 0, 0.02);
      t.tip_m.push_back(at);
      t.axis.push_back(-Eigen::Vector3d::UnitZ());
      t.force_N.push_back(Eigen::Vector3d::Zero());
      t.pedal.push_back(step >= 0 ? 1.0 : 0.0);
      std::array<double, dentar::volume::kMaxMaterials> r{};
      r[0] = step >= 0 ? 1e-3 : 0.0;
      t.removed_mm3.push_back(r);
      t.flags.push_back(0);
    }
  }
  return t;
}

int spans(const std::vector<int>& s) {
  int n = s.empty() ? 0 : 1;
  for (std::size_t i = 1; i < s.size(); ++i) n += s[i] != s[i - 1];
  return n;
}

// A hand that skips step 1: the chain may only go 0 -> 1 -> 2 cheaply, so without the idle
// rule step 1 got one frame (a "step" of 10 ms in the report and the timeline).
TEST(SegmentSteps, ASkippedStepIsNotGivenAFrame) {
  const Exercise ex = three_steps();
  const SessionTrack t = track({{0, 2.0}, {2, 2.0}});
  const auto s = segment_steps(t, ex, nullptr, nullptr);
  EXPECT_EQ(std::count(s.begin(), s.end(), 1), 0);
  EXPECT_EQ(spans(s), 2);
  EXPECT_EQ(s.front(), 0);
  EXPECT_EQ(s.back(), 2);
  // The rule is what removes it: without it the chain passes through step 1.
  SegmentOptions o;
  o.min_pass_span_s = 0;
  const auto raw = segment_steps(t, ex, nullptr, nullptr, o);
  EXPECT_EQ(std::count(raw.begin(), raw.end(), 1), 1);
}

// A short step that cuts is kept, and so is a long idle pause between steps.
TEST(SegmentSteps, ShortCuttingStepsAndLongPausesAreKept) {
  const Exercise ex = three_steps();
  const auto s = segment_steps(track({{0, 2.0}, {1, 0.3}, {2, 2.0}}), ex, nullptr, nullptr);
  EXPECT_EQ(std::count(s.begin(), s.end(), 1), 30);
  EXPECT_EQ(spans(s), 3);
  const auto p = segment_steps(track({{0, 2.0}, {-1, 3.0}, {1, 2.0}, {2, 2.0}}), ex, nullptr, nullptr);
  EXPECT_EQ(spans(p), 3);
  // A whole session without a cut is one span (nothing to merge into).
  const auto idle = segment_steps(track({{-1, 0.2}}), ex, nullptr, nullptr);
  EXPECT_EQ(spans(idle), 1);
}

// The first span can be the short idle one: it joins the span after it.
TEST(SegmentSteps, AShortIdleStartJoinsTheFirstCuttingStep) {
  const Exercise ex = three_steps();
  SessionTrack t = track({{-1, 0.1}, {1, 2.0}, {2, 1.0}});
  const auto s = segment_steps(t, ex, nullptr, nullptr);
  EXPECT_EQ(s.front(), 1);
  EXPECT_EQ(spans(s), 2);
}

}  // namespace
