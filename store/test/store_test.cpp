// The session store on SQLite: URLs, round trip, idempotent keys, migrations
// from every earlier schema, a newer schema refused, 30 stations writing one
// file at once, a station killed mid-write, store-and-forward with the
// server unreachable, password files.
#include <gtest/gtest.h>

#include <chrono>
#include <ctime>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <map>
#include <set>
#include <thread>

#include "dentar/store/auth.h"
#include "dentar/store/station.h"
#include "dentar/store/store.h"
#include "testkit.h"
#include "testutil.h"

namespace {
namespace fs = std::filesystem;
using namespace dentar::store;
using dentar::store::testkit::make_record;

std::unique_ptr<Store> open_ok(const std::string& url, OpenOptions o = {}) {
  auto s = Store::open(url, o);
  EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.error());
  return s.ok() ? std::move(*s) : nullptr;
}

TEST(DbUrl, ParsesAndRedactsAndRejectsWithMessages) {
  auto a = parse_db_url("sqlite:school.db");
  ASSERT_TRUE(a.ok());
  EXPECT_EQ(a->kind, DbUrl::Kind::Sqlite);
  EXPECT_EQ(a->path, "school.db");
  auto b = parse_db_url("postgresql://dentar:s3cret@db.example:5433/dentar?sslmode=require");
  ASSERT_TRUE(b.ok());
  EXPECT_EQ(b->kind, DbUrl::Kind::Postgres);
  EXPECT_EQ(b->redacted, "postgresql://dentar:***@db.example:5433/dentar?...");
  EXPECT_EQ(b->redacted.find("s3cret"), std::string::npos);
  auto c = parse_db_url("mysql://x/y");
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().find("expected sqlite:PATH or postgresql://"), std::string::npos) << c.error();
  auto d = parse_db_url("postgresql://h:99999/db");
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.error().find("port '99999' must be 1-65535"), std::string::npos) << d.error();
  EXPECT_FALSE(parse_db_url("sqlite:").ok());
}

TEST(Store, RoundTripAndIdempotentKey) {
  const fs::path dir = dentar::test::temp_dir("store_roundtrip");
  auto st = open_ok("sqlite:" + (dir / "s.db").string());
  ASSERT_TRUE(st);
  EXPECT_EQ(st->schema_version(), kSchemaVersion);
  SessionRecord r = make_record("s01", "st-1", "molar_access_opening", 7, 100);
  r.recording_path = "/rec/1";
  r.recording_sha256 = std::string(64, 'a');
  r.log_warning = "truncated: kept 10 records";
  r.steps[1].has_expert = false;
  auto p = st->put(r);
  ASSERT_TRUE(p.ok()) << p.error();
  EXPECT_EQ(*p, PutOutcome::Stored);
  auto p2 = st->put(r);
  ASSERT_TRUE(p2.ok());
  EXPECT_EQ(*p2, PutOutcome::AlreadyPresent);
  EXPECT_EQ(*st->count_sessions(), 1);
  auto got = st->session_by_key(r.key);
  ASSERT_TRUE(got.ok() && got->has_value());
  const SessionRecord& g = **got;
  EXPECT_EQ(g.student, "s01");
  EXPECT_EQ(g.station, "st-1");
  EXPECT_EQ(g.exercise, "molar_access_opening");
  EXPECT_EQ(g.started_utc, r.started_utc);
  EXPECT_DOUBLE_EQ(g.points, r.points);
  EXPECT_DOUBLE_EQ(g.coverage_pct, r.coverage_pct);
  EXPECT_DOUBLE_EQ(g.path_mm, r.path_mm);
  EXPECT_EQ(g.pulp_exposed, r.pulp_exposed);
  EXPECT_EQ(g.log_sha256, r.log_sha256);
  EXPECT_EQ(g.log_bytes, r.log_bytes);
  EXPECT_EQ(g.log_warning, r.log_warning);
  EXPECT_EQ(g.recording_sha256, r.recording_sha256);
  EXPECT_EQ(g.score_html, r.score_html);
  EXPECT_EQ(g.score_json, r.score_json);
  ASSERT_EQ(g.metrics.size(), r.metrics.size());
  ASSERT_EQ(g.steps.size(), 4u);
  EXPECT_DOUBLE_EQ(g.steps[0].force_N[2], r.steps[0].force_N[2]);
  EXPECT_DOUBLE_EQ(g.steps[0].expert_sd_N[2], r.steps[0].expert_sd_N[2]);
  EXPECT_FALSE(g.steps[1].has_expert);
  ASSERT_EQ(g.feedback.size(), 4u);
  EXPECT_EQ(g.feedback[2].text, r.feedback[2].text);
  // Summaries and filters.
  ASSERT_TRUE(st->put(make_record("s02", "st-1", "incisor_partial_crown", 8, 200)).ok());
  SessionFilter f;
  f.student = "s02";
  auto ss = st->sessions(f);
  ASSERT_TRUE(ss.ok());
  ASSERT_EQ(ss->size(), 1u);
  EXPECT_EQ((*ss)[0].exercise, "incisor_partial_crown");
  EXPECT_TRUE((*ss)[0].has_report);
  auto studs = st->students();
  ASSERT_TRUE(studs.ok());
  ASSERT_EQ(studs->size(), 2u);
  EXPECT_NEAR((*studs)[0].mean_pct, 100 * r.points / 18, 1e-9);
  // JSON round trip (export format, outbox payload).
  auto back = record_from_json(to_json(g));
  ASSERT_TRUE(back.ok()) << back.error();
  EXPECT_EQ(back->key, g.key);
  EXPECT_EQ(back->steps.size(), 4u);
  // A bad code is refused with a message naming it.
  SessionRecord bad = make_record("s 01; DROP", "st-1", "x", 9, 1);
  auto pb = st->put(bad);
  ASSERT_FALSE(pb.ok());
  EXPECT_NE(pb.error().find("student 's 01; DROP'"), std::string::npos) << pb.error();
}

