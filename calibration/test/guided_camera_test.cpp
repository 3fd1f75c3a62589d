// LiveCameraViews (the live camera step's bookkeeping) on projected board points: each refusal
// with its reason, the running calibration after the sixth view, coverage and the suggestion.
#include <gtest/gtest.h>

#include <random>

#include "dentar/calibration/guided.h"

namespace cal = dentar::calibration;

namespace {

cal::CameraIntrinsics camera() {
  cal::CameraIntrinsics k;
  k.width = 640;
  k.height = 480;
  k.fx = 600;
  k.fy = 601;
  k.cx = 322;
  k.cy = 238;
  k.dist = {-0.12, 0.05, 0, 0, 0};
  return k;
}

cal::BoardView view_at(const cal::CameraIntrinsics& k, const Eigen::Isometry3d& T, std::mt19937_64& rng,
                       double noise_px = 0.1) {
  cal::AprilGridSpec g;
  std::normal_distribution<double> n(0, noise_px);
  cal::BoardView v;
  for (int id = 0; id < g.tag_count(); ++id)
    for (const auto& p : g.tag_corners(id)) {
      Eigen::Vector2d px;
      if (!cal::project_point(k, T * p, px)) continue;
      if (px.x() < 0 || px.y() < 0 || px.x() > k.width - 1 || px.y() > k.height - 1) continue;
      v.image_points.push_back(px + Eigen::Vector2d(n(rng), n(rng)));
      v.object_points.push_back(p);
    }
  return v;
}

// The board held still at T for `secs` (10 frames/s) starting at t.
double hold(cal::LiveCameraViews& c, const cal::CameraIntrinsics& k, const Eigen::Isometry3d& T, double t, double secs,
            std::mt19937_64& rng, double sharpness = 100) {
  for (double s = 0; s < secs; s += 0.1) {
    const cal::BoardView v = view_at(k, T, rng, 0.02);
    c.add_frame(t + s, &v, "", sharpness);
  }
  return t + secs;
}

}  // namespace

TEST(LiveCameraViews, RefusesWithTheReasonAndCalibratesFromTheSixthView) {
  const cal::CameraIntrinsics k = camera();
  cal::AprilGridSpec g;
  const auto poses = cal::plan_board_poses(k, g.width_m(), g.height_m(), 12, 5);
  std::mt19937_64 rng(1);
  cal::LiveCameraViews c(k.width, k.height);

  // Not found.
  c.add_frame(0, nullptr, "board not found in the live view", 0);
  auto r = c.take();
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("board not found"), std::string::npos) << r.message;

  // Moving: the board slides 30 px per frame.
  double t = 1;
  for (int i = 0; i < 5; ++i, t += 0.1) {
    Eigen::Isometry3d T = poses[0];
    T.translation().x() += 0.004 * i;
    const cal::BoardView v = view_at(k, T, rng);
    c.add_frame(t, &v, "", 100);
  }
  r = c.take();
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("moved"), std::string::npos) << r.message;
  EXPECT_FALSE(c.still());

  // Still: taken.
  t = hold(c, k, poses[0], t, 0.6, rng);
  EXPECT_TRUE(c.still());
  r = c.take();
  EXPECT_TRUE(r.ok) << r.message;
  EXPECT_EQ(c.views(), 1);

  // The same place again: too similar.
  t = hold(c, k, poses[0], t + 1, 0.6, rng);
  r = c.take();
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("too similar to view 1"), std::string::npos) << r.message;

  // Blurred: a focus measure a fifth of the views taken.
  t = hold(c, k, poses[1], t + 1, 0.6, rng, 20);
  r = c.take();
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("blurred"), std::string::npos) << r.message;

  // The wrong board: the points' board positions shuffled (another layout).
  {
    cal::BoardView v = view_at(k, poses[1], rng, 0.02);
    std::reverse(v.object_points.begin(), v.object_points.begin() + v.object_points.size() / 2);
    for (int i = 0; i < 6; ++i) c.add_frame(t + 1 + 0.1 * i, &v, "", 100);
    t += 2;
    EXPECT_FALSE(c.last_layout_ok());
    r = c.take();
    EXPECT_FALSE(r.ok);
    EXPECT_NE(r.message.find("wrong board"), std::string::npos) << r.message;
  }

  // Views 2..6: the running calibration appears at the sixth.
  for (int i = 1; i < 6; ++i) {
    EXPECT_FALSE(c.running().calibrations_run > 0) << i;
    t = hold(c, k, poses[static_cast<std::size_t>(i)], t + 1, 0.6, rng);
    r = c.take();
    ASSERT_TRUE(r.ok) << i << ": " << r.message;
  }
  EXPECT_EQ(c.views(), 6);
  ASSERT_GT(c.running().calibrations_run, 0);
  ASSERT_GE(c.running().std_devs.size(), 4u);
  EXPECT_NEAR(c.running().camera.fx, k.fx, 5 * c.running().std_devs[0] + 0.5);
  EXPECT_LT(c.running().rms_px, 0.1);
  EXPECT_EQ(c.refused(), 5);
  // Coverage of the taken views, and a suggestion toward what is missing (before the target).
  const cal::CoverageMap cm = c.coverage();
  EXPECT_GT(cm.image_fraction, 0.3);
  int col = -1, row = -1;
  std::string text;
  EXPECT_TRUE(c.suggestion(col, row, text));
  EXPECT_GE(col, 0);
  EXPECT_NE(text.find("hold the board over the"), std::string::npos) << text;
  EXPECT_FALSE(c.done());
}

