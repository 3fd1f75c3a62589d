// Honest uncertainty (issue 16, part 5): the bundle PnP's covariance and the
// position sigma derived from it, checked against Monte-Carlo scatter the
// way mrcal checks its own: predicted and observed spread within 20 %, for
// the mannequin (every pose component, and the tooth) and for the mirror's
// centre, 85 mm from its one visible 12 mm tag.
#include "dentar/ar/pose_uncertainty.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/calib3d.hpp>
#include <random>
#include <vector>

#include "dentar/ar/bundle_pose.h"

namespace dentar::ar {
namespace {

using Iso = Eigen::Isometry3d;
using Mat6 = Eigen::Matrix<double, 6, 6>;

// The bundle's corners projected with distortion plus Gaussian noise, for
// the tags that face the camera and lie in the image.
std::vector<DetectedTag> noisy_corners(const TagBundle& b, const calibration::CameraIntrinsics& c,
                                       const Iso& T_cam_body, double noise_px, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, noise_px);
  const cv::Matx33d K(c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
  const std::vector<double> dist(c.dist.begin(), c.dist.end());
  std::vector<DetectedTag> out;
  for (const TagPlacement& t : b.tags) {
    const Iso T_cam_tag = T_cam_body * t.T_parent_tag;
    if (T_cam_tag.linear().col(2).dot(-T_cam_tag.translation()) >= 0) continue;  // faces away
    std::vector<cv::Point3d> obj;
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector3d p = T_cam_body * t.corner(k);
      obj.emplace_back(p.x(), p.y(), p.z());
    }
    std::vector<cv::Point2d> img;
    cv::projectPoints(obj, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, dist, img);
    DetectedTag d;
    d.family = b.family;
    d.id = t.id;
    d.decision_margin = 100;
    bool inside = true;
    for (int k = 0; k < 4; ++k) {
      d.corners_px[k] = Eigen::Vector2d(img[k].x + n(rng), img[k].y + n(rng));
      inside = inside && img[k].x > 0 && img[k].y > 0 && img[k].x < c.width - 1 && img[k].y < c.height - 1;
    }
    if (inside) out.push_back(d);
  }
  return out;
}

Iso camera_looking_at_mouth(double d, double az, double el) {
  const Eigen::Vector3d target(0, 0.01, 0);
  const Eigen::Vector3d eye =
      target + d * Eigen::Vector3d(std::sin(az) * std::cos(el), std::sin(el), std::cos(az) * std::cos(el));
  const Eigen::Vector3d z = (target - eye).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitY()).normalized();
  Iso T_man_cam = Iso::Identity();
  T_man_cam.linear() << x, z.cross(x), z;
  T_man_cam.translation() = eye;
  return T_man_cam.inverse();
}

// delta of an estimate against the truth, bundle_pose.h's convention.
Eigen::Matrix<double, 6, 1> delta(const Iso& truth, const Iso& est) {
  Eigen::Matrix<double, 6, 1> d;
  const Eigen::AngleAxisd aa(truth.linear() * est.linear().transpose());
  d.head<3>() = aa.angle() * aa.axis();
  d.tail<3>() = truth.translation() - est.translation();
  return d;
}

