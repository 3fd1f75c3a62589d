// Issue 25: leave-one-person-out accuracy beside person identification, on
// kinematics-only cohorts with strong personal style, over several seeds, for
// every method and the baselines. Each cohort is written as tables and read
// back through the kinematics import (columns.json), as a user's data would be.
//   build/training/training_loso_bench --seeds 5 --classes 2 --per-class 6 --trials 3
// Prints one row per method: mean and SD over seeds (and min-max) of the
// leave-one-person-out accuracy, its 95 % t interval over the seed means,
// the pooled Wilson interval, person identification, and the time to
// cross-validate (train + classify every fold).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "dentar/training/assess.h"
#include "dentar/training/cohort.h"
#include "dentar/training/kinematics.h"

using namespace dentar::training;

namespace {

struct Spec {
  std::string name;
  Method method;
  bool normalise;
};

double t975(int dof) {
  static const double t[] = {0, 12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228};
  return dof >= 1 && dof <= 10 ? t[dof] : 1.96;
}

}  // namespace

int main(int argc, char** argv) {
  int seeds = 5, classes = 2, per_class = 6, trials = 3, decimate = 10, first_seed = 1;
  double style = 1.0, separation = 1.0;
  std::string methods = "hmm,hmm-norm,ghmm,ghmm-norm,dtw,dtw-norm,skill,time,timepath";
  std::string exercise = "molar_access_opening", out;
  bool identity = true, trial_cv = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::cerr << "missing value after " << a << "\n";
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--seeds") seeds = std::stoi(next());
    else if (a == "--first-seed") first_seed = std::stoi(next());
    else if (a == "--classes") classes = std::stoi(next());
    else if (a == "--per-class") per_class = std::stoi(next());
    else if (a == "--trials") trials = std::stoi(next());
    else if (a == "--decimate") decimate = std::stoi(next());
    else if (a == "--style") style = std::stod(next());
    else if (a == "--separation") separation = std::stod(next());
    else if (a == "--methods") methods = next();
    else if (a == "--exercise") exercise = next();
    else if (a == "--out") out = next();
    else if (a == "--no-identity") identity = false;
    else if (a == "--cv-trial") trial_cv = true;
    else {
      std::cerr << "unknown option " << a
                << " (--seeds --first-seed --classes 2|3 --per-class --trials --decimate --style --separation --methods "
                   "--exercise --out --no-identity --cv-trial)\n";
      return 2;
    }
  }
  // Scratch cohorts go to a per-process folder under $TMPDIR unless --out names one; either way
  // each seed's folder is removed after use, and the default parent too (two runs never share it).
  const bool own_out = out.empty();
  if (own_out)
    out = (std::filesystem::temp_directory_path() / ("dentar_loso_bench_" + std::to_string(::getpid()))).string();
  if (classes != 2 && classes != 3) {
    std::cerr << "--classes must be 2 or 3\n";
    return 2;
  }
  std::vector<Spec> specs;
  {
    std::stringstream ss(methods);
    for (std::string m; std::getline(ss, m, ',');) {
      const bool norm = m.size() > 5 && m.substr(m.size() - 5) == "-norm";
      auto meth = parse_method(norm ? m.substr(0, m.size() - 5) : m);
      if (!meth) {
        std::cerr << meth.error() << "\n";
        return 2;
      }
      specs.push_back({m, *meth, norm});
    }
  }
  auto ex = load_builtin_exercise(exercise);
  if (!ex) {
    std::cerr << ex.error() << "\n";
    return 2;
  }
  struct Acc {
    std::vector<double> loso, id, secs, loto;
    int k = 0, n = 0, kid = 0, nid = 0;
  };
  std::map<std::string, Acc> acc;
  double style_sd = 0, gap = 0;
  for (int s = first_seed; s < first_seed + seeds; ++s) {
    CohortOptions o;
    o.experts = o.novices = per_class;
    o.intermediates = classes == 3 ? per_class : 0;
    o.trials = trials;
    o.style = style;
    o.separation = separation;
    o.seed = static_cast<std::uint64_t>(s);
    o.voxel_mm = 0.2;
    o.bur_samples = 500;
    o.kinematics_only = true;
    const std::string dir = out + "/seed" + std::to_string(s);
    std::filesystem::remove_all(dir);
    auto t0 = std::chrono::steady_clock::now();
    auto gen = generate_cohort(*ex, o, dir);
    if (!gen) {
      std::cerr << gen.error() << "\n";
      if (own_out) std::filesystem::remove_all(out);
      return 1;
    }
    auto map = load_column_map(dir + "/columns.json");
    std::vector<std::string> names;
    auto tr = map ? import_trials(dir + "/trials.csv", *map, &names) : dentar::Result<std::vector<Trial>>(dentar::Error{map.error()});
    if (!tr) {
      std::cerr << tr.error() << "\n";
      if (own_out) std::filesystem::remove_all(out);
      return 1;
    }
    const double gen_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // Style against the gap, on log task time: between-person SD within a class, expert-novice gap of the class means.
    {
      std::map<std::string, std::pair<double, int>> person;
      std::map<std::string, std::string> label;
      for (const auto& t : *tr) {
        person[t.subject].first += std::log(static_cast<double>(t.x.rows()) / t.rate_hz);
        person[t.subject].second += 1;
        label[t.subject] = t.label;
      }
      std::map<std::string, std::vector<double>> cls;
      for (const auto& [p, v] : person) cls[label[p]].push_back(v.first / v.second);
      double var = 0;
      int dof = 0;
      std::map<std::string, double> mean;
      for (auto& [l, v] : cls) {
        double m = 0;
        for (double x : v) m += x;
        m /= static_cast<double>(v.size());
        mean[l] = m;
        for (double x : v) var += (x - m) * (x - m);
        dof += static_cast<int>(v.size()) - 1;
      }
      style_sd += std::sqrt(var / std::max(1, dof)) / seeds;
      gap += std::abs(mean["novice"] - mean["expert"]) / seeds;
    }
    std::printf("seed %d: %zu trials of %d persons, mean task time %.0f s, generated and imported in %.1f s\n", s,
                tr->size(), per_class * classes, [&] {
                  double m = 0;
                  for (const auto& t : *tr) m += static_cast<double>(t.x.rows()) / t.rate_hz;
                  return m / static_cast<double>(tr->size());
                }(), gen_s);
    for (const auto& sp : specs) {
      AssessOptions a;
      a.method = sp.method;
      a.normalise = sp.normalise;
      a.states = sp.method == Method::kGaussianHmm ? 5 : 13;
      a.iterations = 20;
      a.decimate = decimate;
      a.seed = static_cast<std::uint64_t>(s);
      auto c0 = std::chrono::steady_clock::now();
      auto r = cross_validate(*tr, names, a, CvMode::kSubject);
      const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - c0).count();
      if (!r) {
        std::cerr << sp.name << ": " << r.error() << "\n";
        if (own_out) std::filesystem::remove_all(out);
        return 1;
      }
      Acc& A = acc[sp.name];
      A.loso.push_back(r->accuracy);
      A.secs.push_back(secs);
      A.k += r->correct;
      A.n += r->n;
      if (identity) {
        auto id = cross_validate(*tr, names, a, CvMode::kIdentity);
        if (!id) {
          std::cerr << sp.name << " (identity): " << id.error() << "\n";
          if (own_out) std::filesystem::remove_all(out);
          return 1;
        }
        A.id.push_back(id->accuracy);
        A.kid += id->correct;
        A.nid += id->n;
      }
      if (trial_cv) {
        auto lt = cross_validate(*tr, names, a, CvMode::kTrial);
        if (!lt) {
          std::cerr << sp.name << " (trial): " << lt.error() << "\n";
          if (own_out) std::filesystem::remove_all(out);
          return 1;
        }
        A.loto.push_back(lt->accuracy);
      }
      std::printf("  %-10s leave one person out %5.1f %% (%d/%d), identity %5.1f %%, %.2f s", sp.name.c_str(),
                  100 * r->accuracy, r->correct, r->n, identity ? 100 * A.id.back() : 0.0, secs);
      if (trial_cv) std::printf(", leave one trial out %5.1f %%", 100 * A.loto.back());
      std::printf("\n");
      std::fflush(stdout);
    }
    std::filesystem::remove_all(dir);
  }
  auto stats = [](const std::vector<double>& v, double& m, double& sd, double& lo, double& hi) {
    m = sd = 0;
    lo = 1e9;
    hi = -1e9;
    for (double x : v) {
      m += x;
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
    m /= static_cast<double>(v.size());
    for (double x : v) sd += (x - m) * (x - m);
    sd = v.size() > 1 ? std::sqrt(sd / static_cast<double>(v.size() - 1)) : 0;
  };
  std::printf("\n%d classes, %d persons a class, %d trials each, style %.2f, separation %.2f, %d seeds from %d\n", classes,
              per_class, trials, style, separation, seeds, first_seed);
  std::printf("log task time: between-person SD within a class %.3f, expert-novice gap %.3f (ratio %.2f)\n", style_sd, gap,
              gap > 0 ? style_sd / gap : 0.0);
  std::printf("| method | leave one person out, mean ± SD (min–max) | 95 %% t interval of the seed means | pooled Wilson | "
              "person identification, mean ± SD | cross-validation time, mean s |\n|---|---|---|---|---|---|\n");
  for (const auto& sp : specs) {
    const Acc& A = acc[sp.name];
    double m, sd, lo, hi, im = 0, isd = 0, ilo, ihi, tm, tsd, tlo, thi, wlo, whi;
    stats(A.loso, m, sd, lo, hi);
    if (!A.id.empty()) stats(A.id, im, isd, ilo, ihi);
    stats(A.secs, tm, tsd, tlo, thi);
    wilson_interval(A.k, A.n, wlo, whi);
    const double h = t975(static_cast<int>(A.loso.size()) - 1) * sd / std::sqrt(static_cast<double>(A.loso.size()));
    std::printf("| %s | %.1f ± %.1f %% (%.1f–%.1f) | [%.1f, %.1f] %% | %d/%d [%.1f, %.1f] %% | %.1f ± %.1f %% | %.2f |",
                sp.name.c_str(), 100 * m, 100 * sd, 100 * lo, 100 * hi, 100 * std::max(0.0, m - h),
                100 * std::min(1.0, m + h), A.k, A.n, 100 * wlo, 100 * whi, 100 * im, 100 * isd, tm);
    if (!A.loto.empty()) {
      double lm, lsd, llo, lhi;
      stats(A.loto, lm, lsd, llo, lhi);
      std::printf(" leave one trial out %.1f ± %.1f %% |", 100 * lm, 100 * lsd);
    }
    std::printf("\n");
  }
  if (own_out) std::filesystem::remove_all(out);
  return 0;
}
