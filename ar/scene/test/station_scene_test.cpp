// Station scene JSON: round trip, the shipped default kept in sync, and
// errors that name the file and the field.
#include "dentar/ar/station_scene.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "testutil.h"

namespace dentar::ar {
namespace {

void expect_near(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, const char* what) {
  EXPECT_LT((a.matrix() - b.matrix()).cwiseAbs().maxCoeff(), 1e-12) << what;
}

void expect_same(const StationScene& a, const StationScene& b) {
  EXPECT_EQ(a.name, b.name);
  EXPECT_EQ(a.family, b.family);
  const auto &ka = a.calibration.camera, &kb = b.calibration.camera;
  EXPECT_EQ(ka.width, kb.width);
  EXPECT_EQ(ka.height, kb.height);
  EXPECT_DOUBLE_EQ(ka.fx, kb.fx);
  EXPECT_DOUBLE_EQ(ka.cy, kb.cy);
  EXPECT_EQ(ka.dist, kb.dist);
  expect_near(a.calibration.T_man_tooth, b.calibration.T_man_tooth, "T_man_tooth");
  expect_near(a.calibration.T_man_dev, b.calibration.T_man_dev, "T_man_dev");
  expect_near(a.calibration.T_sty_tip, b.calibration.T_sty_tip, "T_sty_tip");
  expect_near(a.calibration.T_mtag_mir, b.calibration.T_mtag_mir, "T_mtag_mir");
  EXPECT_NEAR(a.calibration.mirror_radius_m, b.calibration.mirror_radius_m, 1e-15);
  ASSERT_EQ(a.mannequin_tags.size(), b.mannequin_tags.size());
  ASSERT_EQ(a.mirror_tags.size(), b.mirror_tags.size());
  for (std::size_t i = 0; i < a.mannequin_tags.size(); ++i) {
    EXPECT_EQ(a.mannequin_tags[i].id, b.mannequin_tags[i].id);
    EXPECT_NEAR(a.mannequin_tags[i].size_m, b.mannequin_tags[i].size_m, 1e-15);
    expect_near(a.mannequin_tags[i].T_parent_tag, b.mannequin_tags[i].T_parent_tag, "T_man_tag");
  }
  for (std::size_t i = 0; i < a.mirror_tags.size(); ++i)
    expect_near(a.mirror_tags[i].T_parent_tag, b.mirror_tags[i].T_parent_tag, "T_mtag_tag");
  EXPECT_LT((a.mannequin.head_radii_m - b.mannequin.head_radii_m).norm(), 1e-15);
  EXPECT_NEAR(a.mirror.paddle_thickness_m, b.mirror.paddle_thickness_m, 1e-15);
  EXPECT_NEAR(a.mirror.paddle_roof_rad, b.mirror.paddle_roof_rad, 1e-15);
  EXPECT_NEAR(a.mirror.paddle_height_m, b.mirror.paddle_height_m, 1e-15);
  EXPECT_NEAR(a.tooth_voxel_m, b.tooth_voxel_m, 1e-15);
}

TEST(StationScene, DefaultIsValidWithTwelveHeadTags) {
  const StationScene s = default_station_scene();
  EXPECT_EQ(s.validate(), "");
  EXPECT_EQ(s.mannequin_tags.size(), 12u);
  EXPECT_EQ(s.family, TagFamilyId::kStandard41h12);
  // Tags lie just outside the head, facing out (z into the tag = inward).
  const auto& m = s.mannequin;
  for (const auto& t : s.mannequin_tags) {
    const Eigen::Vector3d p = t.T_parent_tag.translation() - m.head_centre_m;
    const double q = p.cwiseQuotient(m.head_radii_m).squaredNorm();
    EXPECT_GT(q, 1.0) << t.id;
    EXPECT_LT(t.T_parent_tag.linear().col(2).dot(p), 0.0) << t.id;
  }
  // The haptic device is where haptics::default_station puts it.
  EXPECT_LT((s.calibration.T_tooth_dev().translation() - Eigen::Vector3d(0, 0, 0.028)).norm(), 1e-12);
  // The box station (issue 24): the device's workspace centre 60 mm over the board's centre.
  const StationScene box = box_station_scene();
  EXPECT_LT((box.calibration.T_man_dev.translation() - Eigen::Vector3d(0, 0, 0.060)).norm(), 1e-12);
  EXPECT_NEAR((box.calibration.T_man_dev.linear() * Eigen::Vector3d::UnitY()).z(), 1.0, 1e-12);  // dev y up
}

// The head layouts (issue 16): kWrap20 is kFront12 (the default's) plus ids 12..19;
// kFront12Large is kFront12 with larger forehead (16 mm) and brow (18 mm) tags; no id
// is the mirror's or the pen's; the printed patterns (9/5 of the border: 25.2 mm for a
// 14 mm tagStandard41h12) do not overlap, stay off the open mouth and the plates
// (pattern + quiet zone, 11/5 of the border) clear of the calibration divots the
// stylus must reach.
TEST(StationScene, HeadLayoutsPrintableAndClear) {
  const StationScene front = default_station_scene();
  StationScene wrap = default_station_scene(), large = default_station_scene();
  set_mannequin_layout(wrap, MannequinLayout::kWrap20);
  set_mannequin_layout(large, MannequinLayout::kFront12Large);
  ASSERT_EQ(front.mannequin_tags.size(), 12u);
  ASSERT_EQ(wrap.mannequin_tags.size(), 20u);
  ASSERT_EQ(large.mannequin_tags.size(), 12u);
  // kFront12Large: the same ids and centres; forehead 16 mm, brow 18 mm, the rest 14 mm.
  for (std::size_t i = 0; i < 12; ++i) {
    const TagPlacement &a = front.mannequin_tags[i], &b = large.mannequin_tags[i];
    EXPECT_EQ(b.id, a.id);
    EXPECT_LT((b.T_parent_tag.matrix() - a.T_parent_tag.matrix()).cwiseAbs().maxCoeff(), 1e-15) << i;
    EXPECT_DOUBLE_EQ(b.size_m, i < 2 ? 0.016 : i < 6 ? 0.018 : 0.014) << i;
  }
  for (const StationScene* sp : {&wrap, &large}) {
    const StationScene& lay = *sp;
    const std::string name = sp == &wrap ? "wrap20" : "front12large";
    EXPECT_EQ(lay.validate(), "") << name;
    // Written out and read back unchanged.
    auto r = parse_station_scene(station_scene_to_json(lay), name + ".json");
    ASSERT_TRUE(r.ok()) << r.error();
    expect_same(lay, *r);
    for (std::size_t i = 0; i < lay.mannequin_tags.size(); ++i) {
      EXPECT_EQ(lay.mannequin_tags[i].id, static_cast<int>(i));
      if (i < 12) {
        EXPECT_LT((lay.mannequin_tags[i].T_parent_tag.matrix() - front.mannequin_tags[i].T_parent_tag.matrix())
                      .cwiseAbs()
                      .maxCoeff(),
                  1e-15);
      }
      for (const auto& t : lay.mirror_tags) EXPECT_NE(t.id, lay.mannequin_tags[i].id);
      for (const auto& t : lay.pen.tags) EXPECT_NE(t.id, lay.mannequin_tags[i].id);
    }
    // Border = 5 cells; the pattern is 9 cells, the kit adds a cell of quiet zone each side.
    for (const auto& a : lay.mannequin_tags) {
      const Eigen::Vector3d pa = a.T_parent_tag.translation();
      const double plate_half = 0.5 * a.size_m * 11.0 / 5.0;
      for (const auto& b : lay.mannequin_tags) {
        if (&a == &b) continue;
        // b's centre in a's tag plane: the two (nearly aligned) patterns must not overlap.
        const double pattern = 0.5 * (a.size_m + b.size_m) * 9.0 / 5.0;
        const Eigen::Vector3d d = a.T_parent_tag.linear().transpose() * (b.T_parent_tag.translation() - pa);
        EXPECT_TRUE(std::abs(d.x()) > pattern || std::abs(d.y()) > pattern) << name << " " << a.id << " " << b.id;
      }
      for (const auto& d : lay.fixtures.divots_man) EXPECT_GT((pa - d).norm(), plate_half + 4e-3) << name << " " << a.id;
      // Clear of the lips: a tube of lip_radius around the mouth opening on the face (as the
      // head mesh draws it), farther from the tag's centre than half its printed plate.
      const auto& m = lay.mannequin;
      double lips = 1e9;
      for (int k = 0; k < 360; ++k) {
        const double t = k * M_PI / 180, x = m.mouth_half_width_m * std::cos(t), y = m.mouth_half_height_m * std::sin(t);
        const double q = 1 - std::pow((x - m.head_centre_m.x()) / m.head_radii_m.x(), 2) -
                         std::pow((y - m.head_centre_m.y()) / m.head_radii_m.y(), 2);
        const Eigen::Vector3d ring(x, y, m.head_centre_m.z() + m.head_radii_m.z() * std::sqrt(std::max(q, 0.0)));
        lips = std::min(lips, (pa - ring).norm() - m.lip_radius_m);
      }
      EXPECT_GT(lips, plate_half) << name << " " << a.id;
    }
  }
  // One size up does not fit: 18 mm forehead tags overlap each other.
  StationScene bigger = large;
  bigger.mannequin_tags[0].size_m = bigger.mannequin_tags[1].size_m = 0.018;
  const Eigen::Vector3d d01 = bigger.mannequin_tags[0].T_parent_tag.linear().transpose() *
                              (bigger.mannequin_tags[1].T_parent_tag.translation() -
                               bigger.mannequin_tags[0].T_parent_tag.translation());
  EXPECT_LT(std::abs(d01.x()), 0.018 * 9.0 / 5.0);
  EXPECT_LT(std::abs(d01.y()), 0.018 * 9.0 / 5.0);
}

TEST(StationScene, JsonRoundTrip) {
  StationScene s = default_station_scene();
  s.family = TagFamilyId::kTag36h11;
  s.name = "round trip";
  const std::string text = station_scene_to_json(s);
  auto r = parse_station_scene(text, "mem.json");
  ASSERT_TRUE(r.ok()) << r.error();
  expect_same(s, *r);

  const auto dir = test::temp_dir("station_scene_roundtrip");
  const std::string path = (dir / "station.json").string();
  ASSERT_TRUE(write_station_scene(s, path).ok());
  auto f = read_station_scene(path);
  ASSERT_TRUE(f.ok()) << f.error();
  expect_same(s, *f);
  std::filesystem::remove_all(dir);
}

TEST(StationScene, ShippedDefaultMatchesTheBuiltIn) {
  const std::string path = std::string(DENTAR_SOURCE_DIR) + "/assets/station_default.json";
  auto r = read_station_scene(path);
  ASSERT_TRUE(r.ok()) << r.error();
  expect_same(default_station_scene(), *r);
  EXPECT_EQ(test::read_file(path), station_scene_to_json(default_station_scene()))
      << "assets/station_default.json is out of date; regenerate it with\n"
         "  dentar synth --write-default-station assets/station_default.json";
}

// The mirror's roof paddle (issue 16): its two roof tags face 70 deg apart,
// both toward the reflecting side, and lie on the roof's faces; a station
// file written before the roof (no "paddle_roof_deg") reads as the flat
// paddle it describes and round-trips unchanged.
TEST(StationScene, MirrorRoofPaddleAndOlderFlatFiles) {
  const StationScene s = default_station_scene();
  ASSERT_EQ(s.mirror_tags.size(), 3u);
  EXPECT_NEAR(s.mirror.paddle_roof_rad, 35 * M_PI / 180, 1e-12);
  const Eigen::Vector3d n0 = s.mirror_tags[0].T_parent_tag.linear().col(2);
  const Eigen::Vector3d n2 = s.mirror_tags[2].T_parent_tag.linear().col(2);
  EXPECT_NEAR(std::acos(n0.dot(n2)) * 180 / M_PI, 70.0, 1e-9);
  EXPECT_GT(n0.z(), 0);  // tag z points into the paddle: both face -z (the reflecting side)
  EXPECT_GT(n2.z(), 0);
  EXPECT_LT(s.mirror_tags[1].T_parent_tag.linear().col(2).z(), 0);  // the back tag
  // Each roof tag's centre lies on its face: z = -h/4 tan(a) + |y| tan(a).
  const double ta = std::tan(s.mirror.paddle_roof_rad), q = 0.25 * s.mirror.paddle_height_m;
  for (int i : {0, 2}) {
    const Eigen::Vector3d c = s.mirror_tags[i].T_parent_tag.translation();
    EXPECT_NEAR(c.z(), -q * ta + std::abs(c.y()) * ta, 1e-12);
  }
  // An older file: flat paddle, tags 20 and 21, no roof key.
  StationScene flat = s;
  set_mirror_paddle(flat, MirrorPaddle::kFlat);
  nlohmann::json j = nlohmann::json::parse(station_scene_to_json(flat));
  j["mirror"].erase("paddle_roof_deg");
  auto r = parse_station_scene(j.dump(), "old.json");
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->mirror.paddle_roof_rad, 0.0);
  EXPECT_EQ(r->validate(), "");
  expect_same(flat, *r);
}

// Each edit breaks one field; the message must name the file and that field.
TEST(StationScene, BadFieldsAreNamed) {
  const nlohmann::json good = nlohmann::json::parse(station_scene_to_json(default_station_scene()));
  struct Case {
    const char* pointer;
    nlohmann::json value;
    const char* expect;
  };
  const Case cases[] = {
      {"/format", "nope", "format"},
      {"/version", 5, "version"},
      {"/station_policy/check_threshold_mm", 50.0, "station_policy.check_threshold_mm"},
      {"/station_policy/health_divot", 20, "station_policy.health_divot"},
      {"/camera/device_id", 7, "camera.device_id"},
      {"/camera/latency_ms", -5.0, "camera.latency_ms"},
      {"/camera/latency_ms", "33", "camera.latency_ms"},
      {"/camera/fx", -3.0, "camera.fx"},
      {"/camera/dist", nlohmann::json::array({1, 2}), "camera.dist"},
      {"/tag_family", "tag25h9", "tag_family"},
      {"/mannequin/tags/2/size_mm", "big", "mannequin.tags[2].size_mm"},
      {"/mannequin/tags/3/id", 5000, "mannequin_tags[3].id"},
      {"/mannequin/tags/4/id", 0, "used twice"},
      {"/mannequin/head_radii_mm/1", 1000.0, "mannequin.head_radii_mm[1]"},
      {"/tooth/T_man_tooth/rvec_deg", "x", "tooth.T_man_tooth.rvec_deg"},
      {"/mirror/radius_mm", 0.0, "mirror.radius_mm"},
      {"/mirror/paddle_roof_deg", 75.0, "mirror.paddle_roof_deg"},
      {"/mirror/paddle_thickness_mm", 5.0, "eave"},
      {"/mirror/tags/0/T_mtag_tag/translation_mm/2", nullptr,
       "mirror.tags[0].T_mtag_tag.translation_mm[2]"},
      {"/haptics/T_sty_tip", 3, "haptics.T_sty_tip"},
  };
  for (const Case& c : cases) {
    nlohmann::json j = good;
    j[nlohmann::json::json_pointer(c.pointer)] = c.value;
    auto r = parse_station_scene(j.dump(), "bad.json");
    ASSERT_FALSE(r.ok()) << c.pointer;
    EXPECT_EQ(r.error().rfind("bad.json: ", 0), 0u) << r.error();
    EXPECT_NE(r.error().find(c.expect), std::string::npos) << c.pointer << " -> " << r.error();
  }
  nlohmann::json j = good;
  j["mannequin"]["lip_radius"] = 3;  // misspelt key
  auto r = parse_station_scene(j.dump(), "bad.json");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("mannequin.lip_radius: unknown key"), std::string::npos) << r.error();
  j = good;
  j.erase("haptics");
  r = parse_station_scene(j.dump(), "bad.json");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("haptics: missing"), std::string::npos) << r.error();
  r = parse_station_scene("{\"format\": ", "trunc.json");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("trunc.json: not valid JSON"), std::string::npos) << r.error();
  auto f = read_station_scene("/nonexistent/station.json");
  ASSERT_FALSE(f.ok());
  EXPECT_NE(f.error().find("/nonexistent/station.json"), std::string::npos);
}

