// Store: schema migrations and the queries, written once for both dialects
// ($N parameters, INSERT ... ON CONFLICT, RETURNING; SQLite >= 3.35).
#include "dentar/store/store.h"

#include <algorithm>
#include <charconv>
#include <functional>
#include <map>
#include <optional>
#include <cmath>
#include <sstream>

#include "db.h"

namespace dentar::store {
namespace {

using nlohmann::json;

// {ID}: the surrogate key; {REAL}: a double.
std::string dialect(std::string sql, bool pg) {
  auto rep = [&](const std::string& from, const std::string& to) {
    for (std::size_t p = sql.find(from); p != std::string::npos; p = sql.find(from, p + to.size()))
      sql.replace(p, from.size(), to);
  };
  rep("{ID}", pg ? "BIGSERIAL PRIMARY KEY" : "INTEGER PRIMARY KEY AUTOINCREMENT");
  rep("{REAL}", pg ? "DOUBLE PRECISION" : "REAL");
  return sql;
}

// Migration N takes the schema from version N-1 to N. Never edit a released
// one: add the next.
const char* const kMigrations[] = {
    // 1: students, stations, exercises, sessions, scores, metrics, feedback.
    R"(CREATE TABLE students(id {ID}, code TEXT NOT NULL UNIQUE, name TEXT);
CREATE TABLE stations(id {ID}, code TEXT NOT NULL UNIQUE);
CREATE TABLE exercises(id {ID}, name TEXT NOT NULL UNIQUE, title TEXT);
CREATE TABLE sessions(id {ID}, key TEXT NOT NULL UNIQUE,
  student_id BIGINT NOT NULL REFERENCES students(id), station_id BIGINT NOT NULL REFERENCES stations(id),
  exercise_id BIGINT NOT NULL REFERENCES exercises(id), started_utc TEXT NOT NULL, stored_utc TEXT NOT NULL,
  log_path TEXT NOT NULL, log_sha256 TEXT NOT NULL, log_bytes BIGINT NOT NULL, log_warning TEXT);
CREATE TABLE scores(session_id BIGINT PRIMARY KEY REFERENCES sessions(id), points {REAL} NOT NULL,
  max_points {REAL} NOT NULL, coverage_pct {REAL}, overprep_mm3 {REAL}, forbidden_mm3 {REAL}, removed_mm3 {REAL},
  pulp_exposed INTEGER NOT NULL, perforation INTEGER NOT NULL, duration_s {REAL}, drilling_s {REAL}, path_mm {REAL},
  excessive_force_s {REAL});
CREATE TABLE metrics(session_id BIGINT NOT NULL REFERENCES sessions(id), name TEXT NOT NULL, value {REAL} NOT NULL,
  unit TEXT, PRIMARY KEY(session_id, name));
CREATE TABLE feedback(session_id BIGINT NOT NULL REFERENCES sessions(id), idx INTEGER NOT NULL, step TEXT,
  kind TEXT NOT NULL, text TEXT NOT NULL, PRIMARY KEY(session_id, idx));)",
    // 2: recordings, the report itself (travels with the session to the
    // server), per-step forces against the expert band.
    R"(ALTER TABLE sessions ADD COLUMN recording_path TEXT;
ALTER TABLE sessions ADD COLUMN recording_sha256 TEXT;
ALTER TABLE sessions ADD COLUMN report_dir TEXT;
CREATE TABLE reports(session_id BIGINT PRIMARY KEY REFERENCES sessions(id), score_json TEXT NOT NULL, score_html TEXT);
CREATE TABLE steps(session_id BIGINT NOT NULL REFERENCES sessions(id), idx INTEGER NOT NULL, name TEXT NOT NULL,
  start_s {REAL}, end_s {REAL}, drilling_s {REAL}, path_mm {REAL}, removed_mm3 {REAL},
  fx {REAL}, fy {REAL}, fz {REAL}, sdx {REAL}, sdy {REAL}, sdz {REAL},
  efx {REAL}, efy {REAL}, efz {REAL}, esx {REAL}, esy {REAL}, esz {REAL}, PRIMARY KEY(session_id, idx));)",
    // 3: the station outbox; indexes for the instructor's pages.
    R"(CREATE TABLE outbox(key TEXT PRIMARY KEY, payload TEXT NOT NULL, queued_utc TEXT NOT NULL,
  attempts INTEGER NOT NULL DEFAULT 0, last_error TEXT, sent_utc TEXT);
