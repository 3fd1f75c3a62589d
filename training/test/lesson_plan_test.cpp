// The lesson plan (issue 27): the rules on histories of students of different skill, the
// motor-learning properties they must keep (no error amplification for a novice, guidance
// fades only while the student stays on the path), reading real lesson runs back, plan.json
// and bad input.
#include "dentar/training/lesson_plan.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include "dentar/training/lesson.h"
#include "dentar/training/lesson_run.h"
#include "testutil.h"

namespace dentar::training {
namespace {

namespace fs = std::filesystem;

PastSession sess(int mode, double follow_mm, double score_frac, const std::string& skill = "", int repetition = 0,
                 double amplify = 0) {
  PastSession s;
  s.path = "s";
  s.mode = mode;
  if (follow_mm >= 0) {
    s.has_follow = true;
    s.follow_mean_m = follow_mm * 1e-3;
    s.follow_p95_m = 2 * follow_mm * 1e-3;
  }
  if (score_frac >= 0) {
    s.has_score = true;
    s.points = 18 * score_frac;
    s.max_points = 18;
  }
  s.skill = skill;
  s.guidance.repetition = repetition;
  s.guidance.amplify = amplify;
  return s;
}

void expect_has(const std::string& s, const std::string& what) {
  EXPECT_NE(s.find(what), std::string::npos) << "text: " << s << "\nexpected to contain: " << what;
}

TEST(LessonPlan, FirstSessionWatchesTheExpert) {
  const LessonPlan p = plan_next({});
  EXPECT_EQ(p.mode, 1);
  EXPECT_EQ(p.rule, "first");
  expect_has(p.reason, "mode 1");
}

TEST(LessonPlan, NoviceGetsFullGuidanceThenFadingThenAnUnguidedTrial) {
  // Scored 20 % after plain drilling: full guidance.
  LessonPlan p = plan_next({sess(0, -1, 0.2)});
  EXPECT_EQ(p.level, "novice");
  EXPECT_EQ(p.level_from, "score");
  EXPECT_EQ(p.mode, 2);
  EXPECT_EQ(p.rule, "novice_guidance");
  EXPECT_FALSE(p.guidance.as_needed);
  EXPECT_EQ(p.guidance.repetition, 0);
  EXPECT_EQ(p.guidance.amplify, 0);
  expect_has(p.reason, "20 %");
  // Guided and on the path (0.3 mm <= 0.5 mm): fade and as needed, one repetition more each time.
  std::vector<PastSession> h = {sess(0, -1, 0.2), sess(2, 0.3, 0.95)};  // mode 2's score is the expert's
  for (int rep = 1; rep <= 3; ++rep) {
    p = plan_next(h);
    EXPECT_EQ(p.mode, 2) << "repetition " << rep;
    EXPECT_EQ(p.rule, "novice_fade");
    EXPECT_TRUE(p.guidance.as_needed);
    EXPECT_DOUBLE_EQ(p.guidance.fade, 0.7);
    EXPECT_EQ(p.guidance.repetition, rep);
    expect_has(p.reason, "0.30 mm");
    h.push_back(sess(2, 0.3, 0.95, "", rep));
  }
  // Faded three times and still on the path: an unguided trial (mode 3).
  p = plan_next(h);
  EXPECT_EQ(p.mode, 3);
  EXPECT_EQ(p.rule, "novice_unguided");
  // Strayed in that trial (3 mm > 2 mm): guidance as needed again.
  h.push_back(sess(3, 3.0, 0.3));
  p = plan_next(h);
  EXPECT_EQ(p.mode, 2);
  EXPECT_EQ(p.rule, "novice_back_to_guidance");
  EXPECT_TRUE(p.guidance.as_needed);
  // Off the path (0.8 mm > 0.5 mm) but within 2 mm with guidance faded twice: the same faded
  // guidance (before session 15 it faded back here, which undid every fading step of a novice
  // who never reaches 0.5 mm).
  p = plan_next({sess(0, -1, 0.2), sess(2, 0.8, 0.9, "", 2)});
  EXPECT_EQ(p.rule, "novice_fade_hold");
  EXPECT_EQ(p.mode, 2);
  EXPECT_EQ(p.guidance.repetition, 2);
  EXPECT_TRUE(p.guidance.as_needed);
  // Strayed (2.5 mm > 2 mm) with guidance faded twice: one step less fading.
  p = plan_next({sess(0, -1, 0.2), sess(2, 2.5, 0.9, "", 2)});
  EXPECT_EQ(p.rule, "novice_fade_back");
  EXPECT_EQ(p.guidance.repetition, 1);
  EXPECT_TRUE(p.guidance.as_needed);
  // Off the path under the unfaded field: the full field again.
  p = plan_next({sess(0, -1, 0.2), sess(2, 0.8, 0.9, "", 0)});
  EXPECT_EQ(p.rule, "novice_guidance");
  EXPECT_EQ(p.guidance.repetition, 0);
  EXPECT_FALSE(p.guidance.as_needed);
}

// A novice whose guided error never reaches 0.5 mm (1.2 mm under any guidance, 1.6 mm
// without): before session 15 the plan kept the full field for every repetition. Now an
// unguided check trial comes after every check_every guided sessions, and each check within
// 2 mm fades the guidance one step, until it is faded out.
std::vector<PastSession> script_novice(const PlanOptions& o, int sessions, double guided_mm,
                                       double check_mm, std::vector<LessonPlan>* plans) {
  std::vector<PastSession> h = {sess(0, -1, 0.2)};
  for (int i = 0; i < sessions; ++i) {
    const LessonPlan p = plan_next(h, o);
    plans->push_back(p);
    PastSession s = sess(p.mode, p.mode == 2 ? guided_mm : check_mm, -1);
    s.guidance = p.guidance;
    h.push_back(s);
  }
  return h;
}

TEST(LessonPlan, NoviceOffThePathGetsCheckTrialsAndGuidanceFadesWithPractice) {
  std::vector<LessonPlan> plans;
  script_novice({}, 13, 1.2, 1.6, &plans);
  ASSERT_EQ(plans.size(), 13u);
  std::string rules;
  for (const LessonPlan& p : plans) rules += p.rule + " ";
  SCOPED_TRACE(rules);
  // Full field twice (check_every 2), then the first check trial.
  EXPECT_EQ(plans[0].rule, "novice_guidance");
  EXPECT_EQ(plans[1].rule, "novice_guidance");
  expect_has(plans[1].reason, "check trial after every 2 guided sessions");
  ASSERT_EQ(plans[2].rule, "novice_check");
  EXPECT_EQ(plans[2].mode, 3);
  expect_has(plans[2].reason, "1.20 mm");
  expect_has(plans[2].reason, "2 guided sessions in a row");
  expect_has(plans[2].reason, "unguided check trial");
  // The check's 1.6 mm (within 2 mm) fades the guidance one step; the guided error stays 1.2 mm.
  ASSERT_EQ(plans[3].rule, "novice_fade_practice");
  EXPECT_EQ(plans[3].mode, 2);
  EXPECT_TRUE(plans[3].guidance.as_needed);
  EXPECT_DOUBLE_EQ(plans[3].guidance.fade, 0.7);
  EXPECT_EQ(plans[3].guidance.repetition, 1);
  expect_has(plans[3].reason, "1.60 mm in the unguided check trial");
  expect_has(plans[3].reason, "fades with practice");
  // Held once, checked, faded again: repetition 1, 1, check, 2, 2, check, 3, 3, check.
  EXPECT_EQ(plans[4].rule, "novice_fade_hold");
  EXPECT_EQ(plans[4].guidance.repetition, 1);
  EXPECT_EQ(plans[5].rule, "novice_check");
  EXPECT_EQ(plans[6].guidance.repetition, 2);
  EXPECT_EQ(plans[9].guidance.repetition, 3);
  EXPECT_EQ(plans[11].rule, "novice_check");
  // Faded beyond fade_repetitions (3): no guidance any more.
  const LessonPlan& out = plans[12];
  EXPECT_EQ(out.rule, "novice_follow_again");
  EXPECT_EQ(out.mode, 3);
  expect_has(out.reason, "already faded 3 times");
  // The full field never more than check_every sessions in a row; guided sessions get weaker.
  int run = 0, fixed_run = 0;
  for (const LessonPlan& p : plans) {
    run = p.mode == 2 && !p.guidance.as_needed && p.guidance.repetition == 0 ? run + 1 : 0;
    fixed_run = std::max(fixed_run, run);
  }
  EXPECT_LE(fixed_run, 2);

  // A check that strays (3 mm > 2 mm): guidance as needed again, not faded.
  plans.clear();
  script_novice({}, 4, 1.2, 3.0, &plans);
  EXPECT_EQ(plans[2].rule, "novice_check");
  EXPECT_EQ(plans[3].rule, "novice_back_to_guidance");
  EXPECT_EQ(plans[3].guidance.repetition, 0);
  // A check within 1 mm (close): no guidance next.
  plans.clear();
  script_novice({}, 4, 1.2, 0.8, &plans);
  EXPECT_EQ(plans[3].rule, "novice_follow_again");
  EXPECT_EQ(plans[3].mode, 3);
  expect_has(plans[3].reason, "close");
  // check_every is an option: 4 guided sessions before the first check.
  PlanOptions o;
  o.check_every = 4;
  plans.clear();
  script_novice(o, 5, 1.2, 1.6, &plans);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(plans[i].mode, 2) << i;
  EXPECT_EQ(plans[4].rule, "novice_check");
  expect_has(plans[4].reason, "every 4 guided sessions");
  o.check_every = 0;
  expect_has(o.validate(), "check_every");
}

TEST(LessonPlan, SkilledGetsErrorAmplificationThenAnUnguidedTrial) {
  // A following session's score is the expert's cut: it does not make the student skilled.
  LessonPlan p = plan_next({sess(3, 0.7, 0.9)});
  EXPECT_EQ(p.level, "novice");
  EXPECT_EQ(p.level_from, "no data");
  // The student's own cut (mode 5) scored 90 %, and it follows within 0.7 mm.
  p = plan_next({sess(5, -1, 0.9), sess(3, 0.7, 0.2)});
  EXPECT_EQ(p.level, "skilled");
  EXPECT_EQ(p.mode, 2);
  EXPECT_EQ(p.rule, "skilled_amplify");
  EXPECT_DOUBLE_EQ(p.guidance.amplify, 0.5);
  expect_has(p.reason, "amplification");
  p = plan_next({sess(5, -1, 0.9), sess(3, 0.7, 0.9), sess(2, 1.2, 0.85, "", 0, 0.5)});
  EXPECT_EQ(p.mode, 5);
  EXPECT_EQ(p.rule, "skilled_unguided");
  // A skilled score but far off the expert's path: follow first.
  p = plan_next({sess(0, -1, 0.9), sess(3, 1.5, 0.9)});
  EXPECT_EQ(p.rule, "skilled_follow");
  EXPECT_EQ(p.mode, 3);
}

TEST(LessonPlan, IntermediateFollowsThenFeelsTheForcesThenCuts) {
  LessonPlan p = plan_next({sess(0, -1, 0.6)});
  EXPECT_EQ(p.level, "intermediate");
  EXPECT_EQ(p.mode, 3);
  EXPECT_EQ(p.rule, "intermediate_follow");
  EXPECT_TRUE(p.conditional_replay);
  // Strayed: guidance as needed, across the path only.
  p = plan_next({sess(5, -1, 0.6), sess(3, 2.5, 0.6)});
  EXPECT_EQ(p.mode, 2);
  EXPECT_TRUE(p.guidance.as_needed);
  EXPECT_TRUE(p.guidance.across_path_only);
  // On the path but the cut scores low: the expert's forces (mode 4), then hints (mode 5).
  p = plan_next({sess(5, -1, 0.55), sess(3, 0.8, 0.9)});
  EXPECT_EQ(p.mode, 4);
  expect_has(p.reason, "55 %");
  p = plan_next({sess(5, -1, 0.55), sess(3, 0.8, 0.9), sess(4, 0.9, 0.6)});
  EXPECT_EQ(p.mode, 5);
}

TEST(LessonPlan, AssessmentDecidesTheLevelAndANoviceIsNeverAmplified) {
  // The assessment rates the motion: it outranks a score.
  LessonPlan p = plan_next({sess(3, 0.4, 0.95, "novice")});
  EXPECT_EQ(p.level, "novice");
  EXPECT_EQ(p.level_from, "assessment");
  expect_has(p.reason, "assessment");
  // An expert motion with a failing cut is taken for intermediate.
  p = plan_next({sess(5, 0.4, 0.2, "expert")});
  EXPECT_EQ(p.level, "intermediate");
  // Property over a grid of histories: amplification only for skilled students; a novice's
  // guidance fades only after a guided session on the path.
  for (const std::string skill : {"", "novice", "intermediate", "expert"})
    for (int mode : {0, 1, 2, 3, 4, 5})
      for (double e : {-1.0, 0.2, 0.6, 1.5, 4.0})
        for (double f : {-1.0, 0.1, 0.5, 0.9})
          for (int rep : {0, 2, 5}) {
            const PastSession s = sess(mode, e, f, skill, rep);
            const LessonPlan q = plan_next({s});
            SCOPED_TRACE(testing::Message() << "skill '" << skill << "' mode " << mode << " e " << e << " f " << f
                                            << " rep " << rep << ": " << q.reason);
            EXPECT_GE(q.mode, 1);
            EXPECT_LE(q.mode, 5);
            EXPECT_TRUE(q.guidance.validate().empty()) << q.guidance.validate();
            EXPECT_FALSE(q.reason.empty());
            if (q.level_from == "score") {
              EXPECT_TRUE(mode == 0 || mode == 5) << "a score from mode " << mode << " is the expert's";
            }
            if (q.level != "skilled") {
              EXPECT_EQ(q.guidance.amplify, 0);
            }
            if (q.level == "novice" && q.guidance.repetition > 0) {
              // Fading moves one repetition at a time: on with the error on the path, back when
              // strayed (> 2 mm), held between (one guided session is below check_every).
              EXPECT_EQ(mode, 2);
              EXPECT_GE(e, 0);
              EXPECT_EQ(q.guidance.repetition, e <= 0.5 ? rep + 1 : e > 2.0 ? rep - 1 : rep);
            }
          }
}

TEST(LessonPlan, PlanJsonRoundTripAndBadInput) {
  const LessonPlan p = plan_next({sess(0, -1, 0.2), sess(2, 0.3, 0.25)});
  auto q = parse_lesson_plan(lesson_plan_json(p), "plan.json");
  ASSERT_TRUE(q.ok()) << q.error();
  EXPECT_EQ(q->mode, p.mode);
  EXPECT_EQ(q->reason, p.reason);
  EXPECT_EQ(q->guidance.as_needed, p.guidance.as_needed);
  EXPECT_EQ(q->guidance.repetition, p.guidance.repetition);
  auto bad = parse_lesson_plan("{\"version\": 1, \"mode\": 7}", "p.json");
  ASSERT_FALSE(bad.ok());
  expect_has(bad.error(), "p.json");
  expect_has(bad.error(), "mode = 7");
  bad = parse_lesson_plan("{\"version\": 1, \"mode\": 2}", "p.json");
  ASSERT_FALSE(bad.ok());
  expect_has(bad.error(), "guidance");
  bad = parse_lesson_plan("not json", "p.json");
  ASSERT_FALSE(bad.ok());
  expect_has(bad.error(), "p.json");
  PlanOptions o;
  EXPECT_TRUE(o.validate().empty());
  o.close_m = 0.1e-3;
  expect_has(o.validate(), "close_m");
}

// Real runs: a generated expert lesson, a passive (relaxed) and an active student; the
// plan reads each run's folder back (mode and guidance from the session header, the
// following error from run.json, the score from score.json) and plans from it.
TEST(LessonPlan, ReadsRealLessonRunsOfDifferentStudents) {
  const fs::path d = test::temp_dir("lesson_plan_runs");
  auto lesson = make_generated_lesson("molar_class1_cavity", (d / "lesson").string(), 1);
  ASSERT_TRUE(lesson.ok()) << lesson.error();
  // A relaxed hand without guidance (mode 1, 0.5 s lag) and an active one guided in mode 2.
  struct Case {
    std::string name;
    int mode;
    bool passive;
    double score_frac;
  };
  std::vector<PastSession> read;
  for (const Case& c : {Case{"novice_m1", 1, true, 0.2}, Case{"active_m2", 2, false, 0.5}}) {
    LessonRunOptions o;
    o.mode = c.mode;
    if (c.passive) o.student = StudentModel::passive_hand();
    o.seconds = 2.0;
    o.out_dir = (d / c.name).string();
    fs::create_directories(o.out_dir);
    auto r = run_lesson(*lesson, o);
    ASSERT_TRUE(r.ok()) << r.error();
    // The finish step's score.json (only its outcome matters here).
    std::ofstream(d / c.name / "score.json") << "{\"outcome\": {\"points\": " << 18 * c.score_frac
                                              << ", \"max_points\": 18}}\n";
    auto s = read_past_session((d / c.name).string());
    ASSERT_TRUE(s.ok()) << s.error();
    EXPECT_EQ(s->mode, c.mode);
    ASSERT_TRUE(s->has_follow);
    EXPECT_NEAR(s->follow_mean_m, r->follow_mean_m, 1e-6);
    ASSERT_TRUE(s->has_score);
    EXPECT_NEAR(s->score_fraction(), c.score_frac, 1e-9);
    read.push_back(*s);
  }
  // The unguided passive hand strays far more than the guided active one.
  EXPECT_GT(read[0].follow_mean_m, read[1].follow_mean_m);
  // A novice after watching: full guidance.
  LessonPlan p = plan_next({read[0]});
  EXPECT_EQ(p.level, "novice");
  EXPECT_EQ(p.mode, 2);
  // The plan's file and the session log ("s.dlog" path) read the same.
  auto s = read_past_session((d / "active_m2" / "session.dlog").string());
  ASSERT_TRUE(s.ok()) << s.error();
  EXPECT_EQ(s->mode, 2);
  EXPECT_EQ(s->follow_from, "run.json");
  // Without run.json (a live session): the log replayed in its mode gives the same error.
  fs::remove(d / "active_m2" / "run.json");
  auto replayed = read_past_session((d / "active_m2").string());
  ASSERT_TRUE(replayed.ok()) << replayed.error();
  ASSERT_TRUE(replayed->has_follow);
  EXPECT_EQ(replayed->follow_from, "replay");
  EXPECT_NEAR(replayed->follow_mean_m, read[1].follow_mean_m, 1e-9);
  EXPECT_NEAR(replayed->follow_p95_m, read[1].follow_p95_m, 1e-9);
  // The finish step's assessment (a score made with a skill model) is read as the skill.
  std::ofstream(d / "active_m2" / "score.json")
      << "{\"outcome\": {\"points\": 9, \"max_points\": 18}, \"assessment\": {\"label\": \"expert\", \"margin\": 0.4}}";
  s = read_past_session((d / "active_m2").string());
  ASSERT_TRUE(s.ok()) << s.error();
  EXPECT_EQ(s->skill, "expert");
  std::ofstream(d / "active_m2" / "score.json")
      << "{\"outcome\": {\"points\": 9, \"max_points\": 18}, \"assessment\": {\"label\": 3}}";
  auto bad = read_past_session((d / "active_m2").string());
  ASSERT_FALSE(bad.ok());
  expect_has(bad.error(), "assessment.label");
  // Bad input names the file and field.
  std::ofstream(d / "active_m2" / "score.json") << "{\"outcome\": {\"points\": \"many\"}}";
  bad = read_past_session((d / "active_m2").string());
  ASSERT_FALSE(bad.ok());
  expect_has(bad.error(), "score.json");
  expect_has(bad.error(), "outcome");
  bad = read_past_session((d / "nowhere").string());
  ASSERT_FALSE(bad.ok());
  expect_has(bad.error(), "nowhere");
}

}  // namespace
}  // namespace dentar::training
