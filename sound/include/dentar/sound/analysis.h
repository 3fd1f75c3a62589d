// Spectrum analysis of rendered sound (tests, benchmarks, docs): a Hann-windowed
// magnitude spectrum through OpenCV's dft, its peak and centroid, and levels.
#pragma once

#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include "dentar/volume/result.h"

namespace dentar::sound {

struct Spectrum {
  std::vector<double> magnitude;  // bins 0..n/2
  double bin_hz = 0;
};
// Hann window over x[0, n), zero-padded to an optimal DFT size.
Spectrum magnitude_spectrum(const float* x, std::size_t n, double sample_rate_hz);
// The strongest bin in [fmin, fmax], refined by a parabola through its neighbours, Hz.
double peak_hz(const Spectrum& s, double fmin_hz, double fmax_hz);
// The fundamental of a harmonic tone in [fmin, fmax]: the candidate whose first
// `harmonics` multiples hold the most magnitude (harmonic sum; a broad resonance
// or noise band has no partials above it), refined like peak_hz, Hz.
double fundamental_hz(const Spectrum& s, double fmin_hz, double fmax_hz, int harmonics = 3);
// Power-weighted mean frequency in [fmin, fmax], Hz.
double centroid_hz(const Spectrum& s, double fmin_hz, double fmax_hz);
// Root mean square of x[0, n).
double rms(const float* x, std::size_t n);
// A spectrogram as a PNG: time left to right (hop 256 samples, window 1024, Hann),
// frequency 0 (bottom) to fs/2 (top) in 128 rows, level in dB over 80 dB of range, colour-mapped.
// Errors name the file.
Status write_spectrogram_png(const std::string& path, const std::vector<float>& x, double sample_rate_hz);
inline double to_db(double v) { return v > 0 ? 20.0 * std::log10(v) : -300.0; }

}  // namespace dentar::sound
