// Outcome scoring on hand-made volumes with known answers, and the
// exercise parser's errors.
#include "dentar/training/outcome.h"
#include "dentar/volume/procedural_tooth.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <regex>
#include <string>

namespace dentar::training {
namespace {

using volume::Material;
using volume::VoxelVolume;

constexpr double kH = 0.1e-3;  // 0.1 mm voxels

// A 10 x 10 x 10 mm block of dentin, origin at its corner voxel: voxel
// (i,j,k) centre is (i,j,k) * 0.1 mm.
VoxelVolume block(int n = 100) {
  volume::VolumeGeometry g;
  g.dims = Eigen::Vector3i(n, n, n);
  g.spacing = Eigen::Vector3d::Constant(kH);
  g.origin = Eigen::Vector3d::Zero();
  VoxelVolume v(g);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) v.set(i, j, k, 200, Material::kDentin);
  return v;
}

template <typename F>
void carve(VoxelVolume& v, F inside_mm) {
  for (int k = 0; k < v.dims().z(); ++k)
    for (int j = 0; j < v.dims().y(); ++j)
      for (int i = 0; i < v.dims().x(); ++i)
        if (inside_mm(v.voxel_center(i, j, k) * 1e3)) v.set(i, j, k, 0, v.material(i, j, k));
}

Primitive cylinder(Eigen::Vector3d a_mm, Eigen::Vector3d b_mm, double r_mm) {
  Primitive p;
  p.kind = PrimitiveKind::kCylinder;
  p.a_m = a_mm * 1e-3;
  p.b_m = b_mm * 1e-3;
  p.radius_m = r_mm * 1e-3;
  return p;
}
Primitive box(Eigen::Vector3d lo_mm, Eigen::Vector3d hi_mm) {
  Primitive p;
  p.kind = PrimitiveKind::kBox;
  p.a_m = lo_mm * 1e-3;
  p.b_m = hi_mm * 1e-3;
  return p;
}

// Target: a 2 mm radius well from z = 6 mm to the top at (5, 5).
Exercise well_exercise() {
  Exercise ex;
  ex.source = "well.json";
  Region t{"well", RegionRole::kTarget, {cylinder({5, 5, 6}, {5, 5, 11}, 2.0)}, 4.0, 1.0};
  Region f{"deep", RegionRole::kForbidden, {box({-1, -1, -1}, {11, 11, 5})}, 0, 1};
  Region e{"top", RegionRole::kEntry, {box({-1, -1, 9.85}, {11, 11, 11})}, 0, 1};
  ex.regions = {t, f, e};
  return ex;
}

double cyl_mm3(double r, double h) { return M_PI * r * r * h; }

TEST(Outcome, RemovedVolumeCoverageAndOverPreparation) {
  const VoxelVolume start = block();
  const Exercise ex = well_exercise();
  auto m = build_masks(ex, start);
  ASSERT_TRUE(m.ok()) << m.error();

  // Exactly the target: a well of radius 2 mm, 4 mm deep (z from 6 to 10).
  VoxelVolume cut = start.clone();
  carve(cut, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 2.0 && p.z() >= 6.0; });
  auto o = score_outcome(ex, *m, start, cut);
  ASSERT_TRUE(o.ok()) << o.error();
  const double expect = cyl_mm3(2.0, 4.0);  // 50.3 mm3
  EXPECT_NEAR(o->removed_total_mm3, expect, 0.03 * expect);
  EXPECT_NEAR(o->removed_mm3[static_cast<int>(Material::kDentin)], o->removed_total_mm3, 1e-9);
  EXPECT_NEAR(o->target_coverage_pct, 100.0, 0.5);  // boundary voxels at z = 6 mm
  EXPECT_NEAR(o->overprep_mm3, 0.0, 1e-9);
  EXPECT_NEAR(o->forbidden_mm3, 0.0, 1e-9);
  EXPECT_FALSE(o->perforation);
  EXPECT_FALSE(o->pulp_exposed);
  EXPECT_NEAR(o->points, 4.0, 0.02);

  // Half the depth: 50 % coverage, 2 points.
  VoxelVolume half = start.clone();
  carve(half, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 2.0 && p.z() >= 8.0; });
  auto oh = score_outcome(ex, *m, start, half);
  ASSERT_TRUE(oh.ok());
  EXPECT_NEAR(oh->target_coverage_pct, 50.0, 3.0);
  EXPECT_NEAR(oh->points, 2.0, 0.15);

  // Too wide (r 2.5 mm) and too deep (to z = 4 mm, 1 mm into the forbidden slab).
  VoxelVolume over = start.clone();
  carve(over, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 2.5 && p.z() >= 4.0; });
  auto oo = score_outcome(ex, *m, start, over);
  ASSERT_TRUE(oo.ok());
  const double total = cyl_mm3(2.5, 6.0);
  EXPECT_NEAR(oo->removed_total_mm3, total, 0.03 * total);
  EXPECT_NEAR(oo->overprep_mm3, total - expect, 0.04 * (total - expect));
  // Voxel layers z = 4.0 .. 5.0 mm inclusive: 11 layers of 0.1 mm.
  EXPECT_NEAR(oo->forbidden_mm3, cyl_mm3(2.5, 1.1), 0.05 * cyl_mm3(2.5, 1.1));
  EXPECT_LT(oo->points, 4.0 * (1.0 - 0.5));  // the zone's excess (r 2..2.5 mm, z 5..6) costs points
}

TEST(Outcome, PulpExposureAndPerforation) {
  VoxelVolume start = block();
  // A pulp sphere of radius 1 mm at (5, 5, 3).
  for (int k = 0; k < 100; ++k)
    for (int j = 0; j < 100; ++j)
      for (int i = 0; i < 100; ++i)
        if ((start.voxel_center(i, j, k) * 1e3 - Eigen::Vector3d(5, 5, 3)).norm() <= 1.0)
          start.set(i, j, k, 70, Material::kPulp);
  Exercise ex = well_exercise();
  ex.regions.pop_back();  // no forbidden slab (it would contain the pulp), keep the entry
  ex.regions.erase(ex.regions.begin() + 1);
  Region e{"top", RegionRole::kEntry, {box({-1, -1, 9.85}, {11, 11, 11})}, 0, 1};
  ex.regions.push_back(e);
  auto m = build_masks(ex, start);
  ASSERT_TRUE(m.ok()) << m.error();
  VoxelVolume shallow = start.clone();
  carve(shallow, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 1.0 && p.z() >= 5.0; });
  auto o1 = score_outcome(ex, *m, start, shallow);
  ASSERT_TRUE(o1.ok());
  EXPECT_FALSE(o1->pulp_exposed);
  EXPECT_FALSE(o1->perforation);
  VoxelVolume deep = start.clone();
  carve(deep, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 1.0 && p.z() >= 3.95; });
  auto o2 = score_outcome(ex, *m, start, deep);
  ASSERT_TRUE(o2.ok());
  EXPECT_TRUE(o2->pulp_exposed);
  // A side tunnel from the well out through the x = 10 mm face: perforation.
  VoxelVolume side = shallow.clone();
  carve(side, [](const Eigen::Vector3d& p) { return p.x() >= 5 && std::hypot(p.y() - 5, p.z() - 7) <= 0.5; });
  auto o3 = score_outcome(ex, *m, start, side);
  ASSERT_TRUE(o3.ok());
  EXPECT_TRUE(o3->perforation);
  EXPECT_GT(o3->perforation_mm3, 0.0);
  EXPECT_FALSE(o1->perforation);
}

TEST(Outcome, WallDivergenceAndSmoothness) {
  const VoxelVolume start = block();
  const Eigen::Vector3d axis(5e-3, 5e-3, 0);
  // Straight well: divergence 0, RMS within voxel quantisation.
  VoxelVolume straight = start.clone();
  carve(straight, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 2.0 && p.z() >= 4.0; });
  const WallProfile w0 = wall_profile(straight, axis, {-1, 0, 0}, 4.5e-3, 9.5e-3);
  EXPECT_NEAR(w0.divergence_deg, 0.0, 0.5);
  EXPECT_LT(w0.rms_mm, 0.05);
  ASSERT_FALSE(w0.extent_m.empty());
  EXPECT_NEAR(w0.extent_m[0], 2.0e-3, 0.1e-3);
  // A cone opening 10 degrees toward +z.
  const double tan10 = std::tan(10 * M_PI / 180);
  VoxelVolume cone = start.clone();
  carve(cone, [&](const Eigen::Vector3d& p) {
    return p.z() >= 4.0 && std::hypot(p.x() - 5, p.y() - 5) <= 1.5 + (p.z() - 4.0) * tan10;
  });
  const WallProfile w1 = wall_profile(cone, axis, {0, 1, 0}, 4.5e-3, 9.5e-3);
  EXPECT_NEAR(w1.divergence_deg, 10.0, 1.0);
  // Undercut: narrowing toward +z.
  VoxelVolume under = start.clone();
  carve(under, [&](const Eigen::Vector3d& p) {
    return p.z() >= 4.0 && std::hypot(p.x() - 5, p.y() - 5) <= 2.5 - (p.z() - 4.0) * tan10;
  });
  EXPECT_NEAR(wall_profile(under, axis, {1, 0, 0}, 4.5e-3, 9.5e-3).divergence_deg, -10.0, 1.0);
  // Rough: radius steps +-0.4 mm every 0.5 mm of height.
  VoxelVolume rough = start.clone();
  carve(rough, [&](const Eigen::Vector3d& p) {
    const double r = 2.0 + ((static_cast<int>(std::floor(p.z() / 0.5)) % 2) ? 0.4 : -0.4);
    return p.z() >= 4.0 && std::hypot(p.x() - 5, p.y() - 5) <= r;
  });
  EXPECT_NEAR(wall_profile(rough, axis, {-1, 0, 0}, 4.5e-3, 9.5e-3).rms_mm, 0.4, 0.06);
}

TEST(Outcome, OrificeLineOfSightAndAccessCriteria) {
  const VoxelVolume start = block();
  Exercise ex;
  ex.source = "access.json";
  ex.outcome = OutcomeKind::kAccessOpening;
  ex.regions = {{"access", RegionRole::kTarget, {cylinder({5, 5, 3}, {5, 5, 11}, 2.5)}, 0, 1},
                {"top", RegionRole::kEntry, {box({-1, -1, 9.85}, {11, 11, 11})}, 0, 1}};
  AccessGeometry a;
  a.orifices = {{"A", Eigen::Vector3d(4e-3, 5e-3, 3.2e-3)}, {"B", Eigen::Vector3d(6e-3, 5e-3, 3.2e-3)}};
  a.axis_point_m = Eigen::Vector3d(5e-3, 5e-3, 0);
  a.opening_z_m = 9.5e-3;
  a.floor_z_m = 3.0e-3;
  a.walls_from_z_m = 3.0e-3;
  ex.access = a;
  auto m = build_masks(ex, start);
  ASSERT_TRUE(m.ok()) << m.error();
  // Ideal: a straight 2.5 mm well down to z = 3 mm (the floor level).
  VoxelVolume ideal = start.clone();
  carve(ideal, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 2.5 && p.z() >= 3.05; });
  auto o = score_outcome(ex, *m, start, ideal);
  ASSERT_TRUE(o.ok()) << o.error();
  ASSERT_EQ(o->criteria.size(), 6u);
  for (const auto& c : o->criteria) EXPECT_EQ(c.score, 3) << c.name << ": " << c.detail;
  EXPECT_EQ(o->points, 18);
  EXPECT_EQ(o->max_points, 18);
  // Orifice B hidden under an overhang: a shelf 1 mm above it.
  VoxelVolume shelf = ideal.clone();
  for (int k = 0; k < 100; ++k)
    for (int j = 0; j < 100; ++j)
      for (int i = 0; i < 100; ++i) {
        const Eigen::Vector3d p = shelf.voxel_center(i, j, k) * 1e3;
        if (p.x() > 5.3 && p.z() > 4.0 && p.z() < 4.6) shelf.set(i, j, k, 200, Material::kDentin);
      }
  EXPECT_NEAR(line_of_sight(shelf, a.orifices[1].position_m, a.opening_z_m, 10), 0.0, 1e-12);
  EXPECT_NEAR(line_of_sight(shelf, a.orifices[0].position_m, a.opening_z_m, 10), 1.0, 1e-12);
  auto os = score_outcome(ex, *m, start, shelf);
  ASSERT_TRUE(os.ok());
  EXPECT_LE(os->criteria[0].score, 1);
  // Gouged floor: 1.5 mm deeper in the middle -> floor criterion drops.
  VoxelVolume gouge = ideal.clone();
  carve(gouge, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 1.0 && p.z() >= 1.5; });
  auto og = score_outcome(ex, *m, start, gouge);
  ASSERT_TRUE(og.ok());
  EXPECT_EQ(og->criteria[5].score, 0) << og->criteria[5].detail;  // pi * 1 * 1.5 = 4.7 mm3 below
  EXPECT_NEAR(og->criteria[5].value, M_PI * 1.6, 0.4);  // 16 voxel layers (z 1.5..3.0 mm)
  // Nothing cut: no orifice visible, no wall, and no floor to judge (it
  // used to earn the floor's 3 points for an untouched tooth).
  auto on = score_outcome(ex, *m, start, start);
  ASSERT_TRUE(on.ok());
  EXPECT_EQ(on->points, 0);
  EXPECT_FALSE(on->complete);
  EXPECT_NE(on->criteria[5].detail.find("not opened"), std::string::npos) << on->criteria[5].detail;
}

TEST(Exercise, OverlappingTargetAndForbiddenIsAnErrorNamingBoth) {
  const VoxelVolume start = block(40);
  Exercise ex;
  ex.source = "bad.json";
  ex.regions = {{"cavity", RegionRole::kTarget, {box({0, 0, 2}, {4, 4, 4})}, 1, 1},
                {"pulp_zone", RegionRole::kForbidden, {box({1, 1, 0}, {3, 3, 2.55})}, 0, 1}};
  auto m = build_masks(ex, start);
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.error().find("bad.json"), std::string::npos);
  EXPECT_NE(m.error().find("'cavity' overlaps forbidden region 'pulp_zone'"), std::string::npos) << m.error();
}

