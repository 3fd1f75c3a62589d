// See mesh_lod.h.
#include "dentar/ar/mesh_lod.h"

#include <cmath>

#include "dentar/volume/voxel_volume.h"

namespace dentar::ar {

double cluster_chunk_mesh(const volume::ChunkMesh& cm, int cell, volume::ChunkMesh& out, MeshLodScratch& s) {
  constexpr int kChunk = volume::VoxelVolume::kChunkSize;
  constexpr std::uint64_t kNoCluster = ~std::uint64_t{0};
  out.vertices.clear();
  out.edge_keys.clear();
  out.indices.clear();
  s.map.clear();
  s.sums.clear();
  s.counts.clear();
  s.remap.resize(cm.vertices.size());
  for (std::size_t i = 0; i < cm.vertices.size(); ++i) {
    const volume::GridEdge e = volume::decode_edge_key(cm.edge_keys[i]);
    const int idx[3] = {e.i, e.j, e.k};
    int seam_axis = -1, seams = 0;
    for (int a = 0; a < 3; ++a)
      if (a != e.axis && idx[a] > 0 && idx[a] % kChunk == 0) {
        seam_axis = a;
        ++seams;
      }
    auto cell_of = [&](int a) {
      // floor division for indices down to -1
      return static_cast<std::uint64_t>((idx[a] + cell) / cell) & 0xffff;
    };
    std::uint64_t key = cell_of(0) | (cell_of(1) << 16) | (cell_of(2) << 32);
    if (seams >= 2) {
      key = kNoCluster;  // on a chunk edge: kept as is
    } else if (seams == 1) {
      // In-plane cell plus the plane (its index along the seam axis).
      key = (cell_of(0) * (seam_axis != 0)) | ((cell_of(1) * (seam_axis != 1)) << 16) |
            ((cell_of(2) * (seam_axis != 2)) << 32);
      key |= (static_cast<std::uint64_t>(idx[seam_axis]) & 0x3fff) << 48;
      key |= static_cast<std::uint64_t>(seam_axis + 1) << 62;
    }
    const auto next = static_cast<std::uint32_t>(out.vertices.size());
    std::uint32_t c = next;
    if (key != kNoCluster) c = s.map.try_emplace(key, next).first->second;
    if (c == next) {
      volume::MeshVertex v;
      v.position_m = Eigen::Vector3f::Zero();  // set from the mean below
      v.normal = Eigen::Vector3f::Zero();
      v.material = cm.vertices[i].material;
      out.vertices.push_back(v);
      out.edge_keys.push_back(cm.edge_keys[i]);
      s.sums.push_back(Eigen::Vector3d::Zero());
      s.counts.push_back(0);
    }
    s.sums[c] += cm.vertices[i].position_m.cast<double>();
    ++s.counts[c];
    out.vertices[c].normal += cm.vertices[i].normal;
    s.remap[i] = c;
  }
  for (std::size_t c = 0; c < out.vertices.size(); ++c) {
    volume::MeshVertex& v = out.vertices[c];
    v.position_m = (s.sums[c] / s.counts[c]).cast<float>();
    const float n = v.normal.norm();
    v.normal = n > 1e-12f ? Eigen::Vector3f(v.normal / n) : Eigen::Vector3f::UnitZ();
  }
  double err = 0;
  for (std::size_t i = 0; i < cm.vertices.size(); ++i) {
    const auto& mv = cm.vertices[i];
    err = std::max(err, static_cast<double>(std::abs(mv.normal.dot(out.vertices[s.remap[i]].position_m - mv.position_m))));
  }
  for (std::size_t t = 0; t + 2 < cm.indices.size(); t += 3) {
    const std::uint32_t a = s.remap[cm.indices[t]], b = s.remap[cm.indices[t + 1]], c = s.remap[cm.indices[t + 2]];
    if (a == b || b == c || a == c) continue;
    out.indices.insert(out.indices.end(), {a, b, c});
  }
  return err;
}

}  // namespace dentar::ar
