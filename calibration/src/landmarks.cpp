#include "dentar/calibration/landmarks.h"

#include <cmath>
#include <iomanip>
#include <sstream>

namespace dentar::calibration {

std::string LandmarkOptions::validate() const {
  std::ostringstream os;
  if (min_points < 3) os << "min_points = " << min_points << " must be >= 3";
  else if (!(max_tre_m > 0)) os << "max_tre_m must be > 0";
  else if (!(max_residual_m > 0)) os << "max_residual_m must be > 0";
  else if (!(max_shift_m > 0)) os << "max_shift_m must be > 0";
  else if (!(max_rotation_rad > 0)) os << "max_rotation_rad must be > 0";
  else if (!target_tooth.allFinite()) os << "target_tooth must be finite";
  return os.str();
}

std::string LandmarkSummary::report() const {
  std::ostringstream os;
  os << std::fixed << std::setprecision(2);
  os << "tooth placement " << (ok ? "ok" : "FAILED") << ": " << message;
  if (!fit.residuals_m.empty())
    os << "\n  " << fit.num_points << " landmarks, FRE " << fit.fre_m * 1e3 << " mm, predicted TRE "
       << fit.tre_m * 1e3 << " mm; moved " << shift_m * 1e3 << " mm and "
       << rotation_rad * 180 / M_PI << " deg from the nominal placement";
  return os.str();
}

LandmarkSummary refine_tooth_placement(const std::vector<Eigen::Vector3d>& landmarks_tooth,
                                       const std::vector<Eigen::Vector3d>& touched_man,
                                       const Eigen::Isometry3d& T_man_tooth_nominal,
                                       const LandmarkOptions& o) {
  LandmarkSummary s;
  if (std::string e = o.validate(); !e.empty()) {
    s.message = "LandmarkOptions: " + e;
    return s;
  }
  if (static_cast<int>(landmarks_tooth.size()) < o.min_points) {
    s.message = "only " + std::to_string(landmarks_tooth.size()) + " landmarks defined (need " +
                std::to_string(o.min_points) + "); add tooth_landmarks_mm to the station file";
    return s;
  }
  RegistrationOptions ro;
  ro.min_points = o.min_points;
  ro.max_tre_m = o.max_tre_m;
  ro.max_residual_m = o.max_residual_m;
  ro.fle_m = o.fle_m;
  ro.min_thickness_m = 0.5e-3;  // a tooth is small: landmarks span millimetres, not centimetres
  const Eigen::Vector3d target_man = T_man_tooth_nominal * o.target_tooth;
  // register_divots fits T_a_b with p_a = T_a_b p_b: here b = tooth, a = man.
  s.fit = register_divots(landmarks_tooth, touched_man, target_man, ro);
  s.T_man_tooth = s.fit.T_man_dev;
  if (s.fit.residuals_m.empty()) {
    s.message = s.fit.message;
    return s;
  }
  s.shift_m = (s.T_man_tooth * o.target_tooth - target_man).norm();
  s.rotation_rad =
      Eigen::AngleAxisd((T_man_tooth_nominal.linear().transpose() * s.T_man_tooth.linear()).eval())
          .angle();
  if (!s.fit.ok) {
    s.message = s.fit.message;
    return s;
  }
  std::ostringstream os;
  os << std::fixed << std::setprecision(2);
  if (s.shift_m > o.max_shift_m || s.rotation_rad > o.max_rotation_rad) {
    os << "the tooth moved " << s.shift_m * 1e3 << " mm / " << s.rotation_rad * 180 / M_PI
       << " deg from its nominal placement (limits " << o.max_shift_m * 1e3 << " mm / "
       << o.max_rotation_rad * 180 / M_PI
       << " deg): check that the right tooth is mounted and the landmarks were touched in the "
          "listed order, then repeat";
    s.message = os.str();
    return s;
  }
  os << "TRE " << s.fit.tre_m * 1e3 << " mm at the crown";
  s.message = os.str();
  s.ok = true;
  return s;
}

}  // namespace dentar::calibration