TEST(Exercise, ParserErrorsNameFileAndField) {
  const std::string good = R"({"format":"dentar-exercise","version":1,"name":"t","procedure":"p",
    "tooth":{"kind":"molar","voxel_mm":0.2},"bur":{"shape":"sphere","radius_mm":0.5},"time_limit_s":60,
    "regions":[{"name":"a","role":"target","all":[{"shape":"sphere","center_mm":[0,0,5],"radius_mm":1}]}],
    "steps":[{"name":"s1","region":"a"}]})";
  auto ok = parse_exercise(good, "t.json");
  ASSERT_TRUE(ok.ok()) << ok.error();
  EXPECT_EQ(ok->regions[0].all[0].kind, PrimitiveKind::kSphere);
  auto expect_err = [&](std::string text, const std::string& needle) {
    auto r = parse_exercise(text, "t.json");
    ASSERT_FALSE(r.ok()) << needle;
    EXPECT_NE(r.error().find(needle), std::string::npos) << r.error();
    EXPECT_NE(r.error().find("t.json"), std::string::npos) << r.error();
  };
  auto replace = [&](const std::string& a, const std::string& b) {
    std::string s = good;
    s.replace(s.find(a), a.size(), b);
    return s;
  };
  expect_err(replace("\"radius_mm\":1}", "\"radius_mm\":-1}"), "regions[0].all[0].radius_mm");
  expect_err(replace("\"shape\":\"sphere\",\"center", "\"shape\":\"blob\",\"center"), "unknown shape 'blob'");
  expect_err(replace("\"region\":\"a\"", "\"region\":\"zz\""), "steps[0].region");
  expect_err(replace("\"kind\":\"molar\"", "\"kind\":\"canine\""), "tooth.kind");
  expect_err(replace("\"role\":\"target\"", "\"role\":\"forbidden\""), "no region has role \"target\"");
  expect_err(replace("\"time_limit_s\":60", "\"time_limit_s\":60,\"outcome\":{\"kind\":\"graded_regions\",\"overprep_price\":\"cheap\"}"),
             "outcome.overprep_price': 'cheap'");
  auto priced = parse_exercise(
      replace("\"time_limit_s\":60", "\"time_limit_s\":60,\"outcome\":{\"kind\":\"graded_regions\",\"overprep_price\":\"exercise\"}"),
      "t.json");
  ASSERT_TRUE(priced.ok()) << priced.error();
  EXPECT_TRUE(priced->overprep_exercise_price);
  EXPECT_FALSE(ok->overprep_exercise_price);
  expect_err(good.substr(0, 60), "line 1");
  // The molar's pulp roof (issue 25, session 17): kept in the tooth JSON the sessions rebuild from.
  auto roofed = parse_exercise(replace("\"voxel_mm\":0.2}", "\"voxel_mm\":0.2,\"pulp_roof_mm\":1.0}"), "t.json");
  ASSERT_TRUE(roofed.ok()) << roofed.error();
  EXPECT_NE(roofed->tooth_json.find("\"pulp_roof_mm\":1.0"), std::string::npos) << roofed->tooth_json;
  EXPECT_EQ(ok->tooth_json.find("pulp_roof_mm"), std::string::npos) << ok->tooth_json;
  expect_err(replace("\"voxel_mm\":0.2}", "\"voxel_mm\":0.2,\"pulp_roof_mm\":-2}"), "tooth.pulp_roof_mm");
  expect_err(replace("\"kind\":\"molar\",\"voxel_mm\":0.2}", "\"kind\":\"incisor\",\"voxel_mm\":0.2,\"pulp_roof_mm\":1}"),
             "only a molar");
}

// Session logs recorded before session 18 describe their molar without "pulp_roof_mm" and were
// cut on the old tooth (roof at 0.45 x the crown height): make_start_tooth rebuilds that one when
// the log's starting hash is its hash, the adult default when it is the default's, and leaves any
// other mismatch to the caller (the default tooth, whose hash then differs).
TEST(Exercise, StartToothOfALogRecordedBeforeTheAdultPulp) {
  const std::string desc = "{\"kind\":\"molar\",\"voxel_mm\":0.3}";
  auto now = make_tooth(desc);
  ASSERT_TRUE(now.ok()) << now.error();
  volume::MolarParams p;
  p.voxel_mm = 0.3;
  p.pulp_roof_mm = volume::kLegacyMolarPulpRoofFraction * p.crown_height_mm;
  auto old = volume::make_molar(p);
  ASSERT_TRUE(old.ok()) << old.error();
  ASSERT_NE(now->content_hash(), old->content_hash());
  auto a = make_start_tooth(desc, old->content_hash());
  ASSERT_TRUE(a.ok()) << a.error();
  EXPECT_EQ(a->content_hash(), old->content_hash());
  auto b = make_start_tooth(desc, now->content_hash());
  ASSERT_TRUE(b.ok()) << b.error();
  EXPECT_EQ(b->content_hash(), now->content_hash());
  auto c = make_start_tooth(desc, 12345);
  ASSERT_TRUE(c.ok()) << c.error();
  EXPECT_EQ(c->content_hash(), now->content_hash());
  // A log that names its roof gets that roof, whatever its hash.
  auto d = make_start_tooth("{\"kind\":\"molar\",\"voxel_mm\":0.3,\"pulp_roof_mm\":0.8}", old->content_hash());
  ASSERT_TRUE(d.ok()) << d.error();
  EXPECT_EQ(d->content_hash(), now->content_hash());
  EXPECT_FALSE(make_start_tooth("{\"kind\":\"molar\",\"voxel_mm\":0.3,\"pulp_roof_mm\":-1}", 0).ok());
}

}  // namespace
}  // namespace dentar::training

namespace dentar::training {
namespace {

// The incisor's graded regions on the procedural tooth itself (0.2 mm
// voxels): the exact target removed scores the maximum; a labial reduction
// 0.2 mm too deep costs the labial regions about 0.2 / 1.0 of their points
// and nothing elsewhere.
TEST(Outcome, IncisorGradedRegionsOnTheProceduralTooth) {
  auto ex = load_builtin_exercise("incisor_partial_crown");
  ASSERT_TRUE(ex.ok()) << ex.error();
  // Every voxel beyond the target charged (a 0.2 mm tolerance would spare
  // this 0.2 mm over-reduction whole; its own test is
  // OutcomeCases.ToleranceAndOverReductionChargeOnlyWhatIsBeyondThem).
  ex->tolerance_mm = 0;
  auto start = make_tooth(R"({"kind": "incisor", "voxel_mm": 0.2})");
  ASSERT_TRUE(start.ok()) << start.error();
  auto m = build_masks(*ex, *start);
  ASSERT_TRUE(m.ok()) << m.error();
  const auto dist = distance_to_air_m(*start);
  auto cut_where = [&](auto pred) {
    VoxelVolume cut = start->clone();
    for (int k = 0; k < cut.dims().z(); ++k)
      for (int j = 0; j < cut.dims().y(); ++j)
        for (int i = 0; i < cut.dims().x(); ++i)
          if (pred(i, j, k, m->index(i, j, k))) cut.set(i, j, k, 0, cut.material(i, j, k));
    return cut;
  };
  auto points_of = [](const OutcomeScores& o, const std::string& n) {
    for (const auto& r : o.regions)
      if (r.name == n) return r.points;
    return -1.0;
  };
  const VoxelVolume exact = cut_where([&](int, int, int, std::size_t id) { return (m->bits[id] & m->target_bits) != 0; });
  auto oe = score_outcome(*ex, *m, *start, exact);
  ASSERT_TRUE(oe.ok()) << oe.error();
  EXPECT_NEAR(oe->points, 16.0, 0.01);
  EXPECT_NEAR(oe->target_coverage_pct, 100.0, 0.01);
  EXPECT_FALSE(oe->pulp_exposed);

  // Labial reduction (z 1.05..8.45 mm, labial of y = -0.4 mm) to 1.2 mm instead of 1.0 mm.
  const VoxelVolume deep = cut_where([&](int i, int j, int k, std::size_t id) {
    const Eigen::Vector3d p = start->voxel_center(i, j, k) * 1e3;
    const bool labial = p.y() <= -0.4 && p.z() >= 1.05 && p.z() <= 8.45 && start->density(i, j, k) > volume::kIsoDensity &&
                        dist[id] <= 1.2e-3 + 1e-6;
    return (m->bits[id] & m->target_bits) != 0 || labial;
  });
  auto od = score_outcome(*ex, *m, *start, deep);
  ASSERT_TRUE(od.ok()) << od.error();
  // With overprep_price "exercise" a mm3 too far costs the exercise's price,
  // 16 points over the whole target volume, in every region (session 12);
  // the shipped "region" rule charges each region's points over its own volume.
  EXPECT_FALSE(ex->overprep_exercise_price) << "the shipped rule";
  ex->overprep_exercise_price = true;
  od = score_outcome(*ex, *m, *start, deep);
  ASSERT_TRUE(od.ok()) << od.error();
  double target_vol = 0;
  for (const auto& r : od->regions) target_vol += r.volume_mm3;
  const double price = 16.0 / target_vol;
  for (const char* n : {"labial_incisal", "labial_gingival"}) {
    const double p = points_of(*od, n);
    EXPECT_GT(p, 4.0 * (1 - 0.45)) << n;
    EXPECT_LT(p, 4.0 * (1 - 0.1)) << n;
    for (const auto& r : od->regions) {
      if (r.name == n) {
        EXPECT_NEAR(p, 4.0 * r.coverage_pct / 100 - price * r.overprep_mm3, 1e-9) << n;
      }
    }
  }
  ex->overprep_exercise_price = false;  // the rule before: the region's own points per mm3
  auto odr = score_outcome(*ex, *m, *start, deep);
  ASSERT_TRUE(odr.ok()) << odr.error();
  for (const auto& r : odr->regions) {
    if (r.name == "labial_gingival") {
      EXPECT_NEAR(r.points, 4.0 * (r.coverage_pct / 100 - r.overprep_mm3 / r.volume_mm3), 1e-9);
    }
  }
  EXPECT_GT(points_of(*odr, "labial_gingival"), points_of(*od, "labial_gingival"))
      << "the labial face is larger than the average region: its own price is lower";
  EXPECT_NEAR(points_of(*od, "incisal"), 4.0, 0.05) << "a labial over-reduction is not the incisal region's";
  EXPECT_NEAR(points_of(*od, "marginal"), 4.0, 0.05) << "a labial over-reduction above the margin is not the margin's";
}

}  // namespace
}  // namespace dentar::training

