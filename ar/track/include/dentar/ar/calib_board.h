// Calibration boards on the camera side: AprilTag grid detection (libapriltag via TagDetector),
// board photos from files, and a ray-cast renderer that stands in for the camera in
// `dentar calibrate camera --simulate` (the board as a camera with given intrinsics and
// distortion sees it at a given pose, antialiased, with noise and blur).
// Board geometry and frames: calibration/intrinsics.h (board frame: x along the columns, y
// down the rows, z into the board). Units: metres, pixels (OpenCV convention).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <string>
#include <variant>
#include <vector>

#include "dentar/ar/tag_detector.h"
#include "dentar/calibration/intrinsics.h"
#include "dentar/volume/result.h"

namespace dentar::ar {

// ChArUco board (OpenCV's aruco module): cols x rows squares of square_m (OpenCV's squaresX x
// squaresY, the squares counted, not the inner corners), in the layout OpenCV 4.6 and later print:
// the top-left square black, an ArUco marker of the dictionary (black square of side marker_m,
// one-cell border) centred in every white square, ids first_id, first_id + 1, ... over the
// white squares row by row from the top-left. `legacy`: the layout of boards printed by OpenCV
// before 4.6 (OpenCV 4.7's setLegacyPattern): with an even number of rows the top-left square is
// white (the markers on the other squares, same id order); with an odd number it is the same board.
// The board's points are its (cols-1) x (rows-1) inner corners: corner (r, c), id
// r * (cols - 1) + c, at (c * square_m, r * square_m, 0) in the board frame (origin at the first
// inner corner, as a chessboard's).
struct CharucoSpec {
  int cols = 5, rows = 7;  // squares, 3..100 each
  double square_m = 0.04;
  double marker_m = 0.03;                   // < square_m
  std::string dictionary = "DICT_4X4_50";   // OpenCV's predefined dictionary name
  int first_id = 0;
  bool legacy = false;
  std::string validate() const;  // also checks the dictionary's name and its code count
  // Whether square (col i, row j from the top-left) holds a marker.
  bool white(int i, int j) const { return (i + j) % 2 == ((legacy && rows % 2 == 0) ? 0 : 1); }
  int marker_count() const { return cols * rows / 2; }
  int corner_count() const { return (cols - 1) * (rows - 1); }
  std::vector<Eigen::Vector3d> object_points() const;  // by corner id, m
};

using BoardSpec = std::variant<calibration::ChessboardSpec, calibration::AprilGridSpec, CharucoSpec>;

// Parses a --board text, field by field:
//   chessboard:COLSxROWS:SQUARE_MM                        inner corners (e.g. chessboard:9x6:25)
//   aprilgrid:COLSxROWS:TAG_MM:GAP_MM[:FAMILY[:FIRST_ID]] our AprilTag grid (e.g. aprilgrid:6x5:24:8)
//   kalibr:COLSxROWS:TAG_MM:SPACING_RATIO[:FIRST_ID]      Kalibr's AprilGrid (its aprilgrid.yaml's
//       tagCols x tagRows, tagSize, tagSpacing; tag36h11; gap = ratio * tag; e.g. kalibr:6x6:88:0.3)
//   charuco:COLSxROWS:SQUARE_MM:MARKER_MM:DICT[:FIRST_ID][:legacy] ChArUco, squares (e.g.
//       charuco:5x7:40:30:DICT_4X4_50; DICT is OpenCV's name, the DICT_ prefix and case optional;
//       legacy: printed by OpenCV before 4.6)
// An error quotes the text, names the field (e.g. SQUARE_MM) and the value, and gives the form.
Result<BoardSpec> parse_board_spec(const std::string& text);
std::string board_spec_to_string(const BoardSpec& spec);
double board_width_m(const BoardSpec& spec);   // extent of its points along x, m
double board_height_m(const BoardSpec& spec);  // along y, m

// AprilTag grid in a grayscale image (CV_8UC1): every detected tag of the grid's family with an
// id on the grid gives its 4 corners. Error "board not found in <name>" when fewer than
// min_tags grid tags are seen. The detector must search the grid's family.
Result<calibration::BoardView> detect_aprilgrid(TagDetector& detector, const cv::Mat& gray,
                                                const calibration::AprilGridSpec& spec,
                                                const std::string& name, int min_tags = 2);

// Kalibr's AprilGrid (spec.kalibr; calibration/intrinsics.h) in a grayscale image (CV_8UC1).
// Stock libapriltag finds almost none of its tags: the corner squares touch the tags' corners, so
// a tag's black square and its four corner squares are one dark blob and no quad is fitted; and
// the 2-cell border puts the bits where a tag36h11 decoder does not sample. Here: (1) a grey
// dilation (3x3, then 5x5 for tags the first misses) opens the touching corners; (2) libapriltag
// fits quads on that and decodes with tag36h11's code table read with a 2-cell border (the
// family's bit positions shifted one cell in, its border 10 cells); (3) every tag corner, an
// X-junction between the tag and its corner square, is placed by cornerSubPix on the original
// image (window a third of the gap); a corner that moves farther than the window drops its tag.
// Error "board not found in <name>" when fewer than min_tags tags are found. `stats`, when
// given, receives the tags found and those dropped at refinement.
struct KalibrGridStats {
  int tags = 0;
  int dropped_at_refinement = 0;
};
Result<calibration::BoardView> detect_kalibr_aprilgrid(const cv::Mat& gray, const calibration::AprilGridSpec& spec,
                                                       const std::string& name, int min_tags = 2,
                                                       KalibrGridStats* stats = nullptr);

// A ChArUco board in a grayscale image (CV_8UC1): OpenCV's aruco detectMarkers finds the
// markers (of the board's dictionary, ids on the board), refineDetectedMarkers recovers missed
// ones from the board layout, and interpolateCornersCharuco places each inner corner next to at
// least two found markers (a local homography from the markers, then cornerSubPix). Partial
// views are fine: a corner comes with its id. Error "board not found in <name>" when fewer than
// min_corners corners are placed. `stats`, when given, receives the markers and corners found.
struct CharucoStats {
  int markers = 0;
  int corners = 0;
};
Result<calibration::BoardView> detect_charuco(const cv::Mat& gray, const CharucoSpec& spec, const std::string& name,
                                              int min_corners = 6, CharucoStats* stats = nullptr);

// The markers of a ChArUco board as (bits + 2) x (bits + 2) cells, 0 black / 255 white, one per
// marker (index k = id - first_id), from OpenCV's dictionary: the printed board (make_board_texture).
std::vector<cv::Mat> charuco_marker_cells(const CharucoSpec& spec);

// One detector for a board of any kind, kept across frames (the live camera and stereo steps):
// it builds the AprilTag detector, or the ChArUco dictionary and board, once. detect() takes an
// image (CV_8UC1 or CV_8UC3) and returns the board's points as detect_board does. Not for
// concurrent use: one per thread. Movable.
class BoardDetector {
 public:
  static Result<BoardDetector> create(const BoardSpec& spec);
  Result<calibration::BoardView> detect(const cv::Mat& image, const std::string& name);
  const BoardSpec& spec() const;

