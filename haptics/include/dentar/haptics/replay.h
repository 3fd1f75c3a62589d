// Offline replay of a recorded session: rebuilds the engine configuration
// and bur from the log header and runs the recorded device states through
// the engine in simulated time, as fast as the CPU allows. Testers rely on
// it reproducing the cut volume bit-exactly (same content hash).
#pragma once

#include <cstdint>
#include <string>

#include "dentar/haptics/engine.h"
#include "dentar/haptics/session_log.h"
#include "dentar/volume/bur.h"

namespace dentar::haptics {

// Engine settings recovered from a session log header.
struct SessionSetup {
  EngineConfig engine;
  volume::BurParams bur;
  int bur_samples = 0;
  DeviceLimits limits;
  std::string tooth_json;        // the "tooth" object as written (how to rebuild the volume)
  std::uint64_t volume_hash_start = 0;
};
// Errors name the missing or bad field of the header.
Result<SessionSetup> parse_session_header(const std::string& header_json);

struct ReplayResult {
  std::uint64_t steps = 0;
  std::uint64_t volume_hash = 0;
  double max_force_difference_N = 0;  // replayed vs recorded force
  volume::CutMetrics metrics;
  EngineStats stats;
};

// Replays `log` on `volume`, which must be the session's starting volume
// (checked against the header's hash). The volume is cut in place.
Result<ReplayResult> replay_session(const SessionLog& log, volume::VoxelVolume& volume);

}  // namespace dentar::haptics
