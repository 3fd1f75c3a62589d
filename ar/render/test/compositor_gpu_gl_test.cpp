// The compositor's GPU path (compose_gl, the live display's) against its CPU
// path (compose, the offline driver's) on generator footage with the true
// poses: the same composite within a grey level, the same adapted
// foreground model, the video untouched outside the overlay, and no pixel
// read back or blended on the CPU (the per-frame counters).
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "dentar/ar/compositor.h"
#include "dentar/ar/frame_gray.h"
#include "dentar/ar/gl_objects.h"
#include "dentar/ar/synth.h"
#include "composite_test_util.h"
#include "gl_test_context.h"

namespace dentar::ar {
namespace {

using test::ToothFootage;
using test::truth_input;

// compose_gl's targets, and what the window shows from them: the video
// outside the region, the overlay texture inside (test-side readbacks).
struct Targets {
  RenderTarget overlay;
  Texture video;
  GlFrameTarget t;
  static Targets make(const calibration::CameraIntrinsics& cam) {
    const int w = cam.width, h = cam.height;
    Targets x;
    auto o = RenderTarget::create(w, h, RenderTarget::ColorKind::kTexture);
    EXPECT_TRUE(o.ok()) << o.error();
    x.overlay = std::move(o).value();
    x.video = make_texture();
    glBindTexture(GL_TEXTURE_2D, x.video.id());
    glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA8, w, h);
    glBindTexture(GL_TEXTURE_2D, 0);
    x.t = {x.video.id(), x.overlay.color_texture()};
    return x;
  }
  // The uploaded video as BGR (row 0 = image top).
  cv::Mat video_bgr() const {
    Framebuffer fb = make_framebuffer();
    glBindFramebuffer(GL_FRAMEBUFFER, fb.id());
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, video.id(), 0);
    cv::Mat rgba(overlay.height(), overlay.width(), CV_8UC4), bgr;
    glReadPixels(0, 0, rgba.cols, rgba.rows, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    cv::cvtColor(rgba, bgr, cv::COLOR_RGBA2BGR);
    return bgr;
  }
  // The composite: the video with the overlay texture's region over it.
  cv::Mat composite(const cv::Mat& video_bgr, const cv::Rect& region) const {
    cv::Mat rgba(overlay.height(), overlay.width(), CV_8UC4), bgr;
    overlay.read_rgba(rgba.data, rgba.step[0]);
    cv::flip(rgba, rgba, 0);  // read_rgba flips GL rows; the overlay's rows are image rows
    cv::cvtColor(rgba, bgr, cv::COLOR_RGBA2BGR);
    cv::Mat out = video_bgr.clone();
    if (!region.empty()) bgr(region).copyTo(out(region));
    return out;
  }
};

// `standard` frames with a synthetic finger across the tooth (so the
// segmenter classifies skin and adapts its model), and the generator's tooth.
ToothFootage footage_with_finger(int n) {
  SynthOptions o = synth_preset(SynthPreset::kStandard);
  o.frames = n;
  ToothFootage fo = test::tooth_footage(default_station_scene(), o);
  for (int i = 0; i < static_cast<int>(fo.frames.size()); ++i) {
    auto fi = test::finger_across_tooth(fo.frames[i].mask, i, 100);
    if (!fi) continue;
    fi->rgb = Eigen::Vector3d(0.82, 0.60, 0.55);  // off the segmenter's seed: its model adapts
    paint_synthetic_finger(fo.frames[i].image, *fi);
  }
  return fo;
}

TEST(CompositorGpuGl, MatchesTheCpuCompositeWithoutReadback) {
  DENTAR_GL_TEST_CONTEXT();
  const ToothFootage fo = footage_with_finger(8);
  ASSERT_EQ(fo.error, "");
  auto cpu = Compositor::create(fo.station);
  auto gpu = Compositor::create(fo.station);
  ASSERT_TRUE(cpu.ok()) << cpu.error();
  ASSERT_TRUE(gpu.ok()) << gpu.error();
  ASSERT_EQ(gpu->gpu_path_error(), "");
  const Targets target = Targets::make(fo.station.calibration.camera);
  const volume::Surface& tooth = *fo.tooth->surface;
  int overlays = 0;
  for (const auto& f : fo.frames) {
    CompositeResult rc, rg;
    ASSERT_TRUE(cpu->compose(tooth, truth_input(f), rc).ok());
    const Status s = gpu->compose_gl(tooth, truth_input(f), target.t, rg);
    ASSERT_TRUE(s.ok()) << s.error();
    // What crossed to the CPU: nothing on the GPU path, the region on the CPU path.
    EXPECT_TRUE(rg.gpu_output);
    EXPECT_EQ(rg.readback_px, 0);
    EXPECT_EQ(rg.cpu_blend_px, 0);
    EXPECT_TRUE(rg.image.empty());
    EXPECT_TRUE(rg.tooth_visible.empty());
    EXPECT_EQ(rg.tooth_px, -1);
    EXPECT_EQ(rg.overlay_drawn, rc.overlay_drawn);
    EXPECT_EQ(rg.region, rc.region);
    EXPECT_EQ(rg.triangles_drawn, rc.triangles_drawn);
    EXPECT_EQ(rg.mirror_drawn, rc.mirror_drawn);
    if (rc.overlay_drawn) {
      ++overlays;
      EXPECT_GT(rc.readback_px, 0);
      EXPECT_EQ(rc.cpu_blend_px, rc.region.area());
    }
    // The video's bytes reached the GPU unchanged.
    cv::Mat vdiff;
    cv::absdiff(target.video_bgr(), f.image, vdiff);
    EXPECT_EQ(cv::countNonZero(vdiff.reshape(1)), 0) << "frame " << f.truth.frame;
    const cv::Mat g = target.composite(f.image, rg.region);
    cv::Mat diff, grey;
    cv::absdiff(g, rc.image, diff);
    cv::cvtColor(diff, grey, cv::COLOR_BGR2GRAY);
    double maxd = 0;
    cv::minMaxLoc(diff.reshape(1), nullptr, &maxd);
    const int far = cv::countNonZero(grey > 24);
    if (std::getenv("DENTAR_DEBUG_GPU")) {
      std::vector<cv::Point> pts;
      cv::findNonZero(grey > 24, pts);
      for (const auto& q : pts)
        std::printf("  (%d,%d) cpu %d %d %d gpu %d %d %d video %d %d %d vis %d region %d,%d %dx%d\n", q.x, q.y,
                    rc.image.at<cv::Vec3b>(q)[0], rc.image.at<cv::Vec3b>(q)[1], rc.image.at<cv::Vec3b>(q)[2],
                    g.at<cv::Vec3b>(q)[0], g.at<cv::Vec3b>(q)[1], g.at<cv::Vec3b>(q)[2], f.image.at<cv::Vec3b>(q)[0],
                    f.image.at<cv::Vec3b>(q)[1], f.image.at<cv::Vec3b>(q)[2], rc.tooth_visible.at<uchar>(q),
                    rc.region.x, rc.region.y, rc.region.width, rc.region.height);
    }
    const double mean_region = rc.region.empty() ? 0.0 : cv::mean(diff(rc.region))[0];
    std::printf("[ gpu vs cpu ] frame %d: max %.0f, mean over the region %.3f, pixels off > 24: %d\n",
                f.truth.frame, maxd, mean_region, far);
    // Outside the overlay the video passes through bit for bit.
    cv::Mat outside = cv::Mat::ones(diff.rows, diff.cols, CV_8UC1);
    if (!rc.region.empty()) outside(rc.region).setTo(0);
    EXPECT_EQ(cv::countNonZero(grey & outside), 0) << "frame " << f.truth.frame;
    // Inside: the same classification, float against fixed-point arithmetic
    // (measured: at most 1 level, mean < 0.01 over the region).
    EXPECT_LE(maxd, 2) << "frame " << f.truth.frame;
    EXPECT_LT(mean_region, 0.05) << "frame " << f.truth.frame;
    EXPECT_EQ(far, 0) << "frame " << f.truth.frame;
  }
  EXPECT_GE(overlays, 6);
  // The adapted foreground model, on the GPU, follows the CPU's.
  const Eigen::Vector2d mc = cpu->segmenter().model_chroma(), mg = gpu->gpu_model_chroma_for_test();
  std::printf("[ gpu vs cpu ] model (g/r, b/r): CPU %.5f %.5f, GPU %.5f %.5f\n", mc.x(), mc.y(), mg.x(), mg.y());
  EXPECT_NEAR(mg.x(), mc.x(), 1e-4);
  EXPECT_NEAR(mg.y(), mc.y(), 1e-4);
  const Eigen::Vector2d seed(0.66 / 0.86, 0.55 / 0.86);
  EXPECT_GT((mc - seed).norm(), 0.01) << "the finger should have moved the model off its seed";
}

// Issue 28: the camera's own YUYV through both paths. The CPU path converts it once
// into its output: the same composite as the BGR path given OpenCV's conversion of
// the same bytes, and outside the overlay the camera's own pixels. The GPU path
// uploads YUYV as it came and converts in a shader: its video is OpenCV's
// conversion exactly, its composite the CPU path's within the GPU path's 2 levels.
TEST(CompositorGpuGl, CameraYuyvGivesTheBgrPathsComposite) {
  DENTAR_GL_TEST_CONTEXT();
  const ToothFootage fo = footage_with_finger(3);
  ASSERT_EQ(fo.error, "");
  auto from_bgr = Compositor::create(fo.station);
  auto from_yuyv = Compositor::create(fo.station);
  auto gpu = Compositor::create(fo.station);
  auto gpu_shader = Compositor::create(fo.station);
  ASSERT_TRUE(from_bgr.ok() && from_yuyv.ok() && gpu.ok() && gpu_shader.ok());
  // Both ways of the GPU path: YUYV converted on the CPU into the upload (llvmpipe's default)
  // and in the shader (a GPU's); chosen when the path is set up.
  ::setenv("DENTAR_YUYV_GL", "cpu", 1);
  ASSERT_EQ(gpu->gpu_path_error(), "");
  ::setenv("DENTAR_YUYV_GL", "shader", 1);
  ASSERT_EQ(gpu_shader->gpu_path_error(), "");
  ::unsetenv("DENTAR_YUYV_GL");
  const Targets target = Targets::make(fo.station.calibration.camera);
  const volume::Surface& tooth = *fo.tooth->surface;
  int overlays = 0;
  for (const auto& f : fo.frames) {
    cv::Mat yuyv, bgr;
    bgr_to_yuyv(f.image, yuyv);  // what a UVC camera sends for this scene
    cv::cvtColor(yuyv, bgr, cv::COLOR_YUV2BGR_YUYV);  // the whole-frame BGR path's input
    CompositeInput ib = truth_input(f), iy = truth_input(f);
    ib.video_bgr = &bgr;
    iy.video_bgr = &yuyv;
    CompositeResult rb, ry, rg;
    ASSERT_TRUE(from_bgr->compose(tooth, ib, rb).ok());
    const Status sy = from_yuyv->compose(tooth, iy, ry);
    ASSERT_TRUE(sy.ok()) << sy.error();
    for (int way = 0; way < 2; ++way) {
      Compositor& gc = way == 0 ? *gpu : *gpu_shader;
      const Status sg = gc.compose_gl(tooth, iy, target.t, rg);
      ASSERT_TRUE(sg.ok()) << sg.error();
      ASSERT_EQ(ry.region, rb.region);
      EXPECT_EQ(rg.region, rb.region);
      if (rb.overlay_drawn) ++overlays;
      cv::Mat outside = cv::Mat::ones(bgr.rows, bgr.cols, CV_8UC1);
      if (!rb.region.empty()) outside(rb.region).setTo(0);
      // CPU: the same pixels everywhere; outside the overlay the camera's own.
      EXPECT_EQ(cv::norm(ry.image, rb.image, cv::NORM_INF), 0.0) << "frame " << f.truth.frame;
      EXPECT_EQ(cv::norm(ry.tooth_visible, rb.tooth_visible, cv::NORM_INF), 0.0);
      cv::Mat d;
      cv::absdiff(ry.image, bgr, d);
      cv::cvtColor(d, d, cv::COLOR_BGR2GRAY);
      EXPECT_EQ(cv::countNonZero(d & outside), 0) << "frame " << f.truth.frame;
      // The overlay was blended inside; without one the camera's own pixels everywhere.
      if (rb.overlay_drawn)
        EXPECT_GT(cv::countNonZero(d), 0) << "frame " << f.truth.frame;
      else
        EXPECT_EQ(cv::countNonZero(d), 0) << "frame " << f.truth.frame << ": no overlay, yet pixels changed";
      // GPU: the shader's conversion is OpenCV's.
      const cv::Mat video = target.video_bgr();
      EXPECT_EQ(cv::norm(video, bgr, cv::NORM_INF), 0.0) << "frame " << f.truth.frame;
      const cv::Mat g = target.composite(video, rg.region);
      double maxd = 0;
      cv::absdiff(g, rb.image, d);
      cv::minMaxLoc(d.reshape(1), nullptr, &maxd);
      const double mean_region = rb.region.empty() ? 0.0 : cv::mean(d(rb.region))[0];
      std::printf("[ yuyv ] frame %d, %s: GPU vs BGR path max %.0f, mean over the region %.3f\n", f.truth.frame, way == 0 ? "CPU conversion" : "shader", maxd,
                  mean_region);
      EXPECT_LE(maxd, 2) << "frame " << f.truth.frame;
      EXPECT_LT(mean_region, 0.05) << "frame " << f.truth.frame;
    }
  }
  EXPECT_GE(overlays, 4);
  // A YUYV frame of odd width is refused with its reason.
  cv::Mat odd(fo.station.calibration.camera.height, fo.station.calibration.camera.width - 1, CV_8UC2, cv::Scalar(128, 128));
  CompositeInput io = truth_input(fo.frames[0]);
  io.video_bgr = &odd;
  CompositeResult r;
  const Status so = from_yuyv->compose(tooth, io, r);
  ASSERT_FALSE(so.ok());
  EXPECT_NE(so.error().find("even width"), std::string::npos) << so.error();
}

// Issue 27: the expert's translucent tool and the tooth tint look the same on the live
// display's GPU path as on the CPU path (they are drawn in the shared canvas passes).
TEST(CompositorGpuGl, ExpertToolMatchesTheCpuComposite) {
  DENTAR_GL_TEST_CONTEXT();
  SynthOptions o = synth_preset(SynthPreset::kStandard);
  o.frames = 7;
  const ToothFootage fo = test::tooth_footage(default_station_scene(), o, 3);
  ASSERT_EQ(fo.error, "");
  auto cpu = Compositor::create(fo.station);
  auto gpu = Compositor::create(fo.station);
  auto bare_cpu = Compositor::create(fo.station);  // its own segmenter: the other two adapt alike
  ASSERT_TRUE(cpu.ok()) << cpu.error();
  ASSERT_TRUE(gpu.ok()) << gpu.error();
  ASSERT_TRUE(bare_cpu.ok()) << bare_cpu.error();
  ASSERT_EQ(gpu->gpu_path_error(), "");
  const Targets target = Targets::make(fo.station.calibration.camera);
  const volume::Surface& tooth = *fo.tooth->surface;
  for (const auto& f : fo.frames) {
    CompositeInput in = truth_input(f);
    in.expert.valid = true;
    in.expert.T_tooth_exp.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
    in.expert.T_tooth_exp.translation() = Eigen::Vector3d(0.001, 0, 0.003);
    in.expert.tint = Eigen::Vector3f(1.45f, 0.80f, 0.30f);
    in.tooth_tint = Eigen::Vector3f(1.15f, 0.92f, 0.70f);
    CompositeResult rc, rg, plain;
    ASSERT_TRUE(cpu->compose(tooth, in, rc).ok());
    ASSERT_TRUE(gpu->compose_gl(tooth, in, target.t, rg).ok());
    EXPECT_TRUE(rc.expert_drawn);
    EXPECT_EQ(rg.expert_drawn, rc.expert_drawn);
    EXPECT_EQ(rg.region, rc.region);
    const cv::Mat g = target.composite(f.image, rg.region);
    cv::Mat diff, grey;
    cv::absdiff(g, rc.image, diff);
    cv::cvtColor(diff, grey, cv::COLOR_BGR2GRAY);
    double maxd = 0;
    cv::minMaxLoc(diff.reshape(1), nullptr, &maxd);
    const double mean_region = rc.region.empty() ? 0.0 : cv::mean(diff(rc.region))[0];
    std::printf("[ gpu vs cpu, expert ] frame %d: max %.0f, mean over the region %.3f\n", f.truth.frame, maxd,
                mean_region);
    EXPECT_LE(maxd, 2) << "frame " << f.truth.frame;
    EXPECT_LT(mean_region, 0.05) << "frame " << f.truth.frame;
    // And the expert is really in it: the composite differs from one without.
    CompositeInput bare = truth_input(f);
    ASSERT_TRUE(bare_cpu->compose(tooth, bare, plain).ok());
    cv::absdiff(plain.image, rc.image, diff);
    EXPECT_GT(cv::countNonZero(diff.reshape(1) > 10), 200) << "frame " << f.truth.frame;
  }
}

TEST(CompositorGpuGl, LostTrackingGivesTheVideoAndErrorsAreClear) {
  DENTAR_GL_TEST_CONTEXT();
  const ToothFootage fo = footage_with_finger(1);
  ASSERT_EQ(fo.error, "");
  auto gpu = Compositor::create(fo.station);
  ASSERT_TRUE(gpu.ok()) << gpu.error();
  const Targets target = Targets::make(fo.station.calibration.camera);
  const volume::Surface& tooth = *fo.tooth->surface;
  const SynthFrame& frame = fo.frames[0];
  CompositeInput in = truth_input(frame);
  in.man_valid = false;
  CompositeResult r;
  ASSERT_TRUE(gpu->compose_gl(tooth, in, target.t, r).ok());
  EXPECT_FALSE(r.overlay_drawn);
  EXPECT_TRUE(r.region.empty());  // the frame is the video
  cv::Mat diff;
  cv::absdiff(target.video_bgr(), frame.image, diff);
  EXPECT_EQ(cv::countNonZero(diff.reshape(1)), 0);

  Status s = gpu->compose_gl(tooth, truth_input(frame), GlFrameTarget{}, r);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("no target texture"), std::string::npos) << s.error();
  const cv::Mat small(10, 10, CV_8UC3, cv::Scalar::all(0));
  in.video_bgr = &small;
  s = gpu->compose_gl(tooth, in, target.t, r);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("station camera"), std::string::npos) << s.error();
}

}  // namespace
}  // namespace dentar::ar