// Rows as schema version 1 wrote them (no recording, report or steps).
const char* kV1Rows =
    "INSERT INTO students(code) VALUES('old1');"
    "INSERT INTO stations(code) VALUES('st-old');"
    "INSERT INTO exercises(name, title) VALUES('molar_access_opening', 'Access');"
    "INSERT INTO sessions(key, student_id, station_id, exercise_id, started_utc, stored_utc, log_path, log_sha256, "
    "log_bytes) VALUES('k-old-1', 1, 1, 1, '2026-01-02T03:04:05Z', '2026-01-02T03:05:00Z', '/x/session.dlog', 'k-old-1', 10);"
    "INSERT INTO scores(session_id, points, max_points, pulp_exposed, perforation, duration_s) VALUES(1, 9, 18, 0, 0, 60);"
    "INSERT INTO metrics(session_id, name, value, unit) VALUES(1, 'process.path_mm', 321, 'mm');"
    "INSERT INTO feedback(session_id, idx, step, kind, text) VALUES(1, 0, 'outline', 'ask', 'old feedback');";
const char* kV2Rows =
    "INSERT INTO reports(session_id, score_json, score_html) VALUES(1, '{}', '<p>v2 report</p>');"
    "INSERT INTO steps(session_id, idx, name, fz, efz, esz) VALUES(1, 0, 'outline', -0.8, -1.0, 0.2);";

void check_migrated(Store& st, int from) {
  EXPECT_EQ(st.schema_version(), kSchemaVersion);
  auto old = st.session_by_key("k-old-1");
  ASSERT_TRUE(old.ok() && old->has_value()) << "from v" << from;
  EXPECT_EQ((*old)->student, "old1");
  EXPECT_DOUBLE_EQ((*old)->points, 9);
  ASSERT_EQ((*old)->metrics.size(), 1u);
  EXPECT_EQ((*old)->feedback.at(0).text, "old feedback");
  if (from >= 2) {
    EXPECT_EQ((*old)->score_html, "<p>v2 report</p>");
    ASSERT_EQ((*old)->steps.size(), 1u);
    EXPECT_DOUBLE_EQ((*old)->steps[0].expert_force_N[2], -1.0);
  } else {
    EXPECT_TRUE((*old)->score_html.empty());
  }
  // The migrated database takes new sessions, queued ones too.
  auto p = st.put_and_queue(make_record("new1", "st-1", "molar_access_opening", 3, 5));
  ASSERT_TRUE(p.ok()) << p.error();
  EXPECT_EQ(*st.count_sessions(), 2);
  EXPECT_EQ(*st.pending_count(), 1);
}

