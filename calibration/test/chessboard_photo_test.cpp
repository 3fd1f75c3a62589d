// detect_chessboard on real photos (OpenCV's chessboard samples, Debian package opencv-doc) and
// the grid-smoothness check it applies (calibration session 19, docs/BENCHMARKS.md).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "dentar/calibration/chessboard_grid.h"
#include "dentar/calibration/intrinsics.h"

namespace dentar::calibration {
namespace {

const std::filesystem::path kPhotos = "/usr/share/doc/opencv-doc/examples/data";

// A 9x6 grid seen under perspective with barrel distortion (smooth), row-major.
std::vector<Eigen::Vector2d> smooth_grid() {
  std::vector<Eigen::Vector2d> p;
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 9; ++c) {
      const double x = (c - 4) * 0.06, y = (r - 2.5) * 0.06, w = 1 + 0.35 * x;  // tilted board
      double u = x / w, v = y / w;
      const double k = 1 - 0.28 * (u * u + v * v);
      p.emplace_back(320 + 540 * u * k, 240 + 540 * v * k);
    }
  return p;
}

TEST(ChessboardGrid, SmoothGridPassesAndAShiftedColumnOrCornerIsCaught) {
  const auto good = smooth_grid();
  const GridSmoothness g = chessboard_grid_smoothness(good, 9, 6);
  EXPECT_TRUE(g.smooth()) << g.worst_ratio;
  EXPECT_LT(g.worst_ratio, 0.1);
  // The defect seen on right04.jpg: one column placed ~one square (30 px) along the row.
  for (int col : {0, 4, 8}) {
    auto bad = good;
    for (int r = 0; r < 6; ++r) bad[r * 9 + col].x() += 30;
    const GridSmoothness b = chessboard_grid_smoothness(bad, 9, 6);
    EXPECT_FALSE(b.smooth()) << "column " << col << ": " << b.worst_ratio;
    EXPECT_EQ(b.col, col == 0 ? 1 : col == 8 ? 7 : col) << "column " << col;
    EXPECT_GT(b.worst_px, 20);
  }
  auto one = good;
  one[2 * 9 + 3].y() += 12;  // one corner a third of a square off
  EXPECT_FALSE(chessboard_grid_smoothness(one, 9, 6).smooth());
  // Wrong count, coincident or non-finite corners are not a grid.
  EXPECT_FALSE(chessboard_grid_smoothness(std::vector<Eigen::Vector2d>(good.begin(), good.end() - 1), 9, 6).smooth());
  auto same = good;
  same[1] = same[0];
  same[2] = same[0];
  EXPECT_FALSE(chessboard_grid_smoothness(same, 9, 6).smooth());
  auto nan = good;
  nan[10].x() = std::nan("");
  EXPECT_FALSE(chessboard_grid_smoothness(nan, 9, 6).smooth());
}

// The shared in-square refinement (detect_chessboard, the photo test and bench): a drawn board's
// inner corners lie on pixel edges, at (x0 - 0.5 + c s, y0 - 0.5 + r s).
TEST(ChessboardGrid, RefineMovesCornersOntoTheSaddleAndKeepsOnesThatWouldSlide) {
  const int s = 30, x0 = 60, y0 = 50, cols = 9, rows = 6;
  cv::Mat img(y0 * 2 + s * (rows + 1), x0 * 2 + s * (cols + 1), CV_8UC1, cv::Scalar(255));
  for (int r = -1; r <= rows; ++r)
    for (int c = -1; c <= cols; ++c)
      if (((r + c) & 1) == 0) cv::rectangle(img, cv::Rect(x0 + c * s, y0 + r * s, s, s), cv::Scalar(0), cv::FILLED);
  cv::GaussianBlur(img, img, cv::Size(5, 5), 1.0);
  std::vector<Eigen::Vector2d> truth, p;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) truth.emplace_back(x0 - 0.5 + c * s, y0 - 0.5 + r * s);
  for (const auto& t : truth) p.push_back(t + Eigen::Vector2d(1.6, -1.2));
  p[13] = truth[13] + Eigen::Vector2d(7, 7);  // 9.9 px: beyond half the window, must not snap back
  const auto before = p;
  // Smallest spacing: corner 13 to the one below it, |(-5.4, 21.8)| = 22.5 px: half-window 8 px.
  EXPECT_EQ(refine_chessboard_corners(img.data, img.cols, img.rows, static_cast<int>(img.step), cols, rows, p), 8);
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (i == 13) continue;
    EXPECT_LT((p[i] - truth[i]).norm(), 0.1) << "corner " << i;
  }
  EXPECT_GT((p[13] - truth[13]).norm(), 5.0) << "corner 13 moved more than half the window";
  // Wrong count or no image: nothing changed, 0 returned.
  auto short_list = std::vector<Eigen::Vector2d>(before.begin(), before.end() - 1);
  const auto short_copy = short_list;
  EXPECT_EQ(refine_chessboard_corners(img.data, img.cols, img.rows, static_cast<int>(img.step), cols, rows, short_list), 0);
  EXPECT_EQ(short_list, short_copy);
  auto q = before;
  EXPECT_EQ(refine_chessboard_corners(nullptr, img.cols, img.rows, static_cast<int>(img.step), cols, rows, q), 0);
  EXPECT_EQ(q, before);
}

