// Pose of a rigid tag bundle (the mannequin's tags, the mirror's tags) from
// one frame's tag detections: one PnP over all visible tags' corners.
//
//  1. Keep the detections of the bundle's family whose ids are in the layout
//     (hamming and decision margin thresholds); undistort their corners with
//     the camera model (cv::undistortPoints, back to pixels with the same K).
//  2. Seed: each tag alone with IPPE_SQUARE, both planar solutions. Every
//     seed, mapped to T_cam_body, is scored by its reprojection RMS over all
//     kept corners. Without a previous pose the lowest RMS wins; with one,
//     among the seeds whose RMS is close to the best (ambiguous), the one
//     nearest the previous pose wins, so a single small tag does not flip.
//  3. Refine all corners together with Levenberg-Marquardt; with
//     robust_px > 0 each corner's residual is down-weighted by the Huber
//     loss (iteratively reweighted): a corner pulled off by an occluder or
//     glare no longer drags the whole bundle.
//  4. Covariance from the Gauss-Newton normal equations at the optimum,
//     scaled by the residual variance: sigma^2 (J^T W J)^-1,
//     sigma^2 = sum w r^2 / (2N - 6) (W = the robust weights times the
//     view-angle weights, view_weight_from_rad).
//
// Frames: `cam` (OpenCV optical), `body` (the layout's parent frame: `man`
// for the mannequin, `mtag` for the mirror). Metres and radians; pixels where
// the name says _px. Thread-safe (pure function).
//
// Several views (issue 28, a stereo head): estimate_bundle_pose_views fits
// the same body once to the corners seen in any of the rig's cameras, in the
// rig's frame (`rig` = the left eye `cam_l` by convention): each corner's
// residual is its projection through its own view's intrinsics at
// T_view_rig * T_rig_body. Seeds, weights, the outlier test and the
// covariances are the steps above over every (tag, view) observation; the
// covariance is then in `rig`. Depth along one eye's line of sight is seen
// across by the other eye, which is what a 60-65 mm baseline buys.
// Libraries: OpenCV does the per-eye undistortion (cv::undistortPoints) and
// the per-tag seeds (cv::solvePnPGeneric, SOLVEPNP_IPPE_SQUARE, in each
// eye); the joint refinement is this file's Levenberg-Marquardt, because
// neither OpenCV 4.6 (solvePnP is one camera; triangulatePoints + a 3-D
// alignment would drop the per-corner image noise model and its
// covariance) nor ViSP 3.5 (vpPose is one camera; its multi-camera
// model-based tracker needs CAD models, not tag bundles) fits one rigid
// body to corners of several calibrated cameras with the covariance.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "dentar/ar/station_scene.h"
#include "dentar/ar/tag_detector.h"
#include "dentar/calibration/station.h"

