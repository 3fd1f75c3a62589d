// Offline replay of a recorded session: rebuilds the engine configuration
// and bur from the log header and runs the recorded device states through
// the engine in simulated time, as fast as the CPU allows. Testers rely on
// it reproducing the cut volume bit-exactly (same content hash).
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "dentar/haptics/engine.h"
#include "dentar/haptics/guidance.h"
#include "dentar/haptics/session_log.h"
#include "dentar/volume/bur.h"

namespace dentar::haptics {

// A training mode recorded in the header (issue 27): the mode's parameters and the expert
// recording it replayed (file, content hash, that recording's station).
struct TrainingSetup {
  TrainingParams params;  // params.expert_file: the recording
  std::uint64_t expert_hash = 0;
  Eigen::Isometry3d expert_T_tooth_dev = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d expert_T_sty_tip = Eigen::Isometry3d::Identity();
};

// Engine settings recovered from a session log header.
struct SessionSetup {
  EngineConfig engine;
  volume::BurParams bur;
  int bur_samples = 0;
  DeviceLimits limits;
  std::string tooth_json;        // the "tooth" object as written (how to rebuild the volume)
  std::uint64_t volume_hash_start = 0;
  std::optional<TrainingSetup> training;  // absent: plain drilling
};
// Errors name the missing or bad field of the header.
Result<SessionSetup> parse_session_header(const std::string& header_json);

// The expert recording a trained session replayed (t.params.expert_file), read and checked
// against the header's content hash: the one check for replay, the lesson clock and the plan.
Result<ExpertTrack> load_trained_expert(const TrainingSetup& t);

struct ReplayResult {
  std::uint64_t steps = 0;
  std::uint64_t volume_hash = 0;
  double max_force_difference_N = 0;  // replayed vs recorded force
  volume::CutMetrics metrics;
  EngineStats stats;
};

// Replays `log` on `volume`, which must be the session's starting volume
// (checked against the header's hash). The volume is cut in place. A session trained in a
// mode replays the mode too: the expert recording named in the header is read (and its
// hash checked), so the expert's cut is recomputed from the student's recorded poses.
Result<ReplayResult> replay_session(const SessionLog& log, volume::VoxelVolume& volume);

}  // namespace dentar::haptics
