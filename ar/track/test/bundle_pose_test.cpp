// Bundle PnP on synthetic corners: accuracy against a known pose, the planar
// ambiguity of a single small tag resolved by the previous pose, the
// covariance against Monte-Carlo scatter, and bad inputs.
#include "dentar/ar/bundle_pose.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <opencv2/calib3d.hpp>
#include <random>
#include <vector>

#include "dentar/ar/pose_uncertainty.h"
#include "dentar/ar/tag_detector.h"

namespace dentar::ar {
namespace {

double rot_err_rad(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear() * b.linear().transpose()).angle();
}

double trans_err_m(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm();
}

// Camera looking at the mouth from `distance_m`, from azimuth/elevation.
Eigen::Isometry3d look_at_man(double distance_m, double az_rad, double el_rad) {
  const Eigen::Vector3d target(0, 0.01, 0);
  const Eigen::Vector3d eye =
      target + distance_m * Eigen::Vector3d(std::sin(az_rad) * std::cos(el_rad), std::sin(el_rad),
                                            std::cos(az_rad) * std::cos(el_rad));
  const Eigen::Vector3d z = (target - eye).normalized();                     // forward
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitY()).normalized();  // right (y up)
  const Eigen::Vector3d y = z.cross(x);                                      // down
  Eigen::Isometry3d T_man_cam = Eigen::Isometry3d::Identity();
  T_man_cam.linear().col(0) = x;
  T_man_cam.linear().col(1) = y;
  T_man_cam.linear().col(2) = z;
  T_man_cam.translation() = eye;
  return T_man_cam.inverse();
}

// Projects the bundle's tag corners with cv::projectPoints (distortion
// included), adds Gaussian noise, and returns detections of the tags that
// face the camera and lie in the image.
std::vector<DetectedTag> synth_detections(const TagBundle& b,
                                          const calibration::CameraIntrinsics& c,
                                          const Eigen::Isometry3d& T_cam_body, double noise_px,
                                          std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, noise_px);
  const cv::Matx33d K(c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
  const std::vector<double> dist(c.dist.begin(), c.dist.end());
  cv::Mat R(3, 3, CV_64F), rvec, tvec(3, 1, CV_64F);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) R.at<double>(i, j) = T_cam_body.linear()(i, j);
    tvec.at<double>(i) = T_cam_body.translation()(i);
  }
  cv::Rodrigues(R, rvec);
  std::vector<DetectedTag> out;
  for (const TagPlacement& t : b.tags) {
    const Eigen::Isometry3d T_cam_tag = T_cam_body * t.T_parent_tag;
    // Tag z points into the tag: it faces the camera when z_tag . (tag->cam) < 0.
    if (T_cam_tag.linear().col(2).dot(-T_cam_tag.translation()) >= 0) continue;
    std::vector<cv::Point3d> obj;
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector3d p = t.corner(k);
      obj.emplace_back(p.x(), p.y(), p.z());
    }
    std::vector<cv::Point2d> img;
    cv::projectPoints(obj, rvec, tvec, K, dist, img);
    DetectedTag d;
    d.family = b.family;
    d.id = t.id;
    d.decision_margin = 100;
    bool inside = true;
    for (int k = 0; k < 4; ++k) {
      d.corners_px[k] = Eigen::Vector2d(img[k].x + n(rng), img[k].y + n(rng));
      inside = inside && img[k].x > 0 && img[k].y > 0 && img[k].x < c.width - 1 &&
               img[k].y < c.height - 1;
    }
    if (inside) out.push_back(d);
  }
  return out;
}

TEST(BundlePose, RecoversTheMannequinPoseFromNoisyCorners) {
  const StationScene s = default_station_scene();
  const TagBundle b = mannequin_bundle(s);
  std::mt19937 rng(3);
  double worst_t = 0, worst_r = 0;
  for (int view = 0; view < 6; ++view) {
    const Eigen::Isometry3d T_cam_man = look_at_man(0.30 + 0.02 * view, -0.5 + 0.15 * view, 0.4);
    const auto dets = synth_detections(b, s.calibration.camera, T_cam_man, 0.2, rng);
    ASSERT_GE(dets.size(), 4u) << "view " << view;
    const BundlePose p = estimate_bundle_pose(b, s.calibration.camera, dets);
    ASSERT_TRUE(p.ok()) << p.message;
    EXPECT_EQ(p.tags_used, static_cast<int>(dets.size()));
    EXPECT_LT(p.rms_px, 0.4) << "view " << view;
    EXPECT_LE(p.rms_px, p.seed_rms_px + 1e-9);
    worst_t = std::max(worst_t, trans_err_m(p.T_cam_body, T_cam_man));
    worst_r = std::max(worst_r, rot_err_rad(p.T_cam_body, T_cam_man));
  }
  std::printf("[ bundle ] 0.2 px noise: worst error %.3f mm, %.4f deg\n", worst_t * 1e3,
              worst_r * 180 / M_PI);
  EXPECT_LT(worst_t, 0.5e-3);
  EXPECT_LT(worst_r, 0.1 * M_PI / 180);
}

TEST(BundlePose, ExactCornersGiveTheExactPose) {
  const StationScene s = default_station_scene();
  const TagBundle b = mannequin_bundle(s);
  std::mt19937 rng(1);
  const Eigen::Isometry3d T_cam_man = look_at_man(0.35, -0.4, 0.45);
  const auto dets = synth_detections(b, s.calibration.camera, T_cam_man, 0.0, rng);
  const BundlePose p = estimate_bundle_pose(b, s.calibration.camera, dets);
  ASSERT_TRUE(p.ok()) << p.message;
  EXPECT_LT(trans_err_m(p.T_cam_body, T_cam_man), 1e-7);
  EXPECT_LT(rot_err_rad(p.T_cam_body, T_cam_man), 1e-7);
  EXPECT_LT(p.rms_px, 1e-5);
}

