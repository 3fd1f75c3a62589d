// Surface extraction: watertightness, seams, normals, enclosed volume,
// incremental == full under random bur strokes, and the mesh writers.
#include "dentar/volume/surface.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <map>
#include <random>
#include <sstream>
#include <unordered_map>

#include "dentar/volume/bur.h"
#include "dentar/volume/cutter.h"
#include "dentar/volume/material.h"
#include "dentar/volume/procedural_tooth.h"
#include "testutil.h"

namespace dentar::volume {
namespace {

constexpr double kPi = 3.14159265358979323846;

VolumeGeometry geometry(int nx, int ny, int nz, double spacing_m = 1e-4) {
  VolumeGeometry g;
  g.dims = {nx, ny, nz};
  g.spacing = Eigen::Vector3d::Constant(spacing_m);
  g.origin = {-1e-3, 2e-3, 0.5e-3};
  return g;
}

// Density ramps linearly across the sphere surface (64 units per voxel), so
// linear interpolation along edges recovers the surface closely.
VoxelVolume sphere_volume(const Eigen::Vector3i& dims, const Eigen::Vector3d& centre_vox,
                          double radius_vox) {
  VoxelVolume vol(geometry(dims.x(), dims.y(), dims.z()));
  for (int k = 0; k < dims.z(); ++k)
    for (int j = 0; j < dims.y(); ++j)
      for (int i = 0; i < dims.x(); ++i) {
        const double d = (Eigen::Vector3d(i, j, k) - centre_vox).norm();
        const double v = std::clamp(127.5 + 64.0 * (radius_vox - d), 0.0, 255.0);
        const auto dens = static_cast<std::uint8_t>(std::lround(v));
        if (dens > 0) vol.set(i, j, k, dens, Material::kEnamel);
      }
  return vol;
}

struct EdgeCheck {
  std::size_t bad_directed = 0;  // directed edge used more than once
  std::size_t open = 0;          // directed edge whose reverse is missing
  std::size_t degenerate = 0;    // triangle repeating a vertex index
};

EdgeCheck check_watertight(const TriangleMesh& m) {
  std::unordered_map<std::uint64_t, int> directed;
  EdgeCheck r;
  for (std::size_t t = 0; t < m.triangle_count(); ++t) {
    const std::uint32_t* v = &m.indices[3 * t];
    if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2]) ++r.degenerate;
    for (int k = 0; k < 3; ++k) ++directed[(std::uint64_t{v[k]} << 32) | v[(k + 1) % 3]];
  }
  for (const auto& [key, n] : directed) {
    if (n != 1) ++r.bad_directed;
    if (!directed.count((key << 32) | (key >> 32))) ++r.open;
  }
  return r;
}

void expect_watertight(const TriangleMesh& m) {
  ASSERT_GT(m.triangle_count(), 0u);
  const EdgeCheck r = check_watertight(m);
  EXPECT_EQ(r.bad_directed, 0u) << "directed edges used more than once";
  EXPECT_EQ(r.open, 0u) << "edges used by one triangle or inconsistently oriented";
  EXPECT_EQ(r.degenerate, 0u);
}

double enclosed_volume_m3(const TriangleMesh& m) {
  double v6 = 0;
  for (std::size_t t = 0; t < m.triangle_count(); ++t) {
    const Eigen::Vector3d a = m.vertices[m.indices[3 * t]].position_m.cast<double>();
    const Eigen::Vector3d b = m.vertices[m.indices[3 * t + 1]].position_m.cast<double>();
    const Eigen::Vector3d c = m.vertices[m.indices[3 * t + 2]].position_m.cast<double>();
    v6 += a.dot(b.cross(c));
  }
  return v6 / 6.0;
}

std::size_t duplicate_positions(const TriangleMesh& m) {
  std::vector<std::array<float, 3>> p;
  for (const auto& v : m.vertices)
    p.push_back({v.position_m.x(), v.position_m.y(), v.position_m.z()});
  std::sort(p.begin(), p.end());
  const auto last = std::unique(p.begin(), p.end());
  return static_cast<std::size_t>(p.end() - last);
}

bool bit_equal(const MeshVertex& a, const MeshVertex& b) {
  return std::memcmp(a.position_m.data(), b.position_m.data(), sizeof(float) * 3) == 0 &&
         std::memcmp(a.normal.data(), b.normal.data(), sizeof(float) * 3) == 0 &&
         a.material == b.material;
}

