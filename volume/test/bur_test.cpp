#include "dentar/volume/bur.h"

#include <gtest/gtest.h>

#include <numbers>

namespace dentar::volume {
namespace {

std::vector<BurParams> all_burs() {
  return {BurParams::sphere(0.5), BurParams::cylinder(0.5, 3.0), BurParams::capsule(0.5, 3.0),
          BurParams::cone(0.2, 0.6, 4.0)};
}

class BurProperty : public ::testing::TestWithParam<int> {};

// Property tests run once per bur shape.
TEST_P(BurProperty, SamplesAreInsideExactCountAndDeterministic) {
  const BurParams p = all_burs()[static_cast<std::size_t>(GetParam())];
  for (int n : {1000, 3000, 10000, 30000}) {
    auto s = sample_bur(p, n);
    ASSERT_TRUE(s.ok()) << s.error();
    ASSERT_EQ(s->size(), static_cast<std::size_t>(n));
    ASSERT_EQ(s->region.size(), s->points_m.size());
    for (const auto& q : s->points_m) ASSERT_LE(p.signed_distance(q.cast<double>()), 1e-9);
    EXPECT_DOUBLE_EQ(s->sample_volume_m3 * n, p.volume_m3());
    auto again = sample_bur(p, n);
    ASSERT_TRUE(again.ok());
    EXPECT_EQ(again->points_m, s->points_m);
  }
}

TEST_P(BurProperty, SamplesAreUniform) {
  // Uniform interior sampling: the fraction of points in a sub-region matches
  // its volume fraction. Use the half z > z_mid, whose volume we integrate.
  const BurParams p = all_burs()[static_cast<std::size_t>(GetParam())];
  auto s = sample_bur(p, 20000);
  ASSERT_TRUE(s.ok());
  const double L = p.shape == BurShape::kSphere ? 2 * p.radius_m : p.length_m;
  const double zc = -0.5 * L;
  int above = 0;
  for (const auto& q : s->points_m) above += q.z() > zc ? 1 : 0;
  // Reference fraction by brute-force grid integration of the SDF.
  int in = 0, in_above = 0;
  const int g = 60;
  for (int a = 0; a < g; ++a)
    for (int b = 0; b < g; ++b)
      for (int c = 0; c < g; ++c) {
        const Eigen::Vector3d q((2.0 * (a + 0.5) / g - 1) * p.radius_m,
                                (2.0 * (b + 0.5) / g - 1) * p.radius_m, -(c + 0.5) / g * L);
        if (p.signed_distance(q) <= 0) {
          ++in;
          in_above += q.z() > zc ? 1 : 0;
        }
      }
  EXPECT_NEAR(above / 20000.0, static_cast<double>(in_above) / in, 0.01);
  // And the grid volume matches the closed form.
  const double cell = (2 * p.radius_m / g) * (2 * p.radius_m / g) * (L / g);
  EXPECT_NEAR(in * cell / p.volume_m3(), 1.0, 0.02);
}

TEST_P(BurProperty, RegionsFollowTheDefinition) {
  const BurParams p = all_burs()[static_cast<std::size_t>(GetParam())];
  auto s = sample_bur(p, 5000);
  ASSERT_TRUE(s.ok());
  int tips = 0;
  for (std::size_t i = 0; i < s->size(); ++i) {
    const bool tip = s->region[i] == BurRegion::kTip;
    tips += tip;
    if (p.shape == BurShape::kSphere) {
      EXPECT_FALSE(tip);
    } else {
      EXPECT_EQ(tip, s->points_m[i].z() > -p.tip_region_length_m());
    }
  }
  if (p.shape != BurShape::kSphere) {
    EXPECT_GT(tips, 0);
    EXPECT_LT(tips, 5000);
    EXPECT_FLOAT_EQ(s->tip_body_point_m.z(), static_cast<float>(-p.tip_region_length_m()));
  } else {
    EXPECT_FLOAT_EQ(s->tip_body_point_m.z(), static_cast<float>(-p.radius_m));
  }
}

INSTANTIATE_TEST_SUITE_P(AllShapes, BurProperty, ::testing::Range(0, 4),
                         [](const auto& info) {
                           return std::string(bur_shape_name(
                               all_burs()[static_cast<std::size_t>(info.param)].shape));
                         });

TEST(Bur, SignedDistanceKnownValues) {
  const auto cyl = BurParams::cylinder(0.5, 3.0);
  EXPECT_NEAR(cyl.signed_distance({0, 0, 0.001}), 0.001, 1e-12);        // above the flat end
  EXPECT_NEAR(cyl.signed_distance({0.0007, 0, -0.001}), 0.0002, 1e-12);  // beside
  EXPECT_NEAR(cyl.signed_distance({0, 0, -0.0002}), -0.0002, 1e-12);     // inside near the end
  const auto cap = BurParams::capsule(0.5, 3.0);
  EXPECT_NEAR(cap.signed_distance({0, 0, 0.001}), 0.001, 1e-12);  // round end apex at z=0
  EXPECT_NEAR(cap.signed_distance({0.0005, 0, 0.0}), std::sqrt(2) * 0.0005 - 0.0005, 1e-12);
  const auto cone = BurParams::cone(0.2, 0.6, 4.0);
  EXPECT_NEAR(cone.signed_distance({0.0002, 0, 0.0}), 0.0, 1e-12);
  EXPECT_LT(cone.signed_distance({0.00055, 0, -0.0039}), 0.0);
  EXPECT_GT(cone.signed_distance({0.00055, 0, -0.0001}), 0.0);
  EXPECT_NEAR(BurParams::sphere(0.5).volume_m3(), 4.0 / 3.0 * std::numbers::pi * 1.25e-10, 1e-20);
}

TEST(Bur, BadParamsAndCountsAreRejectedWithTheField) {
  EXPECT_NE(sample_bur(BurParams::sphere(0.5), 0).error().find("sample count 0"), std::string::npos);
  EXPECT_NE(sample_bur(BurParams::sphere(0.5), 1000000).error().find("sample count"),
            std::string::npos);
  EXPECT_NE(sample_bur(BurParams::sphere(500), 100).error().find("radius"), std::string::npos);
  EXPECT_NE(sample_bur(BurParams::cone(0.7, 0.6, 4), 100).error().find("tip radius"),
            std::string::npos);
  EXPECT_NE(sample_bur(BurParams::capsule(1.0, 0.5), 100).error().find("shorter"),
            std::string::npos);
  BurParams nan = BurParams::cylinder(0.5, 3);
  nan.length_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(sample_bur(nan, 100).ok());
  EXPECT_TRUE(parse_bur_shape("cone").ok());
  EXPECT_NE(parse_bur_shape("drill").error().find("sphere, cylinder, capsule, cone"),
            std::string::npos);
}

}  // namespace
}  // namespace dentar::volume
