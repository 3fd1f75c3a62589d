#include "dentar/calibration/intrinsics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace dentar::calibration {
namespace {

CameraIntrinsics truth_camera() {
  CameraIntrinsics k;
  k.width = 640;
  k.height = 480;
  k.fx = 600;
  k.fy = 600;
  k.cx = 322;
  k.cy = 238;
  k.dist = {-0.12, 0.05, 0.0005, -0.0003, 0.0};
  return k;
}

// Views of `spec` seen from `poses` with Gaussian pixel noise sigma_px.
std::vector<BoardView> make_views(const CameraIntrinsics& k, const ChessboardSpec& spec,
                                  const std::vector<Eigen::Isometry3d>& poses, double sigma_px,
                                  std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, sigma_px);
  std::vector<BoardView> views;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    BoardView v;
    v.name = "sim-" + std::to_string(i);
    for (const auto& p : spec.object_points()) {
      Eigen::Vector2d px;
      if (!project_point(k, poses[i] * p, px)) continue;
      v.image_points.push_back(px + Eigen::Vector2d(n(rng), n(rng)));
      v.object_points.push_back(p);
    }
    views.push_back(std::move(v));
  }
  return views;
}

const ChessboardSpec kBoard{9, 6, 0.025};

TEST(Intrinsics, RecoversKnownIntrinsicsWithNoise) {
  const CameraIntrinsics k = truth_camera();
  std::mt19937_64 rng(7);
  auto poses = plan_board_poses(k, 8 * 0.025, 5 * 0.025, 12, 3);
  auto views = make_views(k, kBoard, poses, 0.2, rng);
  IntrinsicsSummary s = calibrate_intrinsics(views, 640, 480);
  ASSERT_TRUE(s.ok) << s.report();
  EXPECT_NEAR(s.camera.fx, k.fx, 2.0);
  EXPECT_NEAR(s.camera.fy, k.fy, 2.0);
  EXPECT_NEAR(s.camera.cx, k.cx, 2.0);
  EXPECT_NEAR(s.camera.cy, k.cy, 2.0);
  EXPECT_NEAR(s.camera.dist[0], k.dist[0], 0.02);
  // RMS of the 2-D reprojection distance: sqrt(2) times the per-coordinate noise.
  EXPECT_NEAR(s.rms_px, 0.2 * std::sqrt(2.0), 0.05);
  EXPECT_EQ(s.used_views.size(), 12u);
  EXPECT_TRUE(s.rejected.empty()) << s.report();
  ASSERT_EQ(s.std_devs.size(), 9u);
  EXPECT_GT(s.std_devs[0], 0.0);
  EXPECT_LT(s.std_devs[0], 2.0);
  EXPECT_GT(s.tilt_spread_rad, 0.2);
  EXPECT_GE(s.coverage.tooth_fraction, 0.75);
  // Board poses come back too.
  EXPECT_LT((s.T_cam_board[0].translation() - poses[0].translation()).norm(), 2e-3);
  const CameraFile f = s.to_camera_file("sim cam");
  EXPECT_TRUE(f.validate().empty()) << f.validate();
  EXPECT_EQ(f.views_used, 12);
}

TEST(Intrinsics, RejectsTheBadViewAndSaysWhy) {
  const CameraIntrinsics k = truth_camera();
  std::mt19937_64 rng(11);
  auto views = make_views(k, kBoard, plan_board_poses(k, 0.2, 0.125, 12, 5), 0.15, rng);
  // View 4: a mis-detection: the second half of the corners shifted by 2.5 px.
  for (std::size_t j = views[4].image_points.size() / 2; j < views[4].image_points.size(); ++j)
    views[4].image_points[j] += Eigen::Vector2d(2.5, -1.5);
  IntrinsicsSummary plain_opts_summary;
  {
    IntrinsicsOptions o;
    o.reject_outliers = false;
    plain_opts_summary = calibrate_intrinsics(views, 640, 480, o);
  }
  IntrinsicsSummary s = calibrate_intrinsics(views, 640, 480);
  ASSERT_TRUE(s.ok) << s.report();
  ASSERT_EQ(s.rejected.size(), 1u) << s.report();
  EXPECT_EQ(s.rejected[0].index, 4);
  EXPECT_EQ(s.rejected[0].name, "sim-4");
  EXPECT_NE(s.rejected[0].reason.find("px"), std::string::npos);
  EXPECT_LT(s.rms_px, 0.25);
  EXPECT_GT(plain_opts_summary.rms_px, 1.3 * s.rms_px);
  EXPECT_TRUE(plain_opts_summary.rejected.empty());
  EXPECT_NEAR(s.camera.fx, k.fx, 2.0);
}

