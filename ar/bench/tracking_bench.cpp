// Tracking speed and accuracy on generated footage (rendered once per clip
// in the setup with SynthGenerator, headless EGL). One core: libapriltag
// threads = 1. Every benchmark iteration tracks one frame; per-frame times
// are recorded and reported as counters (median and p99 in ms), with the
// recall (mannequin tags found / tags a detector should find, per the
// truth) and the mannequin pose error against the truth (p95). The
// `_paced` and `_async` rows feed frames every 33.3 ms as a camera does
// (async: the full-frame search on a worker thread, the live app's default).
//
//   build-*/ar/ar_tracking_bench --benchmark_filter=Track
//   build-*/ar/ar_tracking_bench --benchmark_filter='Jitter|Step'
//   DENTAR_BENCH_FRAMELOG=DIR: one CSV per Track row in DIR, a line per
//   frame (thread CPU, wall, detect/pose time, regions, searched fraction,
//   tags), to find what the slow frames are.
#include <benchmark/benchmark.h>
#include <time.h>

#include <cstdlib>
#include <fstream>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "dentar/ar/egl_context.h"
#include "dentar/ar/pose_filter.h"
#include "dentar/ar/synth.h"
#include "dentar/ar/tracker.h"
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>

namespace dentar::ar {
namespace {

struct Clip {
  StationScene station;
  std::vector<cv::Mat> images;
  std::vector<FrameTruth> truth;
  std::string error;
};

EglContext* egl() {
  static EglContext* ctx = [] {
    auto r = EglContext::create();
    if (!r) {
      std::fprintf(stderr, "no EGL context: %s\n", r.error().c_str());
      return static_cast<EglContext*>(nullptr);
    }
    return new EglContext(std::move(r).value());  // never destroyed (see gl_test_context.h)
  }();
  return ctx;
}

// Clip kinds: the presets, a frontal view with 8-12 head tags in sight (the
// timing goal's condition), and static views for jitter / step response.
enum class Kind { kStandard, kHard, kFrontal, kStatic, kStaticStep };

Clip render(Kind kind, int w, int h, int frames) {
  Clip c;
  if (!egl() || !egl()->make_current().ok()) {
    c.error = "no EGL context";
    return c;
  }
  SynthOptions o = synth_preset(kind == Kind::kHard ? SynthPreset::kHard : SynthPreset::kStandard);
  o.frames = frames;
  o.fps = 30;
  o.width = w;
  o.height = h;
  o.seed = 11;
  o.bur_samples = 1000;
  if (kind == Kind::kFrontal) {
    o.azimuth_centre_rad = 0.0;
    o.azimuth_amplitude_rad = 0.12;
    o.elevation_centre_rad = 0.15;
    o.distance_min_m = 0.30;
    o.distance_max_m = 0.36;
  }
  const bool still = kind == Kind::kStatic || kind == Kind::kStaticStep;
  if (still) {
    // A truly static view: the generator's head tremor (1.5-3.5 Hz) never
    // stops, so one noiseless frame is rendered and every frame of the clip
    // is that frame plus fresh sensor noise (the standard preset's read and
    // shot noise).
    o.motion_speed = 0;
    o.look_at_jitter_m = 0;
    o.read_noise_dn = 0;
    o.shot_noise_gain = 0;
    o.exposure_variation = 0;
    // The step: the camera 2 mm further away (and nothing else changes).
    const double d = kind == Kind::kStaticStep ? 0.352 : 0.35;
    o.distance_min_m = o.distance_max_m = d;
    o.frames = 1;
  }
  auto g = SynthGenerator::create(default_station_scene(), o);
  if (!g) {
    c.error = g.error();
    return c;
  }
  c.station = (*g)->station();
  if (still) {
    SynthFrame f;
    if (Status s = (*g)->next(f); !s) {
      c.error = s.error();
      return c;
    }
    const SynthOptions std_o = synth_preset(SynthPreset::kStandard);
    cv::RNG rng(static_cast<std::uint64_t>(w) * 7 + static_cast<std::uint64_t>(kind));
    cv::Mat clean;
    f.image.convertTo(clean, CV_32FC3);
    for (int i = 0; i < frames; ++i) {
      cv::Mat sigma, noise(clean.size(), CV_32FC3);
      cv::sqrt(clean * std_o.shot_noise_gain + std_o.read_noise_dn * std_o.read_noise_dn, sigma);
      rng.fill(noise, cv::RNG::NORMAL, 0.0, 1.0);
      cv::Mat noisy = clean + noise.mul(sigma), img;
      noisy.convertTo(img, CV_8UC3);  // saturating
      c.images.push_back(img);
      FrameTruth t = f.truth;
      t.frame = i;
      t.time_s = i / o.fps;
      c.truth.push_back(t);
    }
    return c;
  }
  for (int i = 0; i < frames; ++i) {
    SynthFrame f;
    if (Status s = (*g)->next(f); !s) {
      c.error = s.error();
      return c;
    }
    c.images.push_back(f.image);
    c.truth.push_back(f.truth);
  }
  return c;
}

const Clip& clip(Kind kind, int w, int h, int frames) {
  static std::map<std::tuple<int, int, int, int>, Clip> cache;
  const auto key = std::make_tuple(static_cast<int>(kind), w, h, frames);
  auto it = cache.find(key);
  if (it == cache.end()) it = cache.emplace(key, render(kind, w, h, frames)).first;
  return it->second;
}

// CPU time of this thread, ms: what one core spends, whatever the other
// processes sharing the machine do to the wall clock.
double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::min<double>(v.size() - 1, std::floor(p * v.size())))];
}
double rot_deg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return rotation_log(a.linear() * b.linear().transpose()).norm() * 180 / M_PI;
}
double trans_mm(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm() * 1e3;
}

