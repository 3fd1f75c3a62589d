// Cohorts for development and tests: expert and novice sessions from the
// simulated hand, run through the haptic engine in simulated time. Each
// skill factor is documented in docs/formats.md ("Cohort generator"); the
// novice factors move from the expert's values toward the full novice values
// as `separation` goes from 0 (identical classes) to 1.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "dentar/training/exercise.h"

namespace dentar::training {

// Bumped whenever the generated sessions change (cached expert references
// are keyed by it). 6 (session 18): the molar's adult pulp (MolarParams::pulp_roof_mm) and the
// access opening's chamber coordinates moved with it; the generator's code is v5's.
inline constexpr int kCohortGeneratorVersion = 6;

struct SkillParams {
  double tremor_mm = 0.02;     // amplitude of a 9-11 Hz tremor on the hand's target, x and y
  double force_factor = 1.0;   // pressing force relative to the expert's 1.0 N
  double force_jitter = 0.05;  // relative SD of the pressing force from step to step
  double detour_mm = 0.0;      // SD of a random waypoint between steps (path efficiency)
  double pause_prob = 0.05;    // probability of a pause before a step (pedal up, hand still)
  double pause_s = 0.3;        // length of a pause
  double swap_prob = 0.0;      // probability that two neighbouring steps are done in swapped order
  double tilt_deg = 2.0;       // SD of the bur's tilt from the planned axis, per step
  // How the step's part of the target is prepared (layer by layer along the
  // approach, raster rows within the outline, the outline followed):
  double sweep_mm_s = 3.0;     // speed of the bur along the sweep
  double outline_mm = 0.05;    // SD of the outline's error per step (> 0: over-extended)
  double depth_mm = 0.05;      // SD of the floor's error per step (> 0: too deep)
  double skip_prob = 0.0;      // probability that a raster row of a layer is left out
  double stop_prob = 0.0;      // probability that a step's preparation stops early (after 30-80 % of its layers)
};
SkillParams expert_skill();
// Novice skill at a separation in [0, 1] (0 = the expert's values).
SkillParams novice_skill(double separation);

// A person's style: habits that do not change with skill, drawn once per
// simulated person (docs/formats.md, "Personal style"). At strength 1 each
// habit varies between people by more than the expert-novice gap in the
// factor it touches.
struct StyleParams {
  double time_scale = 1.0;      // every move and sweep takes this much longer (speed habit)
  double tremor_hz = 0.0;       // centre of the person's tremor band (0: 9-11 Hz drawn per trial, no style)
  double tremor_gain = 1.0;     // tremor amplitude factor (skill sets the rest)
  double tremor_h2 = 0.0;       // relative weight of the tremor's second harmonic (spectrum shape)
  double force_bias = 1.0;      // pressing force factor
  double pause_gain = 1.0;      // length of the person's pauses (how often: skill)
  Eigen::Vector3d rest_offset_mm = Eigen::Vector3d::Zero();  // posture: where the hand waits between steps
  Eigen::Vector3d tilt_axis = Eigen::Vector3d::UnitX();       // tool-orientation habit: a constant rotation
  double tilt_bias_deg = 0.0;                                 // of the bur axis about tilt_axis
  Eigen::Vector3d mirror_rest_mm = Eigen::Vector3d::Zero();   // posture of the second tool (the mirror hand)
};
// Draws one person's style at `strength` (0: none, the identity).
StyleParams draw_style(double strength, std::uint64_t seed);

struct CohortTrial;

struct CohortOptions {
  int experts = 5, novices = 5, trials = 3;
  int intermediates = 0;  // a third class, "intermediate": novice factors at half the separation
  double separation = 1.0;
  double style = 0.0;     // personal style strength (0: none, the generator before issue 25; 1: documented)
  // true: no engine; write each trial's hand kinematics (bur and mirror,
  // 100 Hz) as kinematics.csv, with columns.json, for `dentar assess
  // --kinematics` (seconds per cohort instead of minutes).
  bool kinematics_only = false;
  std::uint64_t seed = 1;
  double voxel_mm = 0.15;  // coarser than the exercise's tooth, for speed
  int bur_samples = 1000;
  // The cutter's CutParams::sample_jitter for the generated sessions (off: the cohorts so far).
  bool sample_jitter = false;
  // Session 22: cut by overlap volume with the shape-constrained proxy (haptics::use_overlap_cut),
  // so the generated sessions cut the same whatever bur_samples is.
  bool overlap_cut = false;
  // Called after each engine session (not with kinematics_only) with the tooth as the engine
  // left it: the cut a replay of the session's log gives (the same voxels, shown on the score
  // rank bench's seeds), so a caller that scores sessions need not replay them. Runs on the
  // calling thread; an empty function is not called.
  std::function<void(const CohortTrial&, const volume::VoxelVolume&)> on_session;
  std::string validate() const;
};

struct CohortTrial {
  std::string subject, label;  // label "expert" | "intermediate" | "novice"
  int trial = 0;
  std::string session_path;    // session.dlog (kinematics.csv with kinematics_only)
  // Generator's step labels: step k runs over [step_start_s[k], step_end_s[k]).
  std::vector<int> step_order;
  std::vector<double> step_start_s, step_end_s;
  int true_step_at(double t) const;  // -1 outside every step
};

// Writes out_dir/<subject>_t<trial>/session.dlog and steps.json, and
// out_dir/trials.csv (file,subject,trial,label). The exercise gives the
// steps (focus points) and the bur; the tooth is rebuilt at opt.voxel_mm.
Result<std::vector<CohortTrial>> generate_cohort(const Exercise& ex, const CohortOptions& opt,
                                                 const std::string& out_dir);
// The column map of a kinematics_only cohort's tables (docs/formats.md).
std::string kinematics_column_map_json();

// Reads trials.csv (and steps.json where present) of a cohort folder.
Result<std::vector<CohortTrial>> read_cohort(const std::string& dir);

}  // namespace dentar::training