CREATE INDEX outbox_unsent ON outbox(queued_utc) WHERE sent_utc IS NULL;
CREATE INDEX sessions_student_started ON sessions(student_id, started_utc);
CREATE INDEX sessions_exercise_started ON sessions(exercise_id, started_utc);)",
};
static_assert(sizeof(kMigrations) / sizeof(kMigrations[0]) == kSchemaVersion);

std::string d2s(double v) {
  if (!std::isfinite(v)) v = 0;
  char b[32];
  auto r = std::to_chars(b, b + sizeof b, v);
  return std::string(b, r.ptr);
}
Value S(const std::string& s) { return s; }
Value N(double v) { return d2s(v); }
Value I(std::int64_t v) { return std::to_string(v); }
Value Opt(const std::string& s) { return s.empty() ? Value{} : Value{s}; }

double dbl(const Value& v) {
  if (!v) return 0;
  double d = 0;
  const auto r = std::from_chars(v->data(), v->data() + v->size(), d);
  return r.ec == std::errc() ? d : 0;
}
std::int64_t i64(const Value& v) {
  if (!v) return 0;
  std::int64_t d = 0;
  const auto r = std::from_chars(v->data(), v->data() + v->size(), d);
  if (r.ec != std::errc()) return static_cast<std::int64_t>(dbl(v));
  return d;
}
std::string str(const Value& v) { return v ? *v : ""; }
bool flag(const Value& v) { return v && (*v == "1" || *v == "t" || *v == "true"); }

Result<int> read_version(Db& db) {
  auto r = db.query("SELECT MAX(version) FROM dentar_schema");
  if (!r) return Error{r.error()};
  return r->empty() ? 0 : static_cast<int>(i64((*r)[0][0]));
}

Status migrate(Db& db, const DbUrl& url, const OpenOptions& opt, int& version) {
  const bool pg = db.postgres();
  // The version table itself (idempotent, outside the numbered migrations).
  if (auto s = db.exec("CREATE TABLE IF NOT EXISTS dentar_schema(version INTEGER PRIMARY KEY, applied_utc TEXT NOT NULL, program TEXT)");
      !s) {
    // Another process may be creating it at the same moment (postgres): look again.
    if (!pg) return s;
    if (auto v = read_version(db); !v) return s;
  }
  auto cur = read_version(db);
  if (!cur) return Error{cur.error()};
  if (*cur > kSchemaVersion)
    return Error{url.redacted + ": the database's schema is version " + std::to_string(*cur) +
                 ", newer than this program's (" + std::to_string(kSchemaVersion) +
                 "); it was written by a newer DentAR. Upgrade dentar on this machine; nothing was changed."};
  if (*cur >= opt.target_version) {
    version = *cur;
    return {};
  }
  if (!opt.migrate)
    return Error{url.redacted + ": schema version " + std::to_string(*cur) + ", this program needs " +
                 std::to_string(kSchemaVersion) + "; run `dentar db migrate --db " + url.redacted + "`"};
  if (auto s = db.begin_write(); !s) return s;
  if (pg) {
    if (auto s = db.exec("SELECT pg_advisory_xact_lock(7313021)"); !s) {  // one migrator at a time
      db.rollback();
      return s;
    }
  }
  auto again = read_version(db);  // someone else may have migrated while we waited
  if (!again) {
    db.rollback();
    return Error{again.error()};
  }
  int v = *again;
  for (; v < opt.target_version; ++v) {
    if (auto s = db.exec(dialect(kMigrations[v], pg)); !s) {
      db.rollback();
      return Error{"migration to schema version " + std::to_string(v + 1) + " failed: " + s.error()};
    }
    auto q = db.query("INSERT INTO dentar_schema(version, applied_utc, program) VALUES($1, $2, $3)",
                      {I(v + 1), S(utc_now_iso()), S("dentar 0.1.0")});
    if (!q) {
      db.rollback();
      return Error{q.error()};
    }
  }
  if (auto s = db.commit(); !s) return s;
  version = v;
  return {};
}

