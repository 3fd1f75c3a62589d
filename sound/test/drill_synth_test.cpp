// The drill synth's behaviour, checked by analysis of what it renders:
// envelope, pitch under load, material spectra, break-through, transients,
// silence, determinism and parameter validation.
#include "dentar/sound/drill_synth.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "dentar/sound/analysis.h"

namespace dentar::sound {
namespace {

constexpr double kFs = 48000;
constexpr int kStep = 48;  // one 1 kHz haptic step of samples

// A scripted haptic stream: each segment holds its input for `seconds`, set
// every 1 ms (as the session log's steps are); `removing` removes that material each step.
struct Segment {
  double seconds;
  bool pedal, contact;
  double force_N;
  int removing;  // material label, -1 none
};

std::vector<float> render(const std::vector<Segment>& script, DrillParams p = default_drill_params(),
                          std::uint64_t seed = 1, DrillSynth** keep = nullptr) {
  static DrillSynth* last = nullptr;
  delete last;
  last = new DrillSynth(std::move(p), seed);
  DrillSynth& s = *last;
  if (keep) *keep = last;
  std::vector<float> out;
  double t = 0;
  for (const auto& seg : script) {
    const int steps = static_cast<int>(std::lround(seg.seconds * 1000));
    for (int i = 0; i < steps; ++i) {
      DrillInput in;
      in.time_s = t;
      in.pedal = seg.pedal;
      in.contact = seg.contact;
      in.force_N = seg.force_N;
      if (seg.removing >= 0) in.removed[seg.removing] = 1.0;
      s.set_input(in);
      const std::size_t at = out.size();
      out.resize(at + kStep);
      s.render(out.data() + at, kStep);
      t += 1e-3;
    }
  }
  return out;
}

std::size_t at_s(double t) { return static_cast<std::size_t>(t * kFs); }

double fundamental(const std::vector<float>& x, double from_s, double to_s) {
  const auto s = magnitude_spectrum(x.data() + at_s(from_s), at_s(to_s) - at_s(from_s), kFs);
  return fundamental_hz(s, 1500, 7000);  // the whine: 0.3-1 x 5333 Hz
}

TEST(DrillSynth, DefaultsAreValid) { EXPECT_EQ(default_drill_params().validate(), ""); }

TEST(DrillSynth, ValidateNamesTheField) {
  DrillParams p = default_drill_params();
  p.gain = 1.5;
  EXPECT_NE(p.validate().find("gain = 1.5"), std::string::npos) << p.validate();
  p = default_drill_params();
  p.materials[2].mode_hz = 30000;
  EXPECT_NE(p.validate().find("materials[2].mode_hz"), std::string::npos) << p.validate();
  p = default_drill_params();
  p.spin_up_s = std::nan("");
  EXPECT_NE(p.validate().find("spin_up_s"), std::string::npos) << p.validate();
}

TEST(DrillSynth, SilentWithPedalUpAndNoContact) {
  const auto x = render({{2.0, false, false, 0.0, -1}});
  for (std::size_t i = 0; i < x.size(); ++i) ASSERT_EQ(x[i], 0.0f) << "sample " << i;
  // And silent again once the drill has coasted down after the pedal is released.
  const auto y = render({{0.5, true, false, 0.0, -1}, {4.5, false, false, 0.0, -1}});
  EXPECT_GT(rms(y.data() + at_s(0.3), at_s(0.2)), 0.05);
  for (std::size_t i = at_s(4.5); i < y.size(); ++i) ASSERT_EQ(y[i], 0.0f) << "sample " << i;
}

TEST(DrillSynth, SpinUpIdleAndSpinDownFollowThePedal) {
  DrillSynth* s = nullptr;
  const DrillParams p = default_drill_params();
  // After one spin-up time constant from rest: about 1 - 1/e of the free speed.
  render({{p.spin_up_s, true, false, 0.0, -1}}, p, 1, &s);
  EXPECT_NEAR(s->speed_fraction(), 1 - std::exp(-1.0), 0.05);
  // Idle: the free-running whine at free_speed_rpm / 60.
  const auto x = render({{1.0, true, false, 0.0, -1}}, p, 1, &s);
  EXPECT_NEAR(fundamental(x, 0.8, 1.0), p.free_speed_rpm / 60, 30);
  // Coasting: after one spin-down time constant the speed is about 1/e.
  render({{1.0, true, false, 0.0, -1}, {p.spin_down_s, false, false, 0.0, -1}}, p, 1, &s);
  EXPECT_NEAR(s->speed_fraction(), std::exp(-1.0), 0.05);
  // The level follows: rising while spinning up, falling while coasting.
  const auto y = render({{1.0, true, false, 0.0, -1}, {1.0, false, false, 0.0, -1}}, p);
  EXPECT_LT(rms(y.data(), at_s(0.05)), rms(y.data() + at_s(0.5), at_s(0.05)));
  EXPECT_LT(rms(y.data() + at_s(1.5), at_s(0.05)), 0.5 * rms(y.data() + at_s(0.9), at_s(0.05)));
}

TEST(DrillSynth, FundamentalFallsAsForceRises) {
  const DrillParams p = default_drill_params();
  double prev = 1e9;
  for (double f : {0.0, 0.5, 1.0, 2.0, 3.0}) {
    // Spin up, then cut dentin with force f for 0.5 s; measure the last 0.25 s.
    const auto x = render({{0.6, true, false, 0.0, -1}, {0.5, true, true, f, 2}}, p);
    const double f0 = fundamental(x, 0.85, 1.1);
    const double expect = p.free_speed_rpm / 60 *
                          std::max(p.min_speed_fraction, 1 - p.materials[2].friction * f / p.stall_force_N);
    EXPECT_NEAR(f0, expect, 0.02 * expect) << "force " << f << " N";
    EXPECT_LT(f0, 0.95 * prev) << "force " << f << " N: the pitch must fall by at least 5 %";
    prev = f0;
  }
}

TEST(DrillSynth, EnamelAndDentinSpectraDiffer) {
  // Same force, same time: enamel (hard, brittle) is brighter than dentin.
  // Stated margin: spectral centroid (0.5-20 kHz) at least 15 % higher, and more
  // energy around enamel's resonance (4-6 kHz) relative to dentin's (1.5-3 kHz).
  const std::vector<Segment> warm = {{0.6, true, false, 0.0, -1}};
  auto script = [&](int m) {
    auto s = warm;
    s.push_back({0.6, true, true, 1.0, m});
    return s;
  };
  const auto e = render(script(1));
  const auto d = render(script(2));
  const auto se = magnitude_spectrum(e.data() + at_s(0.8), at_s(0.4), kFs);
  const auto sd = magnitude_spectrum(d.data() + at_s(0.8), at_s(0.4), kFs);
  const double ce = centroid_hz(se, 500, 20000), cd = centroid_hz(sd, 500, 20000);
  EXPECT_GT(ce, 1.15 * cd) << "enamel centroid " << ce << " Hz, dentin " << cd << " Hz";
  auto band = [](const Spectrum& s, double lo, double hi) {
    double acc = 0;
    for (std::size_t k = 0; k < s.magnitude.size(); ++k) {
      const double f = static_cast<double>(k) * s.bin_hz;
      if (f >= lo && f <= hi) acc += s.magnitude[k] * s.magnitude[k];
    }
    return acc;
  };
  // Exclude the whine's partials: bands between them.
  const double re = band(se, 1500, 2500) / band(se, 4200, 5000);
  const double rd = band(sd, 1500, 2500) / band(sd, 4200, 5000);
  EXPECT_GT(rd, 3.0 * re) << "dentin low/high band ratio " << rd << ", enamel " << re;
}

TEST(DrillSynth, BreakThroughIntoThePulpIsAStep) {
  const DrillParams p = default_drill_params();
  // Dentin at 1.5 N, then the bur drops into the pulp chamber: pulp is removed
  // at a low force, then the bur is free in the chamber (air).
  const auto x = render({{0.6, true, false, 0.0, -1},
                         {0.5, true, true, 1.5, 2},
                         {0.2, true, true, 0.3, 3},
                         {0.3, true, false, 0.0, -1}},
                        p);
  const double before = fundamental(x, 0.95, 1.1);
  const double pulp = fundamental(x, 1.2, 1.3);
  const double air = fundamental(x, 1.45, 1.6);
  EXPECT_GT(pulp, 1.15 * before) << "before " << before << " Hz, in the pulp " << pulp << " Hz";
  EXPECT_GT(air, pulp) << "in the pulp " << pulp << " Hz, free " << air << " Hz";
  EXPECT_NEAR(air, p.free_speed_rpm / 60, 0.02 * p.free_speed_rpm / 60);
  // The step is quick: 60-100 ms after the break-through the pitch has moved
  // more than half-way to its new value (spin_up_s = 80 ms).
  const double early = fundamental(x, 1.16, 1.2);
  EXPECT_GT(early - before, 0.5 * (pulp - before)) << "60-100 ms after: " << early << " Hz";
  // And the cutting noise falls: the level between the whine's partials drops by >= 6 dB.
  auto between = [&](double from) {
    const auto s = magnitude_spectrum(x.data() + at_s(from), at_s(0.1), kFs);
    double acc = 0;
    for (std::size_t k = 0; k < s.magnitude.size(); ++k) {
      const double f = static_cast<double>(k) * s.bin_hz;
      if (f >= 1000 && f <= 3000) acc += s.magnitude[k] * s.magnitude[k];
    }
    return 10 * std::log10(acc);
  };
  EXPECT_GT(between(1.0) - between(1.2), 6.0);
}

TEST(DrillSynth, FirstContactGivesATransient) {
  DrillSynth* s = nullptr;
  // Free-running, then the bur touches enamel (no removal yet: just the strike).
  const auto x = render({{0.6, true, false, 0.0, -1}, {0.1, true, true, 0.5, -1}}, default_drill_params(), 1, &s);
  EXPECT_EQ(s->contact_onsets(), 1u);
  const double idle = rms(x.data() + at_s(0.55), at_s(0.04));
  const double strike = rms(x.data() + at_s(0.6), at_s(0.004));
  const double later = rms(x.data() + at_s(0.65), at_s(0.04));
  EXPECT_GT(to_db(strike) - to_db(idle), 6.0) << "strike " << strike << ", idle " << idle;
  EXPECT_LT(to_db(later) - to_db(idle), 3.0) << "the transient is short";
}

TEST(DrillSynth, ProbeTickWithTheDrillOff) {
  DrillSynth* s = nullptr;
  const DrillParams p = default_drill_params();
  const auto x = render({{0.2, false, false, 0.0, -1}, {0.2, false, true, 1.0, -1}}, p, 1, &s);
  EXPECT_EQ(s->probe_ticks(), 1u);
  for (std::size_t i = 0; i < at_s(0.2); ++i) ASSERT_EQ(x[i], 0.0f);
  EXPECT_NE(x[at_s(0.2) + 1], 0.0f) << "the tick starts at the contact's first sample";
  const auto sp = magnitude_spectrum(x.data() + at_s(0.2), at_s(0.02), kFs);
  EXPECT_NEAR(peak_hz(sp, 500, 20000), p.probe_mode_hz, 200);
  // It is a tick, not a tone: silent again within 100 ms, though contact holds.
  for (std::size_t i = at_s(0.3); i < x.size(); ++i) ASSERT_EQ(x[i], 0.0f) << "sample " << i;
}

TEST(DrillSynth, DeterministicForTheSameInputs) {
  const std::vector<Segment> script = {{0.3, true, false, 0, -1}, {0.3, true, true, 1.2, 1}, {0.2, false, false, 0, -1}};
  const auto a = render(script), b = render(script);
  EXPECT_EQ(a, b);
  const auto c = render(script, default_drill_params(), 2);
  EXPECT_NE(a, c) << "the seed changes the grains";
}

TEST(DrillSynth, TeacherBeepsAboveTheForceLimitAndIsOffByDefault) {
  EXPECT_EQ(default_drill_params().teacher_force_limit_N, 0.0) << "off by default";
  DrillParams p = default_drill_params();
  p.teacher_force_limit_N = 1.5;
  auto band_db = [](const std::vector<float>& x, double f) {
    const auto s = magnitude_spectrum(x.data() + at_s(0.8), at_s(0.5), kFs);
    double acc = 0;
    for (std::size_t k = 0; k < s.magnitude.size(); ++k) {
      const double fk = static_cast<double>(k) * s.bin_hz;
      if (std::abs(fk - f) < 60) acc += s.magnitude[k] * s.magnitude[k];
    }
    return 10 * std::log10(acc + 1e-30);
  };
  const std::vector<Segment> below = {{0.6, true, false, 0, -1}, {0.8, true, true, 1.2, 2}};
  const std::vector<Segment> above = {{0.6, true, false, 0, -1}, {0.8, true, true, 2.0, 2}};
  DrillSynth* s = nullptr;
  const auto quiet = render(below, p, 1, &s);
  EXPECT_EQ(s->teacher_samples(), 0u);
  const auto beep = render(above, p, 1, &s);
  // Gate open about half of the time while above the limit (pulses at 10 Hz here).
  EXPECT_NEAR(static_cast<double>(s->teacher_samples()), 0.5 * 0.8 * kFs, 0.05 * kFs);
  const auto plain = render(above, default_drill_params());
  EXPECT_GT(band_db(beep, p.teacher_tone_hz) - band_db(plain, p.teacher_tone_hz), 15.0)
      << "the beep stands out at its tone";
  EXPECT_LT(std::abs(band_db(quiet, p.teacher_tone_hz) - band_db(render(below, default_drill_params()), p.teacher_tone_hz)), 0.5)
      << "below the limit the teacher adds nothing";
  // Distinct from the drill: its tone is below the lowest whine fundamental (0.3 x 5333 Hz).
  EXPECT_LT(p.teacher_tone_hz, p.min_speed_fraction * p.free_speed_rpm / 60);
}

TEST(DrillSynth, UserSampleReplacesTheWhineAndIsPitchedBySpeed) {
  DrillParams p = default_drill_params();
  p.hiss_level = 0;
  // A 1 kHz tone "recorded" at the free speed: under load it plays lower.
  p.user_sample.resize(4800);
  for (std::size_t i = 0; i < p.user_sample.size(); ++i)
    p.user_sample[i] = static_cast<float>(std::sin(2 * M_PI * 1000.0 * static_cast<double>(i) / kFs));
  p.user_sample_rpm = p.free_speed_rpm;
  const auto x = render({{0.6, true, false, 0.0, -1}}, p);
  const auto sx = magnitude_spectrum(x.data() + at_s(0.4), at_s(0.2), kFs);
  EXPECT_NEAR(peak_hz(sx, 200, 20000), 1000, 15);
}

}  // namespace
}  // namespace dentar::sound
