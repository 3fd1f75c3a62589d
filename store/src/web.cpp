// The instructor's web page. Each request borrows one database connection
// from a small pool; pages are built from parameterised queries only.
#include "dentar/store/web.h"

#include <httplib.h>
#include <openssl/crypto.h>
#include <openssl/err.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>
#include <openssl/ssl.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <iostream>
#include <condition_variable>
#include <filesystem>
#include <map>
#include <mutex>
#include <optional>
#include <set>

#include "dentar/store/metric_names.h"
#include "dentar/store/store.h"
#include "front.h"
#include "html.h"

namespace dentar::store {

std::string ServeOptions::validate() const {
  if (db_url.empty()) return "--db: required (sqlite:PATH or postgresql://...)";
  if (password_file.empty()) return "--passwords: required (create it with --set-password USER)";
  if (port < 0 || port > 65535) return "--port " + std::to_string(port) + ": must be 0-65535";
  if (cert_file.empty() != key_file.empty()) return "--cert and --key: give both for HTTPS, or neither";
  if (session_hours < 1 || session_hours > 24 * 30) return "--session-hours: must be 1-720";
  if (threads < 1 || threads > 64) return "--threads: must be 1-64";
  if (!(request_timeout_s >= 1 && request_timeout_s <= 600)) return "--request-timeout: must be 1-600 s";
  if (max_conn_per_client < 1 || max_conn_per_client > 1000) return "--max-conn-per-client: must be 1-1000";
  if (max_header_bytes < 1024 || max_header_bytes > (1u << 20)) return "max_header_bytes: must be 1 KiB-1 MiB";
  if (max_headers < 8 || max_headers > 1000) return "max_headers: must be 8-1000";
  if (login_free_tries < 1 || login_free_tries > 100) return "login_free_tries: must be 1-100";
  if (login_max_delay_s < 1 || login_max_delay_s > 24 * 3600) return "--login-max-delay: must be 1-86400 s";
  return "";
}

namespace {

using Clock = std::chrono::steady_clock;
constexpr const char* kCookie = "dentar_session";
// The login form's pre-session cookie: 128 random bits, set by GET /login.
// The form carries HMAC-SHA256(server key, cookie) as its CSRF token, so a
// login POST must come from a page this server gave to this browser (a
// signed double submit: no server state, nothing to fill under a flood).
constexpr const char* kLoginCookie = "dentar_login";

// Who is looking: the login and the session's CSRF token (the logout form
// carries it; a POST without it is refused).
struct Viewer {
  std::string name, csrf;
};

std::string utc_stamp() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char b[32];
  std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return b;
}

// A user name as typed by a stranger, fit for one log line.
std::string loggable(const std::string& s) {
  std::string o;
  for (unsigned char c : s.substr(0, 64)) {
    if (c < 0x20 || c == 0x7f || c == '\'' || c == '\\') {
      char b[8];
      std::snprintf(b, sizeof b, "\\x%02x", c);
      o += b;
    } else {
      o += static_cast<char>(c);
    }
  }
  return o;
}

bool is_id(const std::string& s) {
  if (s.empty() || s.size() > 18) return false;
  for (char c : s)
    if (c < '0' || c > '9') return false;
  return true;
}

// `next` after login: a local path of safe characters only (no scheme, no //).
std::string safe_next(const std::string& n) {
  if (n.empty() || n[0] != '/' || (n.size() > 1 && (n[1] == '/' || n[1] == '\\')) || n.size() > 200) return "/";
  for (unsigned char c : n)
    if (!(std::isalnum(c) || c == '/' || c == '.' || c == '_' || c == '-' || c == '@' || c == '?' || c == '=' ||
          c == '&' || c == '%'))
      return "/";
  return n;
}

int hexval(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// Percent-decoding ('+' is a space); false on a malformed escape.
bool decode(const std::string& in, std::string& out) {
  out.clear();
  for (std::size_t i = 0; i < in.size(); ++i) {
    if (in[i] == '%') {
      if (i + 2 >= in.size()) return false;
      const int a = hexval(in[i + 1]), b = hexval(in[i + 2]);
      if (a < 0 || b < 0) return false;
      out += static_cast<char>(a * 16 + b);
      i += 2;
    } else {
      out += in[i] == '+' ? ' ' : in[i];
    }
  }
  return true;
}

bool query_ok(const std::string& target) {
  const std::size_t q = target.find('?');
  if (q == std::string::npos) return true;
  const std::string query = target.substr(q + 1);
  if (query.empty()) return true;
  std::size_t pos = 0;
  while (pos <= query.size()) {
    std::size_t amp = query.find('&', pos);
    if (amp == std::string::npos) amp = query.size();
    const std::string item = query.substr(pos, amp - pos);
    const std::size_t eq = item.find('=');
    if (eq == std::string::npos || item.find('=', eq + 1) != std::string::npos) return false;
    std::string key, val;
    if (!decode(item.substr(0, eq), key) || !decode(item.substr(eq + 1), val)) return false;
    if (key != "exercise" || val.empty() || !validate_code("exercise", val).empty()) return false;
    pos = amp + 1;
  }
  return true;
}

// Beside a score whose preparation was not finished (score.json
// outcome.complete false, issue 25): the points it earned are shown, never
// without this mark.
constexpr const char* kIncompleteMark =
    " <span class=\"warn\" data-k=\"incomplete\" title=\"the preparation was not finished\">INCOMPLETE</span>";

SessionFilter filter(const std::string& student, const std::string& exercise, std::size_t limit = 0) {
  SessionFilter f;
  f.student = student;
  f.exercise = exercise;
  f.limit = limit;
  return f;
}

std::string pct(double p, double m) { return m > 0 ? html::fixed(100.0 * p / m, 1) : "–"; }

// Issue 27: the student's training with an expert: the modes in order (progression), the
// following error over time per mode, and one row per trained session with its guidance.
const char* mode_name(int m) {
  static const char* names[] = {"", "visual replay", "passive guidance", "active following", "force reversal", "hints"};
  return m >= 1 && m <= 5 ? names[m] : "?";
}

std::string guidance_text(const TrainingRow& t) {
  if (t.mode != 2) return "–";
  std::string g = t.as_needed ? "as needed" : "fixed";
  if (t.across_path_only) g += ", across the path";
  if (t.repetition > 0 && t.fade < 1) g += ", faded " + html::fixed(t.fade, 2) + "^" + std::to_string(t.repetition);
  if (t.amplify > 0) g += ", error amplification " + html::fixed(t.amplify, 2);
  return g;
}

std::string training_section(const std::vector<TrainingRow>& rows) {
  if (rows.empty()) return {};
  std::string b = "<h2 id=\"training\">Training with an expert</h2><p data-k=\"progression\">Modes in order: ";
  for (std::size_t i = 0; i < rows.size(); ++i)
    b += (i ? " → " : "") + std::to_string(rows[i].mode);
  b += "</p>";
  std::map<int, html::Series> by_mode;
  double y_max = 1.0;
  for (const auto& t : rows) {
    if (t.follow_mean_mm < 0) continue;
    auto& se = by_mode[t.mode];
    se.label = "mode " + std::to_string(t.mode) + " " + mode_name(t.mode);
    se.points.emplace_back(html::parse_utc(t.started_utc), t.follow_mean_mm);
    y_max = std::max(y_max, std::ceil(t.follow_mean_mm));
  }
  std::vector<html::Series> all;
  for (auto& [m, se] : by_mode) all.push_back(se);
  if (!all.empty()) b += html::trend_svg(all, "Mean following error (mm) per mode", y_max, " mm", 1);
  b += "<table id=\"training-sessions\"><tr><th>Session</th><th>Started (UTC)</th><th>Exercise</th><th>Mode</th>"
       "<th>Guidance</th><th>Following error, mean</th><th>p95</th><th>Score</th></tr>";
  for (auto it = rows.rbegin(); it != rows.rend(); ++it) {
    const auto& t = *it;
    const std::string id = std::to_string(t.id);
    const auto mm = [](double v) { return v < 0 ? std::string("–") : html::fixed(v, 2) + " mm"; };
    b += "<tr data-id=\"" + id + "\"><td><a href=\"/session/" + id + "\">#" + id + "</a></td><td>" +
         html::esc(t.started_utc) + "</td><td>" + html::esc(t.exercise) + "</td><td data-k=\"mode\">" +
         std::to_string(t.mode) + " " + mode_name(t.mode) + "</td><td data-k=\"guidance\">" + html::esc(guidance_text(t)) +
         "</td><td class=\"n\" data-k=\"follow\">" + mm(t.follow_mean_mm) + "</td><td class=\"n\" data-k=\"p95\">" +
         mm(t.follow_p95_mm) + "</td><td class=\"n\" data-k=\"score\">" +
         (t.expert_cut ? "expert's cut (mode " + std::to_string(t.mode) + ")" : pct(t.points, t.max_points) + " %") +
         "</td></tr>";
  }
  b += "</table>";
  // Per mode: sessions and the following error's first and last value.
  b += "<table id=\"training-progress\"><tr><th>Mode</th><th>Sessions</th><th>First error</th><th>Last error</th></tr>";
  std::map<int, std::vector<const TrainingRow*>> per;
  for (const auto& t : rows) per[t.mode].push_back(&t);
  for (const auto& [m, v] : per) {
    const TrainingRow* first = nullptr;
    const TrainingRow* last = nullptr;
    for (const auto* t : v)
      if (t->follow_mean_mm >= 0) {
        if (!first) first = t;
        last = t;
      }
    const auto e = [](const TrainingRow* t) { return t ? html::fixed(t->follow_mean_mm, 2) + " mm" : std::string("–"); };
    b += "<tr data-mode=\"" + std::to_string(m) + "\"><td>" + std::to_string(m) + " " + mode_name(m) +
         "</td><td class=\"n\">" + std::to_string(v.size()) + "</td><td class=\"n\">" + e(first) +
         "</td><td class=\"n\" data-k=\"last\">" + e(last) + "</td></tr>";
  }
  b += "</table><p>Next session: <code>dentar lesson plan</code> with the student's session folders picks the mode "
       "and guidance from these errors, the scores and the assessment (docs/training_modes.md).</p>";
  return b;
}

OpenOptions readonly_open() {
  OpenOptions o;
  o.create = false;
  o.migrate = false;
  return o;
}

}  // namespace

struct WebServer::Impl {
  ServeOptions opt;
  PasswordFile users;
  PasswordEntry dummy;  // checked for unknown users: as slow as a known one
  std::unique_ptr<RoutedServer> svr;
  std::unique_ptr<Front> front;
  SSL_CTX* ssl_ctx = nullptr;
  bool tls = false;
  std::string login_key;  // random per server start: signs the login forms' CSRF tokens

