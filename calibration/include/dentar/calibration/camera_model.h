// Choosing the camera's distortion model by evidence, and saying where in the image it holds.
//
// A board that covers only the middle of the image lets a flexible model (k1 k2 k3) fit the
// board corners to 0.18 px while folding over outside them (radial factor 0.43 at the image
// corner: points there projected hundreds of pixels away). select_camera_model therefore
//  1. fits each candidate (k1; k1 k2; radtan5; rational8 where the data warrant it) on the
//     views kept by calibrate_intrinsics' outlier rejection,
//  2. compares them on held-out views (K-fold: fit on the other views, solve each held-out
//     view's board pose with the fitted intrinsics, RMS of its reprojection),
//  3. refuses a model whose radial factor is not monotonic, or whose projection cannot be
//     inverted, anywhere in the image (check_lens),
//  4. keeps the simplest valid model not significantly worse on held-out views than the best
//     valid one (paired t over the views),
//  5. maps, over the image, an upper bound of the chosen model's projection error: the
//     projection uncertainty from the fit's noise (the full covariance of the intrinsics with
//     the board poses marginalised, as mrcal does, here without its rotation compensation, so
//     it is conservative), plus the spread between the candidates that fit the held-out views
//     as well, and where the image lies beyond the radius the boards reached ("extrapolated").
// Units: pixels; "normalised" coordinates are x/z, y/z of a camera-frame ray.
#pragma once

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "dentar/calibration/intrinsics.h"

