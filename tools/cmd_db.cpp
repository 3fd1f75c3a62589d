// dentar db: the session store. init/migrate the schema, import scored
// session folders, export everything as JSON lines, forward a station's queue.
#include <filesystem>
#include <fstream>
#include <iostream>

#include "commands.h"
#include "db_util.h"
#include "dentar/store/station.h"
#include "dentar/store/store.h"

namespace dentar::tools {

void add_db(CLI::App& app, int& exit_code) {
  auto* db = app.add_subcommand(
      "db",
      "The session store: SQLite (one file, the default) or PostgreSQL 15 for a school with many stations.\n"
      "Synopsis: dentar db init|migrate --db URL\n"
      "          dentar db import SESSION_DIR... --db URL --student CODE [--station-id CODE] [--station-db sqlite:PATH] [--move]\n"
      "          dentar db export --db URL [--out FILE.jsonl]\n"
      "          dentar db forward --station-db sqlite:PATH --db URL\n"
      "          dentar db status --db URL");
  db->footer(
      "Examples:\n"
      "  dentar db init --db sqlite:school.db\n"
      "  dentar score out/rec && dentar db import out/rec --db sqlite:school.db --student s042\n"
      "  dentar db import out/rec --db postgresql://dentar@school-server/dentar --student s042   # via this station's queue\n"
      "  dentar db forward --station-db sqlite:station.db --db postgresql://dentar@school-server/dentar\n"
      "  dentar db export --db sqlite:school.db --out all.jsonl");
  db->require_subcommand(1, 1);

  struct UrlCli {
    std::string db;
  };
  for (const char* name : {"init", "migrate", "status"}) {
    auto c = std::make_shared<UrlCli>();
    const std::string n = name;
    auto* s = db->add_subcommand(
        n, n == "init" ? "Create the database (or bring it to this program's schema)"
           : n == "migrate" ? "Run the schema migrations (an old database to this program's version)"
                            : "Print the schema version, the number of sessions, and the station queue");
    s->add_option("--db", c->db, "sqlite:PATH or postgresql://USER@HOST[:PORT]/DB")->required();
    s->footer("Example:\n  dentar db " + n + " --db sqlite:school.db");
    s->callback([c, n, &exit_code] {
      if (!check_db_url("db " + n, c->db)) {
        exit_code = 2;
        return;
      }
      announce_lock_waits("db " + n);
      store::OpenOptions o;
      o.create = n == "init";
      o.migrate = n != "status";
      store::OpenFault fault = store::OpenFault::None;
      auto st = store::Store::open(c->db, o, &fault);
      if (!st) {
        print_error("db " + n, st.error());
        exit_code = open_fault_exit_code(fault);
        return;
      }
      auto count = (*st)->count_sessions();
      if (!count) {  // damage the quick check did not see, found while counting
        print_error("db " + n, count.error());
        exit_code = 2;
        return;
      }
      auto queued = (*st)->pending_count();
      std::cout << (*st)->url().redacted << ": schema version " << (*st)->schema_version() << " (this program: "
                << store::kSchemaVersion << "), " << *count << " sessions";
      if (queued && *queued) std::cout << ", " << *queued << " queued for the server";
      if ((*st)->url().kind == store::DbUrl::Kind::Sqlite) std::cout << "; PRAGMA quick_check: ok";
      std::cout << "\n";
      exit_code = 0;
    });
  }

  {
    struct ImportCli {
      DbCli d;
      std::vector<std::string> dirs;
      bool quiet = false;
    };
    auto c = std::make_shared<ImportCli>();
    auto* s = db->add_subcommand("import", "Store scored session folders (scores them first when score.json is missing)");
    s->add_option("SESSION_DIR", c->dirs, "session folders (session.dlog [+ score.json, recording.json]) or .dlog files")
        ->required();
    add_db_options(s, c->d, true);
    s->add_flag("--quiet", c->quiet, "no progress lines");
    s->add_flag("--move", c->d.move,
                "a session already stored under another student is moved to --student (without it, it is refused "
                "and both students are named)");
    s->footer(
        "SESSION_DIR: a live recording (dentar live --record DIR), a demo folder (dentar demo --out DIR), an offline\n"
        "run folder (dentar offline --out DIR: its log in footage/), a scored folder, or a .dlog.\n"
        "Example:\n  dentar db import out/rec --db sqlite:school.db --student s042 --station-id station-3\n"
        "  dentar db import out/offline --db sqlite:school.db --student s042\n"
        "  dentar db import out/rec --db sqlite:school.db --student s043 --move   # stored under s042 by mistake");
    s->callback([c, &exit_code] {
      if (c->d.student.empty()) {
        print_error("db import", "--student CODE is required (whose sessions these are)");
        exit_code = 2;
        return;
      }
      if (!check_db_options("db import", c->d)) {
        exit_code = 2;
        return;
      }
      exit_code = 0;
      for (const auto& d : c->dirs) {
        std::error_code ec;
        if (!std::filesystem::exists(d, ec)) {
          print_error("db import", d + ": no such session folder or log");
          exit_code = 2;
          continue;
        }
        const int rc = store_finished_session("db import", c->d, d, "", c->quiet);
        if (rc != 0) exit_code = std::max(exit_code, rc);
      }
    });
  }

  {
    struct ExportCli {
      std::string db, out;
    };
    auto c = std::make_shared<ExportCli>();
    auto* s = db->add_subcommand("export", "Every stored session as JSON lines (format dentar-stored-session)");
    s->add_option("--db", c->db, "sqlite:PATH or postgresql://...")->required();
    s->add_option("--out", c->out, "output file (default: standard output)");
    s->footer("Example:\n  dentar db export --db sqlite:school.db --out all.jsonl");
    s->callback([c, &exit_code] {
      if (!check_db_url("db export", c->db)) {
        exit_code = 2;
        return;
      }
      store::OpenOptions o;
      o.create = false;
      o.migrate = false;
      store::OpenFault fault = store::OpenFault::None;
      auto st = store::Store::open(c->db, o, &fault);
      if (!st) {
        print_error("db export", st.error());
        exit_code = open_fault_exit_code(fault);
        return;
      }
      std::ofstream file;
      const std::string tmp = c->out + ".partial";
      if (!c->out.empty()) {
        file.open(tmp, std::ios::binary | std::ios::trunc);
        if (!file) {
          print_error("db export", tmp + ": cannot write");
          exit_code = 2;
          return;
        }
      }
      std::ostream& out = c->out.empty() ? std::cout : file;
      std::size_t n = 0;
      auto s = (*st)->for_each([&](const store::SessionRecord& r) -> Status {
        out << store::to_json(r).dump() << "\n";
        ++n;
        if (!out) return Error{"write failed"};
        return {};
      });
      if (!s) {
        print_error("db export", s.error());
        exit_code = 1;
        return;
      }
      if (!c->out.empty()) {
        file.close();
        std::error_code ec;
        std::filesystem::rename(tmp, c->out, ec);
        if (ec || !file) {
          print_error("db export", c->out + ": " + (ec ? ec.message() : "write failed"));
          exit_code = 1;
          return;
        }
        std::cerr << "db export: " << n << " sessions to " << c->out << "\n";
      }
      exit_code = 0;
    });
  }

  {
    struct ForwardCli {
      std::string db, station_db;
    };
    auto c = std::make_shared<ForwardCli>();
    auto* s = db->add_subcommand("forward", "Send the sessions queued at this station to the school's server");
    s->add_option("--db", c->db, "the server: postgresql://... (or sqlite:PATH)")->required();
    s->add_option("--station-db", c->station_db, "this station's queue (default: $DENTAR_STATION_DB or ~/.local/share/dentar/station.db)");
    s->footer("Example:\n  dentar db forward --station-db sqlite:station.db --db postgresql://dentar@school-server/dentar");
    s->callback([c, &exit_code] {
      const std::string local = c->station_db.empty() ? default_station_db() : c->station_db;
      for (const auto& u : {c->db, local})
        if (!check_db_url("db forward", u)) {
          exit_code = 2;
          return;
        }
      announce_lock_waits("db forward");
      const auto r = store::forward_outbox(local, c->db);
      std::cout << "db forward: " << r.sent << " sent, " << r.already << " already on the server, " << r.queued
                << " still queued\n";
      if (!r.error.empty()) {
        print_error("db forward", r.error + " (the queued sessions are kept; run again later)");
        exit_code = 1;
        return;
      }
      exit_code = 0;
    });
  }
}

}  // namespace dentar::tools
