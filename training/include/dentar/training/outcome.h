// Outcome scores from the cut volume against the exercise's regions.
// Formulas: docs/formats.md ("Outcome scores").
#pragma once

#include <array>
#include <string>
#include <vector>

#include "dentar/training/exercise.h"

namespace dentar::training {

struct RegionScore {
  std::string name;
  double volume_mm3 = 0;     // density-weighted volume of the region in the starting tooth
  double removed_mm3 = 0;    // removed inside it
  double coverage_pct = 0;   // 100 * removed / volume
  double overprep_mm3 = 0;   // removed in its zone (region grown by zone_mm) outside every target
  // With the exercise's floor_depth on this region (session 21), overprep_mm3 split at the region's
  // floor level: below it, and above it (past the walls). 0 otherwise.
  double below_floor_mm3 = 0, past_walls_mm3 = 0;
  double points = 0, max_points = 0;
  std::string why;  // one sentence: how the points were reached (report)
};

// One of the six access-opening criteria (0..3: an integer band, or any value
// between with the exercise's "access_points": "continuous"), or a graded
// exercise's wall taper (0..its points).
struct Criterion {
  std::string name;
  double score = 0;
  double value = 0;   // the measured quantity (see `unit`)
  std::string unit;
  std::string detail;  // how the score was reached, for the report
  double max_score = 3;
};

// A cost the exercise charges (pulp exposure, perforation): subtracted
// from the criteria's or regions' sum; the total never goes below 0.
struct Penalty {
  std::string name;
  double points = 0;  // > 0: subtracted
  std::string why;
};

struct OutcomeScores {
  std::array<double, volume::kMaxMaterials> removed_mm3{};  // per material of the starting voxel
  double removed_total_mm3 = 0;
  double target_mm3 = 0, target_removed_mm3 = 0, target_coverage_pct = 0;
  double overprep_mm3 = 0;   // removed outside every target region
  // Of overprep_mm3: tooth (not pulp) removed beyond every target's zone_mm
  // (access opening: above floor_z); charged when the exercise sets
  // over_reduction_rate (penalty "over-reduction").
  double beyond_zone_mm3 = 0;
  // Of overprep_mm3: removed within the exercise's tolerance_mm of a target
  // (not charged).
  double tolerated_mm3 = 0;
  // Of overprep_mm3, access opening: tooth (not pulp) removed outside the
  // target but within a target's zone_mm, above floor_z (the walls flared
  // wider than the outline); charged with the exercise's access_zone_rate.
  double access_zone_mm3 = 0;
  // access_zone_mm3 by its distance outside the access outline (the smallest growth of the
  // access target, in 0.05 mm steps, that reaches the voxel): [q] holds what lies within
  // (0.05 q, 0.05 (q + 1)] mm (issue 25, session 21).
  std::vector<double> access_zone_by_band_mm3;
  // Of access_zone_mm3: what the exercise charges (beyond its access_zone_free_mm; 0 when not charged).
  double access_zone_charged_mm3 = 0;
  // Access opening: each axial wall's over-extension past the access outline (mesial, distal,
  // buccal, palatal: a quarter of 32 directions around the axis each), over the measured levels of
  // its directions: the mean of max(0, the cavity's extent from the axis - the outline's) and its
  // largest value, mm (issue 25, session 21).
  std::array<double, 4> wall_overextension_mean_mm{}, wall_overextension_max_mm{};
  std::array<int, 4> wall_overextension_levels{};  // direction-levels measured per wall
  // Session 22: each wall's over-extension as the exercise's wall_overextension_percentile of its
  // direction-levels' values (mm; the mean and max above are the same values' mean and largest), and
  // the length along the outline over which the wall lies more than wall_overextension_free_mm past
  // it (mm: each direction's arc at the outline, 2 pi / 32 x the outline's distance from the axis,
  // times the share of its levels beyond the free margin; the over-extended area over the height).
  std::array<double, 4> wall_overextension_mm{}, wall_overextension_length_mm{};
  // Every direction-level measured (wall 0..3 M D B P, direction 0..31, level z m, over-extension mm,
  // the outline's distance from the axis mm): for benchmarks and tests.
  struct WallSample {
    int wall = 0, dir = 0;
    double z_m = 0, e_mm = 0, outline_mm = 0;
  };
  std::vector<WallSample> wall_overextension_samples;
  // Session 23: of access_zone_mm3, by wall (M D B P: the voxel's quarter around the access axis, as
  // the walls' directions) and by band as access_zone_by_band_mm3; and each wall's area lying more than
  // access_zone_free_mm past the outline (mm2: each direction-level beyond it counts its arc at the
  // outline, 2 pi / 32 x the outline's distance from the axis, times the voxel's height).
  std::array<std::vector<double>, 4> access_zone_by_wall_band_mm3;
  std::array<double, 4> access_zone_charged_by_wall_mm3{}, wall_overextended_area_mm2{};
  // Access opening: tooth (not pulp) removed below the pulpal floor level (the floor criterion's
  // value), and whether the floor is perforated.
  double floor_below_mm3 = 0;
  bool floor_perforated = false;
  double forbidden_mm3 = 0;  // removed inside forbidden regions
  std::vector<std::pair<std::string, double>> forbidden_by_region;  // name, mm3
  bool pulp_exposed = false;     // the bur entered the pulp: pulp tissue was removed (pulp_removed_mm3 > 0)
  bool pulp_wall_opened = false; // a pulp voxel borders a voxel the cut opened (reported, not charged)
  double pulp_removed_mm3 = 0;
  double pulp_exposure_mm = 0;   // the exposure's size across (Exercise::pulp_exposure_size_mm), 0 when none
  bool perforation = false;      // the cut opened to the outside away from every entry region
  double perforation_mm3 = 0;    // opened voxels that border outside air outside entry regions
  std::vector<RegionScore> regions;  // every target region
  std::vector<Criterion> criteria;   // access opening: the six criteria; graded regions: the wall taper, if set
  std::vector<Penalty> penalties;    // every cost charged (none when nothing went wrong)
  double earned_points = 0;          // criteria or regions, before the penalties
  double points = 0, max_points = 0; // points = max(0, earned - penalties)
  // A finished preparation (docs/formats.md "Outcome scores"): the target
  // coverage reaches the exercise's complete_coverage_pct (and, for an
  // access opening, every orifice can be seen). An unfinished one keeps the
  // points it earned but is always shown as incomplete, with `completion`
  // saying what is missing.
  bool complete = false;
  std::string completion;  // one sentence: why complete or what is missing
  // "12.0 / 16 points" or "3.2 / 16 points, INCOMPLETE"
  std::string headline() const;
};

// start: the starting volume the masks were built on; cut: the same geometry
// after the session. Errors name the mismatch.
Result<OutcomeScores> score_outcome(const Exercise& ex, const RegionMasks& masks,
                                    const volume::VoxelVolume& start, const volume::VoxelVolume& cut);

// Spearman's rank correlation of a and b (same length >= 2; ties get their
// mean rank); NaN when either has no spread. Used to check that totals rank
// sessions by skill (issue 25).
double spearman_rho(const std::vector<double>& a, const std::vector<double>& b);

// Wall profile used by the access criteria (exposed for tests): cavity extent
// (m) from the axis point along `dir` (unit, horizontal) at each level z in
// [z0, z1], one per voxel layer where the axis voxel is open. With the
// starting tooth (`start`, as the scores use it), only the layers opened
// contiguously from z1 down: outside the tooth, removed by the bur, or the
// pulp chamber's own space under them (reached once the roof is broken at
// the axis); the untouched chamber is not a cut (docs/formats.md).
struct WallProfile {
  std::vector<double> z_m, extent_m;
  double divergence_deg = 0;  // atan of d(extent)/dz: > 0 opens toward occlusal
  double rms_mm = 0;          // residual of the straight-line fit
};
WallProfile wall_profile(const volume::VoxelVolume& cut, const Eigen::Vector3d& axis_point_m,
                         const Eigen::Vector3d& dir, double z0_m, double z1_m,
                         const volume::VoxelVolume* start = nullptr);
// Fraction (0..1) of sight rays from `from_m` within `cone_deg` of +z that
// reach z >= top_z_m through open voxels (density < iso) of `cut`.
double line_of_sight(const volume::VoxelVolume& cut, const Eigen::Vector3d& from_m, double top_z_m,
                     double cone_deg);
// Straight-line access to one canal (issue 25, session 20): the share (0..1) of
// file paths that reach z >= top_z_m through open voxels of `cut`. The paths
// start on the orifice's disk (its centre and 8 points at radius_m around it,
// across `axis_up`) and run occlusally along the canal's axis `axis_up` and
// along 8 directions tilted cone_deg from it (81 paths): a file that enters
// the canal along its axis, widened occlusally, without touching a wall or a
// dentin shelf left over the orifice. An origin in solid tooth is a blocked path.
double straight_line_access(const volume::VoxelVolume& cut, const Eigen::Vector3d& orifice_m,
                            const Eigen::Vector3d& axis_up, double top_z_m, double radius_m, double cone_deg);
// The pulp chamber's roof removed (issue 25, session 20): of the chamber's
// footprint (voxel columns holding a pulp voxel of `start` at or above
// from_z_m: the chamber and its horns, not the canals below), the share whose
// column is open in `cut` from its highest starting pulp voxel to the top of
// the volume. 0 for an untouched tooth; a roof or dentin shelf left over any
// part of the chamber or a horn keeps those columns closed.
double roof_removed(const volume::VoxelVolume& start, const volume::VoxelVolume& cut, double from_z_m);

}  // namespace dentar::training
