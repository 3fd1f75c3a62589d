#include "dentar/ar/calib_board.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "dentar/ar/station_scene.h"
#include "dentar/calibration/co_location.h"

namespace dentar::ar {
namespace {

namespace fs = std::filesystem;
using calibration::AprilGridSpec;
using calibration::ChessboardSpec;

double mean_corner_error(const calibration::BoardView& v, const std::vector<Eigen::Vector2d>& truth,
                         const BoardSpec& spec) {
  // Pair detected points with the truth through their board coordinates.
  std::vector<Eigen::Vector3d> pts;
  if (const auto* c = std::get_if<ChessboardSpec>(&spec))
    pts = c->object_points();
  else {
    const auto& g = std::get<AprilGridSpec>(spec);
    for (int id = g.first_id; id < g.first_id + g.tag_count(); ++id)
      for (const auto& p : g.tag_corners(id)) pts.push_back(p);
  }
  double sum = 0;
  int n = 0;
  for (std::size_t i = 0; i < v.object_points.size(); ++i)
    for (std::size_t j = 0; j < pts.size(); ++j)
      if ((pts[j] - v.object_points[i]).norm() < 1e-9) {
        sum += (v.image_points[i] - truth[j]).norm();
        ++n;
      }
  if (std::holds_alternative<ChessboardSpec>(spec)) {
    // A chessboard's corner order is ambiguous up to a half turn (both are valid poses).
    double rev = 0;
    for (std::size_t i = 0; i < v.image_points.size(); ++i)
      rev += (v.image_points[i] - truth[truth.size() - 1 - i]).norm();
    sum = std::min(sum, rev);
  }
  return n ? sum / n : 1e9;
}

Eigen::Isometry3d tilted_pose(double board_w, double board_h, double dist) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.6, 0.8, 0).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0, 0, dist) - T.linear() * Eigen::Vector3d(board_w / 2, board_h / 2, 0);
  return T;
}

TEST(CalibBoard, ParsesBoardSpecs) {
  auto c = parse_board_spec("chessboard:9x6:25");
  ASSERT_TRUE(c.ok()) << c.error();
  EXPECT_EQ(std::get<ChessboardSpec>(*c).cols, 9);
  EXPECT_DOUBLE_EQ(std::get<ChessboardSpec>(*c).square_m, 0.025);
  auto g = parse_board_spec("aprilgrid:6x5:24:8:tag36h11:3");
  ASSERT_TRUE(g.ok()) << g.error();
  EXPECT_EQ(std::get<AprilGridSpec>(*g).first_id, 3);
  EXPECT_EQ(board_spec_to_string(*g), "aprilgrid:6x5:24:8:tag36h11:3");
  for (const char* bad : {"", "chess:9x6:25", "chessboard:9by6:25", "chessboard:9x6", "chessboard:1x6:25",
                          "aprilgrid:6x5:24", "aprilgrid:6x5:24:8:tag99", "aprilgrid:50x50:24:8:tag36h11:0"}) {
    auto r = parse_board_spec(bad);
    EXPECT_FALSE(r.ok()) << bad;
    if (!r.ok()) {
      EXPECT_NE(r.error().find("board"), std::string::npos);
    }
  }
}

TEST(CalibBoard, RenderedChessboardIsDetectedAtTheTrueCorners) {
  const calibration::CameraIntrinsics k = default_camera(640, 480);
  const BoardSpec spec = ChessboardSpec{9, 6, 0.02};
  const Eigen::Isometry3d T = tilted_pose(board_width_m(spec), board_height_m(spec), 0.3);
  const cv::Mat img = render_board_view(make_board_texture(spec), k, T);
  auto v = detect_board(img, spec, "sim");
  ASSERT_TRUE(v.ok()) << v.error();
  EXPECT_EQ(v->image_points.size(), 54u);
  EXPECT_LT(mean_corner_error(*v, project_board_points(spec, k, T), spec), 0.1);
}

