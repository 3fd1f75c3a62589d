// `dentar db` and `dentar serve` as a user runs them: import a scored
// session (scoring it when needed), idempotent re-import, status, export,
// a station whose server is down, bad input with clear messages.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <thread>

#include "dentar/store/auth.h"
#include "dentar/store/store.h"
#include "testkit.h"
#include "testutil.h"

namespace {
namespace fs = std::filesystem;
using dentar::test::CommandResult;

using dentar::test::run_dentar;

// One scored session: a `dentar demo` folder (the simulated hand, 2 s;
// session.dlog + score.json + score.html, ~3 s). Each test runs in its own
// process, so this is made once per test: it replaced a generated cohort
// scored against a reference trial (~13 s CPU, 33 s on a loaded machine,
// per test).
const fs::path& session() {
  static const fs::path dir = [] {
    const fs::path d = dentar::test::temp_dir("cli_db_demo");
    const CommandResult g = run_dentar("demo --simulated --seconds 2 --voxel-mm 0.2 --samples 2000 --out " + (d / "demo").string());
    EXPECT_EQ(g.code, 0) << g.out;
    EXPECT_TRUE(fs::exists(d / "demo" / "score.json"));
    return d / "demo";
  }();
  return dir;
}

TEST(CliDb, HelpHasSynopsisAndExample) {
  for (const char* sub : {"db", "serve", "db import", "db export"}) {
    const CommandResult r = run_dentar(std::string(sub) + " --help");
    EXPECT_EQ(r.code, 0) << sub;
    EXPECT_NE(r.out.find("Example"), std::string::npos) << sub << r.out;
  }
  EXPECT_NE(run_dentar("db --help").out.find("Synopsis"), std::string::npos);
  EXPECT_NE(run_dentar("serve --help").out.find("Synopsis"), std::string::npos);
}

TEST(CliDb, ImportStatusExportAndReimportOnce) {
  const fs::path d = dentar::test::temp_dir("cli_db_import");
  const std::string db = "sqlite:" + (d / "school.db").string();
  ASSERT_EQ(run_dentar("db init --db " + db).code, 0);
  const CommandResult r = run_dentar("db import " + session().string() + " --db " + db + " --student s042 --station-id st-3");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("of s042 (molar_access_opening"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("stored in " + db), std::string::npos) << r.out;
  const CommandResult again = run_dentar("db import " + session().string() + " --db " + db + " --student s042 --station-id st-3");
  ASSERT_EQ(again.code, 0) << again.out;
  EXPECT_NE(again.out.find("already stored"), std::string::npos) << again.out;
  const CommandResult st = run_dentar("db status --db " + db);
  EXPECT_EQ(st.code, 0);
  EXPECT_NE(st.out.find("schema version 3 (this program: 3), 1 sessions"), std::string::npos) << st.out;
  const CommandResult ex = run_dentar("db export --db " + db + " --out " + (d / "all.jsonl").string());
  ASSERT_EQ(ex.code, 0) << ex.out;
  std::ifstream in(d / "all.jsonl");
  std::string line;
  int n = 0;
  nlohmann::json j;
  while (std::getline(in, line)) j = nlohmann::json::parse(line), ++n;
  ASSERT_EQ(n, 1);
  EXPECT_EQ(j["student"], "s042");
  EXPECT_EQ(j["station"], "st-3");
  EXPECT_EQ(j["key"], *dentar::store::sha256_file((session() / "session.dlog").string()));
  const auto score = nlohmann::json::parse(dentar::test::read_file(session() / "score.json"));
  EXPECT_DOUBLE_EQ(j["points"].get<double>(), score["outcome"]["points"].get<double>());
  EXPECT_NE(j["score_html"].get<std::string>().find("<svg"), std::string::npos);
}

TEST(CliDb, UnscoredSessionIsScoredOnImport) {
  const fs::path d = dentar::test::temp_dir("cli_db_unscored");
  const fs::path s = d / "sess";
  fs::create_directories(s);
  fs::copy_file(session() / "session.dlog", s / "session.dlog");  // the log alone: not scored
  const std::string db = "sqlite:" + (d / "school.db").string();
  const CommandResult r = run_dentar("db import " + s.string() + " --db " + db + " --student s1 --station-id st");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("scoring"), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(s / "score.json"));
  EXPECT_TRUE(fs::exists(s / "score.html"));
}

