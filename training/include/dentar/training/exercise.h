// Exercises: the tooth, the procedure and its steps, the target, forbidden
// and entry regions (analytic shapes in the tooth frame, combined by
// intersection), the bur and the time limit. Files: assets/exercises/*.json,
// format in docs/formats.md ("Exercise").
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "dentar/volume/bur.h"
#include "dentar/volume/material.h"
#include "dentar/volume/result.h"
#include "dentar/volume/voxel_volume.h"

namespace dentar::training {

enum class PrimitiveKind : std::uint8_t {
  kSphere,     // centre a, radius
  kBox,        // corners a (min) and b (max)
  kCylinder,   // axis from a to b, radius (flat ends)
  kHalfSpace,  // point a, outward normal b: keeps (p - a)·b <= 0
  kMaterial,   // voxels of `material` in the starting volume
  kShell,      // tooth voxels of the starting volume within `depth` of its surface
  kSolid,      // tooth voxels (density > 0: the partial-volume skin included) of the starting volume
};

// One analytic shape (tooth frame, metres). `negate` takes its complement.
struct Primitive {
  PrimitiveKind kind = PrimitiveKind::kBox;
  Eigen::Vector3d a_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d b_m = Eigen::Vector3d::Zero();
  double radius_m = 0;
  double depth_m = 0;
  volume::Material material = volume::Material::kAir;
  bool negate = false;
  // Geometric test for the analytic kinds (kMaterial/kShell/kSolid need the
  // volume and are handled by build_masks). `grow_m` enlarges the shape (zones).
  bool contains(const Eigen::Vector3d& p_m, double grow_m = 0) const;
};

enum class RegionRole : std::uint8_t { kTarget, kForbidden, kEntry };

// A region is the intersection of its primitives.
struct Region {
  std::string name;
  RegionRole role = RegionRole::kTarget;
  std::vector<Primitive> all;
  double points = 0;       // graded outcome: points this target region is worth
  double zone_mm = 1.0;    // graded outcome: neighbourhood that counts as over-preparation
};

struct ExerciseStep {
  std::string name;
  std::string region;  // name of the region the step works on ("" = none)
  // Where the bur works in this step (tooth frame); used to find the steps in
  // a session. Absent: the centroid of `region`.
  std::optional<Eigen::Vector3d> focus_m;
  // Unit vector from the focus toward where the bur comes from (the bur axis
  // is its opposite); +z (occlusal/incisal) when absent. Used by the cohort
  // generator's scripts.
  Eigen::Vector3d approach = Eigen::Vector3d::UnitZ();
};

struct Orifice {
  std::string name;
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
  // The canal's axis at the orifice, a unit vector toward occlusal (outcome
  // field "canal_axis", issue 25 session 20): the straight line a file takes
  // into the canal. Absent: +z.
  Eigen::Vector3d canal_axis = Eigen::Vector3d::UnitZ();
};

// Access-opening geometry (outcome kind "access_opening").
struct AccessGeometry {
  std::vector<Orifice> orifices;
  Eigen::Vector3d axis_point_m = Eigen::Vector3d::Zero();  // on the long axis of the access
  double opening_z_m = 0;  // occlusal opening plane (tooth frame z)
  double floor_z_m = 0;    // pulpal floor level
  double walls_from_z_m = 0;  // axial walls are measured from here up to the opening (>= floor)
  double sight_cone_deg = 10;  // rays from an orifice within this cone of +z
};

enum class OutcomeKind : std::uint8_t { kGradedRegions, kAccessOpening };

// Access opening: how the six criteria turn what they measure into points
// (outcome field "access_points"). kBands: the integer bands 0-3 (the rule
// since issue 14); kContinuous (issue 25, session 14): each criterion's
// points fall linearly with the measured deviation between the same
// thresholds, so two sessions tie only when they measure the same.
enum class AccessPoints : std::uint8_t { kBands, kContinuous };

// Graded regions: the taper of the cavity's four axial walls (outcome field
// "wall_taper", issue 25 session 14). Each wall (mesial -x, distal +x,
// buccal -y, palatal/lingual +y from the axis point) is measured as the
// access opening's walls are (wall_profile) between from_z and to_z; a wall
// whose divergence lies within [ideal_min_deg, ideal_max_deg] earns points/4,
// and its points fall linearly to 0 at zero_beyond_deg outside that range.
struct WallTaper {
  double points = 0;
  Eigen::Vector3d axis_point_m = Eigen::Vector3d::Zero();
  double from_z_m = 0, to_z_m = 0;
  double ideal_min_deg = -5, ideal_max_deg = 2;
  double zero_beyond_deg = 10;
  // Outline reach (outcome field "wall_taper.outline_reach_full_pct", issue 25 session 19): a wall
  // earns its taper points in proportion to how far it reaches toward the target's outline, full at
  // this percentage or more. Its reach is the mean over the measured layers of min(1, the wall's
  // distance from the axis point / the target outline's in the same direction), a layer where the
  // cavity does not reach counting 0: a wall not cut out to the outline is not yet the wall the
  // preparation needs, and its taper cannot be judged as that wall's. 0: not applied (the rule
  // before session 19).
  double outline_reach_full_pct = 0;
  // Coverage share (field "coverage_full_pct", issue 25 session 22): a criterion judged on the
  // finished form earns its points in proportion to how much of the target the preparation removed,
  // full at this coverage (%) or more: points x min(1, coverage / coverage_full_pct), or, with
  // "coverage_share": "cap", at most that many (the measured grade kept when it is lower). An
  // unfinished preparation's form is the form of part of the cavity. 0 (default): not applied.
  double coverage_full_pct = 0;
  bool coverage_cap = false;
};

// Graded regions: outline extension in millimetres (outcome field "outline_extension", issue 25
// session 20). Each axial wall (mesial -x, distal +x, buccal -y, palatal/lingual +y) is measured
// along its length (the target outline's extent across the wall, less end_margin at each end, in
// voxel steps) at every voxel layer between from_z and to_z where the target's outline lies in the
// starting tooth: the signed distance (m) of the cut outline (the farthest voxel the cut opened
// along the ray from the axis, searched to 1.5 mm past the outline) from the target outline,
// negative short of it (under-extended), positive past it (over-extended). Each sample is graded on
// the rubric's bands: |d| <= ideal: 1, <= acceptable: accept_fraction, <= modification:
// modify_fraction, beyond: 0; a wall earns points/4 x the mean grade of its samples. The points are
// taken from the target region `from_region`'s volume coverage share (its coverage earns
// region points - points); the region's price of a mm3 cut too far is unchanged.
struct OutlineExtension {
  double points = 0;
  std::string from_region;
  Eigen::Vector3d axis_point_m = Eigen::Vector3d::Zero();
  double from_z_m = 0, to_z_m = 0;
  double end_margin_m = 0.5e-3;
  double ideal_m = 0.25e-3, acceptable_m = 0.5e-3, modification_m = 1.0e-3;
  double accept_fraction = 0.85, modify_fraction = 0.62;
  // "overprep_price": "region" (default): a mm3 cut too far in the region's zone costs the region's
  // declared points over its volume, as without this criterion; "coverage": the price of its coverage
  // share (region points - points), so a mm3 left and a mm3 cut too far cost the same again (the cut too
  // far below the floor as well: a comparison rule, session 20).
  bool price_follows_coverage = false;
};

// Graded regions: the floor's depth in millimetres (outcome field "floor_depth", issue 25 session
// 21). The target floor is the bottom face of the region's lowest voxel in each voxel column of the
// region's footprint; the columns sampled are those whose neighbours margin in from the outline
// (along x and y) are in the footprint too. Per column, the signed distance (m) of the cut floor (the
// bottom face of the lowest voxel the cut opened in that column, searched to 1.5 mm below the target
// floor; the top of the starting tooth when none was opened) from the target floor: positive below
// it (too deep), negative short of it (too shallow). Each column graded on the rubric's bands as the
// outline extension's samples (|d| <= ideal: 1, <= acceptable: accept_fraction, <= modification:
// modify_fraction, beyond: 0); the criterion earns points x the mean grade. Its points come out of
// `from_region`'s coverage share, as the outline extension's do. With it, the region's cut too far
// within its zone is split at the region's floor level (its lowest voxel's bottom face): below it
// ("below the floor") is judged by this criterion, not priced by volume; above it ("past the
// walls") by the outline extension when the exercise has one from the same region, else priced by
// volume as before.
struct FloorDepth {
  double points = 0;
  std::string from_region;
  double margin_m = 0.5e-3;
  double ideal_m = 0.25e-3, acceptable_m = 0.5e-3, modification_m = 1.0e-3;
  double accept_fraction = 0.85, modify_fraction = 0.62;
  // "grading": "bands" (default, above) or "continuous": a column's grade falls linearly from 1 at
  // ideal to 0 at modification (so 0.3 and 0.45 mm too deep are not the same grade).
  bool continuous = false;
  // Coverage share (field "coverage_full_pct", issue 25 session 22): a criterion judged on the
  // finished form earns its points in proportion to how much of the target the preparation removed,
  // full at this coverage (%) or more: points x min(1, coverage / coverage_full_pct), or, with
  // "coverage_share": "cap", at most that many (the measured grade kept when it is lower). An
  // unfinished preparation's form is the form of part of the cavity. 0 (default): not applied.
  double coverage_full_pct = 0;
  bool coverage_cap = false;
};

struct Exercise {
  std::string source;  // file name (messages)
  std::string name, title, procedure;
  std::string tooth_json;  // {"kind": "molar"|"incisor", "voxel_mm": ...}: as in the session header
  volume::BurParams bur;
  int bur_samples = 2000;
  double time_limit_s = 600;
  double excessive_force_N = 3.0;  // drilling force above this is "excessive" (process metric)
  std::vector<ExerciseStep> steps;
  std::vector<Region> regions;
  OutcomeKind outcome = OutcomeKind::kGradedRegions;
  std::optional<AccessGeometry> access;
  AccessPoints access_points = AccessPoints::kBands;
  // Continuous access points: a wall diverging occlusally by more than flare_free_deg loses a point
  // per flare_deg_per_point beyond it, at most 2 (outcome fields "flare_free_deg",
  // "flare_deg_per_point"; defaults 25 and 10, the bands' over-flare threshold and step).
  double access_flare_free_deg = 25, access_flare_deg_per_point = 10;
  std::optional<WallTaper> wall_taper;  // graded regions only; its points count in max_points()
  std::optional<OutlineExtension> outline_extension;  // graded regions only; points taken from a region's
  std::optional<FloorDepth> floor_depth;  // graded regions only; points taken from a region's (session 21)
  // What the exercise charges (outcome fields "pulp_exposure_points",
  // "perforation_points"; points subtracted from the total, which never
  // goes below 0). Negative = all the exercise's points (the default: an
  // unnamed cost is the worst one).
  double pulp_exposure_cost = -1;
  double perforation_cost = -1;
  // Graded pulp exposure (outcome fields "pulp_exposure_full_mm" and
  // "pulp_exposure_min_fraction", issue 25 session 15). The exposure's size
  // is the diameter of a hemisphere holding the pulp removed
  // (2 (3V / 2 pi)^(1/3)); an exposure that size or larger across costs the
  // whole pulp_exposure_points, a smaller one min_fraction of it plus the
  // rest in proportion to its size. full_mm 0 (the default): every exposure
  // costs the whole pulp_exposure_points (all or nothing, the rule before).
  double pulp_exposure_full_mm = 0;
  double pulp_exposure_min_fraction = 1;
  // Over-reduction (outcome field "over_reduction_rate", issue 25 session
  // 11): tooth (not pulp) removed outside every target region and beyond
  // every target's zone_mm is charged rate x (the exercise's points per mm3
  // of target) per mm3: with 1, a mm3 of sound tooth cut away beyond the
  // tolerance costs what a mm3 of target left standing costs. 0 (default):
  // not charged (reported only). Access openings: removal below floor_z is
  // the floor criterion's, not charged again.
  double over_reduction_rate = 0;
  // Graded regions: removal outside the targets but within this distance
  // (mm) of a target region is within clinical tolerance and not charged
  // (outcome field "tolerance_mm"; 0: every voxel beyond the target is
  // charged, the rule before session 11).
  double tolerance_mm = 0;
  // Graded regions: what a mm3 cut beyond a target region (within its zone)
  // costs. false (outcome field "overprep_price": "region", the default and
  // the shipped rule): the region's points over the region's volume, so a mm3
  // cut at the incisor's 3 mm3 cervical band costs 7x what it costs at the
  // 36 mm3 labial face next to it. true ("exercise", issue 25 session 12):
  // the exercise's own price, its graded points over its whole target volume,
  // in every region (as over_reduction_rate 1 charges beyond the zones);
  // measured on generated sessions, not shipped: no real or new-user incisor
  // session exists to show it on (docs/BENCHMARKS.md).
  bool overprep_exercise_price = false;
  // Graded regions (outcome field "overflow_cost", issue 25 session 22): what a region's cut too far
  // costs at its price beyond the points its coverage earned is charged to the whole preparation
  // (the cost "over-extended outline" when the floor depth splits the region's cut, else "cut too
  // far"), instead of stopping at the region's 0. false (default): a region's points stop at 0 and
  // the rest of its charge is dropped (the rule before).
  bool overflow_cost = false;
  // Access opening: tooth cut away outside the access outline but within its
  // zone (above the floor) costs rate x (18 points over the access target's
  // volume) per mm3 (outcome field "access_zone_rate"; 0, the default: only
  // the walls' divergence sees it).
  double access_zone_rate = 0;
  // Access opening: of that removal, what lies within this distance (mm) outside the outline is
  // not charged (outcome field "access_zone_free_mm", default 0; issue 25 session 21): the margin a
  // finished outline's wall leaves in the voxel grid and the bur's own roundness.
  double access_zone_free_mm = 0;
  // Access opening (issue 25, session 22): each axial wall's over-extension past the access outline
  // in mm costs this many points per mm beyond wall_overextension_free_mm, one penalty per wall
  // (outcome field "wall_overextension_points_per_mm", 0-100, default 0: measured and reported
  // only). The wall's over-extension is a robust statistic of its columns, not one voxel column's:
  // the wall_overextension_percentile (50-100, default 90) of max(0, the cavity's extent - the
  // outline's) over the wall's 8 directions x its measured levels (docs/formats.md).
  double wall_overextension_points_per_mm = 0;
  double wall_overextension_free_mm = 0.3;   // outcome field "wall_overextension_free_mm", 0-5
  double wall_overextension_percentile = 90; // outcome field "wall_overextension_percentile", 50-100
  // Access opening (issue 25, session 23): the access left standing. Of the access target, what is
  // left below under_extension_full_pct % coverage costs under_extension_rate x (the exercise's
  // points over the access target's volume) per mm3, the price a mm3 cut outside the outline pays
  // (outcome fields "under_extension_rate", 0-100, default 0: not charged; "under_extension_full_pct",
  // 0-100, default 90: the share from which the walls and the floor earn in full).
  double under_extension_rate = 0;
  double under_extension_full_pct = 90;
  // Access opening (issue 25, session 23): dentin removed below the pulpal floor level past the
  // 1 mm3 at which the floor's integrity reaches 0 costs floor_overflow_rate x (the exercise's
  // points over the access target's volume) per mm3 (outcome field "floor_overflow_rate", 0-100,
  // default 0: the floor criterion's 0 is the whole charge). Not charged when the floor is perforated
  // (the perforation's points price it).
  double floor_overflow_rate = 0;
  // A finished preparation removes at least this % of the target (outcome
  // field "complete_coverage_pct"); below it the score is marked incomplete.
  double complete_coverage_pct = 80;
  // Access opening: every orifice must have at least this fraction of clear
  // sight lines for the opening to count as finished.
  double complete_orifice_sight = 0.3;