TEST(CalibBoard, RenderedAprilGridIsDetectedAtTheTrueCorners) {
  const calibration::CameraIntrinsics k = default_camera(640, 480);
  AprilGridSpec g;
  g.cols = 5;
  g.rows = 4;
  g.tag_size_m = 0.03;
  g.gap_m = 0.009;
  const BoardSpec spec = g;
  const Eigen::Isometry3d T = tilted_pose(board_width_m(spec), board_height_m(spec), 0.35);
  const cv::Mat img = render_board_view(make_board_texture(spec), k, T);
  auto v = detect_board(img, spec, "sim");
  ASSERT_TRUE(v.ok()) << v.error();
  EXPECT_EQ(v->image_points.size(), 80u);
  EXPECT_LT(mean_corner_error(*v, project_board_points(spec, k, T), spec), 0.25);
}

TEST(CalibBoard, BlankImageSaysBoardNotFound) {
  const cv::Mat blank(480, 640, CV_8UC1, cv::Scalar(128));
  auto c = detect_board(blank, ChessboardSpec{}, "blank.png");
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().find("board not found in blank.png"), std::string::npos);
  auto g = detect_board(blank, AprilGridSpec{}, "blank.png");
  ASSERT_FALSE(g.ok());
  EXPECT_NE(g.error().find("board not found in blank.png"), std::string::npos);
  int w = 0, h = 0;
  auto f = detect_board_file("/nonexistent/x.png", ChessboardSpec{}, w, h);
  ASSERT_FALSE(f.ok());
  EXPECT_NE(f.error().find("/nonexistent/x.png"), std::string::npos);
}

// The generator standing in for the camera: a simulated session with one warped-board view
// recovers the true intrinsics and rejects that view.
TEST(CalibBoard, SimulatedSessionRecoversTheCameraAndRejectsTheWarpedView) {
  const calibration::CameraIntrinsics k = default_camera(640, 480);
  const BoardSpec spec = ChessboardSpec{9, 6, 0.02};
  const int bad = 3;
  BoardRenderOptions ro;
  ro.supersample = 2;
  const SimulatedBoardSession s = simulate_board_session(spec, k, 10, 5, bad, 0.006, ro);
  std::vector<calibration::BoardView> views;
  for (std::size_t i = 0; i < s.images.size(); ++i) {
    auto v = detect_board(s.images[i], spec, "sim-" + std::to_string(i));
    ASSERT_TRUE(v.ok()) << v.error();
    views.push_back(*v);
  }
  const auto r = calibration::calibrate_intrinsics(views, 640, 480);
  ASSERT_TRUE(r.ok) << r.report();
  ASSERT_EQ(r.rejected.size(), 1u) << r.report();
  EXPECT_EQ(r.rejected[0].index, bad);
  EXPECT_NEAR(r.camera.fx, k.fx, 3.0) << r.report();
  EXPECT_NEAR(r.camera.fy, k.fy, 3.0);
  EXPECT_NEAR(r.camera.cx, k.cx, 3.0);
  EXPECT_NEAR(r.camera.cy, k.cy, 3.0);
  EXPECT_NEAR(r.camera.dist[0], k.dist[0], 0.03);
  EXPECT_LT(r.rms_px, 0.15);
}

// The AprilTag grid board (tags we can print) through the whole camera step.
TEST(CalibBoard, SimulatedAprilGridSessionRecoversTheCamera) {
  const calibration::CameraIntrinsics k = default_camera(640, 480);
  auto spec = parse_board_spec("aprilgrid:6x5:24:8:tag36h11:0");
  ASSERT_TRUE(spec.ok()) << spec.error();
  BoardRenderOptions ro;
  ro.supersample = 2;
  const SimulatedBoardSession s = simulate_board_session(*spec, k, 9, 11, -1, 0, ro);
  std::vector<calibration::BoardView> views;
  for (std::size_t i = 0; i < s.images.size(); ++i) {
    auto v = detect_board(s.images[i], *spec, "grid-" + std::to_string(i));
    if (v.ok()) views.push_back(*v);
  }
  ASSERT_GE(views.size(), 7u);
  const auto r = calibration::calibrate_intrinsics(views, 640, 480);
  ASSERT_TRUE(r.ok) << r.report();
  EXPECT_NEAR(r.camera.fx, k.fx, 3.0) << r.report();
  EXPECT_NEAR(r.camera.cx, k.cx, 3.0);
  EXPECT_NEAR(r.camera.cy, k.cy, 3.0);
  EXPECT_LT(r.rms_px, 0.3);
}

