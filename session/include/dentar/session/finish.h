// The finish step of a run, for the drivers (`dentar offline`, `live`,
// `demo`, `lesson run`, `db import`): score, then store.
//  - score: the session is scored against its exercise and score.json +
//    score.html are written into the run's folder. A failure to score never
//    fails or loses the run: it comes back as a warning.
//  - store: the scored session (its log and score.json) as one record in the
//    store (store/: SQLite, or a PostgreSQL server through this station's own
//    SQLite queue). A failure to store keeps the session folder and says why.
#pragma once

#include <functional>
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

// Where and for whom a finished session is stored (--db, --station-db, --student, --station-id, --move).
struct StoreTarget {
  std::string db;          // sqlite:PATH or postgresql://USER@HOST[:PORT]/DB; empty: not stored
  std::string station_db;  // this station's own SQLite queue when db is a server ("" = db is written directly)
  std::string student, station_id;
  bool move = false;  // a session stored under another student moves to `student`
};

struct StoreOutcome {
  // 0 stored; 1 a failed job (a store locked or unreachable, a log that reads but cannot be
  // scored); 2 bad input (a damaged or foreign log, a damaged, foreign or newer store).
  int exit_code = 0;
  std::string line;     // when stored: "session KEY of STUDENT (EXERCISE, P / M points): MESSAGE"
  std::string warning;  // the store's warning ("" = none)
  std::string error;    // when not stored: why (the session folder is kept)
};

// The store half: `session` (a folder with session.dlog, or a .dlog) scored into report_dir
// ("" = the session's folder) unless its score.json is there (`note` says so first), then
// stored in target.db (store::store_session: the store opened once).
StoreOutcome store_after_score(const StoreTarget& target, const std::string& session, const std::string& report_dir,
                               const std::function<void(const std::string&)>& note);

// The whole finish step: `score` (when given) scored, then `session` stored when target.db
// is set (report_dir as for store_after_score).
struct FinishOutcome {
  bool scored = false;
  DriverScore score;
  bool stored = false;
  StoreOutcome store;
};
FinishOutcome finish_run(const DriverScoreInput* score, const StoreTarget& target, const std::string& session,
                         const std::string& report_dir, const std::function<void(const std::string&)>& note);

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
