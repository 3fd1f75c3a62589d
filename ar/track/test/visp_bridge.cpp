// Built as C++17 (see visp_bridge.h).
#include "visp_bridge.h"

#include <cmath>
#include <exception>
#include <fstream>
#include <list>
#include <string>

#include <visp3/core/vpCameraParameters.h>
#include <visp3/core/vpHomogeneousMatrix.h>
#include <visp3/core/vpImageConvert.h>
#include <visp3/klt/vpKltOpencv.h>
#include <visp3/mbt/vpMbGenericTracker.h>
#include <visp3/me/vpMe.h>

namespace dentar::ar::visp {
namespace {

vpHomogeneousMatrix to_vp(const Eigen::Isometry3d& T) {
  vpHomogeneousMatrix M;
  for (unsigned r = 0; r < 3; ++r) {
    for (unsigned c = 0; c < 3; ++c) M[r][c] = T.linear()(r, c);
    M[r][3] = T.translation()(r);
  }
  return M;
}
Eigen::Isometry3d from_vp(const vpHomogeneousMatrix& M) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (unsigned r = 0; r < 3; ++r) {
    for (unsigned c = 0; c < 3; ++c) T.linear()(r, c) = M[r][c];
    T.translation()(r) = M[r][3];
  }
  return T;
}

class Impl : public Refiner {
 public:
  Impl(const Options& o) : o_(o), tracker_(1, (o.edges ? vpMbGenericTracker::EDGE_TRACKER : 0) |
                                                  (o.klt ? vpMbGenericTracker::KLT_TRACKER : 0)) {}
  bool init(const Model& model, double fx, double fy, double cx, double cy, const std::string& path,
            std::string* error) {
    try {
      {
        // CAO V1: points; lines; faces from lines; faces from points;
        // cylinders; circles ("radius centre p1 p2", point indices).
        std::ofstream f(path);
        f.precision(17);
        std::size_t n = 3 * model.circles.size();
        for (const Face& fc : model.faces) n += fc.size();
        f << "V1\n# 3D points\n" << n << "\n";
        for (const Face& fc : model.faces)
          for (const Eigen::Vector3d& p : fc) f << p.x() << " " << p.y() << " " << p.z() << "\n";
        for (const Circle& c : model.circles)
          for (const Eigen::Vector3d& p : {c.centre, c.p1, c.p2}) f << p.x() << " " << p.y() << " " << p.z() << "\n";
        f << "# 3D lines\n0\n# Faces from 3D lines\n0\n# Faces from 3D points\n" << model.faces.size() << "\n";
        std::size_t k = 0;
        for (const Face& fc : model.faces) {
          f << fc.size();
          for (std::size_t i = 0; i < fc.size(); ++i) f << " " << k++;
          f << "\n";
        }
        f << "# 3D cylinders\n0\n# 3D circles\n" << model.circles.size() << "\n";
        for (const Circle& c : model.circles) {
          f << c.radius << " " << k << " " << k + 1 << " " << k + 2 << "\n";
          k += 3;
        }
        if (!f) {
          if (error) *error = "cannot write the CAO model " + path;
          return false;
        }
      }
      tracker_.setCameraParameters(vpCameraParameters(fx, fy, cx, cy));
      vpMe me;
      me.setMaskSize(5);
      me.setMaskNumber(180);
      me.setRange(static_cast<unsigned>(o_.me_range));
      me.setThreshold(o_.me_threshold);
      me.setMu1(0.5);
      me.setMu2(0.5);
      me.setSampleStep(o_.me_sample_step);
      tracker_.setMovingEdge(me);
      if (o_.klt) {
        vpKltOpencv klt;
        klt.setMaxFeatures(300);
        klt.setWindowSize(5);
        klt.setQuality(0.01);
        klt.setMinDistance(3);
        klt.setHarrisFreeParameter(0.01);
        klt.setBlockSize(3);
        klt.setPyramidLevels(2);
        tracker_.setKltOpencv(klt);
        tracker_.setKltMaskBorder(1);
      }
      tracker_.setAngleAppear(80 * M_PI / 180);
      tracker_.setAngleDisappear(85 * M_PI / 180);
      tracker_.setNearClippingDistance(0.05);
      tracker_.setFarClippingDistance(2.0);
      tracker_.setClipping(tracker_.getClipping() | vpPolygon3D::FOV_CLIPPING);
      tracker_.setDisplayFeatures(o_.display_features);
      tracker_.loadModel(path);
    } catch (const std::exception& e) {
      if (error) *error = e.what();
      return false;
    }
    return true;
  }
  bool refine(const cv::Mat& gray, const Eigen::Isometry3d& T_seed, const cv::Mat* prev_gray,
              const Eigen::Isometry3d* prev_T, Eigen::Isometry3d& out, std::string* error) override {
    try {
      vpImageConvert::convert(gray, I_);
      if (o_.klt) {
        if (!prev_gray || !prev_T) {
          if (error) *error = "KLT needs the previous frame";
          return false;
        }
        vpImageConvert::convert(*prev_gray, I_prev_);
        tracker_.initFromPose(I_prev_, to_vp(*prev_T));
      } else {
        tracker_.initFromPose(I_, to_vp(T_seed));
      }
      tracker_.track(I_);
      vpHomogeneousMatrix cMo;
      tracker_.getPose(cMo);
      out = from_vp(cMo);
      features_ = static_cast<int>(tracker_.getNbFeaturesEdge() + tracker_.getNbFeaturesKlt());
      circle_features_ = 0;
      if (o_.edges) {
        std::list<vpMbtDistanceCircle*> circles;
        tracker_.getLcircle(circles, 0);
        circle_weight_ = -1;
        double w = 0;
        int n = 0;
        for (const vpMbtDistanceCircle* c : circles)
          if (c->isVisible()) {
            circle_features_ += c->isTracked() ? static_cast<int>(c->nbFeature) : 0;
            w += c->getMeanWeight();
            ++n;
          }
        if (n > 0) circle_weight_ = w / n;
      }
    } catch (const std::exception& e) {
      if (error) *error = e.what();
      return false;
    }
    return out.matrix().allFinite();
  }
  int features() const override { return features_; }
  int circle_features() const override { return circle_features_; }
  double circle_weight() const override { return circle_weight_; }
  std::vector<std::vector<double>> features_for_display() override {
    try {
      return tracker_.getFeaturesForDisplay();
    } catch (const std::exception&) {
      return {};
    }
  }
  std::vector<std::vector<double>> model_for_display(int width, int height, const Eigen::Isometry3d& T) override {
    try {
      vpCameraParameters cam;
      tracker_.getCameraParameters(cam);
      return tracker_.getModelForDisplay(static_cast<unsigned>(width), static_cast<unsigned>(height), to_vp(T), cam);
    } catch (const std::exception&) {
      return {};
    }
  }
  int model_circles() const override {
    try {
      std::list<vpMbtDistanceCircle*> circles;
      tracker_.getLcircle(circles, 0);
      return static_cast<int>(circles.size());
    } catch (const std::exception&) {
      return -1;  // no edge tracker
    }
  }