TEST(Intrinsics, RationalModelIsOptionalAndWarns) {
  CameraIntrinsics k = truth_camera();
  std::mt19937_64 rng(17);
  auto views = make_views(k, kBoard, plan_board_poses(k, 0.2, 0.125, 12, 8), 0.1, rng);
  IntrinsicsOptions o;
  o.model = DistortionModel::kRational8;
  IntrinsicsSummary s = calibrate_intrinsics(views, 640, 480, o);
  ASSERT_TRUE(s.ok) << s.report();
  EXPECT_EQ(s.model, kModelRational8);
  ASSERT_EQ(s.dist.size(), 8u);
  ASSERT_EQ(s.std_devs.size(), 12u);
  EXPECT_NEAR(s.camera.fx, k.fx, 3.0);
  bool warned = false;
  for (const auto& w : s.warnings) warned |= w.find("k1 k2 p1 p2 k3") != std::string::npos;
  EXPECT_TRUE(warned);
  EXPECT_TRUE(s.to_camera_file("x").validate().empty());
}

TEST(Intrinsics, TooFewViewsIsRefused) {
  const CameraIntrinsics k = truth_camera();
  std::mt19937_64 rng(1);
  auto views = make_views(k, kBoard, plan_board_poses(k, 0.2, 0.125, 5, 1), 0.2, rng);
  IntrinsicsSummary s = calibrate_intrinsics(views, 640, 480);
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.message.find("too few usable views: 5"), std::string::npos) << s.message;
}

TEST(Intrinsics, ViewsWithTooFewPointsAreUnusable) {
  const CameraIntrinsics k = truth_camera();
  std::mt19937_64 rng(1);
  auto views = make_views(k, kBoard, plan_board_poses(k, 0.2, 0.125, 7, 1), 0.2, rng);
  views[2].image_points.resize(3);
  views[2].object_points.resize(3);
  IntrinsicsSummary s = calibrate_intrinsics(views, 640, 480);
  ASSERT_TRUE(s.ok) << s.report();
  ASSERT_EQ(s.rejected.size(), 1u);
  EXPECT_EQ(s.rejected[0].index, 2);
  EXPECT_NE(s.rejected[0].reason.find("only 3 board points"), std::string::npos);
  views[3].image_points.resize(3);
  views[3].object_points.resize(3);
  EXPECT_FALSE(calibrate_intrinsics(views, 640, 480).ok);
}

TEST(Intrinsics, SameOrientationIsDegenerate) {
  const CameraIntrinsics k = truth_camera();
  std::mt19937_64 rng(2);
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < 10; ++i) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(-0.1 + 0.01 * i, -0.06 + 0.004 * i, 0.35 + 0.01 * (i % 3));
    poses.push_back(T);  // all fronto-parallel
  }
  auto views = make_views(k, kBoard, poses, 0.2, rng);
  IntrinsicsSummary s = calibrate_intrinsics(views, 640, 480);
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.message.find("degenerate geometry"), std::string::npos) << s.message;
  EXPECT_NE(s.message.find("Tilt"), std::string::npos);
}

