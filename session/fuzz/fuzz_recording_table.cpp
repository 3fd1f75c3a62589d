// Fuzz target: parse_recording_table, the frames.csv of a `dentar live
// --record` folder as `dentar offline` replays it (dentar/session/recording_table.h).
//
// The first input byte chooses discovery inline/async (bit 0) and a stereo
// recording that kept both eyes (bit 1: one eyes value 1..3 per frame); the rest is the file.
// Every accepted table must be one a replay can run: as many times and step
// counts as frames, finite non-decreasing times, non-decreasing step counts
// within kMaxRecordedHapticSteps, and (async) one cue per frame whose merge
// names an earlier frame that started a search. Every refusal names the file.
#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>

#include "dentar/session/recording_table.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dentar;
  if (size < 1 || size > 1 << 16) return 0;
  const bool async = (data[0] & 1) != 0, both_eyes = (data[0] & 2) != 0;
  std::istringstream in(std::string(reinterpret_cast<const char*>(data + 1), size - 1));
  const auto r = session::parse_recording_table(in, async, "frames.csv", both_eyes);
  if (!r) {
    if (r.error().rfind("frames.csv: ", 0) != 0) __builtin_trap();
    return 0;
  }
  const session::RecordingTable& t = *r;
  const std::size_t n = t.capture_s.size();
  if (n == 0 || t.haptic_steps.size() != n) __builtin_trap();
  if (async ? t.cues.size() != n : !t.cues.empty()) __builtin_trap();
  if (both_eyes ? t.eyes.size() != n : !t.eyes.empty()) __builtin_trap();
  for (int e : t.eyes)
    if (e < 1 || e > 3) __builtin_trap();
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(t.capture_s[i]) || t.haptic_steps[i] > session::kMaxRecordedHapticSteps) __builtin_trap();
    if (i > 0 && (t.capture_s[i] < t.capture_s[i - 1] || t.haptic_steps[i] < t.haptic_steps[i - 1])) __builtin_trap();
    if (async) {
      const auto m = t.cues[i].merge;
      if (m < -1 || m >= static_cast<std::int64_t>(i)) __builtin_trap();
      if (m >= 0 && !t.cues[static_cast<std::size_t>(m)].start) __builtin_trap();
    }
  }
  return 0;
}
