#include "testkit.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <httplib.h>
#include <netinet/in.h>
#include <openssl/evp.h>
#include <poll.h>
#include <pwd.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <deque>
#include <functional>
#include <fstream>
#include <nlohmann/json.hpp>
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

// --- Chromium over the DevTools protocol (messages are JSON, each ended by a NUL byte) ---

using nlohmann::json;
using Clock = std::chrono::steady_clock;
// Generous: on this shared 2-core machine under load ~25 a DevTools answer
// has taken over 10 s. A command that does not answer within these fails
// the test with the command's name.
constexpr double kStartTimeoutS = 90, kCallTimeoutS = 45;

struct Browser::Impl {
  pid_t pid = -1;
  int to = -1, from = -1;  // our ends: commands to fd 3, replies from fd 4
  std::string buf;
  int next_id = 1;
  std::string target, session;
  std::deque<json> events;
  fs::path profile;

  bool write_all(const std::string& m) {
    std::size_t off = 0;
    while (off < m.size()) {
      const ssize_t n = ::write(to, m.data() + off, m.size() - off);
      if (n <= 0) return false;
      off += static_cast<std::size_t>(n);
    }
    return true;
  }
  // One message, or null on timeout or a closed pipe.
  json read_one(Clock::time_point until) {
    for (;;) {
      if (const auto z = buf.find('\0'); z != std::string::npos) {
        json j = json::parse(buf.substr(0, z), nullptr, false);
        buf.erase(0, z + 1);
        if (!j.is_discarded()) return j;
        continue;
      }
      const int left = static_cast<int>(std::chrono::duration_cast<std::chrono::milliseconds>(until - Clock::now()).count());
      if (left <= 0) return nullptr;
      pollfd p{from, POLLIN, 0};
      if (::poll(&p, 1, left) <= 0) return nullptr;
      char b[65536];
      const ssize_t n = ::read(from, b, sizeof b);
      if (n <= 0) return nullptr;
      buf.append(b, static_cast<std::size_t>(n));
    }
  }
  // A command's result; null with *err set on an error or a timeout.
  json call(const std::string& method, const json& params, bool in_page, double timeout_s, std::string* err) {
    const int id = next_id++;
    json m = {{"id", id}, {"method", method}, {"params", params.is_null() ? json::object() : params}};
    if (in_page) m["sessionId"] = session;
    if (!write_all(m.dump() + std::string(1, '\0'))) {
      if (err) *err = method + ": the browser is gone";
      return nullptr;
    }
    const auto until = Clock::now() + std::chrono::milliseconds(static_cast<long>(timeout_s * 1000));
    for (;;) {
      json r = read_one(until);
      if (r.is_null()) {
        if (err) *err = method + ": no answer from the browser";
        return nullptr;
      }
      if (r.contains("id") && r["id"] == id) {
        if (r.contains("error")) {
          if (err) *err = method + ": " + r["error"].dump();
          return nullptr;
        }
        return r.value("result", json::object());
      }
      if (r.contains("method")) events.push_back(std::move(r));
    }
  }
  // Waits for an event of this page; true if it came.
  bool wait_event(const std::string& method, double timeout_s, const std::function<bool(const json&)>& also = {}) {
    const auto until = Clock::now() + std::chrono::milliseconds(static_cast<long>(timeout_s * 1000));
    for (;;) {
      while (!events.empty()) {
        json e = std::move(events.front());
        events.pop_front();
        if (e.value("method", "") == method && e.value("sessionId", "") == session &&
            (!also || also(e.value("params", json::object()))))
          return true;
      }
      json r = read_one(until);
      if (r.is_null()) return false;
      if (r.contains("method")) events.push_back(std::move(r));
    }
  }
  std::string main_frame;
};