namespace dentar::training {
namespace {

// Issue 25: every case of a criterion on hand-made volumes: untouched,
// complete, over-prepared, exposed, perforated; each with its points, its
// completeness and a sentence saying why.
struct Cases {
  VoxelVolume start = block();
  Exercise ex = well_exercise();
  RegionMasks m;
  Cases() {
    // A pulp sphere (r 0.8 mm) just under the well's floor at (5, 5, 5).
    for (int k = 0; k < 100; ++k)
      for (int j = 0; j < 100; ++j)
        for (int i = 0; i < 100; ++i)
          if ((start.voxel_center(i, j, k) * 1e3 - Eigen::Vector3d(5, 5, 5)).norm() <= 0.8)
            start.set(i, j, k, 70, Material::kPulp);
    ex.regions.erase(ex.regions.begin() + 1);  // the forbidden slab would hold the pulp
    ex.pulp_exposure_cost = 2.5;
    ex.perforation_cost = 1.5;
    auto mm = build_masks(ex, start);
    EXPECT_TRUE(mm.ok()) << mm.error();
    if (mm.ok()) m = *mm;
  }
  OutcomeScores score(const VoxelVolume& cut) const {
    auto o = score_outcome(ex, m, start, cut);
    EXPECT_TRUE(o.ok()) << o.error();
    return o.ok() ? *o : OutcomeScores{};
  }
  VoxelVolume well(double r_mm, double z0_mm) const {
    VoxelVolume c = start.clone();
    carve(c, [&](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= r_mm && p.z() >= z0_mm; });
    return c;
  }
};

bool has(const std::string& s, const std::string& needle) { return s.find(needle) != std::string::npos; }

TEST(OutcomeCases, GradedRegionUntouchedScoresZeroAndIsIncomplete) {
  const Cases c;
  const OutcomeScores o = c.score(c.start);
  EXPECT_EQ(o.points, 0.0);
  EXPECT_EQ(o.earned_points, 0.0);
  EXPECT_FALSE(o.complete);
  EXPECT_TRUE(has(o.completion, "incomplete")) << o.completion;
  EXPECT_TRUE(has(o.headline(), "INCOMPLETE")) << o.headline();
  EXPECT_TRUE(o.penalties.empty());
  ASSERT_EQ(o.regions.size(), 1u);
  EXPECT_TRUE(has(o.regions[0].why, "nothing")) << o.regions[0].why;
}

TEST(OutcomeCases, GradedRegionCompleteHalfAndOverPrepared) {
  const Cases c;
  const OutcomeScores full = c.score(c.well(2.0, 6.0));
  EXPECT_NEAR(full.points, 4.0, 0.02);
  EXPECT_TRUE(full.complete) << full.completion;
  EXPECT_TRUE(full.penalties.empty());
  EXPECT_FALSE(has(full.headline(), "INCOMPLETE"));
  EXPECT_TRUE(has(full.regions[0].why, "100 % of the region removed")) << full.regions[0].why;
  // Half the depth: the 2 points it earned, never silently: marked incomplete.
  const OutcomeScores half = c.score(c.well(2.0, 8.0));
  EXPECT_NEAR(half.points, 2.0, 0.15);
  EXPECT_FALSE(half.complete);
  EXPECT_TRUE(has(half.completion, "at least 80 %")) << half.completion;
  // 0.5 mm too wide: complete, and the excess costs points with a reason.
  const OutcomeScores wide = c.score(c.well(2.5, 6.0));
  EXPECT_TRUE(wide.complete);
  EXPECT_LT(wide.points, 4.0 * 0.6);
  EXPECT_GT(wide.points, 0.0);
  EXPECT_TRUE(has(wide.regions[0].why, "cut too far beyond it")) << wide.regions[0].why;
}

// Issue 25, session 20: a region's sentence is a sum a reader can check. At 1 decimal the live
// class I default read "(7 x 84 % = 5.9 points), less 0.3 for 0.86 mm3 ... = 5.5 points".
TEST(OutcomeCases, RegionSentenceAddsUpToItsPoints) {
  const Cases c;
  const std::regex sum_re(R"(\(\d+ x ([0-9.]+) % = ([0-9.]+) points\)(, less ([0-9.]+) for)?.* = ([0-9.]+) points)");
  int with_charge = 0;
  // Complete, half deep, 0.5 mm too wide, 0.3 mm too wide and half deep.
  for (const auto& [r, z0] : {std::pair{2.0, 6.0}, {2.0, 8.0}, {2.5, 6.0}, {2.3, 7.0}}) {
    const OutcomeScores o = c.score(c.well(r, z0));
    ASSERT_EQ(o.regions.size(), 1u);
    const RegionScore& g = o.regions[0];
    std::smatch mm;
    ASSERT_TRUE(std::regex_search(g.why, mm, sum_re)) << g.why;
    const double cov = std::stod(mm[1]), gross = std::stod(mm[2]), total = std::stod(mm[5]);
    const double charge = mm[4].matched ? std::stod(mm[4]) : 0.0;
    with_charge += mm[4].matched ? 1 : 0;
    EXPECT_NEAR(cov, g.coverage_pct, 0.051) << g.why;
    EXPECT_NEAR(gross, g.max_points * g.coverage_pct / 100, 0.0051) << g.why;
    EXPECT_NEAR(total, g.points, 0.0051) << g.why;
    // The written terms give the written result (to the last digit's rounding).
    EXPECT_NEAR(std::max(0.0, gross - charge), total, 0.0151) << g.why;
  }
  EXPECT_GE(with_charge, 2);
}

TEST(OutcomeCases, PulpExposureAndPerforationCostWhatTheExerciseSays) {
  Cases c;
  // Exposed: the well taken 0.6 mm into the pulp sphere's top (z 5.8 mm).
  const OutcomeScores exp = c.score(c.well(2.0, 5.5));
  ASSERT_TRUE(exp.pulp_exposed);
  EXPECT_FALSE(exp.perforation);
  ASSERT_EQ(exp.penalties.size(), 1u);
  EXPECT_EQ(exp.penalties[0].name, "pulp exposure");
  EXPECT_DOUBLE_EQ(exp.penalties[0].points, 2.5);
  EXPECT_TRUE(has(exp.penalties[0].why, "2.5 points")) << exp.penalties[0].why;
  EXPECT_NEAR(exp.points, exp.earned_points - 2.5, 1e-9);
  // Perforated: a side tunnel out through the x = 10 mm face.
  VoxelVolume side = c.well(2.0, 6.0);
  carve(side, [](const Eigen::Vector3d& p) { return p.x() >= 5 && std::hypot(p.y() - 5, p.z() - 7) <= 0.5; });
  const OutcomeScores per = c.score(side);
  ASSERT_TRUE(per.perforation);
  ASSERT_EQ(per.penalties.size(), 1u);
  EXPECT_EQ(per.penalties[0].name, "perforation");
  EXPECT_NEAR(per.points, std::max(0.0, per.earned_points - 1.5), 1e-9);
  // An exercise that names no cost charges all its points: the total is 0.
  c.ex.pulp_exposure_cost = -1;
  const OutcomeScores all = c.score(c.well(2.0, 5.5));
  EXPECT_EQ(all.points, 0.0);
  EXPECT_DOUBLE_EQ(all.penalties[0].points, 4.0);
}

// Issue 25, session 15: a graded pulp exposure costs by the exposure's size (the diameter of a
// hemisphere of the pulp removed), up to the exercise's stated cost; all or nothing without
// pulp_exposure_full_mm, as before.
TEST(OutcomeCases, GradedPulpExposureCostsBySizeUpToTheExercisesCost) {
  // The size rule: a hemisphere 1 mm across holds (2/3) pi 0.5^3 mm3.
  EXPECT_NEAR(Exercise::pulp_exposure_size_mm(2.0 / 3.0 * M_PI * 0.125), 1.0, 1e-12);
  EXPECT_EQ(Exercise::pulp_exposure_size_mm(0.0), 0.0);
  Cases c;
  c.ex.pulp_exposure_full_mm = 1.0;
  c.ex.pulp_exposure_min_fraction = 0.0;
  // Untouched: no exposure, no cost, still 0 and incomplete.
  const OutcomeScores un = c.score(c.start);
  EXPECT_TRUE(un.penalties.empty());
  EXPECT_EQ(un.points, 0.0);
  EXPECT_FALSE(un.complete);
  // A pinpoint nick: a 0.3 mm bore reaching into the pulp sphere's top (its layer at z 5.7 mm).
  VoxelVolume nick_v = c.well(2.0, 6.0);
  carve(nick_v, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 0.3 && p.z() >= 5.65; });
  const OutcomeScores nick = c.score(nick_v);
  ASSERT_TRUE(nick.pulp_exposed);
  ASSERT_EQ(nick.penalties.size(), 1u);
  const double nick_size = Exercise::pulp_exposure_size_mm(nick.pulp_removed_mm3);
  EXPECT_NEAR(nick.pulp_exposure_mm, nick_size, 1e-12);
  EXPECT_GT(nick_size, 0.1);
  EXPECT_LT(nick_size, 0.6);
  EXPECT_NEAR(nick.penalties[0].points, 2.5 * nick_size, 1e-9) << "in proportion to its size below 1 mm";
  EXPECT_TRUE(has(nick.penalties[0].why, "mm across")) << nick.penalties[0].why;
  EXPECT_TRUE(has(nick.penalties[0].why, "2.5 points for an exposure 1.0 mm across")) << nick.penalties[0].why;
  EXPECT_NEAR(nick.points, std::max(0.0, nick.earned_points - nick.penalties[0].points), 1e-9);
  // 0.3 mm into the pulp over the well's whole floor: larger, dearer, still below the cap.
  const OutcomeScores mid = c.score(c.well(2.0, 5.5));
  ASSERT_TRUE(mid.pulp_exposed);
  EXPECT_GT(mid.pulp_removed_mm3, nick.pulp_removed_mm3);
  EXPECT_GT(mid.penalties[0].points, nick.penalties[0].points);
  EXPECT_LE(mid.penalties[0].points, 2.5);
  // Down to the sphere's centre: over 1 mm across, the whole stated cost and no more.
  const OutcomeScores wide = c.score(c.well(2.0, 5.0));
  ASSERT_TRUE(wide.pulp_exposed);
  EXPECT_GT(wide.pulp_exposure_mm, 1.0);
  EXPECT_DOUBLE_EQ(wide.penalties[0].points, 2.5);
  // A floor fraction: any exposure costs at least half.
  c.ex.pulp_exposure_min_fraction = 0.5;
  const OutcomeScores nick_half = c.score(nick_v);
  EXPECT_NEAR(nick_half.penalties[0].points, 2.5 * (0.5 + 0.5 * nick_size), 1e-9);
  EXPECT_TRUE(has(nick_half.penalties[0].why, "at least 1.2")) << nick_half.penalties[0].why;
  EXPECT_DOUBLE_EQ(c.score(c.well(2.0, 5.0)).penalties[0].points, 2.5);
  // Without pulp_exposure_full_mm: all or nothing, the nick costs everything.
  c.ex.pulp_exposure_full_mm = 0;
  c.ex.pulp_exposure_min_fraction = 1;
  EXPECT_DOUBLE_EQ(c.score(nick_v).penalties[0].points, 2.5);
  // The parser: the fields are range-checked and a fraction without a size is refused, naming the field.
  const std::string text = R"({"format":"dentar-exercise","version":1,"name":"t","procedure":"p",
    "tooth":{"kind":"molar","voxel_mm":0.2},"bur":{"shape":"sphere","radius_mm":0.5},"time_limit_s":60,
    "regions":[{"name":"a","role":"target","points":7,"all":[{"shape":"sphere","center_mm":[0,0,5],"radius_mm":1}]}],
    "steps":[{"name":"s1","region":"a"}],
    "outcome":{"kind":"graded_regions","pulp_exposure_points":5,"pulp_exposure_full_mm":1.0,"pulp_exposure_min_fraction":0}})";
  auto ok = parse_exercise(text, "t.json");
  ASSERT_TRUE(ok.ok()) << ok.error();
  EXPECT_EQ(ok->pulp_exposure_full_mm, 1.0);
  EXPECT_EQ(ok->pulp_exposure_min_fraction, 0.0);
  EXPECT_NEAR(ok->pulp_exposure_charge(2.0 / 3.0 * M_PI * 0.125 / 8), 2.5, 1e-9) << "0.5 mm across: half of 5";
  EXPECT_EQ(ok->pulp_exposure_charge(0), 0.0);
  auto err = [&](const std::string& a, const std::string& b, const std::string& needle) {
    std::string s = text;
    s.replace(s.find(a), a.size(), b);
    auto r = parse_exercise(s, "t.json");
    ASSERT_FALSE(r.ok()) << needle;
    EXPECT_NE(r.error().find(needle), std::string::npos) << r.error();
    EXPECT_NE(r.error().find("t.json"), std::string::npos) << r.error();
  };
  err("\"pulp_exposure_min_fraction\":0", "\"pulp_exposure_min_fraction\":1.5", "outcome.pulp_exposure_min_fraction");
  err("\"pulp_exposure_full_mm\":1.0", "\"pulp_exposure_full_mm\":-1", "outcome.pulp_exposure_full_mm");
  err("\"pulp_exposure_full_mm\":1.0,", "", "needs 'outcome.pulp_exposure_full_mm'");
}

// Issue 25, session 11: the clinical tolerance around the outline, the
// over-reduction beyond the zone, and the tooth's partial-volume skin.
TEST(OutcomeCases, ToleranceAndOverReductionChargeOnlyWhatIsBeyondThem) {
  Cases c;
  const double target = cyl_mm3(2.0, 4.0);  // the well, z 6..10 mm
  // 0.15 mm too wide: charged without a tolerance, within a 0.2 mm one.
  const VoxelVolume wide = c.well(2.15, 6.0);
  const OutcomeScores strict = c.score(wide);
  EXPECT_LT(strict.points, 3.8);
  EXPECT_EQ(strict.tolerated_mm3, 0.0);
  c.ex.tolerance_mm = 0.2;
  const OutcomeScores tol = c.score(wide);
  EXPECT_NEAR(tol.points, 4.0, 0.02);
  EXPECT_NEAR(tol.tolerated_mm3, strict.overprep_mm3, 1e-9);
  EXPECT_NEAR(tol.tolerated_mm3, cyl_mm3(2.15, 4.0) - target, 0.15 * (cyl_mm3(2.15, 4.0) - target));
  // 0.5 mm too wide: the tolerance spares the first 0.2 mm only.
  const OutcomeScores wider = c.score(c.well(2.5, 6.0));
  EXPECT_GT(wider.points, 0.0);
  EXPECT_LT(wider.points, 4.0 * (1 - (cyl_mm3(2.4, 4.0) - cyl_mm3(2.2, 4.0)) / target));
  // Beyond the 1 mm zone (r 3.5 mm): not charged while over_reduction_rate is 0 ...
  const VoxelVolume gouged = c.well(3.5, 6.0);
  const OutcomeScores free_of_charge = c.score(gouged);
  const double beyond = cyl_mm3(3.5, 4.0) - cyl_mm3(3.0, 4.0);
  EXPECT_NEAR(free_of_charge.beyond_zone_mm3, beyond, 0.05 * beyond);
  EXPECT_TRUE(free_of_charge.penalties.empty());
  // ... and at rate 1 each mm3 costs what a mm3 of target left standing costs.
  c.ex.over_reduction_rate = 1.0;
  const OutcomeScores charged = c.score(gouged);
  ASSERT_EQ(charged.penalties.size(), 1u);
  EXPECT_EQ(charged.penalties[0].name, "over-reduction");
  EXPECT_NEAR(charged.penalties[0].points, std::min(4.0, 4.0 / charged.target_mm3 * charged.beyond_zone_mm3), 1e-9);
  EXPECT_TRUE(has(charged.penalties[0].why, "beyond the tolerance")) << charged.penalties[0].why;
  // The price is said with its own figures (the exercise's points over its target), not as "what a
  // mm3 of target left standing costs", which a region's own price per mm3 can contradict.
  char target_txt[32];
  std::snprintf(target_txt, sizeof target_txt, "%.2f", charged.target_mm3);
  EXPECT_TRUE(has(charged.penalties[0].why, std::string("x the exercise's 4 points over its ") + target_txt +
                                                " mm3 of target"))
      << charged.penalties[0].why;
  EXPECT_EQ(charged.points, 0.0);  // 18 mm3 beyond a 50 mm3 target: the zone's excess already took the rest
  // A small gouge 1.5 mm outside the zone (a 0.5 mm bore, 1 mm deep, at r 4 mm).
  VoxelVolume spot = c.well(2.0, 6.0);
  carve(spot, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 9, p.y() - 5) <= 0.5 && p.z() >= 9.0; });
  const OutcomeScores sp = c.score(spot);
  ASSERT_EQ(sp.penalties.size(), 1u);
  EXPECT_NEAR(sp.beyond_zone_mm3, cyl_mm3(0.5, 1.0), 0.1 * cyl_mm3(0.5, 1.0));
  EXPECT_NEAR(sp.points, 4.0 - 4.0 / sp.target_mm3 * sp.beyond_zone_mm3, 0.03);
  // Nothing removed: still 0 points, no penalty, incomplete.
  const OutcomeScores un = c.score(c.start);
  EXPECT_EQ(un.points, 0.0);
  EXPECT_TRUE(un.penalties.empty());
  EXPECT_FALSE(un.complete);
}

TEST(OutcomeCases, ThePartialVolumeSkinOverATargetIsTarget) {
  // A solid-shell target on a block whose top layer is partial-volume skin
  // (density 100 < iso): removing the target with its skin is not
  // over-preparation, and the skin counts toward the coverage.
  VoxelVolume start = block();
  for (int j = 0; j < 100; ++j)
    for (int i = 0; i < 100; ++i) start.set(i, j, 99, 100, Material::kDentin);
  Exercise ex = well_exercise();
  Primitive solid;
  solid.kind = PrimitiveKind::kSolid;
  ex.regions[0].all.push_back(solid);
  ex.regions.erase(ex.regions.begin() + 1);
  auto m = build_masks(ex, start);
  ASSERT_TRUE(m.ok()) << m.error();
  VoxelVolume cut = start.clone();
  carve(cut, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 2.0 && p.z() >= 6.0; });
  auto o = score_outcome(ex, *m, start, cut);
  ASSERT_TRUE(o.ok()) << o.error();
  EXPECT_NEAR(o->overprep_mm3, 0.0, 1e-9);
  EXPECT_NEAR(o->target_coverage_pct, 100.0, 0.5);
  EXPECT_NEAR(o->points, 4.0, 0.02);
}

// The access opening's six criteria, same cases.
// A block of dentin of about 10 mm a side at h_mm voxels (session 22: the same hand-made cuts at 0.1 and
// 0.15 mm), origin at its corner voxel.
VoxelVolume block_mm(double h_mm) {
  const int n = static_cast<int>(std::lround(10.0 / h_mm));
  volume::VolumeGeometry g;
  g.dims = Eigen::Vector3i(n, n, n);
  g.spacing = Eigen::Vector3d::Constant(h_mm * 1e-3);
  g.origin = Eigen::Vector3d::Zero();
  VoxelVolume v(g);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) v.set(i, j, k, 200, Material::kDentin);
  return v;
}

struct AccessCase {
  VoxelVolume start;
  Exercise ex;
  RegionMasks m;
  explicit AccessCase(double h_mm = 0.1) : start(block_mm(h_mm)) {
    // A pulp chamber (box 3.6..6.4 x 3.6..6.4 x 3.1..4 mm) under the access.
    for (int k = 0; k < start.dims().z(); ++k)
      for (int j = 0; j < start.dims().y(); ++j)
        for (int i = 0; i < start.dims().x(); ++i) {
          const Eigen::Vector3d p = start.voxel_center(i, j, k) * 1e3;
          if (std::abs(p.x() - 5) <= 1.4 && std::abs(p.y() - 5) <= 1.4 && p.z() >= 3.1 && p.z() <= 4.0)
            start.set(i, j, k, 70, Material::kPulp);
        }
    ex.source = "access.json";
    ex.outcome = OutcomeKind::kAccessOpening;
    ex.regions = {{"access", RegionRole::kTarget, {cylinder({5, 5, 3}, {5, 5, 11}, 2.5)}, 0, 1},
                  {"top", RegionRole::kEntry, {box({-1, -1, 9.85}, {11, 11, 11})}, 0, 1}};
    AccessGeometry a;
    a.orifices = {{"A", Eigen::Vector3d(4e-3, 5e-3, 3.2e-3)}, {"B", Eigen::Vector3d(6e-3, 5e-3, 3.2e-3)}};
    a.axis_point_m = Eigen::Vector3d(5e-3, 5e-3, 0);
    a.opening_z_m = 9.5e-3;
    a.floor_z_m = 3.0e-3;
    a.walls_from_z_m = 3.0e-3;
    ex.access = a;
    ex.pulp_exposure_cost = 0;  // an access opening unroofs the chamber: exposure is the aim
    ex.perforation_cost = 9;
    ex.complete_coverage_pct = 60;
    auto mm = build_masks(ex, start);
    EXPECT_TRUE(mm.ok()) << mm.error();
    if (mm.ok()) m = *mm;
  }
  OutcomeScores score(const VoxelVolume& cut) const {
    auto o = score_outcome(ex, m, start, cut);
    EXPECT_TRUE(o.ok()) << o.error();
    return o.ok() ? *o : OutcomeScores{};
  }
  VoxelVolume ideal() const {
    VoxelVolume c = start.clone();
    carve(c, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 2.5 && p.z() >= 3.05; });
    return c;
  }
};