// The camera's latency (issue 24, session 12): optional in version 4, absent = unknown (the
// frame path assumes kAssumedCameraLatency_ms); a measured value survives a round trip, in
// embedded and in referenced-camera stations alike.
TEST(StationScene, CameraLatencyIsOptionalAndRoundTrips) {
  StationScene s = default_station_scene();
  EXPECT_LT(s.camera_provenance.latency_ms, 0);
  nlohmann::json j = nlohmann::json::parse(station_scene_to_json(s));
  EXPECT_FALSE(j["camera"].contains("latency_ms"));  // unknown is not written
  s.camera_provenance.latency_ms = 47.5;
  j = nlohmann::json::parse(station_scene_to_json(s));
  EXPECT_EQ(j["camera"]["latency_ms"].get<double>(), 47.5);
  auto r = parse_station_scene(j.dump(), "lat.json");
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->camera_provenance.latency_ms, 47.5);
  // An older version-4 file without the field reads as unknown.
  j["camera"].erase("latency_ms");
  r = parse_station_scene(j.dump(), "old.json");
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_LT(r->camera_provenance.latency_ms, 0);
  j["camera"]["latency_ms"] = 2000;
  r = parse_station_scene(j.dump(), "bad.json");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("camera.latency_ms"), std::string::npos) << r.error();
}

