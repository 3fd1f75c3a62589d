// The side-by-side output's GL pass against its CPU reference (headset.h
// render_eye_cpu), on a headless OpenGL ES 3 context: without pre-warp, with
// the pre-warp and chromatic scale of a real headset's figures, with the loupe
// (inset and full), and the GPU path's composed source (video + overlay region).
#include <gtest/gtest.h>

#define GL_GLEXT_PROTOTYPES
#include <GL/gl.h>
#include <GL/glext.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "dentar/live/eye_output.h"
#include "gl_test_context.h"

using namespace dentar::live;

namespace {

// A camera image with detail at every scale: noise, edges, colour ramps.
cv::Mat test_image(int w, int h) {
  cv::Mat img(h, w, CV_8UC3);
  cv::RNG rng(3);
  rng.fill(img, cv::RNG::UNIFORM, 0, 255);
  cv::GaussianBlur(img, img, cv::Size(0, 0), 1.5);
  for (int i = 0; i < 12; ++i)
    cv::circle(img, cv::Point(rng.uniform(0, w), rng.uniform(0, h)), rng.uniform(10, 60),
               cv::Scalar(rng.uniform(0, 255), rng.uniform(0, 255), rng.uniform(0, 255)), -1, cv::LINE_AA);
  return img;
}

GLuint upload(const cv::Mat& bgr) {
  cv::Mat rgba;
  cv::cvtColor(bgr, rgba, cv::COLOR_BGR2RGBA);
  GLuint t = 0;
  glGenTextures(1, &t);
  glBindTexture(GL_TEXTURE_2D, t);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, rgba.cols, rgba.rows, 0, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data);
  return t;
}

// Draws through `out` into a w x h framebuffer and reads it back (BGR, row 0 = top).
cv::Mat draw_and_read(DisplayOutput& out, const OutputFrame& f, int w, int h) {
  GLuint tex = 0, fbo = 0;
  glGenTextures(1, &tex);
  glBindTexture(GL_TEXTURE_2D, tex);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, w, h, 0, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
  glGenFramebuffers(1, &fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, tex, 0);
  out.draw(f, w, h);
  cv::Mat rgba(h, w, CV_8UC4);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glDeleteFramebuffers(1, &fbo);
  glDeleteTextures(1, &tex);
  cv::Mat bgr;
  cv::cvtColor(rgba, bgr, cv::COLOR_RGBA2BGR);
  cv::flip(bgr, bgr, 0);
  return bgr;
}

struct Diff {
  double mean = 0, p99 = 0, max = 0;
};
Diff compare(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat d;
  cv::absdiff(a, b, d);
  d = d.reshape(1);
  Diff r;
  r.mean = cv::mean(d)[0];
  std::vector<uchar> v(d.begin<uchar>(), d.end<uchar>());
  std::sort(v.begin(), v.end());
  r.p99 = v[v.size() * 99 / 100];
  r.max = v.back();
  return r;
}

dentar::calibration::CameraIntrinsics cam640() {
  dentar::calibration::CameraIntrinsics c;
  c.width = 640, c.height = 480, c.fx = 520, c.fy = 515, c.cx = 322.3, c.cy = 236.8;
  return c;
}

HeadsetProfile profile(bool warp) {
  HeadsetProfile h;
  h.name = "test";
  h.provenance = "test";
  h.panel_w = 1280, h.panel_h = 600;
  h.eyes[0].viewport[0] = 0, h.eyes[0].viewport[1] = 0, h.eyes[0].viewport[2] = 640, h.eyes[0].viewport[3] = 600;
  h.eyes[1].viewport[0] = 640, h.eyes[1].viewport[1] = 0, h.eyes[1].viewport[2] = 640, h.eyes[1].viewport[3] = 600;
  h.eyes[0].lens_center_px[0] = 368.6, h.eyes[0].lens_center_px[1] = 300;
  h.eyes[1].lens_center_px[0] = 271.4, h.eyes[1].lens_center_px[1] = 300;
  h.fov_h_deg = 80, h.fov_v_deg = 85;
  h.ipd_m = 0.064;
  if (warp) h.k1 = 0.22, h.k2 = 0.24, h.chroma_scale_r = 0.996, h.chroma_scale_b = 1.014;  // Rift DK1's SDK figures
  EXPECT_EQ(h.validate(), "");
  return h;
}

