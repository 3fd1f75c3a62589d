// Seed (dissertation) force model: directions and magnitudes in known
// configurations, the open cases, the smoothing filter against a hand
// computation, continuity, and no allocation in compute().
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <new>
#include <numbers>

#include "dentar/haptics/force_model.h"
#include "test_blocks.h"

#include "alloc_counter.h"  // counts this thread's heap allocations

namespace dentar::haptics {
namespace {

using volume::BurParams;
using volume::BurShape;
using volume::Material;
using volume::VoxelVolume;

constexpr double kVoxel = test_blocks::kVoxel;

using test_blocks::make_block;

// Dentin below z = 0 (voxel centres with z <= 0). Nearest-voxel rounding puts
// the seed model's surface at z = +0.05 mm.
VoxelVolume half_space() {
  return make_block([](const Eigen::Vector3d& p) { return p.z() <= 1e-9; });
}
constexpr double kSeedSurface = 0.5 * kVoxel;

// Bur pointing straight down (tip +z = tooth -z) with its tip at `tip`.
Eigen::Isometry3d down_at(const Eigen::Vector3d& tip) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(std::numbers::pi, Eigen::Vector3d::UnitX()).toRotationMatrix();
  T.translation() = tip;
  return T;
}

BurParams bur_of(BurShape s) {
  switch (s) {
    case BurShape::kSphere: return BurParams::sphere(0.5);
    case BurShape::kCylinder: return BurParams::cylinder(0.5, 3.0);
    case BurShape::kCapsule: return BurParams::capsule(0.5, 3.0);
    case BurShape::kCone: return BurParams::cone(0.2, 0.5, 3.0);
  }
  return {};
}

std::unique_ptr<ForceModel> make_seed(const SeedParams& sp = {}) {
  ForceModelParams p;
  p.seed = sp;
  auto m = make_force_model("seed", p, DeviceLimits{}, 30000);
  EXPECT_TRUE(m.ok()) << (m.ok() ? "" : m.error());
  return std::move(m).value();
}

ForceInput input(const VoxelVolume& v, const volume::BurSamples& b, const Eigen::Isometry3d& T,
                 const Eigen::Vector3d& vel = Eigen::Vector3d::Zero()) {
  ForceInput in;
  in.volume = &v;
  in.bur = &b;
  in.T_tooth_tip = T;
  in.velocity_m_per_s = vel;
  return in;
}

// Independent H: unit directions averaged and renormalised, harmonic mean of
// the magnitudes.
Eigen::Vector3d hand_H(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const double na = a.norm(), nb = b.norm();
  return (2 * na * nb / (na + nb)) * (a / na + b / nb).normalized();
}

class SeedShapes : public ::testing::TestWithParam<BurShape> {};

TEST_P(SeedShapes, PushDownIntoHalfSpacePointsUpAndGrowsWithDepth) {
  const VoxelVolume vol = half_space();
  const auto bur = volume::sample_bur(bur_of(GetParam()), 10000);
  ASSERT_TRUE(bur.ok());
  const SeedParams sp;
  double prev_mag = 0;
  std::uint32_t prev_n = 0;
  for (double depth : {0.1e-3, 0.2e-3, 0.3e-3}) {
    auto m = make_seed(sp);  // fresh: the first step renders f_raw unsmoothed
    const ForceOutput o = m->compute(input(vol, *bur, down_at({0, 0, kSeedSurface - depth})));
    ASSERT_TRUE(o.in_contact);
    ASSERT_GT(o.contacts, prev_n);
    EXPECT_DOUBLE_EQ(o.mean_density, 200.0);
    const double expect = sp.density_scale_N * 200.0 + sp.c1_N * o.contacts;
    EXPECT_NEAR(o.force_N.norm(), expect, 1e-9 * expect) << "depth " << depth;
    EXPECT_GT(o.force_N.z(), 0.99 * o.force_N.norm()) << o.force_N.transpose();
    EXPECT_GT(o.force_N.norm(), prev_mag);
    prev_mag = o.force_N.norm();
    prev_n = o.contacts;
    EXPECT_TRUE(o.T_tooth_tip_display.isApprox(down_at({0, 0, kSeedSurface - depth})));
  }
}

INSTANTIATE_TEST_SUITE_P(AllBurs, SeedShapes,
                         ::testing::Values(BurShape::kSphere, BurShape::kCylinder,
                                           BurShape::kCapsule, BurShape::kCone),
                         [](const auto& i) { return std::string(volume::bur_shape_name(i.param)); });

TEST(SeedModel, SphereInCornerPushesOutOfBothFaces) {
  // Floor z <= 0 and wall x >= 0: an inside corner.
  const VoxelVolume vol =
      make_block([](const Eigen::Vector3d& p) { return p.z() <= 1e-9 || p.x() >= -1e-9; });
  const auto bur = volume::sample_bur(BurParams::sphere(0.5), 10000);
  ASSERT_TRUE(bur.ok());
  // Centre 0.5 mm from both seed surfaces minus 0.1 mm: 0.1 mm into each.
  const double c = 0.5e-3 - 0.1e-3;
  auto m = make_seed();
  const ForceOutput o = m->compute(
      input(vol, *bur, down_at({-kSeedSurface - c, 0, kSeedSurface + c - 0.5e-3})));
  ASSERT_TRUE(o.in_contact);
  const Eigen::Vector3d expect = Eigen::Vector3d(-1, 0, 1).normalized();
  EXPECT_GT(o.force_N.normalized().dot(expect), std::cos(5.0 * std::numbers::pi / 180))
      << o.force_N.transpose();
}

TEST(SeedModel, CylinderSideContactIsHorizontal) {
  // A wall x >= 0 above z = 0: only body samples of a vertical cylinder whose
  // tip region hangs below the wall touch it; they push toward the axis.
  const VoxelVolume vol =
      make_block([](const Eigen::Vector3d& p) { return p.x() >= -1e-9 && p.z() >= -1e-9; });
  const auto bur = volume::sample_bur(BurParams::cylinder(0.5, 3.0), 10000);
  ASSERT_TRUE(bur.ok());
  auto m = make_seed();
  const ForceOutput o = m->compute(input(vol, *bur, down_at({-0.4e-3, 0, -1.0e-3})));
  ASSERT_TRUE(o.in_contact);
  EXPECT_LT(o.force_N.x(), 0);
  EXPECT_LT(std::abs(o.force_N.z()), 1e-9 * o.force_N.norm());
  EXPECT_LT(std::abs(o.force_N.y()), 0.05 * o.force_N.norm());

  // A full-height wall also touches the tip region (its samples pull toward
  // the tip/body point, i.e. also up the axis): still mostly horizontal.
  const VoxelVolume wall = make_block([](const Eigen::Vector3d& p) { return p.x() >= -1e-9; });
  auto m2 = make_seed();
  const ForceOutput o2 = m2->compute(input(wall, *bur, down_at({-0.4e-3, 0, -1.0e-3})));
  EXPECT_GT(-o2.force_N.x(), 0.95 * o2.force_N.norm()) << o2.force_N.transpose();
}

TEST(SeedModel, FullyEmbeddedIsFiniteAndBounded) {
  const VoxelVolume vol = make_block([](const Eigen::Vector3d&) { return true; });
  for (BurShape s : {BurShape::kSphere, BurShape::kCylinder, BurShape::kCapsule, BurShape::kCone}) {
    const auto bur = volume::sample_bur(bur_of(s), 10000);
    ASSERT_TRUE(bur.ok());
    auto m = make_seed();
    const SeedParams sp;
    for (int step = 0; step < 50; ++step) {
      const ForceOutput o = m->compute(input(vol, *bur, down_at({0, 0, -1.0e-3})));
      ASSERT_TRUE(o.force_N.allFinite());
      ASSERT_EQ(o.contacts, 10000u);
      EXPECT_LE(o.force_N.norm(), sp.density_scale_N * 255 + sp.c1_N * 10000 + 1e-9);
    }
  }
}

// Two samples symmetric about a sphere's centre: sum f_i is exactly zero.
volume::BurSamples symmetric_pair() {
  volume::BurSamples b;
  b.params = BurParams::sphere(0.5);
  b.points_m = {Eigen::Vector3f(0.2e-3f, 0, -0.5e-3f), Eigen::Vector3f(-0.2e-3f, 0, -0.5e-3f)};
  b.region = {volume::BurRegion::kBody, volume::BurRegion::kBody};
  b.tip_body_point_m = Eigen::Vector3f(0, 0, -0.5e-3f);
  b.sample_volume_m3 = b.params.volume_m3() / 2;
  return b;
}

TEST(SeedModel, SymmetricEmbeddingWithoutHistoryGivesNoCollisionForce) {
  // Solid everywhere: both samples immersed, sum f_i = 0, no history.
  const VoxelVolume vol = make_block([](const Eigen::Vector3d&) { return true; });
  const volume::BurSamples bur = symmetric_pair();
  auto m = make_seed();
  const ForceOutput o = m->compute(input(vol, bur, down_at({0, 0, 1e-3})));
  EXPECT_TRUE(o.in_contact);
  EXPECT_EQ(o.contacts, 2u);
  EXPECT_TRUE(o.force_N.isZero(0)) << o.force_N.transpose();
  // Damping still acts in contact.
  const ForceOutput o2 = m->compute(input(vol, bur, down_at({0, 0, 1e-3}), {0.01, 0, 0}));
  EXPECT_TRUE(o2.force_N.allFinite());
}

TEST(SeedModel, SymmetricEmbeddingKeepsTheHistoryDirection) {
  // Wall x >= 0: first only the +x sample is immersed (pushed toward -x),
  // then both are (solid everywhere): the force keeps pointing to -x.
  const VoxelVolume wall = make_block([](const Eigen::Vector3d& p) { return p.x() >= -1e-9; });
  const VoxelVolume full = make_block([](const Eigen::Vector3d&) { return true; });
  const volume::BurSamples bur = symmetric_pair();
  auto m = make_seed();
  const ForceOutput a = m->compute(input(wall, bur, down_at({0, 0, 1e-3})));
  ASSERT_EQ(a.contacts, 1u);
  ASSERT_LT(a.force_N.x(), 0);
  const ForceOutput b = m->compute(input(full, bur, down_at({0, 0, 1e-3})));
  ASSERT_EQ(b.contacts, 2u);
  ASSERT_TRUE(b.force_N.allFinite());
  EXPECT_GT(-b.force_N.normalized().x(), 0.999);
}

TEST(SeedModel, NoContactGivesZeroAndClearsHistory) {
  const VoxelVolume vol = half_space();
  const auto bur = volume::sample_bur(BurParams::capsule(0.5, 3.0), 3000);
  ASSERT_TRUE(bur.ok());
  auto m = make_seed();
  // In air, moving: no force (damping only in contact).
  ForceOutput o = m->compute(input(vol, *bur, down_at({0, 0, 1e-3}), {0.1, 0.2, -0.3}));
  EXPECT_TRUE(o.force_N.isZero(0));
  EXPECT_EQ(o.contacts, 0u);
  EXPECT_FALSE(o.in_contact);
  // Contact with some history, then leave and come back: the first step of
  // the new contact equals a fresh model's first step (history cleared).
  for (int i = 0; i < 20; ++i)
    m->compute(input(vol, *bur, down_at({0, 0, -0.2e-3}), {0.01 * i, 0, 0}));
  o = m->compute(input(vol, *bur, down_at({0, 0, 1e-3})));
  EXPECT_TRUE(o.force_N.isZero(0));
  EXPECT_FALSE(o.in_contact);
  const Eigen::Isometry3d T = down_at({0.1e-3, 0, -0.15e-3});
  const Eigen::Vector3d v(0.02, -0.01, 0.03);
  const ForceOutput again = m->compute(input(vol, *bur, T, v));
  const ForceOutput fresh = make_seed()->compute(input(vol, *bur, T, v));
  EXPECT_EQ(again.force_N, fresh.force_N);
  EXPECT_TRUE(again.force_N.allFinite());
  EXPECT_GT(again.force_N.norm(), 0);
}

TEST(SeedFilter, WeightsAndBlendMatchHandComputation) {
  EXPECT_DOUBLE_EQ(seed::history_weight(0, 100), 1.3);
  EXPECT_DOUBLE_EQ(seed::history_weight(99, 100), 1.0);
  EXPECT_NEAR(seed::history_weight(33, 100), 1.2, 1e-15);
  EXPECT_NEAR(seed::history_weight(1, 3), 1.15, 1e-15);
  EXPECT_DOUBLE_EQ(seed::history_weight(0, 1), 1.3);
  // |a| = 3, |b| = 1: harmonic mean 1.5 along (1,1,0)/sqrt2.
  const Eigen::Vector3d h = seed::blend({3, 0, 0}, {0, 1, 0});
  EXPECT_NEAR(h.x(), 1.5 / std::sqrt(2.0), 1e-15);
  EXPECT_NEAR(h.y(), 1.5 / std::sqrt(2.0), 1e-15);
  EXPECT_EQ(h.z(), 0);
  // Same direction: the harmonic mean of the magnitudes along it.
  EXPECT_TRUE(seed::blend({0, 0, 1}, {0, 0, 4}).isApprox(Eigen::Vector3d(0, 0, 1.6)));
  // Zero magnitude: the harmonic mean's limit, zero; never NaN.
  EXPECT_TRUE(seed::blend({0, 0, 0}, {1, 0, 0}).isZero(0));
  EXPECT_TRUE(seed::blend({1, 0, 0}, {0, 0, 0}).isZero(0));
  // Opposite directions: f_raw's direction, harmonic-mean magnitude.
  EXPECT_TRUE(seed::blend({2, 0, 0}, {-1, 0, 0}).isApprox(Eigen::Vector3d(4.0 / 3, 0, 0)));
}

TEST(SeedFilter, ModelOutputMatchesHandComputedHistory) {
  const VoxelVolume vol = half_space();
  const auto bur = volume::sample_bur(BurParams::sphere(0.5), 3000);
  ASSERT_TRUE(bur.ok());
  SeedParams sp;
  sp.history = 3;  // weights 1.3, 1.15, 1.0
  const Eigen::Isometry3d T = down_at({0, 0, kSeedSurface - 0.2e-3});
  const Eigen::Vector3d f_coll = make_seed(sp)->compute(input(vol, *bur, T)).force_N;
  auto m = make_seed(sp);
  std::vector<Eigen::Vector3d> rendered;  // newest last
  for (int t = 0; t < 7; ++t) {
    const Eigen::Vector3d v(0.05 * t - 0.1, -0.03 * t, 0.02 * (t % 3));
    const Eigen::Vector3d raw = f_coll - sp.c2_N_s_per_m * v;
    Eigen::Vector3d expect = raw;
    if (!rendered.empty()) {
      Eigen::Vector3d acc = Eigen::Vector3d::Zero();
      double ws = 0;
      const double w[3] = {1.3, 1.15, 1.0};
      for (std::size_t a = 0; a < 3 && a < rendered.size(); ++a) {
        acc += w[a] * rendered[rendered.size() - 1 - a];
        ws += w[a];
      }
      expect = hand_H(raw, acc / ws);
    }
    const Eigen::Vector3d got = m->compute(input(vol, *bur, T, v)).force_N;
    EXPECT_TRUE(got.isApprox(expect, 1e-12)) << "t=" << t << " got " << got.transpose()
                                             << " expected " << expect.transpose();
    rendered.push_back(got);
  }
  // The engine may report the force it actually sent (after the guard).
  const Eigen::Vector3d sent(0.1, 0.2, 0.3);
  m->set_rendered_force(sent);
  rendered.back() = sent;
  const Eigen::Vector3d got = m->compute(input(vol, *bur, T)).force_N;
  const Eigen::Vector3d hist =
      (1.3 * rendered[6] + 1.15 * rendered[5] + 1.0 * rendered[4]) / 3.45;
  EXPECT_TRUE(got.isApprox(hand_H(f_coll, hist), 1e-12));
}

// Tilting a cylinder from tip contact (0 deg) to side contact (90 deg) in
// 0.05 deg steps, its lowest point 0.2 mm under the surface, one step per
// angle: the rendered force changes by less than kMaxJumpN per step. The
// seed model is not smooth (each sample entering adds c1 and moves the mean
// density); the bound says it has no spike: 0.015 N is < 2% of its ~1 N force
// (measured: 0.0045 N, the smoothing filter spreads each change).
TEST(SeedModel, TipToSideRotationHasNoForceJump) {
  constexpr double kMaxJumpN = 0.015;
  const VoxelVolume vol = half_space();
  const auto bur = volume::sample_bur(BurParams::cylinder(0.5, 3.0), 10000);
  ASSERT_TRUE(bur.ok());
  auto m = make_seed();
  Eigen::Vector3d prev = Eigen::Vector3d::Zero();
  double max_jump = 0;
  for (int i = 0; i <= 1800; ++i) {
    const double th = i * 0.05 * std::numbers::pi / 180;
    Eigen::Isometry3d T = down_at({0, 0, 0});
    T.linear() = Eigen::AngleAxisd(th, Eigen::Vector3d::UnitY()).toRotationMatrix() * T.linear();
    T.translation() = Eigen::Vector3d(0, 0, kSeedSurface - 0.2e-3 + 0.5e-3 * std::sin(th));
    const ForceOutput o = m->compute(input(vol, *bur, T));
    ASSERT_TRUE(o.force_N.allFinite());
    ASSERT_TRUE(o.in_contact) << i;
    if (i > 0) max_jump = std::max(max_jump, (o.force_N - prev).norm());
    prev = o.force_N;
  }
  EXPECT_LT(max_jump, kMaxJumpN);
  RecordProperty("max_jump_N", std::to_string(max_jump));
  std::printf("seed tip->side max force change per 0.05 deg step: %.4f N\n", max_jump);
}

TEST(SeedModel, ComputeDoesNotAllocate) {
  const VoxelVolume vol = half_space();
  const auto bur = volume::sample_bur(BurParams::capsule(0.5, 3.0), 10000);
  ASSERT_TRUE(bur.ok());
  auto m = make_seed();
  const long before = dentar::test::this_thread_allocations();
  double sink = 0;
  for (int i = 0; i < 300; ++i) {
    const ForceOutput o = m->compute(input(vol, *bur, down_at({0, 0, -0.1e-3 * (i % 5)})));
    sink += o.force_N.z();
  }
  EXPECT_EQ(dentar::test::this_thread_allocations() - before, 0);
  EXPECT_GT(sink, 0);
}

TEST(SeedModel, BadInputsGiveZeroForce) {
  const VoxelVolume vol = half_space();
  const auto bur = volume::sample_bur(BurParams::sphere(0.5), 1000);
  ASSERT_TRUE(bur.ok());
  auto m = make_seed();
  ForceInput in = input(vol, *bur, down_at({0, 0, -0.1e-3}));
  in.T_tooth_tip.translation().x() = std::nan("");
  EXPECT_TRUE(m->compute(in).force_N.isZero(0));
  in = input(vol, *bur, down_at({0, 0, -0.1e-3}));
  in.volume = nullptr;
  EXPECT_TRUE(m->compute(in).force_N.isZero(0));
}

TEST(ForceModelFactory, ValidatesNamesAndFields) {
  ForceModelParams p;
  EXPECT_FALSE(make_force_model("nope", p, {}, 1000).ok());
  EXPECT_NE(make_force_model("nope", p, {}, 1000).error().find("seed or proxy"), std::string::npos);
  EXPECT_FALSE(make_force_model("seed", p, {}, 0).ok());
  p.seed.history = 0;
  const auto r = make_force_model("seed", p, {}, 1000);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("seed.history"), std::string::npos);
  p = {};
  p.seed.c1_N = -1;
  EXPECT_FALSE(make_force_model("seed", p, {}, 1000).ok());
  EXPECT_EQ(make_force_model("seed", ForceModelParams{}, {}, 1000).value()->name(), "seed");
}

}  // namespace
}  // namespace dentar::haptics
