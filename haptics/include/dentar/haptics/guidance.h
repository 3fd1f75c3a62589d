// Training modes (issue 27; the seed's chapter 5.3): an expert's recorded session replayed
// against the student's hand, computed inside the 1 kHz engine step.
//
//  1 visual replay   the engine is not involved (graphics only);
//  2 passive guidance the expert's tip drags the stylus through a force field
//                     |F| = 0 beyond eps2, k|dx| between eps1 and eps2, k|dx|^2/eps1 below
//                     eps1 (no kick when the tools coincide); contact forces off; the
//                     expert's tool cuts;
//  3 active following the expert's tool is replayed and cuts, the stylus moves freely (no
//                     force); with conditional replay the expert's clock runs only while the
//                     stylus is within eps in position and theta_1..3 about each axis;
//  4 force reversal   the expert's recorded force F is rendered as -F: to stay on the
//                     expert's path the student pushes with F; the expert's tool cuts;
//  5 hints            the student drills as usual; the expert's tool is published for the
//                     overlay, with whether the recording drills at that moment.
//
// Every force here is a request: the engine sends it through the same ForceGuard (device
// clamp, NaN latch, spike limit) and watchdog as contact forces, after a ramp that limits
// how fast a mode's force may appear or vanish (start, stop, pause).
//
// Frames: the expert track is kept in the tooth frame (T_tooth_tip, from the recording's
// own T_tooth_dev and T_sty_tip), so a lesson recorded at another station replays onto this
// tooth. Units SI. Thread: the haptic thread owns a TrainingMode; nothing here allocates,
// locks or does I/O after construction.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "dentar/haptics/session_log.h"
#include "dentar/volume/result.h"

namespace dentar::haptics {

enum class TrainingModeKind : std::uint8_t {
  kNone = 0,
  kVisualReplay = 1,
  kPassiveGuidance = 2,
  kActiveFollowing = 3,
  kForceReversal = 4,
  kHints = 5,
};
const char* training_mode_name(TrainingModeKind m);

// The seed's guidance field. Defaults: k 150 N/m (a firm but overridable pull: 1.5 N at
// eps2, and within every profile's guidance limit below), eps1 0.5 mm (the quadratic core,
// about a bur radius), eps2 10 mm (beyond this the student has let go of the lesson: no
// force rather than a large one).
struct GuidanceParams {
  double k_N_per_m = 150.0;
  double eps1_m = 0.5e-3;
  double eps2_m = 10e-3;
  // Beyond the seed: a damper on the velocity relative to the expert's tip, inside eps2.
  // The seed's field is a pure spring, which with a relaxed hand (a few N/m) rings at
  // ~6 Hz with almost no damping; 1 N s/m is a quarter of a Touch's stable maximum.
  double damping_N_s_per_m = 1.0;
  // Beyond the seed: only the component across the expert's path (free along it).
  bool across_path_only = false;
  // The seed's quadratic core below eps1; false: k|dx| down to zero (the comparison the
  // issue asks for: a linear field's slope stays k where the tools coincide).
  bool quadratic_core = true;
  // Beyond the seed, from the motor-learning literature:
  //  - guidance as needed: the stiffness follows the student's recent error, k * clamp(
  //    e / eps2 * as_needed_gain, as_needed_min, 1), e the error low-passed over
  //    as_needed_tau_s (a student on the path feels little, one who strays the full field);
  //  - fading: k * fade^repetition over a lesson's repetitions;
  //  - error amplification (skilled learners): the field pushes away from the path,
  //    scaled by `amplify` (0: off), still zero beyond eps2.
  bool as_needed = false;
  double as_needed_gain = 4.0, as_needed_min = 0.1, as_needed_tau_s = 1.0;
  double fade = 1.0;
  int repetition = 0;
  double amplify = 0.0;
  std::string validate() const;  // empty when valid, else names the field
};

// The stiffest guidance field a device may render (N/m): 0.4 x its contact limit. A
// guidance spring is two-sided and the hand on it is relaxed, so it is less damped than a
// press on the tooth: with 2 ms of jitter the largest stable guidance stiffness measured
// was 0.51-0.95 x the contact limit across the profiles (haptics_guidance_bench,
// docs/BENCHMARKS.md); 0.4 keeps a margin on every one.
double guidance_stiffness_limit(double contact_max_stiffness_N_per_m);

// Force on the student's tip (N) for delta = expert tip - student tip (m). With a unit
// `tangent` (the expert's direction of travel) and across_path_only, the part of delta
// along the tangent is dropped first.
Eigen::Vector3d guidance_force(const Eigen::Vector3d& delta_m, const GuidanceParams& p,
                               const Eigen::Vector3d& tangent = Eigen::Vector3d::Zero()) noexcept;

// Conditional replay's tolerance: position and the rotation about each of the expert
// tool's axes (the rotation vector of R_expert^T R_student, component by component).
struct FollowTolerance {
  double eps_m = 2e-3;
  double theta_rad[3] = {0.35, 0.35, 3.2};  // 20 deg tilt; roll about the bur axis is free
  std::string validate() const;
};
// The student's tip against the expert's (tooth frame): position error (m) and the
// per-axis rotation error (rad, absolute).
struct FollowError {
  double position_m = 0;
  double angle_rad[3] = {0, 0, 0};
  bool within(const FollowTolerance& t) const noexcept;
};
FollowError follow_error(const Eigen::Isometry3d& T_tooth_expert, const Eigen::Isometry3d& T_tooth_student) noexcept;

// One instant of the expert's recording (tooth frame).
struct ExpertSample {
  Eigen::Isometry3d T_tooth_tip = Eigen::Isometry3d::Identity();
  Eigen::Vector3d velocity_m_per_s = Eigen::Vector3d::Zero();  // of the tip, tooth frame
  Eigen::Vector3d force_N = Eigen::Vector3d::Zero();           // sent to the expert's device
  bool drilling = false;                                       // pedal down
};

// The expert's recording as a track sampled at any time in [0, duration]: positions
// interpolated linearly, rotations by slerp, force and pedal from the step before.
class ExpertTrack {
 public:
  // From a session log and the recording's own station: T_tooth_dev and T_sty_tip as its
  // header gives them. Errors name `what` (the file): fewer than 2 records, time not
  // increasing, non-finite poses.
  static Result<ExpertTrack> from_records(const std::vector<StepRecord>& records,
                                          const Eigen::Isometry3d& T_tooth_dev,
                                          const Eigen::Isometry3d& T_sty_tip, const std::string& what);
  double duration_s() const { return t_.empty() ? 0 : t_.back(); }
  // Clamped to [0, duration]. No allocation.
  ExpertSample at(double t_s) const noexcept;
  std::size_t size() const { return t_.size(); }
  // FNV-1a over the records' times, poses, forces and pedals: a replay checks that it has
  // the recording the session was trained on.
  std::uint64_t content_hash() const { return hash_; }
  const Eigen::Isometry3d& T_tooth_dev() const { return T_tooth_dev_; }  // the recording's
  const Eigen::Isometry3d& T_sty_tip() const { return T_sty_tip_; }