// BundlePoseOptions::shape_weight (issue 28 session 16): corners whose error
// lies mostly in each tag's shape, as motion blur makes it (every quad
// stretched along the image motion, about its own centre, as the generator's
// `hard` turns show), little in its centre. Weighting the shapes down
// follows the centres: a smaller pose error than each corner alone; exact
// corners stay exact; 1 is the plain fit to the bit; out of (0, 1] is
// refused.
TEST(BundlePose, ShapeWeightFollowsTheTagCentres) {
  const StationScene s = default_station_scene();
  const TagBundle b = mannequin_bundle(s);
  std::mt19937 rng(11);
  std::normal_distribution<double> corner(0.0, 0.1);
  std::uniform_real_distribution<double> dir(0.0, M_PI), stretch(0.2, 0.6);
  BundlePoseOptions plain, weighted;
  weighted.shape_weight = 0.3;
  double ss_plain = 0, ss_weighted = 0;
  const int trials = 24;
  for (int i = 0; i < trials; ++i) {
    const Eigen::Isometry3d T_cam_man = look_at_man(0.36, -0.5 + 0.04 * i, 0.45);
    auto dets = synth_detections(b, s.calibration.camera, T_cam_man, 0.0, rng);
    ASSERT_GE(dets.size(), 4u);
    if (i == 0) {
      const BundlePose exact = estimate_bundle_pose(b, s.calibration.camera, dets, weighted);
      ASSERT_TRUE(exact.ok()) << exact.message;
      EXPECT_LT(trans_err_m(exact.T_cam_body, T_cam_man), 1e-7);
    }
    // This frame's blur: one direction and length for every tag.
    const double a = dir(rng), len = stretch(rng);
    const Eigen::Vector2d u(std::cos(a), std::sin(a));
    for (DetectedTag& d : dets) {
      Eigen::Vector2d m = Eigen::Vector2d::Zero();
      for (const auto& c : d.corners_px) m += c / 4;
      for (auto& c : d.corners_px) {
        const double along = u.dot(c - m);
        c += len * (along > 0 ? 1.0 : -1.0) * u + Eigen::Vector2d(corner(rng), corner(rng));
      }
    }
  const BundlePose p = estimate_bundle_pose(b, s.calibration.camera, dets, plain);
    const BundlePose w = estimate_bundle_pose(b, s.calibration.camera, dets, weighted);
    ASSERT_TRUE(p.ok() && w.ok()) << p.message << w.message;
    ss_plain += std::pow(trans_err_m(p.T_cam_body, T_cam_man), 2);
    ss_weighted += std::pow(trans_err_m(w.T_cam_body, T_cam_man), 2);
    if (i == 1) {
      BundlePoseOptions one;
      one.shape_weight = 1.0;
      const BundlePose q = estimate_bundle_pose(b, s.calibration.camera, dets, one);
      EXPECT_TRUE(q.T_cam_body.isApprox(p.T_cam_body, 0.0));
      EXPECT_EQ(q.noise_px2, p.noise_px2);
    }
  }
  const double rms_plain = std::sqrt(ss_plain / trials), rms_weighted = std::sqrt(ss_weighted / trials);
  std::printf("[ bundle ] quads stretched 0.2-0.6 px, 0.1 px corner noise: position RMS %.3f mm plain, %.3f mm shape_weight 0.3\n",
              rms_plain * 1e3, rms_weighted * 1e3);
  EXPECT_LT(rms_weighted, 0.75 * rms_plain);
  for (double bad : {0.0, -0.5, 1.5, std::nan("")}) {
    BundlePoseOptions o;
    o.shape_weight = bad;
    EXPECT_NE(o.validate().find("shape_weight"), std::string::npos) << bad;
  }
}

// The per-tag residual shares add up to the fit's; the view-angle weights
// and the dropping of grazing tags (issue 16 head layout, measured and off
// by default) keep exact corners exact and drop what they say.
TEST(BundlePose, TagResidualsViewWeightsAndGrazingTags) {
  StationScene s = default_station_scene();
  set_mannequin_layout(s, MannequinLayout::kWrap20);
  const TagBundle b = mannequin_bundle(s);
  std::mt19937 rng(5);
  const Eigen::Isometry3d T_cam_man = look_at_man(0.35, -0.5, 0.35);
  const auto dets = synth_detections(b, s.calibration.camera, T_cam_man, 0.15, rng);
  ASSERT_GE(dets.size(), 6u);
  const BundlePose p = estimate_bundle_pose(b, s.calibration.camera, dets);
  ASSERT_TRUE(p.ok()) << p.message;
  ASSERT_EQ(p.tag_residuals.size(), p.tag_ids.size());
  double sum = 0, dof = 0, max_angle = 0;
  for (std::size_t i = 0; i < p.tag_residuals.size(); ++i) {
    EXPECT_EQ(p.tag_residuals[i].id, p.tag_ids[i]);
    sum += p.tag_residuals[i].sum_px2;
    dof += p.tag_residuals[i].dof;
    max_angle = std::max(max_angle, p.tag_residuals[i].view_angle_rad);
  }
  EXPECT_NEAR(dof, p.noise_dof, 1e-6);
  EXPECT_NEAR(sum / dof, p.noise_px2, 1e-9);
  ASSERT_GT(max_angle, 60 * M_PI / 180) << "the view should see a grazing tag";

  const auto exact = synth_detections(b, s.calibration.camera, T_cam_man, 0.0, rng);
  BundlePoseOptions o;
  o.view_weight_from_rad = 40 * M_PI / 180;
  const BundlePose w = estimate_bundle_pose(b, s.calibration.camera, exact, o);
  ASSERT_TRUE(w.ok()) << w.message;
  EXPECT_LT(trans_err_m(w.T_cam_body, T_cam_man), 1e-7);
  EXPECT_EQ(w.tags_used, static_cast<int>(exact.size()));

  o = {};
  o.max_view_angle_rad = 60 * M_PI / 180;
  const BundlePose d = estimate_bundle_pose(b, s.calibration.camera, dets, o);
  ASSERT_TRUE(d.ok()) << d.message;
  EXPECT_LT(d.tags_used, p.tags_used);
  for (const auto& t : d.tag_residuals) EXPECT_LE(t.view_angle_rad, 61 * M_PI / 180) << t.id;  // judged at the first fit
  o.min_tags_kept = 99;  // too few would remain: nothing is dropped
  EXPECT_EQ(estimate_bundle_pose(b, s.calibration.camera, dets, o).tags_used, p.tags_used);
  o.max_view_angle_rad = -1;
  EXPECT_EQ(estimate_bundle_pose(b, s.calibration.camera, dets, o).status, BundlePoseStatus::kInvalidInput);
}

