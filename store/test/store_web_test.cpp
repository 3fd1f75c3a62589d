// The instructor's page: login enforced (with the login form's CSRF token),
// numbers on the pages match the database, path traversal and SQL injection
// in every parameter refused, unknown sessions give the 404 page, and
// headless Chromium (logging in as a user does) renders it.
#include <gtest/gtest.h>
#include <httplib.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <mutex>
#include <regex>
#include <thread>

#include "dentar/store/store.h"
#include "dentar/store/web.h"
#include "testkit.h"
#include "testutil.h"

namespace {
namespace fs = std::filesystem;
using namespace dentar::store;

constexpr const char* kUser = "alice";
constexpr const char* kPassword = "correct-horse-battery";

class Web : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(dentar::test::temp_dir("store_web"));
    db_ = "sqlite:" + (*dir_ / "school.db").string();
    {
      auto st = Store::open(db_);
      ASSERT_TRUE(st.ok()) << st.error();
      int n = 0;
      for (const char* stu : {"s01", "s02", "s03"})
        for (int k = 0; k < 6; ++k, ++n)
          ASSERT_TRUE((*st)->put(testkit::make_record(stu, "st-" + std::to_string(k % 3),
                                                     k % 2 ? "incisor_partial_crown" : "molar_access_opening", 40 + n,
                                                     60 * 24 * k + n))
                          .ok());
    }
    ASSERT_TRUE(set_password((*dir_ / "pw.txt").string(), kUser, kPassword, 100000).ok());
    ServeOptions o;
    o.db_url = db_;
    o.password_file = (*dir_ / "pw.txt").string();
    o.port = 0;
    log_ = new std::vector<std::string>();
    log_mu_ = new std::mutex();
    o.log = [](const std::string& l) {
      std::lock_guard lk(*log_mu_);
      log_->push_back(l);
    };
    auto w = WebServer::create(o);
    ASSERT_TRUE(w.ok()) << w.error();
    server_ = w->release();
    ASSERT_TRUE(server_->bind().ok());
    thread_ = new std::thread([] { (void)server_->listen_after_bind(); });
    base_ = "http://127.0.0.1:" + std::to_string(server_->port());
    // One logged-in cookie for the HTTP-level tests (the login page's form, posted).
    cookie_ = testkit::login_cookie(server_->port(), kUser, kPassword);
    ASSERT_NE(cookie_.find("dentar_session="), std::string::npos);
  }
  static void TearDownTestSuite() {
    server_->stop();
    thread_->join();
    delete thread_;
    delete server_;
  }
  static httplib::Result get(const std::string& path, bool logged_in = true) {
    httplib::Client c("127.0.0.1", server_->port());
    httplib::Headers h;
    if (logged_in) h.emplace("Cookie", cookie_);
    return c.Get(path.c_str(), h);
  }
  static std::unique_ptr<Store> store() {
    auto s = Store::open(db_);
    return std::move(*s);
  }
  static inline fs::path* dir_ = nullptr;
  static inline std::string db_, base_, cookie_;
  static bool logged(const std::string& part) {
    std::lock_guard lk(*log_mu_);
    for (const auto& l : *log_)
      if (l.find(part) != std::string::npos) return true;
    return false;
  }
  static std::string all_log() {
    std::lock_guard lk(*log_mu_);
    std::string s;
    for (const auto& l : *log_) s += l + "\n";
    return s;
  }
  static inline WebServer* server_ = nullptr;
  static inline std::thread* thread_ = nullptr;
  static inline std::vector<std::string>* log_ = nullptr;
  static inline std::mutex* log_mu_ = nullptr;
};

TEST_F(Web, LoginIsEnforcedOnEveryPage) {
  for (const char* p : {"/", "/student/s01", "/session/1", "/session/1/report", "/cohort", "/exercise/molar_access_opening"}) {
    auto r = get(p, false);
    ASSERT_TRUE(r) << p;
    EXPECT_EQ(r->status, 303) << p;
    EXPECT_EQ(r->get_header_value("Location").rfind("/login?next=", 0), 0u) << p;
    EXPECT_EQ(r->body.find("s01"), std::string::npos) << p;
  }
  const testkit::LoginForm form = testkit::get_login_form(server_->port());
  const testkit::LoginReply bad = testkit::post_login(server_->port(), form, kUser, "wrong-password-1");
  EXPECT_EQ(bad.status, 401);
  EXPECT_TRUE(bad.session.empty());
  EXPECT_NE(bad.body.find("Wrong user name or password"), std::string::npos);
  auto forged = httplib::Client("127.0.0.1", server_->port()).Get("/", {{"Cookie", "dentar_session=00ff"}});
  ASSERT_TRUE(forged);
  EXPECT_EQ(forged->status, 303);
  // An open redirect through next= is not possible.
  httplib::Client c("127.0.0.1", server_->port());
  auto off = c.Post("/login", {{"Cookie", form.cookie}},
                    "user=alice&password=correct-horse-battery&next=//evil.example/x&csrf=" + form.csrf,
                    "application/x-www-form-urlencoded");
  ASSERT_TRUE(off);
  EXPECT_EQ(off->status, 303);
  EXPECT_EQ(off->get_header_value("Location"), "/");
}

