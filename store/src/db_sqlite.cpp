// SQLite backend: WAL journal, synchronous=FULL (a committed session survives
// a crash or power cut), foreign keys on, a busy handler for many writers.
#include <fcntl.h>
#include <sqlite3.h>
#include <unistd.h>

#include <charconv>
#include <chrono>
#include <cstdio>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <mutex>
#include <thread>

#include "db.h"

namespace dentar::store {
namespace {

std::mutex g_notice_mu;
std::function<void(const std::string&)> g_notice;


std::string damaged(const std::string& name, const std::string& detail) {
  return name + ": the database file is damaged (" + detail +
         "); nothing was read or written. Restore it from a backup, or save what is left with `sqlite3 " +
         name.substr(7) + " .recover | sqlite3 recovered.db` and use that file";
}

class SqliteDb final : public Db {
 public:
  SqliteDb(sqlite3* db, std::string name) : db_(db), name_(std::move(name)) {}
  ~SqliteDb() override { sqlite3_close_v2(db_); }
  bool postgres() const override { return false; }

  Status exec(const std::string& sql) override {
    char* err = nullptr;
    if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
      std::string m = err ? err : sqlite3_errmsg(db_);
      sqlite3_free(err);
      return Error{name_ + ": " + m};
    }
    return {};
  }

  Result<std::vector<Row>> query(const std::string& sql, const std::vector<Value>& params) override {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(db_, sql.c_str(), static_cast<int>(sql.size()), &st, nullptr) != SQLITE_OK)
      return Error{name_ + ": " + sqlite3_errmsg(db_)};
    struct Fin {
      sqlite3_stmt* s;
      ~Fin() { sqlite3_finalize(s); }
    } fin{st};
    for (std::size_t i = 0; i < params.size(); ++i) {
      // "$N" formatted in place: `"$" + std::to_string(..)` drew GCC 12's false -Wrestrict (bug 105329).
      char n[24];
      std::snprintf(n, sizeof n, "$%zu", i + 1);
      const int idx = sqlite3_bind_parameter_index(st, n);
      if (idx == 0) continue;  // parameter not used by this statement
      const int rc = params[i] ? sqlite3_bind_text(st, idx, params[i]->data(), static_cast<int>(params[i]->size()),
                                                   SQLITE_TRANSIENT)
                               : sqlite3_bind_null(st, idx);
      if (rc != SQLITE_OK) return Error{name_ + ": " + sqlite3_errmsg(db_)};
    }
    std::vector<Row> rows;
    for (;;) {
      const int rc = sqlite3_step(st);
      if (rc == SQLITE_DONE) break;
      if (rc != SQLITE_ROW) return Error{name_ + ": " + sqlite3_errmsg(db_)};
      const int n = sqlite3_column_count(st);
      Row r(static_cast<std::size_t>(n));
      for (int c = 0; c < n; ++c) {
        const int type = sqlite3_column_type(st, c);
        if (type == SQLITE_NULL) continue;
        if (type == SQLITE_FLOAT) {
          // SQLite's own text of a REAL has 15 digits and loses the last bits of a score
          // (0.23337749252479367 came back as 0.233377492524794): shortest round-trip text.
          char b[32];
          const auto e = std::to_chars(b, b + sizeof b, sqlite3_column_double(st, c));
          r[static_cast<std::size_t>(c)] = std::string(b, e.ptr);
          continue;
        }
        const auto* t = reinterpret_cast<const char*>(sqlite3_column_text(st, c));
        r[static_cast<std::size_t>(c)] = std::string(t ? t : "", static_cast<std::size_t>(sqlite3_column_bytes(st, c)));
      }
      rows.push_back(std::move(r));
    }
    return rows;
  }

  Status begin_write() override { return exec("BEGIN IMMEDIATE"); }
  const std::string& name() const { return name_; }

 private:
  sqlite3* db_;
  std::string name_;
};

}  // namespace

void lock_wait_notice(const std::string& text) {
  std::lock_guard lk(g_notice_mu);
  if (g_notice) g_notice(text);
}

