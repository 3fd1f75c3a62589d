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
  bool display_features = false;  // keep the sites for features_for_display() (diagnosis)
};

// One planar face of the model: 3 or more corners in the body frame,
// counter-clockwise seen from the side it is visible from.
using Face = std::vector<Eigen::Vector3d>;

// A circle of the model (CAO "3D circles"): its centre and two more points
// of its plane, body frame. ViSP tracks it as an ellipse of moving edges,
// visible (like a face) when its plane's normal (p1 - centre) x (p2 -
// centre) points toward the camera.
struct Circle {
  Eigen::Vector3d centre, p1, p2;
  double radius = 0;
};

struct Model {
  std::vector<Face> faces;
  std::vector<Circle> circles;
};

class Refiner {
 public:
  // Pinhole camera (the images must be undistorted with the same K).
  // `scratch_dir`: where the CAO model file is written.
  static std::unique_ptr<Refiner> create(const std::vector<Face>& faces, double fx, double fy, double cx,
                                         double cy, const Options& o, const std::string& scratch_dir,
                                         std::string* error);
  // Faces and circles; the CAO file is named after `model_name` in scratch_dir.
  static std::unique_ptr<Refiner> create(const Model& model, double fx, double fy, double cx, double cy,
                                         const Options& o, const std::string& scratch_dir,
                                         const std::string& model_name, std::string* error);
  virtual ~Refiner() = default;
  // Edges: seeds on `image` at T_cam_body and tracks in the same image.
  // Edges + KLT: seeds on `prev_image` at `prev_T`, tracks into `image`.
  // False when ViSP threw (message in *error).
  virtual bool refine(const cv::Mat& gray, const Eigen::Isometry3d& T_seed, const cv::Mat* prev_gray,
                      const Eigen::Isometry3d* prev_T, Eigen::Isometry3d& out, std::string* error) = 0;
  virtual int features() const = 0;  // edge + KLT features used in the last refine
  // Moving-edge sites on the model's circles in the last refine (visible
  // circles only), and the circles ViSP loaded from the CAO file.
  virtual int circle_features() const = 0;
  virtual int model_circles() const = 0;
  // ViSP's mean robust weight of the visible circles' sites in the last
  // refine (-1: no visible circle), and whether all of them were tracked.
  virtual double circle_weight() const = 0;
  // Diagnosis (ViSP's own rows, see vpMbGenericTracker): the last refine's
  // moving-edge sites, and the model's lines / ellipses projected at T.
  virtual std::vector<std::vector<double>> features_for_display() = 0;
  virtual std::vector<std::vector<double>> model_for_display(int width, int height, const Eigen::Isometry3d& T) = 0;
};

}  // namespace dentar::ar::visp