// Login CSRF (issue 26): the login form carries a token bound to the
// browser's pre-session cookie (HMAC with the server's key). A login post
// without the cookie, without the token, with a wrong one, or with another
// browser's token is refused (403, a fresh form, no password checked) and
// logged; the page's own token logs in, and the pre-session cookie is then
// cleared. The login does not touch the database, so this holds the same for
// a PostgreSQL store.
TEST_F(Web, LoginFormCarriesACsrfTokenAndForgedLoginsAreRefused) {
  const int port = server_->port();
  httplib::Client c("127.0.0.1", port);
  auto page = c.Get("/login?next=/cohort");
  ASSERT_TRUE(page);
  ASSERT_EQ(page->status, 200);
  const std::string sc = page->get_header_value("Set-Cookie");
  EXPECT_EQ(sc.rfind("dentar_login=", 0), 0u) << sc;
  EXPECT_NE(sc.find("HttpOnly"), std::string::npos) << sc;
  EXPECT_NE(sc.find("SameSite=Strict"), std::string::npos) << sc;
  const testkit::LoginForm form = testkit::get_login_form(port);
  ASSERT_FALSE(form.cookie.empty());
  ASSERT_EQ(form.csrf.size(), 64u) << "HMAC-SHA256, hex";
  // The same browser reloading the page keeps its cookie and gets the same token.
  auto again = c.Get("/login", {{"Cookie", form.cookie}});
  ASSERT_TRUE(again);
  EXPECT_TRUE(again->get_header_value("Set-Cookie").empty());
  EXPECT_NE(again->body.find("value=\"" + form.csrf + "\""), std::string::npos);
  const testkit::LoginForm other = testkit::get_login_form(port);
  ASSERT_NE(other.csrf, form.csrf) << "each browser its own token";

  auto refused = [&](const testkit::LoginForm& f, const std::string& why) {
    const testkit::LoginReply r = testkit::post_login(port, f, kUser, kPassword);
    EXPECT_EQ(r.status, 403) << why;
    EXPECT_TRUE(r.session.empty()) << why;
    EXPECT_NE(r.body.find("came from another site"), std::string::npos) << why << r.body.substr(0, 800);
    EXPECT_NE(r.body.find("name=\"csrf\""), std::string::npos) << why << ": the 403 page is a fresh form";
  };
  refused({"", ""}, "no cookie, no token (a form on another site)");
  refused({form.cookie, ""}, "no token");
  refused({"", form.csrf}, "the token without its cookie");
  std::string wrong = form.csrf;
  wrong[10] = wrong[10] == 'a' ? 'b' : 'a';
  refused({form.cookie, wrong}, "a wrong token");
  refused({form.cookie, other.csrf}, "another browser's token");
  refused({"dentar_login=" + std::string(32, '0'), form.csrf}, "a cookie the attacker chose");
  EXPECT_TRUE(logged("login refused for user 'alice' from 127.0.0.1: no login cookie")) << all_log();
  // Refusals are logged at most once a minute per address, with the count.
  // (The first refusal of this address is logged; the later ones are counted.)

  const testkit::LoginReply ok = testkit::post_login(port, form, kUser, kPassword, "/cohort");
  EXPECT_EQ(ok.status, 303) << ok.body.substr(0, 500);
  EXPECT_NE(ok.session.find("dentar_session="), std::string::npos);
  // The page's token with a wrong password is an ordinary failed login (401).
  EXPECT_EQ(testkit::post_login(port, other, kUser, "not-the-password").status, 401);
}

