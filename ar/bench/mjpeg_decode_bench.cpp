// Motion JPEG decode cost per camera frame (issue 28, session 18): cv::imdecode
// (what the live source used before) against MjpegDecoder (TurboJPEG directly)
// to BGR and to YUYV from the JPEG's planes, each with the accurate and the fast
// IDCT, on the same frames, at 640x480, 1280x720 and 1920x1080.
//
// Frames: the generator's `webcam` preset (its sensor noise, vignetting, blur;
// its own JPEG step off), 8 frames per size, encoded once as a UVC camera sends
// them: JPEG 4:2:2 at quality 80 (TurboJPEG's encoder), or with
// DENTAR_MJPEG_SUBSAMP=420 at 4:2:0 (what `dentar synth --webcam`'s camera.avi
// holds). Each iteration decodes the next frame of the size (round robin).
//
// Benchmarks, one per (decoder, size):
//   BM_Decode/<decoder>/<W>/<H>        the decode alone
//   BM_DecodeToRgba/<decoder>/<W>/<H>  the decode and the compositor's one CPU
//       conversion of the whole frame into its RGBA upload (BGR: COLOR_BGR2RGBA,
//       YUYV: COLOR_YUV2RGBA_YUYV; compositor.cpp on llvmpipe): what a shown
//       frame costs up to the upload
// decoders: 0 imdecode (cv::imdecode, IMREAD_COLOR), 1 tj_bgr, 2 tj_bgr_fastdct,
// 3 tj_yuyv, 4 tj_yuyv_fastdct.
// Counters (per benchmark, over all frames of the size, against cv::imdecode's
// BGR; YUYV output is compared after OpenCV's COLOR_YUV2BGR_YUYV, the conversion
// the compositor and the recorder use): err_max / err_mean (abs, 0..255 per
// channel), luma_err_max (the tracker's grey: BGR2GRAY vs the YUYV luma expanded
// as frame_gray.cpp does), jpeg_kB (mean frame size).
//
// Timing: the CPU column (thread CPU time, mean of a run's iterations); with
// repetitions, its median and p99 over the runs; and per run, frame_p50_ms and
// frame_p99_ms, the median and p99 of the frames' own thread CPU times
// (CLOCK_THREAD_CPUTIME_ID around each iteration). Run:
//   build/ar/ar_mjpeg_decode_bench --benchmark_repetitions=15 --benchmark_min_time=0.2
//       --benchmark_report_aggregates_only=true   (one line)
#include <benchmark/benchmark.h>

#include <turbojpeg.h>

#include <time.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "dentar/ar/egl_context.h"
#include "dentar/ar/mjpeg_decoder.h"
#include "dentar/ar/synth.h"

