// dentar serve: the instructor's read-only web page over the session store.
#include <csignal>
#include <iostream>

#include "commands.h"
#include "db_util.h"
#include "dentar/store/web.h"

namespace dentar::tools {
namespace {
store::WebServer* g_server = nullptr;
void on_signal(int) {
  if (g_server) g_server->stop();
}
}  // namespace

void add_serve(CLI::App& app, int& exit_code) {
  struct Cli {
    store::ServeOptions o;
    std::string set_user;
    int iterations = store::kDefaultPbkdf2Iterations;
  };
  auto c = std::make_shared<Cli>();
  auto* s = app.add_subcommand(
      "serve",
      "The instructor's web page: students, sessions, scores over time per student and exercise,\n"
      "the cohort, force bands and each session's score report. Read-only; a login is required.\n"
      "Synopsis: dentar serve --db URL --passwords FILE [--host H] [--port P] [--cert PEM --key PEM]\n"
      "          dentar serve --passwords FILE --set-password USER   (reads the password from standard input)");
  s->footer(
      "Examples:\n"
      "  dentar serve --passwords instructors.txt --set-password alice < pw.txt\n"
      "  dentar serve --db sqlite:school.db --passwords instructors.txt --port 8080\n"
      "  dentar serve --db postgresql://dentar@localhost/dentar --passwords instructors.txt \\\n"
      "               --host 0.0.0.0 --port 8443 --cert server.pem --key server.key   # HTTPS\n"
      "Then open http://localhost:8080/ (behind a reverse proxy for HTTPS: see README).");
  s->add_option("--db", c->o.db_url, "sqlite:PATH or postgresql://USER@HOST[:PORT]/DB");
  s->add_option("--passwords", c->o.password_file, "password file (NAME:pbkdf2-sha256:ITER:SALT:HASH lines)")->required();
  s->add_option("--set-password", c->set_user, "add or change USER's password (read from standard input), then exit");
  s->add_option("--iterations", c->iterations, "PBKDF2 iterations for --set-password")->check(CLI::Range(store::kMinPbkdf2Iterations, 100000000))->capture_default_str();
  s->add_option("--host", c->o.host, "address to listen on")->capture_default_str();
  s->add_option("--port", c->o.port, "port (0: any free port, printed)")->capture_default_str();
  s->add_option("--cert", c->o.cert_file, "PEM certificate: serve HTTPS directly");
  s->add_option("--key", c->o.key_file, "PEM private key for --cert");
  s->add_option("--session-hours", c->o.session_hours, "login lifetime (hours)")->capture_default_str();
  s->add_option("--threads", c->o.threads, "worker threads / database connections")->capture_default_str();
  s->add_option("--request-timeout", c->o.request_timeout_s,
                "seconds a client has to send a whole request (TLS handshake, headers, body); slower ones get 408")
      ->capture_default_str();
  s->add_option("--max-conn-per-client", c->o.max_conn_per_client, "open connections one client address may hold")
      ->capture_default_str();
  s->add_option("--login-max-delay", c->o.login_max_delay_s,
                "longest wait (s) imposed after repeated failed logins of a user or from an address")
      ->capture_default_str();
  s->callback([c, &exit_code] {
    if (!c->set_user.empty()) {
      std::string pw;
      std::getline(std::cin, pw);
      if (!pw.empty() && pw.back() == '\r') pw.pop_back();
      if (auto st = store::set_password(c->o.password_file, c->set_user, pw, c->iterations); !st) {
        print_error("serve", st.error());
        exit_code = 2;
        return;
      }
      std::cout << "serve: password of " << c->set_user << " set in " << c->o.password_file << "\n";
      exit_code = 0;
      return;
    }
    if (auto v = c->o.validate(); !v.empty()) {
      print_error("serve", v);
      exit_code = 2;
      return;
    }
    if (!check_db_url("serve", c->o.db_url)) {
      exit_code = 2;
      return;
    }
    store::OpenFault fault = store::OpenFault::None;
    auto w = store::WebServer::create(c->o, &fault);
    if (!w) {
      print_error("serve", w.error());
      exit_code = open_fault_exit_code(fault);
      return;
    }
    if (auto b = (*w)->bind(); !b) {
      print_error("serve", b.error());
      exit_code = 1;
      return;
    }
    g_server = w->get();
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    std::cout << "serve: listening on " << (c->o.cert_file.empty() ? "http" : "https") << "://" << c->o.host << ":"
              << (*w)->port() << "/ (Ctrl-C stops)" << std::endl;
    auto r = (*w)->listen_after_bind();
    g_server = nullptr;
    if (!r) {
      print_error("serve", r.error());
      exit_code = 1;
      return;
    }
    exit_code = 0;
  });
}

}  // namespace dentar::tools
