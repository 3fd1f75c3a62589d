// Per-trial summary features of a kinematics sequence, chosen to carry skill
// and not the person (issue 25): tremor amplitude, force variability across
// work episodes, spread of the tool axis, pauses per work episode, transit
// efficiency (economy of motion), smoothed working path, smoothness (jerk),
// and the second tool's tremor and drift. Each is a ratio or a spread, so a
// person's speed, force level, posture and tool-orientation habit cancel
// (docs/formats.md, "Skill features"). The baselines: task time alone, and
// task time with path length.
//
// Column roles come from the feature names: "[tool.]pos_x_mm" or "tip_x_mm"
// (position, mm), "[tool.]axis_x" (unit axis), "[tool.]force_x_N", "pedal".
#pragma once

#include <string>
#include <vector>

#include "dentar/training/models.h"

namespace dentar::training {

enum class SummarySet { kTime, kTimePath, kSkill };

// Names of the features a set gives for sequences with these column names.
std::vector<std::string> summary_feature_names(SummarySet set, const std::vector<std::string>& columns);
// One row of summary features. Errors name the missing columns.
Result<Eigen::VectorXd> summary_features(SummarySet set, const Sequence& x, const std::vector<std::string>& columns,
                                         double rate_hz);

// Per-trial normalisation for the sequence models (a new person's own
// statistics): positions and axes minus the trial's mean, force divided by
// the trial's mean pressing force, speed by its median. Columns are found by
// name; others are left as they are.
Sequence normalise_trial(const Sequence& x, const std::vector<std::string>& columns);

}  // namespace dentar::training