cv::Mat cpu_panel(const HeadsetProfile& h, const cv::Mat& src, const LoupeView& l, const double c[2], bool warp) {
  cv::Mat panel(h.panel_h, h.panel_w, CV_8UC3, cv::Scalar::all(0));
  for (int e = 0; e < 2; ++e) render_eye_cpu(src, make_eye_mapping(h, e, cam640(), false, l, c, warp), panel);
  return panel;
}

}  // namespace

// Per eye, the GL pass against the CPU reference: the same pixels up to the
// GPU's 8-bit filtering weights. The eyes differ (the IPD shift).
TEST(EyeOutputGl, SideBySideMatchesCpuReference) {
  DENTAR_GL_TEST_CONTEXT();
  const cv::Mat src = test_image(640, 480);
  const GLuint tex = upload(src);
  OutputFrame f;
  f.video = tex, f.tex_w = 640, f.tex_h = 480;
  f.loupe_c[0][0] = f.loupe_c[1][0] = 250, f.loupe_c[0][1] = f.loupe_c[1][1] = 300;
  for (const bool warp : {false, true}) {
    const HeadsetProfile h = profile(true);
    auto out = make_sbs_output(true, h, cam640(), false);
    ASSERT_TRUE(out.ok()) << out.error();
    (*out)->set_prewarp(warp);
    for (const double mag : {0.0, 3.0}) {
      for (const bool inset : {true, false}) {
        if (mag == 0 && !inset) continue;
        LoupeView l;
        l.mag = mag, l.inset = inset;
        (*out)->set_loupe(l);
        const cv::Mat gl = draw_and_read(**out, f, h.panel_w, h.panel_h);
        const cv::Mat ref = cpu_panel(h, src, l, f.loupe_c[0], warp);
        for (int e = 0; e < 2; ++e) {
          const cv::Rect r(h.eyes[e].viewport[0], 0, 640, 600);
          const Diff d = compare(gl(r), ref(r));
          SCOPED_TRACE(::testing::Message() << "warp " << warp << " loupe " << mag << (inset ? " inset" : " full")
                                            << " eye " << e);
          EXPECT_LT(d.mean, 0.6);
          EXPECT_LE(d.p99, 3);
          // Not a blank image matched against a blank image.
          EXPECT_GT(cv::mean(gl(r))[1], 30);
        }
        // The two eyes are not the same picture (mono: the IPD shift).
        EXPECT_GT(compare(gl(cv::Rect(0, 0, 640, 600)), gl(cv::Rect(640, 0, 640, 600))).mean, 5);
      }
    }
  }
  // The pre-warp changes the picture; the CPU reference with it is far from the one without.
  const HeadsetProfile h = profile(true);
  const double c0[2] = {0, 0};
  EXPECT_GT(compare(cpu_panel(h, src, LoupeView{}, c0, true), cpu_panel(h, src, LoupeView{}, c0, false)).mean, 10);
  glDeleteTextures(1, &tex);
}

// The GPU display path hands video and overlay (inside a region) apart: the
// output composes them before its pass.
TEST(EyeOutputGl, ComposesTheGpuPathsOverlayRegion) {
  DENTAR_GL_TEST_CONTEXT();
  const cv::Mat video = test_image(640, 480);
  cv::Mat overlay(480, 640, CV_8UC3, cv::Scalar(20, 200, 40));
  const int region[4] = {200, 150, 420, 330};
  cv::Mat composite = video.clone();
  overlay(cv::Rect(200, 150, 220, 180)).copyTo(composite(cv::Rect(200, 150, 220, 180)));
  const GLuint tv = upload(video), to = upload(overlay);
  OutputFrame f;
  f.video = tv, f.overlay = to, f.tex_w = 640, f.tex_h = 480;
  for (int i = 0; i < 4; ++i) f.region[i] = region[i];
  const HeadsetProfile h = profile(true);
  auto out = make_sbs_output(true, h, cam640(), false);
  ASSERT_TRUE(out.ok()) << out.error();
  const cv::Mat gl = draw_and_read(**out, f, h.panel_w, h.panel_h);
  const double c0[2] = {0, 0};
  const Diff d = compare(gl, cpu_panel(h, composite, LoupeView{}, c0, true));
  EXPECT_LT(d.mean, 0.6);
  EXPECT_LE(d.p99, 3);
  glDeleteTextures(1, &tv);
  glDeleteTextures(1, &to);
}

