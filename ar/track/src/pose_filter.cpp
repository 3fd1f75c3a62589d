#include "dentar/ar/pose_filter.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace dentar::ar {

namespace {

// Exponential smoothing factor of a first-order low-pass at cutoff fc (Hz)
// sampled every dt (s).
double alpha(double fc_hz, double dt_s) {
  const double tau = 1.0 / (2.0 * M_PI * fc_hz);
  return 1.0 / (1.0 + tau / dt_s);
}

bool positive(double v) { return std::isfinite(v) && v > 0; }
bool non_negative(double v) { return std::isfinite(v) && v >= 0; }

}  // namespace

std::string PoseFilterOptions::validate() const {
  std::ostringstream os;
  if (!positive(min_cutoff_hz))
    os << "min_cutoff_hz = " << min_cutoff_hz << " must be finite and > 0";
  else if (!non_negative(beta))
    os << "beta = " << beta << " must be finite and >= 0";
  else if (!positive(d_cutoff_hz))
    os << "d_cutoff_hz = " << d_cutoff_hz << " must be finite and > 0";
  else if (!positive(v_cutoff_hz))
    os << "v_cutoff_hz = " << v_cutoff_hz << " must be finite and > 0";
  else if (!positive(rot_min_cutoff_hz))
    os << "rot_min_cutoff_hz = " << rot_min_cutoff_hz << " must be finite and > 0";
  else if (!non_negative(rot_beta))
    os << "rot_beta = " << rot_beta << " must be finite and >= 0";
  else if (!positive(rot_d_cutoff_hz))
    os << "rot_d_cutoff_hz = " << rot_d_cutoff_hz << " must be finite and > 0";
  else if (!positive(rot_v_cutoff_hz))
    os << "rot_v_cutoff_hz = " << rot_v_cutoff_hz << " must be finite and > 0";
  else if (!non_negative(max_prediction_s) || max_prediction_s > 1.0)
    os << "max_prediction_s = " << max_prediction_s << " must be in [0, 1]";
  else if (!positive(min_dt_s) || min_dt_s > 0.1)
    os << "min_dt_s = " << min_dt_s << " must be in (0, 0.1]";
  return os.str();
}

Eigen::Vector3d rotation_log(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  double angle = aa.angle();
  Eigen::Vector3d axis = aa.axis();
  if (angle > M_PI) {  // Eigen may return (pi, 2pi): take the short way round
    angle = 2 * M_PI - angle;
    axis = -axis;
  }
  return axis * angle;
}

Eigen::Matrix3d rotation_exp(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  if (angle < 1e-15) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
}

Eigen::Isometry3d PoseFilter::update(const Eigen::Isometry3d& T_meas, double time_s) {
  if (!T_meas.matrix().allFinite() || !std::isfinite(time_s)) return T_f_;
  if (!initialised_) {
    T_f_ = T_meas;
    v_f_.setZero();
    w_f_.setZero();
    s_f_.setZero();
    rs_f_.setZero();
    t_last_ = time_s;
    initialised_ = true;
    return T_f_;
  }
  const double dt = std::max(time_s - t_last_, o_.min_dt_s);
  t_last_ = std::max(time_s, t_last_ + o_.min_dt_s);

  // Prior: the filtered pose carried on by the filtered velocity, so a
  // constant motion is followed without the low-pass lag. The cutoff follows
  // the speed of the measurement against that prior (s_f_); the velocity
  // (v_f_) is the strongly low-passed rate of the filtered output, quiet at
  // rest.
  const Eigen::Vector3d x = T_meas.translation();
  const Eigen::Vector3d xf_old = T_f_.translation();
  const Eigen::Vector3d prior = xf_old + v_f_ * dt;
  Eigen::Vector3d xf;
  const double ad = alpha(o_.d_cutoff_hz, dt);
  for (int i = 0; i < 3; ++i) {
    s_f_(i) = ad * (x(i) - prior(i)) / dt + (1 - ad) * s_f_(i);
    const double a = alpha(o_.min_cutoff_hz + o_.beta * std::abs(s_f_(i)), dt);
    xf(i) = a * x(i) + (1 - a) * prior(i);
  }
  const double av = alpha(o_.v_cutoff_hz, dt);
  v_f_ = av * (xf - xf_old) / dt + (1 - av) * v_f_;

  // Rotation: the same on the increment from the prior orientation (body
  // frame rotation vectors).
  const Eigen::Matrix3d Rf = T_f_.linear();
  const Eigen::Matrix3d R_prior = Rf * rotation_exp(w_f_ * dt);
  const Eigen::Vector3d r = rotation_log(R_prior.transpose() * T_meas.linear());
  const double ard = alpha(o_.rot_d_cutoff_hz, dt);
  rs_f_ = ard * (r / dt) + (1 - ard) * rs_f_;
  const double ar = alpha(o_.rot_min_cutoff_hz + o_.rot_beta * rs_f_.norm(), dt);
  Eigen::Matrix3d R = R_prior * rotation_exp(ar * r);
  // Re-orthonormalise: thousands of products drift off SO(3).
  R = Eigen::Quaterniond(R).normalized().toRotationMatrix();
  const double arv = alpha(o_.rot_v_cutoff_hz, dt);
  w_f_ = arv * (rotation_log(Rf.transpose() * R) / dt) + (1 - arv) * w_f_;

  T_f_.linear() = R;
  T_f_.translation() = xf;
  return T_f_;
}

Eigen::Isometry3d PoseFilter::predict(double time_s) const {
  if (!initialised_) return Eigen::Isometry3d::Identity();
  double h = std::isfinite(time_s) ? time_s - t_last_ : 0.0;
  h = std::clamp(h, 0.0, o_.max_prediction_s);
  Eigen::Isometry3d T = T_f_;
  T.translation() += v_f_ * h;
  T.linear() = T_f_.linear() * rotation_exp(w_f_ * h);
  return T;
}

}  // namespace dentar::ar
