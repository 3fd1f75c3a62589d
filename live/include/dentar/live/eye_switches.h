// Two cameras (issue 28): a camera lost or back changes which eyes a frame has; each such
// switch goes from the frame thread to the window, which times it to the swap of the first
// frame it draws after it (live_run.h Shown::switches, the summary's stereo.switches).
//
// Session 22: switches travel in a small bounded queue, not one slot. With one slot a switch
// on a frame the window never took was overwritten by the next frame's switch (a busy machine:
// "right camera back" then "left camera lost" on the next frame), so it vanished from the
// summary. The queue holds kMaxSwitches; one more is not stored but counted (dropped(): the
// summary's stereo.switches_dropped), never lost silently. A switch needs a camera silent for
// 0.1 s, so a window taking frames at all never sees more than a few between two takes.
// Fixed storage: pushing and copying never allocate (the frame thread's path per frame).
//
// A direct change from one eye alone to the other (left only -> right only: the right camera
// came back while the left was lost) is two switches, each named: "right camera back" and
// "left camera lost" (eye_switches_between).
#pragma once

#include <array>
#include <cstdint>
#include <string>

namespace dentar::live {

enum class EyeSwitchKind : std::uint8_t { kLeftLost, kLeftBack, kRightLost, kRightBack };

struct EyeSwitchEvent {
  EyeSwitchKind kind = EyeSwitchKind::kLeftLost;
  int eyes = -1;       // the eyes of the mode switched to (ar::FrameRecord::kEyes*)
  double from_s = 0;   // the capture time it is timed from: the lost camera's last frame, or the
                       // returning camera's first frame back (steady s)
};

// "left camera lost (SPEC)" ... (the summary's `what`, the messages' start).
inline std::string eye_switch_what(EyeSwitchKind k, const std::string& left_spec, const std::string& right_spec) {
  switch (k) {
    case EyeSwitchKind::kLeftLost: return "left camera lost (" + left_spec + ")";
    case EyeSwitchKind::kLeftBack: return "left camera back (" + left_spec + ")";
    case EyeSwitchKind::kRightLost: return "right camera lost (" + right_spec + ")";
    case EyeSwitchKind::kRightBack: return "right camera back (" + right_spec + ")";
  }
  return "?";
}

class EyeSwitchQueue {
 public:
  static constexpr int kMaxSwitches = 8;
  // false: full, not stored, counted in dropped().
  bool push(const EyeSwitchEvent& e) {
    if (n_ >= kMaxSwitches) {
      ++dropped_;
      return false;
    }
    ev_[static_cast<std::size_t>(n_++)] = e;
    return true;
  }
  // Appends `other`'s switches (in order) and its dropped count; `other` is left as it was.
  void append(const EyeSwitchQueue& other) {
    for (int i = 0; i < other.n_; ++i) push(other.ev_[static_cast<std::size_t>(i)]);
    dropped_ += other.dropped_;
  }
  // Empties the queue (the dropped count stays: a running total).
  void clear() { n_ = 0; }
  int size() const { return n_; }
  bool empty() const { return n_ == 0; }
  const EyeSwitchEvent& operator[](int i) const { return ev_[static_cast<std::size_t>(i)]; }
  std::int64_t dropped() const { return dropped_; }
  void reset_dropped() { dropped_ = 0; }

 private:
  std::array<EyeSwitchEvent, kMaxSwitches> ev_{};
  int n_ = 0;
  std::int64_t dropped_ = 0;
};

// The switches from mode `from` to mode `to` (ar::FrameRecord::kEyesLeft 1, kEyesRight 2,
// kEyesBoth 3: the cameras delivering), each camera's change one switch, returns before losses
// (a camera back is seen before the other one is found silent); the capture times they are
// timed from are given per camera. Returns how many were pushed.
struct EyeSwitchTimes {
  double left_last_s = 0, left_back_s = 0;    // the left camera's last frame before its loss; its first back
  double right_last_s = 0, right_back_s = 0;  // the same for the right camera
};
// Session 23: `right_gap`, with the mode the right eye alone before and after (from == to ==
// kEyesRight): the right camera went silent and came back while the left one was lost (no camera
// delivered between). That is two switches too: the right camera lost (eyes kEyesNone: neither
// camera delivers) and back (eyes right alone), timed from t.right_last_s and t.right_back_s.
constexpr int kEyesNone = 0;
inline int eye_switches_between(int from, int to, const EyeSwitchTimes& t, EyeSwitchQueue& out,
                                bool right_gap = false) {
  constexpr int kLeft = 1, kRight = 2;  // ar::FrameRecord::kEyesLeft / kEyesRight
  if (from == kRight && to == kRight && right_gap) {
    int n = out.push({EyeSwitchKind::kRightLost, kEyesNone, t.right_last_s});
    n += out.push({EyeSwitchKind::kRightBack, kRight, t.right_back_s});
    return n;
  }
  if (from == to) return 0;
  const bool left_was_lost = from == kRight, left_lost = to == kRight;
  const bool right_was_lost = from == kLeft, right_lost = to == kLeft;
  int n = 0;
  if (right_was_lost && !right_lost) n += out.push({EyeSwitchKind::kRightBack, to, t.right_back_s});
  if (left_was_lost && !left_lost) n += out.push({EyeSwitchKind::kLeftBack, to, t.left_back_s});
  if (!right_was_lost && right_lost) n += out.push({EyeSwitchKind::kRightLost, to, t.right_last_s});
  if (!left_was_lost && left_lost) n += out.push({EyeSwitchKind::kLeftLost, to, t.left_last_s});
  return n;
}

// The summary's stereo.recoveries (session 23): the right camera's returns, each "right camera
// back" switch among q[first..]: pairs again (eyes both), or the right eye alone while the left
// camera is lost (eyes right; until session 22 these were listed as switches but not counted).
inline int right_camera_returns(const EyeSwitchQueue& q, int first = 0) {
  int n = 0;
  for (int i = first; i < q.size(); ++i) n += q[i].kind == EyeSwitchKind::kRightBack ? 1 : 0;
  return n;
}

}  // namespace dentar::live
