// VoxelVolume: the cuttable tooth. Sparse 16^3 chunks of (density, material).
//
// Frame: `tooth`. Voxel (i,j,k) has its centre at origin + spacing ⊙ (i,j,k),
// in metres. Voxels outside dims read as air with density 0.
//
// Threads: one writer that only removes material (the haptic thread, through
// Cutter) may run while the graphics side drains dirty chunks. Allocation
// (set() on an absent chunk, release_empty_chunks()) is for setup code only.
#pragma once

#include <Eigen/Core>
#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "dentar/volume/material.h"
#include "dentar/volume/result.h"

namespace dentar::volume {

struct VolumeGeometry {
  Eigen::Vector3i dims{0, 0, 0};              // voxels per axis
  Eigen::Vector3d spacing{1e-4, 1e-4, 1e-4};  // m per voxel, per axis
  Eigen::Vector3d origin{0, 0, 0};            // m, centre of voxel (0,0,0)

  // Empty string when valid; otherwise names the field and the constraint.
  std::string validate() const;
  std::int64_t voxel_count() const {
    return std::int64_t{dims.x()} * dims.y() * dims.z();
  }
};

// Sane upper bounds for user-supplied volumes (loaders and create()).
inline constexpr int kMaxDim = 4096;
inline constexpr std::int64_t kMaxVoxels = std::int64_t{1} << 31;

class VoxelVolume {
 public:
  static constexpr int kChunkBits = 4;
  static constexpr int kChunkSize = 1 << kChunkBits;  // 16 voxels per axis
  static constexpr int kChunkVoxels = kChunkSize * kChunkSize * kChunkSize;

  // Voxel data of one chunk, x fastest: index = x + 16*(y + 16*z).
  struct Chunk {
    std::array<std::uint8_t, kChunkVoxels> density{};
    std::array<std::uint8_t, kChunkVoxels> material{};
  };

  // Validating factory for user-supplied geometry.
  static Result<VoxelVolume> create(const VolumeGeometry& g);
  // Asserts that g is valid (programmer input).
  explicit VoxelVolume(const VolumeGeometry& g);
  VoxelVolume(VoxelVolume&&) noexcept = default;
  VoxelVolume& operator=(VoxelVolume&&) noexcept = default;
  VoxelVolume(const VoxelVolume&) = delete;
  VoxelVolume& operator=(const VoxelVolume&) = delete;
  VoxelVolume clone() const;  // deep copy; dirty state is not copied

  const VolumeGeometry& geometry() const { return geom_; }
  const Eigen::Vector3i& dims() const { return geom_.dims; }
  const Eigen::Vector3d& spacing() const { return geom_.spacing; }
  const Eigen::Vector3d& origin() const { return geom_.origin; }
  double voxel_volume_m3() const { return geom_.spacing.prod(); }
  Eigen::Vector3d voxel_center(int i, int j, int k) const {
    return geom_.origin + geom_.spacing.cwiseProduct(Eigen::Vector3d(i, j, k));
  }
  bool in_bounds(int i, int j, int k) const {
    return i >= 0 && j >= 0 && k >= 0 && i < geom_.dims.x() && j < geom_.dims.y() &&
           k < geom_.dims.z();
  }

  // Voxel access; out of bounds reads air/0. set() allocates the chunk if it is
  // absent (setup only) and does not mark it dirty.
  std::uint8_t density(int i, int j, int k) const;
  Material material(int i, int j, int k) const;
  void set(int i, int j, int k, std::uint8_t density, Material m);

  // Chunks. Chunk id = ci + cx*(cj + cy*ck) with (cx,cy,cz) = chunk_dims().
  const Eigen::Vector3i& chunk_dims() const { return chunk_dims_; }
  int num_chunks() const { return static_cast<int>(chunks_.size()); }
  int chunk_id(int ci, int cj, int ck) const {
    return ci + chunk_dims_.x() * (cj + chunk_dims_.y() * ck);
  }
  Eigen::Vector3i chunk_coords(int id) const {
    return {id % chunk_dims_.x(), (id / chunk_dims_.x()) % chunk_dims_.y(),
            id / (chunk_dims_.x() * chunk_dims_.y())};
  }
  // nullptr when the chunk is absent (all air, density 0).
  Chunk* chunk(int id) { return chunks_[static_cast<std::size_t>(id)].get(); }
  const Chunk* chunk(int id) const { return chunks_[static_cast<std::size_t>(id)].get(); }
  int allocated_chunks() const;
  // Installs a whole chunk (setup only, e.g. asset builders); nullptr frees it.
  void adopt_chunk(int id, std::unique_ptr<Chunk> c) {
    chunks_[static_cast<std::size_t>(id)] = std::move(c);
  }
  // Frees chunks whose voxels are all air with density 0. Setup/graphics side
  // only: never while a writer thread runs.
  int release_empty_chunks();

  // Bytes held by voxel storage (allocated chunks + chunk table), and what a
  // dense array of (density, material) over dims would take.
  std::size_t memory_bytes() const;
  std::size_t dense_bytes() const { return static_cast<std::size_t>(geom_.voxel_count()) * 2; }

  // Dirty tracking. mark_dirty* is lock-free and allocation-free (haptic
  // thread); drain_dirty is for one consumer (the mesher).
  void mark_dirty(int chunk_id) noexcept;
  // Marks every chunk holding a voxel in the inclusive box [lo, hi], clamped.
  void mark_dirty_box(const Eigen::Vector3i& lo, const Eigen::Vector3i& hi) noexcept;
  void mark_all_dirty() noexcept;
  // Appends the ids of dirty chunks (ascending) to out and clears them.
  // const: dirty bits are a side channel, not voxel content.
  void drain_dirty(std::vector<int>& out) const;
  bool is_dirty(int chunk_id) const noexcept;

  // 64-bit hash of geometry and all voxel contents. Independent of which
  // all-zero chunks happen to be allocated. Equal volumes give equal hashes.
  std::uint64_t content_hash() const;

  // Sum of density over voxels of each material label (exact integers).
  std::array<std::uint64_t, kMaxMaterials> density_sum_by_material() const;

 private:
  VolumeGeometry geom_;
  Eigen::Vector3i chunk_dims_{0, 0, 0};
  std::vector<std::unique_ptr<Chunk>> chunks_;
  std::size_t dirty_words_ = 0;
  std::unique_ptr<std::atomic<std::uint64_t>[]> dirty_;
};

// Local index of voxel (x,y,z) within a chunk, each in [0,16).
constexpr int chunk_local_index(int x, int y, int z) {
  return x + VoxelVolume::kChunkSize * (y + VoxelVolume::kChunkSize * z);
}

}  // namespace dentar::volume
