// Mirror geometry relative to its tag: T_mtag_mir and the disc radius.
//
// Procedure (what the instructor does): hold the mirror still in a clamp where the camera sees
// both the mannequin's tags and the mirror's tag; with the calibrated stylus touch at least 5
// points spread around the rim of the reflecting face, then its centre. Each touched tip goes
// into the mirror-tag frame through the tracked and calibrated chain
//   p_mtag = T_mtag_cam * T_cam_man * T_man_dev * T_dev_sty * p_tip_sty
// (T_mtag_cam from the tracked mirror tag). The rim points and the centre give a plane (least
// squares); the rim points projected into it give a circle (algebraic fit, then Gauss-Newton on
// the geometric distance): centre, radius, normal. The normal's sign and the in-plane x axis
// are taken from the nominal T_mtag_mir (the side the reflecting face is on cannot be seen in
// touched points). Gates: enough rim points, rim angular coverage, plane and circle residuals,
// radius range, centre touch consistent with the circle.
// Units: metres and radians; report() prints mm.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace dentar::calibration {

struct MirrorOptions {
  int min_rim_points = 4;
  double min_rim_coverage_rad = 3.1416;  // rim points must span >= 180 degrees around the centre
  double max_plane_rms_m = 0.4e-3;
  double max_circle_rms_m = 0.4e-3;
  double min_radius_m = 4e-3, max_radius_m = 20e-3;
  double max_centre_error_m = 1.0e-3;  // touched centre vs fitted centre
  std::string validate() const;
};

struct MirrorSummary {
  bool ok = false;
  std::string message;
  Eigen::Isometry3d T_mtag_mir = Eigen::Isometry3d::Identity();
  double radius_m = 0;
  double plane_rms_m = 0;   // all points to the plane
  double circle_rms_m = 0;  // rim points to the circle (in-plane radial residual)
  double centre_error_m = 0;  // touched centre to the fitted centre (3-D)
  double rim_coverage_rad = 0;
  // Difference from the nominal: centre distance and normal angle.
  double shift_from_nominal_m = 0;
  double tilt_from_nominal_rad = 0;
  std::string report() const;
};

// rim_mtag: rim points, centre_mtag: the touched centre (all in the mirror-tag frame, m).
MirrorSummary calibrate_mirror(const std::vector<Eigen::Vector3d>& rim_mtag,
                               const Eigen::Vector3d& centre_mtag,
                               const Eigen::Isometry3d& T_mtag_mir_nominal,
                               const MirrorOptions& options = {});

}  // namespace dentar::calibration
