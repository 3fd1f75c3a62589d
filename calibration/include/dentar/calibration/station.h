// Station calibration values shared by tracking, haptics and rendering.
// Frames and names follow docs/conventions.md: T_a_b maps frame b into a.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <string>

namespace dentar::calibration {

// OpenCV pinhole model with (k1, k2, p1, p2, k3) distortion, pixels.
struct CameraIntrinsics {
  int width = 0, height = 0;  // image size the calibration belongs to, px
  double fx = 0, fy = 0, cx = 0, cy = 0;  // px
  std::array<double, 5> dist{};           // k1, k2, p1, p2, k3
  std::string validate() const;
};

struct StationCalibration {
  CameraIntrinsics camera;
  Eigen::Isometry3d T_man_tooth = Eigen::Isometry3d::Identity();  // tooth volume in mannequin
  Eigen::Isometry3d T_man_dev = Eigen::Isometry3d::Identity();    // haptic base in mannequin
  Eigen::Isometry3d T_sty_tip = Eigen::Isometry3d::Identity();    // bur tip on the stylus
  Eigen::Isometry3d T_mtag_mir = Eigen::Isometry3d::Identity();   // mirror plane on its tag
  double mirror_radius_m = 0.011;                                  // mirror disc radius

  // Empty when valid; else names the field (non-rigid rotation, NaN, ...).
  std::string validate() const;
  // Static transform the haptic loop works with: T_tooth_dev = T_man_tooth^-1 * T_man_dev.
  Eigen::Isometry3d T_tooth_dev() const { return T_man_tooth.inverse() * T_man_dev; }
};

// Empty when T is a finite rigid transform (orthonormal, det +1 within tol).
std::string check_rigid(const Eigen::Isometry3d& T, const std::string& name);

}  // namespace dentar::calibration
