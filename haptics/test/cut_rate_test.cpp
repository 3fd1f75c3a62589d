// Cut rate against voxel size (issue 25, session 20): the exercise's cone bur
// pressed with 1 N into enamel and dentin through the proxy model and the
// cutter (cut_rate.h), at the cohorts' 0.15 mm and the station's 0.1 mm
// voxels. Without CutParams::sample_jitter the bur held still removes only
// the voxels its fixed samples land in: at 0.1 mm it stalls (0.000 mm^3/s in
// enamel, docs/BENCHMARKS.md "Haptics session 20"); with it the rates agree.
#include <gtest/gtest.h>

#include "cut_rate.h"
#include "dentar/haptics/engine.h"

namespace dentar::haptics {
namespace {

double mean_rate(double h, volume::Material m, int samples, bool jitter, double* max_force = nullptr) {
  auto bur = volume::sample_bur(volume::BurParams::cone(0.4, 0.6, 6.0), samples);
  EXPECT_TRUE(bur.ok());
  volume::CutParams cut;
  cut.sample_jitter = jitter;
  const double phases[4][2] = {{0.0, 0.0}, {0.25, 0.5}, {0.5, 0.25}, {0.75, 0.75}};
  double sum = 0;
  for (const auto& ph : phases) {
    cut_rate::Press p;
    p.voxel_m = h;
    p.material = m;
    p.force_N = 1.0;
    p.seconds = 0.4;
    p.grid_phase = ph[0];
    p.lateral_phase = ph[1];
    const cut_rate::PressResult r = cut_rate::press(p, *bur, cut);
    EXPECT_TRUE(r.finite);
    if (max_force) *max_force = std::max(*max_force, r.max_force_N);
    sum += r.rate_mm3_s / 4;
  }
  return sum;
}

TEST(CutRate, RemovalPerSecondDoesNotDependOnTheVoxelSize) {
  for (auto m : {volume::Material::kEnamel, volume::Material::kDentin})
    for (int samples : {500, 2000}) {
      double fmax = 0;
      const double coarse = mean_rate(0.15e-3, m, samples, true, &fmax);
      const double station = mean_rate(0.1e-3, m, samples, true, &fmax);
      SCOPED_TRACE(std::string(m == volume::Material::kEnamel ? "enamel" : "dentin") + ", " +
                   std::to_string(samples) + " samples: " + std::to_string(coarse) + " mm3/s at 0.15 mm, " +
                   std::to_string(station) + " at 0.1 mm");
      EXPECT_GT(coarse, 0.3);  // it cuts at all (enamel 0.7-1.6 mm^3/s, dentin 5-14)
      EXPECT_GT(station, 0.75 * coarse);
      EXPECT_LT(station, coarse / 0.75);
      // The proxy's spring holds the 1 N; spikes at contact stay under the device's 3.3 N.
      EXPECT_LT(fmax, 3.3);
    }
}

TEST(CutRate, WithoutJitterAStillBurStallsAtTheStationVoxel) {
  // Documents the mechanism (main's behaviour, kept as the default): enamel,
  // 500 samples (0.21 mm apart) against 0.1 mm voxels.
  const double still = mean_rate(0.1e-3, volume::Material::kEnamel, 500, false);
  const double jittered = mean_rate(0.1e-3, volume::Material::kEnamel, 500, true);
  EXPECT_LT(still, 0.1 * jittered);
}

TEST(CutRate, JitteredCutIsDeterministic) {
  auto bur = volume::sample_bur(volume::BurParams::cone(0.4, 0.6, 6.0), 500);
  ASSERT_TRUE(bur.ok());
  volume::CutParams cut;
  cut.sample_jitter = true;
  cut_rate::Press p;
  p.seconds = 0.2;
  const auto a = cut_rate::press(p, *bur, cut), b = cut_rate::press(p, *bur, cut);
  EXPECT_EQ(a.removed_mm3, b.removed_mm3);
  EXPECT_EQ(a.depth_mm, b.depth_mm);
}

// Session 22: a still bur at 1 N for 0.5 s at the station's 0.1 mm voxels,
// the bur cut into 1000 and 10000 samples. `pairing`: use_overlap_cut (the
// overlap cutter and the shape-constrained proxy), else main's sample cutter
// with the sample jitter (as `dentar live` drilled in session 21).
double removed_still(volume::Material m, int samples, bool pairing, double* max_force) {
  auto bur = volume::sample_bur(volume::BurParams::cone(0.4, 0.6, 6.0), samples);
  EXPECT_TRUE(bur.ok());
  EngineConfig cfg;
  cfg.cut.sample_jitter = true;
  if (pairing) use_overlap_cut(cfg);
  cut_rate::Press p;
  p.voxel_m = 0.1e-3;
  p.material = m;
  p.force_N = 1.0;
  p.seconds = 0.5;
  p.grid_phase = 0.25;
  p.lateral_phase = 0.5;
  p.shape_constraint = cfg.model_params.proxy.shape_constraint;
  const cut_rate::PressResult r = cut_rate::press(p, *bur, cfg.cut);
  EXPECT_TRUE(r.finite);
  *max_force = std::max(*max_force, r.max_force_N);
  return r.removed_mm3;
}

TEST(CutRate, StillBurRemovesTheSameVolumeAtAnySampleCount) {
  for (auto m : {volume::Material::kEnamel, volume::Material::kDentin}) {
    double fmax = 0;
    const double sparse = removed_still(m, 1000, true, &fmax);
    const double dense = removed_still(m, 10000, true, &fmax);
    SCOPED_TRACE(std::string(m == volume::Material::kEnamel ? "enamel" : "dentin") + ": " +
                 std::to_string(sparse) + " mm3 at 1000 samples, " + std::to_string(dense) + " at 10000");
    EXPECT_GT(dense, 0.2);  // it cuts (enamel ~0.35 mm3, dentin ~2.5)
    EXPECT_GT(sparse, 0.85 * dense);
    EXPECT_LT(sparse, 1.15 * dense);
    EXPECT_LT(fmax, 3.3);
  }
}

TEST(CutRate, MainsSampleCutterCutsFasterWithFewerSamples) {
  // Documents what the pairing removes (session 21: the proxy sinks into the
  // holes its own sparse samples cut): 1000 samples remove far more than 10000.
  double fmax = 0;
  const double sparse = removed_still(volume::Material::kDentin, 1000, false, &fmax);
  const double dense = removed_still(volume::Material::kDentin, 10000, false, &fmax);
  EXPECT_GT(sparse, 1.5 * dense) << sparse << " mm3 at 1000 samples, " << dense << " at 10000";
}

TEST(CutRate, OverlapCutIsDeterministic) {
  auto bur = volume::sample_bur(volume::BurParams::cone(0.4, 0.6, 6.0), 1000);
  ASSERT_TRUE(bur.ok());
  EngineConfig cfg;
  use_overlap_cut(cfg);
  cut_rate::Press p;
  p.seconds = 0.2;
  p.shape_constraint = true;
  const auto a = cut_rate::press(p, *bur, cfg.cut), b = cut_rate::press(p, *bur, cfg.cut);
  EXPECT_GT(a.removed_mm3, 0.0);
  EXPECT_EQ(a.removed_mm3, b.removed_mm3);
  EXPECT_EQ(a.depth_mm, b.depth_mm);
}

}  // namespace
}  // namespace dentar::haptics