TEST(PoseUncertainty, PointCovarianceMatchesSampledPoses) {
  // A pose covariance with rotation/translation correlation; points far
  // from the origin gain lever-arm error.
  Mat6 A = Mat6::Random() * 1e-3;
  const Mat6 cov = A * A.transpose() + Mat6::Identity() * 1e-8;
  Iso T = Iso::Identity();
  T.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.01, -0.02, 0.35);
  const Eigen::Vector3d p(0.085, 0.0, -0.004);
  const Eigen::LLT<Mat6> llt(cov);
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0, 1);
  Eigen::Matrix3d emp = Eigen::Matrix3d::Zero();
  const int N = 20000;
  for (int i = 0; i < N; ++i) {
    Eigen::Matrix<double, 6, 1> z;
    for (int k = 0; k < 6; ++k) z(k) = n(rng);
    const Eigen::Matrix<double, 6, 1> d = llt.matrixL() * z;
    Iso Tt = T;
    const double a = d.head<3>().norm();
    if (a > 0) Tt.linear() = Eigen::AngleAxisd(a, d.head<3>() / a) * T.linear();
    Tt.translation() += d.tail<3>();
    const Eigen::Vector3d e = Tt * p - T * p;
    emp += e * e.transpose() / N;
  }
  const Eigen::Matrix3d pred = point_covariance(cov, T, p);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(std::sqrt(pred(k, k) / emp(k, k)), 1.0, 0.03) << k;
  EXPECT_NEAR(point_sigma_m(cov, T, p), std::sqrt(emp.trace()), 0.02 * std::sqrt(emp.trace()));
  // At the body origin it is the translation block.
  EXPECT_NEAR(point_sigma_m(cov, T, Eigen::Vector3d::Zero()),
              std::sqrt(cov.bottomRightCorner<3, 3>().trace()), 1e-15);
  Mat6 bad = cov;
  bad(0, 0) = NAN;
  EXPECT_TRUE(std::isinf(point_sigma_m(bad, T, p)));
}

// Monte Carlo: N noisy corner sets at one pose. Predicted = the mean of the
// reported variances; observed = the scatter of the estimates.
struct McResult {
  Mat6 reported = Mat6::Zero(), observed = Mat6::Zero();
  double point_reported2 = 0, point_observed2 = 0;
  double floored_point2 = 0;
};
McResult monte_carlo(const TagBundle& b, const calibration::CameraIntrinsics& cam, const Iso& T_true,
                     const Eigen::Vector3d& point, double noise_px, double floor_px, int n, int seed) {
  McResult r;
  std::mt19937 rng(seed);
  for (int i = 0; i < n; ++i) {
    const auto dets = noisy_corners(b, cam, T_true, noise_px, rng);
    const BundlePose p = estimate_bundle_pose(b, cam, dets, {}, T_true);
    EXPECT_TRUE(p.ok()) << p.message;
    if (!p.ok()) return r;
    const auto d = delta(T_true, p.T_cam_body);
    r.observed += d * d.transpose() / n;
    r.reported += p.covariance / n;
    const Eigen::Vector3d e = T_true * point - p.T_cam_body * point;
    r.point_observed2 += e.squaredNorm() / n;
    r.point_reported2 += point_covariance(p.covariance, p.T_cam_body, point).trace() / n;
    const double s = point_sigma_m(floored_covariance(p, floor_px), p.T_cam_body, point);
    r.floored_point2 += s * s / n;
  }
  return r;
}

TEST(PoseUncertainty, MannequinCovarianceWithin20PercentOfMonteCarlo) {
  const StationScene s = default_station_scene();
  const TagBundle b = mannequin_bundle(s);
  const Iso T = camera_looking_at_mouth(0.36, -0.45, 0.45);
  const Eigen::Vector3d tooth = s.calibration.T_man_tooth.translation();
  const McResult r = monte_carlo(b, s.calibration.camera, T, tooth, 0.3, 0.0, 1000, 11);
  for (int k = 0; k < 6; ++k) {
    const double ratio = std::sqrt(r.reported(k, k) / r.observed(k, k));
    std::printf("[ uncertainty ] mannequin component %d: predicted / observed sigma = %.3f\n", k, ratio);
    EXPECT_GT(ratio, 0.8) << k;
    EXPECT_LT(ratio, 1.2) << k;
  }
  const double ratio = std::sqrt(r.point_reported2 / r.point_observed2);
  std::printf("[ uncertainty ] tooth position sigma: predicted %.4f mm, observed %.4f mm\n",
              std::sqrt(r.point_reported2) * 1e3, std::sqrt(r.point_observed2) * 1e3);
  EXPECT_GT(ratio, 0.8);
  EXPECT_LT(ratio, 1.2);
}

