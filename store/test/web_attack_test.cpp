// Issue 26: the instructor's page on a school network, attacked for real.
// Slow clients (more than worker threads, plain and TLS), a header flood with
// the server's memory watched, 100 wrong logins then the right one, logout
// only by POST with the CSRF token, a stored report that tries to navigate
// away in headless Chromium, HSTS and forward-secret TLS 1.2 ciphers. The
// raw sockets, slow clients and login form come from testkit (shared with
// page_attack_bench).
#include <gtest/gtest.h>
#include <httplib.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <mutex>
#include <thread>

#include "dentar/store/store.h"
#include "dentar/store/web.h"
#include "testkit.h"
#include "testutil.h"

namespace {
namespace fs = std::filesystem;
using namespace dentar::store;
using Clock = std::chrono::steady_clock;

constexpr const char* kUser = "alice";
constexpr const char* kPassword = "correct-horse-battery";

double ms_since(Clock::time_point a) { return std::chrono::duration<double, std::milli>(Clock::now() - a).count(); }

long rss_kb() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  return -1;
}

using testkit::connect_raw;
using testkit::read_until_close;

// A server over a small store, in this process (its memory is ours).
struct Served {
  fs::path dir;
  std::string db;
  std::unique_ptr<WebServer> server;
  std::thread thread;
  std::mutex log_mu;
  std::vector<std::string> log;

  explicit Served(const std::string& name, ServeOptions o = {}, bool tls = false) {
    dir = dentar::test::temp_dir(name);
    db = "sqlite:" + (dir / "school.db").string();
    {
      auto st = Store::open(db);
      EXPECT_TRUE(st.ok()) << st.error();
      for (int k = 0; k < 4; ++k)
        EXPECT_TRUE((*st)->put(testkit::make_record("s01", "st-1", "molar_access_opening", 100 + k, 60 * k)).ok());
      // A score report that tries to take the instructor elsewhere.
      auto evil = testkit::make_record("s02", "st-1", "molar_access_opening", 999, 1000);
      evil.score_html = "<!DOCTYPE html><html><head><meta http-equiv=\"refresh\" content=\"0;url=/cohort\">"
                        "<title>report</title></head><body><p id=\"report-marker\">the report stays</p></body></html>";
      EXPECT_TRUE((*st)->put(evil).ok());
    }
    EXPECT_TRUE(set_password((dir / "pw.txt").string(), kUser, kPassword, 100000).ok());
    o.db_url = db;
    o.password_file = (dir / "pw.txt").string();
    o.port = 0;
    o.log = [this](const std::string& l) {
      std::lock_guard lk(log_mu);
      log.push_back(l);
    };
    if (tls) {
      const auto gen = dentar::test::run_command(
          "openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj /CN=localhost -keyout " + (dir / "key.pem").string() +
          " -out " + (dir / "cert.pem").string() + " 2>&1");
      EXPECT_EQ(gen.code, 0) << gen.out;
      o.cert_file = (dir / "cert.pem").string();
      o.key_file = (dir / "key.pem").string();
    }
    auto w = WebServer::create(o);
    EXPECT_TRUE(w.ok()) << w.error();
    if (!w) return;
    server = std::move(*w);
    EXPECT_TRUE(server->bind().ok());
    thread = std::thread([this] { (void)server->listen_after_bind(); });
  }
  ~Served() {
    if (server) server->stop();
    if (thread.joinable()) thread.join();
  }
  int port() const { return server->port(); }
  std::string base() const { return "http://127.0.0.1:" + std::to_string(port()); }
  bool logged(const std::string& part) {
    std::lock_guard lk(log_mu);
    for (const auto& l : log)
      if (l.find(part) != std::string::npos) return true;
    return false;
  }
  std::string all_log() {
    std::lock_guard lk(log_mu);
    std::string s;
    for (const auto& l : log) s += l + "\n";
    return s;
  }
};

