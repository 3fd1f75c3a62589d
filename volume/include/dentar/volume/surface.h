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
#include <memory>
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

// Mesh of the cells owned by one chunk. Vertices are unique per grid edge
// within the chunk; vertices on a chunk seam also appear (bit-identical) in
// the neighbouring chunk's mesh.
struct ChunkMesh {
  std::vector<MeshVertex> vertices;
  std::vector<std::uint64_t> edge_keys;  // global grid-edge key per vertex (same size)
  std::vector<std::uint32_t> indices;    // triangles, counter-clockwise seen from outside
  // Bumped by each SurfaceExtractor::extract_chunk; Surface bumps it only
  // when a re-extraction changes the mesh.
  std::uint64_t version = 0;
  std::size_t triangle_count() const { return indices.size() / 3; }
  bool empty() const { return indices.empty(); }
};

// Global key of the grid edge from voxel (i,j,k) to (i,j,k) + e_axis, axis in
// {0,1,2}. Indices may be -1 (cells in the border outside the volume) up to
// kMaxDim. Keys are unique per edge; packing: 20 bits per (index + 1), k
// highest, then 2 bits of axis.
std::uint64_t edge_key(int i, int j, int k, int axis);
struct GridEdge {
  int i, j, k, axis;
};
GridEdge decode_edge_key(std::uint64_t key);

// Scratch memory for extracting one chunk (about 1.5 MiB, allocated once per
// extractor: density block, edge->vertex table, output staging).
struct ChunkScratch;

class SurfaceExtractor {
 public:
  SurfaceExtractor();
  ~SurfaceExtractor();
  SurfaceExtractor(const SurfaceExtractor&) = delete;
  SurfaceExtractor& operator=(const SurfaceExtractor&) = delete;

  // Extracts the cells owned by chunk id into out (cleared first); bumps
  // out.version. Does not allocate once out and the scratch have grown.
  // Reads the chunk and its 26 neighbours; chunk_id must be valid.
  void extract_chunk(const VoxelVolume& vol, int chunk_id, ChunkMesh& out);

 private:
  friend class Surface;
  // Extracts into the scratch's staging arrays (no copy); counts returned.
  struct Staged {
    std::uint32_t n_vertices;
    std::size_t n_indices;
  };
  Staged extract_staged(const VoxelVolume& vol, int chunk_id);

  std::unique_ptr<ChunkScratch> scratch_;
};

// Per-chunk meshes of a whole volume. Thread: the mesher thread; the volume
// (which must outlive this) may be cut concurrently only through Cutter.
class Surface {
 public:
  explicit Surface(const VoxelVolume& vol);

  // Re-extracts every chunk. Returns the number of triangles. Classifies each
  // chunk first (all inside / all outside / mixed) and skips chunks whose 27
  // neighbourhood is uniform without reading it. Leaves the volume's dirty set
  // alone (another Surface may be draining it).
  std::size_t extract_all();
  // Drains the volume's dirty chunks and re-extracts only those. Returns the
  // ids of chunks whose mesh changed (for GPU re-upload), ascending. A cut
  // racing with the extraction re-marks its chunks dirty, so the next update
  // catches up.
  std::vector<int> update();
  // Re-extracts the given chunks only; returns the ids whose mesh changed.
  std::vector<int> extract(const std::vector<int>& chunk_ids);

  // Adopts a chunk mesh extracted by another Surface over the same volume
  // (a mesher thread's): the display side of double-buffered meshing. The
  // version is bumped so renderers re-upload it. chunk_id must be valid.
  void replace_chunk(int chunk_id, ChunkMesh mesh);
  const std::vector<ChunkMesh>& chunks() const { return meshes_; }
  std::size_t triangle_count() const;
  std::size_t vertex_count() const;

 private:
  const VoxelVolume* vol_;
  SurfaceExtractor extractor_;
  std::vector<ChunkMesh> meshes_;
  std::vector<std::uint8_t> classes_;  // per chunk, extract_all's skip test
  std::vector<int> dirty_scratch_;
};

// One welded triangle mesh (vertices shared by edge key across chunks).
struct TriangleMesh {
  std::vector<MeshVertex> vertices;
  std::vector<std::uint64_t> edge_keys;  // per vertex, unique
  std::vector<std::uint32_t> indices;    // counter-clockwise seen from outside
  std::size_t triangle_count() const { return indices.size() / 3; }
};
// Concatenates the chunk meshes in chunk order and welds vertices with equal
// edge keys (the first occurrence is kept). Empty chunks are skipped.
TriangleMesh merge_chunks(const std::vector<ChunkMesh>& chunks);

// Writers. Units in files: millimetres (the user boundary), see docs/formats.md.
// PLY: binary little-endian, per-vertex position, normal and material RGB.
// OBJ: text, v (mm) / vn / f v//vn, 1-based. Errors name the path.
Status write_ply(const TriangleMesh& mesh, const std::string& path);
Status write_obj(const TriangleMesh& mesh, const std::string& path);

}  // namespace dentar::volume
