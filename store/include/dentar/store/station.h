// Store and forward at a station: every finished session is committed to the
// station's own SQLite file first (with an outbox row, same transaction),
// then sent to the school's server. The server keeps a session once per key
// (INSERT ... ON CONFLICT DO NOTHING), so a send whose acknowledgement was
// lost is simply sent again; the outbox row is marked sent only after the
// server committed. Nothing acknowledged locally is lost by a crash
// (SQLite WAL, synchronous=FULL).
#pragma once

#include <string>

#include "dentar/store/record.h"
#include "dentar/store/store.h"

namespace dentar::store {

struct ForwardReport {
  std::size_t sent = 0;          // stored by the server now
  std::size_t already = 0;       // the server had it (an earlier send's ack was lost)
  std::size_t queued = 0;        // still waiting in the outbox
  std::string error;             // why sending stopped (server unreachable, ...), empty if all sent
};

// Sends what the outbox holds, oldest first. Never throws; a server that is
// down leaves everything queued.
ForwardReport forward_outbox(const std::string& local_url, const std::string& server_url,
                             std::size_t max_sessions = 1000000);
// The same from a station store already open.
ForwardReport forward_outbox(Store& local, const std::string& server_url, std::size_t max_sessions = 1000000);

struct StoreReport {
  bool stored_locally = false;    // committed on this machine (the acknowledgement)
  bool already = false;           // the key was already stored
  ForwardReport forward;          // when a server is set
  std::string moved_from;         // StoreOptions::move: the student it was stored under
  std::string warning;            // e.g. the server's copy could not be moved
  std::string message;            // one line for the student
};

struct StoreOptions {
  // The same session (key) already stored under another student: refused
  // (bad input, naming both) unless move, which moves it to r.student (in
  // the store written to, and on the server when it answers).
  bool move = false;
};

// Stores a finished session. server_url empty: `local_url` is the store
// (SQLite or PostgreSQL). Otherwise local_url must be sqlite: (the station's
// queue) and the session is forwarded to server_url with everything queued.
// The store written to is opened once (one PRAGMA quick_check). fault: why it
// failed, for the exit code: BadInput (a damaged, foreign or newer store; the
// session under another student without move) or Unavailable (a store that
// is locked or cannot be reached, a write that failed).
Result<StoreReport> store_session(const SessionRecord& r, const std::string& local_url, const std::string& server_url,
                                  const StoreOptions& opt = {}, OpenFault* fault = nullptr);

}  // namespace dentar::store