TEST(OutcomeCases, AccessOpeningUntouchedCompleteOverPreparedExposedPerforated) {
  const AccessCase c;
  // Untouched: 0 of 18 on every criterion, incomplete.
  const OutcomeScores un = c.score(c.start);
  EXPECT_EQ(un.points, 0.0);
  EXPECT_FALSE(un.complete);
  for (const auto& k : un.criteria) {
    EXPECT_EQ(k.score, 0) << k.name;
    EXPECT_TRUE(has(k.detail, "0 of 3")) << k.name << ": " << k.detail;
  }
  // Complete (the chamber unroofed: the pulp is exposed, which costs 0 here,
  // said in a sentence).
  const OutcomeScores id = c.score(c.ideal());
  EXPECT_EQ(id.points, 18.0);
  EXPECT_TRUE(id.complete) << id.completion;
  ASSERT_TRUE(id.pulp_exposed);
  ASSERT_EQ(id.penalties.size(), 1u);
  EXPECT_EQ(id.penalties[0].points, 0.0);
  EXPECT_TRUE(has(id.penalties[0].why, "as this exercise requires")) << id.penalties[0].why;
  for (const auto& k : id.criteria) EXPECT_TRUE(has(k.detail, "3 of 3")) << k.name << ": " << k.detail;
  // Roof only (2 mm deep): walls not formed, orifices hidden: incomplete, few points.
  VoxelVolume roof = c.start.clone();
  carve(roof, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 2.5 && p.z() >= 8.0; });
  const OutcomeScores ro = c.score(roof);
  EXPECT_FALSE(ro.complete);
  EXPECT_TRUE(has(ro.completion, "orifice cannot be seen")) << ro.completion;
  EXPECT_EQ(ro.criteria[5].score, 0) << ro.criteria[5].detail;
  for (int w = 1; w <= 4; ++w) EXPECT_EQ(ro.criteria[w].score, 0) << ro.criteria[w].detail;  // session 19
  // Over-prepared floor: gouged 1.5 mm below it.
  VoxelVolume gouge = c.ideal();
  carve(gouge, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 1.0 && p.z() >= 1.5; });
  const OutcomeScores go = c.score(gouge);
  EXPECT_EQ(go.criteria[5].score, 0);
  EXPECT_TRUE(has(go.criteria[5].detail, "below the floor level")) << go.criteria[5].detail;
  EXPECT_LE(go.points, 15.0);
  // The access region carries no points: its sentence says so, and does not say that nothing was
  // cut beyond it while the outcome reports over-preparation (session 20, the live default).
  ASSERT_EQ(go.regions.size(), 1u);
  EXPECT_GT(go.overprep_mm3, 0.1);
  EXPECT_FALSE(has(go.regions[0].why, "nothing cut beyond it")) << go.regions[0].why;
  EXPECT_TRUE(has(go.regions[0].why, "carries no points of its own")) << go.regions[0].why;
  // Perforated: through the floor and out of the bottom face.
  VoxelVolume through = c.ideal();
  carve(through, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 0.5; });
  const OutcomeScores pe = c.score(through);
  ASSERT_TRUE(pe.perforation);
  EXPECT_EQ(pe.criteria[5].score, 0);
  EXPECT_TRUE(has(pe.criteria[5].detail, "perforated")) << pe.criteria[5].detail;
  bool charged = false;
  for (const auto& p : pe.penalties) charged |= p.name == "perforation" && p.points == 9.0;
  EXPECT_TRUE(charged);
  EXPECT_NEAR(pe.points, std::max(0.0, pe.earned_points - 9.0), 1e-9);
}

// Issue 25, session 19: no access points that were not earned. The walls are measured only over the
// levels the bur opened, contiguously from the opening down (the untouched chamber is not open
// space: it used to count as such, so a cut that never reached it had its walls "formed" over the
// chamber's span), and the floor pays only for the part of it the access reached.
TEST(OutcomeCases, AccessWallsAndFloorCountOnlyWhatWasCut) {
  const AccessCase c;
  const AccessGeometry& a = *c.ex.access;
  // A cut that stops 1 mm above the chamber's roof (z 4.0): no wall level at or under the roof.
  VoxelVolume above = c.start.clone();
  carve(above, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 2.5 && p.z() >= 5.0; });
  const WallProfile old_rule = wall_profile(above, a.axis_point_m, {-1, 0, 0}, a.walls_from_z_m, a.opening_z_m);
  ASSERT_FALSE(old_rule.z_m.empty());
  EXPECT_LT(old_rule.z_m.front(), 4.05e-3);  // the defect: the untouched chamber counted as open
  const WallProfile cut_only =
      wall_profile(above, a.axis_point_m, {-1, 0, 0}, a.walls_from_z_m, a.opening_z_m, &c.start);
  ASSERT_FALSE(cut_only.z_m.empty());
  EXPECT_GT(cut_only.z_m.front(), 4.95e-3);
  EXPECT_NEAR(cut_only.z_m.back(), 9.5e-3, 1e-9);
  // Its walls reach 4.5 of the 6.5 mm span: formed, but paid for what they span only.
  const OutcomeScores ab = c.score(above);
  for (int w = 1; w <= 4; ++w) {
    EXPECT_GT(ab.criteria[w].score, 0.0) << ab.criteria[w].detail;
    EXPECT_LT(ab.criteria[w].score, 3.0 * 4.6 / (0.9 * 6.5)) << ab.criteria[w].detail;
    EXPECT_TRUE(has(ab.criteria[w].detail, "4.50 of the 6.50 mm")) << ab.criteria[w].detail;
  }
  // Stopping 3 mm above the roof: 2.5 of 6.5 mm, not formed (with the chamber counted it spanned 6.4).
  VoxelVolume shallow = c.start.clone();
  carve(shallow, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 2.5 && p.z() >= 7.0; });
  const OutcomeScores sh = c.score(shallow);
  for (int w = 1; w <= 4; ++w) {
    EXPECT_EQ(sh.criteria[w].score, 0.0) << sh.criteria[w].detail;
    EXPECT_TRUE(has(sh.criteria[w].detail, "not formed")) << sh.criteria[w].detail;
  }
  EXPECT_EQ(sh.points, 0.0);
  // Broken through the roof on the axis: the chamber below the break is reached, its levels count.
  VoxelVolume broken = above.clone();
  carve(broken, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 0.5 && p.z() >= 3.95; });
  const WallProfile br = wall_profile(broken, a.axis_point_m, {-1, 0, 0}, a.walls_from_z_m, a.opening_z_m, &c.start);
  ASSERT_FALSE(br.z_m.empty());
  EXPECT_NEAR(br.z_m.front(), 3.1e-3, 1e-9);  // the chamber's lowest level
  EXPECT_NEAR(br.extent_m.front(), 1.45e-3, 0.05e-3);  // to the chamber's side (1.4 mm, + half a voxel)
  // The floor: a narrow shaft (r 0.6 mm) onto orifice A opens the chamber and clears sight lines,
  // with nothing removed below the floor: it used to earn the floor's 3 points; the floor it
  // reached is the shaft's footprint, a few % of the outline's.
  VoxelVolume shaft = c.start.clone();
  carve(shaft, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 4, p.y() - 5) <= 0.6 && p.z() >= 3.95; });
  const OutcomeScores sf = c.score(shaft);
  ASSERT_GT(sf.criteria[0].value, 0.0) << sf.criteria[0].detail;  // the chamber is open
  EXPECT_EQ(sf.criteria[5].value, 0.0);                             // nothing removed below the floor
  EXPECT_LT(sf.criteria[5].score, 0.3) << sf.criteria[5].detail;
  EXPECT_TRUE(has(sf.criteria[5].detail, "of the floor reached")) << sf.criteria[5].detail;
  EXPECT_FALSE(sf.complete);
  // The ideal access reaches the whole floor: full marks (the test above checks all 18 points).
  const OutcomeScores id = c.score(c.ideal());
  EXPECT_EQ(id.criteria[5].score, 3.0) << id.criteria[5].detail;
  EXPECT_TRUE(has(id.criteria[5].detail, "100 % of the floor reached")) << id.criteria[5].detail;
}

TEST(OutcomeCases, AccessOpeningFlaredOutlineIsMeasuredAndChargedOnlyWithARate) {
  AccessCase c;
  EXPECT_EQ(c.score(c.ideal()).access_zone_mm3, 0.0);
  // The walls flared 0.6 mm beyond the 2.5 mm outline from z 6 mm up (inside the 1 mm zone).
  VoxelVolume flared = c.ideal();
  carve(flared, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 3.1 && p.z() >= 6.0; });
  const OutcomeScores free = c.score(flared);
  // Ring volume pi (3.1^2 - 2.5^2) x (10 - 6) mm = 42 mm3, within a voxel layer.
  EXPECT_GT(free.access_zone_mm3, 30.0);
  EXPECT_LT(free.access_zone_mm3, 55.0);
  EXPECT_EQ(free.beyond_zone_mm3, 0.0);
  for (const auto& p : free.penalties) EXPECT_EQ(p.name.find("over-extended outline"), std::string::npos) << "rate 0: reported only";
  c.ex.access_zone_rate = 1;
  const OutcomeScores charged = c.score(flared);
  double cost = 0;
  int walls = 0;
  for (const auto& p : charged.penalties)
    if (p.name.rfind("over-extended outline, ", 0) == 0) {
      cost += p.points;
      ++walls;
      EXPECT_TRUE(has(p.why, "outside the access outline")) << p.why;
    }
  EXPECT_EQ(walls, 4) << "a ring all round: every wall pays its own part";
  EXPECT_NEAR(cost, std::min(18.0, 18.0 / charged.target_mm3 * charged.access_zone_mm3), 1e-9);
  EXPECT_NEAR(charged.points, std::max(0.0, free.points - cost), 1e-9);
}

// Issue 25, session 21: tooth cut away outside the access outline costs its price per mm3 beyond the
// free margin (the shipped molar: rate 1, 0.15 mm), said in its sentence; the walls' shape criteria
// do not see a gouge between the four wall directions, so the score falls by exactly that price.
TEST(OutcomeCases, AccessGougeOutsideTheOutlineCostsItsStatedPrice) {
  AccessCase c;
  c.ex.access_zone_rate = 1;
  c.ex.access_zone_free_mm = 0.15;
  const OutcomeScores un = c.score(c.start);
  EXPECT_EQ(un.points, 0.0);
  EXPECT_TRUE(un.penalties.empty());
  const OutcomeScores id = c.score(c.ideal());
  EXPECT_NEAR(id.points, 18.0, 1e-9);
  EXPECT_EQ(id.access_zone_charged_mm3, 0.0);
  for (const auto& p : id.penalties) EXPECT_EQ(p.name.find("over-extended outline"), std::string::npos) << p.why;
  // A gouge 0.5 mm past the outline at 45 deg (between the distal and palatal walls), z 6 mm up.
  VoxelVolume gouge = c.ideal();
  const double g = 5 + 2.5 * std::sqrt(0.5);
  carve(gouge, [g](const Eigen::Vector3d& p) { return std::hypot(p.x() - g, p.y() - g) <= 0.5 && p.z() >= 6.0; });
  const OutcomeScores go = c.score(gouge);
  EXPECT_NEAR(go.earned_points, id.earned_points, 1e-9) << "the walls' shape criteria do not see it";
  EXPECT_GT(go.access_zone_charged_mm3, 0.5);
  EXPECT_LT(go.access_zone_charged_mm3, go.access_zone_mm3) << "what lies within 0.15 mm is not charged";
  const double per_mm3 = 18.0 / go.target_mm3;
  // Session 23: one penalty per wall the gouge reaches (it straddles the distal and palatal quarters),
  // each its own wall's mm3 at the price; together the whole charge.
  double cost = 0;
  static const char* kWall[4] = {"mesial", "distal", "buccal", "palatal"};
  for (std::size_t w = 0; w < 4; ++w) {
    const Penalty* p = nullptr;
    for (const auto& q : go.penalties)
      if (q.name == std::string("over-extended outline, ") + kWall[w] + " wall") p = &q;
    if (w == 0 || w == 2) {
      EXPECT_EQ(p, nullptr) << kWall[w];
      continue;
    }
    ASSERT_NE(p, nullptr) << kWall[w];
    cost += p->points;
    const double mm3 = go.access_zone_charged_by_wall_mm3[w];
    EXPECT_GT(mm3, 0.1) << kWall[w];
    EXPECT_NEAR(p->points, per_mm3 * mm3, 1e-9);
    char want[128];
    std::snprintf(want, sizeof want, "%s wall: %.2f mm3 of sound tooth above the floor", kWall[w], mm3);
    EXPECT_TRUE(has(p->why, want)) << p->why;
    EXPECT_TRUE(has(p->why, "more than 0.15 mm outside the access outline")) << p->why;
    std::snprintf(want, sizeof want, "charges %.3f points per mm3", per_mm3);
    EXPECT_TRUE(has(p->why, want)) << p->why;
    std::snprintf(want, sizeof want, ": %.3f x %.2f = %.2f points.", per_mm3, mm3, p->points);
    EXPECT_TRUE(has(p->why, want)) << p->why;
    EXPECT_TRUE(has(p->why, " mm2 of the wall, up to ")) << p->why;
  }
  EXPECT_NEAR(go.access_zone_charged_by_wall_mm3[1] + go.access_zone_charged_by_wall_mm3[3], go.access_zone_charged_mm3,
              1e-9);
  EXPECT_NEAR(cost, per_mm3 * go.access_zone_charged_mm3, 1e-9);
  EXPECT_GT(cost, 0.05);
  EXPECT_NEAR(go.points, id.points - cost, 1e-9);
  EXPECT_LT(go.points, id.points);
  // Free margin 0 charges the whole zone removal (session 12's rule).
  c.ex.access_zone_free_mm = 0;
  // (less a wall's sliver under 0.005 mm3, not charged: session 23)
  EXPECT_NEAR(c.score(gouge).access_zone_charged_mm3, go.access_zone_mm3, 0.02);
}

// Issue 25, session 22: each wall's over-extension past the access outline in mm, a percentile of
// its direction-levels, priced per mm past the free margin, one penalty and sentence per wall; the
// same hand-made cut at 0.1 and 0.15 mm voxels prices within the stated tolerance.
struct WallCase : AccessCase {
  explicit WallCase(double h_mm) : AccessCase(h_mm) {
    ex.wall_overextension_points_per_mm = 6;
    ex.wall_overextension_free_mm = 0.3;
    ex.wall_overextension_percentile = 95;
  }
  // The ideal access plus the mesial wall (-x, the quarter 135..225 deg around the axis) cut
  // `over_mm` past the outline over the wall's whole height.
  VoxelVolume mesial_over(double over_mm) const {
    VoxelVolume c = ideal();
    carve(c, [over_mm](const Eigen::Vector3d& p) {
      const double dx = p.x() - 5, dy = p.y() - 5;
      return p.z() >= 3.05 && std::hypot(dx, dy) <= 2.5 + over_mm && dx < 0 && std::abs(dy) <= -dx;
    });
    return c;
  }
};

const Penalty* penalty(const OutcomeScores& o, const std::string& name) {
  for (const auto& p : o.penalties)
    if (p.name == name) return &p;
  return nullptr;
}

