// Issue 26 benchmark: the instructor's page under attack. Starts a real
// `dentar serve` (the binary given, so an older build can be compared), logs
// in, and times normal page requests (GET /student/s01) in three runs:
//   quiet       nothing else going on;
//   slowloris   SLOW connections each sending one header byte every 4 s
//               (more than the server's 8 worker threads);
//   login flood FLOOD threads posting wrong passwords as fast as they can
//               (each with the login form's CSRF token, fetched first);
//   forged flood the same without the form's cookie and token (refused 403).
// Prints p50/p99 per run and how many normal requests were answered within
// the client's 10 s timeout.
//
// Usage: page_attack_bench DENTAR_BINARY [WORKDIR] [REQUESTS=200] [SLOW=12] [FLOOD=4]
#include <httplib.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "dentar/store/auth.h"
#include "dentar/store/store.h"
#include "testkit.h"

namespace {
namespace fs = std::filesystem;
using namespace dentar::store;
using Clock = std::chrono::steady_clock;

struct Run {
  std::vector<double> ms;
  int failed = 0;
};

// n requests (after 5 warm-up ones), one every 100 ms: each run lasts
// >= 20 s for n = 200, long enough for the attacks to be in full swing.
Run time_pages(int port, const std::string& cookie, int n) {
  Run r;
  for (int i = 0; i < n + 5; ++i) {
    if (i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    httplib::Client c("127.0.0.1", port);
    c.set_connection_timeout(10, 0);
    c.set_read_timeout(10, 0);
    const auto a = Clock::now();
    auto res = c.Get("/student/s01", {{"Cookie", cookie}});
    const double d = std::chrono::duration<double, std::milli>(Clock::now() - a).count();
    if (!res || res->status != 200) {
      ++r.failed;
      continue;
    }
    if (i >= 5) r.ms.push_back(d);
  }
  return r;
}

double pct(std::vector<double> v, double p) {
  if (v.empty()) return -1;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

void print(const char* name, const Run& r, int n, const std::string& extra) {
  std::printf("%-12s p50 %8.1f ms  p99 %8.1f ms  answered %zu/%d%s\n", name, pct(r.ms, 0.5), pct(r.ms, 0.99), r.ms.size(), n,
              extra.c_str());
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s DENTAR_BINARY [WORKDIR] [REQUESTS=200] [SLOW=12] [FLOOD=4]\n", argv[0]);
    return 2;
  }
  const std::string bin = argv[1];
  const fs::path dir = argc > 2 ? fs::path(argv[2]) : fs::temp_directory_path() / "dentar_page_attack";
  const int n = argc > 3 ? std::atoi(argv[3]) : 200;
  const int slow = argc > 4 ? std::atoi(argv[4]) : 12;
  const int flood = argc > 5 ? std::atoi(argv[5]) : 4;
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string db = "sqlite:" + (dir / "school.db").string();
  {
    auto st = Store::open(db);
    if (!st) {
      std::fprintf(stderr, "%s\n", st.error().c_str());
      return 1;
    }
    for (int k = 0; k < 60; ++k)
      (void)(*st)->put(testkit::make_record("s0" + std::to_string(k % 3), "st" + std::to_string(k % 5),
                                            k % 2 ? "molar_access_opening" : "incisor_partial_crown", 7000 + k, 41 * k));
  }
  const std::string pw = (dir / "pw.txt").string();
  if (auto s = set_password(pw, "alice", "correct-horse-battery", kDefaultPbkdf2Iterations); !s) {
    std::fprintf(stderr, "%s\n", s.error().c_str());
    return 1;
  }
  const int port = testkit::free_port();
  const pid_t pid = fork();
  if (pid == 0) {
    const std::string p = std::to_string(port);
    const std::string log = (dir / "serve.log").string();
    if (!freopen(log.c_str(), "w", stderr)) _exit(127);
    execl(bin.c_str(), bin.c_str(), "serve", "--db", db.c_str(), "--passwords", pw.c_str(), "--port", p.c_str(),
          "--threads", "8", static_cast<char*>(nullptr));
    _exit(127);
  }
  // The login form as a browser gets it (GET /login: its CSRF token), then posted.
  std::string cookie;
  for (int i = 0; i < 100 && cookie.empty(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    cookie = testkit::login_cookie(port, "alice", "correct-horse-battery");
  }
  if (cookie.empty()) {
    std::fprintf(stderr, "the server did not come up (see %s)\n", (dir / "serve.log").c_str());
    kill(pid, SIGKILL);
    waitpid(pid, nullptr, 0);
    return 1;
  }
  std::printf("server: %s, %d requests of GET /student/s01 per run\n", bin.c_str(), n);
  print("quiet", time_pages(port, cookie, n), n, "");

  {  // slowloris
    // A persistent attacker: a connection the server closed is opened again.
    testkit::SlowClients attack(port, slow, std::chrono::seconds(4), true);
    std::this_thread::sleep_for(std::chrono::seconds(1));
    const Run r = time_pages(port, cookie, n);
    print("slowloris", r, n,
          "  (" + std::to_string(slow) + " connections, 1 header byte / 4 s, " + std::to_string(attack.reconnects()) +
              " reconnects after the server closed one)");
  }
  std::this_thread::sleep_for(std::chrono::seconds(1));
  // Login floods. forged = false: the guesser fetches the login form first, as
  // a browser would (the CSRF token does not stop guessing, throttling does;
  // each unthrottled guess costs the password check). forged = true: posts
  // without the form's cookie and token (another site's form, or a bot that
  // skips the page): refused 403 before any password work.
  auto login_flood = [&](const char* name, bool forged_posts) {
    std::atomic<bool> stop{false};
    std::atomic<long> tries{0}, checked{0}, throttled{0}, forged{0};
    std::vector<std::thread> fl;
    for (int i = 0; i < flood; ++i)
      fl.emplace_back([&, i] {
        const testkit::LoginForm form = forged_posts ? testkit::LoginForm{} : testkit::get_login_form(port);
        httplib::Client c("127.0.0.1", port);
        c.set_read_timeout(10, 0);
        httplib::Headers h;
        if (!form.cookie.empty()) h.emplace("Cookie", form.cookie);
        for (long k = 0; !stop; ++k) {
          auto r = c.Post("/login", h,
                          "user=alice&password=guess-" + std::to_string(i) + "-" + std::to_string(k) + "&next=/" +
                              (form.csrf.empty() ? "" : "&csrf=" + form.csrf),
                          "application/x-www-form-urlencoded");
          ++tries;
          if (r && r->status == 401) ++checked;
          if (r && r->status == 429) ++throttled;
          if (r && r->status == 403) ++forged;
        }
      });
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    const auto a = Clock::now();
    const Run r = time_pages(port, cookie, n);
    const double s = std::chrono::duration<double>(Clock::now() - a).count();
    stop = true;
    for (auto& t : fl) t.join();
    print(name, r, n,
          "  (" + std::to_string(flood) + " threads: " + std::to_string(tries.load()) + " wrong logins in " +
              std::to_string(static_cast<int>(s + 0.5)) + " s, " + std::to_string(checked.load()) + " checked, " +
              std::to_string(throttled.load()) + " throttled, " + std::to_string(forged.load()) +
              " refused for their CSRF token)");
  };
  login_flood("login flood", false);
  std::this_thread::sleep_for(std::chrono::seconds(1));
  login_flood("forged flood", true);
  kill(pid, SIGTERM);
  int status = 0;
  waitpid(pid, &status, 0);
  return 0;
}
