// dentar sound: the drill's sound for a recorded session (issue 29).
//   dentar sound render SESSION.dlog --out FILE.wav
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <vector>

#include "dentar/sound/analysis.h"
#include "dentar/sound/audio_file.h"
#include "dentar/sound/audio_output.h"

#include "commands.h"
#include "sound_cli.h"

namespace dentar::tools {
namespace {

// A scripted haptic stream: each segment holds for `seconds`, one input per 1 ms step.
struct Segment {
  double seconds;
  bool pedal, contact;
  double force_N;
  int removing;  // material label, -1 none
};

std::vector<float> render_script(const std::vector<Segment>& script, const sound::DrillParams& p) {
  sound::DrillSynth synth(p);
  const auto per_step = static_cast<std::size_t>(p.sample_rate_hz / 1000.0);
  std::vector<float> out;
  double t = 0;
  for (const auto& seg : script)
    for (long i = 0; i < std::lround(seg.seconds * 1000); ++i, t += 1e-3) {
      sound::DrillInput in;
      in.time_s = t;
      in.pedal = seg.pedal;
      in.contact = seg.contact;
      in.force_N = seg.force_N;
      if (seg.removing >= 0) in.removed[seg.removing] = 1.0;
      synth.set_input(in);
      out.resize(out.size() + per_step);
      synth.render(out.data() + out.size() - per_step, per_step);
    }
  return out;
}

int run_materials(const std::string& dir, double force_N, const SoundCli& sc) {
  auto params = drill_params_from(sc);
  if (!params) {
    print_error("sound materials", params.error());
    return 2;
  }
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    print_error("sound materials", "cannot create output folder '" + dir + "': " + ec.message());
    return 1;
  }
  struct Clip {
    std::string name;
    std::vector<Segment> script;
  };
  std::vector<Clip> clips;
  for (int m : {1, 2, 3})
    clips.push_back({params->materials[static_cast<std::size_t>(m)].name,
                     {{0.2, true, false, 0, -1}, {0.6, true, true, force_N, m}}});
  clips.push_back({"breakthrough", {{0.2, true, false, 0, -1}, {0.4, true, true, force_N, 2},
                                    {0.2, true, true, 0.3, 3}, {0.3, true, false, 0, -1}}});
  clips.push_back({"probe", {{0.1, false, false, 0, -1}, {0.1, false, true, 0.5, -1}, {0.2, false, false, 0, -1},
                             {0.1, false, true, 0.5, -1}, {0.2, false, false, 0, -1}}});
  std::cout << "clip          fundamental (Hz)  centroid 0.5-20 kHz (Hz)  level (dBFS, last 0.4 s)\n";
  for (const auto& c : clips) {
    auto mixed = sound::render_through_openal(render_script(c.script, *params));
    if (!mixed) {
      print_error("sound materials", mixed.error());
      return 1;
    }
    const std::string wav = (std::filesystem::path(dir) / (c.name + ".wav")).string();
    const std::string png = (std::filesystem::path(dir) / (c.name + ".png")).string();
    if (Status st = sound::write_wav(wav, *mixed, static_cast<int>(params->sample_rate_hz)); !st) {
      print_error("sound materials", st.error());
      return 1;
    }
    if (Status st = sound::write_spectrogram_png(png, *mixed, params->sample_rate_hz); !st) {
      print_error("sound materials", st.error());
      return 1;
    }
    const std::size_t n = static_cast<std::size_t>(0.4 * params->sample_rate_hz);
    const float* tail = mixed->data() + mixed->size() - n;
    const auto sp = sound::magnitude_spectrum(tail, n, params->sample_rate_hz);
    std::cout << std::left << std::setw(14) << c.name << std::right << std::fixed << std::setprecision(0)
              << std::setw(16) << sound::fundamental_hz(sp, 1500, 7000) << std::setw(26)
              << sound::centroid_hz(sp, 500, 20000) << std::setprecision(1) << std::setw(26)
              << sound::to_db(sound::rms(tail, n)) << "\n";
  }
  std::cout << "wrote " << clips.size() << " WAV files and spectrograms (PNG) into " << dir << "\n";
  return 0;
}

}  // namespace

void add_sound(CLI::App& app, int& exit_code) {
  CLI::App* s = app.add_subcommand(
      "sound",
      "The drill's sound (synthesised from the haptic engine's state: pedal, bur speed, cutting\n"
      "force, material under the bur; docs/sound.md).\n"
      "Synopsis: dentar sound render SESSION.dlog --out FILE.wav [--volume PCT] [--mute]\n"
      "                             [--drill-sample FILE [--drill-sample-rpm RPM]] [--quiet]\n"
      "                             [--teach-force-limit N|exercise [--exercise NAME|FILE]]\n"
      "          dentar sound materials --out DIR [--force N] [--volume PCT]");
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
  r->add_option("--exercise", c->sound.exercise,
                "The session's exercise (built-in name or JSON file), for --teach-force-limit exercise");
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

  struct MaterialsCli {
    std::string out;
    double force_N = 1.5;
    SoundCli sound;
  };
  auto m = std::make_shared<MaterialsCli>();
  CLI::App* mat = s->add_subcommand(
      "materials",
      "Listen to the model: a short WAV and its spectrogram (PNG) for enamel, dentin and pulp\n"
      "(spin-up, then cutting at --force), the break-through from dentin into the pulp, and two\n"
      "probe ticks; prints each clip's fundamental, spectral centroid and level (last 0.4 s).");
  mat->add_option("--out", m->out, "Output folder")->required();
  mat->add_option("--force", m->force_N, "Cutting force (N)")->check(CLI::Range(0.0, 10.0))->capture_default_str();
  add_sound_options(mat, m->sound, false);
  mat->footer("Example:\n  dentar sound materials --out docs/sound");
  mat->callback([m, &exit_code] { exit_code = run_materials(m->out, m->force_N, m->sound); });
}

}  // namespace dentar::tools
