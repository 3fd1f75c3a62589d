// Touch detection: a still tip is taken, a moving or briefly seen tip is refused with the reason.
#include "dentar/calibration/touch.h"

#include <gtest/gtest.h>

#include <random>

namespace dentar::calibration {
namespace {

TEST(Touch, StillTipIsTakenAtItsMean) {
  TouchDetector d;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n(0, 0.03e-3);  // tracking noise of a good device
  const Eigen::Vector3d p(0.01, -0.02, 0.05);
  for (int i = 0; i < 30; ++i) d.add(i / 30.0, p + Eigen::Vector3d(n(rng), n(rng), n(rng)));
  EXPECT_TRUE(d.still());
  const TouchResult r = d.take("divot 2");
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_LT((r.tip - p).norm(), 0.03e-3);
  EXPECT_LT(r.travel_m, 0.15e-3);
}

TEST(Touch, MovingStylusIsRefusedWithHowFarItMoved) {
  TouchDetector d;
  // 2 mm/s drift: 1 mm over the 0.5 s window.
  for (int i = 0; i < 30; ++i) d.add(i / 30.0, Eigen::Vector3d(2e-3 * i / 30.0, 0, 0));
  EXPECT_FALSE(d.still());
  const TouchResult r = d.take("divot 2");
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("divot 2: touch refused: the stylus moved by 0.5"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("hold the tip still"), std::string::npos);
}

TEST(Touch, TooShortOrInterruptedIsRefused) {
  TouchDetector d;
  for (int i = 0; i < 6; ++i) d.add(i / 30.0, Eigen::Vector3d::Zero());
  TouchResult r = d.take("landmark 0");
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("seen for only"), std::string::npos) << r.message;
  // A lost pose (NaN) restarts the window.
  for (int i = 6; i < 30; ++i) d.add(i / 30.0, Eigen::Vector3d::Zero());
  EXPECT_TRUE(d.still());
  d.add(1.0, Eigen::Vector3d::Constant(NAN));
  EXPECT_FALSE(d.still());
  // So does a gap longer than max_gap_s.
  for (int i = 0; i < 30; ++i) d.add(2.0 + i / 30.0, Eigen::Vector3d::Zero());
  EXPECT_TRUE(d.still());
  d.add(4.0, Eigen::Vector3d::Zero());
  EXPECT_FALSE(d.still());
}

TEST(Touch, OptionsAreValidated) {
  TouchOptions o;
  EXPECT_EQ(o.validate(), "");
  o.still_m = 0;
  EXPECT_NE(o.validate().find("still_m"), std::string::npos);
}

}  // namespace
}  // namespace dentar::calibration
