#include "dentar/calibration/station.h"

#include <gtest/gtest.h>

namespace dentar::calibration {
namespace {

StationCalibration good() {
  StationCalibration s;
  s.camera = {1280, 720, 900, 900, 640, 360, {0.1, -0.2, 0, 0, 0}};
  s.T_man_tooth.translation() = Eigen::Vector3d(0.01, 0.02, 0.03);
  s.T_man_dev = Eigen::Translation3d(0.2, 0, -0.1) * Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ());
  return s;
}

TEST(Station, ToothFromDeviceComposesTheStaticTransforms) {
  const StationCalibration s = good();
  ASSERT_EQ(s.validate(), "");
  const Eigen::Vector3d p_dev(0.01, -0.02, 0.05);
  const Eigen::Vector3d via_man = s.T_man_tooth.inverse() * (s.T_man_dev * p_dev);
  EXPECT_TRUE((s.T_tooth_dev() * p_dev).isApprox(via_man, 1e-12));
}

TEST(Station, ValidateNamesTheBadField) {
  StationCalibration s = good();
  s.camera.fx = 0;
  EXPECT_NE(s.validate().find("fx"), std::string::npos);
  s = good();
  s.T_man_dev.linear() *= 1.1;  // scaled: not rigid
  EXPECT_NE(s.validate().find("T_man_dev"), std::string::npos);
  s = good();
  s.T_sty_tip.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(s.validate().find("T_sty_tip"), std::string::npos);
  s = good();
  s.T_man_tooth.translation() = Eigen::Vector3d(120, 0, 0);  // millimetres by mistake
  EXPECT_NE(s.validate().find("metres"), std::string::npos);
  s = good();
  s.mirror_radius_m = 11;
  EXPECT_NE(s.validate().find("mirror_radius_m"), std::string::npos);
}

}  // namespace
}  // namespace dentar::calibration
