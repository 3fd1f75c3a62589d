// The cohort generator is a function of its seed: the same options give
// byte-identical session logs, run after run (issue 25, session 12). Before,
// the session log writer cut its blocks by wall time, so two runs wrote the
// same records in differently sized blocks and the files differed.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <string>

#include "dentar/haptics/replay.h"
#include "dentar/haptics/session_log.h"
#include "dentar/training/cohort.h"
#include "dentar/training/session.h"
#include "testutil.h"

namespace dentar::training {
namespace {

TEST(CohortDeterminism, TheSameSeedGivesByteIdenticalSessionLogs) {
  auto ex = load_builtin_exercise("molar_class1_cavity");
  ASSERT_TRUE(ex.ok()) << ex.error();
  CohortOptions o;
  o.experts = 1;
  o.novices = 1;
  o.trials = 1;
  o.voxel_mm = 0.3;
  o.bur_samples = 200;
  o.seed = 12;
  const std::filesystem::path a = dentar::test::temp_dir("determinism_a");
  const std::filesystem::path b = dentar::test::temp_dir("determinism_b");
  auto ta = generate_cohort(*ex, o, a.string());
  ASSERT_TRUE(ta.ok()) << ta.error();
  auto tb = generate_cohort(*ex, o, b.string());
  ASSERT_TRUE(tb.ok()) << tb.error();
  ASSERT_EQ(ta->size(), 2u);
  ASSERT_EQ(tb->size(), 2u);
  for (std::size_t i = 0; i < ta->size(); ++i) {
    const std::string pa = (*ta)[i].session_path, pb = (*tb)[i].session_path;
    auto la = haptics::read_session_log(pa);
    auto lb = haptics::read_session_log(pb);
    ASSERT_TRUE(la.ok()) << la.error();
    ASSERT_TRUE(lb.ok()) << lb.error();
    EXPECT_EQ(la->dropped, 0u) << pa;
    EXPECT_EQ(lb->dropped, 0u) << pb;
    EXPECT_GT(la->records.size(), 10000u) << pa;  // a real session, not an empty file
    // The records first (the content), then the bytes (the blocks around it).
    ASSERT_EQ(la->records.size(), lb->records.size()) << pa << " against " << pb;
    std::size_t differing = 0;
    for (std::size_t r = 0; r < la->records.size(); ++r)
      differing += std::memcmp(&la->records[r], &lb->records[r], sizeof(haptics::StepRecord)) != 0;
    EXPECT_EQ(differing, 0u) << pa << " against " << pb;
    EXPECT_EQ(la->header_json, lb->header_json);
    const std::string fa = dentar::test::read_file(pa), fb = dentar::test::read_file(pb);
    ASSERT_FALSE(fa.empty()) << pa;
    EXPECT_EQ(fa.size(), fb.size()) << pa << " (" << la->good_blocks << " blocks) against " << pb << " ("
                                    << lb->good_blocks << " blocks)";
    EXPECT_TRUE(fa == fb) << pa << " and " << pb << " differ in their bytes";
  }
}

// CohortOptions::on_session hands over the tooth as the generator's engine left it; the score
// rank bench scores that instead of replaying each session's log (issue 25, session 17: the
// replay was half a session's CPU time). It must be the replay's cut, voxel for voxel.
TEST(CohortDeterminism, TheEngineLeavesTheCutAReplayOfItsLogGives) {
  auto ex = load_builtin_exercise("molar_class1_cavity");
  ASSERT_TRUE(ex.ok()) << ex.error();
  CohortOptions o;
  o.experts = 1;
  o.novices = 1;
  o.trials = 1;
  o.voxel_mm = 0.3;
  o.bur_samples = 200;
  o.seed = 17;
  std::vector<std::pair<std::string, volume::VoxelVolume>> left;
  o.on_session = [&left](const CohortTrial& t, const volume::VoxelVolume& v) { left.emplace_back(t.session_path, v.clone()); };
  const std::filesystem::path dir = dentar::test::temp_dir("engine_cut");
  auto trials = generate_cohort(*ex, o, dir.string());
  ASSERT_TRUE(trials.ok()) << trials.error();
  ASSERT_EQ(trials->size(), 2u);
  ASSERT_EQ(left.size(), 2u);  // once per session, in order
  for (std::size_t i = 0; i < left.size(); ++i) {
    ASSERT_EQ(left[i].first, (*trials)[i].session_path);
    auto log = haptics::read_session_log(left[i].first);
    ASSERT_TRUE(log.ok()) << log.error();
    auto setup = haptics::parse_session_header(log->header_json);
    ASSERT_TRUE(setup.ok()) << setup.error();
    auto start = make_tooth(setup->tooth_json);
    ASSERT_TRUE(start.ok()) << start.error();
    volume::VoxelVolume replayed = start->clone();
    auto r = haptics::replay_session(*log, replayed);
    ASSERT_TRUE(r.ok()) << r.error();
    const volume::VoxelVolume& engine = left[i].second;
    ASSERT_EQ(engine.dims(), replayed.dims());
    const auto d = engine.dims();
    std::size_t cut = 0, differ = 0;
    for (int k = 0; k < d.z(); ++k)
      for (int j = 0; j < d.y(); ++j)
        for (int q = 0; q < d.x(); ++q) {
          cut += replayed.density(q, j, k) != start->density(q, j, k);
          differ += engine.density(q, j, k) != replayed.density(q, j, k) || engine.material(q, j, k) != replayed.material(q, j, k);
        }
    EXPECT_GT(cut, 50u) << left[i].first << ": the session cut (almost) nothing";
    EXPECT_EQ(differ, 0u) << left[i].first << ": " << differ << " voxels differ between the engine's tooth and the replay's";
  }
}

}  // namespace
}  // namespace dentar::training
