// Refinement of the mirror's pose from its rim's ellipse in the image
// (issue 16, Build item 3).
//
// The mirror's tags sit on a paddle 85 mm from the disc, so a small angular
// error of the tag fit becomes millimetres at the disc. The disc's own
// outline (a circle of radius r in the `mir` plane, an ellipse in the image)
// fixes the disc's position and tilt without that lever.
//
//  1. From the tag pose, project the rim at N angles (camera model with
//     distortion). The model point of each angle is the disc body's outer
//     silhouette: the face's edge (z = 0) or the back's (z = -thickness),
//     whichever projects farther out along the curve's image normal. Angles
//     where the stem leaves the rim (-y of `mir`) are skipped.
//  2. Along each image normal, within +-search_px, find the strongest edge of
//     the linear-light image (sRGB-decoded per sample when `srgb`); reject
//     weak edges (< min_step of linear light across it), ambiguous ones (a
//     second peak >= ambiguity x the best, more than 1.5 px away) and peaks
//     at the window's end.
//  3. Gauss-Newton on the pose delta (w, v) (BundlePose's convention) over
//     the tag fit as a prior (its information per px^2 of corner noise: the
//     tag corners' residuals linearised at their optimum) plus the rim
//     points' distances along their normals to the projected rim (each
//     sample tied to its angle), Huber-weighted. The rim's own noise is
//     estimated from its residuals and counts as no better than the
//     corners'. The rim does not see the rotation about the disc normal:
//     the prior keeps the tags' there.
//  4. Fallback (refined = false, the tag pose kept): fewer than min_points
//     edges, or the correction further from the tag pose than
//     max_correction_sigma in the tag fit's own covariance (a wrong edge).
//
// Frames: `cam`, `mtag` (the body), `mir`. Metres, radians; _px where said.
// Thread-safe (pure function).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "dentar/ar/bundle_pose.h"
#include "dentar/ar/camera_model.h"

