// The cohort generator's scripts prepare the exercise: generated experts
// score high on the outcome, novices clearly lower (the seed: experts 14.4,
// novices 8.4 of 16), without forbidden-zone damage by experts.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <iostream>

#include "dentar/haptics/replay.h"
#include "dentar/haptics/session_log.h"
#include "dentar/training/cohort.h"
#include "dentar/training/outcome.h"
#include "testutil.h"

namespace dentar::training {
namespace {

struct Scored {
  std::string label;
  OutcomeScores o;
};

std::vector<Scored> generate_and_score(const std::string& exercise, int experts, int novices, double voxel_mm,
                                       std::uint64_t seed) {
  auto ex = load_builtin_exercise(exercise);
  EXPECT_TRUE(ex.ok()) << ex.error();
  CohortOptions o;
  o.experts = experts;
  o.novices = novices;
  o.trials = 1;
  o.voxel_mm = voxel_mm;
  o.bur_samples = 500;
  o.seed = seed;
  const std::string dir =
      dentar::test::temp_dir("cohort_outcome_" + exercise).string();
  std::filesystem::remove_all(dir);
  auto trials = generate_cohort(*ex, o, dir);
  EXPECT_TRUE(trials.ok()) << trials.error();
  std::vector<Scored> out;
  if (!trials.ok()) return out;
  for (const auto& t : *trials) {
    auto log = haptics::read_session_log(t.session_path);
    EXPECT_TRUE(log.ok()) << log.error();
    auto setup = haptics::parse_session_header(log->header_json);
    EXPECT_TRUE(setup.ok()) << setup.error();
    auto start = make_tooth(setup->tooth_json);
    EXPECT_TRUE(start.ok()) << start.error();
    volume::VoxelVolume cut = start->clone();
    auto rep = haptics::replay_session(*log, cut);
    EXPECT_TRUE(rep.ok()) << rep.error();
    auto masks = build_masks(*ex, *start);
    EXPECT_TRUE(masks.ok()) << masks.error();
    auto sc = score_outcome(*ex, *masks, *start, cut);
    EXPECT_TRUE(sc.ok()) << sc.error();
    std::cout << exercise << " " << t.subject << ": " << sc->points << " / " << sc->max_points << " points, coverage "
              << sc->target_coverage_pct << " %, over-prep " << sc->overprep_mm3 << " mm3, forbidden "
              << sc->forbidden_mm3 << " mm3, session " << log->records.size() * 1e-3 << " s\n";
    for (const auto& c : sc->criteria) std::cout << "    " << c.name << ": " << c.score << " (" << c.detail << ")\n";
    out.push_back({t.label, *sc});
  }
  std::filesystem::remove_all(dir);
  return out;
}

void expect_gap(const std::vector<Scored>& s, double expert_min_frac, double gap_frac) {
  double e = 0, n = 0, ne = 0, nn = 0, maxp = 0;
  for (const auto& x : s) {
    maxp = x.o.max_points;
    if (x.label == "expert") {
      e += x.o.points;
      ne += 1;
      EXPECT_LT(x.o.forbidden_mm3, 0.5) << "an expert cut into a forbidden region";
    } else {
      n += x.o.points;
      nn += 1;
    }
  }
  ASSERT_GT(ne, 0);
  ASSERT_GT(nn, 0);
  e /= ne;
  n /= nn;
  EXPECT_GE(e, expert_min_frac * maxp) << "expert mean " << e << " of " << maxp;
  EXPECT_GE(e - n, gap_frac * maxp) << "expert mean " << e << ", novice mean " << n;
}

TEST(CohortOutcome, MolarAccessOpeningExpertsScoreHighNovicesLower) {
  // Generator v4 measured experts 18 and 18, novices 11 and 15 of 18; v5 (the finishing pass
  // along the walls, issue 25 session 16) 17.7 and 16.8, novices 13.2 and 8.1.
  expect_gap(generate_and_score("molar_access_opening", 2, 2, 0.2, 5), 0.85, 0.15);
}

TEST(CohortOutcome, IncisorPartialCrownExpertsScoreHighNovicesLower) {
  // Generator v4 measured 11.9 vs 6.3 of 16, v5 12.1 vs 7.0 (the seed: 14.4 vs 8.4;
  // docs/BENCHMARKS.md).
  expect_gap(generate_and_score("incisor_partial_crown", 1, 1, 0.2, 5), 0.6, 0.2);
}

}  // namespace
}  // namespace dentar::training
