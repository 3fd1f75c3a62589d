// The mirror rim's edge locator (locate_rim_edge, the blurred-step fit) on
// synthetic straight edges with a known position: no rendering, a few
// milliseconds.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>
#include <vector>

#include "dentar/ar/mirror_rim.h"
#include "dentar/ar/srgb.h"

namespace dentar::ar {
namespace {

// A 64x64 image of the half-plane n . (x - p0) > 0 at level `hi`, `lo`
// elsewhere, as a camera forms it: each pixel integrates the light over its
// area (16x16 sub-samples), the lens blurs it (Gaussian, sigma blur_px, in
// linear light), then 8-bit codes (sRGB-encoded when `srgb`, else linear).
cv::Mat edge_image(const Eigen::Vector2d& p0, const Eigen::Vector2d& n, double lo, double hi, double blur_px,
                   bool srgb, double noise = 0, unsigned seed = 1) {
  const int S = 64, K = 16;
  cv::Mat lin(S, S, CV_32F);
  for (int v = 0; v < S; ++v)
    for (int u = 0; u < S; ++u) {
      int in = 0;
      for (int j = 0; j < K; ++j)
        for (int i = 0; i < K; ++i) {
          const Eigen::Vector2d x(u - 0.5 + (i + 0.5) / K, v - 0.5 + (j + 0.5) / K);
          in += n.dot(x - p0) > 0 ? 1 : 0;
        }
      const double c = static_cast<double>(in) / (K * K);
      lin.at<float>(v, u) = static_cast<float>(lo + (hi - lo) * c);
    }
  if (blur_px > 0) cv::GaussianBlur(lin, lin, cv::Size(0, 0), blur_px);
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0, noise);
  cv::Mat out(S, S, CV_8UC1);
  for (int v = 0; v < S; ++v)
    for (int u = 0; u < S; ++u) {
      double x = lin.at<float>(v, u);
      if (srgb) x = x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1 / 2.4) - 0.055;
      x = x * 255 + (noise > 0 ? g(rng) : 0.0);
      out.at<std::uint8_t>(v, u) = static_cast<std::uint8_t>(std::clamp(std::lround(x), 0L, 255L));
    }
  return out;
}

// Clean edges at random sub-pixel positions and orientations, both
// polarities, linear and sRGB codes, the locator started up to 2 px off:
// the position is found without bias (< 0.05 px) and within 0.1 px each.
TEST(MirrorRimEdge, BlurredStepPositionUnbiased) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(0, 1);
  MirrorRimOptions o;
  o.step_fit = true;
  ASSERT_EQ(o.validate(), "");
  double sum = 0, worst = 0;
  int n = 0;
  for (int i = 0; i < 60; ++i) {
    const double ang = 2 * M_PI * U(rng);
    const Eigen::Vector2d nrm(std::cos(ang), std::sin(ang));
    const Eigen::Vector2d p0(31.5 + U(rng), 31.5 + U(rng));
    const bool dark_out = i % 2 == 0, srgb = i % 3 == 0;
    const double lo = 0.08 + 0.1 * U(rng), hi = 0.5 + 0.3 * U(rng);
    // The half-plane n . (x - p0) > 0 (outside) is bright or dark.
    const cv::Mat im = dark_out ? edge_image(p0, -nrm, lo, hi, 0.5, srgb) : edge_image(p0, nrm, lo, hi, 0.5, srgb);
    const double start = -2 + 4 * U(rng);  // the search origin's offset from the true edge
    const RimEdgeFit f = locate_rim_edge(im, srgb, p0 + nrm * start, nrm, 4.0, o);
    ASSERT_TRUE(f.ok) << f.why << " at edge " << i;
    const double err = (start + f.offset_px) - 0.0;  // the edge found, from p0 along the normal
    sum += err;
    worst = std::max(worst, std::abs(err));
    ++n;
    EXPECT_EQ(f.step > 0, !dark_out) << i;
    EXPECT_NEAR(f.width_px, 0.7, 0.25) << i;  // 0.5 px optics + the pixel and the bilinear sample
  }
  std::printf("[ rim edge ] %d clean edges: bias %+.4f px, worst %.4f px\n", n, sum / n, worst);
  EXPECT_LT(std::abs(sum / n), 0.05);
  EXPECT_LT(worst, 0.1);
}

