#include "dentar/ar/tag_pattern_fit.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/imgproc.hpp>
#include <sstream>

namespace dentar::ar {

namespace {

using Corners = std::array<Eigen::Vector2d, 4>;

// The homography mapping image px to the tag's cell coordinates (X right, Y down, cell (r, c)
// spans [c, c+1] x [r, r+1]) for the four corners q (libapriltag's order). false when the
// four points are degenerate.
bool cell_homography(const Corners& q, int b0, int wb, Eigen::Matrix3d& G) {
  const double lo = b0, hi = b0 + wb;
  const double X[4] = {lo, hi, hi, lo}, Y[4] = {hi, hi, lo, lo};
  Eigen::Matrix<double, 8, 8> A;
  Eigen::Matrix<double, 8, 1> rhs;
  for (int k = 0; k < 4; ++k) {
    const double x = q[static_cast<std::size_t>(k)].x(), y = q[static_cast<std::size_t>(k)].y();
    A.row(2 * k) << x, y, 1, 0, 0, 0, -X[k] * x, -X[k] * y;
    A.row(2 * k + 1) << 0, 0, 0, x, y, 1, -Y[k] * x, -Y[k] * y;
    rhs(2 * k) = X[k];
    rhs(2 * k + 1) = Y[k];
  }
  Eigen::FullPivLU<Eigen::Matrix<double, 8, 8>> lu(A);
  if (!lu.isInvertible()) return false;
  const Eigen::Matrix<double, 8, 1> h = lu.solve(rhs);
  if (!h.allFinite()) return false;
  G << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), 1.0;
  return true;
}

// cell_homography and the derivative of its 8 entries h (G = [h0 h1 h2; h3 h4 h5; h6 h7 1])
// with respect to the 8 corner coordinates (column 2k: x of corner k, 2k + 1: its y): from
// A(q) h = rhs, dh = -A^-1 (dA/dq_j) h, and dA/dq_j touches only rows 2k and 2k + 1.
bool cell_homography_d(const Corners& q, int b0, int wb, Eigen::Matrix3d& G, Eigen::Matrix<double, 8, 8>& dh) {
  const double lo = b0, hi = b0 + wb;
  const double X[4] = {lo, hi, hi, lo}, Y[4] = {hi, hi, lo, lo};
  Eigen::Matrix<double, 8, 8> A;
  Eigen::Matrix<double, 8, 1> rhs;
  for (int k = 0; k < 4; ++k) {
    const double x = q[static_cast<std::size_t>(k)].x(), y = q[static_cast<std::size_t>(k)].y();
    A.row(2 * k) << x, y, 1, 0, 0, 0, -X[k] * x, -X[k] * y;
    A.row(2 * k + 1) << 0, 0, 0, x, y, 1, -Y[k] * x, -Y[k] * y;
    rhs(2 * k) = X[k];
    rhs(2 * k + 1) = Y[k];
  }
  Eigen::FullPivLU<Eigen::Matrix<double, 8, 8>> lu(A);
  if (!lu.isInvertible()) return false;
  const Eigen::Matrix<double, 8, 1> h = lu.solve(rhs);
  if (!h.allFinite()) return false;
  G << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), 1.0;
  Eigen::Matrix<double, 8, 8> E = Eigen::Matrix<double, 8, 8>::Zero();  // column j: (dA/dq_j) h
  for (int k = 0; k < 4; ++k) {
    E(2 * k, 2 * k) = h(0) - X[k] * h(6);
    E(2 * k + 1, 2 * k) = h(3) - Y[k] * h(6);
    E(2 * k, 2 * k + 1) = h(1) - X[k] * h(7);
    E(2 * k + 1, 2 * k + 1) = h(4) - Y[k] * h(7);
  }
  dh = -lu.solve(E);
  return dh.allFinite();
}

double side_of(const Corners& q) {
  double area2 = 0;
  for (std::size_t k = 0; k < 4; ++k) area2 += q[k].x() * q[(k + 1) % 4].y() - q[(k + 1) % 4].x() * q[k].y();
  return std::sqrt(std::abs(area2) / 2);
}

