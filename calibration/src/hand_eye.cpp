#include "dentar/calibration/hand_eye.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <sstream>

namespace dentar::calibration {
namespace {

constexpr double kDeg = 180.0 / M_PI;

Eigen::Matrix3d project_to_so3(const Eigen::Matrix3d& M) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d R = svd.matrixU() * svd.matrixV().transpose();
  if (R.determinant() < 0) {
    Eigen::Matrix3d U = svd.matrixU();
    U.col(2) *= -1;
    R = U * svd.matrixV().transpose();
  }
  return R;
}

Eigen::Vector3d log_so3(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

Eigen::Matrix3d exp_so3(const Eigen::Vector3d& w) {
  const double a = w.norm();
  if (a < 1e-300) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(a, w / a).toRotationMatrix();
}

// 6-vector residual of observation o for X, Z (whitened).
Eigen::Matrix<double, 6, 1> residual(const HandEyeObservation& o, const Eigen::Isometry3d& X,
                                     const Eigen::Isometry3d& Z, double sr, double st) {
  const Eigen::Isometry3d T = o.T_base_hand * X * o.T_cam_target;
  Eigen::Matrix<double, 6, 1> e;
  e.head<3>() = log_so3(Z.linear().transpose() * T.linear()) / sr;
  e.tail<3>() = (T.translation() - Z.translation()) / st;
  return e;
}

// X, Z perturbed by the 12-vector d (rotation on the left, translation added).
void apply(const Eigen::Matrix<double, 12, 1>& d, Eigen::Isometry3d& X, Eigen::Isometry3d& Z) {
  X.linear() = exp_so3(d.segment<3>(0)) * X.linear();
  X.translation() += d.segment<3>(3);
  Z.linear() = exp_so3(d.segment<3>(6)) * Z.linear();
  Z.translation() += d.segment<3>(9);
}

double rms_rot(const std::vector<HandEyeObservation>& obs, const Eigen::Isometry3d& X,
               const Eigen::Isometry3d& Z, double& rms_t) {
  double sr = 0, st = 0;
  for (const auto& o : obs) {
    const auto e = residual(o, X, Z, 1, 1);
    sr += e.head<3>().squaredNorm();
    st += e.tail<3>().squaredNorm();
  }
  rms_t = std::sqrt(st / std::max<std::size_t>(1, obs.size()));
  return std::sqrt(sr / std::max<std::size_t>(1, obs.size()));
}

double spread_of(const std::vector<HandEyeObservation>& obs) {
  double m = 0;
  for (std::size_t i = 0; i < obs.size(); ++i)
    for (std::size_t j = i + 1; j < obs.size(); ++j)
      m = std::max(m, rotation_error_rad(obs[i].T_base_hand, obs[j].T_base_hand));
  return m;
}

// Z from X: chordal mean of the rotations, mean of the translations.
Eigen::Isometry3d mean_target(const std::vector<HandEyeObservation>& obs, const Eigen::Isometry3d& X) {
  Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  for (const auto& o : obs) {
    const Eigen::Isometry3d T = o.T_base_hand * X * o.T_cam_target;
    S += T.linear();
    t += T.translation();
  }
  Eigen::Isometry3d Z = Eigen::Isometry3d::Identity();
  Z.linear() = project_to_so3(S);
  Z.translation() = t / static_cast<double>(obs.size());
  return Z;
}

std::string check_inputs(const std::vector<HandEyeObservation>& obs, const HandEyeOptions& o) {
  if (static_cast<int>(obs.size()) < o.min_observations)
    return "too few pose pairs: " + std::to_string(obs.size()) + " (need " +
           std::to_string(o.min_observations) + "); take more, turning the head about different axes";
  for (std::size_t i = 0; i < obs.size(); ++i) {
    for (const auto* T : {&obs[i].T_base_hand, &obs[i].T_cam_target}) {
      const Eigen::Matrix3d R = T->linear();
      if (!T->matrix().allFinite() ||
          (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-6 || R.determinant() < 0)
        return "pose pair " + std::to_string(i) + " is not a finite rigid transform";
    }
  }
  // Turning about two different axes: spread of the relative rotation vectors.
  Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
  int n = 0;
  for (std::size_t i = 0; i < obs.size(); ++i)
    for (std::size_t j = i + 1; j < obs.size(); ++j) {
      const Eigen::Vector3d w =
          log_so3(obs[i].T_base_hand.linear().transpose() * obs[j].T_base_hand.linear());
      S += w * w.transpose();
      ++n;
    }
  const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(S / std::max(1, n)).eigenvalues();
  const double second = std::sqrt(std::max(0.0, ev[1]));
  if (second < o.min_axis_spread_rad) {
    std::ostringstream os;
    os << std::fixed << std::setprecision(1) << "degenerate motion: the body turned about one axis "
       << "only (the second axis carries " << second * kDeg << " deg RMS, need "
       << o.min_axis_spread_rad * kDeg << "); the camera's offset along that axis cannot be "
       << "observed. Turn the head both left-right and up-down (or tilt it) between poses";
    return os.str();
  }
  return {};
}

}  // namespace

const char* hand_eye_method_name(HandEyeMethod m) {
  switch (m) {
    case HandEyeMethod::kOurs: return "ours";
    case HandEyeMethod::kTsai: return "TSAI";
    case HandEyeMethod::kPark: return "PARK";
    case HandEyeMethod::kHoraud: return "HORAUD";
    case HandEyeMethod::kAndreff: return "ANDREFF";
    case HandEyeMethod::kDaniilidis: return "DANIILIDIS";
  }
  return "?";
}

double rotation_error_rad(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle();
}
double translation_error_m(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm();
}

std::string HandEyeOptions::validate() const {
  if (min_observations < 3) return "min_observations must be >= 3";
  if (!(sigma_rot_rad > 0 && sigma_m > 0)) return "sigma_rot_rad and sigma_m must be > 0";
  if (max_iterations < 1) return "max_iterations must be >= 1";
  if (!(min_axis_spread_rad >= 0)) return "min_axis_spread_rad must be >= 0";
  return {};
}

std::string HandEyeResult::report() const {
  std::ostringstream os;
  os << std::fixed << std::setprecision(3);
  os << "hand-eye (" << hand_eye_method_name(method) << ") " << (ok ? "OK: " : "FAILED: ")
     << message << "\n";
  if (ok) {
    const Eigen::Vector3d t = T_hand_cam.translation() * 1e3;
    const Eigen::AngleAxisd aa(T_hand_cam.linear());
    os << "  T_hand_cam: t = (" << t.x() << ", " << t.y() << ", " << t.z() << ") mm, rotation "
       << aa.angle() * kDeg << " deg\n";
    os << "  residual RMS " << rms_rot_rad * kDeg << " deg, " << rms_m * 1e3 << " mm; body "
       << "rotation spread " << std::setprecision(1) << rotation_spread_rad * kDeg << " deg\n";
    if (rot_sd_rad >= 0)
      os << std::setprecision(3) << "  1-sigma of T_hand_cam: " << rot_sd_rad * kDeg << " deg, "
         << trans_sd_m * 1e3 << " mm\n";
  }
  for (const auto& w : warnings) os << "  WARNING: " << w << "\n";
  return os.str();
}

HandEyeResult calibrate_hand_eye(const std::vector<HandEyeObservation>& obs,
                                 const HandEyeOptions& o) {
  HandEyeResult r;
  if (std::string e = o.validate(); !e.empty()) {
    r.message = "invalid options: " + e;
    return r;
  }
  if (std::string e = check_inputs(obs, o); !e.empty()) {
    r.message = e;
    return r;
  }
  r.rotation_spread_rad = spread_of(obs);
  const int n = static_cast<int>(obs.size());
  // Linear rotations: (R_C^T kron R_H) vec(R_X) - vec(R_Z) = 0 (column-major vec).
  Eigen::MatrixXd M(9 * n, 18);
  for (int i = 0; i < n; ++i) {
    const Eigen::Matrix3d RH = obs[i].T_base_hand.linear(), RC = obs[i].T_cam_target.linear();
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) M.block<3, 3>(9 * i + 3 * b, 3 * a) = RC(a, b) * RH;
    M.block<9, 9>(9 * i, 9) = -Eigen::Matrix<double, 9, 9>::Identity();
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(M, Eigen::ComputeThinV);
  Eigen::VectorXd v = svd.matrixV().col(17);
  Eigen::Matrix3d RX = Eigen::Map<const Eigen::Matrix3d>(v.data());
  if (RX.determinant() < 0) v = -v;
  RX = Eigen::Map<const Eigen::Matrix3d>(v.data());
  const Eigen::Matrix3d RZ = Eigen::Map<const Eigen::Matrix3d>(v.data() + 9);
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity(), Z = Eigen::Isometry3d::Identity();
  X.linear() = project_to_so3(RX);
  Z.linear() = project_to_so3(RZ);
  // Linear translations: R_H t_X - t_Z = -(R_H R_X t_C + t_H).
  Eigen::MatrixXd A(3 * n, 6);
  Eigen::VectorXd b(3 * n);
  for (int i = 0; i < n; ++i) {
    const auto& H = obs[i].T_base_hand;
    A.block<3, 3>(3 * i, 0) = H.linear();
    A.block<3, 3>(3 * i, 3) = -Eigen::Matrix3d::Identity();
    b.segment<3>(3 * i) = -(H.linear() * X.linear() * obs[i].T_cam_target.translation() + H.translation());
  }
  const Eigen::VectorXd tz = A.colPivHouseholderQr().solve(b);
  X.translation() = tz.head<3>();
  Z.translation() = tz.tail<3>();

  // Levenberg-Marquardt on the whitened pose residuals.
  auto cost = [&](const Eigen::Isometry3d& x, const Eigen::Isometry3d& z) {
    double c = 0;
    for (const auto& ob : obs) c += residual(ob, x, z, o.sigma_rot_rad, o.sigma_m).squaredNorm();
    return c;
  };
  double lambda = 1e-3, c0 = cost(X, Z);
  Eigen::Matrix<double, 12, 12> JtJ;
  for (int it = 0; it < o.max_iterations; ++it) {
    JtJ.setZero();
    Eigen::Matrix<double, 12, 1> g = Eigen::Matrix<double, 12, 1>::Zero();
    for (const auto& ob : obs) {
      const auto e0 = residual(ob, X, Z, o.sigma_rot_rad, o.sigma_m);
      Eigen::Matrix<double, 6, 12> J;
      for (int k = 0; k < 12; ++k) {
        const double h = 1e-7;
        Eigen::Matrix<double, 12, 1> d = Eigen::Matrix<double, 12, 1>::Zero();
        d[k] = h;
        Eigen::Isometry3d xa = X, za = Z, xb = X, zb = Z;
        apply(d, xa, za);
        apply(-d, xb, zb);
        J.col(k) = (residual(ob, xa, za, o.sigma_rot_rad, o.sigma_m) -
                    residual(ob, xb, zb, o.sigma_rot_rad, o.sigma_m)) / (2 * h);
      }
      JtJ += J.transpose() * J;
      g += J.transpose() * e0;
    }
    r.iterations = it + 1;
    bool improved = false;
    for (int tries = 0; tries < 10 && !improved; ++tries) {
      Eigen::Matrix<double, 12, 12> Hm = JtJ;
      Hm.diagonal() *= 1 + lambda;
      const Eigen::Matrix<double, 12, 1> d = -Hm.ldlt().solve(g);
      if (!d.allFinite()) break;
      Eigen::Isometry3d x2 = X, z2 = Z;
      apply(d, x2, z2);
      const double c2 = cost(x2, z2);
      if (c2 < c0) {
        const bool small = c0 - c2 < 1e-12 * c0 || d.norm() < 1e-12;
        X = x2;
        Z = z2;
        c0 = c2;
        lambda = std::max(1e-9, lambda / 10);
        improved = true;
        if (small) it = o.max_iterations;  // converged
      } else {
        lambda *= 10;
      }
    }
    if (!improved) break;  // no step lowers the cost: at the minimum
  }
  X.linear() = project_to_so3(X.linear());
  Z.linear() = project_to_so3(Z.linear());
  r.T_hand_cam = X;
  r.T_base_target = Z;
  r.rms_rot_rad = rms_rot(obs, X, Z, r.rms_m);
  // Covariance of X: (J^T J)^-1 scaled by the reduced chi-square.
  const double dof = std::max(1, 6 * n - 12);
  const Eigen::Matrix<double, 12, 12> cov = JtJ.ldlt().solve(Eigen::Matrix<double, 12, 12>::Identity()) * (c0 / dof);
  r.rot_sd_rad = std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov.block<3, 3>(0, 0)).eigenvalues()[2]));
  r.trans_sd_m = std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov.block<3, 3>(3, 3)).eigenvalues()[2]));
  int outliers = 0;
  for (const auto& ob : obs)
    outliers += residual(ob, X, Z, o.sigma_rot_rad, o.sigma_m).cwiseAbs().maxCoeff() > o.outlier_sigmas;
  if (outliers > 0)
    r.warnings.push_back(std::to_string(outliers) + " pose pair(s) disagree by more than " +
                         std::to_string(static_cast<int>(o.outlier_sigmas)) + " sigma: check that "
                         "both poses were taken at the same moment and the target did not move");
  std::ostringstream os;
  os << std::fixed << std::setprecision(3) << n << " pose pairs, residual RMS "
     << r.rms_rot_rad * kDeg << " deg / " << r.rms_m * 1e3 << " mm, T_hand_cam known to "
     << r.rot_sd_rad * kDeg << " deg / " << r.trans_sd_m * 1e3 << " mm (1 sigma)";
  r.message = os.str();
  r.ok = X.matrix().allFinite() && Z.matrix().allFinite();
  if (!r.ok) r.message = "the solution is not finite; check the poses";
  return r;
}