// The fit's rejections: a wide (motion-blurred) edge by its width, a clipped
// one by saturation, a thin line (two steps) by its residual or ambiguity.
TEST(MirrorRimEdge, RejectsBlurredSaturatedAndDoubleEdges) {
  MirrorRimOptions o;
  o.step_fit = true;
  const Eigen::Vector2d nrm(std::cos(0.3), std::sin(0.3)), p0(32.2, 31.7);
  // Motion blur of ~4 px across the edge: sigma 1.6 px > 2 x 0.6.
  {
    const cv::Mat im = edge_image(p0, nrm, 0.1, 0.6, 1.6, false);
    const RimEdgeFit f = locate_rim_edge(im, false, p0, nrm, 4.0, o);
    EXPECT_FALSE(f.ok);
    EXPECT_EQ(f.why, "too wide (blur)");
  }
  // A burnt-out highlight outside.
  {
    const cv::Mat im = edge_image(p0, nrm, 0.1, 1.0, 0.5, false);
    const RimEdgeFit f = locate_rim_edge(im, false, p0, nrm, 4.0, o);
    EXPECT_FALSE(f.ok);
    EXPECT_EQ(f.why, "saturated");
  }
  // A bright 1.2 px line on dark: no single step fits it.
  {
    cv::Mat a = edge_image(p0, nrm, 0.0, 0.5, 0.5, false);
    cv::Mat b = edge_image(p0 + nrm * 1.2, nrm, 0.0, 0.5, 0.5, false);
    cv::Mat im;
    cv::subtract(a, b, im);
    cv::add(im, cv::Scalar(25), im);
    const RimEdgeFit f = locate_rim_edge(im, false, p0, nrm, 4.0, o);
    EXPECT_FALSE(f.ok) << f.offset_px;
  }
  // The same clean edge is accepted (the three rejections are the edge's, not the setup's).
  {
    const cv::Mat im = edge_image(p0, nrm, 0.1, 0.6, 0.5, false);
    const RimEdgeFit f = locate_rim_edge(im, false, p0, nrm, 4.0, o);
    EXPECT_TRUE(f.ok) << f.why;
    EXPECT_NEAR(f.offset_px, 0.0, 0.05);
  }
}

// Sensor noise (2 DN on a 0.3 step): the fit stays unbiased on average.
TEST(MirrorRimEdge, NoisyStepUnbiasedOnAverage) {
  MirrorRimOptions o;
  o.step_fit = true;
  o.max_fit_rms = 1.0;  // noise, not the shape, is tested here
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(0, 1);
  double sum = 0, sum2 = 0;
  int n = 0;
  for (int i = 0; i < 40; ++i) {
    const double ang = 2 * M_PI * U(rng);
    const Eigen::Vector2d nrm(std::cos(ang), std::sin(ang)), p0(31.5 + U(rng), 31.5 + U(rng));
    const cv::Mat im = edge_image(p0, nrm, 0.1, 0.4, 0.5, false, 2.0, 100 + i);
    const RimEdgeFit f = locate_rim_edge(im, false, p0, nrm, 4.0, o);
    if (!f.ok) continue;
    sum += f.offset_px;
    sum2 += f.offset_px * f.offset_px;
    ++n;
  }
  ASSERT_GE(n, 36);
  const double m = sum / n, sd = std::sqrt(std::max(0.0, sum2 / n - m * m));
  std::printf("[ rim edge ] %d noisy edges: bias %+.4f px, sd %.4f px\n", n, m, sd);
  EXPECT_LT(std::abs(m), 0.05);
  EXPECT_LT(sd, 0.15);
}

TEST(MirrorRimEdge, OptionsValidated) {
  MirrorRimOptions o;
  o.blur_px = 0;
  EXPECT_NE(o.validate().find("blur_px"), std::string::npos);
  o = {};
  o.parallel_lines = 0;
  EXPECT_NE(o.validate().find("parallel_lines"), std::string::npos);
  o = {};
  o.max_width_ratio = 0.5;
  EXPECT_NE(o.validate().find("max_width_ratio"), std::string::npos);
  o = {};
  o.max_candidates = 0;
  EXPECT_NE(o.validate().find("max_candidates"), std::string::npos);
  o = {};
  o.saturation = 0;
  EXPECT_NE(o.validate().find("saturation"), std::string::npos);
}

}  // namespace
}  // namespace dentar::ar