// Triangles as edge-key triples, each rotated so its smallest key comes first
// (orientation kept), sorted.
using KeyTri = std::array<std::uint64_t, 3>;
std::vector<KeyTri> canonical_triangles(const std::vector<ChunkMesh>& chunks) {
  std::vector<KeyTri> out;
  for (const auto& c : chunks)
    for (std::size_t t = 0; t < c.triangle_count(); ++t) {
      KeyTri k = {c.edge_keys[c.indices[3 * t]], c.edge_keys[c.indices[3 * t + 1]],
                  c.edge_keys[c.indices[3 * t + 2]]};
      std::rotate(k.begin(), std::min_element(k.begin(), k.end()), k.end());
      out.push_back(k);
    }
  std::sort(out.begin(), out.end());
  return out;
}

TEST(EdgeKey, RoundTripsAndIsUnique) {
  std::vector<std::uint64_t> keys;
  for (int k = -1; k < 3; ++k)
    for (int j = -1; j < 3; ++j)
      for (int i = -1; i < 3; ++i)
        for (int a = 0; a < 3; ++a) {
          const std::uint64_t key = edge_key(i, j, k, a);
          const GridEdge g = decode_edge_key(key);
          EXPECT_EQ(g.i, i);
          EXPECT_EQ(g.j, j);
          EXPECT_EQ(g.k, k);
          EXPECT_EQ(g.axis, a);
          keys.push_back(key);
        }
  const GridEdge big = decode_edge_key(edge_key(kMaxDim, kMaxDim - 1, 4000, 2));
  EXPECT_EQ(big.i, kMaxDim);
  EXPECT_EQ(big.k, 4000);
  std::sort(keys.begin(), keys.end());
  EXPECT_EQ(std::unique(keys.begin(), keys.end()), keys.end());
}

TEST(Surface, EmptyVolumeHasNoTriangles) {
  VoxelVolume vol(geometry(20, 33, 17));
  Surface s(vol);
  EXPECT_EQ(s.extract_all(), 0u);
  EXPECT_EQ(s.vertex_count(), 0u);
}

TEST(Surface, SphereIsWatertightOutwardAndHasTheRightVolume) {
  const Eigen::Vector3d c(23.3, 24.1, 22.7);
  const double r = 15.2;  // spans 3x3x3 chunks
  VoxelVolume vol = sphere_volume({48, 48, 48}, c, r);
  Surface s(vol);
  const std::size_t tris = s.extract_all();
  EXPECT_EQ(tris, s.triangle_count());
  const TriangleMesh m = merge_chunks(s.chunks());
  EXPECT_EQ(m.triangle_count(), tris);
  expect_watertight(m);
  EXPECT_EQ(duplicate_positions(m), 0u);
  EXPECT_LT(m.vertices.size(), s.vertex_count()) << "seam vertices were not welded";

  const double h = 1e-4;
  const Eigen::Vector3f centre_m = (vol.origin() + h * c).cast<float>();
  float worst = 1.0f;
  for (const auto& v : m.vertices) {
    EXPECT_NEAR(v.normal.norm(), 1.0f, 1e-5f);
    const Eigen::Vector3f radial = (v.position_m - centre_m).normalized();
    worst = std::min(worst, v.normal.dot(radial));
    EXPECT_EQ(v.material, static_cast<std::uint8_t>(Material::kEnamel));
  }
  EXPECT_GT(worst, 0.9f);

  const double expected = 4.0 / 3.0 * kPi * std::pow(r * h, 3);
  EXPECT_NEAR(enclosed_volume_m3(m) / expected, 1.0, 0.01);
}