TEST(CliDb, StationWithTheServerDownKeepsTheSessionQueued) {
  const fs::path d = dentar::test::temp_dir("cli_db_down");
  const std::string server = "postgresql://dentar@127.0.0.1:" + std::to_string(dentar::store::testkit::free_port()) + "/dentar";
  const std::string local = "sqlite:" + (d / "station.db").string();
  const CommandResult r = run_dentar("db import " + session().string() + " --db " + server + " --station-db " + local +
                              " --student s9 --station-id st-9");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("kept at this station"), std::string::npos) << r.out;
  const CommandResult f = run_dentar("db forward --db " + server + " --station-db " + local);
  EXPECT_EQ(f.code, 1);
  EXPECT_NE(f.out.find("1 still queued"), std::string::npos) << f.out;
  EXPECT_NE(f.out.find("the queued sessions are kept"), std::string::npos) << f.out;
  // The queue goes to a reachable store, once.
  const std::string other = "sqlite:" + (d / "school.db").string();
  const CommandResult ok = run_dentar("db forward --db " + other + " --station-db " + local);
  EXPECT_EQ(ok.code, 0) << ok.out;
  EXPECT_NE(ok.out.find("1 sent"), std::string::npos) << ok.out;
  EXPECT_NE(run_dentar("db forward --db " + other + " --station-db " + local).out.find("0 sent"), std::string::npos);
}

TEST(CliDb, BadInputIsExit2WithAMessage) {
  const fs::path d = dentar::test::temp_dir("cli_db_bad");
  const CommandResult url = run_dentar("db init --db mysql://x/y");
  EXPECT_EQ(url.code, 2);
  EXPECT_NE(url.out.find("expected sqlite:PATH or postgresql://"), std::string::npos) << url.out;
  const CommandResult nostu = run_dentar("db import " + session().string() + " --db sqlite:" + (d / "a.db").string());
  EXPECT_EQ(nostu.code, 2);
  EXPECT_NE(nostu.out.find("--student"), std::string::npos) << nostu.out;
  const CommandResult badstu = run_dentar("db import " + session().string() + " --db sqlite:" + (d / "a.db").string() + " --student 'a b'");
  EXPECT_EQ(badstu.code, 2);
  const CommandResult missing = run_dentar("db import " + (d / "nope").string() + " --db sqlite:" + (d / "a.db").string() + " --student s1");
  EXPECT_EQ(missing.code, 2);
  EXPECT_NE(missing.out.find("no such session folder"), std::string::npos) << missing.out;
  const CommandResult nodb = run_dentar("db status --db sqlite:" + (d / "absent.db").string());
  EXPECT_EQ(nodb.code, 2);  // bad input, as in `serve` (issue 26)
  EXPECT_NE(nodb.out.find("dentar db init"), std::string::npos) << nodb.out;
  // A database from a newer DentAR is refused by every command.
  {
    auto st = dentar::store::Store::open("sqlite:" + (d / "newer.db").string());
    ASSERT_TRUE(st.ok());
    ASSERT_TRUE((*st)->exec_raw("INSERT INTO dentar_schema(version, applied_utc) VALUES(42, 'x')").ok());
  }
  const CommandResult newer = run_dentar("db migrate --db sqlite:" + (d / "newer.db").string());
  EXPECT_EQ(newer.code, 2);
  EXPECT_NE(newer.out.find("newer than this program's"), std::string::npos) << newer.out;
  const CommandResult live = run_dentar("live --db sqlite:x.db --student s1 --seconds 1");
  EXPECT_EQ(live.code, 2);
  EXPECT_NE(live.out.find("--db needs --record DIR"), std::string::npos) << live.out;
}