// Tags of unequal noise (odd ids 0.6 px, even ids 0.1 px, as small grazing
// and large frontal tags differ on the footage): the per-tag covariance
// (BundlePose::covariance_per_tag) predicts the tooth's scatter within 20 %;
// the shared-noise covariance spreads the noisy tags' noise over all.
TEST(PoseUncertainty, PerTagCovarianceWithUnequalTagNoise) {
  const StationScene s = default_station_scene();
  const TagBundle b = mannequin_bundle(s);
  const Eigen::Vector3d tooth = s.calibration.T_man_tooth.translation();
  for (const Iso& T : {camera_looking_at_mouth(0.36, -0.45, 0.45), camera_looking_at_mouth(0.33, 0.3, 0.2)}) {
    std::mt19937 rng(21);
    std::normal_distribution<double> n(0.0, 1.0);
    const int N = 800;
    double obs2 = 0, shared2 = 0, per_tag2 = 0;
    for (int i = 0; i < N; ++i) {
      auto dets = noisy_corners(b, s.calibration.camera, T, 0.0, rng);
      for (DetectedTag& d : dets)
        for (auto& c : d.corners_px) c += (d.id % 2 ? 0.6 : 0.1) * Eigen::Vector2d(n(rng), n(rng));
      const BundlePose p = estimate_bundle_pose(b, s.calibration.camera, dets, {}, T);
      ASSERT_TRUE(p.ok()) << p.message;
      obs2 += (T * tooth - p.T_cam_body * tooth).squaredNorm() / N;
      shared2 += point_covariance(p.covariance, p.T_cam_body, tooth).trace() / N;
      per_tag2 += point_covariance(p.covariance_per_tag, p.T_cam_body, tooth).trace() / N;
    }
    const double obs = std::sqrt(obs2), shared = std::sqrt(shared2), per_tag = std::sqrt(per_tag2);
    std::printf("[ uncertainty ] unequal tag noise, tooth sigma: observed %.4f mm, shared noise %.4f mm (x%.2f), "
                "per-tag noise %.4f mm (x%.2f)\n",
                obs * 1e3, shared * 1e3, shared / obs, per_tag * 1e3, per_tag / obs);
    EXPECT_GT(per_tag / obs, 0.8);
    EXPECT_LT(per_tag / obs, 1.2);
  }
  // With equal noise both agree (the per-tag estimate is then the same
  // noise estimated per tag).
  std::mt19937 rng(5);
  const Iso T = camera_looking_at_mouth(0.36, -0.45, 0.45);
  double shared2 = 0, per_tag2 = 0, obs2 = 0;
  for (int i = 0; i < 400; ++i) {
    const BundlePose p = estimate_bundle_pose(b, s.calibration.camera, noisy_corners(b, s.calibration.camera, T, 0.3, rng), {}, T);
    ASSERT_TRUE(p.ok());
    obs2 += (T * tooth - p.T_cam_body * tooth).squaredNorm() / 400;
    shared2 += point_covariance(p.covariance, p.T_cam_body, tooth).trace() / 400;
    per_tag2 += point_covariance(p.covariance_per_tag, p.T_cam_body, tooth).trace() / 400;
  }
  EXPECT_NEAR(std::sqrt(per_tag2 / obs2), 1.0, 0.2);
  EXPECT_NEAR(std::sqrt(per_tag2 / shared2), 1.0, 0.15);
}