// Id of a code in a name table, created on first use.
Result<std::int64_t> upsert(Db& db, const char* table, const char* col, const std::string& code,
                            const Value& extra_col_value = {}, const char* extra_col = nullptr) {
  const std::string t = table, c = col;
  std::string ins = "INSERT INTO " + t + "(" + c + (extra_col ? std::string(", ") + extra_col : "") +
                    ") VALUES($1" + (extra_col ? ", $2" : "") + ") ON CONFLICT(" + c + ") DO NOTHING";
  std::vector<Value> p = {S(code)};
  if (extra_col) p.push_back(extra_col_value);
  if (auto r = db.query(ins, p); !r) return Error{r.error()};
  auto r = db.query("SELECT id FROM " + t + " WHERE " + c + " = $1", {S(code)});
  if (!r) return Error{r.error()};
  if (r->empty()) return Error{std::string(table) + ": '" + code + "' vanished after insert"};
  return i64((*r)[0][0]);
}

const char* kSummaryCols =
    "s.id, s.key, st.code, sta.code, e.name, e.title, s.started_utc, sc.points, sc.max_points, sc.duration_s, "
    "sc.coverage_pct, sc.pulp_exposed, sc.perforation, (SELECT COUNT(*) FROM reports r WHERE r.session_id = s.id "
    "AND r.score_html IS NOT NULL), (SELECT COUNT(*) FROM metrics m WHERE m.session_id = s.id AND "
    "m.name = 'outcome.complete' AND m.value = 0)";
const char* kSummaryFrom =
    " FROM sessions s JOIN students st ON st.id = s.student_id JOIN stations sta ON sta.id = s.station_id "
    "JOIN exercises e ON e.id = s.exercise_id LEFT JOIN scores sc ON sc.session_id = s.id";

SessionSummary summary_from(const Row& r) {
  SessionSummary s;
  s.id = i64(r[0]);
  s.key = str(r[1]);
  s.student = str(r[2]);
  s.station = str(r[3]);
  s.exercise = str(r[4]);
  s.exercise_title = str(r[5]);
  s.started_utc = str(r[6]);
  s.points = dbl(r[7]);
  s.max_points = dbl(r[8]);
  s.duration_s = dbl(r[9]);
  s.coverage_pct = dbl(r[10]);
  s.pulp_exposed = flag(r[11]);
  s.perforation = flag(r[12]);
  s.has_report = i64(r[13]) > 0;
  s.incomplete = i64(r[14]) > 0;
  return s;
}

}  // namespace

Store::~Store() = default;

Result<std::unique_ptr<Store>> Store::open(const std::string& url_text, const OpenOptions& opt, OpenFault* fault) {
  OpenFault dummy;
  OpenFault& f = fault ? *fault : dummy;
  f = OpenFault::BadInput;
  auto url = parse_db_url(url_text);
  if (!url) return Error{url.error()};
  if (opt.target_version < 1 || opt.target_version > kSchemaVersion)
    return Error{"schema version " + std::to_string(opt.target_version) + " does not exist (1-" +
                 std::to_string(kSchemaVersion) + ")"};
  const bool pg = url->kind == DbUrl::Kind::Postgres;
  auto db = pg ? open_postgres(*url, opt.connect_timeout_s) : open_sqlite(*url, opt.create, opt.check);
  if (!db) {
    const std::string& e = db.error();
    if (pg || e.find("locked") != std::string::npos || e.find("busy") != std::string::npos) f = OpenFault::Unavailable;
    return Error{e};
  }
  std::unique_ptr<Store> s(new Store());
  s->url_ = *url;
  s->db_ = std::move(*db);
  if (auto m = migrate(*s->db_, s->url_, opt, s->version_); !m) {
    const std::string& e = m.error();
    if (e.find("malformed") != std::string::npos)
      f = OpenFault::BadInput;
    else if (e.find("schema version") == std::string::npos && e.find("newer") == std::string::npos)
      f = OpenFault::Unavailable;  // the server or the lock, not the data
    return Error{e};
  }
  f = OpenFault::None;
  return s;
}

