#include "sound_cli.h"

#include <cstdlib>
#include <iostream>

#include "commands.h"
#include "dentar/haptics/session_log.h"
#include "dentar/sound/audio_file.h"
#include "dentar/sound/audio_output.h"
#include "dentar/sound/feed.h"
#include "dentar/training/exercise.h"

namespace dentar::tools {

void add_sound_options(CLI::App* sub, SoundCli& s, bool live) {
  sub->add_option("--volume", s.volume_pct, "Drill sound volume in percent")
      ->check(CLI::Range(0.0, 100.0).description("0 to 100 (percent)"))
      ->capture_default_str();
  sub->add_flag("--mute", s.mute, "No drill sound (renders are silent)");
  sub->add_option("--drill-sample", s.drill_sample,
                  "A recording of the running drill (WAV/FLAC/OGG/AIFF), looped and pitched by the bur's "
                  "speed instead of the synthesised whine (default: synthesised only)");
  sub->add_option("--drill-sample-rpm", s.drill_sample_rpm, "Bur speed the --drill-sample was recorded at")
      ->check(CLI::Range(1000.0, 1000000.0))
      ->capture_default_str();
  sub->add_option("--teach-force-limit", s.teach_force_limit,
                  "Sound as a teacher: a pulsed 880 Hz beep, distinct from the drill, while the force "
                  "exceeds this many newtons, faster the further above (0 = off, the default); "
                  "`exercise`: the session's exercise's excessive_force_N (needs --exercise or a "
                  "recording that names it)")
      ->check(CLI::Validator(
          [](std::string& v) -> std::string {
            if (v == "exercise") return {};
            char* end = nullptr;
            const double n = std::strtod(v.c_str(), &end);
            if (v.empty() || *end != '\0' || !(n >= 0 && n <= 20))
              return "got '" + v + "': give newtons from 0 to 20, or `exercise`";
            return {};
          },
          "N|exercise"));
  if (live)
    sub->add_option("--audio-device", s.device,
                    "Sound output device by name (dentar devices lists them; default: the system's). "
                    "An unknown device falls back to the default; no device at all is a warning");
}

Result<std::pair<double, std::string>> teacher_force_limit(const SoundCli& s) {
  if (s.teach_force_limit != "exercise") {
    const double n = s.teach_force_limit.empty() ? 0.0 : std::strtod(s.teach_force_limit.c_str(), nullptr);
    return std::pair<double, std::string>{n, n > 0 ? "--teach-force-limit" : ""};
  }
  if (s.exercise.empty())
    return Error{"--teach-force-limit exercise: the session has no exercise; give --exercise NAME|FILE, "
                 "or a limit in newtons"};
  auto ex = training::load_named_exercise(s.exercise);
  if (!ex) return Error{"--teach-force-limit exercise: --exercise " + s.exercise + ": " + ex.error()};
  return std::pair<double, std::string>{ex->excessive_force_N, "excessive_force_N of exercise " + s.exercise};
}

Result<sound::DrillParams> drill_params_from(const SoundCli& s) {
  sound::DrillParams p = sound::default_drill_params();
  p.gain = s.mute ? 0.0 : s.volume_pct / 100.0;
  auto limit = teacher_force_limit(s);
  if (!limit) return Error{limit.error()};
  p.teacher_force_limit_N = limit->first;
  if (!s.drill_sample.empty()) {
    auto clip = sound::read_audio(s.drill_sample);
    if (!clip) return Error{"--drill-sample: " + clip.error()};
    p.user_sample = clip->sample_rate_hz == static_cast<int>(p.sample_rate_hz)
                        ? clip->mono
                        : sound::resample_linear(clip->mono, clip->sample_rate_hz, p.sample_rate_hz);
    p.user_sample_rpm = s.drill_sample_rpm;
  }
  if (std::string e = p.validate(); !e.empty()) return Error{"drill sound: " + e};
  return p;
}

int render_session_wav(const std::string& cmd, const std::string& session_log, const std::string& wav,
                       const SoundCli& s, bool quiet, std::uint64_t max_steps) {
  auto params = drill_params_from(s);
  if (!params) {
    print_error(cmd, params.error());
    return 2;
  }
  auto log = haptics::read_session_log(session_log);
  if (!log) {
    print_error(cmd, log.error());
    return 2;
  }
  if (!log->warning.empty()) std::cerr << "dentar " << cmd << ": warning: " << log->warning << "\n";
  if (max_steps > 0)
    std::erase_if(log->records, [max_steps](const haptics::StepRecord& r) { return r.step >= max_steps; });
  auto mono = sound::render_session(*log, *params);
  if (!mono) {
    print_error(cmd, session_log + ": " + mono.error());
    return 2;
  }
  auto mixed = sound::render_through_openal(*mono);
  if (!mixed) {
    print_error(cmd, mixed.error());
    return 1;
  }
  if (Status st = sound::write_wav(wav, *mixed, static_cast<int>(params->sample_rate_hz)); !st) {
    print_error(cmd, st.error());
    return 1;
  }
  if (!quiet)
    std::cout << "wrote " << wav << " (" << static_cast<double>(mixed->size()) / params->sample_rate_hz
              << " s of drill sound at " << static_cast<int>(params->sample_rate_hz) << " Hz, " << log->records.size()
              << " haptic steps" << (s.mute ? ", muted" : "") << ")\n";
  if (!quiet && params->teacher_force_limit_N > 0)
    std::cout << "sound as a teacher: beeps while the force is above " << params->teacher_force_limit_N << " N ("
              << teacher_force_limit(s)->second << ")\n";
  return 0;
}

std::unique_ptr<sound::SoundPlayer> start_live_sound(const std::string& cmd, const SoundCli& s,
                                                     std::function<haptics::HapticSnapshot()> snapshot) {
  if (s.mute) return nullptr;
  auto params = drill_params_from(s);
  if (!params) {
    std::cerr << "dentar " << cmd << ": warning: " << params.error() << "; sound is off\n";
    return nullptr;
  }
  std::string note;
  auto out = sound::AudioOutput::open_device(s.device, {}, note);
  if (!out) {
    std::cerr << "dentar " << cmd << ": warning: " << note << "\n";
    return nullptr;
  }
  std::cout << note << "\n";
  if (params->teacher_force_limit_N > 0)
    std::cout << "sound as a teacher: beeps while the force is above " << params->teacher_force_limit_N << " N ("
              << teacher_force_limit(s)->second << ")\n";
  auto player = std::make_unique<sound::SoundPlayer>(std::move(out), *params, std::move(snapshot));
  player->start();
  return player;
}

}  // namespace dentar::tools
