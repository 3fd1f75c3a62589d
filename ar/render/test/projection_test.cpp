// OpenCV intrinsics -> GL clip space, and the undistortion plan, checked
// against OpenCV on the CPU (no GL needed).
#include "dentar/ar/projection.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <random>

#include "dentar/ar/camera_model.h"

namespace dentar::ar {
namespace {

calibration::CameraIntrinsics test_camera(bool distorted) {
  calibration::CameraIntrinsics k;
  k.width = 640;
  k.height = 480;
  k.fx = 600.0;
  k.fy = 610.0;
  k.cx = 319.3;
  k.cy = 241.7;
  if (distorted) k.dist = {-0.30, 0.12, 0.001, -0.0008, -0.02};
  return k;
}

cv::Point2d opencv_project(const calibration::CameraIntrinsics& k, const Eigen::Vector3d& p) {
  const cv::Matx33d K(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
  std::vector<cv::Point3d> obj{{p.x(), p.y(), p.z()}};
  std::vector<cv::Point2d> img;
  cv::projectPoints(obj, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K,
                    std::vector<double>(k.dist.begin(), k.dist.end()), img);
  return img[0];
}

TEST(Projection, ClipMatrixMatchesOpenCvPinhole) {
  const auto k = test_camera(false);
  const Eigen::Matrix4d P = clip_from_cam(k, 0.01, 2.0);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> xy(-0.2, 0.2), z(0.05, 1.5);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d p(xy(rng), xy(rng), z(rng));
    const Eigen::Vector2d uv = pixel_from_clip(P * p.homogeneous(), k.width, k.height);
    const cv::Point2d ref = opencv_project(k, p);
    EXPECT_NEAR(uv.x(), ref.x, 1e-9);
    EXPECT_NEAR(uv.y(), ref.y, 1e-9);
  }
}

TEST(Projection, PixelCentreConvention) {
  // The principal ray hits OpenCV pixel (cx, cy); pixel (0, 0)'s centre is half
  // a pixel inside the top-left corner of the GL viewport (ndc (-1, +1)).
  auto k = test_camera(false);
  k.cx = 0.0;
  k.cy = 0.0;
  const Eigen::Matrix4d P = clip_from_cam(k, 0.01, 2.0);
  const Eigen::Vector4d c = P * Eigen::Vector4d(0, 0, 1, 1);
  EXPECT_NEAR(c.x() / c.w(), -1.0 + 1.0 / k.width, 1e-12);
  EXPECT_NEAR(c.y() / c.w(), 1.0 - 1.0 / k.height, 1e-12);
}

TEST(Projection, DepthRangeAndWinding) {
  const auto k = test_camera(false);
  const double n = 0.02, f = 1.5;
  const Eigen::Matrix4d P = clip_from_cam(k, n, f);
  const Eigen::Vector4d cn = P * Eigen::Vector4d(0.01, -0.01, n, 1);
  const Eigen::Vector4d cf = P * Eigen::Vector4d(-0.3, 0.2, f, 1);
  EXPECT_NEAR(cn.z() / cn.w(), -1.0, 1e-12);
  EXPECT_NEAR(cf.z() / cf.w(), 1.0, 1e-12);
  // Triangle facing the camera, counter-clockwise seen from the camera
  // (normal (b-a)x(c-a) toward -z): counter-clockwise in GL window space.
  const Eigen::Vector3d a(0, 0, 0.5), b(0.01, 0, 0.5), c(0, -0.01, 0.5);
  ASSERT_LT((b - a).cross(c - a).z(), 0);
  auto ndc = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector4d q = P * p.homogeneous();
    return Eigen::Vector2d(q.x() / q.w(), q.y() / q.w());
  };
  const Eigen::Vector2d A = ndc(a), B = ndc(b), C = ndc(c);
  const double signed_area = (B - A).x() * (C - A).y() - (B - A).y() * (C - A).x();
  EXPECT_GT(signed_area, 0);
}

TEST(Projection, NoDistortionPlanIsIdentity) {
  auto v = plan_undistorted_view(test_camera(false));
  ASSERT_TRUE(v.ok()) << v.error();
  EXPECT_TRUE(v->identity());
  EXPECT_EQ(v->pinhole.width, 640);
  EXPECT_EQ(v->pinhole.cx, 319.3);
}

TEST(Projection, DistortionMapMatchesOpenCv) {
  const auto k = test_camera(true);
  auto v = plan_undistorted_view(k);
  ASSERT_TRUE(v.ok()) << v.error();
  ASSERT_FALSE(v->identity());
  EXPECT_EQ(v->invalid_pixels, 0);
  EXPECT_LT(v->max_inversion_error_px, 1e-6);
  // Barrel distortion: the pinhole canvas is larger than the image.
  EXPECT_GT(v->pinhole.width, k.width);
  EXPECT_GT(v->pinhole.height, k.height);
  EXPECT_EQ(v->pinhole.fx, k.fx);
  std::printf("canvas %dx%d for %dx%d, cx' %.1f cy' %.1f\n", v->pinhole.width, v->pinhole.height,
              k.width, k.height, v->pinhole.cx, v->pinhole.cy);
  // A pinhole pixel p maps to the 3D ray ((p - c')/f, 1); OpenCV projects that
  // ray, with distortion, back onto the output pixel the map came from.
  for (int v_px = 0; v_px < k.height; v_px += 37) {
    for (int u_px = 0; u_px < k.width; u_px += 41) {
      const Eigen::Vector2f m = v->map_px[static_cast<std::size_t>(v_px) * k.width + u_px];
      ASSERT_FALSE(std::isnan(m.x()));
      EXPECT_GE(m.x(), 0.0f);
      EXPECT_LE(m.x(), v->pinhole.width - 1.0f);
      const Eigen::Vector3d ray((m.x() - v->pinhole.cx) / k.fx, (m.y() - v->pinhole.cy) / k.fy, 1);
      const cv::Point2d back = opencv_project(k, ray);
      EXPECT_NEAR(back.x, u_px, 2e-3);  // float storage of the map: ~1e-4 px
      EXPECT_NEAR(back.y, v_px, 2e-3);
    }
  }
}

TEST(Projection, StrongLensIsClippedNotWrong) {
  auto k = test_camera(true);
  k.dist = {-0.6, 0.1, 0, 0, 0};  // folds over near the corners
  UndistortOptions o;
  o.max_canvas_scale = 1.5;
  auto v = plan_undistorted_view(k, o);
  ASSERT_TRUE(v.ok()) << v.error();
  EXPECT_GT(v->invalid_pixels, 0);
  EXPECT_LE(v->pinhole.width, static_cast<int>(1.5 * k.width) + 2 * o.margin_px + 2);
  const CameraModel cam(k);
  for (std::size_t i = 0; i < v->map_px.size(); i += 997) {
    const Eigen::Vector2f m = v->map_px[i];
    if (std::isnan(m.x())) continue;
    const Eigen::Vector2d xn((m.x() - v->pinhole.cx) / k.fx, (m.y() - v->pinhole.cy) / k.fy);
    const Eigen::Vector2d xd = cam.distort(xn);
    EXPECT_NEAR(k.fx * xd.x() + k.cx, static_cast<double>(i % k.width), 2e-3);
  }
}

TEST(Projection, RejectsBadInput) {
  auto k = test_camera(true);
  k.fx = -1;
  auto v = plan_undistorted_view(k);
  ASSERT_FALSE(v.ok());
  EXPECT_NE(v.error().find("fx"), std::string::npos) << v.error();
  UndistortOptions o;
  o.max_canvas_scale = 0.5;
  auto w = plan_undistorted_view(test_camera(true), o);
  ASSERT_FALSE(w.ok());
  EXPECT_NE(w.error().find("max_canvas_scale"), std::string::npos) << w.error();
}

}  // namespace
}  // namespace dentar::ar
