#include "testkit.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <pwd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>

#include "testutil.h"

namespace dentar::store::testkit {
namespace fs = std::filesystem;

int free_port() {
  const int s = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = 0;
  int port = 0;
  if (bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0) {
    socklen_t n = sizeof a;
    getsockname(s, reinterpret_cast<sockaddr*>(&a), &n);
    port = ntohs(a.sin_port);
  }
  close(s);
  return port;
}

namespace {
std::string quote(const std::string& s) {
  std::string o = "'";
  for (char c : s) o += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return o + "'";
}
}  // namespace

bool PgCluster::run(const std::string& cmd, std::string* out) const {
  const std::string full = user_.empty() ? cmd : "runuser -u " + user_ + " -- " + cmd;
  const auto r = dentar::test::run_command(full);
  if (out) *out = r.out;
  return r.code == 0;
}

PgCluster::PgCluster() {
  bin_ = "/usr/lib/postgresql/15/bin";
  if (!fs::exists(bin_ + "/initdb")) {
    error_ = bin_ + "/initdb not found: install postgresql-15 (tools/bootstrap.sh does)";
    return;
  }
  if (geteuid() == 0) user_ = getpwnam("postgres") ? "postgres" : "nobody";
  static int n = 0;
  dir_ = fs::temp_directory_path() / ("dentar_pg_" + std::to_string(getpid()) + "_" + std::to_string(n++));
  fs::remove_all(dir_);
  fs::create_directories(dir_);
  if (!user_.empty()) {
    if (auto* pw = getpwnam(user_.c_str())) {
      if (chown(dir_.c_str(), pw->pw_uid, pw->pw_gid) != 0) {
        error_ = "cannot hand " + dir_.string() + " to " + user_;
        return;
      }
    }
  }
  std::string out;
  // trust on 127.0.0.1 only (the cluster listens there and on its socket folder).
  if (!run(bin_ + "/initdb -D " + quote((dir_ / "data").string()) + " -U dentar -A trust -E UTF8 --no-sync", &out)) {
    error_ = "initdb failed: " + out;
    return;
  }
  port_ = free_port();
  ok_ = start();
}

bool PgCluster::start() {
  std::string out;
  const std::string opts = "-p " + std::to_string(port_) + " -k " + dir_.string() +
                           " -c listen_addresses=127.0.0.1 -c max_connections=200 -c shared_buffers=32MB";
  if (!run(bin_ + "/pg_ctl -D " + quote((dir_ / "data").string()) + " -l " + quote((dir_ / "log.txt").string()) +
               " -o " + quote(opts) + " -w -t 60 start",
           &out)) {
    error_ = "pg_ctl start failed: " + out + "\n" + log();
    return false;
  }
  running_ = true;
  return true;
}

bool PgCluster::stop_immediate() {
  running_ = false;
  return run(bin_ + "/pg_ctl -D " + quote((dir_ / "data").string()) + " -m immediate -w stop");
}

bool PgCluster::stop() {
  running_ = false;
  return run(bin_ + "/pg_ctl -D " + quote((dir_ / "data").string()) + " -m fast -w stop");
}

std::string PgCluster::log() const { return dentar::test::read_file(dir_ / "log.txt"); }

PgCluster::~PgCluster() {
  if (running_) stop_immediate();
  std::error_code ec;
  if (!dir_.empty()) fs::remove_all(dir_, ec);
}

std::string PgCluster::url(const std::string& db) const {
  return "postgresql://dentar@127.0.0.1:" + std::to_string(port_) + "/" + db;
}

SessionRecord make_record(const std::string& student, const std::string& station, const std::string& exercise,
                          std::uint64_t seed, int minute) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  SessionRecord r;
  r.student = student;
  r.station = station;
  r.exercise = exercise;
  r.exercise_title = "Exercise " + exercise;
  const int day = minute / 1440, mi = minute % 1440;
  char b[32];
  std::snprintf(b, sizeof b, "2026-%02d-%02dT%02d:%02d:00Z", 9 + day / 28, 1 + day % 28, mi / 60, mi % 60);
  r.started_utc = b;
  r.max_points = 18;
  r.points = std::round(18 * u(rng) * 4) / 4;
  r.coverage_pct = 100 * u(rng);
  r.overprep_mm3 = 3 * u(rng);
  r.forbidden_mm3 = 0.5 * u(rng);
  r.removed_mm3 = 20 + 10 * u(rng);
  r.pulp_exposed = u(rng) < 0.1;
  r.perforation = u(rng) < 0.05;
  r.duration_s = 60 + 120 * u(rng);
  r.drilling_s = 0.6 * r.duration_s;
  r.path_mm = 500 + 500 * u(rng);
  r.excessive_force_s = 3 * u(rng);
  const char* steps[] = {"outline", "deroof", "flare walls", "refine"};
  for (int i = 0; i < 4; ++i) {
    StepScore s;
    s.name = steps[i];
    s.start_s = 20.0 * i;
    s.end_s = 20.0 * i + 18;
    s.drilling_s = 12;
    s.force_N = {0.2 * (u(rng) - 0.5), 0.2 * (u(rng) - 0.5), -0.5 - u(rng)};
    s.force_sd_N = {0.05, 0.05, 0.2};
    s.has_expert = true;
    s.expert_force_N = {0, 0, -1.0};
    s.expert_sd_N = {0.05, 0.05, 0.15};
    r.steps.push_back(s);
    r.feedback.push_back({s.name, "instruct", "force in minus Z (toward apical) should be 1.3 times higher"});
  }
  for (int i = 0; i < 20; ++i) r.metrics.push_back({"process.metric_" + std::to_string(i) + "_mm", u(rng) * 10, "mm"});
  std::ostringstream key;
  key << std::hex << seed << "-" << student << "-" << minute;
  r.key = sha256_hex(key.str());
  r.log_sha256 = r.key;
  r.log_path = "/stations/" + station + "/sessions/" + r.key.substr(0, 8) + "/session.dlog";
  r.log_bytes = 1000000 + static_cast<std::int64_t>(seed % 1000);
  r.report_dir = "/stations/" + station + "/sessions/" + r.key.substr(0, 8);
  r.score_json = "{\"format\":\"dentar-score\",\"outcome\":{\"points\":" + std::to_string(r.points) + "}}";
  r.score_html = "<!DOCTYPE html><html><body><h1>Score report " + r.key.substr(0, 8) +
                 "</h1><p id=\"points\">" + std::to_string(r.points) + "</p></body></html>";
  return r;
}

