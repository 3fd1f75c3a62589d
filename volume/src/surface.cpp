// Chunked marching cubes (see surface.h for ownership and seam rules).
//
// Per chunk: gather a block of density (local voxels -1..17, neighbours' data
// included, air outside the volume), build the 8-bit case of every owned cell
// row by row (rows without mixed cells are skipped), and emit triangles from
// the generated table (mc_table.cpp). Materials are read from the chunks only
// at vertices. Vertices are deduplicated through a per-chunk array indexed by
// local grid edge, reset afterwards by walking only the entries that were set.
#include "dentar/volume/surface.h"

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <cstring>

#include "mc_table.h"

namespace dentar::volume {
namespace {

constexpr int kC = VoxelVolume::kChunkSize;  // 16
constexpr int kB = kC + 4;                   // block side: local voxels -2..17
constexpr int kBS = kB * kB;
constexpr int kBN = kB * kB * kB;
constexpr int kG = kC + 2;  // edge-grid side: local grid points -1..16
constexpr int kGS = kG * kG;
constexpr int kGN = kG * kG * kG;
constexpr std::uint32_t kNoVertex = 0xffffffffu;
// Integer densities: inside iff d > 127, the same as d > kIsoDensity.
constexpr int kIsoFloor = 127;
static_assert(kIsoDensity > 127.0f && kIsoDensity < 128.0f);
// Surface::extract compares vertices bytewise up to the material.
static_assert(offsetof(MeshVertex, material) == 6 * sizeof(float));

constexpr int bidx(int x, int y, int z) { return (x + 2) + kB * (y + 2) + kBS * (z + 2); }
constexpr int gidx(int x, int y, int z) { return (x + 1) + kG * (y + 1) + kGS * (z + 1); }

constexpr int kBlockStride[3] = {1, kB, kBS};

// Per cube edge: offset of its base corner, its axis, and its slot in the
// per-chunk edge->vertex array relative to the cell's own slot.
struct EdgeInfo {
  int dx, dy, dz, axis, slot_offset;
};
constexpr std::array<EdgeInfo, mc::kNumEdges> make_edge_info() {
  std::array<EdgeInfo, mc::kNumEdges> info{};
  for (int e = 0; e < mc::kNumEdges; ++e) {
    const int c = mc::edge_base_corner(e);
    const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
    info[e] = {dx, dy, dz, mc::edge_axis(e), mc::edge_axis(e) * kGN + dx + kG * dy + kGS * dz};
  }
  return info;
}
constexpr auto kEdgeInfo = make_edge_info();

}  // namespace

std::uint64_t edge_key(int i, int j, int k, int axis) {
  assert(i >= -1 && j >= -1 && k >= -1 && i < (1 << 20) - 1 && j < (1 << 20) - 1 &&
         k < (1 << 20) - 1 && axis >= 0 && axis < 3 && "dentar::volume::edge_key: out of range");
  const auto u = [](int v) { return static_cast<std::uint64_t>(v + 1); };
  return (((u(k) << 40) | (u(j) << 20) | u(i)) << 2) | static_cast<std::uint64_t>(axis);
}

GridEdge decode_edge_key(std::uint64_t key) {
  const auto f = [](std::uint64_t v) { return static_cast<int>(v & 0xfffffu) - 1; };
  return {f(key >> 2), f(key >> 22), f(key >> 42), static_cast<int>(key & 3u)};
}

// Upper bounds for one chunk's output: every owned cell edge crossed, every
// owned cell at the table's maximum.
constexpr int kMaxChunkVertices = 3 * kGN;
constexpr int kMaxChunkIndices = (kC + 1) * (kC + 1) * (kC + 1) * 3 * mc::kMaxTriangles;

struct ChunkScratch {
  alignas(64) std::array<std::uint8_t, kBN> density;
  std::array<std::uint32_t, 3 * kGN> edge_vertex;        // kNoVertex when unset
  std::array<std::uint32_t, kMaxChunkVertices> touched;  // slots of edge_vertex that are set
  // Output staging: written without capacity checks, copied to the
  // ChunkMesh once per chunk.
  std::vector<MeshVertex> vertices;
  std::vector<std::uint64_t> keys;
  std::vector<std::uint32_t> indices;