// The first CSRF refusal from an address is logged at once, with the reason.
TEST_F(Web, ForgedLoginIsLoggedWithItsReason) {
  ServeOptions o;
  std::vector<std::string> lines;
  std::mutex mu;
  o.db_url = db_;
  o.password_file = (*dir_ / "pw.txt").string();
  o.port = 0;
  o.log = [&](const std::string& l) {
    std::lock_guard lk(mu);
    lines.push_back(l);
  };
  auto w = WebServer::create(o);
  ASSERT_TRUE(w.ok()) << w.error();
  ASSERT_TRUE((*w)->bind().ok());
  std::thread t([&] { (void)(*w)->listen_after_bind(); });
  const testkit::LoginForm form = testkit::get_login_form((*w)->port());
  EXPECT_EQ(testkit::post_login((*w)->port(), {form.cookie, std::string(64, 'f')}, kUser, kPassword).status, 403);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(testkit::post_login((*w)->port(), {}, kUser, kPassword).status, 403);
  EXPECT_EQ(testkit::post_login((*w)->port(), form, kUser, kPassword).status, 303);
  (*w)->stop();
  t.join();
  int csrf_lines = 0;
  for (const auto& l : lines) csrf_lines += l.find("the form did not come from this server's login page") != std::string::npos;
  ASSERT_FALSE(lines.empty());
  EXPECT_EQ(lines[0], "login refused for user 'alice' from 127.0.0.1: a wrong CSRF token (the form did not come from "
                      "this server's login page)");
  EXPECT_EQ(csrf_lines, 1) << "one line a minute per address under a flood of forged posts";
  EXPECT_EQ(lines.back(), "login of user 'alice' from 127.0.0.1");
}

TEST_F(Web, NumbersOnThePagesMatchTheDatabase) {
  auto st = store();
  SessionFilter f;
  f.student = "s02";
  auto ss = st->sessions(f);
  ASSERT_TRUE(ss.ok());
  ASSERT_EQ(ss->size(), 6u);
  auto r = get("/student/s02");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200);
  for (const auto& x : *ss) {
    char pts[64];
    std::snprintf(pts, sizeof pts, "%.2f / %.0f", x.points, x.max_points);
    const std::string row = "<tr data-id=\"" + std::to_string(x.id) + "\">";
    const auto at = r->body.find(row);
    ASSERT_NE(at, std::string::npos) << row;
    EXPECT_NE(r->body.find("data-k=\"points\">" + std::string(pts) + "</td>", at), std::string::npos) << pts;
  }
  EXPECT_NE(r->body.find("<svg"), std::string::npos);
  auto home = get("/");
  ASSERT_TRUE(home);
  auto students = st->students();
  for (const auto& s : *students) {
    char mean[32];
    std::snprintf(mean, sizeof mean, "%.1f %%", s.mean_pct);
    const auto at = home->body.find("data-student=\"" + s.code + "\"");
    ASSERT_NE(at, std::string::npos);
    EXPECT_NE(home->body.find("data-k=\"sessions\">" + std::to_string(s.sessions) + "</td>", at), std::string::npos);
    EXPECT_NE(home->body.find("data-k=\"mean_pct\">" + std::string(mean), at), std::string::npos) << mean;
  }
  const auto id = (*ss)[0].id;
  auto sp = get("/session/" + std::to_string(id));
  ASSERT_TRUE(sp);
  ASSERT_EQ(sp->status, 200);
  EXPECT_NE(sp->body.find("force bands"), std::string::npos);
  auto rec = st->session(id);
  EXPECT_NE(sp->body.find((**rec).log_sha256), std::string::npos);
  auto rep = get("/session/" + std::to_string(id) + "/report");
  ASSERT_TRUE(rep);
  EXPECT_EQ(rep->status, 200);
  EXPECT_EQ(rep->body, (**rec).score_html);
  auto filtered = get("/student/s02?exercise=incisor_partial_crown");
  ASSERT_TRUE(filtered);
  EXPECT_EQ(filtered->status, 200);
  EXPECT_NE(filtered->body.find("3 sessions of incisor_partial_crown"), std::string::npos);
  auto cohort = get("/cohort");
  ASSERT_TRUE(cohort);
  EXPECT_EQ(cohort->status, 200);
  EXPECT_NE(cohort->body.find("data-exercise=\"incisor_partial_crown\""), std::string::npos);
}