// right02.jpg and right04.jpg with one grey level of uniform noise (8 draws of cv::RNG(7), as in
// ar/track/test/mjpeg_real_photo_test.cpp): before session 19 the sector-based finder returned a
// board with a whole column 26-38 px off on 1 and 5 of them (OpenCV 4.6, Debian 12). The finder
// must return a smooth board within 2 px of the classic finder's corners on the clean photo (~8 s CPU).
TEST(ChessboardPhotos, NoisyRight02AndRight04GiveTheClassicFindersBoard) {
  if (!std::filesystem::exists(kPhotos / "right02.jpg"))
    GTEST_SKIP() << kPhotos << "/right02.jpg is absent: install the Debian package opencv-doc";
  ChessboardSpec spec;
  spec.cols = 9;
  spec.rows = 6;
  for (const char* name : {"right02.jpg", "right04.jpg"}) {
    // The grey as helper 3's test made it (cv::imdecode to BGR, then to grey) and the same draws.
    const cv::Mat bgr = cv::imread((kPhotos / name).string(), cv::IMREAD_COLOR);
    ASSERT_FALSE(bgr.empty()) << name;
    cv::Mat g;
    cv::cvtColor(bgr, g, cv::COLOR_BGR2GRAY);
    std::vector<cv::Point2f> ref;
    ASSERT_TRUE(cv::findChessboardCorners(g, cv::Size(9, 6), ref, cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE));
    // Refined with the window inside the squares, as detect_chessboard refines: OpenCV's fixed
    // 11 px window moves right02's corners 4.4 px (calibration session 19).
    std::vector<Eigen::Vector2d> p;
    for (const cv::Point2f& q : ref) p.emplace_back(q.x, q.y);
    ASSERT_GT(refine_chessboard_corners(g.data, g.cols, g.rows, static_cast<int>(g.step), 9, 6, p), 0) << name;
    for (std::size_t i = 0; i < ref.size(); ++i) ref[i] = cv::Point2f(static_cast<float>(p[i].x()), static_cast<float>(p[i].y()));
    cv::RNG rng(7);
    for (int d = 1; d <= 8; ++d) {
      cv::Mat n(g.size(), CV_16S), sum, noisy;
      rng.fill(n, cv::RNG::UNIFORM, -1, 2);
      g.convertTo(sum, CV_16S);
      sum += n;
      sum.convertTo(noisy, CV_8U);
      auto v = detect_chessboard(noisy.data, noisy.cols, noisy.rows, static_cast<int>(noisy.step), spec, name);
      ASSERT_TRUE(v.ok()) << name << " draw " << d << ": " << v.error();
      const GridSmoothness s = chessboard_grid_smoothness(v->image_points, 9, 6);
      EXPECT_TRUE(s.smooth()) << name << " draw " << d << ": " << s.worst_ratio;
      double worst = 0;
      for (const Eigen::Vector2d& p : v->image_points) {
        double best = 1e9;
        for (const cv::Point2f& q : ref) best = std::min(best, std::hypot(p.x() - q.x, p.y() - q.y));
        worst = std::max(worst, best);
      }
      EXPECT_LT(worst, 2.0) << name << " draw " << d << ": a corner " << worst << " px from the classic finder's";
    }
  }
}

}  // namespace
}  // namespace dentar::calibration