struct Box {
  double x0 = 1e18, y0 = 1e18, x1 = -1e18, y1 = -1e18;
  void add(const Eigen::Vector2d& p) {
    x0 = std::min(x0, p.x());
    y0 = std::min(y0, p.y());
    x1 = std::max(x1, p.x());
    y1 = std::max(y1, p.y());
  }
  void grow(double g) {
    x0 -= g;
    y0 -= g;
    x1 += g;
    y1 += g;
  }
  bool overlaps(const Box& o) const { return x0 < o.x1 && o.x0 < x1 && y0 < o.y1 && o.y0 < y1; }
};

// The model: the cell pattern (with its half-cell white margin) as a smoothed texture,
// sampled through the homographies of the exposure's subsample times.
struct Model {
  int tw = 0, b0 = 0, wb = 0;
  static constexpr int kTexPerCell = 8;
  cv::Mat tex;  // CV_32F, (tw + 1) x kTexPerCell texels a side, values 0 (black) .. 1 (white)
  Corners blur{};
  int S = 1;  // subsamples

  void build(const cv::Mat& cells, double cell_px, double optics_sigma_px) {
    tw = cells.rows;
    const int n = (tw + 1) * kTexPerCell;
    tex = cv::Mat(n, n, CV_32F, cv::Scalar(1.0f));
    for (int r = 0; r < tw; ++r)
      for (int c = 0; c < tw; ++c)
        tex(cv::Rect(kTexPerCell / 2 + c * kTexPerCell, kTexPerCell / 2 + r * kTexPerCell, kTexPerCell, kTexPerCell))
            .setTo(cells.at<std::uint8_t>(r, c) > 127 ? 1.0 : 0.0);
    const double sigma = std::max(0.5, kTexPerCell * optics_sigma_px / std::max(cell_px, 1e-3));
    cv::GaussianBlur(tex, tex, cv::Size(0, 0), sigma, sigma, cv::BORDER_REPLICATE);
  }
  // Cell coordinates -> texture value (bilinear, clamped).
  double at(double X, double Y) const {
    const double u = std::clamp((X + 0.5) * kTexPerCell - 0.5, 0.0, tex.cols - 1.001);
    const double v = std::clamp((Y + 0.5) * kTexPerCell - 0.5, 0.0, tex.rows - 1.001);
    const int iu = static_cast<int>(u), iv = static_cast<int>(v);
    const double fu = u - iu, fv = v - iv;
    const float* r0 = tex.ptr<float>(iv) + iu;
    const float* r1 = tex.ptr<float>(iv + 1) + iu;
    return (1 - fv) * ((1 - fu) * r0[0] + fu * r0[1]) + fv * ((1 - fu) * r1[0] + fu * r1[1]);
  }
  // at() and its derivative in cell coordinates (of the bilinear interpolant; zero where clamped).
  double at_d(double X, double Y, double& dX, double& dY) const {
    const double u_raw = (X + 0.5) * kTexPerCell - 0.5, v_raw = (Y + 0.5) * kTexPerCell - 0.5;
    const double u = std::clamp(u_raw, 0.0, tex.cols - 1.001), v = std::clamp(v_raw, 0.0, tex.rows - 1.001);
    const int iu = static_cast<int>(u), iv = static_cast<int>(v);
    const double fu = u - iu, fv = v - iv;
    const float* r0 = tex.ptr<float>(iv) + iu;
    const float* r1 = tex.ptr<float>(iv + 1) + iu;
    const double top = (1 - fu) * r0[0] + fu * r0[1], bot = (1 - fu) * r1[0] + fu * r1[1];
    dX = u == u_raw ? kTexPerCell * ((1 - fv) * (r0[1] - r0[0]) + fv * (r1[1] - r1[0])) : 0.0;
    dY = v == v_raw ? kTexPerCell * (bot - top) : 0.0;
    return (1 - fv) * top + fv * bot;
  }
  double time_of(int s, int S_) const { return S_ == 1 ? 0.0 : -0.5 + static_cast<double>(s) / (S_ - 1); }
  // The homographies of the S_ subsample times for corners c. false: degenerate.
  bool homographies(const Corners& c, int S_, std::vector<Eigen::Matrix3d>& Gs) const {
    Gs.resize(static_cast<std::size_t>(S_));
    for (int s = 0; s < S_; ++s) {
      const double t = time_of(s, S_);
      Corners q;
      for (std::size_t k = 0; k < 4; ++k) q[k] = c[k] + t * blur[k];
      if (!cell_homography(q, b0, wb, Gs[static_cast<std::size_t>(s)])) return false;
    }
    return true;
  }
  // Model values at pixel centres px (OpenCV convention: pixel (i, j) centred at (i, j)).
  bool eval(const Corners& c, int S_, const std::vector<Eigen::Vector2d>& px, std::vector<double>& m) const {
    std::vector<Eigen::Matrix3d> Gs;
    if (!homographies(c, S_, Gs)) return false;
    m.assign(px.size(), 0.0);
    const double inv = 1.0 / S_;
    for (std::size_t i = 0; i < px.size(); ++i) {
      double acc = 0;
      for (const Eigen::Matrix3d& G : Gs) {
        const Eigen::Vector3d h = G * Eigen::Vector3d(px[i].x(), px[i].y(), 1.0);
        if (!(std::abs(h.z()) > 1e-12)) return false;
        acc += at(h.x() / h.z(), h.y() / h.z());
      }
      m[i] = acc * inv;
    }
    return true;
  }
  // eval() and the model's derivative with respect to the 8 corner coordinates, analytic (the
  // homography's derivative, the pattern's bilinear gradient): J row i = d m_i / d c.
  bool eval_jacobian(const Corners& c, int S_, const std::vector<Eigen::Vector2d>& px, std::vector<double>& m,
                     Eigen::MatrixXd& J) const {
    std::vector<Eigen::Matrix3d> Gs(static_cast<std::size_t>(S_));
    std::vector<Eigen::Matrix<double, 8, 8>> dhs(static_cast<std::size_t>(S_));
    for (int s = 0; s < S_; ++s) {
      const double t = time_of(s, S_);
      Corners q;
      for (std::size_t k = 0; k < 4; ++k) q[k] = c[k] + t * blur[k];
      if (!cell_homography_d(q, b0, wb, Gs[static_cast<std::size_t>(s)], dhs[static_cast<std::size_t>(s)])) return false;
    }
    m.assign(px.size(), 0.0);
    J.setZero(static_cast<Eigen::Index>(px.size()), 8);
    const double inv = 1.0 / S_;
    for (std::size_t i = 0; i < px.size(); ++i) {
      double acc = 0;
      Eigen::Matrix<double, 1, 8> row = Eigen::Matrix<double, 1, 8>::Zero();
      const double x = px[i].x(), y = px[i].y();
      for (std::size_t s = 0; s < Gs.size(); ++s) {
        const Eigen::Vector3d h = Gs[s] * Eigen::Vector3d(x, y, 1.0);
        if (!(std::abs(h.z()) > 1e-12)) return false;
        const double iz = 1.0 / h.z(), X = h.x() * iz, Y = h.y() * iz;
        double gX = 0, gY = 0;
        acc += at_d(X, Y, gX, gY);
        // d(value)/dh: gX dX/dh + gY dY/dh.
        Eigen::Matrix<double, 1, 8> dv;
        dv << gX * x * iz, gX * y * iz, gX * iz, gY * x * iz, gY * y * iz, gY * iz, -(gX * X + gY * Y) * x * iz,
            -(gX * X + gY * Y) * y * iz;
        row.noalias() += dv * dhs[s];
      }
      m[i] = acc * inv;
      J.row(static_cast<Eigen::Index>(i)) = row * inv;
    }
    return true;
  }
};