// A stereo pair: each eye shows its own camera, with no interpupillary shift
// (the CPU reference with stereo = true), the loupe centred per eye.
TEST(EyeOutputGl, StereoPairEachEyeItsOwnCamera) {
  DENTAR_GL_TEST_CONTEXT();
  const cv::Mat left = test_image(640, 480);
  cv::Mat right;
  cv::flip(left, right, 1);  // a different picture
  const GLuint tl = upload(left), tr = upload(right);
  OutputFrame f;
  f.video = tl, f.right_video = tr, f.tex_w = 640, f.tex_h = 480;
  f.loupe_c[0][0] = 300, f.loupe_c[0][1] = 250, f.loupe_c[1][0] = 280, f.loupe_c[1][1] = 250;
  const HeadsetProfile h = profile(true);
  auto out = make_sbs_output(true, h, cam640(), true);
  ASSERT_TRUE(out.ok()) << out.error();
  LoupeView l;
  l.mag = 2.5;
  (*out)->set_loupe(l);
  const cv::Mat gl = draw_and_read(**out, f, h.panel_w, h.panel_h);
  cv::Mat ref(h.panel_h, h.panel_w, CV_8UC3, cv::Scalar::all(0));
  render_eye_cpu(left, make_eye_mapping(h, 0, cam640(), true, l, f.loupe_c[0]), ref);
  render_eye_cpu(right, make_eye_mapping(h, 1, cam640(), true, l, f.loupe_c[1]), ref);
  const Diff d = compare(gl, ref);
  EXPECT_LT(d.mean, 0.6);
  EXPECT_LE(d.p99, 3);
  // Not the mono view of the left camera.
  cv::Mat mono(h.panel_h, h.panel_w, CV_8UC3, cv::Scalar::all(0));
  render_eye_cpu(left, make_eye_mapping(h, 1, cam640(), false, l, f.loupe_c[1]), mono);
  EXPECT_GT(compare(gl(cv::Rect(640, 0, 640, 600)), mono(cv::Rect(640, 0, 640, 600))).mean, 10);
  glDeleteTextures(1, &tl);
  glDeleteTextures(1, &tr);
}

// The mono window's loupe: the blit as before outside the inset, the loupe's
// mapping inside.
TEST(EyeOutputGl, MonoWindowLoupeInset) {
  DENTAR_GL_TEST_CONTEXT();
  const cv::Mat src = test_image(640, 480);
  const GLuint tex = upload(src);
  OutputFrame f;
  f.video = tex, f.tex_w = 640, f.tex_h = 480;
  f.loupe_c[0][0] = 300, f.loupe_c[0][1] = 200;
  auto out = make_mono_output(true, cam640());
  ASSERT_TRUE(out.ok()) << out.error();
  cv::Mat gl = draw_and_read(**out, f, 640, 480);
  EXPECT_EQ(cv::norm(gl, src, cv::NORM_INF), 0);  // loupe off: the exact pixels
  LoupeView l;
  l.mag = 3;
  (*out)->set_loupe(l);
  gl = draw_and_read(**out, f, 640, 480);
  cv::Mat ref = src.clone();
  render_eye_cpu(src, make_window_mapping(640, 480, cam640(), l, f.loupe_c[0]), ref);
  const Diff d = compare(gl, ref);
  EXPECT_LT(d.mean, 0.6);
  EXPECT_LE(d.p99, 3);
  // Outside the inset the window is the blit's exact pixels.
  EXPECT_EQ(cv::norm(gl(cv::Rect(0, 0, 640, 150)), src(cv::Rect(0, 0, 640, 150)), cv::NORM_INF), 0);
  glDeleteTextures(1, &tex);
}