TEST(LiveCameraViews, StopsItselfWhenTheTrustMapCoversTheImage) {
  const cal::CameraIntrinsics k = camera();
  cal::AprilGridSpec g;
  cal::LiveCameraOptions o;
  o.target_views = 8;
  const auto poses = cal::plan_board_poses(k, g.width_m(), g.height_m(), 10, 9);
  std::mt19937_64 rng(2);
  cal::LiveCameraViews c(k.width, k.height, o);
  double t = 0;
  for (int i = 0; i < 8; ++i) {
    t = hold(c, k, poses[static_cast<std::size_t>(i)], t + 1, 0.6, rng);
    ASSERT_TRUE(c.take().ok) << i;
  }
  EXPECT_FALSE(c.done());  // no trust map for these views yet
  cal::TrustMap tm;
  tm.cols = o.intrinsics.coverage_cols;
  tm.rows = o.intrinsics.coverage_rows;
  tm.trusted.assign(tm.cols * tm.rows, 1);
  tm.extrapolated.assign(tm.cols * tm.rows, 0);
  tm.trusted_fraction = 1;
  tm.tooth_trusted_fraction = 1;
  c.set_trust(tm, 7);
  EXPECT_FALSE(c.done());  // the map is for fewer views than taken
  c.set_trust(tm, 8);
  EXPECT_TRUE(c.done());
  int col, row;
  std::string text;
  EXPECT_FALSE(c.suggestion(col, row, text));
  // An untrusted corner: suggested, not done.
  tm.trusted[0] = 0;
  tm.trusted_fraction = 1 - 1.0 / (tm.cols * tm.rows);
  o.done_trusted_fraction = 1.0;
  cal::LiveCameraViews c2(k.width, k.height, o);
  t = 0;
  for (int i = 0; i < 8; ++i) {
    t = hold(c2, k, poses[static_cast<std::size_t>(i)], t + 1, 0.6, rng);
    ASSERT_TRUE(c2.take().ok) << i;
  }
  c2.set_trust(tm, 8);
  EXPECT_FALSE(c2.done());
  ASSERT_TRUE(c2.suggestion(col, row, text));
  EXPECT_EQ(col, 0);
  EXPECT_EQ(row, 0);
  EXPECT_NE(text.find("top-left corner"), std::string::npos) << text;
}