// Issue 24 (session 11): findChessboardCornersSB's own corners pull the calibrated principal
// point to the left on generated views (truth known), on every seed and with more views too;
// refined by cornerSubPix (the default now) the error is centred on zero. The station's
// simulated head camera (seeds 1-2 of the calibration workflow's hidden truth), 12 views each as
// `dentar calibrate camera --simulate` renders them (no warped view), radtan5 fitted.
TEST(CalibBoard, RefinedSectorCornersDoNotBiasThePrincipalPoint) {
  double mean_dcx[2] = {0, 0}, mean_abs_dcx[2] = {0, 0}, corner_rms[2] = {0, 0};
  const int seeds = 2;
  for (int seed = 1; seed <= seeds; ++seed) {
    const auto truth = calibration::simulated_truth(default_station_scene().calibration, seed);
    const auto& k = truth.camera;
    ChessboardSpec refined{9, 6, 0.02}, plain{9, 6, 0.02};
    plain.detector = calibration::ChessboardDetector::kSectorBasedUnrefined;
    const BoardTexture tex = make_board_texture(BoardSpec(refined));
    const auto poses = calibration::plan_board_poses(k, 0.16, 0.1, 12, seed);
    std::vector<calibration::BoardView> views[2];
    double se[2] = {0, 0};
    int n[2] = {0, 0};
    for (int i = 0; i < 12; ++i) {
      BoardRenderOptions ro;
      ro.supersample = 2;
      ro.seed = seed * 1000 + i;
      const cv::Mat img = render_board_view(tex, k, poses[i], ro);
      auto truth_px = project_board_points(BoardSpec(refined), k, poses[i]);
      for (int d = 0; d < 2; ++d) {
        auto v = detect_board(img, BoardSpec(d == 0 ? refined : plain), "v");
        ASSERT_TRUE(v.ok()) << v.error();
        // The detector may list the corners from the other end (the board is symmetric).
        auto t = truth_px;
        if ((v->image_points[0] - t[0]).norm() > (v->image_points[0] - t.back()).norm())
          std::reverse(t.begin(), t.end());
        for (std::size_t j = 0; j < t.size(); ++j, ++n[d]) se[d] += (v->image_points[j] - t[j]).squaredNorm();
        views[d].push_back(*v);
      }
    }
    for (int d = 0; d < 2; ++d) {
      const auto r = calibration::calibrate_intrinsics(views[d], k.width, k.height);
      ASSERT_TRUE(r.ok) << r.report();
      const double dcx = r.camera.cx - k.cx;
      std::printf("seed %d, %s corners: %.3f px from the truth (RMS), cx off by %+.3f px, cy %+.3f px\n", seed,
                  d == 0 ? "refined" : "sector-based", std::sqrt(se[d] / n[d]), dcx, r.camera.cy - k.cy);
      mean_dcx[d] += dcx / seeds;
      mean_abs_dcx[d] += std::abs(dcx) / seeds;
      corner_rms[d] += std::sqrt(se[d] / n[d]) / seeds;
    }
  }
  // Measured: refined |cx error| 0.14 px mean (-0.00, -0.27), sector-based -0.39 px mean
  // (-0.22, -0.55); corners 0.040 against 0.051 px RMS.
  EXPECT_LT(mean_dcx[1], -0.3);
  EXPECT_LT(mean_abs_dcx[0], 0.2);
  EXPECT_LT(mean_abs_dcx[0], 0.5 * mean_abs_dcx[1]);
  EXPECT_LT(corner_rms[0], corner_rms[1]);
}

