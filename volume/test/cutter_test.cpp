#include "dentar/volume/cutter.h"

#include <gtest/gtest.h>

#include <optional>
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

// Session 23: the overlap rule evaluated at every voxel of the bur's index box, with no
// coarse level (no chunk, block or sub-block skipped or taken whole), in the cutter's
// visiting order (chunks, 4^3 blocks, voxels: the first pulp exposure and the overlap
// sum depend on it). The cutter's culling must give exactly these bits.
struct BruteOverlap {
  VoxelVolume* vol;
  CutParams p;
  std::uint64_t step = 0;
  std::optional<PulpExposure> exposure{};
  std::uint64_t full = 0, part = 0;  // voxels cut with share 1, with share in (0, 1)
  CutResult cut(const BurParams& bp, const Eigen::Isometry3d& T, double force_N, double dt) {
    CutResult res;
    const std::uint64_t si = step++;
    const double f = std::min(force_N, p.max_effective_force_N);
    const bool cutting = f >= p.min_force_N && f > 0;
    const VolumeGeometry& g = vol->geometry();
    const double h = std::cbrt(vol->voxel_volume_m3()), inv_h = 1.0 / h;
    const Eigen::Matrix3d Rt = T.linear().transpose();
    const Eigen::Vector3d c0 = Rt * (g.origin - T.translation());
    const Eigen::Vector3d ax = Rt.col(0) * g.spacing.x(), ay = Rt.col(1) * g.spacing.y(),
                          az = Rt.col(2) * g.spacing.z();
    const double r = bp.radius_m + 0.5 * h;
    const double z_lo = -(bp.shape == BurShape::kSphere ? 2.0 * bp.radius_m : bp.length_m) - 0.5 * h;
    Eigen::Vector3d vmin = Eigen::Vector3d::Constant(1e300), vmax = Eigen::Vector3d::Constant(-1e300);
    for (int c = 0; c < 8; ++c) {
      const Eigen::Vector3d q((c & 1) ? r : -r, (c & 2) ? r : -r, (c & 4) ? 0.5 * h : z_lo);
      const Eigen::Vector3d v = (T * q - g.origin).cwiseQuotient(g.spacing);
      vmin = vmin.cwiseMin(v);
      vmax = vmax.cwiseMax(v);
    }
    Eigen::Vector3i lo, hi;
    for (int a = 0; a < 3; ++a) {
      lo(a) = std::max(0, static_cast<int>(std::ceil(vmin(a))));
      hi(a) = std::min(g.dims(a) - 1, static_cast<int>(std::floor(vmax(a))));
      if (lo(a) > hi(a)) return res;
    }
    std::array<double, kMaxMaterials> amount{};
    if (cutting)
      for (int m = 1; m < kMaxMaterials; ++m)
        amount[static_cast<std::size_t>(m)] = std::min(
            p.base_rate_per_s * (f / p.reference_force_N) * dt * material_info(m).removal_rate * 65536.0,
            255.0 * 65536.0);
    const std::uint32_t phase = static_cast<std::uint32_t>(si) * 0x632BE5ABu;
    for (int ck = lo.z() >> 4; ck <= hi.z() >> 4; ++ck)
      for (int cj = lo.y() >> 4; cj <= hi.y() >> 4; ++cj)
        for (int ci = lo.x() >> 4; ci <= hi.x() >> 4; ++ci) {
          const int cid = vol->chunk_id(ci, cj, ck);
          VoxelVolume::Chunk* c = vol->chunk(cid);
          if (!c) continue;
          for (int bk = 0; bk < 16; bk += 4)
            for (int bj = 0; bj < 16; bj += 4)
              for (int bi = 0; bi < 16; bi += 4)
                for (int k = std::max(16 * ck + bk, lo.z()); k <= std::min(16 * ck + bk + 3, hi.z()); ++k)
                  for (int j = std::max(16 * cj + bj, lo.y()); j <= std::min(16 * cj + bj + 3, hi.y()); ++j)
                    for (int i = std::max(16 * ci + bi, lo.x()); i <= std::min(16 * ci + bi + 3, hi.x()); ++i) {
                      const auto li = static_cast<std::size_t>(chunk_local_index(i & 15, j & 15, k & 15));
                      const std::uint8_t mat = c->material[li];
                      std::uint8_t& d = c->density[li];
                      if (mat == 0 || d == 0) continue;
                      const double sd = bp.signed_distance(c0 + i * ax + j * ay + k * az);
                      const double share = std::clamp(0.5 - sd * inv_h, 0.0, 1.0);
                      if (share <= 0.0) continue;
                      ++(share == 1.0 ? full : part);
                      ++res.samples_in_solid;
                      res.overlap_m3 += share * vol->voxel_volume_m3();
                      if (mat == static_cast<std::uint8_t>(Material::kPulp)) {
                        res.touched_pulp = true;
                        if (cutting && !exposure) exposure = PulpExposure{si, vol->voxel_center(i, j, k)};
                      }
                      const std::uint32_t dither = (static_cast<std::uint32_t>(li) * 0x9E3779B9u +
                                                    static_cast<std::uint32_t>(cid) * 0x85EBCA6Bu + phase) >> 16;
                      const std::uint32_t units =
                          (static_cast<std::uint32_t>(amount[mat & (kMaxMaterials - 1)] * share) + dither) >> 16;
                      const auto removed = static_cast<std::uint8_t>(std::min<std::uint32_t>(units, d));
                      d = static_cast<std::uint8_t>(d - removed);
                      if (d == 0) c->material[li] = 0;
                      res.removed[mat & (kMaxMaterials - 1)] += removed;
                    }
        }
    return res;
  }
};

