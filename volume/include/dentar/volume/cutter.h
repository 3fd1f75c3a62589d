// Cutting: removes material under a bur's sample points and keeps the
// running metrics (removed volume per material, pulp exposure).
//
// Thread: step() runs in the haptic thread. It never allocates, locks or does
// I/O; it only lowers density in allocated chunks and marks chunks dirty.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <optional>

#include "dentar/volume/bur.h"
#include "dentar/volume/material.h"
#include "dentar/volume/voxel_volume.h"

namespace dentar::volume {

// base_rate_per_s for the overlap cutter (CutParams::overlap), calibrated so
// that the exercise's cone bur held still at 1 N cuts a 0.15 mm block as fast
// as the sample cutter with the cohorts' 1000 samples did (haptics_cut_rate_bench:
// dentin 7.03 against 6.91 mm3/s, enamel 0.892 against 0.896; at 6000 the
// overlap cutter gives 3.28 / 0.377; docs/BENCHMARKS.md "Haptics session 22").
inline constexpr double kOverlapBaseRatePerS = 11000.0;

struct CutParams {
  // Density units (0..255) removed per second from a voxel fully under the
  // bur, for a material of removal_rate 1 (dentin) at the reference force.
  double base_rate_per_s = 6000.0;
  double reference_force_N = 1.0;
  // Removal scales linearly with force up to this force, then saturates.
  double max_effective_force_N = 4.0;
  // Forces below this remove nothing (the bur rests on the surface).
  double min_force_N = 0.05;
  // Shift the bur's samples each step by a different sub-spacing offset (a
  // low-discrepancy sequence over a cube one mean sample spacing wide, in the
  // tip frame), so that over a few steps every voxel under the bur is cut,
  // not only the voxels a sample lands in. Without it a bur held still (or
  // swept along one line) removes only the voxels hit by its fixed samples,
  // so the cut rate depends on the voxel size against the sample spacing
  // (docs/BENCHMARKS.md, "Haptics session 20 - cut rate against voxel size").
  // Off by default: the sessions generated so far were cut without it.
  bool sample_jitter = false;
  // Cut by overlap volume instead of by samples: every voxel the bur overlaps
  // loses base_rate x (its share inside the bur) x material rate x force
  // factor, the share estimated from the bur's exact signed distance at the
  // voxel centre (clamp(0.5 - d / h, 0, 1), h = cbrt(voxel volume)). The
  // removal is then a property of the bur's shape and the force, not of how
  // many samples stand for it (docs/BENCHMARKS.md, "Haptics session 22").
  // sample_jitter is ignored when on. Off by default here: CutParams{} keeps
  // the sample cutter for code that has not chosen.
  bool overlap = false;

  std::string validate() const;
};

// What one cutting step removed. Density units summed over voxels: divide by
// 255 and multiply by the voxel volume for a volume.
struct CutResult {
  std::array<std::uint32_t, kMaxMaterials> removed{};  // density units per material
  std::uint32_t samples_in_solid = 0;  // samples (overlap: voxels) that landed in non-air voxels
  bool touched_pulp = false;           // a sample (overlap: an overlapped voxel) is pulp
  double overlap_m3 = 0.0;  // bur volume inside non-air voxels this step (samples: count x sample volume)
  std::uint64_t total_removed() const;
};

struct PulpExposure {
  std::uint64_t step = 0;           // Cutter step index at which it happened
  Eigen::Vector3d position_m{0, 0, 0};  // tooth frame, centre of the first pulp voxel hit
};

struct CutMetrics {
  std::array<double, kMaxMaterials> removed_mm3{};  // per material
  double removed_total_mm3 = 0.0;
  double original_tooth_mm3 = 0.0;  // density-weighted volume of all non-air material
  double removed_percent = 0.0;     // 100 * removed_total / original_tooth
  std::optional<PulpExposure> pulp_exposure;
};

class Cutter {
 public:
  // The volume must outlive the cutter. Reads the original tooth volume once.
  Cutter(VoxelVolume& volume, const CutParams& params = {});

  // Removes material under the samples placed at T_tooth_tip. force_N is the
  // magnitude of the force pressing the bur into the tooth; dt_s the step
  // length (1e-3 at 1 kHz). Deterministic: the same sequence of calls on the
  // same volume gives a bit-identical volume. Non-finite inputs cut nothing.
  CutResult step(const BurSamples& bur, const Eigen::Isometry3d& T_tooth_tip, double force_N,
                 double dt_s) noexcept;

  std::uint64_t steps() const { return step_; }
  CutMetrics metrics() const;

 private:
  CutResult step_overlap(const BurParams& bur, const Eigen::Isometry3d& T_tooth_tip, double f,
                         bool cutting, double dt_s, std::uint64_t step_index) noexcept;
  // One solid voxel (material mat != 0, density > 0) under the bur, the same for both
  // cutters: counts it (overlap_m3 of bur in it), notes pulp touched and the first
  // exposure, removes (amount_fx + dither) >> 16 density units (16 fractional bits;
  // each cutter keeps its own dither hash), turns an emptied voxel into air and grows
  // the changed box [lo, hi].
  void cut_voxel(CutResult& res, VoxelVolume::Chunk& c, std::size_t li, std::uint8_t mat, int i,
                 int j, int k, double overlap_m3, std::uint32_t amount_fx, std::uint32_t dither,
                 bool cutting, std::uint64_t step_index, Eigen::Vector3i& lo,
                 Eigen::Vector3i& hi) noexcept;
  // The end of a step: marks the changed box dirty (with the mesher's margins) and
  // adds the step's removal to the totals. Nothing when nothing changed (hi.x() < 0).
  void finish_step(const CutResult& res, const Eigen::Vector3i& lo, const Eigen::Vector3i& hi) noexcept;

  VoxelVolume* vol_;
  CutParams params_;
  std::uint64_t step_ = 0;
  std::array<std::uint64_t, kMaxMaterials> removed_total_{};
  double original_units_ = 0.0;
  std::optional<PulpExposure> exposure_;
};

}  // namespace dentar::volume