namespace dentar::ar {

struct MirrorRimOptions {
  int samples = 72;               // angles along the rim
  double search_px = 4.0;         // half-width of the edge search along the normal
  double min_step = 0.03;         // linear light (0..1) across an accepted edge
  double ambiguity = 0.7;         // second peak / best peak at or above this: rejected
  double stem_exclude_rad = 0.45; // half-width of the skipped arc around -y (the stem)
  int min_points = 20;            // fewer accepted edges: fallback
  double huber_px = 1.0;          // robust threshold on a rim point's residual
  double max_correction_sigma = 6.0;  // Mahalanobis bound on the correction (6 dof)
  int iterations = 6;
  // Search rounds: the first within +-search_px of the tag pose's rim, each
  // later one within +-research_px of the refined pose's.
  int rounds = 2;
  double research_px = 1.5;
  // The rim's points share one blur and one silhouette model: their
  // information is counted as at most this many independent points (the
  // covariance, and so the tracker's gate).
  double rim_effective_points = 12;
  // Fit the rim's image scale as a free parameter (its size then says
  // nothing about the depth: an edge bias would move it by centimetres).
  bool free_scale = true;
  // Use the rim only for the image position of the disc's centre: a
  // rim-only fit (free scale, the tags' prior weakened by 1e-4) gives that
  // point and its 2x2 covariance, which then joins the tag prior as one 2-D
  // measurement. The disc's tilt and size from a 10-30 px ellipse are left
  // to the tags (measured: otherwise the error along the line of sight grows).
  bool centre_only = false;
  // Keep the disc centre's distance along its line of sight at the tags'
  // value (a hard constraint in the fit): the rim then moves the centre only
  // across the line of sight and tilts the disc.
  bool keep_depth = true;
  // The model point: the outer silhouette of the face and back circles
  // (true), or the face's circle only (false).
  bool silhouette_back = true;
  // The edge locator (issue 16, rim depth): false = the strongest gradient
  // with a parabola (as before); true = a blurred-step fit (see
  // locate_rim_edge) on the mean of parallel profiles, with the tests below.
  bool step_fit = false;
  double blur_px = 0.6;           // predicted edge blur (Gaussian sigma, px): optics + pixel
  double max_width_ratio = 2.0;   // fitted blur above this x blur_px: rejected (motion blur, a ramp)
  double max_fit_rms = 0.12;      // fit residual RMS / |step| above this: rejected (not one step)
  double saturation = 0.97;       // linear light at or above this in the fit window: rejected (glare)
  int parallel_lines = 3;         // profiles averaged, spread along the tangent
  double parallel_px = 0.75;      // spacing of those profiles along the tangent (px)
  // An edge whose step sign differs from both its accepted neighbours' (a
  // different boundary) is rejected.
  bool polarity_check = true;
  // The fit's model point slides along its circle onto the edge's line (the
  // outline's exact crossing, not the first-order one: matters for the
  // back's circle and where the ellipse is tightly curved).
  bool exact_silhouette = false;
  // Where the face's circle is the outline, the level just inside the edge
  // must be the face's (the median of the image at half the radius):
  // |inside - face| <= face_level_tol x max(face, 0.05); 0 = off (step_fit only).
  double face_level_tol = 0;
  // Fallback when the rim's residual RMS at the optimum exceeds this (px;
  // 0 = off): the outline found is not one ellipse.
  double max_rim_rms_px = 0;
  // step_fit: instead of the strongest step per angle, every step that
  // passes the fit's tests, then the one image shift of the predicted
  // outline most of them agree with (a consensus over pairs of angles), and
  // per angle the step nearest to it.
  bool joint_select = false;
  // joint_select: at most this many steps (the strongest) fitted per angle;
  // 16 = all of them within +-4 px (3 measured worse on `fast` and `standard`).
  int max_candidates = 16;
  std::string validate() const;
};

// One edge along a line: the blurred-step fit (step_fit).
struct RimEdgeFit {
  bool ok = false;
  std::string why;       // not ok: the reason
  double offset_px = 0;  // the step's position along the normal, from the line's origin
  double width_px = 0;   // its fitted blur (Gaussian sigma)
  double step = 0;       // linear light, signed: outside (+normal) - inside
  double rms = 0;        // fit residual RMS (linear light)
  double inside = 0;     // the fitted level on the inner side (linear light)
};

// The edge nearest to `origin_px` (within +-window_px) along the unit image
// normal `normal`: the mean of `parallel_lines` bilinear profiles in linear
// light (sRGB-decoded when `srgb`), spread along the tangent; the strongest
// gradient seeds a least-squares fit of  a + step * Phi((x - x0) / width)
// (Phi the normal CDF) over +-(1.5 px + 2 blur_px) around it. Rejected: off
// the image, a peak at the window's end, |step| < min_step, a second
// gradient peak >= ambiguity x the best, width > max_width_ratio x blur_px,
// residual RMS > max_fit_rms x |step|, a sample >= saturation.
RimEdgeFit locate_rim_edge(const cv::Mat& gray, bool srgb, const Eigen::Vector2d& origin_px,
                           const Eigen::Vector2d& normal, double window_px, const MirrorRimOptions& options);

struct MirrorRimEdge {
  double angle_rad = 0;          // rim angle in `mir` (x axis = 0)
  bool back = false;             // the model point is the back (z = -thickness) circle
  Eigen::Vector2d model_px;      // the model point at the tag pose (distorted pixels)
  Eigen::Vector2d normal;        // outward image normal there
  double offset_px = 0;          // the edge found along the normal, from model_px
  double step = 0;               // linear-light step across it (signed: outside - inside)
  double weight = 0;             // Huber weight at the optimum (0 before a fit)
};

struct MirrorRimResult {
  bool refined = false;
  std::string why;  // not refined: the reason
  int candidates = 0;     // angles searched (in the image, off the stem)
  int points = 0;         // edges accepted
  double rms_px = 0;      // rim residual RMS at the optimum (Huber-weighted)
  double noise_px2 = 0;   // the rim's noise estimate used (>= the corners')
  double correction_sigma = 0;  // the correction's Mahalanobis distance in the tag fit's covariance
  Eigen::Isometry3d T_cam_body = Eigen::Isometry3d::Identity();  // refined T_cam_mtag (= the tags' if not refined)
  // As BundlePose::covariance_per_px2 / covariance_per_tag, for the joint fit
  // (rim weights relative to the corner noise).
  Eigen::Matrix<double, 6, 6> covariance_per_px2 = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 6> covariance_per_tag = Eigen::Matrix<double, 6, 6>::Zero();
  std::vector<MirrorRimEdge> edges;  // accepted edges (diagnosis)
};

// gray: CV_8UC1, the tracker's image (`srgb`: levels sRGB-encoded).
// tags: the mirror's tag fit (body = mtag), ok. corner_noise_px2: the corner
// noise behind its covariance (floored by the caller).
MirrorRimResult refine_mirror_rim(const cv::Mat& gray, bool srgb, const CameraModel& model,
                                  const BundlePose& tags, double corner_noise_px2,
                                  const Eigen::Isometry3d& T_mtag_mir, double radius_m,
                                  double thickness_m, const MirrorRimOptions& options = {});

}  // namespace dentar::ar