HandEyeResult calibrate_hand_eye_opencv(const std::vector<HandEyeObservation>& obs,
                                        HandEyeMethod method) {
  HandEyeResult r;
  r.method = method;
  HandEyeOptions o;
  o.min_axis_spread_rad = 0;
  if (std::string e = check_inputs(obs, o); !e.empty()) {
    r.message = e;
    return r;
  }
  r.rotation_spread_rad = spread_of(obs);
  cv::HandEyeCalibrationMethod m = cv::CALIB_HAND_EYE_TSAI;
  switch (method) {
    case HandEyeMethod::kTsai: m = cv::CALIB_HAND_EYE_TSAI; break;
    case HandEyeMethod::kPark: m = cv::CALIB_HAND_EYE_PARK; break;
    case HandEyeMethod::kHoraud: m = cv::CALIB_HAND_EYE_HORAUD; break;
    case HandEyeMethod::kAndreff: m = cv::CALIB_HAND_EYE_ANDREFF; break;
    case HandEyeMethod::kDaniilidis: m = cv::CALIB_HAND_EYE_DANIILIDIS; break;
    case HandEyeMethod::kOurs: r.message = "use calibrate_hand_eye for our method"; return r;
  }
  std::vector<cv::Mat> Rg, tg, Rc, tc;
  auto to_cv = [](const Eigen::Isometry3d& T, std::vector<cv::Mat>& R, std::vector<cv::Mat>& t) {
    cv::Mat r3(3, 3, CV_64F), t3(3, 1, CV_64F);
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) r3.at<double>(a, b) = T.linear()(a, b);
      t3.at<double>(a) = T.translation()(a);
    }
    R.push_back(r3);
    t.push_back(t3);
  };
  for (const auto& ob : obs) {
    to_cv(ob.T_base_hand, Rg, tg);
    to_cv(ob.T_cam_target, Rc, tc);
  }
  cv::Mat R, t;
  try {
    cv::calibrateHandEye(Rg, tg, Rc, tc, R, t, m);
  } catch (const cv::Exception& e) {
    r.message = std::string("OpenCV calibrateHandEye failed: ") + e.err;
    return r;
  }
  if (R.empty() || t.empty() || !cv::checkRange(R) || !cv::checkRange(t)) {
    r.message = "OpenCV calibrateHandEye returned a non-finite result";
    return r;
  }
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) X.linear()(a, b) = R.at<double>(a, b);
    X.translation()(a) = t.at<double>(a);
  }
  X.linear() = project_to_so3(X.linear());
  r.T_hand_cam = X;
  r.T_base_target = mean_target(obs, X);
  r.rms_rot_rad = rms_rot(obs, X, r.T_base_target, r.rms_m);
  r.ok = true;
  std::ostringstream os;
  os << std::fixed << std::setprecision(3) << obs.size() << " pose pairs, residual RMS "
     << r.rms_rot_rad * kDeg << " deg / " << r.rms_m * 1e3 << " mm (no uncertainty from OpenCV)";
  r.message = os.str();
  if ((method == HandEyeMethod::kTsai || method == HandEyeMethod::kDaniilidis) &&
      r.rotation_spread_rad > kOpenCvHandEyeSafeRotationRad) {
    std::ostringstream w;
    w << std::fixed << std::setprecision(0) << "OpenCV's " << hand_eye_method_name(method)
      << " is unreliable when the body turns by more than " << kOpenCvHandEyeSafeRotationRad * kDeg
      << " deg between poses (these turn by up to " << r.rotation_spread_rad * kDeg
      << " deg); measured on such motions it is wrong by 1-4 degrees (DANIILIDIS also by up to "
         "3 cm). Use PARK or ANDREFF, or DentAR's own method (calibrate_hand_eye: linear start + least-squares refinement)";
    r.warnings.push_back(w.str());
  }
  return r;
}

