// SVG plots for the offline report. Hand-written SVG keeps the report one
// self-contained file that any browser opens, with no dependency.
#include "dentar/ar/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <sstream>
#include <tuple>

namespace dentar::ar {
namespace {

// Colour-blind-safe palette (Okabe-Ito).
const char* const kPalette[] = {"#0072B2", "#D55E00", "#009E73", "#CC79A7",
                                "#E69F00", "#56B4E9", "#000000", "#F0E442"};

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", v);
  return buf;
}

// Tick label: as few digits as the tick step needs.
std::string tick_label(double v, double step) {
  char buf[32];
  const int decimals = step >= 1 ? 0 : std::min(6, static_cast<int>(std::ceil(-std::log10(step) - 1e-9)));
  if (std::abs(v) < step * 1e-6) v = 0;  // no "-0"
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

struct Frame {  // plot area in SVG pixels and its data range
  double left, top, width, height;
  double x0, x1, y0, y1;
  double px(double x) const { return left + (x - x0) / (x1 - x0) * width; }
  double py(double y) const { return top + height - (y - y0) / (y1 - y0) * height; }
};

void open_svg(std::ostringstream& s, int w, int h) {
  s << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << w << "\" height=\"" << h
    << "\" viewBox=\"0 0 " << w << ' ' << h
    << "\" font-family=\"sans-serif\" font-size=\"12\">\n"
    << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
}

void draw_axes(std::ostringstream& s, const Frame& f, const std::string& title,
               const std::string& x_label, const std::string& y_label) {
  s << "<text x=\"" << num(f.left + f.width / 2) << "\" y=\"16\" text-anchor=\"middle\" "
    << "font-weight=\"bold\">" << html_escape(title) << "</text>\n";
  const double step_x = [&] {
    auto t = nice_ticks(f.x0, f.x1);
    return t.size() > 1 ? t[1] - t[0] : 1.0;
  }();
  for (double t : nice_ticks(f.x0, f.x1)) {
    const double x = f.px(t);
    s << "<line x1=\"" << num(x) << "\" y1=\"" << num(f.top) << "\" x2=\"" << num(x) << "\" y2=\""
      << num(f.top + f.height) << "\" stroke=\"#e4e4e4\"/>\n"
      << "<text x=\"" << num(x) << "\" y=\"" << num(f.top + f.height + 15)
      << "\" text-anchor=\"middle\">" << tick_label(t, step_x) << "</text>\n";
  }
  const auto yt = nice_ticks(f.y0, f.y1);
  const double step_y = yt.size() > 1 ? yt[1] - yt[0] : 1.0;
  for (double t : yt) {
    const double y = f.py(t);
    s << "<line x1=\"" << num(f.left) << "\" y1=\"" << num(y) << "\" x2=\"" << num(f.left + f.width)
      << "\" y2=\"" << num(y) << "\" stroke=\"#e4e4e4\"/>\n"
      << "<text x=\"" << num(f.left - 6) << "\" y=\"" << num(y + 4) << "\" text-anchor=\"end\">"
      << tick_label(t, step_y) << "</text>\n";
  }
  s << "<rect x=\"" << num(f.left) << "\" y=\"" << num(f.top) << "\" width=\"" << num(f.width)
    << "\" height=\"" << num(f.height) << "\" fill=\"none\" stroke=\"#444\"/>\n";
  s << "<text x=\"" << num(f.left + f.width / 2) << "\" y=\"" << num(f.top + f.height + 32)
    << "\" text-anchor=\"middle\">" << html_escape(x_label) << "</text>\n";
  const double ymid = f.top + f.height / 2;
  s << "<text x=\"14\" y=\"" << num(ymid) << "\" text-anchor=\"middle\" transform=\"rotate(-90 14 "
    << num(ymid) << ")\">" << html_escape(y_label) << "</text>\n";
}

void no_data(std::ostringstream& s, const Frame& f) {
  s << "<text x=\"" << num(f.left + f.width / 2) << "\" y=\"" << num(f.top + f.height / 2)
    << "\" text-anchor=\"middle\" fill=\"#888\">no data</text>\n";
}

// Expands a degenerate range so a constant series still plots.
void widen(double& lo, double& hi) {
  if (!(hi > lo)) {
    const double pad = std::max(1e-9, std::abs(lo) * 0.1 + (lo == 0 ? 1.0 : 0.0));
    lo -= pad;
    hi += pad;
  }
}

}  // namespace

std::vector<double> nice_ticks(double lo, double hi, int target) {
  std::vector<double> out;
  if (!std::isfinite(lo) || !std::isfinite(hi) || !(hi > lo) || target < 1) return out;
  const double raw = (hi - lo) / target;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * mag >= raw) {
      step = m * mag;
      break;
    }
  for (double t = std::ceil(lo / step - 1e-9) * step; t <= hi + step * 1e-9; t += step)
    out.push_back(t);
  return out;
}

