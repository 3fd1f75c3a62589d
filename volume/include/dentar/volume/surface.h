// Surface extraction: marching cubes per 16^3 chunk on the density field at
// kIsoDensity, with incremental re-extraction of dirty chunks.
//
// Cells: chunk c owns the cells whose lowest corner lies in c; the first chunk
// along an axis also owns the cells starting at -1 (outside is air). Each cell reads
// its upper neighbours' voxels (one-voxel border) and gradients read one more,
// so a cut must dirty chunks within [lo-2, hi+1] of the changed voxels (Cutter
// does). Outside the volume is air, so a tooth touching the box stays closed.
//
// Seams: a vertex lies on a grid edge and carries that edge's global key.
// Both chunks that touch a seam edge compute it from the same inputs in the
// same order, so it is bit-identical; merged meshes weld by key, leaving no
// duplicate vertices and no cracks.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "dentar/volume/result.h"
#include "dentar/volume/voxel_volume.h"

namespace dentar::volume {

struct MeshVertex {
  Eigen::Vector3f position_m;  // tooth frame, metres
  Eigen::Vector3f normal;      // unit, outward (toward lower density)
  std::uint8_t material;       // Material label for colour
};

struct ChunkMesh {
  std::vector<MeshVertex> vertices;
  std::vector<std::uint64_t> edge_keys;  // global grid-edge key per vertex (same size)
  std::vector<std::uint32_t> indices;    // triangles, counter-clockwise seen from outside
  std::uint64_t version = 0;             // bumped each time the chunk is re-extracted
  std::size_t triangle_count() const { return indices.size() / 3; }
  bool empty() const { return indices.empty(); }
};

// Global key of the grid edge from voxel (i,j,k) along axis (0,1,2). Indices
// may be -1 (cells in the border outside the volume).
std::uint64_t edge_key(int i, int j, int k, int axis);

// Scratch memory for extracting one chunk; reuse it to avoid allocation.
struct ChunkScratch;

class SurfaceExtractor {
 public:
  SurfaceExtractor();
  ~SurfaceExtractor();
  SurfaceExtractor(const SurfaceExtractor&) = delete;
  SurfaceExtractor& operator=(const SurfaceExtractor&) = delete;

  // Extracts the cells owned by chunk id into out (cleared first); bumps
  // out.version. Does not allocate once out and the scratch have grown.
  void extract_chunk(const VoxelVolume& vol, int chunk_id, ChunkMesh& out);

 private:
  ChunkScratch* scratch_;
};

// Per-chunk meshes of a whole volume.
class Surface {
 public:
  explicit Surface(const VoxelVolume& vol);

  // Re-extracts every chunk. Returns the number of triangles.
  std::size_t extract_all();
  // Drains the volume's dirty chunks and re-extracts only those. Returns the
  // ids of chunks whose mesh changed (for GPU re-upload).
  std::vector<int> update();
  // Re-extracts the given chunks only.
  void extract(const std::vector<int>& chunk_ids);

  const std::vector<ChunkMesh>& chunks() const { return meshes_; }
  std::size_t triangle_count() const;
  std::size_t vertex_count() const;

 private:
  const VoxelVolume* vol_;
  SurfaceExtractor extractor_;
  std::vector<ChunkMesh> meshes_;
  std::vector<int> dirty_scratch_;
};

// One welded triangle mesh (vertices shared by edge key across chunks).
struct TriangleMesh {
  std::vector<MeshVertex> vertices;
  std::vector<std::uint32_t> indices;
  std::size_t triangle_count() const { return indices.size() / 3; }
};
TriangleMesh merge_chunks(const std::vector<ChunkMesh>& chunks);

// Writers. Units in files: millimetres (the user boundary), see docs/formats.md.
Status write_ply(const TriangleMesh& mesh, const std::string& path);
Status write_obj(const TriangleMesh& mesh, const std::string& path);

}  // namespace dentar::volume
