// Compositor on generator footage with the true poses (FrameTruth), so the
// tracker's error is excluded: registration of the tooth, occlusion against
// the ground-truth masks, the mirror reflection against the plane equation,
// lost tracking, a mirror facing away, and bad input.
#include "dentar/ar/compositor.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "dentar/ar/camera_model.h"
#include "dentar/ar/synth.h"
#include "dentar/volume/procedural_tooth.h"
#include "composite_test_util.h"
#include "gl_test_context.h"

namespace dentar::ar {
namespace {

using test::finger_across_tooth;
using test::ToothFootage;
using test::truth_input;

// Frames 0, 6, ..., 24 of `standard` at 640x480 (before the first cut), and
// the generator's tooth.
ToothFootage standard_footage() {
  SynthOptions o = synth_preset(SynthPreset::kStandard);
  o.frames = 25;
  return test::tooth_footage(default_station_scene(), o, 6);
}

TEST(CompositorGl, RegistrationMatchesTruthSilhouette) {
  DENTAR_GL_TEST_CONTEXT();
  const ToothFootage fo = standard_footage();
  ASSERT_EQ(fo.error, "");
  CompositorOptions o;  // occlusion off: the whole silhouette
  o.phantoms = false;
  o.segmentation = false;
  o.mirror = false;
  o.draw_bur = false;
  auto comp = Compositor::create(fo.station, o);
  ASSERT_TRUE(comp.ok()) << comp.error();
  for (const auto& f : fo.frames) {
    CompositeResult r;
    ASSERT_TRUE(comp->compose(*fo.tooth->surface, truth_input(f), r).ok());
    ASSERT_TRUE(r.overlay_drawn);
    const cv::Mat truth = f.mask != 0;
    ASSERT_GT(cv::countNonZero(truth), 200) << "frame " << f.truth.frame;
    const MaskScore s = compare_masks(r.tooth_visible > 127, truth);
    std::printf("[ registration ] frame %d: IoU %.4f, boundary F %.4f, level %d\n", f.truth.frame,
                s.iou, s.boundary_f, r.lod_level);
    EXPECT_GE(s.iou, 0.98) << "frame " << f.truth.frame << " level " << r.lod_level;
    auto sil = fo.gen->render_tooth_silhouette(f.truth.T_cam_tooth);
    ASSERT_TRUE(sil.ok()) << sil.error();
    EXPECT_GE(compare_masks(r.tooth_visible > 127, *sil).iou, 0.98) << "frame " << f.truth.frame;
    // The overlay changed the image only inside the reported region.
    cv::Mat diff;
    cv::absdiff(r.image, f.image, diff);
    cv::Mat outside = cv::Mat::ones(diff.rows, diff.cols, CV_8UC1);
    outside(r.region).setTo(0);
    cv::Mat changed;
    cv::cvtColor(diff, changed, cv::COLOR_BGR2GRAY);
    EXPECT_EQ(cv::countNonZero(changed & outside), 0);
    EXPECT_GT(cv::countNonZero(changed), 200);
  }
}

TEST(CompositorGl, RegistrationHoldsWithLevelOfDetail) {
  DENTAR_GL_TEST_CONTEXT();
  const ToothFootage fo = standard_footage();
  ASSERT_EQ(fo.error, "");
  CompositorOptions o;
  o.phantoms = o.segmentation = o.mirror = o.draw_bur = false;
  o.triangle_budget = 60000;  // forces a coarser level than the full ~150k
  auto comp = Compositor::create(fo.station, o);
  ASSERT_TRUE(comp.ok()) << comp.error();
  for (const auto& f : fo.frames) {
    CompositeResult r;
    ASSERT_TRUE(comp->compose(*fo.tooth->surface, truth_input(f), r).ok());
    const auto tris = comp->lod_triangle_counts();
    ASSERT_EQ(tris.size(), 4u);
    EXPECT_GT(r.lod_level, 0);
    EXPECT_LE(tris[static_cast<std::size_t>(r.lod_level)], o.triangle_budget);
    EXPECT_LE(r.triangles_drawn, o.triangle_budget);
    const MaskScore s = compare_masks(r.tooth_visible > 127, f.mask != 0);
    EXPECT_GE(s.iou, 0.95) << "frame " << f.truth.frame << " level " << r.lod_level;
  }
}

TEST(CompositorGl, OcclusionMatchesTruthMask) {
  DENTAR_GL_TEST_CONTEXT();
  const ToothFootage fo = standard_footage();
  ASSERT_EQ(fo.error, "");
  auto comp = Compositor::create(fo.station);
  ASSERT_TRUE(comp.ok()) << comp.error();
  int hidden_frames = 0;
  for (const auto& f : fo.frames) {
    CompositeResult r;
    ASSERT_TRUE(comp->compose(*fo.tooth->surface, truth_input(f), r).ok());
    const cv::Mat truth = f.mask == kMaskToothVisible;
    const MaskScore s = compare_masks(r.tooth_visible > 127, truth);
    // Without phantoms the hidden part would count: occlusion must be doing work.
    if (f.truth.tooth_hidden_px > 100) {
      ++hidden_frames;
      EXPECT_LT(compare_masks(f.mask != 0, truth).iou, 0.97);
    }
    std::printf("[ occlusion ] frame %d: IoU %.4f, boundary F %.4f (hidden %d of %d px)\n",
                f.truth.frame, s.iou, s.boundary_f, f.truth.tooth_hidden_px, f.truth.tooth_px);
    EXPECT_GE(s.iou, 0.98) << "frame " << f.truth.frame << " boundary F " << s.boundary_f;
    EXPECT_GE(s.boundary_f, 0.95) << "frame " << f.truth.frame;
  }
  EXPECT_GT(hidden_frames, 0) << "no frame of the sample has the tooth partly hidden";
}

// A synthetic finger across the tooth (the generator's hand rarely crosses
// it): the segmenter must cut it out of the tooth.
TEST(CompositorGl, OcclusionHidesTheToothBehindAFinger) {
  DENTAR_GL_TEST_CONTEXT();
  ToothFootage fo = standard_footage();
  ASSERT_EQ(fo.error, "");
  auto comp = Compositor::create(fo.station);
  ASSERT_TRUE(comp.ok()) << comp.error();
  CompositorOptions no_seg;
  no_seg.segmentation = false;
  auto comp_off = Compositor::create(fo.station, no_seg);
  ASSERT_TRUE(comp_off.ok()) << comp_off.error();
  int k = 0;
  for (auto& f : fo.frames) {
    const auto fi = finger_across_tooth(f.mask, k++, 100);
    ASSERT_TRUE(fi.has_value()) << "frame " << f.truth.frame << ": the tooth is hardly visible";
    const cv::Mat finger = paint_synthetic_finger(f.image, *fi);
    const cv::Mat truth = (f.mask == kMaskToothVisible) & ~finger;
    ASSERT_GT(cv::countNonZero((f.mask == kMaskToothVisible) & finger), 30);
    CompositeResult r, r_off;
    ASSERT_TRUE(comp->compose(*fo.tooth->surface, truth_input(f), r).ok());
    ASSERT_TRUE(comp_off->compose(*fo.tooth->surface, truth_input(f), r_off).ok());
    const MaskScore s = compare_masks(r.tooth_visible > 127, truth);
    const MaskScore s_off = compare_masks(r_off.tooth_visible > 127, truth);
    std::printf("[ finger ] frame %d: IoU %.4f (segmentation off: %.4f), boundary F %.4f\n",
                f.truth.frame, s.iou, s_off.iou, s.boundary_f);
    EXPECT_GE(s.iou, 0.95) << "frame " << f.truth.frame << " boundary F " << s.boundary_f;
    EXPECT_GT(s.iou, s_off.iou + 0.05) << "frame " << f.truth.frame;
  }
}

// A small sphere (the marker) as the "tooth": radius r_m around the tooth origin.
struct Marker {
  std::optional<volume::VoxelVolume> volume;
  std::unique_ptr<volume::Surface> surface;
  explicit Marker(double r_m) {
    volume::VolumeGeometry g;
    const double h = 0.1e-3;
    const int n = static_cast<int>(std::ceil(2 * r_m / h)) + 6;
    g.dims = Eigen::Vector3i(n, n, n);
    g.spacing = Eigen::Vector3d::Constant(h);
    g.origin = Eigen::Vector3d::Constant(-0.5 * (n - 1) * h);
    volume.emplace(g);
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          const double d = (volume->voxel_center(i, j, k)).norm();
          const double v = std::clamp(127.5 + 100.0 * (r_m - d) / h, 0.0, 250.0);
          if (v > 0) volume->set(i, j, k, static_cast<std::uint8_t>(v), volume::Material::kEnamel);
        }
    surface = std::make_unique<volume::Surface>(*volume);
    surface->extract_all();
  }
};

// Scene: marker at p (cam), mirror centre m with its normal bisecting the
// directions to the camera and to the marker, so the marker's reflection is
// seen through the mirror centre.
struct MirrorScene {
  StationScene station = default_station_scene();
  Eigen::Vector3d p{-0.012, 0.004, 0.25}, m{0.02, -0.004, 0.30};
  Eigen::Isometry3d T_cam_mir = Eigen::Isometry3d::Identity();
  CompositeInput in;
  cv::Mat video;
  explicit MirrorScene(bool facing = true) {
    const auto& k = station.calibration.camera;
    video = cv::Mat::zeros(k.height, k.width, CV_8UC3);
    Eigen::Vector3d n = ((-m).normalized() + (p - m).normalized()).normalized();
    if (!facing) n = -n;
    Eigen::Vector3d x = n.cross(Eigen::Vector3d::UnitY()).normalized();
    T_cam_mir.linear().col(0) = x;
    T_cam_mir.linear().col(1) = n.cross(x);
    T_cam_mir.linear().col(2) = n;
    T_cam_mir.translation() = m;
    Eigen::Isometry3d T_cam_tooth = Eigen::Isometry3d::Identity();
    T_cam_tooth.translation() = p;
    in.video_bgr = &video;
    in.man_valid = true;
    in.T_cam_man = T_cam_tooth * station.calibration.T_man_tooth.inverse();
    in.mirror_valid = true;
    in.T_cam_mtag = T_cam_mir * station.calibration.T_mtag_mir.inverse();
  }
  Eigen::Vector3d reflected() const {
    const Eigen::Vector3d n = T_cam_mir.linear().col(2);
    return p - 2.0 * n * n.dot(p - m);
  }
};

CompositorOptions marker_options() {
  CompositorOptions o;
  o.phantoms = false;  // the mannequin would hide the floating marker
  o.segmentation = false;
  return o;
}

TEST(CompositorGl, MirrorReflectionLandsWhereThePlaneEquationPutsIt) {
  DENTAR_GL_TEST_CONTEXT();
  MirrorScene sc;
  Marker marker(2.0e-3);
  auto comp = Compositor::create(sc.station, marker_options());
  ASSERT_TRUE(comp.ok()) << comp.error();
  CompositeResult r;
  ASSERT_TRUE(comp->compose(*marker.surface, sc.in, r).ok());
  ASSERT_TRUE(r.mirror_drawn);
  // Reflection pixels: changed, but not the directly seen marker.
  cv::Mat gray;
  cv::cvtColor(r.image, gray, cv::COLOR_BGR2GRAY);
  const cv::Mat refl = (gray > 20) & (r.tooth_visible == 0);
  const cv::Moments mo = cv::moments(refl, true);
  ASSERT_GT(mo.m00, 10) << "no reflection pixels";
  const Eigen::Vector2d found(mo.m10 / mo.m00, mo.m01 / mo.m00);
  const CameraModel cam(sc.station.calibration.camera);
  const auto expected = cam.project(sc.reflected());
  ASSERT_TRUE(expected.has_value());
  std::printf("[ mirror ] reflection of the marker found %.3f px from the plane equation's point\n",
              (found - *expected).norm());
  EXPECT_LT((found - *expected).norm(), 0.5)
      << "found " << found.transpose() << " expected " << expected->transpose();
  // The reflected point is seen through the mirror centre (by construction).
  EXPECT_LT((*cam.project(sc.m) - *expected).norm(), 0.5);
  // The direct marker is drawn where it is.
  const cv::Moments md = cv::moments(r.tooth_visible > 127, true);
  ASSERT_GT(md.m00, 10);
  EXPECT_LT((Eigen::Vector2d(md.m10 / md.m00, md.m01 / md.m00) - *cam.project(sc.p)).norm(), 0.5);
}

TEST(CompositorGl, NoReflectionWhenTheMirrorFacesAway) {
  DENTAR_GL_TEST_CONTEXT();
  MirrorScene sc(/*facing=*/false);
  Marker marker(2.0e-3);
  auto comp = Compositor::create(sc.station, marker_options());
  ASSERT_TRUE(comp.ok()) << comp.error();
  CompositeResult r;
  ASSERT_TRUE(comp->compose(*marker.surface, sc.in, r).ok());
  EXPECT_FALSE(r.mirror_drawn);
  cv::Mat gray;
  cv::cvtColor(r.image, gray, cv::COLOR_BGR2GRAY);
  EXPECT_EQ(cv::countNonZero((gray > 20) & (r.tooth_visible == 0)), 0);
  EXPECT_GT(r.tooth_px, 10);  // the marker itself is still drawn
  // Lost mirror tracking: no reflection either.
  MirrorScene facing;
  facing.in.mirror_valid = false;
  ASSERT_TRUE(comp->compose(*marker.surface, facing.in, r).ok());
  EXPECT_FALSE(r.mirror_drawn);
}

TEST(CompositorGl, NoOverlayWhenTrackingIsLost) {
  DENTAR_GL_TEST_CONTEXT();
  MirrorScene sc;
  Marker marker(2.0e-3);
  auto comp = Compositor::create(sc.station, marker_options());
  ASSERT_TRUE(comp.ok()) << comp.error();
  sc.video.setTo(cv::Scalar(40, 90, 160));
  sc.in.man_valid = false;
  CompositeResult r;
  ASSERT_TRUE(comp->compose(*marker.surface, sc.in, r).ok());
  EXPECT_FALSE(r.overlay_drawn);
  EXPECT_FALSE(r.mirror_drawn);
  EXPECT_EQ(r.tooth_px, 0);
  EXPECT_EQ(cv::countNonZero(r.tooth_visible), 0);
  cv::Mat diff;
  cv::absdiff(r.image, sc.video, diff);
  EXPECT_EQ(cv::countNonZero(diff.reshape(1)), 0);
  // Back on: drawn again.
  sc.in.man_valid = true;
  ASSERT_TRUE(comp->compose(*marker.surface, sc.in, r).ok());
  EXPECT_TRUE(r.overlay_drawn);
  EXPECT_GT(r.tooth_px, 10);
}

TEST(CompositorGl, BadInputGivesClearErrors) {
  DENTAR_GL_TEST_CONTEXT();
  MirrorScene sc;
  Marker marker(2.0e-3);
  CompositorOptions bad;
  bad.feather_px = -1;
  auto c0 = Compositor::create(sc.station, bad);
  ASSERT_FALSE(c0.ok());
  EXPECT_NE(c0.error().find("feather_px"), std::string::npos) << c0.error();
  bad = {};
  bad.lod_cell_voxels = {4, 2};
  EXPECT_NE(bad.validate().find("lod_cell_voxels[1]"), std::string::npos) << bad.validate();
  bad.lod_cell_voxels = {3};
  EXPECT_NE(bad.validate().find("lod_cell_voxels[0]"), std::string::npos) << bad.validate();

  auto comp = Compositor::create(sc.station, marker_options());
  ASSERT_TRUE(comp.ok()) << comp.error();
  CompositeResult r;
  r.tooth_px = 12345;  // must stay untouched on error
  CompositeInput in = sc.in;
  in.video_bgr = nullptr;
  Status s = comp->compose(*marker.surface, in, r);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("empty"), std::string::npos) << s.error();
  const cv::Mat empty;
  in.video_bgr = &empty;
  s = comp->compose(*marker.surface, in, r);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("empty"), std::string::npos) << s.error();
  const cv::Mat small = cv::Mat::zeros(240, 320, CV_8UC3);
  in.video_bgr = &small;
  s = comp->compose(*marker.surface, in, r);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("320x240"), std::string::npos) << s.error();
  EXPECT_NE(s.error().find("station"), std::string::npos) << s.error();
  const auto& k = sc.station.calibration.camera;
  const cv::Mat gray = cv::Mat::zeros(k.height, k.width, CV_8UC1);
  in.video_bgr = &gray;
  s = comp->compose(*marker.surface, in, r);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("CV_8UC3"), std::string::npos) << s.error();
  EXPECT_EQ(r.tooth_px, 12345);
  EXPECT_FALSE(comp->set_options(bad).ok());
}