// Why the covariance over-states the error on footage by 1.5-2x while the
// Monte Carlo above agrees, two hypotheses measured (docs/BENCHMARKS.md):
// (1) libapriltag's corners are intersections of four fitted edge lines, so
// their errors are not independent: noise as a random offset of each edge
// line (0.2 px) moves the two corners of an edge together;
// (2) the generator's corner bias: every tag's outline 0.09 px too small
// (systematic) plus 0.12 px of independent noise. In a bundle each tag's
// shrink is a depth change the rigid body cannot follow: it goes mostly into
// the residual, which inflates the noise estimate, not into the pose.
TEST(PoseUncertainty, WhyTheCovarianceIsPessimisticOnFootage) {
  const StationScene s = default_station_scene();
  const TagBundle b = mannequin_bundle(s);
  const Eigen::Vector3d tooth = s.calibration.T_man_tooth.translation();
  double ratios[2] = {0, 0};
  for (int model : {0, 1}) {
    const Iso T = camera_looking_at_mouth(0.36, -0.45, 0.45);
    std::mt19937 rng(31);
    std::normal_distribution<double> n(0.0, 1.0);
    const int N = 600;
    double obs2 = 0, pred2 = 0;
    for (int i = 0; i < N; ++i) {
      auto dets = noisy_corners(b, s.calibration.camera, T, 0.0, rng);
      for (DetectedTag& d : dets) {
        const auto c = d.corners_px;
        Eigen::Vector2d mid = Eigen::Vector2d::Zero();
        for (const auto& p : c) mid += p / 4;
        if (model == 1) {
          for (auto& p : d.corners_px)
            p += -0.09 * (p - mid).normalized() + 0.12 * Eigen::Vector2d(n(rng), n(rng));
          continue;
        }
        std::array<double, 4> off;
        std::array<Eigen::Vector2d, 4> nrm;
        for (int e = 0; e < 4; ++e) {  // edge e runs from corner e to corner e+1
          const Eigen::Vector2d dir = (c[(e + 1) % 4] - c[e]).normalized();
          nrm[e] = Eigen::Vector2d(dir.y(), -dir.x());
          if (nrm[e].dot(0.5 * (c[e] + c[(e + 1) % 4]) - mid) < 0) nrm[e] = -nrm[e];
          off[e] = 0.2 * n(rng);
        }
        for (int k = 0; k < 4; ++k) {  // corner k lies on edges k-1 and k
          const int a = (k + 3) % 4;
          Eigen::Matrix2d A;
          A.row(0) = nrm[a].transpose();
          A.row(1) = nrm[k].transpose();
          d.corners_px[k] += A.inverse() * Eigen::Vector2d(off[a], off[k]);
        }
      }
      const BundlePose p = estimate_bundle_pose(b, s.calibration.camera, dets, {}, T);
      ASSERT_TRUE(p.ok()) << p.message;
      obs2 += (T * tooth - p.T_cam_body * tooth).squaredNorm() / N;
      pred2 += point_covariance(p.covariance, p.T_cam_body, tooth).trace() / N;
    }
    ratios[model] = std::sqrt(pred2 / obs2);
    std::printf("[ uncertainty ] %s: tooth sigma predicted %.4f mm, observed %.4f mm (x%.2f)\n",
                model == 0 ? "edge-line noise 0.2 px" : "outline bias -0.09 px + 0.12 px noise",
                std::sqrt(pred2) * 1e3, std::sqrt(obs2) * 1e3, ratios[model]);
  }
  // Measured: neither reproduces generator v1 footage's 1.5-2x (x1.07 and
  // x0.94): the covariance stays honest under both, so neither is the
  // reason. On generator v2 footage with sRGB decoding the gap is gone
  // (ar_covariance_footage_gl_test: 0.85-1.04 at the mannequin's origin).
  for (double r : ratios) {
    EXPECT_GT(r, 0.8);
    EXPECT_LT(r, 1.2);
  }
}

