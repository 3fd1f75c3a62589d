#include "dentar/ar/pose_uncertainty.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace dentar::ar {

Eigen::Matrix3d point_covariance(const PoseCovariance& cov, const Eigen::Isometry3d& T_cam_body,
                                 const Eigen::Vector3d& p_body) {
  const Eigen::Vector3d q = T_cam_body.linear() * p_body;  // R p
  Eigen::Matrix<double, 3, 6> A;
  A.leftCols<3>() << 0, q.z(), -q.y(), -q.z(), 0, q.x(), q.y(), -q.x(), 0;  // -[q]x
  A.rightCols<3>() = Eigen::Matrix3d::Identity();
  return A * cov * A.transpose();
}

double point_sigma_m(const PoseCovariance& cov, const Eigen::Isometry3d& T_cam_body,
                     const Eigen::Vector3d& p_body) {
  const double v = point_covariance(cov, T_cam_body, p_body).trace();
  return std::isfinite(v) && v >= 0 ? std::sqrt(v) : std::numeric_limits<double>::infinity();
}

PoseCovariance floored_covariance(const BundlePose& p, double floor_px) {
  return p.covariance_per_px2 * std::max(p.noise_px2, floor_px * floor_px);
}

double pooled_noise_px2(const BundlePose& body, const BundlePose* other, bool comparable_only) {
  if (other == nullptr || !other->ok() || other->noise_dof <= 0 || body.noise_dof <= 0)
    return body.noise_px2;
  const double db = body.noise_dof;
  if (!comparable_only) {
    const double dother = other->noise_dof;
    return (body.noise_px2 * db + other->noise_px2 * dother) / (db + dother);
  }
  double max_angle = 0;
  for (const auto& t : body.tag_residuals) max_angle = std::max(max_angle, t.view_angle_rad);
  double sum = body.noise_px2 * db, dof = db;
  for (const auto& t : other->tag_residuals)
    if (t.view_angle_rad <= max_angle + 1e-9 && t.dof > 0) {
      sum += t.sum_px2;
      dof += t.dof;
    }
  return sum / dof;
}

PoseCovariance covariance_with_noise(const BundlePose& body, double noise_px2, double floor_px) {
  return body.covariance_per_px2 * std::max(noise_px2, floor_px * floor_px);
}

}  // namespace dentar::ar
