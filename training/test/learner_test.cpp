// The simulated student who learns (learner.h, issue 27): the learning rule on hand-made
// traces (guidance lowers what is credited, errors are learned less the larger they are,
// forgetting), bad parameters, and short seeded learning curves through the engine: the
// learner improves without guidance, and the fixed field lowers the training error but
// leaves less learned than training without it (the guidance hypothesis, as the model
// documents it in docs/learner_model.md). The full comparison is training_learning_bench.
#include "dentar/training/learner.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "dentar/haptics/replay.h"
#include "dentar/haptics/session_log.h"
#include "testutil.h"

namespace dentar::training {
namespace {

namespace fs = std::filesystem;

const Lesson& shared_lesson() {
  static const Lesson l = [] {
    const fs::path d = test::temp_dir("learner_lesson");
    auto r = make_generated_lesson("molar_class1_cavity", (d / "lesson").string(), 1);
    EXPECT_TRUE(r.ok()) << r.error();
    return r.ok() ? *r : Lesson{};
  }();
  return l;
}

// A straight expert track along x at 10 mm/s for 2 s (tooth frame), as a session log would give it.
haptics::ExpertTrack line_track() {
  std::vector<haptics::StepRecord> recs(2001);
  for (std::size_t i = 0; i < recs.size(); ++i) {
    haptics::StepRecord& r = recs[i];
    r.time_s = static_cast<double>(i) * 1e-3;
    const double p[3] = {0.01 * r.time_s, 0, 0};
    for (int k = 0; k < 3; ++k) r.position_m[k] = p[k];
  }
  auto t = haptics::ExpertTrack::from_records(recs, Eigen::Isometry3d::Identity(),
                                              Eigen::Isometry3d::Identity(), "line");
  EXPECT_TRUE(t.ok()) << t.error();
  return std::move(t).value();
}

// A trace in which the hand went where the memory planned, except that a device force moved
// it by `by_force` (m, along +y) at every step (no visual correction, no noise).
std::vector<LearnerSample> trace_moved_by(const haptics::ExpertTrack& track, const LearnedPath& m,
                                          double by_force, double grip) {
  std::vector<LearnerSample> v;
  for (int i = 0; i <= 2000; ++i) {
    LearnerSample s;
    s.expert_time_s = i * 1e-3;
    s.expert_tip = track.at(s.expert_time_s).T_tooth_tip.translation();
    s.hand_tip = m.at(s.expert_time_s) + Eigen::Vector3d(0, by_force, 0);
    s.force_N = Eigen::Vector3d(0, by_force * grip, 0);
    v.push_back(s);
  }
  return v;
}

TEST(Learner, TheForcesDisplacementIsCreditedByForceCredit) {
  const haptics::ExpertTrack track = line_track();
  LearnerModel m = LearnerModel::skilled();
  m.prior_blur_s = 0;
  m.prior_offset_mm = 1.0;  // the prior misses by a smooth ~1 mm
  m.retention = 1;
  LearnedPath unguided = LearnedPath::prior(track, 2, m, 3), guided = unguided;
  const double before = unguided.mean_distance_to(track);
  ASSERT_GT(before, 0.3e-3);
  unguided.learn(trace_moved_by(track, unguided, 0, m.grip_N_per_m), m);
  // The same plan, but a force moved the hand 0.3 mm along +y.
  guided.learn(trace_moved_by(track, guided, 0.3e-3, m.grip_N_per_m), m);
  const double after_u = unguided.mean_distance_to(track), after_g = guided.mean_distance_to(track);
  EXPECT_LT(after_u, before * 0.85);  // it learns
  EXPECT_NE(after_g, after_u);
  // With full credit for the force (force_credit 1, use_rate 0) the moved and the unmoved
  // hand teach the same; with none, the move is taken for the plan's own.
  LearnerModel full = m;
  full.force_credit = 1;
  full.use_rate = 0;
  LearnerModel none = full;
  none.force_credit = 0;
  LearnedPath a = LearnedPath::prior(track, 2, full, 3), b = a, c = a;
  a.learn(trace_moved_by(track, a, 0, full.grip_N_per_m), full);
  b.learn(trace_moved_by(track, b, 0.3e-3, full.grip_N_per_m), full);
  c.learn(trace_moved_by(track, c, 0.3e-3, none.grip_N_per_m), none);
  EXPECT_NEAR(a.mean_distance_to(track), b.mean_distance_to(track), 1e-9);
  EXPECT_NE(c.mean_distance_to(track), a.mean_distance_to(track));
}

TEST(Learner, LargeErrorsAreLearnedLessInProportion) {
  const haptics::ExpertTrack track = line_track();
  LearnerModel m = LearnerModel::novice();
  m.prior_blur_s = 0;
  m.use_rate = 0;
  m.retention = 1;
  for (double off : {0.3, 3.0}) {
    m.prior_offset_mm = off;
    LearnedPath p = LearnedPath::prior(track, 2, m, 5);
    const double before = p.mean_distance_to(track);
    p.learn(trace_moved_by(track, p, 0, m.grip_N_per_m), m);
    const double frac = 1 - p.mean_distance_to(track) / before;
    // error_rate * half / (half + |e|): ~0.4 * 0.5 / 0.8 at 0.3 mm, ~0.4 * 0.5 / 3.5 at 3 mm.
    if (off < 1)
      EXPECT_GT(frac, 0.15) << off;
    else
      EXPECT_LT(frac, 0.1) << off;
    EXPECT_GT(frac, 0.0) << off;
  }
}

TEST(Learner, ForgetsTowardThePriorWithoutPractice) {
  const haptics::ExpertTrack track = line_track();
  LearnerModel m = LearnerModel::novice();
  m.prior_blur_s = 0;
  LearnedPath p = LearnedPath::prior(track, 2, m, 7);
  const double before = p.mean_distance_to(track);
  for (int i = 0; i < 5; ++i) p.learn(trace_moved_by(track, p, 0, m.grip_N_per_m), m);
  const double learnt = p.mean_distance_to(track);
  EXPECT_LT(learnt, before * 0.7);
  for (int i = 0; i < 30; ++i) p.learn({}, m);  // no practice: only forgetting
  EXPECT_GT(p.mean_distance_to(track), learnt + 0.5 * (before - learnt));
}

TEST(Learner, BadParametersAreNamed) {
  LearnerModel m;
  m.force_credit = 1.5;
  EXPECT_NE(m.validate().find("force_credit"), std::string::npos);
  m = LearnerModel::skilled();
  m.error_rate = 0.8;
  m.use_rate = 0.4;
  EXPECT_NE(m.validate().find("error_rate + use_rate"), std::string::npos);
  LearningOptions o;
  o.repetitions = 0;
  EXPECT_NE(o.validate().find("repetitions"), std::string::npos);
  EXPECT_FALSE(parse_condition("guided").ok());
  EXPECT_NE(parse_condition("guided").error().find("as_needed"), std::string::npos);
  ASSERT_TRUE(parse_condition("across_path").ok());
  auto r = run_learning_curve(Lesson{}, m, GuidanceCondition::kNone, 1,
                              LearningOptions{});  // checked first
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("use_rate"), std::string::npos);
}

// Short seeded curves through the engine: the first `seconds` of the generated expert's
// lesson, one novice (seed 2).
LearningCurve curve(GuidanceCondition c, int reps = 5, double seconds = 5) {
  LearningOptions o;
  o.repetitions = reps;
  o.seconds = seconds;
  auto r = run_learning_curve(shared_lesson(), LearnerModel::novice(), c, 2, o);
  EXPECT_TRUE(r.ok()) << r.error();
  return r.ok() ? *r : LearningCurve{};
}

TEST(Learner, LearnsWithoutGuidanceAndTheFixedFieldsAdvantageDoesNotCarryOver) {
  const LearningCurve none = curve(GuidanceCondition::kNone);
  const LearningCurve fixed = curve(GuidanceCondition::kFixed);
  ASSERT_EQ(none.reps.size(), 5u);
  ASSERT_EQ(fixed.reps.size(), 5u);
  std::printf(
      "none: train %.3f -> %.3f mm, memory %.3f mm, retention %.3f mm (before %.3f); fixed: train "
      "%.3f -> %.3f mm, "
      "memory %.3f mm, retention %.3f mm\n",
      none.reps.front().train_mean_m * 1e3, none.reps.back().train_mean_m * 1e3,
      none.reps.back().memory_m * 1e3, none.retention_mean_m * 1e3, none.before_mean_m * 1e3,
      fixed.reps.front().train_mean_m * 1e3, fixed.reps.back().train_mean_m * 1e3,
      fixed.reps.back().memory_m * 1e3, fixed.retention_mean_m * 1e3);
  // Without guidance the training error falls over the repetitions, the memory approaches
  // the path at every repetition, and the unguided retention test (expert hidden) after
  // training beats the one before.
  EXPECT_LT(none.reps.back().train_mean_m, 0.9 * none.reps.front().train_mean_m);
  EXPECT_LT(none.retention_mean_m, 0.8 * none.before_mean_m);
  for (std::size_t k = 1; k < none.reps.size(); ++k)
    EXPECT_LT(none.reps[k].memory_m, none.reps[k - 1].memory_m) << k;
  // The same learner and noise (common seeds) from the same start.
  EXPECT_EQ(none.before_mean_m, fixed.before_mean_m);
  // The guidance hypothesis as the model gives it (docs/learner_model.md): the fixed field
  // lowers the error during training at every repetition by a fifth or more...
  for (std::size_t k = 0; k < 5; ++k)
    EXPECT_LT(fixed.reps[k].train_mean_m, 0.8 * none.reps[k].train_mean_m) << k;
  // ...but that advantage does not carry over: what is learned (the memory) and the
  // unguided retention error are no better than after training without guidance (within
  // 0.02 and 0.05 mm, against a training advantage of several tenths of a millimetre).
  EXPECT_GT(fixed.reps.back().memory_m, none.reps.back().memory_m - 0.02e-3);
  EXPECT_GT(fixed.retention_mean_m, none.retention_mean_m - 0.05e-3);
}

TEST(Learner, TheSameSeedGivesTheSameCurve) {
  const LearningCurve a = curve(GuidanceCondition::kAsNeeded, 1, 3),
                      b = curve(GuidanceCondition::kAsNeeded, 1, 3);
  ASSERT_EQ(a.reps.size(), 1u);
  ASSERT_EQ(b.reps.size(), 1u);
  EXPECT_EQ(a.reps[0].train_mean_m, b.reps[0].train_mean_m);
  EXPECT_EQ(a.reps[0].memory_m, b.reps[0].memory_m);
  EXPECT_EQ(a.retention_mean_m, b.retention_mean_m);
  EXPECT_GT(a.reps[0].mean_force_N, 0.0);  // the field worked
}

}  // namespace
}  // namespace dentar::training