  ~Impl() {
    front.reset();
    if (ssl_ctx) SSL_CTX_free(ssl_ctx);
  }

  std::mutex mu;  // guards cookies, the pool and the login throttle
  struct CookieSession {
    std::string user, csrf;
    Clock::time_point expires;
  };
  std::map<std::string, CookieSession> cookies;
  std::vector<std::unique_ptr<Store>> pool;
  std::condition_variable pool_cv;

  // Login throttling, per account and per client address: the first
  // login_free_tries failures cost nothing; each further one doubles the
  // wait before the next try is even checked (1 s, 2 s, 4 s, ... up to
  // login_max_delay_s), so guessing slows to one try per max delay and a
  // throttled try costs no PBKDF2 work. Never a permanent lockout: the wait
  // ends, a success clears the count, and a count is forgotten after an hour
  // without failures.
  struct Throttle {
    int failures = 0;
    int refused = 0;  // tries refused while waiting, reported with the next log line
    Clock::time_point last_failure, next_try;
  };
  std::map<std::string, Throttle> throttle;  // "user:NAME" and "addr:IP"

  // CSRF refusals are logged once a minute per address (with how many were
  // not), so a flood of forged posts cannot flood the log.
  struct LogGate {
    Clock::time_point last;
    long unlogged = 0;
  };
  std::map<std::string, LogGate> csrf_log;
  // nullopt: keep this refusal quiet (it is counted); else the line's
  // suffix, " (N more from this address since the last line)" or "".
  std::optional<std::string> csrf_log_gate(const std::string& addr) {
    std::lock_guard lk(mu);
    const auto now = Clock::now();
    if (csrf_log.size() > 10000) csrf_log.clear();
    auto [it, fresh] = csrf_log.try_emplace(addr);
    if (!fresh && now - it->second.last < std::chrono::minutes(1)) {
      ++it->second.unlogged;
      return std::nullopt;
    }
    const long n = it->second.unlogged;
    it->second = {now, 0};
    return n ? " (" + std::to_string(n) + " more from this address since the last line)" : std::string();
  }

