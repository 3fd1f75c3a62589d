// The camera response measured from chessboard views (issue 24): generated views with a known
// response, a flat and a saturated board refused with the reason, the station field's
// validation, and OpenCV's real chessboard photographs (opencv-doc; skipped when absent).
#include "dentar/calibration/response.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <algorithm>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <string>
#include <vector>

#include "dentar/calibration/intrinsics.h"

namespace dentar::calibration {
namespace {

constexpr int kCols = 7, kRows = 5;

struct Board {
  std::vector<std::uint8_t> gray;
  std::vector<double> corners;  // row-major, OpenCV px
  int w = 320, h = 240;
};

double srgb_encode(double v) {
  v = std::clamp(v, 0.0, 1.0);
  return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1 / 2.4) - 0.055;
}

// A camera's view of a printed chessboard: the board (kCols + 1) x (kRows + 1) squares of
// 22 px, turned and slightly foreshortened, black 4 % / white 85 % reflectance under light
// that falls off across the image, integrated over the pixel (3 x 3 samples) and blurred
// (Gaussian sigma 0.8 px) in linear light, then encoded by `encode` (linear light 0..1 ->
// code 0..1), Gaussian noise of 0.7 codes, rounded. Corners from the geometry plus 0.03 px noise
// (a detector's).
Board render(unsigned seed, double exposure, const std::function<double(double)>& encode,
             double black = 0.04, double white = 0.85) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> nz(0, 1);
  Board b;
  const double sq = 22, ang = 0.3 * u(rng), persp = 0.0006 * u(rng);
  const Eigen::Vector2d c0(b.w / 2.0 + 10 * u(rng), b.h / 2.0 + 8 * u(rng));
  const Eigen::Rotation2Dd R(ang);
  // Board point (X, Y) in squares, origin at inner corner (0, 0) -> image.
  auto to_img = [&](double X, double Y) {
    const Eigen::Vector2d p = R * Eigen::Vector2d((X - (kCols - 1) / 2.0) * sq, (Y - (kRows - 1) / 2.0) * sq);
    const double s = 1.0 / (1.0 + persp * p.x());
    return Eigen::Vector2d(c0 + s * p);
  };
  // Inverse by Newton (the map is nearly affine).
  auto to_board = [&](const Eigen::Vector2d& q) {
    Eigen::Vector2d X((q - c0).x() / sq + (kCols - 1) / 2.0, (q - c0).y() / sq + (kRows - 1) / 2.0);
    X = Eigen::Vector2d((R.inverse() * (q - c0)).x() / sq + (kCols - 1) / 2.0,
                        (R.inverse() * (q - c0)).y() / sq + (kRows - 1) / 2.0);
    for (int it = 0; it < 3; ++it) {
      const Eigen::Vector2d f = to_img(X.x(), X.y()) - q;
      const double e = 1e-4;
      Eigen::Matrix2d J;
      J.col(0) = (to_img(X.x() + e, X.y()) - to_img(X.x(), X.y())) / e;
      J.col(1) = (to_img(X.x(), X.y() + e) - to_img(X.x(), X.y())) / e;
      X -= J.inverse() * f;
    }
    return X;
  };
  std::vector<double> lin(static_cast<std::size_t>(b.w * b.h));
  for (int y = 0; y < b.h; ++y)
    for (int x = 0; x < b.w; ++x) {
      double acc = 0;
      for (int sy = 0; sy < 3; ++sy)
        for (int sx = 0; sx < 3; ++sx) {
          const Eigen::Vector2d X = to_board(Eigen::Vector2d(x - 0.5 + (sx + 0.5) / 3, y - 0.5 + (sy + 0.5) / 3));
          double refl = 0.3;  // the table around the board
          if (X.x() > -1 && X.x() < kCols && X.y() > -1 && X.y() < kRows) {
            const int ix = static_cast<int>(std::floor(X.x())), iy = static_cast<int>(std::floor(X.y()));
            refl = ((ix + iy) % 2 == 0) ? black : white;
          }
          acc += refl / 9;
        }
      const double light = exposure * (1.0 - 0.25 * x / b.w - 0.15 * y / b.h);
      lin[static_cast<std::size_t>(y * b.w + x)] = acc * light;
    }
  // Separable Gaussian blur, sigma 0.8 px.
  const double sigma = 0.8;
  std::vector<double> k;
  for (int i = -3; i <= 3; ++i) k.push_back(std::exp(-i * i / (2 * sigma * sigma)));
  double ks = 0;
  for (double v : k) ks += v;
  for (double& v : k) v /= ks;
  std::vector<double> tmp(lin.size());
  for (int y = 0; y < b.h; ++y)
    for (int x = 0; x < b.w; ++x) {
      double s = 0;
      for (int i = -3; i <= 3; ++i) s += k[i + 3] * lin[static_cast<std::size_t>(y * b.w + std::clamp(x + i, 0, b.w - 1))];
      tmp[static_cast<std::size_t>(y * b.w + x)] = s;
    }
  b.gray.resize(lin.size());
  for (int y = 0; y < b.h; ++y)
    for (int x = 0; x < b.w; ++x) {
      double s = 0;
      for (int i = -3; i <= 3; ++i) s += k[i + 3] * tmp[static_cast<std::size_t>(std::clamp(y + i, 0, b.h - 1) * b.w + x)];
      const double code = 255 * encode(std::clamp(s, 0.0, 1.0)) + 0.7 * nz(rng);
      b.gray[static_cast<std::size_t>(y * b.w + x)] = static_cast<std::uint8_t>(std::clamp(std::lround(code), 0L, 255L));
    }
  for (int r = 0; r < kRows; ++r)
    for (int c = 0; c < kCols; ++c) {
      const Eigen::Vector2d p = to_img(c, r);
      b.corners.push_back(p.x() + 0.03 * nz(rng));
      b.corners.push_back(p.y() + 0.03 * nz(rng));
    }
  return b;
}