// Issue 25: a session whose preparation was not finished (score.json
// outcome.complete false) keeps its points but is marked INCOMPLETE on the
// student's session list and beside the last score on the student list, as
// on its own page; a finished one and a score without the metric (stored
// before issue 25) are not marked.
TEST_F(Web, StudentListsMarkUnfinishedSessionsIncomplete) {
  auto st = store();
  auto with_complete = [](dentar::store::SessionRecord r, double complete) {
    r.metrics.push_back({"outcome.complete", complete, "bool"});
    return r;
  };
  // s08: an old finished session, then an unfinished last one; s09: an
  // unfinished session, then a finished last one; s10: no metric at all.
  ASSERT_TRUE(st->put(with_complete(testkit::make_record("s08", "st-0", "molar_access_opening", 801, 10), 1)).ok());
  ASSERT_TRUE(st->put(with_complete(testkit::make_record("s08", "st-0", "molar_access_opening", 802, 20), 0)).ok());
  ASSERT_TRUE(st->put(with_complete(testkit::make_record("s09", "st-0", "molar_access_opening", 901, 10), 0)).ok());
  ASSERT_TRUE(st->put(with_complete(testkit::make_record("s09", "st-0", "molar_access_opening", 902, 20), 1)).ok());
  ASSERT_TRUE(st->put(testkit::make_record("s10", "st-0", "molar_access_opening", 1001, 10)).ok());
  SessionFilter f;
  f.student = "s08";
  auto s08 = st->sessions(f);
  ASSERT_TRUE(s08.ok()) << s08.error();
  ASSERT_EQ(s08->size(), 2u);
  EXPECT_FALSE((*s08)[0].incomplete);
  EXPECT_TRUE((*s08)[1].incomplete);
  const std::string mark = "data-k=\"incomplete\"";
  auto page = get("/student/s08");
  ASSERT_TRUE(page);
  ASSERT_EQ(page->status, 200);
  auto row_of = [&](const std::string& body, const std::string& start) {
    const auto at = body.find(start);
    if (at == std::string::npos) return std::string();
    return body.substr(at, body.find("</tr>", at) - at);
  };
  const std::string unfinished = row_of(page->body, "<tr data-id=\"" + std::to_string((*s08)[1].id) + "\">");
  const std::string finished = row_of(page->body, "<tr data-id=\"" + std::to_string((*s08)[0].id) + "\">");
  ASSERT_FALSE(unfinished.empty());
  ASSERT_FALSE(finished.empty());
  EXPECT_NE(unfinished.find(mark), std::string::npos) << unfinished;
  EXPECT_NE(unfinished.find("INCOMPLETE"), std::string::npos);
  EXPECT_EQ(finished.find(mark), std::string::npos) << finished;
  // The student list: the last session's mark only.
  auto home = get("/");
  ASSERT_TRUE(home);
  ASSERT_EQ(home->status, 200);
  EXPECT_NE(row_of(home->body, "<tr data-student=\"s08\"").find(mark), std::string::npos);
  EXPECT_EQ(row_of(home->body, "<tr data-student=\"s09\"").find(mark), std::string::npos);
  EXPECT_EQ(row_of(home->body, "<tr data-student=\"s10\"").find(mark), std::string::npos);
  EXPECT_FALSE(row_of(home->body, "<tr data-student=\"s10\"").empty());
  auto students = st->students();
  ASSERT_TRUE(students.ok());
  for (const auto& x : *students) EXPECT_EQ(x.last_incomplete, x.code == "s08") << x.code;
  auto s10 = get("/student/s10");
  ASSERT_TRUE(s10);
  EXPECT_EQ(s10->body.find(mark), std::string::npos);
}