std::string chromium_binary() {
  for (const char* p : {"/usr/bin/chromium", "/usr/bin/chromium-browser"})
    if (fs::exists(p)) return p;
  return "";
}

BrowserResult chromium(const std::string& flags, const std::string& url) {
  static int n = 0;
  const fs::path prof = fs::temp_directory_path() / ("dentar_chromium_" + std::to_string(getpid()) + "_" + std::to_string(n++));
  fs::remove_all(prof);
  fs::create_directories(prof);
  const std::string cmd = chromium_binary() +
                          " --headless --no-sandbox --disable-gpu --disable-quic --no-first-run"
                          " --disable-background-networking --disable-component-update --disable-sync"
                          " --disable-dev-shm-usage --user-data-dir=" + quote(prof.string()) + " " + flags + " " +
                          quote(url) + " 2>/dev/null";
  const auto r = dentar::test::run_command(cmd);
  std::error_code ec;
  fs::remove_all(prof, ec);
  return {r.code, r.out};
}

fs::path login_page_file(const fs::path& dir, const std::string& base, const std::string& user,
                         const std::string& password, const std::string& next) {
  const fs::path p = dir / "login.html";
  std::ofstream f(p);
  f << "<!DOCTYPE html><html><body><form id=\"f\" method=\"post\" action=\"" << base << "/login\">"
    << "<input name=\"user\" value=\"" << user << "\"><input name=\"password\" value=\"" << password
    << "\"><input name=\"next\" value=\"" << next << "\"></form>"
    << "<script>document.getElementById('f').submit();</script></body></html>";
  return p;
}

}  // namespace dentar::store::testkit
