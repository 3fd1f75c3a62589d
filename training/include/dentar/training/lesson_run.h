// A lesson run offline (issue 27): a training mode 1..5 on a lesson's expert recording, the
// student's hand simulated on a device profile's plant, every step through the haptic engine
// (its force clamp, NaN guard, watchdog and the mode's start/stop/pause ramp), recorded as a
// session log with the training section, so it can be scored and replayed bit-exactly.
//
// The simulated student (SimStudentDevice) watches the expert's tool (the engine's
// snapshot, fed back after each step) with a reaction lag and follows it with a hand spring;
// its aim wanders (an Ornstein-Uhlenbeck process, seeded). An "active" student grips the
// stylus (300 N/m toward where it aims); a "passive" one rests its hand on it (10 N/m, and it
// aims 0.5 s late): mode 2's guidance has to do the work. Units SI; frames: the run's station
// is the recording's (T_tooth_dev, T_sty_tip from its header).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "dentar/haptics/device.h"
#include "dentar/haptics/device_profiles.h"
#include "dentar/haptics/engine.h"
#include "dentar/training/lesson.h"

namespace dentar::training {

class LearnedPath;  // learner.h

// One haptic step of a learner's repetition (tooth frame, SI): what learner.h learns from.
struct LearnerSample {
  double expert_time_s = 0;
  Eigen::Vector3d expert_tip = Eigen::Vector3d::Zero();
  Eigen::Vector3d hand_tip = Eigen::Vector3d::Zero();  // the stylus tip after the step
  Eigen::Vector3d feedback = Eigen::Vector3d::Zero();  // the learner's own visual correction
  Eigen::Vector3d force_N = Eigen::Vector3d::Zero();   // sent to the device (after the guard)
};

// A learner (learner.h) in place of the plain follower: the hand aims at its memory of the
// expert's path at the expert's clock plus a visual correction integrated from the error
// it sees lag_s late (StudentModel::lag_s), bounded; with `recall` the expert is hidden
// (a retention test): the memory and the wander only. `memory` nullptr: the plain follower.
struct LearnerHooks {
  const LearnedPath* memory = nullptr;  // not owned; must outlive the run
  double feedback_tau_s = 0.5;
  double feedback_max_m = 5e-3;
  bool recall = false;
  std::vector<LearnerSample>* trace = nullptr;  // when set, receives every step (cleared first)
};

struct StudentModel {
  bool passive = false;          // true: relaxed hand (mode 2's "passive hand")
  double lag_s = 0.25;           // reaction delay to what the student sees (passive: 0.5)
  double noise_mm = 0.2;         // SD of the wander of the hand's aim, per axis
  double noise_tau_s = 0.3;      // its correlation time
  double grip_N_per_m = 300.0;   // hand spring toward the aim (passive: 10)
  double damping_ratio = 0.7;    // of the hand (passive: 0.3)
  // Straying (mode 3's test): from device time stray_at_s, for stray_s, the aim is moved by
  // stray_mm along the tooth's +y.
  double stray_at_s = -1, stray_s = 0, stray_mm = 0;
  std::uint64_t seed = 1;
  static StudentModel passive_hand();
  std::string validate() const;
};

// A simulated stylus on a device profile's plant (profile tip mass + 0.1 kg of hand), the
// force held over each period (zero-order hold), optional jitter on the period, and a hand
// that aims at the expert's tool as it was seen lag_s ago. `renders_force` false: a device
// with no motors (the pen stylus): the force sent is ignored.
class SimStudentDevice final : public haptics::HapticDevice {
 public:
  static Result<std::unique_ptr<SimStudentDevice>> create(const haptics::DeviceProfile& profile,
                                                          const haptics::DeviceLimits& limits,
                                                          const Eigen::Isometry3d& T_tooth_dev,
                                                          const Eigen::Isometry3d& T_sty_tip,
                                                          const Eigen::Isometry3d& T_tooth_tip_start,
                                                          const StudentModel& student, bool renders_force,
                                                          double jitter_s = 0);
  std::string name() const override { return name_; }
  const haptics::DeviceLimits& limits() const override { return limits_; }
  bool read(haptics::DeviceState& out) noexcept override;
  void write_force(const Eigen::Vector3d& force_dev_N) noexcept override;
  // What the student sees after a step: the expert's tip (tooth frame) and whether it
  // drills (the student's pedal follows it, lagged).
  // expert_time_s: the expert's clock (a learner aims at its memory at that time).
  void see(const Eigen::Isometry3d& T_tooth_expert_tip, bool drilling, double expert_time_s = 0) noexcept;
  // Makes this student a learner (before the first step; `h.memory` must outlive it).
  void set_learner(const LearnerHooks& h) noexcept;
  // A learner's visual correction now (tooth frame, m).
  Eigen::Vector3d feedback_tooth() const { return u_; }
  // The student holds the stylus's pause button (a lesson's pause point).
  void hold_pause(bool on) noexcept { pause_ = on; }
  double time_s() const { return t_; }
  // The stylus tip (tooth frame).
  Eigen::Vector3d tip_tooth() const;

