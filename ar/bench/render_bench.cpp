// Render + readback time per frame on the headless EGL context (llvmpipe on
// CPU-only machines) for the default procedural molar. See docs/BENCHMARKS.md.
//   ./build/ar/ar_render_bench --benchmark_repetitions=3
// Counters: triangles drawn, p50_ms / p99_ms of per-frame wall time (each
// frame ends with glReadPixels, which waits for the GPU/rasteriser to finish,
// so a frame's time is the whole render + warp + readback).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <opencv2/core.hpp>
#include <vector>

#include "dentar/ar/egl_context.h"
#include "dentar/ar/renderer.h"
#include "dentar/volume/procedural_tooth.h"

namespace dentar::ar {
namespace {

namespace dv = dentar::volume;

// One context for the process, never destroyed (see gl_test_context.h).
EglContext* context() {
  static EglContext* ctx = [] {
    auto r = EglContext::create();
    if (!r) {
      std::fprintf(stderr, "render_bench: %s\n", r.error().c_str());
      std::exit(1);
    }
    std::fprintf(stderr, "render_bench: %s\n", r->description().c_str());
    return new EglContext(std::move(r).value());
  }();
  return ctx;
}

struct DefaultTooth {
  dv::VoxelVolume volume;
  std::unique_ptr<dv::Surface> surface;
  Eigen::Vector3d lo, hi;
};
const DefaultTooth& default_tooth() {
  static const DefaultTooth* t = [] {
    auto* d = new DefaultTooth{std::move(dv::make_molar({})).value(), nullptr, {}, {}};
    d->surface = std::make_unique<dv::Surface>(d->volume);
    d->surface->extract_all();
    d->lo.setConstant(1e9);
    d->hi.setConstant(-1e9);
    for (const auto& c : d->surface->chunks()) {
      for (const auto& v : c.vertices) {
        d->lo = d->lo.cwiseMin(v.position_m.cast<double>());
        d->hi = d->hi.cwiseMax(v.position_m.cast<double>());
      }
    }
    return d;
  }();
  return *t;
}

calibration::CameraIntrinsics camera(int width, bool distorted) {
  calibration::CameraIntrinsics k;
  if (width == 640) {
    k.width = 640;
    k.height = 480;
    k.fx = k.fy = 600.0;
  } else {
    k.width = 1280;
    k.height = 720;
    k.fx = k.fy = 900.0;
  }
  k.cx = 0.5 * (k.width - 1);
  k.cy = 0.5 * (k.height - 1);
  if (distorted) k.dist = {-0.28, 0.09, 0.0008, -0.0005, -0.01};
  return k;
}

// Looking down at the crown from distance_m, tilted 25 degrees.
Eigen::Isometry3d view(const DefaultTooth& t, double distance_m) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(0.45, Eigen::Vector3d::UnitX()) *
                Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  const Eigen::Vector3d centre = 0.5 * (t.lo + t.hi);
  T.translation() = Eigen::Vector3d(0, 0, distance_m) - T.linear() * centre;
  return T;
}

void report(benchmark::State& state, std::vector<double>& ms) {
  std::sort(ms.begin(), ms.end());
  if (ms.empty()) return;
  state.counters["p50_ms"] = ms[ms.size() / 2];
  state.counters["p99_ms"] = ms[std::min(ms.size() - 1, ms.size() * 99 / 100)];
}

RendererOptions options(std::int64_t distort_arg) {
  RendererOptions o;
  o.warp = distort_arg == 2 ? RendererOptions::WarpMode::kCpu : RendererOptions::WarpMode::kGpu;
  return o;
}

// Args: width (640 | 1280), distortion (0 none | 1 GPU warp | 2 cv::remap
// warp), camera distance (mm).
void BM_RenderToothReadback(benchmark::State& state) {
  context();
  const DefaultTooth& tooth = default_tooth();
  const auto k = camera(static_cast<int>(state.range(0)), state.range(1) != 0);
  auto renderer = Renderer::create(k, options(state.range(1)));
  auto tr = ToothRenderer::create();
  if (!renderer || !tr) {
    state.SkipWithError((renderer ? tr.error() : renderer.error()).c_str());
    return;
  }
  tr->sync(*tooth.surface);
  const Eigen::Isometry3d T = view(tooth, 1e-3 * static_cast<double>(state.range(2)));
  cv::Mat rgba;
  std::vector<double> ms;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    renderer->begin_frame();
    tr->draw(renderer->clip_from_cam(), T);
    renderer->end_frame();
    renderer->read_rgba(rgba);
    const auto t1 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(rgba.data);
    ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
  }
  report(state, ms);
  state.counters["triangles"] = static_cast<double>(tr->triangle_count());
  state.counters["covered_px"] = cv::countNonZero(rgba.reshape(1, rgba.rows * rgba.cols).col(3));
}
BENCHMARK(BM_RenderToothReadback)
    ->ArgNames({"width", "distort", "dist_mm"})
    ->Args({640, 0, 60})
    ->Args({640, 1, 60})
    ->Args({640, 2, 60})
    ->Args({1280, 0, 60})
    ->Args({1280, 1, 60})
    ->Args({1280, 2, 60})
    ->Args({640, 0, 300})
    ->Args({1280, 2, 300})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The fixed cost of a frame without geometry: clear, warp, readback.
void BM_EmptyFrameReadback(benchmark::State& state) {
  context();
  const auto k = camera(static_cast<int>(state.range(0)), state.range(1) != 0);
  auto renderer = Renderer::create(k, options(state.range(1)));
  if (!renderer) {
    state.SkipWithError(renderer.error().c_str());
    return;
  }
  cv::Mat rgba;
  std::vector<double> ms;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    renderer->begin_frame();
    renderer->end_frame();
    renderer->read_rgba(rgba);
    const auto t1 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(rgba.data);
    ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
  }
  report(state, ms);
}
BENCHMARK(BM_EmptyFrameReadback)
    ->ArgNames({"width", "distort"})
    ->Args({640, 0})
    ->Args({640, 1})
    ->Args({640, 2})
    ->Args({1280, 0})
    ->Args({1280, 1})
    ->Args({1280, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
}  // namespace dentar::ar

BENCHMARK_MAIN();
