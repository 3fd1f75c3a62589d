// Cut rate against voxel size (issue 25, session 20): the exercise's cone bur
// pressed with a constant force into a flat dentin / enamel block through the
// proxy force model and the cutter (haptics/test/cut_rate.h), at 0.15, 0.1 and
// 0.075 mm voxels, averaged over 4 placements of the surface and the bur
// against the voxel grid. Prints removed mm^3/s, depth mm/s, mean force and
// penetration (second half of each run). Deterministic: no timing.
//   ./build/haptics/haptics_cut_rate_bench [--seconds 0.4] [--force 1]
#include <cstdio>
#include <cstdlib>
#include <string>

#include "../test/cut_rate.h"

using namespace dentar;

int main(int argc, char** argv) {
  double seconds = 0.4, force = 1.0;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--seconds") seconds = std::atof(argv[i + 1]);
    else if (a == "--force") force = std::atof(argv[i + 1]);
    else {
      std::fprintf(stderr, "unknown option %s (use --seconds S --force N)\n", a.c_str());
      return 2;
    }
  }
  if (!(seconds > 0.01 && seconds < 60) || !(force > 0 && force < 10)) {
    std::fprintf(stderr, "--seconds must be in (0.01, 60), --force in (0, 10)\n");
    return 2;
  }
  for (bool jitter : {false, true}) {
  std::printf("\nsample_jitter %s\n", jitter ? "on" : "off (main)");
  volume::CutParams cut;
  cut.sample_jitter = jitter;
  std::printf("bur       samples material voxel_mm  mm3_s  depth_mm_s  depth_mm  force_N  pen_mm  max_force_N\n");
  for (int samples : {500, 2000}) {
    auto bur = volume::sample_bur(volume::BurParams::cone(0.4, 0.6, 6.0), samples);
    if (!bur) return 1;
    for (auto m : {volume::Material::kDentin, volume::Material::kEnamel})
      for (double h : {0.15e-3, 0.1e-3, 0.075e-3}) {
        haptics::cut_rate::PressResult sum;
        double mx = 0;
        const double phases[4][2] = {{0.0, 0.0}, {0.25, 0.5}, {0.5, 0.25}, {0.75, 0.75}};
        for (const auto& ph : phases) {
          haptics::cut_rate::Press p;
          p.voxel_m = h;
          p.material = m;
          p.force_N = force;
          p.seconds = seconds;
          p.grid_phase = ph[0];
          p.lateral_phase = ph[1];
          const auto r = haptics::cut_rate::press(p, *bur, cut);
          sum.rate_mm3_s += r.rate_mm3_s / 4;
          sum.depth_rate_mm_s += r.depth_rate_mm_s / 4;
          sum.depth_mm += r.depth_mm / 4;
          sum.mean_force_N += r.mean_force_N / 4;
          sum.mean_penetration_mm += r.mean_penetration_mm / 4;
          mx = std::max(mx, r.max_force_N);
        }
        std::printf("cone0.4/0.6 %5d %-8s %6.3f  %7.3f  %9.3f  %8.3f  %7.3f  %6.3f  %7.3f\n", samples,
                    m == volume::Material::kDentin ? "dentin" : "enamel", h * 1e3, sum.rate_mm3_s,
                    sum.depth_rate_mm_s, sum.depth_mm, sum.mean_force_N, sum.mean_penetration_mm, mx);
      }
  }
  }
  return 0;
}
