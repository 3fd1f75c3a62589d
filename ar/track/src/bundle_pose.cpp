#include "dentar/ar/bundle_pose.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <utility>

namespace dentar::ar {

namespace {

using Vec6 = Eigen::Matrix<double, 6, 1>;

// One kept corner: its point in the body frame, its undistorted pixel and
// the view that saw it.
struct Corner {
  Eigen::Vector3d p_body;
  Eigen::Vector2d uv_px;
  int view = 0;
  // How the corner moves with its view's blur stretch S = (Sxx, Sxy, Syy)
  // (BundlePoseOptions::blur_stretch_sigma_px): d uv / d S, from the
  // observed quad (blur_jacobians).
  Eigen::Matrix<double, 2, 3> blur = Eigen::Matrix<double, 2, 3>::Zero();
  // How it moves with its tag's outline offset e (BundlePoseOptions::
  // tag_outline_sigma): d uv / d e = blur * (2, 0, 2), every edge out by e.
  Eigen::Vector2d outline = Eigen::Vector2d::Zero();
};

// The blur model of one observed quad (quad_blur_model, bundle_pose.h): each
// corner's d uv / d S, fixed by the observed quad.
void blur_jacobians(Corner* q) {
  const QuadBlurModel m = quad_blur_model({q[0].uv_px, q[1].uv_px, q[2].uv_px, q[3].uv_px});
  for (int k = 0; k < 4; ++k) {
    q[k].blur = m.d_corner_d_S[static_cast<std::size_t>(k)];
    q[k].outline = q[k].blur * Eigen::Vector3d(2, 0, 2);  // every edge out by e: S = diag(2e, 2e)
  }
}

struct Pinhole {
  double fx, fy, cx, cy;
};

// One view's projection: its pinhole (after undistortion) and T_view_rig.
struct ViewGeom {
  Pinhole k;
  Eigen::Isometry3d T_view_rig = Eigen::Isometry3d::Identity();
  bool identity = true;  // T_view_rig is the identity (the single-camera fit)
};

// Residuals (projection - observation) and, when J is given, their
// Jacobian w.r.t. delta = (w, v) in the rig frame: R <- exp(w) R,
// t <- t + v (rotation about the body origin, so v is the error of the
// reported translation itself). A corner of view c projects
// p_c = T_c_rig (R p_body + t), so dp_c/d(w, v) = R_c_rig [-[R p_body]x, I].
// Returns false when a corner lies behind its camera.
bool residuals_raw(const Eigen::Isometry3d& T_rig_body, const std::vector<Corner>& corners,
                   const std::vector<ViewGeom>& views, Eigen::VectorXd& r, Eigen::MatrixXd* J) {
  const auto n = static_cast<Eigen::Index>(corners.size());
  r.resize(2 * n);
  if (J) J->resize(2 * n, 6);
  for (Eigen::Index i = 0; i < n; ++i) {
    const ViewGeom& vg = views[static_cast<std::size_t>(corners[i].view)];
    const Pinhole& k = vg.k;
    const Eigen::Vector3d p_rig = T_rig_body * corners[i].p_body;
    const Eigen::Vector3d p = vg.identity ? p_rig : Eigen::Vector3d(vg.T_view_rig * p_rig);
    if (!(p.z() > 1e-4)) return false;  // 0.1 mm: behind or on the camera
    const double iz = 1.0 / p.z();
    r(2 * i) = k.fx * p.x() * iz + k.cx - corners[i].uv_px.x();
    r(2 * i + 1) = k.fy * p.y() * iz + k.cy - corners[i].uv_px.y();
    if (J) {
      Eigen::Matrix<double, 2, 3> du_dp;
      du_dp << k.fx * iz, 0, -k.fx * p.x() * iz * iz, 0, k.fy * iz, -k.fy * p.y() * iz * iz;
      if (!vg.identity) du_dp = du_dp * vg.T_view_rig.linear();
      // p_rig = exp(w) R p_body + t + v: dp_rig/d(w, v) at 0 = [-[R p_body]x, I].
      const Eigen::Vector3d q = p_rig - T_rig_body.translation();
      Eigen::Matrix3d skew;
      skew << 0, -q.z(), q.y(), q.z(), 0, -q.x(), -q.y(), q.x(), 0;
      J->block<2, 3>(2 * i, 0) = -du_dp * skew;
      J->block<2, 3>(2 * i, 3) = du_dp;
    }
  }
  return r.allFinite();
}

// BundlePoseOptions::shape_weight: each tag's 8 rows (its 4 corners, kept
// together in `corners`) become its centre part plus shape_weight x its
// shape part: rows_k <- c + s (rows_k - c), c = the mean of its 4 corners'.
void weight_shapes(double s, Eigen::VectorXd& r, Eigen::MatrixXd* J) {
  if (s == 1.0) return;
  for (Eigen::Index t = 0; t + 8 <= r.size(); t += 8) {
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    for (int k = 0; k < 4; ++k) c += r.segment<2>(t + 2 * k) / 4;
    for (int k = 0; k < 4; ++k) r.segment<2>(t + 2 * k) = c + s * (r.segment<2>(t + 2 * k) - c);
    if (J) {
      Eigen::MatrixXd cj = Eigen::MatrixXd::Zero(2, J->cols());
      for (int k = 0; k < 4; ++k) cj += J->middleRows(t + 2 * k, 2) / 4;
      for (int k = 0; k < 4; ++k) J->middleRows(t + 2 * k, 2) = cj + s * (J->middleRows(t + 2 * k, 2) - cj);
    }
  }
}

// Weights per residual: the prior weight pw (the view-angle weight of the
// corner's tag, 1 without) times the Huber weight of the corner (both
// residuals of a corner share one), and the weighted robust cost
// sum pw_i rho(|r_i|); k <= 0: Huber weights 1, cost = sum pw r^2.
double huber(const Eigen::VectorXd& r, double k, const Eigen::VectorXd& pw, Eigen::VectorXd& w) {
  w = pw;
  double cost = 0;
  for (Eigen::Index i = 0; i + 1 < r.size(); i += 2) {
    const double d = std::hypot(r(i), r(i + 1));
    if (k > 0 && d > k) {
      w(i) *= k / d;
      w(i + 1) *= k / d;
      cost += pw(i) * (2 * k * d - k * k);
    } else {
      cost += pw(i) * d * d;
    }
  }
  return cost;
}

double rms_of(const Eigen::VectorXd& r) {
  return r.size() == 0 ? 0.0 : std::sqrt(r.squaredNorm() / (static_cast<double>(r.size()) / 2));
}

// R <- exp(w) R, t <- t + v, matching the Jacobian above.
Eigen::Isometry3d apply_delta(const Vec6& d, const Eigen::Isometry3d& T) {
  Eigen::Isometry3d out = T;
  const Eigen::Vector3d w = d.head<3>();
  const double angle = w.norm();
  if (angle > 0) out.linear() = Eigen::AngleAxisd(angle, w / angle) * T.linear();
  out.translation() += d.tail<3>();
  return out;
}

double rotation_angle(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear() * b.linear().transpose()).angle();
}

Eigen::Isometry3d from_rvec_tvec(const cv::Mat& rvec, const cv::Mat& tvec) {
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) T.linear()(i, j) = R.at<double>(i, j);
    T.translation()(i) = tvec.at<double>(i);
  }
  return T;
}