void migrate_from_each_version(const std::function<std::string(int)>& url_for) {
  for (int from = 1; from < kSchemaVersion; ++from) {
    SCOPED_TRACE("from schema version " + std::to_string(from));
    const std::string url = url_for(from);
    {
      OpenOptions o;
      o.target_version = from;
      auto old = open_ok(url, o);
      ASSERT_TRUE(old);
      EXPECT_EQ(old->schema_version(), from);
      ASSERT_TRUE(old->exec_raw(kV1Rows).ok());
      if (from >= 2) {
        ASSERT_TRUE(old->exec_raw(kV2Rows).ok());
      }
    }
    {  // Refused without migration, with the command to run.
      OpenOptions o;
      o.migrate = false;
      auto r = Store::open(url, o);
      ASSERT_FALSE(r.ok());
      EXPECT_NE(r.error().find("dentar db migrate"), std::string::npos) << r.error();
    }
    auto st = open_ok(url);
    ASSERT_TRUE(st);
    check_migrated(*st, from);
  }
}

void newer_schema_refused(const std::string& url) {
  {
    auto st = open_ok(url);
    ASSERT_TRUE(st);
    ASSERT_TRUE(st->put(make_record("s1", "st", "ex", 1, 1)).ok());
    ASSERT_TRUE(st->exec_raw("INSERT INTO dentar_schema(version, applied_utc, program) VALUES(99, 'x', 'dentar 9')").ok());
  }
  auto r = Store::open(url);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("schema is version 99, newer than this program's (" + std::to_string(kSchemaVersion) + ")"),
            std::string::npos)
      << r.error();
  EXPECT_NE(r.error().find("Upgrade dentar"), std::string::npos);
}

TEST(Store, MigratesFromEveryEarlierSchemaVersion) {
  const fs::path dir = dentar::test::temp_dir("store_migrate");
  migrate_from_each_version([&](int v) { return "sqlite:" + (dir / ("v" + std::to_string(v) + ".db")).string(); });
}

TEST(Store, RefusesANewerSchema) {
  const fs::path dir = dentar::test::temp_dir("store_newer");
  newer_schema_refused("sqlite:" + (dir / "n.db").string());
}

TEST(Store, ThirtyStationsWriteOneSqliteFileAtOnce) {
  const fs::path dir = dentar::test::temp_dir("store_30");
  const std::string url = "sqlite:" + (dir / "school.db").string();
  ASSERT_TRUE(open_ok(url));
  std::atomic<int> failures{0}, dup{0};
  std::vector<std::thread> th;
  for (int s = 0; s < 30; ++s)
    th.emplace_back([&, s] {
      auto st = Store::open(url);
      if (!st) return (void)++failures;
      for (int k = 0; k < 10; ++k) {
        const auto r = make_record("stu" + std::to_string(s % 7), "st" + std::to_string(s), "molar_access_opening",
                                   1000 * s + k, k);
        auto p = (*st)->put(r);
        if (!p) ++failures;
        if (k < 3) {  // a retry after a lost acknowledgement
          auto again = (*st)->put(r);
          if (!again || *again != PutOutcome::AlreadyPresent) ++dup;
        }
      }
    });
  for (auto& t : th) t.join();
  EXPECT_EQ(failures, 0);
  EXPECT_EQ(dup, 0);
  auto st = open_ok(url);
  EXPECT_EQ(*st->count_sessions(), 300);
  auto all = st->sessions();
  std::set<std::string> keys;
  for (const auto& s : *all) keys.insert(s.key);
  EXPECT_EQ(keys.size(), 300u);
}