  struct Impl;

 private:
  std::shared_ptr<Impl> impl_;
};

// Detects the board in an image (CV_8UC1 or CV_8UC3) of any kind (a BoardDetector made for
// the call).
Result<calibration::BoardView> detect_board(const cv::Mat& image, const BoardSpec& spec,
                                            const std::string& name);
// Loads a photo (any format OpenCV reads) and detects the board; errors name the file.
// width/height receive the image size.
Result<calibration::BoardView> detect_board_file(const std::string& path, const BoardSpec& spec,
                                                 int& width, int& height);

// The printed board as a texture: 8-bit gray, `px_per_m` texture pixels per metre, texture
// pixel (0,0)'s top-left corner at board point origin_m (the board's white margin included).
struct BoardTexture {
  cv::Mat image;  // CV_8UC1
  double px_per_m = 0;
  Eigen::Vector2d origin_m = Eigen::Vector2d::Zero();
};
BoardTexture make_board_texture(const BoardSpec& spec, double px_per_m = 4000);

struct BoardRenderOptions {
  int supersample = 3;         // per-axis samples per pixel (antialiasing), 1..8
  double blur_sigma_px = 0.5;  // optics blur, px (0 = none)
  double noise_sigma_dn = 2;   // Gaussian sensor noise, 8-bit digital numbers
  std::uint8_t background = 70;
  // A "warped board" (printout not flat): the board surface bulges by this much toward the
  // camera at its centre (paraboloid, zero on the board's edges), m. 0 = flat. Used to make a
  // realistic outlier view in simulation.
  double warp_m = 0;
  std::uint64_t seed = 1;
  std::string validate() const;
};

// Ray-casts the board as the camera k sees it at T_cam_board: per sample, undistort the pixel to
// a ray, intersect the board surface, sample the texture bilinearly. CV_8UC1, k.width x k.height.
cv::Mat render_board_view(const BoardTexture& texture, const calibration::CameraIntrinsics& k,
                          const Eigen::Isometry3d& T_cam_board, const BoardRenderOptions& options = {});

// Ground-truth image points of the board's points at a pose (no noise), OpenCV convention.
std::vector<Eigen::Vector2d> project_board_points(const BoardSpec& spec,
                                                  const calibration::CameraIntrinsics& k,
                                                  const Eigen::Isometry3d& T_cam_board);

// A simulated photo session: `count` poses from calibration::plan_board_poses, rendered; the
// view at index bad_view (if >= 0) is rendered with a warped board (bad_warp_m) as the outlier.
struct SimulatedBoardSession {
  std::vector<cv::Mat> images;
  std::vector<Eigen::Isometry3d> T_cam_board;  // truth
};
SimulatedBoardSession simulate_board_session(const BoardSpec& spec,
                                             const calibration::CameraIntrinsics& k, int count,
                                             std::uint64_t seed, int bad_view = -1,
                                             double bad_warp_m = 0.006,
                                             const BoardRenderOptions& options = {});

}  // namespace dentar::ar