Result<PutOutcome> Store::put(const SessionRecord& r) { return put_impl(r, false); }
Result<PutOutcome> Store::put_and_queue(const SessionRecord& r) { return put_impl(r, true); }

Result<PutOutcome> Store::put_impl(const SessionRecord& r, bool queue) {
  if (version_ < kSchemaVersion)
    return Error{url_.redacted + ": schema version " + std::to_string(version_) + " is older than this program's"};
  for (const auto& [what, v] : {std::pair{"student", r.student}, std::pair{"station", r.station},
                                std::pair{"exercise", r.exercise}}) {
    if (v.empty()) return Error{std::string("session ") + r.key.substr(0, 16) + ": " + what + " is empty"};
    if (auto e = validate_code(what, v); !e.empty()) return Error{e};
  }
  if (r.key.empty()) return Error{"session: empty key"};
  Db& db = *db_;
  if (auto s = db.begin_write(); !s) return Error{s.error()};
  auto fail = [&](const std::string& e) -> Result<PutOutcome> {
    db.rollback();
    return Error{e};
  };
  auto student = upsert(db, "students", "code", r.student);
  if (!student) return fail(student.error());
  auto station = upsert(db, "stations", "code", r.station);
  if (!station) return fail(station.error());
  auto exercise = upsert(db, "exercises", "name", r.exercise, Opt(r.exercise_title), "title");
  if (!exercise) return fail(exercise.error());
  const std::string stored = utc_now_iso();
  auto ins = db.query(
      "INSERT INTO sessions(key, student_id, station_id, exercise_id, started_utc, stored_utc, log_path, log_sha256, "
      "log_bytes, log_warning, recording_path, recording_sha256, report_dir) "
      "VALUES($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13) ON CONFLICT(key) DO NOTHING RETURNING id",
      {S(r.key), I(*student), I(*station), I(*exercise), S(r.started_utc), S(stored), S(r.log_path), S(r.log_sha256),
       I(r.log_bytes), Opt(r.log_warning), Opt(r.recording_path), Opt(r.recording_sha256), Opt(r.report_dir)});
  if (!ins) return fail(ins.error());
  if (ins->empty()) {  // already stored: nothing to write
    if (auto s = db.commit(); !s) return Error{s.error()};
    return PutOutcome::AlreadyPresent;
  }
  const Value id = I(i64((*ins)[0][0]));
  auto q = [&](const std::string& sql, const std::vector<Value>& p) -> bool {
    auto x = db.query(sql, p);
    if (!x) {
      db.rollback();
      return false;
    }
    return true;
  };
  auto err = [&](const std::string& sql, const std::vector<Value>& p) -> std::string {
    auto x = db.query(sql, p);
    if (!x) {
      db.rollback();
      return x.error();
    }
    return "";
  };
  (void)q;
  if (auto e = err("INSERT INTO scores(session_id, points, max_points, coverage_pct, overprep_mm3, forbidden_mm3, "
                   "removed_mm3, pulp_exposed, perforation, duration_s, drilling_s, path_mm, excessive_force_s) "
                   "VALUES($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13)",
                   {id, N(r.points), N(r.max_points), N(r.coverage_pct), N(r.overprep_mm3), N(r.forbidden_mm3),
                    N(r.removed_mm3), I(r.pulp_exposed), I(r.perforation), N(r.duration_s), N(r.drilling_s),
                    N(r.path_mm), N(r.excessive_force_s)});
      !e.empty())
    return Error{e};
  // Many small rows: one multi-row INSERT per table keeps round trips low.
  auto multi = [&](const std::string& head, std::size_t ncol, std::size_t nrow,
                   const std::function<void(std::size_t, std::vector<Value>&)>& fill) -> std::string {
    const std::size_t chunk = 100;
    for (std::size_t b = 0; b < nrow; b += chunk) {
      std::string sql = head + " VALUES";
      std::vector<Value> p;
      for (std::size_t i = b; i < std::min(nrow, b + chunk); ++i) {
        sql += (i == b ? "(" : ",(");
        const std::size_t base = p.size();
        fill(i, p);
        for (std::size_t c = 0; c < ncol; ++c) sql += (c ? ",$" : "$") + std::to_string(base + c + 1);
        sql += ")";
      }
      if (auto e = err(sql, p); !e.empty()) return e;
    }
    return "";
  };
  // Duplicate metric names (a malformed score.json) keep the first.
  std::vector<const Metric*> metrics;
  {
    std::vector<std::string> seen;
    for (const auto& m : r.metrics) {
      if (std::find(seen.begin(), seen.end(), m.name) != seen.end()) continue;
      seen.push_back(m.name);
      metrics.push_back(&m);
    }
  }
  if (auto e = multi("INSERT INTO metrics(session_id, name, value, unit)", 4, metrics.size(),
                     [&](std::size_t i, std::vector<Value>& p) {
                       p.insert(p.end(), {id, S(metrics[i]->name), N(metrics[i]->value), Opt(metrics[i]->unit)});
                     });
      !e.empty())
    return Error{e};
  if (auto e = multi("INSERT INTO feedback(session_id, idx, step, kind, text)", 5, r.feedback.size(),
                     [&](std::size_t i, std::vector<Value>& p) {
                       const auto& f = r.feedback[i];
                       p.insert(p.end(), {id, I(static_cast<std::int64_t>(i)), S(f.step), S(f.kind), S(f.text)});
                     });
      !e.empty())
    return Error{e};
  if (auto e = multi("INSERT INTO steps(session_id, idx, name, start_s, end_s, drilling_s, path_mm, removed_mm3, fx, "
                     "fy, fz, sdx, sdy, sdz, efx, efy, efz, esx, esy, esz)",
                     20, r.steps.size(),
                     [&](std::size_t i, std::vector<Value>& p) {
                       const auto& s = r.steps[i];
                       p.insert(p.end(), {id, I(static_cast<std::int64_t>(i)), S(s.name), N(s.start_s), N(s.end_s),
                                          N(s.drilling_s), N(s.path_mm), N(s.removed_mm3)});
                       for (double v : s.force_N) p.push_back(N(v));
                       for (double v : s.force_sd_N) p.push_back(N(v));
                       for (double v : s.expert_force_N) p.push_back(s.has_expert ? N(v) : Value{});
                       for (double v : s.expert_sd_N) p.push_back(s.has_expert ? N(v) : Value{});
                     });
      !e.empty())
    return Error{e};
  if (auto e = err("INSERT INTO reports(session_id, score_json, score_html) VALUES($1, $2, $3)",
                   {id, S(r.score_json), Opt(r.score_html)});
      !e.empty())
    return Error{e};
  if (queue) {
    SessionRecord copy = r;
    if (auto e = err("INSERT INTO outbox(key, payload, queued_utc) VALUES($1, $2, $3) ON CONFLICT(key) DO NOTHING",
                     {S(r.key), S(to_json(copy).dump()), S(stored)});
        !e.empty())
      return Error{e};
  }
  if (auto s = db.commit(); !s) return Error{s.error()};
  return PutOutcome::Stored;
}