// A station process killed (SIGKILL) while storing: every session it had
// acknowledged (put_and_queue returned) is in the file, queued for the server.
TEST(Store, StationKilledMidWriteLosesNothingAcknowledged) {
  const fs::path dir = dentar::test::temp_dir("store_kill");
  const std::string url = "sqlite:" + (dir / "station.db").string();
  ASSERT_TRUE(open_ok(url));
  int fds[2];
  ASSERT_EQ(pipe(fds), 0);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    close(fds[0]);
    auto st = Store::open(url);
    if (!st) _exit(3);
    for (int k = 0;; ++k) {
      const auto r = make_record("s1", "st-kill", "molar_access_opening", 5000 + k, k);
      if (!(*st)->put_and_queue(r)) _exit(4);
      const std::string line = r.key + "\n";  // the acknowledgement
      if (write(fds[1], line.data(), line.size()) != static_cast<ssize_t>(line.size())) _exit(5);
    }
  }
  close(fds[1]);
  std::vector<std::string> acked;
  std::string buf;
  char c;
  while (acked.size() < 40 && read(fds[0], &c, 1) == 1) {
    if (c == '\n') acked.push_back(buf), buf.clear();
    else buf += c;
  }
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  close(fds[0]);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the writer ended by itself, status " << status;
  ASSERT_EQ(acked.size(), 40u);
  auto st = open_ok(url);
  for (const auto& k : acked) EXPECT_TRUE(*st->has_key(k)) << k;
  const auto n = *st->count_sessions();
  EXPECT_GE(n, 40);
  EXPECT_EQ(*st->pending_count(), n);  // every stored session is queued, none half-written
  ASSERT_TRUE(st->exec_raw("PRAGMA integrity_check").ok());
}

TEST(Station, ServerUnreachableKeepsTheSessionQueuedThenSendsItOnce) {
  const fs::path dir = dentar::test::temp_dir("store_outbox");
  const std::string local = "sqlite:" + (dir / "station.db").string();
  const std::string down = "postgresql://dentar@127.0.0.1:" + std::to_string(testkit::free_port()) + "/dentar";
  const auto r = make_record("s7", "st-3", "molar_access_opening", 77, 1);
  auto rep = store_session(r, local, down);
  ASSERT_TRUE(rep.ok()) << rep.error();
  EXPECT_TRUE(rep->stored_locally);
  EXPECT_EQ(rep->forward.queued, 1u);
  EXPECT_NE(rep->message.find("kept at this station"), std::string::npos) << rep->message;
  EXPECT_NE(rep->message.find("1 session(s) queued"), std::string::npos) << rep->message;
  // The server (here a SQLite file) comes back: sent once.
  const std::string server = "sqlite:" + (dir / "server.db").string();
  auto f = forward_outbox(local, server);
  EXPECT_EQ(f.sent, 1u);
  EXPECT_EQ(f.queued, 0u);
  EXPECT_TRUE(f.error.empty()) << f.error;
  auto again = forward_outbox(local, server);
  EXPECT_EQ(again.sent, 0u);
  EXPECT_EQ(*open_ok(server)->count_sessions(), 1);
  // A lost acknowledgement: the row is sent again, the server keeps one.
  ASSERT_TRUE(open_ok(local)->exec_raw("UPDATE outbox SET sent_utc = NULL").ok());
  auto resend = forward_outbox(local, server);
  EXPECT_EQ(resend.sent, 0u);
  EXPECT_EQ(resend.already, 1u);
  EXPECT_EQ(*open_ok(server)->count_sessions(), 1);
}

// store_session says why it failed, for the exit code (issue 26 review): a
// store that cannot be reached is Unavailable (exit 1), a damaged file or
// the session under another student without move is BadInput (exit 2, both
// students named, nothing changed); with move it moves, on the station's
// store and on the server.
TEST(Station, StoreSessionSaysWhyItFailedAndMovesOnlyWhenAsked) {
  const fs::path dir = dentar::test::temp_dir("store_session_fault");
  const auto r = make_record("s1", "st-1", "molar_access_opening", 5, 1);
  OpenFault f = OpenFault::None;
  const std::string down = "postgresql://dentar@127.0.0.1:" + std::to_string(testkit::free_port()) + "/dentar";
  auto unreachable = store_session(r, down, "", {}, &f);
  ASSERT_FALSE(unreachable.ok());
  EXPECT_EQ(f, OpenFault::Unavailable) << unreachable.error();
  {
    std::FILE* junk = std::fopen((dir / "junk.db").c_str(), "wb");
    ASSERT_NE(junk, nullptr);
    for (int i = 0; i < 8192; ++i) std::fputc('x', junk);
    std::fclose(junk);
  }
  f = OpenFault::None;
  auto damaged = store_session(r, "sqlite:" + (dir / "junk.db").string(), "", {}, &f);
  ASSERT_FALSE(damaged.ok());
  EXPECT_EQ(f, OpenFault::BadInput) << damaged.error();

  const std::string local = "sqlite:" + (dir / "station.db").string();
  const std::string server = "sqlite:" + (dir / "server.db").string();
  auto first = store_session(r, local, server, {}, &f);
  ASSERT_TRUE(first.ok()) << first.error();
  EXPECT_EQ(f, OpenFault::None);
  EXPECT_EQ(first->forward.sent, 1u);
  SessionRecord other = r;
  other.student = "s2";
  auto refused = store_session(other, local, server, {}, &f);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(f, OpenFault::BadInput);
  EXPECT_NE(refused.error().find("already stored under student s1, not s2: nothing was changed"), std::string::npos)
      << refused.error();
  EXPECT_EQ((**open_ok(local)->session_by_key(r.key)).student, "s1");
  StoreOptions move;
  move.move = true;
  auto moved = store_session(other, local, server, move, &f);
  ASSERT_TRUE(moved.ok()) << moved.error();
  EXPECT_EQ(f, OpenFault::None);
  EXPECT_EQ(moved->moved_from, "s1");
  EXPECT_TRUE(moved->already);
  EXPECT_EQ((**open_ok(local)->session_by_key(r.key)).student, "s2");
  EXPECT_EQ((**open_ok(server)->session_by_key(r.key)).student, "s2");
  EXPECT_EQ(*open_ok(server)->count_sessions(), 1);
}

