// Stylus-tip (pivot) calibration: the tip rests in a divot while the stylus is tilted about it.
// Frames follow docs/conventions.md: T_dev_sty maps stylus coordinates into the device base.
// Units: metres and radians in code; Summary::report() prints mm and degrees for instructors.
#pragma once

#include <Eigen/Geometry>
#include <numbers>
#include <string>
#include <vector>

namespace dentar::calibration {

struct PivotOptions {
  int min_poses = 10;  // fewer poses are refused
  // Orientation spread (see PivotSummary::spread_rad) must reach this; 15 degrees.
  double min_spread_rad = 15.0 * std::numbers::pi / 180.0;
  // The weakest direction (PivotSummary::weakest_tilt_rad) must reach this; 5 degrees.
  // Catches tilting in one plane only, which leaves one component of the tip unobservable.
  double min_weakest_tilt_rad = 5.0 * std::numbers::pi / 180.0;
  // Empty when valid, else names the field and the constraint.
  std::string validate() const;
};

// Status, message and result together (Ceres Solver::Summary style). When ok is false the
// message says what to do next and the result fields hold no calibration.
struct PivotSummary {
  bool ok = false;
  std::string message;

  // Result (valid only when ok). T_sty_tip: translation = p_tip_sty, rotation identity (a
  // pivot cannot observe the bur axis; conventions.md gives tip the stylus's orientation).
  Eigen::Isometry3d T_sty_tip = Eigen::Isometry3d::Identity();
  Eigen::Vector3d p_tip_sty = Eigen::Vector3d::Zero();    // m
  Eigen::Vector3d p_divot_dev = Eigen::Vector3d::Zero();  // m
  // Covariance of p_tip_sty (m^2) from the least-squares residual: sigma^2 (A^T A)^-1 with
  // sigma^2 = |r|^2 / (3N - 6). Assumes isotropic, independent noise on the tip position.
  Eigen::Matrix3d cov_tip_sty = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d cov_divot_dev = Eigen::Matrix3d::Zero();  // m^2
  // RMS over poses of the 3-D distance between the tip mapped into dev and the divot, m.
  double rmse_m = 0;
  double max_residual_m = 0;
  int worst_pose = -1;  // index of the pose with the largest residual

  // Diagnostics (filled whenever the input was readable, also on a gate failure).
  int num_poses = 0;
  // Orientation spread: the largest angle between any pose's rotation and the mean rotation
  // (the chordal mean: the arithmetic mean of the R_i projected back onto SO(3)).
  double spread_rad = 0;
  // sqrt of the smallest eigenvalue of (1/N) sum (R_i - Rbar)^T (R_i - Rbar), Rbar the
  // arithmetic mean of the R_i: the RMS tilt (small-angle, rad) seen by the worst-determined
  // tip direction. This is the information matrix of the tip up to sigma^2 / N.
  double weakest_tilt_rad = 0;

  // One-paragraph report in millimetres and degrees.
  std::string report() const;
};

// Solves [R_i  -I] [p_tip_sty; p_divot_dev] = -t_i in the least-squares sense over all poses.
// Never aborts on user input: non-finite or non-rigid poses, too few poses and too little
// rotation return ok = false with a message.
PivotSummary calibrate_pivot(const std::vector<Eigen::Isometry3d>& T_dev_sty,
                             const PivotOptions& options = {});

}  // namespace dentar::calibration
