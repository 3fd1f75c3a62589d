// dentar replay: mode 1 of issue 27 as a window of its own. A session or lesson replayed
// with its cut recomputed from the raw tool states, seen from any side, with a timeline,
// the force plots and, with --against, the expert beside it aligned by DTW per step.
// The logic is in replay/ (replay/include/dentar/replay/app.h).
#include <iostream>
#include <sstream>

#include "commands.h"
#include "dentar/replay/app.h"

namespace dentar::tools {

void add_replay(CLI::App& app, int& exit_code) {
  auto o = std::make_shared<replay::ReplayOptions>();
  auto size = std::make_shared<std::string>("1280x720");
  auto no_vsync = std::make_shared<bool>(false);
  CLI::App* sub = app.add_subcommand("replay", "Replay a session or lesson in a window: the cut from any side, steps, forces (mode 1)");
  sub->add_option("RECORDING", o->input,
                  "a session log (.dlog), a session folder (session.dlog), a lesson folder, or builtin:EXERCISE")
      ->required();
  sub->add_option("--against", o->against, "a second recording (the expert's, or a lesson) played with it, aligned by DTW per step");
  sub->add_flag("--superimpose", o->superimpose, "with --against: one view, the second recording translucent (default: side by side)");
  sub->add_option("--exercise", o->exercise, "the exercise whose steps to find (default: the lesson's, else by the tooth)");
  sub->add_option("--at", o->at_s, "start at this time, s from the recording's start (default 0)");
  sub->add_option("--speed", o->speed, "playback speed, 0.0625 to 16 (default 1)");
  sub->add_flag("--play", o->play, "start playing (default: paused at --at)");
  sub->add_option("--size", *size, "window size WxH (default 1280x720)");
  sub->add_option("--yaw", o->yaw_deg, "view azimuth about the tooth's long axis, deg (default -35)");
  sub->add_option("--pitch", o->pitch_deg, "view elevation above the occlusal plane, deg (default 45)");
  sub->add_option("--zoom", o->zoom, "closer than the framing of the whole tooth by this factor (default 1)");
  sub->add_option("--enamel", o->enamel_alpha, "enamel opacity 0..1 (default 1; the window has a slider)");
  sub->add_option("--dentin", o->dentin_alpha, "dentin opacity 0..1 (default 1)");
  sub->add_option("--pulp", o->pulp_alpha, "pulp opacity 0..1 (default 1)");
  sub->add_option("--frames", o->frames, "close after N frames (tests, benchmarks; default: until closed)");
  sub->add_option("--screenshot", o->screenshot, "with --frames: save the window's pixels after the last frame (PNG)");
  sub->add_option("--render", o->render, "no window: render the view at --at to this PNG (headless EGL) and exit");
  sub->add_option("--play-scale", o->play_scale,
                  "while playing, render the 3-D view at this fraction of its pixels per axis and scale it up (0.25..1; "
                  "default 0.5; paused: full resolution)");
  sub->add_option("--play-lod", o->play_lod_voxels,
                  "while playing, draw the tooth's mesh clustered in cells of this many voxels (2, 4 or 8; 0 = the full "
                  "mesh; default 2; paused: the full mesh)");
  sub->add_option("--stats", o->stats, "write frame times (median, p99) and the alignment to this JSON");
  sub->add_option("--keys", o->keys, "scripted key presses, one per frame (tests): e.g. --keys n n space")->expected(0, -1);
  sub->add_flag("--no-vsync", *no_vsync, "do not wait for the display's refresh (benchmarks)");
  sub->footer(
      "Mouse: left drag orbits, right drag pans, wheel zooms. Keys: arrows orbit, +/- zoom, W/A/S/D pan, R resets,\n"
      "space plays/pauses, ,/. back/forward 5 s, [/] speed, N/P next/previous step, 1-9 step k, Home/End,\n"
      "Tab side by side/superimposed, Q or Esc quits.\n"
      "Examples:\n"
      "  dentar replay builtin:molar_access_opening\n"
      "  dentar replay run1/session.dlog --against builtin:molar_access_opening --superimpose\n"
      "  dentar replay builtin:molar_access_opening --at 120 --enamel 0.2 --dentin 0.3 --render view.png");
  sub->callback([o, size, no_vsync, &exit_code] {
    int w = 0, h = 0;
    char x = 0;
    std::istringstream in(*size);
    if (!(in >> w >> x >> h) || x != 'x' || !in.eof()) {
      print_error("replay", "--size '" + *size + "': give WxH, e.g. 1280x720");
      exit_code = 2;
      return;
    }
    o->width = w;
    o->height = h;
    o->vsync = !*no_vsync;
    const replay::ReplayOutcome r = replay::run_replay(*o);
    if (r.exit_code != 0) {
      print_error("replay", r.message);
    } else {
      std::cout << r.message << "\n";
    }
    exit_code = r.exit_code;
  });
}

}  // namespace dentar::tools
