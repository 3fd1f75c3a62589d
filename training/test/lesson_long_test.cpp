// Long (label "long", off by default): every built-in exercise's generated expert lesson,
// every mode for 5 s of the expert, each session replayed bit-exactly. The default suite runs
// the same code on one exercise (lesson_test.cpp).
#include <gtest/gtest.h>

#include <filesystem>

#include "dentar/haptics/replay.h"
#include "dentar/haptics/session_log.h"
#include "dentar/training/exercise.h"
#include "dentar/training/lesson.h"
#include "dentar/training/lesson_run.h"
#include "testutil.h"

namespace dentar::training {
namespace {

namespace fs = std::filesystem;

TEST(LessonLong, EveryModeRunsOnEveryBuiltinLessonAndReplays) {
  const fs::path d = test::temp_dir("lesson_long");
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(builtin_exercise_dir()))
    if (e.path().extension() == ".json") names.push_back(e.path().stem().string());
  ASSERT_GE(names.size(), 3u);
  for (const std::string& n : names) {
    SCOPED_TRACE(n);
    auto l = make_generated_lesson(n, (d / n).string(), 1);
    ASSERT_TRUE(l.ok()) << l.error();
    for (int mode = 1; mode <= 5; ++mode) {
      SCOPED_TRACE(mode);
      LessonRunOptions o;
      o.mode = mode;
      o.seconds = 5;
      o.out_dir = (d / (n + "_m" + std::to_string(mode))).string();
      auto r = run_lesson(*l, o);
      ASSERT_TRUE(r.ok()) << r.error();
      EXPECT_GE(r->expert_end_s, 5.0 - 1e-9);
      EXPECT_EQ(r->drill_mismatch, 0u);
      auto log = haptics::read_session_log(r->session_path);
      ASSERT_TRUE(log.ok()) << log.error();
      auto vol = make_tooth(l->tooth_json);
      ASSERT_TRUE(vol.ok()) << vol.error();
      auto rep = haptics::replay_session(*log, *vol);
      ASSERT_TRUE(rep.ok()) << rep.error();
      EXPECT_EQ(rep->volume_hash, r->volume_hash);
      fs::remove_all(o.out_dir);
    }
  }
}

}  // namespace
}  // namespace dentar::training
