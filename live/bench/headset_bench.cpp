// The headset output's cost per frame on this machine's GL (llvmpipe here):
// the per-eye pass (eye_output.h) with and without the lens pre-warp, and the
// digital loupe, drawing a 1280x720 camera frame (already a texture: the
// upload is the same as the mono window's) into an off-screen framebuffer of
// the panel's size, glFinish after each frame. See docs/BENCHMARKS.md,
// "Issue 28 (session 15): headset output and loupe".
//   ./build/live/live_headset_bench --benchmark_repetitions=1
// Counters: p50_ms, p99_ms (wall time per frame, draw + glFinish); cpu_p50_ms,
// cpu_p99_ms (the process's CPU time per frame, llvmpipe's rasteriser threads
// included: what the frame costs the machine, less sensitive than wall time to
// other work on it).
// Configurations (config:N): 0 mono blit (the window as before, 1280x720 window),
// 1 mono + loupe inset 3x, 2 mono + loupe full 3x, 3 sbs DK1 panel (1280x800)
// without pre-warp, 4 the same with pre-warp, 5 with pre-warp + loupe inset 3x,
// 6 sbs generic panel (2880x1600) without pre-warp, 7 with pre-warp,
// 8 with pre-warp + loupe inset 3x.
#include <benchmark/benchmark.h>

#define GL_GLEXT_PROTOTYPES
#include <GL/gl.h>
#include <GL/glext.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "dentar/ar/egl_context.h"
#include "dentar/ar/frame_gray.h"
#include "dentar/live/eye_output.h"
#include "dentar/live/hud_window.h"