  ChunkScratch() : vertices(kMaxChunkVertices), keys(kMaxChunkVertices), indices(kMaxChunkIndices) {
    density.fill(0);
    edge_vertex.fill(kNoVertex);
  }
};

namespace {

// The 27 chunks around (and including) the centre, nullptr where absent or
// outside the chunk grid. Index (dx+1) + 3*(dy+1) + 9*(dz+1).
struct Neighbourhood {
  std::array<const VoxelVolume::Chunk*, 27> chunk{};
  bool any = false;
};

Neighbourhood neighbourhood(const VoxelVolume& vol, const Eigen::Vector3i& cc) {
  Neighbourhood n;
  const Eigen::Vector3i& cd = vol.chunk_dims();
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int x = cc.x() + dx, y = cc.y() + dy, z = cc.z() + dz;
        const VoxelVolume::Chunk* c = nullptr;
        if (x >= 0 && y >= 0 && z >= 0 && x < cd.x() && y < cd.y() && z < cd.z())
          c = vol.chunk(vol.chunk_id(x, y, z));
        n.chunk[static_cast<std::size_t>((dx + 1) + 3 * (dy + 1) + 9 * (dz + 1))] = c;
        n.any = n.any || c != nullptr;
      }
  return n;
}

// Copies the density of the block around chunk cc for local voxels -1..17
// (the -2 planes stay zero: only the first chunk along an axis reads them,
// and for it they lie outside the volume). Interior chunks: three copies per
// row from pointers fetched once per 3x3 neighbour segment.
void gather_density_interior(const Neighbourhood& nb, std::uint8_t* dst) {
  constexpr int kSegLo[3] = {-1, 0, kC}, kSegHi[3] = {0, kC, kC + 2};  // [lo, hi)
  for (int sz = 0; sz < 3; ++sz) {
    for (int sy = 0; sy < 3; ++sy) {
      const std::size_t nbi = static_cast<std::size_t>(3 * sy + 9 * sz);
      const VoxelVolume::Chunk* c0 = nb.chunk[nbi];
      const VoxelVolume::Chunk* c1 = nb.chunk[nbi + 1];
      const VoxelVolume::Chunk* c2 = nb.chunk[nbi + 2];
      for (int lz = kSegLo[sz]; lz < kSegHi[sz]; ++lz) {
        for (int ly = kSegLo[sy]; ly < kSegHi[sy]; ++ly) {
          std::uint8_t* row = dst + bidx(-1, ly, lz);
          const int src = kC * (ly - kC * (sy - 1)) + kC * kC * (lz - kC * (sz - 1));
          row[0] = c0 ? c0->density[static_cast<std::size_t>(src + kC - 1)] : 0;
          if (c1)
            std::memcpy(row + 1, c1->density.data() + src, kC);
          else
            std::memset(row + 1, 0, kC);
          if (c2)
            std::memcpy(row + 1 + kC, c2->density.data() + src, 2);
          else
            std::memset(row + 1 + kC, 0, 2);
        }
      }
    }
  }
}

// General version for chunks whose block reaches outside the volume: voxels
// outside read as 0 (air). Also leaves the -2 planes alone.
void gather_density(const VoxelVolume& vol, const Eigen::Vector3i& cc, const Neighbourhood& nb,
                    std::uint8_t* dst) {
  const Eigen::Vector3i& dims = vol.dims();
  const Eigen::Vector3i base = cc * kC;
  // The three x pieces of a row: (source chunk dx, first local x, first block
  // x, length), clipped to the volume.
  struct Piece {
    int dx, src, dst, len;
  };
  Piece pieces[3];
  int n_pieces = 0, covered = 0;
  const int starts[3] = {-1, 0, kC}, lens[3] = {1, kC, 2};
  for (int p = 0; p < 3; ++p) {
    int lo = base.x() + starts[p], hi = lo + lens[p];  // global [lo, hi)
    lo = std::max(lo, 0);
    hi = std::min(hi, dims.x());
    if (lo >= hi) continue;
    const int dx = p - 1;
    pieces[n_pieces++] = {dx, lo - (base.x() + dx * kC), lo - base.x() + 1, hi - lo};
    covered += hi - lo;
  }
  const bool clipped_x = covered != kB - 1;
  for (int bz = 1; bz < kB; ++bz) {
    const int lz = bz - 2, gz = base.z() + lz;
    const int dz = lz < 0 ? -1 : (lz >= kC ? 1 : 0);
    for (int by = 1; by < kB; ++by) {
      std::uint8_t* row = dst + bz * kBS + by * kB + 1;  // starts at local x = -1
      const int ly = by - 2, gy = base.y() + ly;
      if (gy < 0 || gy >= dims.y() || gz < 0 || gz >= dims.z()) {
        std::memset(row, 0, kB - 1);
        continue;
      }
      if (clipped_x) std::memset(row, 0, kB - 1);
      const int dy = ly < 0 ? -1 : (ly >= kC ? 1 : 0);
      const int src_row = kC * (ly - dy * kC) + kC * kC * (lz - dz * kC);
      for (int p = 0; p < n_pieces; ++p) {
        const Piece& pc = pieces[p];
        const VoxelVolume::Chunk* c =
            nb.chunk[static_cast<std::size_t>((pc.dx + 1) + 3 * (dy + 1) + 9 * (dz + 1))];
        const auto len = static_cast<std::size_t>(pc.len);
        if (c)
          std::memcpy(row + pc.dst, c->density.data() + src_row + pc.src, len);
        else
          std::memset(row + pc.dst, 0, len);
      }
    }
  }
}

// Chunk classes for skipping uniform neighbourhoods without gathering.
constexpr std::uint8_t kAllOutside = 0, kAllInside = 1, kMixed = 2;

std::uint8_t classify(const VoxelVolume::Chunk* c) {
  if (!c) return kAllOutside;
  unsigned any_in = 0, all_in = 1;
  for (const std::uint8_t d : c->density) {
    const unsigned in = d > kIsoFloor ? 1u : 0u;
    any_in |= in;
    all_in &= in;
  }
  return all_in ? kAllInside : (any_in ? kMixed : kAllOutside);
}

// True when the chunk and its 26 neighbours (outside the grid: air) are all
// uniformly inside or all uniformly outside: then no owned cell is crossed.
bool uniform_neighbourhood(const VoxelVolume& vol, const Eigen::Vector3i& cc,
                           const std::vector<std::uint8_t>& classes) {
  const Eigen::Vector3i& cd = vol.chunk_dims();
  const std::uint8_t centre =
      classes[static_cast<std::size_t>(vol.chunk_id(cc.x(), cc.y(), cc.z()))];
  if (centre == kMixed) return false;
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int x = cc.x() + dx, y = cc.y() + dy, z = cc.z() + dz;
        const bool in_grid = x >= 0 && y >= 0 && z >= 0 && x < cd.x() && y < cd.y() && z < cd.z();
        const std::uint8_t c =
            in_grid ? classes[static_cast<std::size_t>(vol.chunk_id(x, y, z))] : kAllOutside;
        if (c != centre) return false;
      }
  return true;
}

}  // namespace

