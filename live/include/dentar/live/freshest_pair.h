// Freshest pair wins (issue 28, session 17): a stereo pair from two cameras is made around a
// left frame, and making it can wait for the right eye's partner. When a newer left frame
// arrived meanwhile, the pair is already stale: processing it would put one more frame
// period into the capture-to-swap time. It is skipped (counted as dropped) and the pair is
// made again around the newer frame.
//
// `Cam` is any camera with CaptureThread's take: bool wait_take(ar::Frame&, double timeout_s)
// (the newest frame not yet taken; timeout 0: do not wait). `pair(frame)` makes the pair
// around `frame` (it may wait for the right eye). Thread: the consumer's (the frame thread).
#pragma once

#include <utility>

#include "dentar/ar/frame_source.h"

namespace dentar::live {

// Pairs `f`, then while a newer left frame is waiting (at most max_skips times) replaces `f`
// with it and pairs again. Returns the pairs skipped as stale.
template <class Cam, class Pair>
int take_freshest_pair(Cam& left, ar::Frame& f, Pair&& pair, int max_skips = 2) {
  pair(f);
  int skipped = 0;
  ar::Frame newer;
  while (skipped < max_skips && left.wait_take(newer, 0)) {
    f = std::move(newer);
    newer = ar::Frame{};
    ++skipped;
    pair(f);
  }
  return skipped;
}

}  // namespace dentar::live
