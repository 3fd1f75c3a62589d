#include "dentar/store/station.h"

#include "dentar/store/store.h"

namespace dentar::store {

ForwardReport forward_outbox(const std::string& local_url, const std::string& server_url, std::size_t max_sessions) {
  ForwardReport rep;
  auto local = Store::open(local_url);
  if (!local) {
    rep.error = local.error();
    return rep;
  }
  auto count = (*local)->pending_count();
  rep.queued = count ? static_cast<std::size_t>(*count) : 0;
  if (rep.queued == 0) return rep;
  auto server = Store::open(server_url);
  if (!server) {
    rep.error = server.error();
    return rep;
  }
  std::size_t done = 0;
  while (done < max_sessions) {
    auto batch = (*local)->pending(std::min<std::size_t>(100, max_sessions - done));
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
        (void)(*local)->mark_failed(q.key, rec.error());
        rep.error = "outbox " + q.key.substr(0, 16) + ": " + rec.error();
        continue;
      }
      auto put = (*server)->put(*rec);
      if (!put) {
        (void)(*local)->mark_failed(q.key, put.error());
        rep.error = put.error();
        auto left = (*local)->pending_count();
        rep.queued = left ? static_cast<std::size_t>(*left) : rep.queued;
        return rep;  // the server went away: stop, the rest stays queued
      }
      // The server committed: only now is the row marked. A crash between
      // the two sends it again later, which the server ignores (same key).
      if (auto m = (*local)->mark_sent(q.key); !m) {
        rep.error = m.error();
        return rep;
      }
      (*put == PutOutcome::Stored ? rep.sent : rep.already)++;
      ++done;
    }
    if (!rep.error.empty()) break;
  }
  auto left = (*local)->pending_count();
  rep.queued = left ? static_cast<std::size_t>(*left) : 0;
  return rep;
}

Result<StoreReport> store_session(const SessionRecord& r, const std::string& local_url, const std::string& server_url) {
  StoreReport rep;
  if (server_url.empty()) {
    auto st = Store::open(local_url);
    if (!st) return Error{st.error()};
    auto put = (*st)->put(r);
    if (!put) return Error{put.error()};
    rep.stored_locally = true;
    rep.already = *put == PutOutcome::AlreadyPresent;
    rep.message = std::string(rep.already ? "already stored in " : "stored in ") + (*st)->url().redacted;
    return rep;
  }
  auto lu = parse_db_url(local_url);
  if (!lu) return Error{lu.error()};
  if (lu->kind != DbUrl::Kind::Sqlite) return Error{"the station's own store must be sqlite:PATH, got " + lu->redacted};
  {
    auto st = Store::open(local_url);
    if (!st) return Error{st.error()};
    auto put = (*st)->put_and_queue(r);
    if (!put) return Error{put.error()};
    rep.stored_locally = true;
    rep.already = *put == PutOutcome::AlreadyPresent;
  }
  rep.forward = forward_outbox(local_url, server_url);
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
