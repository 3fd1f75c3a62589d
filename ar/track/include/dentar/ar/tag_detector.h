// AprilTag detection for tracking: an owning wrapper of a libapriltag
// detector and its families (create/destroy pairs), with the speed/accuracy
// settings exposed. Corners come out in OpenCV's pixel convention (pixel
// centres at integers), i.e. libapriltag's corners minus 0.5 px, so they can
// go straight into cv::undistortPoints / cv::solvePnP.
//
// Thread: a TagDetector is used by one thread at a time (libapriltag's
// detector holds scratch state); `threads` > 1 makes libapriltag itself use
// a worker pool inside detect(). threads == 1 runs inline (deterministic).
#pragma once

#include <Eigen/Core>
#include <array>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "dentar/ar/apriltags.h"
#include "dentar/ar/station_scene.h"
#include "dentar/volume/result.h"

struct apriltag_detector;

namespace dentar::ar {

// How the image's grey levels relate to light: the camera's response curve.
// A lens and the pixel area blur an edge symmetrically in *linear* light; a
// camera that then encodes its output (sRGB, as video cameras do) bends the
// blurred ramp, and an edge fitted to the encoded grey levels moves toward
// the bright side by a fraction of the blur width (~0.1-0.3 px; on the
// mirror's 12 mm tags millimetres at its centre, docs/BENCHMARKS.md issue
// 16). libapriltag always searches and decodes the image as delivered
// (issue 24: a linearised copy is darker and lost most tags on real
// photographs); a known response only changes the edge refit: with kSrgb
// each detection's edges are refit in linear light (libapriltag's
// gradient-peak refit done again on the sRGB-decoded grey levels, and the
// area refit below when asked). kLinear keeps libapriltag's corners (its
// own assumption; right for linear-coverage test drawings).
// kCurve: a measured curve (TagDetectorOptions::response_curve, from the
// station's camera.response, `dentar calibrate camera`). kAuto: the station's
// response, resolved by the Tracker (resolve_camera_response, tracker.h); a
// TagDetector refuses it unresolved.
enum class CameraResponse { kLinear, kSrgb, kCurve, kAuto };
const char* camera_response_name(CameraResponse r);  // "linear", "srgb", "curve", "auto"
// Parses "auto", "srgb", "linear"; the error names the value and the choices
// ("curve" is refused: a measured curve comes from the station, use auto).
Result<CameraResponse> parse_camera_response(const std::string& name);

struct TagDetectorOptions {
  // Families searched in one pass (at least one; no duplicates).
  std::vector<TagFamilyId> families = {TagFamilyId::kStandard41h12};
  // Quad search on an image decimated by this factor (1 = full resolution;
  // >= 1). Decoding and edge refinement still use the full image.
  double decimation = 2.0;
  int threads = 1;  // libapriltag worker threads, 1..64
  // Snap the quad edges to the full-resolution gradients: recovers most of
  // the corner accuracy lost to decimation. Keep on for pose estimation.
  bool refine_edges = true;
  double blur_sigma = 0.0;  // Gaussian blur before the quad search, px (0 = off)
  // Bit errors libapriltag corrects (0..3). Each detection reports how many
  // it corrected in `hamming`; the pose stage can reject those above its own
  // threshold. More bits cost memory for the decode table (41h12: 2 bits).
  int max_bits_corrected = 2;
  // Corner candidates libapriltag's quad fit keeps per outline (its
  // qtp.max_nmaxima: the strongest maxima of the line-fit error along the
  // outline; every 4 of them are tried, C(n, 4) line fits). 4..20. The
  // default is libapriltag's 10; the tracker uses 7 (auto_detector_options,
  // tracker.h): 35 combinations instead of 210, the same tags and corners
  // on every real set, about 4 % less detection work (docs/BENCHMARKS.md,
  // "Issue 24 (session 13): detection time").
  int corner_candidates = 10;
  // The images' response curve (above). The default keeps libapriltag's
  // behaviour; the tracker (TrackerOptions) defaults to kSrgb.
  CameraResponse response = CameraResponse::kLinear;
  // response == kCurve: grey code i -> relative linear light, 256 entries in
  // [0, 1], non-decreasing, curve[255] > curve[0]. Ignored otherwise.
  std::vector<double> response_curve;
  // Re-fit the border square's edges after libapriltag, in linear light
  // (from `response`),
  // with an estimator that blur cannot move (the area under the edge across
  // the border's two one-cell rings). libapriltag's own refinement (gradient
  // peak within +-2 px) moves blurred edges of small or grazing tags by
  // -0.05..-0.1 px (docs/BENCHMARKS.md issue 16, third part). Tags whose
  // cells are under 3 px keep libapriltag's corners.
  bool refit_edges_linear = false;

