// The layout of a lesson's note beside the tooth (note_label.h): inside the frame wherever
// the anchor is, wrapped to the frame's width, on the side with room.
#include "dentar/ar/note_label.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "dentar/ar/station_scene.h"

namespace dentar::ar {
namespace {

const cv::Rect kFrame(0, 0, 1280, 720);

bool inside(const cv::Rect& r) { return (r & kFrame) == r && r.area() > 0; }

TEST(NoteLabel, BesideTheAnchorAndInsideTheFrame) {
  const NoteLabelLayout l =
      layout_note_label("keep the bur upright", Eigen::Vector2d(640, 360), kFrame.size());
  ASSERT_EQ(l.lines.size(), 1u);
  EXPECT_TRUE(inside(l.box));
  EXPECT_GT(l.box.x, 640);       // to the right
  EXPECT_LT(l.box.br().y, 360);  // above
  EXPECT_TRUE(l.box.contains(l.leader_end));
  // At the right edge: to the left of the anchor; at the top: below it; far outside: clamped.
  const NoteLabelLayout r =
      layout_note_label("keep the bur upright", Eigen::Vector2d(1270, 20), kFrame.size());
  EXPECT_TRUE(inside(r.box));
  EXPECT_LT(r.box.br().x, 1270);
  EXPECT_GT(r.box.y, 20);
  for (const Eigen::Vector2d a : {Eigen::Vector2d(-5000, -5000), Eigen::Vector2d(9000, 9000),
                                  Eigen::Vector2d(std::nan(""), 1e300)}) {
    const NoteLabelLayout o = layout_note_label("x", a, kFrame.size());
    EXPECT_TRUE(inside(o.box)) << a.transpose();
    EXPECT_TRUE(o.box.contains(o.leader_end));
  }
}

TEST(NoteLabel, LongTextWrapsWithinFortyPercentAndIsCutAtFourLines) {
  std::string text;
  for (int i = 0; i < 60; ++i) text += "word" + std::to_string(i) + " ";
  const NoteLabelLayout l = layout_note_label(text, Eigen::Vector2d(100, 600), kFrame.size());
  EXPECT_EQ(l.lines.size(), 4u);
  EXPECT_EQ(l.lines.back().substr(l.lines.back().size() - 3), "...");
  EXPECT_LE(l.box.width, static_cast<int>(0.4 * kFrame.width));
  EXPECT_TRUE(inside(l.box));
  // Drawn: the box holds the background colour; nothing is drawn on an empty image.
  cv::Mat img(kFrame.size(), CV_8UC3, cv::Scalar::all(0));
  draw_note_label(img, l);
  const NoteLabelStyle st;
  EXPECT_EQ(img.at<cv::Vec3b>(l.box.y + 2, l.box.x + 2),
            cv::Vec3b(static_cast<uchar>(st.background[0]), static_cast<uchar>(st.background[1]),
                      static_cast<uchar>(st.background[2])));
  cv::Mat none;
  draw_note_label(none, l);
  EXPECT_TRUE(none.empty());
}

TEST(NoteLabel, ToothCentreProjectsThroughTheStation) {
  const StationScene st = default_station_scene();
  // The camera looking at the tooth from 0.3 m: the centre projects to the principal point.
  Eigen::Isometry3d T_cam_tooth = Eigen::Isometry3d::Identity();
  T_cam_tooth.translation() = Eigen::Vector3d(0, 0, 0.3);
  const Eigen::Isometry3d T_cam_man = T_cam_tooth * st.calibration.T_man_tooth.inverse();
  const auto c = tooth_centre_px(st, T_cam_man);
  ASSERT_TRUE(c.has_value());
  EXPECT_NEAR(c->x(), st.calibration.camera.cx, 1e-6);
  EXPECT_NEAR(c->y(), st.calibration.camera.cy, 1e-6);
  T_cam_tooth.translation() = Eigen::Vector3d(0, 0, -0.3);  // behind the camera
  EXPECT_FALSE(tooth_centre_px(st, T_cam_tooth * st.calibration.T_man_tooth.inverse()).has_value());
}

}  // namespace
}  // namespace dentar::ar