// ---- the expert's tool (issue 27) ----

// Mean BGR over a (2h+1)^2 window around px.
cv::Vec3d mean_at(const cv::Mat& img, const Eigen::Vector2d& px, int h = 2) {
  const cv::Rect r(static_cast<int>(std::lround(px.x())) - h, static_cast<int>(std::lround(px.y())) - h, 2 * h + 1,
                   2 * h + 1);
  const cv::Scalar m = cv::mean(img(r & cv::Rect(0, 0, img.cols, img.rows)));
  return {m[0], m[1], m[2]};
}

// The expert's tip 8 mm above the marker (tooth frame = camera axes here), its bur axis
// pointing away from the camera: the handpiece head is seen end-on, a 5 mm disc around the
// projection of the axis.
ExpertTool expert_above_marker(double opacity) {
  ExpertTool e;
  e.valid = true;
  e.T_tooth_exp.translation() = Eigen::Vector3d(0.0, -0.008, 0.0);
  e.opacity = opacity;
  return e;
}

TEST(CompositorGl, ExpertToolIsTranslucentWhereItProjects) {
  DENTAR_GL_TEST_CONTEXT();
  MirrorScene sc;
  Marker marker(2.0e-3);
  CompositorOptions o = marker_options();
  o.mirror = false;
  auto comp = Compositor::create(sc.station, o);
  ASSERT_TRUE(comp.ok()) << comp.error();
  const CameraModel cam(sc.station.calibration.camera);
  const Eigen::Isometry3d T_cam_tooth = sc.in.T_cam_man * sc.station.calibration.T_man_tooth;
  const ExpertTool e = expert_above_marker(0.45);
  const auto head = cam.project(T_cam_tooth * e.T_tooth_exp * Eigen::Vector3d(0, 0, -0.006));
  ASSERT_TRUE(head.has_value());
  // Two backgrounds: a translucent ghost shows each through itself; an opaque one neither.
  const cv::Mat black = cv::Mat::zeros(sc.video.size(), CV_8UC3);
  const cv::Mat white(sc.video.size(), CV_8UC3, cv::Scalar::all(255));
  auto compose = [&](const cv::Mat& video, const ExpertTool& ex, CompositeResult& r) {
    CompositeInput in = sc.in;
    in.video_bgr = &video;
    in.expert = ex;
    ASSERT_TRUE(comp->compose(*marker.surface, in, r).ok());
  };
  CompositeResult on_black, on_white, opaque_black, opaque_white, none;
  compose(black, e, on_black);
  compose(white, e, on_white);
  compose(black, expert_above_marker(1.0), opaque_black);
  compose(white, expert_above_marker(1.0), opaque_white);
  compose(black, ExpertTool{}, none);
  EXPECT_TRUE(on_black.expert_drawn);
  EXPECT_FALSE(none.expert_drawn);
  const cv::Vec3d b = mean_at(on_black.image, *head), w = mean_at(on_white.image, *head);
  const cv::Vec3d ob = mean_at(opaque_black.image, *head), ow = mean_at(opaque_white.image, *head);
  std::printf("[ expert ] head pixel on black %.1f %.1f %.1f, on white %.1f %.1f %.1f; opaque %.1f / %.1f\n", b[0],
              b[1], b[2], w[0], w[1], w[2], ob[0], ow[0]);
  for (int c = 0; c < 3; ++c) {
    // Opaque: the background does not show; translucent: it shows with weight 1 - 0.45.
    EXPECT_NEAR(ob[c], ow[c], 1.0) << "channel " << c;
    EXPECT_NEAR(w[c] - b[c], 255.0 * (1 - 0.45), 3.0) << "channel " << c;
    // On black, the ghost's colour scaled by its opacity (premultiplied "over").
    EXPECT_NEAR(b[c], 0.45 * ob[c], 2.0) << "channel " << c;
  }
  EXPECT_GT(b[0] + b[1] + b[2], 30.0) << "no ghost where it projects";
  // Tinted blue: more blue than red (BGR).
  EXPECT_GT(ob[0], ob[2] + 20);
  // No tool: nothing there, and the marker drawn as before; the ghost adds no tooth coverage.
  EXPECT_EQ(mean_at(none.image, *head), cv::Vec3d(0, 0, 0));
  EXPECT_EQ(on_black.tooth_px, none.tooth_px);
  cv::Mat diff;
  cv::absdiff(on_black.tooth_visible, none.tooth_visible, diff);
  EXPECT_EQ(cv::countNonZero(diff), 0);
  // Changed pixels lie inside the reported region.
  cv::absdiff(on_black.image, none.image, diff);
  cv::Mat changed;
  cv::cvtColor(diff, changed, cv::COLOR_BGR2GRAY);
  EXPECT_GT(cv::countNonZero(changed), 200);
  cv::Mat outside = cv::Mat::ones(diff.rows, diff.cols, CV_8UC1);
  outside(on_black.region).setTo(0);
  EXPECT_EQ(cv::countNonZero(changed & outside), 0);
}

