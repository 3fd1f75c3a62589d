#include "dentar/calibration/response.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>

namespace dentar::calibration {

double srgb_to_linear(double u) {
  u = std::clamp(u, 0.0, 1.0);
  return u <= 0.04045 ? u / 12.92 : std::pow((u + 0.055) / 1.055, 2.4);
}

namespace {

// One edge: the squares' codes, and the pixels (4 codes, bilinear weights) of the samples
// along it. The interpolation is done in linear light for each candidate response (an
// edge's code is not the code-space average of its neighbours: that would pull every
// response toward linear).
struct Edge {
  double lo, hi;  // codes / 255
  std::vector<std::array<std::uint8_t, 4>> px;
  std::vector<std::array<float, 4>> w;
  int view;
};

// A response as a table: code -> linear light.
using Table = std::array<double, 256>;
Table gamma_table(double g) {
  Table t;
  for (int i = 0; i < 256; ++i) t[static_cast<std::size_t>(i)] = std::pow(i / 255.0, g);
  return t;
}
Table srgb_table() {
  Table t;
  for (int i = 0; i < 256; ++i) t[static_cast<std::size_t>(i)] = srgb_to_linear(i / 255.0);
  return t;
}
// Linear light at the edge relative to the squares': 0.5 when the response is right.
double edge_fraction(const Edge& e, const Table& t) {
  auto lin = [&](double code01) {  // the squares' median codes are not integers: interpolate
    const double c = std::clamp(code01 * 255, 0.0, 255.0);
    const int i = std::min(254, static_cast<int>(c));
    return t[static_cast<std::size_t>(i)] + (c - i) * (t[static_cast<std::size_t>(i + 1)] - t[static_cast<std::size_t>(i)]);
  };
  const double lo = lin(e.lo), hi = lin(e.hi);
  double sum = 0;
  for (std::size_t k = 0; k < e.px.size(); ++k)
    for (int j = 0; j < 4; ++j) sum += e.w[k][static_cast<std::size_t>(j)] * t[e.px[k][static_cast<std::size_t>(j)]];
  return (sum / static_cast<double>(e.px.size()) - lo) / (hi - lo);
}

// Bilinear sample, NaN outside.
double sample(const ResponseView& v, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= v.width || y0 + 1 >= v.height) return NAN;
  const double a = x - x0, b = y - y0;
  const std::uint8_t* r0 = v.gray + static_cast<std::ptrdiff_t>(y0) * v.stride_bytes;
  const std::uint8_t* r1 = r0 + v.stride_bytes;
  return (1 - b) * ((1 - a) * r0[x0] + a * r0[x0 + 1]) + b * ((1 - a) * r1[x0] + a * r1[x0 + 1]);
}

struct P {
  double x, y;
};

// Median code near the centre of the square with corners a b c d (in order around it).
double square_level(const ResponseView& v, P a, P b, P c, P d) {
  double s[9];
  int n = 0;
  for (double u : {0.35, 0.5, 0.65})
    for (double w : {0.35, 0.5, 0.65}) {
      // Bilinear in the corners: a (0,0), b (1,0), c (1,1), d (0,1).
      const double x = (1 - u) * (1 - w) * a.x + u * (1 - w) * b.x + u * w * c.x + (1 - u) * w * d.x;
      const double y = (1 - u) * (1 - w) * a.y + u * (1 - w) * b.y + u * w * c.y + (1 - u) * w * d.y;
      const double q = sample(v, x, y);
      if (std::isnan(q)) return NAN;
      s[n++] = q;
    }
  std::nth_element(s, s + 4, s + 9);
  return s[4];
}

double sse_gamma(const std::vector<Edge>& e, double g, int skip_view) {
  const Table t = gamma_table(g);
  double s = 0;
  for (const Edge& x : e)
    if (x.view != skip_view) {
      const double r = edge_fraction(x, t) - 0.5;
      s += r * r;
    }
  return s;
}

// Golden-section search of the gamma in [0.3, 4] (SSE is unimodal in gamma: t_pred rises
// monotonically with gamma).
double fit_gamma(const std::vector<Edge>& e, int skip_view) {
  double a = 0.3, b = 4.0;
  const double r = (std::sqrt(5.0) - 1) / 2;
  double c = b - r * (b - a), d = a + r * (b - a);
  double fc = sse_gamma(e, c, skip_view), fd = sse_gamma(e, d, skip_view);
  for (int i = 0; i < 60; ++i) {
    if (fc < fd) {
      b = d;
      d = c;
      fd = fc;
      c = b - r * (b - a);
      fc = sse_gamma(e, c, skip_view);
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + r * (b - a);
      fd = sse_gamma(e, d, skip_view);
    }
  }
  return 0.5 * (a + b);
}

double median_of(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace

ResponseEstimate estimate_response_chessboard(const std::vector<ResponseView>& views, int cols,
                                              int rows) {
  ResponseEstimate out;
  if (cols < 3 || rows < 3) {
    out.message = "the chessboard needs at least 3x3 inner corners to measure the response";
    return out;
  }
  std::vector<Edge> edges;
  std::vector<double> los, his;
  int candidates = 0;
  std::vector<int> view_edges(views.size(), 0);
  for (std::size_t vi = 0; vi < views.size(); ++vi) {
    const ResponseView& v = views[vi];
    if (v.gray == nullptr || v.width < 8 || v.height < 8 || v.stride_bytes < v.width ||
        v.corners_xy.size() != static_cast<std::size_t>(2 * cols * rows))
      continue;
    auto at = [&](int r, int c) {
      const std::size_t i = static_cast<std::size_t>(2 * (r * cols + c));
      return P{v.corners_xy[i], v.corners_xy[i + 1]};
    };
    // One edge from corner p to corner q between the squares (p q q2 p2) and (p q q3 p3).
    auto add = [&](P p, P q, P p2, P q2, P p3, P q3) {
      ++candidates;
      const double l1 = square_level(v, p, q, q2, p2), l2 = square_level(v, p, q, q3, p3);
      if (std::isnan(l1) || std::isnan(l2)) return;
      const double lo = std::min(l1, l2), hi = std::max(l1, l2);
      los.push_back(lo);
      his.push_back(hi);
      if (lo <= 3 || hi >= 250) {
        ++out.edges_clipped;
        return;
      }
      if (hi - lo < 20) {
        ++out.edges_flat;
        return;
      }
      Edge e{lo / 255, hi / 255, {}, {}, static_cast<int>(vi)};
      for (double f = 0.25; f <= 0.75 + 1e-9; f += 0.05) {
        const double x = p.x + f * (q.x - p.x), y = p.y + f * (q.y - p.y);
        const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
        if (x0 < 0 || y0 < 0 || x0 + 1 >= v.width || y0 + 1 >= v.height) return;
        const double a = x - x0, b = y - y0;
        const std::uint8_t* r0 = v.gray + static_cast<std::ptrdiff_t>(y0) * v.stride_bytes;
        const std::uint8_t* r1 = r0 + v.stride_bytes;
        e.px.push_back({r0[x0], r0[x0 + 1], r1[x0], r1[x0 + 1]});
        e.w.push_back({static_cast<float>((1 - a) * (1 - b)), static_cast<float>(a * (1 - b)),
                       static_cast<float>((1 - a) * b), static_cast<float>(a * b)});
      }
      edges.push_back(std::move(e));
      ++view_edges[vi];
    };
    for (int r = 1; r + 1 < rows; ++r)
      for (int c = 0; c + 1 < cols; ++c)
        add(at(r, c), at(r, c + 1), at(r - 1, c), at(r - 1, c + 1), at(r + 1, c), at(r + 1, c + 1));
    for (int c = 1; c + 1 < cols; ++c)
      for (int r = 0; r + 1 < rows; ++r)
        add(at(r, c), at(r + 1, c), at(r, c - 1), at(r + 1, c - 1), at(r, c + 1), at(r + 1, c + 1));
  }
  out.median_lo = median_of(los);
  out.median_hi = median_of(his);
  out.edges = static_cast<int>(edges.size());
  for (int n : view_edges) out.views += n > 0 ? 1 : 0;
  std::ostringstream os;
  os.setf(std::ios::fixed);
  os.precision(0);
  if (candidates > 0 && out.edges_clipped * 2 > candidates) {
    os << "the board is saturated: " << out.edges_clipped << " of " << candidates
       << " edges have a square clipped at black (<= 3) or white (>= 250) (median black "
       << out.median_lo << ", white " << out.median_hi
       << "); lower the exposure or the light and take the views again";
    out.message = os.str();
    return out;
  }
  if (candidates > 0 && out.edges_flat * 2 > candidates) {
    os << "the board is flat: its black and white squares differ by under 20 grey levels on "
       << out.edges_flat << " of " << candidates << " edges (median black " << out.median_lo
       << ", white " << out.median_hi
       << "); light the board evenly and use a printed black-and-white board";
    out.message = os.str();
    return out;
  }
  if (out.views < 3 || out.edges < 60) {
    os << "too few usable board edges to measure the response: " << out.edges << " edges in "
       << out.views << " views (need 60 in 3; " << out.edges_clipped << " clipped, "
       << out.edges_flat << " flat)";
    out.message = os.str();
    return out;
  }
  out.gamma = fit_gamma(edges, -1);
  // Jackknife over views.
  std::vector<double> g;
  for (std::size_t vi = 0; vi < views.size(); ++vi)
    if (view_edges[vi] > 0) g.push_back(fit_gamma(edges, static_cast<int>(vi)));
  double mean = 0;
  for (double x : g) mean += x / static_cast<double>(g.size());
  double ss = 0;
  for (double x : g) ss += (x - mean) * (x - mean);
  const double n = static_cast<double>(g.size());
  out.gamma_sigma = std::sqrt((n - 1) / n * ss);
  double sg = 0, sl = 0, ssr = 0;
  const Table tg = gamma_table(out.gamma), tl = gamma_table(1.0), ts = srgb_table();
  for (const Edge& e : edges) {
    const double rg = edge_fraction(e, tg) - 0.5, rl = edge_fraction(e, tl) - 0.5,
                 rs = edge_fraction(e, ts) - 0.5;
    sg += rg * rg;
    sl += rl * rl;
    ssr += rs * rs;
  }
  const double m = static_cast<double>(edges.size());
  out.rms_gamma = std::sqrt(sg / m);
  out.rms_linear = std::sqrt(sl / m);
  out.rms_srgb = std::sqrt(ssr / m);
  const double tol = 1.05 * out.rms_gamma + 0.002;
  if (out.rms_srgb <= tol && out.rms_srgb <= out.rms_linear)
    out.named = "srgb";
  else if (out.rms_linear <= tol)
    out.named = "linear";
  out.ok = true;
  return out;
}

std::string CameraResponseCurve::validate(const std::string& field) const {
  if (kind.empty() || kind == "linear" || kind == "srgb") {
    if (!table.empty()) return field + ".curve is only allowed with kind \"curve\"";
  } else if (kind == "curve") {
    if (table.size() != 256)
      return field + ".curve has " + std::to_string(table.size()) +
             " entries; it must have 256 (one per 8-bit grey code)";
    for (std::size_t i = 0; i < table.size(); ++i) {
      if (!std::isfinite(table[i]) || table[i] < 0 || table[i] > 1) {
        std::ostringstream os;
        os << field << ".curve[" << i << "] = " << table[i] << " must be in [0, 1]";
        return os.str();
      }
      if (i > 0 && table[i] < table[i - 1]) {
        std::ostringstream os;
        os << field << ".curve[" << i << "] = " << table[i] << " is below curve[" << i - 1
           << "] = " << table[i - 1] << ": the curve must not decrease (not monotonic)";
        return os.str();
      }
    }
    if (!(table[255] > table[0])) return field + ".curve is flat: curve[255] must exceed curve[0]";
  } else {
    return field + ".kind \"" + kind + "\" must be \"linear\", \"srgb\" or \"curve\"";
  }
  if (!std::isfinite(gamma) || gamma < 0 || gamma > 10)
    return field + ".gamma must be in [0, 10]";
  if (!std::isfinite(gamma_sigma) || gamma_sigma < -1 || gamma_sigma > 10)
    return field + ".gamma_sigma must be in [0, 10] (or absent)";
  if (views < 0 || edges < 0) return field + ".views and .edges must be >= 0";
  return {};
}

CameraResponseCurve response_from_estimate(const ResponseEstimate& e) {
  CameraResponseCurve c;
  if (!e.ok) return c;
  c.gamma = e.gamma;
  c.gamma_sigma = e.gamma_sigma;
  c.views = e.views;
  c.edges = e.edges;
  if (!e.named.empty()) {
    c.kind = e.named;
    return c;
  }
  c.kind = "curve";
  c.table.resize(256);
  for (int i = 0; i < 256; ++i) c.table[static_cast<std::size_t>(i)] = std::pow(i / 255.0, e.gamma);
  return c;
}

}  // namespace dentar::calibration