Browser::Browser(int width, int height) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  if (chromium_binary().empty()) {
    error_ = "Debian's chromium is not installed (tools/bootstrap.sh installs it)";
    return;
  }
  ::signal(SIGPIPE, SIG_IGN);  // a browser that died is an error, not the end of the test
  static std::atomic<int> n{0};
  m.profile = fs::temp_directory_path() / ("dentar_cdp_" + std::to_string(getpid()) + "_" + std::to_string(n++));
  fs::remove_all(m.profile);
  fs::create_directories(m.profile);
  int cmd[2], rep[2];
  if (::pipe2(cmd, O_CLOEXEC) != 0 || ::pipe2(rep, O_CLOEXEC) != 0) {
    error_ = "pipe failed";
    return;
  }
  const std::vector<std::string> args = {chromium_binary(), "--headless", "--no-sandbox", "--disable-gpu",
                                         "--disable-quic", "--no-first-run", "--disable-background-networking",
                                         "--disable-component-update", "--disable-sync", "--disable-dev-shm-usage",
                                         "--remote-debugging-pipe", "--user-data-dir=" + m.profile.string(),
                                         "about:blank"};
  m.pid = ::fork();
  if (m.pid == 0) {
    ::setpgid(0, 0);
    // Above 10 first (the pipes may be 3 or 4 themselves), then onto 3 and 4 without close-on-exec.
    const int a = ::fcntl(cmd[0], F_DUPFD, 10), b = ::fcntl(rep[1], F_DUPFD, 10);
    if (a < 0 || b < 0 || ::dup2(a, 3) < 0 || ::dup2(b, 4) < 0) _exit(127);
    const int null = ::open("/dev/null", O_RDWR);
    if (null >= 0) ::dup2(null, 1), ::dup2(null, 2);
    std::vector<char*> argv;
    for (const auto& x : args) argv.push_back(const_cast<char*>(x.c_str()));
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    _exit(127);
  }
  ::close(cmd[0]);
  ::close(rep[1]);
  m.to = cmd[1];
  m.from = rep[0];
  if (m.pid < 0) {
    error_ = "fork failed";
    return;
  }
  auto t = m.call("Target.createTarget", {{"url", "about:blank"}}, false, kStartTimeoutS, &error_);
  if (t.is_null()) return;
  m.target = t.value("targetId", "");
  auto a = m.call("Target.attachToTarget", {{"targetId", m.target}, {"flatten", true}}, false, kCallTimeoutS, &error_);
  if (a.is_null()) return;
  m.session = a.value("sessionId", "");
  if (m.call("Page.enable", {}, true, kCallTimeoutS, &error_).is_null()) return;
  if (m.call("Emulation.setDeviceMetricsOverride",
             {{"width", width}, {"height", height}, {"deviceScaleFactor", 1}, {"mobile", false}}, true, kCallTimeoutS, &error_)
          .is_null())
    return;
  auto ft = m.call("Page.getFrameTree", {}, true, kCallTimeoutS, &error_);
  if (ft.is_null()) return;
  m.main_frame = ft["frameTree"]["frame"].value("id", "");
}

