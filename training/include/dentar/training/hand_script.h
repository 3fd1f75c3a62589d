// The simulated hand's path for an exercise: what `dentar live --stylus sim --exercise X`
// drills. The cohort generator's script (cohort.h) at the expert's skill and no personal
// style, so the live rehearsal works the exercise's own steps on the exercise's own tooth.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "dentar/haptics/scripts.h"
#include "dentar/training/exercise.h"

namespace dentar::training {

// Bur-tip waypoints in the tooth frame (for haptics::to_hand_script), one expert session of
// `ex` on `start` (the exercise's tooth as drilled, any voxel size): the generator's step
// order, approaches and sweeps, seeded (the same seed, the same path). Errors: the exercise's
// regions cannot be built on `start` (build_masks).
Result<std::vector<haptics::TipWaypoint>> expert_tip_script(const Exercise& ex, const volume::VoxelVolume& start,
                                                            std::uint64_t seed = 1);

// A simulated person for `dentar live --stylus sim --exercise X --hand-skill S --hand-style G
// --hand-seed N`: the cohort generator's script at skill S (1 = expert, 0 = the full novice;
// novice_skill(1 - S)), varied per person as the generator varies a subject, with a personal
// style of strength G (draw_style: speed, tremor band, force bias, posture, tool-tilt habit).
// skill 1, style 0 is expert_tip_script(seed) exactly (no subject variation).
struct HandOptions {
  double skill = 1.0;       // [0, 1]
  double style = 0.0;       // [0, 3], as CohortOptions::style
  std::uint64_t seed = 1;
  std::string validate() const;  // "" when valid, else the field and its range
};
Result<std::vector<haptics::TipWaypoint>> hand_tip_script(const Exercise& ex, const volume::VoxelVolume& start,
                                                          const HandOptions& o);

}  // namespace dentar::training