// `dentar offline --db`: the replayed session is scored and stored.
TEST(CliDb, OfflineStoresTheReplayedSession) {
  const fs::path d = dentar::test::temp_dir("cli_db_offline");
  const std::string db = "sqlite:" + (d / "school.db").string();
  const CommandResult r = run_dentar("offline --out " + (d / "run").string() +
                              " --frames 20 --resolution 640x480 --no-video --quiet --db " + db +
                              " --student s5 --station-id st-off");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("offline: session"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("stored in " + db), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(d / "run" / "score.json"));  // scored beside the offline report
  auto st = dentar::store::Store::open(db);
  ASSERT_TRUE(st.ok());
  auto rec = (*st)->session_by_key(*dentar::store::sha256_file((d / "run" / "footage" / "session.dlog").string()));
  ASSERT_TRUE(rec.ok() && rec->has_value());
  EXPECT_EQ((**rec).student, "s5");
  EXPECT_EQ((**rec).station, "st-off");
  EXPECT_FALSE((**rec).score_html.empty());
}

// Issue 26: `dentar db import` takes the folders the program makes: an offline run (its log
// in footage/, score.json in the run folder) and a demo folder; the same session under another
// student is refused with both names unless --move, which moves it.
TEST(CliDb, ImportTakesOfflineAndDemoFoldersAndRefusesAnotherStudentUnlessMove) {
  const fs::path d = dentar::test::temp_dir("cli_db_folders");
  const std::string db = "sqlite:" + (d / "school.db").string();
  const CommandResult off = run_dentar("offline --out " + (d / "offline").string() +
                                " --frames 20 --resolution 640x480 --no-video --quiet");
  ASSERT_EQ(off.code, 0) << off.out;
  const CommandResult demo = run_dentar("demo --simulated --seconds 2 --voxel-mm 0.2 --samples 2000 --out " + (d / "demo").string());
  ASSERT_EQ(demo.code, 0) << demo.out;
  const CommandResult a = run_dentar("db import " + (d / "offline").string() + " --db " + db + " --student s1 --station-id st");
  ASSERT_EQ(a.code, 0) << a.out;
  EXPECT_NE(a.out.find("of s1 ("), std::string::npos) << a.out;
  EXPECT_EQ(a.out.find("no session log"), std::string::npos) << a.out;
  const CommandResult b = run_dentar("db import " + (d / "demo").string() + " --db " + db + " --student s1 --station-id st");
  ASSERT_EQ(b.code, 0) << b.out;
  const std::string key = *dentar::store::sha256_file((d / "offline" / "footage" / "session.dlog").string());
  {
    auto st = dentar::store::Store::open(db);
    ASSERT_TRUE(st.ok());
    EXPECT_EQ(*(*st)->count_sessions(), 2);
    auto rec = (*st)->session_by_key(key);
    ASSERT_TRUE(rec.ok() && rec->has_value());
    EXPECT_EQ((**rec).student, "s1");
    EXPECT_EQ(fs::path((**rec).report_dir).filename(), "offline");  // score.json of the run folder
  }
  // The same offline run under s2: refused, both named, nothing changed.
  const CommandResult other = run_dentar("db import " + (d / "offline").string() + " --db " + db + " --student s2 --station-id st");
  EXPECT_EQ(other.code, 2) << other.out;
  EXPECT_NE(other.out.find("already stored under student s1, not s2"), std::string::npos) << other.out;
  EXPECT_NE(other.out.find("--move"), std::string::npos) << other.out;
  {
    auto st = dentar::store::Store::open(db);
    EXPECT_EQ((**(*st)->session_by_key(key)).student, "s1");
  }
  // --move: stored under s2 now, and the message says from whom.
  const CommandResult moved =
      run_dentar("db import " + (d / "offline").string() + " --db " + db + " --student s2 --station-id st --move");
  ASSERT_EQ(moved.code, 0) << moved.out;
  EXPECT_NE(moved.out.find("of s2 ("), std::string::npos) << moved.out;
  EXPECT_NE(moved.out.find("moved from student s1"), std::string::npos) << moved.out;
  {
    auto st = dentar::store::Store::open(db);
    EXPECT_EQ((**(*st)->session_by_key(key)).student, "s2");
    EXPECT_EQ(*(*st)->count_sessions(), 2);
  }
  // A folder that is none of these: the message says what was looked for.
  fs::create_directories(d / "empty");
  const CommandResult none = run_dentar("db import " + (d / "empty").string() + " --db " + db + " --student s1");
  EXPECT_EQ(none.code, 2);
  EXPECT_NE(none.out.find("footage/session.dlog"), std::string::npos) << none.out;
  // A damaged database: bad input (2), as db status and serve.
  {
    std::ofstream bad(d / "bad.db", std::ios::binary);
    bad << std::string(8192, 'x');
  }
  const CommandResult dmg = run_dentar("db import " + (d / "demo").string() + " --db sqlite:" + (d / "bad.db").string() +
                                " --student s1 --station-id st");
  EXPECT_EQ(dmg.code, 2) << dmg.out;
  EXPECT_EQ(run_dentar("db status --db sqlite:" + (d / "bad.db").string()).code, 2);
}

