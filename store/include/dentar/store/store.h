// The session store: one schema on SQLite or PostgreSQL, chosen by URL.
// Opening runs the versioned migrations (under a lock: many stations may open
// at once) and refuses a database whose schema is newer than the program.
// Every write is one transaction keyed by the session's idempotent key, so a
// session stored twice (a retry after a lost acknowledgement) is kept once.
// One Store is one connection: use one per thread.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dentar/store/db_url.h"
#include "dentar/store/record.h"

namespace dentar::store {

// The schema version this program writes (docs/formats.md "Session store").
constexpr int kSchemaVersion = 3;

struct OpenOptions {
  bool create = true;      // sqlite: create the file if missing
  bool migrate = true;     // false: refuse a database older than kSchemaVersion
  int target_version = kSchemaVersion;  // tests: build an older schema
  int connect_timeout_s = 5;            // postgres
  bool check = true;       // sqlite: PRAGMA quick_check when an existing file opens
};

// Why an open failed, for the exit code: BadInput (a damaged or foreign file,
// a schema newer or older than this program, no such file: exit 2) or
// Unavailable (the server cannot be reached, the file stays locked: exit 1).
enum class OpenFault { None, BadInput, Unavailable };

// Called (from the waiting thread) when an open or a write has waited ~0.3 s
// for another program's lock (SQLite: its busy handler; PostgreSQL: the
// statement found in pg_blocking_pids from a second connection, naming the
// holder), with a line to show the user. The command line prints it at
// once; the default is silence.
void set_lock_wait_notice(std::function<void(const std::string&)> fn);

struct StudentSummary {
  std::string code, name;
  std::int64_t sessions = 0;
  double mean_pct = 0, last_pct = 0;  // points / max_points, %
  std::string last_utc;
  bool last_incomplete = false;  // the last session's score says the preparation was not finished
};

struct SessionSummary {
  std::int64_t id = 0;
  std::string key, student, station, exercise, exercise_title, started_utc;
  double points = 0, max_points = 0, duration_s = 0, coverage_pct = 0;
  bool pulp_exposed = false, perforation = false, has_report = false;
  // The score says the preparation was not finished (metric outcome.complete
  // = 0, issue 25); sessions scored before issue 25 have no such metric.
  bool incomplete = false;
};

// A session trained in a mode (issue 27): what `dentar lesson run` (run.json) recorded,
// stored as metrics "training.*" (record.h). One row per trained session.
struct TrainingRow {
  std::int64_t id = 0;  // the session
  std::string started_utc, exercise;
  int mode = 0;  // 1..5
  double follow_mean_mm = -1, follow_p95_mm = -1;  // -1: not measured
  bool as_needed = false, across_path_only = false;
  int repetition = 0;
  double fade = 1, amplify = 0;
  double points = 0, max_points = 0;
  // The score is the expert's cut (modes 1-4: the expert's bur cut, not the student's).
  bool expert_cut = false;
};

struct SessionFilter {
  std::string student, exercise, station;  // empty: any
  std::size_t limit = 0;                   // 0: all
};

enum class PutOutcome { Stored, AlreadyPresent };

class Db;  // private: the backend

class Store {
 public:
  static Result<std::unique_ptr<Store>> open(const std::string& url, const OpenOptions& opt = {},
                                             OpenFault* fault = nullptr);
  ~Store();
  Store(const Store&) = delete;
  Store& operator=(const Store&) = delete;

  const DbUrl& url() const { return url_; }
  int schema_version() const { return version_; }

  // Stores the session (students/stations/exercises created on first use).
  Result<PutOutcome> put(const SessionRecord& r);
  // Station side: put + an outbox row in the same transaction.
  Result<PutOutcome> put_and_queue(const SessionRecord& r);

  Result<std::vector<StudentSummary>> students();
  Result<std::vector<SessionSummary>> sessions(const SessionFilter& f = {});
  // The trained sessions among sessions(f), in the same order (issue 27).
  Result<std::vector<TrainingRow>> training(const SessionFilter& f = {});
  Result<std::vector<std::string>> exercises();
  // Full record by id (nullopt: no such session).
  Result<std::optional<SessionRecord>> session(std::int64_t id);
  Result<std::optional<SessionRecord>> session_by_key(const std::string& key);
  // Moves a stored session to another student (`dentar db import --move`): the student is
  // created on first use. Error when no session has this key.
  Status move_session(const std::string& key, const std::string& student);
  Result<std::int64_t> count_sessions();
  Result<bool> has_key(const std::string& key);
  // Every session, oldest first, one at a time (export).
  Status for_each(const std::function<Status(const SessionRecord&)>& f);

  // Outbox (the station's local store).
  struct Queued {
    std::string key, payload;  // payload: to_json(record)
    int attempts = 0;
  };
  Result<std::vector<Queued>> pending(std::size_t limit = 100);
  Result<std::int64_t> pending_count();
  Status mark_sent(const std::string& key);
  Status mark_failed(const std::string& key, const std::string& error);

  // Maintenance and tests: statements without parameters (e.g. writing rows
  // the way an older schema version did).
  Status exec_raw(const std::string& sql);

 private:
  Store() = default;
  Result<PutOutcome> put_impl(const SessionRecord& r, bool queue);
  DbUrl url_;
  std::unique_ptr<Db> db_;
  int version_ = 0;
};

}  // namespace dentar::store
