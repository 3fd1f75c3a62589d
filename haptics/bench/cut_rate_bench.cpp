// Cut rate against voxel size (issue 25, session 20): the exercise's cone bur
// pressed with a constant force into a flat dentin / enamel block through the
// proxy force model and the cutter (haptics/test/cut_rate.h), at 0.15, 0.1 and
// 0.075 mm voxels, averaged over 4 placements of the surface and the bur
// against the voxel grid. Prints removed mm^3/s, depth mm/s, mean force and
// penetration (second half of each run). Deterministic: no timing.
//   ./build/haptics/haptics_cut_rate_bench [--seconds 0.4] [--force 1]
//       [--samples 500,2000] [--voxels-mm 0.15,0.1,0.075] [--jitter both|on|off]
//       [--model-samples N]   (the force model constrains with its own N-sample bur; 0 = the cutter's)
//       [--cutter samples|overlap] [--constraint samples|shape]   (session 22: CutParams::overlap,
//       ProxyParams::shape_constraint; default samples/samples = main's pairing)
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "../test/cut_rate.h"

using namespace dentar;

int main(int argc, char** argv) {
  double seconds = 0.4, force = 1.0;
  std::vector<int> sample_counts{500, 2000};
  std::vector<double> voxels_m{0.15e-3, 0.1e-3, 0.075e-3};
  std::vector<bool> jitters{false, true};
  int model_samples = 0;
  bool overlap = false, shape = false;
  // Comma-separated list of positive numbers; false on anything else.
  auto parse_list = [](const std::string& text, std::vector<double>& out) {
    out.clear();
    std::stringstream ss(text);
    std::string item;
    while (std::getline(ss, item, ',')) {
      char* end = nullptr;
      const double v = std::strtod(item.c_str(), &end);
      if (item.empty() || *end != '\0' || !(v > 0)) return false;
      out.push_back(v);
    }
    return !out.empty();
  };
  if (argc % 2 == 0) {
    std::fprintf(stderr, "option %s has no value\n", argv[argc - 1]);
    return 2;
  }
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    std::vector<double> list;
    if (a == "--seconds") seconds = std::atof(argv[i + 1]);
    else if (a == "--model-samples") model_samples = std::atoi(argv[i + 1]);
    else if (a == "--force") force = std::atof(argv[i + 1]);
    else if (a == "--samples") {
      if (!parse_list(argv[i + 1], list)) {
        std::fprintf(stderr, "--samples %s: expected counts like 500,2000,10000\n", argv[i + 1]);
        return 2;
      }
      sample_counts.clear();
      for (double v : list) sample_counts.push_back(static_cast<int>(v));
    } else if (a == "--voxels-mm") {
      if (!parse_list(argv[i + 1], list)) {
        std::fprintf(stderr, "--voxels-mm %s: expected sizes like 0.15,0.1\n", argv[i + 1]);
        return 2;
      }
      voxels_m.clear();
      for (double v : list) voxels_m.push_back(v * 1e-3);
    } else if (a == "--cutter" || a == "--constraint") {
      const std::string v = argv[i + 1];
      const bool on = v == (a == "--cutter" ? "overlap" : "shape");
      if (!on && v != "samples") {
        std::fprintf(stderr, "%s %s: expected samples or %s\n", a.c_str(), v.c_str(),
                     a == "--cutter" ? "overlap" : "shape");
        return 2;
      }
      (a == "--cutter" ? overlap : shape) = on;
    } else if (a == "--jitter") {
      const std::string v = argv[i + 1];
      if (v == "both") jitters = {false, true};
      else if (v == "on") jitters = {true};
      else if (v == "off") jitters = {false};
      else {
        std::fprintf(stderr, "--jitter %s: expected both, on or off\n", v.c_str());
        return 2;
      }
    } else {
      std::fprintf(stderr,
                   "unknown option %s (use --seconds S --force N --samples A,B --voxels-mm X,Y "
                   "--jitter both|on|off --cutter samples|overlap --constraint samples|shape)\n",
                   a.c_str());
      return 2;
    }
  }
  if (!(seconds > 0.01 && seconds < 60) || !(force > 0 && force < 10)) {
    std::fprintf(stderr, "--seconds must be in (0.01, 60), --force in (0, 10)\n");
    return 2;
  }
  std::optional<volume::BurSamples> model_bur;
  if (model_samples != 0) {
    auto mb = volume::sample_bur(volume::BurParams::cone(0.4, 0.6, 6.0), model_samples);
    if (!mb) {
      std::fprintf(stderr, "--model-samples: %s\n", mb.error().c_str());
      return 2;
    }
    model_bur = std::move(*mb);
    std::printf("force model constrains with its own %d-sample bur\n", model_samples);
  }
  for (bool jitter : jitters) {
  std::printf("\nsample_jitter %s, cutter %s, constraint %s\n", jitter ? "on" : "off (main)",
              overlap ? "overlap" : "samples", shape ? "shape" : "samples");
  volume::CutParams cut;
  cut.sample_jitter = jitter;
  cut.overlap = overlap;
  // The overlap cutter at its calibrated rate (haptics::use_overlap_cut).
  if (overlap) cut.base_rate_per_s = volume::kOverlapBaseRatePerS;
  std::printf("base_rate_per_s %.0f\n", cut.base_rate_per_s);
  std::printf("bur       samples material voxel_mm  mm3_s  depth_mm_s  depth_mm  force_N  pen_mm  max_force_N  overlap_mm3\n");
  for (int samples : sample_counts) {
    auto bur = volume::sample_bur(volume::BurParams::cone(0.4, 0.6, 6.0), samples);
    if (!bur) {
      std::fprintf(stderr, "%s\n", bur.error().c_str());
      return 2;
    }
    for (auto m : {volume::Material::kDentin, volume::Material::kEnamel})
      for (double h : voxels_m) {
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
          p.shape_constraint = shape;
          const auto r = haptics::cut_rate::press(p, *bur, cut, model_bur ? &*model_bur : nullptr);
          sum.rate_mm3_s += r.rate_mm3_s / 4;
          sum.depth_rate_mm_s += r.depth_rate_mm_s / 4;
          sum.depth_mm += r.depth_mm / 4;
          sum.mean_force_N += r.mean_force_N / 4;
          sum.mean_penetration_mm += r.mean_penetration_mm / 4;
          sum.mean_overlap_mm3 += r.mean_overlap_mm3 / 4;
          mx = std::max(mx, r.max_force_N);
        }
        std::printf("cone0.4/0.6 %5d %-8s %6.3f  %7.3f  %9.3f  %8.3f  %7.3f  %6.3f  %7.3f  %7.4f\n", samples,
                    m == volume::Material::kDentin ? "dentin" : "enamel", h * 1e3, sum.rate_mm3_s,
                    sum.depth_rate_mm_s, sum.depth_mm, sum.mean_force_N, sum.mean_penetration_mm, mx, sum.mean_overlap_mm3);
      }
  }
  }
  return 0;
}
