// Two cameras' mode switches on their way to the window (eye_switches.h, session 22): none
// lost when the window misses frames, a direct change from one eye alone to the other is the
// two switches it is, and a full queue counts what it could not hold.
#include <gtest/gtest.h>

#include <string>

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

// Session 23: each of the two cameras lost and back once, in either order: four switches in the
// order they happened, and one recovery (the right camera's return), whatever the left camera did
// meanwhile. Until session 22 the right camera's return to the right eye alone (the left camera
// still lost) was listed but not counted in stereo.recoveries, and its silence while the left
// camera was lost (neither delivering) was neither listed nor counted.
TEST(EyeSwitches, EachCameraLostAndBackIsFourSwitchesAndOneRecovery) {
  const EyeSwitchTimes t{10.0, 14.0, 11.0, 13.0};  // left: last 10, back 14; right: last 11, back 13
  auto what = [](const EyeSwitchQueue& q) {
    std::string s;
    for (int i = 0; i < q.size(); ++i) {
      const char* k[] = {"left lost", "left back", "right lost", "right back"};
      s += std::string(s.empty() ? "" : ", ") + k[static_cast<int>(q[i].kind)] + "/" + std::to_string(q[i].eyes);
    }
    return s;
  };
  {  // Left lost, right lost, right back, left back: the mode is the right eye alone throughout
     // the right camera's gap (no frame at all in it), seen when its first frame back is drawn.
    EyeSwitchQueue q;
    eye_switches_between(kBoth, kRight, t, q);                // left lost
    eye_switches_between(kRight, kRight, t, q, false);        // right frames alone: nothing
    eye_switches_between(kRight, kRight, t, q, true);         // right lost and back meanwhile
    eye_switches_between(kRight, kBoth, t, q);                // left back
    EXPECT_EQ(what(q), "left lost/2, right lost/0, right back/2, left back/3");
    EXPECT_EQ(q[1].eyes, kEyesNone);
    EXPECT_EQ(q[1].from_s, 11.0);
    EXPECT_EQ(q[2].from_s, 13.0);
    EXPECT_EQ(right_camera_returns(q), 1);
    EXPECT_EQ(right_camera_returns(q, 3), 0);  // counted from a given switch on
  }
  {  // Right lost, left lost, right back, left back: the left eye alone straight to the right eye
     // alone is the right camera's return (counted) and the left camera's loss.
    EyeSwitchQueue q;
    eye_switches_between(kBoth, kLeft, t, q);
    eye_switches_between(kLeft, kRight, t, q);
    eye_switches_between(kRight, kBoth, t, q);
    EXPECT_EQ(what(q), "right lost/1, right back/2, left lost/2, left back/3");
    EXPECT_EQ(right_camera_returns(q), 1);
  }
  {  // The right camera lost and back alone: pairs again, one recovery as before.
    EyeSwitchQueue q;
    eye_switches_between(kBoth, kLeft, t, q);
    eye_switches_between(kLeft, kBoth, t, q);
    EXPECT_EQ(what(q), "right lost/1, right back/3");
    EXPECT_EQ(right_camera_returns(q), 1);
  }
  {  // Only the left camera lost and back: no recovery (the right eye never left).
    EyeSwitchQueue q;
    eye_switches_between(kBoth, kRight, t, q);
    eye_switches_between(kRight, kBoth, t, q);
    EXPECT_EQ(right_camera_returns(q), 0);
  }
  EyeSwitchQueue q;  // right_gap means nothing outside the right eye alone
  EXPECT_EQ(eye_switches_between(kBoth, kBoth, t, q, true), 0);
  EXPECT_EQ(eye_switches_between(kLeft, kLeft, t, q, true), 0);
}

}  // namespace
}  // namespace dentar::live