// A shape spanning many chunks, touching every face of a box whose sizes are
// not multiples of 16, with cavities and random noise that produces every
// ambiguous face configuration: the merged mesh must still be closed.
TEST(Surface, NoisyShapeTouchingTheBorderIsWatertight) {
  const Eigen::Vector3i dims(37, 50, 41);
  VoxelVolume vol(geometry(dims.x(), dims.y(), dims.z(), 0.2e-3));
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> noise(0, 255);
  for (int k = 0; k < dims.z(); ++k)
    for (int j = 0; j < dims.y(); ++j)
      for (int i = 0; i < dims.x(); ++i) {
        int d = 255;
        const double cav = (Eigen::Vector3d(i, j, k) - Eigen::Vector3d(18, 20, 20)).norm();
        if (cav < 8) d = 0;
        if (i > 24 && j > 30) d = noise(rng);  // a noisy block touching two faces
        if (k < 3 && (i + j) % 5 == 0) d = 0;  // holes through the bottom face
        vol.set(i, j, k, static_cast<std::uint8_t>(d), d > 0 ? Material::kDentin : Material::kAir);
      }
  Surface s(vol);
  ASSERT_GT(s.extract_all(), 0u);
  const TriangleMesh m = merge_chunks(s.chunks());
  expect_watertight(m);
  EXPECT_EQ(duplicate_positions(m), 0u);
  for (const auto& v : m.vertices) {
    ASSERT_TRUE(v.normal.allFinite());
    EXPECT_NEAR(v.normal.norm(), 1.0f, 1e-5f);
    ASSERT_TRUE(v.position_m.allFinite());
  }
  // A solid box touching the volume border closes at the border: its mesh
  // reaches the half-voxel outside the first and last voxel centres.
  float min_x = 1e9f, max_x = -1e9f;
  for (const auto& v : m.vertices) {
    min_x = std::min(min_x, v.position_m.x());
    max_x = std::max(max_x, v.position_m.x());
  }
  EXPECT_LT(min_x, vol.origin().x());
  EXPECT_GT(max_x, vol.voxel_center(dims.x() - 1, 0, 0).x());
}

TEST(Surface, SeamVerticesAreBitIdenticalInBothChunks) {
  VoxelVolume vol = sphere_volume({64, 40, 40}, {31.6, 19.2, 20.4}, 17.0);
  Surface s(vol);
  s.extract_all();
  std::map<std::uint64_t, MeshVertex> first;
  std::size_t shared = 0;
  for (const auto& c : s.chunks()) {
    ASSERT_EQ(c.edge_keys.size(), c.vertices.size());
    std::vector<std::uint64_t> keys = c.edge_keys;
    std::sort(keys.begin(), keys.end());
    EXPECT_EQ(std::unique(keys.begin(), keys.end()), keys.end()) << "duplicate within a chunk";
    for (std::size_t i = 0; i < c.vertices.size(); ++i) {
      auto [it, inserted] = first.emplace(c.edge_keys[i], c.vertices[i]);
      if (inserted) continue;
      ++shared;
      EXPECT_TRUE(bit_equal(it->second, c.vertices[i])) << "key " << c.edge_keys[i];
    }
  }
  EXPECT_GT(shared, 100u);
  const TriangleMesh m = merge_chunks(s.chunks());
  EXPECT_EQ(m.vertices.size(), first.size());
  EXPECT_EQ(duplicate_positions(m), 0u);
}

TEST(Surface, OpenedPulpIsColouredAsPulp) {
  // Dentin slab with a pulp pocket (low density, below iso): vertices on
  // dentin-pulp edges take the pulp label, dentin-air edges stay dentin.
  VoxelVolume vol(geometry(24, 24, 24));
  for (int k = 4; k < 20; ++k)
    for (int j = 4; j < 20; ++j)
      for (int i = 4; i < 20; ++i) {
        const bool pocket = i >= 9 && i < 14 && j >= 9 && j < 14 && k >= 9 && k < 14;
        vol.set(i, j, k, pocket ? 70 : 200, pocket ? Material::kPulp : Material::kDentin);
      }
  Surface s(vol);
  s.extract_all();
  const TriangleMesh m = merge_chunks(s.chunks());
  expect_watertight(m);
  std::size_t pulp = 0, dentin = 0;
  for (std::size_t i = 0; i < m.vertices.size(); ++i) {
    const GridEdge g = decode_edge_key(m.edge_keys[i]);
    const bool near_pocket =
        g.i >= 7 && g.i <= 14 && g.j >= 7 && g.j <= 14 && g.k >= 7 && g.k <= 14;
    const auto mat = static_cast<Material>(m.vertices[i].material);
    EXPECT_EQ(mat, near_pocket ? Material::kPulp : Material::kDentin) << i;
    (mat == Material::kPulp ? pulp : dentin)++;
  }
  EXPECT_GT(pulp, 0u);
  EXPECT_GT(dentin, 0u);
}

