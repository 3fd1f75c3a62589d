// Shared by the store tests and store_bench: a throwaway PostgreSQL 15
// cluster, synthetic session records, headless Chromium.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

#include "dentar/store/record.h"

namespace dentar::store::testkit {

// A free TCP port on 127.0.0.1 (bound and released).
int free_port();

// initdb + pg_ctl from /usr/lib/postgresql/15/bin into a temporary folder.
// As root they run as the `postgres` user (Debian's package creates it) or
// `nobody`: initdb refuses to run as root. Stopped and removed by the
// destructor.
class PgCluster {
 public:
  PgCluster();
  ~PgCluster();
  bool ok() const { return ok_; }
  const std::string& error() const { return error_; }
  std::string url(const std::string& db = "postgres") const;
  int port() const { return port_; }
  bool start();          // pg_ctl start -w
  bool stop_immediate(); // pg_ctl stop -m immediate: like a crash (no checkpoint, recovery at start)
  bool stop();           // fast shutdown
  std::string log() const;

 private:
  bool run(const std::string& cmd, std::string* out = nullptr) const;
  std::filesystem::path dir_;
  std::string bin_, user_;
  int port_ = 0;
  bool ok_ = false, running_ = false;
  std::string error_;
};

// A plausible scored session for student/station/exercise, numbers from the
// seed (deterministic). started_utc = base day + n minutes.
SessionRecord make_record(const std::string& student, const std::string& station, const std::string& exercise,
                          std::uint64_t seed, int minute);

// Headless Chromium (Debian's `chromium`); empty string if not installed.
std::string chromium_binary();
// Runs chromium with the given extra flags and URL in a fresh profile;
// returns stdout (--dump-dom) and the exit code.
struct BrowserResult {
  int code = -1;
  std::string out;
};
BrowserResult chromium(const std::string& flags, const std::string& url);
// A file:// page that logs in to `base` (POST /login) and lands on `next`.
std::filesystem::path login_page_file(const std::filesystem::path& dir, const std::string& base, const std::string& user,
                                      const std::string& password, const std::string& next);

}  // namespace dentar::store::testkit
