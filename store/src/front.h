// The page server's front: it owns the listening socket and reads every
// request's head and body itself, in one poll loop, before a worker thread
// sees it. cpp-httplib 0.11.4 (Debian 12) only has a timeout per read, so a
// client that sends one header byte every 4 s holds one of its worker threads
// for as long as it likes; here a worker only ever gets a complete request
// (head + body in memory), handed to httplib through its protected
// Server::process_request with a Stream over that buffer.
//
// Limits (each answered with a short error page, logged, and the connection
// closed): a deadline for the TLS handshake + head + body of each request
// (408), the head's size and header count (431), the body's size (413), a
// body without Content-Length (411), connections per client address and in
// all (503). Private to store/.
#pragma once

#include <openssl/ssl.h>

#include <functional>
#include <memory>
#include <string>

#include <httplib.h>

#include "dentar/core/result.h"

namespace dentar::store {

struct FrontOptions {
  std::string host = "127.0.0.1";
  int port = 0;                           // 0: any free port
  int workers = 8;                        // threads that run the pages
  double request_timeout_s = 10;          // accept (or the last response) -> whole request read
  double write_timeout_s = 10;            // one response written
  std::size_t max_header_bytes = 16384;   // request line + headers
  std::size_t max_headers = 64;           // header lines
  std::size_t max_body_bytes = 64 * 1024; // Content-Length
  int max_conn_per_client = 16;           // open connections of one client address
  int max_connections = 512;              // open connections in all
  int keep_alive_max = 100;               // requests on one connection
  SSL_CTX* tls = nullptr;                 // not owned; set: HTTPS only
  std::function<void(const std::string&)> log;  // one line per refusal
};

// Serves one complete request held by `s`; returns false to close.
using FrontHandler = std::function<bool(httplib::Stream& s, bool last, bool& close)>;

class Front {
 public:
  Front(FrontOptions opt, FrontHandler handler);
  ~Front();
  Status bind();  // port() is known after this
  int port() const;
  Status run();   // blocks until stop()
  void stop();    // async-signal-safe (an atomic flag and an eventfd)

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// An httplib::Server whose routes run on a Stream the front gives it.
class RoutedServer : public httplib::Server {
 public:
  bool serve_one(httplib::Stream& s, bool last, bool& closed) { return process_request(s, last, closed, nullptr); }
};

}  // namespace dentar::store