// The leave-one-out outlier test (BundlePoseOptions::outlier_px, issue 16,
// off by default): one tag's corners pushed 3 px off leave the fit and the
// pose comes back; with clean corners nothing leaves; too few tags: nothing
// leaves; bad thresholds are refused by name.
TEST(BundlePose, OutlierTestDropsOneShiftedTag) {
  const StationScene s = default_station_scene();
  const TagBundle b = mannequin_bundle(s);
  std::mt19937 rng(5);
  const Eigen::Isometry3d T_cam_man = look_at_man(0.35, -0.3, 0.4);
  auto dets = synth_detections(b, s.calibration.camera, T_cam_man, 0.15, rng);
  ASSERT_GE(dets.size(), 6u);
  BundlePoseOptions o;
  o.outlier_px = 1.0;
  const BundlePose clean = estimate_bundle_pose(b, s.calibration.camera, dets, o);
  ASSERT_TRUE(clean.ok()) << clean.message;
  EXPECT_EQ(clean.rejected_id, -1);
  EXPECT_EQ(clean.tags_used, static_cast<int>(dets.size()));

  // One tag's corners shifted 3 px (a blur-dragged or mis-ordered detection).
  const int bad = dets[2].id;
  for (auto& c : dets[2].corners_px) c += Eigen::Vector2d(3.0, -1.5);
  const BundlePose off = estimate_bundle_pose(b, s.calibration.camera, dets);
  const BundlePose on = estimate_bundle_pose(b, s.calibration.camera, dets, o);
  ASSERT_TRUE(off.ok() && on.ok());
  EXPECT_EQ(off.rejected_id, -1);
  EXPECT_EQ(on.rejected_id, bad);
  EXPECT_GT(on.rejected_rms_px, 2.0);
  EXPECT_EQ(on.tags_used, off.tags_used - 1);
  EXPECT_EQ(std::count(on.tag_ids.begin(), on.tag_ids.end(), bad), 0);
  EXPECT_LT(trans_err_m(on.T_cam_body, T_cam_man), 0.5 * trans_err_m(off.T_cam_body, T_cam_man));
  EXPECT_LT(on.rms_px, 0.5 * off.rms_px);

  o.min_tags_kept = static_cast<int>(dets.size());  // none may leave
  EXPECT_EQ(estimate_bundle_pose(b, s.calibration.camera, dets, o).rejected_id, -1);
  o = {};
  o.outlier_px = -1;
  BundlePose e = estimate_bundle_pose(b, s.calibration.camera, dets, o);
  EXPECT_EQ(e.status, BundlePoseStatus::kInvalidInput);
  EXPECT_NE(e.message.find("outlier_px"), std::string::npos) << e.message;
  o = {};
  o.outlier_ratio = 0.5;
  e = estimate_bundle_pose(b, s.calibration.camera, dets, o);
  EXPECT_EQ(e.status, BundlePoseStatus::kInvalidInput);
  EXPECT_NE(e.message.find("outlier_ratio"), std::string::npos) << e.message;
}

// The reported covariance matches the scatter of the estimates under
// repeated noise (translation along the optical axis and rotation).
TEST(BundlePose, CovarianceMatchesMonteCarloScatter) {
  const StationScene s = default_station_scene();
  const TagBundle b = mannequin_bundle(s);
  const Eigen::Isometry3d T_cam_man = look_at_man(0.35, -0.4, 0.45);
  std::mt19937 rng(5);
  const int n = 300;
  Eigen::Matrix<double, 6, 6> emp = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 6> reported = Eigen::Matrix<double, 6, 6>::Zero();
  for (int i = 0; i < n; ++i) {
    const auto dets = synth_detections(b, s.calibration.camera, T_cam_man, 0.3, rng);
    const BundlePose p = estimate_bundle_pose(b, s.calibration.camera, dets);
    ASSERT_TRUE(p.ok()) << p.message;
    // delta: R_true = exp(w) R_est, t_true = t_est + v.
    Eigen::Matrix<double, 6, 1> d;
    const Eigen::AngleAxisd aa(T_cam_man.linear() * p.T_cam_body.linear().transpose());
    d.head<3>() = aa.angle() * aa.axis();
    d.tail<3>() = T_cam_man.translation() - p.T_cam_body.translation();
    emp += d * d.transpose() / n;
    reported += p.covariance / n;
  }
  std::printf(
      "[ bundle ] sigma tz: reported %.4f mm, Monte-Carlo %.4f mm; sigma rx: %.4f vs "
      "%.4f deg\n",
      std::sqrt(reported(5, 5)) * 1e3, std::sqrt(emp(5, 5)) * 1e3,
      std::sqrt(reported(0, 0)) * 180 / M_PI, std::sqrt(emp(0, 0)) * 180 / M_PI);
  for (int k = 0; k < 6; ++k) {
    const double ratio = std::sqrt(reported(k, k) / emp(k, k));
    EXPECT_GT(ratio, 0.75) << "component " << k;
    EXPECT_LT(ratio, 1.33) << "component " << k;
  }
}

