// What a pose covariance says about a point of the body: the uncertainty of
// the mirror's centre (85 mm from its tags) or of the tooth, from the bundle
// PnP's covariance (bundle_pose.h: delta = (w rad, v m) in `cam`,
// R_true = exp(w) R, t_true = t + v).
//
// Used for gating: the tracker hides the mirror's reflection when its
// centre's position sigma exceeds TrackerOptions::mirror_max_sigma_m, rather
// than drawing a reflection millimetres off. Pure functions, thread-safe.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dentar/ar/bundle_pose.h"

namespace dentar::ar {

using PoseCovariance = Eigen::Matrix<double, 6, 6>;

// Covariance (m^2, in `cam`) of the point p_body of a body at T_cam_body:
// d(T p) = -[R p]x w + v.
Eigen::Matrix3d point_covariance(const PoseCovariance& cov, const Eigen::Isometry3d& T_cam_body,
                                 const Eigen::Vector3d& p_body);
// sqrt(trace(point_covariance)): the RMS 3-D position error to expect (m);
// infinity when the covariance is not finite.
double point_sigma_m(const PoseCovariance& cov, const Eigen::Isometry3d& T_cam_body,
                     const Eigen::Vector3d& p_body);

// The covariance used for gating: the residual estimate of the corner noise
// is itself noisy with few corners and near zero when four corners of one
// tag fit almost exactly, so the noise is taken as at least floor_px per
// axis: covariance_per_px2 * max(noise_px2, floor_px^2).
PoseCovariance floored_covariance(const BundlePose& p, double floor_px);

// The corner noise (px^2 per axis) of `body`'s fit pooled with another fit
// of the same frame (`other`, e.g. the mannequin's when `body` is the
// mirror): both residual sums over both residual degrees of freedom,
// (noise_b dof_b + noise_o dof_o) / (dof_b + dof_o). The same camera,
// detector, blur and sensor noise make both bodies' corners equally noisy;
// the mirror's 2 tags alone give 10 dof, so its own estimate scatters by
// +-45 % and its per-tag outline errors (which its pose barely follows)
// inflate it by ~25 % on footage (docs/BENCHMARKS.md, issue 16). `other`
// not ok (or nullptr): body's own noise_px2.
// comparable_only: pool only those of other's tags seen no more obliquely
// than body's most oblique tag (BundlePose::tag_residuals: their residual
// sums and degrees of freedom). Grazing tags are noisier than frontal ones;
// the mannequin's 20-tag head layout sees several at 55-70 deg where the
// mirror's tags are seen at 20-50, and pooling them all over-stated the
// mirror centre's sigma by 26 % on `mirror` (docs/BENCHMARKS.md, issue 16
// head layout). No comparable tag: body's own noise_px2.
double pooled_noise_px2(const BundlePose& body, const BundlePose* other, bool comparable_only = false);
// covariance_per_px2 of `body` times max(noise_px2, floor_px^2).
PoseCovariance covariance_with_noise(const BundlePose& body, double noise_px2, double floor_px);

}  // namespace dentar::ar
