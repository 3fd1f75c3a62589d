// Station health: the file checks (age, check, camera), a moved mannequin tag found from the
// detections alone, and the stylus tip at the health divot.
#include "dentar/live/station_health.h"

#include <gtest/gtest.h>

#include <random>

#include "dentar/ar/camera_model.h"

namespace dentar::live {
namespace {

constexpr double kDay = 86400;
// 2026-11-25T12:00:00Z
constexpr double kNow = 1795608000;

ar::StationScene calibrated(const std::string& date) {
  ar::StationScene st = ar::default_station_scene();
  for (const char* step : {"camera", "pivot", "register", "tooth", "mirror", "check"})
    st.set_step_report({step, date, true, "", {}});
  return st;
}

const HealthItem* find(const std::vector<HealthItem>& v, const std::string& check) {
  for (const auto& i : v)
    if (i.check == check) return &i;
  return nullptr;
}

TEST(StationHealth, AgeParsesIsoDates) {
  EXPECT_NEAR(*age_days("2026-11-25T12:00:00Z", kNow), 0.0, 1e-9);
  EXPECT_NEAR(*age_days("2026-10-26T12:00:00Z", kNow), 30.0, 1e-9);
  EXPECT_FALSE(age_days("yesterday", kNow));
  EXPECT_FALSE(age_days("2026-13-01T00:00:00Z", kNow));
}

TEST(StationHealth, FreshCheckedStationIsOk) {
  const auto items = check_station_file(calibrated("2026-11-20T09:00:00Z"), false, kNow, "");
  for (const auto& i : items) EXPECT_EQ(i.level, HealthLevel::kOk) << i.check << ": " << i.message;
  ASSERT_TRUE(find(items, "calibration age"));
  EXPECT_NE(find(items, "calibration age")->message.find("calibrated 5 days ago"), std::string::npos);
}

TEST(StationHealth, OldUncheckedOrFailedStationsNeedAnInstructor) {
  StationHealth h;
  for (const auto& i : check_station_file(calibrated("2026-09-01T09:00:00Z"), false, kNow, "")) h.set(i);
  EXPECT_TRUE(h.instructor_needed());
  EXPECT_NE(h.headline().find("INSTRUCTOR NEEDED: calibration age: calibrated 85 days ago"), std::string::npos)
      << h.headline();
  EXPECT_NE(h.headline().find("max_age_days"), std::string::npos);
  // A station policy with a longer limit accepts it.
  ar::StationScene st = calibrated("2026-09-01T09:00:00Z");
  st.policy.max_age_days = 120;
  EXPECT_EQ(find(check_station_file(st, false, kNow, ""), "calibration age")->level, HealthLevel::kOk);
  // Never calibrated.
  const auto none = check_station_file(ar::default_station_scene(), false, kNow, "");
  EXPECT_EQ(find(none, "calibration age")->level, HealthLevel::kInstructor);
  // Check failed.
  st = calibrated("2026-11-20T09:00:00Z");
  st.set_step_report({"check", "2026-11-20T09:30:00Z", false, "", {}});
  auto items = check_station_file(st, false, kNow, "");
  EXPECT_EQ(find(items, "station check")->level, HealthLevel::kInstructor);
  EXPECT_NE(find(items, "station check")->message.find("FAILED"), std::string::npos);
  // A step redone after the check: a warning.
  st = calibrated("2026-11-20T09:00:00Z");
  st.set_step_report({"pivot", "2026-11-21T09:00:00Z", true, "", {}});
  items = check_station_file(st, false, kNow, "");
  EXPECT_EQ(find(items, "station check")->level, HealthLevel::kWarning);
  EXPECT_NE(find(items, "station check")->message.find("pivot step was redone"), std::string::npos);
  // A built-in station: one note, "uncalibrated (built-in intrinsics)", no warning, no alarm.
  items = check_station_file(ar::default_station_scene(), true, kNow, "");
  ASSERT_EQ(items.size(), 1u);
  EXPECT_EQ(items[0].level, HealthLevel::kNote);
  StationHealthMonitor builtin(ar::box_station_scene(), true, kNow, "");
  const StationHealth bh = builtin.health();
  EXPECT_FALSE(bh.instructor_needed());
  EXPECT_EQ(bh.worst(), HealthLevel::kNote);
  EXPECT_EQ(bh.headline().rfind("station: uncalibrated (built-in intrinsics)", 0), 0u) << bh.headline();
}

TEST(StationHealth, StationFileOfAnotherCameraIsRefused) {
  ar::StationScene st = calibrated("2026-11-20T09:00:00Z");
  st.camera_provenance.device_id = "footage camA/video.mkv";
  StationHealthMonitor same(st, false, kNow, "footage camA/video.mkv");
  EXPECT_FALSE(same.refusal());
  StationHealthMonitor other(st, false, kNow, "footage camB/video.mkv");
  ASSERT_TRUE(other.refusal());
  EXPECT_NE(other.refusal()->message.find("calibrated with camera \"footage camA/video.mkv\""), std::string::npos);
  EXPECT_NE(other.refusal()->message.find("this camera is \"footage camB/video.mkv\""), std::string::npos);
  EXPECT_EQ(camera_identity("live:/x/clipB/video.mkv"), "footage clipB/video.mkv");
}

// Detections of the default head's tags seen from the front, through the station camera;
// `moved` shifts one tag's true position (man frame) before projecting.
std::vector<ar::DetectedTag> detections(const ar::StationScene& st, const Eigen::Isometry3d& T_cam_man, int moved_id,
                                        const Eigen::Vector3d& shift, std::mt19937_64& rng) {
  const ar::CameraModel cam(st.calibration.camera);
  std::normal_distribution<double> n(0, 0.1);
  std::vector<ar::DetectedTag> out;
  for (const auto& t : st.mannequin_tags) {
    const Eigen::Vector3d centre_cam = T_cam_man * t.T_parent_tag.translation();
    const Eigen::Vector3d into_tag = T_cam_man.linear() * t.T_parent_tag.linear().col(2);
    if (into_tag.dot(centre_cam.normalized()) < 0.3) continue;  // facing away or grazing
    ar::DetectedTag d;
    d.family = st.family;
    d.id = t.id;
    bool ok = true;
    for (int c = 0; c < 4; ++c) {
      Eigen::Vector3d p = t.corner(c);
      if (t.id == moved_id) p += shift;
      const auto q = cam.project(T_cam_man * p);
      if (!q || q->x() < 0 || q->y() < 0 || q->x() > st.calibration.camera.width || q->y() > st.calibration.camera.height)
        ok = false;
      else
        d.corners_px[static_cast<std::size_t>(c)] = *q + Eigen::Vector2d(n(rng), n(rng));
    }
    if (ok) out.push_back(d);
  }
  return out;
}

TEST(StationHealth, MovedMannequinTagIsNamed) {
  const ar::StationScene st = calibrated("2026-11-20T09:00:00Z");
  std::mt19937_64 rng(5);
  Eigen::Isometry3d T_man_cam = Eigen::Isometry3d::Identity();
  T_man_cam.linear() = Eigen::Vector3d(1, -1, -1).asDiagonal();
  T_man_cam.translation() = Eigen::Vector3d(0.0, 0.02, 0.33);
  // Untouched layout: every tag in place.
  {
    TagLayoutCheck chk(st, 10);
    for (int f = 0; f < 10; ++f) {
      const Eigen::Isometry3d T = T_man_cam * Eigen::AngleAxisd(0.02 * f, Eigen::Vector3d::UnitY());
      chk.add(detections(st, T.inverse(), -1, {}, rng));
    }
    ASSERT_TRUE(chk.done()) << chk.frames();
    const HealthItem r = chk.result();
    EXPECT_EQ(r.level, HealthLevel::kOk) << r.message;
    EXPECT_GE(chk.displacement_m().size(), 4u);
  }
  // One tag moved by 3 mm.
  const auto first = detections(st, T_man_cam.inverse(), -1, {}, rng);
  ASSERT_GE(first.size(), 4u);
  const int moved = first[1].id;
  TagLayoutCheck chk(st, 10);
  for (int f = 0; f < 10; ++f) {
    const Eigen::Isometry3d T = T_man_cam * Eigen::AngleAxisd(0.02 * f, Eigen::Vector3d::UnitY());
    chk.add(detections(st, T.inverse(), moved, Eigen::Vector3d(0.003, 0, 0), rng));
  }
  const HealthItem r = chk.result();
  EXPECT_EQ(r.level, HealthLevel::kInstructor);
  EXPECT_NE(r.message.find("mannequin tag " + std::to_string(moved) + " ("), std::string::npos) << r.message;
  const double d = chk.displacement_m().at(moved);
  EXPECT_GT(d, 2.0e-3);
  EXPECT_LT(d, 4.0e-3);
  for (const auto& [id, disp] : chk.displacement_m()) {
    if (id != moved) {
      EXPECT_LT(disp, st.policy.tag_moved_m) << "tag " << id;
    }
  }
}

TEST(StationHealth, OnABuiltInStationAMovedTagIsAWarningNotTheAlarm) {
  // The same 3 mm displacement as above, on the built-in station (nothing was calibrated for
  // this bench: a kit taped by hand sits elsewhere than the built-in layout).
  const ar::StationScene st = ar::default_station_scene();
  std::mt19937_64 rng(5);
  Eigen::Isometry3d T_man_cam = Eigen::Isometry3d::Identity();
  T_man_cam.linear() = Eigen::Vector3d(1, -1, -1).asDiagonal();
  T_man_cam.translation() = Eigen::Vector3d(0.0, 0.02, 0.33);
  const auto first = detections(st, T_man_cam.inverse(), -1, {}, rng);
  ASSERT_GE(first.size(), 4u);
  const int moved = first[1].id;
  for (bool builtin : {false, true}) {
    StationHealthMonitor mon(st, builtin, kNow, "");
    for (int f = 0; f < 10; ++f) {
      const Eigen::Isometry3d T = T_man_cam * Eigen::AngleAxisd(0.02 * f, Eigen::Vector3d::UnitY());
      mon.on_frame(detections(st, T.inverse(), moved, Eigen::Vector3d(0.003, 0, 0), rng), f / 30.0,
                   Eigen::Isometry3d::Identity(), false);
    }
    const StationHealth h = mon.health();
    const HealthItem* layout = find(h.items, "tag layout");
    ASSERT_TRUE(layout);
    EXPECT_NE(layout->message.find("mannequin tag " + std::to_string(moved) + " ("), std::string::npos);
    if (builtin) {
      EXPECT_EQ(layout->level, HealthLevel::kWarning) << layout->message;
      EXPECT_FALSE(h.instructor_needed());
      EXPECT_EQ(h.headline().find("INSTRUCTOR"), std::string::npos) << h.headline();
      EXPECT_NE(layout->message.find("placed approximately"), std::string::npos) << layout->message;
    } else {
      EXPECT_EQ(layout->level, HealthLevel::kInstructor);
      EXPECT_TRUE(h.instructor_needed());
    }
  }
}

TEST(StationHealth, StylusTipAtTheHealthDivot) {
  const ar::StationScene st = calibrated("2026-11-20T09:00:00Z");
  const auto& c = st.calibration;
  const Eigen::Vector3d divot = st.fixtures.divots_man[0];
  // A stylus pose whose calibrated tip lands at `p` (man frame).
  auto pose_for = [&](const Eigen::Vector3d& p) {
    Eigen::Isometry3d T_man_sty = Eigen::Isometry3d::Identity();
    T_man_sty.linear() = Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitX()).toRotationMatrix();
    T_man_sty.translation() = p - T_man_sty.linear() * c.T_sty_tip.translation();
    return Eigen::Isometry3d(c.T_man_dev.inverse() * T_man_sty);
  };
  std::mt19937_64 rng(2);
  std::normal_distribution<double> n(0, 0.03e-3);
  auto noisy = [&](const Eigen::Vector3d& p) -> Eigen::Vector3d { return p + Eigen::Vector3d(n(rng), n(rng), n(rng)); };
  // Held still 0.3 mm off: ok.
  {
    DivotTouchCheck chk(st);
    ASSERT_TRUE(chk.available());
    std::optional<HealthItem> r;
    for (int i = 0; i < 40 && !r; ++i) r = chk.add(i / 30.0, pose_for(noisy(divot + Eigen::Vector3d(0.3e-3, 0, 0))), true);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->level, HealthLevel::kOk) << r->message;
    EXPECT_NEAR(chk.error_m(), 0.3e-3, 0.05e-3);
  }
  // Held still 2.5 mm off (the bur was changed for a longer one): an instructor.
  {
    DivotTouchCheck chk(st);
    std::optional<HealthItem> r;
    for (int i = 0; i < 40 && !r; ++i) r = chk.add(i / 30.0, pose_for(noisy(divot + Eigen::Vector3d(0, 0, 2.5e-3))), true);
    ASSERT_TRUE(r) << "tip " << ((c.T_man_dev * pose_for(divot + Eigen::Vector3d(0, 0, 2.5e-3)) * c.T_sty_tip).translation() - divot).transpose();
    EXPECT_EQ(r->level, HealthLevel::kInstructor);
    EXPECT_NE(r->message.find(" mm from divot 0 (limit 1.00 mm"), std::string::npos) << r->message;
    EXPECT_NEAR(chk.error_m(), 2.5e-3, 0.05e-3);
    EXPECT_NE(r->message.find("pivot and register"), std::string::npos);
  }
  // Moving through the divot, or invalid poses: no touch is taken.
  {
    DivotTouchCheck chk(st);
    for (int i = 0; i < 60; ++i) {
      const Eigen::Vector3d p = divot + Eigen::Vector3d(-3e-3 + 0.1e-3 * i, 0, 0);
      EXPECT_FALSE(chk.add(i / 30.0, pose_for(p), true));
    }
    for (int i = 0; i < 60; ++i) EXPECT_FALSE(chk.add(2 + i / 30.0, pose_for(divot), false));
    EXPECT_FALSE(chk.done());
  }
}

}  // namespace
}  // namespace dentar::live