double percentile(std::vector<double> v, double pct) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(v.begin(), v.end());
  const double pos = std::clamp(pct, 0.0, 100.0) / 100.0 * static_cast<double>(v.size() - 1);
  const auto i = static_cast<std::size_t>(pos);
  if (i + 1 >= v.size()) return v.back();
  return v[i] + (pos - static_cast<double>(i)) * (v[i + 1] - v[i]);
}

std::string html_escape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string svg_line_plot(const LinePlot& p) {
  std::ostringstream s;
  open_svg(s, p.width_px, p.height_px);
  // Legend to the right of the plot area, 200 px wide.
  Frame f{62, 26, p.width_px - 62.0 - 200.0, p.height_px - 26.0 - 44.0, 0, 1, 0, 1};
  double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
  for (const auto& ser : p.series)
    for (std::size_t i = 0; i < std::min(ser.x.size(), ser.y.size()); ++i) {
      if (!std::isfinite(ser.x[i]) || !std::isfinite(ser.y[i])) continue;
      x0 = std::min(x0, ser.x[i]);
      x1 = std::max(x1, ser.x[i]);
      y0 = std::min(y0, ser.y[i]);
      y1 = std::max(y1, ser.y[i]);
    }
  const bool empty = !(x1 >= x0);
  if (!empty) {
    if (std::isfinite(p.goal_y)) {
      y0 = std::min(y0, p.goal_y);
      y1 = std::max(y1, p.goal_y);
    }
    if (p.y_from_zero) {
      y0 = std::min(y0, 0.0);
      y1 = std::max(y1, 0.0);
    }
    widen(x0, x1);
    widen(y0, y1);
    y1 += (y1 - y0) * 0.05;  // headroom
    f.x0 = x0, f.x1 = x1, f.y0 = y0, f.y1 = y1;
  }
  draw_axes(s, f, p.title, p.x_label, p.y_label);
  if (empty) {
    no_data(s, f);
    s << "</svg>\n";
    return s.str();
  }
  // Ids are global in an HTML page holding several plots: one per title.
  const std::string clip = "clip" + std::to_string(std::hash<std::string>{}(p.title) % 1000000007u);
  s << "<clipPath id=\"" << clip << "\"><rect x=\"" << num(f.left) << "\" y=\"" << num(f.top) << "\" width=\""
    << num(f.width) << "\" height=\"" << num(f.height) << "\"/></clipPath>\n";
  int legend_row = 0;
  for (std::size_t k = 0; k < p.series.size(); ++k) {
    const auto& ser = p.series[k];
    const std::string colour = ser.colour.empty() ? kPalette[k % 8] : ser.colour;
    // One polyline per run of finite points: gaps stay gaps.
    std::string pts;
    int run = 0;
    auto flush = [&] {
      if (run == 1)  // an isolated point is drawn as a dot
        s << "<circle r=\"1.8\" fill=\"" << colour << "\" cx=\""
          << pts.substr(0, pts.find(',')) << "\" cy=\"" << pts.substr(pts.find(',') + 1) << "\"/>\n";
      else if (run > 1)
        s << "<polyline clip-path=\"url(#" << clip << ")\" fill=\"none\" stroke=\"" << colour
          << "\" stroke-width=\"1.4\" points=\"" << pts << "\"/>\n";
      pts.clear();
      run = 0;
    };
    for (std::size_t i = 0; i < std::min(ser.x.size(), ser.y.size()); ++i) {
      if (!std::isfinite(ser.x[i]) || !std::isfinite(ser.y[i])) {
        flush();
        continue;
      }
      if (run) pts += ' ';
      pts += num(f.px(ser.x[i])) + "," + num(f.py(ser.y[i]));
      ++run;
    }
    flush();
    const double ly = f.top + 10 + 18 * legend_row++;
    const double lx = f.left + f.width + 12;
    s << "<line x1=\"" << num(lx) << "\" y1=\"" << num(ly) << "\" x2=\"" << num(lx + 18)
      << "\" y2=\"" << num(ly) << "\" stroke=\"" << colour << "\" stroke-width=\"2\"/>\n"
      << "<text x=\"" << num(lx + 24) << "\" y=\"" << num(ly + 4) << "\">"
      << html_escape(ser.label) << "</text>\n";
  }
  if (std::isfinite(p.goal_y)) {
    const double y = f.py(p.goal_y);
    s << "<line x1=\"" << num(f.left) << "\" y1=\"" << num(y) << "\" x2=\"" << num(f.left + f.width)
      << "\" y2=\"" << num(y) << "\" stroke=\"#B00\" stroke-dasharray=\"6 4\"/>\n";
    const double ly = f.top + 10 + 18 * legend_row++;
    const double lx = f.left + f.width + 12;
    s << "<line x1=\"" << num(lx) << "\" y1=\"" << num(ly) << "\" x2=\"" << num(lx + 18)
      << "\" y2=\"" << num(ly) << "\" stroke=\"#B00\" stroke-dasharray=\"6 4\"/>\n"
      << "<text x=\"" << num(lx + 24) << "\" y=\"" << num(ly + 4) << "\">"
      << html_escape(p.goal_label.empty() ? "goal" : p.goal_label) << "</text>\n";
  }
  s << "</svg>\n";
  return s.str();
}

