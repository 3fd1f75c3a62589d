// Station scene JSON: round trip, the shipped default kept in sync, and
// errors that name the file and the field.
#include "dentar/ar/station_scene.h"

#include <gtest/gtest.h>

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
  EXPECT_LT((s.calibration.T_tooth_dev().translation() - Eigen::Vector3d(0, -0.15, -0.12)).norm(),
            1e-12);
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
      {"/version", 3, "version"},
      {"/camera/fx", -3.0, "camera.fx"},
      {"/camera/dist", nlohmann::json::array({1, 2}), "camera.dist"},
      {"/tag_family", "tag25h9", "tag_family"},
      {"/mannequin/tags/2/size_mm", "big", "mannequin.tags[2].size_mm"},
      {"/mannequin/tags/3/id", 5000, "mannequin_tags[3].id"},
      {"/mannequin/tags/4/id", 0, "used twice"},
      {"/mannequin/head_radii_mm/1", 1000.0, "mannequin.head_radii_mm[1]"},
      {"/tooth/T_man_tooth/rvec_deg", "x", "tooth.T_man_tooth.rvec_deg"},
      {"/mirror/radius_mm", 0.0, "mirror.radius_mm"},
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

}  // namespace
}  // namespace dentar::ar
