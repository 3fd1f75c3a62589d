// Internals of intrinsics.cpp shared with camera_model.cpp (not a public header).
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "dentar/calibration/intrinsics.h"

namespace dentar::calibration::detail {

// One cv::calibrateCamera run on a subset of the views with the model's flags.
struct CalibRun {
  bool ok = false;
  std::string error;
  double rms = 0;
  cv::Mat K, D, std_int;
  std::vector<cv::Mat> rvecs, tvecs;
  std::vector<double> per_view;  // aligned with the subset
};

CalibRun run_calibration(const std::vector<BoardView>& views, const std::vector<int>& subset,
                         int width, int height, DistortionModel model);

Eigen::Isometry3d to_iso(const cv::Mat& rvec, const cv::Mat& tvec);

}  // namespace dentar::calibration::detail
