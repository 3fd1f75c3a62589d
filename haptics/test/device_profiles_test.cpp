#include "dentar/haptics/device_profiles.h"

#include <gtest/gtest.h>

#include <limits>

#include "dentar/haptics/scripts.h"

namespace dentar::haptics {
namespace {

TEST(DeviceProfiles, TableHasTheIssueFiguresWithSources) {
  const DeviceProfile* touch = find_device_profile("touch");
  ASSERT_NE(touch, nullptr);
  EXPECT_EQ(touch->max_force_N, 3.3);
  EXPECT_EQ(touch->max_stiffness_N_per_m, 400.0);
  EXPECT_EQ(touch->max_damping_N_s_per_m, 4.0);
  EXPECT_EQ(touch->workspace_radius_m, 0.075);
  const DeviceProfile* falcon = find_device_profile("falcon");
  ASSERT_NE(falcon, nullptr);
  EXPECT_EQ(falcon->max_force_N, 8.0);
  EXPECT_EQ(falcon->max_stiffness_N_per_m, 3000.0);
  EXPECT_EQ(falcon->max_damping_N_s_per_m, 20.0);
  EXPECT_EQ(falcon->workspace_radius_m, 0.04);
  EXPECT_EQ(find_device_profile("omni")->max_stiffness_N_per_m, 700.0);
  for (const DeviceProfile& p : device_profiles()) {
    EXPECT_EQ(limits_from_profile(p).validate(), "") << p.id;
    EXPECT_NE(p.source.find("CHAI3D"), std::string::npos) << p.id;
    EXPECT_FALSE(p.mass_source.empty()) << p.id;
    EXPECT_TRUE(p.backend == "hd" || p.backend == "dhd") << p.id;
    EXPECT_GT(p.tip_mass_kg, 0) << p.id;
    EXPECT_EQ(find_device_profile(p.id), &p);
  }
}

TEST(DeviceProfiles, VendorModelNamesFindTheirProfile) {
  EXPECT_EQ(find_device_profile("PHANTOM Omni")->id, "omni");
  EXPECT_EQ(find_device_profile("phantom omni")->id, "omni");
  EXPECT_EQ(find_device_profile("Touch")->id, "touch");
  EXPECT_EQ(find_device_profile("omega.7")->id, "omega");
  EXPECT_EQ(find_device_profile("sigma.7")->id, "sigma");
  EXPECT_EQ(find_device_profile("delta.3")->id, "delta");
  EXPECT_EQ(find_device_profile("PHANTOM Premium 1.5 6DOF")->id, "premium");
  EXPECT_EQ(find_device_profile("Falcon")->id, "falcon");
  EXPECT_EQ(find_device_profile("nope"), nullptr);
  EXPECT_EQ(find_device_profile(""), nullptr);
}

TEST(DeviceProfiles, GainsFollowTheProfile) {
  const DeviceProfile& touch = *find_device_profile("touch");
  DeviceLimits limits;
  ForceModelParams params;
  ASSERT_TRUE(apply_profile(touch, {}, limits, params).ok());
  EXPECT_EQ(limits.max_force_N, 3.3);
  EXPECT_EQ(limits.max_stiffness_N_per_m, 400.0);
  EXPECT_EQ(params.proxy.stiffness_N_per_m, 0.8 * 400.0);
  EXPECT_LE(params.proxy.damping_N_s_per_m, 4.0);
  // The force model accepts them; the engine's guard clamps at the profile's force.
  EXPECT_TRUE(make_force_model("proxy", params, limits, 100).ok());
  EXPECT_TRUE(make_force_model("seed", params, limits, 100).ok());
  // User values at or below the profile are taken as given.
  ASSERT_TRUE(apply_profile(touch, {350.0, 3.0, 2.0}, limits, params).ok());
  EXPECT_EQ(params.proxy.stiffness_N_per_m, 350.0);
  EXPECT_EQ(params.proxy.damping_N_s_per_m, 3.0);
  EXPECT_EQ(params.seed.c2_N_s_per_m, 3.0);
  EXPECT_EQ(limits.max_force_N, 2.0);
}

TEST(DeviceProfiles, UserValuesAboveTheProfileAreRefusedWithAClearMessage) {
  const DeviceProfile& touch = *find_device_profile("touch");
  DeviceLimits limits;
  ForceModelParams params;
  const DeviceLimits before = limits;
  Status s = apply_profile(touch, {2000.0, 0, 0}, limits, params);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("stiffness = 2000 N/m is above"), std::string::npos) << s.error();
  EXPECT_NE(s.error().find("400 N/m"), std::string::npos) << s.error();
  EXPECT_NE(s.error().find("CHAI3D"), std::string::npos) << s.error();
  EXPECT_NE(s.error().find("--stiffness <= 400"), std::string::npos) << s.error();
  EXPECT_EQ(limits.max_stiffness_N_per_m, before.max_stiffness_N_per_m);  // untouched
  s = apply_profile(touch, {0, 10.0, 0}, limits, params);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("damping = 10 N s/m"), std::string::npos) << s.error();
  s = apply_profile(touch, {0, 0, 5.0}, limits, params);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("max force = 5 N"), std::string::npos) << s.error();
  EXPECT_NE(s.error().find("--max-force"), std::string::npos) << s.error();
  s = apply_profile(touch, {std::numeric_limits<double>::quiet_NaN(), 0, 0}, limits, params);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("finite"), std::string::npos) << s.error();
  s = apply_profile(touch, {-1, 0, 0}, limits, params);
  EXPECT_FALSE(s.ok());
}

