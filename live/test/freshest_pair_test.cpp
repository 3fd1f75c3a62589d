// Freshest pair wins (issue 28, session 17; freshest_pair.h): a stereo pair that went stale
// while it was made (a newer left frame arrived) is skipped and the pair made again around
// the newer frame; a pair with no newer frame waiting is kept. No timing: a scripted camera
// delivers its "arrivals" when the pairing step says so.
#include <gtest/gtest.h>

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
    return true;
  }
};

// The pairing step: records which left frames were paired; `during` makes left frames arrive
// while the given pairing (0, 1, ...) waits for its right partner.
struct Pairing {
  ScriptedCamera& left;
  std::deque<std::vector<std::pair<std::int64_t, double>>> during;
  std::vector<std::int64_t> paired;
  void operator()(ar::Frame& f) {
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

}  // namespace
}  // namespace dentar::live
