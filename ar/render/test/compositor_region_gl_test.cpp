// Issue 28: the compositor's region path (the default: work only where the
// overlay is) against its whole-frame path (CompositorOptions::region_path =
// false, every stage over the whole frame). Inside the region the two give the
// same composite and the same visible-tooth mask; outside it the region path's
// composite is the camera's own pixels, and so is the whole-frame path's (the
// region holds everything that was drawn). Skipping the tooth's chunks that face
// away from the eye (CompositorOptions::cull_facing_away) changes no pixel, in the
// direct view and in the mirror, and draws fewer triangles. The live display's GPU
// path (compose_gl) is checked the same way: its composite (the video with the
// overlay texture's region over it) is the whole-frame path's, pixel for pixel.
#include <gtest/gtest.h>

#include <cstdio>
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

// Pixels of `a` and `b` (same type) that differ, inside (in = true) or outside `r`.
int differing(const cv::Mat& a, const cv::Mat& b, const cv::Rect& r, bool in, double* max_diff) {
  cv::Mat d;
  cv::absdiff(a, b, d);
  if (d.channels() > 1) {
    cv::Mat m;
    cv::transform(d, m, cv::Matx13f(1, 1, 1));
    d = m;
  }
  cv::Mat mask = cv::Mat::zeros(a.size(), CV_8UC1);
  mask(r).setTo(255);
  if (!in) mask = ~mask;
  cv::Mat dd;
  d.convertTo(dd, CV_32F);
  double mx = 0;
  cv::minMaxLoc(dd, nullptr, &mx, nullptr, nullptr, mask);
  if (max_diff != nullptr) *max_diff = mx;
  return cv::countNonZero((dd > 0) & mask);
}

// compose_gl's two target textures and the composite the window would show from them
// (test-side readbacks: the video outside the region, the overlay texture inside).
struct GlTargets {
  RenderTarget overlay;
  Texture video;
  GlFrameTarget t;
  explicit GlTargets(int w, int h) {
    auto o = RenderTarget::create(w, h, RenderTarget::ColorKind::kTexture);
    EXPECT_TRUE(o.ok()) << o.error();
    overlay = std::move(o).value();
    video = make_texture();
    glBindTexture(GL_TEXTURE_2D, video.id());
    glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA8, w, h);
    glBindTexture(GL_TEXTURE_2D, 0);
    t = {video.id(), overlay.color_texture()};
  }
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

