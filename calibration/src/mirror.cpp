#include "dentar/calibration/mirror.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace dentar::calibration {

std::string MirrorOptions::validate() const {
  std::ostringstream os;
  if (min_rim_points < 3) os << "min_rim_points = " << min_rim_points << " must be >= 3";
  else if (!(min_rim_coverage_rad >= 0)) os << "min_rim_coverage_rad must be >= 0";
  else if (!(max_plane_rms_m > 0 && max_circle_rms_m > 0)) os << "residual limits must be > 0";
  else if (!(min_radius_m > 0 && max_radius_m > min_radius_m)) os << "radius range is empty";
  else if (!(max_centre_error_m > 0)) os << "max_centre_error_m must be > 0";
  return os.str();
}

std::string MirrorSummary::report() const {
  std::ostringstream os;
  os << std::fixed << std::setprecision(2);
  os << "mirror " << (ok ? "ok" : "FAILED") << ": " << message;
  if (radius_m > 0)
    os << "\n  radius " << radius_m * 1e3 << " mm, plane RMS " << plane_rms_m * 1e3
       << " mm, circle RMS " << circle_rms_m * 1e3 << " mm, centre touch off by "
       << centre_error_m * 1e3 << " mm, rim coverage " << rim_coverage_rad * 180 / M_PI
       << " deg; " << shift_from_nominal_m * 1e3 << " mm / " << tilt_from_nominal_rad * 180 / M_PI
       << " deg from the nominal";
  return os.str();
}

