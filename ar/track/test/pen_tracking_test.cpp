// The tracker's pen body (the tracked pen that stands in for the stylus):
// a picture of the pen flag's front tag at a known pose is found, its pose
// measured, and nothing is reported when pen tracking is off.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "dentar/ar/apriltags.h"
#include "dentar/ar/camera_model.h"
#include "dentar/ar/tracker.h"
#include "tag_drawing.h"

namespace dentar::ar {
namespace {

// The front pen tag drawn at T_cam_ptag into a white frame (pinhole, no distortion).
cv::Mat pen_frame(const StationScene& st, const Eigen::Isometry3d& T_cam_ptag) {
  const TagFamily fam = TagFamily::create(st.family);
  const TagPlacement& t = st.pen.tags[0];
  cv::Mat out(st.calibration.camera.height, st.calibration.camera.width, CV_8UC1, cv::Scalar(255));
  test::draw_tag_pinhole(out, fam, t, T_cam_ptag, st.calibration.camera, 24, 0, cv::INTER_AREA);
  cv::Mat bgr;
  cv::cvtColor(out, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

StationScene station() {
  StationScene st = default_station_scene();
  st.calibration.camera.dist = {0, 0, 0, 0, 0};
  return st;
}

TEST(PenTracking, MeasuresThePenFlagPose) {
  const StationScene st = station();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(0.35, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.02, -0.01, 0.22);
  const cv::Mat frame = pen_frame(st, T);
  TrackerOptions o;
  o.track_pen = true;
  auto tr = Tracker::create(st, o);
  ASSERT_TRUE(tr.ok()) << tr.error();
  for (int k = 0; k < 3; ++k) {  // the full-frame search, then the predicted regions
    auto f = tr->track(frame, k / 30.0, k / 30.0);
    ASSERT_TRUE(f.ok()) << f.error();
    EXPECT_EQ(f->pen.name, "pen");
    ASSERT_EQ(f->pen.state, TrackState::kTracking) << "frame " << k;
    EXPECT_EQ(f->pen.tags_used, 1);
    EXPECT_LT((f->pen.T_cam_body_measured.translation() - T.translation()).norm(), 1.5e-3) << "frame " << k;
    const double deg =
        Eigen::AngleAxisd(f->pen.T_cam_body_measured.linear().transpose() * T.linear()).angle() * 180 / M_PI;
    EXPECT_LT(deg, 1.5) << "frame " << k;
    EXPECT_EQ(f->mannequin.state, TrackState::kLost);
  }
}

TEST(PenTracking, OffByDefaultAndRefusedWithoutAPen) {
  StationScene st = station();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(0, 0, 0.2);
  auto tr = Tracker::create(st, TrackerOptions{});
  ASSERT_TRUE(tr.ok()) << tr.error();
  auto f = tr->track(pen_frame(st, T), 0, 0);
  ASSERT_TRUE(f.ok()) << f.error();
  EXPECT_EQ(f->pen.state, TrackState::kLost);
  EXPECT_GE(f->tags_detected, 1) << "the tag is in the picture, only the body is off";
  st.pen.tags.clear();
  TrackerOptions o;
  o.track_pen = true;
  auto bad = Tracker::create(st, o);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("pen"), std::string::npos) << bad.error();
}

}  // namespace
}  // namespace dentar::ar
