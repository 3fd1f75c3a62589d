#include "dentar/calibration/station.h"

#include <cmath>
#include <sstream>

namespace dentar::calibration {

std::string CameraIntrinsics::validate() const {
  std::ostringstream os;
  if (width <= 0 || height <= 0 || width > 16384 || height > 16384)
    os << "camera image size " << width << "x" << height << " px is outside 1..16384";
  else if (!(std::isfinite(fx) && std::isfinite(fy) && fx > 0 && fy > 0 && fx <= 1e6 && fy <= 1e6))
    os << "camera fx, fy = " << fx << ", " << fy << " px must be in (0, 1e6]";
  else if (!(std::isfinite(cx) && std::isfinite(cy) && cx >= 0 && cy >= 0 && cx <= width &&
             cy <= height))
    os << "camera principal point (" << cx << ", " << cy << ") px lies outside the image";
  else
    for (std::size_t i = 0; i < dist.size(); ++i)
      if (!std::isfinite(dist[i])) {
        os << "camera distortion coefficient " << i << " is not finite";
        break;
      }
  return os.str();
}

std::string check_rigid(const Eigen::Isometry3d& T, const std::string& name) {
  if (!T.matrix().allFinite()) return name + " has non-finite entries";
  const Eigen::Matrix3d R = T.linear();
  const double ortho = (R.transpose() * R - Eigen::Matrix3d::Identity()).norm();
  if (ortho > 1e-6 || std::abs(R.determinant() - 1.0) > 1e-6) {
    std::ostringstream os;
    os << name << " rotation is not orthonormal with det +1 (|R^T R - I| = " << ortho
       << ", det = " << R.determinant() << ")";
    return os.str();
  }
  if (T.translation().norm() > 10.0)
    return name + " translation is over 10 m: transforms are in metres";
  return {};
}

std::string StationCalibration::validate() const {
  if (std::string e = camera.validate(); !e.empty()) return e;
  for (const auto& [T, name] : {std::pair{&T_man_tooth, "T_man_tooth"}, {&T_man_dev, "T_man_dev"},
                                {&T_sty_tip, "T_sty_tip"}, {&T_mtag_mir, "T_mtag_mir"}})
    if (std::string e = check_rigid(*T, name); !e.empty()) return e;
  if (!std::isfinite(mirror_radius_m) || mirror_radius_m <= 0.002 || mirror_radius_m > 0.03) {
    std::ostringstream os;
    os << "mirror_radius_m = " << mirror_radius_m << " must be in (0.002, 0.03] m";
    return os.str();
  }
  return {};
}

}  // namespace dentar::calibration