SurfaceExtractor::SurfaceExtractor() : scratch_(std::make_unique<ChunkScratch>()) {}
SurfaceExtractor::~SurfaceExtractor() = default;

void SurfaceExtractor::extract_chunk(const VoxelVolume& vol, int chunk_id, ChunkMesh& out) {
  assert(chunk_id >= 0 && chunk_id < vol.num_chunks() &&
         "dentar::volume::SurfaceExtractor::extract_chunk: chunk id out of range");
  const Staged st = extract_staged(vol, chunk_id);
  const ChunkScratch& s = *scratch_;
  out.vertices.assign(s.vertices.data(), s.vertices.data() + st.n_vertices);
  out.edge_keys.assign(s.keys.data(), s.keys.data() + st.n_vertices);
  out.indices.assign(s.indices.data(), s.indices.data() + st.n_indices);
  ++out.version;
}

SurfaceExtractor::Staged SurfaceExtractor::extract_staged(const VoxelVolume& vol, int chunk_id) {
  const Eigen::Vector3i cc = vol.chunk_coords(chunk_id);
  const Neighbourhood nb = neighbourhood(vol, cc);
  if (!nb.any) return {0, 0};  // all air around: no surface

  ChunkScratch& s = *scratch_;
  std::uint8_t* const D = s.density.data();
  bool interior = true;
  for (int a = 0; a < 3; ++a)
    interior = interior && cc[a] > 0 && (cc[a] + 1) * kC + 2 <= vol.dims()[a];
  if (interior)
    gather_density_interior(nb, D);
  else
    gather_density(vol, cc, nb, D);

  const mc::CaseTable& table = mc::case_table();
  const Eigen::Vector3i base = cc * kC;
  const Eigen::Vector3i& dims = vol.dims();
  const Eigen::Vector3d& origin = vol.origin();
  const Eigen::Vector3d& spacing = vol.spacing();
  // Central differences in density units per metre.
  const float inv2s[3] = {static_cast<float>(0.5 / spacing.x()),
                          static_cast<float>(0.5 / spacing.y()),
                          static_cast<float>(0.5 / spacing.z())};
  // Tooth-frame coordinate of each local grid index -1..16 per axis. Each
  // value depends only on the global index, so seams agree bit for bit.
  float grid_m[3][kG];
  for (int a = 0; a < 3; ++a)
    for (int g = 0; g < kG; ++g)
      grid_m[a][g] =
          static_cast<float>(origin[a] + spacing[a] * static_cast<double>(base[a] + g - 1));
  std::uint32_t* const ev = s.edge_vertex.data();
  MeshVertex* const vout = s.vertices.data();
  std::uint64_t* const kout = s.keys.data();
  std::uint32_t* const iout = s.indices.data();
  std::uint32_t nv = 0;
  std::size_t ni = 0;

  // Material of local voxel (x,y,z) in -1..16, read from the chunks directly
  // (only needed at vertices, so cheaper than gathering a block).
  auto material_at = [&](int x, int y, int z) -> std::uint8_t {
    if (!interior) {
      const int gx = base.x() + x, gy = base.y() + y, gz = base.z() + z;
      if (gx < 0 || gy < 0 || gz < 0 || gx >= dims.x() || gy >= dims.y() || gz >= dims.z())
        return 0;
    }
    const VoxelVolume::Chunk* c = nb.chunk[static_cast<std::size_t>(
        ((x >> 4) + 1) + 3 * ((y >> 4) + 1) + 9 * ((z >> 4) + 1))];
    return c ? c->material[static_cast<std::size_t>(chunk_local_index(x & 15, y & 15, z & 15))] : 0;
  };

  // First chunk along an axis also owns the cells starting at -1.
  const int x0 = cc.x() == 0 ? -1 : 0;
  const int y0 = cc.y() == 0 ? -1 : 0;
  const int z0 = cc.z() == 0 ? -1 : 0;

  auto make_vertex = [&](int gx, int gy, int gz, int axis) -> std::uint32_t {
    // Always from the lower-index endpoint p to q = p + e_axis, so the two
    // chunks sharing a seam edge compute bit-identical results.
    const int p = bidx(gx, gy, gz);
    const int q = p + kBlockStride[axis];
    const float d0 = D[p], d1 = D[q];
    const float t = (kIsoDensity - d0) / (d1 - d0);
    float g[3];
    for (int a = 0; a < 3; ++a) {
      const int st = kBlockStride[a];
      const int g0 = D[p + st] - D[p - st], g1 = D[q + st] - D[q - st];
      g[a] = (static_cast<float>(g0) + t * static_cast<float>(g1 - g0)) * inv2s[a];
    }
    MeshVertex& v = vout[nv];
    if (g[0] != 0.0f || g[1] != 0.0f || g[2] != 0.0f) {
      // Outward = toward lower density. Normalised after the cell loop, where
      // the sqrt/div latency of many vertices overlaps.
      for (int a = 0; a < 3; ++a) v.normal[a] = -g[a];
    } else {
      // Flat gradient: fall back to the edge direction toward its air end.
      for (int a = 0; a < 3; ++a) v.normal[a] = 0.0f;
      v.normal[axis] = d0 > d1 ? 1.0f : -1.0f;
    }
    const int lg[3] = {gx, gy, gz};
    for (int a = 0; a < 3; ++a) v.position_m[a] = grid_m[a][lg[a] + 1];
    v.position_m[axis] = static_cast<float>(
        origin[axis] +
        spacing[axis] * (static_cast<double>(base[axis] + lg[axis]) + static_cast<double>(t)));
    // Inside endpoint's material, unless the outside one is pulp.
    const bool p_inside = d0 > d1;
    int qx = gx, qy = gy, qz = gz;
    (axis == 0 ? qx : axis == 1 ? qy : qz) += 1;
    const std::uint8_t mp = material_at(gx, gy, gz), mq = material_at(qx, qy, qz);
    const std::uint8_t m_in = p_inside ? mp : mq, m_out = p_inside ? mq : mp;
    constexpr auto kPulp = static_cast<std::uint8_t>(Material::kPulp);
    v.material = m_out == kPulp ? kPulp : m_in;
    kout[nv] = edge_key(base.x() + gx, base.y() + gy, base.z() + gz, axis);
    return nv++;
  };

  std::uint8_t cases[kC + 1];
  for (int z = z0; z < kC; ++z) {
    for (int y = y0; y < kC; ++y) {
      const std::uint8_t* r00 = D + bidx(0, y, z);
      const std::uint8_t* r10 = r00 + kB;
      const std::uint8_t* r01 = r00 + kBS;
      const std::uint8_t* r11 = r01 + kB;
      // cases[x + 1] for cells x = -1..15; corner c = bx + 2 by + 4 bz. A row
      // without mixed cells (most of them) costs only this vectorised loop.
      unsigned mixed = 0;
      for (int x = -1; x < kC; ++x) {
        const auto in = [](std::uint8_t d) { return d > kIsoFloor ? 1u : 0u; };
        const unsigned c = in(r00[x]) | (in(r00[x + 1]) << 1) | (in(r10[x]) << 2) |
                           (in(r10[x + 1]) << 3) | (in(r01[x]) << 4) | (in(r01[x + 1]) << 5) |
                           (in(r11[x]) << 6) | (in(r11[x + 1]) << 7);
        cases[x + 1] = static_cast<std::uint8_t>(c);
        mixed |= static_cast<unsigned>(static_cast<std::uint8_t>(c + 1) > 1);
      }
      if (!mixed) continue;
      for (int x = x0; x < kC; ++x) {
        const int c = cases[x + 1];
        if (c == 0 || c == 255) continue;
        const int cell_slot = gidx(x, y, z);
        // Resolve each crossed edge once, then emit the case's triangles.
        std::uint32_t local[mc::kNumEdges];
        for (unsigned bits = table.crossed_edges[static_cast<std::size_t>(c)]; bits;
             bits &= bits - 1) {
          const int edge = std::countr_zero(bits);
          const EdgeInfo& e = kEdgeInfo[static_cast<std::size_t>(edge)];
          const int slot = cell_slot + e.slot_offset;
          std::uint32_t v = ev[slot];
          if (v == kNoVertex) {
            s.touched[nv] = static_cast<std::uint32_t>(slot);
            v = make_vertex(x + e.dx, y + e.dy, z + e.dz, e.axis);
            ev[slot] = v;
          }
          local[edge] = v;
        }
        const std::uint8_t* tri = table.triangles[static_cast<std::size_t>(c)].data();
        const int n = 3 * table.num_triangles[static_cast<std::size_t>(c)];
        for (int i = 0; i < n; ++i) iout[ni++] = local[tri[i]];
      }
    }
  }
  for (std::uint32_t i = 0; i < nv; ++i) ev[s.touched[i]] = kNoVertex;
  // Only non-zero gradients reach here (a multiple of 0.5/255 density units
  // per voxel up to float rounding, far from underflow), so no division by
  // zero; the same code normalises seam vertices in both chunks.
  for (std::uint32_t i = 0; i < nv; ++i) {
    Eigen::Vector3f& n = vout[i].normal;
    const float inv = 1.0f / std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    n[0] *= inv;
    n[1] *= inv;
    n[2] *= inv;
  }
  return {nv, ni};
}