// Issue 28: the stereo rig (right eye's intrinsics, T_left_right) round-trips; a file
// without it reads as one camera; a right eye of another size or a baseline no head has is
// refused, naming the field.
TEST(StationScene, StereoRigIsOptionalAndRoundTrips) {
  StationScene s = default_station_scene();
  EXPECT_FALSE(s.stereo.present);
  nlohmann::json j = nlohmann::json::parse(station_scene_to_json(s));
  EXPECT_FALSE(j.contains("stereo"));
  calibration::CameraIntrinsics right = s.calibration.camera;
  right.fx *= 1.01;
  right.cx += 2.5;
  s.stereo = make_stereo_rig(s.calibration.camera, 0.063, right);
  s.stereo.T_caml_camr.linear() = Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitY()).toRotationMatrix();
  auto r = parse_station_scene(station_scene_to_json(s), "stereo.json");
  ASSERT_TRUE(r.ok()) << r.error();
  ASSERT_TRUE(r->stereo.present);
  EXPECT_NEAR(r->stereo.baseline_m(), 0.063, 1e-12);
  EXPECT_NEAR(r->stereo.camera_right.fx, right.fx, 1e-9);
  EXPECT_NEAR(r->stereo.camera_right.cx, right.cx, 1e-9);
  EXPECT_TRUE(r->stereo.T_caml_camr.isApprox(s.stereo.T_caml_camr, 1e-12));
  j = nlohmann::json::parse(station_scene_to_json(s));
  j["stereo"]["camera_right"]["width"] = 1280;
  j["stereo"]["camera_right"]["cx"] = 640;
  r = parse_station_scene(j.dump(), "sizes.json");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("stereo.camera_right is 1280x480"), std::string::npos) << r.error();
  j = nlohmann::json::parse(station_scene_to_json(s));
  j["stereo"]["T_left_right"]["translation_mm"] = {0.5, 0, 0};
  r = parse_station_scene(j.dump(), "baseline.json");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("stereo.T_left_right"), std::string::npos) << r.error();
  j = nlohmann::json::parse(station_scene_to_json(s));
  j["stereo"].erase("T_left_right");
  r = parse_station_scene(j.dump(), "missing.json");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("T_left_right"), std::string::npos) << r.error();
}

