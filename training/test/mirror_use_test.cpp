// Mirror use: the four sightline classes on hand-built scenes with known
// answers, and "unavailable" (never zero) when no mirror was tracked. The
// frames.csv reader (offline and live layouts) is session's: session/test/frames_csv_test.cpp.
#include "dentar/training/mirror_use.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include "testutil.h"

namespace dentar::training {
namespace {

using Iso = Eigen::Isometry3d;

// Camera at c looking at `look` (tooth frame): T_tooth_cam.
Iso camera_at(const Eigen::Vector3d& c, const Eigen::Vector3d& look) {
  const Eigen::Vector3d z = (look - c).normalized();
  const Eigen::Vector3d x = z.unitOrthogonal();
  const Eigen::Vector3d y = z.cross(x);
  Iso T = Iso::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = y;
  T.linear().col(2) = z;
  T.translation() = c;
  return T;
}

// Mirror plane at m whose reflecting normal bisects the directions to the
// site p and to the camera c (the specular point is m): T_tooth_mir.
Iso mirror_between(const Eigen::Vector3d& m, const Eigen::Vector3d& p, const Eigen::Vector3d& c) {
  const Eigen::Vector3d n = ((p - m).normalized() + (c - m).normalized()).normalized();
  const Eigen::Vector3d x = n.unitOrthogonal();
  Iso T = Iso::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = n.cross(x);
  T.linear().col(2) = n;
  T.translation() = m;
  return T;
}

const Eigen::Vector3d kSite = Eigen::Vector3d::Zero();
const Eigen::Vector3d kUp = Eigen::Vector3d::UnitZ();

Sightline classify(const Eigen::Vector3d& cam, const std::optional<Iso>& T_tooth_mir, double radius = 0.011) {
  SightGeometry g;
  g.mirror_radius_m = radius;
  const Iso T_cam_tooth = camera_at(cam, T_tooth_mir ? T_tooth_mir->translation() : kSite).inverse();
  std::optional<Iso> T_cam_mir;
  if (T_tooth_mir) T_cam_mir = T_cam_tooth * *T_tooth_mir;
  return classify_sightline(g, kSite, kUp, T_cam_tooth, T_cam_mir);
}

TEST(MirrorUse, DirectViewFromAboveTheSurface) {
  EXPECT_EQ(classify({0, 0, 0.2}, std::nullopt), Sightline::kDirect);
  EXPECT_EQ(classify({0.1, 0.0, 0.1}, std::nullopt), Sightline::kDirect);  // 45 degrees
}

TEST(MirrorUse, NoViewFromBehindOrGrazing) {
  EXPECT_EQ(classify({0, 0, -0.2}, std::nullopt), Sightline::kNone);
  EXPECT_EQ(classify({0.3, 0, 0.01}, std::nullopt), Sightline::kNone);  // 88 degrees: grazing
}

TEST(MirrorUse, MirrorOnlyWhenTheCameraCannotSeeTheSurface) {
  const Eigen::Vector3d cam(0.3, 0, 0), m(0, 0, 0.02);
  EXPECT_EQ(classify(cam, mirror_between(m, kSite, cam)), Sightline::kMirror);
  // The same mirror turned away (reflecting face toward neither): no view.
  Iso flipped = mirror_between(m, kSite, cam);
  flipped.linear() = flipped.linear() * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  EXPECT_EQ(classify(cam, flipped), Sightline::kNone);
  // The plane unchanged but the disc moved 5 mm along it: the specular point
  // falls outside a 1 mm disc.
  Iso shifted = mirror_between(m, kSite, cam);
  shifted.translation() += 5e-3 * shifted.linear().col(0);
  EXPECT_EQ(classify(cam, shifted, 1e-3), Sightline::kNone);
  EXPECT_EQ(classify(cam, shifted, 8e-3), Sightline::kMirror);
}

TEST(MirrorUse, BothWhenDirectAndReflected) {
  const Eigen::Vector3d cam(0.3, 0, 0.3), m(0, 0, 0.02);
  EXPECT_EQ(classify(cam, mirror_between(m, kSite, cam)), Sightline::kBoth);
}

TEST(MirrorUse, FieldOfViewLimitsTheDirectView) {
  SightGeometry g;
  g.tan_half_fov_x = g.tan_half_fov_y = 0.1;  // about 11 degrees half angle
  // Camera above, looking 45 degrees away from the site.
  const Iso T_cam_tooth = camera_at({0, 0, 0.2}, {0.2, 0, 0}).inverse();
  EXPECT_EQ(classify_sightline(g, kSite, kUp, T_cam_tooth, std::nullopt), Sightline::kNone);
  g.tan_half_fov_x = g.tan_half_fov_y = 0;  // no field-of-view test
  EXPECT_EQ(classify_sightline(g, kSite, kUp, T_cam_tooth, std::nullopt), Sightline::kDirect);
}

SessionTrack still_track(int n) {
  SessionTrack t;
  t.rate_hz = 100;
  for (int i = 0; i < n; ++i) {
    t.t_s.push_back(0.01 * i);
    t.tip_m.emplace_back(0, 0, 0);
    t.axis.emplace_back(0, 0, -1);
    t.force_N.emplace_back(0, 0, 0);
    t.pedal.push_back(1);
    t.removed_mm3.push_back({});
    t.flags.push_back(0);
  }
  return t;
}

TEST(MirrorUse, UnavailableWithoutATrackedMirrorAndCountedWithOne) {
  auto ex = load_builtin_exercise("molar_access_opening");
  ASSERT_TRUE(ex.ok()) << ex.error();
  const SessionTrack t = still_track(100);
  const std::vector<int> steps(100, 0);
  SightGeometry g;
  std::vector<ViewFrame> frames(10);
  const Iso T_cam_tooth = camera_at({0.3, 0, 0}, {0, 0, 0.02}).inverse();
  for (int i = 0; i < 10; ++i) {
    frames[static_cast<std::size_t>(i)].session_s = 0.05 * i;
    frames[static_cast<std::size_t>(i)].pedal = true;
    frames[static_cast<std::size_t>(i)].T_cam_man = T_cam_tooth;  // T_man_tooth = identity
  }
  MirrorUse u = mirror_use(frames, g, t, *ex, steps);
  EXPECT_FALSE(u.available);
  EXPECT_NE(u.why.find("never tracked"), std::string::npos) << u.why;
  // The mirror held over the site in 6 of the 10 frames: 6 mirror, 4 none
  // (the camera is level with the occlusal surface and cannot see it).
  const Iso T_cam_mir = T_cam_tooth * mirror_between({0, 0, 0.02}, kSite, {0.3, 0, 0});
  for (int i = 0; i < 6; ++i) frames[static_cast<std::size_t>(i)].T_cam_mtag = T_cam_mir;  // T_mtag_mir = identity
  u = mirror_use(frames, g, t, *ex, steps);
  ASSERT_TRUE(u.available) << u.why;
  EXPECT_EQ(u.frames_tracked, 10);
  EXPECT_EQ(u.frames_mirror_tracked, 6);
  EXPECT_EQ(u.drilling[static_cast<int>(Sightline::kMirror)], 6);
  EXPECT_EQ(u.drilling[static_cast<int>(Sightline::kNone)], 4);
  EXPECT_NEAR(u.drilling_pct(Sightline::kMirror), 60.0, 1e-9);
  EXPECT_EQ(u.by_step[0][static_cast<int>(Sightline::kMirror)], 6);
}

}  // namespace
}  // namespace dentar::training
