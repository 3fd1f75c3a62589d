#include "dentar/haptics/force_guard.h"

#include <gtest/gtest.h>

#include <limits>

namespace dentar::haptics {
namespace {

TEST(ForceGuard, ClampsMagnitudeToTheDeviceMaximum) {
  ForceGuard g({3.0, 1e9});
  const Eigen::Vector3d f = g.apply({30, 40, 0}, 1e-3);
  EXPECT_NEAR(f.norm(), 3.0, 1e-12);
  EXPECT_NEAR(f.x() / f.y(), 0.75, 1e-12);  // direction kept
  EXPECT_EQ(g.clamped_steps(), 1u);
}

TEST(ForceGuard, NonFiniteInputLatchesZeroForceUntilReset) {
  ForceGuard g({3.0, 1e9});
  g.apply({1, 0, 0}, 1e-3);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(g.apply({nan, 0, 0}, 1e-3), Eigen::Vector3d::Zero());
  EXPECT_EQ(g.fault(), GuardFault::kNonFinite);
  EXPECT_EQ(g.apply({1, 0, 0}, 1e-3), Eigen::Vector3d::Zero());  // still latched
  g.reset();
  EXPECT_EQ(g.apply({1, 0, 0}, 1e-3), Eigen::Vector3d(1, 0, 0));
  EXPECT_EQ(g.apply({1, 0, 0}, std::numeric_limits<double>::infinity()), Eigen::Vector3d::Zero());
}

TEST(ForceGuard, LimitsTheRateSoAStepBecomesARamp) {
  ForceGuard g({3.0, 1000.0});  // 1 N per ms
  EXPECT_NEAR(g.apply({0, 0, 2.5}, 1e-3).z(), 1.0, 1e-12);
  EXPECT_NEAR(g.apply({0, 0, 2.5}, 1e-3).z(), 2.0, 1e-12);
  EXPECT_NEAR(g.apply({0, 0, 2.5}, 1e-3).z(), 2.5, 1e-12);
  EXPECT_EQ(g.rate_limited_steps(), 2u);
}

TEST(ForceGuard, LimitsValidateNamesTheField) {
  EXPECT_TRUE(ForceLimits{}.validate().empty());
  EXPECT_NE((ForceLimits{-1, 10}).validate().find("max_force_N"), std::string::npos);
  EXPECT_NE((ForceLimits{3, 0}).validate().find("max_force_rate"), std::string::npos);
}

}  // namespace
}  // namespace dentar::haptics
