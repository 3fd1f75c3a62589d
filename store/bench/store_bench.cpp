// store_bench: sessions stored per second with 30 stations writing at once
// (SQLite file and a throwaway PostgreSQL 15 cluster, same run), and the
// instructor's page time (p50/p99) for a student with 500 sessions.
//   usage: store_bench [--sessions-per-station N] [--page-requests N]
#include <httplib.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <thread>

#include "dentar/store/store.h"
#include "dentar/store/web.h"
#include "testkit.h"
#include "testutil.h"

namespace {
namespace fs = std::filesystem;
using namespace dentar::store;
using Clock = std::chrono::steady_clock;

double pct(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size() - 1) + 0.5))];
}

void writers(const std::string& name, const std::string& url, int per_station) {
  std::vector<std::vector<double>> lat(30);
  std::atomic<int> fails{0};
  const auto t0 = Clock::now();
  std::vector<std::thread> th;
  for (int s = 0; s < 30; ++s)
    th.emplace_back([&, s] {
      auto st = Store::open(url);
      if (!st) return (void)++fails;
      // Built by append, not "b" + to_string(): GCC 12 warns a false -Wrestrict on that.
      std::string batch = "b", station = "st";
      batch += std::to_string(s % 10);
      station += std::to_string(s);
      for (int k = 0; k < per_station; ++k) {
        const auto r = testkit::make_record(batch, station,
                                            "molar_access_opening", 900000 + 1000 * s + k, k);
        const auto a = Clock::now();
        if (!(*st)->put(r)) ++fails;
        lat[s].push_back(std::chrono::duration<double, std::milli>(Clock::now() - a).count());
      }
    });
  for (auto& t : th) t.join();
  const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
  std::vector<double> all;
  for (auto& v : lat) all.insert(all.end(), v.begin(), v.end());
  std::printf("%-10s 30 stations x %d sessions: %.0f sessions/s (wall %.2f s), one session's write p50 %.1f ms, p99 %.1f ms, failures %d\n",
              name.c_str(), per_station, 30.0 * per_station / wall, wall, pct(all, 0.5), pct(all, 0.99), fails.load());
}

void page_time(const std::string& name, const std::string& url, const fs::path& dir, int requests) {
  {
    auto st = Store::open(url);
    if (!st) {
      std::printf("%s: %s\n", name.c_str(), st.error().c_str());
      return;
    }
    for (int k = 0; k < 500; ++k)
      (void)(*st)->put(testkit::make_record("p500", "st" + std::to_string(k % 30),
                                            k % 3 ? "molar_access_opening" : "incisor_partial_crown", 5000000 + k, 37 * k));
  }
  const std::string pw = (dir / (name + "_pw.txt")).string();
  (void)set_password(pw, "bench", "bench-password", 100000);
  ServeOptions o;
  o.db_url = url;
  o.password_file = pw;
  o.port = 0;
  auto w = WebServer::create(o);
  if (!w) {
    std::printf("%s: %s\n", name.c_str(), w.error().c_str());
    return;
  }
  (void)(*w)->bind();
  std::thread t([&] { (void)(*w)->listen_after_bind(); });
  httplib::Client c("127.0.0.1", (*w)->port());
  httplib::Headers h = {{"Cookie", testkit::login_cookie((*w)->port(), "bench", "bench-password")}};
  for (const char* page : {"/student/p500", "/", "/cohort"}) {
    std::vector<double> ms;
    std::size_t bytes = 0;
    for (int i = 0; i < requests + 5; ++i) {
      const auto a = Clock::now();
      auto r = c.Get(page, h);
      const double d = std::chrono::duration<double, std::milli>(Clock::now() - a).count();
      if (!r || r->status != 200) {
        std::printf("%s %s: failed\n", name.c_str(), page);
        break;
      }
      bytes = r->body.size();
      if (i >= 5) ms.push_back(d);  // 5 warm-up requests
    }
    std::printf("%-10s page %-14s (student with 500 sessions in the store): p50 %.1f ms, p99 %.1f ms, %zu bytes, %d requests\n",
                name.c_str(), page, pct(ms, 0.5), pct(ms, 0.99), bytes, requests);
  }
  (*w)->stop();
  t.join();
}

}  // namespace

int main(int argc, char** argv) {
  int per_station = 20, requests = 200;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--sessions-per-station")) per_station = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--page-requests")) requests = std::atoi(argv[i + 1]);
  }
  const fs::path dir = dentar::test::temp_dir("store_bench");
  testkit::PgCluster pg;
  if (!pg.ok()) {
    std::cerr << "store_bench: " << pg.error() << "\n";
    return 1;
  }
  auto admin = Store::open(pg.url("postgres"));
  if (!admin) return 1;
  (void)(*admin)->exec_raw("CREATE DATABASE bench_write");
  (void)(*admin)->exec_raw("CREATE DATABASE bench_page");
  const std::string sq = "sqlite:" + (dir / "write.db").string();
  (void)Store::open(sq);
  (void)Store::open(pg.url("bench_write"));
  writers("sqlite", sq, per_station);
  writers("postgresql", pg.url("bench_write"), per_station);
  page_time("sqlite", "sqlite:" + (dir / "page.db").string(), dir, requests);
  page_time("postgresql", pg.url("bench_page"), dir, requests);
  fs::remove_all(dir);
  return 0;
}