TEST(DeviceProfiles, ForceModelsRefuseDampingAboveTheDevice) {
  DeviceLimits limits = limits_from_profile(*find_device_profile("touch"));
  ForceModelParams params;
  params.proxy.stiffness_N_per_m = 300;
  params.proxy.damping_N_s_per_m = 4.5;
  auto m = make_force_model("proxy", params, limits, 100);
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.error().find("proxy.damping_N_s_per_m"), std::string::npos) << m.error();
  params.seed.c2_N_s_per_m = 4.5;
  m = make_force_model("seed", params, limits, 100);
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.error().find("seed.c2_N_s_per_m"), std::string::npos) << m.error();
}

TEST(DeviceProfiles, ReachCheckSaysWhetherTheStylusReachesTheTooth) {
  const Eigen::AlignedBox3d tooth(Eigen::Vector3d(-5e-3, -5e-3, -3e-3), Eigen::Vector3d(5e-3, 5e-3, 9e-3));
  Eigen::Isometry3d T_sty_tip = Eigen::Isometry3d::Identity();
  T_sty_tip.translation() = Eigen::Vector3d(0, 0, 0.022);
  // Device workspace centre 6 cm below the tooth: a Touch (75 mm + 22 mm) reaches it.
  Eigen::Isometry3d T_tooth_dev = Eigen::Isometry3d::Identity();
  T_tooth_dev.translation() = Eigen::Vector3d(0, 0, -0.06);
  const DeviceLimits touch = limits_from_profile(*find_device_profile("touch"));
  ReachReport r = check_reach(touch, T_tooth_dev, T_sty_tip, tooth);
  EXPECT_TRUE(r.reachable) << r.message;
  EXPECT_NEAR(r.reach_m, 0.097, 1e-12);
  // The Falcon's 40 mm does not: the message names the shortfall and what to do.
  const DeviceLimits falcon = limits_from_profile(*find_device_profile("falcon"));
  r = check_reach(falcon, T_tooth_dev, T_sty_tip, tooth);
  EXPECT_FALSE(r.reachable);
  EXPECT_NEAR(r.worst_distance_m, std::sqrt(25e-6 + 25e-6 + 0.069 * 0.069), 1e-12);
  EXPECT_NE(r.message.find("cannot reach"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("move the device closer"), std::string::npos) << r.message;
  // The suggested move brings every corner kReachMargin_m inside the reach, and is no longer
  // than needed: 5 % less leaves the farthest corner short of that margin.
  ASSERT_TRUE(r.movable);
  EXPECT_GT(r.move_tooth_m.z(), 0);  // up, toward the tooth
  EXPECT_NE(r.message.find(" mm toward the tooth"), std::string::npos) << r.message;
  Eigen::Isometry3d moved = Eigen::Translation3d(r.move_tooth_m) * T_tooth_dev;
  ReachReport after = check_reach(falcon, moved, T_sty_tip, tooth);
  EXPECT_TRUE(after.reachable) << after.message;
  EXPECT_NEAR(after.worst_distance_m, after.reach_m - kReachMargin_m, 1e-6);
  moved = Eigen::Translation3d(0.95 * r.move_tooth_m) * T_tooth_dev;
  after = check_reach(falcon, moved, T_sty_tip, tooth);
  EXPECT_GT(after.worst_distance_m, after.reach_m - kReachMargin_m + 1e-4);
  // The default scripted station (issue 24: the workspace centre 28 mm above the tooth) is within
  // reach of every profile, the Falcon's 62 mm included; before, it stood 19 cm away.
  const Station st = default_station();
  for (const DeviceProfile& p : device_profiles())
    EXPECT_TRUE(check_reach(limits_from_profile(p), st.T_tooth_dev, st.T_sty_tip, tooth).reachable) << p.id;
  EXPECT_FALSE(check_reach(touch, T_tooth_dev, T_sty_tip, Eigen::AlignedBox3d()).reachable);
  // A tooth larger than the reach: no move helps, and the message says so.
  const Eigen::AlignedBox3d huge(Eigen::Vector3d::Constant(-0.1), Eigen::Vector3d::Constant(0.1));
  r = check_reach(falcon, T_tooth_dev, T_sty_tip, huge);
  EXPECT_FALSE(r.reachable);
  EXPECT_FALSE(r.movable);
  EXPECT_NE(r.message.find("larger than this device's reach"), std::string::npos) << r.message;
}

}  // namespace
}  // namespace dentar::haptics
