#include "dentar/calibration/stereo.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <map>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <random>
#include <sstream>

#include "intrinsics_detail.h"

namespace dentar::calibration {

namespace {

constexpr double kDeg = M_PI / 180.0;

std::string fmt(double v, int prec = 2) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(prec) << v;
  return os.str();
}

struct Lens8 {
  cv::Mat K, D;
};
Lens8 lens_of(const IntrinsicsSummary& s) {
  Lens8 l;
  l.K = (cv::Mat_<double>(3, 3) << s.camera.fx, 0, s.camera.cx, 0, s.camera.fy, s.camera.cy, 0, 0, 1);
  std::vector<double> d = s.dist;
  if (d.empty()) d.assign(s.camera.dist.begin(), s.camera.dist.end());
  l.D = cv::Mat(d, true).reshape(1, 1);
  return l;
}

int model_flags(DistortionModel m) {
  int flags = 0;
  if (m == DistortionModel::kRational8) flags |= cv::CALIB_RATIONAL_MODEL;
  if (m == DistortionModel::kK1) flags |= cv::CALIB_FIX_K2 | cv::CALIB_FIX_K3 | cv::CALIB_ZERO_TANGENT_DIST;
  if (m == DistortionModel::kK1K2) flags |= cv::CALIB_FIX_K3 | cv::CALIB_ZERO_TANGENT_DIST;
  return flags;
}

// Board points both eyes saw in one capture, matched by their board coordinates.
struct CommonView {
  int index = -1;
  std::vector<cv::Point3f> obj;
  std::vector<cv::Point2f> l, r;
};

CommonView match(const BoardView& a, const BoardView& b, int index) {
  CommonView v;
  v.index = index;
  // Board coordinates on a 0.1 um grid (a turned board's are computed, not copied).
  auto key = [](const Eigen::Vector3d& q) {
    return std::make_tuple(std::llround(q.x() * 1e7), std::llround(q.y() * 1e7), std::llround(q.z() * 1e7));
  };
  std::map<std::tuple<long long, long long, long long>, std::size_t> in_b;
  for (std::size_t j = 0; j < b.object_points.size() && j < b.image_points.size(); ++j) in_b[key(b.object_points[j])] = j;
  for (std::size_t j = 0; j < a.object_points.size() && j < a.image_points.size(); ++j) {
    const auto& q = a.object_points[j];
    auto it = in_b.find(key(q));
    if (it == in_b.end()) continue;
    v.obj.emplace_back(static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()));
    v.l.emplace_back(static_cast<float>(a.image_points[j].x()), static_cast<float>(a.image_points[j].y()));
    const auto& p = b.image_points[it->second];
    v.r.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
  }
  return v;
}

Eigen::Isometry3d from_rt(const cv::Mat& R, const cv::Mat& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) T.linear()(i, j) = R.at<double>(i, j);
    T.translation()(i) = t.at<double>(i);
  }
  return T;
}

Eigen::Vector3d rotvec(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

// T_camr_caml from stereoCalibrate (x_r = R x_l + T); false when it fails.
bool stereo_fit(const std::vector<const CommonView*>& views, Lens8& l, Lens8& r, cv::Size size, int flags,
                Eigen::Isometry3d& T_caml_camr, double& rms) {
  std::vector<std::vector<cv::Point3f>> obj;
  std::vector<std::vector<cv::Point2f>> pl, pr;
  for (const CommonView* v : views) {
    obj.push_back(v->obj);
    pl.push_back(v->l);
    pr.push_back(v->r);
  }
  cv::Mat R, T, E, F;
  try {
    rms = cv::stereoCalibrate(obj, pl, pr, l.K, l.D, r.K, r.D, size, R, T, E, F, flags,
                              cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-10));
  } catch (const cv::Exception&) {
    return false;
  }
  if (!std::isfinite(rms) || R.empty() || !cv::checkRange(R) || !cv::checkRange(T)) return false;
  R.convertTo(R, CV_64F);
  T.convertTo(T, CV_64F);
  T_caml_camr = from_rt(R, T).inverse();
  return true;
}

}  // namespace