// Version 3: the hand-eye result with its uncertainty and date, the camera's identity and the
// station policy survive a round trip.
TEST(StationScene, VersionThreeFieldsRoundTrip) {
  StationScene s = default_station_scene();
  s.camera_provenance.device_id = "HD Webcam C615 @ usb-0000:00:14.0-1";
  s.hand_eye.present = true;
  s.hand_eye.T_hand_cam = Eigen::Translation3d(0.01, -0.02, 0.08) *
                          Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized());
  s.hand_eye.hand = "HMD";
  s.hand_eye.method = "ours";
  s.hand_eye.rot_sd_rad = 0.001;
  s.hand_eye.trans_sd_m = 0.0004;
  s.hand_eye.rms_rot_rad = 0.002;
  s.hand_eye.rms_m = 0.0007;
  s.hand_eye.observations = 12;
  s.hand_eye.date = "2026-11-25T10:00:00Z";
  s.policy.check_threshold_m = 0.3e-3;
  s.policy.max_age_days = 14;
  s.policy.health_divot = 2;
  s.set_step_report({"hand_eye", "2026-11-25T10:00:00Z", true, "12 poses", {{"rot_sd_deg", 0.06}}});
  s.set_step_report({"camera", "2026-11-25T09:00:00Z", true, "", {}});
  s.set_step_report({"check", "2026-11-25T11:00:00Z", true, "", {{"threshold_mm", 0.3}}});
  auto r = parse_station_scene(station_scene_to_json(s), "v3.json");
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->version, kStationFileVersion);
  EXPECT_EQ(r->migrated_from, 0);
  EXPECT_EQ(r->camera_provenance.device_id, s.camera_provenance.device_id);
  ASSERT_TRUE(r->hand_eye.present);
  EXPECT_LT((r->hand_eye.T_hand_cam.matrix() - s.hand_eye.T_hand_cam.matrix()).norm(), 1e-12);
  EXPECT_EQ(r->hand_eye.hand, "HMD");
  EXPECT_NEAR(r->hand_eye.rot_sd_rad, 0.001, 1e-15);
  EXPECT_NEAR(r->hand_eye.trans_sd_m, 0.0004, 1e-15);
  EXPECT_EQ(r->hand_eye.observations, 12);
  EXPECT_EQ(r->hand_eye.date, "2026-11-25T10:00:00Z");
  EXPECT_NEAR(r->policy.check_threshold_m, 0.3e-3, 1e-15);
  EXPECT_EQ(r->policy.max_age_days, 14);
  EXPECT_EQ(r->policy.health_divot, 2);
  // Report entries stay in workflow order, hand_eye after camera.
  ASSERT_EQ(r->calibration_report.size(), 3u);
  EXPECT_EQ(r->calibration_report[0].step, "camera");
  EXPECT_EQ(r->calibration_report[1].step, "hand_eye");
  EXPECT_EQ(r->calibration_report[2].step, "check");
}