TEST(CompositorGl, ExpertToolAbsentLeavesTheFrameBitIdentical) {
  DENTAR_GL_TEST_CONTEXT();
  MirrorScene sc;
  Marker marker(2.0e-3);
  auto comp = Compositor::create(sc.station, marker_options());
  ASSERT_TRUE(comp.ok()) << comp.error();
  CompositeResult before, with, after;
  CompositeInput in = sc.in;
  ASSERT_TRUE(comp->compose(*marker.surface, in, before).ok());
  in.expert = expert_above_marker(0.45);
  ASSERT_TRUE(comp->compose(*marker.surface, in, with).ok());
  in.expert.valid = false;
  ASSERT_TRUE(comp->compose(*marker.surface, in, after).ok());
  cv::Mat diff;
  cv::absdiff(before.image, after.image, diff);
  EXPECT_EQ(cv::countNonZero(diff.reshape(1)), 0);
  cv::absdiff(before.image, with.image, diff);
  EXPECT_GT(cv::countNonZero(diff.reshape(1)), 100);
  EXPECT_EQ(before.region, after.region);
}

TEST(CompositorGl, ExpertToolIsOverlaidUnlessDepthTested) {
  // The expert's tool 25 mm behind the marker (its handpiece head, seen end-on, covers the
  // marker's projection): overlaid, it shows over the marker; depth-tested, the marker hides it.
  DENTAR_GL_TEST_CONTEXT();
  MirrorScene sc;
  Marker marker(2.0e-3);
  CompositorOptions o = marker_options();
  o.mirror = false;
  auto comp = Compositor::create(sc.station, o);
  ASSERT_TRUE(comp.ok()) << comp.error();
  const CameraModel cam(sc.station.calibration.camera);
  const auto centre = cam.project(sc.p);
  ASSERT_TRUE(centre.has_value());
  CompositeInput in = sc.in;
  CompositeResult none, over, tested;
  ASSERT_TRUE(comp->compose(*marker.surface, in, none).ok());
  in.expert = expert_above_marker(0.5);
  in.expert.T_tooth_exp.translation() = Eigen::Vector3d(0, 0, 0.025);
  ASSERT_TRUE(comp->compose(*marker.surface, in, over).ok());
  in.expert.depth_tested = true;
  ASSERT_TRUE(comp->compose(*marker.surface, in, tested).ok());
  const cv::Vec3d n = mean_at(none.image, *centre, 1), v = mean_at(over.image, *centre, 1),
                  t = mean_at(tested.image, *centre, 1);
  std::printf("[ expert ] marker centre: %.1f %.1f %.1f alone, %.1f %.1f %.1f overlaid, %.1f %.1f %.1f depth-tested\n",
              n[0], n[1], n[2], v[0], v[1], v[2], t[0], t[1], t[2]);
  EXPECT_GT(cv::norm(v - n), 20.0) << "the overlaid ghost does not show over the marker";
  EXPECT_LT(cv::norm(t - n), 1.0) << "the depth-tested ghost shows through the marker";
  // Around the marker the ghost shows either way (nothing in front of it there).
  const auto side = cam.project(sc.p + Eigen::Vector3d(0.0035, 0, 0.020));
  ASSERT_TRUE(side.has_value());
  EXPECT_GT(cv::norm(mean_at(tested.image, *side, 1) - mean_at(none.image, *side, 1)), 20.0);
}

