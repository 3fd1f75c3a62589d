// Hand-eye calibration: where a camera sits on the body that carries it (an HMD, or a frame
// tracked by something else), from poses of both.
// Frames: `base` the tracker of the carrying body (e.g. the HMD's tracking origin), `hand` the
// carrying body, `cam` the camera, `target` a board or tag bundle that stays still in `base`.
// Each observation pairs T_base_hand (from the body's tracker) with T_cam_target (from the
// camera), taken at the same moment. The unknowns are X = T_hand_cam and Z = T_base_target,
// with T_base_hand * X * T_cam_target = Z for every observation (OpenCV's calibrateHandEye
// calls them gripper2base, target2cam and cam2gripper).
//
// Our method (calibrate_hand_eye): a linear start that holds for any rotation size (rotations
// from the null space of (R_Ci^T kron R_Hi) vec(R_X) - vec(R_Z) = 0, projected onto SO(3); then
// translations by linear least squares), refined by Levenberg-Marquardt (Eigen, hand-written)
// on the pose residuals log(R_Z^T R_Hi R_X R_Ci) / sigma_rot and (t_pred - t_Z) / sigma_m,
// with the covariance of X from the final Jacobian.
// Units: metres, radians.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace dentar::calibration {

struct HandEyeObservation {
  Eigen::Isometry3d T_base_hand = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_cam_target = Eigen::Isometry3d::Identity();
};

// kOurs, then OpenCV 4.6's five cv::calibrateHandEye methods.
enum class HandEyeMethod { kOurs, kTsai, kPark, kHoraud, kAndreff, kDaniilidis };
const char* hand_eye_method_name(HandEyeMethod m);  // "ours", "TSAI", "PARK", ...

struct HandEyeOptions {
  int min_observations = 4;
  // The body must turn about at least two different axes: the smallest eigenvalue of the
  // spread of the relative rotation vectors must reach this angle (rad, RMS).
  double min_axis_spread_rad = 5.0 * 3.14159265358979 / 180;
  double sigma_rot_rad = 1e-3;  // weights of the residuals (noise of one pose pair)
  double sigma_m = 1e-3;
  int max_iterations = 100;
  // A pair whose residual exceeds this many sigmas after the fit is reported (not dropped).
  double outlier_sigmas = 5;
  std::string validate() const;
};

struct HandEyeResult {
  bool ok = false;
  std::string message;  // failure: what to do; success: one line
  HandEyeMethod method = HandEyeMethod::kOurs;
  Eigen::Isometry3d T_hand_cam = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_base_target = Eigen::Isometry3d::Identity();
  double rms_rot_rad = 0, rms_m = 0;  // residuals of T_base_hand X T_cam_target against Z
  double rotation_spread_rad = 0;     // largest rotation between two observations of the body
  // 1-sigma of X (ours only): rotation (rad, worst axis) and translation (m, worst axis), from
  // the LM Jacobian scaled by the residuals' variance.
  double rot_sd_rad = -1, trans_sd_m = -1;
  int iterations = 0;
  std::vector<std::string> warnings;
  std::string report() const;
};

HandEyeResult calibrate_hand_eye(const std::vector<HandEyeObservation>& obs,
                                 const HandEyeOptions& options = {});

// OpenCV 4.6's cv::calibrateHandEye with one of its methods (not kOurs), for comparison; Z is
// then the mean of T_base_hand X T_cam_target. It carries a warning whenever the motions hold
// rotations larger than kOpenCvHandEyeSafeRotationRad for TSAI and DANIILIDIS, which fail
// there (wrong by degrees from ~150 degrees on; measured: docs/BENCHMARKS.md,
// hand_eye_test.cpp). HORAUD, PARK and ANDREFF held on the same motions.
inline constexpr double kOpenCvHandEyeSafeRotationRad = 90.0 * 3.14159265358979 / 180;
HandEyeResult calibrate_hand_eye_opencv(const std::vector<HandEyeObservation>& obs,
                                        HandEyeMethod method);

// Generated motions: n body poses whose orientations spread up to rotation_spread_rad (each is
// a turn of 1/4..1/2 of the spread about a random axis from a common orientation, so pairs
// differ by up to the spread), positions within 0.3 m; camera poses from the truth, both with
// Gaussian noise (rotation sigma_rot_rad per axis, translation sigma_m per axis).
std::vector<HandEyeObservation> simulate_hand_eye(const Eigen::Isometry3d& T_hand_cam,
                                                  const Eigen::Isometry3d& T_base_target, int n,
                                                  double rotation_spread_rad, double sigma_rot_rad,
                                                  double sigma_m, std::mt19937_64& rng);

// Rotation angle (rad) and translation distance (m) between two poses.
double rotation_error_rad(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b);
double translation_error_m(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b);

}  // namespace dentar::calibration