 private:
  SimStudentDevice() = default;
  std::string name_;
  haptics::DeviceLimits limits_;
  StudentModel s_;
  Eigen::Isometry3d T_tooth_dev_, T_dev_tooth_, T_sty_tip_, T_tip_sty_;
  double mass_ = 0.1, k_ = 300, b_ = 1, jitter_ = 0, t_ = 0;
  bool renders_ = true, pause_ = false;
  Eigen::Vector3d x_ = Eigen::Vector3d::Zero(), v_ = Eigen::Vector3d::Zero(), f_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d wander_ = Eigen::Vector3d::Zero();
  // A learner (learner.h): its memory, the expert's clock, the correction and the delay
  // line of the hand tip as seen (tooth frame).
  LearnerHooks learner_;
  double expert_time_ = 0;
  Eigen::Vector3d u_ = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> seen_hand_;
  // The delay line of what was seen (one entry per step).
  std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>> seen_;
  std::vector<std::uint8_t> seen_drill_;
  std::size_t head_ = 0;
  Eigen::Isometry3d aim_ = Eigen::Isometry3d::Identity();  // the tip pose aimed at now
  bool aim_drill_ = false;
  std::mt19937_64 rng_;
};

struct LessonRunOptions {
  int mode = 2;                  // 1..5
  std::string device = "touch";  // a device profile id (`dentar devices`), or "pen" (no force)
  StudentModel student;
  double seconds = 0;            // stop at this expert time (0: the whole recording)
  double jitter_s = 0;           // extra period length, uniform in [0, jitter_s]
  bool pauses = true;            // the lesson's pause points stop the expert
  std::string out_dir;           // session.dlog and run.json go here ("" = not recorded)
  LearnerHooks learner;          // a learning student (learner.h); default: the plain follower
  std::string validate() const;
};

struct LessonRunResult {
  int mode_asked = 0, mode_run = 0;
  std::string fallback;          // why the mode run differs from the one asked ("" = none)
  std::vector<std::string> notes;  // gains lowered to the device's limits, etc.
  std::string device;
  haptics::GuidanceParams guidance;  // the field as run (after lowering to the device's limits)
  std::string session_path;
  std::uint64_t steps = 0;
  double expert_end_s = 0;       // the expert's clock at the end
  // The student's tip against the expert's, after the expert's first 0.5 s (m).
  double follow_mean_m = 0, follow_p95_m = 0, follow_max_m = 0;
  double waited_s = 0;           // mode 3: time the expert waited for the student
  int pauses_taken = 0;
  double paused_s = 0;
  // Forces sent to the device (after the guard).
  double max_force_N = 0, first_force_N = 0;
  double mean_force_N = 0;       // mean |f| over the run (how much the mode pushed)
  double start_max_step_N = 0;   // largest per-step change of |f| in the first 0.3 s
  double start_field_N = 0;      // what the mode asks at the start, unramped (modes 2, 4)
  double max_step_N = 0;         // largest per-step change of |f| over the run
  // Pause points: |f| when the first pause began, and the largest per-step change of |f|
  // from then until 0.3 s after the last pause ended (the fade out and back in).
  double pause_field_N = 0, pause_max_step_N = 0;
  // Mode 4: largest |sent - (-F)| where the mode ran unpaused for ramp_s and |F| is below the clamp.
  double reversal_error_N = 0;
  std::uint64_t reversal_checked = 0;
  // Mode 5 (any mode): steps whose expert-drilling flag differs from the recording's pedal
  // at the expert's time, and steps with the flag on.
  std::uint64_t drill_mismatch = 0, drill_steps = 0;
  // The expert's tip: largest move in one step against the recording's own largest.
  double max_expert_jump_m = 0, fastest_recorded_step_m = 0;
  std::uint64_t volume_hash = 0;
  double removed_mm3 = 0;
  haptics::EngineStats stats;
};

// Runs the lesson in a mode with a simulated student. Bad options and a device profile
// that does not exist are errors naming the option; a mode that needs force (2, 4) on a
// device with none falls back to mode 3 (visual guidance: the expert drawn and waiting for
// the student) and says so in `fallback`. Writes out_dir/session.dlog and run.json.
Result<LessonRunResult> run_lesson(const Lesson& lesson, const LessonRunOptions& opt);

// One line per figure, for the terminal and run.json.
std::string lesson_run_json(const LessonRunResult& r);

}  // namespace dentar::training