std::string svg_histogram(const Histogram& h) {
  std::ostringstream s;
  open_svg(s, h.width_px, h.height_px);
  Frame f{56, 26, h.width_px - 56.0 - 12.0, h.height_px - 26.0 - 74.0, 0, 1, 0, 1};
  std::vector<double> v;
  for (double x : h.samples)
    if (std::isfinite(x)) v.push_back(x);
  if (v.empty() || h.bins < 1) {
    draw_axes(s, f, h.title, h.x_label, "frames");
    no_data(s, f);
    s << "</svg>\n";
    return s.str();
  }
  double lo = percentile(v, 0.5), hi = percentile(v, 99.5);
  widen(lo, hi);
  std::vector<int> count(static_cast<std::size_t>(h.bins), 0);
  int clamped = 0;
  for (double x : v) {
    if (x < lo || x > hi) ++clamped;
    const double t = (std::clamp(x, lo, hi) - lo) / (hi - lo);
    const int b = std::min(h.bins - 1, static_cast<int>(t * h.bins));
    ++count[static_cast<std::size_t>(b)];
  }
  const int top = *std::max_element(count.begin(), count.end());
  f.x0 = lo, f.x1 = hi, f.y0 = 0, f.y1 = top * 1.08;
  draw_axes(s, f, h.title, h.x_label, "frames");
  const double bw = f.width / h.bins;
  for (int b = 0; b < h.bins; ++b) {
    const int c = count[static_cast<std::size_t>(b)];
    if (!c) continue;
    const double y = f.py(c);
    s << "<rect x=\"" << num(f.left + b * bw + 0.5) << "\" y=\"" << num(y) << "\" width=\""
      << num(std::max(0.5, bw - 1.0)) << "\" height=\"" << num(f.top + f.height - y)
      << "\" fill=\"#0072B2\"/>\n";
  }
  const double med = percentile(v, 50), p99 = percentile(v, 99);
  for (auto [val, colour, name] : {std::tuple{med, "#009E73", "median"}, std::tuple{p99, "#D55E00", "p99"}}) {
    const double x = f.px(std::clamp(val, lo, hi));
    s << "<line x1=\"" << num(x) << "\" y1=\"" << num(f.top) << "\" x2=\"" << num(x) << "\" y2=\""
      << num(f.top + f.height) << "\" stroke=\"" << colour << "\" stroke-width=\"2\"/>\n";
    (void)name;
  }
  char cap[160];
  std::snprintf(cap, sizeof cap, "median %.3g (green), p99 %.3g (red), n = %zu", med, p99, v.size());
  s << "<text x=\"" << num(f.left) << "\" y=\"" << num(f.top + f.height + 50) << "\" fill=\"#333\">"
    << html_escape(cap) << "</text>\n";
  if (clamped)
    s << "<text x=\"" << num(f.left) << "\" y=\"" << num(f.top + f.height + 66)
      << "\" fill=\"#333\">" << clamped << " outliers clamped to the end bins</text>\n";
  s << "</svg>\n";
  return s.str();
}

}  // namespace dentar::ar