namespace dentar::ar {

// A rigid body's tags: TagPlacement::T_parent_tag is T_body_tag.
struct TagBundle {
  std::string name;  // for messages: "mannequin", "mirror"
  TagFamilyId family = TagFamilyId::kStandard41h12;
  std::vector<TagPlacement> tags;
};
TagBundle mannequin_bundle(const StationScene& s);  // body = man
TagBundle mirror_bundle(const StationScene& s);     // body = mtag

struct BundlePoseOptions {
  int max_hamming = 1;               // detections with more corrected bits are ignored
  double min_decision_margin = 0.0;  // and those below this margin
  int max_iterations = 30;           // Levenberg-Marquardt
  // Seeds within this factor of the best seed's RMS (plus ambiguity_px) are
  // treated as equally good; the previous pose then chooses among them.
  double ambiguity_ratio = 3.0;
  double ambiguity_px = 1.0;
  // Huber threshold on a corner's reprojection distance (px): corners
  // farther off count linearly, not quadratically. 0 = plain least squares.
  double robust_px = 0.0;
  // Corners of tags seen obliquely are noisier (issue 16, generator v2
  // footage: corner error p50 0.13 px within 40 deg of view angle, 0.15 at
  // 40-55, 0.24 at 55-70). With view_weight_from_rad > 0 each tag's corners
  // are weighted by min(1, cos(view angle) / cos(view_weight_from_rad))^2
  // (view angle: between the tag's normal and the ray to its centre, at the
  // seed pose, then again at the first fit's; cos floored at 0.1), i.e.
  // their noise modelled as growing like 1 / cos(view angle) beyond that
  // angle. noise_px2 and the covariances are then those of this weighted
  // fit: noise_px2 is the noise of a corner seen within the angle, which
  // makes it comparable between bodies (TrackerOptions::pool_noise).
  // 0 = every corner weighs the same.
  double view_weight_from_rad = 0.0;
  // Tags seen more obliquely than this at the fit's optimum are dropped and
  // the rest refitted, when at least min_tags_kept remain (0 = keep all).
  double max_view_angle_rad = 0.0;
  int min_tags_kept = 4;
  // Leave-one-out outlier test for a single tag (issue 16: a blurred or
  // grazing tag whose corners are off pulls the whole bundle millimetres
  // away). After the fit, the tag with the largest corner RMS is refitted
  // out; if its corners, predicted by the pose of the others, are more than
  // outlier_px RMS and more than outlier_ratio x the others' RMS off, it
  // leaves the fit (BundlePose::rejected_id), when at least min_tags_kept
  // others remain. One tag per frame. 0 = off.
  double outlier_px = 0.0;
  double outlier_ratio = 4.0;
  // Weight of each tag's shape (its corners about their mean) against its
  // centre in the fit (1 = each corner alone, as libapriltag gives them).
  // Motion blur puts most of a corner's error into the tag's shape
  // (issue 28 session 16: 0.47-0.60 px against 0.15-0.18 px in the centre
  // at 110 deg/s on `hard`). The residuals, noise_px2 and the covariances
  // are then those of the weighted fit (rms_px too, and the outlier test
  // compares weighted residuals). In (0, 1]. Not the tracker's default:
  // measured on `hard` it lowers the error but the residual noise of the
  // weighted fit then under-states it (docs/BENCHMARKS.md, issue 28
  // session 16).
  double shape_weight = 1.0;
  // Motion blur in the fit (issue 28 session 17). Blur stretches every tag's
  // outline in one view the same way: each edge moves along its outward
  // normal n by n^T S n / 2 px, with S a symmetric 2x2 stretch (px) shared
  // by all the tags one view sees in this frame (S = L d d^T for a blur of
  // L px along the image direction d; a corner moves where its two shifted
  // edges meet). With blur_stretch_sigma_px > 0 each view's S (3 numbers)
  // is fitted jointly with the pose (both eyes share the pose, each eye its
  // own S), with a zero-mean prior: each component of S costs as much as a
  // corner residual of S / blur_stretch_sigma_px px. The covariances are
  // the pose's, with the stretch marginalised out, and noise_px2's degrees
  // of freedom lose the stretch's effective parameter count.
  // 0 = off (each corner fitted alone, as before). Not the trackers'
  // default: on `hard` it lowers the error on the same detections (tuning
  // seed 5, stereo RMS 0.135 -> 0.098 mm in the fastest frames) but on
  // held-out seeds the tracker drew fewer frames with a worse p95; the
  // refused frames' corner error is not a shared stretch
  // (docs/BENCHMARKS.md, issue 28 session 17). 8 is the value measured.
  double blur_stretch_sigma_px = 0.0;
  // A tag's outline offset (issue 28 session 18): the four edges of one tag
  // as one view sees it move outward along their normals by one common
  // offset e (px; a corner goes where its two moved edges meet, the blur
  // model's S = 2 e I), from the edge threshold, blur or a small tag's
  // corner refinement. e grows or shrinks the tag in the image, which one
  // camera reads as depth: four corners with independent noise average
  // such an error away, a common offset does not. With
  // tag_outline_sigma = k > 0 the fit still takes each corner alone, and
  // BundlePose::outline_covariance_per_px2 is what an offset of k times the
  // corner noise per tag observation adds to its covariance (a sandwich:
  // the corners' predicted covariance noise^2 (I + k^2 u u^T), u = d corners
  // / d e from the observed quad). Two views see depth across each other
  // and gain little; one view's depth from a few small tags gains the error
  // such an offset makes. (Fitting with that covariance, generalised least
  // squares, was measured on the stereo mirror and made it worse:
  // docs/BENCHMARKS.md, issue 28 session 18.) 0 = off (zero).
  double tag_outline_sigma = 0.0;
  std::string validate() const;  // empty when valid
};

enum class BundlePoseStatus {
  kOk,
  kNoDetections,  // the detection list was empty
  kNoBundleTags,  // detections, but none of this bundle's family/ids/thresholds
  kInvalidInput,  // bad camera, options or layout (message says which field)
  kFailed,        // numerical failure (message says where)
};
const char* bundle_pose_status_name(BundlePoseStatus s);

struct BundlePose {
  BundlePoseStatus status = BundlePoseStatus::kFailed;
  std::string message;  // empty when ok
  Eigen::Isometry3d T_cam_body = Eigen::Isometry3d::Identity();
  double rms_px = 0;         // corner reprojection RMS after refinement (undistorted px)
  double seed_rms_px = 0;    // the chosen seed's RMS before refinement
  int tags_used = 0;         // tag observations whose corners entered the fit (a tag seen by two views counts twice)
  std::vector<int> tag_ids;  // their ids, ascending (a tag seen by two views appears twice)
  int views_used = 0;        // views that contributed corners (1 for the single-camera fit)
  int iterations = 0;        // LM iterations run
  int downweighted = 0;      // corners beyond robust_px at the optimum (Huber weight < 1)
  int rejected_id = -1;      // the tag the outlier test removed (outlier_px), -1 = none
  double rejected_rms_px = 0;  // its corners' RMS under the others' pose
  // Covariance of the pose error delta = (w [rad], v [m]), both in the camera
  // frame: R_true = exp(w) R_cam_body (rotation vector w about the body
  // origin), t_true = t_cam_body + v. So the bottom-right 3x3 block is the
  // covariance of T_cam_body.translation() itself. Zero when not ok.
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
  // The same for 1 px^2 of corner noise per axis, (J^T W J)^-1, and the
  // residual estimate of that noise, sum w r^2 / (2N - 6) (px^2):
  // covariance = covariance_per_px2 * noise_px2.
  Eigen::Matrix<double, 6, 6> covariance_per_px2 = Eigen::Matrix<double, 6, 6>::Zero();
  double noise_px2 = 0;
  int noise_dof = 0;  // 2N - 6: the residual degrees of freedom behind noise_px2
  // The same covariance with each tag's own corner noise (its residuals over
  // its residual degrees of freedom) instead of one noise for all: a
  // sandwich C (sum_t s_t J_t^T J_t) C with C = covariance_per_px2. Small or
  // grazing tags are noisier than large frontal ones (docs/BENCHMARKS.md,
  // issue 16), and one shared noise spreads their noise over the good tags.
  Eigen::Matrix<double, 6, 6> covariance_per_tag = Eigen::Matrix<double, 6, 6>::Zero();
  // BundlePoseOptions::tag_outline_sigma: the covariance (per px^2 of corner
  // noise, as covariance_per_px2) that a common outline offset per tag
  // observation adds; not included in the covariances above (add it, times
  // the corner noise, where the stated error should carry it). Zero when off.
  Eigen::Matrix<double, 6, 6> outline_covariance_per_px2 = Eigen::Matrix<double, 6, 6>::Zero();
  // Each used tag's share of the residual: its weighted residual sum (px^2),
  // its residual degrees of freedom (8 minus its leverage; they add up to
  // noise_dof) and its view angle at the optimum (between its normal and the
  // ray to its centre, rad). Lets another body pool only comparable tags'
  // noise (pose_uncertainty.h, pooled_noise_px2).
  struct TagResidual {
    int id = 0;
    double sum_px2 = 0, dof = 0, view_angle_rad = 0;
    int view = 0;  // the view (index into estimate_bundle_pose_views' list) that saw it
  };
  std::vector<TagResidual> tag_residuals;  // in fit order (by view, then id)
  // The fitted blur stretch S of each view (BundlePoseOptions::
  // blur_stretch_sigma_px), (Sxx, Sxy, Syy) in px; one per view given
  // (zero for a view that saw none of the bundle), empty when off.
  std::vector<Eigen::Vector3d> blur_stretch_px;
  bool ok() const { return status == BundlePoseStatus::kOk; }
};

// T_cam_body_prev: the body's pose in the previous frame (or a prediction),
// used only to break the planar ambiguity. Never throws; bad input gives a
// status and a message naming the field.
BundlePose estimate_bundle_pose(const TagBundle& bundle,
                                const calibration::CameraIntrinsics& camera,
                                const std::vector<DetectedTag>& detections,
                                const BundlePoseOptions& options = {},
                                const std::optional<Eigen::Isometry3d>& T_cam_body_prev = {});

// One camera of a rig: its intrinsics (its own image size and distortion),
// where it sits on the rig (T_view_rig maps the rig frame into this camera's
// optical frame: identity for the left eye, T_camr_caml = T_caml_camr^-1 for
// the right) and what it detected (full-image OpenCV pixels). The pointers
// are borrowed for the call.
struct BundleView {
  const calibration::CameraIntrinsics* camera = nullptr;
  Eigen::Isometry3d T_view_rig = Eigen::Isometry3d::Identity();
  const std::vector<DetectedTag>* detections = nullptr;
};
// The bundle's pose in the rig frame (BundlePose::T_cam_body is T_rig_body,
// its covariances in `rig`) from every view's corners at once. One view with
// T_view_rig = identity is estimate_bundle_pose above, to the bit. Views
// without a detection of the bundle add nothing: a frame that one eye sees
// and the other does not is the single-view fit (in the rig's frame).
// T_rig_body_prev as above. Bad input: kInvalidInput naming views[i].
BundlePose estimate_bundle_pose_views(const TagBundle& bundle, const std::vector<BundleView>& views,
                                      const BundlePoseOptions& options = {},
                                      const std::optional<Eigen::Isometry3d>& T_rig_body_prev = {});

// The blur model of one tag's quad as the fit uses it (BundlePoseOptions::blur_stretch_sigma_px):
// each edge moves along its outward normal n by n^T S n / 2 px, S = (Sxx, Sxy, Syy) the view's
// stretch, and a corner goes where its two moved edges meet. Linear in S: d_corner_d_S[k] is
// corner k's d uv / d S (px per px). corners_px: the 4 corners in libapriltag's order (any
// pixel convention: only differences count). A corner whose two edges are nearly parallel
// (|det| of their normals < 0.2) gets a zero Jacobian; a quad with an edge shorter than 1e-9 px
// is degenerate: all zero (normals zero too). Pure function, any thread.
struct QuadBlurModel {
  std::array<Eigen::Vector2d, 4> edge_normal;  // [e]: outward unit normal of the edge from corner e to e + 1
  std::array<Eigen::Matrix<double, 2, 3>, 4> d_corner_d_S;
  bool degenerate = false;
};
QuadBlurModel quad_blur_model(const std::array<Eigen::Vector2d, 4>& corners_px);

}  // namespace dentar::ar