TEST_F(Web, StudentPageShowsTrainingModesErrorsAndProgression) {
  // Issue 27: s11 trained in modes 2, 2, 3 (metrics "training.*" as imported from run.json);
  // s12 never trained: no training section.
  auto st = store();
  auto trained = [](dentar::store::SessionRecord r, int mode, double mean, double p95, bool as_needed, int rep) {
    r.metrics.push_back({"training.mode", static_cast<double>(mode), ""});
    r.metrics.push_back({"training.follow_error_mm.mean", mean, "mm"});
    r.metrics.push_back({"training.follow_error_mm.p95", p95, "mm"});
    r.metrics.push_back({"training.guidance.as_needed", as_needed ? 1.0 : 0.0, "bool"});
    r.metrics.push_back({"training.guidance.repetition", static_cast<double>(rep), ""});
    r.metrics.push_back({"training.guidance.fade", 0.7, ""});
    return r;
  };
  ASSERT_TRUE(st->put(trained(testkit::make_record("s11", "st-0", "molar_class1_cavity", 1101, 10), 2, 0.61, 1.2, false, 0)).ok());
  ASSERT_TRUE(st->put(trained(testkit::make_record("s11", "st-0", "molar_class1_cavity", 1102, 20), 2, 0.38, 0.7, true, 1)).ok());
  ASSERT_TRUE(st->put(trained(testkit::make_record("s11", "st-0", "molar_class1_cavity", 1103, 30), 3, 1.25, 2.4, false, 0)).ok());
  ASSERT_TRUE(st->put(testkit::make_record("s11", "st-0", "molar_class1_cavity", 1104, 40)).ok());  // plain drilling
  ASSERT_TRUE(st->put(testkit::make_record("s12", "st-0", "molar_class1_cavity", 1201, 10)).ok());
  SessionFilter f;
  f.student = "s11";
  auto rows = st->training(f);
  ASSERT_TRUE(rows.ok()) << rows.error();
  ASSERT_EQ(rows->size(), 3u);
  auto page = get("/student/s11");
  ASSERT_TRUE(page);
  ASSERT_EQ(page->status, 200);
  const std::string& b = page->body;
  EXPECT_NE(b.find("Training with an expert"), std::string::npos);
  EXPECT_NE(b.find("<p data-k=\"progression\">Modes in order: 2 → 2 → 3</p>"), std::string::npos) << b;
  EXPECT_NE(b.find("Mean following error (mm) per mode"), std::string::npos);
  auto row_of = [&](std::int64_t id) {
    const std::string start = "<tr data-id=\"" + std::to_string(id) + "\"><td><a href=\"/session/" + std::to_string(id) +
                              "\">#" + std::to_string(id) + "</a></td><td>";
    const auto t = b.find("id=\"training-sessions\"");
    const auto at = b.find(start, t);
    return at == std::string::npos ? std::string() : b.substr(at, b.find("</tr>", at) - at);
  };
  const std::string second = row_of((*rows)[1].id);
  ASSERT_FALSE(second.empty()) << b;
  EXPECT_NE(second.find("data-k=\"mode\">2 passive guidance"), std::string::npos) << second;
  EXPECT_NE(second.find("as needed, faded 0.70^1"), std::string::npos) << second;
  EXPECT_NE(second.find("data-k=\"follow\">0.38 mm"), std::string::npos) << second;
  EXPECT_NE(second.find("data-k=\"p95\">0.70 mm"), std::string::npos) << second;
  EXPECT_NE(row_of((*rows)[2].id).find("3 active following"), std::string::npos);
  // Modes 1-4: the expert's bur cut, so the row shows whose cut it is, not a student score,
  // and the student's mean score on the list counts only the plain session (#1104).
  EXPECT_NE(second.find("data-k=\"score\">expert's cut (mode 2)"), std::string::npos) << second;
  EXPECT_EQ(second.find(" %</td>"), std::string::npos) << second;
  auto students = st->students();
  ASSERT_TRUE(students.ok()) << students.error();
  SessionFilter all11;
  all11.student = "s11";
  auto ss = st->sessions(all11);
  ASSERT_TRUE(ss.ok());
  double plain_pct = -1;
  for (const auto& x : *ss)
    if (x.started_utc == testkit::make_record("s11", "st-0", "molar_class1_cavity", 1104, 40).started_utc)
      plain_pct = 100.0 * x.points / x.max_points;
  ASSERT_GE(plain_pct, 0);
  for (const auto& x : *students)
    if (x.code == "s11") {
      EXPECT_NEAR(x.mean_pct, plain_pct, 1e-9) << "the expert's cuts are not the student's mean";
    }
  // A student whose newest session is an expert's cut: the list's last score is the newest
  // session the student cut.
  ASSERT_TRUE(st->put(testkit::make_record("s13", "st-0", "molar_class1_cavity", 1301, 10)).ok());
  ASSERT_TRUE(st->put(trained(testkit::make_record("s13", "st-0", "molar_class1_cavity", 1302, 20), 2, 0.5, 1, false, 0)).ok());
  const auto own = testkit::make_record("s13", "st-0", "molar_class1_cavity", 1301, 10);
  auto students13 = st->students();
  ASSERT_TRUE(students13.ok()) << students13.error();
  for (const auto& x : *students13)
    if (x.code == "s13") {
      EXPECT_NEAR(x.last_pct, 100.0 * own.points / own.max_points, 1e-9);
      EXPECT_NEAR(x.mean_pct, 100.0 * own.points / own.max_points, 1e-9);
    }
  // The sessions table says whose cut a trained session's score is; the plain one shows its %.
  const auto srow = [&](std::int64_t id) {
    const auto at = b.find("<tr data-id=\"" + std::to_string(id) + "\">", b.find("id=\"sessions\""));
    return at == std::string::npos ? std::string() : b.substr(at, b.find("</tr>", at) - at);
  };
  EXPECT_NE(srow((*rows)[2].id).find("data-k=\"pct\">expert's cut (mode 3)"), std::string::npos) << srow((*rows)[2].id);
  std::int64_t plain_id = 0;
  for (const auto& x : *ss)
    if (x.started_utc == testkit::make_record("s11", "st-0", "molar_class1_cavity", 1104, 40).started_utc) plain_id = x.id;
  EXPECT_NE(srow(plain_id).find(" %"), std::string::npos) << srow(plain_id);
  EXPECT_EQ(srow(plain_id).find("expert's cut"), std::string::npos);
  // The session's own page says so too; the plain session's page shows its points as the student's.
  {
    auto sp = get("/session/" + std::to_string((*rows)[2].id));
    ASSERT_TRUE(sp);
    ASSERT_EQ(sp->status, 200);
    EXPECT_NE(sp->body.find("data-k=\"points\">expert's cut (mode 3), not the student's: "), std::string::npos) << sp->body;
    auto pp = get("/session/" + std::to_string(plain_id));
    ASSERT_TRUE(pp);
    EXPECT_EQ(pp->body.find("expert's cut"), std::string::npos);
    EXPECT_NE(pp->body.find("data-k=\"points\">"), std::string::npos);
  }
  // Per mode: first and last error.
  const auto m2 = b.find("<tr data-mode=\"2\">");
  ASSERT_NE(m2, std::string::npos);
  const std::string mode2 = b.substr(m2, b.find("</tr>", m2) - m2);
  EXPECT_NE(mode2.find(">2</td>"), std::string::npos) << mode2;
  EXPECT_NE(mode2.find("0.61 mm"), std::string::npos) << mode2;
  EXPECT_NE(mode2.find("data-k=\"last\">0.38 mm"), std::string::npos) << mode2;
  auto plain = get("/student/s12");
  ASSERT_TRUE(plain);
  ASSERT_EQ(plain->status, 200);
  EXPECT_EQ(plain->body.find("Training with an expert"), std::string::npos);
}