TEST(OutcomeCases, AccessWallOverExtendedInMmCostsItsPriceAtBothVoxelSizes) {
  // The stated tolerance between 0.1 and 0.15 mm voxels: 0.1 mm (0.6 points at 6 per mm). Measured (session
  // 22): 0.675 mm at 0.1 mm voxels, 0.600 at 0.15. A percentile near the top of a wall's direction-levels
  // takes the upper tail of the grid's quantisation (the cut's and the outline's voxel faces meet a ray
  // up to about 0.7 voxel apart, the same at every level of a vertical wall).
  constexpr double kTolMm = 0.1;
  double cost_at[2] = {-1, -1}, mm_at[2] = {-1, -1};
  const double sizes[2] = {0.1, 0.15};
  for (int s = 0; s < 2; ++s) {
    SCOPED_TRACE(sizes[s]);
    const WallCase c(sizes[s]);
    const OutcomeScores un = c.score(c.start);
    EXPECT_EQ(un.points, 0.0);
    EXPECT_EQ(penalty(un, "mesial wall over-extended"), nullptr);
    const OutcomeScores id = c.score(c.ideal());
    EXPECT_NEAR(id.points, 18.0, 1e-9);
    for (std::size_t w = 0; w < 4; ++w) EXPECT_LE(id.wall_overextension_mm[w], 0.3) << w;
    for (const auto& p : id.penalties) EXPECT_EQ(p.name.find("over-extended"), std::string::npos) << p.why;
    const OutcomeScores ov = c.score(c.mesial_over(0.6));
    EXPECT_NEAR(ov.earned_points, id.earned_points, 1e-9) << "the walls' shape criteria do not change";
    // The mesial wall lies 0.6 mm past the outline over its quarter of the outline (2 pi 2.5 / 4 = 3.9 mm).
    EXPECT_NEAR(ov.wall_overextension_mm[0], 0.6, 0.1);
    EXPECT_GT(ov.wall_overextension_length_mm[0], 3.0);
    EXPECT_LT(ov.wall_overextension_length_mm[0], 4.5);
    for (std::size_t w = 1; w < 4; ++w) EXPECT_LE(ov.wall_overextension_mm[w], 0.3) << w;
    const Penalty* p = penalty(ov, "mesial wall over-extended");
    ASSERT_NE(p, nullptr);
    const double over = std::round(100 * ov.wall_overextension_mm[0]) / 100;
    EXPECT_NEAR(p->points, 6 * (over - 0.3), 1e-9);
    char want[160];
    std::snprintf(want, sizeof want, "mesial wall over-extended %.2f mm past the access outline over %.1f mm of its length",
                  over, ov.wall_overextension_length_mm[0]);
    EXPECT_TRUE(has(p->why, want)) << p->why;
    std::snprintf(want, sizeof want, "6.00 points per mm past 0.30 mm: 6.00 x %.2f = %.2f points.", over - 0.3, p->points);
    EXPECT_TRUE(has(p->why, want)) << p->why;
    ASSERT_EQ(ov.penalties.size(), id.penalties.size() + 1) << "only the mesial wall is charged";
    EXPECT_NEAR(ov.points, id.points - p->points, 1e-9);
    EXPECT_LT(ov.points, id.points - 1.0);
    cost_at[s] = p->points;
    mm_at[s] = ov.wall_overextension_mm[0];
  }
  EXPECT_NEAR(mm_at[0], mm_at[1], kTolMm);
  EXPECT_NEAR(cost_at[0], cost_at[1], 6 * kTolMm + 1e-9);
  EXPECT_NEAR(cost_at[0], 6 * 0.3, 6 * 0.1);
  EXPECT_NEAR(cost_at[1], 6 * 0.3, 6 * 0.1);
}

// Issue 25, session 23: the over-extended outline priced per wall by its volume past the free margin
// (its depth past the margin integrated over the wall's length and height), so that a local gouge
// costs by its size: the same hand-made cut at 0.1 and 0.15 mm voxels within the stated tolerance.
TEST(OutcomeCases, AccessOverExtendedWallCostsItsVolumeAtBothVoxelSizes) {
  // Stated tolerance: 15 % of the mesial wall's charged volume between the two voxel sizes (a cut
  // face and the free margin's 0.05 mm bands each fall within half a voxel: at 0.15 mm voxels
  // +-0.075 mm on 0.45 mm past the margin). Measured at the commit: see docs/BENCHMARKS.md.
  constexpr double kTolRel = 0.15;
  double mm3_at[2] = {-1, -1}, cost_at[2] = {-1, -1};
  const double sizes[2] = {0.1, 0.15};
  for (int s = 0; s < 2; ++s) {
    SCOPED_TRACE(sizes[s]);
    WallCase c(sizes[s]);
    c.ex.wall_overextension_points_per_mm = 0;  // the session 22 rule off: the volume per wall alone
    c.ex.access_zone_rate = 1;
    c.ex.access_zone_free_mm = 0.15;
    EXPECT_EQ(c.score(c.start).points, 0.0);
    const OutcomeScores id = c.score(c.ideal());
    EXPECT_NEAR(id.points, 18.0, 1e-9);
    for (const auto& p : id.penalties) EXPECT_EQ(p.name.find("over-extended"), std::string::npos) << p.why;
    const OutcomeScores ov = c.score(c.mesial_over(0.6));
    EXPECT_NEAR(ov.earned_points, id.earned_points, 1e-9);
    // The mesial quarter ring 2.65..3.1 mm from the axis, z 3.05..10 mm: pi / 4 (3.1^2 - 2.65^2) x 6.95
    // = 14.1 mm3 past the margin (2.5..2.65 mm nearer, not charged).
    const double want = M_PI / 4 * (3.1 * 3.1 - 2.65 * 2.65) * 6.95;
    EXPECT_NEAR(ov.access_zone_charged_by_wall_mm3[0], want, kTolRel * want);
    // The other walls: at most the voxels on the quarter's 45 deg edges (0.31 mm3 at 0.15 mm voxels).
    for (std::size_t w = 1; w < 4; ++w) EXPECT_LT(ov.access_zone_charged_by_wall_mm3[w], 0.05 * want) << w;
    const Penalty* p = penalty(ov, "over-extended outline, mesial wall");
    ASSERT_NE(p, nullptr);
    const double per_mm3 = 18.0 / ov.target_mm3;
    EXPECT_NEAR(p->points, per_mm3 * ov.access_zone_charged_by_wall_mm3[0], 1e-9);
    // Its area past the margin: the quarter's arc at the outline (2 pi 2.5 / 4 = 3.9 mm) over the
    // measured height (3.0..9.5 mm: 6.5 mm): about 25.5 mm2.
    EXPECT_NEAR(ov.wall_overextended_area_mm2[0], 3.93 * 6.5, 0.2 * 3.93 * 6.5);
    EXPECT_TRUE(has(p->why, "mesial wall: ")) << p->why;
    EXPECT_TRUE(has(p->why, " mm2 of the wall, up to 0.")) << p->why;
    double charged = 0;
    for (const auto& q : ov.penalties)
      if (q.name.rfind("over-extended outline, ", 0) == 0) charged += q.points;
    EXPECT_NEAR(ov.points, id.points - charged, 1e-9) << "the sentences add up to the charge";
    mm3_at[s] = ov.access_zone_charged_by_wall_mm3[0];
    cost_at[s] = p->points;
    // A local gouge of the same depth over a sixth of the wall's height costs about a sixth as much.
    VoxelVolume local = c.ideal();
    carve(local, [](const Eigen::Vector3d& q) {
      const double dx = q.x() - 5, dy = q.y() - 5;
      return q.z() >= 7.0 && q.z() <= 8.15 && std::hypot(dx, dy) <= 3.1 && dx < 0 && std::abs(dy) <= -dx;
    });
    const OutcomeScores lo = c.score(local);
    const Penalty* lp = penalty(lo, "over-extended outline, mesial wall");
    ASSERT_NE(lp, nullptr);
    EXPECT_NEAR(lp->points / p->points, 1.15 / 6.95, 0.06);
  }
  EXPECT_NEAR(mm3_at[0], mm3_at[1], kTolRel * mm3_at[0]);
  EXPECT_NEAR(cost_at[0], cost_at[1], kTolRel * cost_at[0]);
  std::printf("[ session 23 ] mesial wall 0.6 mm past: %.3f mm3 -> %.3f points at 0.1 mm, %.3f mm3 -> %.3f at 0.15 mm\n",
              mm3_at[0], cost_at[0], mm3_at[1], cost_at[1]);
}

// Issue 25, session 23: the access left standing below the exercise's full share costs the
// over-extension's price per mm3; the floor gouged past the 1 mm3 its integrity covers costs the same
// (not when it is perforated: the perforation prices that).
TEST(OutcomeCases, AccessLeftStandingAndFloorGougedCostTheirStatedPrice) {
  AccessCase c;
  c.ex.under_extension_rate = 1;
  c.ex.under_extension_full_pct = 90;
  c.ex.floor_overflow_rate = 1;
  const OutcomeScores un = c.score(c.start);
  EXPECT_EQ(un.points, 0.0);
  EXPECT_FALSE(un.complete);
  const OutcomeScores id = c.score(c.ideal());
  EXPECT_NEAR(id.points, 18.0, 1e-9);
  EXPECT_GE(id.target_coverage_pct, 90.0);
  EXPECT_EQ(penalty(id, "under-extended access"), nullptr);
  EXPECT_EQ(penalty(id, "floor gouged"), nullptr);
  // Stopped short of the outline: r 2.0 of the 2.5 mm outline, the whole depth.
  VoxelVolume shortc = c.start.clone();
  carve(shortc, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 2.0 && p.z() >= 3.05; });
  const OutcomeScores sh = c.score(shortc);
  ASSERT_LT(sh.target_coverage_pct, 80.0);
  const Penalty* u = penalty(sh, "under-extended access");
  ASSERT_NE(u, nullptr);
  const double per_mm3 = 18.0 / sh.target_mm3;
  const double short_mm3 = (90 - sh.target_coverage_pct) / 100 * sh.target_mm3;
  EXPECT_NEAR(u->points, per_mm3 * short_mm3, 1e-9);
  char want[128];
  std::snprintf(want, sizeof want, "%.3f x %.2f = %.2f points.", per_mm3, short_mm3, u->points);
  EXPECT_TRUE(has(u->why, want)) << u->why;
  EXPECT_TRUE(has(u->why, "full from 90 % removed")) << u->why;
  EXPECT_NEAR(sh.points, std::max(0.0, sh.earned_points - u->points), 1e-9);
  c.ex.under_extension_rate = 0;
  EXPECT_EQ(penalty(c.score(shortc), "under-extended access"), nullptr) << "rate 0: not charged";
  c.ex.under_extension_rate = 1;
  // The floor gouged: a shaft r 0.8 mm from the floor (z 3) 1 mm down: about 2.0 mm3 below it.
  VoxelVolume gouge = c.ideal();
  carve(gouge, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 0.8 && p.z() >= 2.0; });
  const OutcomeScores go = c.score(gouge);
  ASSERT_FALSE(go.perforation);
  EXPECT_NEAR(go.floor_below_mm3, M_PI * 0.64 * 1.0, 0.3);
  EXPECT_EQ(go.criteria[5].score, 0.0) << go.criteria[5].detail;
  const Penalty* f = penalty(go, "floor gouged");
  ASSERT_NE(f, nullptr);
  EXPECT_NEAR(f->points, per_mm3 * (go.floor_below_mm3 - 1.0), 1e-9);
  std::snprintf(want, sizeof want, "%.3f x %.2f = %.2f points.", per_mm3, go.floor_below_mm3 - 1.0, f->points);
  EXPECT_TRUE(has(f->why, want)) << f->why;
  std::string all;
  for (std::size_t k = 0; k < go.criteria.size(); ++k)
    all += go.criteria[k].name + " " + std::to_string(go.criteria[k].score) + " (ideal " + std::to_string(id.criteria[k].score) + "); ";
  for (const auto& q : go.penalties) all += q.name + " -" + std::to_string(q.points) + "; ";
  // (The band-scored walls of this case also see the shaft: their points are the criteria's.)
  EXPECT_LE(go.earned_points, id.earned_points - 3.0 + 1e-9) << all;
  EXPECT_NEAR(go.points, std::max(0.0, go.earned_points - f->points), 1e-9) << "the price past 1 mm3: " << all;
  // Less than 1 mm3 below the floor (r 0.5 mm, 1 mm down: 0.79 mm3): the floor criterion's alone.
  VoxelVolume small = c.ideal();
  carve(small, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 0.5 && p.z() >= 2.0; });
  const OutcomeScores sm = c.score(small);
  ASSERT_FALSE(sm.perforation);
  EXPECT_LT(sm.floor_below_mm3, 1.0);
  EXPECT_EQ(penalty(sm, "floor gouged"), nullptr);
  // Perforated through the floor: the perforation's 9 points, no floor-gouged charge beside it.
  VoxelVolume through = c.ideal();
  carve(through, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 0.5; });
  const OutcomeScores pe = c.score(through);
  ASSERT_TRUE(pe.perforation);
  EXPECT_EQ(penalty(pe, "floor gouged"), nullptr);
  EXPECT_NE(penalty(pe, "perforation"), nullptr);
}

}  // namespace
}  // namespace dentar::training

namespace dentar::training {
namespace {

TEST(Outcome, SpearmanRankCorrelationWithTies) {
  EXPECT_NEAR(spearman_rho({1, 2, 3, 4}, {10, 20, 30, 40}), 1.0, 1e-12);
  EXPECT_NEAR(spearman_rho({1, 2, 3, 4}, {4, 3, 2, 1}), -1.0, 1e-12);
  // Ties take their mean rank: x ranks (1, 2.5, 2.5, 4), y ranks (1, 2, 3, 4).
  EXPECT_NEAR(spearman_rho({1, 2, 2, 3}, {1, 2, 3, 4}), 4.5 / std::sqrt(4.5 * 5.0), 1e-12);
  EXPECT_TRUE(std::isnan(spearman_rho({1, 1, 1}, {1, 2, 3})));
  EXPECT_TRUE(std::isnan(spearman_rho({1}, {1})));
}

}  // namespace
}  // namespace dentar::training

