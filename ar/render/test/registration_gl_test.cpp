// Registration (issue 6): on the generator's `standard` footage, the virtual
// tooth drawn at the TRACKED pose (T_cam_man from the tracker, then the
// station's T_man_tooth) covers the same pixels as the tooth at the true
// pose. Goal: silhouette IoU >= 0.98 at 1280x720 (mean over the tracked
// frames; no frame below 0.95). At 0.1 mm per voxel the tooth covers about
// 1,200 px there, so 0.98 means the drawn outline is within ~0.15 px of the
// true one: about 0.05 mm at the tooth. At 640x480 the tooth is ~4x smaller
// and the same pose error costs twice the IoU; it is held to a lower bound.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "dentar/ar/synth.h"
#include "dentar/ar/tracker.h"
#include "gl_test_context.h"

namespace dentar::ar {
namespace {

double iou(const cv::Mat& a, const cv::Mat& b) {
  const int inter = cv::countNonZero(a & b), uni = cv::countNonZero(a | b);
  return uni ? static_cast<double>(inter) / uni : 1.0;
}

void check_registration(int width, int height, int frames, double mean_iou, double min_iou) {
  SynthOptions o = synth_preset(SynthPreset::kStandard);
  o.frames = frames;
  o.width = width;
  o.height = height;
  o.seed = 5;
  o.bur_samples = 1000;
  auto g = SynthGenerator::create(default_station_scene(), o);
  ASSERT_TRUE(g.ok()) << g.error();
  const StationScene& st = (*g)->station();
  auto tracker = Tracker::create(st);
  ASSERT_TRUE(tracker.ok()) << tracker.error();
  int measured = 0;
  double worst = 1.0, sum = 0;
  for (int i = 0; i < frames; ++i) {
    SynthFrame f;
    ASSERT_TRUE((*g)->next(f).ok());
    auto tf = tracker->track(f.image, f.truth.time_s, f.truth.time_s);
    ASSERT_TRUE(tf.ok()) << tf.error();
    if (tf->mannequin.state == TrackState::kLost) continue;
    const cv::Mat truth = f.mask > 0;  // the tooth as cut so far, occluded or not
    if (cv::countNonZero(truth) < 100) continue;  // tooth (nearly) out of view
    auto control = (*g)->render_tooth_silhouette(f.truth.T_cam_tooth);
    ASSERT_TRUE(control.ok());
    EXPECT_GE(iou(*control > 0, truth), 0.999) << "the generator's own silhouette differs from its mask";
    auto drawn = (*g)->render_tooth_silhouette(tf->mannequin.T_cam_body * st.calibration.T_man_tooth);
    ASSERT_TRUE(drawn.ok()) << drawn.error();
    const double v = iou(*drawn > 0, truth);
    worst = std::min(worst, v);
    sum += v;
    EXPECT_GE(v, min_iou) << width << "x" << height << " frame " << i << " state "
                          << track_state_name(tf->mannequin.state);
    ++measured;
  }
  ASSERT_GE(measured, frames * 8 / 10) << "too few tracked frames to measure";
  EXPECT_GE(sum / measured, mean_iou) << width << "x" << height;
  std::printf("[ registration ] %dx%d: %d frames, silhouette IoU mean %.4f, worst %.4f\n", width, height,
              measured, sum / measured, worst);
}

TEST(Registration, TrackedToothSilhouetteMatchesTruthAt640x480) {
  DENTAR_GL_TEST_CONTEXT();
  check_registration(640, 480, 30, 0.95, 0.90);
}

TEST(Registration, TrackedToothSilhouetteMatchesTruthAt1280x720) {
  DENTAR_GL_TEST_CONTEXT();
  check_registration(1280, 720, 30, 0.98, 0.95);
}

}  // namespace
}  // namespace dentar::ar