// Session 16: a rig whose right eye has its own intrinsics (camera_right): the right eye's
// view is drawn through them, not the left camera's; eye_rects says where each eye lies.
TEST(EyeOutputGl, StereoRightEyeThroughItsOwnCamera) {
  DENTAR_GL_TEST_CONTEXT();
  const cv::Mat left = test_image(640, 480);
  cv::Mat right;
  cv::flip(left, right, 1);
  const GLuint tl = upload(left), tr = upload(right);
  OutputFrame f;
  f.video = tl, f.right_video = tr, f.tex_w = 640, f.tex_h = 480;
  auto cam_r = cam640();
  cam_r.fx = cam_r.fy = 560;  // another lens
  cam_r.cx = 331.0, cam_r.cy = 228.0;
  const HeadsetProfile h = profile(false);
  auto out = make_sbs_output(true, h, cam640(), true, &cam_r);
  ASSERT_TRUE(out.ok()) << out.error();
  const cv::Mat gl = draw_and_read(**out, f, h.panel_w, h.panel_h);
  const double c0[2] = {0, 0};
  cv::Mat ref(h.panel_h, h.panel_w, CV_8UC3, cv::Scalar::all(0)), wrong = ref.clone();
  render_eye_cpu(left, make_eye_mapping(h, 0, cam640(), true, {}, c0), ref);
  render_eye_cpu(right, make_eye_mapping(h, 1, cam_r, true, {}, c0), ref);
  render_eye_cpu(right, make_eye_mapping(h, 1, cam640(), true, {}, c0), wrong);
  const Diff d = compare(gl, ref);
  EXPECT_LT(d.mean, 0.6);
  EXPECT_LE(d.p99, 3);
  const cv::Rect re(640, 0, 640, 600);
  EXPECT_GT(compare(gl(re), wrong(re)).mean, 5) << "the right eye drawn through the left camera";
  // Where each eye lies in a framebuffer of the panel's size, and in one twice as large.
  PanelRect r[2];
  ASSERT_EQ((*out)->eye_rects(h.panel_w, h.panel_h, 640, 480, r), 2);
  for (int e = 0; e < 2; ++e) {
    EXPECT_EQ(r[e].x, h.eyes[static_cast<std::size_t>(e)].viewport[0]);
    EXPECT_EQ(r[e].w, h.eyes[static_cast<std::size_t>(e)].viewport[2]);
  }
  ASSERT_EQ((*out)->eye_rects(2 * h.panel_w, 2 * h.panel_h, 640, 480, r), 2);
  EXPECT_EQ(r[1].x, 2 * h.eyes[1].viewport[0]);
  EXPECT_EQ(r[1].h, 2 * h.eyes[1].viewport[3]);
  auto mono = make_mono_output(true, cam640());
  ASSERT_TRUE(mono.ok()) << mono.error();
  ASSERT_EQ((*mono)->eye_rects(1280, 1024, 640, 480, r), 1);
  EXPECT_EQ(r[0].y, 32);
  EXPECT_EQ(r[0].h, 960);
  glDeleteTextures(1, &tl);
  glDeleteTextures(1, &tr);
}

// Issue 28 session 18: the pre-warp passes on the same frame (eye_output.h WarpPass). exact
// (the default) draws only the grid cells where the camera is seen, with kFull's fragment
// program: the same pixels as kFull, to the bit. mesh and lut: within the CPU reference's
// tolerance, as kFull is. With the pre-warp and chromatic scale, the loupe off, full and inset.
TEST(EyeOutputGl, WarpPassesMatchTheFullPass) {
  DENTAR_GL_TEST_CONTEXT();
  const cv::Mat src = test_image(640, 480);
  const GLuint tex = upload(src);
  OutputFrame f;
  f.video = tex, f.tex_w = 640, f.tex_h = 480;
  f.loupe_c[0][0] = f.loupe_c[1][0] = 250, f.loupe_c[0][1] = f.loupe_c[1][1] = 300;
  const HeadsetProfile h = profile(true);
  for (const double mag : {0.0, 3.0}) {
    for (const bool inset : {true, false}) {
      if (mag == 0 && !inset) continue;
      LoupeView l;
      l.mag = mag, l.inset = inset;
      // The mesh with 8 px cells (docs/headset.md: within 0.2 camera px; 16 px cells, 1.0).
      auto draw = [&](WarpPass p) {
        auto out = make_sbs_output(true, h, cam640(), false, nullptr, p, p == WarpPass::kMesh ? 8 : 16);
        EXPECT_TRUE(out.ok()) << out.error();
        (*out)->set_loupe(l);
        return draw_and_read(**out, f, h.panel_w, h.panel_h);
      };
      const cv::Mat full = draw(WarpPass::kFull);
      const cv::Mat ref = cpu_panel(h, src, l, f.loupe_c[0], true);
      SCOPED_TRACE(::testing::Message() << "loupe " << mag << (inset ? " inset" : " full"));
      EXPECT_EQ(cv::norm(draw(WarpPass::kExact), full, cv::NORM_INF), 0) << "exact differs from full";
      for (const WarpPass p : {WarpPass::kMesh, WarpPass::kLut}) {
        const cv::Mat gl = draw(p);
        const Diff d = compare(gl, ref);
        SCOPED_TRACE(warp_pass_name(p));
        EXPECT_LT(d.mean, 0.6);
        EXPECT_LE(d.p99, 3);
        EXPECT_GT(cv::mean(gl)[1], 15);  // not blank
      }
    }
  }
  // Bad grid sizes are refused with the field named.
  auto bad = make_sbs_output(true, h, cam640(), false, nullptr, WarpPass::kMesh, 2);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("cell_px = 2"), std::string::npos) << bad.error();
  WarpPass p;
  EXPECT_FALSE(parse_warp_pass("fast", p));
  EXPECT_TRUE(parse_warp_pass("mesh", p) && p == WarpPass::kMesh);
  glDeleteTextures(1, &tex);
}

