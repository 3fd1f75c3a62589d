// A simulated student who LEARNS (issue 27, "learning curves on simulated students"): a
// memory of the expert's path that each repetition of a lesson updates, so that a learning
// curve and an unguided retention test can be measured through the real engine and modes.
//
// The model (docs/learner_model.md gives the sources and every assumption):
//  - Execution: the hand aims at its memory m(tau) of where the expert's tip is at the
//    lesson's time tau (feedforward), plus a visual correction u that integrates the error
//    it sees between the expert's tool and its own, lag_s late (feedback), plus motor noise
//    (an Ornstein-Uhlenbeck wander). The hand is the lesson run's simulated stylus (a grip
//    spring on the device profile's plant), so guidance forces move it as they would.
//  - Learning, after each repetition, per node of m (every bin_s of lesson time):
//      s    = (expert - hand) + u + force_credit * F / grip   (the error the learner credits
//             to its own plan: what it saw, what it corrected itself, and the part of the
//             displacement by the device's force F that it attributes to itself)
//      m   += error_rate * e_half / (e_half + |s|) * s       (error-based learning whose
//             sensitivity falls with the size of the error)
//           + use_rate * (hand - m)                           (use-dependent learning: the
//             movement made is remembered, guided or not)
//      m    = prior + retention * (m - prior)                 (forgetting toward the prior)
//    Guidance lowers s (it does part of the correcting, and only force_credit of it is
//    credited) but makes the movement made better: whether guidance helps or hurts
//    retention follows from these two terms and the error size, not from a rule per
//    condition (with the defaults it hurts the novice slightly; with use_rate 0.15 it
//    helps: docs/BENCHMARKS.md, issue 27 session 15).
//  - Retention: the expert is hidden and there is no force; the hand aims at m(tau) plus its
//    noise only.
// Units SI; positions in the tooth frame; tau = the expert's clock (s). Offline only.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "dentar/haptics/guidance.h"
#include "dentar/training/lesson.h"
#include "dentar/training/lesson_plan.h"
#include "dentar/training/lesson_run.h"

namespace dentar::training {

struct LearnerModel {
  std::string name = "novice";
  // Execution (the hand: StudentModel's grip and damping, an active student).
  double lag_s = 0.35;       // visual reaction delay of the correction
  double noise_mm = 0.35;    // SD of the aim's wander, per axis
  double noise_tau_s = 0.3;  // its correlation time
  double grip_N_per_m = 300.0;
  double damping_ratio = 0.7;
  double feedback_tau_s = 0.5;   // time constant of the visual correction (integrator)
  double feedback_max_mm = 5.0;  // the correction's bound (the student gives up beyond)
  // What the learner knows before the first repetition: the expert's path blurred over
  // prior_blur_s (a Gaussian in time) and offset by a smooth personal error of SD
  // prior_offset_mm per axis, correlated over prior_offset_tau_s of lesson time (seeded).
  double prior_blur_s = 1.5;
  double prior_offset_mm = 1.5;
  double prior_offset_tau_s = 3.0;
  // Learning (the same for both presets: the difference between a novice and a skilled
  // learner is what they know and how they move, not how they learn).
  double bin_s = 0.05;         // the memory's resolution in lesson time
  double error_rate = 0.4;     // error-based learning rate at small errors
  double error_half_mm = 0.5;  // error at which that rate has halved
  double use_rate = 0.05;      // use-dependent learning rate
  double force_credit = 0.1;   // the share of the force's displacement credited to oneself
  double retention = 0.95;     // kept per repetition, toward the prior
  static LearnerModel novice();
  static LearnerModel skilled();
  // "" when valid, else the field and its range.
  std::string validate() const;
  // The execution part as the lesson run's student (seed: the wander's).
  StudentModel student(std::uint64_t seed) const;
};

// The learner's memory of the expert's path: nodes every bin_s of lesson time (tooth frame,
// m), linear between nodes, clamped at the ends.
class LearnedPath {
 public:
  // The prior of `model` for the first `seconds` of `track` (seeded personal offset).
  static LearnedPath prior(const haptics::ExpertTrack& track, double seconds,
                           const LearnerModel& model, std::uint64_t seed);
  Eigen::Vector3d at(double tau_s) const noexcept;
  // One repetition's update from its trace (LessonRunOptions::learner.trace). Samples
  // outside [0, end] are ignored; nodes with no sample only forget.
  void learn(const std::vector<LearnerSample>& trace, const LearnerModel& model);
  // Mean distance from the expert's path over the nodes (a diagnostic of the state, not a
  // measured outcome: the outcomes are run through the engine).
  double mean_distance_to(const haptics::ExpertTrack& track) const;
  std::size_t nodes() const { return m_.size(); }
  double bin_s() const { return bin_; }

 private:
  double bin_ = 0.05;
  std::vector<Eigen::Vector3d> m_, prior_;
};

// The guidance conditions compared (issue 27, part 5): mode 1 with no force; mode 2 with
// the seed's fixed field; as needed; faded over the repetitions (fade^rep); across the path
// only; error amplification; and "plan": each repetition's mode and guidance chosen by the
// lesson plan (plan_next) from the repetitions before.
enum class GuidanceCondition { kNone, kFixed, kAsNeeded, kFading, kAcrossPath, kAmplify, kPlan };
const char* condition_name(GuidanceCondition c);
// "none", "fixed", "as_needed", "fading", "across_path", "amplify", "plan".
Result<GuidanceCondition> parse_condition(const std::string& s);
const std::vector<GuidanceCondition>& fixed_conditions();  // all but kPlan, in the order above

struct LearningOptions {
  int repetitions = 10;
  double seconds = 10;  // of the lesson per repetition (its start; the benchmark's)
  std::string device = "touch";
  double fade = 0.7;        // kFading: k * fade^rep, rep = 0 .. repetitions-1
  double amplify = 0.5;     // kAmplify
  bool probe_each = false;  // a retention test after every repetition too (does not learn)
  PlanOptions plan;         // kPlan's thresholds
  std::string validate() const;
};

struct RepetitionResult {
  int mode = 1;
  haptics::GuidanceParams guidance;
  std::string rule;                          // kPlan: the plan's rule
  double train_mean_m = 0, train_p95_m = 0;  // following error during the repetition (engine)
  double mean_force_N = 0;
  double probe_mean_m = -1, probe_p95_m = -1;  // retention test after it (probe_each)
  double memory_m = 0;  // the memory's mean distance to the path after learning
};

struct LearningCurve {
  std::string learner, condition;
  std::uint64_t seed = 0;
  double before_mean_m = 0, before_p95_m = 0;  // retention test before any training
  std::vector<RepetitionResult> reps;
  double retention_mean_m = 0, retention_p95_m = 0;  // after the last repetition
  double cpu_s = 0;
};

// Repetitions of `lesson` in condition c for one learner (seed: its prior and its noise),
// each through run_lesson (the engine, the mode, its guard and ramps), then an unguided
// retention test (mode 1, the expert hidden, memory only). Errors: bad options, and
// run_lesson's.
Result<LearningCurve> run_learning_curve(const Lesson& lesson, const LearnerModel& model,
                                         GuidanceCondition c, std::uint64_t seed,
                                         const LearningOptions& opt);

}  // namespace dentar::training