TEST(PoseUncertainty, MirrorCentreSigmaWithin20PercentOfMonteCarlo) {
  const StationScene s = default_station_scene();
  const TagBundle b = mirror_bundle(s);
  // The front tag 35 cm away, turned 35 deg: 20-25 px at 640x480, the
  // mirror's centre 85 mm along the handle.
  Iso T = Iso::Identity();
  T.linear() = (Eigen::AngleAxisd(0.6, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.03, 0.02, 0.35);
  const Eigen::Vector3d centre = s.calibration.T_mtag_mir.translation();
  const McResult r = monte_carlo(b, s.calibration.camera, T, centre, 0.3, 0.3, 1000, 12);
  const double pred = std::sqrt(r.point_reported2), obs = std::sqrt(r.point_observed2),
               floored = std::sqrt(r.floored_point2);
  std::printf("[ uncertainty ] mirror centre sigma: predicted %.3f mm (floored at the true noise %.3f mm), "
              "observed %.3f mm\n",
              pred * 1e3, floored * 1e3, obs * 1e3);
  EXPECT_GT(pred / obs, 0.8);
  EXPECT_LT(pred / obs, 1.2);
  // Flooring at the true noise never under-states it.
  EXPECT_GT(floored / obs, 0.9);
  EXPECT_LT(floored / obs, 1.4);
  // With one 12 mm tag the mirror's centre is millimetres uncertain at this
  // noise: the gate (1 mm) has something to hide.
  EXPECT_GT(obs, 1e-3);
}

// The mirror's sigma with its corner noise pooled with the mannequin's of
// the same frame (pooled_noise_px2, what the tracker gates on): the same
// 0.3 px noise on both bodies' corners; the pooled sigma of the mirror
// centre must match the scatter within 20 % and scatter less from trial to
// trial than the mirror's own 10-dof estimate.
TEST(PoseUncertainty, PooledNoiseMirrorSigmaWithin20PercentOfMonteCarlo) {
  const StationScene s = default_station_scene();
  const TagBundle mir = mirror_bundle(s), man = mannequin_bundle(s);
  Iso T_mir = Iso::Identity();
  T_mir.linear() = (Eigen::AngleAxisd(0.6, Eigen::Vector3d::UnitY()) *
                    Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()))
                       .toRotationMatrix();
  T_mir.translation() = Eigen::Vector3d(0.03, 0.02, 0.35);
  const Iso T_man = camera_looking_at_mouth(0.36, -0.45, 0.45);
  const Eigen::Vector3d centre = s.calibration.T_mtag_mir.translation();
  std::mt19937 rng(41);
  const int N = 800;
  double obs2 = 0, own2 = 0, pooled2 = 0;
  std::vector<double> own, pooled;
  for (int i = 0; i < N; ++i) {
    const BundlePose pm = estimate_bundle_pose(mir, s.calibration.camera,
                                               noisy_corners(mir, s.calibration.camera, T_mir, 0.3, rng), {}, T_mir);
    const BundlePose pa = estimate_bundle_pose(man, s.calibration.camera,
                                               noisy_corners(man, s.calibration.camera, T_man, 0.3, rng), {}, T_man);
    ASSERT_TRUE(pm.ok() && pa.ok()) << pm.message << pa.message;
    ASSERT_GT(pa.noise_dof, 4 * pm.noise_dof);  // the mannequin's many tags
    obs2 += (T_mir * centre - pm.T_cam_body * centre).squaredNorm() / N;
    const double so = point_sigma_m(pm.covariance, pm.T_cam_body, centre);
    const double sp =
        point_sigma_m(covariance_with_noise(pm, pooled_noise_px2(pm, &pa), 0.0), pm.T_cam_body, centre);
    own2 += so * so / N;
    pooled2 += sp * sp / N;
    own.push_back(so);
    pooled.push_back(sp);
  }
  auto spread = [](const std::vector<double>& v) {
    double m = 0, q = 0;
    for (double x : v) m += x / v.size();
    for (double x : v) q += (x - m) * (x - m) / v.size();
    return std::sqrt(q) / m;
  };
  const double obs = std::sqrt(obs2);
  std::printf("[ uncertainty ] mirror centre, pooled noise: predicted %.3f mm (own noise %.3f mm), observed %.3f mm; "
              "trial-to-trial spread of sigma: pooled %.2f, own %.2f\n",
              std::sqrt(pooled2) * 1e3, std::sqrt(own2) * 1e3, obs * 1e3, spread(pooled), spread(own));
  EXPECT_GT(std::sqrt(pooled2) / obs, 0.8);
  EXPECT_LT(std::sqrt(pooled2) / obs, 1.2);
  EXPECT_LT(spread(pooled), 0.5 * spread(own));
  // No reference (or a failed one): the body's own estimate.
  const BundlePose failed;
  const BundlePose pm = estimate_bundle_pose(mir, s.calibration.camera,
                                             noisy_corners(mir, s.calibration.camera, T_mir, 0.3, rng), {}, T_mir);
  EXPECT_EQ(pooled_noise_px2(pm, nullptr), pm.noise_px2);
  EXPECT_EQ(pooled_noise_px2(pm, &failed), pm.noise_px2);
}

