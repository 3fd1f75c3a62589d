#include "html.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>

namespace dentar::store::html {

std::string esc(const std::string& s) {
  std::string o;
  o.reserve(s.size());
  for (char c : s) switch (c) {
      case '&': o += "&amp;"; break;
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '"': o += "&quot;"; break;
      case '\'': o += "&#39;"; break;
      default: o += c;
    }
  return o;
}

std::string url_part(const std::string& s) {
  static const char* k = "0123456789ABCDEF";
  std::string o;
  for (unsigned char c : s) {
    if (std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '~') o += static_cast<char>(c);
    else {
      o += '%';
      o += k[c >> 4];
      o += k[c & 15];
    }
  }
  return o;
}

std::string fixed(double v, int decimals) {
  if (!std::isfinite(v)) return "–";
  char b[64];
  std::snprintf(b, sizeof b, "%.*f", decimals, v);
  return b;
}

namespace {
const char* kStyle =
    "body{font-family:system-ui,sans-serif;margin:0;color:#1c2430;background:#f6f7f9}"
    "header{background:#1d3b5a;color:#fff;padding:10px 24px;display:flex;gap:24px;align-items:center}"
    "header a{color:#fff;text-decoration:none;font-weight:600}header .user{margin-left:auto;font-weight:400}"
    "main{padding:16px 24px;max-width:1200px}h1{font-size:1.5em}h2{font-size:1.15em;margin-top:28px}"
    "table{border-collapse:collapse;background:#fff;margin:8px 0}td,th{border:1px solid #d5dae1;padding:4px 10px;"
    "text-align:left}th{background:#eef1f5}td.n{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}"
    ".warn{color:#a33;font-weight:600}.ok{color:#286b2a}.muted{color:#667}svg{background:#fff;border:1px solid #d5dae1;"
    "margin:6px 0}form.login{background:#fff;padding:20px;border:1px solid #d5dae1;max-width:320px}"
    "form.login input{display:block;margin:6px 0 12px;width:100%;padding:6px}"
    "form.logout{display:inline;margin:0}form.logout button{background:none;border:0;color:#fff;text-decoration:underline;"
    "cursor:pointer;font:inherit;padding:0}";
}  // namespace

std::string page(const std::string& title, const std::string& body, const std::string& user, const std::string& csrf) {
  std::string h = "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>" + esc(title) +
                  " · DentAR</title><style>" + kStyle + "</style></head><body><header><a href=\"/\">DentAR</a>";
  if (!user.empty())
    h += "<a href=\"/\">Students</a><a href=\"/cohort\">Cohort</a><span class=\"user\">" + esc(user) +
         " · <form class=\"logout\" method=\"post\" action=\"/logout\"><input type=\"hidden\" name=\"csrf\" value=\"" +
         esc(csrf) + "\"><button type=\"submit\">Log out</button></form></span>";
  h += "</header><main>" + body + "</main></body></html>";
  return h;
}

std::string message_page(int status, const std::string& title, const std::string& text, const std::string& user,
                         const std::string& csrf) {
  return page(title, "<h1 id=\"status\" data-status=\"" + std::to_string(status) + "\">" + std::to_string(status) +
                         " · " + esc(title) + "</h1><p>" + esc(text) + "</p><p><a href=\"/\">Back to the students</a></p>",
              user, csrf);
}

std::string login_page(const std::string& next, const std::string& error, const std::string& csrf) {
  std::string b = "<h1>Instructor login</h1>";
  if (!error.empty()) b += "<p class=\"warn\" id=\"login-error\">" + esc(error) + "</p>";
  b += "<form class=\"login\" method=\"post\" action=\"/login\"><label>User<input name=\"user\" autocomplete=\"username\" "
       "required></label><label>Password<input name=\"password\" type=\"password\" autocomplete=\"current-password\" "
       "required></label><input type=\"hidden\" name=\"next\" value=\"" +
       esc(next) + "\"><input type=\"hidden\" name=\"csrf\" value=\"" + esc(csrf) + "\"><button type=\"submit\">Log in</button></form>";
  return page("Login", b, "");
}

double parse_utc(const std::string& iso) {
  std::tm tm{};
  int y, mo, d, h = 0, mi = 0, s = 0;
  if (std::sscanf(iso.c_str(), "%4d-%2d-%2dT%2d:%2d:%2d", &y, &mo, &d, &h, &mi, &s) < 3) return 0;
  tm.tm_year = y - 1900;
  tm.tm_mon = mo - 1;
  tm.tm_mday = d;
  tm.tm_hour = h;
  tm.tm_min = mi;
  tm.tm_sec = s;
  return static_cast<double>(timegm(&tm));
}

std::string colour(std::size_t i) {
  static const char* k[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22"};
  return k[i % 10];
}

namespace {
std::string date_of(double t) {
  const std::time_t tt = static_cast<std::time_t>(t);
  std::tm tm{};
  gmtime_r(&tt, &tm);
  char b[32];
  std::strftime(b, sizeof b, "%Y-%m-%d", &tm);
  return b;
}
std::string num(double v) { return fixed(v, 1); }
}  // namespace

std::string trend_svg(const std::vector<Series>& series, const std::string& title, double y_max,
                      const std::string& y_unit, int y_decimals) {
  const double W = 780, H = 260, L = 50, R = 200, T = 28, B = 34;
  double x0 = 1e300, x1 = -1e300;
  for (const auto& s : series)
    for (const auto& p : s.points) x0 = std::min(x0, p.first), x1 = std::max(x1, p.first);
  if (x0 > x1) x0 = 0, x1 = 1;
  if (x1 - x0 < 1) x0 -= 0.5, x1 += 0.5;
  auto X = [&](double x) { return L + (W - L - R) * (x - x0) / (x1 - x0); };
  auto Y = [&](double y) { return T + (H - T - B) * (1 - std::clamp(y / y_max, 0.0, 1.0)); };
  std::string s = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + num(W) + "\" height=\"" + num(H) +
                  "\" role=\"img\" aria-label=\"" + esc(title) + "\"><text x=\"" + num(L) + "\" y=\"18\" font-size=\"13\" font-weight=\"600\">" +
                  esc(title) + "</text>";
  for (int g = 0; g <= 4; ++g) {
    const double y = y_max * g / 4;
    s += "<line x1=\"" + num(L) + "\" x2=\"" + num(W - R) + "\" y1=\"" + num(Y(y)) + "\" y2=\"" + num(Y(y)) +
         "\" stroke=\"#e3e6ea\"/><text x=\"" + num(L - 6) + "\" y=\"" + num(Y(y) + 4) +
         "\" font-size=\"11\" text-anchor=\"end\">" + fixed(y, y_decimals) + esc(y_unit) + "</text>";
  }
  s += "<text x=\"" + num(L) + "\" y=\"" + num(H - 10) + "\" font-size=\"11\">" + date_of(x0) + "</text><text x=\"" +
       num(W - R) + "\" y=\"" + num(H - 10) + "\" font-size=\"11\" text-anchor=\"end\">" + date_of(x1) + "</text>";
  for (std::size_t i = 0; i < series.size(); ++i) {
    const auto& se = series[i];
    const std::string c = se.colour.empty() ? colour(i) : se.colour;
    std::string pts;
    for (const auto& p : se.points) pts += num(X(p.first)) + "," + num(Y(p.second)) + " ";
    if (se.points.size() > 1)
      s += "<polyline fill=\"none\" stroke=\"" + c + "\" stroke-width=\"1.5\" points=\"" + pts + "\"/>";
    if (se.points.size() <= 200)
      for (const auto& p : se.points)
        s += "<circle cx=\"" + num(X(p.first)) + "\" cy=\"" + num(Y(p.second)) + "\" r=\"2.5\" fill=\"" + c + "\"/>";
    if (i < 12)
      s += "<rect x=\"" + num(W - R + 12) + "\" y=\"" + num(T + 16.0 * static_cast<double>(i)) +
           "\" width=\"10\" height=\"10\" fill=\"" + c + "\"/><text x=\"" + num(W - R + 26) + "\" y=\"" +
           num(T + 9 + 16.0 * static_cast<double>(i)) + "\" font-size=\"11\">" + esc(se.label.substr(0, 28)) + "</text>";
  }
  return s + "</svg>";
}

std::string force_band_svg(const std::vector<ForceRow>& rows) {
  if (rows.empty()) return "<p class=\"muted\">No per-step forces in this session.</p>";
  double fmax = 0.5;
  for (const auto& r : rows)
    fmax = std::max({fmax, std::abs(r.mean) + r.sd, r.has_expert ? std::abs(r.expert_mean) + r.expert_sd : 0.0});
  const double W = 720, L = 260, R = 20, rowh = 22, T = 30;
  const double H = T + rowh * static_cast<double>(rows.size()) + 30;
  auto X = [&](double f) { return L + (W - L - R) * (f + fmax) / (2 * fmax); };
  std::string s = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + num(W) + "\" height=\"" + num(H) +
                  "\" role=\"img\" aria-label=\"force bands\"><text x=\"8\" y=\"18\" font-size=\"13\" font-weight=\"600\">"
                  "Mean force per step and axis (N): student (dot, ±1 SD) against the experts' band (mean ± 1 SD)</text>";
  s += "<line x1=\"" + num(X(0)) + "\" x2=\"" + num(X(0)) + "\" y1=\"" + num(T - 4) + "\" y2=\"" + num(H - 26) +
       "\" stroke=\"#999\"/>";
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const auto& r = rows[i];
    const double y = T + rowh * static_cast<double>(i) + rowh / 2;
    s += "<text x=\"8\" y=\"" + num(y + 4) + "\" font-size=\"11\">" + esc(r.step.substr(0, 28)) + " · " + esc(r.axis) + "</text>";
    if (r.has_expert)
      s += "<rect x=\"" + num(X(r.expert_mean - r.expert_sd)) + "\" y=\"" + num(y - 7) + "\" width=\"" +
           num(std::max(3.0, X(r.expert_mean + r.expert_sd) - X(r.expert_mean - r.expert_sd))) +
           "\" height=\"14\" fill=\"#8fd18a\"/><line x1=\"" + num(X(r.expert_mean)) + "\" x2=\"" +
           num(X(r.expert_mean)) + "\" y1=\"" + num(y - 8) + "\" y2=\"" + num(y + 8) +
           "\" stroke=\"#1e6b24\" stroke-width=\"2\"/>";
    const bool inside = r.has_expert && std::abs(r.mean - r.expert_mean) <= r.expert_sd;
    const std::string c = !r.has_expert ? "#1f77b4" : inside ? "#286b2a" : "#c0392b";
    s += "<line x1=\"" + num(X(r.mean - r.sd)) + "\" x2=\"" + num(X(r.mean + r.sd)) + "\" y1=\"" + num(y) + "\" y2=\"" +
         num(y) + "\" stroke=\"" + c + "\"/><circle cx=\"" + num(X(r.mean)) + "\" cy=\"" + num(y) + "\" r=\"4\" fill=\"" +
         c + "\"/>";
  }
  s += "<text x=\"" + num(L) + "\" y=\"" + num(H - 8) + "\" font-size=\"11\">" + fixed(-fmax, 1) + " N</text><text x=\"" +
       num(W - R) + "\" y=\"" + num(H - 8) + "\" font-size=\"11\" text-anchor=\"end\">+" + fixed(fmax, 1) + " N</text>";
  return s + "</svg>";
}

std::string strip_svg(const std::vector<std::pair<std::string, std::vector<double>>>& rows, const std::string& title) {
  const double W = 720, L = 160, R = 20, rowh = 20, T = 30;
  const double H = T + rowh * static_cast<double>(rows.size()) + 30;
  auto X = [&](double p) { return L + (W - L - R) * std::clamp(p, 0.0, 100.0) / 100.0; };
  std::string s = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + num(W) + "\" height=\"" + num(H) +
                  "\" role=\"img\" aria-label=\"" + esc(title) + "\"><text x=\"8\" y=\"18\" font-size=\"13\" font-weight=\"600\">" +
                  esc(title) + "</text>";
  for (int g = 0; g <= 4; ++g)
    s += "<line x1=\"" + num(X(25.0 * g)) + "\" x2=\"" + num(X(25.0 * g)) + "\" y1=\"" + num(T - 4) + "\" y2=\"" +
         num(H - 26) + "\" stroke=\"#e3e6ea\"/><text x=\"" + num(X(25.0 * g)) + "\" y=\"" + num(H - 8) +
         "\" font-size=\"11\" text-anchor=\"middle\">" + std::to_string(25 * g) + "%</text>";
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const double y = T + rowh * static_cast<double>(i) + rowh / 2;
    s += "<text x=\"8\" y=\"" + num(y + 4) + "\" font-size=\"11\">" + esc(rows[i].first.substr(0, 22)) + "</text>";
    double sum = 0;
    for (double v : rows[i].second) {
      s += "<circle cx=\"" + num(X(v)) + "\" cy=\"" + num(y) + "\" r=\"3\" fill=\"#1f77b4\" fill-opacity=\"0.45\"/>";
      sum += v;
    }
    if (!rows[i].second.empty()) {
      const double m = sum / static_cast<double>(rows[i].second.size());
      s += "<line x1=\"" + num(X(m)) + "\" x2=\"" + num(X(m)) + "\" y1=\"" + num(y - 8) + "\" y2=\"" + num(y + 8) +
           "\" stroke=\"#c0392b\" stroke-width=\"2\"/>";
    }
  }
  return s + "</svg>";
}

}  // namespace dentar::store::html
