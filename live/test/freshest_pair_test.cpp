// Freshest pair wins (issue 28, session 17; freshest_pair.h): a stereo pair that went stale
// while it was made (a newer left frame arrived) is skipped and the pair made again around
// the newer frame; a pair with no newer frame waiting is kept. No timing: a scripted camera
// delivers its "arrivals" when the pairing step says so.
#include <gtest/gtest.h>

#include <cmath>
#include <deque>
#include <vector>

#include "dentar/live/freshest_pair.h"

namespace dentar::live {
namespace {

// A camera with CaptureThread's newest-frame slot: arrive() puts a frame in the slot
// (replacing one not taken, as "latest frame wins" does), wait_take takes it.
struct ScriptedCamera {
  bool full = false;
  ar::Frame slot;
  int replaced = 0;
  void arrive(std::int64_t index, double steady_s) {
    if (full) ++replaced;
    slot = ar::Frame{};
    slot.index = index;
    slot.steady_s = steady_s;
    full = true;
  }
  bool wait_take(ar::Frame& out, double /*timeout_s*/) {
    if (!full) return false;
    out = std::move(slot);
    full = false;
    ++taken;
    return true;
  }
  double ready_steady_s() const { return full ? slot.steady_s : 0; }  // a peek: takes nothing
  int taken = 0;
};

// The pairing step: records which left frames were paired; `during` makes left frames arrive
// while the given pairing (0, 1, ...) waits for its right partner.
struct Pairing {
  ScriptedCamera& left;
  std::deque<std::vector<std::pair<std::int64_t, double>>> during;
  std::vector<std::int64_t> paired;
  template <class Stale>
  void operator()(ar::Frame& f, const Stale& /*stale*/) {
    paired.push_back(f.index);
    if (!during.empty()) {
      for (const auto& [i, t] : during.front()) left.arrive(i, t);
      during.pop_front();
    }
  }
};

TEST(FreshestPair, StalePairIsSkippedWhenANewerPairIsWaiting) {
  ScriptedCamera left;
  left.arrive(7, 1.000);
  ar::Frame f;
  ASSERT_TRUE(left.wait_take(f, 0));
  // Frame 8 arrives while frame 7 waits for its right partner: the pair (7, R) is stale.
  Pairing pair{left, {{{8, 1.033}}, {}}, {}};
  const int skipped = take_freshest_pair(left, f, pair);
  EXPECT_EQ(skipped, 1);
  EXPECT_EQ(f.index, 8) << "the pair processed must be made around the newest left frame";
  EXPECT_DOUBLE_EQ(f.steady_s, 1.033);
  EXPECT_EQ(pair.paired, (std::vector<std::int64_t>{7, 8}));
  EXPECT_FALSE(left.full) << "the newer frame was taken";
}

TEST(FreshestPair, FreshPairIsKept) {
  ScriptedCamera left;
  left.arrive(3, 0.100);
  ar::Frame f;
  ASSERT_TRUE(left.wait_take(f, 0));
  Pairing pair{left, {}, {}};
  EXPECT_EQ(take_freshest_pair(left, f, pair), 0);
  EXPECT_EQ(f.index, 3);
  EXPECT_EQ(pair.paired, (std::vector<std::int64_t>{3}));
}

// A camera delivering faster than pairs can be made: at most max_skips pairs are skipped,
// then the newest pair made is processed (a pair is always processed: no starvation).
TEST(FreshestPair, SkipsAreBounded) {
  ScriptedCamera left;
  left.arrive(0, 0.0);
  ar::Frame f;
  ASSERT_TRUE(left.wait_take(f, 0));
  Pairing pair{left, {{{1, 0.033}}, {{2, 0.066}}, {{3, 0.100}}, {{4, 0.133}}}, {}};
  EXPECT_EQ(take_freshest_pair(left, f, pair, 2), 2);
  EXPECT_EQ(f.index, 2);
  EXPECT_EQ(pair.paired, (std::vector<std::int64_t>{0, 1, 2}));
  EXPECT_TRUE(left.full) << "frame 3 stays in the slot for the next pair";
}


// Session 21, peek before take: a scripted run of both cameras. The right eye's pairing is
// pair_right's: take the newest right frame not older than half a period before the left one
// (an older one is passed over, as wait_take_since does, never taken), then, when it was not the
// partner, wait for the partner and take it. With the peek it takes nothing once `stale()` says
// a newer left frame is already waiting; the old rule (no peek) always takes. Both must choose
// the same pairs; the peek takes a right frame only for the pairs kept.
struct StereoPairing {
  ScriptedCamera& left;
  ScriptedCamera& right;
  bool peek = true;
  int* passed = nullptr;
  // Arrivals (left, right) while the given pairing waits for its partner; one entry a pairing.
  std::deque<std::pair<std::vector<std::pair<std::int64_t, double>>, std::vector<std::pair<std::int64_t, double>>>>
      during;
  ar::Frame held;  // the right frame taken last (pair_right's right_pending_)
  bool held_any = false;
  static constexpr double kHalf = 0.5 / 30;
  void take_since(double oldest) {
    if (!right.full) return;
    if (right.slot.steady_s < oldest) {  // too old to pair: passed over (never decoded on demand)
      right.full = false;
      ++*passed;
      return;
    }
    ar::Frame r;
    if (right.wait_take(r, 0)) held = std::move(r), held_any = true;
  }
  bool partner(const ar::Frame& f) const { return held_any && std::abs(held.steady_s - f.steady_s) <= kHalf; }
  template <class Stale>
  void operator()(ar::Frame& f, const Stale& stale) {
    const double oldest = f.steady_s - kHalf;
    if (!(peek && stale())) take_since(oldest);
    if (!during.empty()) {
      for (const auto& [i, t] : during.front().first) left.arrive(i, t);
      for (const auto& [i, t] : during.front().second) right.arrive(i, t);
      during.pop_front();
    }
    if (!partner(f) && !(peek && stale())) take_since(oldest);  // the partner came while it waited
  }
};

struct PairRun {
  std::vector<std::pair<std::int64_t, std::int64_t>> pairs;  // (left, right) index; right -1: none
  int right_taken = 0, right_passed = 0, left_taken = 0, skipped = 0;
};
// Each step the frame loop takes the newest left frame and makes the freshest pair. At some
// steps the right frame is late: it comes while the pairing waits, together with the next left
// frame (one or two more), so the pair goes stale.
PairRun run_script(bool peek) {
  ScriptedCamera left, right;
  PairRun run;
  const double p = 1.0 / 30;
  std::int64_t k = 0;
  for (int step = 0; step < 12; ++step) {
    const int late = step % 4 == 1 ? 1 : step % 4 == 3 ? 2 : 0;
    left.arrive(k, k * p);
    if (late == 0) right.arrive(k, k * p + 0.002);
    ar::Frame f;
    if (!left.wait_take(f, 0)) continue;
    StereoPairing pairing{left, right, peek, &run.right_passed, {}, {}, false};
    for (int i = 0; i < late; ++i)  // the right frame k + i comes with the left frame k + i + 1
      pairing.during.push_back({{{k + i + 1, (k + i + 1) * p}}, {{k + i, (k + i) * p + 0.002}}});
    if (late > 0) pairing.during.push_back({{}, {{k + late, (k + late) * p + 0.002}}});
    k += late + 1;
    run.skipped += take_freshest_pair(left, f, pairing, 2);
    run.pairs.push_back({f.index, pairing.partner(f) ? pairing.held.index : -1});
  }
  run.left_taken = left.taken;
  run.right_taken = right.taken;
  return run;
}

TEST(FreshestPair, PeekChoosesTheSamePairsAndTakesOnlyTheirRightFrames) {
  const PairRun old_rule = run_script(false), peeked = run_script(true);
  EXPECT_EQ(peeked.pairs, old_rule.pairs) << "the peek changed which pairs are made";
  EXPECT_EQ(peeked.skipped, old_rule.skipped);
  EXPECT_EQ(peeked.left_taken, old_rule.left_taken);
  EXPECT_EQ(old_rule.skipped, 9) << "three steps with one stale pair, three with two";
  for (const auto& [l, r] : peeked.pairs) EXPECT_EQ(l, r) << "each left frame paired with its own right frame";
  // Old rule: a right frame taken for every pairing, kept or skipped; peek: one per pair kept,
  // the stale pairs' partners passed over untaken.
  EXPECT_EQ(old_rule.right_taken, static_cast<int>(old_rule.pairs.size()) + old_rule.skipped);
  EXPECT_EQ(peeked.right_taken, static_cast<int>(peeked.pairs.size()));
  EXPECT_EQ(peeked.right_passed, peeked.skipped);
}

}  // namespace
}  // namespace dentar::live