// Mannequin tags a detector should find (as in tracker_gl_test.cpp).
std::set<int> expected_tags(const FrameTruth& t) {
  std::set<int> ids;
  for (const TagTruth& g : t.tags)
    if (!g.on_mirror && g.in_image && g.visible_fraction > 0.95 && g.side_px >= 14 &&
        g.view_angle_rad < 70 * M_PI / 180)
      ids.insert(g.id);
  return ids;
}

struct Config {
  const char* name;
  bool roi;
  double decimation;      // full frame
  double roi_decimation;  // inside regions
  double roi_decimate_above_px;
  // kAsync: the full-frame search on a worker thread (the live app's
  // choice). Paced: frames come every 33.3 ms, as a camera delivers them
  // (the worker then has the time it has in a live run; the frame thread
  // starts each frame with the caches another thread left).
  DiscoveryMode discovery = DiscoveryMode::kInline;
  bool paced = false;
  double motion_across = 1.0;  // TrackerOptions::roi_motion_across
};

// clip_name: the registered clip's name (for DENTAR_BENCH_FRAMELOG's file).
void BM_Track(benchmark::State& state, const char* clip_name, Kind kind, int w, int h, int frames, Config cfg) {
  const Clip& c = clip(kind, w, h, frames);
  if (!c.error.empty()) {
    state.SkipWithError(c.error.c_str());
    return;
  }
  TrackerOptions o;
  o.detector.decimation = cfg.decimation;
  o.detector.threads = 1;
  o.predicted_regions = cfg.roi;
  o.roi_decimation = cfg.roi_decimation;
  o.roi_decimate_above_px = cfg.roi_decimate_above_px;
  o.discovery = cfg.discovery;
  o.roi_motion_across = cfg.motion_across;
  const bool paced = cfg.paced;
  auto tr = Tracker::create(c.station, o);
  if (!tr) {
    state.SkipWithError(tr.error().c_str());
    return;
  }
  std::vector<double> total, detect, cpu, wall, cpu_roi, t_err, r_err, ft_err, fr_err;
  int expected = 0, found = 0, full = 0, visible = 0, measured = 0;
  std::size_t i = 0;
  auto due = std::chrono::steady_clock::now();
  std::ofstream log;
  if (const char* dir = std::getenv("DENTAR_BENCH_FRAMELOG")) {
    const std::string name = std::string(clip_name) + "_" + cfg.name;
    log.open(std::string(dir) + "/" + name + ".csv");
    if (!log) {
      state.SkipWithError(("DENTAR_BENCH_FRAMELOG: cannot write in " + std::string(dir)).c_str());
      return;
    }
    log << "frame,cpu_ms,wall_ms,detect_ms,pose_ms,full,regions,searched,tags,measured,merged\n";
  }
  for (auto _ : state) {
    if (i == c.images.size()) {  // wrap: a new clip for the tracker
      i = 0;
      tr->reset();
    }
    if (paced) {
      state.PauseTiming();
      due += std::chrono::microseconds(33333);
      std::this_thread::sleep_until(due);
      state.ResumeTiming();
    }
    const double t = c.truth[i].time_s;
    const double c0 = thread_cpu_ms();
    const auto w0 = std::chrono::steady_clock::now();
    auto f = tr->track(c.images[i], t, t);
    cpu.push_back(thread_cpu_ms() - c0);
    wall.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - w0).count());
    if (!f) {
      state.SkipWithError(f.error().c_str());
      return;
    }
    total.push_back(f->timing.total_ms);
    detect.push_back(f->timing.detect_ms);
    if (log)
      log << i << ',' << cpu.back() << ',' << wall.back() << ',' << f->timing.detect_ms << ','
          << f->timing.pose_ms << ',' << (f->full_frame ? 1 : 0) << ',' << f->regions << ','
          << f->searched_fraction << ',' << f->tags_detected << ','
          << (f->mannequin.measured ? 1 : 0) << ',' << f->discovery_merged << '\n';
    full += f->full_frame ? 1 : 0;
    if (!f->full_frame) cpu_roi.push_back(cpu.back());
    const std::set<int> want = expected_tags(c.truth[i]);
    expected += static_cast<int>(want.size());
    visible += static_cast<int>(want.size());
    for (const DetectedTag& d : f->tags) found += want.count(d.id) ? 1 : 0;
    if (f->mannequin.measured) {
      ++measured;
      t_err.push_back(trans_mm(f->mannequin.T_cam_body_measured, c.truth[i].T_cam_man));
      r_err.push_back(rot_deg(f->mannequin.T_cam_body_measured, c.truth[i].T_cam_man));
      ft_err.push_back(trans_mm(f->mannequin.T_cam_body, c.truth[i].T_cam_man));
      fr_err.push_back(rot_deg(f->mannequin.T_cam_body, c.truth[i].T_cam_man));
    }
    ++i;
  }
  const double n = static_cast<double>(total.size());
  state.counters["med_ms"] = percentile(total, 0.5);
  state.counters["p99_ms"] = percentile(total, 0.99);
  state.counters["det_med_ms"] = percentile(detect, 0.5);
  state.counters["cpu_med_ms"] = percentile(cpu, 0.5);
  state.counters["cpu_p99_ms"] = percentile(cpu, 0.99);
  // Wall time of the whole track() call as the caller sees it.
  state.counters["wall_med_ms"] = percentile(wall, 0.5);
  state.counters["wall_p99_ms"] = percentile(wall, 0.99);
  // The region frames alone (the periodic full-frame searches excluded).
  state.counters["roi_cpu_med_ms"] = percentile(cpu_roi, 0.5);
  state.counters["roi_cpu_p99_ms"] = percentile(cpu_roi, 0.99);
  state.counters["full_frac"] = full / n;
  state.counters["tags"] = visible / n;
  state.counters["recall"] = expected ? double(found) / expected : 0;
  state.counters["meas_frac"] = measured / n;
  state.counters["t_p95_mm"] = percentile(t_err, 0.95);
  state.counters["r_p95_deg"] = percentile(r_err, 0.95);
  state.counters["ft_p95_mm"] = percentile(ft_err, 0.95);
  state.counters["fr_p95_deg"] = percentile(fr_err, 0.95);
}