std::string StereoCalibrationOptions::validate() const {
  if (auto e = model.validate(); !e.empty()) return "model." + e;
  if (min_common_views < 3) return "min_common_views = " + std::to_string(min_common_views) + " must be >= 3";
  if (min_common_points < 4) return "min_common_points = " + std::to_string(min_common_points) + " must be >= 4";
  if (!(max_rotation_scatter_rad > 0) || !(max_translation_scatter_m > 0))
    return "max_rotation_scatter_rad and max_translation_scatter_m must be > 0";
  if (!(max_residual_ratio > 1)) return "max_residual_ratio = " + std::to_string(max_residual_ratio) + " must be > 1";
  if (bootstrap < 0 || bootstrap > 10000) return "bootstrap = " + std::to_string(bootstrap) + " must be in 0..10000";
  return {};
}

std::string StereoCalibration::report() const {
  std::ostringstream os;
  os << "stereo calibration: " << (ok ? "OK" : "REFUSED") << ": " << message << "\n";
  auto eye = [&](const char* name, const ModelSelection& m) {
    if (!m.chosen.calibrations_run) return;
    os << "  " << name << " eye: fx " << fmt(m.chosen.camera.fx) << " fy " << fmt(m.chosen.camera.fy) << " cx "
       << fmt(m.chosen.camera.cx) << " cy " << fmt(m.chosen.camera.cy) << " px, model "
       << distortion_model_name(m.model) << ", RMS " << fmt(m.chosen.rms_px, 3) << " px, trusted to "
       << fmt(m.trust.max_error_px, 1) << " px over " << fmt(m.trust.trusted_fraction * 100, 0)
       << "% of the image" << (m.ok ? "" : " (REFUSED: " + m.message + ")") << "\n";
  };
  eye("left", left);
  eye("right", right);
  if (!views.empty()) {
    const Eigen::Vector3d t = T_caml_camr.translation() * 1e3;
    const Eigen::AngleAxisd aa(T_caml_camr.linear());
    os << "  T_left_right: t = (" << fmt(t.x(), 3) << ", " << fmt(t.y(), 3) << ", " << fmt(t.z(), 3)
       << ") mm +- (" << fmt(sigma_t_m.x() * 1e3, 3) << ", " << fmt(sigma_t_m.y() * 1e3, 3) << ", "
       << fmt(sigma_t_m.z() * 1e3, 3) << ") mm (1 sigma), rotation " << fmt(aa.angle() / kDeg, 3)
       << " deg +- (" << fmt(sigma_r_rad.x() / kDeg, 3) << ", " << fmt(sigma_r_rad.y() / kDeg, 3) << ", "
       << fmt(sigma_r_rad.z() / kDeg, 3) << ") deg; baseline " << fmt(baseline_m() * 1e3, 3) << " +- "
       << fmt(sigma_baseline_m * 1e3, 3) << " mm; RMS " << fmt(rms_px, 3) << " px over " << views.size()
       << " common views (1-sigma from " << resamples << " refits)\n";
    os << "  rigidity: per-view relative poses scatter " << fmt(rotation_scatter_rad / kDeg, 3) << " deg, "
       << fmt(translation_scatter_m * 1e3, 3) << " mm RMS; one rig " << fmt(rigid_rms_px, 3) << " px vs per-view poses "
       << fmt(free_rms_px, 3) << " px RMS (ratio " << fmt(residual_ratio, 2) << ")\n";
  }
  return os.str();
}

