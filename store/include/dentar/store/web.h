// The instructor's read-only web page over a session store (cpp-httplib).
// Pages: / (students), /student/CODE, /session/ID, /session/ID/report (the
// stored score.html), /cohort, /exercise/NAME, /login (its form's CSRF token bound to a pre-session
// cookie), /logout (POST with the session's CSRF token). Everything but
// /login needs a cookie session; parameters are checked against a strict
// alphabet (bad ones: 400 page) and only ever bound as SQL parameters; an
// unknown student/session is the 404 page. No file is served from disk.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "dentar/store/auth.h"
#include "dentar/store/store.h"

namespace dentar::store {

struct ServeOptions {
  std::string db_url;
  std::string password_file;
  std::string host = "127.0.0.1";
  int port = 8080;                 // 0: any free port (see WebServer::port)
  std::string cert_file, key_file; // both set: HTTPS directly (OpenSSL build of cpp-httplib)
  int session_hours = 8;           // cookie session lifetime
  int threads = 8;                 // database connections / worker threads
  // Slow and flooding clients (see store/src/front.h): a request's TLS
  // handshake, head and body must be in within request_timeout_s; a head is
  // at most max_header_bytes and max_headers lines; one client address holds
  // at most max_conn_per_client connections.
  double request_timeout_s = 10;
  std::size_t max_header_bytes = 16384;
  std::size_t max_headers = 64;
  int max_conn_per_client = 16;
  // Login throttling per user name and per client address: after
  // login_free_tries failures, 1 s, 2 s, 4 s ... up to login_max_delay_s
  // before the next try is checked (429 + Retry-After meanwhile).
  int login_free_tries = 5;
  int login_max_delay_s = 300;
  // One line per refusal, failed login, throttle and server error (default:
  // standard error, "serve: UTC-TIME line").
  std::function<void(const std::string&)> log;
  std::string validate() const;
};

class WebServer {
 public:
  // fault: why the store could not be opened (exit 2 for a damaged or
  // foreign file, 1 for a server that cannot be reached).
  static Result<std::unique_ptr<WebServer>> create(const ServeOptions& opt, OpenFault* fault = nullptr);
  ~WebServer();
  // Binds and serves until stop() (blocking). Error if the port is taken.
  Status listen();
  // Binds now (so port() is known), serving happens in listen_after_bind().
  Status bind();
  Status listen_after_bind();
  int port() const;
  void stop();

 private:
  WebServer() = default;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dentar::store