// Static view: RMS of the de-meaned pose error (3-D, mm) before and after
// the filter, after one second of settling.
void BM_StaticJitter(benchmark::State& state, int w, int h) {
  const Clip& c = clip(Kind::kStatic, w, h, 120);
  if (!c.error.empty()) {
    state.SkipWithError(c.error.c_str());
    return;
  }
  double raw = 0, filt = 0, raw_r = 0, filt_r = 0;
  for (auto _ : state) {
    auto tr = Tracker::create(c.station, TrackerOptions{});
    if (!tr) {
      state.SkipWithError(tr.error().c_str());
      return;
    }
    std::vector<Eigen::Vector3d> em, ef, rm, rf;
    for (std::size_t i = 0; i < c.images.size(); ++i) {
      auto f = tr->track(c.images[i], c.truth[i].time_s, c.truth[i].time_s);
      if (!f || !f->mannequin.measured || i < 30) continue;
      const Eigen::Isometry3d& T = c.truth[i].T_cam_man;
      em.push_back(f->mannequin.T_cam_body_measured.translation() - T.translation());
      ef.push_back(f->mannequin.T_cam_body.translation() - T.translation());
      rm.push_back(rotation_log(f->mannequin.T_cam_body_measured.linear() * T.linear().transpose()));
      rf.push_back(rotation_log(f->mannequin.T_cam_body.linear() * T.linear().transpose()));
    }
    auto rms_demeaned = [](const std::vector<Eigen::Vector3d>& v) {
      Eigen::Vector3d m = Eigen::Vector3d::Zero();
      for (const auto& x : v) m += x;
      m /= std::max<double>(1, v.size());
      double s = 0;
      for (const auto& x : v) s += (x - m).squaredNorm();
      return std::sqrt(s / std::max<double>(1, v.size()));
    };
    raw = rms_demeaned(em) * 1e3;
    filt = rms_demeaned(ef) * 1e3;
    raw_r = rms_demeaned(rm) * 180 / M_PI;
    filt_r = rms_demeaned(rf) * 180 / M_PI;
  }
  state.counters["raw_mm"] = raw;
  state.counters["filtered_mm"] = filt;
  state.counters["raw_deg"] = raw_r;
  state.counters["filtered_deg"] = filt_r;
}