namespace dentar::training {
namespace {

// Issue 25 (session 14): a graded exercise's wall taper. The well of `Cases` (r 2 mm from z 6 mm to the
// top), measured from z 6.5 to 9.5 mm; 4 points, full between -5 and +2 deg, none 10 deg outside.
struct TaperCase : Cases {
  TaperCase() {
    WallTaper t;
    t.points = 4;
    t.axis_point_m = Eigen::Vector3d(5e-3, 5e-3, 0);
    t.from_z_m = 6.5e-3;
    t.to_z_m = 9.5e-3;
    ex.wall_taper = t;
  }
  // A well whose radius grows by tan(deg) per mm upward from 2 mm at z 6 (deg < 0: an undercut).
  VoxelVolume cone(double deg) const {
    VoxelVolume c = start.clone();
    const double t = std::tan(deg * M_PI / 180);
    carve(c, [&](const Eigen::Vector3d& p) { return p.z() >= 6.0 && std::hypot(p.x() - 5, p.y() - 5) <= 2.0 + (p.z() - 6.0) * t; });
    return c;
  }
};

TEST(OutcomeCases, WallTaperGradesEachWallAgainstTheIdealRange) {
  const TaperCase c;
  EXPECT_EQ(c.ex.max_points(), 8.0);  // the region's 4 + the taper's 4
  // Untouched: no cavity, so no wall: 0, and the total stays 0.
  const OutcomeScores un = c.score(c.start);
  ASSERT_EQ(un.criteria.size(), 1u);
  EXPECT_EQ(un.criteria[0].name, "wall taper");
  EXPECT_EQ(un.criteria[0].score, 0.0);
  EXPECT_EQ(un.criteria[0].max_score, 4.0);
  EXPECT_TRUE(has(un.criteria[0].detail, "not formed")) << un.criteria[0].detail;
  EXPECT_EQ(un.points, 0.0);
  // Parallel walls: every wall in the range, all 4 points, and the region's 4: 8 of 8.
  const OutcomeScores par = c.score(c.well(2.0, 6.0));
  EXPECT_NEAR(par.criteria[0].score, 4.0, 1e-9) << par.criteria[0].detail;
  EXPECT_NEAR(par.points, 8.0, 0.02);
  EXPECT_TRUE(has(par.criteria[0].detail, "4.00 of 4")) << par.criteria[0].detail;
  // Diverging 10 deg: 8 deg past +2 on every wall: 1 x (1 - 8/10) = 0.2 each (the measured angle is
  // within about 1 deg of the carved one: WallDivergenceAndSmoothness), and exactly that from the
  // measured mean excess (`value`).
  const OutcomeScores div = c.score(c.cone(10));
  EXPECT_NEAR(div.criteria[0].value, 8.0, 1.0);
  EXPECT_NEAR(div.criteria[0].score, 4.0 * (1.0 - div.criteria[0].value / 10.0), 1e-9) << div.criteria[0].detail;
  EXPECT_TRUE(has(div.criteria[0].detail, "diverging")) << div.criteria[0].detail;
  // Converging 8 deg (an undercut beyond the 5 deg of retention form): 3 deg too much, 0.7 each.
  const OutcomeScores con = c.score(c.cone(-8));
  EXPECT_NEAR(con.criteria[0].score, 2.8, 0.3) << con.criteria[0].detail;
  EXPECT_TRUE(has(con.criteria[0].detail, "converging")) << con.criteria[0].detail;
  // Converging 3 deg: within the range, full points.
  EXPECT_NEAR(c.score(c.cone(-3)).criteria[0].score, 4.0, 1e-9);
  // The points add to the total and pulp exposure still costs what the exercise says.
  EXPECT_NEAR(div.earned_points, div.regions[0].points + div.criteria[0].score, 1e-9);
  const OutcomeScores exp = c.score(c.well(2.0, 5.4));
  ASSERT_TRUE(exp.pulp_exposed);
  EXPECT_NEAR(exp.points, std::max(0.0, exp.earned_points - 2.5), 1e-9);
  // A shallow cut (0.8 mm deep, a quarter of the measured height) forms no wall.
  EXPECT_EQ(c.score(c.well(2.0, 9.2)).criteria[0].score, 0.0);
}

// Issue 25 (session 19): with outline_reach_full_pct, a wall earns its taper points in proportion to how
// far it reaches toward the target's outline (the well's r 2 mm), full at that reach: a cavity not cut
// out to its outline does not earn the taper of walls it has not cut.
TEST(OutcomeCases, WallTaperIsEarnedOnlyAsFarAsTheOutlineIsReached) {
  TaperCase c;
  c.ex.wall_taper->outline_reach_full_pct = 90;
  // Untouched: still 0.
  const OutcomeScores un = c.score(c.start);
  EXPECT_EQ(un.criteria[0].score, 0.0);
  EXPECT_EQ(un.points, 0.0);
  // The complete cavity (the whole well, parallel walls): its walls reach the outline, full marks.
  const OutcomeScores full = c.score(c.well(2.0, 6.0));
  EXPECT_NEAR(full.criteria[0].score, 4.0, 1e-9) << full.criteria[0].detail;
  EXPECT_NEAR(full.points, 8.0, 0.02);
  EXPECT_FALSE(has(full.criteria[0].detail, "reach of the outline")) << full.criteria[0].detail;
  // An unfinished outline: a parallel-walled well of r 1 mm, full depth. Without the rule its walls
  // earn the whole 4 points; with it each wall reaches about half way (1.0 of 2.0 mm, each measured to
  // the surface half a voxel past the last open / target voxel centre): 4 x 0.5 / 0.9.
  const VoxelVolume narrow = c.well(1.0, 6.0);
  const OutcomeScores nr = c.score(narrow);
  EXPECT_NEAR(nr.criteria[0].score, 4.0 * 0.5 / 0.9, 0.25) << nr.criteria[0].detail;
  EXPECT_TRUE(has(nr.criteria[0].detail, "reach of the outline")) << nr.criteria[0].detail;
  EXPECT_FALSE(nr.complete) << nr.completion;
  TaperCase off;  // the rule before session 19: the same walls earn everything
  EXPECT_NEAR(off.score(narrow).criteria[0].score, 4.0, 1e-9);
  // The region's points do not change with the rule: only the taper moved.
  EXPECT_NEAR(nr.regions[0].points, off.score(narrow).regions[0].points, 1e-12);
  // Reached out to the outline but only two thirds of the measured height (z 7.5 up; 6.5-9.5 measured):
  // a layer not reached counts 0, reach 2/3: 4 x (2/3) / 0.9.
  const OutcomeScores shallow = c.score(c.well(2.0, 7.5));
  EXPECT_NEAR(shallow.criteria[0].score, 4.0 * (2.0 / 3.0) / 0.9, 0.25) << shallow.criteria[0].detail;
  // Never more than the rule before gives.
  EXPECT_LE(shallow.criteria[0].score, off.score(c.well(2.0, 7.5)).criteria[0].score + 1e-12);
}

// Continuous access points: each criterion falls with what it measures, between the bands' thresholds.
TEST(OutcomeCases, ContinuousAccessPointsFallWithTheDeviation) {
  AccessCase c;
  c.ex.access_points = AccessPoints::kContinuous;
  // Untouched: still 0 on every criterion.
  const OutcomeScores un = c.score(c.start);
  EXPECT_EQ(un.points, 0.0);
  for (const auto& k : un.criteria) EXPECT_EQ(k.score, 0.0) << k.name << ": " << k.detail;
  // The ideal well: orifices and floor 3; straight walls lose only their voxel roughness (RMS / 0.15 mm).
  const OutcomeScores id = c.score(c.ideal());
  EXPECT_EQ(id.criteria[0].score, 3.0) << id.criteria[0].detail;
  EXPECT_EQ(id.criteria[5].score, 3.0) << id.criteria[5].detail;
  for (int w = 1; w <= 4; ++w) {
    EXPECT_GT(id.criteria[w].score, 2.6) << id.criteria[w].detail;
    EXPECT_LE(id.criteria[w].score, 3.0);
    EXPECT_TRUE(has(id.criteria[w].detail, "for its roughness")) << id.criteria[w].detail;
  }
  // A small gouge below the floor (r 0.4 mm, 0.3 mm deep: about 0.15 mm3): the bands give 2, the
  // continuous rule 3 x (1 - mm3).
  VoxelVolume nick = c.ideal();
  carve(nick, [](const Eigen::Vector3d& p) { return std::hypot(p.x() - 5, p.y() - 5) <= 0.4 && p.z() >= 2.75; });
  const OutcomeScores nc = c.score(nick);
  const double below = nc.criteria[5].value;
  ASSERT_GT(below, 0.05);
  ASSERT_LT(below, 0.3);
  EXPECT_NEAR(nc.criteria[5].score, 3.0 * (1.0 - below), 1e-9) << nc.criteria[5].detail;
  c.ex.access_points = AccessPoints::kBands;
  EXPECT_EQ(c.score(nick).criteria[5].score, 2.0);
  c.ex.access_points = AccessPoints::kContinuous;
  // Walls flared 35 deg: 10 deg past the free 25 deg costs 1 point (at 10 deg a point).
  VoxelVolume flared = c.start.clone();
  const double t35 = std::tan(35 * M_PI / 180);
  carve(flared, [&](const Eigen::Vector3d& p) {
    return p.z() >= 3.05 && std::hypot(p.x() - 5, p.y() - 5) <= 1.6 + (p.z() - 3.05) * t35;
  });
  const OutcomeScores fl = c.score(flared);
  for (int w = 1; w <= 4; ++w) {
    EXPECT_TRUE(has(fl.criteria[w].detail, "for over-flaring")) << fl.criteria[w].detail;
    EXPECT_LT(fl.criteria[w].score, 2.3) << fl.criteria[w].detail;
  }
  // With the flare free up to 5 deg at 5 deg a point (exercise fields), the same walls lose 2 (the cap).
  c.ex.access_flare_free_deg = 5;
  c.ex.access_flare_deg_per_point = 5;
  for (int w = 1; w <= 4; ++w) EXPECT_LT(c.score(flared).criteria[w].score, 1.01);
}

// Issue 25, session 20: the continuous orifice criterion grades straight-line access. A partial
// unroofing (two holes through the chamber's roof, one over each orifice) clears every sight line
// straight up from the orifices, which the old criterion paid in full (3 of 3), but leaves the roof
// as shelves over the chamber: it earns in proportion to the roof removed. The ideal access 3,
// untouched 0; a file path along a canal axis tilted past the opening's side is blocked.
TEST(OutcomeCases, StraightLineAccessPaysARemovedRoofNotSightLines) {
  AccessCase c;
  c.ex.access_points = AccessPoints::kContinuous;
  const AccessGeometry& a = *c.ex.access;
  EXPECT_EQ(c.score(c.start).criteria[0].score, 0.0);
  EXPECT_EQ(roof_removed(c.start, c.start, 3.2e-3), 0.0);
  const OutcomeScores id = c.score(c.ideal());
  EXPECT_EQ(id.criteria[0].name, "straight-line access");
  EXPECT_EQ(id.criteria[0].score, 3.0) << id.criteria[0].detail;
  EXPECT_EQ(roof_removed(c.start, c.ideal(), 3.2e-3), 1.0);
  // The access cut down to 0.5 mm above the chamber (roof 4.0..4.5 mm left), then a hole of r 0.9 mm
  // through the roof over each orifice.
  VoxelVolume partial = c.start.clone();
  carve(partial, [](const Eigen::Vector3d& p) {
    return (std::hypot(p.x() - 5, p.y() - 5) <= 2.5 && p.z() >= 4.5) ||
           ((std::hypot(p.x() - 4, p.y() - 5) <= 0.9 || std::hypot(p.x() - 6, p.y() - 5) <= 0.9) && p.z() >= 3.95);
  });
  for (const auto& f : a.orifices) EXPECT_EQ(line_of_sight(partial, f.position_m, a.opening_z_m, 10), 1.0) << f.name;
  const double roof = roof_removed(c.start, partial, 3.2e-3);
  EXPECT_GT(roof, 0.3);
  EXPECT_LT(roof, 0.8);
  const OutcomeScores pa = c.score(partial);
  EXPECT_NEAR(pa.criteria[0].score, 3.0 * roof / 0.9, 0.05) << pa.criteria[0].detail;  // the paths clear
  EXPECT_LT(pa.criteria[0].score, id.criteria[0].score - 0.5);
  EXPECT_TRUE(has(pa.criteria[0].detail, "% of the pulp chamber's roof and horns is removed")) << pa.criteria[0].detail;
  EXPECT_TRUE(has(pa.criteria[0].detail, "Sight lines straight up from the orifices: 100 % clear")) << pa.criteria[0].detail;
  // A file path along a canal axis tilted 40 deg toward -x from orifice A leaves the r 2.5 mm access
  // through its side: blocked where the vertical paths are clear.
  const Eigen::Vector3d tilted(-std::sin(40 * M_PI / 180), 0, std::cos(40 * M_PI / 180));
  EXPECT_EQ(straight_line_access(c.ideal(), a.orifices[0].position_m, Eigen::Vector3d::UnitZ(), a.opening_z_m, 0.2e-3, 0),
            1.0);
  EXPECT_EQ(straight_line_access(c.ideal(), a.orifices[0].position_m, tilted, a.opening_z_m, 0.2e-3, 0), 0.0);
  EXPECT_EQ(straight_line_access(c.start, a.orifices[0].position_m, Eigen::Vector3d::UnitZ(), a.opening_z_m, 0.2e-3, 10),
            0.0);
}

TEST(Exercise, AccessPointsAndWallTaperFieldsAreCheckedAndNamed) {
  const std::string graded = R"({"format":"dentar-exercise","version":1,"name":"t","procedure":"p",
    "tooth":{"kind":"molar","voxel_mm":0.2},"bur":{"shape":"sphere","radius_mm":0.5},"time_limit_s":60,
    "regions":[{"name":"a","role":"target","points":7,"all":[{"shape":"sphere","center_mm":[0,0,5],"radius_mm":1}]}],
    "steps":[{"name":"s1","region":"a"}],
    "outcome":{"kind":"graded_regions","wall_taper":{"points":3,"axis_point_mm":[0,0,0],"from_z_mm":4.2,"to_z_mm":5.7}}})";
  auto ok = parse_exercise(graded, "t.json");
  ASSERT_TRUE(ok.ok()) << ok.error();
  ASSERT_TRUE(ok->wall_taper.has_value());
  EXPECT_EQ(ok->max_points(), 10.0);
  EXPECT_NEAR(ok->wall_taper->from_z_m, 4.2e-3, 1e-12);
  EXPECT_EQ(ok->wall_taper->ideal_min_deg, -5.0);
  EXPECT_EQ(ok->wall_taper->ideal_max_deg, 2.0);
  auto err = [](const std::string& text, const std::string& needle) {
    auto r = parse_exercise(text, "t.json");
    ASSERT_FALSE(r.ok()) << needle;
    EXPECT_NE(r.error().find(needle), std::string::npos) << r.error();
    EXPECT_NE(r.error().find("t.json"), std::string::npos) << r.error();
  };
  auto rep = [&](const std::string& a, const std::string& b) {
    std::string s = graded;
    s.replace(s.find(a), a.size(), b);
    return s;
  };
  err(rep("\"to_z_mm\":5.7", "\"to_z_mm\":4.0"), "outcome.wall_taper.to_z_mm");
  err(rep("\"points\":3,", ""), "outcome.wall_taper.points");
  err(rep("\"to_z_mm\":5.7", "\"to_z_mm\":5.7,\"ideal_min_deg\":5"), "outcome.wall_taper.ideal_max_deg");
  err(rep("\"to_z_mm\":5.7", "\"to_z_mm\":5.7,\"outline_reach_full_pct\":101"), "outcome.wall_taper.outline_reach_full_pct");
  // Session 21: the access opening's free margin outside the outline, checked and named.
  err(rep("\"kind\":\"graded_regions\",", "\"kind\":\"graded_regions\",\"access_zone_free_mm\":-0.1,"),
      "outcome.access_zone_free_mm");
  err(rep("\"kind\":\"graded_regions\",", "\"kind\":\"graded_regions\",\"access_zone_free_mm\":\"x\","),
      "outcome.access_zone_free_mm");
  // Session 22: the walls' over-extension in mm.
  err(rep("\"kind\":\"graded_regions\",", "\"kind\":\"graded_regions\",\"wall_overextension_points_per_mm\":-1,"),
      "outcome.wall_overextension_points_per_mm");
  err(rep("\"kind\":\"graded_regions\",", "\"kind\":\"graded_regions\",\"wall_overextension_free_mm\":[0.3],"),
      "outcome.wall_overextension_free_mm");
  err(rep("\"kind\":\"graded_regions\",", "\"kind\":\"graded_regions\",\"wall_overextension_percentile\":40,"),
      "outcome.wall_overextension_percentile");
  // Session 23: the access left standing and the floor gouged past its criterion.
  err(rep("\"kind\":\"graded_regions\",", "\"kind\":\"graded_regions\",\"under_extension_rate\":-1,"),
      "outcome.under_extension_rate");
  err(rep("\"kind\":\"graded_regions\",", "\"kind\":\"graded_regions\",\"under_extension_full_pct\":120,"),
      "outcome.under_extension_full_pct");
  err(rep("\"kind\":\"graded_regions\",", "\"kind\":\"graded_regions\",\"floor_overflow_rate\":\"x\","),
      "outcome.floor_overflow_rate");
  EXPECT_EQ(ok->wall_taper->outline_reach_full_pct, 0.0);  // absent: not applied
  auto reach = parse_exercise(rep("\"to_z_mm\":5.7", "\"to_z_mm\":5.7,\"outline_reach_full_pct\":90"), "t.json");
  ASSERT_TRUE(reach.ok()) << reach.error();
  EXPECT_EQ(reach->wall_taper->outline_reach_full_pct, 90.0);
  err(rep("\"kind\":\"graded_regions\",", "\"kind\":\"graded_regions\",\"access_points\":\"continuous\","),
      "outcome.access_points");
  err(rep("\"kind\":\"graded_regions\",", "\"kind\":\"graded_regions\",\"flare_free_deg\":5,"), "outcome.flare_free_deg");
  // An access opening takes "continuous" and refuses another word, naming it.
  const std::string access = R"({"format":"dentar-exercise","version":1,"name":"t","procedure":"p",
    "tooth":{"kind":"molar","voxel_mm":0.2},"bur":{"shape":"sphere","radius_mm":0.5},"time_limit_s":60,
    "regions":[{"name":"a","role":"target","all":[{"shape":"sphere","center_mm":[0,0,5],"radius_mm":1}]}],
    "steps":[{"name":"s1","region":"a"}],
    "outcome":{"kind":"access_opening","orifices":[{"name":"o","position_mm":[0,0,1]}],"axis_point_mm":[0,0,0],
               "opening_z_mm":5,"floor_z_mm":1,"access_points":"continuous"}})";
  auto ac = parse_exercise(access, "t.json");
  ASSERT_TRUE(ac.ok()) << ac.error();
  EXPECT_EQ(ac->access_points, AccessPoints::kContinuous);
  std::string smooth = access;
  smooth.replace(smooth.find("\"continuous\""), 12, "\"smooth\"");
  err(smooth, "outcome.access_points': 'smooth'");
  std::string tapered = access;
  tapered.replace(tapered.find("\"access_points\""), 0,
                  "\"wall_taper\":{\"points\":1,\"axis_point_mm\":[0,0,0],\"from_z_mm\":1,\"to_z_mm\":2},");
  err(tapered, "outcome.wall_taper");
  // A canal axis (session 20) is normalised; one that does not rise toward occlusal is refused, named.
  const auto axis = [&](const std::string& v) {
    std::string j = access;
    const std::string at = "\"position_mm\":[0,0,1]";
    j.replace(j.find(at), at.size(), at + ",\"canal_axis\":" + v);
    return j;
  };
  auto ax = parse_exercise(axis("[0,3,4]"), "t.json");
  ASSERT_TRUE(ax.ok()) << ax.error();
  EXPECT_NEAR((ax->access->orifices[0].canal_axis - Eigen::Vector3d(0, 0.6, 0.8)).norm(), 0.0, 1e-12);
  EXPECT_EQ(ac->access->orifices[0].canal_axis, Eigen::Vector3d::UnitZ());
  err(axis("[0,1,-1]"), "outcome.orifices[0].canal_axis");
  err(axis("[0,0,0]"), "outcome.orifices[0].canal_axis");
  err(axis("[0,1]"), "outcome.orifices[0].canal_axis");
}

}  // namespace
}  // namespace dentar::training

