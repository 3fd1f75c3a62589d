// Issue 28 session 22: a tag's four corners fitted to its known, motion-blurred cell pattern
// where its pose predicts it (for a tag the detector cannot decode in a blurred frame).
//
// The model: the tag's cells (TagFamily::cells: the code, the border rings and a half-cell
// white plate margin), each corner k moving along its predicted blur vector v_k over the
// exposure (corner at time s in [-1/2, 1/2] of the exposure: c_k + s v_k; the pose's time is
// the exposure's middle, s = 0), the pixel the mean of the pattern over `subsamples` times
// (each through the homography of that time's four corners), the pattern smoothed by a
// Gaussian of optics_sigma_px image pixels. In linear light (the camera response's table):
// image = a + b x model, brightness a and contrast b free (nuisance parameters).
//
// The fit: the corners' mean shift searched on a grid over +-reach (decimated pixels, fewer
// subsamples), then Gauss-Newton (Levenberg-Marquardt damping) on the 8 corner coordinates
// and a, b, the Jacobian analytic (numeric_jacobian: forward differences), Huber weights against
// occluders. Gauss-Newton of our own rather than Ceres or cv::findTransformECC: ECC fits a
// warp of one template without blur (the blur here moves with the corners and differs per
// corner) and has no brightness offset; Ceres would add a dependency for a 10-parameter
// problem.
//
// Then the cell check: with the fitted corners fixed, every cell's albedo is fitted freely
// (each cell's blurred footprint a basis image, a ridge toward mid-grey so that cells the
// blur does not resolve stay undecided); a cell is "confident" when its albedo is more than
// cell_confidence x b from mid-grey. Refused (kWrongCells) when the confident cells that
// disagree with the known code are more than max_wrong_cells, or fewer than min_right_cells
// agree, or the weighted correlation of image and model is under min_correlation. A tag of
// another id differs in >= 11 bits (tag36h11) or >= 12 (tagStandard41h12).
//
// OpenCV pixel convention (distorted image px, as the detector's corners); libapriltag's
// corner order (TagPlacement::corner: (-1, 1), (1, 1), (1, -1), (-1, -1) in the tag's
// x right / y down cell grid).
#pragma once

#include <Eigen/Core>
#include <array>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

namespace dentar::ar {

struct TagPatternFitOptions {
  int max_iterations = 12;          // Gauss-Newton steps
  double optics_sigma_px = 0.6;     // the pattern's smoothing (lens and pixel), image px
  double subsample_px = 1.0;        // blur subsamples: one per this many px of the longest corner path
  int max_subsamples = 25;          // ... at most (odd; the grid search uses a third of them)
  double huber_sigmas = 2.0;        // residuals beyond this many robust sigmas get Huber weights
  double min_correlation = 0.90;    // weighted correlation of image and fitted model
  double cell_confidence = 0.25;    // a cell's albedo this far (x contrast) from mid-grey counts
  int max_wrong_cells = 1;          // confident cells against the code: more refuses
  int min_right_cells = 12;         // confident cells with the code: fewer refuses
  double max_shape_px = 2.0;        // the fitted square's shape (less its shift) against the prediction
  int min_pixels = 60;              // pixels in the fit
  // The Gauss-Newton Jacobian: false = analytic (the homography's derivative in the corners
  // and the pattern's gradient; session 23), true = forward differences of the model (0.2 px,
  // 8 more model evaluations a step; session 22's).
  bool numeric_jacobian = false;
  std::string validate() const;     // empty when valid, else names the field
};

enum class TagPatternFitStatus {
  kFitted,
  kOverlap,        // another square (predicted or decoded) overlaps the fitted area
  kNoFit,          // too few pixels, no contrast (b <= 0), or the fit diverged
  kWrongCells,     // the cell check or the correlation refused it
  kOffPrediction,  // the fitted square's shift over the reach or its shape over max_shape_px
  kBadInput,       // see `message`
};
const char* tag_pattern_fit_status_name(TagPatternFitStatus s);  // "fitted", "overlap", ...

struct TagPatternFit {
  TagPatternFitStatus status = TagPatternFitStatus::kBadInput;
  std::array<Eigen::Vector2d, 4> corners_px{};  // the fitted corners (every status after the fit)
  double brightness = 0, contrast = 0;          // a, b (linear light units of to_linear)
  double correlation = 0;                       // weighted, image against the fitted model
  int right_cells = 0, wrong_cells = 0;         // confident cells with / against the code
  int pixels = 0, iterations = 0;
  double shift_px = 0, shape_px = 0;  // against the prediction
  // The fitted corners' stated sigma (px, RMS over the 8 coordinates): the fit's weighted
  // residual variance times its inverse normal matrix, as if pixels were independent. 0 when
  // the fit stopped before a full step. Compared with the corner errors of rendered tags in
  // CornerBias.PatternFitFindsTagsTheDetectorMissesAndRefusesAWrongId.
  double corner_sigma_px = 0;
  std::string message;                // kBadInput: what was wrong
};

// gray: CV_8UC1 image, valid at least over the predicted tag plus its blur and reach;
// cells: TagFamily::cells(id) (total_width^2, 0 black / 255 white); border_start,
// width_at_border: TagFamily's (the corners are the border square's); predicted_px: the tag's
// corners at the exposure's middle; blur_px: each corner's image motion over the whole
// exposure (zero: no blur); reach_px: how far the prediction may be off (> 0); others_px:
// every other square predicted or decoded (each grown by outer_extent of its side, as this
// one's cells are): one overlapping this tag's cells plus its blur refuses (kOverlap);
// to_linear: the camera response's table (nullptr: the grey levels as they are).
TagPatternFit fit_tag_pattern(const cv::Mat& gray, const cv::Mat& cells, int border_start, int width_at_border,
                              const std::array<Eigen::Vector2d, 4>& predicted_px,
                              const std::array<Eigen::Vector2d, 4>& blur_px, double reach_px, double outer_extent,
                              const std::vector<std::array<Eigen::Vector2d, 4>>& others_px,
                              const TagPatternFitOptions& options = {},
                              const std::array<double, 256>* to_linear = nullptr);

}  // namespace dentar::ar