namespace {

using namespace dentar;

ar::EglContext* context() {
  static ar::EglContext* ctx = [] {
    auto r = ar::EglContext::create();
    return r ? new ar::EglContext(std::move(r).value()) : nullptr;
  }();
  return ctx;
}

calibration::CameraIntrinsics cam720() {
  calibration::CameraIntrinsics c;
  c.width = 1280, c.height = 720, c.fx = c.fy = 1000, c.cx = 639.5, c.cy = 359.5;
  return c;
}

// 30 draws an iteration, each finished (glFinish): wall and process CPU ms p50 / p99 as counters.
// Process CPU includes llvmpipe's rasteriser threads: the pass's whole cost.
// move_centre: the loupe's centre moved a little before each draw, as the live display loop
// sets it from each frame's tracked tooth (loupe on or off).
void time_draws(benchmark::State& state, live::DisplayOutput& out, live::OutputFrame f, int W, int H,
                bool move_centre = false) {
  auto cpu_ms = [] {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
  };
  std::vector<double> ms, cpu;
  for (auto _ : state) {
    for (int i = 0; i < 30; ++i) {
      if (move_centre)
        for (auto& c : f.loupe_c) c[0] += (i % 2 ? 0.25 : -0.25), c[1] += (i % 2 ? -0.125 : 0.125);
      const auto t0 = std::chrono::steady_clock::now();
      const double c0 = cpu_ms();
      out.draw(f, W, H);
      glFinish();
      cpu.push_back(cpu_ms() - c0);
      ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
  }
  std::sort(ms.begin(), ms.end());
  std::sort(cpu.begin(), cpu.end());
  state.counters["p50_ms"] = ms[ms.size() / 2];
  state.counters["p99_ms"] = ms[std::min(ms.size() - 1, ms.size() * 99 / 100)];
  state.counters["cpu_p50_ms"] = cpu[cpu.size() / 2];
  state.counters["cpu_p99_ms"] = cpu[std::min(cpu.size() - 1, cpu.size() * 99 / 100)];
}

void BM_HeadsetOutput(benchmark::State& state) {
  if (!context() || !context()->make_current()) {
    state.SkipWithError("no EGL context");
    return;
  }
  const int config = static_cast<int>(state.range(0));
  const char* profile = config >= 6 ? "assets/headsets/generic_2x1440x1600.json" : "assets/headsets/oculus_rift_dk1.json";
  auto h = live::read_headset_profile(profile);
  if (!h) {
    state.SkipWithError(h.error().c_str());
    return;
  }
  const bool sbs = config >= 3;
  const int W = sbs ? h->panel_w : 1280, H = sbs ? h->panel_h : 720;
  auto out = sbs ? live::make_sbs_output(true, *h, cam720(), false) : live::make_mono_output(true, cam720());
  if (!out) {
    state.SkipWithError(out.error().c_str());
    return;
  }
  live::LoupeView l;
  if (config == 1 || config == 5 || config == 8) l.mag = 3;
  if (config == 2) l.mag = 3, l.inset = false;
  (*out)->set_loupe(l);
  (*out)->set_prewarp(config == 4 || config == 5 || config == 7 || config == 8);
  cv::Mat img(720, 1280, CV_8UC4);
  cv::randu(img, 0, 255);
  GLuint tex = 0, target = 0, fbo = 0;
  glGenTextures(1, &tex);
  glBindTexture(GL_TEXTURE_2D, tex);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, 1280, 720, 0, GL_RGBA, GL_UNSIGNED_BYTE, img.data);
  glGenTextures(1, &target);
  glBindTexture(GL_TEXTURE_2D, target);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, W, H, 0, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
  glGenFramebuffers(1, &fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, target, 0);
  live::OutputFrame f;
  f.video = tex, f.tex_w = 1280, f.tex_h = 720;
  f.loupe_c[0][0] = f.loupe_c[1][0] = 700, f.loupe_c[0][1] = f.loupe_c[1][1] = 400;
  for (int i = 0; i < 5; ++i) (*out)->draw(f, W, H);  // warm-up (shader compile, first draws)
  glFinish();
  time_draws(state, **out, f, W, H);
  state.counters["panel_mpx"] = W * H / 1e6;
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  out->reset();
  glDeleteFramebuffers(1, &fbo);
  glDeleteTextures(1, &target);
  glDeleteTextures(1, &tex);
}
BENCHMARK(BM_HeadsetOutput)->DenseRange(0, 8)->Iterations(3)->Unit(benchmark::kMillisecond);

// Issue 28 session 18: the pre-warp pass's designs on the same frames, as `dentar live --output
// sbs` draws a stereo 2x640x480 pair (the bench's clip: synth's camera, fx = fy = 600 px)
// into the Rift DK1's 1280x800 panel (a window of the panel's size). Arguments: pass (0 full,
// the sessions 15-17 pass; 1 exact on the live cells; 2 mesh; 3 lookup texture), the grid's
// cell size (panel px), loupe (0 off, 1 inset 3x). Counters as BM_HeadsetOutput, plus the
// live cells' share of the two viewports and, for the mesh and the lookup, the warp's
// largest error against the exact mapping over the panel (camera px and panel px, the worst
// eye and channel; headset.h warp_grid_error / warp_lut_error).
// Session 19: a fourth argument, the camera (1: 640x480, fx 600; 2: 1280x720, fx 1200, the
// same field of view), and a fifth: 1 moves the loupe's centre by a fraction of a pixel before
// each draw, as the live display loop sets it from every frame's tracked tooth.
//   ./build/live/live_headset_bench --benchmark_filter=Warp
void BM_HeadsetWarp(benchmark::State& state) {
  if (!context() || !context()->make_current()) {
    state.SkipWithError("no EGL context");
    return;
  }
  const live::WarpPass pass = static_cast<live::WarpPass>(state.range(0));
  const int cell = static_cast<int>(state.range(1));
  const bool inset = state.range(2) != 0;
  const int k = state.range(3) >= 2 ? 2 : 1;  // camera: 640x480 or 1280x720 (same field of view)
  const bool moving = state.range(4) != 0;
  // Session 22: camera 3 = the 1280x720 camera's texture at half size (640x360, fx 600): what
  // a half-size upload would sample.
  const bool half = state.range(3) == 3;
  const int cw = k == 2 && !half ? 1280 : 640, ch = k == 2 ? (half ? 360 : 720) : 480;
  auto h = live::read_headset_profile("assets/headsets/oculus_rift_dk1.json");
  if (!h) {
    state.SkipWithError(h.error().c_str());
    return;
  }
  calibration::CameraIntrinsics cam;
  cam.width = cw, cam.height = ch, cam.fx = cam.fy = 600 * (k == 2 && !half ? 2 : 1), cam.cx = (cw - 1) / 2.0,
  cam.cy = (ch - 1) / 2.0;
  const int W = h->panel_w, H = h->panel_h;
  auto out = live::make_sbs_output(true, *h, cam, true, &cam, pass, cell);
  if (!out) {
    state.SkipWithError(out.error().c_str());
    return;
  }
  live::LoupeView l;
  if (inset) l.mag = 3;
  (*out)->set_loupe(l);
  cv::Mat img(ch, cw, CV_8UC4), img_r(ch, cw, CV_8UC4);
  cv::randu(img, 0, 255);
  cv::randu(img_r, 0, 255);
  GLuint tex[2] = {0, 0}, target = 0, fbo = 0;
  glGenTextures(2, tex);
  for (int e = 0; e < 2; ++e) {
    glBindTexture(GL_TEXTURE_2D, tex[e]);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, cw, ch, 0, GL_RGBA, GL_UNSIGNED_BYTE, (e ? img_r : img).data);
  }
  glGenTextures(1, &target);
  glBindTexture(GL_TEXTURE_2D, target);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, W, H, 0, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
  glGenFramebuffers(1, &fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, target, 0);
  live::OutputFrame f;
  f.video = tex[0], f.right_video = tex[1], f.tex_w = cw, f.tex_h = ch;
  f.loupe_c[0][0] = f.loupe_c[1][0] = 330 * k, f.loupe_c[0][1] = f.loupe_c[1][1] = 250 * k;
  for (int i = 0; i < 5; ++i) (*out)->draw(f, W, H);  // warm-up (shader compile, first draws, the grid)
  glFinish();
  time_draws(state, **out, f, W, H, moving);
  // The grid's live share and the warp's error (CPU, the same mappings the output drew).
  double live_share = 1, err_cam = 0, err_panel = 0;
  const double c0[2] = {330.0 * k, 250.0 * k};
  long vp_px = 0, live_px = 0;
  for (int e = 0; e < 2; ++e) {
    const live::EyeMapping m = live::make_eye_mapping(*h, e, cam, true, l, c0);
    const int cols = (m.vp[2] + cell - 1) / cell, rows = (m.vp[3] + cell - 1) / cell;
    const live::WarpGrid g = live::make_warp_grid(m, cols, rows);
    vp_px += static_cast<long>(m.vp[2]) * m.vp[3];
    live_px += static_cast<long>(g.live_cells()) * m.vp[2] * m.vp[3] / (cols * rows);
    live::WarpError we;
    if (pass == live::WarpPass::kMesh && !inset) we = live::warp_grid_error(g, m);
    if (pass == live::WarpPass::kLut) we = live::warp_lut_error(m, true);
    for (int ch = 0; ch < 3; ++ch) {
      err_cam = std::max(err_cam, we.max_cam_px[ch]);
      err_panel = std::max(err_panel, we.max_panel_px[ch]);
    }
  }
  if (pass != live::WarpPass::kFull) live_share = double(live_px) / double(vp_px);
  state.counters["live_share"] = live_share;
  state.counters["err_cam_px"] = err_cam;
  state.counters["err_panel_px"] = err_panel;
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  out->reset();
  glDeleteFramebuffers(1, &fbo);
  glDeleteTextures(1, &target);
  glDeleteTextures(2, tex);
}
BENCHMARK(BM_HeadsetWarp)
    ->Args({0, 16, 0, 1, 0})
    ->Args({1, 16, 0, 1, 0})
    ->Args({1, 32, 0, 1, 0})
    ->Args({2, 8, 0, 1, 0})
    ->Args({2, 16, 0, 1, 0})
    ->Args({2, 32, 0, 1, 0})
    ->Args({3, 16, 0, 1, 0})
    ->Args({0, 16, 1, 1, 0})
    ->Args({1, 16, 1, 1, 0})
    ->Args({1, 16, 0, 1, 1})
    ->Args({1, 16, 0, 2, 0})
    ->Args({1, 16, 0, 2, 1})
    // Session 22: the 1280x720 camera (the 2x720p row) through full, mesh 8 / 16 and the lookup.
    ->Args({0, 16, 0, 2, 0})
    ->Args({2, 8, 0, 2, 0})
    ->Args({2, 16, 0, 2, 0})
    ->Args({1, 16, 0, 3, 0})
    ->Args({2, 8, 0, 3, 0})
    ->Iterations(3)
    ->Unit(benchmark::kMillisecond);