namespace dentar::training {
namespace {

// Outline extension in mm (issue 25, session 20). Target: a box x 3-7, y 4-6 mm from z 6 mm up through
// the block's top (10 mm), 7 points of which the outline extension takes 4 (1 per wall), measured from
// z 6.5 to 9.5 mm with the rubric's bands 0.25 / 0.5 / 1.0 mm.
struct ExtensionCase {
  VoxelVolume start = block();
  Exercise ex;
  RegionMasks masks;
  ExtensionCase() {
    ex.source = "box.json";
    ex.regions = {Region{"box", RegionRole::kTarget, {box({3, 4, 6}, {7, 6, 11})}, 7.0, 0.8},
                  Region{"top", RegionRole::kEntry, {box({-1, -1, 9.85}, {11, 11, 11})}, 0, 1}};
    OutlineExtension t;
    t.points = 4;
    t.from_region = "box";
    t.axis_point_m = Eigen::Vector3d(5, 5, 0) * 1e-3;
    t.from_z_m = 6.5e-3;
    t.to_z_m = 9.5e-3;
    ex.outline_extension = t;
    auto m = build_masks(ex, start);
    EXPECT_TRUE(m.ok()) << m.error();
    masks = *m;
  }
  // The box cut with its mesial (-x) wall at x0 and the rest on the outline.
  VoxelVolume cut(double x0) const {
    VoxelVolume v = start.clone();
    carve(v, [&](const Eigen::Vector3d& p) {
      return p.x() >= x0 - 1e-9 && p.x() <= 7 + 1e-9 && p.y() >= 4 - 1e-9 && p.y() <= 6 + 1e-9 && p.z() >= 6 - 1e-9;
    });
    return v;
  }
  OutcomeScores score(const VoxelVolume& v) const {
    auto o = score_outcome(ex, masks, start, v);
    EXPECT_TRUE(o.ok()) << o.error();
    return *o;
  }
};

TEST(OutcomeCases, OutlineExtensionJudgesShortAndPastByTheSameDistance) {
  ExtensionCase c;
  EXPECT_EQ(c.ex.max_points(), 7.0);
  // Untouched: every wall is short by the whole outline (beyond 1 mm): 0, and the total 0.
  const OutcomeScores un = c.score(c.start);
  ASSERT_EQ(un.criteria.size(), 1u);
  EXPECT_EQ(un.criteria[0].name, "outline extension");
  EXPECT_EQ(un.criteria[0].score, 0.0) << un.criteria[0].detail;
  EXPECT_EQ(un.points, 0.0);
  // The ideal box: every wall on the outline, 4 of 4, and the region's coverage share 3 of 3: 7 of 7.
  const OutcomeScores id = c.score(c.cut(3.0));
  EXPECT_NEAR(id.criteria[0].score, 4.0, 1e-9) << id.criteria[0].detail;
  EXPECT_NEAR(id.regions[0].points, 3.0, 0.02) << id.regions[0].why;
  EXPECT_NEAR(id.points, 7.0, 0.02);
  EXPECT_TRUE(id.complete) << id.completion;
  // The mesial wall 0.5 mm short of the outline over its whole length: acceptable (0.85 of its 1).
  const OutcomeScores sh = c.score(c.cut(3.5));
  EXPECT_NEAR(sh.criteria[0].score, 3.85, 1e-9) << sh.criteria[0].detail;
  EXPECT_TRUE(has(sh.criteria[0].detail, "mesial wall median 0.50 mm short of the outline")) << sh.criteria[0].detail;
  // The mesial wall 0.5 mm past the outline: the same distance, the same points.
  const OutcomeScores ov = c.score(c.cut(2.5));
  EXPECT_NEAR(ov.criteria[0].score, sh.criteria[0].score, 1e-9) << ov.criteria[0].detail;
  EXPECT_TRUE(has(ov.criteria[0].detail, "mesial wall median 0.50 mm past the outline")) << ov.criteria[0].detail;
  // 1.5 mm short: beyond the modification band, the mesial wall earns nothing; the buccal and palatal
  // walls are not cut where their outline runs from x 3.5 to 4.4 mm (10 of their 31 samples, x 3.5-6.5
  // in 0.1 mm steps): each earns 21/31.
  const OutcomeScores sh15 = c.score(c.cut(4.5));
  EXPECT_NEAR(sh15.criteria[0].score, 1.0 + 2.0 * 21.0 / 31.0, 1e-9) << sh15.criteria[0].detail;
  EXPECT_TRUE(has(sh15.criteria[0].detail, "mesial wall median 1.50 mm short of the outline")) << sh15.criteria[0].detail;
  // The volume terms still differ: the short box left target standing, the long one cut past it.
  EXPECT_LT(sh.regions[0].coverage_pct, 100.0);
  EXPECT_GT(ov.regions[0].overprep_mm3, 0.0);
}

TEST(Exercise, OutlineExtensionFieldsAreCheckedAndNamed) {
  const auto text = [](const std::string& oe) {
    return R"({"format":"dentar-exercise","version":1,"name":"t","procedure":"p",
    "tooth":{"kind":"molar","voxel_mm":0.2},"bur":{"shape":"sphere","radius_mm":0.5},"time_limit_s":60,
    "regions":[{"name":"a","role":"target","points":7,"all":[{"shape":"sphere","center_mm":[0,0,5],"radius_mm":1}]}],
    "steps":[{"name":"s1","region":"a"}],
    "outcome":{"kind":"graded_regions","outline_extension":)" + oe + "}}";
  };
  auto ok = parse_exercise(text(R"({"points":4,"from_region":"a","axis_point_mm":[0,0,0],"from_z_mm":4.2,"to_z_mm":5.7})"),
                           "t.json");
  ASSERT_TRUE(ok.ok()) << ok.error();
  ASSERT_TRUE(ok->outline_extension.has_value());
  EXPECT_EQ(ok->max_points(), 7.0);  // taken from the region's 7
  EXPECT_NEAR(ok->outline_extension->acceptable_m, 0.5e-3, 1e-12);
  auto err = [&](const std::string& oe, const std::string& needle) {
    auto r = parse_exercise(text(oe), "t.json");
    ASSERT_FALSE(r.ok());
    EXPECT_TRUE(has(r.error(), needle)) << r.error();
    EXPECT_TRUE(has(r.error(), "t.json")) << r.error();
  };
  err(R"({"points":4,"from_region":"b","axis_point_mm":[0,0,0],"from_z_mm":4.2,"to_z_mm":5.7})",
      "'outcome.outline_extension.from_region': 'b' is not a target region");
  err(R"({"points":8,"from_region":"a","axis_point_mm":[0,0,0],"from_z_mm":4.2,"to_z_mm":5.7})",
      "outcome.outline_extension.points");
  err(R"({"points":4,"from_region":"a","axis_point_mm":[0,0,0],"from_z_mm":4.2,"to_z_mm":5.7,"ideal_mm":0.6})",
      "ideal_mm");
  err(R"({"points":4,"axis_point_mm":[0,0,0],"from_z_mm":4.2,"to_z_mm":5.7})", "outcome.outline_extension.from_region");
  err(R"({"points":4,"from_region":"a","axis_point_mm":[0,0,0],"from_z_mm":4.2,"to_z_mm":5.7,"overprep_price":"x"})",
      "'outcome.outline_extension.overprep_price': 'x' is not a price");
}

}  // namespace
}  // namespace dentar::training