// ---------------------------------------------------------------------------
// Surface

Surface::Surface(const VoxelVolume& vol)
    : vol_(&vol), meshes_(static_cast<std::size_t>(vol.num_chunks())) {}

std::size_t Surface::extract_all() {
  // Classify every chunk once (reads each allocated chunk's 4 KiB of
  // density), then skip chunks in uniform neighbourhoods without gathering.
  const int n = vol_->num_chunks();
  classes_.resize(static_cast<std::size_t>(n));
  for (int c = 0; c < n; ++c) classes_[static_cast<std::size_t>(c)] = classify(vol_->chunk(c));
  std::size_t tris = 0;
  for (int c = 0; c < n; ++c) {
    ChunkMesh& m = meshes_[static_cast<std::size_t>(c)];
    if (uniform_neighbourhood(*vol_, vol_->chunk_coords(c), classes_)) {
      m.vertices.clear();
      m.edge_keys.clear();
      m.indices.clear();
      ++m.version;
      continue;
    }
    extractor_.extract_chunk(*vol_, c, m);
    tris += m.triangle_count();
  }
  return tris;
}

std::vector<int> Surface::extract(const std::vector<int>& chunk_ids) {
  std::vector<int> changed;
  const ChunkScratch& s = *extractor_.scratch_;
  for (const int c : chunk_ids) {
    ChunkMesh& cur = meshes_[static_cast<std::size_t>(c)];
    const SurfaceExtractor::Staged st = extractor_.extract_staged(*vol_, c);
    // Compare the staged result with the current mesh before copying, so an
    // unchanged chunk costs no copy and keeps its version.
    bool same = cur.vertices.size() == st.n_vertices && cur.indices.size() == st.n_indices &&
                std::equal(cur.edge_keys.begin(), cur.edge_keys.end(), s.keys.begin()) &&
                std::equal(cur.indices.begin(), cur.indices.end(), s.indices.begin());
    // Bitwise over the meaningful bytes (position, normal, material; not the
    // padding after material).
    constexpr std::size_t kVertexBytes = offsetof(MeshVertex, material) + 1;
    for (std::uint32_t i = 0; same && i < st.n_vertices; ++i)
      same = std::memcmp(&cur.vertices[i], &s.vertices[i], kVertexBytes) == 0;
    if (same) continue;
    cur.vertices.assign(s.vertices.data(), s.vertices.data() + st.n_vertices);
    cur.edge_keys.assign(s.keys.data(), s.keys.data() + st.n_vertices);
    cur.indices.assign(s.indices.data(), s.indices.data() + st.n_indices);
    ++cur.version;
    changed.push_back(c);
  }
  return changed;
}

