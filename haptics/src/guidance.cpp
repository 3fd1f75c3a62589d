#include "dentar/haptics/guidance.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace dentar::haptics {

const char* training_mode_name(TrainingModeKind m) {
  switch (m) {
    case TrainingModeKind::kNone: return "none";
    case TrainingModeKind::kVisualReplay: return "visual replay";
    case TrainingModeKind::kPassiveGuidance: return "passive guidance";
    case TrainingModeKind::kActiveFollowing: return "active following";
    case TrainingModeKind::kForceReversal: return "force reversal";
    case TrainingModeKind::kHints: return "hints";
  }
  return "unknown";
}

std::string GuidanceParams::validate() const {
  std::ostringstream os;
  if (!std::isfinite(k_N_per_m) || k_N_per_m < 0)
    os << "guidance stiffness k = " << k_N_per_m << " N/m must be >= 0";
  else if (!std::isfinite(eps1_m) || eps1_m <= 0)
    os << "eps1 = " << eps1_m * 1e3 << " mm must be > 0";
  else if (!std::isfinite(eps2_m) || eps2_m <= eps1_m)
    os << "eps2 = " << eps2_m * 1e3 << " mm must be greater than eps1 = " << eps1_m * 1e3 << " mm";
  else if (!std::isfinite(damping_N_s_per_m) || damping_N_s_per_m < 0)
    os << "guidance damping = " << damping_N_s_per_m << " N s/m must be >= 0";
  else if (!std::isfinite(as_needed_gain) || as_needed_gain <= 0)
    os << "as_needed_gain = " << as_needed_gain << " must be > 0";
  else if (!std::isfinite(as_needed_min) || as_needed_min < 0 || as_needed_min > 1)
    os << "as_needed_min = " << as_needed_min << " must be in [0, 1]";
  else if (!std::isfinite(as_needed_tau_s) || as_needed_tau_s <= 0)
    os << "as_needed_tau = " << as_needed_tau_s << " s must be > 0";
  else if (!std::isfinite(fade) || fade <= 0 || fade > 1)
    os << "fade = " << fade << " must be in (0, 1]";
  else if (repetition < 0)
    os << "repetition = " << repetition << " must be >= 0";
  else if (!std::isfinite(amplify) || amplify < 0 || amplify > 1)
    os << "amplify = " << amplify << " must be in [0, 1]";
  return os.str();
}

double guidance_stiffness_limit(double contact_max_stiffness_N_per_m) { return 0.4 * contact_max_stiffness_N_per_m; }

Eigen::Vector3d guidance_force(const Eigen::Vector3d& delta_m, const GuidanceParams& p,
                               const Eigen::Vector3d& tangent) noexcept {
  Eigen::Vector3d d = delta_m;
  if (p.across_path_only) {
    const double tn = tangent.norm();
    if (tn > 1e-12) {
      const Eigen::Vector3d u = tangent / tn;
      d -= u * u.dot(d);
    }
  }
  const double r = d.norm();
  if (!(r > 0) || r > p.eps2_m || !std::isfinite(r)) return Eigen::Vector3d::Zero();
  // Magnitude k r beyond eps1, k r^2 / eps1 inside: both k eps1 at eps1 (continuous), and
  // the slope falls to zero as the tools coincide, so the loop does not buzz there.
  const double mag = r >= p.eps1_m || !p.quadratic_core ? p.k_N_per_m * r : p.k_N_per_m * r * r / p.eps1_m;
  return d * (mag / r);
}

std::string FollowTolerance::validate() const {
  std::ostringstream os;
  if (!std::isfinite(eps_m) || eps_m <= 0) {
    os << "follow tolerance eps = " << eps_m * 1e3 << " mm must be > 0";
  } else {
    for (int i = 0; i < 3; ++i)
      if (!std::isfinite(theta_rad[i]) || theta_rad[i] <= 0) {
        os << "follow tolerance theta" << i + 1 << " = " << theta_rad[i] * 180 / M_PI << " deg must be > 0";
        break;
      }
  }
  return os.str();
}

bool FollowError::within(const FollowTolerance& t) const noexcept {
  return position_m <= t.eps_m && angle_rad[0] <= t.theta_rad[0] && angle_rad[1] <= t.theta_rad[1] &&
         angle_rad[2] <= t.theta_rad[2];
}

FollowError follow_error(const Eigen::Isometry3d& T_tooth_expert, const Eigen::Isometry3d& T_tooth_student) noexcept {
  FollowError e;
  e.position_m = (T_tooth_student.translation() - T_tooth_expert.translation()).norm();
  const Eigen::AngleAxisd aa(T_tooth_expert.linear().transpose() * T_tooth_student.linear());
  const Eigen::Vector3d w = aa.axis() * aa.angle();  // in the expert tool's frame
  for (int i = 0; i < 3; ++i) e.angle_rad[i] = std::isfinite(w[i]) ? std::abs(w[i]) : M_PI;
  return e;
}