BundlePose fail(BundlePoseStatus s, std::string message) {
  BundlePose p;
  p.status = s;
  p.message = std::move(message);
  return p;
}

}  // namespace

TagBundle mannequin_bundle(const StationScene& s) {
  return TagBundle{"mannequin", s.family, s.mannequin_tags};
}

TagBundle mirror_bundle(const StationScene& s) {
  return TagBundle{"mirror", s.family, s.mirror_tags};
}

std::string BundlePoseOptions::validate() const {
  if (max_hamming < 0) return "max_hamming = " + std::to_string(max_hamming) + " must be >= 0";
  if (!std::isfinite(min_decision_margin)) return "min_decision_margin must be finite";
  if (max_iterations < 0 || max_iterations > 1000)
    return "max_iterations = " + std::to_string(max_iterations) + " must be in 0..1000";
  if (!std::isfinite(ambiguity_ratio) || ambiguity_ratio < 1)
    return "ambiguity_ratio = " + std::to_string(ambiguity_ratio) + " must be >= 1";
  if (!std::isfinite(ambiguity_px) || ambiguity_px < 0)
    return "ambiguity_px = " + std::to_string(ambiguity_px) + " must be >= 0";
  if (!std::isfinite(robust_px) || robust_px < 0)
    return "robust_px = " + std::to_string(robust_px) + " must be >= 0 (0 = off)";
  if (!std::isfinite(view_weight_from_rad) || view_weight_from_rad < 0 || view_weight_from_rad >= 1.5)
    return "view_weight_from_rad = " + std::to_string(view_weight_from_rad) +
           " must be in [0, 1.5) (0 = off)";
  if (!std::isfinite(max_view_angle_rad) || max_view_angle_rad < 0 || max_view_angle_rad >= 1.57)
    return "max_view_angle_rad = " + std::to_string(max_view_angle_rad) + " must be in [0, 1.57) (0 = off)";
  if (min_tags_kept < 1) return "min_tags_kept = " + std::to_string(min_tags_kept) + " must be >= 1";
  if (!std::isfinite(outlier_px) || outlier_px < 0)
    return "outlier_px = " + std::to_string(outlier_px) + " must be finite and >= 0 (0 = off)";
  if (!std::isfinite(outlier_ratio) || outlier_ratio < 1)
    return "outlier_ratio = " + std::to_string(outlier_ratio) + " must be >= 1";
  if (!std::isfinite(shape_weight) || shape_weight <= 0 || shape_weight > 1)
    return "shape_weight = " + std::to_string(shape_weight) + " must be in (0, 1]";
  if (!std::isfinite(blur_stretch_sigma_px) || blur_stretch_sigma_px < 0)
    return "blur_stretch_sigma_px = " + std::to_string(blur_stretch_sigma_px) + " must be finite and >= 0 (0 = off)";
  if (!std::isfinite(tag_outline_sigma) || tag_outline_sigma < 0 || tag_outline_sigma > 100)
    return "tag_outline_sigma = " + std::to_string(tag_outline_sigma) + " must be in [0, 100] (0 = off)";
  return {};
}