StereoCalibration calibrate_stereo(const std::vector<BoardView>& left, const std::vector<BoardView>& right,
                                   int width, int height, const StereoCalibrationOptions& options) {
  StereoCalibration out;
  if (auto e = options.validate(); !e.empty()) {
    out.message = "StereoCalibrationOptions: " + e;
    return out;
  }
  if (left.size() != right.size()) {
    out.message = "the left eye has " + std::to_string(left.size()) + " views but the right eye " +
                  std::to_string(right.size()) + "; view i of each eye must be one capture";
    return out;
  }
  // 1. Intrinsics per eye, from every view the eye found the board in.
  auto found = [](const std::vector<BoardView>& vs) {
    std::vector<BoardView> f;
    for (const auto& v : vs)
      if (!v.image_points.empty()) f.push_back(v);
    return f;
  };
  out.left = select_camera_model(found(left), width, height, options.model);
  out.right = select_camera_model(found(right), width, height, options.model);
  out.camera_left = out.left.chosen.camera;
  out.camera_right = out.right.chosen.camera;
  if (!out.left.ok || !out.right.ok) {
    out.message = std::string(!out.left.ok ? "left" : "right") + " eye's intrinsics refused: " +
                  (!out.left.ok ? out.left.message : out.right.message);
    return out;
  }
  // 2. Common views. A chessboard's corners may come back in the reverse order in one eye (its
  // pattern looks the same turned 180 degrees): each capture is matched both ways, the right
  // eye's board turned or not, and the match whose relative pose turns less is kept (the eyes of
  // a stereo head look the same way). Decoded tags never need the turn (it turns by 180 deg).
  Lens8 L = lens_of(out.left.chosen), R = lens_of(out.right.chosen);
  auto relative_angle = [&](const CommonView& v) {
    cv::Mat rl, tl, rr, tr, Rl, Rr;
    if (!cv::solvePnP(v.obj, v.l, L.K, L.D, rl, tl) || !cv::solvePnP(v.obj, v.r, R.K, R.D, rr, tr)) return M_PI;
    cv::Rodrigues(rl, Rl);
    cv::Rodrigues(rr, Rr);
    return Eigen::AngleAxisd((from_rt(Rl, tl) * from_rt(Rr, tr).inverse()).linear()).angle();
  };
  std::vector<CommonView> common;
  for (std::size_t i = 0; i < left.size(); ++i) {
    CommonView v = match(left[i], right[i], static_cast<int>(i));
    if (right[i].object_points.size() >= 4 && static_cast<int>(v.obj.size()) >= options.min_common_points) {
      BoardView turned = right[i];
      double mx = 0, my = 0;
      for (const auto& q : turned.object_points) {
        mx = std::max(mx, q.x());
        my = std::max(my, q.y());
      }
      for (auto& q : turned.object_points) q = Eigen::Vector3d(mx - q.x(), my - q.y(), q.z());
      CommonView t = match(left[i], turned, static_cast<int>(i));
      if (t.obj.size() == v.obj.size() && relative_angle(t) < relative_angle(v)) {
        v = std::move(t);
        ++out.turned_views;
      }
    }
    if (static_cast<int>(v.obj.size()) >= options.min_common_points) common.push_back(std::move(v));
  }
  if (static_cast<int>(common.size()) < options.min_common_views) {
    out.message = "only " + std::to_string(common.size()) + " of " + std::to_string(left.size()) +
                  " captures show the board to both eyes (at least " + std::to_string(options.min_common_points) +
                  " points in common); " + std::to_string(options.min_common_views) +
                  " are needed: hold the board where both cameras see it";
    return out;
  }
  const cv::Size size(width, height);
  std::vector<const CommonView*> all;
  for (const auto& v : common) all.push_back(&v);
  if (!stereo_fit(all, L, R, size, cv::CALIB_FIX_INTRINSIC, out.T_caml_camr, out.rms_px)) {
    out.message = "the extrinsics fit failed (OpenCV stereoCalibrate did not converge)";
    return out;
  }
  // 3. Rigidity: each view's own relative pose against the estimate, and the residual of one rig
  // for all views against each eye's own pose per view.
  double sr = 0, st = 0, free_sq = 0;
  std::size_t free_n = 0;
  for (const auto& v : common) {
    cv::Mat rl, tl, rr, tr;
    cv::solvePnP(v.obj, v.l, L.K, L.D, rl, tl);
    cv::solvePnP(v.obj, v.r, R.K, R.D, rr, tr);
    for (int e = 0; e < 2; ++e) {
      std::vector<cv::Point2f> proj;
      cv::projectPoints(v.obj, e == 0 ? rl : rr, e == 0 ? tl : tr, e == 0 ? L.K : R.K, e == 0 ? L.D : R.D, proj);
      const auto& seen = e == 0 ? v.l : v.r;
      for (std::size_t j = 0; j < proj.size(); ++j) {
        const cv::Point2f d = proj[j] - seen[j];
        free_sq += static_cast<double>(d.dot(d));
        ++free_n;
      }
    }
    cv::Mat Rl, Rr;
    cv::Rodrigues(rl, Rl);
    cv::Rodrigues(rr, Rr);
    const Eigen::Isometry3d T_l_b = from_rt(Rl, tl), T_r_b = from_rt(Rr, tr);
    const Eigen::Isometry3d Ti = T_l_b * T_r_b.inverse();
    const Eigen::Isometry3d d = out.T_caml_camr.inverse() * Ti;
    StereoViewPose p;
    p.index = v.index;
    p.name = left[v.index].name;
    p.points = static_cast<int>(v.obj.size());
    p.rotation_dev_rad = Eigen::AngleAxisd(d.linear()).angle();
    p.translation_dev_m = (Ti.translation() - out.T_caml_camr.translation()).norm();
    sr += p.rotation_dev_rad * p.rotation_dev_rad;
    st += p.translation_dev_m * p.translation_dev_m;
    out.views.push_back(p);
  }
  out.rotation_scatter_rad = std::sqrt(sr / static_cast<double>(common.size()));
  out.translation_scatter_m = std::sqrt(st / static_cast<double>(common.size()));
  out.free_rms_px = std::sqrt(free_sq / static_cast<double>(std::max<std::size_t>(1, free_n)));
  out.rigid_rms_px = out.rms_px;
  out.residual_ratio = out.free_rms_px > 0 ? out.rigid_rms_px / out.free_rms_px : 0;
  if (out.residual_ratio > options.max_residual_ratio || out.rotation_scatter_rad > options.max_rotation_scatter_rad ||
      out.translation_scatter_m > options.max_translation_scatter_m) {
    std::vector<StereoViewPose> worst = out.views;
    std::sort(worst.begin(), worst.end(), [&](const StereoViewPose& a, const StereoViewPose& b) {
      return a.rotation_dev_rad / options.max_rotation_scatter_rad + a.translation_dev_m / options.max_translation_scatter_m >
             b.rotation_dev_rad / options.max_rotation_scatter_rad + b.translation_dev_m / options.max_translation_scatter_m;
    });
    std::ostringstream os;
    os << "the rig is not rigid across the views: the right eye's pose relative to the left scatters by "
       << fmt(out.rotation_scatter_rad / kDeg, 3) << " deg and " << fmt(out.translation_scatter_m * 1e3, 2)
       << " mm RMS from view to view (gross limits " << fmt(options.max_rotation_scatter_rad / kDeg, 3) << " deg, "
       << fmt(options.max_translation_scatter_m * 1e3, 2) << " mm), more than the corners' noise explains: one rig for "
       << "all views leaves " << fmt(out.rigid_rms_px, 3) << " px RMS against " << fmt(out.free_rms_px, 3)
       << " px with each view's own poses (ratio " << fmt(out.residual_ratio, 2) << ", limit "
       << fmt(options.max_residual_ratio, 2) << "); most off:";
    for (std::size_t i = 0; i < worst.size() && i < 3; ++i)
      os << " " << worst[i].name << " (" << fmt(worst[i].rotation_dev_rad / kDeg, 3) << " deg, "
         << fmt(worst[i].translation_dev_m * 1e3, 2) << " mm)";
    os << ". Were the cameras moved against each other between photos? Fix them rigidly and take all "
          "the photos again in one session";
    out.message = os.str();
    return out;
  }
  // 4. Joint refinement and its uncertainty: jackknife (or bootstrap) over the common views,
  // intrinsics refitted with the extrinsics.
  std::mt19937_64 rng(options.seed * 7919 + 3);
  std::uniform_int_distribution<std::size_t> pick(0, common.size() - 1);
  std::vector<Eigen::Matrix<double, 7, 1>> devs;
  // stereoCalibrate has one set of model flags for both eyes: the more flexible eye's (a
  // 5-coefficient eye beside a rational8 one is padded with zeros).
  const DistortionModel flexible =
      free_coefficient_count(out.left.model) >= free_coefficient_count(out.right.model) ? out.left.model
                                                                                        : out.right.model;
  const int flags = cv::CALIB_USE_INTRINSIC_GUESS | model_flags(flexible);
  auto padded = [](const cv::Mat& D, int n) {
    cv::Mat o = cv::Mat::zeros(1, std::max(n, D.cols), CV_64F);
    D.copyTo(o(cv::Rect(0, 0, D.cols, 1)));
    return o;
  };
  const int ncoef = std::max(L.D.cols, R.D.cols);
  // The estimate: both eyes' intrinsics refined with the extrinsics (the rig constrains them
  // too), started at step 1's; the resamples below scatter about this fit.
  {
    Lens8 lj{L.K.clone(), padded(L.D, ncoef)}, rj{R.K.clone(), padded(R.D, ncoef)};
    Eigen::Isometry3d Tj;
    double rms = 0;
    if (stereo_fit(all, lj, rj, size, flags, Tj, rms)) {
      out.T_caml_camr = Tj;
      out.rms_px = rms;
      L = lj;
      R = rj;
    }
  }
  auto to_cam = [&](const Lens8& l) {
    CameraIntrinsics k;
    k.width = width;
    k.height = height;
    k.fx = l.K.at<double>(0, 0);
    k.fy = l.K.at<double>(1, 1);
    k.cx = l.K.at<double>(0, 2);
    k.cy = l.K.at<double>(1, 2);
    for (int i = 0; i < 5 && i < l.D.cols; ++i) k.dist[static_cast<std::size_t>(i)] = l.D.at<double>(0, i);
    return k;
  };
  out.camera_left = to_cam(L);
  out.camera_right = to_cam(R);
  auto deviation = [&](const std::vector<const CommonView*>& sample, Eigen::Matrix<double, 7, 1>& e) {
    Lens8 lb{L.K.clone(), L.D.clone()}, rb{R.K.clone(), R.D.clone()};
    Eigen::Isometry3d Tb;
    double rms = 0;
    if (!stereo_fit(sample, lb, rb, size, flags, Tb, rms)) return false;
    const Eigen::Isometry3d d = out.T_caml_camr.inverse() * Tb;
    e.head<3>() = Tb.translation() - out.T_caml_camr.translation();
    e.segment<3>(3) = out.T_caml_camr.linear() * rotvec(d.linear());
    e(6) = Tb.translation().norm() - out.baseline_m();
    return true;
  };
  Eigen::Matrix<double, 7, 1> var = Eigen::Matrix<double, 7, 1>::Zero();
  if (options.uncertainty == StereoUncertainty::kJackknife) {
    // Leave one capture out: var = (n-1)/n * sum (theta_i - mean)^2.
    for (std::size_t skip = 0; skip < common.size(); ++skip) {
      std::vector<const CommonView*> sample;
      for (std::size_t i = 0; i < common.size(); ++i)
        if (i != skip) sample.push_back(&common[i]);
      Eigen::Matrix<double, 7, 1> e;
      if (deviation(sample, e)) devs.push_back(e);
    }
    if (devs.size() >= 3) {
      Eigen::Matrix<double, 7, 1> mean = Eigen::Matrix<double, 7, 1>::Zero();
      for (const auto& e : devs) mean += e;
      mean /= static_cast<double>(devs.size());
      for (const auto& e : devs) var += (e - mean).cwiseAbs2();
      var *= static_cast<double>(devs.size() - 1) / static_cast<double>(devs.size());
    }
  } else {
    for (int b = 0; b < options.bootstrap; ++b) {
      std::vector<const CommonView*> sample;
      for (std::size_t i = 0; i < common.size(); ++i) sample.push_back(&common[pick(rng)]);
      Eigen::Matrix<double, 7, 1> e;
      if (deviation(sample, e)) devs.push_back(e);
    }
    if (devs.size() >= 2) {
      Eigen::Matrix<double, 7, 1> mean = Eigen::Matrix<double, 7, 1>::Zero();
      for (const auto& e : devs) mean += e;
      mean /= static_cast<double>(devs.size());
      for (const auto& e : devs) var += (e - mean).cwiseAbs2();
      var /= static_cast<double>(devs.size() - 1);
    }
  }
  out.resamples = static_cast<int>(devs.size());
  out.sigma_t_m = var.head<3>().cwiseSqrt();
  out.sigma_r_rad = var.segment<3>(3).cwiseSqrt();
  out.sigma_baseline_m = std::sqrt(var(6));
  out.ok = true;
  out.message = "baseline " + fmt(out.baseline_m() * 1e3, 2) + " +- " + fmt(out.sigma_baseline_m * 1e3, 2) +
                " mm, rotation between the eyes " + fmt(Eigen::AngleAxisd(out.T_caml_camr.linear()).angle() / kDeg, 2) +
                " deg, from " + std::to_string(common.size()) + " common views" +
                (out.turned_views > 0 ? " (" + std::to_string(out.turned_views) +
                                            " with the right eye's chessboard corners in reverse order, matched turned)"
                                      : "");
  return out;
}

}  // namespace dentar::calibration
