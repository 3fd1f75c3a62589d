// PenDevice: the tracked pen as a haptic device. A fresh pose is read back
// exactly; a stale, lost or non-finite pose is a device fault (zero force).
#include "dentar/live/pen_device.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>

namespace dentar::live {
namespace {

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

TEST(PenDevice, ReadsTheLatestPoseAndFaultsWhenStaleOrLost) {
  PenDevice pen(haptics::DeviceLimits{}, 0.2);
  haptics::DeviceState s;
  EXPECT_FALSE(pen.read(s));
  EXPECT_TRUE(s.fault) << "no pose yet";
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(0.01, -0.02, 0.03);
  T.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()).toRotationMatrix();
  pen.publish(T, true, now_s());
  ASSERT_TRUE(pen.read(s));
  EXPECT_FALSE(s.fault);
  EXPECT_TRUE(s.T_dev_sty.isApprox(T, 1e-15));
  EXPECT_FALSE(s.pedal) << "the pedal comes from a Pedal, never from the pen";
  // A second pose 33 ms later: the velocity follows.
  Eigen::Isometry3d T2 = T;
  T2.translation().x() += 0.0033;
  const double t1 = now_s();
  pen.publish(T, true, t1 - 0.033);
  ASSERT_TRUE(pen.read(s));
  pen.publish(T2, true, t1);
  ASSERT_TRUE(pen.read(s));
  EXPECT_NEAR(s.velocity_m_per_s.x(), 0.1, 1e-6);
  // Lost.
  pen.publish(T2, false, now_s());
  EXPECT_FALSE(pen.read(s));
  EXPECT_TRUE(s.fault);
  // Stale: the last pose is older than 200 ms.
  pen.publish(T2, true, now_s() - 0.3);
  EXPECT_FALSE(pen.read(s));
  EXPECT_TRUE(s.fault);
  // Non-finite.
  Eigen::Isometry3d bad = T;
  bad.translation().y() = std::nan("");
  pen.publish(bad, true, now_s());
  EXPECT_FALSE(pen.read(s));
  EXPECT_TRUE(s.fault);
  // The force the engine sent is kept for the HUD.
  pen.write_force(Eigen::Vector3d(0, 1.5, 0));
  EXPECT_EQ(pen.last_force().y(), 1.5);
}

}  // namespace
}  // namespace dentar::live