// `dentar live --record --db` in a real window (Xvfb): the recording is
// scored and stored with its recording hash.
TEST(CliDb, LiveStoresTheRecordedSession) {
  ASSERT_EQ(std::system("command -v xvfb-run >/dev/null 2>&1"), 0) << "xvfb-run missing (tools/bootstrap.sh installs xvfb)";
  const fs::path d = dentar::test::temp_dir("cli_db_live");
  ASSERT_EQ(run_dentar("synth --preset standard --frames 30 --resolution 640x480 --seed 3 --out " + (d / "clip").string()).code, 0);
  const std::string db = "sqlite:" + (d / "school.db").string();
  const CommandResult r = dentar::test::run_command(
      "xvfb-run -a -s '-screen 0 1280x1024x24' " + std::string(DENTAR_BINARY) + " live --camera live:" +
      (d / "clip" / "video.mkv").string() + " --station " + (d / "clip" / "station.json").string() +
      " --stylus replay:" + (d / "clip" / "session.dlog").string() + " --record " + (d / "rec").string() +
      " --no-hud --quiet --db " + db + " --student s6 --station-id st-live 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("live: session"), std::string::npos) << r.out;
  auto st = dentar::store::Store::open(db);
  ASSERT_TRUE(st.ok());
  auto rec = (*st)->session_by_key(*dentar::store::sha256_file((d / "rec" / "session.dlog").string()));
  ASSERT_TRUE(rec.ok() && rec->has_value());
  EXPECT_EQ((**rec).student, "s6");
  EXPECT_EQ((**rec).recording_sha256.size(), 64u);
  EXPECT_EQ((**rec).started_utc.size(), 20u);  // recording.json "started"
}

TEST(CliServe, SetPasswordThenRefusesBadSetups) {
  const fs::path d = dentar::test::temp_dir("cli_serve");
  const std::string pw = (d / "pw.txt").string();
  const CommandResult s = dentar::test::run_command("echo 'a-long-password' | " + std::string(DENTAR_BINARY) +
                                                    " serve --passwords " + pw + " --set-password alice --iterations 100000");
  ASSERT_EQ(s.code, 0) << s.out;
  EXPECT_NE(dentar::test::read_file(pw).find("alice:pbkdf2-sha256:100000:"), std::string::npos);
  const CommandResult nodb = run_dentar("serve --passwords " + pw + " --db sqlite:" + (d / "absent.db").string());
  EXPECT_EQ(nodb.code, 2);
  EXPECT_NE(nodb.out.find("no such database file"), std::string::npos) << nodb.out;
  const CommandResult nopw = run_dentar("serve --passwords " + (d / "none.txt").string() + " --db sqlite:x.db");
  EXPECT_EQ(nopw.code, 2);
  EXPECT_NE(nopw.out.find("cannot read the password file"), std::string::npos) << nopw.out;
  const CommandResult certs = run_dentar("serve --passwords " + pw + " --db sqlite:x.db --cert a.pem");
  EXPECT_EQ(certs.code, 2);
  EXPECT_NE(certs.out.find("--cert and --key"), std::string::npos) << certs.out;
}

// Issue 26: a page overwritten in the middle of the file. `db status`,
// `serve` and `db import` all refuse it with exit 2 and the reason
// (PRAGMA quick_check); the same file undamaged passes.
TEST(CliDb, CorruptedPageInTheMiddleIsRefusedEverywhere) {
  const fs::path d = dentar::test::temp_dir("cli_db_corrupt");
  const fs::path file = d / "school.db";
  const std::string db = "sqlite:" + file.string();
  {
    auto st = dentar::store::Store::open(db);
    ASSERT_TRUE(st.ok()) << st.error();
    for (int k = 0; k < 120; ++k)
      ASSERT_TRUE((*st)->put(dentar::store::testkit::make_record("s" + std::to_string(k % 7), "st-1",
                                                                 "molar_access_opening", 500 + k, k))
                      .ok());
  }
  const std::string pw = (d / "pw.txt").string();
  ASSERT_TRUE(dentar::store::set_password(pw, "alice", "correct-horse-battery", 100000).ok());
  const CommandResult good = run_dentar("db status --db " + db);
  ASSERT_EQ(good.code, 0) << good.out;
  EXPECT_NE(good.out.find("120 sessions; PRAGMA quick_check: ok"), std::string::npos) << good.out;
  // Overwrite one 4 KiB page half way through the file.
  const auto size = fs::file_size(file);
  ASSERT_GT(size, 40u * 4096u);
  {
    std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(size / 2 / 4096 * 4096));
    const std::string junk(4096, '\xa5');
    f.write(junk.data(), static_cast<std::streamsize>(junk.size()));
  }
  const CommandResult status = run_dentar("db status --db " + db);
  EXPECT_EQ(status.code, 2) << status.out;
  EXPECT_NE(status.out.find(db + ": the database file is damaged (PRAGMA quick_check"), std::string::npos) << status.out;
  EXPECT_NE(status.out.find("Restore it from a backup"), std::string::npos) << status.out;
  const CommandResult serve = dentar::test::run_command("timeout 30 " + std::string(DENTAR_BINARY) + " serve --db " + db +
                                                        " --passwords " + pw + " --port 0");
  EXPECT_EQ(serve.code, 2) << serve.out;
  EXPECT_NE(serve.out.find(db + ": the database file is damaged (PRAGMA quick_check"), std::string::npos) << serve.out;
  const CommandResult imp = run_dentar("db import " + session().string() + " --db " + db + " --student s042 --station-id st-3");
  EXPECT_EQ(imp.code, 2) << imp.out;
  EXPECT_NE(imp.out.find("the database file is damaged"), std::string::npos) << imp.out;
}

