// The live window's redraw without a new frame (redraw_policy.h, issue 28 session 19).
#include "dentar/live/redraw_policy.h"

#include <gtest/gtest.h>

#include <limits>

using dentar::live::redraw_due;
using dentar::live::RedrawPolicy;

TEST(RedrawPolicy, NewFramesAlwaysDrawn) {
  const RedrawPolicy p;
  for (const double since : {0.0, 0.001, 0.05, 1.0}) EXPECT_TRUE(redraw_due(p, true, false, false, since)) << since;
}

// The 30 ms wakes of the loop between frames: no redraw until the HUD's idle period.
TEST(RedrawPolicy, IdleWakesSkippedUntilTheHudsPeriod) {
  const RedrawPolicy p;  // 0.1 s
  EXPECT_FALSE(redraw_due(p, false, false, false, 0.0));
  EXPECT_FALSE(redraw_due(p, false, false, false, 0.03));
  EXPECT_FALSE(redraw_due(p, false, false, false, 0.099));
  EXPECT_TRUE(redraw_due(p, false, false, false, 0.1));
  EXPECT_TRUE(redraw_due(p, false, false, false, 5.0));
  // Never drawn (the first wake): a clock far in the past, or not a number, draws.
  EXPECT_TRUE(redraw_due(p, false, false, false, 1e9));
  EXPECT_TRUE(redraw_due(p, false, false, false, std::numeric_limits<double>::quiet_NaN()));
  RedrawPolicy fast;
  fast.idle_period_s = 0.03;
  EXPECT_TRUE(redraw_due(fast, false, false, false, 0.031));
}

// A camera going quiet (the raw video within 200 ms) or coming back, and a key press, are
// drawn at the next wake whatever the HUD's period.
TEST(RedrawPolicy, StallChangeAndKeysDrawnAtOnce) {
  const RedrawPolicy p;
  EXPECT_TRUE(redraw_due(p, false, true, false, 0.0));
  EXPECT_TRUE(redraw_due(p, false, false, true, 0.0));
  EXPECT_TRUE(redraw_due(p, false, true, true, 0.01));
}