const char* bundle_pose_status_name(BundlePoseStatus s) {
  switch (s) {
    case BundlePoseStatus::kOk:
      return "ok";
    case BundlePoseStatus::kNoDetections:
      return "no detections";
    case BundlePoseStatus::kNoBundleTags:
      return "no tags of the bundle";
    case BundlePoseStatus::kInvalidInput:
      return "invalid input";
    case BundlePoseStatus::kFailed:
      return "failed";
  }
  return "?";
}

BundlePose estimate_bundle_pose(const TagBundle& bundle,
                                const calibration::CameraIntrinsics& camera,
                                const std::vector<DetectedTag>& detections,
                                const BundlePoseOptions& options,
                                const std::optional<Eigen::Isometry3d>& T_cam_body_prev) {
  return estimate_bundle_pose_views(bundle, {BundleView{&camera, Eigen::Isometry3d::Identity(), &detections}},
                                    options, T_cam_body_prev);
}

BundlePose estimate_bundle_pose_views(const TagBundle& bundle, const std::vector<BundleView>& views,
                                      const BundlePoseOptions& options,
                                      const std::optional<Eigen::Isometry3d>& T_cam_body_prev) {
  const std::string who = "estimate_bundle_pose(" + bundle.name + "): ";
  if (auto e = options.validate(); !e.empty())
    return fail(BundlePoseStatus::kInvalidInput, who + "options: " + e);
  if (views.empty()) return fail(BundlePoseStatus::kInvalidInput, who + "no views");
  const bool multi = views.size() > 1;
  auto view_name = [&](std::size_t v) { return multi ? "views[" + std::to_string(v) + "]." : std::string(); };
  std::vector<ViewGeom> geoms;
  for (std::size_t v = 0; v < views.size(); ++v) {
    const BundleView& bv = views[v];
    if (bv.camera == nullptr || bv.detections == nullptr)
      return fail(BundlePoseStatus::kInvalidInput, who + "views[" + std::to_string(v) + "] has no camera or detections");
    if (auto e = bv.camera->validate(); !e.empty())
      return fail(BundlePoseStatus::kInvalidInput, who + view_name(v) + "camera: " + e);
    if (!bv.T_view_rig.matrix().allFinite())
      return fail(BundlePoseStatus::kInvalidInput, who + "views[" + std::to_string(v) + "].T_view_rig is not finite");
    ViewGeom g;
    g.k = Pinhole{bv.camera->fx, bv.camera->fy, bv.camera->cx, bv.camera->cy};
    g.T_view_rig = bv.T_view_rig;
    g.identity = bv.T_view_rig.matrix().isIdentity(0.0);
    geoms.push_back(g);
  }
  if (bundle.tags.empty())
    return fail(BundlePoseStatus::kInvalidInput, who + "the bundle has no tags");
  std::map<int, const TagPlacement*> layout;
  for (std::size_t i = 0; i < bundle.tags.size(); ++i) {
    const TagPlacement& t = bundle.tags[i];
    if (!std::isfinite(t.size_m) || t.size_m <= 0)
      return fail(BundlePoseStatus::kInvalidInput,
                  who + "tags[" + std::to_string(i) + "].size_m must be finite and > 0");
    if (!layout.emplace(t.id, &t).second)
      return fail(BundlePoseStatus::kInvalidInput, who + "tags[" + std::to_string(i) + "].id = " +
                                                       std::to_string(t.id) + " appears twice");
  }
  if (T_cam_body_prev && !T_cam_body_prev->matrix().allFinite())
    return fail(BundlePoseStatus::kInvalidInput, who + "T_cam_body_prev is not finite");
  std::size_t n_detections = 0;
  for (const BundleView& bv : views) n_detections += bv.detections->size();
  if (n_detections == 0) return fail(BundlePoseStatus::kNoDetections, who + "no detections");

  // One tag seen by one view: the unit of the fit (its 4 corners).
  struct Obs {
    const TagPlacement* t;
    int view;
  };
  std::vector<Corner> corners;
  std::vector<Obs> tags;
  for (std::size_t v = 0; v < views.size(); ++v) {
    // Keep one detection per layout id (the most confident if seen twice).
    std::map<int, const DetectedTag*> kept;
    for (const DetectedTag& d : *views[v].detections) {
      if (d.family != bundle.family || !layout.count(d.id) || d.hamming > options.max_hamming ||
          d.decision_margin < options.min_decision_margin)
        continue;
      bool finite = true;
      for (const auto& c : d.corners_px) finite = finite && c.allFinite();
      if (!finite) continue;
      auto [it, added] = kept.emplace(d.id, &d);
      if (!added && d.decision_margin > it->second->decision_margin) it->second = &d;
    }
    if (kept.empty()) continue;
    const calibration::CameraIntrinsics& camera = *views[v].camera;
    const cv::Matx33d K(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
    const std::vector<double> dist(camera.dist.begin(), camera.dist.end());
    // Undistort every kept corner into the ideal pinhole image with the same K.
    std::vector<cv::Point2d> distorted, undistorted;
    for (const auto& [id, d] : kept)
      for (const auto& c : d->corners_px) distorted.emplace_back(c.x(), c.y());
    try {
      cv::undistortPoints(distorted, undistorted, K, dist, cv::noArray(), K);
    } catch (const cv::Exception& e) {
      return fail(BundlePoseStatus::kFailed, who + view_name(v) + "cv::undistortPoints: " + e.what());
    }
    std::size_t u = 0;
    for (const auto& [id, d] : kept) {
      const TagPlacement* t = layout.at(id);
      for (int c = 0; c < 4; ++c, ++u)
        corners.push_back(Corner{t->corner(c), Eigen::Vector2d(undistorted[u].x, undistorted[u].y),
                                 static_cast<int>(v)});
      if (options.blur_stretch_sigma_px > 0 || options.tag_outline_sigma > 0)
        blur_jacobians(&corners[corners.size() - 4]);
      tags.push_back(Obs{t, static_cast<int>(v)});
    }
  }
  if (tags.empty())
    return fail(BundlePoseStatus::kNoBundleTags,
                who + std::to_string(n_detections) + " detection(s), none of the bundle's " +
                    tag_family_name(bundle.family) + " ids (or all below the thresholds)");
  auto T_view = [&](const Obs& o, const Eigen::Isometry3d& T_rig_body) {
    return Eigen::Isometry3d(geoms[static_cast<std::size_t>(o.view)].T_view_rig * T_rig_body * o.t->T_parent_tag);
  };

  // Seeds: both IPPE_SQUARE solutions of every tag in every view, as T_rig_body.
  std::vector<Eigen::Isometry3d> seeds;
  for (std::size_t ti = 0; ti < tags.size(); ++ti) {
    const double h = tags[ti].t->size_m / 2;
    const ViewGeom& g = geoms[static_cast<std::size_t>(tags[ti].view)];
    const cv::Matx33d K(g.k.fx, 0, g.k.cx, 0, g.k.fy, g.k.cy, 0, 0, 1);
    // IPPE_SQUARE's required object points: libapriltag's corner order.
    const std::vector<cv::Point3d> obj = {{-h, h, 0}, {h, h, 0}, {h, -h, 0}, {-h, -h, 0}};
    std::vector<cv::Point2d> img;
    for (int c = 0; c < 4; ++c) {
      const Eigen::Vector2d& u = corners[4 * ti + static_cast<std::size_t>(c)].uv_px;
      img.emplace_back(u.x(), u.y());
    }
    std::vector<cv::Mat> rvecs, tvecs;
    try {
      cv::solvePnPGeneric(obj, img, K, cv::noArray(), rvecs, tvecs, false,
                          cv::SOLVEPNP_IPPE_SQUARE);
    } catch (const cv::Exception&) {
      continue;  // degenerate quad (collinear corners): the other tags may still seed
    }
    for (std::size_t s = 0; s < rvecs.size(); ++s) {
      const Eigen::Isometry3d T_view_tag = from_rvec_tvec(rvecs[s], tvecs[s]);
      const Eigen::Isometry3d T_rig_body =
          (g.identity ? T_view_tag : Eigen::Isometry3d(g.T_view_rig.inverse() * T_view_tag)) *
          tags[ti].t->T_parent_tag.inverse();
      if (T_rig_body.matrix().allFinite()) seeds.push_back(T_rig_body);
    }
  }
  if (T_cam_body_prev) seeds.push_back(*T_cam_body_prev);

  // Score the seeds over all corners.
  std::vector<double> seed_rms(seeds.size(), std::numeric_limits<double>::infinity());
  Eigen::VectorXd r;
  double best_rms = std::numeric_limits<double>::infinity();
  for (std::size_t s = 0; s < seeds.size(); ++s) {
    if (residuals_raw(seeds[s], corners, geoms, r, nullptr)) seed_rms[s] = rms_of(r);
    best_rms = std::min(best_rms, seed_rms[s]);
  }
  if (!std::isfinite(best_rms))
    return fail(BundlePoseStatus::kFailed,
                who + "no seed pose puts the tags in front of the camera");
  std::size_t chosen = 0;
  double chosen_key = std::numeric_limits<double>::infinity();
  const double ambiguous_below = best_rms * options.ambiguity_ratio + options.ambiguity_px;
  for (std::size_t s = 0; s < seeds.size(); ++s) {
    double key = seed_rms[s];
    if (T_cam_body_prev) {
      // Planar ambiguity: equally good fits are told apart by continuity.
      if (!(seed_rms[s] <= ambiguous_below)) continue;
      key = rotation_angle(seeds[s], *T_cam_body_prev);
    }
    if (key < chosen_key) {
      chosen_key = key;
      chosen = s;
    }
  }

  // Levenberg-Marquardt on all corners. The parameters: the pose's 6, then
  // with the blur model each view's stretch S (3 each, in `blur`).
  Eigen::Isometry3d T = seeds[chosen];
  BundlePose out;
  out.seed_rms_px = seed_rms[chosen];
  const bool blur_on = options.blur_stretch_sigma_px > 0;
  const Eigen::Index np = blur_on ? 6 + 3 * static_cast<Eigen::Index>(views.size()) : 6;
  const double blur_prior = blur_on ? 1.0 / (options.blur_stretch_sigma_px * options.blur_stretch_sigma_px) : 0.0;
  Eigen::VectorXd blur = Eigen::VectorXd::Zero(np - 6);
  Eigen::MatrixXd J;
  Eigen::VectorXd w;
  // The fit's residuals: with the blur model each corner moved by its view's
  // stretch; with BundlePoseOptions::shape_weight, each tag's shape part weighted.
  auto residuals_s = [&](const Eigen::Isometry3d& T_rig_body, const Eigen::VectorXd& S,
                         const std::vector<Corner>& cs, const std::vector<ViewGeom>& vs, Eigen::VectorXd& rr,
                         Eigen::MatrixXd* JJ) {
    if (!residuals_raw(T_rig_body, cs, vs, rr, JJ)) return false;
    if (blur_on) {
      if (JJ) {
        JJ->conservativeResize(Eigen::NoChange, np);
        JJ->rightCols(np - 6).setZero();
      }
      for (std::size_t i = 0; i < cs.size(); ++i) {
        const Eigen::Index row = static_cast<Eigen::Index>(2 * i), col = 3 * cs[i].view;
        const Eigen::Matrix<double, 2, 3>& Bi = cs[i].blur;
        rr.segment<2>(row) += Bi * S.segment<3>(col);
        if (JJ) JJ->block<2, 3>(row, 6 + col) = Bi;
      }
    }
    weight_shapes(options.shape_weight, rr, JJ);
    return true;
  };
  auto residuals = [&](const Eigen::Isometry3d& T_rig_body, const std::vector<Corner>& cs,
                       const std::vector<ViewGeom>& vs, Eigen::VectorXd& rr, Eigen::MatrixXd* JJ) {
    return residuals_s(T_rig_body, blur, cs, vs, rr, JJ);
  };
  // Prior weight of each residual: 1, or its tag's view-angle weight
  // (BundlePoseOptions::view_weight_from_rad) at the pose T.
  Eigen::VectorXd pw = Eigen::VectorXd::Ones(static_cast<Eigen::Index>(2 * corners.size()));
  auto set_view_weights = [&](const Eigen::Isometry3d& T_cam_body) {
    const double c0 = std::cos(options.view_weight_from_rad);
    for (std::size_t ti = 0; ti < tags.size(); ++ti) {
      const Eigen::Isometry3d T_cam_tag = T_view(tags[ti], T_cam_body);
      // z of the tag points into it: cos(view angle) = z . (ray to its centre).
      const double c = std::max(T_cam_tag.linear().col(2).dot(T_cam_tag.translation().normalized()), 0.1);
      const double f = std::min(1.0, c / c0);
      pw.segment<8>(static_cast<Eigen::Index>(8 * ti)).setConstant(f * f);
    }
  };
  // The robust cost plus the stretch's prior.
  auto cost_of = [&](const Eigen::VectorXd& rr, const Eigen::VectorXd& S, Eigen::VectorXd& ww) {
    return huber(rr, options.robust_px, pw, ww) + blur_prior * S.squaredNorm();
  };
  const bool view_weighted = options.view_weight_from_rad > 0;
  if (view_weighted) set_view_weights(T);
  residuals(T, corners, geoms, r, &J);
  double cost = cost_of(r, blur, w);
  double lambda = 1e-3;
  // The normal equations' matrix: the corners' J^T W J plus the stretch's prior.
  auto normal_matrix = [&] {
    Eigen::MatrixXd H = J.transpose() * w.asDiagonal() * J;
    if (blur_on) H.diagonal().tail(np - 6).array() += blur_prior;
    return H;
  };
  auto levenberg_marquardt = [&] {
    for (int it = 0; it < options.max_iterations; ++it) {
      out.iterations += 1;
      // IRLS: the Huber weights of the current residuals.
      const Eigen::MatrixXd H = normal_matrix();
      Eigen::VectorXd g = J.transpose() * w.asDiagonal() * r;
      if (blur_on) g.tail(np - 6) += blur_prior * blur;
      Eigen::MatrixXd A = H;
      A.diagonal() += lambda * H.diagonal().cwiseMax(1e-12);
      const Eigen::VectorXd delta = A.ldlt().solve(-g);
      if (!delta.allFinite()) break;
      const Eigen::Isometry3d T_try = apply_delta(delta.head<6>(), T);
      const Eigen::VectorXd blur_try = blur + delta.tail(np - 6);
      Eigen::VectorXd r_try, w_try;
      Eigen::MatrixXd J_try;
      double cost_try = 0;
      if (residuals_s(T_try, blur_try, corners, geoms, r_try, &J_try) &&
          (cost_try = cost_of(r_try, blur_try, w_try)) < cost) {
        const double gain = cost - cost_try;
        T = T_try;
        blur = blur_try;
        r = std::move(r_try);
        J = std::move(J_try);
        w = std::move(w_try);
        cost = cost_try;
        lambda = std::max(lambda / 10, 1e-9);
        if (gain < 1e-12 * (1 + cost) || delta.norm() < 1e-12) break;
      } else {
        lambda *= 10;
        if (lambda > 1e8) break;  // no descent left: at the minimum
      }
    }
  };
  // Starts another pass from T (after the weights or the corners changed).
  auto restart = [&] {
    residuals(T, corners, geoms, r, &J);
    cost = cost_of(r, blur, w);
    lambda = 1e-3;
  };
  levenberg_marquardt();
  // With view weights: a second pass with the weights at the first pass's
  // optimum (the seed's angles can be off by a few degrees).
  if (view_weighted) {
    set_view_weights(T);
    restart();
    levenberg_marquardt();
  }
  // Refit on a subset of the tags (kept tags, their corners), unweighted
  // but for the view-angle weights.
  auto refit = [&](std::vector<Obs> kt, std::vector<Corner> kc) {
    tags = std::move(kt);
    corners = std::move(kc);
    pw = Eigen::VectorXd::Ones(static_cast<Eigen::Index>(2 * corners.size()));
    if (view_weighted) set_view_weights(T);
    restart();
    levenberg_marquardt();
  };
  // The tags (and their four corners each) for which keep(index) holds.
  auto subset = [&](auto keep) {
    std::pair<std::vector<Obs>, std::vector<Corner>> kept;
    for (std::size_t ti = 0; ti < tags.size(); ++ti) {
      if (!keep(ti)) continue;
      kept.first.push_back(tags[ti]);
      for (int c = 0; c < 4; ++c) kept.second.push_back(corners[4 * ti + static_cast<std::size_t>(c)]);
    }
    return kept;
  };
  // Tags seen more obliquely than max_view_angle_rad at the optimum leave
  // the fit, when at least min_tags_kept others remain.
  if (options.max_view_angle_rad > 0) {
    const double cmax = std::cos(options.max_view_angle_rad);
    auto [kt, kc] = subset([&](std::size_t ti) {
      const Eigen::Isometry3d T_cam_tag = T_view(tags[ti], T);
      return !(T_cam_tag.linear().col(2).dot(T_cam_tag.translation().normalized()) < cmax);
    });
    if (kt.size() < tags.size() && static_cast<int>(kt.size()) >= options.min_tags_kept)
      refit(std::move(kt), std::move(kc));
  }

  // Leave-one-out test of the worst-fitting tag (BundlePoseOptions::outlier_px).
  if (options.outlier_px > 0 && static_cast<int>(tags.size()) > options.min_tags_kept) {
    std::size_t worst = 0;
    double worst_ss = -1;
    for (std::size_t ti = 0; ti < tags.size(); ++ti) {
      const double ss = r.segment<8>(static_cast<Eigen::Index>(8 * ti)).squaredNorm();
      if (ss > worst_ss) {
        worst_ss = ss;
        worst = ti;
      }
    }
    // Keep the full fit's state to return to.
    const std::vector<Corner> all_c = corners;
    const std::vector<Obs> all_t = tags;
    const Eigen::VectorXd all_pw = pw, all_r = r, all_w = w;
    const Eigen::MatrixXd all_J = J;
    const Eigen::Isometry3d all_T = T;
    const Eigen::VectorXd all_blur = blur;
    const double all_cost = cost;
    auto [kt, kc] = subset([&](std::size_t ti) { return ti != worst; });
    refit(std::move(kt), std::move(kc));
    // The left-out tag's corners under the others' pose.
    std::vector<Corner> out_c(all_c.begin() + static_cast<std::ptrdiff_t>(4 * worst),
                              all_c.begin() + static_cast<std::ptrdiff_t>(4 * worst + 4));
    Eigen::VectorXd r_out;
    const bool in_front = residuals(T, out_c, geoms, r_out, nullptr);
    const double rms_out = in_front ? rms_of(r_out) : std::numeric_limits<double>::infinity();
    const double rms_in = rms_of(r);
    if (rms_out > options.outlier_px && rms_out > options.outlier_ratio * rms_in) {
      out.rejected_id = all_t[worst].t->id;
      out.rejected_rms_px = rms_out;
    } else {
      corners = all_c;
      tags = all_t;
      pw = all_pw;
      r = all_r;
      w = all_w;
      J = all_J;
      T = all_T;
      blur = all_blur;
      cost = all_cost;
    }
  }

  out.T_cam_body = T;
  out.rms_px = rms_of(r);
  out.tags_used = static_cast<int>(tags.size());
  std::vector<bool> view_used(views.size(), false);
  for (const Obs& o : tags) {
    out.tag_ids.push_back(o.t->id);
    view_used[static_cast<std::size_t>(o.view)] = true;
  }
  out.views_used = static_cast<int>(std::count(view_used.begin(), view_used.end(), true));
  std::sort(out.tag_ids.begin(), out.tag_ids.end());
  const Eigen::MatrixXd H = normal_matrix();
  Eigen::FullPivLU<Eigen::MatrixXd> lu(H);
  if (!lu.isInvertible())
    return fail(BundlePoseStatus::kFailed,
                who + "the fit is degenerate (singular normal equations)");
  // All parameters' covariance per px^2; the pose's is its top-left block
  // (the stretch marginalised out).
  const Eigen::MatrixXd C_all = lu.inverse();
  // Residual degrees of freedom: the rows less the parameters' effective
  // count, tr(J^T W J H^-1) (6 without the blur model; the stretch, held by
  // its prior, counts less than its 3 per view).
  const double dof = static_cast<double>(r.size()) -
                     (blur_on ? (J.transpose() * w.asDiagonal() * J * C_all).trace() : 6.0);
  if (dof <= 0)
    return fail(BundlePoseStatus::kFailed,
                who + "the fit is degenerate (singular normal equations)");
  for (Eigen::Index i = 0; i < w.size(); i += 2) out.downweighted += w(i) < pw(i) ? 1 : 0;
  // = sum r^2 without down-weighted corners; with view weights the noise of
  // a corner seen within view_weight_from_rad.
  const double wss = r.dot(w.asDiagonal() * r);
  out.covariance_per_px2 = C_all.topLeftCorner<6, 6>();
  out.noise_px2 = wss / dof;
  out.noise_dof = static_cast<int>(std::lround(dof));
  out.covariance = out.noise_px2 * out.covariance_per_px2;
  // BundlePoseOptions::tag_outline_sigma: what a common outline offset per tag observation
  // (sigma k x the corner noise, along u = d corners / d offset) adds to the estimate's
  // covariance: C (sum_t k^2 g_t g_t^T / pw_t) C, g_t = J_t^T W_t u_t (the sandwich's extra
  // part; the fit itself keeps each corner alone).
  if (options.tag_outline_sigma > 0) {
    const double k2 = options.tag_outline_sigma * options.tag_outline_sigma;
    Eigen::MatrixXd G = Eigen::MatrixXd::Zero(np, np);
    for (std::size_t t = 0; t < tags.size(); ++t) {
      const Eigen::Index r0 = static_cast<Eigen::Index>(8 * t);
      Eigen::Matrix<double, 8, 1> u;
      for (std::size_t c = 0; c < 4; ++c)
        u.segment<2>(static_cast<Eigen::Index>(2 * c)) = corners[4 * t + c].outline;
      const double pwt = std::max(pw(r0), 1e-12);
      const Eigen::VectorXd g = J.middleRows(r0, 8).transpose() * (w.segment<8>(r0).asDiagonal() * u);
      G += (k2 / pwt) * g * g.transpose();
    }
    out.outline_covariance_per_px2 = (C_all * G * C_all).topLeftCorner<6, 6>();
  }
  if (blur_on)
    for (std::size_t v = 0; v < views.size(); ++v) out.blur_stretch_px.push_back(blur.segment<3>(static_cast<Eigen::Index>(3 * v)));
  // Per-tag noise (sandwich): each tag's corners get their own noise
  // estimate, its residual sum over its residual degrees of freedom
  // (8 minus the tag's share of the 6 pose parameters, the trace of its
  // rows' hat matrix), floored below at 1e-4 of the mean (a tag that fits
  // exactly still has some noise).
  {
    const Eigen::MatrixXd& C = C_all;
    Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(np, np);
    const double mean = std::max(out.noise_px2, 1e-12);
    for (std::size_t t = 0; t < tags.size(); ++t) {
      const Eigen::Index r0 = static_cast<Eigen::Index>(8 * t);
      const Eigen::MatrixXd Jt = J.middleRows(r0, 8);
      const Eigen::Matrix<double, 8, 1> wt = w.segment<8>(r0);
      const Eigen::Matrix<double, 8, 1> rt = r.segment<8>(r0);
      const double lev = (Jt * C * Jt.transpose() * wt.asDiagonal()).trace();
      const double ss = rt.dot(wt.asDiagonal() * rt);
      const double s2 = std::max(ss / std::max(8.0 - lev, 0.5), 1e-4 * mean);
      meat += s2 * Jt.transpose() * wt.asDiagonal() * Jt;
      const Eigen::Isometry3d T_cam_tag = T_view(tags[t], out.T_cam_body);
      const double c = T_cam_tag.linear().col(2).dot(T_cam_tag.translation().normalized());
      out.tag_residuals.push_back({tags[t].t->id, ss, 8.0 - lev, std::acos(std::clamp(c, -1.0, 1.0)), tags[t].view});
    }
    out.covariance_per_tag = (C * meat * C).topLeftCorner<6, 6>();
  }
  if (!out.T_cam_body.matrix().allFinite() || !out.covariance_per_px2.allFinite())
    return fail(BundlePoseStatus::kFailed, who + "the refinement diverged");
  out.status = BundlePoseStatus::kOk;
  return out;
}

QuadBlurModel quad_blur_model(const std::array<Eigen::Vector2d, 4>& q) {
  QuadBlurModel out;
  for (auto& J : out.d_corner_d_S) J.setZero();
  for (auto& n : out.edge_normal) n.setZero();
  Eigen::Vector2d m = Eigen::Vector2d::Zero();
  for (int k = 0; k < 4; ++k) m += q[static_cast<std::size_t>(k)] / 4;
  std::array<Eigen::Vector2d, 4> n;  // n[e]: outward normal of the edge from corner e to e + 1
  for (std::size_t e = 0; e < 4; ++e) {
    const Eigen::Vector2d a = q[e], b = q[(e + 1) % 4];
    Eigen::Vector2d nn(b.y() - a.y(), a.x() - b.x());
    const double len = nn.norm();
    if (!(len > 1e-9)) {
      out.degenerate = true;
      return out;
    }
    nn /= len;
    if (nn.dot((a + b) / 2 - m) < 0) nn = -nn;
    n[e] = nn;
  }
  out.edge_normal = n;
  for (std::size_t k = 0; k < 4; ++k) {
    const Eigen::Vector2d& n1 = n[(k + 3) % 4];
    const Eigen::Vector2d& n2 = n[k];
    Eigen::Matrix2d N;
    N << n1.transpose(), n2.transpose();
    Eigen::Matrix<double, 2, 3> A;
    A << n1.x() * n1.x(), 2 * n1.x() * n1.y(), n1.y() * n1.y(), n2.x() * n2.x(), 2 * n2.x() * n2.y(),
        n2.y() * n2.y();
    if (std::abs(N.determinant()) >= 0.2) out.d_corner_d_S[k] = N.inverse() * A / 2;
  }
  return out;
}

}  // namespace dentar::ar
