// Scoring a finished session: replay the log on the starting tooth, score
// the outcome against the exercise, decode the process, find the steps,
// compare with the experts, give feedback, optionally classify skill, and
// write a self-contained HTML report (SVG plots) and a JSON summary.
// Callable from `dentar score`, and from the offline and live drivers.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "dentar/training/assess.h"
#include "dentar/training/feedback.h"
#include "dentar/training/mirror_use.h"
#include "dentar/training/outcome.h"

namespace dentar::training {

struct ScoreOptions {
  std::string session;    // a .dlog file, or a folder holding session.dlog (and optionally station.json)
  std::string exercise;   // built-in name or a .json path; empty: by the session's tooth
                          // (molar -> molar_access_opening, incisor -> incisor_partial_crown)
  std::string out_dir;    // empty: the session's folder
  std::string reference;  // expert reference JSON; empty: generated from expert cohort sessions
                          // (cached as <out_dir>/expert_reference.json)
  std::string model;      // optional skill model (dentar assess --train ... --save)
  int reference_trials = 3;
  bool write_files = true;
  // Mirror use (docs/formats.md "Mirror use"): per-frame camera and mirror
  // poses (frames.csv of `dentar offline` or `dentar live --record`; empty:
  // <session folder>/frames.csv when present) and the station geometry (the
  // drivers read it from station.json). Either missing: mirror use unavailable.
  std::string frames_csv;
  // Reads frames_csv (the caller's frames.csv reader, session::read_view_frames: training
  // sits below the run room and keeps no reader of its own). Empty: mirror use unavailable.
  std::function<Result<std::vector<ViewFrame>>(const std::string& path, double rate_hz)> read_frames;
  std::optional<SightGeometry> sight;
  std::string sight_source;  // where the geometry came from (report)
  // Score beside it a whole generated expert session and a generated novice
  // session of the same exercise (cohort generator; cached beside the
  // expert reference), so a short or unfinished session's score can be read
  // against finished ones (issue 25; `dentar offline` on built-in footage).
  bool compare = false;
};

// One session's outcome in a side-by-side comparison.
struct ComparisonRow {
  std::string label;  // "generated expert session", ...
  double points = 0, max_points = 0, coverage_pct = 0, duration_s = 0, drilling_s = 0;
  bool complete = false;
  std::string completion;
};

// A generated expert (skill separation 0) and novice (separation 1) session
// of `ex`, scored: from the cache ($DENTAR_CACHE_DIR, as the expert
// reference) when there, else generated in work_dir (removed after).
Result<std::vector<ComparisonRow>> generated_comparison(const Exercise& ex, const std::string& work_dir);

struct ScoreSummary {
  std::string session_path, exercise_name, exercise_title, report_html, summary_json;
  std::string log_warning;   // truncated/corrupt log: what was kept
  bool station_found = false;
  double seconds = 0;        // time spent scoring
  OutcomeScores outcome;
  ProcessMetrics process;
  ExpertReference reference;
  std::vector<FeedbackMessage> feedback;
  std::optional<Verdict> verdict;
  MirrorUse mirror;
  std::vector<ComparisonRow> comparison;  // with ScoreOptions::compare: this session first, then the generated ones
  std::string comparison_warning;         // why the comparison is missing (it never fails the score)
  // The session's training mode (issue 27; 0 = plain drilling). In modes 1-4 the expert's
  // bur cuts, not the student's: the outcome is the expert's cut, not the student's score.
  int training_mode = 0;
  bool expert_cut() const { return training_mode >= 1 && training_mode <= 4; }
  std::string cut_label() const;  // "expert's cut (mode N)" or "student's cut"
  std::string summary_text() const;  // a few lines for a terminal
};

Result<ScoreSummary> score_session(const ScoreOptions& opt);

// Exercise that fits a session's tooth description (see ScoreOptions::exercise).
std::string default_exercise_for(const std::string& tooth_json);

}  // namespace dentar::training
