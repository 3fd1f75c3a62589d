#include "dentar/store/station.h"

#include <optional>

#include "dentar/store/store.h"

namespace dentar::store {

ForwardReport forward_outbox(const std::string& local_url, const std::string& server_url, std::size_t max_sessions) {
  auto local = Store::open(local_url);
  if (!local) {
    ForwardReport rep;
    rep.error = local.error();
    return rep;
  }
  return forward_outbox(**local, server_url, max_sessions);
}

ForwardReport forward_outbox(Store& local, const std::string& server_url, std::size_t max_sessions) {
  ForwardReport rep;
  auto count = local.pending_count();
  rep.queued = count ? static_cast<std::size_t>(*count) : 0;
  if (rep.queued == 0) return rep;
  auto server = Store::open(server_url);
  if (!server) {
    rep.error = server.error();
    return rep;
  }
  std::size_t done = 0;
  while (done < max_sessions) {
    auto batch = local.pending(std::min<std::size_t>(100, max_sessions - done));
    if (!batch) {
      rep.error = batch.error();
      break;
    }
    if (batch->empty()) break;
    for (const auto& q : *batch) {
      Result<SessionRecord> rec = Error{"unparsed"};
      try {
        rec = record_from_json(nlohmann::json::parse(q.payload));
      } catch (const nlohmann::json::exception& e) {
        rec = Error{std::string("outbox payload: ") + e.what()};
      }
      if (!rec) {  // cannot happen for rows we wrote; keep the row, say why
        (void)local.mark_failed(q.key, rec.error());
        rep.error = "outbox " + q.key.substr(0, 16) + ": " + rec.error();
        continue;
      }
      auto put = (*server)->put(*rec);
      if (!put) {
        (void)local.mark_failed(q.key, put.error());
        rep.error = put.error();
        auto left = local.pending_count();
        rep.queued = left ? static_cast<std::size_t>(*left) : rep.queued;
        return rep;  // the server went away: stop, the rest stays queued
      }
      // The server committed: only now is the row marked. A crash between
      // the two sends it again later, which the server ignores (same key).
      if (auto m = local.mark_sent(q.key); !m) {
        rep.error = m.error();
        return rep;
      }
      (*put == PutOutcome::Stored ? rep.sent : rep.already)++;
      ++done;
    }
    if (!rep.error.empty()) break;
  }
  auto left = local.pending_count();
  rep.queued = left ? static_cast<std::size_t>(*left) : 0;
  return rep;
}

Result<StoreReport> store_session(const SessionRecord& r, const std::string& local_url, const std::string& server_url,
                                  const StoreOptions& opt, OpenFault* fault) {
  OpenFault dummy;
  OpenFault& f = fault ? *fault : dummy;
  f = OpenFault::BadInput;
  StoreReport rep;
  std::optional<DbUrl> lu;
  if (!server_url.empty()) {
    auto u = parse_db_url(local_url);
    if (!u) return Error{u.error()};
    if (u->kind != DbUrl::Kind::Sqlite) return Error{"the station's own store must be sqlite:PATH, got " + u->redacted};
    lu = *u;
  }
  auto st = Store::open(local_url, {}, &f);
  if (!st) return Error{st.error()};
  Store& local = **st;
  // The same session under another student: refused, naming both, unless move.
  if (auto had = local.session_by_key(r.key); had && *had && (**had).student != r.student) {
    const std::string old_student = (**had).student;
    if (!opt.move) {
      f = OpenFault::BadInput;
      return Error{"session " + r.key.substr(0, 12) + " is already stored under student " + old_student + ", not " +
                   r.student + ": nothing was changed. Pass --move to move it to " + r.student +
                   ", or give --student " + old_student};
    }
    if (auto m = local.move_session(r.key, r.student); !m) {
      f = OpenFault::Unavailable;
      return Error{"moving the session to " + r.student + ": " + m.error()};
    }
    rep.moved_from = old_student;
    OpenOptions oo;
    oo.create = false;
    if (!server_url.empty())  // the school's server keeps its own copy: move it there too when it answers
      if (auto sv = Store::open(server_url, oo)) {
        if (auto hs = (*sv)->session_by_key(r.key); hs && *hs && (**hs).student != r.student)
          if (auto m = (*sv)->move_session(r.key, r.student); !m)
            rep.warning = "moving the session on " + (*sv)->url().redacted + ": " + m.error();
      }
  }
  auto put = server_url.empty() ? local.put(r) : local.put_and_queue(r);
  if (!put) {
    // A damaged database file is bad input (as in `db status` and `serve`); else the job failed.
    f = put.error().find("the database file is damaged") != std::string::npos ? OpenFault::BadInput
                                                                               : OpenFault::Unavailable;
    return Error{put.error()};
  }
  f = OpenFault::None;
  rep.stored_locally = true;
  rep.already = *put == PutOutcome::AlreadyPresent;
  if (server_url.empty()) {
    rep.message = std::string(rep.already ? "already stored in " : "stored in ") + local.url().redacted;
    return rep;
  }
  rep.forward = forward_outbox(local, server_url);
  const std::string server = parse_db_url(server_url) ? parse_db_url(server_url)->redacted : server_url;
  if (rep.forward.queued == 0)
    rep.message = "stored at the station (" + lu->redacted + ") and sent to " + server;
  else
    rep.message = "kept at this station (" + lu->redacted + "), " + std::to_string(rep.forward.queued) +
                  " session(s) queued; they are sent to " + server + " when it can be reached (" +
                  rep.forward.error + ")";
  return rep;
}

}  // namespace dentar::store