// The SQLite file is created readable by its owner only; a password in a
// PostgreSQL URL is refused (it would show in `ps`) with what to do instead.
TEST(CliDb, PrivateFileAndNoPasswordOnTheCommandLine) {
  const fs::path d = dentar::test::temp_dir("cli_db_private");
  ASSERT_EQ(run_dentar("db init --db sqlite:" + (d / "s.db").string()).code, 0);
  struct stat sb {};
  ASSERT_EQ(::stat((d / "s.db").c_str(), &sb), 0);
  EXPECT_EQ(sb.st_mode & 0777, 0600u);
  for (const std::string cmd : {"db status --db ", "db init --db ", "serve --passwords x.txt --db "}) {
    const CommandResult r = run_dentar(cmd + "postgresql://dentar:s3cret-pw@127.0.0.1:1/dentar");
    EXPECT_EQ(r.code, 2) << cmd << r.out;
    EXPECT_NE(r.out.find("postgresql://dentar:***@127.0.0.1:1/dentar: a password on the command line"), std::string::npos)
        << cmd << r.out;
    EXPECT_NE(r.out.find("PGPASSWORD"), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("s3cret"), std::string::npos) << r.out;
  }
  const CommandResult q = run_dentar("db status --db 'postgresql://dentar@127.0.0.1:1/dentar?password=s3cret'");
  EXPECT_EQ(q.code, 2) << q.out;
  EXPECT_EQ(q.out.find("s3cret"), std::string::npos) << q.out;
}

