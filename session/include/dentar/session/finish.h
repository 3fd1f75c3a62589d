// Scoring a finished session for the drivers (`dentar offline`, `live`,
// `demo`): the session is scored against its exercise and score.json +
// score.html are written into the run's folder. A failure to score never
// fails or loses the run: it comes back as a warning.
#pragma once

#include <string>

#include "dentar/training/mirror_use.h"
#include "dentar/volume/result.h"

namespace dentar::session {

struct DriverScoreInput {
  std::string session;     // the session log (.dlog) of the run
  std::string out_dir;     // where score.json / score.html go
  std::string exercise;    // --exercise (name or JSON); empty: recording.json's "exercise", else by the tooth
  std::string recording;   // a `dentar live --record` folder the session came from ("" = none)
  std::string frames_csv;  // camera frames for mirror use ("" = none)
  std::string station;     // station.json for mirror use ("" = none)
  bool compare = false;    // score a generated expert and novice session beside it (ScoreOptions::compare)
};

struct DriverScore {
  bool ok = false;
  std::string line;     // one line for the terminal ("score: 12.0 / 18 points ...")
  std::string html;     // a block for a run report linking score.html
  std::string warning;  // when not ok: why the session was not scored
};

DriverScore score_after_run(const DriverScoreInput& in);

// Empty when `exercise` ("" allowed) names a loadable exercise, else the
// error: the drivers check --exercise before a run (bad input, exit 2).
std::string check_exercise(const std::string& exercise);

// Removes score.json / score.html of an earlier run from `dir`, so a run
// whose scoring fails never shows an old score as its own.
void remove_old_score(const std::string& dir);

// Mirror-use geometry from a station file (T_man_tooth, T_mtag_mir, mirror
// radius, the camera's field of view).
Result<training::SightGeometry> sight_from_station(const std::string& station_json);

// The exercise recorded in a `dentar live --record` folder's recording.json ("" = none).
std::string recorded_exercise(const std::string& recording_dir);

}  // namespace dentar::session