namespace dentar::live {
namespace {

// Issue 24: every built-in station's device placement reaches the whole crown with the common
// profiles (Touch, Omni, Falcon), and every other profile too.
TEST(StationReach, BuiltInStationsAreReachableByEveryProfile) {
  for (const char* name : {"default", "box"}) {
    const ar::StationScene st = *ar::builtin_station_scene(name);
    const auto box = crown_box_tooth(st);
    ASSERT_TRUE(box.ok()) << box.error();
    // The crown: about 11 x 11 mm, 7 mm high, on the tooth frame's cervical plane.
    EXPECT_NEAR(box->max().z() - box->min().z(), 7e-3, 0.2e-3);
    EXPECT_GT(box->sizes().x(), 8e-3);
    for (const auto& p : haptics::device_profiles()) {
      const StationReach r = check_station_reach(st, haptics::limits_from_profile(p), p.display_name, *box);
      EXPECT_TRUE(r.reach.reachable) << name << " / " << p.id << ": " << r.item.message;
      EXPECT_EQ(r.item.level, HealthLevel::kOk) << name << " / " << p.id;
      EXPECT_NE(r.item.message.find("reaches the whole crown"), std::string::npos) << r.item.message;
      EXPECT_EQ(r.move_man_m.norm(), 0.0);
    }
  }
}

// The reach check follows the tooth a session drills (`dentar live --exercise`): the incisor's
// crown, 10.5 mm long and 8.5 mm wide, on the same cervical plane; a description without a known
// kind is an error naming it. The molar's box from its description is the station's.
TEST(StationReach, CrownBoxFollowsTheTooth) {
  const ar::StationScene st = ar::default_station_scene();
  const auto molar = crown_box_tooth(st);
  const auto molar_desc = crown_box_tooth(R"({"kind":"molar","voxel_mm":0.1})");
  ASSERT_TRUE(molar.ok() && molar_desc.ok());
  EXPECT_TRUE(molar->min().isApprox(molar_desc->min()) && molar->max().isApprox(molar_desc->max()));
  const auto inc = crown_box_tooth(R"({"kind":"incisor","voxel_mm":0.1})");
  ASSERT_TRUE(inc.ok()) << inc.error();
  EXPECT_NEAR(inc->max().z() - inc->min().z(), 10.5e-3, 0.3e-3);
  EXPECT_NEAR(inc->min().z(), 0.0, 0.3e-3);  // the cervical plane
  EXPECT_NEAR(inc->sizes().x(), 8.5e-3, 0.5e-3);
  EXPECT_LT(inc->sizes().y(), molar->sizes().y());
  for (const auto& p : haptics::device_profiles()) {
    const StationReach r = check_station_reach(st, haptics::limits_from_profile(p), p.display_name, *inc);
    EXPECT_TRUE(r.reach.reachable) << p.id << ": " << r.item.message;
  }
  const auto bad = crown_box_tooth(R"({"kind":"canine","voxel_mm":0.1})");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("canine"), std::string::npos) << bad.error();
}

// A device that stands too far gets the move in the instructor's words, and making that move
// makes the crown reachable.
TEST(StationReach, UnreachableStationSaysHowFarAndWhere) {
  ar::StationScene st = ar::default_station_scene();
  const auto box = crown_box_tooth(st);
  ASSERT_TRUE(box.ok()) << box.error();
  const haptics::DeviceProfile& touch = *haptics::find_device_profile("touch");
  const haptics::DeviceLimits L = haptics::limits_from_profile(touch);
  // The device 120 mm toward the patient's right and 40 mm lower than the built-in placement.
  st.calibration.T_man_dev = Eigen::Translation3d(-0.12, -0.04, 0) * st.calibration.T_man_dev;
  StationReach r = check_station_reach(st, L, touch.display_name, *box);
  EXPECT_FALSE(r.reach.reachable);
  EXPECT_EQ(r.item.level, HealthLevel::kInstructor);
  EXPECT_EQ(r.item.check, "stylus reach");
  const std::string& m = r.item.message;
  EXPECT_NE(m.find("3D Systems Touch cannot reach the whole crown"), std::string::npos) << m;
  EXPECT_NE(m.find("mm toward the patient's left"), std::string::npos) << m;
  EXPECT_NE(m.find("mm up"), std::string::npos) << m;
  EXPECT_NE(m.find("(mannequin frame)"), std::string::npos) << m;
  EXPECT_NE(m.find("dentar calibrate register"), std::string::npos) << m;
  EXPECT_GT(r.move_man_m.x(), 0);
  EXPECT_GT(r.move_man_m.y(), 0);
  // The move needed: the farthest point's excess over the reach plus the margin, at least.
  EXPECT_GE(r.move_man_m.norm(), r.reach.worst_distance_m - r.reach.reach_m + haptics::kReachMargin_m - 1e-6);
  st.calibration.T_man_dev = Eigen::Translation3d(r.move_man_m) * st.calibration.T_man_dev;
  r = check_station_reach(st, L, touch.display_name, *box);
  EXPECT_TRUE(r.reach.reachable) << r.item.message;
  EXPECT_NEAR(r.reach.reach_m - r.reach.worst_distance_m, haptics::kReachMargin_m, 1e-6);

  // The box station speaks of the board: its device lifted 100 mm too high.
  ar::StationScene bs = ar::box_station_scene();
  bs.calibration.T_man_dev = Eigen::Translation3d(0, 0, 0.10) * bs.calibration.T_man_dev;
  const haptics::DeviceProfile& falcon = *haptics::find_device_profile("falcon");
  r = check_station_reach(bs, haptics::limits_from_profile(falcon), falcon.display_name, *box);
  EXPECT_FALSE(r.reach.reachable);
  EXPECT_NE(r.item.message.find("mm down toward the board (board frame)"), std::string::npos) << r.item.message;
  EXPECT_EQ(r.item.message.find("patient"), std::string::npos) << r.item.message;
}

TEST(StationReach, DescribeMoveLeavesOutSmallComponents) {
  const ar::StationScene st = ar::default_station_scene();
  EXPECT_EQ(describe_move_man(st, Eigen::Vector3d(0.03, -0.0004, -0.04)),
            "50 mm: 30 mm toward the patient's left, 40 mm back toward the head (mannequin frame)");
}

}  // namespace
}  // namespace dentar::live