TEST(CompositorGl, ExpertToolShowsInTheMirror) {
  DENTAR_GL_TEST_CONTEXT();
  MirrorScene sc;
  Marker marker(2.0e-3);
  auto comp = Compositor::create(sc.station, marker_options());
  ASSERT_TRUE(comp.ok()) << comp.error();
  const CameraModel cam(sc.station.calibration.camera);
  const Eigen::Isometry3d T_cam_tooth = sc.in.T_cam_man * sc.station.calibration.T_man_tooth;
  const ExpertTool e = expert_above_marker(0.6);
  // The head point and its mirror image (reflection about the mirror plane).
  const Eigen::Vector3d h = T_cam_tooth * e.T_tooth_exp * Eigen::Vector3d(0, 0, -0.006);
  const Eigen::Vector3d n = sc.T_cam_mir.linear().col(2), m = sc.T_cam_mir.translation();
  const Eigen::Vector3d h_refl = h - 2.0 * n * n.dot(h - m);
  // Precondition: the reflected point is seen inside the mirror disc.
  const Eigen::Vector3d ray = h_refl.normalized();
  const double s = n.dot(m) / n.dot(ray);
  const Eigen::Vector3d hit = s * ray;
  ASSERT_LT((hit - m).norm(), 0.8 * sc.station.calibration.mirror_radius_m);
  const auto px = cam.project(h_refl);
  ASSERT_TRUE(px.has_value());
  CompositeResult none, with;
  CompositeInput in = sc.in;
  ASSERT_TRUE(comp->compose(*marker.surface, in, none).ok());
  in.expert = e;
  ASSERT_TRUE(comp->compose(*marker.surface, in, with).ok());
  ASSERT_TRUE(with.mirror_drawn);
  const cv::Vec3d a = mean_at(none.image, *px, 1), b = mean_at(with.image, *px, 1);
  std::printf("[ expert ] reflection at (%.1f, %.1f): %.1f %.1f %.1f without, %.1f %.1f %.1f with\n", px->x(),
              px->y(), a[0], a[1], a[2], b[0], b[1], b[2]);
  EXPECT_GT(b[0] - a[0], 20.0) << "no reflected ghost where the mirror shows it";
  // Dimmer than the direct ghost (opacity times the mirror's reflectance).
  const auto direct = cam.project(h);
  ASSERT_TRUE(direct.has_value());
  const cv::Vec3d d = mean_at(with.image, *direct, 1);
  EXPECT_LT(b[0], d[0]);
  // Nothing reflected with the expert absent.
  EXPECT_LT(a[0] + a[1] + a[2], 3.0);
}