TEST(CompositorRegionGl, RegionPathMatchesWholeFramePathInsideAndIsTheVideoOutside) {
  DENTAR_GL_TEST_CONTEXT();
  // Frames 0, 8, 16 of `standard` at 640x480 (before the first cut), a finger painted
  // across the tooth on every other frame so the segmentation has work.
  SynthOptions so = synth_preset(SynthPreset::kStandard);
  so.frames = 17;
  test::ToothFootage fo = test::tooth_footage(default_station_scene(), so, 8);
  ASSERT_EQ(fo.error, "");
  ASSERT_EQ(fo.frames.size(), 3u);
  CompositorOptions whole_o;
  whole_o.region_path = false;
  CompositorOptions all_o;
  all_o.cull_facing_away = false;
  auto region = Compositor::create(fo.station);
  auto whole = Compositor::create(fo.station, whole_o);
  auto all = Compositor::create(fo.station, all_o);
  ASSERT_TRUE(region.ok()) << region.error();
  ASSERT_TRUE(whole.ok()) << whole.error();
  ASSERT_TRUE(all.ok()) << all.error();
  const int W = fo.station.calibration.camera.width, H = fo.station.calibration.camera.height;
  const bool gpu = (*region).gpu_path_error().empty() && (*whole).gpu_path_error().empty();
  if (!gpu) std::printf("[ region ] no GPU path here (%s): CPU path only\n", (*region).gpu_path_error().c_str());
  GlTargets ta(W, H), tb(W, H);
  int k = 0, mirrors = 0, fingers = 0;
  for (auto& f : fo.frames) {
    if (k % 2 == 0)
      if (const auto fi = test::finger_across_tooth(f.mask, k, 100)) {
        paint_synthetic_finger(f.image, *fi);
        ++fingers;
      }
    ++k;
    const CompositeInput in = test::truth_input(f);
    CompositeResult a, b, c;
    ASSERT_TRUE(region->compose(*fo.tooth->surface, in, a).ok());
    ASSERT_TRUE(whole->compose(*fo.tooth->surface, in, b).ok());
    ASSERT_TRUE(all->compose(*fo.tooth->surface, in, c).ok());
    const cv::Rect r = a.region;
    SCOPED_TRACE("frame " + std::to_string(f.truth.frame));
    ASSERT_TRUE(a.overlay_drawn);
    ASSERT_FALSE(r.empty());
    mirrors += a.mirror_drawn ? 1 : 0;
    // The region is small and the whole-frame path really covered the frame.
    EXPECT_LT(r.area(), W * H / 10) << "region " << r;
    EXPECT_EQ(b.region, cv::Rect(0, 0, W, H));
    EXPECT_GT(b.cpu_blend_px, 5 * a.cpu_blend_px);
    // Something is drawn in the region, and it is the same in both paths.
    double mx = 0;
    EXPECT_GT(differing(a.image, f.image, r, true, nullptr), 100) << "no overlay in the region";
    EXPECT_EQ(differing(a.image, b.image, r, true, &mx), 0) << "largest difference " << mx;
    EXPECT_EQ(differing(a.tooth_visible, b.tooth_visible, r, true, &mx), 0) << "largest difference " << mx;
    EXPECT_EQ(a.tooth_px, b.tooth_px);
    // Outside: the camera's own pixels, on both paths; no visible tooth.
    EXPECT_EQ(differing(a.image, f.image, r, false, &mx), 0) << "largest difference " << mx;
    EXPECT_EQ(differing(b.image, f.image, r, false, &mx), 0) << "largest difference " << mx;
    EXPECT_EQ(cv::countNonZero(a.tooth_visible), cv::countNonZero(a.tooth_visible(r)));
    EXPECT_EQ(a.triangles_drawn, b.triangles_drawn);
    // The chunks facing away: not drawn, and not missed.
    EXPECT_EQ(cv::norm(a.image, c.image, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(a.tooth_visible, c.tooth_visible, cv::NORM_INF), 0.0);
    EXPECT_LT(a.triangles_drawn, c.triangles_drawn);
    std::printf("[ region ] frame %d: region %dx%d (%.2f %% of the frame), mirror %d, tooth triangles %zu (%zu without "
                "the facing test)\n",
                f.truth.frame, r.width, r.height, 100.0 * r.area() / (W * H), a.mirror_drawn ? 1 : 0,
                a.triangles_drawn, c.triangles_drawn);
    if (gpu) {
      CompositeResult ga, gb;
      ASSERT_TRUE(region->compose_gl(*fo.tooth->surface, in, ta.t, ga).ok());
      ASSERT_TRUE(whole->compose_gl(*fo.tooth->surface, in, tb.t, gb).ok());
      glFinish();
      EXPECT_EQ(ga.region, a.region);
      EXPECT_EQ(gb.region, cv::Rect(0, 0, W, H));
      const cv::Mat ca = ta.composite(f.image, ga.region), cb = tb.composite(f.image, gb.region);
      EXPECT_EQ(differing(ca, cb, r, true, &mx), 0) << "GPU path, largest difference " << mx;
      EXPECT_EQ(differing(ca, f.image, r, false, &mx), 0) << "GPU path, largest difference " << mx;
      EXPECT_EQ(differing(cb, f.image, r, false, &mx), 0) << "GPU path, largest difference " << mx;
      EXPECT_GT(differing(ca, f.image, r, true, nullptr), 100) << "GPU path: no overlay in the region";
    }
  }
  EXPECT_GE(mirrors, 1) << "no frame had the mirror's reflection";
  EXPECT_GE(fingers, 1) << "no frame had a finger over the tooth";
}

}  // namespace
}  // namespace dentar::ar

