#include "dentar/ar/camera_model.h"

namespace dentar::ar {

Eigen::Vector2d CameraModel::distort(const Eigen::Vector2d& xn) const {
  const auto& d = k_.dist;
  const double x = xn.x(), y = xn.y();
  const double r2 = x * x + y * y;
  const double radial = 1 + r2 * (d[0] + r2 * (d[1] + r2 * d[4]));
  return {x * radial + 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x),
          y * radial + d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y};
}

Eigen::Vector2d CameraModel::undistort(const Eigen::Vector2d& xd, int iterations) const {
  Eigen::Vector2d x = xd;
  for (int i = 0; i < iterations; ++i) x -= distort(x) - xd;
  return x;
}

std::optional<Eigen::Vector2d> CameraModel::project(const Eigen::Vector3d& p) const {
  if (!p.allFinite() || p.z() <= 1e-3) return std::nullopt;
  const Eigen::Vector2d xd = distort({p.x() / p.z(), p.y() / p.z()});
  return Eigen::Vector2d(k_.fx * xd.x() + k_.cx, k_.fy * xd.y() + k_.cy);
}

}  // namespace dentar::ar