Browser::~Browser() {
  Impl& m = *impl_;
  if (m.pid > 0) {
    if (m.to >= 0) (void)m.call("Browser.close", {}, false, 3, nullptr);
    int status = 0;
    bool gone = false;
    for (int i = 0; i < 30 && !gone; ++i) {
      gone = ::waitpid(m.pid, &status, WNOHANG) == m.pid;
      if (!gone) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    ::kill(-m.pid, SIGKILL);  // the browser's own process group (its helpers)
    if (!gone) ::waitpid(m.pid, &status, 0);
  }
  if (m.to >= 0) ::close(m.to);
  if (m.from >= 0) ::close(m.from);
  std::error_code ec;
  if (!m.profile.empty()) fs::remove_all(m.profile, ec);
}

bool Browser::open(const std::string& url, double timeout_s) {
  if (!ok()) return false;
  Impl& m = *impl_;
  m.events.clear();
  auto r = m.call("Page.navigate", {{"url", url}}, true, timeout_s, &error_);
  if (r.is_null()) return false;
  if (r.contains("errorText")) {
    error_ = "Page.navigate " + url + ": " + r["errorText"].dump();
    return false;
  }
  if (!m.wait_event("Page.loadEventFired", timeout_s)) {
    error_ = url + ": the page did not load within " + std::to_string(timeout_s) + " s";
    return false;
  }
  return true;
}

bool Browser::type(const std::string& selector, const std::string& text) {
  if (!ok()) return false;
  Impl& m = *impl_;
  auto doc = m.call("DOM.getDocument", {{"depth", 0}}, true, kCallTimeoutS, &error_);
  if (doc.is_null()) return false;
  auto q = m.call("DOM.querySelector", {{"nodeId", doc["root"]["nodeId"]}, {"selector", selector}}, true, kCallTimeoutS, &error_);
  if (q.is_null()) return false;
  if (q.value("nodeId", 0) == 0) {
    error_ = "no element matches " + selector + " on " + url();
    return false;
  }
  if (m.call("DOM.focus", {{"nodeId", q["nodeId"]}}, true, kCallTimeoutS, &error_).is_null()) return false;
  return !m.call("Input.insertText", {{"text", text}}, true, kCallTimeoutS, &error_).is_null();
}

bool Browser::press_enter(double timeout_s) {
  if (!ok()) return false;
  Impl& m = *impl_;
  m.events.clear();
  const json key = {{"key", "Enter"}, {"code", "Enter"}, {"windowsVirtualKeyCode", 13}, {"nativeVirtualKeyCode", 13}};
  json down = key;
  down["type"] = "keyDown";
  down["text"] = "\r";
  json up = key;
  up["type"] = "keyUp";
  if (m.call("Input.dispatchKeyEvent", down, true, kCallTimeoutS, &error_).is_null()) return false;
  if (m.call("Input.dispatchKeyEvent", up, true, kCallTimeoutS, &error_).is_null()) return false;
  if (!m.wait_event("Page.loadEventFired", timeout_s)) {
    error_ = "no page loaded within " + std::to_string(timeout_s) + " s after Enter";
    return false;
  }
  return true;
}

bool Browser::navigates_within(double s) {
  Impl& m = *impl_;
  const std::string frame = m.main_frame;
  return m.wait_event("Page.frameNavigated", s, [&](const json& p) {
    return p.contains("frame") && p["frame"].value("id", "") == frame;
  });
}

std::string Browser::dom() {
  if (!ok()) return "";
  Impl& m = *impl_;
  auto doc = m.call("DOM.getDocument", {{"depth", 0}}, true, kCallTimeoutS, &error_);
  if (doc.is_null()) return "";
  auto h = m.call("DOM.getOuterHTML", {{"nodeId", doc["root"]["nodeId"]}}, true, kCallTimeoutS, &error_);
  return h.is_null() ? "" : h.value("outerHTML", "");
}

std::string Browser::url() {
  Impl& m = *impl_;
  auto i = m.call("Target.getTargetInfo", {{"targetId", m.target}}, false, kCallTimeoutS, nullptr);
  return i.is_null() ? "" : i["targetInfo"].value("url", "");
}

bool Browser::screenshot(const fs::path& png) {
  if (!ok()) return false;
  auto r = impl_->call("Page.captureScreenshot", {{"format", "png"}}, true, kCallTimeoutS, &error_);
  if (r.is_null()) return false;
  const std::string b64 = r.value("data", "");
  std::string bytes(b64.size() / 4 * 3 + 3, '\0');
  const int n = EVP_DecodeBlock(reinterpret_cast<unsigned char*>(bytes.data()),
                                reinterpret_cast<const unsigned char*>(b64.data()), static_cast<int>(b64.size()));
  if (n < 0) {
    error_ = "Page.captureScreenshot: not base64";
    return false;
  }
  std::size_t len = static_cast<std::size_t>(n);
  for (std::size_t i = b64.size(); i > 0 && b64[i - 1] == '='; --i) --len;  // EVP_DecodeBlock counts the padding
  std::ofstream f(png, std::ios::binary);
  f.write(bytes.data(), static_cast<std::streamsize>(len));
  return static_cast<bool>(f);
}

bool browser_login(Browser& b, const std::string& base, const std::string& user, const std::string& password,
                   const std::string& next) {
  return b.open(base + "/login?next=" + next) && b.type("input[name=user]", user) &&
         b.type("input[name=password]", password) && b.press_enter();
}

// --- the login over plain HTTP ---

LoginForm get_login_form(int port) {
  httplib::Client c("127.0.0.1", port);
  auto r = c.Get("/login");
  LoginForm f;
  if (!r) return f;
  for (auto [a, e] = r->headers.equal_range("Set-Cookie"); a != e; ++a)
    if (a->second.rfind("dentar_login=", 0) == 0) f.cookie = a->second.substr(0, a->second.find(';'));
  const std::string mark = "name=\"csrf\" value=\"";
  if (const auto at = r->body.find(mark); at != std::string::npos) {
    const auto end = r->body.find('"', at + mark.size());
    f.csrf = r->body.substr(at + mark.size(), end - at - mark.size());
  }
  return f;
}

LoginReply post_login(int port, const LoginForm& form, const std::string& user, const std::string& password,
                      const std::string& next) {
  httplib::Client c("127.0.0.1", port);
  httplib::Headers h;
  if (!form.cookie.empty()) h.emplace("Cookie", form.cookie);
  httplib::Params p = {{"user", user}, {"password", password}, {"next", next}};
  if (!form.csrf.empty()) p.emplace("csrf", form.csrf);
  auto r = c.Post("/login", h, p);
  LoginReply o;
  if (!r) return o;
  o.status = r->status;
  o.body = r->body;
  o.retry_after = r->get_header_value("Retry-After");
  for (auto [a, e] = r->headers.equal_range("Set-Cookie"); a != e; ++a)
    if (a->second.rfind("dentar_session=", 0) == 0) o.session = a->second.substr(0, a->second.find(';'));
  return o;
}

std::string login_cookie(int port, const std::string& user, const std::string& password) {
  const LoginReply r = post_login(port, get_login_form(port), user, password);
  return r.status == 303 ? r.session : "";
}

// --- raw sockets ---

int connect_raw(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

std::string read_until_close(int fd, int ms) {
  std::string out;
  const auto end = Clock::now() + std::chrono::milliseconds(ms);
  char b[4096];
  for (;;) {
    const int left = static_cast<int>(std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now()).count());
    if (left <= 0) break;
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, left) <= 0) break;
    const ssize_t n = ::recv(fd, b, sizeof b, 0);
    if (n <= 0) break;
    out.append(b, static_cast<std::size_t>(n));
  }
  return out;
}

