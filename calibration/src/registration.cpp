#include "dentar/calibration/registration.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "geometry_util.h"

namespace dentar::calibration {
namespace {

struct Principal {
  Eigen::Vector3d centroid;
  Eigen::Vector3d lambda;  // eigenvalues of the scatter / N, ascending, m^2
  Eigen::Matrix3d axes;    // columns: principal axes matching lambda
};

Principal principal(const std::vector<Eigen::Vector3d>& p) {
  Principal out;
  out.centroid.setZero();
  for (const auto& x : p) out.centroid += x;
  out.centroid /= static_cast<double>(p.size());
  Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
  for (const auto& x : p) S += (x - out.centroid) * (x - out.centroid).transpose();
  S /= static_cast<double>(p.size());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(S);
  out.lambda = eig.eigenvalues().cwiseMax(0.0);
  out.axes = eig.eigenvectors();
  return out;
}

std::string mm(double m) {
  std::ostringstream os;
  os.setf(std::ios::fixed);
  os.precision(3);
  os << m * 1e3 << " mm";
  return os.str();
}

}  // namespace

std::string RegistrationOptions::validate() const {
  std::ostringstream os;
  if (min_points < 3)
    os << "min_points = " << min_points << " must be >= 3";
  else if (!std::isfinite(max_tre_m) || max_tre_m <= 0)
    os << "max_tre_m = " << max_tre_m << " must be finite and > 0";
  else if (!std::isfinite(fle_m) || fle_m > 0.01)
    os << "fle_m = " << fle_m << " must be finite and <= 0.01 m (<= 0 means estimate)";
  else if (!std::isfinite(min_thickness_m) || min_thickness_m < 0)
    os << "min_thickness_m = " << min_thickness_m << " must be finite and >= 0";
  else if (!std::isfinite(thickness_fle_factor) || thickness_fle_factor < 0)
    os << "thickness_fle_factor = " << thickness_fle_factor << " must be finite and >= 0";
  else if (!(max_residual_m > 0))
    os << "max_residual_m = " << max_residual_m << " must be > 0";
  return os.str();
}

std::string RegistrationSummary::report() const {
  std::ostringstream os;
  os << "station registration " << (ok ? "ok" : "FAILED") << ": " << message;
  if (residuals_m.empty()) return os.str();
  os << "\n  " << num_points << " divots, FRE " << mm(fre_m) << ", FLE " << mm(fle_m)
     << (fle_estimated ? " (estimated from FRE)" : " (given)") << ", predicted TRE at tooth "
     << mm(tre_m) << "\n  worst divot " << worst_point << " at " << mm(residuals_m[worst_point])
     << "; divot spread off line " << mm(line_rms_m) << ", off plane " << mm(plane_rms_m);
  return os.str();
}

double predicted_tre(const std::vector<Eigen::Vector3d>& fiducials_man,
                     const Eigen::Vector3d& target_man, double fle_m) {
  const double n = static_cast<double>(fiducials_man.size());
  if (n < 3) return std::numeric_limits<double>::infinity();
  const Principal pc = principal(fiducials_man);
  const Eigen::Vector3d r = target_man - pc.centroid;
  double sum = 0;
  for (int k = 0; k < 3; ++k) {
    // Mean squared distance of the fiducials from axis k: the other two eigenvalues.
    const double f2 = pc.lambda.sum() - pc.lambda(k);
    const double along = r.dot(pc.axes.col(k));
    const double d2 = std::max(0.0, r.squaredNorm() - along * along);
    if (f2 <= 0) return std::numeric_limits<double>::infinity();
    sum += d2 / f2;
  }
  return std::sqrt(fle_m * fle_m / n * (1.0 + sum / 3.0));
}

RegistrationSummary register_divots(const std::vector<Eigen::Vector3d>& p_dev,
                                    const std::vector<Eigen::Vector3d>& p_man,
                                    const Eigen::Vector3d& target_man,
                                    const RegistrationOptions& options) {
  RegistrationSummary s;
  if (std::string e = options.validate(); !e.empty()) {
    s.message = "RegistrationOptions: " + e;
    return s;
  }
  if (p_dev.size() != p_man.size()) {
    s.message = std::to_string(p_dev.size()) + " touched divots but " +
                std::to_string(p_man.size()) +
                " known divot positions; touch each listed divot exactly once, in order";
    return s;
  }
  const int n = static_cast<int>(p_dev.size());
  s.num_points = n;
  for (int i = 0; i < n; ++i) {
    if (!p_dev[i].allFinite()) {
      s.message = "touched divot " + std::to_string(i) +
                  " is not finite (NaN/inf from the device); touch it again";
      return s;
    }
    if (!p_man[i].allFinite()) {
      s.message =
          "known position of divot " + std::to_string(i) + " is not finite; fix the scene file";
      return s;
    }
  }
  if (!target_man.allFinite()) {
    s.message = "the target (tooth) position is not finite; fix the scene file";
    return s;
  }
  if (n < options.min_points) {
    s.message = "only " + std::to_string(n) + " divots touched; touch at least " +
                std::to_string(options.min_points) + ", spread around the tooth";
    return s;
  }

  // Fit: R = argmax tr(R^T sum m_i d_i^T) over SO(3) (Umeyama 1991 without scale).
  Eigen::Vector3d c_dev = Eigen::Vector3d::Zero(), c_man = Eigen::Vector3d::Zero();
  for (int i = 0; i < n; ++i) {
    c_dev += p_dev[i];
    c_man += p_man[i];
  }
  c_dev /= n;
  c_man /= n;
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (int i = 0; i < n; ++i) H += (p_man[i] - c_man) * (p_dev[i] - c_dev).transpose();
  const Eigen::Matrix3d R = detail::nearest_rotation(H);
  s.T_man_dev = Eigen::Isometry3d::Identity();
  s.T_man_dev.linear() = R;
  s.T_man_dev.translation() = c_man - R * c_dev;

  double sum_sq = 0;
  s.residuals_m.resize(n);
  for (int i = 0; i < n; ++i) {
    s.residuals_m[i] = (s.T_man_dev * p_dev[i] - p_man[i]).norm();
    sum_sq += s.residuals_m[i] * s.residuals_m[i];
    if (s.worst_point < 0 || s.residuals_m[i] > s.residuals_m[s.worst_point]) s.worst_point = i;
  }
  s.fre_m = std::sqrt(sum_sq / n);
  s.fle_estimated = !(options.fle_m > 0);
  s.fle_m = s.fle_estimated ? s.fre_m * std::sqrt(static_cast<double>(n) / (n - 2)) : options.fle_m;

  // Geometry of the known positions: noise-free, so it says what the layout can deliver.
  const Principal pc = principal(p_man);
  s.line_rms_m = std::sqrt(pc.lambda(0) + pc.lambda(1));
  s.plane_rms_m = std::sqrt(pc.lambda(0));
  // Before the geometry gate: a wrong touch inflates the estimated FLE used there.
  if (s.residuals_m[s.worst_point] > options.max_residual_m) {
    s.message = "divot " + std::to_string(s.worst_point) + " is off by " +
                mm(s.residuals_m[s.worst_point]) + " (limit " + mm(options.max_residual_m) +
                "); it was probably touched outside its divot or out of order; touch it again";
    return s;
  }

  const double min_thick =
      std::max(options.min_thickness_m, options.thickness_fle_factor * s.fle_m);
  if (s.line_rms_m <= min_thick) {
    s.message = "the divots are (nearly) on one line (RMS distance from it " + mm(s.line_rms_m) +
                ", need > " + mm(min_thick) +
                "): the rotation about that line is undetermined; touch divots on different "
                "sides of the tooth, at different heights";
    s.residuals_m.clear();
    return s;
  }
  if (s.plane_rms_m <= min_thick) {
    s.message = "the divots are (nearly) in one plane (RMS distance from it " + mm(s.plane_rms_m) +
                ", need > " + mm(min_thick) +
                "); add divots above or below that plane (e.g. on the palate or chin)";
    s.residuals_m.clear();
    return s;
  }
  s.tre_m = predicted_tre(p_man, target_man, s.fle_m);
  if (!(s.tre_m <= options.max_tre_m)) {
    s.message = "predicted TRE at the tooth is " + mm(s.tre_m) + " (limit " +
                mm(options.max_tre_m) +
                "); touch more divots, spread wider around the tooth, and seat the tip "
                "carefully in each";
    return s;
  }
  s.ok = true;
  s.message = "ok";
  return s;
}

}  // namespace dentar::calibration