// A session (alias `s`) whose score is the student's: not an expert's cut (training modes 1-4, issue 27).
std::string not_expert_cut(const std::string& s = "s") {
  return "NOT EXISTS (SELECT 1 FROM metrics mx WHERE mx.session_id = " + s + ".id AND (mx.name = 'training.expert_cut' OR "
         "(mx.name = 'training.mode' AND mx.value >= 1 AND mx.value <= 4)))";
}

Result<std::vector<StudentSummary>> Store::students() {
  auto r = db_->query(
      "SELECT st.code, st.name, COUNT(s.id), AVG(CASE WHEN sc.max_points > 0 AND " + not_expert_cut() +
      " THEN 100.0 * sc.points / sc.max_points END), "
      "MAX(s.started_utc) FROM students st LEFT JOIN sessions s ON s.student_id = st.id "
      "LEFT JOIN scores sc ON sc.session_id = s.id GROUP BY st.id, st.code, st.name ORDER BY st.code");
  if (!r) return Error{r.error()};
  std::vector<StudentSummary> out;
  for (const auto& row : *r) {
    StudentSummary s;
    s.code = str(row[0]);
    s.name = str(row[1]);
    s.sessions = i64(row[2]);
    s.mean_pct = dbl(row[3]);
    s.last_utc = str(row[4]);
    out.push_back(s);
  }
  // Last session's score per student (one more query, not one per student): the last one the
  // student cut (an expert's cut in modes 1-4 is not the student's score).
  auto last = db_->query(
      "SELECT st.code, sc.points, sc.max_points, (SELECT COUNT(*) FROM metrics m WHERE m.session_id = s.id AND "
      "m.name = 'outcome.complete' AND m.value = 0) FROM sessions s JOIN students st ON st.id = s.student_id "
      "JOIN scores sc ON sc.session_id = s.id WHERE s.id = (SELECT s2.id FROM sessions s2 WHERE s2.student_id = "
      "s.student_id AND " + not_expert_cut("s2") + " ORDER BY s2.started_utc DESC, s2.id DESC LIMIT 1)");
  if (!last) return Error{last.error()};
  for (const auto& row : *last)
    for (auto& s : out)
      if (s.code == str(row[0])) {
        if (dbl(row[2]) > 0) s.last_pct = 100.0 * dbl(row[1]) / dbl(row[2]);
        s.last_incomplete = i64(row[3]) > 0;
      }
  return out;
}

