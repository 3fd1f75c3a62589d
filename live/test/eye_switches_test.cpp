// Two cameras' mode switches on their way to the window (eye_switches.h, session 22): none
// lost when the window misses frames, a direct change from one eye alone to the other is the
// two switches it is, and a full queue counts what it could not hold.
#include <gtest/gtest.h>

#include "dentar/live/eye_switches.h"

namespace dentar::live {
namespace {

constexpr int kLeft = 1, kRight = 2, kBoth = 3;  // ar::FrameRecord::kEyes*

// The frame thread hands each frame's switches to the shown slot (hand_over: append); the
// window takes the slot now and then (take_shown: append to its own, then empty the slot).
TEST(EyeSwitches, SwitchesOnFramesTheWindowNeverTookAllReachIt) {
  EyeSwitchQueue shown, window;
  EyeSwitchTimes t{1.0, 2.0, 3.0, 4.0};
  EyeSwitchQueue frame1, frame2;
  ASSERT_EQ(eye_switches_between(kBoth, kLeft, t, frame1), 1);  // right camera lost
  shown.append(frame1);                                          // the window does not take it
  ASSERT_EQ(eye_switches_between(kLeft, kBoth, t, frame2), 1);   // right camera back, next frame
  shown.append(frame2);
  window.append(shown);
  shown.clear();
  ASSERT_EQ(window.size(), 2);  // one slot kept only the second (sessions 17-21)
  EXPECT_EQ(window[0].kind, EyeSwitchKind::kRightLost);
  EXPECT_EQ(window[0].eyes, kLeft);
  EXPECT_EQ(window[0].from_s, 3.0);
  EXPECT_EQ(window[1].kind, EyeSwitchKind::kRightBack);
  EXPECT_EQ(window[1].eyes, kBoth);
  EXPECT_EQ(window[1].from_s, 4.0);
  EXPECT_EQ(window.dropped(), 0);
}

TEST(EyeSwitches, LeftOnlyStraightToRightOnlyIsTheRightBackAndTheLeftLost) {
  EyeSwitchQueue q;
  const EyeSwitchTimes t{10.0, 11.0, 12.0, 13.0};
  ASSERT_EQ(eye_switches_between(kLeft, kRight, t, q), 2);
  EXPECT_EQ(q[0].kind, EyeSwitchKind::kRightBack);
  EXPECT_EQ(q[0].from_s, 13.0);
  EXPECT_EQ(q[1].kind, EyeSwitchKind::kLeftLost);
  EXPECT_EQ(q[1].from_s, 10.0);
  for (int i = 0; i < 2; ++i) EXPECT_EQ(q[i].eyes, kRight);
  q.clear();
  ASSERT_EQ(eye_switches_between(kRight, kLeft, t, q), 2);  // and the other way round
  EXPECT_EQ(q[0].kind, EyeSwitchKind::kLeftBack);
  EXPECT_EQ(q[0].from_s, 11.0);
  EXPECT_EQ(q[1].kind, EyeSwitchKind::kRightLost);
  EXPECT_EQ(q[1].from_s, 12.0);
  q.clear();
  EXPECT_EQ(eye_switches_between(kBoth, kBoth, t, q), 0);
  ASSERT_EQ(eye_switches_between(kBoth, kRight, t, q), 1);
  EXPECT_EQ(q[0].kind, EyeSwitchKind::kLeftLost);
  ASSERT_EQ(eye_switches_between(kRight, kBoth, t, q), 1);
  EXPECT_EQ(q[1].kind, EyeSwitchKind::kLeftBack);
  EXPECT_EQ(eye_switch_what(EyeSwitchKind::kRightBack, "live:l.avi", "live:r.avi"), "right camera back (live:r.avi)");
  EXPECT_EQ(eye_switch_what(EyeSwitchKind::kLeftLost, "live:l.avi", "live:r.avi"), "left camera lost (live:l.avi)");
}

TEST(EyeSwitches, AFullQueueCountsWhatItCannotHold) {
  EyeSwitchQueue q;
  for (int i = 0; i < EyeSwitchQueue::kMaxSwitches; ++i)
    EXPECT_TRUE(q.push({EyeSwitchKind::kLeftLost, kRight, double(i)}));
  EXPECT_FALSE(q.push({EyeSwitchKind::kLeftBack, kBoth, 99.0}));
  EXPECT_EQ(q.size(), EyeSwitchQueue::kMaxSwitches);
  EXPECT_EQ(q.dropped(), 1);
  EXPECT_EQ(q[EyeSwitchQueue::kMaxSwitches - 1].from_s, EyeSwitchQueue::kMaxSwitches - 1.0);  // the first kept
  EyeSwitchQueue w;  // the count travels with the switches
  w.push({EyeSwitchKind::kRightLost, kLeft, 0.5});
  w.append(q);
  EXPECT_EQ(w.size(), EyeSwitchQueue::kMaxSwitches);
  EXPECT_EQ(w.dropped(), 2);
  w.clear();
  EXPECT_TRUE(w.empty());
  EXPECT_EQ(w.dropped(), 2);  // a running total until read
  w.reset_dropped();
  EXPECT_EQ(w.dropped(), 0);
}

}  // namespace
}  // namespace dentar::live