  const Region* region(const std::string& n) const;
  double max_points() const;  // 18 for an access opening, sum of points (regions + wall taper) otherwise
  double pulp_exposure_points() const { return pulp_exposure_cost < 0 ? max_points() : pulp_exposure_cost; }
  // What an exposure removing pulp_mm3 of pulp costs (0 when none was removed): pulp_exposure_points()
  // scaled by the graded rule above.
  double pulp_exposure_charge(double pulp_mm3) const;
  // The exposure's size (mm across) the graded rule uses.
  static double pulp_exposure_size_mm(double pulp_mm3);
  double perforation_points() const { return perforation_cost < 0 ? max_points() : perforation_cost; }
};

// Parses an exercise; every error names the file (`name`) and the field.
Result<Exercise> parse_exercise(const std::string& json_text, const std::string& name);
Result<Exercise> load_exercise(const std::string& path);
// The exercises shipped in assets/exercises (name without .json): in $DENTAR_ASSETS when set,
// else in the source tree's assets (compiled in); never the working directory's (session 22).
// Exercise::source is the file read.
Result<Exercise> load_builtin_exercise(const std::string& name);
// An exercise as the command line, a lesson or a replay names it: a path when it contains
// ".json" or a '/', else a built-in name (load_builtin_exercise, whose error lists the names).
// The one rule for every command (session 14: lesson and replay had their own).
Result<Exercise> load_named_exercise(const std::string& name_or_path);
std::string builtin_exercise_dir();

// Builds a tooth from its description (session header "tooth" object or an
// exercise's): kinds "molar" and "incisor" with optional "voxel_mm"; a molar with optional
// "pulp_roof_mm" (absent: MolarParams's adult default).
Result<volume::VoxelVolume> make_tooth(const std::string& tooth_json);
// The tooth a session log started from: make_tooth, and when its content hash is not
// `start_hash` and the log describes a molar without "pulp_roof_mm", the molar as it was before
// session 18 (roof at volume::kLegacyMolarPulpRoofFraction x the crown height) if that one has
// the hash. Logs recorded before the adult pulp became the default keep replaying and scoring on
// the tooth they were cut on. Any other mismatch is left to the caller's hash check.
Result<volume::VoxelVolume> make_start_tooth(const std::string& tooth_json, std::uint64_t start_hash);

// One bit per region (bit r = regions[r]) for every voxel of the starting
// volume, x fastest. At most 32 regions.
struct RegionMasks {
  Eigen::Vector3i dims{0, 0, 0};
  std::vector<std::uint32_t> bits;
  std::uint32_t target_bits = 0, forbidden_bits = 0, entry_bits = 0;
  std::size_t index(int i, int j, int k) const {
    return static_cast<std::size_t>(i) +
           static_cast<std::size_t>(dims.x()) * (static_cast<std::size_t>(j) +
                                                 static_cast<std::size_t>(dims.y()) * k);
  }
};

// Rasterises the regions on the starting volume. Errors: a target and a
// forbidden region that share a voxel (names both regions, the file and the
// voxel's position in mm), an empty target region.
Result<RegionMasks> build_masks(const Exercise& ex, const volume::VoxelVolume& start);

// Distance (m) from each voxel of `vol` to the nearest outside voxel (not
// solid and not pulp)
// (3-4-5 chamfer approximation, within 3 %); 0 for non-solid voxels.
std::vector<float> distance_to_air_m(const volume::VoxelVolume& vol);

}  // namespace dentar::training
