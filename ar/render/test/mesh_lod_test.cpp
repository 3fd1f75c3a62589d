// The tooth's level of detail (mesh_lod.h) on the procedural molar at the replay's voxel size:
// fewer triangles, a bounded geometric error, the materials kept, and no cracks between
// chunks (the coarse copies of two neighbouring chunks agree on their shared seam).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <tuple>

#include "dentar/ar/mesh_lod.h"
#include "dentar/volume/procedural_tooth.h"
#include "dentar/volume/surface.h"

namespace dentar::ar {
namespace {

using Pos = std::tuple<float, float, float>;

// Edges used by exactly one triangle after welding vertices at bit-identical positions: a
// closed surface has none; a crack between two chunks shows up as a row of them.
std::size_t open_edges(const std::vector<volume::ChunkMesh>& meshes) {
  std::map<Pos, int> ids;
  std::map<std::pair<int, int>, int> uses;
  for (const auto& m : meshes) {
    std::vector<int> id(m.vertices.size());
    for (std::size_t i = 0; i < m.vertices.size(); ++i) {
      const auto& p = m.vertices[i].position_m;
      id[i] = ids.try_emplace(Pos{p.x(), p.y(), p.z()}, static_cast<int>(ids.size())).first->second;
    }
    for (std::size_t t = 0; t + 2 < m.indices.size(); t += 3)
      for (int e = 0; e < 3; ++e) {
        int a = id[m.indices[t + e]], b = id[m.indices[t + (e + 1) % 3]];
        if (a > b) std::swap(a, b);
        ++uses[{a, b}];
      }
  }
  std::size_t n = 0;
  for (const auto& [e, k] : uses) n += k == 1;
  return n;
}

struct Molar {
  volume::VoxelVolume volume;
  std::unique_ptr<volume::Surface> surface;
  static Molar make() {
    volume::MolarParams p;
    p.voxel_mm = 0.15;  // the replay's lessons
    auto v = volume::make_molar(p);
    EXPECT_TRUE(v.ok()) << v.error();
    Molar m{std::move(v).value(), nullptr};
    m.surface = std::make_unique<volume::Surface>(m.volume);
    m.surface->extract_all();
    return m;
  }
};

TEST(MeshLod, FewerTrianglesBoundedErrorNoCracks) {
  const Molar molar = Molar::make();
  const auto& full = molar.surface->chunks();
  std::size_t full_tris = 0;
  for (const auto& c : full) full_tris += c.triangle_count();
  ASSERT_GT(full_tris, 20000u);
  EXPECT_EQ(open_edges(full), 0u) << "the full surface is closed";
  MeshLodScratch scratch;
  std::size_t last = full_tris;
  for (int cell : {2, 4}) {
    std::vector<volume::ChunkMesh> coarse(full.size());
    double err = 0;
    std::size_t tris = 0;
    for (std::size_t i = 0; i < full.size(); ++i) {
      if (full[i].empty()) continue;
      err = std::max(err, cluster_chunk_mesh(full[i], cell, coarse[i], scratch));
      tris += coarse[i].triangle_count();
      ASSERT_EQ(coarse[i].edge_keys.size(), coarse[i].vertices.size());
      // Materials: only those of the chunk's own vertices.
      std::set<int> in, out;
      for (const auto& v : full[i].vertices) in.insert(v.material);
      for (const auto& v : coarse[i].vertices) out.insert(v.material);
      for (int m : out) EXPECT_TRUE(in.count(m)) << "chunk " << i << " material " << m;
      for (std::uint32_t k : coarse[i].indices) ASSERT_LT(k, coarse[i].vertices.size());
    }
    std::printf("[ lod ] cell %d voxels: %zu of %zu triangles, error %.3f mm\n", cell, tris, full_tris, err * 1e3);
    EXPECT_LT(tris, last / 2) << "cell " << cell;
    // A member moves at most across its cell's diagonal (along its normal, much less on average).
    EXPECT_LE(err, std::sqrt(3.0) * cell * 0.15e-3) << "cell " << cell << ": the surface moves less than a cell";
    // No cracks: the coarse chunks still close up (a few open edges where clustering folds a
    // thin part, not a row along each seam).
    EXPECT_LE(open_edges(coarse), tris / 1000) << "cell " << cell;
    last = tris;
  }
}

// Each cluster of a chunk seam is made from the same members in both chunks, so the two
// copies of a seam vertex stay bit-identical: a chunk's coarse seam vertices all appear in its
// neighbours' coarse meshes.
TEST(MeshLod, SeamVerticesAreSharedByBothChunks) {
  const Molar molar = Molar::make();
  const auto& full = molar.surface->chunks();
  MeshLodScratch scratch;
  std::vector<volume::ChunkMesh> coarse(full.size());
  std::map<Pos, int> seen;  // position -> chunks holding it
  for (std::size_t i = 0; i < full.size(); ++i) {
    if (full[i].empty()) continue;
    cluster_chunk_mesh(full[i], 2, coarse[i], scratch);
    std::set<Pos> mine;
    for (const auto& v : coarse[i].vertices) mine.insert(Pos{v.position_m.x(), v.position_m.y(), v.position_m.z()});
    for (const auto& p : mine) ++seen[p];
  }
  // Seam vertices (on a chunk boundary plane): those whose first member's edge lies in one.
  std::size_t seam = 0, shared = 0;
  constexpr int kChunk = volume::VoxelVolume::kChunkSize;
  for (const auto& c : coarse)
    for (std::size_t i = 0; i < c.vertices.size(); ++i) {
      const volume::GridEdge e = volume::decode_edge_key(c.edge_keys[i]);
      const int idx[3] = {e.i, e.j, e.k};
      bool on = false;
      for (int a = 0; a < 3; ++a) on = on || (a != e.axis && idx[a] > 0 && idx[a] % kChunk == 0);
      if (!on) continue;
      ++seam;
      const auto& p = c.vertices[i].position_m;
      shared += seen[Pos{p.x(), p.y(), p.z()}] >= 2;
    }
  ASSERT_GT(seam, 500u);
  EXPECT_EQ(shared, seam) << "every coarse seam vertex is in both chunks' meshes";
}

}  // namespace
}  // namespace dentar::ar