namespace dentar::ar {
namespace {

// The outline of the directly seen tooth (tooth_visible >= 128) against the full
// mesh's at the same pose: mean distance between the two outlines, px
// (differing pixels / the full mesh outline's length).
double outline_px(const cv::Mat& visible, const cv::Mat& truth_visible) {
  const cv::Mat a = visible >= 128, t = truth_visible >= 128;
  cv::Mat eroded, x;
  cv::erode(t, eroded, cv::Mat());
  const int edge = cv::countNonZero(t - eroded);
  cv::bitwise_xor(a, t, x);
  return edge > 0 ? double(cv::countNonZero(x)) / edge : -1;
}

// Issue 28: the level of detail's error budget is kept in angle
// (CompositorOptions::lod_reference_width_px = 640, the default): at 1920x1080 the
// tooth is drawn from a coarser level than a budget in px of the frame would allow,
// and its outline stays as close to the full mesh's as at 640x480.
TEST(CompositorRegionGl, LevelOfDetailInAngleKeepsTheOutlineAtEveryResolution) {
  DENTAR_GL_TEST_CONTEXT();
  double worst640 = 0;
  for (const auto& [W, H] : {std::pair{640, 480}, std::pair{1920, 1080}}) {
    SynthOptions so = synth_preset(SynthPreset::kStandard);
    so.frames = 2;
    so.width = W;
    so.height = H;
    test::ToothFootage fo = test::tooth_footage(default_station_scene(), so, 1);
    ASSERT_EQ(fo.error, "");
    ASSERT_EQ(fo.frames.size(), 2u);
    CompositorOptions full_o, px_o;
    full_o.lod_max_error_px = 0;        // the full mesh: the truth
    px_o.lod_reference_width_px = 0;    // the budget in px of this frame (session 15)
    auto angle = Compositor::create(fo.station);
    auto full = Compositor::create(fo.station, full_o);
    auto pxl = Compositor::create(fo.station, px_o);
    ASSERT_TRUE(angle.ok() && full.ok() && pxl.ok());
    for (const auto& f : fo.frames) {
      const CompositeInput in = test::truth_input(f);
      CompositeResult a, t, p;
      ASSERT_TRUE(angle->compose(*fo.tooth->surface, in, a).ok());
      ASSERT_TRUE(full->compose(*fo.tooth->surface, in, t).ok());
      ASSERT_TRUE(pxl->compose(*fo.tooth->surface, in, p).ok());
      const double e = outline_px(a.tooth_visible, t.tooth_visible);
      const double ep = outline_px(p.tooth_visible, t.tooth_visible);
      std::printf("[ lod ] %dx%d frame %d: level %d (%zu triangles; budget in px: level %d, %zu), outline %.3f px "
                  "(budget in px: %.3f)\n",
                  W, H, f.truth.frame, a.lod_level, a.triangles_drawn, p.lod_level, p.triangles_drawn, e, ep);
      ASSERT_GE(e, 0) << "no tooth drawn";
      if (W == 640) {
        EXPECT_EQ(a.lod_level, p.lod_level);  // the reference width: nothing changes
        worst640 = std::max(worst640, e);
      } else {
        EXPECT_GT(a.lod_level, p.lod_level);  // coarser than a budget in px allows
        EXPECT_LT(a.triangles_drawn, p.triangles_drawn / 2);
        // In px of the 1920 frame, i.e. 3x stricter in angle than at 640.
        EXPECT_LE(e, std::max(worst640, 0.05)) << "at 640x480 the worst was " << worst640;
      }
    }
  }
}

}  // namespace
}  // namespace dentar::ar

