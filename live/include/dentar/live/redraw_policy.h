// When the live window redraws without a new camera frame (issue 28, session 19).
//
// The display loop wakes at least every 30 ms (DisplayLoop::take_shown) to check for a
// stalled camera, poll input and count a lesson's passes. Sessions 13-18 redrew the whole
// window on every wake: the headset's pre-warp pass (both eyes, 6-7 ms CPU on llvmpipe at
// 2x1280x720) ran again over the frame already shown, on the frame thread's core, and a
// fresh frame arriving meanwhile waited for it. Session 19's profile of 2x1280x720 into the
// Rift DK1 view found ~2 window draws per frame shown under load. A wake without a new frame
// now redraws only when something on screen must change at once: the camera's stall state
// (the raw video within 200 ms of a silence), a key press, or the HUD's figures when it was
// last drawn `idle_period_s` ago or more (10 Hz by default).
//
// Thread: the display loop's (the main thread). Pure: no clock, no GL.
#pragma once

namespace dentar::live {

struct RedrawPolicy {
  double idle_period_s = 0.1;  // the HUD's refresh without new frames, s (> 0)
};

// fresh: a new frame to show; stall_changed: the camera's stall state differs from the one
// last drawn; input: a key was pressed this wake; since_draw_s: time since the last swap, s.
inline bool redraw_due(const RedrawPolicy& p, bool fresh, bool stall_changed, bool input, double since_draw_s) {
  return fresh || stall_changed || input || !(since_draw_s < p.idle_period_s);
}

}  // namespace dentar::live