// Slowloris: 12 connections (the server has 2 workers) each send one byte of
// their request head every 0.5 s. A normal request is still answered within
// 1 s (a quiet one takes a few ms here; without the front it waits for a
// worker until the slow clients give up), and the slow ones get 408 and are
// closed at the request deadline.
TEST(WebAttack, SlowClientsDoNotHoldTheWorkers) {
  ServeOptions o;
  o.threads = 2;
  o.request_timeout_s = 3;
  Served s("web_slow", o);
  ASSERT_TRUE(s.server);
  constexpr int kSlow = 12;
  // Each sends the request line, Host and 40 bytes of an X-Slow header, one
  // byte every 0.5 s, then waits.
  testkit::SlowClients slow(s.port(), kSlow, std::chrono::milliseconds(500), false, 80);
  ASSERT_EQ(slow.connected(), kSlow);
  std::this_thread::sleep_for(std::chrono::milliseconds(1200));  // the slow clients are in
  for (int round = 0; round < 3; ++round) {
    httplib::Client c("127.0.0.1", s.port());
    c.set_read_timeout(5, 0);
    const auto a = Clock::now();
    auto r = c.Get("/login");
    const double ms = ms_since(a);
    ASSERT_TRUE(r) << httplib::to_string(r.error());
    EXPECT_EQ(r->status, 200);
    EXPECT_LT(ms, 1000.0) << "a normal request waited behind " << kSlow << " slow clients";
  }
  // The deadline ends each slow request (3 s after it connected). The
  // clients stop sending first, so the server's close is a FIN, not a reset.
  slow.stop();
  int timed_out = 0;
  for (int fd : slow.fds()) {
    const std::string got = read_until_close(fd, 4000);
    if (got.find("408 Request Timeout") != std::string::npos) ++timed_out;
  }
  EXPECT_EQ(timed_out, kSlow);
  EXPECT_TRUE(s.logged("127.0.0.1: the request was not complete within 3 s")) << s.all_log();
}

// One address may hold max_conn_per_client connections; more are answered
// 503 and closed at once, and the page still works for everybody else.
TEST(WebAttack, ConnectionsPerClientAreLimited) {
  ServeOptions o;
  o.max_conn_per_client = 6;
  Served s("web_perclient", o);
  ASSERT_TRUE(s.server);
  std::vector<int> fds;
  for (int i = 0; i < 6; ++i) fds.push_back(connect_raw(s.port()));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  const int extra = connect_raw(s.port());
  ASSERT_GE(extra, 0);
  EXPECT_NE(read_until_close(extra, 2000).find("503"), std::string::npos);
  ::close(extra);
  for (int fd : fds) ::close(fd);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  httplib::Client c("127.0.0.1", s.port());
  auto r = c.Get("/login");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_TRUE(s.logged("more than 6 connections from this address")) << s.all_log();
}

// Four requests with 45 MB of headers each: refused (431) after 16 KiB, and
// the server's memory (this process) does not grow with them.
TEST(WebAttack, HeaderFloodIsRefusedAndMemoryStays) {
  Served s("web_flood");
  ASSERT_TRUE(s.server);
  {  // warm up: the first pages allocate the pools
    httplib::Client c("127.0.0.1", s.port());
    ASSERT_TRUE(c.Get("/login"));
  }
  const long before = rss_kb();
  std::string chunk;
  while (chunk.size() < (1u << 20)) chunk += "X-Flood: " + std::string(90, 'a') + "\r\n";
  constexpr std::size_t kFlood = 45u << 20;
  std::vector<std::thread> clients;
  std::atomic<int> refused{0};
  std::atomic<std::size_t> max_sent{0};
  for (int i = 0; i < 4; ++i)
    clients.emplace_back([&] {
      const int fd = connect_raw(s.port());
      if (fd < 0) return;
      std::string head = "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n";
      std::size_t sent = 0;
      (void)::send(fd, head.data(), head.size(), MSG_NOSIGNAL);
      while (sent < kFlood) {
        const ssize_t n = ::send(fd, chunk.data(), chunk.size(), MSG_NOSIGNAL);
        if (n <= 0) break;
        sent += static_cast<std::size_t>(n);
      }
      const std::string got = read_until_close(fd, 2000);
      if (sent < kFlood || got.find("431") != std::string::npos) ++refused;
      std::size_t m = max_sent;
      while (sent > m && !max_sent.compare_exchange_weak(m, sent)) {
      }
      ::close(fd);
    });
  for (auto& t : clients) t.join();
  const long after = rss_kb();
  EXPECT_EQ(refused.load(), 4);
  EXPECT_LT(max_sent.load(), kFlood / 4) << "the server kept reading a 45 MB head";
  EXPECT_LT(after - before, 20 * 1024) << "RSS " << before << " kB -> " << after << " kB";
  EXPECT_TRUE(s.logged("request head over 16384 bytes")) << s.all_log();
  httplib::Client c("127.0.0.1", s.port());
  auto r = c.Get("/login");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
}

