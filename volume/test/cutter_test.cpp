#include "dentar/volume/cutter.h"

#include <gtest/gtest.h>

#include <random>

#include "dentar/volume/procedural_tooth.h"

namespace dentar::volume {
namespace {

// 64^3 block at 0.1 mm, one material at full density, origin at 0.
VoxelVolume block(Material m) {
  VolumeGeometry g;
  g.dims = {64, 64, 64};
  g.spacing = Eigen::Vector3d::Constant(1e-4);
  VoxelVolume v(g);
  for (int k = 0; k < 48; ++k)  // solid below z = 4.8 mm
    for (int j = 0; j < 64; ++j)
      for (int i = 0; i < 64; ++i) v.set(i, j, k, material_info(m).full_density, m);
  return v;
}

// Bur pointing straight down (+z of tip = -z of tooth) with its tip at p.
Eigen::Isometry3d pose_down(const Eigen::Vector3d& p) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  T.translation() = p;
  return T;
}

std::uint64_t drill(VoxelVolume& v, const BurSamples& bur, double force, int steps) {
  // A low rate keeps every voxel far from fully removed, so removal stays
  // proportional to rate x force (what these tests check).
  CutParams slow;
  slow.base_rate_per_s = 1000.0;
  Cutter c(v, slow);
  std::uint64_t total = 0;
  // Tip 0.5 mm into the surface, bur body above it.
  for (int s = 0; s < steps; ++s)
    total += c.step(bur, pose_down({3.2e-3, 3.2e-3, 4.25e-3}), force, 1e-3).total_removed();
  return total;
}

TEST(Cutter, HarderMaterialCutsSlowerAndForceCutsFaster) {
  auto bur = sample_bur(BurParams::sphere(0.8), 5000);
  ASSERT_TRUE(bur.ok());
  VoxelVolume enamel = block(Material::kEnamel), dentin = block(Material::kDentin),
              pulp = block(Material::kPulp);
  const double e = static_cast<double>(drill(enamel, *bur, 1.0, 20));
  const double d = static_cast<double>(drill(dentin, *bur, 1.0, 20));
  const double p = static_cast<double>(drill(pulp, *bur, 1.0, 20));
  ASSERT_GT(e, 0);
  EXPECT_NEAR(e / d, material_info(Material::kEnamel).removal_rate, 0.05);
  EXPECT_GT(p, d);  // pulp (soft tissue) goes fastest, limited by its density
  VoxelVolume dentin2 = block(Material::kDentin), dentin0 = block(Material::kDentin);
  const double d2 = static_cast<double>(drill(dentin2, *bur, 2.0, 20));
  EXPECT_NEAR(d2 / d, 2.0, 0.1);
  EXPECT_EQ(drill(dentin0, *bur, 0.0, 20), 0u);  // resting, no force: no cut
}

TEST(Cutter, RemovalRateDoesNotDependOnSampleCount) {
  auto few = sample_bur(BurParams::sphere(0.8), 1000), many = sample_bur(BurParams::sphere(0.8), 30000);
  ASSERT_TRUE(few.ok() && many.ok());
  VoxelVolume a = block(Material::kDentin), b = block(Material::kDentin);
  const double ra = static_cast<double>(drill(a, *few, 1.0, 30));
  const double rb = static_cast<double>(drill(b, *many, 1.0, 30));
  EXPECT_NEAR(ra / rb, 1.0, 0.1);
}

TEST(Cutter, VoxelsCutToZeroBecomeAirAndMetricsAddUp) {
  auto bur = sample_bur(BurParams::capsule(0.5, 3.0), 10000);
  ASSERT_TRUE(bur.ok());
  VoxelVolume v = block(Material::kDentin);
  const auto before = v.density_sum_by_material();
  Cutter c(v);
  for (int s = 0; s < 400; ++s) c.step(*bur, pose_down({3.2e-3, 3.2e-3, 4.5e-3}), 4.0, 1e-3);
  // Straight under the tip the dentin is gone.
  EXPECT_EQ(v.material(32, 32, 46), Material::kAir);
  EXPECT_EQ(v.density(32, 32, 46), 0);
  const auto after = v.density_sum_by_material();
  const int dentin = static_cast<int>(Material::kDentin);
  const double removed_units = static_cast<double>(before[dentin] - after[dentin]);
  const CutMetrics m = c.metrics();
  const double expect_mm3 = removed_units / 200.0 * 1e-3;  // 0.1 mm voxels = 1e-3 mm^3
  EXPECT_NEAR(m.removed_mm3[dentin], expect_mm3, 1e-9);
  EXPECT_NEAR(m.removed_total_mm3, expect_mm3, 1e-9);
  EXPECT_NEAR(m.original_tooth_mm3, 64 * 64 * 48 * 1e-3, 1e-6);
  EXPECT_NEAR(m.removed_percent, 100 * expect_mm3 / m.original_tooth_mm3, 1e-9);
  EXPECT_FALSE(m.pulp_exposure.has_value());
}

TEST(Cutter, MarksDirtyEveryChunkWhoseSurfaceMayChange) {
  auto bur = sample_bur(BurParams::sphere(0.3), 2000);
  ASSERT_TRUE(bur.ok());
  VoxelVolume v = block(Material::kDentin);
  std::vector<int> ids;
  v.drain_dirty(ids);
  ids.clear();
  Cutter c(v);
  // Tip at voxel (16,16,45), body above: the bur sits on the corner of 4
  // chunks and cuts voxels k = 45..47.
  const auto r = c.step(*bur, pose_down({1.6e-3, 1.6e-3, 4.5e-3}), 4.0, 1e-3);
  ASSERT_GT(r.total_removed(), 0u);
  v.drain_dirty(ids);
  // Changed voxels span i,j in [13,19]; lo-2 and hi+1 reach chunks 0 and 1
  // in x and y; k in [45,47] gives chunk 2 and, through hi+1 = 48, chunk 3.
  for (int ci = 0; ci < 2; ++ci)
    for (int cj = 0; cj < 2; ++cj)
      for (int ck = 2; ck < 4; ++ck)
        EXPECT_TRUE(std::find(ids.begin(), ids.end(), v.chunk_id(ci, cj, ck)) != ids.end());
  for (int id : ids) EXPECT_LE(v.chunk_coords(id).x(), 1);
}

// Session 22: the overlap cutter removes from each voxel the bur's share of it,
// so a still bur removes what the densest sample cutter removes (30000
// samples, no proxy here), and a bur wholly inside solid removes its own volume.
TEST(Cutter, OverlapCutRemovesTheBursShareOfEachVoxel) {
  auto many = sample_bur(BurParams::sphere(0.8), 30000), few = sample_bur(BurParams::sphere(0.8), 10);
  ASSERT_TRUE(many.ok() && few.ok());
  CutParams slow;
  slow.base_rate_per_s = 1000.0;
  CutParams over = slow;
  over.overlap = true;
  VoxelVolume a = block(Material::kDentin), b = block(Material::kDentin), c = block(Material::kDentin);
  Cutter ca(a, slow), cb(b, over), cc(c, over);
  std::uint64_t ra = 0, rb = 0, rc = 0;
  for (int s = 0; s < 30; ++s) {
    const Eigen::Isometry3d T = pose_down({3.23e-3, 3.17e-3, 4.27e-3});
    ra += ca.step(*many, T, 1.0, 1e-3).total_removed();
    rb += cb.step(*many, T, 1.0, 1e-3).total_removed();
    rc += cc.step(*few, T, 1.0, 1e-3).total_removed();
  }
  ASSERT_GT(ra, 0u);
  EXPECT_NEAR(static_cast<double>(rb) / static_cast<double>(ra), 1.0, 0.03);
  EXPECT_EQ(rb, rc);  // the sample count plays no part
  EXPECT_EQ(a.content_hash() == b.content_hash(), false);  // different cutters, same amount

  // Wholly inside (sphere centre 2 mm below the surface): 1000 units/s x 10 ms
  // = 10 units from every voxel of the sphere's 2.14 mm^3.
  VoxelVolume d = block(Material::kDentin);
  Cutter cd(d, over);
  std::uint64_t rd = 0;
  for (int s = 0; s < 10; ++s) rd += cd.step(*few, pose_down({3.2e-3, 3.2e-3, 2.0e-3}), 1.0, 1e-3).total_removed();
  const double sphere_voxels = 4.0 / 3.0 * M_PI * 0.8 * 0.8 * 0.8 / 1e-3;  // mm^3 / (0.1 mm)^3
  EXPECT_NEAR(static_cast<double>(rd) / (10.0 * sphere_voxels), 1.0, 0.03);
  const double full = material_info(Material::kDentin).full_density;
  const double sphere_mm3 = 4.0 / 3.0 * M_PI * 0.512;
  EXPECT_NEAR(cd.metrics().removed_total_mm3 / (10.0 / full * sphere_mm3), 1.0, 0.03);
}

TEST(Cutter, DeterministicBitIdenticalVolumeForTheSameSequence) {
  MolarParams p;
  p.voxel_mm = 0.15;
  auto a = make_molar(p), b = make_molar(p);
  ASSERT_TRUE(a.ok() && b.ok());
  auto bur = sample_bur(BurParams::cone(0.3, 0.6, 4.0), 3000);
  ASSERT_TRUE(bur.ok());
  auto run = [&](VoxelVolume& v, double force_scale) {
    Cutter c(v);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1, 1);
    for (int s = 0; s < 1500; ++s) {
      Eigen::Isometry3d T = pose_down({2e-3 * u(rng), 2e-3 * u(rng), 6.0e-3 + 1e-3 * u(rng)});
      T.linear() = T.linear() * Eigen::AngleAxisd(0.3 * u(rng), Eigen::Vector3d::UnitY());
      c.step(*bur, T, force_scale * (1.5 + u(rng)), 1e-3);
    }
    return c.metrics();
  };
  const auto ma = run(*a, 1.0);
  const auto mb = run(*b, 1.0);
  EXPECT_EQ(a->content_hash(), b->content_hash());
  EXPECT_EQ(ma.removed_total_mm3, mb.removed_total_mm3);
  EXPECT_GT(ma.removed_total_mm3, 0.05);
  auto c = make_molar(p);
  run(*c, 1.001);  // a slightly different force sequence
  EXPECT_NE(a->content_hash(), c->content_hash());
}

