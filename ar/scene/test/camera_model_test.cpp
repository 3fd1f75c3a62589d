#include "dentar/ar/camera_model.h"

#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>
#include <random>

namespace dentar::ar {
namespace {

TEST(CameraModel, ProjectionMatchesOpenCvProjectPoints) {
  calibration::CameraIntrinsics k{1280, 720, 910.5, 905.25, 641.3, 358.7,
                                  {-0.28, 0.09, 0.0012, -0.0007, -0.012}};
  const CameraModel cam(k);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<cv::Point3d> pts;
  for (int i = 0; i < 200; ++i) pts.emplace_back(0.12 * u(rng), 0.07 * u(rng), 0.3 + 0.1 * u(rng));
  const cv::Matx33d K(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
  std::vector<cv::Point2d> ref;
  cv::projectPoints(pts, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K,
                    std::vector<double>(k.dist.begin(), k.dist.end()), ref);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const auto px = cam.project({pts[i].x, pts[i].y, pts[i].z});
    ASSERT_TRUE(px.has_value());
    EXPECT_NEAR(px->x(), ref[i].x, 1e-6);
    EXPECT_NEAR(px->y(), ref[i].y, 1e-6);
    const Eigen::Vector2d xn(pts[i].x / pts[i].z, pts[i].y / pts[i].z);
    EXPECT_NEAR((cam.undistort(cam.distort(xn)) - xn).norm(), 0.0, 1e-9);
  }
  EXPECT_FALSE(cam.project({0, 0, -0.1}).has_value());
}

}  // namespace
}  // namespace dentar::ar
