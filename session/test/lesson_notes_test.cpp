// A replay of a lesson's session finds the lesson's notes (issue 27): LessonClock::from_header
// reads lesson.json beside the expert's recording, so `dentar offline` of the session draws
// them beside the tooth; a recording outside a lesson has none, a damaged lesson.json is
// named in notes() (a warning of the run), and the replay still runs.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "dentar/session/lesson_clock.h"
#include "dentar/training/lesson.h"
#include "testutil.h"

namespace dentar::session {
namespace {

namespace fs = std::filesystem;

TEST(LessonNotes, ActiveNoteFollowsTheExpertsClock) {
  std::vector<training::Annotation> a(3);
  a[0].time_s = 1.0, a[0].text = "one";
  a[1].time_s = 2.0, a[1].pause_s = 3;  // a bare pause: never on show
  a[2].time_s = 4.0, a[2].text = "two";
  EXPECT_EQ(training::active_note(a, 0.5), -1);
  EXPECT_EQ(training::active_note(a, 1.0), 0);
  EXPECT_EQ(training::active_note(a, 3.9), 0);
  EXPECT_EQ(training::active_note(a, 4.0), 2);  // the newer note replaces the older
  EXPECT_EQ(training::active_note(a, 8.9), 2);
  EXPECT_EQ(training::active_note(a, 9.0), -1);  // kNoteShowS after it
  EXPECT_EQ(training::active_note(a, 1.5, 0.4), -1);
  EXPECT_EQ(training::active_note({}, 1.0), -1);
}

TEST(LessonNotes, ReplayFindsTheLessonBesideTheRecording) {
  const fs::path d = test::temp_dir("lesson_notes");
  auto l = training::make_generated_lesson("molar_class1_cavity", (d / "lesson").string(), 1);
  ASSERT_TRUE(l.ok()) << l.error();
  ASSERT_FALSE(l->annotations.empty());
  haptics::TrainingSetup t;
  t.params = l->params;
  t.params.mode = haptics::TrainingModeKind::kActiveFollowing;
  t.params.expert_file = l->recording_path();
  t.expert_hash = l->recording_hash;
  auto c = LessonClock::from_header(t);
  ASSERT_TRUE(c.ok()) << c.error();
  EXPECT_EQ((*c)->lesson().annotations.size(), l->annotations.size());
  EXPECT_EQ((*c)->lesson().annotations.front().text, l->annotations.front().text);
  EXPECT_TRUE((*c)->notes().empty());

  // The recording alone (no lesson.json beside it): no notes, nothing to warn about.
  fs::create_directories(d / "alone");
  fs::copy_file(l->recording_path(), d / "alone" / training::kLessonRecording);
  t.params.expert_file = (d / "alone" / training::kLessonRecording).string();
  c = LessonClock::from_header(t);
  ASSERT_TRUE(c.ok()) << c.error();
  EXPECT_TRUE((*c)->lesson().annotations.empty());
  EXPECT_TRUE((*c)->notes().empty());

  // A damaged lesson.json beside it: the replay runs, without notes, and says why.
  std::ofstream(d / "alone" / training::kLessonFile) << "{ not json";
  c = LessonClock::from_header(t);
  ASSERT_TRUE(c.ok()) << c.error();
  EXPECT_TRUE((*c)->lesson().annotations.empty());
  ASSERT_EQ((*c)->notes().size(), 1u);
  EXPECT_NE((*c)->notes()[0].find("the lesson's notes are not shown"), std::string::npos)
      << (*c)->notes()[0];
  EXPECT_NE((*c)->notes()[0].find("lesson.json"), std::string::npos) << (*c)->notes()[0];
}

}  // namespace
}  // namespace dentar::session