TEST(Surface, UpdateReportsOnlyChangedChunks) {
  VoxelVolume vol = sphere_volume({48, 48, 48}, {24, 24, 24}, 14.0);
  Surface s(vol);
  s.extract_all();
  EXPECT_TRUE(s.update().empty());
  // Dirty but unchanged: re-extracted, not reported.
  vol.mark_dirty(vol.chunk_id(1, 1, 1));
  EXPECT_TRUE(s.update().empty());
  // Carve a voxel on the surface at the +x pole.
  const int i = 24 + 14, j = 24, k = 24;
  const std::uint64_t before =
      s.chunks()[static_cast<std::size_t>(vol.chunk_id(i / 16, 1, 1))].version;
  vol.set(i, j, k, 0, Material::kAir);
  vol.mark_dirty_box(Eigen::Vector3i(i, j, k) - Eigen::Vector3i::Constant(2),
                     Eigen::Vector3i(i, j, k) + Eigen::Vector3i::Constant(1));
  const std::vector<int> changed = s.update();
  ASSERT_FALSE(changed.empty());
  EXPECT_TRUE(std::is_sorted(changed.begin(), changed.end()));
  EXPECT_GT(s.chunks()[static_cast<std::size_t>(vol.chunk_id(i / 16, 1, 1))].version, before);
  Surface fresh(vol);
  fresh.extract_all();
  EXPECT_EQ(canonical_triangles(s.chunks()), canonical_triangles(fresh.chunks()));
}

// >= 1000 random bur strokes through the Cutter with Surface::update every
// few strokes must give exactly the mesh of a fresh full extraction.
TEST(Surface, IncrementalEqualsFullUnderRandomBurStrokes) {
  MolarParams mp;
  mp.voxel_mm = 0.25;
  auto tooth = make_molar(mp);
  ASSERT_TRUE(tooth.ok()) << tooth.error();
  VoxelVolume& vol = tooth.value();
  auto bur = sample_bur(BurParams::sphere(0.6), 400);
  ASSERT_TRUE(bur.ok()) << bur.error();
  Cutter cutter(vol);

  Surface inc(vol);
  inc.extract_all();
  std::vector<int> ignored;
  vol.drain_dirty(ignored);  // start clean
  TriangleMesh current = merge_chunks(inc.chunks());
  ASSERT_GT(current.triangle_count(), 0u);

  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::size_t total_changed = 0;
  constexpr int kStrokes = 1000;
  for (int stroke = 0; stroke < kStrokes; ++stroke) {
    // Start on a random surface vertex, push slightly inward, move a little.
    const auto& v = current.vertices[static_cast<std::size_t>(
        u01(rng) * static_cast<double>(current.vertices.size() - 1))];
    Eigen::Vector3d p = v.position_m.cast<double>() - 0.3e-3 * v.normal.cast<double>();
    const Eigen::Vector3d dir = Eigen::Vector3d(u01(rng) - 0.5, u01(rng) - 0.5, u01(rng) - 0.5);
    for (int step = 0; step < 4; ++step) {
      Eigen::Isometry3d T_tooth_tip = Eigen::Isometry3d::Identity();
      T_tooth_tip.translation() = p;
      cutter.step(bur.value(), T_tooth_tip, 2.0, 0.01);
      p += 0.2e-3 * dir;
    }
    if (stroke % 3 == 2) {
      total_changed += inc.update().size();
      if (stroke % 30 == 29) current = merge_chunks(inc.chunks());  // follow the cavity
    }
  }
  total_changed += inc.update().size();
  EXPECT_GT(total_changed, 50u);
  EXPECT_GT(cutter.metrics().removed_total_mm3, 1.0);

  Surface full(vol);
  full.extract_all();
  const auto a = canonical_triangles(inc.chunks());
  const auto b = canonical_triangles(full.chunks());
  EXPECT_EQ(a.size(), b.size());
  EXPECT_TRUE(a == b) << "incremental and full triangle sets differ";
  // Vertex attributes agree too, chunk by chunk.
  for (std::size_t c = 0; c < full.chunks().size(); ++c) {
    const ChunkMesh &x = inc.chunks()[c], &y = full.chunks()[c];
    ASSERT_EQ(x.edge_keys, y.edge_keys) << "chunk " << c;
    ASSERT_EQ(x.indices, y.indices) << "chunk " << c;
    for (std::size_t i = 0; i < x.vertices.size(); ++i)
      ASSERT_TRUE(bit_equal(x.vertices[i], y.vertices[i])) << "chunk " << c << " vertex " << i;
  }
  expect_watertight(merge_chunks(inc.chunks()));
}

// --- writers ---------------------------------------------------------------

TriangleMesh small_sphere_mesh() {
  VoxelVolume vol = sphere_volume({20, 20, 20}, {9.5, 10.2, 9.8}, 6.0);
  Surface s(vol);
  s.extract_all();
  return merge_chunks(s.chunks());
}

