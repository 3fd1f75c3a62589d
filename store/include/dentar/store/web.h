// The instructor's read-only web page over a session store (cpp-httplib).
// Pages: / (students), /student/CODE, /session/ID, /session/ID/report (the
// stored score.html), /cohort, /exercise/NAME, /login, /logout. Everything but
// /login needs a cookie session; parameters are checked against a strict
// alphabet (bad ones: 400 page) and only ever bound as SQL parameters; an
// unknown student/session is the 404 page. No file is served from disk.
#pragma once

#include <memory>
#include <string>

#include "dentar/store/auth.h"

namespace dentar::store {

struct ServeOptions {
  std::string db_url;
  std::string password_file;
  std::string host = "127.0.0.1";
  int port = 8080;                 // 0: any free port (see WebServer::port)
  std::string cert_file, key_file; // both set: HTTPS directly (OpenSSL build of cpp-httplib)
  int session_hours = 8;           // cookie session lifetime
  int threads = 8;                 // database connections / worker threads
  std::string validate() const;
};

class WebServer {
 public:
  static Result<std::unique_ptr<WebServer>> create(const ServeOptions& opt);
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
