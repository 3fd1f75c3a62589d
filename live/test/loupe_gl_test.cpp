// The digital loupe on generated footage with a head shake: the tracker's pose
// centres it (headset.h LoupeCentre on the projected tooth centre), the
// magnified tooth's outline (the virtual tooth as the compositor draws it, at
// the tracked pose) against the truth's outline in the same magnified image,
// and the tooth held in place in the view while the head shakes.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "dentar/ar/synth.h"
#include "dentar/ar/tracker.h"
#include "dentar/live/headset.h"
#include "dentar/volume/procedural_tooth.h"
#include "gl_test_context.h"

using namespace dentar;
using namespace dentar::ar;

namespace {

// The loupe's full view of a mask (CV_8UC1) at magnification m around c.
cv::Mat magnify(const cv::Mat& mask, const calibration::CameraIntrinsics& cam, double m, const double c[2]) {
  live::LoupeView l;
  l.mag = m;
  l.inset = false;
  cv::Mat src, out(mask.rows, mask.cols, CV_8UC3, cv::Scalar::all(0));
  cv::cvtColor(mask, src, cv::COLOR_GRAY2BGR);
  live::render_eye_cpu(src, live::make_window_mapping(mask.cols, mask.rows, cam, l, c), out);
  cv::Mat g;
  cv::cvtColor(out, g, cv::COLOR_BGR2GRAY);
  return g > 127;
}

// Mean and largest distance (px) of a's outline from b's outline.
std::pair<double, double> outline_distance(const cv::Mat& a, const cv::Mat& b) {
  std::vector<std::vector<cv::Point>> ca, cb;
  cv::findContours(a.clone(), ca, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  cv::findContours(b.clone(), cb, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  cv::Mat edge_b(b.size(), CV_8UC1, cv::Scalar(255));
  cv::drawContours(edge_b, cb, -1, cv::Scalar(0), 1);
  cv::Mat dist;
  cv::distanceTransform(edge_b, dist, cv::DIST_L2, 3);
  double sum = 0, worst = 0;
  int n = 0;
  for (const auto& c : ca)
    for (const cv::Point& p : c) {
      const double d = dist.at<float>(p);
      sum += d, worst = std::max(worst, d), ++n;
    }
  return {n ? sum / n : 1e9, worst};
}

}  // namespace

// Footage (20 frames): the standard scene with a head shake (the camera yaws 1.1 deg back
// and forth every 0.25 s, at 90 deg/s peak speed: a nervous or talking head),
// 640x480, 3x loupe.
TEST(LoupeGl, MagnifiedToothOnTruthAndHeldUnderHeadShake) {
  DENTAR_GL_TEST_CONTEXT();
  SynthOptions o = synth_preset(SynthPreset::kStandard);
  o.frames = 20;  // > one shake period (0.5 s) at 30 fps
  o.width = 640;
  o.height = 480;
  o.seed = 11;
  o.bur_samples = 500;
  o.head_turn_rad = 0.02;
  o.head_turn_s = 0.1;
  o.head_turn_period_s = 0.5;
  o.motion_blur = true;
  auto g = SynthGenerator::create(default_station_scene(), o);
  ASSERT_TRUE(g.ok()) << g.error();
  const StationScene& st = (*g)->station();
  const calibration::CameraIntrinsics& cam = st.calibration.camera;
  volume::MolarParams mp;
  mp.voxel_mm = st.tooth_voxel_m * 1e3;
  auto vol = volume::make_molar(mp);
  ASSERT_TRUE(vol.ok()) << vol.error();
  const Eigen::Vector3d centre =
      vol->origin() + vol->spacing().cwiseProduct((vol->dims() - Eigen::Vector3i::Ones()).cast<double>() / 2);
  auto tracker = Tracker::create(st);
  ASSERT_TRUE(tracker.ok()) << tracker.error();
  constexpr double kMag = 3.0;
  live::LoupeCentre loupe;
  double fixed_c[2] = {0, 0};  // a loupe that does not follow: fixed where the first frame put it
  bool have_fixed = false;
  double worst_view = 0, worst_fixed = 0, worst_mean_outline = 0, sum_outline = 0, truth_travel = 0;
  double prev_truth[2] = {0, 0};
  int measured = 0;
  for (int i = 0; i < o.frames; ++i) {
    SynthFrame f;
    ASSERT_TRUE((*g)->next(f).ok());
    auto tf = tracker->track(f.image, f.truth.time_s, f.truth.time_s);
    ASSERT_TRUE(tf.ok()) << tf.error();
    const bool tracked = tf->mannequin.state != TrackState::kLost;
    double u = 0, v = 0;
    const bool ok =
        tracked && live::project_point(cam, tf->mannequin.T_cam_body * st.calibration.T_man_tooth, centre, u, v);
    loupe.update(ok, u, v);
    if (!ok || !loupe.initialised()) continue;
    if (!have_fixed) fixed_c[0] = loupe.centre()[0], fixed_c[1] = loupe.centre()[1], have_fixed = true;
    // The truth: the tooth's centre with the true pose, where the loupe shows it.
    double tu = 0, tv = 0;
    ASSERT_TRUE(live::project_point(cam, f.truth.T_cam_tooth, centre, tu, tv));
    if (measured > 0) truth_travel = std::max(truth_travel, std::hypot(tu - prev_truth[0], tv - prev_truth[1]));
    prev_truth[0] = tu, prev_truth[1] = tv;
    // In the magnified view (camera px times the magnification, from the view's centre).
    worst_view = std::max(worst_view, kMag * std::hypot(tu - loupe.centre()[0], tv - loupe.centre()[1]));
    worst_fixed = std::max(worst_fixed, kMag * std::hypot(tu - fixed_c[0], tv - fixed_c[1]));
    // The outline: the virtual tooth as drawn (tracked pose) against the truth's silhouette.
    const cv::Mat truth = f.mask > 0;
    if (cv::countNonZero(truth) < 100) continue;
    auto drawn = (*g)->render_tooth_silhouette(tf->mannequin.T_cam_body * st.calibration.T_man_tooth);
    ASSERT_TRUE(drawn.ok()) << drawn.error();
    const cv::Mat mt = magnify(truth, cam, kMag, loupe.centre());
    const cv::Mat md = magnify(*drawn > 0, cam, kMag, loupe.centre());
    ASSERT_GT(cv::countNonZero(mt), 9 * cv::countNonZero(truth) * 0.8) << "the tooth is not inside the loupe's view";
    const auto [mean_d, max_d] = outline_distance(md, mt);
    worst_mean_outline = std::max(worst_mean_outline, mean_d);
    sum_outline += mean_d;
    EXPECT_LT(max_d, 8.0) << "frame " << i;
    ++measured;
  }
  ASSERT_GE(measured, o.frames * 3 / 4);
  std::printf("[ loupe ] %d frames: outline mean %.2f px (worst frame %.2f) at %.0fx; tooth centre in the view within "
              "%.2f px (a loupe that does not follow: %.1f px); the tooth moved up to %.1f px per frame\n",
              measured, sum_outline / measured, worst_mean_outline, kMag, worst_view, worst_fixed, truth_travel);
  // The magnified outline on the truth's: within 2.5 px of the 3x image on average (0.8 camera px).
  EXPECT_LT(sum_outline / measured, 2.5);
  EXPECT_LT(worst_mean_outline, 4.0);
  // The shake moves the tooth several px per frame in the camera image ...
  EXPECT_GT(truth_travel, 2.0);
  EXPECT_GT(worst_fixed, 20.0);
  // ... and the loupe holds it within 6 px of its view's centre (the deadband, 0.75 camera px, plus the
  // tracking error, times 3).
  EXPECT_LT(worst_view, 6.0);
}
