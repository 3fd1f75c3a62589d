#include "dentar/sound/analysis.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace dentar::sound {

Spectrum magnitude_spectrum(const float* x, std::size_t n, double sample_rate_hz) {
  Spectrum s;
  if (n < 2) return s;
  const int size = cv::getOptimalDFTSize(static_cast<int>(n));
  cv::Mat in = cv::Mat::zeros(1, size, CV_64F);
  auto* p = in.ptr<double>();
  for (std::size_t i = 0; i < n; ++i) {
    const double w = 0.5 - 0.5 * std::cos(2.0 * M_PI * static_cast<double>(i) / static_cast<double>(n - 1));
    p[i] = w * x[i];
  }
  cv::Mat out;
  cv::dft(in, out, cv::DFT_COMPLEX_OUTPUT);
  const auto* c = out.ptr<cv::Vec2d>();
  s.magnitude.resize(static_cast<std::size_t>(size / 2 + 1));
  for (int k = 0; k <= size / 2; ++k) s.magnitude[static_cast<std::size_t>(k)] = std::hypot(c[k][0], c[k][1]);
  s.bin_hz = sample_rate_hz / size;
  return s;
}

double peak_hz(const Spectrum& s, double fmin_hz, double fmax_hz) {
  if (s.magnitude.size() < 3 || s.bin_hz <= 0) return 0;
  const auto lo = static_cast<std::size_t>(std::max(1.0, std::ceil(fmin_hz / s.bin_hz)));
  const auto hi = std::min(s.magnitude.size() - 2, static_cast<std::size_t>(fmax_hz / s.bin_hz));
  if (lo > hi) return 0;
  std::size_t best = lo;
  for (std::size_t k = lo; k <= hi; ++k)
    if (s.magnitude[k] > s.magnitude[best]) best = k;
  const double a = s.magnitude[best - 1], b = s.magnitude[best], c = s.magnitude[best + 1];
  const double den = a - 2 * b + c;
  const double d = den != 0 ? 0.5 * (a - c) / den : 0.0;
  return (static_cast<double>(best) + std::clamp(d, -0.5, 0.5)) * s.bin_hz;
}

double fundamental_hz(const Spectrum& s, double fmin_hz, double fmax_hz, int harmonics) {
  const std::size_t n = s.magnitude.size();
  if (n < 4 || s.bin_hz <= 0) return 0;
  const auto lo = static_cast<std::size_t>(std::max(1.0, std::ceil(fmin_hz / s.bin_hz)));
  const auto hi = std::min(n - 2, static_cast<std::size_t>(fmax_hz / s.bin_hz));
  auto near = [&](std::size_t k) {
    if (k + 1 >= n) return 0.0;
    return std::max({s.magnitude[k - 1], s.magnitude[k], s.magnitude[k + 1]});
  };
  std::size_t best = 0;
  double best_v = -1;
  for (std::size_t k = lo; k <= hi; ++k) {
    double v = 0;
    for (int h = 1; h <= harmonics; ++h) v += near(k * static_cast<std::size_t>(h));
    if (v > best_v) {
      best_v = v;
      best = k;
    }
  }
  if (best == 0) return 0;
  // Refine on the strongest of the three bins around the winner.
  std::size_t k = best;
  if (s.magnitude[k - 1] > s.magnitude[k]) --k;
  if (s.magnitude[k + 1] > s.magnitude[k]) ++k;
  const double a = s.magnitude[k - 1], b = s.magnitude[k], c = s.magnitude[k + 1];
  const double den = a - 2 * b + c;
  const double d = den != 0 ? 0.5 * (a - c) / den : 0.0;
  return (static_cast<double>(k) + std::clamp(d, -0.5, 0.5)) * s.bin_hz;
}

double centroid_hz(const Spectrum& s, double fmin_hz, double fmax_hz) {
  double num = 0, den = 0;
  for (std::size_t k = 0; k < s.magnitude.size(); ++k) {
    const double f = static_cast<double>(k) * s.bin_hz;
    if (f < fmin_hz || f > fmax_hz) continue;
    const double pw = s.magnitude[k] * s.magnitude[k];
    num += f * pw;
    den += pw;
  }
  return den > 0 ? num / den : 0;
}

double rms(const float* x, std::size_t n) {
  if (n == 0) return 0;
  double acc = 0;
  for (std::size_t i = 0; i < n; ++i) acc += static_cast<double>(x[i]) * x[i];
  return std::sqrt(acc / static_cast<double>(n));
}

Status write_spectrogram_png(const std::string& path, const std::vector<float>& x, double sample_rate_hz) {
  constexpr int kWin = 1024, kHop = 256, kBins = kWin / 2;
  if (x.size() < static_cast<std::size_t>(kWin)) return Error{path + ": fewer than 1024 samples to analyse"};
  const int cols = static_cast<int>((x.size() - kWin) / kHop) + 1;
  cv::Mat db(kBins, cols, CV_32F);
  double top = -300;
  for (int c = 0; c < cols; ++c) {
    const Spectrum s = magnitude_spectrum(x.data() + static_cast<std::size_t>(c) * kHop, kWin, sample_rate_hz);
    for (int k = 0; k < kBins; ++k) {
      const double v = to_db(s.magnitude[static_cast<std::size_t>(k)] + 1e-12);
      db.at<float>(kBins - 1 - k, c) = static_cast<float>(v);
      top = std::max(top, v);
    }
  }
  cv::Mat grey;
  db.convertTo(grey, CV_8U, 255.0 / 80.0, -255.0 / 80.0 * (top - 80.0));  // [top-80, top] dB -> 0..255
  // 128 frequency rows (187.5 Hz each at 48 kHz) keep the file small and the bands readable.
  cv::Mat small;
  cv::resize(grey, small, cv::Size(cols, kBins / 4), 0, 0, cv::INTER_AREA);
  cv::Mat colour;
  cv::applyColorMap(small, colour, cv::COLORMAP_INFERNO);
  try {
    if (!cv::imwrite(path, colour)) return Error{path + ": cannot write the PNG; check the folder exists"};
  } catch (const cv::Exception& e) {
    return Error{path + ": cannot write the PNG (" + std::string(e.what()) + ")"};
  }
  return {};
}

}  // namespace dentar::sound
