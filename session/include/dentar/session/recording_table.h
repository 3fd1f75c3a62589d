// The per-frame table of a `dentar live --record` folder (frames.csv, see
// docs/formats.md "Live recording"), as `dentar offline` replays it: each
// frame's capture time, the haptic steps done when it was composited, and
// (discovery "async") what the live tracker's full-frame search did.
#pragma once

#include <cstdint>
#include <istream>
#include <string>
#include <vector>

#include "dentar/ar/tracker.h"
#include "dentar/volume/result.h"

namespace dentar::session {

struct RecordingTable {
  std::vector<double> capture_s;            // per frame index, s, finite, non-decreasing
  std::vector<std::uint64_t> haptic_steps;  // per frame index, non-decreasing
  std::vector<ar::DiscoveryCue> cues;           // discovery "async" only, per frame index
  // Per frame index: the drawn stylus pose's step (fractional, at most haptic_steps; -1 = the
  // newest pose). Empty for recordings without the column (before issue 24's compensation).
  std::vector<double> pose_step;
  // Stereo recordings that keep both eyes (issue 28, recording.json "stereo"): per frame index,
  // the eyes it had (ar::FrameRecord::kEyesBoth, kEyesLeft or kEyesRight: frames.csv `eyes`).
  // Empty for one camera.
  std::vector<int> eyes;
  bool cues_exact = true;  // false: a merge named a frame whose search the table lacks (dropped)
  bool truncated = false;  // the last row was cut short (a crash): the rows before it are kept
};

// Largest haptic step count accepted: 10^10 steps = 116 days at 1 kHz. A
// replay steps the engine up to each frame's count, so a corrupt huge value
// must be refused, not run.
inline constexpr std::uint64_t kMaxRecordedHapticSteps = 10'000'000'000ULL;

// Parses the table from `in`. `async`: recording.json says discovery
// "async" (the disc_start and disc_merged columns are then required).
// `both_eyes`: recording.json says the run was stereo and kept both eyes (the
// column eyes is then required). A table with the column eyes but without
// both_eyes is a stereo run recorded before the right eye was kept (session 15:
// frames/ only): refused, it cannot be replayed as the run tracked it.
// `name` is used in messages. Errors name the line and the column, and what
// is wrong with the value.
Result<RecordingTable> parse_recording_table(std::istream& in, bool async, const std::string& name,
                                             bool both_eyes = false);

}  // namespace dentar::session