// Real photographs: OpenCV's sample chessboard set (Debian opencv-doc, left01..left14.jpg,
// 9x6 inner corners, provenance in tests/data_provenance.md). With the corners OpenCV's
// calibration sample finds (findChessboardCorners + cornerSubPix), plain calibrateCamera on all
// views keeps an outlier view; ours must reject it automatically and reach RMS <= 0.25 px and a
// std dev of f <= 1 px. With our default sector-based detector the same set is checked too.
std::vector<calibration::BoardView> load_left_set(calibration::ChessboardDetector d, int& w, int& h) {
  const fs::path dir = "/usr/share/doc/opencv-doc/examples/data";
  ChessboardSpec c{9, 6, 0.025};
  c.detector = d;
  std::vector<calibration::BoardView> views;
  for (int i = 1; i <= 14; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "left%02d.jpg", i);
    if (!fs::exists(dir / name)) continue;
    auto v = detect_board_file((dir / name).string(), c, w, h);
    if (v.ok()) views.push_back(*v);
  }
  return views;
}

TEST(CalibBoard, RealChessboardPhotosOutlierRejected) {
  if (!fs::exists("/usr/share/doc/opencv-doc/examples/data/left01.jpg"))
    GTEST_SKIP() << "/usr/share/doc/opencv-doc/examples/data/left01.jpg absent: install the "
                    "Debian package opencv-doc";
  int w = 0, h = 0;
  const auto views = load_left_set(calibration::ChessboardDetector::kClassic, w, h);
  ASSERT_GE(views.size(), 10u);
  calibration::IntrinsicsOptions plain_o;
  plain_o.reject_outliers = false;
  const auto plain = calibration::calibrate_intrinsics(views, w, h, plain_o);
  const auto ours = calibration::calibrate_intrinsics(views, w, h);
  ASSERT_TRUE(plain.ok) << plain.report();
  ASSERT_TRUE(ours.ok) << ours.report();
  std::printf("classic corners, plain calibrateCamera: RMS %.3f px over %zu views, std f %.3f px\n",
              plain.rms_px, plain.used_views.size(), plain.std_devs[0]);
  std::printf("classic corners, ours:\n%s", ours.report().c_str());
  EXPECT_GE(ours.rejected.size(), 1u);
  EXPECT_LE(ours.rejected.size(), 2u);
  EXPECT_LE(ours.rms_px, 0.25);
  EXPECT_LE(ours.std_devs[0], 1.0);
  EXPECT_LE(ours.std_devs[1], 1.0);
  EXPECT_GT(plain.rms_px, ours.rms_px + 0.05);
  // Both agree on the focal length within a few std devs.
  EXPECT_NEAR(plain.camera.fx, ours.camera.fx, 3.0);
}

TEST(CalibBoard, RealChessboardPhotosSectorBasedDetector) {
  if (!fs::exists("/usr/share/doc/opencv-doc/examples/data/left01.jpg"))
    GTEST_SKIP() << "/usr/share/doc/opencv-doc/examples/data/left01.jpg absent: install the "
                    "Debian package opencv-doc";
  int w = 0, h = 0;
  const auto views = load_left_set(calibration::ChessboardDetector::kSectorBased, w, h);
  ASSERT_GE(views.size(), 10u);
  const auto ours = calibration::calibrate_intrinsics(views, w, h);
  ASSERT_TRUE(ours.ok) << ours.report();
  std::printf("sector-based corners, ours:\n%s", ours.report().c_str());
  EXPECT_LE(ours.rms_px, 0.25);
  EXPECT_LE(ours.std_devs[0], 1.0);
  // The default places the corners with cornerSubPix after the sector-based detector: on the
  // real photos the fit's RMS falls (measured 0.179 against 0.230 px with radtan5, 13 views,
  // none rejected either way).
  const auto plain_views = load_left_set(calibration::ChessboardDetector::kSectorBasedUnrefined, w, h);
  const auto plain = calibration::calibrate_intrinsics(plain_views, w, h);
  ASSERT_TRUE(plain.ok) << plain.report();
  std::printf("sector-based corners unrefined: RMS %.3f px; refined %.3f px\n", plain.rms_px, ours.rms_px);
  EXPECT_EQ(plain_views.size(), views.size());
  EXPECT_LT(ours.rms_px, plain.rms_px - 0.03);
}

}  // namespace
}  // namespace dentar::ar
