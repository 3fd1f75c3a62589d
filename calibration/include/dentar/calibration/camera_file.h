// Camera intrinsics files: OpenCV FileStorage (YAML/XML, what `dentar calibrate camera` and
// OpenCV's calibration samples write) and ROS sensor_msgs/CameraInfo YAML (camera_calibration_parsers).
// Units: pixels for the camera matrix and the reprojection error; distortion is dimensionless.
#pragma once

#include <string>
#include <vector>

#include "dentar/calibration/station.h"
#include "dentar/core/result.h"

namespace dentar::calibration {

// Distortion models. The tracker and renderer use the 5-coefficient model only
// (CameraIntrinsics::dist); "rational8" is accepted for import/export and reported with a
// warning when its k4..k6 are not zero (the tracker then drops them).
inline constexpr const char* kModelRadTan5 = "pinhole-radtan5";  // OpenCV k1 k2 p1 p2 k3 (ROS plumb_bob)
inline constexpr const char* kModelRational8 = "rational8";  // + k4 k5 k6 (ROS rational_polynomial)
// The radtan5 model with fewer coefficients fitted (issue 24: a file names its model as it
// is): k1 only (k2 p1 p2 k3 are 0), k1 k2 only (p1 p2 k3 are 0). Stored as 5 coefficients.
inline constexpr const char* kModelK1 = "pinhole-k1";
inline constexpr const char* kModelK1K2 = "pinhole-k1k2";
// Empty when `model` is one of the four names above and `dist` (5 or 8 coefficients) is what
// it allows; else says which coefficient disagrees ("model pinhole-k1 has k2 = 0.1; ...").
std::string check_model_coefficients(const std::string& model, const std::vector<double>& dist);

struct CameraFile {
  CameraIntrinsics camera;  // image size, fx fy cx cy (px), k1 k2 p1 p2 k3
  std::string model = kModelRadTan5;
  // All distortion coefficients of `model` (5 or 8); dist[0..4] equals camera.dist.
  std::vector<double> dist;
  double rms_px = -1;  // overall reprojection RMS of the calibration, px; < 0 when unknown
  // Standard deviations of fx fy cx cy k1 k2 p1 p2 k3 [k4 k5 k6] (px for the first four), in
  // that order (OpenCV's stdDeviationsIntrinsics order); empty when unknown.
  std::vector<double> std_devs;
  std::string date;         // ISO 8601 UTC, e.g. "2026-11-22T01:30:00Z"; may be empty
  std::string device;       // free text: camera model/serial; may be empty
  std::string camera_name;  // ROS camera_name; may be empty
  int views_used = 0;       // views kept by the calibration; 0 when unknown
  // Set by read_camera_file: "opencv-yaml", "opencv-xml" or "ros-yaml".
  std::string source_format;
  // Non-empty when something was read but deserves the user's attention (e.g. rational
  // coefficients the tracker ignores).
  std::string warning;

  // Empty when valid; else names the field.
  std::string validate() const;
};

// Reads an OpenCV FileStorage YAML/XML (keys camera_matrix, distortion_coefficients,
// image_width, image_height; also the tutorial's Camera_Matrix/Distortion_Coefficients/
// image_Width/image_Height and our extra fields) or a ROS camera_info YAML (camera_matrix with
// rows/cols/data, distortion_model plumb_bob or rational_polynomial). The kind is detected from
// the content. Errors name the file and the field, and say what to do (a station JSON given
// here is recognised and named as such).
Result<CameraFile> read_camera_file(const std::string& path);

// Writes an OpenCV FileStorage YAML (".yaml"/".yml") or XML (".xml") with every field above.
// Refuses invalid content; writes to a temporary file and renames, so a failure leaves no
// half-written file.
Status write_camera_file(const std::string& path, const CameraFile& file);

// Writes a ROS camera_info YAML (camera_calibration_parsers layout): rectification identity,
// projection [K | 0]. distortion_model plumb_bob for 5 coefficients, rational_polynomial for 8.
Status write_ros_camera_info(const std::string& path, const CameraFile& file);

}  // namespace dentar::calibration
