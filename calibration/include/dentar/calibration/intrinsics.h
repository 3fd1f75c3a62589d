// Camera intrinsics from views of a planar calibration board (chessboard or AprilTag grid).
// Board frame `board`: origin at the board's first corner, x along the columns, y along the
// rows (down in the printed image), z into the board; all board points have z = 0.
// Units: metres for board geometry, pixels (OpenCV convention: pixel centres at integers) for
// image points. Detection of AprilTag boards lives in ar (ar/calib_board.h); chessboards are
// detected here (OpenCV calib3d).
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "dentar/calibration/camera_file.h"
#include "dentar/calibration/station.h"
#include "dentar/core/result.h"

namespace dentar::calibration {

// Chessboard: cols x rows inner corners (OpenCV's patternSize), squares of square_m.
// Corner (r, c) is at (c * square_m, r * square_m, 0); points are listed row-major.
enum class ChessboardDetector {
  // findChessboardCornersSB finds the board, cornerSubPix (window inside the squares) places
  // the corners; falls back to kClassic. The SB corners alone bias the principal point on
  // generated views (intrinsics.cpp, docs/BENCHMARKS.md issue 24 session 11).
  kSectorBased,
  kClassic,      // findChessboardCorners + cornerSubPix (11x11), as OpenCV's calibration sample
  kSectorBasedUnrefined,  // findChessboardCornersSB's own corners (the default before session 11)
};
struct ChessboardSpec {
  int cols = 9, rows = 6;
  double square_m = 0.025;
  ChessboardDetector detector = ChessboardDetector::kSectorBased;
  std::string validate() const;
  std::vector<Eigen::Vector3d> object_points() const;
};

// AprilTag grid board (tags we can print): cols x rows tags of border-square side tag_size_m,
// separated by gap_m; tag (r, c) has id first_id + r * cols + c. Tag (r, c)'s centre is at
// ((c + 0.5) * tag_size_m + c * gap_m, (r + 0.5) * tag_size_m + r * gap_m, 0); its corners
// follow libapriltag's order (tag frame = board frame shifted to the tag centre):
// (-s/2,+s/2), (+s/2,+s/2), (+s/2,-s/2), (-s/2,-s/2).
struct AprilGridSpec {
  int cols = 6, rows = 5;
  double tag_size_m = 0.024;
  double gap_m = 0.008;
  std::string family = "tag36h11";
  int first_id = 0;
  // Kalibr's AprilGrid (issue 28): tag36h11 tags drawn with a 2-cell black border (10 x 10 cells,
  // tag_size_m = the black square's side) and a black square of side gap_m in every gap crossing
  // (also around the outside), touching the corners of the tags around it. Same tag geometry,
  // but numbered as Kalibr prints it: the first tag bottom-left, ids along the row, then up the
  // page (tag (r, c), r counted down, has id first_id + (rows - 1 - r) * cols + c).
  bool kalibr = false;
  std::string validate() const;
  int tag_count() const { return cols * rows; }
  bool has_id(int id) const { return id >= first_id && id < first_id + tag_count(); }
  // Corners of tag `id` (must satisfy has_id) in the board frame, m.
  std::array<Eigen::Vector3d, 4> tag_corners(int id) const;
  double width_m() const { return cols * tag_size_m + (cols - 1) * gap_m; }
  double height_m() const { return rows * tag_size_m + (rows - 1) * gap_m; }
};

// One view of the board: image points paired by index with board points.
struct BoardView {
  std::string name;                           // file name or "sim-07"; used in reports
  std::vector<Eigen::Vector2d> image_points;  // px, OpenCV convention
  std::vector<Eigen::Vector3d> object_points;  // board frame, m (z = 0)
};

// Finds the chessboard's inner corners in an 8-bit grayscale image (row stride in bytes),
// refined to sub-pixel accuracy as spec.detector says (default: findChessboardCornersSB, its
// corners placed by cornerSubPix; falling back to findChessboardCorners + cornerSubPix). Error "board not found in <name>" with what to do.
Result<BoardView> detect_chessboard(const std::uint8_t* gray, int width, int height,
                                    int stride_bytes, const ChessboardSpec& spec,
                                    const std::string& name);

// Distortion models, simplest last in this list but ordered by coefficient count in
// camera_model.h. kK1 and kK1K2 are the radtan5 model with the other coefficients held at 0
// (their files say pinhole-k1 / pinhole-k1k2, camera_file.h).
enum class DistortionModel { kRadTan5, kRational8, kK1, kK1K2 };
// "k1", "k1k2", "radtan5", "rational8".
const char* distortion_model_name(DistortionModel m);

struct IntrinsicsOptions {
  DistortionModel model = DistortionModel::kRadTan5;
  int min_views = 6;            // fewer usable views are refused; rejection never goes below
  int min_points_per_view = 8;  // a view with fewer points is unusable
  bool reject_outliers = true;  // false: plain calibrateCamera on every usable view
  // A view is an outlier when its RMS exceeds max(median + mad_k * 1.4826 * MAD,
  // min_outlier_rms_px) or exceeds max_view_rms_px outright. The worst outlier is dropped and
  // the calibration re-run until none is left.
  double mad_k = 4.0;
  double min_outlier_rms_px = 0.3;  // a view this good is never called an outlier
  double max_view_rms_px = 1.0;     // hard limit
  // Degenerate geometry: the board normals' RMS angle about their mean must reach this (rad).
  double min_tilt_spread_rad = 0.14;  // 8 degrees
  // Coverage map: grid of cells over the image.
  int coverage_cols = 8, coverage_rows = 6;
  // Where the tooth is drawn, as fractions of the image (x0, y0, x1, y1); default the central
  // third. A warning is given when less than min_tooth_coverage of its cells hold board points.
  std::array<double, 4> tooth_region = {1.0 / 3, 1.0 / 3, 2.0 / 3, 2.0 / 3};
  double min_tooth_coverage = 0.75;
  std::string validate() const;
};

struct RejectedView {
  int index = -1;  // into the input views
  std::string name;
  double rms_px = 0;  // its RMS when it was rejected (0 if never calibrated)
  std::string reason;
};

struct CoverageMap {
  int cols = 0, rows = 0;
  std::vector<int> counts;  // row-major, board points of the used views per cell
  double image_fraction = 0;  // fraction of all cells holding >= 1 point
  double tooth_fraction = 0;  // fraction of the tooth region's cells holding >= 1 point
  // One text line per row: '#' >= 5 points, '+' 1..4, '.' none.
  std::string ascii() const;
};

struct IntrinsicsSummary {
  bool ok = false;
  std::string message;                // what went wrong and what to do, or a one-line success
  std::vector<std::string> warnings;  // e.g. poor coverage of the tooth region