namespace {
// The filter's conditions on students (st), exercises (e) and stations (sta), as numbered parameters.
void add_filter(const SessionFilter& f, std::string& sql, std::vector<Value>& p) {
  if (!f.student.empty()) {
    p.push_back(S(f.student));
    sql += " AND st.code = $" + std::to_string(p.size());
  }
  if (!f.exercise.empty()) {
    p.push_back(S(f.exercise));
    sql += " AND e.name = $" + std::to_string(p.size());
  }
  if (!f.station.empty()) {
    p.push_back(S(f.station));
    sql += " AND sta.code = $" + std::to_string(p.size());
  }
}
}  // namespace

Result<std::vector<SessionSummary>> Store::sessions(const SessionFilter& f) {
  std::string sql = std::string("SELECT ") + kSummaryCols + kSummaryFrom + " WHERE 1=1";
  std::vector<Value> p;
  add_filter(f, sql, p);
  sql += " ORDER BY s.started_utc, s.id";
  if (f.limit) sql += " LIMIT " + std::to_string(f.limit);
  auto r = db_->query(sql, p);
  if (!r) return Error{r.error()};
  std::vector<SessionSummary> out;
  out.reserve(r->size());
  for (const auto& row : *r) out.push_back(summary_from(row));
  return out;
}

Result<std::vector<TrainingRow>> Store::training(const SessionFilter& f) {
  auto ss = sessions(f);
  if (!ss) return Error{ss.error()};
  std::vector<TrainingRow> out;
  if (ss->empty()) return out;
  std::map<std::int64_t, std::size_t> at;
  for (const auto& x : *ss) at.emplace(x.id, at.size());
  std::vector<std::optional<TrainingRow>> rows(ss->size());
  std::string sql = "SELECT m.session_id, m.name, m.value FROM metrics m JOIN sessions s ON s.id = m.session_id "
                    "JOIN students st ON st.id = s.student_id JOIN exercises e ON e.id = s.exercise_id "
                    "JOIN stations sta ON sta.id = s.station_id WHERE m.name LIKE 'training.%'";
  std::vector<Value> p;
  add_filter(f, sql, p);
  auto r = db_->query(sql, p);
  if (!r) return Error{r.error()};
  for (const auto& row : *r) {
    const auto it = at.find(i64(row[0]));
    if (it == at.end()) continue;  // beyond the filter's limit
    auto& t = rows[it->second];
    if (!t) t.emplace();
    const std::string name = str(row[1]);
    const double v = dbl(row[2]);
    if (name == "training.mode") t->mode = static_cast<int>(v);
    else if (name == "training.follow_error_mm.mean") t->follow_mean_mm = v;
    else if (name == "training.follow_error_mm.p95") t->follow_p95_mm = v;
    else if (name == "training.guidance.as_needed") t->as_needed = v != 0;
    else if (name == "training.guidance.across_path_only") t->across_path_only = v != 0;
    else if (name == "training.guidance.repetition") t->repetition = static_cast<int>(v);
    else if (name == "training.guidance.fade") t->fade = v;
    else if (name == "training.guidance.amplify") t->amplify = v;
    else if (name == "training.expert_cut") t->expert_cut = v != 0;
  }
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (!rows[i] || rows[i]->mode < 1 || rows[i]->mode > 5) continue;
    TrainingRow t = *rows[i];
    const auto& x = (*ss)[i];
    t.id = x.id;
    t.started_utc = x.started_utc;
    t.exercise = x.exercise;
    t.points = x.points;
    t.max_points = x.max_points;
    if (t.mode >= 1 && t.mode <= 4) t.expert_cut = true;  // stored before score.json said cut_by
    out.push_back(t);
  }
  return out;
}

