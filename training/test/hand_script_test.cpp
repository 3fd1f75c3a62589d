// The simulated hand as a person (`dentar live --stylus sim --exercise X --hand-skill S
// --hand-style G --hand-seed N`): the defaults are the expert script, a lower skill or a
// style gives another person's path, the same seed the same path.
#include "dentar/training/hand_script.h"

#include <gtest/gtest.h>

#include <cmath>

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

}  // namespace
}  // namespace dentar::training
