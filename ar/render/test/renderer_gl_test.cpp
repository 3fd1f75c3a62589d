// ToothRenderer and PartRenderer on llvmpipe: per-chunk re-upload, the
// silhouette against projected vertices, per-material transparency,
// determinism, and the instrument meshes.
#include <gtest/gtest.h>

#include <chrono>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>

#include "dentar/ar/camera_model.h"
#include "dentar/ar/renderer.h"
#include "dentar/volume/cutter.h"
#include "dentar/volume/procedural_tooth.h"
#include "gl_test_context.h"

namespace dentar::ar {
namespace {

namespace dv = dentar::volume;

calibration::CameraIntrinsics camera(bool distorted) {
  calibration::CameraIntrinsics k;
  k.width = 640;
  k.height = 480;
  k.fx = 600.0;
  k.fy = 602.0;
  k.cx = 322.4;
  k.cy = 238.9;
  if (distorted) k.dist = {-0.28, 0.09, 0.0008, -0.0005, -0.01};
  return k;
}

// The molar at 0.12 mm voxels (the default 0.08 mm is the benchmark's job;
// the checks here do not depend on the resolution), meshed once.
struct Tooth {
  dv::VoxelVolume volume;
  std::unique_ptr<dv::Surface> surface;
  Eigen::Vector3d lo, hi;  // bounding box of the mesh vertices, tooth frame
};
Tooth& tooth() {
  static Tooth* t = [] {
    dv::MolarParams p;
    p.voxel_mm = 0.12;
    auto* tt = new Tooth{std::move(dv::make_molar(p)).value(), nullptr, {}, {}};
    tt->surface = std::make_unique<dv::Surface>(tt->volume);
    tt->surface->extract_all();
    tt->lo.setConstant(1e9);
    tt->hi.setConstant(-1e9);
    for (const auto& c : tt->surface->chunks()) {
      for (const auto& v : c.vertices) {
        tt->lo = tt->lo.cwiseMin(v.position_m.cast<double>());
        tt->hi = tt->hi.cwiseMax(v.position_m.cast<double>());
      }
    }
    return tt;
  }();
  return *t;
}

// Camera looking straight down at the occlusal surface (tooth +z toward the
// camera), the crown's top centre on the optical axis at `distance_m`.
Eigen::Isometry3d occlusal_view(const Tooth& t, double distance_m) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Vector3d top(0.5 * (t.lo.x() + t.hi.x()), 0.5 * (t.lo.y() + t.hi.y()), t.hi.z());
  T.translation() = Eigen::Vector3d(0, 0, distance_m) - T.linear() * top;
  return T;
}

// An oblique, off-centre view (the whole tooth in the image).
Eigen::Isometry3d oblique_view(const Tooth& t) {
  Eigen::Isometry3d T = occlusal_view(t, 0.06);
  const Eigen::Vector3d centre = 0.5 * (t.lo + t.hi);
  const Eigen::Vector3d c_cam = T * centre;
  Eigen::Isometry3d R = Eigen::Isometry3d::Identity();
  R.linear() = (Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitX()) *
                Eigen::AngleAxisd(-0.35, Eigen::Vector3d::UnitY()))
                   .toRotationMatrix();
  // Rotate about the tooth centre, then shift it toward the upper left.
  Eigen::Isometry3d about = Eigen::Translation3d(c_cam) * R * Eigen::Translation3d(-c_cam);
  return Eigen::Translation3d(-0.012, -0.008, 0.0) * about * T;
}

