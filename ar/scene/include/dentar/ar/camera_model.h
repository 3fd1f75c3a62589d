// Pinhole camera with OpenCV's (k1, k2, p1, p2, k3) lens distortion, in the
// camera optical frame `cam` (x right, y down, z forward). Pixel centres at
// integer coordinates (OpenCV convention).
#pragma once

#include <Eigen/Core>
#include <optional>

#include "dentar/calibration/station.h"

namespace dentar::ar {

class CameraModel {
 public:
  explicit CameraModel(const calibration::CameraIntrinsics& k) : k_(k) {}

  // Pixel of a point in the camera frame (m); nullopt behind the camera
  // (z <= 1 mm) or non-finite.
  std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& p_cam) const;
  // Distorts a normalised image point (x/z, y/z).
  Eigen::Vector2d distort(const Eigen::Vector2d& xn) const;
  // Inverse of distort() by fixed-point iteration (as cv::undistortPoints).
  Eigen::Vector2d undistort(const Eigen::Vector2d& xd, int iterations = 20) const;
  const calibration::CameraIntrinsics& intrinsics() const { return k_; }

 private:
  calibration::CameraIntrinsics k_;
};

}  // namespace dentar::ar
