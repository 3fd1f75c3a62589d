// The drill-sound options shared by the subcommands that run or replay a session
// (`dentar sound`, `dentar offline --audio`, `dentar demo`): volume, mute, output
// device, an optional user sample, and the helpers that turn them into sound.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "dentar/haptics/engine.h"
#include "dentar/sound/drill_synth.h"
#include "dentar/sound/player.h"
#include "dentar/volume/result.h"

namespace dentar::tools {

struct SoundCli {
  std::string audio;         // WAV to write (renders); "" = none
  std::string device;        // output device by name ("" = default); live playback only
  double volume_pct = 70;    // 0..100
  bool mute = false;
  std::string drill_sample;  // optional user recording of the running drill
  double drill_sample_rpm = 320000;
  // Sound as a teacher: beep above this force. --teach-force-limit N, or "exercise": the
  // session's exercise's excessive_force_N (`exercise`, which the command fills from its
  // --exercise or the recording's). "" or "0" = off.
  std::string teach_force_limit;
  std::string exercise;  // the session's exercise (name or JSON file), "" = none known
};

// Adds --volume, --mute, --drill-sample, --drill-sample-rpm; `live` adds
// --audio-device (the device to play through). Ranges are checked by CLI11
// (exit 2 with a message naming the option and its range).
void add_sound_options(CLI::App* sub, SoundCli& s, bool live);
// The drill's parameters from the options; errors (a user sample that is not
// audio, --teach-force-limit exercise with no exercise) name the option and the file.
Result<sound::DrillParams> drill_params_from(const SoundCli& s);
// Renders `session_log` to `wav` (time-aligned: step n at n / rate_hz) through
// OpenAL's loopback mixer. Returns an exit code (0, 1 job failed, 2 bad input)
// after printing the reason as "dentar <cmd>: ...".
// `max_steps` > 0: only the first max_steps steps (what a run replayed, e.g. `dentar offline`
// stopped by --max-frames), so the file ends with the video.
// The teacher's force limit in newtons (0 = off) and where it came from ("" when off).
Result<std::pair<double, std::string>> teacher_force_limit(const SoundCli& s);
int render_session_wav(const std::string& cmd, const std::string& session_log, const std::string& wav,
                       const SoundCli& s, bool quiet, std::uint64_t max_steps = 0);
// Live playback beside a running engine: opens the device (falling back to the
// default; none at all is a warning and returns null), starts the audio thread.
std::unique_ptr<sound::SoundPlayer> start_live_sound(const std::string& cmd, const SoundCli& s,
                                                     std::function<haptics::HapticSnapshot()> snapshot);

}  // namespace dentar::tools