SlowClients::SlowClients(int port, int n, std::chrono::milliseconds every, bool reconnect, std::size_t max_bytes)
    : port_(port) {
  for (int i = 0; i < n; ++i) fds_.push_back(connect_raw(port));
  drip_ = std::thread([this, every, reconnect, max_bytes] {
    const std::string head = "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: ";
    std::vector<std::size_t> at(fds_.size(), 0);
    while (!stop_) {
      {
        std::lock_guard lk(mu_);
        for (std::size_t i = 0; i < fds_.size(); ++i) {
          if (!reconnect && at[i] >= max_bytes) continue;
          const char c = at[i] < head.size() ? head[at[i]] : 'a';
          if (fds_[i] < 0 || ::send(fds_[i], &c, 1, MSG_NOSIGNAL) != 1) {
            if (!reconnect) continue;
            if (fds_[i] >= 0) ::close(fds_[i]);
            fds_[i] = connect_raw(port_);
            at[i] = 0;
            ++reconnects_;
            continue;
          }
          ++at[i];
        }
      }
      // Sleep in small steps so that stop() is quick.
      const auto until = Clock::now() + every;
      while (!stop_ && Clock::now() < until) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
}

void SlowClients::stop() {
  stop_ = true;
  if (drip_.joinable()) drip_.join();
}

SlowClients::~SlowClients() {
  stop();
  for (int fd : fds_)
    if (fd >= 0) ::close(fd);
}

int SlowClients::connected() const {
  std::lock_guard lk(mu_);
  int k = 0;
  for (int fd : fds_) k += fd >= 0;
  return k;
}

std::vector<int> SlowClients::fds() {
  std::lock_guard lk(mu_);
  return fds_;
}

}  // namespace dentar::store::testkit