TEST_F(Web, UnknownSessionsAndPagesAreThe404Page) {
  for (const char* p : {"/session/999999", "/session/999999/report", "/student/nobody", "/exercise/none", "/nope", "/session"}) {
    auto r = get(p);
    ASSERT_TRUE(r) << p;
    EXPECT_EQ(r->status, 404) << p;
    EXPECT_NE(r->body.find("data-status=\"404\""), std::string::npos) << p << r->body;
  }
}

// Every parameter of every page, with traversal and injection attempts:
// refused (400/404), nothing else leaks, the database is unchanged.
TEST_F(Web, PathTraversalAndSqlInjectionAreRefused) {
  auto before = *store()->count_sessions();
  const std::vector<std::string> attacks = {
      "/../school.db", "/school.db", "/%2e%2e/%2e%2e/etc/passwd", "/session/..%2F..%2Fschool.db",
      "/session/1/..%2F..%2F..%2Fetc%2Fpasswd", "/session/1%2F..%2F..%2Fschool.db/report",
      "/student/..%2F..%2Fetc%2Fpasswd", "/student/..", "/exercise/..%2Fschool.db",
      "/session/1%20OR%201=1", "/session/1;DROP%20TABLE%20sessions", "/session/1'--/report",
      "/student/s01'%20OR%20'1'='1", "/student/s01%27%3B%20DROP%20TABLE%20sessions%3B--",
      "/exercise/x'%20UNION%20SELECT%20key%20FROM%20sessions--",
      "/student/s01?exercise=x'%20OR%201=1--",
      "/student/s01?exercise=molar_access_opening&exercise=x'--", "/student/s01?exercise=%ZZ", "/student/s01?exercise=..%2F..%2Fetc", "/student/s01?id=1%20OR%201=1",
      "/cohort?x=1'", "/?student=s01'--"};
  for (const auto& a : attacks) {
    auto r = get(a);
    ASSERT_TRUE(r) << a;
    EXPECT_TRUE(r->status == 400 || r->status == 404) << a << " -> " << r->status;
    EXPECT_EQ(r->body.find("SQLite format"), std::string::npos) << a;
    EXPECT_EQ(r->body.find("root:"), std::string::npos) << a;
    EXPECT_EQ(r->body.find("data-id="), std::string::npos) << a;  // no session rows leaked
  }
  const testkit::LoginReply inj =
      testkit::post_login(server_->port(), testkit::get_login_form(server_->port()), "alice' OR 1=1--", "' OR '1'='1");
  EXPECT_EQ(inj.status, 401);
  EXPECT_EQ(*store()->count_sessions(), before);
  EXPECT_TRUE(store()->students().ok());
}

