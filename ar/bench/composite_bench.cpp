// Compositing time per frame and its error, on generator footage
// (`standard`, 1280x720, the procedural molar at 0.08 mm: ~300k triangles,
// the mirror in the mouth, the true poses). See docs/BENCHMARKS.md.
//   ./build-gl/ar/ar_composite_bench --benchmark_repetitions=1
// Each configuration first runs once over all frames to measure its error
// against the generator's masks (not timed), then is timed.
// Counters (ms are per frame, over all timed frames of all iterations):
//   p50_ms, p99_ms          compose() wall time (render + readback + blend + segmentation)
//   seg_p50_ms, seg_p99_ms  its segmentation stage
//   iou_sil                 mean IoU of the whole silhouette (occlusion, bur and mirror off)
//                           vs mask != 0 (only in the "sil" configurations)
//   iou_occ, iou_occ_min    IoU of tooth_visible > 127 vs mask == 64 (occlusion on)
//   bf_occ                  boundary F-score (2 px) of the same
//   tris                    tooth triangles drawn per frame (direct + reflection)
// Configurations (config:N): 0 naive (no culling, full mesh), 1 culling, 2 default
// (culling + LOD by screen error), 3-5 triangle budgets 100k/50k/20k, 6 occlusion
// off (silhouette IoU), 7 mirror off, 8 default on frames with a synthetic
// finger across the tooth, 9 the same without segmentation, 10-12 silhouette IoU
// (occlusion, bur and mirror off) at the full mesh / 50k budget / 20k budget.
// Environment: DENTAR_COMPOSITE_FRAMES (default 40), DENTAR_COMPOSITE_PRINT=1
// prints the per-frame quality of each configuration to stderr,
// DENTAR_COMPOSITE_DUMP=<dir> writes each configuration's first composite there,
// DENTAR_COMPOSITE_PRESET=standard|hard|mirror picks the footage; with PRINT, frame 0's
// mirror geometry is printed too (where the crown's reflection meets the mirror plane);
// DENTAR_COMPOSITE_NO_PHANTOMS=1 / DENTAR_COMPOSITE_NO_SEGMENTATION=1 turn the
// phantoms / the segmentation off in every configuration (debugging).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "dentar/ar/compositor.h"
#include "dentar/ar/egl_context.h"
#include "dentar/ar/synth.h"
#include "composite_test_util.h"