// A 2 mm step of the camera (static view A, then static view B 2 mm
// further away): frames after the step before the filtered pose covers 50 %
// and 90 % of it (0 = in the step's own frame).
void BM_StepLag(benchmark::State& state, int w, int h) {
  const Clip& a = clip(Kind::kStatic, w, h, 120);
  const Clip& b = clip(Kind::kStaticStep, w, h, 120);
  if (!a.error.empty() || !b.error.empty()) {
    state.SkipWithError("no footage");
    return;
  }
  int lag50 = -1, lag90 = -1;
  double step_mm = 0;
  for (auto _ : state) {
    auto tr = Tracker::create(a.station, TrackerOptions{});
    if (!tr) {
      state.SkipWithError(tr.error().c_str());
      return;
    }
    const Eigen::Vector3d pa = a.truth[60].T_cam_man.translation();
    const Eigen::Vector3d pb = b.truth[60].T_cam_man.translation();
    step_mm = (pb - pa).norm() * 1e3;
    lag50 = lag90 = -1;
    for (int i = 0; i < 90; ++i) {
      const bool after = i >= 60;
      const Clip& c = after ? b : a;
      const double t = i / 30.0;
      auto f = tr->track(c.images[static_cast<std::size_t>(i)], t, t);
      if (!f) {
        state.SkipWithError(f.error().c_str());
        return;
      }
      if (!after) continue;
      const double covered =
          (f->mannequin.T_cam_body.translation() - pa).dot(pb - pa) / (pb - pa).squaredNorm();
      if (lag50 < 0 && covered >= 0.5) lag50 = i - 60;
      if (lag90 < 0 && covered >= 0.9) lag90 = i - 60;
    }
  }
  state.counters["step_mm"] = step_mm;
  state.counters["lag50_frames"] = lag50;
  state.counters["lag90_frames"] = lag90;
}

