// Freshest pair wins (issue 28, session 17): a stereo pair from two cameras is made around a
// left frame, and making it can wait for the right eye's partner. When a newer left frame
// arrived meanwhile, the pair is already stale: processing it would put one more frame
// period into the capture-to-swap time. It is skipped (counted as dropped) and the pair is
// made again around the newer frame.
//
// Peek before take (session 21): the pairing sees that a newer left frame is waiting by its
// capture time alone (CaptureThread::ready_steady_s: nothing taken, nothing decoded), so the
// pairing of a left frame already stale takes no right-eye partner (`stale()` below): a right
// frame is taken only for the pair that is kept. The pairs chosen are the same as before.
//
// `Cam` is any camera with CaptureThread's take and peek: bool wait_take(ar::Frame&, double
// timeout_s) (the newest frame not yet taken; waits up to timeout_s) and double
// ready_steady_s() (the capture time of the frame a take would return now, 0: none; a frame
// still being decoded is not counted, as before: the same pairs). `pair(frame, stale)` makes the
// pair around `frame` (it may wait for the right eye); `stale()` is true while a newer left frame
// waits and the pair would be skipped: the pairing should then take no right frame and return.
// Thread: the consumer's (the frame thread).
#pragma once

#include <utility>

#include "dentar/ar/frame_source.h"

namespace dentar::live {

// Pairs `f`, then while a newer left frame is waiting (at most max_skips times) replaces `f`
// with it and pairs again. Returns the pairs skipped as stale.
template <class Cam, class Pair>
int take_freshest_pair(Cam& left, ar::Frame& f, Pair&& pair, int max_skips = 2) {
  int skipped = 0;
  for (;;) {
    const bool may_skip = skipped < max_skips;
    const auto stale = [&] { return may_skip && left.ready_steady_s() > f.steady_s; };
    pair(f, stale);
    if (!stale()) return skipped;
    ar::Frame newer;
    if (!left.wait_take(newer, 0)) {  // seen but not delivered (on demand: its decode failed)
      pair(f, [] { return false; });
      return skipped;
    }
    f = std::move(newer);
    ++skipped;
  }
}

}  // namespace dentar::live