// One 10 mm tag at ~60 deg, 17 px wide: both IPPE solutions fit the noisy
// corners about equally well. Alone the fit sometimes flips; given the
// previous pose it never does.
TEST(BundlePose, PreviousPoseResolvesThePlanarAmbiguity) {
  calibration::CameraIntrinsics cam;
  cam.width = 640;
  cam.height = 480;
  cam.fx = cam.fy = 600;
  cam.cx = 319.5;
  cam.cy = 239.5;
  TagBundle b;
  b.name = "mirror";
  TagPlacement t;
  t.id = 7;
  t.size_m = 0.010;
  b.tags.push_back(t);
  Eigen::Isometry3d T_cam_tag = Eigen::Isometry3d::Identity();
  T_cam_tag.linear() = (Eigen::AngleAxisd(1.05, Eigen::Vector3d::UnitX()) *
                        Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY()))
                           .toRotationMatrix();
  T_cam_tag.translation() = Eigen::Vector3d(0.02, -0.01, 0.35);
  std::mt19937 rng(9);
  int flips_alone = 0, flips_with_prev = 0, failures = 0;
  const int n = 200;
  for (int i = 0; i < n; ++i) {
    const auto dets = synth_detections(b, cam, T_cam_tag, 0.4, rng);
    ASSERT_EQ(dets.size(), 1u);
    // The previous frame's pose: the truth moved by ~1 deg and 1 mm.
    Eigen::Isometry3d prev = T_cam_tag;
    prev.linear() = Eigen::AngleAxisd(0.017, Eigen::Vector3d(1, 1, 0).normalized()) * prev.linear();
    prev.translation() += Eigen::Vector3d(1e-3, 0, 0);
    const BundlePose alone = estimate_bundle_pose(b, cam, dets);
    const BundlePose cont = estimate_bundle_pose(b, cam, dets, {}, prev);
    if (!alone.ok() || !cont.ok()) {
      ++failures;
      continue;
    }
    flips_alone += rot_err_rad(alone.T_cam_body, T_cam_tag) > 10 * M_PI / 180 ? 1 : 0;
    flips_with_prev += rot_err_rad(cont.T_cam_body, T_cam_tag) > 10 * M_PI / 180 ? 1 : 0;
    EXPECT_EQ(cont.tags_used, 1);
  }
  std::printf(
      "[ bundle ] single 10 mm tag at 60 deg, 0.4 px noise: %d/%d flips alone, %d with "
      "the previous pose\n",
      flips_alone, n, flips_with_prev);
  EXPECT_EQ(failures, 0);
  EXPECT_GT(flips_alone, 0) << "the case is not ambiguous: the test proves nothing";
  EXPECT_EQ(flips_with_prev, 0);
}

TEST(BundlePose, BadInputsGiveAClearStatus) {
  const StationScene s = default_station_scene();
  const TagBundle b = mannequin_bundle(s);
  const auto& cam = s.calibration.camera;

  BundlePose p = estimate_bundle_pose(b, cam, {});
  EXPECT_EQ(p.status, BundlePoseStatus::kNoDetections);
  EXPECT_NE(p.message.find("mannequin"), std::string::npos) << p.message;

  DetectedTag unknown;
  unknown.id = 2000;  // not on the head
  for (int k = 0; k < 4; ++k)
    unknown.corners_px[k] = Eigen::Vector2d(100 + 10 * (k % 2), 100 + 10 * (k / 2));
  p = estimate_bundle_pose(b, cam, {unknown});
  EXPECT_EQ(p.status, BundlePoseStatus::kNoBundleTags);
  EXPECT_NE(p.message.find("none of the bundle"), std::string::npos) << p.message;

  // A head tag id but the wrong family, or too many corrected bits.
  DetectedTag wrong = unknown;
  wrong.id = s.mannequin_tags[0].id;
  wrong.family = TagFamilyId::kTag36h11;
  EXPECT_EQ(estimate_bundle_pose(b, cam, {wrong}).status, BundlePoseStatus::kNoBundleTags);
  wrong.family = b.family;
  wrong.hamming = 2;
  EXPECT_EQ(estimate_bundle_pose(b, cam, {wrong}).status, BundlePoseStatus::kNoBundleTags);

  calibration::CameraIntrinsics bad = cam;
  bad.fx = 0;
  p = estimate_bundle_pose(b, bad, {wrong});
  EXPECT_EQ(p.status, BundlePoseStatus::kInvalidInput);
  EXPECT_NE(p.message.find("camera"), std::string::npos) << p.message;

  TagBundle empty;
  EXPECT_EQ(estimate_bundle_pose(empty, cam, {wrong}).status, BundlePoseStatus::kInvalidInput);

  BundlePoseOptions o;
  o.max_iterations = -1;
  p = estimate_bundle_pose(b, cam, {wrong}, o);
  EXPECT_EQ(p.status, BundlePoseStatus::kInvalidInput);
  EXPECT_NE(p.message.find("max_iterations"), std::string::npos) << p.message;

  // Non-finite corners are dropped, not propagated.
  DetectedTag nan = wrong;
  nan.hamming = 0;
  nan.corners_px[2] = Eigen::Vector2d(std::nan(""), 0);
  EXPECT_EQ(estimate_bundle_pose(b, cam, {nan}).status, BundlePoseStatus::kNoBundleTags);
}

TEST(TagDetector, BadImagesAndOptionsGiveClearErrors) {
  TagDetectorOptions o;
  o.decimation = 0.5;
  auto bad = TagDetector::create(o);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("decimation"), std::string::npos) << bad.error();
  o = TagDetectorOptions{};
  o.families.clear();
  EXPECT_FALSE(TagDetector::create(o).ok());
  o = TagDetectorOptions{};
  o.corner_candidates = 3;
  bad = TagDetector::create(o);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("corner_candidates = 3"), std::string::npos) << bad.error();
  o.corner_candidates = 21;
  EXPECT_FALSE(TagDetector::create(o).ok());
  o.corner_candidates = 4;
  EXPECT_TRUE(TagDetector::create(o).ok());

  auto d = TagDetector::create();
  ASSERT_TRUE(d.ok()) << d.error();
  auto r = d->detect(cv::Mat());
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("empty"), std::string::npos) << r.error();
  r = d->detect(cv::Mat(48, 64, CV_8UC3, cv::Scalar::all(128)));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("CV_8UC1"), std::string::npos) << r.error();
  r = d->detect(cv::Mat(3, 3, CV_8UC1, cv::Scalar::all(128)));
  EXPECT_FALSE(r.ok());
  r = d->detect(cv::Mat(48, 64, CV_8UC1, cv::Scalar::all(128)));
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_TRUE(r->empty());
  EXPECT_FALSE(d->set_threads(0).ok());
  EXPECT_FALSE(d->set_decimation(std::nan("")).ok());
  EXPECT_TRUE(d->set_decimation(1.0).ok());
  EXPECT_EQ(d->options().decimation, 1.0);
}