// Filter settings on recorded measurements: the tracker runs once with the
// filter off (measured poses), then each setting filters that stream
// offline. Reports the filtered error p95 against the truth on moving
// footage and the static jitter (de-meaned 3-D RMS).
struct Measured {
  std::vector<double> t;
  std::vector<Eigen::Isometry3d> meas, truth;
};
const Measured& measured(Kind kind, int w, int h, int frames) {
  static std::map<std::tuple<int, int, int, int>, Measured> cache;
  const auto key = std::make_tuple(static_cast<int>(kind), w, h, frames);
  auto it = cache.find(key);
  if (it != cache.end()) return it->second;
  Measured& m = cache[key];
  const Clip& c = clip(kind, w, h, frames);
  TrackerOptions o;
  o.filter_enabled = false;
  auto tr = Tracker::create(c.station, o);
  if (!tr) return m;
  for (std::size_t i = 0; i < c.images.size(); ++i) {
    auto f = tr->track(c.images[i], c.truth[i].time_s, c.truth[i].time_s);
    if (!f || !f->mannequin.measured) continue;
    m.t.push_back(c.truth[i].time_s);
    m.meas.push_back(f->mannequin.T_cam_body_measured);
    m.truth.push_back(c.truth[i].T_cam_man);
  }
  return m;
}

void BM_FilterSweep(benchmark::State& state, PoseFilterOptions fo) {
  const Measured& mv = measured(Kind::kStandard, 640, 480, 120);
  const Measured& ms = measured(Kind::kStatic, 640, 480, 120);
  if (mv.t.empty() || ms.t.empty()) {
    state.SkipWithError("no footage");
    return;
  }
  double p95 = 0, r95 = 0, raw95 = 0, jit = 0, jit_raw = 0;
  for (auto _ : state) {
    PoseFilter f(fo);
    std::vector<double> e, er, eraw;
    for (std::size_t i = 0; i < mv.t.size(); ++i) {
      const Eigen::Isometry3d T = f.update(mv.meas[i], mv.t[i]);
      if (i < 10) continue;
      e.push_back(trans_mm(T, mv.truth[i]));
      er.push_back(rot_deg(T, mv.truth[i]));
      eraw.push_back(trans_mm(mv.meas[i], mv.truth[i]));
    }
    p95 = percentile(e, 0.95);
    r95 = percentile(er, 0.95);
    raw95 = percentile(eraw, 0.95);
    PoseFilter g(fo);
    std::vector<Eigen::Vector3d> d, draw;
    for (std::size_t i = 0; i < ms.t.size(); ++i) {
      const Eigen::Isometry3d T = g.update(ms.meas[i], ms.t[i]);
      if (i < 30) continue;
      d.push_back(T.translation() - ms.truth[i].translation());
      draw.push_back(ms.meas[i].translation() - ms.truth[i].translation());
    }
    auto rms = [](const std::vector<Eigen::Vector3d>& v) {
      Eigen::Vector3d m = Eigen::Vector3d::Zero();
      for (const auto& x : v) m += x;
      m /= std::max<double>(1, v.size());
      double s = 0;
      for (const auto& x : v) s += (x - m).squaredNorm();
      return std::sqrt(s / std::max<double>(1, v.size())) * 1e3;
    };
    jit = rms(d);
    jit_raw = rms(draw);
  }
  state.counters["moving_t_p95_mm"] = p95;
  state.counters["moving_r_p95_deg"] = r95;
  state.counters["moving_raw_p95_mm"] = raw95;
  state.counters["static_jitter_mm"] = jit;
  state.counters["static_raw_mm"] = jit_raw;
}

