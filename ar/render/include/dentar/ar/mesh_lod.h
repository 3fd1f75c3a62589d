// A coarser copy of a tooth chunk's mesh (a level of detail): vertex clustering on the voxel
// grid. Used by the compositor's per-chunk levels and by the replay window while it plays
// (issue 27). CPU only.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "dentar/volume/surface.h"

namespace dentar::ar {

// Reused memory of cluster_chunk_mesh (allocated on first use, kept between calls).
struct MeshLodScratch {
  std::unordered_map<std::uint64_t, std::uint32_t> map;
  std::vector<Eigen::Vector3d> sums;
  std::vector<int> counts;
  std::vector<std::uint32_t> remap;
};

// Vertex clustering in cells of `cell_voxels` voxels (a divisor of the chunk size, so cells
// never straddle chunks). Each vertex lies on a grid edge (its edge key); a vertex on a chunk
// seam also exists, bit-identical, in the neighbour chunk's mesh. To keep the two copies
// identical after clustering, seam vertices are clustered only with seam vertices of the same
// plane (2-D cells in it; both chunks see exactly that set), vertices on two seam planes
// (chunk edges) are kept, and interior vertices cluster in 3-D cells. A cluster's vertex is
// the mean of its members (in double, so the two chunks' sums agree) with the mean normal, and
// the material and edge key of its first member: it stays on a smooth surface (no staircase),
// so the coarse mesh has no cracks at chunk seams. Triangles that collapse are dropped.
// `out.version` is left as it was (the caller's). Returns the largest distance of a member
// from its cluster vertex along the member's normal, m (the level's geometric error;
// tangential moves do not change what is seen).
double cluster_chunk_mesh(const volume::ChunkMesh& in, int cell_voxels, volume::ChunkMesh& out,
                          MeshLodScratch& scratch);

}  // namespace dentar::ar