// Pixels (integer centres within the image, excluding its last row / column) whose every
// subsample time maps inside the pattern (cells plus margin) less `inset` cells, within box.
std::vector<Eigen::Vector2d> pixels_inside(const Model& M, const Corners& c, const cv::Mat& g, double inset) {
  std::vector<Eigen::Vector2d> out;
  std::vector<Eigen::Matrix3d> Gs;
  const int S_ = M.S == 1 ? 1 : 3;  // the exposure's ends and middle
  if (!M.homographies(c, S_, Gs)) return out;
  Box b;
  for (int s = 0; s < S_; ++s)
    for (std::size_t k = 0; k < 4; ++k) b.add(c[k] + M.time_of(s, S_) * M.blur[k]);
  const double ext = 0.5 * (M.tw - M.wb + 1) / M.wb * side_of(c) + 1;  // cells and margin beyond the square
  b.grow(ext);
  const int x0 = std::max(0, static_cast<int>(std::floor(b.x0))), y0 = std::max(0, static_cast<int>(std::floor(b.y0)));
  const int x1 = std::min(g.cols - 2, static_cast<int>(std::ceil(b.x1))),
            y1 = std::min(g.rows - 2, static_cast<int>(std::ceil(b.y1)));
  const double lo = -0.5 + inset, hi = M.tw + 0.5 - inset;
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      bool in = true;
      for (const Eigen::Matrix3d& G : Gs) {
        const Eigen::Vector3d h = G * Eigen::Vector3d(x, y, 1.0);
        const double X = h.x() / h.z(), Y = h.y() / h.z();
        if (!(h.z() > 0 || h.z() < 0) || !(X >= lo && X <= hi && Y >= lo && Y <= hi)) {
          in = false;
          break;
        }
      }
      if (in) out.emplace_back(x, y);
    }
  return out;
}