TEST(Intrinsics, WarnsWhenTheToothRegionIsNotCovered) {
  const CameraIntrinsics k = truth_camera();
  std::mt19937_64 rng(4);
  // Small boards near the image corners only.
  const ChessboardSpec small{4, 3, 0.012};
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < 8; ++i) {
    const double sx = (i % 2) ? 1 : -1, sy = (i / 2 % 2) ? 1 : -1;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(0.5, Eigen::Vector3d(std::cos(i), std::sin(i), 0)).toRotationMatrix();
    T.translation() = Eigen::Vector3d(sx * 0.1 - 0.018, sy * 0.07 - 0.012, 0.4);
    poses.push_back(T);
  }
  auto views = make_views(k, small, poses, 0.1, rng);
  IntrinsicsSummary s = calibrate_intrinsics(views, 640, 480);
  EXPECT_LT(s.coverage.tooth_fraction, 0.3);
  bool warned = false;
  for (const auto& w : s.warnings) warned |= w.find("tooth") != std::string::npos;
  EXPECT_TRUE(warned) << s.report();
}

TEST(Intrinsics, AprilGridCornersFollowTheLayout) {
  AprilGridSpec g;
  g.cols = 3;
  g.rows = 2;
  g.tag_size_m = 0.02;
  g.gap_m = 0.005;
  g.first_id = 10;
  ASSERT_TRUE(g.validate().empty());
  EXPECT_FALSE(g.has_id(9));
  EXPECT_TRUE(g.has_id(15));
  EXPECT_FALSE(g.has_id(16));
  const auto c = g.tag_corners(14);  // row 1, col 1; centre (0.035, 0.035)
  EXPECT_TRUE(c[0].isApprox(Eigen::Vector3d(0.025, 0.045, 0)));
  EXPECT_TRUE(c[2].isApprox(Eigen::Vector3d(0.045, 0.025, 0)));
  EXPECT_NEAR(g.width_m(), 0.07, 1e-12);
  g.family = "tag25h9";
  EXPECT_NE(g.validate().find("tag25h9"), std::string::npos);
}

// Monte-Carlo: the reported std dev of fx, cx (OpenCV's stdDeviationsIntrinsics) must match the
// observed scatter of the estimates over repeated noisy calibrations of the same geometry.
TEST(Intrinsics, ReportedStdDevsMatchMonteCarloScatter) {
  const CameraIntrinsics k = truth_camera();
  const auto poses = plan_board_poses(k, 0.2, 0.125, 8, 21);
  const int trials = 100;
  std::mt19937_64 rng(99);
  std::vector<double> fx, cx, sd_fx, sd_cx;
  for (int t = 0; t < trials; ++t) {
    auto views = make_views(k, kBoard, poses, 0.3, rng);
    IntrinsicsOptions o;
    o.reject_outliers = false;
    IntrinsicsSummary s = calibrate_intrinsics(views, 640, 480, o);
    ASSERT_TRUE(s.ok) << s.message;
    fx.push_back(s.camera.fx);
    cx.push_back(s.camera.cx);
    sd_fx.push_back(s.std_devs[0]);
    sd_cx.push_back(s.std_devs[2]);
  }
  auto stddev = [](const std::vector<double>& v) {
    double m = 0;
    for (double x : v) m += x;
    m /= v.size();
    double s = 0;
    for (double x : v) s += (x - m) * (x - m);
    return std::sqrt(s / (v.size() - 1));
  };
  auto rms = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x * x;
    return std::sqrt(s / v.size());
  };
  const double ratio_fx = stddev(fx) / rms(sd_fx);
  const double ratio_cx = stddev(cx) / rms(sd_cx);
  EXPECT_GT(ratio_fx, 0.6);
  EXPECT_LT(ratio_fx, 1.6);
  EXPECT_GT(ratio_cx, 0.6);
  EXPECT_LT(ratio_cx, 1.6);
  RecordProperty("ratio_fx", std::to_string(ratio_fx));
  RecordProperty("ratio_cx", std::to_string(ratio_cx));
  std::printf("observed/reported std dev: fx %.3f, cx %.3f (reported fx %.3f px)\n", ratio_fx,
              ratio_cx, rms(sd_fx));
}

}  // namespace
}  // namespace dentar::calibration
