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

}  // namespace
}  // namespace dentar::ar