// HTTPS directly (Debian's cpp-httplib is built with OpenSSL): a self-signed
// certificate made with the openssl command; the login cookie is Secure.
TEST(WebTls, ServesHttpsWithASecureCookie) {
  const fs::path d = dentar::test::temp_dir("store_web_tls");
  const auto gen = dentar::test::run_command(
      "openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj /CN=localhost -keyout " + (d / "key.pem").string() +
      " -out " + (d / "cert.pem").string() + " 2>&1");
  ASSERT_EQ(gen.code, 0) << gen.out;
  ASSERT_TRUE(Store::open("sqlite:" + (d / "s.db").string()).ok());
  ASSERT_TRUE(set_password((d / "pw.txt").string(), "bob", "bob-password-1", 100000).ok());
  ServeOptions o;
  o.db_url = "sqlite:" + (d / "s.db").string();
  o.password_file = (d / "pw.txt").string();
  o.port = 0;
  o.cert_file = (d / "cert.pem").string();
  o.key_file = (d / "key.pem").string();
  auto w = WebServer::create(o);
  ASSERT_TRUE(w.ok()) << w.error();
  ASSERT_TRUE((*w)->bind().ok());
  std::thread t([&] { (void)(*w)->listen_after_bind(); });
  httplib::SSLClient c("127.0.0.1", (*w)->port());
  c.enable_server_certificate_verification(false);
  auto page = c.Get("/login");
  ASSERT_TRUE(page) << httplib::to_string(page.error());
  const std::string pre = page->get_header_value("Set-Cookie");
  EXPECT_NE(pre.find("; Secure"), std::string::npos) << pre;
  const std::string mark = "name=\"csrf\" value=\"";
  const auto at = page->body.find(mark);
  ASSERT_NE(at, std::string::npos);
  const std::string csrf = page->body.substr(at + mark.size(), 64);
  auto r = c.Post("/login", {{"Cookie", pre.substr(0, pre.find(';'))}},
                  "user=bob&password=bob-password-1&next=/&csrf=" + csrf, "application/x-www-form-urlencoded");
  ASSERT_TRUE(r) << httplib::to_string(r.error());
  EXPECT_EQ(r->status, 303);
  bool secure_session = false;
  for (auto [a, e] = r->headers.equal_range("Set-Cookie"); a != e; ++a)
    secure_session |= a->second.rfind("dentar_session=", 0) == 0 && a->second.find("; Secure") != std::string::npos;
  EXPECT_TRUE(secure_session);
  // Plain HTTP to the HTTPS port gets no page.
  httplib::Client plain("127.0.0.1", (*w)->port());
  auto p = plain.Get("/login");
  EXPECT_TRUE(!p || p->status != 200);
  (*w)->stop();
  t.join();
  // A key that is not PEM is refused with the file names.
  dentar::test::write_file(d / "bad.pem", "not a key");
  o.key_file = (d / "bad.pem").string();
  auto bad = WebServer::create(o);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("not a usable PEM certificate and key"), std::string::npos) << bad.error();
}

class Browser : public Web {
 protected:
  void SetUp() override {
    ASSERT_FALSE(testkit::chromium_binary().empty())
        << "Debian's chromium is not installed (tools/bootstrap.sh installs it); the browser tests need it";
  }
  // Logs in as a user does (the server's login page, typed, Enter) and lands on `next`.
  static std::string dom_after_login(const std::string& next) {
    testkit::Browser b;
    EXPECT_TRUE(testkit::browser_login(b, base_, kUser, kPassword, next)) << b.error();
    return b.dom();
  }
};