template <typename T>
T read_le(const std::string& b, std::size_t& off) {
  T v;
  std::memcpy(&v, b.data() + off, sizeof(T));
  off += sizeof(T);
  return v;
}

TEST(MeshIo, PlyRoundTrip) {
  const TriangleMesh m = small_sphere_mesh();
  const auto path = test::temp_dir("ply") / "sphere.ply";
  const Status st = write_ply(m, path.string());
  ASSERT_TRUE(st.ok()) << st.error();
  const std::string bytes = test::read_file(path);
  const std::string end_tag = "end_header\n";
  const std::size_t hend = bytes.find(end_tag);
  ASSERT_NE(hend, std::string::npos);
  const std::string header = bytes.substr(0, hend);
  EXPECT_EQ(header.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
  EXPECT_NE(header.find("element vertex " + std::to_string(m.vertices.size()) + "\n"),
            std::string::npos);
  EXPECT_NE(header.find("element face " + std::to_string(m.triangle_count()) + "\n"),
            std::string::npos);
  EXPECT_NE(header.find("property uchar red"), std::string::npos);
  std::size_t off = hend + end_tag.size();
  ASSERT_EQ(bytes.size(), off + m.vertices.size() * 27 + m.triangle_count() * 13);
  const auto& rgb = material_info(Material::kEnamel).rgb;
  for (const auto& v : m.vertices) {
    for (int a = 0; a < 3; ++a)
      EXPECT_FLOAT_EQ(read_le<float>(bytes, off), v.position_m[a] * 1000.0f);
    for (int a = 0; a < 3; ++a) EXPECT_EQ(read_le<float>(bytes, off), v.normal[a]);
    for (int a = 0; a < 3; ++a) EXPECT_EQ(read_le<std::uint8_t>(bytes, off), rgb[a]);
  }
  for (std::size_t t = 0; t < m.triangle_count(); ++t) {
    EXPECT_EQ(read_le<std::uint8_t>(bytes, off), 3);
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(read_le<std::int32_t>(bytes, off), static_cast<std::int32_t>(m.indices[3 * t + k]));
  }
}

TEST(MeshIo, ObjRoundTrip) {
  const TriangleMesh m = small_sphere_mesh();
  const auto path = test::temp_dir("obj") / "sphere.obj";
  const Status st = write_obj(m, path.string());
  ASSERT_TRUE(st.ok()) << st.error();
  std::istringstream in(test::read_file(path));
  std::vector<Eigen::Vector3f> v, vn;
  std::vector<std::array<int, 3>> f;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string tag;
    ls >> tag;
    if (tag == "v" || tag == "vn") {
      Eigen::Vector3f p;
      ls >> p.x() >> p.y() >> p.z();
      (tag == "v" ? v : vn).push_back(p);
    } else if (tag == "f") {
      std::array<int, 3> tri{};
      for (int k = 0; k < 3; ++k) {
        std::string tok;
        ls >> tok;
        const auto slash = tok.find("//");
        ASSERT_NE(slash, std::string::npos) << line;
        tri[k] = std::stoi(tok.substr(0, slash));
        EXPECT_EQ(tri[k], std::stoi(tok.substr(slash + 2)));
      }
      f.push_back(tri);
    }
  }
  ASSERT_EQ(v.size(), m.vertices.size());
  ASSERT_EQ(vn.size(), m.vertices.size());
  ASSERT_EQ(f.size(), m.triangle_count());
  for (std::size_t i = 0; i < v.size(); ++i) {
    for (int a = 0; a < 3; ++a) EXPECT_FLOAT_EQ(v[i][a], m.vertices[i].position_m[a] * 1000.0f);
    EXPECT_EQ(vn[i], m.vertices[i].normal);  // shortest round-trip text
  }
  for (std::size_t t = 0; t < f.size(); ++t)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(f[t][k], static_cast<int>(m.indices[3 * t + k]) + 1);
}

TEST(MeshIo, UnwritablePathNamesThePath) {
  const TriangleMesh m = small_sphere_mesh();
  const std::string bad = "/nonexistent-dentar-dir/sub/mesh";
  const Status a = write_ply(m, bad + ".ply");
  ASSERT_FALSE(a.ok());
  EXPECT_NE(a.error().find(bad + ".ply"), std::string::npos) << a.error();
  const Status b = write_obj(m, bad + ".obj");
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().find(bad + ".obj"), std::string::npos) << b.error();
}

}  // namespace
}  // namespace dentar::volume
