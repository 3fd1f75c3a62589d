// The lesson plan (issue 27, "guidance that adapts"): from a student's recent sessions (their
// training mode and guidance, following error, score, and skill assessment) it picks the next
// mode and its guidance settings, and says why in one sentence. The rules are in
// docs/training_modes.md ("The lesson plan") and follow three points of the motor-learning
// literature: guidance helps novices and error amplification helps skilled learners;
// guidance as needed and guidance faded over repetitions (mixed with unguided trials)
// transfer better than constant guidance; guidance should constrain only the directions that
// matter (across the path).
//
// Units: SI in code; plan.json and the reason sentence use mm (the user boundary).
#pragma once

#include <string>
#include <vector>

#include "dentar/haptics/guidance.h"
#include "dentar/training/assess.h"
#include "dentar/volume/result.h"

namespace dentar::training {

// What the plan knows of one past session (oldest first in a history).
struct PastSession {
  std::string path;  // the session folder or log (messages)
  int mode = 0;      // 0: plain drilling (no training section), 1..5: the training mode
  haptics::GuidanceParams guidance;  // as recorded in the session header (mode 2)
  bool has_follow = false;           // a following error was measured
  std::string follow_from;           // "run.json" (dentar lesson run), "replay" (the log replayed in its mode)
  double follow_mean_m = 0, follow_p95_m = 0;
  bool has_score = false;  // score.json (the finish step's score)
  double points = 0, max_points = 0;
  std::string skill;  // assessment label ("novice", "intermediate", "expert"; "" = not assessed)
  double score_fraction() const { return max_points > 0 ? points / max_points : 0; }
};

// The rules' thresholds (documented; each a plan option).
struct PlanOptions {
  double on_path_m = 0.5e-3;   // mean following error "on the path" (the seed field's eps1)
  double close_m = 1.0e-3;     // "close": good enough to follow without guidance
  double strayed_m = 2.0e-3;   // "strayed": mode 3's default follow tolerance eps
  double novice_score = 0.4;   // score fraction below which a student counts as a novice
  double skilled_score = 0.75; // at or above: skilled
  double fade = 0.7;           // guidance fading factor per repetition
  // Faded this often and still on the path: an unguided trial; with practice fading (check
  // trials below), faded more often than this: no guidance any more.
  int fade_repetitions = 3;
  // A novice guided (mode 2) this many sessions in a row without reaching the path gets an
  // unguided check trial (mode 3) next; its error decides the guidance after it (within
  // strayed_m: one fading step more than before the check, within close_m: no guidance,
  // beyond strayed_m: guidance as needed again). Guidance so fades with practice even for a
  // novice who never gets below on_path_m (session 15). A faded novice is faded back one step
  // only beyond strayed_m (before session 15: beyond on_path_m, which undid every fading step).
  int check_every = 2;
  double amplify = 0.5;        // error amplification for skilled students
  std::string validate() const;  // empty, or names the field
};

struct LessonPlan {
  int mode = 1;
  std::string level;  // "novice", "intermediate", "skilled": what the plan took the student for
  std::string level_from;  // "assessment", "score", "no data"
  haptics::GuidanceParams guidance;  // mode 2's field (defaults otherwise)
  bool conditional_replay = true;    // mode 3
  std::string rule;    // short id of the rule that fired (tests, the instructor's page)
  std::string reason;  // one sentence for the student and the instructor
};

// The next session's mode and guidance. An empty history plans mode 1 (watch first).
// Options must validate (asserted by the caller; plan_next does not check them). Scores count
// only from sessions in which the student cut (plain drilling, mode 5): in modes 1-4 the
// expert's bur cuts, so those sessions' scores are the expert's.
LessonPlan plan_next(const std::vector<PastSession>& history, const PlanOptions& options = {});

// A session folder (holding session.dlog, and run.json / score.json when present) or a
// session .dlog: its mode and guidance from the log header, the following error from
// run.json (`dentar lesson run`) or, for a session trained in mode 2-4 without one (a live
// session), by replaying the log in its mode (the lesson's recording must be where the
// header says; a 50 s session takes ~1 s), the score and, when it was scored with a skill model, the
// assessment's label from score.json; with `model` (`dentar assess --save`) the session's
// motion is assessed here (overriding score.json's label). Errors name the
// file and field.
Result<PastSession> read_past_session(const std::string& path, const SkillModel* model = nullptr);

// plan.json (docs/formats.md, "Lesson plan") and its reader (`dentar lesson run --plan`).
std::string lesson_plan_json(const LessonPlan& p);
Result<LessonPlan> parse_lesson_plan(const std::string& json_text, const std::string& name);

}  // namespace dentar::training