// Older files are read and migrated: the new parts get their defaults, migrated_from says
// from which version, and writing gives the current version. A v3 field in an older file is
// refused with the version it needs.
TEST(StationScene, OlderVersionsAreMigrated) {
  nlohmann::json j = nlohmann::json::parse(station_scene_to_json(default_station_scene()));
  j.erase("hand_eye");
  j.erase("station_policy");
  j["camera"].erase("response");  // a version 4 field
  for (int v : {3, 2, 1, 0}) {
    nlohmann::json old = j;
    if (v == 3) old["station_policy"] = nlohmann::json::object();
    if (v < 2) {
      old.erase("calibration_fixtures");
      old.erase("calibration_report");
    }
    if (v == 0) old.erase("version");
    else old["version"] = v;
    auto r = parse_station_scene(old.dump(), "old.json");
    ASSERT_TRUE(r.ok()) << v << ": " << r.error();
    EXPECT_EQ(r->version, std::max(v, 1));
    EXPECT_EQ(r->migrated_from, std::max(v, 1));
    EXPECT_FALSE(r->hand_eye.present);
    EXPECT_NEAR(r->policy.check_threshold_m, StationPolicy{}.check_threshold_m, 0);
    const nlohmann::json out = nlohmann::json::parse(station_scene_to_json(*r));
    EXPECT_EQ(out["version"], kStationFileVersion);
    EXPECT_TRUE(out.contains("station_policy"));
  }
  nlohmann::json bad = j;
  bad["version"] = 2;
  bad["camera"].erase("response");
  bad["station_policy"] = {{"max_age_days", 5}};
  auto r = parse_station_scene(bad.dump(), "old.json");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("station_policy: needs version 3"), std::string::npos) << r.error();
  bad = j;
  bad["version"] = 2;
  bad["camera"].erase("response");
  bad["camera"]["device_id"] = "cam";
  r = parse_station_scene(bad.dump(), "old.json");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("camera.device_id: needs version 3"), std::string::npos) << r.error();
  // A hand-eye block that is not rigid is named.
  nlohmann::json he = nlohmann::json::parse(station_scene_to_json(default_station_scene()));
  he["hand_eye"] = {{"T_hand_cam", {{"translation_mm", {0, 0, 2000}}, {"rvec_deg", {0, 0, 0}}}},
                    {"hand", "HMD"}, {"method", "ours"}, {"rms_rotation_deg", 0.1}, {"rms_mm", 0.2},
                    {"observations", 8}, {"date", "2026-11-25T10:00:00Z"}};
  r = parse_station_scene(he.dump(), "he.json");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("hand_eye.T_hand_cam"), std::string::npos) << r.error();
}

}  // namespace
}  // namespace dentar::ar

