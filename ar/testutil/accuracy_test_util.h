// Test helpers shared by the tracking accuracy tests against the generator's
// truth (preset_accuracy_gl_test, mirror_accuracy_gl_test): the footage
// held in memory, the run size from the environment, and the error figures.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

#include "dentar/ar/pose_filter.h"
#include "dentar/ar/synth.h"

namespace dentar::ar::test {

// Rotation (degrees) and translation (millimetres) between two poses.
inline double rot_deg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return rotation_log(a.linear() * b.linear().transpose()).norm() * 180 / M_PI;
}
inline double trans_mm(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm() * 1e3;
}
// The p-quantile (0..1) as the element at floor(p * n); NaN when empty.
inline double pct(std::vector<double> v, double p) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::min<double>(v.size() - 1, std::floor(p * v.size())))];
}
inline double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? NAN : s / v.size();
}

// The rows of a table binned by key(sample): bins [-inf, e0), [e0, e1), ...,
// [en, +inf) of `edges`; row(lo, hi, members) for each bin with members,
// lo/hi its ends with the open ones as -1 and 999 (for the row's label).
template <class T, class Key, class Row>
void for_each_bin(const std::vector<T>& samples, Key key, std::vector<double> edges, Row row) {
  edges.insert(edges.begin(), -1e9);
  edges.push_back(1e9);
  for (std::size_t b = 0; b + 1 < edges.size(); ++b) {
    std::vector<const T*> in;
    for (const T& s : samples)
      if (key(s) >= edges[b] && key(s) < edges[b + 1]) in.push_back(&s);
    if (!in.empty()) row(std::max(-1.0, edges[b]), std::min(999.0, edges[b + 1]), in);
  }
}

// The run's footage size: 60 frames of 640x480 (the figures the tests assert
// as regression bounds), or DENTAR_PRESET_FRAMES / DENTAR_PRESET_SIZE (e.g.
// 150 / 1280x720) for the benchmark record, printed without asserting.
struct RunSize {
  int frames = 60, w = 640, h = 480;
  bool is_default() const { return frames == 60 && w == 640 && h == 480; }
};
inline RunSize run_size() {
  RunSize s;
  if (const char* f = std::getenv("DENTAR_PRESET_FRAMES")) s.frames = std::max(5, std::atoi(f));
  if (const char* z = std::getenv("DENTAR_PRESET_SIZE")) std::sscanf(z, "%dx%d", &s.w, &s.h);
  return s;
}

// The accuracy tests' generator options: `preset` at the run size, seed 5,
// 1000 bur samples (the preset and mirror tests run the same footage, so
// their figures compare).
inline SynthOptions accuracy_options(SynthPreset preset) {
  const RunSize z = run_size();
  SynthOptions o = synth_preset(preset);
  o.frames = z.frames;
  o.width = z.w;
  o.height = z.h;
  o.seed = 5;
  o.bur_samples = 1000;
  return o;
}

// Generator footage in memory: the station as rendered and o.frames frames,
// images and truth only (the accuracy tests read no mask: dropped to keep
// the memory down). error: the generator's, when it failed.
struct Footage {
  StationScene station;
  std::vector<SynthFrame> frames;
  std::string error;
};

inline Footage make_footage(const StationScene& station, const SynthOptions& o) {
  Footage f;
  auto g = SynthGenerator::create(station, o);
  if (!g) {
    f.error = g.error();
    return f;
  }
  f.station = (*g)->station();
  for (int i = 0; i < o.frames; ++i) {
    SynthFrame s;
    if (Status st = (*g)->next(s); !st) {
      f.error = st.error();
      return f;
    }
    s.mask.release();
    s.image = s.image.clone();
    f.frames.push_back(std::move(s));
  }
  return f;
}

}  // namespace dentar::ar::test
