// The simulated hand's path for an exercise: what `dentar live --stylus sim --exercise X`
// drills. The cohort generator's script (cohort.h) at the expert's skill and no personal
// style, so the live rehearsal works the exercise's own steps on the exercise's own tooth.
#pragma once

#include <cstdint>
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

}  // namespace dentar::training