double linear_at(const cv::Mat& g, const std::array<double, 256>* lin, int x, int y) {
  const std::uint8_t v = g.at<std::uint8_t>(y, x);
  return lin ? (*lin)[v] : static_cast<double>(v);
}

// Weighted least squares of y on [1, m]: a, b and the weighted correlation.
void fit_ab(const std::vector<double>& y, const std::vector<double>& m, const std::vector<double>& w, double& a,
            double& b, double& corr) {
  double sw = 0, sy = 0, sm = 0;
  for (std::size_t i = 0; i < y.size(); ++i) {
    sw += w[i];
    sy += w[i] * y[i];
    sm += w[i] * m[i];
  }
  const double my = sy / sw, mm = sm / sw;
  double cym = 0, cmm = 0, cyy = 0;
  for (std::size_t i = 0; i < y.size(); ++i) {
    cym += w[i] * (y[i] - my) * (m[i] - mm);
    cmm += w[i] * (m[i] - mm) * (m[i] - mm);
    cyy += w[i] * (y[i] - my) * (y[i] - my);
  }
  b = cmm > 1e-12 ? cym / cmm : 0.0;
  a = my - b * mm;
  corr = cmm > 1e-12 && cyy > 1e-12 ? cym / std::sqrt(cmm * cyy) : 0.0;
}

double cost(const std::vector<double>& y, const std::vector<double>& m, const std::vector<double>& w, double a,
            double b) {
  double c = 0;
  for (std::size_t i = 0; i < y.size(); ++i) {
    const double r = y[i] - a - b * m[i];
    c += w[i] * r * r;
  }
  return c;
}

// Huber weights for residuals of (a, b, m): 1 within k robust sigmas, k sigma / |r| beyond.
void huber(const std::vector<double>& y, const std::vector<double>& m, double a, double b, double k,
           std::vector<double>& w) {
  std::vector<double> ar(y.size());
  for (std::size_t i = 0; i < y.size(); ++i) ar[i] = std::abs(y[i] - a - b * m[i]);
  std::vector<double> tmp = ar;
  std::nth_element(tmp.begin(), tmp.begin() + static_cast<std::ptrdiff_t>(tmp.size() / 2), tmp.end());
  const double sigma = std::max(1.4826 * tmp[tmp.size() / 2], 1e-6 * std::max(1.0, std::abs(b)));
  w.resize(y.size());
  for (std::size_t i = 0; i < y.size(); ++i) w[i] = ar[i] <= k * sigma ? 1.0 : k * sigma / ar[i];
}

}  // namespace

