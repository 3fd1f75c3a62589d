// Lessons and the training modes offline with a simulated student (issue 27): the lesson
// file (make, read back, bad input), each mode on a generated expert's lesson, safety at a
// mode's start on every device profile, the pen's fallback, and bit-exact replay.
#include "dentar/training/lesson.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "dentar/haptics/device_profiles.h"
#include "dentar/haptics/replay.h"
#include "dentar/haptics/session_log.h"
#include "dentar/training/exercise.h"
#include "dentar/training/lesson_run.h"
#include "testutil.h"

namespace dentar::training {
namespace {

namespace fs = std::filesystem;

// One generated expert lesson (molar class I cavity, 35 s) for the whole process.
const Lesson& shared_lesson() {
  static const Lesson l = [] {
    const fs::path d = test::temp_dir("lesson_shared");
    auto r = make_generated_lesson("molar_class1_cavity", (d / "lesson").string(), 1);
    EXPECT_TRUE(r.ok()) << r.error();
    return r.ok() ? *r : Lesson{};
  }();
  return l;
}

void expect_has(const std::string& s, const std::string& what) {
  EXPECT_NE(s.find(what), std::string::npos) << "message: " << s << "\nexpected to contain: " << what;
}

LessonRunResult run(int mode, const LessonRunOptions& base = {}) {
  LessonRunOptions o = base;
  o.mode = mode;
  auto r = run_lesson(shared_lesson(), o);
  EXPECT_TRUE(r.ok()) << r.error();
  return r.ok() ? *r : LessonRunResult{};
}

TEST(LessonFile, MakeReadBackAndShow) {
  const Lesson& g = shared_lesson();
  ASSERT_FALSE(g.path.empty());
  EXPECT_EQ(g.exercise, "molar_class1_cavity");
  EXPECT_GT(g.duration_s, 10.0);
  // The generated expert's steps became text annotations, in order.
  ASSERT_GE(g.annotations.size(), 2u);
  expect_has(g.annotations.front().text, "Step 1: ");
  // A lesson made from that recording with notes and pauses at times and at steps.
  const fs::path d = test::temp_dir("lesson_make");
  LessonMakeOptions o;
  o.exercise = "molar_class1_cavity";
  o.annotations.push_back(*parse_annotation_arg("5.5:keep the bur upright", false, "--note"));
  o.annotations.push_back(*parse_annotation_arg("@3000", true, "--pause"));
  auto l = make_lesson(g.path, (d / "mine").string(), o);  // a folder: not a session.dlog folder
  ASSERT_FALSE(l.ok());
  expect_has(l.error(), "holds no session.dlog");
  // Left by a killed `lesson make` (no such process): removed. Another live process's: kept.
  fs::create_directories(d / "mine.part999999999");
  fs::create_directories(d / ("mine.part" + std::to_string(::getppid())));
  fs::create_directories(d / "mine.partial_notes");
  l = make_lesson(g.recording_path(), (d / "mine").string(), o);
  ASSERT_TRUE(l.ok()) << l.error();
  EXPECT_FALSE(fs::exists(d / "mine.part999999999"));
  EXPECT_TRUE(fs::exists(d / ("mine.part" + std::to_string(::getppid()))));
  EXPECT_TRUE(fs::exists(d / "mine.partial_notes"));
  auto back = load_lesson((d / "mine").string());
  ASSERT_TRUE(back.ok()) << back.error();
  EXPECT_EQ(back->recording_hash, g.recording_hash);
  ASSERT_EQ(back->annotations.size(), 2u) << "no steps.json beside a lesson's recording";
  // Sorted by time; the step annotation resolved to the recording's time of step 3000.
  EXPECT_EQ(back->annotations[0].step, 3000);
  EXPECT_NEAR(back->annotations[0].time_s, 3.0, 2e-3);
  EXPECT_EQ(back->annotations[0].pause_s, 2.0);
  EXPECT_EQ(back->annotations[1].text, "keep the bur upright");
  const std::string text = describe_lesson(*back);
  expect_has(text, "keep the bur upright");
  expect_has(text, "[pause 2.0 s]");
  expect_has(text, "eps1 0.50 mm");
  // The file round-trips.
  auto again = parse_lesson(lesson_json(*back), "x.json");
  ASSERT_TRUE(again.ok()) << again.error();
  EXPECT_EQ(lesson_json(*again), lesson_json(*back));
}

TEST(LessonFile, BadInputNamesTheFileAndField) {
  const Lesson& g = shared_lesson();
  ASSERT_FALSE(g.path.empty());
  const fs::path d = test::temp_dir("lesson_bad");
  const std::string good = test::read_file(fs::path(g.path) / kLessonFile);
  // A copy of the lesson to break, one fault at a time.
  auto copy = [&](const std::string& name, const std::string& json_text) {
    const fs::path p = d / name;
    fs::create_directories(p);
    fs::copy_file(g.recording_path(), p / kLessonRecording);
    test::write_file(p / kLessonFile, json_text);
    return p;
  };
  auto replace = [](std::string s, const std::string& from, const std::string& to) {
    const auto at = s.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return at == std::string::npos ? s : s.replace(at, from.size(), to);
  };
  {  // The recording missing.
    const fs::path p = copy("missing", good);
    fs::remove(p / kLessonRecording);
    auto l = load_lesson(p.string());
    ASSERT_FALSE(l.ok());
    expect_has(l.error(), (p / kLessonFile).string() + ": recording.file: ");
    expect_has(l.error(), "no such recording");
  }
  {  // The recording truncated (a corrupt tail).
    const fs::path p = copy("corrupt", good);
    fs::resize_file(p / kLessonRecording, fs::file_size(p / kLessonRecording) - 5000);
    auto l = load_lesson(p.string());
    ASSERT_FALSE(l.ok());
    expect_has(l.error(), "recording.file: ");
    expect_has(l.error(), "damaged");
  }
  {  // Another recording than the lesson was made from.
    char h[17];
    std::snprintf(h, sizeof h, "%016llx", static_cast<unsigned long long>(g.recording_hash ^ 1));
    char h0[17];
    std::snprintf(h0, sizeof h0, "%016llx", static_cast<unsigned long long>(g.recording_hash));
    auto l = load_lesson(copy("hash", replace(good, h0, h)).string());
    ASSERT_FALSE(l.ok());
    expect_has(l.error(), "recording.hash: ");
    expect_has(l.error(), "make the lesson again");
  }
  {  // An unknown exercise, and a lesson for another tooth.
    auto l = load_lesson(copy("unknown", replace(good, "\"molar_class1_cavity\"", "\"molar_class9\"")).string());
    ASSERT_FALSE(l.ok());
    expect_has(l.error(), "exercise: no built-in exercise 'molar_class9' (built-in: ");
    l = load_lesson(copy("incisor", replace(good, "\"molar_class1_cavity\"", "\"incisor_partial_crown\"")).string());
    ASSERT_FALSE(l.ok());
    expect_has(l.error(), "exercise: 'incisor_partial_crown' is for tooth kind 'incisor', the lesson's recording is of a 'molar'");
  }
  {  // A truncated lesson.json.
    auto l = load_lesson(copy("truncated", good.substr(0, good.size() / 2)).string());
    ASSERT_FALSE(l.ok());
    expect_has(l.error(), "lesson.json: not valid JSON");
  }
  // Field errors from the parser (no recording needed).
  auto parse_error = [&](const std::string& text) {
    auto l = parse_lesson(text, "L.json");
    EXPECT_FALSE(l.ok());
    return l.ok() ? std::string() : l.error();
  };
  expect_has(parse_error(replace(good, "\"eps1_mm\": 0.5", "\"eps1_mm\": 12.0")),
             "L.json: modes: eps2 = 10 mm must be greater than eps1 = 12 mm");
  expect_has(parse_error(replace(good, "\"eps_mm\": 2.0", "\"eps_mm\": -1.0")), "L.json: modes: follow tolerance eps = -1 mm");
  expect_has(parse_error(replace(good, "\"k_N_per_m\": 150.0", "\"k_N_per_m\": \"stiff\"")),
             "L.json: modes.guidance.k_N_per_m must be a number");
  expect_has(parse_error(replace(good, "\"annotations\": [", "\"annotations\": [{\"time_s\": 1e6, \"text\": \"late\"},")),
             "L.json: annotations[0].time_s = 1000000.0 s is past the end of the recording");
  expect_has(parse_error(replace(good, "\"annotations\": [", "\"annotations\": [{\"time_s\": 1, \"step\": 3, \"text\": \"x\"},")),
             "annotations[0]. needs exactly one of time_s and step");
  expect_has(parse_error(replace(good, "\"version\": 1", "\"version\": 7")), "L.json: version 7.0 is not supported");
  // A step annotation past the end is found when the recording is read.
  {
    auto l = load_lesson(copy("late_step", replace(good, "\"annotations\": [", "\"annotations\": [{\"step\": 99999999, \"text\": \"late\"},")).string());
    ASSERT_FALSE(l.ok());
    expect_has(l.error(), "annotations[0].step = 99999999 is not in the recording");
  }
  // make: a refused lesson leaves nothing behind (no folder, no .part folder).
  LessonMakeOptions o;
  o.exercise = "incisor_partial_crown";
  auto m = make_lesson(g.recording_path(), (d / "made").string(), o);
  ASSERT_FALSE(m.ok());
  expect_has(m.error(), "the recording is of tooth kind 'molar'");
  o.exercise = "molar_class1_cavity";
  o.annotations.push_back(*parse_annotation_arg("1e5:too late", false, "--note"));
  m = make_lesson(g.recording_path(), (d / "made").string(), o);
  ASSERT_FALSE(m.ok());
  expect_has(m.error(), "annotation 1 at 100000.0 s is outside the recording");
  o.annotations = {*parse_annotation_arg("@99999999:too late", false, "--note")};
  m = make_lesson(g.recording_path(), (d / "made").string(), o);
  ASSERT_FALSE(m.ok());
  expect_has(m.error(), "is not in the recording");
  for (const auto& e : fs::directory_iterator(d)) EXPECT_EQ(e.path().filename().string().find("made"), std::string::npos) << e.path();
  // An existing folder is refused.
  LessonMakeOptions plain;
  plain.exercise = "molar_class1_cavity";
  m = make_lesson(g.recording_path(), g.path, plain);
  ASSERT_FALSE(m.ok());
  expect_has(m.error(), "already exists");
  // Arguments.
  EXPECT_FALSE(parse_annotation_arg("x:y", false, "--note").ok());
  expect_has(parse_annotation_arg("3:-1", true, "--pause").error(), "--pause '3:-1': the pause must be in (0, 600] s");
  LessonRunOptions bad;
  bad.mode = 6;
  expect_has(bad.validate(), "--mode 6 must be 1..5");
  bad.mode = 2;
  bad.device = "phantom9";
  auto r = run_lesson(g, bad);
  ASSERT_FALSE(r.ok());
  expect_has(r.error(), "--device 'phantom9' is not a device profile");
}

// builtin:NAME makes the generated lesson in the cache once and reuses it; an unknown
// exercise is refused.
TEST(LessonFile, BuiltinLessonsAreMadeInTheCacheOnFirstUse) {
  const fs::path cache = test::temp_dir("lesson_cache");
  ::setenv("DENTAR_CACHE_DIR", cache.c_str(), 1);
  auto p = resolve_lesson_path("builtin:molar_class1_cavity");
  ASSERT_TRUE(p.ok()) << p.error();
  EXPECT_EQ(fs::path(*p).parent_path().parent_path(), cache / "lessons");
  auto l = load_lesson(*p);
  ASSERT_TRUE(l.ok()) << l.error();
  const auto when = fs::last_write_time(fs::path(*p) / kLessonFile);
  auto again = resolve_lesson_path("builtin:molar_class1_cavity");
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(*again, *p);
  EXPECT_EQ(fs::last_write_time(fs::path(*p) / kLessonFile), when) << "reused, not made again";
  auto bad = resolve_lesson_path("builtin:molar_class9");
  ASSERT_FALSE(bad.ok());
  expect_has(bad.error(), "builtin:molar_class9: --exercise: no built-in exercise 'molar_class9'");
  EXPECT_EQ(*resolve_lesson_path("some/folder"), "some/folder");
  ::unsetenv("DENTAR_CACHE_DIR");
}

// Mode 2 pulls a passive (relaxed, lagging, noisy) hand along the expert's path: within
// 0.6 mm on average and 1.2 mm at p95, where the same hand unguided (mode 1) trails by
// several times that.
TEST(LessonModes, PassiveGuidancePullsAPassiveHandAlongThePath) {
  LessonRunOptions o;
  o.student = StudentModel::passive_hand();
  o.student.seed = 3;
  o.seconds = 8;
  const LessonRunResult g = run(2, o), free = run(1, o);
  std::printf("mode 2: mean %.3f p95 %.3f mm; unguided: mean %.3f p95 %.3f mm\n", g.follow_mean_m * 1e3,
              g.follow_p95_m * 1e3, free.follow_mean_m * 1e3, free.follow_p95_m * 1e3);
  EXPECT_LT(g.follow_mean_m, 0.6e-3);
  EXPECT_LT(g.follow_p95_m, 1.2e-3);
  EXPECT_GT(free.follow_mean_m, 2 * g.follow_mean_m);
  EXPECT_EQ(g.stats.watchdog_trips, 0u);
}

// Mode 3: the expert waits while the student strays (6 mm off for 1 s) and resumes without a
// jump: no step moves the expert's tool further than its recording moves in one step, and
// the force on the stylus stays zero.
TEST(LessonModes, ConditionalReplayWaitsForAStrayingStudentWithoutAJump) {
  LessonRunOptions o;
  o.student.seed = 5;
  o.student.stray_at_s = 3.0;
  o.student.stray_s = 1.0;
  o.student.stray_mm = 6.0;
  o.seconds = 7;
  const LessonRunResult r = run(3, o);
  EXPECT_GT(r.waited_s, 0.8);
  EXPECT_LT(r.waited_s, 1.6) << "the expert waits about as long as the student is away";
  EXPECT_GE(r.expert_end_s, 7.0 - 1e-9) << "and resumes to the end";
  EXPECT_LE(r.max_expert_jump_m, r.fastest_recorded_step_m + 1e-9);
  EXPECT_GT(r.max_expert_jump_m, 0.0);
  EXPECT_EQ(r.max_force_N, 0.0);
  // Without straying it does not wait (the student follows within the tolerance).
  LessonRunOptions calm = o;
  calm.student.stray_at_s = -1;
  EXPECT_LT(run(3, calm).waited_s, 0.05);
}

// Mode 4 renders minus the recorded force, exactly, once faded in.
TEST(LessonModes, ForceReversalRendersMinusTheRecording) {
  LessonRunOptions o;
  o.seconds = 8;
  const LessonRunResult r = run(4, o);
  EXPECT_GT(r.reversal_checked, 5000u);
  EXPECT_LT(r.reversal_error_N, 1e-9);
  EXPECT_GT(r.max_force_N, 0.3) << "the generated expert presses with about 1 N";
}

// Mode 5: the expert-drilling flag (the colour change) is on exactly while the recording
// drills, and the student drills as usual.
TEST(LessonModes, HintsFlagIsOnExactlyWhileTheRecordingDrills) {
  LessonRunOptions o;
  o.seconds = 10;
  const LessonRunResult r = run(5, o);
  EXPECT_GT(r.drill_steps, 1000u);
  EXPECT_EQ(r.drill_mismatch, 0u);
  EXPECT_GT(r.removed_mm3, 0.0) << "the student's bur cuts in hints mode";
}

// Safety: no kick when a mode starts, on every device profile, with 2 ms of jitter: mode 2's
// first step sends under 2 % of what its field asks (k x the 1 mm start offset), and no step
// in the first 0.3 s changes the force by more than 10 % of it.
TEST(LessonModes, NoKickAtModeStartOnEveryProfile) {
  for (const auto& prof : haptics::device_profiles()) {
    SCOPED_TRACE(prof.id);
    LessonRunOptions o;
    o.device = prof.id;
    o.jitter_s = 2e-3;
    o.seconds = 0.6;
    const LessonRunResult r = run(2, o);
    EXPECT_GT(r.start_field_N, 0.05);
    EXPECT_LE(r.first_force_N, 0.02 * r.start_field_N);
    EXPECT_LE(r.start_max_step_N, 0.1 * r.start_field_N);
    EXPECT_LE(r.max_force_N, prof.max_force_N + 1e-9) << "the device clamp";
    EXPECT_EQ(r.stats.watchdog_trips, 0u);
  }
}

// The generated expert presses nothing at its first step, so mode 4 cannot kick at its
// start; a pause point while it presses is the hard case: the reversed force fades out and
// back in (no step changes |f| by more than 10 % of the force at the pause), on every
// profile with 2 ms of jitter, and stays within the device clamp.
TEST(LessonModes, NoKickWhenForceReversalPausesOnEveryProfile) {
  Lesson l = shared_lesson();
  ASSERT_FALSE(l.path.empty());
  // The pause 0.2 s after the expert first presses with 0.5 N.
  auto log = haptics::read_session_log(l.recording_path());
  ASSERT_TRUE(log.ok()) << log.error();
  auto setup = haptics::parse_session_header(log->header_json);
  ASSERT_TRUE(setup.ok()) << setup.error();
  auto track = haptics::ExpertTrack::from_records(log->records, setup->engine.T_tooth_dev, setup->engine.T_sty_tip, "x");
  ASSERT_TRUE(track.ok()) << track.error();
  double press = 0;
  while (press < track->duration_s() && track->at(press).force_N.norm() < 0.5) press += 0.01;
  ASSERT_LT(press, 10.0);
  Annotation pause;
  pause.time_s = press + 0.2;
  pause.pause_s = 0.4;
  l.annotations.insert(l.annotations.begin(), pause);
  for (const auto& prof : haptics::device_profiles()) {
    SCOPED_TRACE(prof.id);
    LessonRunOptions o;
    o.mode = 4;
    o.device = prof.id;
    o.jitter_s = 2e-3;
    o.seconds = pause.time_s + 0.4;
    auto r = run_lesson(l, o);
    ASSERT_TRUE(r.ok()) << r.error();
    EXPECT_EQ(r->pauses_taken, 1);
    EXPECT_GT(r->pause_field_N, 0.3);
    EXPECT_LE(r->pause_max_step_N, 0.1 * r->pause_field_N);
    EXPECT_LE(r->max_force_N, prof.max_force_N + 1e-9);
  }
}

// A device with no force (the pen stylus) falls back to visual guidance and says so.
TEST(LessonModes, ThePenFallsBackToVisualGuidance) {
  for (int mode : {2, 4}) {
    LessonRunOptions o;
    o.device = "pen";
    o.seconds = 2;
    const LessonRunResult r = run(mode, o);
    EXPECT_EQ(r.mode_asked, mode);
    EXPECT_EQ(r.mode_run, 3);
    expect_has(r.fallback, "the pen stylus renders no force");
    expect_has(r.fallback, "falls back to visual guidance");
    EXPECT_EQ(r.max_force_N, 0.0);
  }
  LessonRunOptions o;
  o.device = "pen";
  o.seconds = 1;
  EXPECT_TRUE(run(5, o).fallback.empty()) << "hints need no force";
}

// Every session is recorded with its training section and replays bit-exactly, including a
// lesson's pause point (held through the recorded stylus button).
TEST(LessonModes, RecordedSessionWithAPauseReplaysBitExactly) {
  const Lesson& g = shared_lesson();
  ASSERT_FALSE(g.path.empty());
  Lesson l = g;
  Annotation pause;
  pause.time_s = 2.0;
  pause.pause_s = 0.5;
  pause.text = "look at the entry";
  l.annotations.insert(l.annotations.begin(), pause);
  const fs::path d = test::temp_dir("lesson_replay");
  for (int mode : {2, 3}) {
    SCOPED_TRACE(mode);
    LessonRunOptions o;
    o.mode = mode;
    o.seconds = 9;
    o.student.seed = 7;
    o.out_dir = (d / ("m" + std::to_string(mode))).string();
    auto r = run_lesson(l, o);
    ASSERT_TRUE(r.ok()) << r.error();
    EXPECT_EQ(r->pauses_taken, 1);
    EXPECT_TRUE(fs::exists(fs::path(o.out_dir) / "run.json"));
    auto log = haptics::read_session_log(r->session_path);
    ASSERT_TRUE(log.ok()) << log.error();
    EXPECT_TRUE(log->warning.empty()) << log->warning;
    EXPECT_EQ(log->records.size(), r->steps);
    auto setup = haptics::parse_session_header(log->header_json);
    ASSERT_TRUE(setup.ok()) << setup.error();
    ASSERT_TRUE(setup->training.has_value());
    EXPECT_EQ(static_cast<int>(setup->training->params.mode), mode);
    auto vol = make_tooth(l.tooth_json);
    ASSERT_TRUE(vol.ok());
    auto rep = haptics::replay_session(*log, *vol);
    ASSERT_TRUE(rep.ok()) << rep.error();
    EXPECT_EQ(rep->volume_hash, r->volume_hash);
    EXPECT_EQ(rep->max_force_difference_N, 0.0);
    EXPECT_GT(r->removed_mm3, 0.0) << "the expert's bur cut";
  }
}

}  // namespace
}  // namespace dentar::training
