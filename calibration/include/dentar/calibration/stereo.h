// Stereo calibration (issue 28): two cameras fixed to each other, from views of one board seen
// by both at the same instant (view i of the left eye and view i of the right are one capture).
//
//  1. Intrinsics per eye: select_camera_model on that eye's views (the camera step's model
//     selection on held-out views and its trust map), every view where the eye found the board.
//  2. Extrinsics T_caml_camr (maps the right eye's optical frame into the left's) on the views
//     where both eyes found the board, points matched by their board coordinates (a chessboard
//     found in reverse corner order in one eye, 180-degree symmetric, is matched turned: the
//     match giving the smaller rotation between the eyes is kept):
//     cv::stereoCalibrate with both eyes' intrinsics fixed at step 1's (for step 3), then jointly
//     with both eyes' intrinsics refined from step 1's (the chosen models' terms): the estimate.
//  3. Rigidity: each common view alone gives a relative pose (both eyes' board poses, solvePnP
//     with step 1's intrinsics, T_caml_board * T_camr_board^-1). Their scatter about the estimate
//     is partly the corners' noise; the rig moved between views (a loose mount, photos from two
//     sessions) when one rig for all views fits the corners much worse than each view's own poses
//     do: RMS ratio above max_residual_ratio, or a gross scatter (max_rotation_scatter_rad,
//     max_translation_scatter_m). Refused, naming the views that differ most.
//  4. Uncertainty: jackknife over the common views (each left out once; or a bootstrap,
//     resampled with replacement); each fit refits both eyes' intrinsics (the chosen models'
//     terms, started at step 1's) and the extrinsics jointly (stereoCalibrate), so the
//     intrinsics' own uncertainty is carried into the extrinsics. The 1-sigma of the translation
//     (m) and of the rotation vector (rad) of T_est^-1 * T_refit, per axis of cam_l.
// Units: metres, radians, pixels (OpenCV convention).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "dentar/calibration/camera_model.h"
#include "dentar/calibration/intrinsics.h"

namespace dentar::calibration {

// How the extrinsics' uncertainty is estimated (step 4): resampling the captures with
// replacement, or leaving each capture out once.
enum class StereoUncertainty { kBootstrap, kJackknife };

struct StereoCalibrationOptions {
  ModelSelectionOptions model;  // per eye
  int min_common_views = 6;     // views where both eyes found the board
  int min_common_points = 8;    // points both eyes saw, per view
  // Rigidity (step 3): one rig's RMS over each view's own poses' RMS. Rigid rigs: 1.01-1.1
  // (generated, 0.15 px noise; OpenCV's stereo sample photographs); a right camera turned 0.5 deg
  // after half the views: 5.6 (docs/BENCHMARKS.md, issue 28 session 14).
  double max_residual_ratio = 1.5;
  // Gross scatter of the per-view relative poses (RMS), refused whatever the residuals say.
  double max_rotation_scatter_rad = 1.0 * M_PI / 180;
  double max_translation_scatter_m = 10e-3;
  // Leave-one-out: over 12 generated rigs its 1-sigma was 1.15x optimistic, the 40-resample
  // bootstrap's 1.26x, at 14 fits instead of 40 (docs/BENCHMARKS.md, issue 28 session 14).
  StereoUncertainty uncertainty = StereoUncertainty::kJackknife;
  int bootstrap = 40;  // resamples for the uncertainty (kBootstrap; 0: none)
  std::uint64_t seed = 1;
  std::string validate() const;
};

struct StereoViewPose {
  std::string name;          // the left eye's view name
  int index = -1;            // into the input views
  int points = 0;            // points both eyes saw
  double rotation_dev_rad = 0;   // this view's relative pose against the estimate
  double translation_dev_m = 0;
};

struct StereoCalibration {
  bool ok = false;
  std::string message;  // failure: the reason and what to do; success: one line
  ModelSelection left, right;  // per-eye intrinsics (model and trust map)
  // The joint fit: both eyes' intrinsics (5 coefficients kept; the chosen models' terms) refined
  // with the extrinsics, started at the per-eye ones. These go into the station file.
  CameraIntrinsics camera_left, camera_right;
  Eigen::Isometry3d T_caml_camr = Eigen::Isometry3d::Identity();
  double rms_px = 0;  // the joint fit's RMS over both eyes' common points
  // 1-sigma (step 4): translation x y z (m) and rotation vector x y z (rad), in cam_l.
  Eigen::Vector3d sigma_t_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d sigma_r_rad = Eigen::Vector3d::Zero();
  double sigma_baseline_m = 0;
  int resamples = 0;  // fits behind the 1-sigma
  int turned_views = 0;  // captures matched with the right eye's board turned 180 deg (see step 2)
  std::vector<StereoViewPose> views;  // the common views
  double rotation_scatter_rad = 0;    // RMS over the common views
  double translation_scatter_m = 0;
  double rigid_rms_px = 0;    // one rig for all views, intrinsics fixed at step 1's
  double free_rms_px = 0;     // each eye's own board pose per view
  double residual_ratio = 0;  // rigid / free
  double baseline_m() const { return T_caml_camr.translation().norm(); }
  std::string report() const;  // mm and degrees
};

// left[i] and right[i] are one capture (a view with no points: the board was not found in that
// eye). Both eyes' images are width x height px. Never aborts on user input: ok = false with the
// reason (mismatched counts, too few common views, an eye's intrinsics refused, a non-rigid rig).
StereoCalibration calibrate_stereo(const std::vector<BoardView>& left, const std::vector<BoardView>& right,
                                   int width, int height, const StereoCalibrationOptions& options = {});

}  // namespace dentar::calibration
