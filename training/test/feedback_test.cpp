#include "dentar/training/feedback.h"

#include <gtest/gtest.h>

namespace dentar::training {
namespace {

ProcessMetrics student(const Eigen::Vector3d& force) {
  ProcessMetrics p;
  StepMetrics s;
  s.name = "palatal orifice";
  s.force.n = 100;
  s.force.mean = force;
  s.tip_mean_mm = Eigen::Vector3d(0, 1.3, 2.0);
  s.axis_mean = Eigen::Vector3d(0, 0, -1);
  s.drilling_s = 3.0;
  p.steps.push_back(s);
  return p;
}

ExpertReference reference(double fz_mean, double fz_sd) {
  ExpertReference r;
  r.sessions = 5;
  StepReference s;
  s.name = "palatal orifice";
  s.sessions = 5;
  s.force_mean = Eigen::Vector3d(0.05, 0.0, fz_mean);
  s.force_sd = Eigen::Vector3d(0.05, 0.05, fz_sd);
  s.tip_mean_mm = Eigen::Vector3d(0, 1.3, 2.0);
  s.tip_sd_mm = Eigen::Vector3d(0.1, 0.1, 0.1);
  s.axis_mean = Eigen::Vector3d(0, 0, -1);
  s.axis_sd_deg = 2;
  s.drilling_mean_s = 3.0;
  s.drilling_sd_s = 0.5;
  r.steps.push_back(s);
  r.path_mean_mm = 100;
  r.path_sd_mm = 10;
  return r;
}

TEST(Feedback, TooLittleForceGivesTheMultiplierAlongTheMainDirection) {
  auto m = tutoring_feedback(student({0.0, 0.0, -0.5}), reference(-1.0, 0.1), 3.0);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].kind, "instruct");
  EXPECT_NE(m[0].text.find("force in minus Z (toward apical) should be 2.0 times higher"), std::string::npos) << m[0].text;
  EXPECT_NE(m[0].text.find("Step 1 (palatal orifice)"), std::string::npos);
}

TEST(Feedback, WithinOneSdIsWellDone) {
  auto m = tutoring_feedback(student({0.0, 0.0, -0.95}), reference(-1.0, 0.1), 3.0);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].kind, "well_done");
  EXPECT_NE(m[0].text.find("well done"), std::string::npos);
}

TEST(Feedback, RightMainForceWithLargeOffAxisForceAsks) {
  auto m = tutoring_feedback(student({0.0, 0.6, -1.0}), reference(-1.0, 0.1), 3.0);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].kind, "ask");
  EXPECT_NE(m[0].text.find("do you know that minus Z (toward apical) should be the main direction of force in this stage?"),
            std::string::npos) << m[0].text;
  EXPECT_NE(m[0].text.find("plus Y (toward lingual)"), std::string::npos) << m[0].text;
}

TEST(Feedback, MultiplierIsCappedWhereMoreForceCouldDamageTheTooth) {
  auto m = tutoring_feedback(student({0.0, 0.0, -0.5}), reference(-2.0, 0.1), 1.0);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_NE(m[0].text.find("2.0 times higher"), std::string::npos) << m[0].text;  // 4x capped at 1.0 N / 0.5 N
  EXPECT_NE(m[0].text.find("raise it gradually, up to 1.00 N at most this time"), std::string::npos) << m[0].text;
  auto too_much = tutoring_feedback(student({0.0, 0.0, -2.0}), reference(-1.0, 0.1), 3.0);
  ASSERT_EQ(too_much.size(), 1u);
  EXPECT_NE(too_much[0].text.find("2.0 times lower"), std::string::npos) << too_much[0].text;
}

TEST(Feedback, ReferenceRoundTripsAndIsBuiltFromExperts) {
  ProcessMetrics a = student({0, 0, -1.0}), b = student({0, 0, -1.2});
  a.path_mm = 90;
  b.path_mm = 110;
  const ExpertReference r = build_reference("x", {a, b});
  EXPECT_NEAR(r.steps[0].force_mean.z(), -1.1, 1e-12);
  EXPECT_NEAR(r.steps[0].force_sd.z(), std::sqrt(0.02), 1e-12);
  EXPECT_NEAR(r.path_mean_mm, 100, 1e-12);
  auto back = reference_from_json(reference_to_json(r), "ref.json");
  ASSERT_TRUE(back.ok()) << back.error();
  EXPECT_NEAR(back->steps[0].force_sd.z(), r.steps[0].force_sd.z(), 1e-9);
  EXPECT_FALSE(reference_from_json("{}", "ref.json").ok());
}

// Mirror use: a student's views of one step (drilling frames per class:
// direct, mirror, both, none) against experts whose views were measured.
ProcessMetrics viewer(std::array<int, 4> views) {
  ProcessMetrics p = student({0.0, 0.0, -1.0});  // force right: only the mirror is judged
  p.mirror_tracked = true;
  p.steps[0].views = views;
  return p;
}