 private:
  std::uint64_t hash_ = 0;
  Eigen::Isometry3d T_tooth_dev_ = Eigen::Isometry3d::Identity(), T_sty_tip_ = Eigen::Isometry3d::Identity();
  std::vector<double> t_;  // from 0
  std::vector<Eigen::Vector3d> p_;
  std::vector<Eigen::Quaterniond> q_;
  std::vector<Eigen::Vector3d> v_, f_;
  std::vector<std::uint8_t> drill_;
};

// A gain that moves to its target at a bounded rate: a mode's force fades in when it
// starts and out when it stops or pauses, instead of stepping (no kick).
class Ramp {
 public:
  explicit Ramp(double seconds_full_scale = 0.25, double initial = 0)
      : rate_(1.0 / seconds_full_scale), target_(initial), value_(initial) {}
  void set_target(double g) noexcept { target_ = g < 0 ? 0 : (g > 1 ? 1 : g); }
  double target() const noexcept { return target_; }
  double value() const noexcept { return value_; }
  double step(double dt_s) noexcept;

 private:
  double rate_;    // full scale per second
  double target_;  // 0..1
  double value_;
};

struct TrainingParams {
  TrainingModeKind mode = TrainingModeKind::kNone;
  GuidanceParams guidance;
  FollowTolerance tolerance;
  bool conditional_replay = true;  // mode 3: the expert waits for the student
  double speed = 1.0;              // expert time per real time (0.25 .. 2)
  double ramp_s = 0.25;            // force fade in/out, s (0.05 .. 2)
  // Where the expert's recording is (written into the session log's header, so that a
  // replay rebuilds the mode; docs/formats.md). Not read by the engine.
  std::string expert_file;
  std::string validate() const;
};

// What a training mode asks of one engine step.
struct TrainingStep {
  Eigen::Vector3d force_tooth_N = Eigen::Vector3d::Zero();  // added to the (gated) contact force
  bool contact_forces = true;  // the student's bur feels the tooth
  bool student_cuts = true;    // the student's bur cuts when the pedal is down
  bool expert_cuts = false;    // the expert's bur cuts where the recording drilled
  double expert_cut_dt_s = 0;  // for how long (expert time) it cuts this step
  double expert_time_s = 0;
  bool expert_waiting = false;  // conditional replay: paused for the student
  ExpertSample expert;
  FollowError error;
};

// The state of one mode over a session; the engine calls step() once per haptic step.
class TrainingMode {
 public:
  // `track` must outlive the mode.
  static Result<TrainingMode> create(const TrainingParams& p, const ExpertTrack& track);
  // The student's tip pose and velocity (tooth frame) this step.
  TrainingStep step(const Eigen::Isometry3d& T_tooth_student_tip, const Eigen::Vector3d& v_tooth_student,
                    double dt_s) noexcept;
  // Pause/resume by the student (or a lesson's pause point): the expert's clock stops and
  // the mode's force fades out; on resume it fades in again. No jump: the expert's pose is
  // a function of its clock, which does not move while paused.
  void set_paused(bool paused) noexcept { paused_ = paused; }
  // The engine holds the mode paused while the stylus's pause button (kButtonSecondary) is
  // down: a pause that comes through the device state is recorded, so a replay repeats it.
  void set_held(bool held) noexcept { held_ = held; }
  bool paused() const noexcept { return paused_ || held_; }
  bool finished() const noexcept { return clock_s_ >= track_->duration_s(); }
  const TrainingParams& params() const { return p_; }
  const ExpertTrack& track() const { return *track_; }

 private:
  TrainingMode(const TrainingParams& p, const ExpertTrack& track) : p_(p), track_(&track), ramp_(p.ramp_s) {}
  TrainingParams p_;
  const ExpertTrack* track_;
  Ramp ramp_;
  double clock_s_ = 0;
  double error_lp_m_ = 0;  // low-passed following error (guidance as needed)
  bool paused_ = false;
  bool held_ = false;
};

}  // namespace dentar::haptics
