// The learning-curve benchmark's main finding for the novice learner model, at the
// benchmark's own size (docs/BENCHMARKS.md, issue 27 session 15: the first 10 s of the
// generated expert's lesson, 10 repetitions), on seeds 1-3: about 40 s of CPU, so it carries
// the label "training_long" (off by default). The default suite's learner_test runs a short
// seeded subset.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include "dentar/training/learner.h"
#include "testutil.h"

namespace dentar::training {
namespace {

namespace fs = std::filesystem;

TEST(LearnerLong, NoviceFixedFieldHelpsInTrainingHurtsInRetentionAndFadingRecovers) {
  const fs::path d = test::temp_dir("learner_long");
  auto lesson = make_generated_lesson("molar_class1_cavity", (d / "lesson").string(), 1);
  ASSERT_TRUE(lesson.ok()) << lesson.error();
  LearningOptions o;
  o.repetitions = 10;
  o.seconds = 10;
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    auto none =
        run_learning_curve(*lesson, LearnerModel::novice(), GuidanceCondition::kNone, seed, o);
    auto fixed =
        run_learning_curve(*lesson, LearnerModel::novice(), GuidanceCondition::kFixed, seed, o);
    auto fading =
        run_learning_curve(*lesson, LearnerModel::novice(), GuidanceCondition::kFading, seed, o);
    ASSERT_TRUE(none.ok() && fixed.ok() && fading.ok());
    std::printf(
        "seed %llu: retention none %.4f, fixed %.4f, fading %.4f mm (before %.4f); training rep 10 "
        "none %.3f, fixed %.3f mm\n",
        static_cast<unsigned long long>(seed), none->retention_mean_m * 1e3,
        fixed->retention_mean_m * 1e3, fading->retention_mean_m * 1e3, none->before_mean_m * 1e3,
        none->reps.back().train_mean_m * 1e3, fixed->reps.back().train_mean_m * 1e3);
    EXPECT_LT(none->retention_mean_m, 0.6 * none->before_mean_m) << seed;
    EXPECT_LT(fixed->reps.back().train_mean_m, 0.8 * none->reps.back().train_mean_m) << seed;
    EXPECT_GT(fixed->retention_mean_m, none->retention_mean_m) << seed;
    EXPECT_LT(fading->retention_mean_m, fixed->retention_mean_m) << seed;
  }
}

}  // namespace
}  // namespace dentar::training
