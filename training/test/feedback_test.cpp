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
  EXPECT_NE(m[0].text.find("could damage the tooth"), std::string::npos) << m[0].text;
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

}  // namespace
}  // namespace dentar::training
