// PostgreSQL backend through libpq: text parameters and results. A lost
// connection is reset once before a statement (the server restarted); a
// statement that fails mid-transaction fails the transaction, and the caller
// retries the whole session later (idempotent key).
//
// Lock waits are not silent (issue 26): every statement is sent without
// blocking; one that has no answer after 0.3 s is checked from a second,
// short-lived connection (pg_blocking_pids of ours in pg_stat_activity). If
// it waits for another connection's lock, the user is told at once who holds
// it, as SQLite's busy handler does; a slow statement that waits for no lock
// says nothing. lock_timeout = 60 s bounds the wait like SQLite's: then the
// statement (and its transaction) fails and the caller keeps the session.
#include <libpq-fe.h>
#include <poll.h>

#include <cerrno>
#include <chrono>

#include "db.h"

namespace dentar::store {
namespace {

using Clock = std::chrono::steady_clock;
constexpr int kLockTimeoutS = 60;
constexpr auto kFirstProbe = std::chrono::milliseconds(300);
constexpr auto kProbeEvery = std::chrono::seconds(1);

std::string trim(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s;
}

PGconn* connect(const std::string& uri, int connect_timeout_s, const char* app) {
  // Keywords override the URI's (connect_timeout: a server that is down fails fast).
  const std::string timeout = std::to_string(connect_timeout_s);
  const char* keys[] = {"dbname", "connect_timeout", "application_name", nullptr};
  const char* vals[] = {uri.c_str(), timeout.c_str(), app, nullptr};
  return PQconnectdbParams(keys, vals, 1);  // expand_dbname: the URI
}

class PgDb final : public Db {
 public:
  PgDb(PGconn* c, std::string name, std::string uri, int connect_timeout_s)
      : c_(c), name_(std::move(name)), uri_(std::move(uri)), connect_timeout_s_(connect_timeout_s) {}
  ~PgDb() override {
    if (probe_) PQfinish(probe_);
    PQfinish(c_);
  }
  bool postgres() const override { return true; }

  Status exec(const std::string& sql) override {
    if (auto s = ensure(); !s) return s;
    if (!PQsendQuery(c_, sql.c_str())) return Error{name_ + ": " + trim(PQerrorMessage(c_))};
    std::string err;
    for (PGresult* r : results()) {
      const auto st = PQresultStatus(r);
      if (err.empty() && st != PGRES_COMMAND_OK && st != PGRES_TUPLES_OK && st != PGRES_EMPTY_QUERY) err = message(r);
      PQclear(r);
    }
    if (!err.empty()) return Error{err};
    return {};
  }

  Result<std::vector<Row>> query(const std::string& sql, const std::vector<Value>& params) override {
    if (auto s = ensure(); !s) return Error{s.error()};
    std::vector<const char*> vals(params.size());
    for (std::size_t i = 0; i < params.size(); ++i) vals[i] = params[i] ? params[i]->c_str() : nullptr;
    if (!PQsendQueryParams(c_, sql.c_str(), static_cast<int>(params.size()), nullptr, vals.data(), nullptr, nullptr, 0))
      return Error{name_ + ": " + trim(PQerrorMessage(c_))};
    std::vector<PGresult*> all = results();
    PGresult* r = all.empty() ? nullptr : all.back();  // one statement: one result
    for (std::size_t i = 0; i + 1 < all.size(); ++i) PQclear(all[i]);
    const auto st = r ? PQresultStatus(r) : PGRES_FATAL_ERROR;
    if (st != PGRES_COMMAND_OK && st != PGRES_TUPLES_OK) {
      std::string err = message(r);
      PQclear(r);
      return Error{err};
    }
    std::vector<Row> rows(static_cast<std::size_t>(PQntuples(r)));
    const int nf = PQnfields(r);
    for (int i = 0; i < PQntuples(r); ++i) {
      Row& row = rows[static_cast<std::size_t>(i)];
      row.resize(static_cast<std::size_t>(nf));
      for (int f = 0; f < nf; ++f)
        if (!PQgetisnull(r, i, f)) row[static_cast<std::size_t>(f)] = std::string(PQgetvalue(r, i, f), PQgetlength(r, i, f));
    }
    PQclear(r);
    return rows;
  }

  Status begin_write() override { return exec("BEGIN"); }

