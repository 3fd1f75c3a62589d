// Test helper: a printed tag drawn into an image through the exact camera
// homography of a pinhole camera (no lens distortion), so tracking tests run
// without GL (and under ThreadSanitizer). Shared by the discovery, pen and
// live tests.
#pragma once

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "dentar/ar/apriltags.h"
#include "dentar/ar/station_scene.h"

namespace dentar::ar::test {

// Draws tag `t` (its cells at `px_per_cell`, with a quiet zone of
// `margin_px` around them) at T_cam_parent * t.T_parent_tag into `img`
// (CV_8UC1 or CV_8UC3 of the camera's size). Tag-image pixel edges sit at
// -0.5 (OpenCV's continuous coordinates); the border square (width_at_border
// cells) has side t.size_m. `interpolation`: cv::INTER_LINEAR for tags about
// the size of their print, cv::INTER_AREA when they shrink a lot.
inline void draw_tag_pinhole(cv::Mat& img, const TagFamily& fam, const TagPlacement& t,
                             const Eigen::Isometry3d& T_cam_parent, const calibration::CameraIntrinsics& k,
                             int px_per_cell = 10, int margin_px = 10, int interpolation = cv::INTER_LINEAR) {
  cv::Mat tag = render_tag_image(fam, t.id, px_per_cell, margin_px);
  if (img.channels() == 3) cv::cvtColor(tag, tag, cv::COLOR_GRAY2BGR);
  const double cell_m = t.size_m / fam.width_at_border(), half_cells = fam.total_width() / 2.0;
  std::vector<cv::Point2f> src, dst;
  for (const auto& [u, v] : {std::pair{0.0, 0.0}, {1.0, 0.0}, {1.0, 1.0}, {0.0, 1.0}}) {
    const double px = u * tag.cols, py = v * tag.rows;  // continuous, edges at 0
    const Eigen::Vector3d p =
        T_cam_parent * t.T_parent_tag *
        Eigen::Vector3d(((px - margin_px) / px_per_cell - half_cells) * cell_m,
                        ((py - margin_px) / px_per_cell - half_cells) * cell_m, 0);
    src.emplace_back(static_cast<float>(px - 0.5), static_cast<float>(py - 0.5));
    dst.emplace_back(static_cast<float>(k.fx * p.x() / p.z() + k.cx), static_cast<float>(k.fy * p.y() / p.z() + k.cy));
  }
  cv::warpPerspective(tag, img, cv::getPerspectiveTransform(src, dst), img.size(), interpolation,
                      cv::BORDER_TRANSPARENT);
}

}  // namespace dentar::ar::test