namespace {

using Bytes = std::vector<std::uint8_t>;
constexpr int kFrames = 8;
constexpr std::array<const char*, 5> kNames = {"imdecode", "tj_bgr", "tj_bgr_fastdct", "tj_yuyv", "tj_yuyv_fastdct"};

dentar::ar::EglContext* context() {
  static dentar::ar::EglContext* c = [] {
    auto r = dentar::ar::EglContext::create();
    return r ? new dentar::ar::EglContext(std::move(r).value()) : nullptr;
  }();
  return c;
}

double thread_cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

Bytes encode(const cv::Mat& bgr, int subsamp, int quality) {
  tjhandle h = tjInitCompress();
  unsigned char* buf = nullptr;
  unsigned long size = 0;
  Bytes out;
  if (tjCompress2(h, bgr.data, bgr.cols, static_cast<int>(bgr.step[0]), bgr.rows, TJPF_BGR, &buf, &size, subsamp,
                  quality, 0) == 0)
    out.assign(buf, buf + size);
  tjFree(buf);
  tjDestroy(h);
  return out;
}

// The frames of one size, generated and encoded once per process.
const std::vector<Bytes>* frames(int w, int h, std::string& error) {
  static std::map<std::pair<int, int>, std::vector<Bytes>> cache;
  auto it = cache.find({w, h});
  if (it != cache.end()) return &it->second;
  if (context() == nullptr) {
    error = "no headless EGL context (the generator renders the frames)";
    return nullptr;
  }
  dentar::ar::SynthOptions o = dentar::ar::synth_preset(dentar::ar::SynthPreset::kWebcam);
  o.width = w;
  o.height = h;
  o.frames = kFrames;
  o.seed = 3;
  o.camera.jpeg_quality = 0;  // the bench encodes them itself, once
  auto g = dentar::ar::SynthGenerator::create(dentar::ar::default_station_scene(), o);
  if (!g) {
    error = g.error();
    return nullptr;
  }
  const char* sub = std::getenv("DENTAR_MJPEG_SUBSAMP");
  const int subsamp = sub != nullptr && std::string(sub) == "420" ? TJSAMP_420 : TJSAMP_422;
  std::vector<Bytes> v;
  for (int i = 0; i < kFrames; ++i) {
    dentar::ar::SynthFrame f;
    if (auto s = (*g)->next(f); !s) {
      error = s.error();
      return nullptr;
    }
    v.push_back(encode(f.image, subsamp, 80));
  }
  return &cache.emplace(std::make_pair(w, h), std::move(v)).first->second;
}

// One decode with decoder k; false when it failed.
bool decode(int k, dentar::ar::MjpegDecoder& acc, dentar::ar::MjpegDecoder& fast, const Bytes& j, cv::Mat& out) {
  using dentar::ar::MjpegOutput;
  switch (k) {
    case 0: out = cv::imdecode(j, cv::IMREAD_COLOR); return !out.empty();
    case 1: return acc.decode(j.data(), j.size(), MjpegOutput::kBgr, out);
    case 2: return fast.decode(j.data(), j.size(), MjpegOutput::kBgr, out);
    case 3: return acc.decode(j.data(), j.size(), MjpegOutput::kYuyv, out);
    default: return fast.decode(j.data(), j.size(), MjpegOutput::kYuyv, out);
  }
}

void counters(benchmark::State& state, int k, const std::vector<Bytes>& fr) {
  dentar::ar::MjpegDecoder acc(false), fast(true);
  double emax = 0, esum = 0, lmax = 0, bytes = 0;
  std::size_t n = 0;
  for (const Bytes& j : fr) {
    cv::Mat ref = cv::imdecode(j, cv::IMREAD_COLOR), got, bgr, d;
    if (!decode(k, acc, fast, j, got)) continue;
    if (got.type() == CV_8UC2)
      cv::cvtColor(got, bgr, cv::COLOR_YUV2BGR_YUYV);
    else
      bgr = got;
    cv::absdiff(bgr, ref, d);
    emax = std::max(emax, cv::norm(d, cv::NORM_INF));
    esum += cv::sum(d.reshape(1))[0];
    n += d.total() * 3;
    cv::Mat gref;
    cv::cvtColor(ref, gref, cv::COLOR_BGR2GRAY);
    for (int r = 0; r < got.rows; ++r)
      for (int c = 0; c < got.cols; ++c) {
        const int g = got.type() == CV_8UC2
                          ? std::clamp(static_cast<int>(std::lround((got.at<cv::Vec2b>(r, c)[0] - 16) * 255.0 / 219.0)), 0, 255)
                          : static_cast<int>((got.at<cv::Vec3b>(r, c)[0] * 1868 + got.at<cv::Vec3b>(r, c)[1] * 9617 +
                                              got.at<cv::Vec3b>(r, c)[2] * 4899 + (1 << 13)) >> 14);
        lmax = std::max(lmax, static_cast<double>(std::abs(g - gref.at<uchar>(r, c))));
      }
    bytes += static_cast<double>(j.size());
  }
  state.counters["err_max"] = emax;
  state.counters["err_mean"] = n > 0 ? esum / static_cast<double>(n) : NAN;
  state.counters["luma_err_max"] = lmax;
  state.counters["jpeg_kB"] = bytes / std::max<std::size_t>(1, fr.size()) / 1024.0;
}

void run(benchmark::State& state, bool to_rgba) {
  const int k = static_cast<int>(state.range(0)), w = static_cast<int>(state.range(1)),
            h = static_cast<int>(state.range(2));
  std::string error;
  const std::vector<Bytes>* fr = frames(w, h, error);
  if (fr == nullptr) {
    state.SkipWithError(error.c_str());
    return;
  }
  state.SetLabel(kNames[static_cast<std::size_t>(k)]);
  dentar::ar::MjpegDecoder acc(false), fast(true);
  cv::Mat out, rgba;
  std::size_t i = 0;
  std::vector<double> per_frame_ms;  // thread CPU time of each iteration
  per_frame_ms.reserve(1 << 14);
  for (auto _ : state) {
    const double t0 = thread_cpu_ms();
    const Bytes& j = (*fr)[i++ % fr->size()];
    if (!decode(k, acc, fast, j, out)) {
      state.SkipWithError("decode failed");
      break;
    }
    if (to_rgba)
      cv::cvtColor(out, rgba, out.type() == CV_8UC2 ? cv::COLOR_YUV2RGBA_YUYV : cv::COLOR_BGR2RGBA);
    benchmark::DoNotOptimize(out.data);
    benchmark::DoNotOptimize(rgba.data);
    out.release();  // a camera frame is a new buffer each time (handed to the frame thread)
    if (per_frame_ms.size() < per_frame_ms.capacity()) per_frame_ms.push_back(thread_cpu_ms() - t0);
  }
  // Per-frame CPU time within this run (repetition): median and p99 of the frames.
  std::sort(per_frame_ms.begin(), per_frame_ms.end());
  if (!per_frame_ms.empty()) {
    state.counters["frame_p50_ms"] = per_frame_ms[per_frame_ms.size() / 2];
    state.counters["frame_p99_ms"] =
        per_frame_ms[std::min(per_frame_ms.size() - 1, static_cast<std::size_t>(0.99 * per_frame_ms.size()))];
  }
  if (!to_rgba && state.thread_index() == 0) counters(state, k, *fr);
}

void BM_Decode(benchmark::State& state) { run(state, false); }
void BM_DecodeToRgba(benchmark::State& state) { run(state, true); }

double p99(const std::vector<double>& v) {
  if (v.empty()) return 0;
  std::vector<double> s = v;
  std::sort(s.begin(), s.end());
  return s[std::min(s.size() - 1, static_cast<std::size_t>(std::ceil(0.99 * static_cast<double>(s.size()))) - 1)];
}

void sizes(benchmark::internal::Benchmark* b) {
  for (const auto& [w, h] : {std::pair{640, 480}, std::pair{1280, 720}, std::pair{1920, 1080}})
    for (int k = 0; k < static_cast<int>(kNames.size()); ++k) b->Args({k, w, h});
  b->ArgNames({"decoder", "w", "h"});
  b->Unit(benchmark::kMillisecond);
  b->ComputeStatistics("p99", p99);
}

BENCHMARK(BM_Decode)->Apply(sizes);
BENCHMARK(BM_DecodeToRgba)->Apply(sizes);

}  // namespace

BENCHMARK_MAIN();