Result<std::vector<std::string>> Store::exercises() {
  auto r = db_->query("SELECT name FROM exercises ORDER BY name");
  if (!r) return Error{r.error()};
  std::vector<std::string> out;
  for (const auto& row : *r) out.push_back(str(row[0]));
  return out;
}

Status Store::move_session(const std::string& key, const std::string& student) {
  if (auto e = validate_code("student", student); !e.empty()) return Error{e};
  Db& db = *db_;
  if (auto s = db.begin_write(); !s) return Error{s.error()};
  auto id = upsert(db, "students", "code", student);
  if (!id) {
    db.rollback();
    return Error{id.error()};
  }
  auto r = db.query("UPDATE sessions SET student_id = $1 WHERE key = $2 RETURNING id", {I(*id), S(key)});
  if (!r || r->empty()) {
    db.rollback();
    return Error{r ? "session " + key.substr(0, 12) + ": not stored in " + url_.redacted : r.error()};
  }
  return db.commit();
}

Result<std::optional<SessionRecord>> Store::session_by_key(const std::string& key) {
  auto r = db_->query("SELECT id FROM sessions WHERE key = $1", {S(key)});
  if (!r) return Error{r.error()};
  if (r->empty()) return std::optional<SessionRecord>{};
  return session(i64((*r)[0][0]));
}

Result<std::optional<SessionRecord>> Store::session(std::int64_t id) {
  auto r = db_->query(
      "SELECT s.key, st.code, sta.code, e.name, e.title, s.started_utc, s.stored_utc, s.log_path, s.log_sha256, "
      "s.log_bytes, s.log_warning, s.recording_path, s.recording_sha256, s.report_dir, sc.points, sc.max_points, "
      "sc.coverage_pct, sc.overprep_mm3, sc.forbidden_mm3, sc.removed_mm3, sc.pulp_exposed, sc.perforation, "
      "sc.duration_s, sc.drilling_s, sc.path_mm, sc.excessive_force_s, rp.score_json, rp.score_html "
      "FROM sessions s JOIN students st ON st.id = s.student_id JOIN stations sta ON sta.id = s.station_id "
      "JOIN exercises e ON e.id = s.exercise_id LEFT JOIN scores sc ON sc.session_id = s.id "
      "LEFT JOIN reports rp ON rp.session_id = s.id WHERE s.id = $1",
      {I(id)});
  if (!r) return Error{r.error()};
  if (r->empty()) return std::optional<SessionRecord>{};
  const Row& x = (*r)[0];
  SessionRecord s;
  s.id = id;
  s.key = str(x[0]);
  s.student = str(x[1]);
  s.station = str(x[2]);
  s.exercise = str(x[3]);
  s.exercise_title = str(x[4]);
  s.started_utc = str(x[5]);
  s.stored_utc = str(x[6]);
  s.log_path = str(x[7]);
  s.log_sha256 = str(x[8]);
  s.log_bytes = i64(x[9]);
  s.log_warning = str(x[10]);
  s.recording_path = str(x[11]);
  s.recording_sha256 = str(x[12]);
  s.report_dir = str(x[13]);
  s.points = dbl(x[14]);
  s.max_points = dbl(x[15]);
  s.coverage_pct = dbl(x[16]);
  s.overprep_mm3 = dbl(x[17]);
  s.forbidden_mm3 = dbl(x[18]);
  s.removed_mm3 = dbl(x[19]);
  s.pulp_exposed = flag(x[20]);
  s.perforation = flag(x[21]);
  s.duration_s = dbl(x[22]);
  s.drilling_s = dbl(x[23]);
  s.path_mm = dbl(x[24]);
  s.excessive_force_s = dbl(x[25]);
  s.score_json = str(x[26]);
  s.score_html = str(x[27]);
  auto m = db_->query("SELECT name, value, unit FROM metrics WHERE session_id = $1 ORDER BY name", {I(id)});
  if (!m) return Error{m.error()};
  for (const auto& row : *m) s.metrics.push_back({str(row[0]), dbl(row[1]), str(row[2])});
  auto fb = db_->query("SELECT step, kind, text FROM feedback WHERE session_id = $1 ORDER BY idx", {I(id)});
  if (!fb) return Error{fb.error()};
  for (const auto& row : *fb) s.feedback.push_back({str(row[0]), str(row[1]), str(row[2])});
  auto st = db_->query(
      "SELECT name, start_s, end_s, drilling_s, path_mm, removed_mm3, fx, fy, fz, sdx, sdy, sdz, efx, efy, efz, esx, "
      "esy, esz FROM steps WHERE session_id = $1 ORDER BY idx",
      {I(id)});
  if (!st) return Error{st.error()};
  for (const auto& row : *st) {
    StepScore k;
    k.name = str(row[0]);
    k.start_s = dbl(row[1]);
    k.end_s = dbl(row[2]);
    k.drilling_s = dbl(row[3]);
    k.path_mm = dbl(row[4]);
    k.removed_mm3 = dbl(row[5]);
    for (int i = 0; i < 3; ++i) {
      k.force_N[i] = dbl(row[6 + i]);
      k.force_sd_N[i] = dbl(row[9 + i]);
      k.expert_force_N[i] = dbl(row[12 + i]);
      k.expert_sd_N[i] = dbl(row[15 + i]);
    }
    k.has_expert = row[12].has_value();
    s.steps.push_back(k);
  }
  return std::optional<SessionRecord>(std::move(s));
}

