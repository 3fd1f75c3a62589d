#include "dentar/ar/tag_edge_fit.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>

namespace dentar::ar {

namespace {

// Light at (x, y) (the grey levels through lin, or as they are), bilinear; false off the image.
bool sample(const cv::Mat& g, const std::array<double, 256>* lin, double x, double y, double& v) {
  if (!(x >= 0 && y >= 0 && x < g.cols - 1 && y < g.rows - 1)) return false;
  const int ix = static_cast<int>(x), iy = static_cast<int>(y);
  const double fx = x - ix, fy = y - iy;
  const std::uint8_t* r0 = g.ptr<std::uint8_t>(iy) + ix;
  const std::uint8_t* r1 = g.ptr<std::uint8_t>(iy + 1) + ix;
  if (lin == nullptr) {
    v = (1 - fy) * ((1 - fx) * r0[0] + fx * r0[1]) + fy * ((1 - fx) * r1[0] + fx * r1[1]);
  } else {
    const auto& L = *lin;
    v = (1 - fy) * ((1 - fx) * L[r0[0]] + fx * L[r0[1]]) + fy * ((1 - fx) * L[r1[0]] + fx * L[r1[1]]);
  }
  return true;
}

struct Line {
  Eigen::Vector2d p0 = Eigen::Vector2d::Zero(), dir = Eigen::Vector2d::UnitX();
  double rms_px = 0;
};

// One side from a to b, outward normal n (see the header). false: too few edge points.
bool fit_side(const cv::Mat& g, const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& n,
              bool inside_bright, double reach, double max_lobe_px, const TagEdgeFitOptions& o,
              const std::array<double, 256>* lin, Line& out) {
  const int np = o.samples_per_side;
  constexpr double kStep = 0.5;  // px along the normal
  const int half = static_cast<int>(std::ceil((reach + 2) / kStep));
  const int len = 2 * half + 1;
  std::vector<double> grad(static_cast<std::size_t>(np * len), 0.0);
  std::vector<char> valid(static_cast<std::size_t>(np * len), 0);
  const double sgn = inside_bright ? -1.0 : 1.0;  // the edge's expected sign of dI/dn (n outward)
  auto at = [&](int i, int j) { return static_cast<std::size_t>(i * len + j); };
  auto point = [&](int i) { return a + (0.2 + 0.6 * i / (np - 1)) * (b - a); };
  for (int i = 0; i < np; ++i) {
    const Eigen::Vector2d q = point(i);
    for (int j = 0; j < len; ++j) {
      const double d = (j - half) * kStep;
      const Eigen::Vector2d p0 = q + (d - 0.75) * n, p1 = q + (d + 0.75) * n;
      double v0 = 0, v1 = 0;
      if (!sample(g, lin, p0.x(), p0.y(), v0) || !sample(g, lin, p1.x(), p1.y(), v1)) continue;
      grad[at(i, j)] = sgn * (v1 - v0) / 1.5;
      valid[at(i, j)] = 1;
    }
  }
  // The side's offset: the largest summed gradient of the edge's sign within +-reach.
  const int lim = static_cast<int>(std::floor(reach / kStep));
  int best_j = -1;
  double best = 0;
  for (int j = half - lim; j <= half + lim; ++j) {
    double sum = 0;
    for (int i = 0; i < np; ++i) sum += std::max(0.0, grad[at(i, j)]);
    if (sum > best) {
      best = sum;
      best_j = j;
    }
  }
  if (best_j < 0) return false;
  std::vector<Eigen::Vector2d> pts;
  for (int i = 0; i < np; ++i) {
    // The lobe's peak within 2 px of the side's offset, then the lobe down to 30 % of it.
    int pk = -1;
    for (int j = std::max(0, best_j - 4); j <= std::min(len - 1, best_j + 4); ++j)
      if (valid[at(i, j)] && (pk < 0 || grad[at(i, j)] > grad[at(i, pk)])) pk = j;
    if (pk < 0 || grad[at(i, pk)] < o.min_gradient) continue;
    const double floor = 0.3 * grad[at(i, pk)];
    double w = 0, wd = 0;
    int j_lo = pk, j_hi = pk;
    for (int j = pk; j >= 0 && valid[at(i, j)] && grad[at(i, j)] >= floor; --j) {
      w += grad[at(i, j)];
      wd += grad[at(i, j)] * (j - half) * kStep;
      j_lo = j;
    }
    for (int j = pk + 1; j < len && valid[at(i, j)] && grad[at(i, j)] >= floor; ++j) {
      w += grad[at(i, j)];
      wd += grad[at(i, j)] * (j - half) * kStep;
      j_hi = j;
    }
    if ((j_hi - j_lo) * kStep > max_lobe_px) continue;  // blurred into the neighbouring rings
    pts.push_back(point(i) + (wd / w) * n);
  }
  for (int pass = 0; pass < 2; ++pass) {
    if (static_cast<int>(pts.size()) < o.min_points_per_side) return false;
    Eigen::Vector2d m = Eigen::Vector2d::Zero();
    for (const auto& p : pts) m += p;
    m /= static_cast<double>(pts.size());
    Eigen::Matrix2d C = Eigen::Matrix2d::Zero();
    for (const auto& p : pts) C += (p - m) * (p - m).transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(C);
    const Eigen::Vector2d dir = es.eigenvectors().col(1);
    const Eigen::Vector2d nn(-dir.y(), dir.x());
    double ss = 0;
    std::vector<Eigen::Vector2d> keep;
    for (const auto& p : pts) {
      const double r = nn.dot(p - m);
      ss += r * r;
      if (std::abs(r) <= 1.0) keep.push_back(p);
    }
    out.p0 = m;
    out.dir = dir;
    out.rms_px = std::sqrt(ss / static_cast<double>(pts.size()));
    if (keep.size() == pts.size()) break;
    pts = std::move(keep);
  }
  return static_cast<int>(pts.size()) >= o.min_points_per_side;
}

struct Rect2 {
  double x0 = 1e18, y0 = 1e18, x1 = -1e18, y1 = -1e18;
  void add(const Eigen::Vector2d& p) {
    x0 = std::min(x0, p.x());
    y0 = std::min(y0, p.y());
    x1 = std::max(x1, p.x());
    y1 = std::max(y1, p.y());
  }
};

double side_of(const std::array<Eigen::Vector2d, 4>& q) {
  double area2 = 0;
  for (std::size_t k = 0; k < 4; ++k) area2 += q[k].x() * q[(k + 1) % 4].y() - q[(k + 1) % 4].x() * q[k].y();
  return std::sqrt(std::abs(area2) / 2);
}

}  // namespace

std::string TagEdgeFitOptions::validate() const {
  std::ostringstream os;
  if (samples_per_side < 6 || samples_per_side > 100)
    os << "samples_per_side = " << samples_per_side << " must be in 6..100";
  else if (!(std::isfinite(min_gradient) && min_gradient > 0 && min_gradient <= 255))
    os << "min_gradient = " << min_gradient << " must be in (0, 255] grey levels per px";
  else if (!(std::isfinite(max_rms_px) && max_rms_px > 0 && max_rms_px <= 10))
    os << "max_rms_px = " << max_rms_px << " must be in (0, 10] px";
  else if (!(std::isfinite(max_shape_px) && max_shape_px > 0 && max_shape_px <= 100))
    os << "max_shape_px = " << max_shape_px << " must be in (0, 100] px";
  else if (!(std::isfinite(max_lobe_cells) && max_lobe_cells > 0 && max_lobe_cells <= 10))
    os << "max_lobe_cells = " << max_lobe_cells << " must be in (0, 10]";
  else if (min_points_per_side < 3 || min_points_per_side > samples_per_side)
    os << "min_points_per_side = " << min_points_per_side << " must be in 3..samples_per_side";
  return os.str();
}

const char* tag_edge_fit_status_name(TagEdgeFitStatus s) {
  switch (s) {
    case TagEdgeFitStatus::kFitted:
      return "fitted";
    case TagEdgeFitStatus::kAmbiguous:
      return "ambiguous";
    case TagEdgeFitStatus::kNoEdges:
      return "no edges";
    case TagEdgeFitStatus::kOffPrediction:
      return "off the prediction";
    case TagEdgeFitStatus::kBadInput:
      return "bad input";
  }
  return "?";
}

TagEdgeFit fit_tag_border(const cv::Mat& gray, const std::array<Eigen::Vector2d, 4>& predicted_px,
                          bool inside_bright, int border_cells, double reach_px, double outer_extent,
                          const std::vector<std::array<Eigen::Vector2d, 4>>& others_px,
                          const TagEdgeFitOptions& o, const std::array<double, 256>* to_linear) {
  TagEdgeFit r;
  auto bad = [&](const std::string& m) {
    r.status = TagEdgeFitStatus::kBadInput;
    r.message = "fit_tag_border: " + m;
    return r;
  };
  if (auto e = o.validate(); !e.empty()) return bad("options." + e);
  if (gray.empty() || gray.type() != CV_8UC1) return bad("the image must be 8-bit grey (CV_8UC1), non-empty");
  for (const auto& p : predicted_px)
    if (!p.allFinite()) return bad("a predicted corner is not finite");
  if (!(std::isfinite(reach_px) && reach_px > 0 && reach_px <= 1000))
    return bad("reach_px = " + std::to_string(reach_px) + " must be in (0, 1000]");
  if (!(std::isfinite(outer_extent) && outer_extent >= 0 && outer_extent <= 2))
    return bad("outer_extent = " + std::to_string(outer_extent) + " must be in [0, 2]");
  if (border_cells < 3 || border_cells > 100)
    return bad("border_cells = " + std::to_string(border_cells) + " must be in 3..100");
  const double side = side_of(predicted_px);
  if (!(side >= 4)) return bad("the predicted square's side " + std::to_string(side) + " px is under 4 px");
  // Ambiguity: another square's cells within the reach of this one's cells.
  Rect2 self;
  for (const auto& p : predicted_px) self.add(p);
  const double g_self = reach_px + outer_extent * side;
  for (const auto& q : others_px) {
    Rect2 other;
    for (const auto& p : q) other.add(p);
    const double g = g_self + outer_extent * side_of(q);
    if (self.x0 - g < other.x1 && other.x0 < self.x1 + g && self.y0 - g < other.y1 && other.y0 < self.y1 + g) {
      r.status = TagEdgeFitStatus::kAmbiguous;
      return r;
    }
  }
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  for (const auto& p : predicted_px) centre += 0.25 * p;
  std::array<Line, 4> lines;
  for (std::size_t k = 0; k < 4; ++k) {
    const Eigen::Vector2d& a = predicted_px[k];
    const Eigen::Vector2d& b = predicted_px[(k + 1) % 4];
    const Eigen::Vector2d u = (b - a).normalized();
    Eigen::Vector2d n(-u.y(), u.x());
    if (n.dot(0.5 * (a + b) - centre) < 0) n = -n;
    const bool ok = fit_side(gray, a, b, n, inside_bright, reach_px, o.max_lobe_cells * side / border_cells, o, to_linear,
                             lines[k]);
    r.side_rms_px[k] = lines[k].rms_px;
    if (!ok || lines[k].rms_px > o.max_rms_px) {
      r.status = TagEdgeFitStatus::kNoEdges;
      return r;
    }
  }
  // Corner k lies on side k-1 (corner k-1 -> k) and side k (k -> k+1).
  for (std::size_t k = 0; k < 4; ++k) {
    const Line& s0 = lines[(k + 3) % 4];
    const Line& s1 = lines[k];
    Eigen::Matrix2d A;
    A.col(0) = s0.dir;
    A.col(1) = -s1.dir;
    if (std::abs(A.determinant()) < 0.2) {  // sides within ~12 deg of parallel
      r.status = TagEdgeFitStatus::kNoEdges;
      return r;
    }
    const Eigen::Vector2d st = A.partialPivLu().solve(s1.p0 - s0.p0);
    r.corners_px[k] = s0.p0 + st.x() * s0.dir;
  }
  Eigen::Vector2d shift = Eigen::Vector2d::Zero();
  for (std::size_t k = 0; k < 4; ++k) shift += 0.25 * (r.corners_px[k] - predicted_px[k]);
  double shape = 0;
  for (std::size_t k = 0; k < 4; ++k) shape = std::max(shape, (r.corners_px[k] - predicted_px[k] - shift).norm());
  r.shift_px = shift.norm();
  r.shape_px = shape;
  r.status = r.shift_px > reach_px || shape > o.max_shape_px ? TagEdgeFitStatus::kOffPrediction
                                                               : TagEdgeFitStatus::kFitted;
  return r;
}

}  // namespace dentar::ar
