// PostgreSQL backend through libpq: text parameters and results. A lost
// connection is reset once before a statement (the server restarted); a
// statement that fails mid-transaction fails the transaction, and the caller
// retries the whole session later (idempotent key).
#include <libpq-fe.h>

#include "db.h"

namespace dentar::store {
namespace {

class PgDb final : public Db {
 public:
  PgDb(PGconn* c, std::string name) : c_(c), name_(std::move(name)) {}
  ~PgDb() override { PQfinish(c_); }
  bool postgres() const override { return true; }

  Status exec(const std::string& sql) override {
    if (auto s = ensure(); !s) return s;
    PGresult* r = PQexec(c_, sql.c_str());
    const auto st = PQresultStatus(r);
    std::string err = (st == PGRES_COMMAND_OK || st == PGRES_TUPLES_OK) ? "" : message(r);
    PQclear(r);
    if (!err.empty()) return Error{err};
    return {};
  }

  Result<std::vector<Row>> query(const std::string& sql, const std::vector<Value>& params) override {
    if (auto s = ensure(); !s) return Error{s.error()};
    std::vector<const char*> vals(params.size());
    for (std::size_t i = 0; i < params.size(); ++i) vals[i] = params[i] ? params[i]->c_str() : nullptr;
    PGresult* r = PQexecParams(c_, sql.c_str(), static_cast<int>(params.size()), nullptr, vals.data(), nullptr,
                               nullptr, 0);
    const auto st = PQresultStatus(r);
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
  Status ensure() {
    if (PQstatus(c_) == CONNECTION_OK) return {};
    PQreset(c_);
    if (PQstatus(c_) != CONNECTION_OK) return Error{name_ + ": connection lost: " + trim(PQerrorMessage(c_))};
    return {};
  }
  static std::string trim(std::string s) {
    while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
    return s;
  }
  std::string message(PGresult* r) const {
    std::string m = r ? PQresultErrorMessage(r) : "";
    if (m.empty()) m = PQerrorMessage(c_);
    return name_ + ": " + trim(m);
  }
  PGconn* c_;
  std::string name_;
};

}  // namespace

Result<std::unique_ptr<Db>> open_postgres(const DbUrl& url, int connect_timeout_s) {
  // Keywords override the URI's (connect_timeout: a server that is down fails fast).
  const std::string timeout = std::to_string(connect_timeout_s);
  const char* keys[] = {"dbname", "connect_timeout", "application_name", nullptr};
  const char* vals[] = {url.uri.c_str(), timeout.c_str(), "dentar", nullptr};
  PGconn* c = PQconnectdbParams(keys, vals, 1);  // expand_dbname: the URI
  if (!c) return Error{url.redacted + ": out of memory"};
  if (PQstatus(c) != CONNECTION_OK) {
    std::string m = PQerrorMessage(c);
    while (!m.empty() && (m.back() == '\n' || m.back() == ' ')) m.pop_back();
    PQfinish(c);
    return Error{url.redacted + ": cannot connect: " + m};
  }
  // Server notices (e.g. "terminating connection due to immediate shutdown")
  // surface as errors on the next statement; do not print them.
  PQsetNoticeProcessor(c, [](void*, const char*) {}, nullptr);
  PGresult* r = PQexec(c, "SET client_min_messages = warning");
  PQclear(r);
  return std::unique_ptr<Db>(std::make_unique<PgDb>(c, url.redacted));
}

}  // namespace dentar::store