// Pooling only comparable tags (TrackerOptions::pool_comparable_tags): the
// other body's tags seen more obliquely than the body's own most oblique tag
// stay out of the pool.
TEST(PoseUncertainty, PooledNoiseWithComparableTagsOnly) {
  BundlePose body, other;
  body.status = other.status = BundlePoseStatus::kOk;
  body.noise_dof = 10;
  body.noise_px2 = 0.4 / 10;
  body.tag_residuals = {{20, 0.2, 5, 0.5}, {22, 0.2, 5, 0.7}};
  other.noise_dof = 15;
  other.noise_px2 = 1.1 / 15;
  other.tag_residuals = {{0, 0.05, 5, 0.3}, {1, 0.05, 5, 0.7}, {2, 1.0, 5, 1.1}};
  EXPECT_NEAR(pooled_noise_px2(body, &other), (0.4 + 1.1) / 25, 1e-12);
  EXPECT_NEAR(pooled_noise_px2(body, &other, true), (0.4 + 0.1) / 20, 1e-12);
  other.tag_residuals = {{2, 1.1, 15, 1.1}};  // none comparable: the body's own
  EXPECT_NEAR(pooled_noise_px2(body, &other, true), body.noise_px2, 1e-12);
  EXPECT_NEAR(pooled_noise_px2(body, nullptr, true), body.noise_px2, 1e-12);
}

TEST(PoseUncertainty, FlooredCovarianceOfAnExactFitIsTheFloor) {
  const StationScene s = default_station_scene();
  const TagBundle b = mirror_bundle(s);
  Iso T = Iso::Identity();
  T.translation() = Eigen::Vector3d(0, 0, 0.3);
  std::mt19937 rng(1);
  const auto dets = noisy_corners(b, s.calibration.camera, T, 0.0, rng);
  const BundlePose p = estimate_bundle_pose(b, s.calibration.camera, dets);
  ASSERT_TRUE(p.ok()) << p.message;
  EXPECT_LT(p.noise_px2, 1e-12);
  // The raw covariance says "exact"; floored, it says 0.25 px of noise.
  const Eigen::Vector3d c = s.calibration.T_mtag_mir.translation();
  EXPECT_LT(point_sigma_m(p.covariance, p.T_cam_body, c), 1e-7);
  const double f = point_sigma_m(floored_covariance(p, 0.25), p.T_cam_body, c);
  const double f2 = point_sigma_m(floored_covariance(p, 0.5), p.T_cam_body, c);
  EXPECT_GT(f, 1e-4);
  EXPECT_NEAR(f2 / f, 2.0, 1e-9);
}