namespace dentar::calibration {

// Pinhole camera with OpenCV's distortion, up to 8 coefficients: k1 k2 p1 p2 k3 k4 k5 k6
// (k4..k6 are 0 for the 5-coefficient models).
struct Lens {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::array<double, 8> d{};
  static Lens from(const CameraIntrinsics& k);
  // From a fit (all its coefficients, 5 or 8).
  static Lens from(const IntrinsicsSummary& s);
  // Radial factor f(r) = (1 + k1 r^2 + k2 r^4 + k3 r^6) / (1 + k4 r^2 + k5 r^4 + k6 r^6).
  double radial_factor(double r) const;
  // Pixel of the ray (x, y, 1).
  Eigen::Vector2d project(const Eigen::Vector2d& xy) const;
  // Normalised ray of a pixel (Newton on the distortion, started from the radial-only
  // solution on the monotonic branch). False when it does not converge to 1e-6 px.
  bool unproject(const Eigen::Vector2d& px, Eigen::Vector2d& xy) const;
};

// Coefficients a model fits: 1, 2, 5, 8.
int free_coefficient_count(DistortionModel m);

struct LensCheck {
  bool ok = false;
  std::string reason;        // why not, in words for an instructor (empty when ok)
  double r_image = 0;        // normalised radius of the farthest image corner (undistorted)
  double corner_factor = 1;  // radial factor at r_image
  double r_fold = 0;         // where r f(r) stops increasing (inf-like 1e9 when nowhere up to 10)
  double reversal_px = 0;    // largest move of f against its overall trend, in px at r_image
};

// Refuses a lens whose radial factor is not monotonic over the image (a reversal of more than
// max_reversal_px at the image corner), is <= 0, or whose projection is not invertible at
// every pixel of the image (checked on a 16 px grid and along the whole border).
LensCheck check_lens(const Lens& lens, double max_reversal_px = 0.5);

struct CandidateModel {
  DistortionModel model = DistortionModel::kK1;
  bool fitted = false;
  IntrinsicsSummary fit;       // on all the kept views
  double heldout_rms_px = -1;  // RMS reprojection distance of the held-out views
  int heldout_points = 0;
  std::vector<double> heldout_view_mse;  // per kept view, mean squared distance (NaN: unsolved)
  // Paired t statistic, over the held-out views, of this model's squared error minus the best
  // valid model's: > significance_t means this model is significantly worse.
  double t_vs_best = 0;
  LensCheck check;
  bool as_good = false;        // valid and not significantly worse than the best on held-out views
  std::string verdict;         // "chosen: ...", "refused: ...", "worse on held-out views ..."
  double tangential_chi2 = -1;  // radtan5: (p1/sd_p1)^2 + (p2/sd_p2)^2 (-1: not computed)
};

// The error bound over the image, on the coverage map's grid.
struct TrustMap {
  int cols = 0, rows = 0;
  // Per cell (row-major), the worst of 9 sample points (corners, edge middles, centre):
  std::vector<double> sigma_px;    // 1-sigma projection uncertainty (worst direction)
  std::vector<double> spread_px;   // largest disagreement with the other as-good candidates
  std::vector<double> bound_px;    // sigma_k * sigma + spread; +inf where extrapolated
  std::vector<unsigned char> extrapolated;  // beyond the radius the boards reached
  std::vector<unsigned char> trusted;       // bound <= max_error_px and not extrapolated
  double trusted_fraction = 0;        // of all cells
  double tooth_trusted_fraction = 0;  // of the tooth region's cells
  double r_data = 0;                  // largest normalised radius of a board point
  double max_error_px = 1.0;          // the threshold the map was made for
  // One line per row: '.' bound <= 0.3 px, ':' <= max_error_px, 'x' above, '?' extrapolated.
  std::string ascii(double max_error_px) const;
  // Is pixel (u, v) in a trusted cell?
  bool trusted_at(double u, double v, int width, int height) const;
};

struct ModelSelectionOptions {
  IntrinsicsOptions intrinsics;  // rejection, gates, coverage grid, tooth region (model ignored)
  int folds = 5;                 // K of the K-fold held-out comparison (fewer when fewer views)
  // "As good" as the best valid model (lowest held-out RMS): the paired t statistic of the
  // per-view held-out squared errors (this model minus the best) is below significance_t.
  // A model that only memorises the boards gains nothing here; a real lens term lowers the
  // error on every held-out view and is kept.
  double significance_t = 2.0;
  // ... and its held-out RMS is within as_good_ratio * best + as_good_px (with few views the
  // t test alone misses a model that is plainly worse: twice the best RMS at t = 1.9).
  double as_good_ratio = 1.05;
  double as_good_px = 0.005;
  // rational8 is fitted only when radtan5 is valid and significantly better than k1k2 on
  // held-out views (higher-order distortion is evident) and the boards cover at least this
  // fraction of the image.
  double rational_min_coverage = 0.5;
  // k1 and k1k2 are set aside when radtan5's tangential coefficients are significantly non-zero:
  // (p1/sd_p1)^2 + (p2/sd_p2)^2 above this (chi-square, 2 degrees of freedom; 13.8: p = 0.001).
  // Held-out reprojection cannot see what dropping them costs: the principal point shifts to
  // absorb them and the board poses turn with it, so the images agree while the camera frame is
  // turned (the camera-frame co-location, issue 24; docs/BENCHMARKS.md session 11). 0: off.
  double tangential_chi2 = 13.8;
  double max_reversal_px = 0.5;  // check_lens
  double max_error_px = 1.0;     // trust threshold of the map
  double sigma_k = 3.0;          // noise part of the bound: sigma_k * sigma
  double extrapolation_margin = 1.1;  // trusted up to this times the boards' radius
  std::optional<DistortionModel> force;  // a user's choice; still refused when it folds
  std::string validate() const;
};

struct ModelSelection {
  bool ok = false;
  std::string message;  // failure: what went wrong and what to do; success: one line
  DistortionModel model = DistortionModel::kK1;
  std::string why;      // why this model, in one or two sentences
  IntrinsicsSummary chosen;                // the chosen model's calibration
  std::vector<CandidateModel> candidates;  // k1, k1k2, radtan5, rational8 (in that order)
  TrustMap trust;
  std::vector<std::string> warnings;       // coverage/trust, with the photos to add
  std::string report() const;              // instructor report (replaces chosen.report())
  // Camera file of the chosen model (date: ISO UTC now when empty).
  CameraFile to_camera_file(const std::string& device, const std::string& date = {}) const {
    return chosen.to_camera_file(device, date);
  }
};

ModelSelection select_camera_model(const std::vector<BoardView>& views, int width, int height,
                                   const ModelSelectionOptions& options = {});

// A camera's frame is only defined up to a small rotation (a shifted cx is the same images as
// a slightly turned camera; the board poses absorb it), so two lenses are compared, as mrcal
// does, after the rotation of the rays that best aligns them over the pixels `fit_px` (e.g.
// where the boards were): R with est.project(R * ray_ref(q)) ~ q. Gauss-Newton, small angles.
Eigen::Matrix3d align_rotation(const Lens& ref, const Lens& est,
                               const std::vector<Eigen::Vector2d>& fit_px);
// Projection error of `est` against `ref` at pixel (u, v): the ref ray of the pixel, turned by
// R, projected by est, minus the pixel. NaN where ref cannot unproject it.
double projection_error_px(const Lens& ref, const Lens& est, const Eigen::Matrix3d& R, double u,
                           double v);

}  // namespace dentar::calibration