namespace dentar::ar {
namespace {

EglContext* context() {
  static EglContext* ctx = [] {
    auto r = EglContext::create();
    if (!r) {
      std::fprintf(stderr, "composite_bench: %s\n", r.error().c_str());
      std::exit(1);
    }
    std::fprintf(stderr, "composite_bench: %s\n", r->description().c_str());
    return new EglContext(std::move(r).value());
  }();
  return ctx;
}

struct Footage {
  // `frames` (image, mask, truth), the station as rendered and the uncut
  // tooth; its generator is released once the frames are made.
  test::ToothFootage synth;
  // The same frames with a synthetic finger across the visible tooth (the
  // generator's hand rarely crosses it); mask updated (finger = foreground).
  std::vector<SynthFrame> finger_frames;
};

const Footage& footage() {
  static const Footage* f = [] {
    context();
    auto* d = new Footage;
    StationScene st = default_station_scene();
    st.tooth_voxel_m = 0.08e-3;  // the ~300k-triangle molar
    const char* preset = std::getenv("DENTAR_COMPOSITE_PRESET");
    const auto p = parse_synth_preset(preset != nullptr ? preset : "standard");
    if (!p) {
      std::fprintf(stderr, "composite_bench: unknown DENTAR_COMPOSITE_PRESET '%s'\n", preset);
      std::exit(2);
    }
    SynthOptions o = synth_preset(*p);
    o.width = 1280;
    o.height = 720;
    const char* n = std::getenv("DENTAR_COMPOSITE_FRAMES");
    o.frames = n != nullptr ? std::max(1, std::atoi(n)) : 40;
    // The generator's tooth before the first cut (the scripted drilling
    // starts after ~1.4 s; later frames differ by the access cavity only).
    d->synth = test::tooth_footage(st, o);
    if (!d->synth.error.empty()) {
      std::fprintf(stderr, "composite_bench: %s\n", d->synth.error.c_str());
      std::exit(1);
    }
    d->synth.gen.reset();
    for (int i = 0; i < static_cast<int>(d->synth.frames.size()); ++i) {
      const SynthFrame& fr = d->synth.frames[i];
      SynthFrame ff = fr;
      ff.image = fr.image.clone();
      ff.mask = fr.mask.clone();
      if (const auto fi = test::finger_across_tooth(ff.mask, i, 50)) {
        const cv::Mat finger = paint_synthetic_finger(ff.image, *fi);
        ff.mask.setTo(kMaskForeground, (ff.mask == kMaskToothVisible) & finger);
      }
      d->finger_frames.push_back(std::move(ff));
    }
    std::fprintf(stderr, "composite_bench: %zu frames 1280x720, tooth %zu triangles\n",
                 d->synth.frames.size(), d->synth.tooth->triangles);
    return d;
  }();
  return *f;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(std::min<double>(v.size() - 1, q * (v.size() - 1) + 0.5));
  return v[i];
}

enum Config : int {
  kNaive = 0,   // no culling, full mesh, occlusion on
  kCull,        // culling, full mesh
  kAuto,        // culling + LOD by screen error (default options)
  kBudget100k,  // + triangle budget
  kBudget50k,
  kBudget20k,
  kNoOcclusion,  // default but phantoms and segmentation off (silhouette IoU)
  kNoMirror,     // default without the mirror pass
  kFinger,       // default, on the frames with a synthetic finger
  kFingerNoSeg,  // the same without segmentation (phantoms only)
  kSilFull,      // silhouette IoU (occlusion and bur off) at the full mesh,
  kSil50k,       //   with a 50k budget,
  kSil20k,       //   with a 20k budget
};

CompositorOptions options_for(int c) {
  CompositorOptions o;
  switch (c) {
    case kNaive:
      o.cull_chunks = false;
      o.lod_max_error_px = 0;
      break;
    case kCull:
      o.lod_max_error_px = 0;
      break;
    case kBudget100k:
      o.triangle_budget = 100000;
      break;
    case kBudget50k:
      o.triangle_budget = 50000;
      break;
    case kBudget20k:
      o.triangle_budget = 20000;
      break;
    case kNoOcclusion:
      // The virtual bur and the mirror face (when reflecting) hide the tooth too.
      o.phantoms = o.segmentation = o.draw_bur = o.mirror = false;
      break;
    case kNoMirror:
      o.mirror = false;
      break;
    case kFingerNoSeg:
      o.segmentation = false;
      break;
    case kSilFull:
    case kSil50k:
    case kSil20k:
      o.phantoms = o.segmentation = o.draw_bur = o.mirror = false;
      o.lod_max_error_px = c == kSilFull ? 0.0 : o.lod_max_error_px;
      o.triangle_budget = c == kSil50k ? 50000 : (c == kSil20k ? 20000 : 0);
      break;
    default:
      break;
  }
  if (std::getenv("DENTAR_COMPOSITE_NO_PHANTOMS") != nullptr) o.phantoms = false;  // debugging
  if (std::getenv("DENTAR_COMPOSITE_NO_SEGMENTATION") != nullptr) o.segmentation = false;
  return o;
}

void BM_Composite(benchmark::State& state) {
  const Footage& fo = footage();
  const int config = static_cast<int>(state.range(0));
  auto comp = Compositor::create(fo.synth.station, options_for(config));
  if (!comp) {
    state.SkipWithError(comp.error().c_str());
    return;
  }
  const bool occlusion = config != kNoOcclusion && config < kSilFull;
  const auto& frames = (config == kFinger || config == kFingerNoSeg) ? fo.finger_frames : fo.synth.frames;
  const bool print = std::getenv("DENTAR_COMPOSITE_PRINT") != nullptr;
  if (print) {
    CompositeResult r0;
    (void)comp->compose(*fo.synth.tooth->surface, test::truth_input(fo.synth.frames.front()), r0);
    const auto tris = comp->lod_triangle_counts();
    const auto err = comp->lod_errors_m();
    {
      const FrameTruth& t = fo.synth.frames.front().truth;
      const Eigen::Isometry3d T_cam_mir = t.T_cam_mir;
      const Eigen::Vector3d n = T_cam_mir.linear().col(2), pm = T_cam_mir.translation();
      const Eigen::Vector3d d = pm.normalized(), r = d - 2 * d.dot(n) * n;
      const Eigen::Vector3d tc = t.T_cam_tooth * Eigen::Vector3d(0, 0, 0.004);  // crown
      const Eigen::Vector3d tr = tc - 2 * n * n.dot(tc - pm);                  // reflected
      const Eigen::Vector3d hit = tr * (n.dot(pm) / n.dot(tr));  // ray to tr meets the plane
      std::fprintf(stderr,
                   "mirror: n.(-p) = %.4f, angle(reflected view ray, to crown) = %.1f deg, "
                   "ray to the reflected crown meets the plane %.1f mm from the mirror centre "
                   "(radius %.1f mm)\n",
                   n.dot(-pm), std::acos(r.normalized().dot((tc - pm).normalized())) * 180 / M_PI,
                   (hit - pm).norm() * 1e3, fo.synth.station.calibration.mirror_radius_m * 1e3);
    }
    for (std::size_t l = 0; l < tris.size(); ++l)
      std::fprintf(stderr, "config %d: level %zu: %zu triangles, error %.4f mm\n", config, l,
                   tris[l], err[l] * 1e3);
  }
  // Error pass (untimed).
  double iou_sum = 0, iou_min = 1, bf_sum = 0, tris = 0;
  CompositeResult r;
  for (const auto& f : frames) {
    if (Status s = comp->compose(*fo.synth.tooth->surface, test::truth_input(f), r); !s) {
      state.SkipWithError(s.error().c_str());
      return;
    }
    const cv::Mat truth = occlusion ? cv::Mat(f.mask == kMaskToothVisible) : cv::Mat(f.mask != 0);
    const MaskScore m = compare_masks(r.tooth_visible > 127, truth);
    iou_sum += m.iou;
    iou_min = std::min(iou_min, m.iou);
    bf_sum += m.boundary_f;
    tris += static_cast<double>(r.triangles_drawn);
    const char* dump_frame = std::getenv("DENTAR_COMPOSITE_DUMP_FRAME");
    if (const char* dir = std::getenv("DENTAR_COMPOSITE_DUMP");
        dir != nullptr && f.truth.frame == (dump_frame != nullptr ? std::atoi(dump_frame) : 0)) {
      const std::string base = std::string(dir) + "/composite_config" + std::to_string(config);
      cv::imwrite(base + ".png", r.image);
      if (!r.region.empty()) {
        const cv::Rect z = (r.region + cv::Size(r.region.width, r.region.height)) -
                           cv::Point(r.region.width / 2, r.region.height / 2);
        cv::Mat crop;
        cv::resize(r.image(z & cv::Rect(0, 0, r.image.cols, r.image.rows)), crop, cv::Size(), 3,
                   3, cv::INTER_NEAREST);
        cv::imwrite(base + "_zoom.png", crop);
        // Error map: green = truth only, red = ours only, white = both.
        cv::Mat err(r.image.size(), CV_8UC3, cv::Scalar::all(0));
        const cv::Mat ours = r.tooth_visible > 127;
        err.setTo(cv::Scalar(255, 255, 255), ours & truth);
        err.setTo(cv::Scalar(0, 255, 0), ~ours & truth);
        err.setTo(cv::Scalar(0, 0, 255), ours & ~truth);
        cv::Mat video_crop, err_crop;
        cv::resize(err(z & cv::Rect(0, 0, r.image.cols, r.image.rows)), err_crop, cv::Size(), 3, 3,
                   cv::INTER_NEAREST);
        cv::resize(f.image(z & cv::Rect(0, 0, r.image.cols, r.image.rows)), video_crop, cv::Size(),
                   3, 3, cv::INTER_NEAREST);
        cv::imwrite(base + "_error.png", err_crop);
        cv::imwrite(base + "_video.png", video_crop);
      }
    }
    if (print)
      std::fprintf(stderr,
                   "config %d frame %3d: iou %.4f bf %.4f truth_px %d hidden_px %d fg_px %d "
                   "lod %d tris %zu mirror %d | sync %.2f render %.2f read %.2f seg %.2f blend %.2f "
                   "total %.2f ms, region %dx%d\n",
                   config, f.truth.frame, m.iou, m.boundary_f, f.truth.tooth_px,
                   f.truth.tooth_hidden_px, cv::countNonZero(f.mask == kMaskForeground),
                   r.lod_level, r.triangles_drawn, r.mirror_drawn ? 1 : 0, r.timing.sync_ms,
                   r.timing.render_ms, r.timing.readback_ms, r.timing.segment_ms,
                   r.timing.blend_ms, r.timing.total_ms, r.region.width, r.region.height);
  }
  const double nf = static_cast<double>(frames.size());
  // Timed pass.
  std::vector<double> total_ms, seg_ms;
  std::size_t i = 0;
  for (auto _ : state) {
    const auto& f = frames[i++ % frames.size()];
    const auto t0 = std::chrono::steady_clock::now();
    if (Status s = comp->compose(*fo.synth.tooth->surface, test::truth_input(f), r); !s) {
      state.SkipWithError(s.error().c_str());
      return;
    }
    total_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    seg_ms.push_back(r.timing.segment_ms);
  }
  state.counters["p50_ms"] = percentile(total_ms, 0.5);
  state.counters["p99_ms"] = percentile(total_ms, 0.99);
  state.counters["seg_p50_ms"] = percentile(seg_ms, 0.5);
  state.counters["seg_p99_ms"] = percentile(seg_ms, 0.99);
  state.counters[occlusion ? "iou_occ" : "iou_sil"] = iou_sum / nf;
  state.counters[occlusion ? "iou_occ_min" : "iou_sil_min"] = iou_min;
  state.counters["bf"] = bf_sum / nf;
  state.counters["tris"] = tris / nf;
}
BENCHMARK(BM_Composite)
    ->ArgName("config")
    ->DenseRange(kNaive, kSil20k)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(80);

// The segmentation alone, worst case: every pixel of a 1280x720 frame
// classified (in the compositor it runs on the tooth's region only).
void BM_SegmentFullFrame(benchmark::State& state) {
  const Footage& fo = footage();
  const SynthFrame& f = fo.synth.frames.front();
  cv::Mat expected(f.image.rows, f.image.cols, CV_8UC4, cv::Scalar(217, 115, 122, 255));  // gum
  cv::Mat region(f.image.rows, f.image.cols, CV_8UC1, cv::Scalar(255));
  cv::Mat fg;
  ForegroundSegmenter seg;
  std::vector<double> ms;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    seg.segment(f.image, expected, region, fg);
    benchmark::DoNotOptimize(fg.data);
    ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  state.counters["p50_ms"] = percentile(ms, 0.5);
  state.counters["p99_ms"] = percentile(ms, 0.99);
}
BENCHMARK(BM_SegmentFullFrame)->Unit(benchmark::kMillisecond)->Iterations(50);

}  // namespace
}  // namespace dentar::ar

BENCHMARK_MAIN();