// An importer that finds the database locked says so at once, then stores
// the session when the lock is released.
TEST(CliDb, ImporterWaitingOnALockSaysSo) {
  const fs::path d = dentar::test::temp_dir("cli_db_lock");
  const std::string db = "sqlite:" + (d / "school.db").string();
  ASSERT_EQ(run_dentar("db init --db " + db).code, 0);
  auto holder = dentar::store::Store::open(db);
  ASSERT_TRUE(holder.ok());
  ASSERT_TRUE((*holder)->exec_raw("BEGIN IMMEDIATE").ok());
  // The importer may score the session first (seconds): the lock is held
  // until it says it waits (or 120 s pass), then released.
  const fs::path log = d / "import.log";
  CommandResult r;
  std::thread import([&] {
    r = run_dentar("db import " + session().string() + " --db " + db + " --student s042 --station-id st-3 > " +
            log.string() + " 2>&1");
  });
  const std::string notice = "db import: " + db + ": the database is locked by another program";
  for (int i = 0; i < 1200 && dentar::test::read_file(log).find(notice) == std::string::npos; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  (void)(*holder)->exec_raw("COMMIT");
  import.join();
  r.out = dentar::test::read_file(log);
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find(notice), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("stored in " + db), std::string::npos) << r.out;
}

// The same on PostgreSQL (issue 26): another connection holds a lock on the
// sessions table in an open transaction. The importer (through this
// station's queue to the server) says at once that it waits and who holds
// the lock, then sends the session when the lock is released.
TEST(CliDb, PgImporterWaitingOnALockSaysSo) {
  const fs::path sess = session();  // scored before the clock starts
  dentar::store::testkit::PgCluster pg;
  ASSERT_TRUE(pg.ok()) << pg.error();
  {
    auto admin = dentar::store::Store::open(pg.url("postgres"));
    ASSERT_TRUE(admin.ok()) << admin.error();
    ASSERT_TRUE((*admin)->exec_raw("CREATE DATABASE school").ok());
  }
  const std::string db = pg.url("school");
  const CommandResult init = run_dentar("db init --db " + db);
  ASSERT_EQ(init.code, 0) << init.out;
  const fs::path d = dentar::test::temp_dir("cli_db_pglock");
  auto holder = dentar::store::Store::open(db);
  ASSERT_TRUE(holder.ok()) << holder.error();
  ASSERT_TRUE((*holder)->exec_raw("BEGIN; LOCK TABLE sessions IN EXCLUSIVE MODE").ok());
  const fs::path log = d / "import.log";
  CommandResult r;
  std::thread import([&] {
    r = run_dentar("db import " + sess.string() + " --db " + db + " --station-db sqlite:" + (d / "station.db").string() +
            " --student s042 --station-id st-3 > " + log.string() + " 2>&1");
  });
  const std::string notice = "db import: " + db + ": a lock is held by another connection (process ";
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < 600 && dentar::test::read_file(log).find(notice) == std::string::npos; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  const double waited_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  (void)(*holder)->exec_raw("COMMIT");
  import.join();
  r.out = dentar::test::read_file(log);
  std::cout << "the notice " << waited_s << " s after the import started:\n" << r.out;
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find(notice), std::string::npos) << r.out;
  // The holder named: our Store's connection, idle in its open transaction.
  EXPECT_NE(r.out.find(", 'dentar' as dentar, idle in transaction for "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("; waiting up to 60 s"), std::string::npos) << r.out;
  EXPECT_LT(waited_s, 30.0) << "the notice came late (the lock timeout is 60 s)";
  EXPECT_NE(r.out.find("stored at the station"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("and sent to " + db), std::string::npos) << r.out;
  auto st = dentar::store::Store::open(db);
  ASSERT_TRUE(st.ok());
  EXPECT_EQ(*(*st)->count_sessions(), 1);
}

}  // namespace