 private:
  Options o_;
  vpMbGenericTracker tracker_;
  vpImage<unsigned char> I_, I_prev_;
  int features_ = 0, circle_features_ = 0;
  double circle_weight_ = -1;
};

}  // namespace

std::unique_ptr<Refiner> Refiner::create(const std::vector<Face>& faces, double fx, double fy, double cx,
                                         double cy, const Options& o, const std::string& scratch_dir,
                                         std::string* error) {
  return create(Model{faces, {}}, fx, fy, cx, cy, o, scratch_dir, "dentar_visp_model", error);
}

std::unique_ptr<Refiner> Refiner::create(const Model& model, double fx, double fy, double cx, double cy,
                                         const Options& o, const std::string& scratch_dir,
                                         const std::string& model_name, std::string* error) {
  for (const Circle& c : model.circles)
    if (!(c.radius > 0) || !((c.p1 - c.centre).cross(c.p2 - c.centre).norm() > 0)) {
      if (error) *error = "visp::Model circle: radius must be > 0 and centre, p1, p2 must span a plane";
      return nullptr;
    }
  for (const Face& f : model.faces)
    if (f.size() < 3) {
      if (error) *error = "visp::Model face: needs >= 3 corners, has " + std::to_string(f.size());
      return nullptr;
    }
  auto r = std::make_unique<Impl>(o);
  if (!r->init(model, fx, fy, cx, cy, scratch_dir + "/" + model_name + ".cao", error)) return nullptr;
  return r;
}

}  // namespace dentar::ar::visp
