// The shipped exercises load, rasterise on their tooth without overlapping
// target and forbidden regions, and score an ideal preparation (every target
// voxel removed) at or near full marks and an untouched tooth near zero.
#include <gtest/gtest.h>

#include "dentar/training/outcome.h"
#include "dentar/volume/material.h"

namespace dentar::training {
namespace {

struct Loaded {
  Exercise ex;
  volume::VoxelVolume start;
  RegionMasks masks;
};

Loaded load(const std::string& name) {
  auto ex = load_builtin_exercise(name);
  EXPECT_TRUE(ex.ok()) << ex.error();
  auto tooth = make_tooth(ex->tooth_json);
  EXPECT_TRUE(tooth.ok()) << tooth.error();
  auto m = build_masks(*ex, *tooth);
  EXPECT_TRUE(m.ok()) << m.error();
  return {std::move(*ex), std::move(*tooth), std::move(*m)};
}

// Removes every voxel of the target regions (the ideal preparation).
volume::VoxelVolume ideal(const Loaded& l) {
  volume::VoxelVolume v = l.start.clone();
  const auto d = v.dims();
  for (int k = 0; k < d.z(); ++k)
    for (int j = 0; j < d.y(); ++j)
      for (int i = 0; i < d.x(); ++i)
        if (l.masks.bits[l.masks.index(i, j, k)] & l.masks.target_bits) v.set(i, j, k, 0, v.material(i, j, k));
  return v;
}

TEST(ExerciseAssets, IncisorPartialCrownScoresSixteenForTheIdealCut) {
  const Loaded l = load("incisor_partial_crown");
  EXPECT_EQ(l.ex.steps.size(), 13u);
  EXPECT_EQ(l.ex.max_points(), 16.0);
  auto o = score_outcome(l.ex, l.masks, l.start, ideal(l));
  ASSERT_TRUE(o.ok()) << o.error();
  EXPECT_NEAR(o->points, 16.0, 1e-6);
  EXPECT_NEAR(o->forbidden_mm3, 0.0, 1e-9);
  EXPECT_FALSE(o->pulp_exposed);
  for (const auto& r : o->regions) EXPECT_GT(r.volume_mm3, 1.0) << r.name;
  auto none = score_outcome(l.ex, l.masks, l.start, l.start);
  ASSERT_TRUE(none.ok());
  EXPECT_EQ(none->points, 0.0);
}

TEST(ExerciseAssets, MolarAccessOpeningIdealCutScoresHigh) {
  const Loaded l = load("molar_access_opening");
  EXPECT_EQ(l.ex.steps.size(), 4u);
  auto o = score_outcome(l.ex, l.masks, l.start, ideal(l));
  ASSERT_TRUE(o.ok()) << o.error();
  ASSERT_EQ(o->criteria.size(), 6u);
  for (const auto& c : o->criteria) EXPECT_GE(c.score, 2) << c.name << ": " << c.detail;
  EXPECT_GE(o->points, 15);
  EXPECT_TRUE(o->pulp_exposed);
  EXPECT_FALSE(o->perforation);
  auto none = score_outcome(l.ex, l.masks, l.start, l.start);
  ASSERT_TRUE(none.ok());
  // An untouched tooth: no orifice seen, no wall cut, no floor reached (it once earned the intact
  // floor's 3 points; the walls are measured only where cut since issue 25 session 19).
  EXPECT_EQ(none->points, 0.0);
  for (const auto& c : none->criteria) EXPECT_EQ(c.score, 0.0) << c.name << ": " << c.detail;
  EXPECT_FALSE(none->complete);
}

TEST(ExerciseAssets, ClassOneCavity) {
  const Loaded l = load("molar_class1_cavity");
  auto o = score_outcome(l.ex, l.masks, l.start, ideal(l));
  ASSERT_TRUE(o.ok()) << o.error();
  EXPECT_NEAR(o->points, 10.0, 1e-6);
  EXPECT_FALSE(o->pulp_exposed);
  // The box's walls are parallel: the wall taper (issue 25, session 14) gives all its 3 points.
  ASSERT_EQ(o->criteria.size(), 2u);
  EXPECT_EQ(o->criteria[0].name, "wall taper");
  EXPECT_NEAR(o->criteria[0].score, 3.0, 1e-9) << o->criteria[0].detail;
  // Its floor lies on the target floor in every column (issue 25, session 21): the floor depth's 3 of 3,
  // and the cavity region's coverage the other 4 of its 7.
  EXPECT_EQ(o->criteria[1].name, "floor depth");
  EXPECT_NEAR(o->criteria[1].score, 3.0, 1e-9) << o->criteria[1].detail;
  ASSERT_EQ(o->regions.size(), 1u);
  EXPECT_NEAR(o->regions[0].points, 4.0, 1e-6) << o->regions[0].why;
  auto none = score_outcome(l.ex, l.masks, l.start, l.start);
  ASSERT_TRUE(none.ok());
  EXPECT_EQ(none->points, 0.0);
  ASSERT_EQ(none->criteria.size(), 2u);
  EXPECT_EQ(none->criteria[1].score, 0.0) << none->criteria[1].detail;
  EXPECT_FALSE(none->complete);
}

}  // namespace
}  // namespace dentar::training
