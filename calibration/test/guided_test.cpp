// Live step bookkeeping: the pivot stops itself once the tip is known to 0.2 mm and the gates
// pass; its hint names what is missing; touches go in order, refused while the tip moves.
#include "dentar/calibration/guided.h"

#include <gtest/gtest.h>

#include <random>

#include "dentar/calibration/co_location.h"
#include "dentar/calibration/station.h"

namespace dentar::calibration {
namespace {

StationCalibration truth() {
  StationCalibration t;
  t.T_sty_tip.translation() = Eigen::Vector3d(0.0004, -0.0003, 0.0225);
  return t;
}

TEST(LivePivot, StopsItselfAtTheTargetTipError) {
  std::mt19937_64 rng(4);
  const auto poses = simulate_pivot_poses(truth(), simulated_pivot_divot_dev(), 200, 25 * M_PI / 180, StylusNoise{}, rng);
  LivePivot p;
  int used = 0;
  for (const auto& T : poses) {
    p.add(T);
    ++used;
    if (p.done()) break;
  }
  ASSERT_TRUE(p.done()) << p.hint();
  EXPECT_LT(used, 200);
  EXPECT_GE(p.poses(), 10);
  EXPECT_LE(p.tip_sd_m(), 0.2e-3);
  EXPECT_NE(p.hint().find("done"), std::string::npos);
  const PivotSummary r = p.final_result();
  ASSERT_TRUE(r.ok) << r.message;
  // The predicted error is honest: the true error is within 3 sigma.
  EXPECT_LT((r.p_tip_sty - truth().T_sty_tip.translation()).norm(), 3 * p.tip_sd_m());
}

TEST(LivePivot, HintsNameWhatIsMissingAndStillPosesAreNotCounted) {
  LivePivot p;
  const Eigen::Vector3d tip = truth().T_sty_tip.translation(), divot(0.01, 0.02, 0.03);
  auto pose = [&](const Eigen::AngleAxisd& R) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = R.toRotationMatrix();
    T.translation() = divot - T.linear() * tip;
    return T;
  };
  // Held still: one pose only.
  for (int i = 0; i < 50; ++i) p.add(pose(Eigen::AngleAxisd(0, Eigen::Vector3d::UnitX())));
  EXPECT_EQ(p.poses(), 1);
  // Rocking in one plane only (about x): the weakest direction stays at zero.
  for (int i = -20; i <= 20; ++i) p.add(pose(Eigen::AngleAxisd(i * M_PI / 180, Eigen::Vector3d::UnitX())));
  EXPECT_FALSE(p.done());
  EXPECT_NE(p.hint().find("not only in one plane"), std::string::npos) << p.hint();
}

TEST(LiveTouches, InOrderAndMovingTouchesRefused) {
  LiveTouches t("divot", 4);
  double time = 0;
  auto hold = [&](const Eigen::Vector3d& p, double secs) {
    for (int i = 0; i < secs * 60; ++i) t.add_sample(time += 1 / 60.0, p);
  };
  hold(Eigen::Vector3d(0, 0, 0), 0.8);
  EXPECT_TRUE(t.take().ok);
  EXPECT_EQ(t.next(), 1);
  // Pressed while still arriving: refused, same divot next.
  for (int i = 0; i < 40; ++i) t.add_sample(time += 1 / 60.0, Eigen::Vector3d(0.01 + 1e-4 * i, 0, 0));
  const TouchResult r = t.take();
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("divot 1: touch refused: the stylus moved"), std::string::npos) << r.message;
  EXPECT_EQ(t.next(), 1);
  EXPECT_EQ(t.refused(), 1);
  hold(Eigen::Vector3d(0.02, 0, 0), 0.8);
  EXPECT_TRUE(t.take().ok);
  hold(Eigen::Vector3d(0.0, 0.02, 0), 0.8);
  EXPECT_TRUE(t.take().ok);
  // Three points always lie in a plane: no running fit before the fourth.
  EXPECT_TRUE(running_fit(t.taken_dev(), {{0.1, 0, 0}, {0.12, 0, 0}, {0.1, 0.02, 0}}, Eigen::Vector3d::Zero())
                  .residuals_m.empty());
  hold(Eigen::Vector3d(0.0, 0.0, 0.02), 0.8);
  EXPECT_TRUE(t.take().ok);
  EXPECT_TRUE(t.done());
  EXPECT_FALSE(t.take().ok);
  // The running fit of the four touches against their known positions (a pure shift).
  const std::vector<Eigen::Vector3d> known = {{0.1, 0, 0}, {0.12, 0, 0}, {0.1, 0.02, 0}, {0.1, 0, 0.02}};
  const RegistrationSummary f = running_fit(t.taken_dev(), known, Eigen::Vector3d(0.11, 0.01, 0.01));
  ASSERT_FALSE(f.residuals_m.empty()) << f.message;
  EXPECT_LT(f.fre_m, 1e-6);
  EXPECT_LT((f.T_man_dev * Eigen::Vector3d(0, 0, 0) - known[0]).norm(), 1e-6);
}

}  // namespace
}  // namespace dentar::calibration
