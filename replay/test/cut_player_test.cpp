// The cut at any time, recomputed from the raw tool states (cut_player.h): at the end it is
// bit-identical to haptics::replay_session (volume content hash), whatever way the player
// got there (one seek, many small seeks while playing, a seek back and forward again), and
// a time in the middle gives the same volume by each way. Plus the recording's steps and
// bad input of open_recording. One generated expert lesson (molar class I cavity).
#include "dentar/replay/cut_player.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "dentar/haptics/replay.h"
#include "dentar/replay/recording.h"
#include "dentar/training/lesson.h"
#include "testutil.h"

namespace dentar::replay {
namespace {

namespace fs = std::filesystem;

const Recording& rec() {
  static const Recording r = [] {
    // The fixture's lesson (replay/CMakeLists.txt) when ctest made it, else one made here.
    fs::path lesson = DENTAR_REPLAY_TEST_LESSON;
    if (!fs::exists(lesson / "lesson.json")) {
      lesson = test::temp_dir("cut_player") / "lesson";
      auto l = training::make_generated_lesson("molar_class1_cavity", lesson.string(), 1);
      EXPECT_TRUE(l.ok()) << l.error();
    }
    auto x = open_recording(lesson.string());
    EXPECT_TRUE(x.ok()) << x.error();
    return x.ok() ? std::move(x).value() : Recording{};
  }();
  return r;
}

std::uint64_t hash_at(CutPlayer& p, double t) {
  auto s = p.seek(t);
  EXPECT_TRUE(s.ok()) << s.error();
  return p.volume().content_hash();
}

void check_steps(const Recording& r);

TEST(CutPlayer, EndsBitIdenticalToTheReplayAndSeeksAgreeStepsFound) {
  const Recording& r = rec();
  ASSERT_TRUE(r.log);
  volume::VoxelVolume v = r.start->clone();
  auto rep = haptics::replay_session(*r.log, v);
  ASSERT_TRUE(rep.ok()) << rep.error();
  auto p = CutPlayer::create(r);
  ASSERT_TRUE(p.ok()) << p.error();
  CutPlayer& cp = **p;
  const std::uint64_t start = cp.volume().content_hash();
  // Playing: small steps forward to the middle.
  const double mid = 0.5 * r.duration_s;
  for (double t = 0; t < mid; t += 0.37) (void)hash_at(cp, t);
  const std::uint64_t mid_played = hash_at(cp, mid);
  EXPECT_NE(mid_played, start) << "the bur has cut by the middle";
  EXPECT_EQ(hash_at(cp, r.duration_s), rep->volume_hash) << "at the end: bit-identical to replay_session";
  EXPECT_EQ(cp.steps_done(), r.log->records.size());
  // Back to the middle (a restart), then one jump to the end.
  EXPECT_EQ(hash_at(cp, mid), mid_played);
  EXPECT_EQ(hash_at(cp, 1e9), rep->volume_hash) << "clamped to the end";
  EXPECT_EQ(hash_at(cp, 0), hash_at(cp, -5)) << "clamped to the start";
  // The bur at the recorded pose of the step shown, in the tooth.
  (void)hash_at(cp, mid);
  const Eigen::Vector3d tip = cp.T_tooth_tip().translation();
  EXPECT_LT(tip.norm(), 0.05) << "the tip is near the tooth, tooth frame (m)";
  check_steps(r);
}

// The recording's steps, annotations and times (called from the test above: ctest runs each
// test in a process of its own, and the lesson is made once per process).
void check_steps(const Recording& r) {
  ASSERT_TRUE(r.is_lesson);
  EXPECT_EQ(r.exercise.name, "molar_class1_cavity");
  EXPECT_FALSE(r.annotations.empty());
  ASSERT_FALSE(r.steps.empty());
  EXPECT_DOUBLE_EQ(r.steps.front().start_s, 0.0);
  for (std::size_t i = 1; i < r.steps.size(); ++i) {
    EXPECT_DOUBLE_EQ(r.steps[i].start_s, r.steps[i - 1].end_s);
    EXPECT_NE(r.steps[i].index, r.steps[i - 1].index);
  }
  EXPECT_NEAR(r.steps.back().end_s, r.duration_s, 1e-9);
  EXPECT_EQ(r.track.size(), r.log->records.size() / 10);
  EXPECT_EQ(r.record_at(0), 0u);
  EXPECT_EQ(r.record_at(r.duration_s), r.log->records.size() - 1);
  EXPECT_EQ(r.step_at(-1), -1);
}

TEST(Recording, BadInputNamesTheFile) {
  const fs::path d = test::temp_dir("recording_bad");
  auto x = open_recording((d / "nope").string());
  ASSERT_FALSE(x.ok());
  EXPECT_NE(x.error().find((d / "nope").string() + ": no such file or folder"), std::string::npos) << x.error();
  fs::create_directories(d / "empty");
  x = open_recording((d / "empty").string());
  ASSERT_FALSE(x.ok());
  EXPECT_NE(x.error().find("a folder without session.dlog or lesson.json"), std::string::npos) << x.error();
  test::write_file(d / "junk.dlog", std::string(300, 'x'));
  x = open_recording((d / "junk.dlog").string());
  ASSERT_FALSE(x.ok());
  EXPECT_NE(x.error().find((d / "junk.dlog").string()), std::string::npos) << x.error();
  x = open_recording("builtin:no_such_exercise");
  ASSERT_FALSE(x.ok());
  EXPECT_NE(x.error().find("builtin:no_such_exercise"), std::string::npos) << x.error();
  // (An exercise for another tooth: replay_xvfb_test's bad input, on a real lesson.)
  // A log damaged after its header plays what was kept, and says so.
  const fs::path rec_path = fs::path(DENTAR_REPLAY_TEST_LESSON) / "expert.dlog";
  if (fs::exists(rec_path)) {
    const std::string bytes = test::read_file(rec_path);
    test::write_file(d / "cut.dlog", bytes.substr(0, bytes.size() / 3));
    auto t = open_recording((d / "cut.dlog").string());
    ASSERT_TRUE(t.ok()) << t.error();
    EXPECT_NE(t->warning.find((d / "cut.dlog").string() + ": byte offset "), std::string::npos) << t->warning;
    EXPECT_GT(t->duration_s, 1.0);
  }
}

// --against: a recording of another tooth, voxel size or exercise is refused, naming both.
TEST(Recording, AgainstNeedsTheSameToothAndExercise) {
  Recording a, b;
  a.input = "student.dlog";
  b.input = "lesson_b";
  a.setup.tooth_json = R"({"kind":"molar","voxel_mm":0.15})";
  a.exercise.name = b.exercise.name = "molar_class1_cavity";
  b.setup.tooth_json = a.setup.tooth_json;
  EXPECT_EQ(check_comparable(a, b), "");
  b.setup.tooth_json = R"({"kind":"incisor","voxel_mm":0.15})";
  EXPECT_EQ(check_comparable(a, b),
            "lesson_b is a recording of tooth kind 'incisor', student.dlog of 'molar': --against needs a recording of "
            "the same tooth (a lesson for the molar)");
  b.setup.tooth_json = R"({"kind":"molar","voxel_mm":0.1})";
  EXPECT_NE(check_comparable(a, b).find("the same tooth at the same voxel size"), std::string::npos);
  b.setup.tooth_json = a.setup.tooth_json;
  b.exercise.name = "molar_access_opening";
  EXPECT_NE(check_comparable(a, b).find("lesson_b is for the exercise 'molar_access_opening'"), std::string::npos);
}

}  // namespace
}  // namespace dentar::replay
