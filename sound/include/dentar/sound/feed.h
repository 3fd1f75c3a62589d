// From the haptic side to the drill's sound. Two sources, one DrillInput:
//  - the engine's HapticSnapshot (live: the audio thread polls Engine::snapshot(),
//    a seqlock read, exactly as the display does; nothing runs inside the
//    engine's step);
//  - a session log's StepRecords (offline renders and `dentar sound render`),
//    which the same engine step wrote, so a replay hears what the live run did.
// Time alignment: step n of a log is at n / rate_hz, as `dentar offline` places
// it against the video (ar/offline.h), so sample i of a render is at i / fs.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "dentar/haptics/engine.h"
#include "dentar/haptics/session_log.h"
#include "dentar/sound/drill_synth.h"
#include "dentar/volume/result.h"

namespace dentar::sound {

// One step record as the sound's input (force magnitude, contact flag, pedal,
// this step's removal per material, faults). `pulp_exposed` is carried by the caller.
DrillInput input_from_record(const haptics::StepRecord& r, double rate_hz) noexcept;

// Snapshots to inputs: the snapshot's removal is cumulative (mm³ per material),
// so this keeps the previous totals and hands on the difference. Allocation-free.
class SnapshotFeed {
 public:
  DrillInput next(const haptics::HapticSnapshot& s) noexcept;

 private:
  double last_removed_[kSoundMaterials] = {};
  std::uint64_t last_step_ = ~0ull;
};

// Renders a whole session log, time-aligned (step n at n / rate_hz, with
// rate_hz from the log's header), as mono samples at params.sample_rate_hz.
// The synth takes each step's input at the step's first sample. Deterministic.
// Errors: a header without a valid engine rate, an invalid DrillParams.
Result<std::vector<float>> render_session(const haptics::SessionLog& log, const DrillParams& params,
                                          std::uint64_t seed = 1);

}  // namespace dentar::sound