void set_lock_wait_notice(std::function<void(const std::string&)> fn) {
  std::lock_guard lk(g_notice_mu);
  g_notice = std::move(fn);
}

Result<std::unique_ptr<Db>> open_sqlite(const DbUrl& url, bool create, bool check) {
  namespace fs = std::filesystem;
  bool existed = false;
  if (url.path != ":memory:") {
    std::error_code ec;
    existed = fs::exists(url.path, ec);
    if (!create && !existed)
      return Error{url.redacted + ": no such database file; create it with `dentar db init --db " + url.redacted + "`"};
    const fs::path parent = fs::path(url.path).parent_path();
    if (!parent.empty() && !fs::exists(parent, ec)) fs::create_directories(parent, ec);
    if (fs::is_directory(url.path, ec)) return Error{url.redacted + ": is a folder, expected a database file"};
    if (!existed) {
      // Created readable by the owner only (sessions name students); SQLite
      // gives its -wal and -shm files the database file's mode.
      const int fd = ::open(url.path.c_str(), O_CREAT | O_EXCL | O_WRONLY | O_CLOEXEC, 0600);
      if (fd >= 0) ::close(fd);
    }
  }
  sqlite3* db = nullptr;
  const int flags = SQLITE_OPEN_READWRITE | (create ? SQLITE_OPEN_CREATE : 0) | SQLITE_OPEN_NOMUTEX;
  if (sqlite3_open_v2(url.path.c_str(), &db, flags, nullptr) != SQLITE_OK) {
    std::string m = db ? sqlite3_errmsg(db) : "out of memory";
    sqlite3_close_v2(db);
    return Error{url.redacted + ": cannot open: " + m};
  }
  // Waiting for the write lock: retry every 1-2 ms for up to ~60 s. SQLite's
  // default busy timeout backs off to 100 ms sleeps, which lets a writer
  // starve for seconds among 30 (measured: p99 5.3 s vs the median 12 ms).
  // The first ~0.3 s of waiting is ordinary contention among writers; after
  // that the waiter says so (once per wait) instead of looking hung.
  auto d = std::make_unique<SqliteDb>(db, url.redacted);
  sqlite3_busy_handler(
      db,
      [](void* name, int n) -> int {
        if (n == 200)
          lock_wait_notice(*static_cast<const std::string*>(name) +
                 ": the database is locked by another program (an import or a migration); waiting up to 60 s");
        if (n >= 40000) return 0;
        thread_local unsigned seed = static_cast<unsigned>(reinterpret_cast<std::uintptr_t>(&n));
        seed = seed * 1103515245u + 12345u;
        std::this_thread::sleep_for(std::chrono::microseconds(1000 + (seed >> 16) % 1000));
        return 1;
      },
      const_cast<std::string*>(&d->name()));
  // A file that is not SQLite fails here ("file is not a database").
  if (auto s = d->exec("PRAGMA journal_mode=WAL; PRAGMA synchronous=FULL; PRAGMA foreign_keys=ON;"); !s) {
    if (s.error().find("malformed") != std::string::npos) return Error{damaged(url.redacted, s.error().substr(url.redacted.size() + 2))};
    return Error{s.error() + " (is it a DentAR SQLite database?)"};
  }
  // Damage inside the file (a torn or overwritten page) would otherwise look
  // like missing sessions: check the b-trees before anyone reads or writes.
  if (check && existed) {
    auto r = d->query("PRAGMA quick_check(5)", {});
    if (!r) return Error{damaged(url.redacted, "PRAGMA quick_check failed: " + r.error().substr(url.redacted.size() + 2))};
    std::string problems;
    for (const auto& row : *r)
      if (!row.empty() && row[0] && *row[0] != "ok") problems += (problems.empty() ? "" : "; ") + *row[0];
    if (!problems.empty()) return Error{damaged(url.redacted, "PRAGMA quick_check: " + problems)};
  }
  return std::unique_ptr<Db>(std::move(d));
}

}  // namespace dentar::store