TEST(Cutter, OverlapCutsTheSameBitsAsEveryVoxelEvaluated) {
  // Every shape, tilted, drilled down from above the crown through to the pulp of a
  // 0.15 mm molar (voxels wholly and partly inside the bur, air, enamel, dentin and
  // pulp all occur), jittered and tilted differently each step, now and then below
  // the cutting force.
  MolarParams mp;
  mp.voxel_mm = 0.15;
  auto tooth = make_molar(mp);
  ASSERT_TRUE(tooth.ok());
  for (const BurParams& bp : {BurParams::capsule(0.5, 3.0), BurParams::cone(0.2, 0.5, 3.0),
                              BurParams::sphere(1.2), BurParams::cylinder(0.45, 2.5)}) {
    SCOPED_TRACE(std::string(bur_shape_name(bp.shape)));
    VoxelVolume a = tooth->clone(), b = tooth->clone();
    auto bur = sample_bur(bp, 100);
    ASSERT_TRUE(bur.ok());
    CutParams over;
    over.overlap = true;
    over.base_rate_per_s = 20000.0;
    Cutter cutter(a, over);
    BruteOverlap brute{&b, over};
    std::mt19937 rng(23);
    std::uniform_real_distribution<double> u(-1, 1);
    std::uint64_t removed = 0;
    bool pulp = false;
    for (int s = 0; s < 250; ++s) {
      Eigen::Isometry3d T = pose_down({-1.1e-3 + 2e-4 * u(rng), 1.2e-3 + 2e-4 * u(rng), 7.5e-3 - 2.4e-5 * s});
      T.linear() = T.linear() * Eigen::AngleAxisd(0.25 * u(rng), Eigen::Vector3d(u(rng), u(rng), 0.3).normalized());
      const double force = s % 50 == 7 ? 0.01 : 2.0 + u(rng);
      const CutResult x = cutter.step(*bur, T, force, 1e-3);
      const CutResult y = brute.cut(bp, T, force, 1e-3);
      ASSERT_EQ(x.removed, y.removed) << "step " << s;
      ASSERT_EQ(x.samples_in_solid, y.samples_in_solid) << "step " << s;
      ASSERT_EQ(x.touched_pulp, y.touched_pulp) << "step " << s;
      ASSERT_EQ(x.overlap_m3, y.overlap_m3) << "step " << s;
      removed += x.total_removed();
      pulp = pulp || x.touched_pulp;
    }
    EXPECT_EQ(a.content_hash(), b.content_hash());
    EXPECT_GT(removed, 100000u);
    EXPECT_GT(brute.full, 5000u);  // voxels the coarse levels may take whole
    EXPECT_GT(brute.part, 5000u);  // and ones they must leave to the per-voxel distance
    EXPECT_TRUE(pulp);
    const CutMetrics m = cutter.metrics();
    ASSERT_TRUE(m.pulp_exposure.has_value() && brute.exposure.has_value());
    EXPECT_EQ(m.pulp_exposure->step, brute.exposure->step);
    EXPECT_EQ(m.pulp_exposure->position_m, brute.exposure->position_m);
  }
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