// Issue 28 session 19: the display loop moves the loupe's centre on every frame, loupe on or
// off, and a stereo pair turns into the mono view for a frame whose right eye is missing.
// Each eye's pre-warp grid is kept while its mapping is unchanged (the loupe's centre does
// not change it while the loupe is off) and kept for both views: drawn through one output
// over many such frames, every frame gives the pixels a new output gives for that frame
// alone (NORM_INF = 0), and the grids are made once per eye and view. With the loupe on,
// its centre does change the mapping: the grid is remade, and the pixels follow.
TEST(EyeOutputGl, WarpGridKeptWhileTheLoupeIsOffAndRemadeWhenItMatters) {
  DENTAR_GL_TEST_CONTEXT();
  const cv::Mat left = test_image(640, 480);
  cv::Mat right;
  cv::flip(left, right, 1);
  const GLuint tl = upload(left), tr = upload(right);
  const HeadsetProfile h = profile(true);
  auto make = [&](const LoupeView& l) {
    auto out = make_sbs_output(true, h, cam640(), true, nullptr, WarpPass::kExact, 16);
    EXPECT_TRUE(out.ok()) << out.error();
    (*out)->set_loupe(l);
    return std::move(*out);
  };
  auto frame = [&](int i) {
    OutputFrame f;
    f.video = tl, f.tex_w = 640, f.tex_h = 480;
    f.right_video = i % 3 == 2 ? 0 : tr;  // every third frame without the right eye: the mono view
    for (int e = 0; e < 2; ++e) f.loupe_c[e][0] = 300 + 7.5 * i + e, f.loupe_c[e][1] = 250 - 3.25 * i;
    return f;
  };
  for (const double mag : {0.0, 2.5}) {
    SCOPED_TRACE(::testing::Message() << "loupe " << mag);
    LoupeView l;
    l.mag = mag, l.inset = false;
    auto kept = make(l);
    EXPECT_EQ(kept->warp_grid_builds(), 0);
    const int n = 6;
    for (int i = 0; i < n; ++i) {
      const OutputFrame f = frame(i);
      const cv::Mat a = draw_and_read(*kept, f, h.panel_w, h.panel_h);
      auto fresh = make(l);
      const cv::Mat b = draw_and_read(*fresh, f, h.panel_w, h.panel_h);
      EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0) << "frame " << i;
      EXPECT_GT(cv::mean(a)[1], 5) << "frame " << i;  // not blank
    }
    if (mag == 0)  // both eyes, stereo and mono: 4 grids, whatever the centre did
      EXPECT_EQ(kept->warp_grid_builds(), 4);
    else  // the full loupe's mapping follows the centre: every draw of every eye
      EXPECT_EQ(kept->warp_grid_builds(), 2 * n);
  }
  // The key itself: the centre counts only with the loupe on.
  const double c0[2] = {300, 250}, c1[2] = {310, 240};
  LoupeView off, on;
  on.mag = 3, on.inset = false;
  EXPECT_EQ(warp_grid_key(make_eye_mapping(h, 0, cam640(), true, off, c0), 40, 38),
            warp_grid_key(make_eye_mapping(h, 0, cam640(), true, off, c1), 40, 38));
  EXPECT_NE(warp_grid_key(make_eye_mapping(h, 0, cam640(), true, on, c0), 40, 38),
            warp_grid_key(make_eye_mapping(h, 0, cam640(), true, on, c1), 40, 38));
  EXPECT_NE(warp_grid_key(make_eye_mapping(h, 0, cam640(), true, off, c0), 40, 38),
            warp_grid_key(make_eye_mapping(h, 0, cam640(), false, off, c0), 40, 38));
  glDeleteTextures(1, &tl);
  glDeleteTextures(1, &tr);
}