ResponseEstimate estimate(const std::vector<Board>& boards) {
  std::vector<ResponseView> v;
  for (const Board& b : boards)
    v.push_back({b.gray.data(), b.w, b.h, b.w, b.corners, "sim"});
  return estimate_response_chessboard(v, kCols, kRows);
}

std::vector<Board> session(const std::function<double(double)>& encode, unsigned seed,
                           double black = 0.04, double white = 0.85, double exposure_base = 0.8) {
  std::vector<Board> boards;
  for (int i = 0; i < 8; ++i)
    boards.push_back(render(seed + i, exposure_base * (0.7 + 0.06 * i), encode, black, white));
  return boards;
}

TEST(CameraResponse, RecoversAKnownGammaWithinItsUncertainty) {
  for (double g : {1.0, 1.8, 2.2}) {
    SCOPED_TRACE(g);
    const ResponseEstimate e = estimate(session([g](double v) { return std::pow(v, 1 / g); }, 11));
    ASSERT_TRUE(e.ok) << e.message;
    std::printf("[ response ] true gamma %.2f: fitted %.3f +- %.3f (%d edges, %d views); rms t: "
                "gamma %.4f linear %.4f srgb %.4f; named \"%s\"\n",
                g, e.gamma, e.gamma_sigma, e.edges, e.views, e.rms_gamma, e.rms_linear, e.rms_srgb,
                e.named.c_str());
    EXPECT_GT(e.gamma_sigma, 0);
    EXPECT_LT(e.gamma_sigma, 0.2);
    // The stated uncertainty covers the truth (3 sigma, plus the blur/sampling floor).
    EXPECT_LT(std::abs(e.gamma - g), 3 * e.gamma_sigma + 0.08);
    if (g == 1.0) {
      EXPECT_EQ(e.named, "linear");
    }
  }
}

TEST(CameraResponse, TellsSrgbFromLinear) {
  const ResponseEstimate s = estimate(session(srgb_encode, 21));
  ASSERT_TRUE(s.ok) << s.message;
  std::printf("[ response ] sRGB camera: gamma %.3f +- %.3f, rms srgb %.4f linear %.4f, named \"%s\"\n",
              s.gamma, s.gamma_sigma, s.rms_srgb, s.rms_linear, s.named.c_str());
  EXPECT_EQ(s.named, "srgb");
  EXPECT_LT(s.rms_srgb, s.rms_linear);
  const CameraResponseCurve c = response_from_estimate(s);
  EXPECT_EQ(c.kind, "srgb");
  EXPECT_EQ(c.validate(), "");
  // A gamma that is neither becomes a 256-entry curve that validates.
  const ResponseEstimate g = estimate(session([](double v) { return std::pow(v, 1 / 1.6); }, 31));
  ASSERT_TRUE(g.ok) << g.message;
  const CameraResponseCurve gc = response_from_estimate(g);
  if (g.named.empty()) {
    EXPECT_EQ(gc.kind, "curve");
    EXPECT_EQ(gc.table.size(), 256u);
    EXPECT_EQ(gc.validate(), "");
  }
}