TEST(Auth, HashVerifyAndPasswordFileErrorsNameTheLine) {
  const auto e = hash_password("correct horse", 2000);
  EXPECT_TRUE(verify_password(e, "correct horse"));
  EXPECT_FALSE(verify_password(e, "correct horsf"));
  EXPECT_EQ(e.hash.size(), 32u);
  const fs::path dir = dentar::test::temp_dir("store_auth");
  const std::string pf = (dir / "pw.txt").string();
  ASSERT_TRUE(set_password(pf, "alice", "alice-password", 100000).ok());
  ASSERT_TRUE(set_password(pf, "bob", "bob-password", 100000).ok());
  EXPECT_EQ(fs::status(pf).permissions() & fs::perms::others_read, fs::perms::none);
  auto f = load_password_file(pf);
  ASSERT_TRUE(f.ok()) << f.error();
  ASSERT_EQ(f->size(), 2u);
  EXPECT_TRUE(verify_password(f->at("alice"), "alice-password"));
  EXPECT_FALSE(verify_password(f->at("bob"), "alice-password"));
  EXPECT_FALSE(set_password(pf, "carol", "short", 2000).ok());
  // Issue 26: at least 12 characters, at least 100,000 iterations.
  const auto eleven = set_password(pf, "carol", "eleven-char", 100000);
  ASSERT_FALSE(eleven.ok());
  EXPECT_NE(eleven.error().find("11 characters, at least 12"), std::string::npos) << eleven.error();
  EXPECT_TRUE(set_password(pf, "carol", "twelve-chars", 100000).ok());
  EXPECT_FALSE(set_password(pf, "dave", "a-long-enough-password", 99999).ok());
  const std::string weak = (dir / "weak.txt").string();
  dentar::test::write_file(weak, "# old file\nalice:pbkdf2-sha256:1000:00112233445566778899aabbccddeeff:"
                                 "00112233445566778899aabbccddeeff00112233445566778899aabbccddeeff\n");
  auto few = load_password_file(weak);
  ASSERT_FALSE(few.ok());
  EXPECT_NE(few.error().find(weak + ": line 2: field 3 (iterations) is 1000, fewer than 100000"), std::string::npos)
      << few.error();
  EXPECT_NE(few.error().find("--set-password alice"), std::string::npos) << few.error();
  auto bad = parse_password_file("# c\nalice:pbkdf2-sha256:100000:0011:00\n");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("line 2: salt"), std::string::npos) << bad.error();
  auto scheme = parse_password_file("a:md5:1:00:00\n");
  ASSERT_FALSE(scheme.ok());
  EXPECT_NE(scheme.error().find("line 1: scheme 'md5' unknown"), std::string::npos) << scheme.error();
}

