// The cut at any time of a recording, recomputed from its raw tool states (mode 1 of
// issue 27): the recorded device states go through the engine again (haptics::ReplayDevice,
// simulated time, the header's engine, bur and training mode), so the volume at time t is
// what the student's bur had removed by then, and at the end it is bit-identical to
// haptics::replay_session's (content hash; tested).
//
// Seeking forward runs the steps in between; seeking backward restarts from the starting
// tooth (the engine's state, e.g. the proxy, cannot be rewound), so its cost is that of a
// replay up to t (BENCHMARKS: a 5-minute session replays in a few seconds).
//
// Thread: the caller's (the window's); the engine runs inline (run_steps), never its thread.
#pragma once

#include <Eigen/Geometry>
#include <memory>
#include <optional>

#include "dentar/haptics/engine.h"
#include "dentar/haptics/guidance.h"
#include "dentar/haptics/replay_device.h"
#include "dentar/replay/recording.h"
#include "dentar/volume/surface.h"

namespace dentar::replay {

class CutPlayer {
 public:
  // Errors: the starting tooth does not match the header's hash, a trained session whose
  // expert recording is missing or changed, an engine the header does not allow.
  static Result<std::unique_ptr<CutPlayer>> create(const Recording& rec);
  ~CutPlayer();

  // Brings the volume (and the surface) to time t (clamped to [0, duration]). Returns the
  // haptic steps run.
  Result<std::uint64_t> seek(double t_s);
  double time_s() const { return time_s_; }
  std::size_t steps_done() const { return done_; }

  const volume::VoxelVolume& volume() const { return *volume_; }
  // The meshes of the current volume (re-extracted for the chunks the last seek changed).
  const volume::Surface& surface() const { return *surface_; }
  // The bur tip at the last step run, tooth frame (T_tooth_dev · T_dev_sty · T_sty_tip, as
  // recorded), and whether the pedal was down / the bur in contact.
  Eigen::Isometry3d T_tooth_tip() const;
  bool pedal() const;
  bool contact() const;
  const volume::BurParams& bur() const { return rec_->setup.bur; }

 private:
  CutPlayer() = default;
  Status restart();
  const Recording* rec_ = nullptr;
  std::unique_ptr<volume::VoxelVolume> volume_;
  std::unique_ptr<volume::Surface> surface_;
  std::unique_ptr<volume::BurSamples> bur_;
  std::optional<haptics::ExpertTrack> expert_;
  std::optional<haptics::TrainingMode> mode_;
  haptics::EngineConfig engine_cfg_;
  std::unique_ptr<haptics::ReplayDevice> device_;
  std::unique_ptr<haptics::Engine> engine_;
  std::size_t done_ = 0;  // records run through the engine
  double time_s_ = 0;
};

}  // namespace dentar::replay
