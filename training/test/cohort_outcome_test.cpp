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
  // The tooth each session's engine left: what a replay of its log gives
  // (CohortDeterminism.TheEngineLeavesTheCutAReplayOfItsLogGives), without cutting it twice.
  std::vector<volume::VoxelVolume> left;
  o.on_session = [&left](const CohortTrial&, const volume::VoxelVolume& v) { left.push_back(v.clone()); };
  auto trials = generate_cohort(*ex, o, dir);
  EXPECT_TRUE(trials.ok()) << trials.error();
  std::vector<Scored> out;
  if (!trials.ok()) return out;
  EXPECT_EQ(left.size(), trials->size());
  if (left.size() != trials->size()) return out;
  for (std::size_t i = 0; i < trials->size(); ++i) {
    const CohortTrial& t = (*trials)[i];
    auto log = haptics::read_session_log(t.session_path);
    EXPECT_TRUE(log.ok()) << log.error();
    auto setup = haptics::parse_session_header(log->header_json);
    EXPECT_TRUE(setup.ok()) << setup.error();
    auto start = make_tooth(setup->tooth_json);
    EXPECT_TRUE(start.ok()) << start.error();
    const volume::VoxelVolume& cut = left[i];
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
  // along the walls, issue 25 session 16) 17.7 and 16.8, novices 13.2 and 8.1; v6 (session 18:
  // the adult pulp, the access 2.35 mm deeper) 16.4 and 17.3, novices 4.9 and 7.5; session 19's
  // scoring (walls only where cut, the floor paid for the share reached: the experts reach 72 and
  // 88 % of it) 15.8 and 17.2, novices 2.8 and 5.4. The bounds (15.3 of 18, a 2.7 gap) hold.
  // Session 23, measured with overlap_cut on (not the default: docs/BENCHMARKS.md): experts 17.1
  // and 17.5, novices 1.3 and 4.5 (the sample cutter on the same scripts: 15.9 and 17.3, 1.5 and 5.0).
  expect_gap(generate_and_score("molar_access_opening", 2, 2, 0.2, 5), 0.85, 0.15);
}

TEST(CohortOutcome, IncisorPartialCrownExpertsScoreHighNovicesLower) {
  // Generator v4 measured 11.9 vs 6.3 of 16, v5 12.1 vs 7.0 (the seed: 14.4 vs 8.4;
  // docs/BENCHMARKS.md); with overlap_cut on (session 23, not the default) 12.35 vs 7.00 (the
  // sample cutter on the same scripts: 12.09 vs 6.97).
  expect_gap(generate_and_score("incisor_partial_crown", 1, 1, 0.2, 5), 0.6, 0.2);
}

// Issue 25's benchmark in small: the total ranks sessions by their generated skill (Spearman rho
// against skill), the score rank bench's cohort shape (five skill levels from the expert's to the
// full novice's, each its own seed) with two people a level, at 0.2 mm voxels. The bench's
// figure (docs/BENCHMARKS.md, "Issue 25 session 17") is 15 people on six seeds at 0.15 mm: class I
// 0.842 +- 0.056. Measured here on seeds 1-4 at 0.2 mm before choosing: 0.840, 0.714, 0.790,
// 0.972; seed 1 (the tuning seed, not the best; 0.840) is asserted at 0.70, the lowest of the four
// less a margin. On the old tooth what mis-ranked here was a skill-0.75 person nicking the pulp
// (-4.2) below a skill-0.5 person who stopped early (6.5, INCOMPLETE): the old model's pulp horns
// stood 0.15-0.3 mm beside the cavity's walls at its floor. Session 18 made the molar's pulp an
// adult's by default (roof 0.8 mm above the cervical line): no session of this cohort reaches the
// pulp and seed 1 ranks at 0.960 (was 0.840; the pulp-uncharged figure it printed). The bound is
// kept at 0.70: seeds 2-4 were not re-measured on the adult tooth at this size. Session 23, with
// overlap_cut on (not the default): seed 1 still 0.960.
TEST(CohortOutcome, ClassICavityTotalsRankASeededSmallCohortBySkill) {
  auto ex = load_builtin_exercise("molar_class1_cavity");
  ASSERT_TRUE(ex.ok()) << ex.error();
  const int levels = 5;
  std::vector<double> skill, total, uncharged;
  for (int l = 0; l < levels; ++l) {
    CohortOptions o;
    o.experts = 0;
    o.novices = 2;
    o.trials = 1;
    o.separation = static_cast<double>(l) / (levels - 1);
    o.voxel_mm = 0.2;
    o.bur_samples = 500;
    o.seed = 1 * 1000 + static_cast<std::uint64_t>(l);  // the bench's --seed 1
    std::vector<volume::VoxelVolume> left;
    o.on_session = [&left](const CohortTrial&, const volume::VoxelVolume& v) { left.push_back(v.clone()); };
    const std::string dir = dentar::test::temp_dir("cohort_rank_" + std::to_string(l)).string();
    auto trials = generate_cohort(*ex, o, dir);
    ASSERT_TRUE(trials.ok()) << trials.error();
    ASSERT_EQ(left.size(), trials->size());
    auto start = make_tooth([&] {
      auto log = haptics::read_session_log((*trials)[0].session_path);
      EXPECT_TRUE(log.ok()) << log.error();
      auto setup = haptics::parse_session_header(log->header_json);
      EXPECT_TRUE(setup.ok()) << setup.error();
      return setup->tooth_json;
    }());
    ASSERT_TRUE(start.ok()) << start.error();
    auto masks = build_masks(*ex, *start);
    ASSERT_TRUE(masks.ok()) << masks.error();
    for (const auto& cut : left) {
      auto sc = score_outcome(*ex, *masks, *start, cut);
      ASSERT_TRUE(sc.ok()) << sc.error();
      double pulp = 0;
      for (const auto& p : sc->penalties)
        if (p.name == "pulp exposure") pulp += p.points;
      std::cout << "class I skill " << 1.0 - o.separation << ": " << sc->headline() << ", pulp exposure -" << pulp << "\n";
      skill.push_back(1.0 - o.separation);
      total.push_back(sc->points);
      uncharged.push_back(std::min(sc->earned_points, sc->points + pulp));
    }
    std::filesystem::remove_all(dir);
  }
  const double rho = spearman_rho(total, skill), rho_uncharged = spearman_rho(uncharged, skill);
  std::cout << "class I rho " << rho << " (pulp exposure uncharged: " << rho_uncharged << ")\n";
  EXPECT_GE(rho, 0.70) << "the class I totals no longer rank a seeded cohort by skill";
  // Both experts above both full novices, and nothing above the experts.
  for (std::size_t i = 0; i < total.size(); ++i) {
    if (skill[i] != 1.0) continue;
    for (std::size_t j = 0; j < total.size(); ++j) {
      if (skill[j] == 0.0) {
        EXPECT_GT(total[i], total[j] + 3.0) << "expert " << i << " against novice " << j;
      }
      if (skill[j] < 1.0) {
        EXPECT_GE(total[i], total[j]) << "expert " << i << " against skill " << skill[j];
      }
    }
  }
}

}  // namespace
}  // namespace dentar::training
