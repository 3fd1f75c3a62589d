#include "db_util.h"

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "dentar/session/finish.h"
#include "dentar/store/db_url.h"
#include "dentar/store/station.h"
#include "dentar/store/store.h"
#include "dentar/training/report.h"

namespace dentar::tools {
namespace fs = std::filesystem;

std::string default_station_db() {
  if (const char* e = std::getenv("DENTAR_STATION_DB"); e && *e) return e;
  const char* home = std::getenv("HOME");
  return "sqlite:" + (fs::path(home && *home ? home : ".") / ".local/share/dentar/station.db").string();
}

void add_db_options(CLI::App* sub, DbCli& c, bool db_required) {
  auto* o = sub->add_option("--db", c.db,
                            db_required ? "where sessions are kept: sqlite:PATH or postgresql://USER@HOST[:PORT]/DB"
                                        : "store the finished session here: sqlite:PATH or postgresql://USER@HOST[:PORT]/DB");
  if (db_required) o->required();
  sub->add_option("--station-db", c.station_db,
                  "this station's own SQLite queue when --db is a server (default: $DENTAR_STATION_DB or "
                  "~/.local/share/dentar/station.db)");
  sub->add_option("--student", c.student, "the student's code (letters, digits, . _ @ -)");
  sub->add_option("--station-id", c.station_id, "this station's code (default: the host name)");
}

std::optional<store::DbUrl> check_db_url(const std::string& cmd, const std::string& url, const std::string& option) {
  auto u = store::parse_db_url(url);
  if (!u) {
    print_error(cmd, option + ": " + u.error());
    return std::nullopt;
  }
  if (auto e = store::password_on_command_line(*u, option); !e.empty()) {
    print_error(cmd, e);
    return std::nullopt;
  }
  return *u;
}

void announce_lock_waits(const std::string& cmd) {
  store::set_lock_wait_notice([cmd](const std::string& text) { std::cerr << cmd << ": " << text << std::endl; });
}

int open_fault_exit_code(store::OpenFault fault) { return fault == store::OpenFault::Unavailable ? 1 : 2; }

bool check_db_options(const std::string& cmd, DbCli& c) {
  if (c.db.empty()) return true;
  const auto u = check_db_url(cmd, c.db);
  if (!u) return false;
  if (c.student.empty()) {
    print_error(cmd, "--db needs --student CODE (whose session this is)");
    return false;
  }
  if (auto e = store::validate_code("--student", c.student); !e.empty()) {
    print_error(cmd, e);
    return false;
  }
  if (c.station_id.empty()) {
    char host[256] = {};
    gethostname(host, sizeof host - 1);
    c.station_id = host[0] ? host : "station";
    for (char& ch : c.station_id)
      if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '.' && ch != '-' && ch != '_') ch = '-';
  }
  if (auto e = store::validate_code("--station-id", c.station_id); !e.empty()) {
    print_error(cmd, e);
    return false;
  }
  if (u->kind == store::DbUrl::Kind::Postgres && c.station_db.empty()) c.station_db = default_station_db();
  if (!c.station_db.empty()) {
    const auto s = check_db_url(cmd, c.station_db, "--station-db");
    if (!s) return false;
    if (s->kind != store::DbUrl::Kind::Sqlite) {
      print_error(cmd, "--station-db " + c.station_db + ": must be sqlite:PATH");
      return false;
    }
  }
  return true;
}

Result<SessionPaths> find_session(const std::string& path) {
  std::error_code ec;
  const fs::path p = path;
  if (fs::is_regular_file(p, ec)) return SessionPaths{path, ""};
  if (!fs::is_directory(p, ec)) return Error{path + ": no such session folder or log"};
  if (fs::is_regular_file(p / "session.dlog", ec)) return SessionPaths{path, ""};
  // A `dentar offline` run: the footage (and its session log) in footage/ when it was
  // generated, else where summary.json's inputs.session says; score.json in the run folder.
  std::string looked = (p / "session.dlog").string() + " (a live recording, a demo folder)";
  if (fs::is_regular_file(p / "summary.json", ec)) {
    if (fs::is_regular_file(p / "footage" / "session.dlog", ec))
      return SessionPaths{(p / "footage" / "session.dlog").string(), path};
    looked += ", " + (p / "footage" / "session.dlog").string() + " (an offline run on built-in footage)";
    std::ifstream in(p / "summary.json");
    const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
    if (j.is_object() && j.contains("inputs") && j["inputs"].is_object() && j["inputs"].contains("session") &&
        j["inputs"]["session"].is_string()) {
      const fs::path log = j["inputs"]["session"].get<std::string>();
      if (fs::is_regular_file(log, ec)) return SessionPaths{log.string(), path};
      looked += ", " + log.string() + " (summary.json's inputs.session)";
    } else {
      looked += "; summary.json names no session log (the offline run had no --session)";
    }
  } else {
    looked += ", " + (p / "footage" / "session.dlog").string() + " (with summary.json: an offline run)";
    if (fs::is_regular_file(p / "footage" / "session.dlog", ec))
      looked += "; footage/session.dlog is there but summary.json is not: the offline run did not finish";
  }
  return Error{path + ": no session log here: looked for " + looked};
}

int store_finished_session(const std::string& cmd, const DbCli& c, const std::string& session_arg,
                           const std::string& report_dir_arg, bool quiet) {
  std::string session = session_arg, report_dir = report_dir_arg;
  if (report_dir.empty()) {
    auto found = find_session(session_arg);
    if (!found) {
      print_error(cmd, found.error());
      return 2;
    }
    session = found->session;
    report_dir = found->report_dir;
  }
  announce_lock_waits(cmd);
  // The finish step's store half (session/finish.h): scored first when it has no score.json.
  const session::StoreTarget t{c.db, c.station_db, c.student, c.station_id, c.move};
  const session::StoreOutcome r = session::store_after_score(t, session, report_dir, [&](const std::string& s) {
    if (!quiet) std::cout << cmd << ": " << s << "\n";
  });
  if (r.exit_code != 0) {
    print_error(cmd, r.error);
    return r.exit_code;
  }
  if (!r.warning.empty()) print_error(cmd, "warning: " + r.warning);
  std::cout << cmd << ": " << r.line << "\n";
  return 0;
}

}  // namespace dentar::tools
