// Storing a finished session from `dentar live`, `dentar offline` and
// `dentar db import`: score it if it has no score.json yet, then store it
// (station store-and-forward when the target is a server).
#pragma once

#include <CLI/CLI.hpp>
#include <optional>
#include <string>

#include "dentar/store/store.h"
#include "dentar/volume/result.h"

namespace dentar::tools {

struct DbCli {
  std::string db;          // --db URL: where the session is kept
  std::string station_db;  // --station-db sqlite:PATH: this station's own queue (server targets)
  std::string student;     // --student CODE
  std::string station_id;  // --station-id CODE (default: the host name)
  bool move = false;       // --move (db import): a session stored under another student moves to --student
};

// What `dentar db import PATH` stores: the session log and the folder with its score.json.
// PATH may be a .dlog, a folder holding session.dlog (a `dentar live --record` recording, a
// `dentar demo` folder, a `dentar score` folder), or a `dentar offline` run folder (its
// session log in footage/, or where its summary.json's inputs.session says; score.json in
// the run folder). Error (bad input) names what was looked for.
struct SessionPaths {
  std::string session, report_dir;  // report_dir empty: the log's folder
};
Result<SessionPaths> find_session(const std::string& path);

// Adds --db, --station-db, --student, --station-id to a subcommand.
void add_db_options(CLI::App* sub, DbCli& c, bool db_required);

// Checks the options before any work (bad input: message, returns false).
bool check_db_options(const std::string& cmd, DbCli& c);

// Scores `session` (a folder with session.dlog, or a .dlog) into report_dir
// (empty: the session's folder) unless score.json is there, then stores it
// (store::store_session: the store opened once, the another-student / --move
// check inside). Prints one line for the student. Returns the exit code (0;
// 1 for a locked or unreachable store or a failed write; 2 for bad input).
int store_finished_session(const std::string& cmd, const DbCli& c, const std::string& session,
                           const std::string& report_dir, bool quiet);

// A --db URL that parses and holds no password (PGPASSWORD or a pgpass file
// instead): the parsed URL; prints the message and returns nullopt otherwise
// (exit 2).
std::optional<store::DbUrl> check_db_url(const std::string& cmd, const std::string& url,
                                         const std::string& option = "--db");

// SQLite lock waits are printed at once ("cmd: ... waiting up to 60 s").
void announce_lock_waits(const std::string& cmd);

// Store::open's fault to the exit-code policy: bad input 2, unavailable 1.
int open_fault_exit_code(store::OpenFault fault);

// The station's own queue when --db is a server and --station-db is not
// given: $DENTAR_STATION_DB, else ~/.local/share/dentar/station.db.
std::string default_station_db();

}  // namespace dentar::tools
