#include "dentar/calibration/pivot.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <numbers>
#include <sstream>

#include "dentar/calibration/station.h"
#include "geometry_util.h"

namespace dentar::calibration {

std::string PivotOptions::validate() const {
  std::ostringstream os;
  if (min_poses < 3)
    os << "min_poses = " << min_poses << " must be >= 3 (6 unknowns, 3 equations per pose)";
  else if (!std::isfinite(min_spread_rad) || min_spread_rad < 0 ||
           min_spread_rad > std::numbers::pi)
    os << "min_spread_rad = " << min_spread_rad << " must be in [0, pi]";
  else if (!std::isfinite(min_weakest_tilt_rad) || min_weakest_tilt_rad < 0 ||
           min_weakest_tilt_rad > std::numbers::pi)
    os << "min_weakest_tilt_rad = " << min_weakest_tilt_rad << " must be in [0, pi]";
  return os.str();
}

std::string PivotSummary::report() const {
  std::ostringstream os;
  os.setf(std::ios::fixed);
  os.precision(3);
  const double deg = 180.0 / std::numbers::pi;
  if (!ok) {
    os << "pivot calibration FAILED: " << message;
    return os.str();
  }
  const Eigen::Vector3d sd = cov_tip_sty.diagonal().cwiseMax(0).cwiseSqrt() * 1e3;
  os << "pivot calibration ok: " << num_poses << " poses, spread " << std::setprecision(1)
     << spread_rad * deg << " deg (weakest direction " << weakest_tilt_rad * deg << " deg)"
     << std::setprecision(3) << "\n  tip in stylus frame [mm]: " << p_tip_sty.x() * 1e3 << " "
     << p_tip_sty.y() * 1e3 << " " << p_tip_sty.z() * 1e3 << "  (1-sigma " << sd.x() << " "
     << sd.y() << " " << sd.z() << ")\n  divot in device frame [mm]: " << p_divot_dev.x() * 1e3
     << " " << p_divot_dev.y() * 1e3 << " " << p_divot_dev.z() * 1e3 << "\n  RMSE " << rmse_m * 1e3
     << " mm, worst pose " << worst_pose << " at " << max_residual_m * 1e3 << " mm";
  return os.str();
}

PivotSummary calibrate_pivot(const std::vector<Eigen::Isometry3d>& T_dev_sty,
                             const PivotOptions& options) {
  PivotSummary s;
  if (std::string e = options.validate(); !e.empty()) {
    s.message = "PivotOptions: " + e;
    return s;
  }
  const int n = static_cast<int>(T_dev_sty.size());
  s.num_poses = n;
  for (int i = 0; i < n; ++i) {
    if (std::string e = check_rigid(T_dev_sty[i], "T_dev_sty[" + std::to_string(i) + "]");
        !e.empty()) {
      s.message = e + "; drop this pose (device glitch?) and record it again";
      return s;
    }
  }
  if (n < options.min_poses) {
    s.message = "only " + std::to_string(n) + " stylus poses; collect at least " +
                std::to_string(options.min_poses) +
                " with the tip resting in the divot, tilting the stylus between them";
    return s;
  }

  // Spread gate: chordal mean rotation, then the largest angle from it.
  Eigen::Matrix3d R_sum = Eigen::Matrix3d::Zero();
  for (const auto& T : T_dev_sty) R_sum += T.linear();
  const Eigen::Matrix3d R_bar = R_sum / n;  // arithmetic mean, not a rotation
  const Eigen::Matrix3d R_mean = detail::nearest_rotation(R_bar);
  for (const auto& T : T_dev_sty) {
    const double angle = Eigen::AngleAxisd(R_mean.transpose() * T.linear()).angle();
    s.spread_rad = std::max(s.spread_rad, angle);
  }
  // Observability of the tip: after eliminating the divot, the normal matrix of the tip is
  // sum (R_i - R_bar)^T (R_i - R_bar); a near-zero eigenvalue is a direction the poses do not
  // move (e.g. tilting about one axis only leaves the tip's component along it free).
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  for (const auto& T : T_dev_sty) {
    const Eigen::Matrix3d D = T.linear() - R_bar;
    M += D.transpose() * D;
  }
  M /= n;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig_M(M);
  s.weakest_tilt_rad = std::sqrt(std::max(0.0, eig_M.eigenvalues()(0)));

  const double deg = 180.0 / std::numbers::pi;
  if (s.spread_rad < options.min_spread_rad) {
    std::ostringstream os;
    os.precision(1);
    os.setf(std::ios::fixed);
    os << "orientation spread is only " << s.spread_rad * deg << " deg (need "
       << options.min_spread_rad * deg
       << " deg); keep the tip in the divot and tilt the stylus further, in several directions";
    s.message = os.str();
    return s;
  }
  if (s.weakest_tilt_rad < options.min_weakest_tilt_rad) {
    std::ostringstream os;
    os.precision(1);
    os.setf(std::ios::fixed);
    os << "the stylus was tilted mostly about one axis (RMS tilt in the weakest direction "
       << s.weakest_tilt_rad * deg << " deg, need " << options.min_weakest_tilt_rad * deg
       << " deg), so part of the tip offset is unobservable; tilt it also sideways (circle "
          "around the divot)";
    s.message = os.str();
    return s;
  }

  // Stacked system A x = b, x = [p_tip_sty; p_divot_dev], A_i = [R_i  -I], b_i = -t_i.
  Eigen::MatrixXd A(3 * n, 6);
  Eigen::VectorXd b(3 * n);
  for (int i = 0; i < n; ++i) {
    A.block<3, 3>(3 * i, 0) = T_dev_sty[i].linear();
    A.block<3, 3>(3 * i, 3) = -Eigen::Matrix3d::Identity();
    b.segment<3>(3 * i) = -T_dev_sty[i].translation();
  }
  // QR on A rather than the normal equations: same answer, better conditioning.
  const Eigen::VectorXd x = A.colPivHouseholderQr().solve(b);
  const Eigen::VectorXd r = A * x - b;
  s.p_tip_sty = x.head<3>();
  s.p_divot_dev = x.tail<3>();
  s.T_sty_tip = Eigen::Isometry3d::Identity();
  s.T_sty_tip.translation() = s.p_tip_sty;

  double sum_sq = 0;
  for (int i = 0; i < n; ++i) {
    const double e = r.segment<3>(3 * i).norm();
    sum_sq += e * e;
    if (e > s.max_residual_m) {
      s.max_residual_m = e;
      s.worst_pose = i;
    }
  }
  s.rmse_m = std::sqrt(sum_sq / n);
  // Unbiased per-coordinate noise variance (6 parameters fitted to 3N numbers).
  const double sigma2 = sum_sq / (3 * n - 6);
  const Eigen::Matrix<double, 6, 6> AtA = A.transpose() * A;
  const Eigen::Matrix<double, 6, 6> cov = sigma2 * AtA.inverse();
  s.cov_tip_sty = cov.topLeftCorner<3, 3>();
  s.cov_divot_dev = cov.bottomRightCorner<3, 3>();
  if (!x.allFinite() || !cov.allFinite()) {
    s.message = "pivot least squares did not give a finite solution; record the poses again";
    return s;
  }
  s.ok = true;
  s.message = "ok";
  return s;
}

}  // namespace dentar::calibration