// A rendered tag is found with its id and corners in OpenCV's convention.
TEST(TagDetector, FindsARenderedTagWithOpenCvCorners) {
  for (TagFamilyId fam : {TagFamilyId::kStandard41h12, TagFamilyId::kTag36h11}) {
    const TagFamily f = TagFamily::create(fam);
    const int ppc = 12, margin = 40, code = 5;
    const cv::Mat img = render_tag_image(f, code, ppc, margin);
    TagDetectorOptions o;
    o.families = {TagFamilyId::kStandard41h12, TagFamilyId::kTag36h11};
    o.decimation = 1;
    auto d = TagDetector::create(o);
    ASSERT_TRUE(d.ok()) << d.error();
    auto r = d->detect(img);
    ASSERT_TRUE(r.ok()) << r.error();
    ASSERT_EQ(r->size(), 1u) << tag_family_name(fam);
    const DetectedTag& t = r->front();
    EXPECT_EQ(t.family, fam);
    EXPECT_EQ(t.id, code);
    EXPECT_EQ(t.hamming, 0);
    // Border square's outer edge: pixel edges at b0*ppc and (b0+wb)*ppc from
    // the margin; in OpenCV's convention an edge between pixels i-1 and i is
    // at i - 0.5. Corner 0 is (-s/2, +s/2): left, bottom.
    const double lo = margin + f.border_start() * ppc - 0.5;
    const double hi = margin + (f.border_start() + f.width_at_border()) * ppc - 0.5;
    const std::array<Eigen::Vector2d, 4> expect = {Eigen::Vector2d(lo, hi), Eigen::Vector2d(hi, hi),
                                                   Eigen::Vector2d(hi, lo),
                                                   Eigen::Vector2d(lo, lo)};
    for (int k = 0; k < 4; ++k)
      EXPECT_LT((t.corners_px[k] - expect[k]).norm(), 0.25)
          << tag_family_name(fam) << " corner " << k << ": " << t.corners_px[k].transpose();
  }
}


// ---- Several views (issue 28: a stereo head) ----

// A stereo head: the right eye 63 mm to the left eye's right (x_l = T_caml_camr x_r).
Eigen::Isometry3d stereo_T_caml_camr(double baseline_m = 0.063) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(baseline_m, 0, 0);
  return T;
}

// The mirror's tag frame 32 cm in front of the left eye, turned a little.
Eigen::Isometry3d mirror_in_front() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(-0.15, Eigen::Vector3d::UnitX())).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.01, 0.02, 0.32);
  return T;
}

// The covariance of the fit from both eyes against the scatter of 300 noisy
// fits, per component (the mono test's check), and what the second eye buys
// along the left eye's line of sight, the mono fit's weakest direction: at
// the mannequin's origin and at the mirror's centre (85 mm from its 12 mm
// tags), at 0.3 px of corner noise.
TEST(BundlePoseViews, StereoCovarianceMatchesMonteCarloAndBeatsMonoInDepth) {
  const StationScene s = default_station_scene();
  const auto& cam = s.calibration.camera;
  const Eigen::Isometry3d T_caml_camr = stereo_T_caml_camr();
  const Eigen::Vector3d centre = s.calibration.T_mtag_mir.translation();
  struct Case {
    TagBundle b;
    Eigen::Isometry3d T_caml_body;
    Eigen::Vector3d point;
  };
  const Case cases[] = {{mannequin_bundle(s), look_at_man(0.35, -0.4, 0.45), Eigen::Vector3d::Zero()},
                        {mirror_bundle(s), mirror_in_front(), centre}};
  for (const Case& c : cases) {
    std::mt19937 rng(11);
    const int n = 300;
    using Mat6 = Eigen::Matrix<double, 6, 6>;
    Mat6 emp = Mat6::Zero(), reported = Mat6::Zero();
    double mono_depth2 = 0, stereo_depth2 = 0, mono_sigma2 = 0, stereo_sigma2 = 0;
    const Eigen::Vector3d p_true = c.T_caml_body * c.point;
    const Eigen::Vector3d los = p_true.normalized();  // the left eye's line of sight to the point
    for (int i = 0; i < n; ++i) {
      const auto dl = synth_detections(c.b, cam, c.T_caml_body, 0.3, rng);
      const auto dr = synth_detections(c.b, cam, T_caml_camr.inverse() * c.T_caml_body, 0.3, rng);
      ASSERT_FALSE(dl.empty());
      ASSERT_FALSE(dr.empty());
      const BundlePose st = estimate_bundle_pose_views(
          c.b, {BundleView{&cam, Eigen::Isometry3d::Identity(), &dl}, BundleView{&cam, T_caml_camr.inverse(), &dr}});
      ASSERT_TRUE(st.ok()) << st.message;
      EXPECT_EQ(st.views_used, 2);
      EXPECT_EQ(st.tags_used, static_cast<int>(dl.size() + dr.size()));
      const BundlePose mo = estimate_bundle_pose(c.b, cam, dl);
      ASSERT_TRUE(mo.ok()) << mo.message;
      Eigen::Matrix<double, 6, 1> d;
      const Eigen::AngleAxisd aa(c.T_caml_body.linear() * st.T_cam_body.linear().transpose());
      d.head<3>() = aa.angle() * aa.axis();
      d.tail<3>() = c.T_caml_body.translation() - st.T_cam_body.translation();
      emp += d * d.transpose() / n;
      reported += st.covariance / n;
      const double e_st = los.dot(st.T_cam_body * c.point - p_true), e_mo = los.dot(mo.T_cam_body * c.point - p_true);
      stereo_depth2 += e_st * e_st / n;
      mono_depth2 += e_mo * e_mo / n;
      stereo_sigma2 += los.dot(point_covariance(st.covariance, st.T_cam_body, c.point) * los) / n;
      mono_sigma2 += los.dot(point_covariance(mo.covariance, mo.T_cam_body, c.point) * los) / n;
    }
    std::printf("[ views ] %s: depth RMS at its %s mono %.4f mm, stereo %.4f mm (reported %.4f / %.4f mm)\n",
                c.b.name.c_str(), c.point.isZero() ? "origin" : "centre", std::sqrt(mono_depth2) * 1e3,
                std::sqrt(stereo_depth2) * 1e3, std::sqrt(mono_sigma2) * 1e3, std::sqrt(stereo_sigma2) * 1e3);
    for (int k = 0; k < 6; ++k) {
      const double ratio = std::sqrt(reported(k, k) / emp(k, k));
      EXPECT_GT(ratio, 0.75) << c.b.name << " component " << k;
      EXPECT_LT(ratio, 1.33) << c.b.name << " component " << k;
    }
    // The point's depth sigma, reported and observed, within 25 % of each other.
    EXPECT_NEAR(std::sqrt(stereo_sigma2 / stereo_depth2), 1.0, 0.25) << c.b.name;
    // Measured 0.58x (mannequin origin) and 0.53x (mirror centre): more than
    // the 0.71x that twice the corners alone would give.
    EXPECT_LT(std::sqrt(stereo_depth2), 0.68 * std::sqrt(mono_depth2)) << c.b.name;
  }
}