// The loupe's centre per frame on the CPU: the tooth's centre projected with the
// frame's pose (the station's distortion) and the deadband (headset.h LoupeCentre).
void BM_LoupeCentre(benchmark::State& state) {
  calibration::CameraIntrinsics c = cam720();
  c.dist = {0.1, -0.2, 0.001, 0.001, 0.05};
  live::LoupeCentre lc;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(0.01, 0.02, 0.35);
  int i = 0;
  for (auto _ : state) {
    T.translation().x() += (i++ % 2 ? 1e-4 : -1e-4);
    double u = 0, v = 0;
    const bool ok = live::project_point(c, T, Eigen::Vector3d(0.005, 0.005, 0.01), u, v);
    lc.update(ok, u, v);
    benchmark::DoNotOptimize(lc.centre()[0]);
  }
}
BENCHMARK(BM_LoupeCentre)->Unit(benchmark::kMicrosecond);

}  // namespace

// Issue 28 session 23: one eye's half-size texture from a 1280x720 YUYV composite with a 200x160
// overlay patch: arg 0 = the full-size upload conversion then the 2x2 mean (session 22's path),
// 1 = upload_pixels_half (straight from the YUYV). CPU per eye frame.
void BM_UploadHalf(benchmark::State& state) {
  const bool direct = state.range(0) == 1;
  cv::Mat scene(720, 1280, CV_8UC3), yuyv;
  cv::randu(scene, 0, 256);
  cv::GaussianBlur(scene, scene, cv::Size(0, 0), 2.0);  // camera-like, not pure noise
  dentar::ar::bgr_to_yuyv(scene, yuyv);
  cv::Mat patch(160, 200, CV_8UC3, cv::Scalar(30, 200, 90));
  const cv::Rect rect(611, 301, 200, 160);
  cv::Mat full, half;
  for (auto _ : state) {
    if (direct) {
      dentar::live::upload_pixels_half(yuyv, patch, rect, false, half);
    } else {
      dentar::live::upload_pixels(yuyv, patch, rect, false, full);
      cv::resize(full, half, cv::Size(640, 360), 0, 0, cv::INTER_AREA);
    }
    benchmark::DoNotOptimize(half.data);
  }
}
BENCHMARK(BM_UploadHalf)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
