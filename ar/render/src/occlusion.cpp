#include "dentar/ar/occlusion.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <sstream>

namespace dentar::ar {
namespace {

Eigen::Vector2d chroma_of(const Eigen::Vector3d& rgb) {
  const double r = std::max(rgb.x(), 1e-6);
  return {rgb.y() / r, rgb.z() / r};
}

float sat(float x) { return std::clamp(x, 0.0f, 1.0f); }

cv::Mat boundary_of(const cv::Mat& m) {
  // Inside pixels with an outside 4-neighbour; the image border counts as outside.
  cv::Mat bin = m != 0, padded, eroded;
  cv::copyMakeBorder(bin, padded, 1, 1, 1, 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::erode(padded, eroded, cv::getStructuringElement(cv::MORPH_CROSS, cv::Size(3, 3)));
  cv::Mat e = eroded(cv::Rect(1, 1, m.cols, m.rows));
  return bin & ~e;
}

}  // namespace

std::string SegmenterOptions::validate() const {
  std::ostringstream os;
  if (!seed_rgb.allFinite() || seed_rgb.minCoeff() < 0 || seed_rgb.maxCoeff() > 1 ||
      seed_rgb.x() < 0.05)
    os << "seed_rgb must be sRGB in [0, 1] with red >= 0.05";
  else if (!(std::isfinite(max_distance) && max_distance > 0 && max_distance < 2))
    os << "max_distance = " << max_distance << " must be in (0, 2)";
  else if (!(std::isfinite(softness) && softness > 0 && softness < 1))
    os << "softness = " << softness << " must be in (0, 1)";
  else if (mix_radius_px < 0 || mix_radius_px > 16)
    os << "mix_radius_px = " << mix_radius_px << " must be in 0..16";
  else if (min_red < 0 || min_red > 254)
    os << "min_red = " << min_red << " must be in 0..254";
  else if (!(std::isfinite(adapt_rate) && adapt_rate >= 0 && adapt_rate <= 1))
    os << "adapt_rate = " << adapt_rate << " must be in [0, 1]";
  else if (!(std::isfinite(max_adapt) && max_adapt >= 0 && max_adapt < 1))
    os << "max_adapt = " << max_adapt << " must be in [0, 1)";
  return os.str();
}

ForegroundSegmenter::ForegroundSegmenter(const SegmenterOptions& options)
    : options_(options), seed_(chroma_of(options.seed_rgb)), model_(seed_) {}

void ForegroundSegmenter::reset() { model_ = seed_; }

void ForegroundSegmenter::segment(const cv::Mat& video_bgr, const cv::Mat& expected_rgba,
                                  const cv::Mat& region, cv::Mat& fg) {
  assert(video_bgr.type() == CV_8UC3 && expected_rgba.type() == CV_8UC4 &&
         region.type() == CV_8UC1 && video_bgr.size() == expected_rgba.size() &&
         video_bgr.size() == region.size() &&
         "dentar::ar::ForegroundSegmenter::segment: CV_8UC3/CV_8UC4/CV_8UC1 of one size");
  fg.create(video_bgr.size(), CV_8UC1);
  fg.setTo(0);
  const float mg = static_cast<float>(model_.x()), mb = static_cast<float>(model_.y());
  const float dmax = static_cast<float>(options_.max_distance);
  const float inv_soft = 1.0f / static_cast<float>(options_.softness);
  const int min_red = options_.min_red;
  const float reach = dmax + 0.5f * static_cast<float>(options_.softness);
  const float reach2 = reach * reach;
  // Where the expected surface is sampled: the pixel and +-r, +-r/2 along both axes.
  const int r = options_.mix_radius_px, h = options_.mix_radius_px / 2;
  std::vector<std::array<int, 2>> offsets = {{0, 0}};
  if (r > 0)
    for (int d : {r, h})
      if (d > 0) offsets.insert(offsets.end(), {{d, 0}, {-d, 0}, {0, d}, {0, -d}});
  // 1/x for 8-bit values: a table instead of a division per pixel.
  static const std::array<float, 256> kInv = [] {
    std::array<float, 256> t{};
    for (int i = 1; i < 256; ++i) t[static_cast<std::size_t>(i)] = 1.0f / static_cast<float>(i);
    return t;
  }();
  double sum_g = 0, sum_b = 0;
  long n_conf = 0;
  for (int v = 0; v < video_bgr.rows; ++v) {
    const auto* px = video_bgr.ptr<cv::Vec3b>(v);
    const auto* rg = region.ptr<std::uint8_t>(v);
    auto* out = fg.ptr<std::uint8_t>(v);
    for (int u = 0; u < video_bgr.cols; ++u) {
      if (rg[u] == 0 || px[u][2] < min_red) continue;
      const float inv_r = kInv[px[u][2]];
      const float cg = px[u][1] * inv_r, cb = px[u][0] * inv_r;
      // Squared distance first: most pixels are far from the model.
      const float d2_fg = (cg - mg) * (cg - mg) + (cb - mb) * (cb - mb);
      if (d2_fg >= reach2) continue;
      const float d_fg = std::sqrt(d2_fg);
      // Expected chromaticities at the pixel and around it (blur mixes
      // neighbouring surfaces: white teeth over pink gum blend to a
      // skin-like colour), and the distance to the nearest of them or of
      // the segments between them.
      int n_exp = 0;
      std::array<Eigen::Vector2f, 9> e;
      for (const auto& o : offsets) {
        const int vv = std::clamp(v + o[1], 0, video_bgr.rows - 1);
        const int uu = std::clamp(u + o[0], 0, video_bgr.cols - 1);
        const cv::Vec4b a = expected_rgba.at<cv::Vec4b>(vv, uu);
        if (a[3] == 0 || a[0] <= 8) continue;
        const Eigen::Vector2f c(a[1] * kInv[a[0]], a[2] * kInv[a[0]]);
        bool seen = false;
        for (int k = 0; k < n_exp && !seen; ++k) seen = (e[static_cast<std::size_t>(k)] - c).squaredNorm() < 1e-6f;
        if (!seen) e[static_cast<std::size_t>(n_exp++)] = c;
      }
      float d_bg = std::numeric_limits<float>::infinity();
      const Eigen::Vector2f q(cg, cb);
      for (int a = 0; a < n_exp; ++a) {
        const Eigen::Vector2f& pa = e[static_cast<std::size_t>(a)];
        d_bg = std::min(d_bg, (q - pa).norm());
        for (int b = a + 1; b < n_exp; ++b) {
          const Eigen::Vector2f ab = e[static_cast<std::size_t>(b)] - pa;
          const float t = std::clamp((q - pa).dot(ab) / std::max(ab.squaredNorm(), 1e-12f), 0.0f, 1.0f);
          d_bg = std::min(d_bg, (q - pa - t * ab).norm());
        }
      }
      // Soft decisions: nearer the foreground model than the expected
      // surface, and within max_distance of the model.
      const float p_rel = std::isinf(d_bg) ? 1.0f : sat(0.5f + (d_bg - d_fg) * inv_soft);
      const float p_abs = sat(0.5f + (dmax - d_fg) * inv_soft);
      const float p = p_rel * p_abs;
      out[u] = static_cast<std::uint8_t>(std::lround(255.0f * p));
      if (p > 0.95f) {
        sum_g += cg;
        sum_b += cb;
        ++n_conf;
      }
    }
  }
  if (n_conf >= 30 && options_.adapt_rate > 0) {
    const Eigen::Vector2d mean(sum_g / n_conf, sum_b / n_conf);
    Eigen::Vector2d m = model_ + options_.adapt_rate * (mean - model_);
    const Eigen::Vector2d d = m - seed_;
    if (d.norm() > options_.max_adapt) m = seed_ + d * (options_.max_adapt / d.norm());
    model_ = m;
  }
}

cv::Mat paint_synthetic_finger(cv::Mat& bgr, const SyntheticFinger& f) {
  assert(bgr.type() == CV_8UC3 && "dentar::ar::paint_synthetic_finger: CV_8UC3 image");
  cv::Mat mask = cv::Mat::zeros(bgr.size(), CV_8UC1);
  const Eigen::Vector2d ab = f.b_px - f.a_px;
  const double len2 = std::max(ab.squaredNorm(), 1e-12);
  auto to_linear = [](double c) { return std::pow(c, 2.2); };
  auto to_srgb = [](double c) { return std::pow(std::clamp(c, 0.0, 1.0), 1.0 / 2.2); };
  const Eigen::Vector3d lin(to_linear(f.rgb.x()), to_linear(f.rgb.y()), to_linear(f.rgb.z()));
  cv::RNG rng(f.seed);
  const int x0 = std::max(0, static_cast<int>(std::min(f.a_px.x(), f.b_px.x()) - f.radius_px - 2));
  const int x1 = std::min(bgr.cols - 1,
                          static_cast<int>(std::max(f.a_px.x(), f.b_px.x()) + f.radius_px + 2));
  const int y0 = std::max(0, static_cast<int>(std::min(f.a_px.y(), f.b_px.y()) - f.radius_px - 2));
  const int y1 = std::min(bgr.rows - 1,
                          static_cast<int>(std::max(f.a_px.y(), f.b_px.y()) + f.radius_px + 2));
  for (int v = y0; v <= y1; ++v) {
    auto* p = bgr.ptr<cv::Vec3b>(v);
    auto* m = mask.ptr<std::uint8_t>(v);
    for (int u = x0; u <= x1; ++u) {
      const Eigen::Vector2d q(u, v);
      const double t = std::clamp((q - f.a_px).dot(ab) / len2, 0.0, 1.0);
      const double d = (q - (f.a_px + t * ab)).norm();
      const double cov = std::clamp(f.radius_px - d + 0.5, 0.0, 1.0);
      if (cov <= 0) continue;
      if (cov > 0.5) m[u] = 255;
      const double nz = std::sqrt(std::max(0.0, 1.0 - std::pow(std::min(d / f.radius_px, 1.0), 2)));
      const double light = 0.3 + 0.7 * nz;
      for (int c = 0; c < 3; ++c) {
        const double fc = 255.0 * to_srgb(lin[2 - c] * light) + rng.gaussian(f.noise_dn);
        const double val = (1 - cov) * p[u][c] + cov * fc;
        p[u][c] = static_cast<std::uint8_t>(std::clamp(std::lround(val), 0L, 255L));
      }
    }
  }
  return mask;
}

MaskScore compare_masks(const cv::Mat& predicted, const cv::Mat& truth, double tolerance_px) {
  assert(predicted.type() == CV_8UC1 && truth.type() == CV_8UC1 &&
         predicted.size() == truth.size() &&
         "dentar::ar::compare_masks: two CV_8UC1 masks of one size");
  MaskScore s;
  const cv::Mat a = predicted != 0, b = truth != 0;
  s.predicted_px = cv::countNonZero(a);
  s.truth_px = cv::countNonZero(b);
  s.intersection_px = cv::countNonZero(a & b);
  const int uni = s.predicted_px + s.truth_px - s.intersection_px;
  s.iou = uni == 0 ? 1.0 : static_cast<double>(s.intersection_px) / uni;

  const cv::Mat ba = boundary_of(a), bb = boundary_of(b);
  const int na = cv::countNonZero(ba), nb = cv::countNonZero(bb);
  if (na == 0 && nb == 0) return s;
  if (na == 0 || nb == 0) {
    s.precision = s.recall = s.boundary_f = 0.0;
    return s;
  }
  // Distance to the nearest boundary pixel of the other mask.
  cv::Mat da, db;
  cv::distanceTransform(~ba, da, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  cv::distanceTransform(~bb, db, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  const float tol = static_cast<float>(tolerance_px);
  const int matched_a = cv::countNonZero((db <= tol) & ba);
  const int matched_b = cv::countNonZero((da <= tol) & bb);
  s.precision = static_cast<double>(matched_a) / na;
  s.recall = static_cast<double>(matched_b) / nb;
  s.boundary_f = (s.precision + s.recall) > 0
                     ? 2 * s.precision * s.recall / (s.precision + s.recall)
                     : 0.0;
  return s;
}

}  // namespace dentar::ar