  // Empty when valid; else names the field ("decimation = 0.5 must be >= 1").
  std::string validate() const;
};

// One tag as detected.
struct DetectedTag {
  TagFamilyId family = TagFamilyId::kStandard41h12;
  int id = 0;
  int hamming = 0;             // bits corrected to decode it
  double decision_margin = 0;  // libapriltag's decoding confidence (higher = better)
  // OpenCV pixel convention, libapriltag's corner order (see station_scene.h:
  // tag-frame corners (-s/2,+s/2), (+s/2,+s/2), (+s/2,-s/2), (-s/2,-s/2)).
  std::array<Eigen::Vector2d, 4> corners_px;
  // Not decoded: the tracker's model-based edge fit placed this border square where the
  // tag's prediction said (TrackerOptions::edge_fit); hamming and decision_margin are 0.
  bool edge_fit = false;
  // Not decoded: the tracker's cell-pattern fit placed it (TrackerOptions::pattern_fit).
  bool pattern_fit = false;
};

// Owns one libapriltag detector and its families. Move-only.
class TagDetector {
 public:
  // Error when the options are invalid (message names the field).
  static Result<TagDetector> create(const TagDetectorOptions& options = {});
  TagDetector(TagDetector&& o) noexcept;
  TagDetector& operator=(TagDetector&& o) noexcept;
  TagDetector(const TagDetector&) = delete;
  TagDetector& operator=(const TagDetector&) = delete;
  ~TagDetector();

  // Runtime settings (no re-creation); errors name the field and leave the
  // detector unchanged.
  Status set_decimation(double decimation);
  Status set_threads(int threads);
  void set_refine_edges(bool on);
  const TagDetectorOptions& options() const { return options_; }

  // Detects tags in an 8-bit grayscale image (CV_8UC1, any stride; at least
  // 8x8 px). Error for an empty or wrong-type image. The image is only read
  // during the call. An image without tags gives an empty list.
  Result<std::vector<DetectedTag>> detect(const cv::Mat& gray);
  // The same, but libapriltag's quad search and decoding run on a linear-
  // light copy of `gray` (8-bit, from the response); the corners are then
  // refit as detect() does. Not a first search: on real photographs the
  // linear copy lost 36 of 47 tags (issue 24). It is the second look the
  // Tracker takes where a tag it expects was missed: on small tags blurred
  // in linear light (defocus, motion, the pixel area) sRGB encoding lifts
  // the blurred black border above libapriltag's threshold (the mean of
  // the tile's extremes), and on the linear copy it stays dark
  // (docs/BENCHMARKS.md, issue 24 session 11). Error when the response is
  // linear (the image already is), or as detect().
  Result<std::vector<DetectedTag>> detect_in_linear_light(const cv::Mat& gray);

  // The response's grey level -> linear light table (0..255 scale; identity for kLinear).
  const std::array<double, 256>& to_linear() const { return to_linear_; }

 private:
  TagDetector() = default;
  void reset() noexcept;
  // libapriltag on `search` (gray or its linear copy), corners refit on gray.
  Result<std::vector<DetectedTag>> run(const cv::Mat& gray, const cv::Mat& search);
  struct DetectorDeleter {
    void operator()(apriltag_detector* d) const noexcept;
  };
  TagDetectorOptions options_;
  // The detector references the families' decode tables: it is destroyed
  // first (reset()).
  std::vector<TagFamily> families_;
  std::unique_ptr<apriltag_detector, DetectorDeleter> detector_;
  // Grey code -> linear light (0..255) from options_.response (float
  // values, held as double: the refit reads them without conversion).
  std::array<double, 256> to_linear_{};
  // detect_in_linear_light: grey code -> linear light as 8-bit codes, and
  // the linearised copy (reused while the size stays).
  cv::Mat search_lut_, linear_;
};

}  // namespace dentar::ar
