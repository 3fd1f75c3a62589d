// Kalibr's AprilGrid (issue 28): rendered views of the board (tag36h11 with a 2-cell border and
// corner squares in the gap crossings) through the board ray-caster; our detector against stock
// libapriltag (the tag36h11 family as shipped) on the same images: recall of the visible tags and
// the corners' error against the projected truth.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>

#include "dentar/ar/calib_board.h"
#include "dentar/ar/tag_detector.h"
#include "dentar/calibration/intrinsics.h"

namespace dentar::ar {
namespace {

calibration::CameraIntrinsics cam() {
  calibration::CameraIntrinsics k;
  k.width = 640;
  k.height = 480;
  k.fx = k.fy = 600;
  k.cx = 320;
  k.cy = 240;
  k.dist = {-0.08, 0.02, 0, 0, 0};
  return k;
}

struct Recall {
  int visible = 0, ours = 0, stock = 0, wrong_ids = 0;
  double sq_err = 0;
  int points = 0;
  double ours_s = 0, stock_s = 0;  // detection time (the benchmark's speed column)
};
double now_s() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

Recall run(const std::string& board, int views, std::uint64_t seed) {
  auto spec = parse_board_spec(board);
  EXPECT_TRUE(spec.ok()) << spec.error();
  const auto& g = std::get<calibration::AprilGridSpec>(*spec);
  EXPECT_TRUE(g.kalibr);
  const auto k = cam();
  const BoardTexture tex = make_board_texture(*spec, 6000);
  const auto poses = calibration::plan_board_poses(k, board_width_m(*spec), board_height_m(*spec), views, seed);
  calibration::AprilGridSpec plain = g;
  plain.kalibr = false;
  TagDetectorOptions to;
  to.families = {TagFamilyId::kTag36h11};
  to.decimation = 1.0;
  auto stock = TagDetector::create(to);
  EXPECT_TRUE(stock.ok());
  Recall r;
  for (int i = 0; i < views; ++i) {
    BoardRenderOptions ro;
    ro.supersample = 2;
    ro.seed = seed * 100 + i;
    const cv::Mat img = render_board_view(tex, k, poses[i], ro);
    const auto truth = project_board_points(*spec, k, poses[i]);  // tag-major, 4 corners each
    std::map<int, bool> visible;
    for (int t = 0; t < g.tag_count(); ++t) {
      bool in = true;
      for (int c = 0; c < 4; ++c) {
        const auto& p = truth[static_cast<std::size_t>(4 * t + c)];
        in = in && p.x() > 4 && p.y() > 4 && p.x() < k.width - 5 && p.y() < k.height - 5;
      }
      if (in) {
        visible[g.first_id + t] = true;
        ++r.visible;
      }
    }
    double t0 = now_s();
    auto ours = detect_kalibr_aprilgrid(img, g, "view-" + std::to_string(i), 1);
    r.ours_s += now_s() - t0;
    if (ours) {
      for (std::size_t j = 0; j < ours->image_points.size(); j += 4) {
        // Which tag: its corner 0 in the board frame.
        int id = -1;
        for (int t = 0; t < g.tag_count() && id < 0; ++t)
          if ((g.tag_corners(g.first_id + t)[0] - ours->object_points[j]).norm() < 1e-9) id = g.first_id + t;
        if (!visible.count(id)) {
          ++r.wrong_ids;
          continue;
        }
        ++r.ours;
        for (int c = 0; c < 4; ++c) {
          const auto& tr = truth[static_cast<std::size_t>(4 * (id - g.first_id) + c)];
          r.sq_err += (ours->image_points[j + static_cast<std::size_t>(c)] - tr).squaredNorm();
          ++r.points;
        }
      }
    }
    t0 = now_s();
    auto st = detect_aprilgrid(*stock, img, plain, "view", 0);
    r.stock_s += now_s() - t0;
    if (st) r.stock += static_cast<int>(st->image_points.size() / 4);
  }
  return r;
}

TEST(KalibrGrid, FindsTheTagsStockLibapriltagMissesWithSubPixelCorners) {
  const Recall r = run("kalibr:6x5:24:0.3", 6, 11);
  const double rms = std::sqrt(r.sq_err / std::max(1, r.points));
  std::printf("[ kalibr ] visible tags %d: ours %d (%.1f %%), stock libapriltag %d (%.1f %%), wrong ids %d; "
              "corner RMS %.3f px over %d corners\n",
              r.visible, r.ours, 100.0 * r.ours / r.visible, r.stock, 100.0 * r.stock / r.visible, r.wrong_ids,
              rms, r.points);
  ASSERT_GT(r.visible, 60);
  EXPECT_GE(r.ours, r.visible * 9 / 10);
  EXPECT_EQ(r.wrong_ids, 0);
  EXPECT_LT(r.stock, r.visible / 10);  // the reason for our detector
  EXPECT_LT(rms, 0.25);
}

TEST(KalibrGrid, SpecParsingAndRefusals) {
  auto s = parse_board_spec("kalibr:6x6:88:0.3");
  ASSERT_TRUE(s.ok()) << s.error();
  const auto& g = std::get<calibration::AprilGridSpec>(*s);
  EXPECT_TRUE(g.kalibr);
  EXPECT_NEAR(g.gap_m, 0.0264, 1e-9);
  EXPECT_EQ(board_spec_to_string(*s), "kalibr:6x6:88:0.3:0");
  // Kalibr's numbering: tag 0 bottom-left of the print (largest y, the board's y runs down the
  // page), tag 1 to its right, tag 6 above it.
  EXPECT_NEAR(g.tag_corners(0)[3].x(), 0, 1e-12);
  EXPECT_NEAR(g.tag_corners(0)[1].y(), g.height_m(), 1e-12);
  EXPECT_GT(g.tag_corners(1)[0].x(), g.tag_corners(0)[0].x());
  EXPECT_LT(g.tag_corners(6)[0].y(), g.tag_corners(0)[0].y());
  auto bad = parse_board_spec("kalibr:6x6:88:3");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("SPACING_RATIO"), std::string::npos) << bad.error();
  auto few = parse_board_spec("kalibr:6x6");
  ASSERT_FALSE(few.ok());
  EXPECT_NE(few.error().find("kalibr:COLSxROWS"), std::string::npos) << few.error();
  // A blank image: not found, said so.
  auto none = detect_kalibr_aprilgrid(cv::Mat(120, 160, CV_8UC1, cv::Scalar(128)), g, "blank.png");
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.error().find("blank.png"), std::string::npos);
}

TEST(KalibrGrid, BenchmarkRecall) {
  const char* n = std::getenv("DENTAR_KALIBR_VIEWS");
  if (!n) GTEST_SKIP() << "set DENTAR_KALIBR_VIEWS (and DENTAR_KALIBR_BOARD)";
  const char* b = std::getenv("DENTAR_KALIBR_BOARD");
  const Recall r = run(b ? b : "kalibr:6x5:24:0.3", std::atoi(n), 21);
  std::printf("[ kalibr bench ] visible %d: ours %d (%.1f %%), stock %d (%.1f %%), wrong ids %d, corner RMS %.3f px; "
              "%.1f ms per image (stock %.1f ms)\n",
              r.visible, r.ours, 100.0 * r.ours / r.visible, r.stock, 100.0 * r.stock / r.visible, r.wrong_ids,
              std::sqrt(r.sq_err / std::max(1, r.points)), 1e3 * r.ours_s / std::atoi(n), 1e3 * r.stock_s / std::atoi(n));
}

}  // namespace
}  // namespace dentar::ar