  // The login form's token for a pre-session cookie value.
  std::string login_csrf(const std::string& pre) const {
    unsigned char mac[EVP_MAX_MD_SIZE];
    unsigned int n = 0;
    const std::string msg = "dentar-login-form:" + pre;
    HMAC(EVP_sha256(), login_key.data(), static_cast<int>(login_key.size()),
         reinterpret_cast<const unsigned char*>(msg.data()), msg.size(), mac, &n);
    static const char* hex = "0123456789abcdef";
    std::string o;
    for (unsigned int i = 0; i < n; ++i) o += hex[mac[i] >> 4], o += hex[mac[i] & 15];
    return o;
  }
  static bool is_pre_session(const std::string& v) {
    if (v.size() != 32) return false;
    for (char c : v)
      if (hexval(c) < 0) return false;
    return true;
  }
  // The login page with its token; sets a pre-session cookie when the
  // request has none (a reload or a second tab keeps the one it has).
  void send_login(const httplib::Request& req, httplib::Response& res, int status, const std::string& next,
                  const std::string& error) {
    std::string pre = cookie_value(req, kLoginCookie);
    if (!is_pre_session(pre)) {
      pre = random_token_hex(16);
      res.set_header("Set-Cookie", std::string(kLoginCookie) + "=" + pre +
                                       "; Path=/login; HttpOnly; SameSite=Strict; Max-Age=3600" + (tls ? "; Secure" : ""));
    }
    send(res, status, html::login_page(next, error, login_csrf(pre)));
  }

  void log(const std::string& line) {
    if (opt.log) opt.log(line);
    else std::cerr << "serve: " << utc_stamp() << " " << line << std::endl;
  }

  // Seconds until `key` may try again (0: now). Caller holds mu.
  long wait_s(const std::string& key, Clock::time_point now) {
    auto it = throttle.find(key);
    if (it == throttle.end()) return 0;
    if (now - it->second.last_failure > std::chrono::hours(1) && now >= it->second.next_try) {
      throttle.erase(it);
      return 0;
    }
    if (now >= it->second.next_try) return 0;
    return static_cast<long>(std::chrono::ceil<std::chrono::seconds>(it->second.next_try - now).count());
  }
  // Records a failure; returns the new wait in seconds. Caller holds mu.
  long fail_login(const std::string& key, Clock::time_point now) {
    if (throttle.size() > 100000) {  // bounded memory under a flood of names
      for (auto it = throttle.begin(); it != throttle.end();)
        it = now >= it->second.next_try ? throttle.erase(it) : std::next(it);
    }
    Throttle& t = throttle[key];
    ++t.failures;
    t.last_failure = now;
    long d = 0;
    if (t.failures > opt.login_free_tries) {
      const int k = std::min(t.failures - opt.login_free_tries - 1, 30);
      d = std::min<long>(1L << k, opt.login_max_delay_s);
    }
    t.next_try = now + std::chrono::seconds(d);
    return d;
  }

  struct Lease {
    Impl* impl;
    std::unique_ptr<Store> store;
    Lease(Impl* i, std::unique_ptr<Store> s) : impl(i), store(std::move(s)) {}
    Lease(Lease&&) = default;
    ~Lease() {
      if (!store) return;
      std::lock_guard lk(impl->mu);
      impl->pool.push_back(std::move(store));
      impl->pool_cv.notify_one();
    }
  };
  Result<Lease> lease() {
    {
      std::unique_lock lk(mu);
      if (!pool.empty()) {
        Lease l{this, std::move(pool.back())};
        pool.pop_back();
        return l;
      }
    }
    OpenOptions o = readonly_open();
    o.check = false;  // checked once when the server started
    auto s = Store::open(opt.db_url, o);
    if (!s) return Error{s.error()};
    return Lease{this, std::move(*s)};
  }

  // The session cookie's token, or "".
  static std::string cookie_token(const httplib::Request& req) { return cookie_value(req, kCookie); }
  static std::string cookie_value(const httplib::Request& req, const char* name) {
    const std::string c = req.get_header_value("Cookie");
    const std::string key = std::string(name) + "=";
    std::size_t p = 0;
    while ((p = c.find(key, p)) != std::string::npos) {
      if (p == 0 || c[p - 1] == ' ' || c[p - 1] == ';') {
        std::size_t e = c.find(';', p);
        return c.substr(p + key.size(), e == std::string::npos ? std::string::npos : e - p - key.size());
      }
      p += key.size();
    }
    return "";
  }