TEST(Record, ImportNeedsAScoredSessionAndSaysHow) {
  const fs::path dir = dentar::test::temp_dir("store_import");
  dentar::test::write_file(dir / "session.dlog", "not really a log");
  ImportOptions io;
  io.student = "s1";
  io.station = "st";
  auto r = record_from_session_dir(dir.string(), io);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("score.json: missing; score the session first (`dentar score"), std::string::npos) << r.error();
  io.student = "../etc";
  auto b = record_from_session_dir(dir.string(), io);
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().find("must not start with '.'"), std::string::npos) << b.error();
  dentar::test::write_file(dir / "score.json", R"({"format":"dentar-score","version":1,"exercise":{"name":"molar_access_opening"},
    "outcome":{"points":12.5,"max_points":18,"target_coverage_pct":91,"criteria":[{"name":"Mesial wall","score":2}]},
    "process":{"duration_s":80,"path_mm":640},"steps":[{"name":"outline","force_mean_N":[0,0,-1]}],
    "feedback":[{"step":0,"kind":"well_done","text":"good"},{"step":-1,"kind":"caution","text":"path"},{"step":"x","kind":7}]})");
  dentar::test::write_file(dir / "recording.json", R"({"format":"dentar-recording","started":"2026-11-20T09:30:00Z"})");
  io.student = "s1";
  auto ok = record_from_session_dir(dir.string(), io);
  ASSERT_TRUE(ok.ok()) << ok.error();
  EXPECT_EQ(ok->key, sha256_hex("not really a log"));
  EXPECT_EQ(ok->started_utc, "2026-11-20T09:30:00Z");
  EXPECT_DOUBLE_EQ(ok->points, 12.5);
  EXPECT_FALSE(ok->recording_sha256.empty());
  bool crit = false;
  for (const auto& m : ok->metrics) crit |= m.name == "outcome.criteria.Mesial wall.score" && m.value == 2;
  EXPECT_TRUE(crit);
  ASSERT_EQ(ok->feedback.size(), 3u);
  EXPECT_EQ(ok->feedback[0].step, "outline");  // score.json gives the step's index
  EXPECT_EQ(ok->feedback[1].step, "");         // the whole session
  EXPECT_EQ(ok->feedback[2].kind, "");         // a mistyped field is dropped, never a crash
}

TEST(Record, ABareLogStartsWhenItEndedLessItsDurationNotAtImport) {
  // Issue 25: without recording.json the page showed the log's write time
  // (the import, for a copied log) as the start. The log was last written
  // when the session ended; the start is that less process.duration_s.
  const fs::path dir = dentar::test::temp_dir("store_import_start");
  dentar::test::write_file(dir / "session.dlog", "a bare log");
  dentar::test::write_file(dir / "score.json", R"({"format":"dentar-score","version":1,"exercise":{"name":"molar_access_opening"},
    "outcome":{"points":3,"max_points":18,"complete":false},"process":{"duration_s":304.4}})");
  std::tm tm{};
  tm.tm_year = 2026 - 1900;
  tm.tm_mon = 10;
  tm.tm_mday = 20;
  tm.tm_hour = 10;
  const auto end = std::chrono::system_clock::from_time_t(timegm(&tm));  // 2026-11-20T10:00:00Z
  fs::last_write_time(dir / "session.dlog", std::chrono::file_clock::from_sys(end));
  ImportOptions io;
  io.student = "s1";
  io.station = "st";
  auto r = record_from_session_dir(dir.string(), io);
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->started_utc, "2026-11-20T09:54:55Z");  // 10:00:00 less 304.4 s, to the second
  bool incomplete = false;
  for (const auto& m : r->metrics) incomplete |= m.name == "outcome.complete" && m.value == 0;
  EXPECT_TRUE(incomplete);
}