namespace dentar::ar {
// Issue 24: the camera's measured response (v4 field camera.response) round-trips; a curve that
// is not monotonic, has the wrong length or an unknown kind is refused naming the field; an
// older file may not carry it; a model name that disagrees with the coefficients is refused.
TEST(StationScene, CameraResponseFieldAndModelName) {
  StationScene st = default_station_scene();
  st.camera_provenance.response.kind = "curve";
  for (int i = 0; i < 256; ++i) st.camera_provenance.response.table.push_back(std::pow(i / 255.0, 2.1));
  st.camera_provenance.response.gamma = 2.1;
  st.camera_provenance.response.gamma_sigma = 0.04;
  st.camera_provenance.response.views = 12;
  auto r = parse_station_scene(station_scene_to_json(st), "resp.json");
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->camera_provenance.response.kind, "curve");
  ASSERT_EQ(r->camera_provenance.response.table.size(), 256u);
  EXPECT_NEAR(r->camera_provenance.response.table[128], std::pow(128 / 255.0, 2.1), 1e-12);
  EXPECT_NEAR(r->camera_provenance.response.gamma_sigma, 0.04, 1e-12);
  const nlohmann::json good = nlohmann::json::parse(station_scene_to_json(st));
  auto refused = [&](nlohmann::json j, const std::string& field) {
    auto p = parse_station_scene(j.dump(), "bad.json");
    ASSERT_FALSE(p.ok()) << field;
    EXPECT_NE(p.error().find(field), std::string::npos) << p.error();
  };
  nlohmann::json j = good;
  j["camera"]["response"]["curve"][100] = 0.0;  // not monotonic
  refused(j, "camera.response.curve[100]");
  j = good;
  j["camera"]["response"]["curve"].erase(j["camera"]["response"]["curve"].size() - 1);  // 255 entries
  refused(j, "camera.response.curve");
  j = good;
  j["camera"]["response"]["kind"] = "gamma22";
  refused(j, "camera.response.kind");
  j = good;
  j["version"] = 3;
  refused(j, "camera.response: needs version 4");
  // Named kinds carry no curve.
  j = good;
  j["camera"]["response"] = {{"kind", "srgb"}, {"gamma", 2.2}, {"gamma_sigma", 0.05}};
  r = parse_station_scene(j.dump(), "srgb.json");
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->camera_provenance.response.kind, "srgb");
  // A k1-only model with a k2 coefficient.
  j = good;
  j["camera"]["model"] = "pinhole-k1";
  j["camera"]["dist"] = {-0.2, 0.05, 0, 0, 0};
  refused(j, "camera.model");
  j["camera"]["dist"] = {-0.2, 0, 0, 0, 0};
  EXPECT_TRUE(parse_station_scene(j.dump(), "k1.json").ok());
}
}  // namespace dentar::ar
