// Station registration: divots touched with the calibrated stylus (device frame) are paired with
// their known positions on the mannequin (mannequin frame) to give T_man_dev.
// Units: metres in code; RegistrationSummary::report() prints millimetres.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace dentar::calibration {

struct RegistrationOptions {
  int min_points = 6;         // fewer divots are refused
  double max_tre_m = 0.5e-3;  // pass/fail gate on the predicted TRE at the target (the tooth)
  // Fiducial localisation error (RMS 3-D length, m). <= 0: estimate it from the FRE as
  // FLE^2 = FRE^2 N / (N - 2) (Fitzpatrick 1998: <FRE^2> = (1 - 2/N) FLE^2).
  double fle_m = 0;
  // Geometry gate on the known divot positions: the RMS distance from the best-fit line
  // (collinear) and from the best-fit plane (coplanar) must each reach
  // max(min_thickness_m, thickness_fle_factor * FLE). A planar set does fix a rigid transform,
  // but the TRE then grows fast off the plane and one mis-touched divot can tilt the whole
  // station unnoticed; this is a policy, set both to 0 to accept planar sets.
  double min_thickness_m = 1e-3;
  double thickness_fle_factor = 3.0;
  // A divot whose residual exceeds this was probably touched wrongly or paired with the wrong
  // known position; it is refused with its index.
  double max_residual_m = 2e-3;
  std::string validate() const;
};

// Status, message and result together (Ceres Solver::Summary style).
struct RegistrationSummary {
  bool ok = false;
  std::string message;

  // Result: x_man = T_man_dev * x_dev. Filled whenever the fit ran, also when a quality gate
  // (TRE, residual) failed, so the instructor can see the numbers; use it only when ok.
  Eigen::Isometry3d T_man_dev = Eigen::Isometry3d::Identity();
  double fre_m = 0;  // RMS of |T_man_dev p_dev_i - p_man_i|
  double fle_m = 0;  // FLE used for the prediction (given or estimated)
  bool fle_estimated = false;
  double tre_m = 0;                 // Fitzpatrick's predicted RMS TRE at the target
  std::vector<double> residuals_m;  // per divot
  int worst_point = -1;

  // Geometry diagnostics of the known divot configuration (mannequin frame).
  int num_points = 0;
  double line_rms_m = 0;   // RMS distance from the best-fit line
  double plane_rms_m = 0;  // RMS distance from the best-fit plane

  std::string report() const;
};

// Fitzpatrick, West & Maurer (1998): predicted RMS target registration error at target_man for
// the fiducial configuration fiducials_man with isotropic FLE (RMS 3-D length):
//   TRE^2 = FLE^2 / N * (1 + 1/3 sum_k d_k^2 / f_k^2),
// d_k: distance of the target from principal axis k of the fiducials, f_k: RMS distance of the
// fiducials from that axis. Returns +inf for collinear configurations (some f_k = 0).
double predicted_tre(const std::vector<Eigen::Vector3d>& fiducials_man,
                     const Eigen::Vector3d& target_man, double fle_m);

// Umeyama/Horn least-squares rigid fit (no scale) of p_dev onto p_man (paired by index), with
// FRE, predicted TRE at target_man and the gates of RegistrationOptions. Never aborts on user
// input: size mismatch, NaN, too few or degenerate divots return ok = false with a message.
RegistrationSummary register_divots(const std::vector<Eigen::Vector3d>& p_dev,
                                    const std::vector<Eigen::Vector3d>& p_man,
                                    const Eigen::Vector3d& target_man,
                                    const RegistrationOptions& options = {});

}  // namespace dentar::calibration