TEST(Cutter, DrillingDownThroughTheCrownExposesThePulpOnce) {
  MolarParams p;
  p.voxel_mm = 0.1;
  auto v = make_molar(p);
  ASSERT_TRUE(v.ok());
  auto bur = sample_bur(BurParams::cylinder(0.5, 4.0), 4000);
  ASSERT_TRUE(bur.ok());
  Cutter c(*v);
  std::uint64_t first_pulp_step = 0;
  bool enamel_before_pulp = false;
  // Lower the bur 5 um per ms from above the mesiopalatal cusp region, like
  // a student opening an access cavity toward the pulp horn.
  for (int s = 0; s < 2000; ++s) {
    const double z = 7.5e-3 - 5e-6 * s;
    const auto r = c.step(*bur, pose_down({-1.1e-3, 1.2e-3, z}), 3.0, 1e-3);
    if (r.removed[static_cast<int>(Material::kEnamel)] > 0 && first_pulp_step == 0)
      enamel_before_pulp = true;
    if (r.touched_pulp && first_pulp_step == 0) first_pulp_step = static_cast<std::uint64_t>(s);
  }
  const CutMetrics m = c.metrics();
  ASSERT_TRUE(m.pulp_exposure.has_value());
  EXPECT_TRUE(enamel_before_pulp);
  EXPECT_EQ(m.pulp_exposure->step, first_pulp_step);
  const Eigen::Vector3d e = m.pulp_exposure->position_m;
  EXPECT_LT(e.z(), 5.5e-3);  // under the enamel
  EXPECT_GT(m.removed_mm3[static_cast<int>(Material::kEnamel)], 0.1);
  EXPECT_GT(m.removed_mm3[static_cast<int>(Material::kDentin)], 0.1);
}

