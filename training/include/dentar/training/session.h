// A recorded session decoded for assessment: the bur tip, its axis and the
// force the student applies to the tooth, all in the tooth frame, plus the
// pedal and the material removed; process metrics; automatic step finding.
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "dentar/haptics/replay.h"
#include "dentar/haptics/session_log.h"
#include "dentar/training/exercise.h"
#include "dentar/training/models.h"

namespace dentar::training {

// One frame per `decimation` haptic steps (block means; pedal/removal summed).
struct SessionTrack {
  std::string source;
  double rate_hz = 0;                  // frames per second
  std::vector<double> t_s;
  std::vector<Eigen::Vector3d> tip_m;  // bur tip, tooth frame
  std::vector<Eigen::Vector3d> axis;   // bur axis (+z of tip), tooth frame
  std::vector<Eigen::Vector3d> force_N;  // force the bur presses on the tooth (= -rendered force), tooth frame
  std::vector<double> pedal;           // fraction of the frame's steps with the pedal down
  std::vector<std::array<double, volume::kMaxMaterials>> removed_mm3;  // removed in the frame, per material
  std::vector<std::uint8_t> flags;     // OR of the steps' flags
  std::size_t size() const { return t_s.size(); }
  double removed_total(std::size_t i) const;
};

// Decodes a session log (its header gives T_tooth_dev, T_sty_tip and the
// tooth's voxel size). decimation >= 1 (10: 100 Hz from 1 kHz).
Result<SessionTrack> decode_session(const haptics::SessionLog& log, const std::string& name, int decimation = 10);

// Features for assessment: tip (mm), axis (unit), force (N), tip speed (mm/s): 10 columns.
const std::vector<std::string>& track_feature_names();
Sequence track_features(const SessionTrack& s);

// Automatic steps: Viterbi over the exercise's steps. Frames that remove
// material cost |tip - focus|^2 / sigma^2 per 10 ms of track (scaled by the
// track's rate); staying costs 0, moving to the next step `next_cost`, to any
// other step `jump_cost`. Returns the step index per frame.
// The switch costs (session 14) make a step change need about a second of
// cutting nearer another focus: at 4 / 40 the steps flickered (707 spans for
// 32 true steps on a generated cohort); at 100 / 10000 the spans match the
// generator's (31 of 32) and frame agreement on held-out cohorts rose from
// 0.60-0.66 to 0.89-0.93 (docs/BENCHMARKS.md, "the steps' flicker").
struct SegmentOptions {
  double sigma_m = 1.0e-3;
  double next_cost = 100.0;
  double jump_cost = 10000.0;
  // A span shorter than this in which no cutting frame lies nearest its own step's focus
  // carries no evidence for the step: the chain passed through a step the hand skipped (a
  // one-frame "step" between two others, since the next step is cheap and a jump is not). It
  // joins the span before it (after it, at the start), so the step reads as not done.
  double min_pass_span_s = 0.5;
};
std::vector<int> segment_steps(const SessionTrack& s, const Exercise& ex, const RegionMasks* masks,
                               const volume::VoxelVolume* start, const SegmentOptions& o = {});
// Focus point of each step (its focus_mm, else its region's centroid in the masks).
std::vector<Eigen::Vector3d> step_focus(const Exercise& ex, const RegionMasks* masks, const volume::VoxelVolume* start);

struct ForceStats {
  double n = 0;  // frames
  Eigen::Vector3d mean = Eigen::Vector3d::Zero(), sd = Eigen::Vector3d::Zero();
  double mean_magnitude = 0, max_magnitude = 0;
};

struct StepMetrics {
  std::string name;
  double start_s = 0, end_s = 0, drilling_s = 0, path_mm = 0, removed_mm3 = 0;
  ForceStats force;  // while drilling and in contact
  Eigen::Vector3d tip_mean_mm = Eigen::Vector3d::Zero(), tip_sd_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis_mean = Eigen::Vector3d::Zero();  // mean bur axis (unit)
  // Drilling frames per sightline class (direct, mirror, both, none; see
  // mirror_use.h), filled where mirror use was measured (ProcessMetrics::mirror_tracked).
  std::array<int, 4> views{};
};

struct ProcessMetrics {
  double duration_s = 0, drilling_s = 0, path_mm = 0, excessive_force_s = 0;
  double excessive_force_N = 0;
  std::array<ForceStats, volume::kMaxMaterials> force_by_material{};  // frames removing that material
  std::vector<StepMetrics> steps;
  bool mirror_tracked = false;  // mirror use measured (score_session: camera frames and station given)
  std::uint64_t watchdog_frames = 0, clamped_frames = 0;
};

ProcessMetrics process_metrics(const SessionTrack& s, const Exercise& ex, const std::vector<int>& steps);

}  // namespace dentar::training