void register_all() {
  const std::vector<Config> configs = {
      {"full_dec1", false, 1.0, 1.0, 1e9},       {"full_dec2", false, 2.0, 1.0, 1e9},
      {"full_dec3", false, 3.0, 1.0, 1e9},       {"roi_dec1", true, 2.0, 1.0, 1e9},
      {"roi_adaptive", true, 2.0, 1.0, 24.0},    {"roi_dec2", true, 2.0, 2.0, 1e9},
      {"roi_dec3", true, 3.0, 3.0, 1e9},
      {"roi_adaptive_paced", true, 2.0, 1.0, 24.0, DiscoveryMode::kInline, true},
      {"roi_adaptive_async", true, 2.0, 1.0, 24.0, DiscoveryMode::kAsync, true},
      {"roi_adaptive_across0.5", true, 2.0, 1.0, 24.0, DiscoveryMode::kInline, false, 0.5},
      {"roi_adaptive_across0.25", true, 2.0, 1.0, 24.0, DiscoveryMode::kInline, false, 0.25},
      {"roi_adaptive_across0", true, 2.0, 1.0, 24.0, DiscoveryMode::kInline, false, 0.0},
      {"roi_adaptive_async_across0.5", true, 2.0, 1.0, 24.0, DiscoveryMode::kAsync, true, 0.5},
      {"roi_adaptive_async_across0.25", true, 2.0, 1.0, 24.0, DiscoveryMode::kAsync, true, 0.25},
  };
  struct ClipDef {
    const char* name;
    Kind kind;
    int w, h, frames;
  };
  const std::vector<ClipDef> clips = {
      {"frontal_640x480", Kind::kFrontal, 640, 480, 120},
      {"frontal_1280x720", Kind::kFrontal, 1280, 720, 120},
      {"standard_640x480", Kind::kStandard, 640, 480, 120},
      {"standard_1280x720", Kind::kStandard, 1280, 720, 120},
      {"hard_640x480", Kind::kHard, 640, 480, 90},
      {"hard_1280x720", Kind::kHard, 1280, 720, 90},
  };
  for (const ClipDef& cd : clips)
    for (const Config& cfg : configs) {
      const std::string name = std::string("Track/") + cd.name + "/" + cfg.name;
      benchmark::RegisterBenchmark(name.c_str(), BM_Track, cd.name, cd.kind, cd.w, cd.h, cd.frames, cfg)
          ->Iterations(2 * cd.frames)
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime();
    }
  struct Sweep {
    const char* name;
    double mc, beta, dc, vc;
  };
  for (const Sweep& sw : std::vector<Sweep>{{"smooth_mc0.3_b200_v0.5", 0.3, 200, 4, 0.5},
                                            {"mc0.3_b200_v2", 0.3, 200, 4, 2},
                                            {"mc0.3_b600_v2", 0.3, 600, 4, 2},
                                            {"mc0.5_b400_v1", 0.5, 400, 4, 1},
                                            {"mc1_b200_v1", 1, 200, 4, 1},
                                            {"mc1_b600_v2", 1, 600, 4, 2},
                                            {"mc2_b200_v2", 2, 200, 4, 2},
                                            {"mc1_b1500_v2", 1, 1500, 4, 2},
                                            {"mc0.5_b1500_v2", 0.5, 1500, 4, 2},
                                            {"mc1_b3000_v2", 1, 3000, 4, 2},
                                            {"mc2_b1500_v4", 2, 1500, 4, 4}}) {
    PoseFilterOptions fo;
    fo.min_cutoff_hz = sw.mc;
    fo.beta = sw.beta;
    fo.d_cutoff_hz = sw.dc;
    fo.v_cutoff_hz = sw.vc;
    fo.rot_min_cutoff_hz = sw.mc;
    fo.rot_beta = sw.beta / 8;
    fo.rot_v_cutoff_hz = sw.vc;
    benchmark::RegisterBenchmark((std::string("FilterSweep/") + sw.name).c_str(), BM_FilterSweep,
                                 fo)
        ->Iterations(1);
  }
  for (auto [w, h] : {std::pair{640, 480}, std::pair{1280, 720}}) {
    const std::string sz = std::to_string(w) + "x" + std::to_string(h);
    benchmark::RegisterBenchmark(("StaticJitter/" + sz).c_str(), BM_StaticJitter, w, h)
        ->Iterations(1)
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("StepLag/" + sz).c_str(), BM_StepLag, w, h)
        ->Iterations(1)
        ->Unit(benchmark::kMillisecond);
  }
}

}  // namespace
}  // namespace dentar::ar

int main(int argc, char** argv) {
  cv::setNumThreads(1);  // one core: no OpenCV worker threads either
  dentar::ar::register_all();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