// 100 wrong passwords, then the right one: delayed (429 + Retry-After, the
// password not even checked), then accepted once the wait is over. Each
// failure and each throttle is logged; another user from the same address is
// throttled too (per address), and the wait is never longer than the cap.
TEST(WebAttack, LoginThrottlingDelaysWithoutLockingOut) {
  ServeOptions o;
  o.login_free_tries = 5;
  o.login_max_delay_s = 2;
  Served s("web_throttle", o);
  ASSERT_TRUE(s.server);
  // The guesser fetches the login form like a browser (its CSRF token is no
  // secret from the one who asks for it; it only stops other sites' forms).
  const testkit::LoginForm form = testkit::get_login_form(s.port());
  ASSERT_FALSE(form.csrf.empty());
  int checked = 0, throttled = 0;
  for (int i = 0; i < 100; ++i) {
    const auto r = testkit::post_login(s.port(), form, kUser, "wrong-guess-" + std::to_string(i));
    ASSERT_TRUE(r.status == 401 || r.status == 429) << r.status;
    (r.status == 401 ? checked : throttled)++;
  }
  EXPECT_GE(checked, 5);
  EXPECT_LE(checked, 20) << "most guesses must be refused unchecked";
  const auto right = testkit::post_login(s.port(), form, kUser, kPassword);
  EXPECT_EQ(right.status, 429);
  EXPECT_TRUE(right.session.empty());
  const int wait = std::stoi(right.retry_after);
  EXPECT_GE(wait, 1);
  EXPECT_LE(wait, 2);
  EXPECT_NE(right.body.find("try again in"), std::string::npos);
  EXPECT_NE(right.body.find("name=\"csrf\" value=\"" + form.csrf + "\""), std::string::npos) << "the form still works";
  const auto bob = testkit::post_login(s.port(), form, "bob", "whatever-it-is");
  EXPECT_EQ(bob.status, 429) << "the address is throttled, whatever the user name";
  std::this_thread::sleep_for(std::chrono::milliseconds(wait * 1000 + 200));
  const auto later = testkit::post_login(s.port(), form, kUser, kPassword);
  EXPECT_EQ(later.status, 303) << later.body.substr(0, 500);
  EXPECT_NE(later.session.find("dentar_session="), std::string::npos);
  EXPECT_TRUE(s.logged("login failed for user 'alice' from 127.0.0.1: failure 1 of the user")) << s.all_log();
  EXPECT_TRUE(s.logged("login throttled for user 'alice' from 127.0.0.1: next try in")) << s.all_log();
  EXPECT_TRUE(s.logged("login of user 'alice' from 127.0.0.1")) << s.all_log();
}

std::string login_cookie(Served& s) { return testkit::login_cookie(s.port(), kUser, kPassword); }

// Logout is a form (POST) with the session's CSRF token; a GET does nothing,
// a POST without the token (another site's form) is refused.
TEST(WebAttack, LogoutIsAPostWithTheCsrfToken) {
  Served s("web_csrf");
  ASSERT_TRUE(s.server);
  const std::string cookie = login_cookie(s);
  ASSERT_FALSE(cookie.empty());
  httplib::Client c("127.0.0.1", s.port());
  httplib::Headers h = {{"Cookie", cookie}};
  auto home = c.Get("/", h);
  ASSERT_TRUE(home);
  ASSERT_EQ(home->status, 200);
  const std::string mark = "name=\"csrf\" value=\"";
  const auto at = home->body.find(mark);
  ASSERT_NE(at, std::string::npos) << "the logout form carries a token";
  EXPECT_NE(home->body.find("<form class=\"logout\" method=\"post\" action=\"/logout\">"), std::string::npos);
  const std::string token = home->body.substr(at + mark.size(), 32);
  auto get = c.Get("/logout", h);
  ASSERT_TRUE(get);
  EXPECT_EQ(get->status, 404);
  auto forged = c.Post("/logout", h, "csrf=0000", "application/x-www-form-urlencoded");
  ASSERT_TRUE(forged);
  EXPECT_EQ(forged->status, 403);
  auto none = c.Post("/logout", h, "", "application/x-www-form-urlencoded");
  ASSERT_TRUE(none);
  EXPECT_EQ(none->status, 403);
  auto still = c.Get("/", h);
  ASSERT_TRUE(still);
  EXPECT_EQ(still->status, 200) << "the session survives forged logouts";
  auto out = c.Post("/logout", h, "csrf=" + token, "application/x-www-form-urlencoded");
  ASSERT_TRUE(out);
  EXPECT_EQ(out->status, 303);
  auto gone = c.Get("/", h);
  ASSERT_TRUE(gone);
  EXPECT_EQ(gone->status, 303) << "logged out";
  EXPECT_TRUE(s.logged("logout refused for user 'alice' from 127.0.0.1: no or a wrong CSRF token")) << s.all_log();
}