  Viewer viewer_of(const httplib::Request& req) {
    const std::string tok = cookie_token(req);
    if (tok.empty()) return {};
    std::lock_guard lk(mu);
    auto it = cookies.find(tok);
    if (it == cookies.end()) return {};
    if (it->second.expires > Clock::now()) return {it->second.user, it->second.csrf};
    cookies.erase(it);
    return {};
  }

  // sandbox (stored reports): the document runs without scripts, forms,
  // navigation of its own (a <meta http-equiv=refresh> does nothing) and in
  // an opaque origin, whatever an imported score.html holds.
  void headers(httplib::Response& res, bool sandbox = false) const {
    res.set_header("Content-Security-Policy",
                   std::string("default-src 'none'; style-src 'unsafe-inline'; img-src data:; form-action 'self'; "
                               "frame-ancestors 'none'") + (sandbox ? "; sandbox" : ""));
    res.set_header("X-Content-Type-Options", "nosniff");
    res.set_header("Referrer-Policy", "no-referrer");
    res.set_header("X-Frame-Options", "DENY");
    res.set_header("Cache-Control", "no-store");
    if (tls) res.set_header("Strict-Transport-Security", "max-age=31536000");
  }
  void send(httplib::Response& res, int status, const std::string& body) const {
    res.status = status;
    headers(res);
    res.set_content(body, "text/html; charset=utf-8");
  }
  void fail(httplib::Response& res, int status, const Viewer& v, const std::string& text) const {
    const char* title = status == 404 ? "Not found" : status == 400 ? "Bad request" : status == 401 ? "Login needed"
                        : status == 403 ? "Forbidden" : status == 429 ? "Too many tries" : "Server error";
    send(res, status, html::message_page(status, title, text, v.name, v.csrf));
  }
  // A server error: the page says it was logged, and it is (with the cause).
  void fail500(const httplib::Request& req, httplib::Response& res, const Viewer& v, const std::string& text,
               const std::string& cause) {
    log("error on " + req.method + " " + loggable(req.path) + ": " + text + " " + cause);
    fail(res, 500, v, text + " The error was logged.");
  }

  // Wraps a page: login required, a database connection, errors as pages.
  using PageFn = std::function<void(const httplib::Request&, httplib::Response&, Store&, const Viewer& user)>;
  httplib::Server::Handler guarded(PageFn fn) {
    return [this, fn](const httplib::Request& req, httplib::Response& res) {
      const Viewer user = viewer_of(req);
      if (user.name.empty()) {
        headers(res);
        res.set_redirect("/login?next=" + html::url_part(safe_next(req.path)), 303);
        return;
      }
      // Every query parameter is checked on the raw query (not httplib's
      // lenient parse): only `exercise=CODE`, one '=' each.
      if (!query_ok(req.target)) {
        fail(res, 400, user, "The request has a parameter this page does not accept.");
        return;
      }
      auto l = lease();
      if (!l) {
        fail500(req, res, user, "The session database cannot be reached right now; try again in a minute.", l.error());
        return;
      }
      fn(req, res, *l->store, user);
    };
  }