TEST(CompositorGl, ExpertToolAndToothTintBadValuesAreErrors) {
  DENTAR_GL_TEST_CONTEXT();
  MirrorScene sc;
  Marker marker(2.0e-3);
  auto comp = Compositor::create(sc.station, marker_options());
  ASSERT_TRUE(comp.ok()) << comp.error();
  CompositeInput in = sc.in;
  CompositeResult r;
  in.expert = expert_above_marker(0.0);
  Status st = comp->compose(*marker.surface, in, r);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().find("expert.opacity"), std::string::npos) << st.error();
  in.expert = expert_above_marker(0.5);
  in.expert.T_tooth_exp.translation().x() = std::nan("");
  st = comp->compose(*marker.surface, in, r);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().find("T_tooth_exp"), std::string::npos) << st.error();
  in.expert = {};
  in.tooth_tint = Eigen::Vector3f(1, -1, 1);
  st = comp->compose(*marker.surface, in, r);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().find("tooth_tint[1]"), std::string::npos) << st.error();
  // A tint changes the tooth's colour, not its coverage.
  CompositeResult plain, warm;
  in.tooth_tint = Eigen::Vector3f::Ones();
  ASSERT_TRUE(comp->compose(*marker.surface, in, plain).ok());
  in.tooth_tint = Eigen::Vector3f(1.3f, 0.7f, 0.5f);
  ASSERT_TRUE(comp->compose(*marker.surface, in, warm).ok());
  EXPECT_EQ(plain.tooth_px, warm.tooth_px);
  const cv::Moments mo = cv::moments(plain.tooth_visible > 127, true);
  ASSERT_GT(mo.m00, 10);
  const Eigen::Vector2d c(mo.m10 / mo.m00, mo.m01 / mo.m00);
  const cv::Vec3d p = mean_at(plain.image, c, 1), q = mean_at(warm.image, c, 1);
  EXPECT_GT(q[2] - q[0], p[2] - p[0] + 20) << "the warm tint did not redden the tooth";
}

}  // namespace
}  // namespace dentar::ar