TEST(CameraResponse, RefusesAFlatOrSaturatedBoard) {
  // Grey on grey: 10 codes apart.
  const ResponseEstimate flat = estimate(session(srgb_encode, 41, 0.40, 0.44));
  ASSERT_FALSE(flat.ok);
  EXPECT_NE(flat.message.find("flat"), std::string::npos) << flat.message;
  // Over-exposed: the white squares at 255.
  const ResponseEstimate sat = estimate(session(srgb_encode, 51, 0.04, 0.85, 3.0));
  ASSERT_FALSE(sat.ok);
  EXPECT_NE(sat.message.find("saturated"), std::string::npos) << sat.message;
  EXPECT_NE(sat.message.find("exposure"), std::string::npos) << sat.message;
  // No views.
  EXPECT_FALSE(estimate({}).ok);
}

TEST(CameraResponse, StationCurveIsValidatedNamingTheField) {
  CameraResponseCurve c;
  c.kind = "curve";
  c.table.resize(255, 0.5);
  std::string e = c.validate();
  EXPECT_NE(e.find("camera.response.curve has 255 entries"), std::string::npos) << e;
  c.table.resize(256);
  for (int i = 0; i < 256; ++i) c.table[static_cast<std::size_t>(i)] = i / 255.0;
  EXPECT_EQ(c.validate(), "");
  c.table[12] = 0.01;
  e = c.validate();
  EXPECT_NE(e.find("camera.response.curve[12]"), std::string::npos) << e;
  EXPECT_NE(e.find("monotonic"), std::string::npos) << e;
  c.table[12] = 12 / 255.0;
  c.kind = "gamma";
  EXPECT_NE(c.validate().find("camera.response.kind"), std::string::npos);
  c.kind = "srgb";
  EXPECT_NE(c.validate().find("only allowed"), std::string::npos);
}

// OpenCV's sample chessboard photographs (Debian opencv-doc, tests/data_provenance.md): a
// real camera's response, measured. Printed for docs/BENCHMARKS.md; asserted only to be a
// sane, decided measurement (the truth is not known).
TEST(CameraResponse, OpenCvSampleChessboardPhotos) {
  const std::filesystem::path dir = "/usr/share/doc/opencv-doc/examples/data";
  if (!std::filesystem::exists(dir / "left01.jpg"))
    GTEST_SKIP() << dir << " is absent: install the Debian package opencv-doc";
  std::vector<cv::Mat> imgs;
  std::vector<ResponseView> views;
  ChessboardSpec spec;
  spec.cols = 9;
  spec.rows = 6;
  for (int i = 1; i <= 14; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "left%02d.jpg", i);
    cv::Mat g = cv::imread((dir / name).string(), cv::IMREAD_GRAYSCALE);
    if (g.empty()) continue;
    auto v = detect_chessboard(g.data, g.cols, g.rows, static_cast<int>(g.step), spec, name);
    if (!v) continue;
    imgs.push_back(g);
    ResponseView rv{imgs.back().data, g.cols, g.rows, static_cast<int>(g.step), {}, name};
    for (const auto& p : v->image_points) {
      rv.corners_xy.push_back(p.x());
      rv.corners_xy.push_back(p.y());
    }
    views.push_back(rv);
  }
  ASSERT_GE(views.size(), 10u);
  const ResponseEstimate e = estimate_response_chessboard(views, 9, 6);
  std::printf("[ response ] OpenCV left*.jpg: %s gamma %.3f +- %.3f (%d edges, %d views; %d clipped, "
              "%d flat; median black %.0f white %.0f); rms t: gamma %.4f linear %.4f srgb %.4f; "
              "named \"%s\"\n",
              e.ok ? "ok" : e.message.c_str(), e.gamma, e.gamma_sigma, e.edges, e.views,
              e.edges_clipped, e.edges_flat, e.median_lo, e.median_hi, e.rms_gamma, e.rms_linear,
              e.rms_srgb, e.named.c_str());
  ASSERT_TRUE(e.ok) << e.message;
  EXPECT_GT(e.gamma, 0.5);
  EXPECT_LT(e.gamma, 3.5);
  EXPECT_LT(e.gamma_sigma, 0.5);
}

}  // namespace
}  // namespace dentar::calibration