  CameraIntrinsics camera;   // dist = k1 k2 p1 p2 k3 (valid when the fit ran)
  std::string model = kModelRadTan5;  // the file-level model: pinhole-k1, pinhole-k1k2, pinhole-radtan5, rational8
  DistortionModel terms = DistortionModel::kRadTan5;  // the coefficients that were fitted
  std::vector<double> dist;  // all coefficients of the model (5 or 8)
  // Std devs of fx fy cx cy k1 k2 p1 p2 k3 [k4 k5 k6] (OpenCV's stdDeviationsIntrinsics: from
  // the Jacobian at the solution, scaled by the residual's variance, with OpenCV 4.6's
  // variance estimate corrected for counting 2 residuals per point; see intrinsics.cpp).
  std::vector<double> std_devs;
  // RMS over the used views of the 2-D reprojection distance (as OpenCV reports it), px.
  double rms_px = 0;
  std::vector<double> per_view_rms_px;  // per input view (last calibration it took part in; 0 if none)
  std::vector<int> used_views;         // indices into the input
  std::vector<RejectedView> rejected;
  std::vector<Eigen::Isometry3d> T_cam_board;  // per used view (same order as used_views)
  double tilt_spread_rad = 0;  // RMS angle of the board normals about their mean
  CoverageMap coverage;
  int calibrations_run = 0;

  std::string report() const;  // instructor report: px and degrees
  // The camera file to save (date: ISO UTC now when empty).
  CameraFile to_camera_file(const std::string& device, const std::string& date = {}) const;
};

// Calibrates from the views (image size width x height px). Never aborts on user input: too few
// usable views, degenerate geometry (all boards with the same orientation) and OpenCV failures
// return ok = false with a message.
IntrinsicsSummary calibrate_intrinsics(const std::vector<BoardView>& views, int width, int height,
                                       const IntrinsicsOptions& options = {});

// Pixel of a camera-frame point (m) through the 5-coefficient model; nullopt-like: returns false
// when z <= 0.
bool project_point(const CameraIntrinsics& k, const Eigen::Vector3d& p_cam, Eigen::Vector2d& px);

// A realistic set of board poses T_cam_board for a camera: boards filling a good part of the
// image, tilted 15..45 degrees about varied axes, centred on a grid of image positions so the
// views cover the image (including its centre). Deterministic for a seed.
std::vector<Eigen::Isometry3d> plan_board_poses(const CameraIntrinsics& k, double board_w_m,
                                                double board_h_m, int count, std::uint64_t seed);
// The same, with every board corner inside the centred rectangle holding `area_fraction` of the
// image (sides sqrt(area_fraction) of the image's, 0 < area_fraction <= 1; 1 gives
// plan_board_poses exactly): the photos of a user who kept the board in the middle.
std::vector<Eigen::Isometry3d> plan_board_poses_in_region(const CameraIntrinsics& k,
                                                          double board_w_m, double board_h_m,
                                                          int count, std::uint64_t seed,
                                                          double area_fraction);

}  // namespace dentar::calibration