// The stored report with <meta http-equiv=refresh> is served with a CSP
// sandbox, and headless Chromium stays on it (no navigation to /cohort).
TEST(WebAttack, StoredReportCannotNavigate) {
  Served s("web_sandbox");
  ASSERT_TRUE(s.server);
  auto st = Store::open(s.db);
  ASSERT_TRUE(st.ok());
  SessionFilter f;
  f.student = "s02";
  auto ss = (*st)->sessions(f);
  ASSERT_TRUE(ss.ok());
  ASSERT_EQ(ss->size(), 1u);
  const std::string path = "/session/" + std::to_string((*ss)[0].id) + "/report";
  const std::string cookie = login_cookie(s);
  httplib::Client c("127.0.0.1", s.port());
  auto r = c.Get(path.c_str(), {{"Cookie", cookie}});
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200);
  EXPECT_NE(r->get_header_value("Content-Security-Policy").find("; sandbox"), std::string::npos);
  // The instructor logs in on the server's login page and lands on the
  // report; its refresh (0 s) would navigate at once: nothing in 3 s.
  testkit::Browser b;
  ASSERT_TRUE(testkit::browser_login(b, s.base(), kUser, kPassword, path)) << b.error();
  EXPECT_NE(b.url().find(path), std::string::npos) << b.url();
  EXPECT_FALSE(b.navigates_within(3.0)) << "the report navigated away to " << b.url();
  EXPECT_NE(b.url().find(path), std::string::npos) << b.url();
  const std::string dom = b.dom();
  EXPECT_NE(dom.find("the report stays"), std::string::npos) << dom.substr(0, 2000);
  EXPECT_EQ(dom.find("<h1>Cohort</h1>"), std::string::npos) << "the report navigated away";
}

// HTTPS: slow handshakes do not hold the workers either, HSTS is sent, and
// TLS 1.2 offers only forward-secret (ECDHE) suites.
TEST(WebAttack, TlsHoldsAgainstSlowHandshakesAndIsForwardSecret) {
  ServeOptions o;
  o.threads = 2;
  o.request_timeout_s = 3;
  Served s("web_tls", o, true);
  ASSERT_TRUE(s.server);
  std::vector<int> idle;
  for (int i = 0; i < 10; ++i) idle.push_back(connect_raw(s.port()));  // connect, never say hello
  const char hello_start[] = {0x16, 0x03, 0x01};
  for (int fd : idle) (void)::send(fd, hello_start, sizeof hello_start, MSG_NOSIGNAL);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  httplib::SSLClient c("127.0.0.1", s.port());
  c.enable_server_certificate_verification(false);
  c.set_read_timeout(5, 0);
  const auto a = Clock::now();
  auto r = c.Get("/login");
  const double ms = ms_since(a);
  ASSERT_TRUE(r) << httplib::to_string(r.error());
  EXPECT_EQ(r->status, 200);
  EXPECT_LT(ms, 1000.0);
  EXPECT_EQ(r->get_header_value("Strict-Transport-Security"), "max-age=31536000");
  for (int fd : idle) ::close(fd);
  const std::string sc = "openssl s_client -connect 127.0.0.1:" + std::to_string(s.port()) + " -tls1_2 -cipher ";
  const auto plain_rsa = dentar::test::run_command("echo | " + sc + "AES128-GCM-SHA256 2>&1");
  EXPECT_NE(plain_rsa.code, 0) << plain_rsa.out;
  const auto ecdhe = dentar::test::run_command("echo | " + sc + "ECDHE-RSA-AES128-GCM-SHA256 2>&1");
  EXPECT_EQ(ecdhe.code, 0) << ecdhe.out;
  EXPECT_NE(ecdhe.out.find("ECDHE-RSA-AES128-GCM-SHA256"), std::string::npos);
}

}  // namespace