 private:
  // Every result of the statement sent, waiting on the socket; a wait over
  // kFirstProbe is checked for a lock (once told, not again for this statement).
  std::vector<PGresult*> results() {
    auto next_probe = Clock::now() + kFirstProbe;
    bool told = false, can_probe = true;
    while (PQisBusy(c_)) {
      const int sock = PQsocket(c_);
      if (sock < 0) break;
      int wait_ms = -1;
      if (!told && can_probe)
        wait_ms = static_cast<int>(std::max<long>(
            0, std::chrono::duration_cast<std::chrono::milliseconds>(next_probe - Clock::now()).count()));
      pollfd p{sock, POLLIN, 0};
      const int n = ::poll(&p, 1, wait_ms);
      if (n > 0) {
        if (!PQconsumeInput(c_)) break;  // the connection broke: PQgetResult says why
        continue;
      }
      if (n < 0) {
        if (errno == EINTR) continue;
        break;  // PQgetResult reports what is left
      }
      const std::string holder = blocker(&can_probe);
      if (!holder.empty()) {
        told = true;
        lock_wait_notice(name_ + ": a lock is held by another connection (" + holder + "); waiting up to " +
                         std::to_string(kLockTimeoutS) + " s");
      }
      next_probe = Clock::now() + kProbeEvery;
    }
    std::vector<PGresult*> out;
    while (PGresult* r = PQgetResult(c_)) out.push_back(r);
    return out;
  }

  // Who holds the lock this connection waits for ("" if it waits for none,
  // or cannot be checked: then *again = false, no more checks).
  std::string blocker(bool* again) {
    if (!probe_ || PQstatus(probe_) != CONNECTION_OK) {
      if (probe_) PQfinish(probe_);
      probe_ = connect(uri_, connect_timeout_s_, "dentar lock check");
      if (!probe_ || PQstatus(probe_) != CONNECTION_OK) {
        if (probe_) PQfinish(probe_);
        probe_ = nullptr;
        *again = false;
        return "";
      }
    }
    const std::string pid = std::to_string(PQbackendPID(c_));
    const char* vals[] = {pid.c_str()};
    PGresult* r = PQexecParams(
        probe_,
        "SELECT b.pid, COALESCE(NULLIF(b.application_name, ''), '?'), COALESCE(b.usename, '?'), "
        "COALESCE(b.state, '?'), COALESCE(EXTRACT(EPOCH FROM now() - COALESCE(b.xact_start, b.query_start))::bigint, -1) "
        "FROM unnest(pg_blocking_pids($1::int)) AS w(pid) JOIN pg_stat_activity b ON b.pid = w.pid ORDER BY b.pid",
        1, nullptr, vals, nullptr, nullptr, 0);
    std::string who;
    if (PQresultStatus(r) == PGRES_TUPLES_OK) {
      for (int i = 0; i < PQntuples(r) && i < 3; ++i) {
        const std::string age = PQgetvalue(r, i, 4);
        who += std::string(i ? "; " : "") + "process " + PQgetvalue(r, i, 0) + ", '" + PQgetvalue(r, i, 1) +
               "' as " + PQgetvalue(r, i, 2) + ", " + PQgetvalue(r, i, 3) +
               (age != "-1" ? " for " + age + " s" : "");
      }
      if (PQntuples(r) > 3) who += "; and " + std::to_string(PQntuples(r) - 3) + " more";
    } else {
      *again = false;
    }
    PQclear(r);
    return who;
  }

  Status ensure() {
    if (probe_) {  // the last wait is over: give the connection back
      PQfinish(probe_);
      probe_ = nullptr;
    }
    if (PQstatus(c_) == CONNECTION_OK) return {};
    PQreset(c_);
    if (PQstatus(c_) != CONNECTION_OK) return Error{name_ + ": connection lost: " + trim(PQerrorMessage(c_))};
    setup(c_);
    return {};
  }
  std::string message(PGresult* r) const {
    std::string m = r ? PQresultErrorMessage(r) : "";
    if (m.empty()) m = PQerrorMessage(c_);
    m = name_ + ": " + trim(m);
    const char* code = r ? PQresultErrorField(r, PG_DIAG_SQLSTATE) : nullptr;
    if (code && std::string(code) == "55P03")
      m += " (another connection held a lock for more than " + std::to_string(kLockTimeoutS) + " s; nothing was written)";
    return m;
  }

 public:
  static void setup(PGconn* c) {
    // Server notices (e.g. "terminating connection due to immediate shutdown")
    // surface as errors on the next statement; do not print them.
    PQsetNoticeProcessor(c, [](void*, const char*) {}, nullptr);
    PGresult* r = PQexec(c, ("SET client_min_messages = warning; SET lock_timeout = '" + std::to_string(kLockTimeoutS) +
                             "s'").c_str());
    PQclear(r);
  }

 private:
  PGconn* c_;
  PGconn* probe_ = nullptr;
  std::string name_, uri_;
  int connect_timeout_s_;
};

}  // namespace

Result<std::unique_ptr<Db>> open_postgres(const DbUrl& url, int connect_timeout_s) {
  PGconn* c = connect(url.uri, connect_timeout_s, "dentar");
  if (!c) return Error{url.redacted + ": out of memory"};
  if (PQstatus(c) != CONNECTION_OK) {
    std::string m = trim(PQerrorMessage(c));
    PQfinish(c);
    return Error{url.redacted + ": cannot connect: " + m};
  }
  PgDb::setup(c);
  return std::unique_ptr<Db>(std::make_unique<PgDb>(c, url.redacted, url.uri, connect_timeout_s));
}

}  // namespace dentar::store
