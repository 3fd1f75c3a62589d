// The simulated hand as a person (`dentar live --stylus sim --exercise X --hand-skill S
// --hand-style G --hand-seed N`): the defaults are the expert script, a lower skill or a
// style gives another person's path, the same seed the same path.
#include "dentar/training/hand_script.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace dentar::training {
namespace {

struct Fixture {
  Exercise ex;
  volume::VoxelVolume tooth;
};

const Fixture& incisor() {
  static Fixture f = [] {
    auto ex = load_builtin_exercise("incisor_partial_crown");
    EXPECT_TRUE(ex.ok()) << ex.error();
    auto t = make_tooth(R"({"kind":"incisor","voxel_mm":0.3})");
    EXPECT_TRUE(t.ok()) << t.error();
    return Fixture{*ex, std::move(*t)};
  }();
  return f;
}

bool same(const std::vector<haptics::TipWaypoint>& a, const std::vector<haptics::TipWaypoint>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i].time_s != b[i].time_s || a[i].tip_tooth_m != b[i].tip_tooth_m || a[i].axis_tooth != b[i].axis_tooth ||
        a[i].pedal != b[i].pedal)
      return false;
  return true;
}

// Mean distance (mm) of the tip from the expert's at the same time, over the expert's path.
double mean_gap_mm(const std::vector<haptics::TipWaypoint>& e, const std::vector<haptics::TipWaypoint>& p) {
  double s = 0;
  std::size_t j = 0;
  for (const auto& w : e) {
    while (j + 1 < p.size() && p[j + 1].time_s <= w.time_s) ++j;
    s += (w.tip_tooth_m - p[j].tip_tooth_m).norm();
  }
  return 1e3 * s / static_cast<double>(e.size());
}

TEST(HandScript, DefaultsAreTheExpertScript) {
  const auto& f = incisor();
  auto e = expert_tip_script(f.ex, f.tooth, 3);
  ASSERT_TRUE(e.ok()) << e.error();
  HandOptions o;
  o.seed = 3;
  auto h = hand_tip_script(f.ex, f.tooth, o);
  ASSERT_TRUE(h.ok()) << h.error();
  EXPECT_TRUE(same(*e, *h));
}

TEST(HandScript, SkillAndStyleMakeAnotherPersonAndTheSeedRepeatsIt) {
  const auto& f = incisor();
  auto e = expert_tip_script(f.ex, f.tooth, 5);
  ASSERT_TRUE(e.ok());
  HandOptions o;
  o.skill = 0.0;
  o.style = 1.0;
  o.seed = 5;
  auto n1 = hand_tip_script(f.ex, f.tooth, o);
  auto n2 = hand_tip_script(f.ex, f.tooth, o);
  ASSERT_TRUE(n1.ok()) << n1.error();
  ASSERT_TRUE(n2.ok());
  EXPECT_TRUE(same(*n1, *n2));
  EXPECT_FALSE(same(*e, *n1));
  // A novice with a style moves elsewhere than the expert (detours, tremor, posture), by
  // more than the expert's own 0.02 mm tremor.
  EXPECT_GT(mean_gap_mm(*e, *n1), 0.2);
  o.seed = 6;
  auto n3 = hand_tip_script(f.ex, f.tooth, o);
  ASSERT_TRUE(n3.ok());
  EXPECT_FALSE(same(*n1, *n3));
  // Every waypoint is finite and time runs forward.
  for (std::size_t i = 1; i < n1->size(); ++i) {
    EXPECT_GE((*n1)[i].time_s, (*n1)[i - 1].time_s);
    ASSERT_TRUE((*n1)[i].tip_tooth_m.allFinite());
  }
}

TEST(HandScript, OutOfRangeSkillOrStyleIsNamed) {
  const auto& f = incisor();
  HandOptions o;
  o.skill = 1.5;
  auto r = hand_tip_script(f.ex, f.tooth, o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("hand skill"), std::string::npos) << r.error();
  o.skill = 0.5;
  o.style = -1;
  r = hand_tip_script(f.ex, f.tooth, o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("hand style"), std::string::npos) << r.error();
  o.style = std::nan("");
  EXPECT_FALSE(hand_tip_script(f.ex, f.tooth, o).ok());
}


// Generator v5 (issue 25, session 16): the expert's class I plan finishes the preparation along
// its outline. The cavity is the box |x| <= 2.2, |y| <= 0.9 mm down to z = 3.9 mm, cut with a
// 0.5 mm radius cylinder: at the floor the bur's centre must run along y = -0.4 and y = +0.4 (its
// side on the buccal and palatal walls) over the walls' whole length, |x| <= 1.7. The v4 raster's
// rows ran across those walls and touched each only at every other row's end, so about half of
// each wall's length was planed; the finishing pass runs the bur along all of it.
TEST(HandScript, TheClassIExpertRunsTheBurAlongTheWholeBuccalAndPalatalWallsAtTheFloor) {
  auto ex = load_builtin_exercise("molar_class1_cavity");
  ASSERT_TRUE(ex.ok()) << ex.error();
  auto tooth = make_tooth(R"({"kind":"molar","voxel_mm":0.15})");
  ASSERT_TRUE(tooth.ok()) << tooth.error();
  for (std::uint64_t seed : {1u, 2u}) {
    auto e = expert_tip_script(*ex, *tooth, seed);
    ASSERT_TRUE(e.ok()) << e.error();
    // 0.1 mm bins of x over the wall's length, per wall: visited by a drilling tip target at the
    // floor's level (the hand aims below the floor by its press: z < 4.3 mm) within 0.1 mm of
    // the wall's bur line.
    constexpr int kBins = 34;
    std::vector<int> buccal(kBins, 0), palatal(kBins, 0);
    for (std::size_t i = 1; i < e->size(); ++i) {
      const auto& w = (*e)[i];
      if (!w.pedal || w.tip_tooth_m.z() > 4.3e-3) continue;
      const double x = w.tip_tooth_m.x() * 1e3, y = w.tip_tooth_m.y() * 1e3;
      const int b = static_cast<int>(std::floor((x + 1.7) / 0.1));
      if (b < 0 || b >= kBins) continue;
      if (std::abs(y + 0.4) < 0.1) buccal[static_cast<std::size_t>(b)] = 1;
      if (std::abs(y - 0.4) < 0.1) palatal[static_cast<std::size_t>(b)] = 1;
      // Never past the outline: the bur's side stays inside the box (tremor and tilt aside).
      EXPECT_LT(std::abs(y), 0.5) << "seed " << seed << " at t = " << w.time_s << " s";
    }
    int nb = 0, np = 0;
    for (int b = 0; b < kBins; ++b) nb += buccal[static_cast<std::size_t>(b)], np += palatal[static_cast<std::size_t>(b)];
    EXPECT_GE(nb, kBins - 2) << "seed " << seed << ": the buccal wall planed over " << nb << " of " << kBins << " bins";
    EXPECT_GE(np, kBins - 2) << "seed " << seed << ": the palatal wall planed over " << np << " of " << kBins << " bins";
  }
}

}  // namespace
}  // namespace dentar::training
