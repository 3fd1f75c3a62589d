// dentar sound: the drill's sound for a recorded session (issue 29).
//   dentar sound render SESSION.dlog --out FILE.wav
#include <filesystem>
#include <iostream>

#include "commands.h"
#include "sound_cli.h"

namespace dentar::tools {

void add_sound(CLI::App& app, int& exit_code) {
  CLI::App* s = app.add_subcommand(
      "sound",
      "The drill's sound (synthesised from the haptic engine's state: pedal, bur speed, cutting\n"
      "force, material under the bur; docs/sound.md).\n"
      "Synopsis: dentar sound render SESSION.dlog --out FILE.wav [--volume PCT] [--mute]\n"
      "                             [--drill-sample FILE [--drill-sample-rpm RPM]] [--quiet]");
  s->require_subcommand(1, 1);
  struct RenderCli {
    std::string log, out;
    SoundCli sound;
    bool quiet = false;
  };
  auto c = std::make_shared<RenderCli>();
  CLI::App* r = s->add_subcommand(
      "render",
      "Render a session log's drill sound to a WAV file (48 kHz, 16-bit, mono), time-aligned with\n"
      "the session (haptic step n at n / rate_hz, as dentar offline places it against the video),\n"
      "mixed through OpenAL Soft's loopback device (no sound card needed). Deterministic: the same\n"
      "log always gives the same file.");
  r->add_option("SESSION", c->log, "Session log (.dlog)")->required();
  r->add_option("--out", c->out, "WAV file to write")->required();
  r->add_flag("--quiet", c->quiet, "No summary line");
  add_sound_options(r, c->sound, false);
  r->footer(
      "Example:\n"
      "  dentar demo --out out/demo --simulated\n"
      "  dentar sound render out/demo/session.dlog --out out/demo/drill.wav --volume 80");
  r->callback([c, &exit_code] {
    if (!std::filesystem::exists(c->log)) {
      print_error("sound render", "SESSION " + c->log + ": no such file");
      exit_code = 2;
      return;
    }
    exit_code = render_session_wav("sound render", c->log, c->out, c->sound, c->quiet);
  });
}

}  // namespace dentar::tools