ExpertReference mirror_reference(std::vector<std::array<int, 4>> expert_views) {
  std::vector<ProcessMetrics> ex;
  for (const auto& v : expert_views) ex.push_back(viewer(v));
  ExpertReference r = build_reference("x", ex);
  r.path_mean_mm = 100;
  r.path_sd_mm = 10;
  return r;
}

std::vector<FeedbackMessage> mirror_messages(const std::vector<FeedbackMessage>& all) {
  std::vector<FeedbackMessage> m;
  for (const auto& x : all)
    if (x.text.find("mirror") != std::string::npos || x.text.find("could not see") != std::string::npos) m.push_back(x);
  return m;
}

TEST(Feedback, MirrorStepSeenDirectlyIsToldToUseTheMirror) {
  // Experts see the palatal site in the mirror in 80, 90 and 100 % of their drilling frames.
  const ExpertReference r = mirror_reference({{20, 80, 0, 0}, {10, 70, 20, 0}, {0, 100, 0, 0}});
  ASSERT_EQ(r.steps[0].view_sessions, 3);
  EXPECT_NEAR(r.steps[0].mirror_pct_mean, 90.0, 1e-9);
  EXPECT_NEAR(r.steps[0].mirror_pct_sd, 10.0, 1e-9);
  // The student looked straight at it (bending) in 70 %, mirror in 30 %.
  auto m = mirror_messages(tutoring_feedback(viewer({70, 30, 0, 0}), r, 3.0));
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].kind, "instruct");
  EXPECT_NE(m[0].text.find("use the mirror for this step: you saw the site in the mirror in 30 %"), std::string::npos)
      << m[0].text;
  EXPECT_NE(m[0].text.find("experts 90 +/- 10 %"), std::string::npos) << m[0].text;
  EXPECT_NE(m[0].text.find("directly in 70 %"), std::string::npos) << m[0].text;
  // Working blind instead: the same advice names that.
  auto blind = mirror_messages(tutoring_feedback(viewer({10, 20, 0, 70}), r, 3.0));
  ASSERT_EQ(blind.size(), 1u);
  EXPECT_NE(blind[0].text.find("without sight of it in 70 %"), std::string::npos) << blind[0].text;
  // Within one SD of the experts (85 % >= 90 - 10): well done.
  auto good = mirror_messages(tutoring_feedback(viewer({15, 60, 25, 0}), r, 3.0));
  ASSERT_EQ(good.size(), 1u);
  EXPECT_EQ(good[0].kind, "well_done");
  EXPECT_NE(good[0].text.find("well done: you worked in the mirror in 85 %"), std::string::npos) << good[0].text;
}

TEST(Feedback, DirectViewStepGetsNoMirrorAdviceUnlessWorkingBlind) {
  // Experts see this site directly (mirror 0-10 %).
  const ExpertReference r = mirror_reference({{100, 0, 0, 0}, {90, 0, 10, 0}, {95, 0, 0, 5}});
  EXPECT_TRUE(mirror_messages(tutoring_feedback(viewer({100, 0, 0, 0}), r, 3.0)).empty());
  auto blind = mirror_messages(tutoring_feedback(viewer({50, 0, 0, 50}), r, 3.0));
  ASSERT_EQ(blind.size(), 1u);
  EXPECT_EQ(blind[0].kind, "caution");
  EXPECT_NE(blind[0].text.find("could not see the site in 50 %"), std::string::npos) << blind[0].text;
}

TEST(Feedback, NoMirrorAdviceWithoutViews) {
  // Experts without measured views (a generated reference), or a student
  // session without camera frames, or too few classified frames: nothing.
  ExpertReference gen = reference(-1.0, 0.1);
  EXPECT_EQ(gen.steps[0].view_sessions, 0);
  EXPECT_TRUE(mirror_messages(tutoring_feedback(viewer({70, 30, 0, 0}), gen, 3.0)).empty());
  const ExpertReference r = mirror_reference({{0, 100, 0, 0}, {0, 90, 0, 10}, {0, 95, 0, 5}});
  ProcessMetrics no_cam = viewer({70, 30, 0, 0});
  no_cam.mirror_tracked = false;
  EXPECT_TRUE(mirror_messages(tutoring_feedback(no_cam, r, 3.0)).empty());
  EXPECT_TRUE(mirror_messages(tutoring_feedback(viewer({5, 2, 0, 0}), r, 3.0)).empty());
  // The reference keeps the expert views through JSON.
  auto back = reference_from_json(reference_to_json(r), "ref.json");
  ASSERT_TRUE(back.ok()) << back.error();
  EXPECT_EQ(back->steps[0].view_sessions, 3);
  EXPECT_NEAR(back->steps[0].mirror_pct_mean, r.steps[0].mirror_pct_mean, 1e-9);
  EXPECT_NEAR(back->steps[0].no_sight_pct_sd, r.steps[0].no_sight_pct_sd, 1e-9);
}

}  // namespace
}  // namespace dentar::training