namespace dentar::ar {
namespace {

// Issue 28 session 20: CompositeInput::keep_yuyv. The composite of a YUYV frame stays the
// camera's frame outside the overlay (out.image shares its buffer: nothing converted) and
// the BGR patch inside patch_rect holds the overlay: composite_bgr() of it is the
// whole-frame conversion's composite (keep_yuyv = false) and the whole-frame path's,
// pixel for pixel. And compose() draws into the previous result's buffers only when the
// caller holds them alone: a composite still held elsewhere is never overwritten.
TEST(CompositorRegionGl, KeepYuyvGivesTheSameCompositeAndConvertsOnlyTheRegion) {
  DENTAR_GL_TEST_CONTEXT();
  SynthOptions so = synth_preset(SynthPreset::kStandard);
  so.frames = 9;
  test::ToothFootage fo = test::tooth_footage(default_station_scene(), so, 8);
  ASSERT_EQ(fo.error, "");
  ASSERT_EQ(fo.frames.size(), 2u);
  CompositorOptions whole_o;
  whole_o.region_path = false;
  // One compositor per way: the segmenter's foreground model adapts from frame to frame.
  auto region = Compositor::create(fo.station);
  auto keeping = Compositor::create(fo.station);
  auto whole = Compositor::create(fo.station, whole_o);
  ASSERT_TRUE(region.ok()) << region.error();
  ASSERT_TRUE(keeping.ok()) << keeping.error();
  ASSERT_TRUE(whole.ok()) << whole.error();
  const int W = fo.station.calibration.camera.width, H = fo.station.calibration.camera.height;
  CompositeResult kept, conv;  // reused across frames, as the live loop does
  cv::Mat held_conv, held_conv_copy, held_vis, held_vis_copy;
  int k = 0;
  for (auto& f : fo.frames) {
    SCOPED_TRACE("frame " + std::to_string(f.truth.frame));
    if (k++ == 0)
      if (const auto fi = test::finger_across_tooth(f.mask, 0, 100)) paint_synthetic_finger(f.image, *fi);
    cv::Mat yuyv;
    bgr_to_yuyv(f.image, yuyv);
    CompositeInput in = test::truth_input(f);
    in.video_bgr = &yuyv;
    CompositeResult w;
    ASSERT_TRUE(whole->compose(*fo.tooth->surface, in, w).ok());
    ASSERT_TRUE(region->compose(*fo.tooth->surface, in, conv).ok());
    in.keep_yuyv = true;
    ASSERT_TRUE(keeping->compose(*fo.tooth->surface, in, kept).ok());
    ASSERT_TRUE(kept.overlay_drawn);
    // The frame itself, not a copy; the patch holds the region, from an even column.
    ASSERT_EQ(kept.image.type(), CV_8UC2);
    EXPECT_EQ(kept.image.data, yuyv.data);
    ASSERT_FALSE(kept.patch.empty());
    EXPECT_EQ(kept.patch.type(), CV_8UC3);
    EXPECT_EQ(kept.patch.size(), kept.patch_rect.size());
    EXPECT_EQ(kept.patch_rect & kept.region, kept.region);
    EXPECT_EQ(kept.patch_rect.x % 2, 0);
    EXPECT_EQ(kept.patch_rect.width % 2, 0);
    EXPECT_LE(kept.patch_rect.width, kept.region.width + 2);
    EXPECT_EQ(kept.region, conv.region);
    EXPECT_LT(kept.patch_rect.area(), W * H / 10);
    cv::Mat full;
    composite_bgr(kept, full);
    EXPECT_EQ(cv::norm(full, conv.image, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(full, w.image, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(kept.tooth_visible, conv.tooth_visible, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(kept.tooth_visible, w.tooth_visible, cv::NORM_INF), 0.0);
    EXPECT_EQ(kept.tooth_px, w.tooth_px);
    cv::Mat video;
    cv::cvtColor(yuyv, video, cv::COLOR_YUV2BGR_YUYV);
    EXPECT_GT(cv::norm(full(kept.region), video(kept.region), cv::NORM_INF), 0.0) << "no overlay in the patch";
    // A BGR result is its own whole frame.
    cv::Mat same;
    composite_bgr(conv, same);
    EXPECT_EQ(cv::norm(same, conv.image, cv::NORM_INF), 0.0);
    // The previous frame's composite, still held here: untouched by this frame's compose.
    if (!held_conv.empty()) {
      EXPECT_EQ(cv::norm(held_conv, held_conv_copy, cv::NORM_INF), 0.0) << "a held composite was drawn over";
      EXPECT_EQ(cv::norm(held_vis, held_vis_copy, cv::NORM_INF), 0.0) << "a held mask was drawn over";
      EXPECT_NE(conv.image.data, held_conv.data);
    }
    held_conv = conv.image;
    held_conv_copy = conv.image.clone();
    held_vis = conv.tooth_visible;
    held_vis_copy = conv.tooth_visible.clone();
  }
  // Held alone, the buffers are drawn into again (no new frame-size allocation), with the
  // same pixels as a new result's.
  held_conv.release();
  held_vis.release();
  const unsigned char* img_data = conv.image.data;
  const unsigned char* vis_data = conv.tooth_visible.data;
  cv::Mat yuyv;
  bgr_to_yuyv(fo.frames.back().image, yuyv);
  CompositeInput in = test::truth_input(fo.frames.back());
  in.video_bgr = &yuyv;
  CompositeResult fresh;
  ASSERT_TRUE(region->compose(*fo.tooth->surface, in, conv).ok());
  ASSERT_TRUE(whole->compose(*fo.tooth->surface, in, fresh).ok());  // the rival's, its model at the same frames
  EXPECT_EQ(conv.image.data, img_data);
  EXPECT_EQ(conv.tooth_visible.data, vis_data);
  EXPECT_EQ(cv::norm(conv.image, fresh.image, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(conv.tooth_visible, fresh.tooth_visible, cv::NORM_INF), 0.0);
}

}  // namespace
}  // namespace dentar::ar

namespace dentar::ar {
namespace {

// Issue 28 session 23: the composite's cuts. (1) The attachments switched by write masks
// (attachment_masks), the mannequin's parts that face away from
// the eye (phantom_facing_cull) and, in the mirror, lie wholly behind what the reflection
// draws (phantom_depth_cull) are not drawn: the composite is the same, pixel for pixel.
// (2) The reflection's own level of detail (reflection_lod, at its virtual image's
// distance) changes only the mirror's pixels (the direct tooth's mask is the same), never
// draws more triangles, and stays close to the direct view's level there. (3) Triangles per
// pixel (lod_min_triangle_px = 1): the drawn tooth's outline against the full mesh stays
// within 0.25 px on average (measured 0.02 in docs/BENCHMARKS.md, session 23).
TEST(CompositorRegionGl, Session23CutsKeepThePixelsOrBoundTheirError) {
  DENTAR_GL_TEST_CONTEXT();
  SynthOptions so = synth_preset(SynthPreset::kStandard);
  so.frames = 1;
  so.width = 1280;
  so.height = 720;
  test::ToothFootage fo = test::tooth_footage(default_station_scene(), so, 1);
  ASSERT_EQ(fo.error, "");
  ASSERT_EQ(fo.frames.size(), 1u);
  CompositorOptions before, same_lod, tri, full;
  before.phantom_facing_cull = false;
  before.phantom_depth_cull = false;
  before.attachment_masks = false;
  CompositorOptions refl;  // the reflection at its own level
  refl.reflection_lod = true;
  tri.lod_min_triangle_px = 1;
  full.lod_max_error_px = 0;
  auto now = Compositor::create(fo.station, refl);
  auto old = Compositor::create(fo.station, before);
  auto same = Compositor::create(fo.station, same_lod);
  auto trip = Compositor::create(fo.station, tri);
  auto fullc = Compositor::create(fo.station, full);
  ASSERT_TRUE(now.ok() && old.ok() && same.ok() && trip.ok() && fullc.ok());
  int mirrors = 0;
  for (const auto& f : fo.frames) {
    const CompositeInput in = test::truth_input(f);
    CompositeResult a, b, s, t, u;
    ASSERT_TRUE(now->compose(*fo.tooth->surface, in, a).ok());
    ASSERT_TRUE(old->compose(*fo.tooth->surface, in, b).ok());
    ASSERT_TRUE(same->compose(*fo.tooth->surface, in, s).ok());
    ASSERT_TRUE(trip->compose(*fo.tooth->surface, in, t).ok());
    ASSERT_TRUE(fullc->compose(*fo.tooth->surface, in, u).ok());
    ASSERT_TRUE(a.overlay_drawn);
    mirrors += a.mirror_drawn ? 1 : 0;
    const cv::Rect all(0, 0, a.image.cols, a.image.rows);
    double mx = 0;
    // (1) the culls alone: `same` differs from `now` only by them.
    EXPECT_EQ(differing(s.image, b.image, all, true, &mx), 0) << "phantom culls changed pixels, max " << mx;
    EXPECT_EQ(differing(s.tooth_visible, b.tooth_visible, all, true, &mx), 0);
    // (2) the reflection's own level.
    EXPECT_EQ(differing(a.tooth_visible, s.tooth_visible, all, true, &mx), 0);
    EXPECT_LE(a.triangles_drawn, s.triangles_drawn);
    cv::Mat d;
    cv::absdiff(a.image, s.image, d);
    const double mean_refl = a.region.empty() ? 0.0 : cv::mean(d(a.region))[0];
    // (3) triangles per pixel against the full mesh.
    const double e = outline_px(t.tooth_visible, u.tooth_visible);
    std::printf("[ s23 ] frame %d: triangles %zu (reflection at the direct level %zu; tri/px %zu, level %d), "
                "mirror mean diff %.3f levels in the region, outline tri/px vs full %.3f px\n",
                f.truth.frame, a.triangles_drawn, s.triangles_drawn, t.triangles_drawn, t.lod_level, mean_refl, e);
    EXPECT_LE(mean_refl, 1.0);
    ASSERT_GE(e, 0) << "no tooth drawn";
    EXPECT_LE(e, 0.25);
    EXPECT_LE(t.triangles_drawn, a.triangles_drawn);
  }
  EXPECT_GE(mirrors, 1) << "no frame had the mirror's reflection";
}

}  // namespace
}  // namespace dentar::ar