std::vector<int> Surface::update() {
  dirty_scratch_.clear();
  vol_->drain_dirty(dirty_scratch_);
  return extract(dirty_scratch_);
}

std::size_t Surface::triangle_count() const {
  std::size_t n = 0;
  for (const auto& m : meshes_) n += m.triangle_count();
  return n;
}

std::size_t Surface::vertex_count() const {
  std::size_t n = 0;
  for (const auto& m : meshes_) n += m.vertices.size();
  return n;
}

// ---------------------------------------------------------------------------
// Merging

namespace {
// True when the edge can belong to cells of two chunks: one of its two
// transverse coordinates sits on an interior chunk boundary.
bool on_seam(std::uint64_t key) {
  const GridEdge g = decode_edge_key(key);
  const int idx[3] = {g.i, g.j, g.k};
  for (int a = 0; a < 3; ++a)
    if (a != g.axis && idx[a] > 0 && (idx[a] & (kC - 1)) == 0) return true;
  return false;
}
}  // namespace

TriangleMesh merge_chunks(const std::vector<ChunkMesh>& chunks) {
  std::size_t nv = 0, ni = 0;
  for (const auto& c : chunks) {
    nv += c.vertices.size();
    ni += c.indices.size();
  }
  // Flat numbering of all chunk vertices; rep[f] is the first flat vertex
  // with the same edge key (only seam vertices can have one).
  std::vector<std::uint32_t> rep(nv);
  std::vector<std::pair<std::uint64_t, std::uint32_t>> seam;
  seam.reserve(nv / 4);
  {
    std::uint32_t f = 0;
    for (const auto& c : chunks)
      for (std::size_t i = 0; i < c.vertices.size(); ++i, ++f) {
        rep[f] = f;
        if (on_seam(c.edge_keys[i])) seam.emplace_back(c.edge_keys[i], f);
      }
  }
  std::sort(seam.begin(), seam.end());
  for (std::size_t i = 1; i < seam.size(); ++i)
    if (seam[i].first == seam[i - 1].first) rep[seam[i].second] = rep[seam[i - 1].second];

  TriangleMesh m;
  m.vertices.reserve(nv);
  m.edge_keys.reserve(nv);
  m.indices.reserve(ni);
  std::vector<std::uint32_t> remap(nv);
  std::uint32_t f = 0;
  for (const auto& c : chunks) {
    const std::uint32_t first = f;
    for (std::size_t i = 0; i < c.vertices.size(); ++i, ++f) {
      if (rep[f] == f) {
        remap[f] = static_cast<std::uint32_t>(m.vertices.size());
        m.vertices.push_back(c.vertices[i]);
        m.edge_keys.push_back(c.edge_keys[i]);
      } else {
        remap[f] = remap[rep[f]];  // rep[f] < f: already numbered
      }
    }
    for (const std::uint32_t idx : c.indices) m.indices.push_back(remap[first + idx]);
  }
  return m;
}

void Surface::replace_chunk(int chunk_id, ChunkMesh mesh) {
  ChunkMesh& m = meshes_.at(static_cast<std::size_t>(chunk_id));
  mesh.version = m.version + 1;
  m = std::move(mesh);
}

}  // namespace dentar::volume