Result<ExpertTrack> ExpertTrack::from_records(const std::vector<StepRecord>& records,
                                              const Eigen::Isometry3d& T_tooth_dev,
                                              const Eigen::Isometry3d& T_sty_tip, const std::string& what) {
  if (records.size() < 2)
    return Error{what + ": the expert recording has " + std::to_string(records.size()) +
                 " haptic steps; a lesson needs at least 2 (record a longer session)"};
  if (!T_tooth_dev.matrix().allFinite() || !T_sty_tip.matrix().allFinite())
    return Error{what + ": the recording's T_tooth_dev or T_sty_tip has non-finite entries"};
  ExpertTrack tr;
  const std::size_t n = records.size();
  tr.t_.reserve(n);
  tr.p_.reserve(n);
  tr.q_.reserve(n);
  tr.v_.reserve(n);
  tr.f_.reserve(n);
  tr.drill_.reserve(n);
  tr.T_tooth_dev_ = T_tooth_dev;
  tr.T_sty_tip_ = T_sty_tip;
  std::uint64_t h = 1469598103934665603ull;
  auto mix = [&h](const void* p, std::size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ull;
  };
  const double t0 = records.front().time_s;
  for (std::size_t i = 0; i < n; ++i) {
    const StepRecord& r = records[i];
    Eigen::Isometry3d T_dev_sty = Eigen::Isometry3d::Identity();
    for (int a = 0; a < 3; ++a) {
      T_dev_sty.translation()[a] = r.position_m[a];
      for (int b = 0; b < 3; ++b) T_dev_sty.linear()(a, b) = r.rotation[3 * a + b];
    }
    const Eigen::Vector3d v(r.velocity_m_per_s[0], r.velocity_m_per_s[1], r.velocity_m_per_s[2]);
    const Eigen::Vector3d f(r.force_dev_N[0], r.force_dev_N[1], r.force_dev_N[2]);
    if (!std::isfinite(r.time_s) || !T_dev_sty.matrix().allFinite() || !v.allFinite() || !f.allFinite())
      return Error{what + ": haptic step " + std::to_string(r.step) + " has a non-finite time, pose, velocity or force"};
    const double t = r.time_s - t0;
    if (i > 0 && !(t > tr.t_.back()))
      return Error{what + ": haptic step " + std::to_string(r.step) + " does not come after the one before (time " +
                   std::to_string(r.time_s) + " s); the recording is out of order or repeated"};
    const Eigen::Isometry3d T_tooth_tip = T_tooth_dev * T_dev_sty * T_sty_tip;
    tr.t_.push_back(t);
    tr.p_.push_back(T_tooth_tip.translation());
    tr.q_.push_back(Eigen::Quaterniond(T_tooth_tip.linear()).normalized());
    tr.v_.push_back(T_tooth_dev.linear() * v);
    tr.f_.push_back(T_tooth_dev.linear() * f);
    tr.drill_.push_back(r.pedal ? 1 : 0);
    mix(&r.time_s, sizeof r.time_s);
    mix(r.position_m, sizeof r.position_m);
    mix(r.rotation, sizeof r.rotation);
    mix(r.force_dev_N, sizeof r.force_dev_N);
    mix(&r.pedal, sizeof r.pedal);
  }
  tr.hash_ = h;
  return tr;
}

ExpertSample ExpertTrack::at(double t_s) const noexcept {
  ExpertSample s;
  if (t_.empty()) return s;
  const double t = std::clamp(std::isfinite(t_s) ? t_s : 0.0, 0.0, t_.back());
  // The segment [i, i + 1] holding t.
  std::size_t i = static_cast<std::size_t>(std::upper_bound(t_.begin(), t_.end(), t) - t_.begin());
  i = i == 0 ? 0 : i - 1;
  if (i + 1 >= t_.size()) i = t_.size() - 2;
  const double a = std::clamp((t - t_[i]) / (t_[i + 1] - t_[i]), 0.0, 1.0);
  s.T_tooth_tip.linear() = q_[i].slerp(a, q_[i + 1]).toRotationMatrix();
  s.T_tooth_tip.translation() = (1 - a) * p_[i] + a * p_[i + 1];
  s.velocity_m_per_s = (1 - a) * v_[i] + a * v_[i + 1];
  // Force and pedal are what the step held (zero-order, as the device rendered them).
  const std::size_t k = a >= 1.0 ? i + 1 : i;
  s.force_N = f_[k];
  s.drilling = drill_[k] != 0;
  return s;
}

