// The smoothness check detect_chessboard (intrinsics.h) applies to a chessboard's corners before
// it returns them: a board whose corners are not a smooth grid is never returned; the other
// OpenCV finder is tried, and when neither gives a smooth grid the error is "<name> refused: ..."
// naming the corner and the figures (calibration session 19, docs/BENCHMARKS.md).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace dentar::calibration {

// How far a chessboard's corners are from a smooth grid: the largest second difference along a
// row or a column, |p[k-1] - 2 p[k] + p[k+1]|, over the half-distance |p[k+1] - p[k-1]| / 2 of the
// two neighbours (dimensionless; perspective and lens distortion keep it small, a corner or a
// column placed on the wrong square makes it ~0.5-2). Points row-major, cols x rows.
struct GridSmoothness {
  double worst_ratio = 0;  // infinity when the points are not cols x rows or degenerate
  double worst_px = 0;     // that second difference, px
  int row = -1, col = -1;  // the corner where it is largest
  bool along_row = true;
  bool smooth() const;
};
// The bound detect_chessboard applies, measured on OpenCV's 26 real photos with noise and on
// generated views (docs/BENCHMARKS.md, calibration session 19).
inline constexpr double kMaxGridSecondDifference = 0.35;
inline bool GridSmoothness::smooth() const { return worst_ratio <= kMaxGridSecondDifference; }
GridSmoothness chessboard_grid_smoothness(const std::vector<Eigen::Vector2d>& points, int cols, int rows);

// The sub-pixel placement detect_chessboard gives the finders' corners (intrinsics.cpp has why):
// cv::cornerSubPix with a half-window of 0.4x the smallest corner spacing, 2..11 px, so the
// window stays inside the squares; a corner the refinement moves farther than half that window
// (it slid to another edge) keeps its position. gray: 8-bit, stride in bytes; points row-major,
// cols x rows, px, refined in place. Returns the half-window used (px), or 0 when the points are
// not cols x rows or the image is empty (nothing is changed then).
int refine_chessboard_corners(const std::uint8_t* gray, int width, int height, int stride_bytes, int cols, int rows,
                              std::vector<Eigen::Vector2d>& points);

struct BoardView;  // intrinsics.h
// RMS distance of a board's image points to the best plane homography of its object points, px
// (no lens model: distortion leaves ~1-2 px on OpenCV's sample views; a column of corners on the
// wrong square 5-7 px). NaN when no homography fits. For benches and tests that judge a finder.
double board_homography_rms_px(const BoardView& v);
}  // namespace dentar::calibration
