// HTML and SVG building blocks for the instructor's pages. Private to store/.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace dentar::store::html {

std::string esc(const std::string& s);          // text and attribute values
std::string url_part(const std::string& s);     // one path segment / query value
std::string fixed(double v, int decimals);
// csrf: the session's token, carried by the header's logout form (a POST).
std::string page(const std::string& title, const std::string& body, const std::string& user,
                 const std::string& csrf = "");
std::string message_page(int status, const std::string& title, const std::string& text, const std::string& user,
                         const std::string& csrf = "");
// csrf: the login form's token (bound to the browser's pre-session cookie).
std::string login_page(const std::string& next, const std::string& error, const std::string& csrf);

struct Series {
  std::string label;
  std::vector<std::pair<double, double>> points;  // x, y
  std::string colour;
};
// Score trend: x = time (UTC seconds), y = % of the exercise's points (or another
// quantity: y_unit labels the axis, e.g. " mm").
std::string trend_svg(const std::vector<Series>& series, const std::string& title, double y_max = 100,
                      const std::string& y_unit = "%", int y_decimals = 0);
// Per step: the student's mean force per tooth axis (dot, ±1 SD whisker)
// against the experts' mean ± 1 SD (band).
struct ForceRow {
  std::string step, axis;
  double mean, sd;
  bool has_expert;
  double expert_mean, expert_sd;
};
std::string force_band_svg(const std::vector<ForceRow>& rows);
// One row of dots per label (cohort view).
std::string strip_svg(const std::vector<std::pair<std::string, std::vector<double>>>& rows, const std::string& title);

double parse_utc(const std::string& iso);  // seconds since the epoch; 0 if not ISO 8601
std::string colour(std::size_t i);

}  // namespace dentar::store::html