std::string TagPatternFitOptions::validate() const {
  std::ostringstream os;
  if (max_iterations < 1 || max_iterations > 100)
    os << "max_iterations = " << max_iterations << " must be in 1..100";
  else if (!(std::isfinite(optics_sigma_px) && optics_sigma_px >= 0 && optics_sigma_px <= 5))
    os << "optics_sigma_px = " << optics_sigma_px << " must be in [0, 5] px";
  else if (!(std::isfinite(subsample_px) && subsample_px >= 0.25 && subsample_px <= 10))
    os << "subsample_px = " << subsample_px << " must be in [0.25, 10] px";
  else if (max_subsamples < 1 || max_subsamples > 101 || max_subsamples % 2 == 0)
    os << "max_subsamples = " << max_subsamples << " must be odd, 1..101";
  else if (!(std::isfinite(huber_sigmas) && huber_sigmas >= 0.5 && huber_sigmas <= 100))
    os << "huber_sigmas = " << huber_sigmas << " must be in [0.5, 100]";
  else if (!(std::isfinite(min_correlation) && min_correlation >= 0 && min_correlation <= 1))
    os << "min_correlation = " << min_correlation << " must be in [0, 1]";
  else if (!(std::isfinite(cell_confidence) && cell_confidence > 0 && cell_confidence < 0.5))
    os << "cell_confidence = " << cell_confidence << " must be in (0, 0.5) (of the contrast)";
  else if (max_wrong_cells < 0 || max_wrong_cells > 100)
    os << "max_wrong_cells = " << max_wrong_cells << " must be in 0..100";
  else if (min_right_cells < 0 || min_right_cells > 200)
    os << "min_right_cells = " << min_right_cells << " must be in 0..200";
  else if (!(std::isfinite(max_shape_px) && max_shape_px > 0 && max_shape_px <= 100))
    os << "max_shape_px = " << max_shape_px << " must be in (0, 100] px";
  else if (min_pixels < 10 || min_pixels > 100000)
    os << "min_pixels = " << min_pixels << " must be in 10..100000";
  return os.str();
}

const char* tag_pattern_fit_status_name(TagPatternFitStatus s) {
  switch (s) {
    case TagPatternFitStatus::kFitted:
      return "fitted";
    case TagPatternFitStatus::kOverlap:
      return "overlap";
    case TagPatternFitStatus::kNoFit:
      return "no fit";
    case TagPatternFitStatus::kWrongCells:
      return "wrong cells";
    case TagPatternFitStatus::kOffPrediction:
      return "off the prediction";
    case TagPatternFitStatus::kBadInput:
      return "bad input";
  }
  return "?";
}

