// Generated sessions for the feedback property tests (issue 25): per-step
// student and expert statistics drawn across the whole range a trainer
// meets (expert-like, novice-like, no force, force the other way, tiny or
// zero SDs, one or two expert sessions, too few frames, mirror views or
// none), seeded and deterministic. Shared by the default subset
// (feedback_property_test) and the long run (feedback_property_long_test,
// label "long").
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <map>
#include <random>
#include <string>

#include "dentar/training/feedback.h"

namespace dentar::training::test {

struct GeneratedSession {
  ProcessMetrics student;
  ExpertReference ref;
  double excessive_force_N = 3;
};

inline GeneratedSession generate_session(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> g(0, 1);
  auto pick = [&](std::initializer_list<double> v) { return *(v.begin() + static_cast<long>(rng() % v.size())); };
  GeneratedSession c;
  c.excessive_force_N = pick({0.5, 1.0, 3.0, 3.0});
  const int steps = 1 + static_cast<int>(rng() % 6);
  c.ref.sessions = static_cast<int>(pick({0, 1, 2, 3, 5, 10}));
  c.student.mirror_tracked = u(rng) < 0.5;
  for (int k = 0; k < steps; ++k) {
    StepReference e;
    e.name = "step " + std::to_string(k + 1);
    e.sessions = static_cast<int>(pick({0, 1, 2, 3, 3, 5, 10}));
    const int main = static_cast<int>(rng() % 3);
    for (int a = 0; a < 3; ++a) {
      const double scale = a == main ? pick({0.0, 0.01, 0.1, 0.5, 1.0, 2.0, 4.0}) : pick({0.0, 0.02, 0.1, 0.3});
      e.force_mean(a) = (u(rng) < 0.5 ? -1 : 1) * scale * (0.5 + u(rng));
      e.force_sd(a) = pick({0.0, 0.001, 0.05, 0.2}) * (0.5 + u(rng));
      e.tip_mean_mm(a) = 3 * g(rng);
      e.tip_sd_mm(a) = pick({0.0, 0.1, 0.5});
    }
    e.axis_mean = Eigen::Vector3d(0.2 * g(rng), 0.2 * g(rng), u(rng) < 0.8 ? -1 : 1).normalized();
    e.axis_sd_deg = pick({0.0, 2.0, 10.0});
    e.drilling_mean_s = pick({0.0, 0.5, 5.0, 30.0});
    e.drilling_sd_s = pick({0.0, 0.1, 2.0});
    e.view_sessions = static_cast<int>(pick({0, 1, 3, 5}));
    e.mirror_pct_mean = pick({0.0, 10.0, 60.0, 90.0});
    e.mirror_pct_sd = pick({0.0, 5.0, 20.0});
    e.no_sight_pct_mean = pick({0.0, 5.0, 30.0});
    e.no_sight_pct_sd = pick({0.0, 5.0});
    c.ref.steps.push_back(e);

    StepMetrics s;
    s.name = e.name;
    s.force.n = pick({0.0, 5.0, 10.0, 100.0, 1000.0});
    // The student's force: the experts' scaled by a skill factor (negative:
    // pressing the other way), plus noise; sometimes exactly zero.
    const double f = pick({-1.0, 0.0, 0.02, 0.3, 0.7, 0.95, 1.0, 1.05, 1.5, 3.0, 10.0});
    for (int a = 0; a < 3; ++a)
      s.force.mean(a) = u(rng) < 0.1 ? 0.0 : f * e.force_mean(a) + pick({0.0, 0.01, 0.1, 0.5}) * g(rng);
    s.tip_mean_mm = e.tip_mean_mm + pick({0.0, 0.3, 2.0}) * Eigen::Vector3d(g(rng), g(rng), g(rng));
    const Eigen::Vector3d ax = e.axis_mean + pick({0.0, 0.1, 0.5}) * Eigen::Vector3d(g(rng), g(rng), g(rng));
    s.axis_mean = u(rng) < 0.05 ? Eigen::Vector3d::Zero() : ax.normalized();
    s.drilling_s = std::max(0.0, e.drilling_mean_s * pick({0.0, 1.0, 3.0}) + g(rng));
    for (auto& v : s.views) v = static_cast<int>(rng() % 40) * static_cast<int>(rng() % 2);
    c.student.steps.push_back(s);
  }
  if (u(rng) < 0.2) c.student.steps.resize(rng() % (c.student.steps.size() + 1));  // fewer steps found
  c.ref.duration_mean_s = 100;
  c.ref.path_mean_mm = pick({0.0, 100.0, 500.0});
  c.ref.path_sd_mm = pick({0.0, 10.0});
  c.ref.excessive_mean_s = pick({0.0, 1.0});
  c.ref.excessive_sd_s = pick({0.0, 0.5});
  c.student.path_mm = c.ref.path_mean_mm * pick({0.5, 1.0, 3.0});
  c.student.excessive_force_s = pick({0.0, 0.04, 0.5, 5.0});
  return c;
}

// Runs `n` generated sessions from `seed`; fails the test on the first few
// broken rules and returns how often each rule spoke.
inline std::map<std::string, long> check_generated_sessions(std::uint64_t seed, long n) {
  std::mt19937_64 rng(seed);
  std::map<std::string, long> fired;
  long broken = 0;
  for (long i = 0; i < n; ++i) {
    const GeneratedSession c = generate_session(rng);
    const auto msgs = tutoring_feedback(c.student, c.ref, c.excessive_force_N);
    for (const auto& m : msgs) ++fired[m.rule];
    const auto bad = feedback_violations(c.student, c.ref, c.excessive_force_N, msgs);
    if (!bad.empty() && ++broken <= 5) ADD_FAILURE() << "session " << i << " (seed " << seed << "): " << bad.front();
  }
  EXPECT_EQ(broken, 0) << "of " << n << " generated sessions";
  return fired;
}

}  // namespace dentar::training::test