cv::Rect2d projected_bbox(const calibration::CameraIntrinsics& k, const Eigen::Isometry3d& T,
                          const dv::Surface& s) {
  std::vector<cv::Point3d> pts;
  for (const auto& c : s.chunks()) {
    for (const auto& v : c.vertices) {
      const Eigen::Vector3d p = T * v.position_m.cast<double>();
      pts.emplace_back(p.x(), p.y(), p.z());
    }
  }
  std::vector<cv::Point2d> img;
  const cv::Matx33d K(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
  cv::projectPoints(pts, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K,
                    std::vector<double>(k.dist.begin(), k.dist.end()), img);
  double u0 = 1e9, v0 = 1e9, u1 = -1e9, v1 = -1e9;
  for (const auto& p : img) {
    u0 = std::min(u0, p.x);
    v0 = std::min(v0, p.y);
    u1 = std::max(u1, p.x);
    v1 = std::max(v1, p.y);
  }
  return {u0, v0, u1 - u0, v1 - v0};
}

// Bounding box of pixels with non-zero alpha (virtual content), in pixel
// centres: [first, last] column/row.
cv::Rect2d coverage_bbox(const cv::Mat& rgba) {
  std::vector<cv::Mat> ch;
  cv::split(rgba, ch);
  const cv::Rect r = cv::boundingRect(ch[3] > 0);
  return {static_cast<double>(r.x), static_cast<double>(r.y), r.width - 1.0, r.height - 1.0};
}

struct Scene {
  Renderer renderer;
  ToothRenderer tooth;
};
Scene make_scene(const calibration::CameraIntrinsics& k,
                 RendererOptions::WarpMode warp = RendererOptions::WarpMode::kGpu) {
  RendererOptions o;
  o.warp = warp;
  auto r = Renderer::create(k, o);
  EXPECT_TRUE(r.ok()) << r.error();
  auto t = ToothRenderer::create();
  EXPECT_TRUE(t.ok()) << t.error();
  return {std::move(r).value(), std::move(t).value()};
}

cv::Mat render(Scene& s, const dv::Surface& surface, const Eigen::Isometry3d& T_cam_tooth) {
  s.tooth.sync(surface);
  s.renderer.begin_frame();
  s.tooth.draw(s.renderer.clip_from_cam(), T_cam_tooth);
  s.renderer.end_frame();
  cv::Mat rgba;
  s.renderer.read_rgba(rgba);
  return rgba;
}

TEST(ToothRendererGl, UploadsEveryNonEmptyChunkOnce) {
  DENTAR_GL_TEST_CONTEXT();
  auto t = ToothRenderer::create();
  ASSERT_TRUE(t.ok()) << t.error();
  const dv::Surface& s = *tooth().surface;
  std::size_t non_empty = 0;
  for (const auto& c : s.chunks()) non_empty += !c.empty();
  const int first = t->sync(s);
  EXPECT_EQ(static_cast<std::size_t>(first), non_empty);
  EXPECT_EQ(t->triangle_count(), s.triangle_count());
  EXPECT_EQ(t->sync(s), 0);  // nothing changed: nothing re-uploaded
  EXPECT_EQ(t->total_uploads(), non_empty);
  std::printf("tooth at 0.12 mm: %zu triangles in %zu chunks\n", s.triangle_count(), non_empty);
}

TEST(ToothRendererGl, ReuploadsOnlyTheChunksACutChanged) {
  DENTAR_GL_TEST_CONTEXT();
  Tooth& base = tooth();
  dv::VoxelVolume vol = base.volume.clone();
  dv::Surface surface(vol);
  surface.extract_all();
  Scene scene = make_scene(camera(false));
  const Eigen::Isometry3d T_cam_tooth = occlusal_view(base, 0.045);
  render(scene, surface, T_cam_tooth);
  const std::uint64_t before = scene.tooth.total_uploads();

  // Drill straight down into the crown centre with a 1 mm round bur.
  auto bur = dv::sample_bur(dv::BurParams::sphere(0.5), 2000);
  ASSERT_TRUE(bur.ok());
  dv::Cutter cutter(vol);
  Eigen::Isometry3d T_tooth_tip = Eigen::Isometry3d::Identity();
  T_tooth_tip.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  T_tooth_tip.translation() =
      Eigen::Vector3d(0.5 * (base.lo.x() + base.hi.x()) + 1.5e-3, 0.5 * (base.lo.y() + base.hi.y()),
                      base.hi.z() - 2.0e-3);
  for (int i = 0; i < 200; ++i) (void)cutter.step(*bur, T_tooth_tip, 3.0, 1e-3);
  ASSERT_GT(cutter.metrics().removed_total_mm3, 0.0);

  const std::vector<int> changed = surface.update();
  ASSERT_FALSE(changed.empty());
  const cv::Mat after = render(scene, surface, T_cam_tooth);
  EXPECT_EQ(scene.tooth.last_uploaded(), changed);  // both ascending chunk ids
  EXPECT_EQ(scene.tooth.total_uploads() - before, changed.size());
  EXPECT_LT(changed.size(), surface.chunks().size() / 10);
  std::printf("cut changed %zu of %zu chunks; re-uploaded %zu\n", changed.size(),
              surface.chunks().size(), scene.tooth.last_uploaded().size());
  // And the GPU copy now equals a fresh upload of the cut surface.
  Scene fresh = make_scene(camera(false));
  const cv::Mat reference = render(fresh, surface, T_cam_tooth);
  EXPECT_EQ(cv::norm(after, reference, cv::NORM_INF), 0.0);
}

void expect_silhouette_matches(bool distorted, const Eigen::Isometry3d& T_cam_tooth,
                               RendererOptions::WarpMode warp = RendererOptions::WarpMode::kGpu) {
  const auto k = camera(distorted);
  Scene scene = make_scene(k, warp);
  const cv::Mat rgba = render(scene, *tooth().surface, T_cam_tooth);
  if (const char* dir = std::getenv("DENTAR_TEST_IMAGES")) {
    static int n = 0;
    cv::Mat bgr;
    cv::cvtColor(rgba, bgr, cv::COLOR_RGBA2BGR);
    cv::imwrite(std::string(dir) + "/silhouette_" + std::to_string(n++) + ".png", bgr);
  }
  const cv::Rect2d got = coverage_bbox(rgba);
  const cv::Rect2d want = projected_bbox(k, T_cam_tooth, *tooth().surface);
  std::printf("%s: rendered [%.0f..%.0f]x[%.0f..%.0f], vertices [%.2f..%.2f]x[%.2f..%.2f]\n",
              distorted ? "distorted" : "pinhole", got.x, got.x + got.width, got.y,
              got.y + got.height, want.x, want.x + want.width, want.y, want.y + want.height);
  // Covered pixel centres lie within a pixel of the extreme vertices.
  EXPECT_NEAR(got.x, want.x, 1.0);
  EXPECT_NEAR(got.y, want.y, 1.0);
  EXPECT_NEAR(got.x + got.width, want.x + want.width, 1.0);
  EXPECT_NEAR(got.y + got.height, want.y + want.height, 1.0);
  EXPECT_GT(want.width, 80.0);  // the tooth fills a good part of the image
}

TEST(ToothRendererGl, SilhouetteMatchesProjectedVertices) {
  DENTAR_GL_TEST_CONTEXT();
  expect_silhouette_matches(false, occlusal_view(tooth(), 0.045));
  expect_silhouette_matches(false, oblique_view(tooth()));
}

TEST(ToothRendererGl, SilhouetteMatchesProjectedVerticesWithDistortion) {
  DENTAR_GL_TEST_CONTEXT();
  expect_silhouette_matches(true, occlusal_view(tooth(), 0.045));
  expect_silhouette_matches(true, oblique_view(tooth()));
  expect_silhouette_matches(true, oblique_view(tooth()), RendererOptions::WarpMode::kCpu);
}

double colour_distance(const cv::Vec4b& a, const Eigen::Vector3f& rgb01) {
  return std::sqrt(std::pow(a[0] - 255.0 * rgb01.x(), 2) + std::pow(a[1] - 255.0 * rgb01.y(), 2) +
                   std::pow(a[2] - 255.0 * rgb01.z(), 2));
}

TEST(ToothRendererGl, TransparentEnamelRevealsWhatLiesBeneath) {
  DENTAR_GL_TEST_CONTEXT();
  const auto k = camera(false);
  Scene scene = make_scene(k);
  const Eigen::Isometry3d T = occlusal_view(tooth(), 0.045);
  // Crown centre: the principal point (the crown's top centre is on the axis).
  const cv::Point px(static_cast<int>(std::lround(k.cx)), static_cast<int>(std::lround(k.cy)));
  const Eigen::Vector3f enamel = scene.tooth.style(dv::Material::kEnamel).rgb;
  const Eigen::Vector3f pulp = scene.tooth.style(dv::Material::kPulp).rgb;

  const cv::Vec4b opaque = render(scene, *tooth().surface, T).at<cv::Vec4b>(px);
  scene.tooth.set_style(dv::Material::kEnamel, {enamel, 0.0f});
  const cv::Vec4b hidden = render(scene, *tooth().surface, T).at<cv::Vec4b>(px);
  scene.tooth.set_style(dv::Material::kEnamel, {enamel, 0.4f});
  const cv::Vec4b half = render(scene, *tooth().surface, T).at<cv::Vec4b>(px);
  std::printf(
      "crown centre RGBA: opaque (%d %d %d %d), enamel alpha 0 (%d %d %d %d), 0.4 (%d %d %d %d)\n",
      opaque[0], opaque[1], opaque[2], opaque[3], hidden[0], hidden[1], hidden[2], hidden[3],
      half[0], half[1], half[2], half[3]);
  // Opaque: lit enamel (near-white, neutral). Enamel hidden: the mesh has no
  // enamel/dentin interface, so the ray through the crown centre next meets
  // the pulp chamber's floor (labelled pulp): the pixel turns red.
  EXPECT_EQ(opaque[3], 255);
  EXPECT_LT(colour_distance(opaque, enamel), colour_distance(opaque, pulp));
  EXPECT_LT(colour_distance(hidden, pulp), colour_distance(hidden, enamel));
  EXPECT_GT(hidden[0], hidden[1] + 60);  // red dominates
  // 40 % enamel: in between, blended over the pulp.
  EXPECT_GT(half[1], hidden[1] + 20);
  EXPECT_LT(half[1], opaque[1]);
}

TEST(ToothRendererGl, DeterministicImages) {
  DENTAR_GL_TEST_CONTEXT();
  const auto k = camera(true);
  const Eigen::Isometry3d T = oblique_view(tooth());
  Scene a = make_scene(k);
  const cv::Mat first = render(a, *tooth().surface, T);
  const cv::Mat second = render(a, *tooth().surface, T);
  Scene b = make_scene(k);
  const cv::Mat third = render(b, *tooth().surface, T);
  EXPECT_EQ(cv::norm(first, second, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(first, third, cv::NORM_INF), 0.0);
  // The CPU warp is deterministic too, and close to the GPU one (both
  // bilinear; they differ in sub-pixel weight quantisation only).
  Scene c = make_scene(k, RendererOptions::WarpMode::kCpu);
  const cv::Mat cpu1 = render(c, *tooth().surface, T);
  const cv::Mat cpu2 = render(c, *tooth().surface, T);
  EXPECT_EQ(cv::norm(cpu1, cpu2, cv::NORM_INF), 0.0);
  cv::Mat diff;
  cv::absdiff(first, cpu1, diff);
  EXPECT_LT(cv::mean(diff)[0], 1.0);
  EXPECT_LE(cv::norm(first, cpu1, cv::NORM_INF), 40.0);
  EXPECT_GT(cv::countNonZero(first.reshape(1) > 0), 1000);
}

TEST(PartRendererGl, DrawsBurHandpieceAndMirrorWhereTheyAre) {
  DENTAR_GL_TEST_CONTEXT();
  const auto k = camera(true);
  auto renderer = Renderer::create(k);
  ASSERT_TRUE(renderer.ok()) << renderer.error();
  auto parts = PartRenderer::create();
  ASSERT_TRUE(parts.ok()) << parts.error();
  const auto bur_params = dv::BurParams::capsule(0.5, 3.0);
  const GpuPart bur = parts->upload(make_bur_mesh(bur_params));
  const GpuPart handpiece = parts->upload(make_handpiece_mesh(bur_params));
  const MirrorMeshes mirror_mesh = make_mirror_meshes();
  const GpuPart mirror_face = parts->upload(mirror_mesh.face);
  const GpuPart mirror_body = parts->upload(mirror_mesh.body);

  // Bur pointing down-right across the image at 12 cm; mirror facing the
  // camera on the left at 15 cm.
  Eigen::Isometry3d T_cam_tip = Eigen::Isometry3d::Identity();
  T_cam_tip.linear() = Eigen::AngleAxisd(-1.2, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T_cam_tip.translation() = Eigen::Vector3d(0.02, 0.01, 0.12);
  Eigen::Isometry3d T_cam_mir = Eigen::Isometry3d::Identity();
  T_cam_mir.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  T_cam_mir.translation() = Eigen::Vector3d(-0.03, -0.01, 0.15);

  const MaterialStyle steel{{0.75f, 0.75f, 0.78f}, 1.0f}, body{{0.2f, 0.3f, 0.6f}, 1.0f},
      glass{{0.1f, 0.9f, 0.2f}, 1.0f};
  renderer->begin_frame();
  parts->draw(bur, renderer->clip_from_cam(), T_cam_tip, steel);
  parts->draw(handpiece, renderer->clip_from_cam(), T_cam_tip, body);
  parts->draw(mirror_face, renderer->clip_from_cam(), T_cam_mir, glass);
  parts->draw(mirror_body, renderer->clip_from_cam(), T_cam_mir, body);
  renderer->end_frame();
  cv::Mat rgba;
  renderer->read_rgba(rgba);
  ASSERT_EQ(gl_error_message("parts"), "");
  if (const char* dir = std::getenv("DENTAR_TEST_IMAGES")) {
    cv::Mat bgr;
    cv::cvtColor(rgba, bgr, cv::COLOR_RGBA2BGR);
    cv::imwrite(std::string(dir) + "/parts.png", bgr);
  }

  const CameraModel cam(k);
  auto pixel_at = [&](const Eigen::Vector3d& p_cam) {
    const auto uv = cam.project(p_cam);
    EXPECT_TRUE(uv.has_value());
    return rgba.at<cv::Vec4b>(static_cast<int>(std::lround(uv->y())),
                              static_cast<int>(std::lround(uv->x())));
  };
  // Inside the bur's hemispherical end: steel-grey (neutral) and covered.
  const cv::Vec4b tip = pixel_at(T_cam_tip * Eigen::Vector3d(0, 0, -0.5e-3));
  EXPECT_EQ(tip[3], 255);
  EXPECT_NEAR(tip[0], tip[2], 25);
  // The handpiece head: bluish.
  const double z_head = bur_shank_end_z_m(bur_params) - 4e-3;
  const cv::Vec4b head = pixel_at(T_cam_tip * Eigen::Vector3d(0, 0, z_head));
  EXPECT_GT(head[2], head[0] + 30);
  // The mirror's face (its reflection comes later): green.
  const cv::Vec4b face = pixel_at(T_cam_mir * Eigen::Vector3d(0.004, 0.003, 0));
  EXPECT_GT(face[1], face[0] + 80);
  // Nothing far from both: still the clear colour.
  EXPECT_EQ(rgba.at<cv::Vec4b>(10, 10)[3], 0);
}

}  // namespace
}  // namespace dentar::ar