// Blur in the fit (BundlePoseOptions::blur_stretch_sigma_px, issue 28
// session 17). Every quad of one eye stretched the same way along one image
// direction about its own centre (the corners pushed +-len along it, as in
// ShapeWeightFollowsTheTagCentres: not the fit's own edge model), each eye
// its own direction and length, plus 0.1 px noise: the per-eye stretch
// fitted with the pose takes most of the pose error that a fit of each
// corner alone makes, in stereo and mono. Exact corners stay exact; the
// fitted stretch widens the quads as the applied one does; bad values are refused.
TEST(BundlePoseViews, BlurStretchInTheFitFollowsASharedStretch) {
  const StationScene s = default_station_scene();
  const auto& cam = s.calibration.camera;
  const TagBundle b = mannequin_bundle(s);
  const Eigen::Isometry3d T_camr_caml = stereo_T_caml_camr().inverse();
  std::mt19937 rng(17);
  std::normal_distribution<double> noise(0.0, 0.1);
  std::uniform_real_distribution<double> dir(0.0, M_PI), stretch(0.2, 0.6);
  BundlePoseOptions plain, blur;
  blur.blur_stretch_sigma_px = 8;
  auto stretch_all = [&](std::vector<DetectedTag>& dets, const Eigen::Vector2d& u, double len) {
    for (DetectedTag& d : dets) {
      Eigen::Vector2d m = Eigen::Vector2d::Zero();
      for (const auto& c : d.corners_px) m += c / 4;
      for (auto& c : d.corners_px) c += len * (u.dot(c - m) > 0 ? 1.0 : -1.0) * u + Eigen::Vector2d(noise(rng), noise(rng));
    }
  };
  double ss[2][2] = {{0, 0}, {0, 0}};  // [mono, stereo][plain, blur]
  int along = 0;
  const int trials = 20;
  for (int i = 0; i < trials; ++i) {
    const Eigen::Isometry3d T = look_at_man(0.36, -0.5 + 0.05 * i, 0.45);
    auto dl = synth_detections(b, cam, T, 0.0, rng);
    auto dr = synth_detections(b, cam, T_camr_caml * T, 0.0, rng);
    ASSERT_GE(dl.size(), 4u);
    ASSERT_GE(dr.size(), 4u);
    if (i == 0) {
      const BundlePose exact = estimate_bundle_pose_views(
          b, {BundleView{&cam, Eigen::Isometry3d::Identity(), &dl}, BundleView{&cam, T_camr_caml, &dr}}, blur);
      ASSERT_TRUE(exact.ok()) << exact.message;
      EXPECT_LT(trans_err_m(exact.T_cam_body, T), 1e-7);
      ASSERT_EQ(exact.blur_stretch_px.size(), 2u);
      EXPECT_LT(exact.blur_stretch_px[0].norm() + exact.blur_stretch_px[1].norm(), 1e-5);
    }
    const double al = dir(rng), ar = dir(rng), ll = stretch(rng), lr = stretch(rng);
    const Eigen::Vector2d ul(std::cos(al), std::sin(al));
    stretch_all(dl, ul, ll);
    stretch_all(dr, Eigen::Vector2d(std::cos(ar), std::sin(ar)), lr);
    const std::vector<BundleView> both = {BundleView{&cam, Eigen::Isometry3d::Identity(), &dl},
                                          BundleView{&cam, T_camr_caml, &dr}};
    const BundlePoseOptions* opts[2] = {&plain, &blur};
    for (int k = 0; k < 2; ++k) {
      const BundlePose mo = estimate_bundle_pose(b, cam, dl, *opts[k]);
      const BundlePose st = estimate_bundle_pose_views(b, both, *opts[k]);
      ASSERT_TRUE(mo.ok() && st.ok()) << mo.message << st.message;
      ss[0][k] += std::pow(trans_err_m(mo.T_cam_body, T), 2);
      ss[1][k] += std::pow(trans_err_m(st.T_cam_body, T), 2);
      EXPECT_EQ(st.blur_stretch_px.size(), k == 1 ? 2u : 0u);
      if (k == 1) {
        // The applied push is outward: the left eye's fitted S widens the
        // quads (trace > 0). (Its direction is not asserted: with the
        // mannequin's tags at similar image angles, edge normals cover two
        // directions and Sxy is held by its prior alone.)
        const Eigen::Vector3d& S = st.blur_stretch_px[0];
        along += S(0) + S(2) > 0.1 ? 1 : 0;
      }
    }
  }
  const auto rms_mm = [&](int p, int k) { return std::sqrt(ss[p][k] / trials) * 1e3; };
  std::printf("[ blur ] quads stretched 0.2-0.6 px per eye, 0.1 px noise: position RMS mono %.3f -> %.3f mm, stereo %.3f -> %.3f mm; "
              "left eye's stretch widens the quads in %d / %d frames\n",
              rms_mm(0, 0), rms_mm(0, 1), rms_mm(1, 0), rms_mm(1, 1), along, trials);
  EXPECT_LT(rms_mm(0, 1), 0.6 * rms_mm(0, 0));
  EXPECT_LT(rms_mm(1, 1), 0.6 * rms_mm(1, 0));
  EXPECT_GE(along, trials - 3);
  for (double bad : {-1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    BundlePoseOptions o;
    o.blur_stretch_sigma_px = bad;
    EXPECT_NE(o.validate().find("blur_stretch_sigma_px"), std::string::npos) << bad;
  }
}

// With the blur model on and no blur (0.3 px noise only), the stereo
// covariance, the stretch marginalised out, still matches the Monte-Carlo
// scatter (the check of StereoCovarianceMatchesMonteCarloAndBeatsMonoInDepth).
TEST(BundlePoseViews, BlurStretchCovarianceMatchesMonteCarlo) {
  const StationScene s = default_station_scene();
  const auto& cam = s.calibration.camera;
  const TagBundle b = mannequin_bundle(s);
  const Eigen::Isometry3d T = look_at_man(0.35, -0.4, 0.45);
  const Eigen::Isometry3d T_camr_caml = stereo_T_caml_camr().inverse();
  BundlePoseOptions blur;
  blur.blur_stretch_sigma_px = 8;
  for (int views = 1; views <= 2; ++views) {
    std::mt19937 rng(23);
    const int n = 300;
    Eigen::Matrix<double, 6, 6> emp = Eigen::Matrix<double, 6, 6>::Zero(), reported = emp;
    for (int i = 0; i < n; ++i) {
      const auto dl = synth_detections(b, cam, T, 0.3, rng);
      const auto dr = synth_detections(b, cam, T_camr_caml * T, 0.3, rng);
      std::vector<BundleView> vs = {BundleView{&cam, Eigen::Isometry3d::Identity(), &dl}};
      if (views == 2) vs.push_back(BundleView{&cam, T_camr_caml, &dr});
      const BundlePose p = estimate_bundle_pose_views(b, vs, blur);
      ASSERT_TRUE(p.ok()) << p.message;
      Eigen::Matrix<double, 6, 1> d;
      const Eigen::AngleAxisd aa(T.linear() * p.T_cam_body.linear().transpose());
      d.head<3>() = aa.angle() * aa.axis();
      d.tail<3>() = T.translation() - p.T_cam_body.translation();
      emp += d * d.transpose() / n;
      reported += p.covariance / n;
    }
    std::printf("[ blur ] %d view(s), blur model on, no blur: sigma tz reported %.4f mm, Monte-Carlo %.4f mm\n", views,
                std::sqrt(reported(5, 5)) * 1e3, std::sqrt(emp(5, 5)) * 1e3);
    for (int k = 0; k < 6; ++k) {
      const double ratio = std::sqrt(reported(k, k) / emp(k, k));
      EXPECT_GT(ratio, 0.75) << views << " view(s), component " << k;
      EXPECT_LT(ratio, 1.33) << views << " view(s), component " << k;
    }
  }
}

// Each tag's outline moved out by one common offset e (every edge along its
// outward normal; a corner where its two moved edges meet), e drawn per tag
// observation, plus independent corner noise.
void add_outline_offsets(std::vector<DetectedTag>& ds, double noise_px, double outline_px, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  for (DetectedTag& d : ds) {
    Eigen::Vector2d m = Eigen::Vector2d::Zero();
    for (const auto& c : d.corners_px) m += c / 4;
    auto normal = [&](int a, int b) {
      const Eigen::Vector2d p = d.corners_px[a], q = d.corners_px[b];
      Eigen::Vector2d nn(q.y() - p.y(), p.x() - q.x());
      nn.normalize();
      return nn.dot((p + q) / 2 - m) < 0 ? Eigen::Vector2d(-nn) : nn;
    };
    std::array<Eigen::Vector2d, 4> u;
    for (int k = 0; k < 4; ++k) {
      Eigen::Matrix2d N;
      N << normal((k + 3) % 4, k).transpose(), normal(k, (k + 1) % 4).transpose();
      u[k] = N.inverse() * Eigen::Vector2d(1, 1);
    }
    const double e = outline_px * n(rng);
    for (int k = 0; k < 4; ++k)
      d.corners_px[k] += e * u[k] + noise_px * Eigen::Vector2d(n(rng), n(rng));
  }
}

// The outline offset in the corners' predicted covariance
// (BundlePoseOptions::tag_outline_sigma, issue 28 session 18), on the
// mirror's two 12 mm tags 32 cm away: corners with 0.1 px of noise plus a
// common outline offset of 2 x that per tag observation. One eye reads the
// disc centre's depth from the tags' size: without the model its stated
// depth error is too small (the offset is not noise that four corners
// average); with it, the stated depth error covers the scatter, in one eye
// and in two, and the covariance matches the Monte-Carlo scatter per
// component. Exact corners stay exact; bad values are refused.
TEST(BundlePoseViews, TagOutlineOffsetCovarianceMatchesMonteCarlo) {
  const StationScene s = default_station_scene();
  const auto& cam = s.calibration.camera;
  const TagBundle b = mirror_bundle(s);
  const Eigen::Isometry3d T = mirror_in_front();
  const Eigen::Isometry3d T_camr_caml = stereo_T_caml_camr().inverse();
  const Eigen::Vector3d centre = s.calibration.T_mtag_mir.translation();
  const Eigen::Vector3d p_true = T * centre, los = p_true.normalized();
  BundlePoseOptions on;
  on.tag_outline_sigma = 2;
  {  // exact corners: the exact pose
    std::mt19937 rng(1);
    const auto dl = synth_detections(b, cam, T, 0.0, rng);
    const BundlePose p = estimate_bundle_pose(b, cam, dl, on);
    ASSERT_TRUE(p.ok()) << p.message;
    EXPECT_LT(trans_err_m(p.T_cam_body, T), 1e-7);
  }
  double ratio_off_mono = 0;
  for (int views = 1; views <= 2; ++views) {
    for (const BundlePoseOptions& o : {BundlePoseOptions{}, on}) {
      std::mt19937 rng(29);
      const int n = 300;
      Eigen::Matrix<double, 6, 6> emp = Eigen::Matrix<double, 6, 6>::Zero(), reported = emp;
      double depth2 = 0, sigma2 = 0;
      for (int i = 0; i < n; ++i) {
        auto dl = synth_detections(b, cam, T, 0.0, rng);
        auto dr = synth_detections(b, cam, T_camr_caml * T, 0.0, rng);
        add_outline_offsets(dl, 0.1, 0.2, rng);
        add_outline_offsets(dr, 0.1, 0.2, rng);
        std::vector<BundleView> vs = {BundleView{&cam, Eigen::Isometry3d::Identity(), &dl}};
        if (views == 2) vs.push_back(BundleView{&cam, T_camr_caml, &dr});
        const BundlePose p = estimate_bundle_pose_views(b, vs, o, T);
        ASSERT_TRUE(p.ok()) << p.message;
        Eigen::Matrix<double, 6, 1> d;
        const Eigen::AngleAxisd aa(T.linear() * p.T_cam_body.linear().transpose());
        d.head<3>() = aa.angle() * aa.axis();
        d.tail<3>() = T.translation() - p.T_cam_body.translation();
        emp += d * d.transpose() / n;
        // The stated covariance at the corners' known noise (0.1 px; the residuals' own
        // estimate carries part of the offsets), with the outline offset's part.
        const Eigen::Matrix<double, 6, 6> cov = (p.covariance_per_px2 + p.outline_covariance_per_px2) * 0.01;
        if (o.tag_outline_sigma == 0) {
          EXPECT_TRUE(p.outline_covariance_per_px2.isZero());
        }
        reported += cov / n;
        const double e = los.dot(p.T_cam_body * centre - p_true);
        depth2 += e * e / n;
        sigma2 += los.dot(point_covariance(cov, p.T_cam_body, centre) * los) / n;
      }
      const double ratio = std::sqrt(sigma2 / depth2);
      std::printf("[ outline ] %d view(s), tag_outline_sigma %.0f: centre depth RMS %.4f mm, stated %.4f mm (%.2fx)\n",
                  views, o.tag_outline_sigma, std::sqrt(depth2) * 1e3, std::sqrt(sigma2) * 1e3, ratio);
      if (o.tag_outline_sigma > 0) {
        EXPECT_GT(ratio, 0.8) << views << " view(s)";
        EXPECT_LT(ratio, 1.25) << views << " view(s)";
        for (int k = 0; k < 6; ++k) {
          const double rk = std::sqrt(reported(k, k) / emp(k, k));
          EXPECT_GT(rk, 0.75) << views << " view(s), component " << k;
          EXPECT_LT(rk, 1.33) << views << " view(s), component " << k;
        }
      } else {
        if (views == 1) ratio_off_mono = ratio;
      }
    }
  }
  // Without the model one eye under-states the depth error it makes.
  EXPECT_LT(ratio_off_mono, 0.8);  // measured 0.68x
  BundlePoseOptions bad;
  bad.tag_outline_sigma = -1;
  EXPECT_NE(bad.validate().find("tag_outline_sigma"), std::string::npos);
  bad.tag_outline_sigma = NAN;
  EXPECT_FALSE(bad.validate().empty());
}
// A frame one eye does not see: the fit is that of the other eye alone, in
// the rig's (left eye's) frame; one view at the identity is the mono fit.
TEST(BundlePoseViews, OneBlindEyeGivesTheSingleViewFit) {
  const StationScene s = default_station_scene();
  const auto& cam = s.calibration.camera;
  const TagBundle b = mannequin_bundle(s);
  const Eigen::Isometry3d T_caml_camr = stereo_T_caml_camr();
  const Eigen::Isometry3d T_caml_man = look_at_man(0.35, -0.4, 0.45);
  std::mt19937 rng(4);
  const auto dl = synth_detections(b, cam, T_caml_man, 0.2, rng);
  const auto dr = synth_detections(b, cam, T_caml_camr.inverse() * T_caml_man, 0.2, rng);
  const std::vector<DetectedTag> none;
  const BundlePose mono_l = estimate_bundle_pose(b, cam, dl), mono_r = estimate_bundle_pose(b, cam, dr);
  ASSERT_TRUE(mono_l.ok() && mono_r.ok());
  const BundleView left{&cam, Eigen::Isometry3d::Identity(), &dl}, right{&cam, T_caml_camr.inverse(), &dr};
  const BundlePose only_l = estimate_bundle_pose_views(b, {left, BundleView{&cam, T_caml_camr.inverse(), &none}});
  ASSERT_TRUE(only_l.ok()) << only_l.message;
  EXPECT_EQ(only_l.views_used, 1);
  EXPECT_TRUE(only_l.T_cam_body.isApprox(mono_l.T_cam_body, 1e-12));
  EXPECT_TRUE(only_l.covariance.isApprox(mono_l.covariance, 1e-9));
  const BundlePose only_r = estimate_bundle_pose_views(b, {BundleView{&cam, Eigen::Isometry3d::Identity(), &none}, right});
  ASSERT_TRUE(only_r.ok()) << only_r.message;
  EXPECT_EQ(only_r.views_used, 1);
  EXPECT_LT(trans_err_m(only_r.T_cam_body, T_caml_camr * mono_r.T_cam_body), 1e-8);
  EXPECT_LT(rot_err_rad(only_r.T_cam_body, T_caml_camr * mono_r.T_cam_body), 1e-8);
  for (const auto& t : only_r.tag_residuals) EXPECT_EQ(t.view, 1);
  // Neither eye: no detections.
  EXPECT_EQ(estimate_bundle_pose_views(b, {BundleView{&cam, Eigen::Isometry3d::Identity(), &none}, BundleView{&cam, Eigen::Isometry3d::Identity(), &none}}).status,
            BundlePoseStatus::kNoDetections);
  // Bad views name themselves.
  BundlePose p = estimate_bundle_pose_views(b, {left, BundleView{nullptr, Eigen::Isometry3d::Identity(), &dr}});
  EXPECT_EQ(p.status, BundlePoseStatus::kInvalidInput);
  EXPECT_NE(p.message.find("views[1]"), std::string::npos) << p.message;
  calibration::CameraIntrinsics bad = cam;
  bad.fy = -1;
  p = estimate_bundle_pose_views(b, {left, BundleView{&bad, T_caml_camr.inverse(), &dr}});
  EXPECT_EQ(p.status, BundlePoseStatus::kInvalidInput);
  EXPECT_NE(p.message.find("views[1].camera"), std::string::npos) << p.message;
  EXPECT_EQ(estimate_bundle_pose_views(b, {}).status, BundlePoseStatus::kInvalidInput);
}

}  // namespace
}  // namespace dentar::ar