MirrorSummary calibrate_mirror(const std::vector<Eigen::Vector3d>& rim,
                               const Eigen::Vector3d& centre_touch,
                               const Eigen::Isometry3d& T_nom, const MirrorOptions& o) {
  MirrorSummary s;
  std::ostringstream os;
  os << std::fixed << std::setprecision(2);
  if (std::string e = o.validate(); !e.empty()) {
    s.message = "MirrorOptions: " + e;
    return s;
  }
  if (static_cast<int>(rim.size()) < o.min_rim_points) {
    os << "only " << rim.size() << " rim points (need " << o.min_rim_points
       << "): touch more points spread around the mirror's rim";
    s.message = os.str();
    return s;
  }
  for (const auto& p : rim)
    if (!p.allFinite()) {
      s.message = "a rim point is not finite (was the mirror tag tracked?)";
      return s;
    }
  if (!centre_touch.allFinite()) {
    s.message = "the centre point is not finite (was the mirror tag tracked?)";
    return s;
  }
  // Plane through all points (rim + centre): the smallest principal axis.
  std::vector<Eigen::Vector3d> all = rim;
  all.push_back(centre_touch);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : all) mean += p;
  mean /= all.size();
  Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
  for (const auto& p : all) C += (p - mean) * (p - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(C);
  Eigen::Vector3d n = es.eigenvectors().col(0);
  const Eigen::Vector3d z_nom = T_nom.linear().col(2);
  if (n.dot(z_nom) < 0) n = -n;
  // In-plane axes: x from the nominal x projected into the plane.
  Eigen::Vector3d x = T_nom.linear().col(0);
  x = x - x.dot(n) * n;
  if (x.norm() < 1e-6) x = es.eigenvectors().col(2);
  x.normalize();
  const Eigen::Vector3d y = n.cross(x);
  double plane2 = 0;
  for (const auto& p : all) plane2 += std::pow((p - mean).dot(n), 2);
  s.plane_rms_m = std::sqrt(plane2 / all.size());
  // Circle in the plane: Kasa algebraic fit  u^2 + v^2 + D u + E v + F = 0, then Gauss-Newton.
  std::vector<Eigen::Vector2d> uv;
  for (const auto& p : rim) uv.emplace_back((p - mean).dot(x), (p - mean).dot(y));
  Eigen::MatrixXd A(uv.size(), 3);
  Eigen::VectorXd b(uv.size());
  for (std::size_t i = 0; i < uv.size(); ++i) {
    A.row(i) << uv[i].x(), uv[i].y(), 1.0;
    b(i) = -uv[i].squaredNorm();
  }
  const Eigen::Vector3d sol = A.colPivHouseholderQr().solve(b);
  Eigen::Vector2d c(-sol(0) / 2, -sol(1) / 2);
  double r = std::sqrt(std::max(0.0, c.squaredNorm() - sol(2)));
  for (int it = 0; it < 20; ++it) {
    Eigen::MatrixXd J(uv.size(), 3);
    Eigen::VectorXd res(uv.size());
    for (std::size_t i = 0; i < uv.size(); ++i) {
      const Eigen::Vector2d d = uv[i] - c;
      const double dn = std::max(d.norm(), 1e-12);
      res(i) = dn - r;
      J.row(i) << -d.x() / dn, -d.y() / dn, -1.0;
    }
    const Eigen::Vector3d step = (J.transpose() * J).ldlt().solve(-J.transpose() * res);
    c += step.head<2>();
    r += step(2);
    if (step.norm() < 1e-12) break;
  }
  double circ2 = 0;
  std::vector<double> ang;
  for (const auto& q : uv) {
    circ2 += std::pow((q - c).norm() - r, 2);
    ang.push_back(std::atan2(q.y() - c.y(), q.x() - c.x()));
  }
  s.circle_rms_m = std::sqrt(circ2 / uv.size());
  s.radius_m = r;
  // Angular coverage: 2 pi minus the largest gap between consecutive rim angles.
  std::sort(ang.begin(), ang.end());
  double gap = 2 * M_PI - (ang.back() - ang.front());
  for (std::size_t i = 1; i < ang.size(); ++i) gap = std::max(gap, ang[i] - ang[i - 1]);
  s.rim_coverage_rad = 2 * M_PI - gap;
  const Eigen::Vector3d centre = mean + c.x() * x + c.y() * y;
  s.centre_error_m = (centre_touch - centre).norm();
  s.T_mtag_mir.linear().col(0) = x;
  s.T_mtag_mir.linear().col(1) = y;
  s.T_mtag_mir.linear().col(2) = n;
  s.T_mtag_mir.translation() = centre;
  s.shift_from_nominal_m = (centre - T_nom.translation()).norm();
  s.tilt_from_nominal_rad = std::acos(std::clamp(n.dot(z_nom), -1.0, 1.0));

  if (!s.T_mtag_mir.matrix().allFinite() || !std::isfinite(r) || !std::isfinite(s.circle_rms_m))
    os << "the fit failed (non-finite result): the touched points are degenerate; repeat";
  else if (s.rim_coverage_rad < o.min_rim_coverage_rad)
    os << "the rim points cover only " << s.rim_coverage_rad * 180 / M_PI << " deg of the rim (need "
       << o.min_rim_coverage_rad * 180 / M_PI << "): touch points all the way around";
  else if (s.plane_rms_m > o.max_plane_rms_m)
    os << "the points are " << s.plane_rms_m * 1e3 << " mm RMS off a plane (limit "
       << o.max_plane_rms_m * 1e3 << " mm): the mirror moved or a point missed the face; repeat";
  else if (s.circle_rms_m > o.max_circle_rms_m)
    os << "the rim points are " << s.circle_rms_m * 1e3 << " mm RMS off a circle (limit "
       << o.max_circle_rms_m * 1e3 << " mm): touch exactly on the rim edge; repeat";
  else if (r < o.min_radius_m || r > o.max_radius_m)
    os << "fitted radius " << r * 1e3 << " mm is outside " << o.min_radius_m * 1e3 << ".."
       << o.max_radius_m * 1e3 << " mm: were the rim points on this mirror?";
  else if (s.centre_error_m > o.max_centre_error_m)
    os << "the touched centre is " << s.centre_error_m * 1e3 << " mm from the fitted centre (limit "
       << o.max_centre_error_m * 1e3 << " mm): touch the centre again";
  else {
    os << "radius " << r * 1e3 << " mm, circle RMS " << s.circle_rms_m * 1e3 << " mm";
    s.ok = true;
  }
  s.message = os.str();
  return s;
}

}  // namespace dentar::calibration