// Issue 28 session 22 (--display-texture half): the headset view drawn from the camera frame
// box-averaged 2x2 into a texture of half the size, against the same view from the full-size
// texture, a 1280x720 camera whose pixels are smaller than the panel's (a half-size texel still
// at most one panel px at the lens centre: what `auto` asks). The output's mapping scales the
// intrinsics to the texture's size, so the two views agree up to the filtering; a quarter-size
// texture (4x4 averaged: measured mean 1.03, p99 15 levels) is caught. Measured half against full
// on this image (noise blurred at the camera's scale, the hardest case): mean 0.37, p99 5, max 42.
TEST(EyeOutputGl, HalfSizeTextureWithinToleranceOfFullSize) {
  DENTAR_GL_TEST_CONTEXT();
  dentar::calibration::CameraIntrinsics cam;
  cam.width = 1280, cam.height = 720, cam.fx = cam.fy = 1200, cam.cx = 644.6, cam.cy = 356.6;
  const HeadsetProfile h = profile(true);
  const double c0[2] = {0, 0};
  double ratio = 1e9;  // camera px per panel px at the lens centre (as the display loop's auto)
  for (int e = 0; e < 2; ++e) {
    const EyeMapping m = make_eye_mapping(h, e, cam, true, {}, c0, true);
    for (int a = 0; a < 2; ++a) ratio = std::min(ratio, m.f_cam[a] / m.f_eye[a]);
  }
  ASSERT_GE(ratio, 2.0) << "the test's camera must be finer than the panel";
  const cv::Mat src = test_image(1280, 720);
  cv::Mat src_r;
  cv::flip(src, src_r, 1);  // the right eye: another picture
  cv::Mat half, half_r, quarter, quarter_r;
  cv::resize(src, half, cv::Size(640, 360), 0, 0, cv::INTER_AREA);
  cv::resize(src_r, half_r, cv::Size(640, 360), 0, 0, cv::INTER_AREA);
  cv::resize(src, quarter, cv::Size(320, 180), 0, 0, cv::INTER_AREA);
  cv::resize(src_r, quarter_r, cv::Size(320, 180), 0, 0, cv::INTER_AREA);
  auto out = make_sbs_output(true, h, cam, true, &cam, WarpPass::kExact, 16);
  ASSERT_TRUE(out.ok()) << out.error();
  auto view = [&](const cv::Mat& l, const cv::Mat& r, int tw, int th) {
    const GLuint tl = upload(l), tr = upload(r);
    OutputFrame f;
    f.video = tl, f.right_video = tr, f.tex_w = tw, f.tex_h = th;
    const cv::Mat px = draw_and_read(**out, f, h.panel_w, h.panel_h);
    glDeleteTextures(1, &tl);
    glDeleteTextures(1, &tr);
    return px;
  };
  const cv::Mat full = view(src, src_r, 1280, 720);
  const cv::Mat from_half = view(half, half_r, 640, 360);
  const Diff d = compare(from_half, full);
  std::printf("[ half ] camera px per panel px at the lens centre %.2f; half against full: mean %.2f, p99 %.0f, max %.0f levels\n",
              ratio, d.mean, d.p99, d.max);
  EXPECT_LT(d.mean, 0.6);
  EXPECT_LE(d.p99, 8);
  EXPECT_GT(cv::mean(from_half)[1], 15);  // not blank
  // The check can fail: a quarter-size texture (a texel then over a panel px at the centre).
  const Diff dq = compare(view(quarter, quarter_r, 320, 180), full);
  std::printf("[ half ] quarter against full: mean %.2f, p99 %.0f\n", dq.mean, dq.p99);
  EXPECT_TRUE(dq.mean >= 0.6 || dq.p99 > 8) << "quarter: mean " << dq.mean << " p99 " << dq.p99;
}
