// train_model / classify on degenerate input: clear messages, no NaN.
#include "dentar/training/assess.h"

#include <gtest/gtest.h>

#include <cmath>

namespace dentar::training {
namespace {

std::vector<Trial> trials(bool constant_force) {
  std::vector<Trial> t;
  for (int s = 0; s < 4; ++s) {
    Sequence x(50, 2);
    for (int i = 0; i < 50; ++i) {
      x(i, 0) = std::sin(i * 0.3 + s) + (s < 2 ? 0.0 : 2.0);
      x(i, 1) = constant_force ? 1.5 : std::cos(i * 0.2 * (s + 1));
    }
    t.push_back({"S" + std::to_string(s), s < 2 ? "expert" : "novice", "trial" + std::to_string(s), 1, x});
  }
  return t;
}

TEST(Assess, ConstantFeatureIsRejectedByName) {
  for (Method m : {Method::kDiscreteHmm, Method::kGaussianHmm, Method::kDtw}) {
    AssessOptions o;
    o.method = m;
    o.states = 2;
    o.symbols = 3;
    auto r = train_model(trials(true), {"position", "force_z"}, o);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().find("'force_z' is constant"), std::string::npos) << r.error();
  }
}

TEST(Assess, NanInATrainingTrialOrAtClassificationIsRejectedWithItsPlace) {
  auto t = trials(false);
  t[2].x(7, 1) = std::nan("");
  AssessOptions o;
  o.states = 2;
  o.symbols = 3;
  auto r = train_model(t, {"position", "force_z"}, o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("trial2: row 7, feature 'force_z'"), std::string::npos) << r.error();
  auto good = train_model(trials(false), {"position", "force_z"}, o);
  ASSERT_TRUE(good.ok()) << good.error();
  Sequence x = trials(false)[0].x;
  x(3, 0) = std::numeric_limits<double>::infinity();
  auto v = classify(*good, x);
  ASSERT_FALSE(v.ok());
  EXPECT_NE(v.error().find("row 3, feature 'position'"), std::string::npos) << v.error();
  auto ok = classify(*good, trials(false)[3].x);
  ASSERT_TRUE(ok.ok());
  for (double s : ok->score) EXPECT_TRUE(std::isfinite(s));
}

TEST(Assess, OneLabelOnlyAndBadOptionsAreErrors) {
  auto t = trials(false);
  for (auto& x : t) x.label = "expert";
  auto r = train_model(t, {}, AssessOptions{});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("at least two skill labels"), std::string::npos);
  AssessOptions o;
  o.states = 0;
  EXPECT_FALSE(train_model(trials(false), {}, o).ok());
  auto two = trials(false);
  two.resize(2);
  auto cv = cross_validate_subjects(two, {}, AssessOptions{});
  ASSERT_FALSE(cv.ok());
  EXPECT_NE(cv.error().find("at least 3 subjects"), std::string::npos);
}

}  // namespace
}  // namespace dentar::training
