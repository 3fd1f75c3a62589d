// Temporal filter for a rigid-body pose stream (T_cam_body at camera rate):
// a One Euro filter on SE(3) plus constant-velocity prediction to the time
// the frame will be displayed.
//
//  - Translation: one One Euro filter per axis (metres), smoothing toward a
//    prior = the filtered pose carried on by the filtered velocity (a
//    constant motion is followed without the usual low-pass lag).
//  - Rotation: the increment from the filtered orientation to the measured
//    one, as a rotation vector r = log(R_f^T R_meas) (body frame, radians),
//    is low-passed: R_f <- R_f exp(alpha r) (with the angular-velocity
//    prior as for translation). No wrap-around at +-pi, no Euler angles.
//  - Speed-adaptive cutoff (Casiez et al. 2012): fc = min_cutoff + beta *
//    |speed|, where the speed is itself low-passed (d_cutoff). Slow motion is
//    smoothed hard (kills jitter), fast motion passes almost unfiltered (no
//    lag). The speed is measured between the measurement and the prior (not
//    the previous raw sample): while the output trails a step the cutoff
//    stays high, which is what keeps the step lag within one frame.
//  - Prediction: the filtered pose moved on by the filtered velocities
//    (linear m/s, angular rad/s in the body frame; the low-passed rate of the
//    filtered output, so unbiased on constant motion and as quiet as the
//    output) for (t - last update), clamped to max_prediction_s.
//
// Times are seconds on any monotonic clock (the frame's capture time).
// Not thread-safe; one filter per body.
#pragma once

#include <Eigen/Geometry>
#include <string>

namespace dentar::ar {

struct PoseFilterOptions {
  // Translation: cutoff at rest (Hz), speed coefficient (Hz per m/s), the
  // cutoff of the speed estimate (Hz) and of the velocity used for the prior
  // and the prediction (Hz). Tuned on generated footage (docs/BENCHMARKS.md,
  // FilterSweep): a head-mounted camera never stands still (tremor at
  // 1.5-3.5 Hz), so the filter must follow small fast motion; at rest it
  // still takes the tracker's 0.03 mm noise down to ~0.02 mm.
  double min_cutoff_hz = 1.0;
  double beta = 3000.0;
  double d_cutoff_hz = 4.0;
  double v_cutoff_hz = 2.0;
  // Rotation: the same with the angular speed (Hz per rad/s).
  double rot_min_cutoff_hz = 1.0;
  double rot_beta = 375.0;
  double rot_d_cutoff_hz = 4.0;
  double rot_v_cutoff_hz = 2.0;
  // Longest extrapolation predict() does past the last update, s; beyond it
  // the pose is held (a stale velocity must not fling the overlay away).
  double max_prediction_s = 0.1;
  // Updates closer than this (s) are treated as this far apart (a repeated
  // timestamp must not divide by zero).
  double min_dt_s = 1e-4;

  std::string validate() const;  // empty when valid, else names the field
};

class PoseFilter {
 public:
  explicit PoseFilter(const PoseFilterOptions& options = {}) : o_(options) {}

  // Feeds one measured pose taken at time_s (s). The first update after
  // construction or reset() initialises the filter (output = measurement,
  // velocity 0). A time_s not after the previous update counts as min_dt_s
  // later. Returns the filtered pose at time_s. Non-finite input is ignored
  // (returns the current state).
  Eigen::Isometry3d update(const Eigen::Isometry3d& T_meas, double time_s);
  // The filtered pose extrapolated to time_s with the filtered velocities
  // (time_s before the last update gives the filtered pose itself).
  // Identity when never updated.
  Eigen::Isometry3d predict(double time_s) const;
  void reset() { initialised_ = false; }
  bool initialised() const { return initialised_; }
  double last_time_s() const { return t_last_; }
  const Eigen::Isometry3d& filtered() const { return T_f_; }
  // Filtered velocities: linear (m/s, camera frame) and angular (rad/s, body frame).
  const Eigen::Vector3d& linear_velocity() const { return v_f_; }
  const Eigen::Vector3d& angular_velocity() const { return w_f_; }
  const PoseFilterOptions& options() const { return o_; }

 private:
  PoseFilterOptions o_;
  bool initialised_ = false;
  double t_last_ = 0;
  Eigen::Isometry3d T_f_ = Eigen::Isometry3d::Identity();
  Eigen::Vector3d v_f_ = Eigen::Vector3d::Zero();  // per axis, m/s
  Eigen::Vector3d w_f_ = Eigen::Vector3d::Zero();  // rad/s, body frame
  // Speeds that set the cutoffs, measured against the filtered value.
  Eigen::Vector3d s_f_ = Eigen::Vector3d::Zero();   // m/s per axis
  Eigen::Vector3d rs_f_ = Eigen::Vector3d::Zero();  // rad/s
};

// Rotation vector (axis * angle, |angle| <= pi) of R, and its inverse.
Eigen::Vector3d rotation_log(const Eigen::Matrix3d& R);
Eigen::Matrix3d rotation_exp(const Eigen::Vector3d& w);

}  // namespace dentar::ar
