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

  std::string validate() const;
};

// What one cutting step removed. Density units summed over voxels: divide by
// 255 and multiply by the voxel volume for a volume.
struct CutResult {
  std::array<std::uint32_t, kMaxMaterials> removed{};  // density units per material
  std::uint32_t samples_in_solid = 0;  // samples that landed in non-air voxels
  bool touched_pulp = false;           // a sample landed in a pulp voxel
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
  VoxelVolume* vol_;
  CutParams params_;
  std::uint64_t step_ = 0;
  std::array<std::uint64_t, kMaxMaterials> removed_total_{};
  double original_units_ = 0.0;
  std::optional<PulpExposure> exposure_;
};

}  // namespace dentar::volume
