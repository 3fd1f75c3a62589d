// Small geometry helpers shared by the calibration sources (private).
#pragma once

#include <Eigen/Dense>

namespace dentar::calibration::detail {

// The rotation closest to M in the Frobenius norm (SVD projection with det fixed to +1).
inline Eigen::Matrix3d nearest_rotation(const Eigen::Matrix3d& M) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  // Flip the weakest axis when U V^T would be a reflection (Umeyama 1991, eq. 39).
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) D(2, 2) = -1;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

}  // namespace dentar::calibration::detail
