// Tooth placement: the nominal T_man_tooth from the station file refined by touching known
// landmarks on the tooth model (cusp tips, cervical points; given in the tooth frame) with the
// calibrated stylus. The touched points reach the mannequin frame through the registered
// station: p_man = T_man_dev * T_dev_sty * p_tip_sty. Paired-point registration (Umeyama, via
// register_divots) gives T_man_tooth with FRE and Fitzpatrick's TRE at the crown centre.
// Units: metres and radians in code; the report prints mm and degrees.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "dentar/calibration/registration.h"

namespace dentar::calibration {

struct LandmarkOptions {
  int min_points = 4;            // fewer landmarks are refused
  double max_tre_m = 0.5e-3;     // gate on the predicted TRE at the target
  double max_residual_m = 1.5e-3;  // a landmark further off was touched wrongly
  // Gate on how far the refined placement moved from the nominal one (a larger move means the
  // wrong tooth was touched, or the model is not where the station file says: check, re-touch).
  double max_shift_m = 3e-3;
  double max_rotation_rad = 0.1745;  // 10 degrees
  double fle_m = 0;  // <= 0: estimated from the FRE
  // Where the TRE is predicted, tooth frame (default: 4 mm above the cervical centre, the
  // crown where drilling happens).
  Eigen::Vector3d target_tooth = Eigen::Vector3d(0, 0, 4e-3);
  std::string validate() const;
};

struct LandmarkSummary {
  bool ok = false;
  std::string message;
  Eigen::Isometry3d T_man_tooth = Eigen::Isometry3d::Identity();  // refined (when the fit ran)
  RegistrationSummary fit;  // FRE, TRE, residuals (p_dev = landmarks in tooth frame)
  double shift_m = 0;       // |refined - nominal| at the target point
  double rotation_rad = 0;  // angle of nominal^-1 * refined
  std::string report() const;
};

// landmarks_tooth[i] is touched at touched_man[i]. Never aborts on user input.
LandmarkSummary refine_tooth_placement(const std::vector<Eigen::Vector3d>& landmarks_tooth,
                                       const std::vector<Eigen::Vector3d>& touched_man,
                                       const Eigen::Isometry3d& T_man_tooth_nominal,
                                       const LandmarkOptions& options = {});

}  // namespace dentar::calibration