  void routes() {
    auto& s = *svr;
    s.set_payload_max_length(64 * 1024);
    s.set_exception_handler([this](const httplib::Request& req, httplib::Response& res, std::exception_ptr ep) {
      std::string what = "unknown exception";
      try {
        if (ep) std::rethrow_exception(ep);
      } catch (const std::exception& e) {
        what = e.what();
      } catch (...) {
      }
      fail500(req, res, {}, "Something went wrong on the server.", "(exception: " + what + ")");
    });
    s.set_error_handler(httplib::Server::HandlerWithResponse([this](const httplib::Request&, httplib::Response& res) {
      if (!res.body.empty()) return httplib::Server::HandlerResponse::Unhandled;  // our own page
      fail(res, res.status == 404 ? 404 : res.status, {},
           res.status == 404 ? "There is no such page." : "The request could not be handled.");
      return httplib::Server::HandlerResponse::Handled;
    }));

    s.Get("/login", [this](const httplib::Request& req, httplib::Response& res) {
      send_login(req, res, 200, safe_next(req.get_param_value("next")), "");
    });
    s.Post("/login", [this](const httplib::Request& req, httplib::Response& res) {
      const std::string user = req.get_param_value("user"), pw = req.get_param_value("password");
      const std::string next = safe_next(req.get_param_value("next"));
      const std::string ukey = "user:" + user, akey = "addr:" + req.remote_addr;
      const std::string who = "user '" + loggable(user) + "' from " + req.remote_addr;
      // Login CSRF: the form must be the one this server gave this browser
      // (its token signs the browser's pre-session cookie). Checked first: a
      // forged post costs no password work and does not count as a guess.
      {
        const std::string pre = cookie_value(req, kLoginCookie), given = req.get_param_value("csrf");
        const std::string want = is_pre_session(pre) ? login_csrf(pre) : "";
        if (want.empty() || given.size() != want.size() || CRYPTO_memcmp(given.data(), want.data(), want.size()) != 0) {
          if (auto more = csrf_log_gate(req.remote_addr))
            log("login refused for " + who + ": " +
                (want.empty() ? "no login cookie" : given.empty() ? "no CSRF token" : "a wrong CSRF token") +
                " (the form did not come from this server's login page)" + *more);
          send_login(req, res, 403, next, "This login form has expired or came from another site; log in again here.");
          return;
        }
      }
      long wait = 0;
      int refused = 0;
      {
        std::lock_guard lk(mu);
        const auto now = Clock::now();
        wait = std::max(wait_s(ukey, now), wait_s(akey, now));
        if (wait > 0)
          for (const auto& k : {ukey, akey})
            if (auto t = throttle.find(k); t != throttle.end()) refused = ++t->second.refused;
      }
      if (wait > 0) {  // no password check at all: a throttled guess costs nothing
        if (refused == 1)
          log("login refused for " + who + ": throttled after failed logins, next try in " + std::to_string(wait) + " s");
        res.set_header("Retry-After", std::to_string(wait));
        send_login(req, res, 429, next,
                   "Too many failed logins for this user or from this computer; try again in " + std::to_string(wait) + " s.");
        return;
      }
      auto it = users.find(user);
      // Unknown users cost the same PBKDF2 work as known ones.
      const bool ok = verify_password(it != users.end() ? it->second : dummy, pw) && it != users.end();
      if (!ok) {
        long du = 0, da = 0;
        int fu = 0, fa = 0, ru = 0, ra = 0;
        {
          std::lock_guard lk(mu);
          const auto now = Clock::now();
          du = fail_login(ukey, now);
          da = fail_login(akey, now);
          auto& tu = throttle[ukey];
          auto& ta = throttle[akey];
          fu = tu.failures, fa = ta.failures, ru = tu.refused, ra = ta.refused;
          tu.refused = ta.refused = 0;
        }
        log("login failed for " + who + (it == users.end() ? " (no such user)" : "") + ": failure " + std::to_string(fu) +
            " of the user, " + std::to_string(fa) + " from the address" +
            (ru + ra ? " (" + std::to_string(std::max(ru, ra)) + " tries refused while throttled)" : ""));
        if (const long d = std::max(du, da); d > 0)
          log("login throttled for " + who + ": next try in " + std::to_string(d) + " s");
        send_login(req, res, 401, next, "Wrong user name or password.");
        return;
      }
      const std::string tok = random_token_hex(32);
      {
        std::lock_guard lk(mu);
        throttle.erase(ukey);
        throttle.erase(akey);
        for (auto c = cookies.begin(); c != cookies.end();)  // drop expired sessions
          c = c->second.expires < Clock::now() ? cookies.erase(c) : std::next(c);
        cookies[tok] = {user, random_token_hex(16), Clock::now() + std::chrono::hours(opt.session_hours)};
      }
      log("login of " + who);
      headers(res);
      res.set_header("Set-Cookie", std::string(kCookie) + "=" + tok + "; Path=/; HttpOnly; SameSite=Lax; Max-Age=" +
                                       std::to_string(opt.session_hours * 3600) + (tls ? "; Secure" : ""));
      // The pre-session cookie has done its job.
      res.set_header("Set-Cookie", std::string(kLoginCookie) + "=; Path=/login; HttpOnly; SameSite=Strict; Max-Age=0" +
                                       (tls ? "; Secure" : ""));
      res.set_redirect(next, 303);
    });
    // Logout is a POST carrying the session's CSRF token (a GET, or a POST
    // from another site, cannot end the session).
    s.Post("/logout", [this](const httplib::Request& req, httplib::Response& res) {
      const std::string tok = cookie_token(req);
      const Viewer v = viewer_of(req);
      if (!v.name.empty()) {
        const std::string given = req.get_param_value("csrf");
        if (given.size() != v.csrf.size() || CRYPTO_memcmp(given.data(), v.csrf.data(), given.size()) != 0) {
          log("logout refused for user '" + loggable(v.name) + "' from " + req.remote_addr + ": no or a wrong CSRF token");
          fail(res, 403, v, "This form has expired or came from another site; reload the page and try again.");
          return;
        }
        std::lock_guard lk(mu);
        cookies.erase(tok);
      }
      headers(res);
      res.set_header("Set-Cookie", std::string(kCookie) + "=; Path=/; HttpOnly; SameSite=Lax; Max-Age=0");
      res.set_redirect("/login", 303);
    });

    s.Get("/", guarded([this](const httplib::Request& req, httplib::Response& res, Store& st, const Viewer& user) {
      auto students = st.students();
      if (!students) return fail500(req, res, user, "The student list could not be read.", students.error());
      std::string b = "<h1>Students</h1><table id=\"students\"><tr><th>Student</th><th>Sessions</th><th>Mean score</th>"
                      "<th>Last score</th><th>Last session</th></tr>";
      for (const auto& x : *students)
        b += "<tr data-student=\"" + html::esc(x.code) + "\"><td><a href=\"/student/" + html::url_part(x.code) + "\">" +
             html::esc(x.code) + "</a></td><td class=\"n\" data-k=\"sessions\">" + std::to_string(x.sessions) +
             "</td><td class=\"n\" data-k=\"mean_pct\">" + (x.sessions ? html::fixed(x.mean_pct, 1) + " %" : "–") +
             "</td><td class=\"n\" data-k=\"last_pct\">" + (x.sessions ? html::fixed(x.last_pct, 1) + " %" : "–") +
             (x.sessions && x.last_incomplete ? kIncompleteMark : "") +
             "</td><td>" + html::esc(x.last_utc) + "</td></tr>";
      b += "</table>";
      if (students->empty()) b += "<p class=\"muted\">No sessions stored yet (<code>dentar db import</code>).</p>";
      send(res, 200, html::page("Students", b, user.name, user.csrf));
    }));

    s.Get(R"(/student/([^/]+))", guarded([this](const httplib::Request& req, httplib::Response& res, Store& st,
                                             const Viewer& user) {
      const std::string code = req.matches[1];
      if (!validate_code("student", code).empty()) return fail(res, 400, user, "That is not a student code.");
      const std::string ex = req.get_param_value("exercise");
      auto ss = st.sessions(filter(code, ex));
      if (!ss) return fail500(req, res, user, "The sessions could not be read.", ss.error());
      if (ss->empty()) {
        auto any = st.sessions(filter(code, "", 1));
        if (!any || any->empty()) return fail(res, 404, user, "There is no student with that code.");
      }
      auto tr = st.training(filter(code, ex));
      if (!tr) return fail500(req, res, user, "The training sessions could not be read.", tr.error());
      // Sessions in training modes 1-4 scored the expert's cut: not in the student's score trend,
      // and their score cell says whose cut it was (issue 27).
      std::map<std::int64_t, int> expert_cut;
      for (const auto& t : *tr)
        if (t.expert_cut) expert_cut[t.id] = t.mode;
      std::map<std::string, html::Series> by_ex;
      for (const auto& x : *ss) {
        auto& se = by_ex[x.exercise];
        se.label = x.exercise;
        if (x.max_points > 0 && !expert_cut.count(x.id)) se.points.emplace_back(html::parse_utc(x.started_utc), 100.0 * x.points / x.max_points);
      }
      std::string b = "<h1>Student " + html::esc(code) + "</h1><p>" + std::to_string(ss->size()) + " sessions" +
                      (ex.empty() ? "" : " of " + html::esc(ex) + " (<a href=\"/student/" + html::url_part(code) + "\">all</a>)") +
                      "</p><h2>Scores over time</h2>";
      std::vector<html::Series> all;
      for (auto& [name, se] : by_ex) all.push_back(se);
      b += html::trend_svg(all, "Score (% of the exercise's points) per exercise");
      b += "<h2>Sessions</h2><table id=\"sessions\"><tr><th>Session</th><th>Started (UTC)</th><th>Exercise</th>"
           "<th>Station</th><th>Points</th><th>Score</th><th>Target removed</th><th>Time</th><th>Pulp</th><th>Report</th></tr>";
      for (auto it = ss->rbegin(); it != ss->rend(); ++it) {
        const auto& x = *it;
        const std::string id = std::to_string(x.id);
        b += "<tr data-id=\"" + id + "\"><td><a href=\"/session/" + id + "\">#" + id + "</a></td><td>" +
             html::esc(x.started_utc) + "</td><td><a href=\"/student/" + html::url_part(code) + "?exercise=" +
             html::url_part(x.exercise) + "\">" + html::esc(x.exercise) + "</a></td><td>" + html::esc(x.station) +
             "</td><td class=\"n\" data-k=\"points\">" + html::fixed(x.points, 2) + " / " + html::fixed(x.max_points, 0) +
             "</td><td class=\"n\" data-k=\"pct\">" +
             (expert_cut.count(x.id) ? "expert's cut (mode " + std::to_string(expert_cut[x.id]) + ")"
                                     : pct(x.points, x.max_points) + " %" + (x.incomplete ? kIncompleteMark : "")) +
             "</td><td class=\"n\">" +
             html::fixed(x.coverage_pct, 1) + " %</td><td class=\"n\">" + html::fixed(x.duration_s, 1) + " s</td><td>" +
             (x.pulp_exposed ? "<span class=\"warn\">exposed</span>" : "–") + "</td><td>" +
             (x.has_report ? "<a href=\"/session/" + id + "/report\">report</a>" : "–") + "</td></tr>";
      }
      b += "</table>";
      b += training_section(*tr);
      send(res, 200, html::page("Student " + code, b, user.name, user.csrf));
    }));

    s.Get(R"(/session/([^/]+))", guarded([this](const httplib::Request& req, httplib::Response& res, Store& st,
                                             const Viewer& user) {
      const std::string ids = req.matches[1];
      if (!is_id(ids)) return fail(res, 400, user, "A session number is digits only.");
      auto r = st.session(std::stoll(ids));
      if (!r) return fail500(req, res, user, "The session could not be read.", r.error());
      if (!*r) return fail(res, 404, user, "There is no session #" + ids + ".");
      const SessionRecord& x = **r;
      std::string b = "<h1>Session #" + ids + "</h1><table id=\"summary\">";
      auto row = [&](const std::string& k, const std::string& label, const std::string& v) {
        b += "<tr><th>" + label + "</th><td data-k=\"" + k + "\">" + v + "</td></tr>";
      };
      row("student", "Student", "<a href=\"/student/" + html::url_part(x.student) + "\">" + html::esc(x.student) + "</a>");
      row("exercise", "Exercise", html::esc(x.exercise_title.empty() ? x.exercise : x.exercise_title));
      row("station", "Station", html::esc(x.station));
      row("started", "Started (UTC)", html::esc(x.started_utc));
      bool incomplete = false;  // score.json outcome.complete (scores before issue 25 have none)
      int mode = 0;              // training mode 1..5 (issue 27), 0 = plain drilling
      bool expert_cut = false;   // modes 1-4: the expert's bur cut, so the points are not the student's
      for (const auto& m : x.metrics) {
        incomplete |= m.name == "outcome.complete" && m.value == 0;
        if (m.name == "training.mode") mode = static_cast<int>(m.value);
        if (m.name == "training.expert_cut") expert_cut |= m.value != 0;
      }
      expert_cut |= mode >= 1 && mode <= 4;  // stored before score.json said cut_by
      const std::string pts = html::fixed(x.points, 2) + " / " + html::fixed(x.max_points, 0) + " (" + pct(x.points, x.max_points) + " %)";
      if (expert_cut)
        row("points", "Points", "expert's cut (mode " + std::to_string(mode) + "), not the student's: " + pts);
      else
        row("points", "Points", pts + (incomplete ? " <span class=\"warn\">incomplete: the preparation was not finished</span>" : ""));
      row("coverage", "Target removed", html::fixed(x.coverage_pct, 1) + " %");
      row("overprep", "Over-preparation", html::fixed(x.overprep_mm3, 2) + " mm³");
      row("pulp", "Pulp exposed", x.pulp_exposed ? "<span class=\"warn\">yes</span>" : "no");
      row("perforation", "Perforation", x.perforation ? "<span class=\"warn\">yes</span>" : "no");
      row("duration", "Time / drilling", html::fixed(x.duration_s, 1) + " s / " + html::fixed(x.drilling_s, 1) + " s");
      row("path", "Bur tip path", html::fixed(x.path_mm, 0) + " mm");
      row("excessive", "Drilling with excessive force", html::fixed(x.excessive_force_s, 1) + " s");
      row("log", "Session log", html::esc(x.log_path) + "<br><code>sha256 " + html::esc(x.log_sha256) + "</code> (" +
                                    std::to_string(x.log_bytes) + " bytes)");
      if (!x.recording_path.empty())
        row("recording", "Recording", html::esc(x.recording_path) + "<br><code>sha256 " + html::esc(x.recording_sha256) + "</code>");
      if (!x.log_warning.empty()) row("log_warning", "Log warning", "<span class=\"warn\">" + html::esc(x.log_warning) + "</span>");
      b += "</table>";
      if (!x.score_html.empty()) b += "<p><a id=\"report-link\" href=\"/session/" + ids + "/report\">Full score report</a></p>";
      b += "<h2>Force against the experts, per step</h2>";
      std::vector<html::ForceRow> fr;
      const char* axes[] = {"Fx mesio-distal", "Fy bucco-lingual", "Fz long axis"};
      for (const auto& k : x.steps)
        for (int a = 0; a < 3; ++a)
          fr.push_back({k.name, axes[a], k.force_N[a], k.force_sd_N[a], k.has_expert, k.expert_force_N[a], k.expert_sd_N[a]});
      b += html::force_band_svg(fr);
      b += "<h2>Feedback</h2><ul id=\"feedback\">";
      for (const auto& f : x.feedback)
        b += "<li><b>" + html::esc(f.step.empty() ? "session" : f.step) + "</b> (" + html::esc(f.kind) + "): " + html::esc(f.text) + "</li>";
      b += "</ul><h2>Metrics</h2><table id=\"metrics\"><tr><th>Metric</th><th>Value</th><th>Unit</th></tr>";
      for (const auto& m : x.metrics) {  // in words with units; the stored key as a tooltip
        const MetricLabel ml = metric_label(m.name, m.unit);
        b += "<tr><td title=\"" + html::esc(m.name) + "\">" + html::esc(ml.label) + "</td><td class=\"n\">" +
             html::esc(metric_value_text(ml, m.value, 3)) + "</td><td>" + html::esc(ml.unit) + "</td></tr>";
      }
      b += "</table>";
      send(res, 200, html::page("Session #" + ids, b, user.name, user.csrf));
    }));

    s.Get(R"(/session/([^/]+)/report)", guarded([this](const httplib::Request& req, httplib::Response& res, Store& st,
                                                    const Viewer& user) {
      const std::string ids = req.matches[1];
      if (!is_id(ids)) return fail(res, 400, user, "A session number is digits only.");
      auto r = st.session(std::stoll(ids));
      if (!r) return fail500(req, res, user, "The session could not be read.", r.error());
      if (!*r) return fail(res, 404, user, "There is no session #" + ids + ".");
      if ((*r)->score_html.empty()) return fail(res, 404, user, "Session #" + ids + " was stored without its report.");
      // The stored score.html (never a file from disk), sandboxed.
      res.status = 200;
      headers(res, true);
      res.set_content((*r)->score_html, "text/html; charset=utf-8");
    }));

    s.Get("/cohort", guarded([this](const httplib::Request& req, httplib::Response& res, Store& st, const Viewer& user) {
      auto exs = st.exercises();
      if (!exs) return fail500(req, res, user, "The exercises could not be read.", exs.error());
      std::string b = "<h1>Cohort</h1>";
      if (exs->empty()) b += "<p class=\"muted\">No sessions stored yet.</p>";
      for (const auto& e : *exs) {
        auto ss = st.sessions(filter("", e));
        if (!ss) return fail500(req, res, user, "The sessions could not be read.", ss.error());
        std::map<std::string, std::vector<double>> per;
        for (const auto& x : *ss)
          if (x.max_points > 0) per[x.student].push_back(100.0 * x.points / x.max_points);
        b += "<h2><a href=\"/exercise/" + html::url_part(e) + "\">" + html::esc(e) + "</a></h2>";
        std::vector<std::pair<std::string, std::vector<double>>> rows(per.begin(), per.end());
        b += html::strip_svg(rows, "Every session's score (dots) and each student's mean (red bar)");
        b += "<table class=\"cohort\" data-exercise=\"" + html::esc(e) +
             "\"><tr><th>Student</th><th>Sessions</th><th>Mean</th><th>Best</th><th>Last</th></tr>";
        for (const auto& [stu, v] : rows) {
          double sum = 0, best = 0;
          for (double p : v) sum += p, best = std::max(best, p);
          b += "<tr data-student=\"" + html::esc(stu) + "\"><td><a href=\"/student/" + html::url_part(stu) + "?exercise=" +
               html::url_part(e) + "\">" + html::esc(stu) + "</a></td><td class=\"n\" data-k=\"sessions\">" +
               std::to_string(v.size()) + "</td><td class=\"n\" data-k=\"mean_pct\">" +
               html::fixed(sum / static_cast<double>(v.size()), 1) + " %</td><td class=\"n\">" + html::fixed(best, 1) +
               " %</td><td class=\"n\">" + html::fixed(v.back(), 1) + " %</td></tr>";
        }
        b += "</table>";
      }
      send(res, 200, html::page("Cohort", b, user.name, user.csrf));
    }));

    s.Get(R"(/exercise/([^/]+))", guarded([this](const httplib::Request& req, httplib::Response& res, Store& st,
                                              const Viewer& user) {
      const std::string e = req.matches[1];
      if (!validate_code("exercise", e).empty()) return fail(res, 400, user, "That is not an exercise name.");
      auto ss = st.sessions(filter("", e));
      if (!ss) return fail500(req, res, user, "The sessions could not be read.", ss.error());
      if (ss->empty()) return fail(res, 404, user, "No session of that exercise is stored.");
      std::map<std::string, html::Series> per;
      for (const auto& x : *ss) {
        auto& se = per[x.student];
        se.label = x.student;
        if (x.max_points > 0) se.points.emplace_back(html::parse_utc(x.started_utc), 100.0 * x.points / x.max_points);
      }
      std::vector<html::Series> all;
      for (auto& [k, v] : per) all.push_back(v);
      std::string b = "<h1>Exercise " + html::esc(e) + "</h1><p>" + std::to_string(ss->size()) + " sessions by " +
                      std::to_string(per.size()) + " students</p>" + html::trend_svg(all, "Score over time, one line per student");
      send(res, 200, html::page("Exercise " + e, b, user.name, user.csrf));
    }));
  }
};

WebServer::~WebServer() { stop(); }

Result<std::unique_ptr<WebServer>> WebServer::create(const ServeOptions& opt, OpenFault* fault) {
  OpenFault dummy;
  OpenFault& f = fault ? *fault : dummy;
  f = OpenFault::BadInput;
  if (auto v = opt.validate(); !v.empty()) return Error{v};
  auto users = load_password_file(opt.password_file);
  if (!users) return Error{users.error()};
  if (users->empty()) return Error{opt.password_file + ": no user; add one with --set-password USER"};
  // The database must exist, be undamaged (PRAGMA quick_check) and be at this
  // program's schema (no migration from a read-only server: `dentar db migrate`).
  auto probe = Store::open(opt.db_url, readonly_open(), &f);
  if (!probe) return Error{probe.error()};
  f = OpenFault::BadInput;
  std::unique_ptr<WebServer> w(new WebServer());
  w->impl_ = std::make_unique<Impl>();
  Impl& m = *w->impl_;
  m.opt = opt;
  m.users = *users;
  m.dummy = hash_password(random_token_hex(16), m.users.begin()->second.iterations);
  m.login_key = random_token_hex(32);
  m.pool.push_back(std::move(*probe));
  if (!opt.cert_file.empty()) {
    std::error_code ec;
    for (const auto& file : {opt.cert_file, opt.key_file})
      if (!std::filesystem::is_regular_file(file, ec)) return Error{file + ": no such certificate/key file"};
    // TLS 1.2 and 1.3 only; for TLS 1.2 only ECDHE key exchange with AEAD
    // ciphers (forward secrecy: a stolen key does not open recorded
    // traffic). TLS 1.3's suites are all forward-secret.
    m.ssl_ctx = SSL_CTX_new(TLS_server_method());
    if (!m.ssl_ctx) return Error{"OpenSSL: cannot create a TLS context"};
    SSL_CTX_set_min_proto_version(m.ssl_ctx, TLS1_2_VERSION);
    SSL_CTX_set_options(m.ssl_ctx, SSL_OP_NO_COMPRESSION | SSL_OP_NO_RENEGOTIATION | SSL_OP_CIPHER_SERVER_PREFERENCE);
    const bool ok = SSL_CTX_set_cipher_list(m.ssl_ctx, "ECDHE+AESGCM:ECDHE+CHACHA20") == 1 &&
                    SSL_CTX_use_certificate_chain_file(m.ssl_ctx, opt.cert_file.c_str()) == 1 &&
                    SSL_CTX_use_PrivateKey_file(m.ssl_ctx, opt.key_file.c_str(), SSL_FILETYPE_PEM) == 1 &&
                    SSL_CTX_check_private_key(m.ssl_ctx) == 1;
    ERR_clear_error();
    if (!ok) return Error{opt.cert_file + " / " + opt.key_file + ": not a usable PEM certificate and key"};
    m.tls = true;
  }
  m.svr = std::make_unique<RoutedServer>();
  m.svr->set_keep_alive_max_count(100);  // what the front allows (the Keep-Alive header says so)
  m.svr->set_keep_alive_timeout(static_cast<time_t>(opt.request_timeout_s));
  m.routes();
  FrontOptions fo;
  fo.host = opt.host;
  fo.port = opt.port;
  fo.workers = opt.threads;
  fo.request_timeout_s = opt.request_timeout_s;
  fo.max_header_bytes = opt.max_header_bytes;
  fo.max_headers = opt.max_headers;
  fo.max_body_bytes = 64 * 1024;
  fo.max_conn_per_client = opt.max_conn_per_client;
  fo.tls = m.ssl_ctx;
  Impl* mp = &m;
  fo.log = [mp](const std::string& line) { mp->log(line); };
  m.front = std::make_unique<Front>(fo, [mp](httplib::Stream& s, bool last, bool& close) {
    return mp->svr->serve_one(s, last, close);
  });
  f = OpenFault::None;
  return w;
}

Status WebServer::bind() { return impl_->front->bind(); }

Status WebServer::listen_after_bind() { return impl_->front->run(); }

Status WebServer::listen() {
  if (auto s = bind(); !s) return s;
  return listen_after_bind();
}

int WebServer::port() const { return impl_->front->port(); }

void WebServer::stop() {
  if (impl_ && impl_->front) impl_->front->stop();
}

}  // namespace dentar::store
