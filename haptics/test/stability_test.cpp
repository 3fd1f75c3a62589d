// Closed-loop stability, written once and run for every device profile and
// every bur shape: the engine (proxy model at the profile's gains, force
// guard at its force) drives a ProfileSimDevice (the profile's tip mass, a
// lightly damped hand, 1 kHz zero-order hold, HD's one-period mailbox delay
// for OpenHaptics devices) pressing on enamel.
//  - no buzz: after contact the force oscillates by less than 0.05 N;
//  - no kick: the contact force never exceeds what a passive spring contact
//    gives at the approach speed (steady + v sqrt(m k));
//  - no pop-through: pushed with twice the device's force, the drawn bur
//    stays on the surface and the force holds at the device maximum;
//  - the same with up to 2 ms of jitter on every engine period.
// A control test shows the buzz detector does fire when the stiffness is
// far above what the loop can render.
#include <gtest/gtest.h>

#include <cmath>

#include "closed_loop.h"

namespace dentar::haptics {
namespace {

using closed_loop::Config;
using closed_loop::Scenario;
using volume::BurShape;

struct Case {
  std::string profile;
  BurShape shape;
};
void PrintTo(const Case& c, std::ostream* os) {
  *os << c.profile << "/" << volume::bur_shape_name(c.shape);
}

class Stability : public ::testing::TestWithParam<Case> {
 protected:
  Config config(Scenario s, double jitter_s) const {
    Config c;
    c.profile = find_device_profile(GetParam().profile);
    c.shape = GetParam().shape;
    c.scenario = s;
    c.jitter_s = jitter_s;
    c.delay_steps = c.profile->backend == "hd" ? 1 : 0;  // HD: servo mailbox
    return c;
  }
  // The passive-contact bound on the peak force (see the file comment).
  static double kick_bound(const Config& c, const closed_loop::Result& r) {
    const double k = 0.8 * c.profile->max_stiffness_N_per_m;
    const double m = c.profile->tip_mass_kg + ProfileSimParams{}.hand_mass_kg;
    const double offset = r.press_N / ProfileSimParams{}.hand_stiffness_N_per_m + r.press_N / k;
    const double v = (3e-3 - closed_loop::kSurfaceZ + offset) / 0.3;  // approach speed, m/s
    return r.steady_N + v * std::sqrt(m * k) + 0.05;
  }
  void check_press(double jitter_s) const {
    const Config c = config(Scenario::kPress, jitter_s);
    const closed_loop::Result r = closed_loop::run(c);
    ASSERT_TRUE(r.error.empty()) << r.error;
    ASSERT_GT(r.contact_s, 0) << "never touched";
    EXPECT_NEAR(r.steady_N, r.press_N, 0.05 * r.press_N) << "the hand gets the force it asks for";
    EXPECT_LT(r.buzz_N, 0.05) << "buzz: force oscillation amplitude " << r.buzz_N << " N";
    EXPECT_LE(r.peak_N, kick_bound(c, r)) << "kick: peak " << r.peak_N << " N, steady " << r.steady_N;
    EXPECT_LE(r.peak_N, c.profile->max_force_N + 1e-9);
    EXPECT_GT(r.min_display_z_m, 0.0) << "the drawn bur entered the enamel";
  }
  void check_push_through(double jitter_s) const {
    const Config c = config(Scenario::kPushThrough, jitter_s);
    const closed_loop::Result r = closed_loop::run(c);
    ASSERT_TRUE(r.error.empty()) << r.error;
    // The hand pushes with twice the device's force: the device saturates,
    // the stylus sinks, the proxy (the drawn bur) stays on the surface.
    EXPECT_GT(r.min_display_z_m, 0.0) << "pop-through: the drawn bur went to z = " << r.min_display_z_m;
    EXPECT_NEAR(r.force_z_at_hold_end_N, c.profile->max_force_N, 1e-6) << "the force must hold, pushing out";
    EXPECT_LE(r.peak_N, c.profile->max_force_N + 1e-9);
    EXPECT_EQ(r.end_force_N, 0.0) << "after withdrawing, the bur is free";
    EXPECT_GT(r.display_z_m.back(), 2e-3);
  }
};

TEST_P(Stability, PressHasNoBuzzNoKick) { check_press(0.0); }
TEST_P(Stability, PressHasNoBuzzNoKickWith2msJitter) { check_press(2e-3); }
TEST_P(Stability, NoPopThrough) { check_push_through(0.0); }
TEST_P(Stability, NoPopThroughWith2msJitter) { check_push_through(2e-3); }

std::vector<Case> all_cases() {
  std::vector<Case> out;
  for (const DeviceProfile& p : device_profiles())
    for (BurShape s : {BurShape::kSphere, BurShape::kCylinder, BurShape::kCapsule, BurShape::kCone})
      out.push_back({p.id, s});
  return out;
}

INSTANTIATE_TEST_SUITE_P(AllProfilesAllBurs, Stability, ::testing::ValuesIn(all_cases()),
                         [](const auto& i) {
                           return i.param.profile + "_" + std::string(volume::bur_shape_name(i.param.shape));
                         });

// The detector is not blind: far above the stable stiffness the same loop buzzes.
TEST(StabilityControl, BuzzIsDetectedAboveTheStableStiffness) {
  Config c;
  c.profile = find_device_profile("touch");
  c.delay_steps = 1;
  c.stiffness_N_per_m = 15000;  // ~47x the Touch's default gain
  const closed_loop::Result r = closed_loop::run(c);
  ASSERT_TRUE(r.error.empty()) << r.error;
  EXPECT_GT(r.buzz_N, 0.05);
  Config ok = c;
  ok.stiffness_N_per_m = 0;  // the profile's gain
  EXPECT_LT(closed_loop::run(ok).buzz_N, 0.05);
}

}  // namespace
}  // namespace dentar::haptics