TEST_F(Browser, LoginPageWithoutCookie) {
  const auto r = testkit::chromium("--dump-dom", base_ + "/student/s01");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("Instructor login"), std::string::npos) << r.out.substr(0, 2000);
  EXPECT_EQ(r.out.find("data-id="), std::string::npos);
}

TEST_F(Browser, StudentPageNumbersMatchTheDatabase) {
  const std::string dom = dom_after_login("/student/s03");
  ASSERT_NE(dom.find("Student s03"), std::string::npos) << dom.substr(0, 3000);
  SessionFilter f;
  f.student = "s03";
  auto ss = store()->sessions(f);
  std::regex row(R"re(<tr data-id="(\d+)">.*?data-k="points">([0-9.]+) / ([0-9]+)</td>)re");
  std::map<std::int64_t, double> shown;
  for (auto it = std::sregex_iterator(dom.begin(), dom.end(), row); it != std::sregex_iterator(); ++it)
    shown[std::stoll((*it)[1])] = std::stod((*it)[2]);
  ASSERT_EQ(shown.size(), ss->size());
  for (const auto& x : *ss) {
    ASSERT_TRUE(shown.count(x.id)) << x.id;
    EXPECT_NEAR(shown[x.id], x.points, 0.005) << x.id;
  }
}

TEST_F(Browser, StudentPageShowsTheTrainingSection) {
  // Issue 27: Chromium renders the training section (modes in order, the error plot, rows).
  auto st = store();
  for (int k = 0; k < 3; ++k) {
    auto r = testkit::make_record("s21", "st-0", "molar_class1_cavity", 2101 + k, 10 * (k + 1));
    r.metrics.push_back({"training.mode", k < 2 ? 2.0 : 3.0, ""});
    r.metrics.push_back({"training.follow_error_mm.mean", 0.5 - 0.1 * k, "mm"});
    r.metrics.push_back({"training.follow_error_mm.p95", 1.0, "mm"});
    ASSERT_TRUE(st->put(r).ok());
  }
  const std::string dom = dom_after_login("/student/s21");
  ASSERT_NE(dom.find("Training with an expert"), std::string::npos) << dom.substr(0, 3000);
  EXPECT_NE(dom.find("Modes in order: 2 → 2 → 3"), std::string::npos);
  EXPECT_NE(dom.find("aria-label=\"Mean following error (mm) per mode\""), std::string::npos);
  std::regex row(R"re(data-k="follow">([0-9.]+) mm</td>)re");
  std::vector<double> shown;
  for (auto it = std::sregex_iterator(dom.begin(), dom.end(), row); it != std::sregex_iterator(); ++it)
    shown.push_back(std::stod((*it)[1]));
  ASSERT_EQ(shown.size(), 3u);
  EXPECT_DOUBLE_EQ(shown[0], 0.30);  // newest first
  EXPECT_DOUBLE_EQ(shown[2], 0.50);
  EXPECT_NE(dom.find("expert's cut (mode 2)"), std::string::npos) << "modes 1-4 show whose cut the score is";
}

TEST_F(Browser, UnknownSessionShowsThe404Page) {
  const std::string dom = dom_after_login("/session/424242");
  EXPECT_NE(dom.find("404 · Not found"), std::string::npos) << dom.substr(0, 2000);
  EXPECT_NE(dom.find("There is no session #424242"), std::string::npos);
}

TEST_F(Browser, ScreenshotOfTheStudentPageRenders) {
  const fs::path d = dentar::test::temp_dir("store_web_shot");
  const fs::path png = d / "student.png";
  testkit::Browser b(1200, 900);
  ASSERT_TRUE(testkit::browser_login(b, base_, kUser, kPassword, "/student/s01")) << b.error();
  EXPECT_NE(b.url().find("/student/s01"), std::string::npos) << b.url();
  ASSERT_TRUE(b.screenshot(png)) << b.error();
  const cv::Mat img = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty()) << png;
  EXPECT_EQ(img.cols, 1200);
  EXPECT_EQ(img.rows, 900);
  // The header bar (#1d3b5a) is drawn at the top, the page is not blank.
  const cv::Vec3b top = img.at<cv::Vec3b>(10, 600);
  EXPECT_NEAR(top[0], 0x5a, 12);
  EXPECT_NEAR(top[1], 0x3b, 12);
  EXPECT_NEAR(top[2], 0x1d, 12);
  cv::Scalar mean, sd;
  cv::meanStdDev(img, mean, sd);
  EXPECT_GT(sd[0], 20.0);
}

}  // namespace