// Which tag layout on the mirror's handle constrains its centre best: the
// predicted sigma of the mirror centre (0.25 px of corner noise) over 40
// random views of the paddle (28-42 cm, turned up to 40 deg), for the
// current paddle and the candidates of issue 16. Design figures, recorded in
// docs/BENCHMARKS.md; the test asserts only what the geometry must give.
TEST(PoseUncertainty, MirrorLayoutStudy) {
  const StationScene s = default_station_scene();
  const Eigen::Vector3d centre = s.calibration.T_mtag_mir.translation();
  auto tag = [](int id, double size, const Eigen::Vector3d& at, const Eigen::Matrix3d& R) {
    TagPlacement t;
    t.id = id;
    t.size_m = size;
    t.T_parent_tag.linear() = R;
    t.T_parent_tag.translation() = at;
    return t;
  };
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  struct Layout {
    const char* name;
    std::vector<TagPlacement> tags;
  };
  StationScene roof = s;
  set_mirror_paddle(roof, MirrorPaddle::kRoof);
  std::vector<TagPlacement> roof_front;  // the roof's two faces, without the back tag
  for (const TagPlacement& t : roof.mirror_tags)
    if (t.T_parent_tag.linear().col(2).z() > 0) roof_front.push_back(t);
  std::vector<Layout> layouts = {
      {"flat paddle: one 12 mm tag (30 mm paddle)", {tag(20, 0.012, {0, 0, 0}, I)}},
      {"one 20 mm tag (40 mm paddle)", {tag(20, 0.020, {0, 0, 0}, I)}},
      {"two 12 mm tags, roof at +-35 deg across the handle",
       {tag(20, 0.012, {0, -0.009, 0.003}, Eigen::AngleAxisd(0.61, Eigen::Vector3d::UnitX()).toRotationMatrix()),
        tag(22, 0.012, {0, 0.009, 0.003}, Eigen::AngleAxisd(-0.61, Eigen::Vector3d::UnitX()).toRotationMatrix())}},
      {"two 12 mm tags 40 mm apart along the handle (60 mm paddle)",
       {tag(20, 0.012, {-0.02, 0, 0}, I), tag(22, 0.012, {0.02, 0, 0}, I)}},
      {"three 12 mm tags, 20 mm apart, toward the head (70 mm paddle)",
       {tag(20, 0.012, {-0.04, 0, 0}, I), tag(22, 0.012, {-0.02, 0, 0}, I), tag(23, 0.012, {0, 0, 0}, I)}},
      {"station default since issue 16: roof paddle 35 deg, tags at y = +-10 mm", roof_front},
  };
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Iso> views;
  for (int i = 0; i < 40; ++i) {
    Iso T = Iso::Identity();
    T.linear() = (Eigen::AngleAxisd(0.7 * u(rng), Eigen::Vector3d::UnitY()) *
                  Eigen::AngleAxisd(0.7 * u(rng), Eigen::Vector3d::UnitX()) *
                  Eigen::AngleAxisd(M_PI * u(rng), Eigen::Vector3d::UnitZ()))
                     .toRotationMatrix();
    T.translation() = Eigen::Vector3d(0.03 * u(rng), 0.03 * u(rng), 0.35 + 0.07 * u(rng));
    views.push_back(T);
  }
  std::vector<double> medians;
  std::printf("[ uncertainty ] mirror centre sigma at 0.25 px corner noise, 640x480, 40 views:\n");
  for (const Layout& l : layouts) {
    TagBundle b{"mirror", s.family, l.tags};
    std::vector<double> sig;
    for (const Iso& T : views) {
      std::mt19937 r0(0);
      const auto dets = noisy_corners(b, s.calibration.camera, T, 0.0, r0);
      if (dets.empty()) continue;
      const BundlePose p = estimate_bundle_pose(b, s.calibration.camera, dets, {}, T);
      if (!p.ok()) continue;
      sig.push_back(point_sigma_m(floored_covariance(p, 0.25), p.T_cam_body, centre) * 1e3);
    }
    std::sort(sig.begin(), sig.end());
    const double med = sig.empty() ? 1e9 : sig[sig.size() / 2];
    const double p90 = sig.empty() ? 1e9 : sig[sig.size() * 9 / 10];
    std::printf("[ uncertainty ]   %-62s views %2zu  median %.2f mm  p90 %.2f mm\n", l.name, sig.size(), med, p90);
    medians.push_back(med);
  }
  // A bigger tag and a longer baseline along the handle both beat the
  // current single 12 mm tag.
  EXPECT_LT(medians[1], medians[0]);
  EXPECT_LT(medians[3], 0.7 * medians[0]);
  // The roof built into the station halves the flat paddle's sigma.
  ASSERT_EQ(roof_front.size(), 2u);
  EXPECT_LT(medians[5], 0.5 * medians[0]);
}

}  // namespace
}  // namespace dentar::ar