double Ramp::step(double dt_s) noexcept {
  const double d = rate_ * (std::isfinite(dt_s) && dt_s > 0 ? dt_s : 0.0);
  if (value_ < target_)
    value_ = std::min(target_, value_ + d);
  else
    value_ = std::max(target_, value_ - d);
  return value_;
}

std::string TrainingParams::validate() const {
  std::ostringstream os;
  if (std::string g = guidance.validate(); !g.empty())
    os << g;
  else if (std::string t = tolerance.validate(); !t.empty())
    os << t;
  else if (!std::isfinite(speed) || speed < 0.25 || speed > 2)
    os << "expert speed = " << speed << " must be in [0.25, 2]";
  else if (!std::isfinite(ramp_s) || ramp_s < 0.05 || ramp_s > 2)
    os << "force ramp = " << ramp_s << " s must be in [0.05, 2]";
  else if (static_cast<int>(mode) > 5)
    os << "mode = " << static_cast<int>(mode) << " must be 1..5";
  return os.str();
}

Result<TrainingMode> TrainingMode::create(const TrainingParams& p, const ExpertTrack& track) {
  if (std::string v = p.validate(); !v.empty()) return Error{"training mode: " + v};
  if (track.size() < 2) return Error{"training mode: the expert track is empty"};
  return TrainingMode(p, track);
}

TrainingStep TrainingMode::step(const Eigen::Isometry3d& T_tooth_student_tip, const Eigen::Vector3d& v_tooth_student,
                                double dt_s) noexcept {
  TrainingStep s;
  if (p_.mode == TrainingModeKind::kNone) return s;
  const double dt = std::isfinite(dt_s) && dt_s > 0 ? dt_s : 0.0;
  // The student against where the expert is now, then the expert's clock moves on.
  const ExpertSample now = track_->at(clock_s_);
  s.error = follow_error(now.T_tooth_tip, T_tooth_student_tip);
  const bool paused = paused_ || held_;
  bool run = !paused;
  if (p_.mode == TrainingModeKind::kActiveFollowing && p_.conditional_replay && !s.error.within(p_.tolerance)) {
    run = false;
    s.expert_waiting = true;
  }
  const double before = clock_s_;
  if (run) clock_s_ = std::min(track_->duration_s(), clock_s_ + dt * p_.speed);
  s.expert_cut_dt_s = clock_s_ - before;
  s.expert_time_s = clock_s_;
  s.expert = run ? track_->at(clock_s_) : now;
  const bool active = s.expert_cut_dt_s > 0;
  ramp_.set_target(paused || finished() ? 0.0 : 1.0);
  const double g = ramp_.step(dt);
  switch (p_.mode) {
    case TrainingModeKind::kNone: break;
    case TrainingModeKind::kVisualReplay:
      // Watching: the stylus neither feels nor cuts the tooth.
      s.contact_forces = false;
      s.student_cuts = false;
      s.expert_cuts = active && s.expert.drilling;
      break;
    case TrainingModeKind::kPassiveGuidance: {
      s.contact_forces = false;
      s.student_cuts = false;
      s.expert_cuts = active && s.expert.drilling;
      const Eigen::Vector3d delta = s.expert.T_tooth_tip.translation() - T_tooth_student_tip.translation();
      const GuidanceParams& gp = p_.guidance;
      // The stiffness this step: faded over repetitions, and as needed by the recent error.
      const double a = dt / (gp.as_needed_tau_s + dt);
      error_lp_m_ += a * (std::min(s.error.position_m, gp.eps2_m) - error_lp_m_);
      double scale = std::pow(gp.fade, gp.repetition);
      if (gp.as_needed) scale *= std::clamp(error_lp_m_ / gp.eps2_m * gp.as_needed_gain, gp.as_needed_min, 1.0);
      Eigen::Vector3d f = scale * guidance_force(delta, gp, s.expert.velocity_m_per_s);
      if (gp.amplify > 0) {
        // Error amplification: the same field, pushing away from the path (no damper).
        f = -gp.amplify * f;
      } else if (delta.norm() <= gp.eps2_m && v_tooth_student.allFinite()) {
        f += gp.damping_N_s_per_m * (s.expert.velocity_m_per_s * p_.speed - v_tooth_student);
      }
      s.force_tooth_N = g * f;
      break;
    }
    case TrainingModeKind::kActiveFollowing:
      s.contact_forces = false;
      s.student_cuts = false;
      s.expert_cuts = active && s.expert.drilling;
      break;
    case TrainingModeKind::kForceReversal:
      s.contact_forces = false;
      s.student_cuts = false;
      s.expert_cuts = active && s.expert.drilling;
      s.force_tooth_N = -g * s.expert.force_N;
      break;
    case TrainingModeKind::kHints:
      break;  // the student drills as usual; the expert is only shown
  }
  if (!s.force_tooth_N.allFinite()) s.force_tooth_N.setZero();
  return s;
}

}  // namespace dentar::haptics
