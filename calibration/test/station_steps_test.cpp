// The station calibration steps against a simulated truth with noise (co_location.h), and
// Monte-Carlo checks that the reported uncertainties match the observed scatter.
#include <gtest/gtest.h>

#include <cmath>

#include "dentar/calibration/co_location.h"
#include "dentar/calibration/landmarks.h"
#include "dentar/calibration/mirror.h"
#include "dentar/calibration/pivot.h"
#include "dentar/calibration/registration.h"

namespace dentar::calibration {
namespace {

// A station like the default one: tooth in the mouth, device below and in front.
StationCalibration nominal() {
  StationCalibration c;
  c.camera.width = 640;
  c.camera.height = 480;
  c.camera.fx = c.camera.fy = 600;
  c.camera.cx = 320;
  c.camera.cy = 240;
  c.T_man_tooth.translation() = Eigen::Vector3d(0.021, -0.016, -0.025);
  c.T_man_tooth.linear() = Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  c.T_man_dev.translation() = Eigen::Vector3d(0.02, -0.136, 0.125);
  c.T_sty_tip.translation() = Eigen::Vector3d(0, 0, 0.022);
  c.T_mtag_mir.translation() = Eigen::Vector3d(-0.08, 0.01, 0.004);
  c.mirror_radius_m = 0.011;
  return c;
}

// 8 divots on a face-like curved surface around the mouth (man frame, m).
std::vector<Eigen::Vector3d> divots_man() {
  std::vector<Eigen::Vector3d> d;
  const double spots[8][2] = {{-32, 0}, {32, 0}, {-30, 15}, {30, 15}, {-58, -25}, {58, -25}, {0, -35}, {0, 35}};
  for (const auto& s : spots) {
    const double az = s[0] * M_PI / 180, el = s[1] * M_PI / 180;
    d.push_back(Eigen::Vector3d(0, 0.03, -0.085) +
                Eigen::Vector3d(0.075 * std::sin(az) * std::cos(el), 0.105 * std::sin(el),
                                0.095 * std::cos(az) * std::cos(el)));
  }
  return d;
}

std::vector<Eigen::Vector3d> landmarks_tooth() {
  std::vector<Eigen::Vector3d> l;
  for (const auto& q : {Eigen::Vector3d(-2.5, -2.8, 6.6), Eigen::Vector3d(2.5, -2.8, 6.6),
                        Eigen::Vector3d(2.5, 2.8, 6.6), Eigen::Vector3d(-2.5, 2.8, 6.6),
                        Eigen::Vector3d(0, -5.3, 0.3), Eigen::Vector3d(0, 5.3, 0.3)})
    l.push_back(q * 1e-3);
  return l;
}

TEST(StationSteps, PivotRecoversTheTipWithSimulatedNoise) {
  const StationCalibration truth = simulated_truth(nominal(), 3);
  std::mt19937_64 rng(5);
  const StylusNoise noise;
  const auto poses = simulate_pivot_poses(truth, simulated_pivot_divot_dev(), 20, 0.45, noise, rng);
  const PivotSummary s = calibrate_pivot(poses);
  ASSERT_TRUE(s.ok) << s.message;
  EXPECT_LE(s.rmse_m, 0.3e-3);
  EXPECT_LT((s.p_tip_sty - truth.T_sty_tip.translation()).norm(), 0.3e-3);
  EXPECT_LT((s.p_divot_dev - simulated_pivot_divot_dev()).norm(), 0.3e-3);
}

TEST(StationSteps, PivotWithTooLittleRotationIsRefused) {
  const StationCalibration truth = simulated_truth(nominal(), 3);
  std::mt19937_64 rng(5);
  const auto poses = simulate_pivot_poses(truth, simulated_pivot_divot_dev(), 20, 0.08, {}, rng);
  const PivotSummary s = calibrate_pivot(poses);
  EXPECT_FALSE(s.ok);
  EXPECT_FALSE(s.message.empty());
}

// Monte-Carlo: the pivot covariance predicts the tip's scatter.
TEST(StationSteps, PivotCovarianceMatchesMonteCarloScatter) {
  const StationCalibration truth = simulated_truth(nominal(), 4);
  std::mt19937_64 rng(6);
  const int trials = 300;
  double err2 = 0, pred2 = 0;
  for (int t = 0; t < trials; ++t) {
    const auto poses = simulate_pivot_poses(truth, simulated_pivot_divot_dev(), 15, 0.45, {}, rng);
    const PivotSummary s = calibrate_pivot(poses);
    ASSERT_TRUE(s.ok) << s.message;
    err2 += (s.p_tip_sty - truth.T_sty_tip.translation()).squaredNorm();
    pred2 += s.cov_tip_sty.trace();
  }
  const double ratio = std::sqrt(err2 / pred2);
  std::printf("pivot: observed/predicted tip error = %.3f\n", ratio);
  EXPECT_GT(ratio, 0.6);
  EXPECT_LT(ratio, 1.6);
}

// Registration with 8 divots and 0.2 mm FLE: TRE at the tooth <= 0.3 mm (goal), and the
// predicted TRE matches the observed error over many trials.
TEST(StationSteps, RegistrationTreMatchesMonteCarloAndMeetsTheGoal) {
  const StationCalibration truth = simulated_truth(nominal(), 5);
  const auto d_man = divots_man();
  std::vector<Eigen::Vector3d> d_dev;
  for (const auto& p : d_man) d_dev.push_back(truth.T_man_dev.inverse() * p);
  const Eigen::Vector3d target = truth.T_man_tooth * Eigen::Vector3d(0, 0, 4e-3);
  std::mt19937_64 rng(7);
  StylusNoise noise;
  noise.fle_m = 0.2e-3;
  RegistrationOptions o;
  o.fle_m = noise.fle_m;  // known FLE: the prediction is then Fitzpatrick's formula alone
  const int trials = 300;
  double err2 = 0, pred = 0;
  for (int t = 0; t < trials; ++t) {
    const auto touches = simulate_touches(truth, d_dev, noise, rng);
    std::vector<Eigen::Vector3d> p_dev;
    for (const auto& T : touches) p_dev.push_back((T * truth.T_sty_tip).translation());
    const RegistrationSummary s = register_divots(p_dev, d_man, target, o);
    ASSERT_TRUE(s.ok) << s.report();
    err2 += (s.T_man_dev * (truth.T_man_dev.inverse() * target) - target).squaredNorm();
    pred = s.tre_m;
  }
  const double observed = std::sqrt(err2 / trials);
  std::printf("registration: predicted TRE %.3f mm, observed RMS %.3f mm\n", pred * 1e3, observed * 1e3);
  EXPECT_LE(pred, 0.3e-3);
  EXPECT_GT(observed / pred, 0.6);
  EXPECT_LT(observed / pred, 1.6);
}

TEST(StationSteps, LandmarksRefineTheToothPlacement) {
  const StationCalibration nom = nominal();
  const StationCalibration truth = simulated_truth(nom, 8);
  std::mt19937_64 rng(9);
  std::normal_distribution<double> n(0.0, 0.2e-3 / std::sqrt(3.0));
  std::vector<Eigen::Vector3d> touched;
  for (const auto& l : landmarks_tooth())
    touched.push_back(truth.T_man_tooth * l + Eigen::Vector3d(n(rng), n(rng), n(rng)));
  LandmarkOptions o;
  o.fle_m = 0.2e-3;
  const LandmarkSummary s = refine_tooth_placement(landmarks_tooth(), touched, nom.T_man_tooth, o);
  ASSERT_TRUE(s.ok) << s.report();
  const Eigen::Vector3d target(0, 0, 4e-3);
  EXPECT_LT((s.T_man_tooth * target - truth.T_man_tooth * target).norm(), 0.35e-3);
  EXPECT_GT(s.shift_m, 0.1e-3);  // the truth differs from the nominal and the fit saw it
  // A nominal placement 6 mm off means the wrong tooth or a bad file: refused.
  Eigen::Isometry3d wrong = nom.T_man_tooth;
  wrong.translation().x() += 6e-3;
  const LandmarkSummary w = refine_tooth_placement(landmarks_tooth(), touched, wrong, o);
  EXPECT_FALSE(w.ok);
  EXPECT_NE(w.message.find("moved"), std::string::npos) << w.message;
  // Too few landmarks.
  const LandmarkSummary f = refine_tooth_placement({landmarks_tooth()[0], landmarks_tooth()[1]},
                                                   {touched[0], touched[1]}, nom.T_man_tooth, o);
  EXPECT_FALSE(f.ok);
}

std::vector<Eigen::Vector3d> rim_points(const StationCalibration& truth, int n, double span_rad,
                                        double sigma, std::mt19937_64& rng) {
  std::normal_distribution<double> g(0.0, sigma);
  std::vector<Eigen::Vector3d> rim;
  for (int i = 0; i < n; ++i) {
    const double a = span_rad * i / n + 0.3;
    rim.push_back(truth.T_mtag_mir * Eigen::Vector3d(truth.mirror_radius_m * std::cos(a),
                                                     truth.mirror_radius_m * std::sin(a), 0) +
                  Eigen::Vector3d(g(rng), g(rng), g(rng)));
  }
  return rim;
}

TEST(StationSteps, MirrorRecoversPlaneCentreAndRadius) {
  const StationCalibration nom = nominal();
  const StationCalibration truth = simulated_truth(nom, 10);
  std::mt19937_64 rng(11);
  const double sigma = 0.15e-3;
  const auto rim = rim_points(truth, 8, 2 * M_PI, sigma, rng);
  const Eigen::Vector3d centre = truth.T_mtag_mir.translation();
  const MirrorSummary s = calibrate_mirror(rim, centre, nom.T_mtag_mir);
  ASSERT_TRUE(s.ok) << s.report();
  EXPECT_NEAR(s.radius_m, truth.mirror_radius_m, 0.2e-3);
  EXPECT_LT((s.T_mtag_mir.translation() - centre).norm(), 0.3e-3);
  const double tilt = std::acos(s.T_mtag_mir.linear().col(2).dot(truth.T_mtag_mir.linear().col(2)));
  EXPECT_LT(tilt, 2.0 * M_PI / 180);
  EXPECT_TRUE(check_rigid(s.T_mtag_mir, "T").empty());
}

TEST(StationSteps, MirrorGates) {
  const StationCalibration nom = nominal();
  std::mt19937_64 rng(12);
  const Eigen::Vector3d centre = nom.T_mtag_mir.translation();
  // Too few rim points.
  EXPECT_FALSE(calibrate_mirror(rim_points(nom, 3, 2 * M_PI, 0, rng), centre, nom.T_mtag_mir).ok);
  // Rim points bunched on a quarter of the rim.
  const MirrorSummary q = calibrate_mirror(rim_points(nom, 6, M_PI / 2, 0, rng), centre, nom.T_mtag_mir);
  EXPECT_FALSE(q.ok);
  EXPECT_NE(q.message.find("cover only"), std::string::npos) << q.message;
  // The centre touched 2 mm off.
  const MirrorSummary c = calibrate_mirror(rim_points(nom, 8, 2 * M_PI, 0, rng),
                                           centre + nom.T_mtag_mir.linear().col(0) * 2e-3,
                                           nom.T_mtag_mir);
  EXPECT_FALSE(c.ok);
  EXPECT_NE(c.message.find("centre"), std::string::npos) << c.message;
}

TEST(StationSteps, SimulatedTruthIsDeterministicAndDiffersFromNominal) {
  const StationCalibration a = simulated_truth(nominal(), 1), b = simulated_truth(nominal(), 1);
  EXPECT_TRUE(a.T_man_dev.isApprox(b.T_man_dev));
  EXPECT_GT((a.T_man_dev.translation() - nominal().T_man_dev.translation()).norm(), 0.5e-3);
  EXPECT_TRUE(a.validate().empty()) << a.validate();
}

}  // namespace
}  // namespace dentar::calibration