namespace dentar::training {
namespace {

// Past the walls and below the floor (issue 25, session 21). The box target of the outline-extension
// case (x 3-7, y 4-6 mm, floor at z 6 mm, 7 points, zone 0.8 mm) with a floor depth of 2 points
// (graded continuously: 1 within 0.25 mm of the floor, 0 at 1.0 mm) and, in the full split, an outline
// extension of 2 points (bands 0.25 / 0.5 / 1.0): the region keeps 3 (coverage). Without the outline
// extension (the shipped class I rule) the cut past the walls keeps the region's volume price.
struct SplitCase {
  VoxelVolume start = block();
  Exercise ex;
  RegionMasks masks;
  explicit SplitCase(bool with_outline) {
    ex.source = "box.json";
    ex.regions = {Region{"box", RegionRole::kTarget, {box({3, 4, 6}, {7, 6, 11})}, 7.0, 0.8},
                  Region{"top", RegionRole::kEntry, {box({-1, -1, 9.85}, {11, 11, 11})}, 0, 1}};
    if (with_outline) {
      OutlineExtension t;
      t.points = 2;
      t.from_region = "box";
      t.axis_point_m = Eigen::Vector3d(5, 5, 0) * 1e-3;
      t.from_z_m = 6.5e-3;
      t.to_z_m = 9.5e-3;
      ex.outline_extension = t;
    }
    FloorDepth f;
    f.points = 2;
    f.from_region = "box";
    f.continuous = true;
    ex.floor_depth = f;
    auto m = build_masks(ex, start);
    EXPECT_TRUE(m.ok()) << m.error();
    masks = *m;
  }
  // The box cut with its mesial (-x) wall at x0 and its floor at z0, the rest on the outline.
  VoxelVolume cut(double x0, double z0) const {
    VoxelVolume v = start.clone();
    carve(v, [&](const Eigen::Vector3d& p) {
      return p.x() >= x0 - 1e-9 && p.x() <= 7 + 1e-9 && p.y() >= 4 - 1e-9 && p.y() <= 6 + 1e-9 && p.z() >= z0 - 1e-9;
    });
    return v;
  }
  OutcomeScores score(const VoxelVolume& v) const {
    auto o = score_outcome(ex, masks, start, v);
    EXPECT_TRUE(o.ok()) << o.error();
    return *o;
  }
};

const Criterion* criterion(const OutcomeScores& o, const std::string& name) {
  for (const auto& c : o.criteria)
    if (c.name == name) return &c;
  return nullptr;
}

TEST(OutcomeCases, CutPastTheWallsAndBelowTheFloorArePricedByTheirOwnCriteria) {
  const SplitCase c(true);
  EXPECT_EQ(c.ex.max_points(), 7.0);
  // Untouched: 0 everywhere (the floor is short by the whole cavity's depth, 4 mm).
  const OutcomeScores un = c.score(c.start);
  ASSERT_NE(criterion(un, "floor depth"), nullptr);
  EXPECT_EQ(criterion(un, "floor depth")->score, 0.0) << criterion(un, "floor depth")->detail;
  EXPECT_EQ(un.points, 0.0);
  // The ideal box: the floor depth 2 of 2, the outline 2 of 2, the region 3 of 3: 7 of 7.
  const OutcomeScores id = c.score(c.cut(3.0, 6.0));
  EXPECT_NEAR(criterion(id, "floor depth")->score, 2.0, 1e-9) << criterion(id, "floor depth")->detail;
  EXPECT_NEAR(criterion(id, "outline extension")->score, 2.0, 1e-9);
  EXPECT_NEAR(id.regions[0].points, 3.0, 0.02) << id.regions[0].why;
  EXPECT_NEAR(id.points, 7.0, 0.02);
  EXPECT_TRUE(id.complete) << id.completion;
  // 0.5 mm too deep over the whole floor: every column 0.5 mm below it, graded 1 - 0.25 / 0.75; the
  // 4.3 mm3 below the floor is the floor depth's, not priced by volume (the region keeps 3); the walls 2.
  const OutcomeScores deep = c.score(c.cut(3.0, 5.5));
  const Criterion* fd = criterion(deep, "floor depth");
  EXPECT_NEAR(fd->score, 2.0 * (1.0 - 0.25 / 0.75), 1e-9) << fd->detail;
  EXPECT_TRUE(has(fd->detail, "median 0.50 mm below it")) << fd->detail;
  EXPECT_TRUE(has(fd->detail, "100 % too deep")) << fd->detail;
  EXPECT_NEAR(criterion(deep, "outline extension")->score, 2.0, 1e-9);
  // In voxels: the box's 41 x 21 columns (x 3-7, y 4-6 mm inclusive) x 5 layers (z 5.5-5.9) of 0.001 mm3.
  EXPECT_NEAR(deep.regions[0].below_floor_mm3, 41 * 21 * 5 * 1e-3, 1e-6);
  EXPECT_NEAR(deep.regions[0].past_walls_mm3, 0.0, 1e-9);
  EXPECT_NEAR(deep.regions[0].points, 3.0, 0.02) << deep.regions[0].why;
  EXPECT_TRUE(has(deep.regions[0].why, "4.30 mm3 below the floor is judged by the floor depth")) << deep.regions[0].why;
  // 0.5 mm past the mesial wall, floor on target: the outline extension's mesial wall acceptable
  // (0.85 of its 0.5), the floor depth 2 of 2, the 4.2 mm3 past the wall not priced by volume.
  const OutcomeScores past = c.score(c.cut(2.5, 6.0));
  EXPECT_NEAR(criterion(past, "outline extension")->score, 2.0 - 0.5 * 0.15, 1e-9)
      << criterion(past, "outline extension")->detail;
  EXPECT_NEAR(criterion(past, "floor depth")->score, 2.0, 1e-9) << criterion(past, "floor depth")->detail;
  // 5 x 21 columns (x 2.5-2.9, y 4-6 mm) x 40 layers (z 6-9.9) of 0.001 mm3.
  EXPECT_NEAR(past.regions[0].past_walls_mm3, 5 * 21 * 40 * 1e-3, 1e-6);
  EXPECT_NEAR(past.regions[0].below_floor_mm3, 0.0, 1e-9);
  EXPECT_NEAR(past.regions[0].points, 3.0, 0.02) << past.regions[0].why;
  EXPECT_TRUE(has(past.regions[0].why, "4.20 mm3 past the walls by the outline extension")) << past.regions[0].why;
  // Each fault costs only its own criterion.
  EXPECT_LT(deep.points, id.points);
  EXPECT_LT(past.points, id.points);

  // The shipped class I rule (no outline extension): the region keeps 5 and the cut past the walls
  // keeps its volume price (the region's 7 points over its volume, per mm3), the cut below the floor
  // does not.
  const SplitCase s(false);
  const OutcomeScores sid = s.score(s.cut(3.0, 6.0));
  EXPECT_NEAR(sid.points, 7.0, 0.02);
  const OutcomeScores sdeep = s.score(s.cut(3.0, 5.5));
  EXPECT_NEAR(sdeep.regions[0].points, 5.0, 0.02) << sdeep.regions[0].why;
  EXPECT_NEAR(sdeep.points, 5.0 + 2.0 * (1.0 - 0.25 / 0.75), 0.02);
  const OutcomeScores spast = s.score(s.cut(2.5, 6.0));
  const double price = 7.0 / sid.regions[0].volume_mm3;
  EXPECT_NEAR(spast.regions[0].points, 5.0 - price * spast.regions[0].past_walls_mm3, 0.02) << spast.regions[0].why;
  EXPECT_TRUE(has(spast.regions[0].why, "less 0.85 for 4.20 mm3 cut too far past its walls")) << spast.regions[0].why;
  EXPECT_TRUE(has(spast.regions[0].why, "= 4.15 points.")) << spast.regions[0].why;
  EXPECT_TRUE(has(spast.regions[0].why, "0.00 mm3 below the floor is judged by the floor depth")) << spast.regions[0].why;
  EXPECT_NEAR(criterion(spast, "floor depth")->score, 2.0, 1e-9);
}

TEST(Exercise, FloorDepthFieldsAreCheckedAndNamed) {
  const auto text = [](const std::string& fd) {
    return R"({"format":"dentar-exercise","version":1,"name":"t","procedure":"p",
    "tooth":{"kind":"molar","voxel_mm":0.2},"bur":{"shape":"sphere","radius_mm":0.5},"time_limit_s":60,
    "regions":[{"name":"a","role":"target","points":7,"all":[{"shape":"sphere","center_mm":[0,0,5],"radius_mm":1}]}],
    "steps":[{"name":"s1","region":"a"}],
    "outcome":{"kind":"graded_regions","floor_depth":)" + fd + "}}";
  };
  auto ok = parse_exercise(text(R"({"points":3,"from_region":"a","grading":"continuous"})"), "t.json");
  ASSERT_TRUE(ok.ok()) << ok.error();
  ASSERT_TRUE(ok->floor_depth.has_value());
  EXPECT_TRUE(ok->floor_depth->continuous);
  EXPECT_EQ(ok->max_points(), 7.0);
  EXPECT_NEAR(ok->floor_depth->modification_m, 1.0e-3, 1e-12);
  auto err = [&](const std::string& fd, const std::string& needle) {
    auto r = parse_exercise(text(fd), "t.json");
    ASSERT_FALSE(r.ok());
    EXPECT_TRUE(has(r.error(), needle)) << r.error();
    EXPECT_TRUE(has(r.error(), "t.json")) << r.error();
  };
  err(R"({"points":3,"from_region":"b"})", "'outcome.floor_depth.from_region': 'b' is not a target region");
  err(R"({"points":8,"from_region":"a"})", "outcome.floor_depth.points");
  err(R"({"points":3})", "outcome.floor_depth.from_region");
  err(R"({"points":3,"from_region":"a","ideal_mm":0.6})", "ideal_mm");
  err(R"({"points":3,"from_region":"a","grading":"x"})", "'outcome.floor_depth.grading': 'x' is not a grading");
}


// Issue 25 session 22: the class I rule on a hand-made box (x 3-7, y 4-6 mm, floor z 6; 10 points:
// the region's coverage 4, the floor depth 3, the wall taper 3), the form criteria capped by the
// coverage share (full from the finished 80 %) and the region's cut too far charged in full.
struct ClassICase {
  VoxelVolume start = block();
  Exercise ex;
  RegionMasks masks;
  explicit ClassICase(bool shipped) {
    ex.source = "box.json";
    ex.regions = {Region{"box", RegionRole::kTarget, {box({3, 4, 6}, {7, 6, 11})}, 7.0, 0.8},
                  Region{"top", RegionRole::kEntry, {box({-1, -1, 9.85}, {11, 11, 11})}, 0, 1}};
    ex.over_reduction_rate = 1;
    WallTaper w;
    w.points = 3;
    w.axis_point_m = Eigen::Vector3d(5, 5, 0) * 1e-3;
    w.from_z_m = 6.5e-3;
    w.to_z_m = 9.5e-3;
    w.outline_reach_full_pct = 90;
    FloorDepth f;
    f.points = 3;
    f.from_region = "box";
    f.continuous = true;
    if (shipped) {
      w.coverage_full_pct = f.coverage_full_pct = 80;
      w.coverage_cap = f.coverage_cap = true;
      ex.overflow_cost = true;
    }
    ex.wall_taper = w;
    ex.floor_depth = f;
    auto m = build_masks(ex, start);
    EXPECT_TRUE(m.ok()) << m.error();
    masks = *m;
  }
  // The box cut between x0 and x1 and y0 and y1 (by default its width, 4-6) down to the floor z0.
  VoxelVolume cut(double x0, double x1, double z0, double y0 = 4, double y1 = 6) const {
    VoxelVolume v = start.clone();
    carve(v, [&](const Eigen::Vector3d& p) {
      return p.x() >= x0 - 1e-9 && p.x() <= x1 + 1e-9 && p.y() >= y0 - 1e-9 && p.y() <= y1 + 1e-9 && p.z() >= z0 - 1e-9;
    });
    return v;
  }
  OutcomeScores score(const VoxelVolume& v) const {
    auto o = score_outcome(ex, masks, start, v);
    EXPECT_TRUE(o.ok()) << o.error();
    return *o;
  }
};

std::string fmt2(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.2f", x);
  return b;
}

TEST(OutcomeCases, IncompleteBoxEarnsNoMoreThanItsShare) {
  const ClassICase c(true);
  EXPECT_EQ(c.ex.max_points(), 10.0);
  const OutcomeScores un = c.score(c.start);
  EXPECT_EQ(un.points, 0.0);
  EXPECT_EQ(criterion(un, "floor depth")->score, 0.0);
  EXPECT_EQ(criterion(un, "wall taper")->score, 0.0);
  const OutcomeScores id = c.score(c.cut(3, 7, 6));
  EXPECT_NEAR(id.points, 10.0, 0.02);
  EXPECT_TRUE(id.complete) << id.completion;
  // Half the outline reached (the middle 2 of the box's 4 mm, x 4-6, its full width and depth):
  // walls vertical and floor on target where reached.
  const OutcomeScores half = c.score(c.cut(4, 6, 6));
  const double cov = half.target_coverage_pct;
  EXPECT_NEAR(cov, 100.0 * 21 / 41, 0.5);
  EXPECT_FALSE(half.complete) << half.completion;
  const double share = cov / c.ex.complete_coverage_pct;  // of a finished preparation's form
  const Criterion* fd = criterion(half, "floor depth");
  const Criterion* wt = criterion(half, "wall taper");
  // Each form criterion earns at most its points x the share (the shipped rule before this session:
  // the taper 2.33 and the floor 2.03 of 3 here, both above 3 x 0.64 = 1.92).
  EXPECT_LE(fd->score, 3.0 * share + 1e-9) << fd->detail;
  EXPECT_LE(wt->score, 3.0 * share + 1e-9) << wt->detail;
  EXPECT_NEAR(wt->score, 3.0 * share, 1e-6) << wt->detail;  // its walls are perfect: capped
  EXPECT_TRUE(has(wt->detail, std::to_string(static_cast<int>(std::lround(cov))) + " % of the target removed"))
      << wt->detail;
  EXPECT_TRUE(has(wt->detail, "so at most 3.00 x 0.64 = 1.92 of the")) << wt->detail;
  EXPECT_TRUE(has(wt->detail, "1.92 of 3: ")) << wt->detail;
  EXPECT_LT(half.points, id.points - 3.0);
  EXPECT_LE(half.points, id.points * share + 1e-9);
  double sum = 0;
  for (const auto& r : half.regions) sum += r.points;
  for (const auto& q : half.criteria) sum += q.score;
  EXPECT_NEAR(half.earned_points, sum, 1e-9);
  // Without the cap (the rule before): the same half box earns more than its share of the form.
  const ClassICase before(false);
  const OutcomeScores bh = before.score(before.cut(4, 6, 6));
  EXPECT_GT(criterion(bh, "wall taper")->score, 3.0 * share + 0.2) << criterion(bh, "wall taper")->detail;
  EXPECT_GT(bh.points, half.points + 0.2);
  EXPECT_NEAR(before.score(before.cut(3, 7, 6)).points, 10.0, 0.02);
}

TEST(OutcomeCases, CutPastTheWallsBeyondTheRegionsPointsIsCharged) {
  // 0.7 mm past every wall at full depth (within the 0.8 mm zone, so no over-reduction): 42.6 mm3
  // past the walls at the region's 7 points over its 34.4 mm3, more than its coverage's 4 points.
  const ClassICase c(true), before(false);
  const VoxelVolume wide = c.cut(2.3, 7.7, 6, 3.3, 6.7);
  const OutcomeScores o = c.score(wide), b = before.score(wide);
  ASSERT_EQ(o.regions.size(), 1u);
  EXPECT_EQ(o.regions[0].points, 0.0) << o.regions[0].why;
  const double price = 7.0 / o.regions[0].volume_mm3;
  const double overflow = price * o.regions[0].past_walls_mm3 - 4.0 * o.regions[0].coverage_pct / 100;
  ASSERT_GT(overflow, 0.1) << o.regions[0].why;
  const Penalty* p = nullptr;
  for (const auto& q : o.penalties)
    if (q.name == "over-extended outline") p = &q;
  ASSERT_NE(p, nullptr);
  EXPECT_NEAR(p->points, overflow, 1e-6) << p->why;
  EXPECT_TRUE(has(o.regions[0].why, "the other " + fmt2(overflow) + " are charged below, as over-extended outline"))
      << o.regions[0].why;
  EXPECT_TRUE(has(p->why, fmt2(overflow) + " points.")) << p->why;
  // The rule before: the same region stops at 0 and the rest is dropped.
  for (const auto& q : b.penalties) EXPECT_NE(q.name, "over-extended outline");
  EXPECT_NEAR(o.points, std::max(0.0, b.points - overflow), 1e-6);
  double cost = 0;
  for (const auto& q : o.penalties) cost += q.points;
  EXPECT_NEAR(o.points, std::max(0.0, o.earned_points - cost), 1e-9);
}

TEST(Exercise, CoverageShareAndOverflowFieldsAreCheckedAndNamed) {
  const auto text = [](const std::string& extra) {
    return R"({"format":"dentar-exercise","version":1,"name":"t","procedure":"p",
    "tooth":{"kind":"molar","voxel_mm":0.2},"bur":{"shape":"sphere","radius_mm":0.5},"time_limit_s":60,
    "regions":[{"name":"a","role":"target","points":7,"all":[{"shape":"sphere","center_mm":[0,0,5],"radius_mm":1}]}],
    "steps":[{"name":"s1","region":"a"}],
    "outcome":{"kind":"graded_regions")" + extra + "}}";
  };
  auto ok = parse_exercise(text(R"(,"overflow_cost":true,"floor_depth":{"points":3,"from_region":"a","coverage_full_pct":80,"coverage_share":"cap"},
    "wall_taper":{"points":3,"axis_point_mm":[0,0,0],"from_z_mm":4,"to_z_mm":5,"coverage_full_pct":70})"), "t.json");
  ASSERT_TRUE(ok.ok()) << ok.error();
  EXPECT_TRUE(ok->overflow_cost);
  EXPECT_EQ(ok->floor_depth->coverage_full_pct, 80);
  EXPECT_TRUE(ok->floor_depth->coverage_cap);
  EXPECT_EQ(ok->wall_taper->coverage_full_pct, 70);
  EXPECT_FALSE(ok->wall_taper->coverage_cap);
  auto err = [&](const std::string& extra, const std::string& needle) {
    auto r = parse_exercise(text(extra), "t.json");
    ASSERT_FALSE(r.ok());
    EXPECT_TRUE(has(r.error(), needle)) << r.error();
    EXPECT_TRUE(has(r.error(), "t.json")) << r.error();
  };
  err(R"(,"overflow_cost":1)", "'outcome.overflow_cost': must be true or false");
  err(R"(,"floor_depth":{"points":3,"from_region":"a","coverage_full_pct":120})", "outcome.floor_depth.coverage_full_pct");
  err(R"(,"floor_depth":{"points":3,"from_region":"a","coverage_full_pct":80,"coverage_share":"all"})",
      "'outcome.floor_depth.coverage_share': 'all' is not a rule");
  err(R"(,"floor_depth":{"points":3,"from_region":"a","coverage_share":"cap"})",
      "'outcome.floor_depth.coverage_share': needs 'outcome.floor_depth.coverage_full_pct' above 0");
  err(R"(,"wall_taper":{"points":3,"axis_point_mm":[0,0,0],"from_z_mm":4,"to_z_mm":5,"coverage_share":"x","coverage_full_pct":50})",
      "'outcome.wall_taper.coverage_share': 'x' is not a rule");
}

}  // namespace
}  // namespace dentar::training