std::vector<HandEyeObservation> simulate_hand_eye(const Eigen::Isometry3d& X,
                                                  const Eigen::Isometry3d& Z, int n,
                                                  double spread, double sr, double st,
                                                  std::mt19937_64& rng) {
  std::normal_distribution<double> g(0, 1);
  std::uniform_real_distribution<double> u(0, 1);
  auto noise = [&](double s_rot, double s_t) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = exp_so3(Eigen::Vector3d(g(rng), g(rng), g(rng)) * s_rot);
    T.translation() = Eigen::Vector3d(g(rng), g(rng), g(rng)) * s_t;
    return T;
  };
  const Eigen::Matrix3d R0 = exp_so3(Eigen::Vector3d(0.3, -0.2, 0.1));
  std::vector<HandEyeObservation> out;
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d axis(g(rng), g(rng), g(rng));
    axis.normalize();
    const double angle = spread * (0.25 + 0.25 * u(rng));
    Eigen::Isometry3d H = Eigen::Isometry3d::Identity();
    H.linear() = R0 * Eigen::AngleAxisd(angle, axis).toRotationMatrix();
    H.translation() = Eigen::Vector3d(0.1, 0.2, 1.0) +
                      Eigen::Vector3d(u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5) * 0.3;
    const Eigen::Isometry3d C = (H * X).inverse() * Z;
    out.push_back({H * noise(sr, st), C * noise(sr, st)});
  }
  return out;
}

}  // namespace dentar::calibration
