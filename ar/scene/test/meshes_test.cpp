// Procedural instrument meshes: closed, outward-facing, sized by their parameters.
#include "dentar/ar/meshes.h"

#include <gtest/gtest.h>

#include <map>
#include <utility>

namespace dentar::ar {
namespace {

namespace dv = dentar::volume;

// Every undirected edge of a closed mesh is shared by exactly two triangles,
// used once in each direction (consistent winding). Positions are welded by
// value since revolve() duplicates vertices at creases.
void expect_closed(const PartMesh& m) {
  auto key = [&](std::uint32_t i) {
    const auto& p = m.positions_m[i];
    return std::make_tuple(std::lround(p.x() * 1e7), std::lround(p.y() * 1e7),
                           std::lround(p.z() * 1e7));
  };
  std::map<std::pair<decltype(key(0)), decltype(key(0))>, int> directed;
  for (std::size_t t = 0; t < m.triangle_count(); ++t) {
    for (int e = 0; e < 3; ++e) {
      const auto a = key(m.indices[3 * t + e]), b = key(m.indices[3 * t + (e + 1) % 3]);
      ++directed[{a, b}];
    }
  }
  int bad = 0;
  for (const auto& [edge, n] : directed) {
    const auto rev = directed.find({edge.second, edge.first});
    if (n != 1 || rev == directed.end() || rev->second != 1) ++bad;
  }
  EXPECT_EQ(bad, 0);
}

// Triangle normals (from the winding) agree with the stored vertex normals.
void expect_outward(const PartMesh& m) {
  int disagree = 0;
  for (std::size_t t = 0; t < m.triangle_count(); ++t) {
    const auto& a = m.positions_m[m.indices[3 * t]];
    const auto& b = m.positions_m[m.indices[3 * t + 1]];
    const auto& c = m.positions_m[m.indices[3 * t + 2]];
    const Eigen::Vector3f n = (b - a).cross(c - a);
    const Eigen::Vector3f vn = m.normals[m.indices[3 * t]] + m.normals[m.indices[3 * t + 1]] +
                               m.normals[m.indices[3 * t + 2]];
    if (n.dot(vn) <= 0) ++disagree;
  }
  EXPECT_EQ(disagree, 0);
}

Eigen::AlignedBox3f bounds(const PartMesh& m) {
  Eigen::AlignedBox3f b;
  for (const auto& p : m.positions_m) b.extend(p);
  return b;
}

TEST(Meshes, BurShapesAreClosedOutwardAndWhereTheCutterCuts) {
  BurMeshOptions o;
  o.neck_length_m = 0;  // the cutting part alone
  o.shank_length_m = 0;
  for (const dv::BurParams& bur :
       {dv::BurParams::sphere(0.5), dv::BurParams::cylinder(0.5, 4.0),
        dv::BurParams::capsule(0.6, 3.0), dv::BurParams::cone(0.2, 0.6, 5.0)}) {
    SCOPED_TRACE(std::string(dv::bur_shape_name(bur.shape)));
    const PartMesh m = make_bur_mesh(bur, o);
    expect_closed(m);
    expect_outward(m);
    const Eigen::AlignedBox3f b = bounds(m);
    EXPECT_NEAR(b.max().z(), 0.0, 1e-9);  // the far end is the tip frame's origin
    const double back = bur.shape == dv::BurShape::kSphere ? -2 * bur.radius_m : -bur.length_m;
    EXPECT_NEAR(b.min().z(), back, 1e-7);
    EXPECT_NEAR(b.max().x(), bur.radius_m, 1e-7);
    // Every vertex lies on the surface the cutter uses.
    double worst = 0;
    for (const auto& p : m.positions_m) {
      worst = std::max(worst, std::abs(bur.signed_distance(p.cast<double>())));
    }
    EXPECT_LT(worst, 1e-7);
  }
}

TEST(Meshes, BurWithShankAndHandpiece) {
  const auto bur = dv::BurParams::capsule(0.5, 3.0);
  const PartMesh m = make_bur_mesh(bur);
  expect_outward(m);
  const BurMeshOptions o;
  EXPECT_NEAR(bounds(m).min().z(), -3.0e-3 - o.neck_length_m - o.shank_length_m, 1e-7);
  EXPECT_NEAR(bur_shank_end_z_m(bur), -3.0e-3 - o.neck_length_m - o.shank_length_m, 1e-12);
  const HandpieceParams hp;
  const PartMesh h = make_handpiece_mesh(bur, hp);
  expect_outward(h);
  const Eigen::AlignedBox3f b = bounds(h);
  // The head starts where the shank ends; the handle goes toward -x.
  EXPECT_NEAR(b.max().z(), bur_shank_end_z_m(bur), 1e-4);
  EXPECT_LT(b.min().x(), -0.09);
  EXPECT_GT(b.max().x(), 0.0);
}

TEST(Meshes, MirrorFaceIsTheDiscAtZZero) {
  MirrorMeshParams p;
  p.radius_m = 0.0105;
  const MirrorMeshes m = make_mirror_meshes(p);
  expect_outward(m.face);
  expect_outward(m.body);
  const Eigen::AlignedBox3f f = bounds(m.face);
  EXPECT_NEAR(f.min().z(), 0.0, 1e-9);
  EXPECT_NEAR(f.max().z(), 0.0, 1e-9);
  EXPECT_NEAR(f.max().x(), p.radius_m, 1e-7);
  for (const auto& n : m.face.normals) EXPECT_NEAR(n.z(), 1.0f, 1e-6f);
  // The body stays behind the face; the handle leaves along -y.
  EXPECT_LE(bounds(m.body).max().z(), 1e-9);
  EXPECT_LT(bounds(m.body).min().y(), -0.1);
}

TEST(Meshes, ValidateNamesTheField) {
  HandpieceParams h;
  h.body_length_m = -1;
  EXPECT_NE(h.validate().find("body_length_m"), std::string::npos);
  MirrorMeshParams m;
  m.segments = 2;
  EXPECT_NE(m.validate().find("segments"), std::string::npos);
  BurMeshOptions b;
  b.shank_radius_m = 0;
  EXPECT_NE(b.validate().find("shank_radius_m"), std::string::npos);
}

}  // namespace
}  // namespace dentar::ar