TEST(Record, ATrainedSessionKeepsItsModeErrorsAndGuidance) {
  // Issue 27: run.json of `dentar lesson run` beside the log becomes metrics "training.*",
  // and Store::training() gives them back per session, in order.
  const fs::path dir = dentar::test::temp_dir("store_import_training");
  dentar::test::write_file(dir / "session.dlog", "a trained log");
  dentar::test::write_file(dir / "score.json", R"({"format":"dentar-score","version":1,"exercise":{"name":"molar_class1_cavity"},
    "cut_by":"expert","training_mode":2,"outcome":{"points":9,"max_points":18},"process":{"duration_s":30}})");
  dentar::test::write_file(dir / "run.json", R"({"mode": 2, "mode_name": "passive guidance", "fallback": "",
    "follow_error_mm": {"mean": 0.42, "p95": 0.9, "max": 1.3}, "expert_waited_s": 0,
    "guidance": {"as_needed": true, "across_path_only": false, "fade": 0.7, "repetition": 2, "amplify": 0, "k_N_per_m": 150}})");
  ImportOptions io;
  io.student = "t1";
  io.station = "st";
  auto r = record_from_session_dir(dir.string(), io);
  ASSERT_TRUE(r.ok()) << r.error();
  auto metric = [&](const std::string& n) {
    for (const auto& m : r->metrics)
      if (m.name == n) return m.value;
    return -99.0;
  };
  EXPECT_EQ(metric("training.mode"), 2);
  EXPECT_DOUBLE_EQ(metric("training.follow_error_mm.mean"), 0.42);
  EXPECT_DOUBLE_EQ(metric("training.follow_error_mm.p95"), 0.9);
  EXPECT_EQ(metric("training.guidance.as_needed"), 1);
  EXPECT_EQ(metric("training.guidance.repetition"), 2);
  const fs::path db = dir / "t.db";
  auto st = Store::open("sqlite:" + db.string());
  ASSERT_TRUE(st.ok()) << st.error();
  ASSERT_TRUE((*st)->put(*r).ok());
  SessionFilter f;
  f.student = "t1";
  auto tr = (*st)->training(f);
  ASSERT_TRUE(tr.ok()) << tr.error();
  ASSERT_EQ(tr->size(), 1u);
  EXPECT_EQ((*tr)[0].mode, 2);
  EXPECT_DOUBLE_EQ((*tr)[0].follow_mean_mm, 0.42);
  EXPECT_TRUE((*tr)[0].as_needed);
  EXPECT_EQ((*tr)[0].repetition, 2);
  EXPECT_DOUBLE_EQ((*tr)[0].points, 9);
  EXPECT_EQ(metric("training.expert_cut"), 1) << "mode 2: the score is the expert's cut";
  EXPECT_TRUE((*tr)[0].expert_cut);
  // A broken run.json is an error naming it, not a session without its training.
  dentar::test::write_file(dir / "run.json", R"({"mode": 9})");
  auto bad = record_from_session_dir(dir.string(), io);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("run.json: field mode"), std::string::npos) << bad.error();
  dentar::test::write_file(dir / "run.json", "{not json");
  bad = record_from_session_dir(dir.string(), io);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("run.json: not valid JSON"), std::string::npos) << bad.error();
}

TEST(Record, ALiveTrainedSessionTakesItsModeAndWhoseCutFromScoreJson) {
  // Issue 27: a live trained session has no run.json; score.json's training_mode and cut_by
  // still mark a mode 1-4 score as the expert's cut, and a mode 5 score as the student's.
  const fs::path dir = dentar::test::temp_dir("store_import_live_training");
  dentar::test::write_file(dir / "session.dlog", "a live trained log");
  ImportOptions io;
  io.student = "t2";
  io.station = "st";
  auto metrics_of = [&](const std::string& score) -> std::map<std::string, double> {
    dentar::test::write_file(dir / "score.json", score);
    auto r = record_from_session_dir(dir.string(), io);
    EXPECT_TRUE(r.ok()) << r.error();
    std::map<std::string, double> m;
    if (r.ok())
      for (const auto& x : r->metrics) m[x.name] = x.value;
    return m;
  };
  const std::string head = R"({"format":"dentar-score","version":1,"exercise":{"name":"molar_class1_cavity"},)";
  auto m3 = metrics_of(head + R"("cut_by":"expert","training_mode":3,"outcome":{"points":4,"max_points":18}})");
  EXPECT_EQ(m3["training.mode"], 3);
  EXPECT_EQ(m3["training.expert_cut"], 1);
  auto m5 = metrics_of(head + R"("cut_by":"student","training_mode":5,"outcome":{"points":4,"max_points":18}})");
  EXPECT_EQ(m5["training.mode"], 5);
  EXPECT_EQ(m5.count("training.expert_cut"), 0u);
  auto plain = metrics_of(head + R"("cut_by":"student","outcome":{"points":4,"max_points":18}})");
  EXPECT_EQ(plain.count("training.mode"), 0u);
  dentar::test::write_file(dir / "score.json", head + R"("cut_by":"expert","training_mode":7,"outcome":{}})");
  auto bad = record_from_session_dir(dir.string(), io);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("score.json: field training_mode = 7 must be 1..5"), std::string::npos) << bad.error();
}

}  // namespace