TEST(Cutter, NonFiniteInputsCutNothing) {
  auto bur = sample_bur(BurParams::sphere(0.5), 1000);
  ASSERT_TRUE(bur.ok());
  VoxelVolume v = block(Material::kDentin);
  const auto h = v.content_hash();
  Cutter c(v);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(c.step(*bur, pose_down({3.2e-3, 3.2e-3, 4.5e-3}), nan, 1e-3).total_removed(), 0u);
  EXPECT_EQ(c.step(*bur, pose_down({3.2e-3, 3.2e-3, 4.5e-3}), 1.0, nan).total_removed(), 0u);
  EXPECT_EQ(c.step(*bur, pose_down({nan, 3.2e-3, 4.5e-3}), 1.0, 1e-3).total_removed(), 0u);
  EXPECT_EQ(c.step(*bur, pose_down({3.2e-3, 3.2e-3, 4.5e-3}), 1.0, -1e-3).total_removed(), 0u);
  // Far outside the volume: nothing either, and no crash.
  EXPECT_EQ(c.step(*bur, pose_down({1e3, -1e3, 1e9}), 1.0, 1e-3).total_removed(), 0u);
  EXPECT_EQ(v.content_hash(), h);
}

TEST(Cutter, ParamsValidateNamesTheField) {
  CutParams p;
  EXPECT_TRUE(p.validate().empty());
  p.min_force_N = -1;
  EXPECT_NE(p.validate().find("min_force_N"), std::string::npos);
}

}  // namespace
}  // namespace dentar::volume