TagPatternFit fit_tag_pattern(const cv::Mat& gray, const cv::Mat& cells, int border_start, int width_at_border,
                              const Corners& predicted_px, const Corners& blur_px, double reach_px, double outer_extent,
                              const std::vector<Corners>& others_px, const TagPatternFitOptions& o,
                              const std::array<double, 256>* to_linear) {
  TagPatternFit r;
  auto bad = [&](const std::string& m) {
    r.status = TagPatternFitStatus::kBadInput;
    r.message = "fit_tag_pattern: " + m;
    return r;
  };
  if (auto e = o.validate(); !e.empty()) return bad("options." + e);
  if (gray.empty() || gray.type() != CV_8UC1 || gray.cols < 4 || gray.rows < 4)
    return bad("the image must be 8-bit grey (CV_8UC1), at least 4 x 4");
  if (cells.empty() || cells.type() != CV_8UC1 || cells.rows != cells.cols || cells.rows < 3 || cells.rows > 64)
    return bad("cells must be a square CV_8UC1 grid of 3..64 cells (TagFamily::cells)");
  if (width_at_border < 3 || border_start < 0 || border_start + width_at_border > cells.rows)
    return bad("border_start = " + std::to_string(border_start) + ", width_at_border = " +
               std::to_string(width_at_border) + " do not fit a " + std::to_string(cells.rows) + "-cell grid");
  for (std::size_t k = 0; k < 4; ++k)
    if (!predicted_px[k].allFinite() || !blur_px[k].allFinite())
      return bad("a predicted corner or blur vector is not finite");
  if (!(std::isfinite(reach_px) && reach_px > 0 && reach_px <= 1000))
    return bad("reach_px = " + std::to_string(reach_px) + " must be in (0, 1000]");
  if (!(std::isfinite(outer_extent) && outer_extent >= 0 && outer_extent <= 2))
    return bad("outer_extent = " + std::to_string(outer_extent) + " must be in [0, 2]");
  const double side = side_of(predicted_px);
  if (!(side >= 4)) return bad("the predicted square's side " + std::to_string(side) + " px is under 4 px");
  double blur_len = 0;
  for (const auto& v : blur_px) blur_len = std::max(blur_len, v.norm());
  if (blur_len > 10 * side + 100) return bad("a blur vector of " + std::to_string(blur_len) + " px is implausible");

  // Overlap: this tag's cells swept over the exposure against another square's cells.
  {
    Box self;
    for (std::size_t k = 0; k < 4; ++k) {
      self.add(predicted_px[k] - 0.5 * blur_px[k]);
      self.add(predicted_px[k] + 0.5 * blur_px[k]);
    }
    self.grow(outer_extent * side);
    for (const auto& q : others_px) {
      Box other;
      for (const auto& p : q) other.add(p);
      other.grow(outer_extent * side_of(q));
      if (self.overlaps(other)) {
        r.status = TagPatternFitStatus::kOverlap;
        return r;
      }
    }
  }

  Model M;
  M.b0 = border_start;
  M.wb = width_at_border;
  M.blur = blur_px;
  const double cell_px = side / width_at_border;
  M.build(cells, cell_px, o.optics_sigma_px);
  {
    int S = static_cast<int>(std::ceil(blur_len / o.subsample_px));
    S = std::clamp(S | 1, 1, o.max_subsamples);
    M.S = S;
  }
  const int S_coarse = M.S == 1 ? 1 : std::max(3, (M.S / 3) | 1);

  // Grid search of the mean shift over +-reach (integer px, every other pixel when many).
  const double inset = 0.3;
  const std::vector<Eigen::Vector2d> base = pixels_inside(M, predicted_px, gray, inset);
  if (static_cast<int>(base.size()) < o.min_pixels) {
    r.status = TagPatternFitStatus::kNoFit;
    return r;
  }
  Corners c = predicted_px;
  {
    const int step = std::max(1, static_cast<int>(std::lround(std::max(0.5 * cell_px, 2 * reach_px / 12))));
    const int n = static_cast<int>(std::floor(reach_px / step));
    const std::size_t dec = base.size() > 600 ? 2 : 1;
    std::vector<Eigen::Vector2d> q0;
    for (std::size_t i = 0; i < base.size(); i += dec) q0.push_back(base[i]);
    std::vector<double> m, y(q0.size()), w(q0.size(), 1.0);
    double best = -2;
    Eigen::Vector2d best_t = Eigen::Vector2d::Zero();
    for (int iy = -n; iy <= n; ++iy)
      for (int ix = -n; ix <= n; ++ix) {
        const Eigen::Vector2d t(ix * step, iy * step);
        if (t.norm() > reach_px + 1e-9) continue;
        Corners ct;
        for (std::size_t k = 0; k < 4; ++k) ct[k] = predicted_px[k] + t;
        bool ok = true;
        for (std::size_t i = 0; i < q0.size() && ok; ++i) {
          const int x = static_cast<int>(q0[i].x()) + ix * step, yy = static_cast<int>(q0[i].y()) + iy * step;
          ok = x >= 0 && yy >= 0 && x < gray.cols - 1 && yy < gray.rows - 1;
          if (ok) y[i] = linear_at(gray, to_linear, x, yy);
        }
        if (!ok) continue;
        std::vector<Eigen::Vector2d> q(q0.size());
        for (std::size_t i = 0; i < q0.size(); ++i) q[i] = q0[i] + t;
        if (!M.eval(ct, S_coarse, q, m)) continue;
        double a = 0, b = 0, corr = 0;
        fit_ab(y, m, w, a, b, corr);
        if (b > 0 && corr > best) {
          best = corr;
          best_t = t;
        }
      }
    if (best <= 0) {
      r.status = TagPatternFitStatus::kNoFit;
      return r;
    }
    for (std::size_t k = 0; k < 4; ++k) c[k] += best_t;
  }

  // Gauss-Newton / Levenberg-Marquardt on the corners and (a, b), Huber weights.
  std::vector<Eigen::Vector2d> px = pixels_inside(M, c, gray, inset);
  if (static_cast<int>(px.size()) < o.min_pixels) {
    r.status = TagPatternFitStatus::kNoFit;
    return r;
  }
  Corners c_set = c;  // the corners the pixel set was chosen for
  std::vector<double> y, m, w;
  auto load = [&]() {
    y.resize(px.size());
    for (std::size_t i = 0; i < px.size(); ++i)
      y[i] = linear_at(gray, to_linear, static_cast<int>(px[i].x()), static_cast<int>(px[i].y()));
    w.assign(px.size(), 1.0);
  };
  load();
  if (!M.eval(c, M.S, px, m)) {
    r.status = TagPatternFitStatus::kNoFit;
    return r;
  }
  double a = 0, b = 0, corr = 0;
  fit_ab(y, m, w, a, b, corr);
  if (!(b > 0)) {
    r.status = TagPatternFitStatus::kNoFit;
    return r;
  }
  huber(y, m, a, b, o.huber_sigmas, w);
  double lambda = 1e-3;
  constexpr double kH = 0.2;  // px, the finite difference step
  int it = 0;
  std::vector<double> mp, mtry;
  Eigen::MatrixXd Jm;  // the model's analytic derivative (TagPatternFitOptions::numeric_jacobian off)
  // The last normal matrix J^T W J (corners, a, b) and its pixel count: the corners' stated sigma.
  Eigen::Matrix<double, 10, 10> H_last = Eigen::Matrix<double, 10, 10>::Zero();
  std::size_t N_last = 0;
  for (; it < o.max_iterations; ++it) {
    // Re-choose the pixels when the corners moved a third of a cell from where they were chosen.
    double moved = 0;
    for (std::size_t k = 0; k < 4; ++k) moved = std::max(moved, (c[k] - c_set[k]).norm());
    if (moved > cell_px / 3) {
      px = pixels_inside(M, c, gray, inset);
      if (static_cast<int>(px.size()) < o.min_pixels) break;
      c_set = c;
      load();
      if (!M.eval(c, M.S, px, m)) break;
      fit_ab(y, m, w, a, b, corr);
      huber(y, m, a, b, o.huber_sigmas, w);
    }
    const std::size_t N = px.size();
    Eigen::MatrixXd J(static_cast<Eigen::Index>(N), 10);
    if (o.numeric_jacobian) {
      for (int j = 0; j < 8; ++j) {
        Corners cp = c;
        cp[static_cast<std::size_t>(j / 2)][j % 2] += kH;
        if (!M.eval(cp, M.S, px, mp)) {
          r.status = TagPatternFitStatus::kNoFit;
          return r;
        }
        for (std::size_t i = 0; i < N; ++i) J(static_cast<Eigen::Index>(i), j) = b * (mp[i] - m[i]) / kH;
      }
    } else {
      if (!M.eval_jacobian(c, M.S, px, mp, Jm)) {
        r.status = TagPatternFitStatus::kNoFit;
        return r;
      }
      J.leftCols<8>() = b * Jm;
    }
    Eigen::VectorXd res(static_cast<Eigen::Index>(N)), sw(static_cast<Eigen::Index>(N));
    for (std::size_t i = 0; i < N; ++i) {
      const auto ii = static_cast<Eigen::Index>(i);
      J(ii, 8) = 1.0;
      J(ii, 9) = m[i];
      res(ii) = y[i] - a - b * m[i];
      sw(ii) = w[i];
    }
    const Eigen::MatrixXd Jw = sw.asDiagonal() * J;
    const Eigen::Matrix<double, 10, 10> H = J.transpose() * Jw;
    const Eigen::Matrix<double, 10, 1> gvec = Jw.transpose() * res;
    H_last = H;
    N_last = N;
    const double c0 = cost(y, m, w, a, b);
    bool improved = false;
    Eigen::Matrix<double, 10, 1> d = Eigen::Matrix<double, 10, 1>::Zero();
    for (int tries = 0; tries < 5 && !improved; ++tries) {
      Eigen::Matrix<double, 10, 10> A = H;
      for (int k = 0; k < 10; ++k) A(k, k) += lambda * std::max(H(k, k), 1e-9);
      d = A.ldlt().solve(gvec);
      if (!d.allFinite()) break;
      // At most one px per corner coordinate a step.
      const double big = d.head<8>().cwiseAbs().maxCoeff();
      if (big > 1.0) d *= 1.0 / big;
      Corners cn = c;
      for (int j = 0; j < 8; ++j) cn[static_cast<std::size_t>(j / 2)][j % 2] += d(j);
      if (!M.eval(cn, M.S, px, mtry)) {
        lambda *= 4;
        continue;
      }
      const double an = a + d(8), bn = b + d(9);
      if (cost(y, mtry, w, an, bn) < c0) {
        c = cn;
        m.swap(mtry);
        a = an;
        b = bn;
        improved = true;
        lambda = std::max(1e-6, lambda / 3);
      } else {
        lambda *= 4;
      }
    }
    if (!improved) break;
    huber(y, m, a, b, o.huber_sigmas, w);
    if (d.head<8>().cwiseAbs().maxCoeff() < 0.01) {
      ++it;
      break;
    }
  }
  r.iterations = it;
  r.corners_px = c;
  r.pixels = static_cast<int>(px.size());
  if (static_cast<int>(px.size()) < o.min_pixels || m.size() != px.size()) {
    r.status = TagPatternFitStatus::kNoFit;
    return r;
  }
  fit_ab(y, m, w, a, b, corr);
  r.brightness = a;
  r.contrast = b;
  r.correlation = corr;
  // The corners' stated sigma: the weighted residual variance times the inverse normal
  // matrix of the last step (TagPatternFit::corner_sigma_px; pixels taken as independent).
  if (N_last > 10 && N_last == px.size()) {
    const double s2 = cost(y, m, w, a, b) / static_cast<double>(N_last - 10);
    const Eigen::Matrix<double, 10, 10> C = H_last.ldlt().solve(Eigen::Matrix<double, 10, 10>::Identity());
    const double tr = C.diagonal().head<8>().sum();
    if (C.allFinite() && tr > 0) r.corner_sigma_px = std::sqrt(s2 * tr / 8);
  }
  if (!(b > 0)) {
    r.status = TagPatternFitStatus::kNoFit;
    return r;
  }

  // The cell check: every cell's albedo free over the fitted geometry (see the header).
  {
    const int tw = M.tw, nc = tw * tw + 1;  // + the margin
    std::vector<Eigen::Matrix3d> Gs;
    if (!M.homographies(c, M.S, Gs)) {
      r.status = TagPatternFitStatus::kNoFit;
      return r;
    }
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(nc, nc);
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(nc), support = Eigen::VectorXd::Zero(nc);
    std::vector<int> idx(Gs.size());
    for (std::size_t i = 0; i < px.size(); ++i) {
      for (std::size_t s = 0; s < Gs.size(); ++s) {
        const Eigen::Vector3d h = Gs[s] * Eigen::Vector3d(px[i].x(), px[i].y(), 1.0);
        const int cx = static_cast<int>(std::floor(h.x() / h.z())), cy = static_cast<int>(std::floor(h.y() / h.z()));
        idx[s] = cx >= 0 && cy >= 0 && cx < tw && cy < tw ? cy * tw + cx : tw * tw;
      }
      const double f = 1.0 / static_cast<double>(Gs.size());
      // Row of B: fractions per cell; accumulate w B^T B and w B^T y.
      for (std::size_t s = 0; s < Gs.size(); ++s) {
        rhs(idx[s]) += w[i] * f * y[i];
        support(idx[s]) += f;
        for (std::size_t t = 0; t < Gs.size(); ++t) A(idx[s], idx[t]) += w[i] * f * f;
      }
    }
    const double mid = a + 0.5 * b, ridge = 0.05 * cell_px * cell_px;
    for (int k = 0; k < nc; ++k) {
      A(k, k) += ridge;
      rhs(k) += ridge * mid;
    }
    const Eigen::VectorXd alpha = A.ldlt().solve(rhs);
    const double min_support = 0.3 * cell_px * cell_px;
    for (int k = 0; k < tw * tw && alpha.allFinite(); ++k) {
      if (support(k) < min_support) continue;
      const double dv = alpha(k) - mid;
      if (std::abs(dv) <= o.cell_confidence * b) continue;
      const bool white = cells.at<std::uint8_t>(k / tw, k % tw) > 127;
      if ((dv > 0) == white)
        ++r.right_cells;
      else
        ++r.wrong_cells;
    }
    if (!alpha.allFinite() || r.wrong_cells > o.max_wrong_cells || r.right_cells < o.min_right_cells ||
        corr < o.min_correlation) {
      r.status = TagPatternFitStatus::kWrongCells;
      return r;
    }
  }

  Eigen::Vector2d shift = Eigen::Vector2d::Zero();
  for (std::size_t k = 0; k < 4; ++k) shift += 0.25 * (c[k] - predicted_px[k]);
  double shape = 0;
  for (std::size_t k = 0; k < 4; ++k) shape = std::max(shape, (c[k] - predicted_px[k] - shift).norm());
  r.shift_px = shift.norm();
  r.shape_px = shape;
  r.status = r.shift_px > reach_px || shape > o.max_shape_px ? TagPatternFitStatus::kOffPrediction
                                                               : TagPatternFitStatus::kFitted;
  return r;
}

}  // namespace dentar::ar