Result<std::int64_t> Store::count_sessions() {
  auto r = db_->query("SELECT COUNT(*) FROM sessions");
  if (!r) return Error{r.error()};
  return i64((*r)[0][0]);
}

Result<bool> Store::has_key(const std::string& key) {
  auto r = db_->query("SELECT 1 FROM sessions WHERE key = $1", {S(key)});
  if (!r) return Error{r.error()};
  return !r->empty();
}

Status Store::for_each(const std::function<Status(const SessionRecord&)>& f) {
  auto ids = db_->query("SELECT id FROM sessions ORDER BY started_utc, id");
  if (!ids) return Error{ids.error()};
  for (const auto& row : *ids) {
    auto s = session(i64(row[0]));
    if (!s) return Error{s.error()};
    if (!*s) continue;  // removed meanwhile
    if (auto st = f(**s); !st) return st;
  }
  return {};
}

Result<std::vector<Store::Queued>> Store::pending(std::size_t limit) {
  auto r = db_->query("SELECT key, payload, attempts FROM outbox WHERE sent_utc IS NULL ORDER BY queued_utc, key LIMIT " +
                      std::to_string(limit));
  if (!r) return Error{r.error()};
  std::vector<Queued> out;
  for (const auto& row : *r) out.push_back({str(row[0]), str(row[1]), static_cast<int>(i64(row[2]))});
  return out;
}

Result<std::int64_t> Store::pending_count() {
  auto r = db_->query("SELECT COUNT(*) FROM outbox WHERE sent_utc IS NULL");
  if (!r) return Error{r.error()};
  return i64((*r)[0][0]);
}

Status Store::mark_sent(const std::string& key) {
  auto r = db_->query("UPDATE outbox SET sent_utc = $2, attempts = attempts + 1, last_error = NULL WHERE key = $1",
                      {S(key), S(utc_now_iso())});
  if (!r) return Error{r.error()};
  return {};
}

Status Store::exec_raw(const std::string& sql) { return db_->exec(sql); }

Status Store::mark_failed(const std::string& key, const std::string& error) {
  auto r = db_->query("UPDATE outbox SET attempts = attempts + 1, last_error = $2 WHERE key = $1", {S(key), S(error)});
  if (!r) return Error{r.error()};
  return {};
}

}  // namespace dentar::store
