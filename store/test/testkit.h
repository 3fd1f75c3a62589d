// Shared by the store tests and the benchmarks (store_bench,
// page_attack_bench): a throwaway PostgreSQL 15 cluster, synthetic session
// records, headless Chromium (driven over the DevTools protocol), the login
// form over HTTP, raw sockets and slow clients.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

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

// Headless Chromium driven as a user drives it, over the DevTools protocol
// (--remote-debugging-pipe; no script of ours runs in the pages): open a
// URL, type into a field, press Enter, read the page, take a screenshot.
// One fresh profile per Browser; the process group ends with the object.
class Browser {
 public:
  explicit Browser(int width = 1200, int height = 900);
  ~Browser();
  Browser(const Browser&) = delete;
  Browser& operator=(const Browser&) = delete;
  bool ok() const { return error_.empty(); }
  const std::string& error() const { return error_; }
  // Navigates and waits for the page's load event.
  bool open(const std::string& url, double timeout_s = 60);
  // Focuses the first element matching the CSS selector and types the text.
  bool type(const std::string& selector, const std::string& text);
  // Presses Enter in the focused field (a form's implicit submission) and
  // waits for the next page's load event.
  bool press_enter(double timeout_s = 60);
  // Whether the page navigates within `s` seconds (a main-frame navigation).
  bool navigates_within(double s);
  std::string dom();  // the document's outerHTML ("" on failure)
  std::string url();  // the page's URL now
  bool screenshot(const std::filesystem::path& png);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::string error_;
};
// The login as a user does it, same-site: opens BASE/login?next=NEXT from the
// server (its form carries the CSRF token), types the user and the password,
// presses Enter and waits for the page it lands on.
bool browser_login(Browser& b, const std::string& base, const std::string& user, const std::string& password,
                   const std::string& next);

// The login over plain HTTP, as a browser does it: GET /login (the
// pre-session cookie and the form's CSRF token), then POST the form.
struct LoginForm {
  std::string cookie;  // "dentar_login=..." ("" if the page set none)
  std::string csrf;    // the form's hidden csrf field
};
LoginForm get_login_form(int port);
struct LoginReply {
  int status = 0;             // 0: no answer
  std::string session, body;  // session: "dentar_session=..." or ""
  std::string retry_after;
};
LoginReply post_login(int port, const LoginForm& form, const std::string& user, const std::string& password,
                      const std::string& next = "/");
// GET + POST; the session cookie ("dentar_session=...") or "" if refused.
std::string login_cookie(int port, const std::string& user, const std::string& password);

// Raw sockets for the slow-client tests and benchmark.
int connect_raw(int port);  // to 127.0.0.1; -1 on failure
// What the server sent until it closed or `ms` passed.
std::string read_until_close(int fd, int ms);

// Slowloris: `n` connections to 127.0.0.1:port, each sending one byte of a
// request head ("GET / HTTP/1.1 ... X-Slow: aaaa...") every `every`.
// reconnect: a connection the server closed is opened again (a persistent
// attacker); else each sends at most `max_bytes` and then waits. The
// connections stay open until the object ends.
class SlowClients {
 public:
  SlowClients(int port, int n, std::chrono::milliseconds every, bool reconnect,
              std::size_t max_bytes = static_cast<std::size_t>(-1));
  ~SlowClients();
  void stop();  // stops sending; the connections stay open
  int connected() const;
  long reconnects() const { return reconnects_; }
  std::vector<int> fds();

 private:
  int port_;
  std::vector<int> fds_;
  mutable std::mutex mu_;
  std::atomic<bool> stop_{false};
  std::atomic<long> reconnects_{0};
  std::thread drip_;
};

}  // namespace dentar::store::testkit
