// ViSP's model-based tracker behind a plain interface (Eigen, OpenCV only):
// ViSP 3.5's headers do not compile as C++20 (template-id constructors), so
// visp_bridge.cpp is built as C++17 and nothing else sees ViSP. Test-only:
// the refinement is measured, not adopted (docs/BENCHMARKS.md, issue 16).
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

namespace dentar::ar::visp {

struct Options {
  bool edges = true;
  bool klt = false;
  int me_range = 6;         // moving-edge search range along the normal, px
  int me_sample_step = 3;   // px between moving-edge sites
  double me_threshold = 5000;
};

// One planar face of the model: 3-4 corners in the body frame, counter-
// clockwise seen from the side it is visible from.
using Face = std::vector<Eigen::Vector3d>;

class Refiner {
 public:
  // Pinhole camera (the images must be undistorted with the same K).
  // `scratch_dir`: where the CAO model file is written.
  static std::unique_ptr<Refiner> create(const std::vector<Face>& faces, double fx, double fy, double cx,
                                         double cy, const Options& o, const std::string& scratch_dir,
                                         std::string* error);
  virtual ~Refiner() = default;
  // Edges: seeds on `image` at T_cam_body and tracks in the same image.
  // Edges + KLT: seeds on `prev_image` at `prev_T`, tracks into `image`.
  // False when ViSP threw (message in *error).
  virtual bool refine(const cv::Mat& gray, const Eigen::Isometry3d& T_seed, const cv::Mat* prev_gray,
                      const Eigen::Isometry3d* prev_T, Eigen::Isometry3d& out, std::string* error) = 0;
  virtual int features() const = 0;  // edge + KLT features used in the last refine
};

}  // namespace dentar::ar::visp
