// `dentar replay SESSION|LESSON` (issue 27, mode 1 as a window of its own).
//
// The window (GLFW, OpenGL ES 3 through EGL, Dear ImGui HUD; set up as `dentar live`'s
// window in its EGL mode, src/window.h): the tooth being cut, recomputed from the recording's raw tool states, with
// the bur, from an orbit camera; on the left the controls (play, pause, speed, the steps to
// jump to, the lesson's annotations, a transparency slider per material); along the bottom
// the timeline (steps, annotations, the play head) and under it the session report's force
// plot (Fx, Fy, Fz in the tooth frame, step bands). With `against`, a second recording (the
// expert's) plays beside or superimposed, its time mapped to the first's by per-step DTW
// (step_align.h).
//
// Layout (px, the window's): the controls occupy x < kPanelWidth, the timeline and plots
// y >= height - kTimelineHeight; the 3D view is rendered at the size of the area left free
// (principal point in its middle) and blitted there 1:1 from the renderer's framebuffer;
// nothing of the HUD covers it. `render` (headless) writes exactly that area's image, which
// the screenshot test compares with the window's. While playing, the view is rendered at
// play_scale with a coarse tooth (play_lod_voxels) and the HUD is copied from a texture drawn
// again only when it changes (the play heads and the clock over it; src/window.h); paused,
// scrubbed still and the --screenshot frame are the full-quality view.
//
// Mouse: left drag orbits, right (or middle) drag pans, the wheel zooms. Keys: arrows orbit,
// + / - zoom, W A S D pan, R resets the view, space plays / pauses, , and . step back and
// forward 5 s, [ and ] halve / double the speed, N / P (or PageDown / PageUp) jump to the
// next / previous step, 1..9 jump to step k, Home / End, Tab switches side by side /
// superimposed, Q or Esc quits.
//
// Thread: the main thread (GLFW). Exit: 0 done, 1 the job failed (GL), 2 bad input.
#pragma once

#include <string>
#include <vector>

#include "dentar/volume/result.h"

namespace dentar::replay {

inline constexpr int kPanelWidth = 300;
inline constexpr int kTimelineHeight = 240;

struct ReplayOptions {
  std::string input;     // session log, session folder, lesson folder, builtin:EXERCISE
  std::string against;   // "" = none
  std::string exercise;  // "" = the lesson's / by the tooth
  bool superimpose = false;  // with `against`: one view, the second recording translucent
  int width = 1280, height = 720;
  double at_s = 0;        // start time (s); < 0 or past the end is refused
  double speed = 1.0;     // playback speed (0.05..16)
  bool play = false;      // start playing
  int frames = 0;         // > 0: close after this many frames (tests, benchmarks)
  std::string screenshot; // PNG of the window after the last frame
  std::string render;     // headless: no window; the offline render at at_s to this PNG
  std::string stats;      // JSON of the frame times and alignment (optional)
  bool vsync = true;
  // The level of detail while playing: the 3-D view renders at this fraction of its pixels
  // per axis and is scaled up into the window (bilinear); paused, and the frame a
  // --screenshot captures, are rendered at full resolution. 1 = always full.
  double play_scale = 0.5;
  // The tooth's level of detail while playing: its mesh clustered in cells of this many
  // voxels (2, 4 or 8; 0 = the full mesh). Paused, and the --screenshot frame: the full mesh.
  int play_lod_voxels = 2;
  // Scripted key presses, one per frame from the second frame on, through the same code as
  // the user's keys (tests): names as in the key list above ("space", "n", "left", "1", ...).
  std::vector<std::string> keys;
  // The view (degrees and mm at this boundary): yaw/pitch of the orbit camera; zoom > 0
  // scales the framing distance (2 = twice as close).
  double yaw_deg = -35, pitch_deg = 45, zoom = 1.0;
  float enamel_alpha = 1.0f, dentin_alpha = 1.0f, pulp_alpha = 1.0f;
  std::string validate() const;  // empty, or names the option and value
};

struct ReplayOutcome {
  int exit_code = 0;  // 0 done, 1 job failed, 2 bad input
  std::string message;  // the error (exit_code != 0), or a summary
};

ReplayOutcome run_replay(const ReplayOptions& opt);

}  // namespace dentar::replay
