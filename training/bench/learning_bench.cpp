// Issue 27 (session 15): learning curves on simulated students who learn (learner.h). For a
// novice and a skilled learner model, each guidance condition (no guidance, the fixed seed
// field, as needed, fading, across the path only, error amplification, and the lesson plan's
// own choices) over repeated lessons, several seeds: the following error per repetition
// (training) and an unguided retention test afterwards (the expert hidden, no force), every
// run through the engine and the mode (run_lesson). Prints markdown tables: mean ± SD over
// seeds with 95 % t intervals, and paired differences against no guidance and the fixed field
// (the conditions share each seed's noise).
//
//   build/training/training_learning_bench [--lesson DIR | --exercise NAME] [--seconds 20]
//       [--reps 10] [--seeds 5] [--learners novice,skilled]
//       [--conditions none,fixed,as_needed,fading,across_path,amplify,plan] [--device touch]
//       [--probe] [--csv FILE] [--set FIELD=VALUE]...   (a learning parameter of both models)
// Exit: 0 done, 1 a run failed, 2 bad arguments.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "dentar/training/learner.h"
#include "dentar/training/lesson.h"

using namespace dentar;
namespace fs = std::filesystem;

namespace {

const char* kUsage =
    "usage: training_learning_bench [--lesson DIR | --exercise NAME] [--seconds S] [--reps N] "
    "[--seeds N]\n"
    "         [--learners novice,skilled] [--conditions "
    "none,fixed,as_needed,fading,across_path,amplify,plan]\n"
    "         [--device ID] [--probe] [--csv FILE] [--set FIELD=VALUE]...\n"
    "--set changes a learning parameter of both learner models (error_rate, error_half_mm, "
    "use_rate,\n"
    "force_credit, retention), for a sensitivity run.\n"
    "Learning curves of simulated learners (docs/learner_model.md) per guidance condition, through "
    "the engine.\n"
    "example: training_learning_bench --seconds 20 --reps 10 --seeds 5 --csv curves.csv\n";

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> v;
  std::size_t a = 0;
  while (a <= s.size()) {
    const std::size_t b = s.find(',', a);
    const std::string t = s.substr(a, b == std::string::npos ? std::string::npos : b - a);
    if (!t.empty()) v.push_back(t);
    if (b == std::string::npos) break;
    a = b + 1;
  }
  return v;
}

// Two-sided 95 % Student t quantile for df degrees of freedom.
double t95(int df) {
  static const double t[] = {0,     12.706, 4.303, 3.182, 2.776, 2.571, 2.447,
                             2.365, 2.306,  2.262, 2.228, 2.201, 2.179, 2.160,
                             2.145, 2.131,  2.120, 2.110, 2.101, 2.093, 2.086};
  return df <= 0 ? NAN : df <= 20 ? t[df] : 1.96 + 2.4 / df;
}

struct Stat {
  double mean = 0, sd = 0, half = 0;  // half: the 95 % interval's half width
};
Stat stat(const std::vector<double>& v) {
  Stat s;
  if (v.empty()) return s;
  for (double x : v) s.mean += x;
  s.mean /= static_cast<double>(v.size());
  if (v.size() > 1) {
    double q = 0;
    for (double x : v) q += (x - s.mean) * (x - s.mean);
    s.sd = std::sqrt(q / static_cast<double>(v.size() - 1));
    s.half = t95(static_cast<int>(v.size()) - 1) * s.sd / std::sqrt(static_cast<double>(v.size()));
  }
  return s;
}
std::string pm(const Stat& s, double scale = 1e3) {
  char b[64];
  std::snprintf(b, sizeof b, "%.3f ± %.3f", s.mean * scale, s.sd * scale);
  return b;
}
std::string ci(const Stat& s, double scale = 1e3) {
  char b[64];
  std::snprintf(b, sizeof b, "[%.3f, %.3f]", (s.mean - s.half) * scale, (s.mean + s.half) * scale);
  return b;
}

bool number(const char* s, double& out) {
  char* e = nullptr;
  out = std::strtod(s, &e);
  return e != s && *e == '\0' && std::isfinite(out);
}

}  // namespace

int main(int argc, char** argv) {
  std::string lesson_dir, exercise = "molar_class1_cavity", device = "touch", csv;
  training::LearningOptions opt;
  int seeds = 5;
  std::vector<std::string> learners = {"novice", "skilled"};
  std::vector<std::pair<std::string, double>> sets;
  std::vector<std::string> conds = {"none",        "fixed",   "as_needed", "fading",
                                    "across_path", "amplify", "plan"};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto val = [&](const char*& v) {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "%s needs a value\n%s", a.c_str(), kUsage);
        return false;
      }
      v = argv[++i];
      return true;
    };
    const char* v = nullptr;
    double x = 0;
    if (a == "--help" || a == "-h") {
      std::printf("%s", kUsage);
      return 0;
    } else if (a == "--probe") {
      opt.probe_each = true;
    } else if (!val(v)) {
      return 2;
    } else if (a == "--lesson") {
      lesson_dir = v;
    } else if (a == "--exercise") {
      exercise = v;
    } else if (a == "--device") {
      device = v;
    } else if (a == "--csv") {
      csv = v;
    } else if (a == "--learners") {
      learners = split(v);
    } else if (a == "--conditions") {
      conds = split(v);
    } else if (a == "--set") {
      const std::string kv = v;
      const std::size_t eq = kv.find('=');
      double y = 0;
      if (eq == std::string::npos || !number(kv.c_str() + eq + 1, y)) {
        std::fprintf(stderr, "--set %s: expected FIELD=NUMBER\n%s", v, kUsage);
        return 2;
      }
      sets.emplace_back(kv.substr(0, eq), y);
    } else if (!number(v, x)) {
      std::fprintf(stderr, "%s %s: not a number\n%s", a.c_str(), v, kUsage);
      return 2;
    } else if (a == "--seconds") {
      opt.seconds = x;
    } else if (a == "--reps") {
      opt.repetitions = static_cast<int>(x);
    } else if (a == "--seeds") {
      seeds = static_cast<int>(x);
    } else {
      std::fprintf(stderr, "unknown option %s\n%s", a.c_str(), kUsage);
      return 2;
    }
  }
  opt.device = device;
  if (std::string e = opt.validate(); !e.empty()) {
    std::fprintf(stderr, "%s\n", e.c_str());
    return 2;
  }
  if (seeds < 1 || seeds > 100) {
    std::fprintf(stderr, "--seeds %d must be in [1, 100]\n", seeds);
    return 2;
  }
  std::vector<training::LearnerModel> models;
  for (const std::string& l : learners) {
    if (l == "novice")
      models.push_back(training::LearnerModel::novice());
    else if (l == "skilled")
      models.push_back(training::LearnerModel::skilled());
    else {
      std::fprintf(stderr, "--learners: '%s' is not novice or skilled\n", l.c_str());
      return 2;
    }
  }
  for (auto& m : models) {
    for (const auto& [k, y] : sets) {
      double* f = k == "error_rate"      ? &m.error_rate
                  : k == "error_half_mm" ? &m.error_half_mm
                  : k == "use_rate"      ? &m.use_rate
                  : k == "force_credit"  ? &m.force_credit
                  : k == "retention"     ? &m.retention
                                         : nullptr;
      if (!f) {
        std::fprintf(
            stderr,
            "--set %s: not one of error_rate, error_half_mm, use_rate, force_credit, retention\n",
            k.c_str());
        return 2;
      }
      *f = y;
    }
    if (std::string e = m.validate(); !e.empty()) {
      std::fprintf(stderr, "--set: %s\n", e.c_str());
      return 2;
    }
  }
  std::vector<training::GuidanceCondition> cs;
  for (const std::string& c : conds) {
    auto p = training::parse_condition(c);
    if (!p) {
      std::fprintf(stderr, "--conditions: %s\n", p.error().c_str());
      return 2;
    }
    cs.push_back(*p);
  }

  // The lesson: given, or the exercise's generated expert made in a scratch folder (removed).
  std::string scratch;
  auto cleanup = [&] {
    if (!scratch.empty()) fs::remove_all(scratch);
  };
  Result<training::Lesson> lesson = Error{""};
  if (!lesson_dir.empty()) {
    lesson = training::load_lesson(lesson_dir);
    if (!lesson) {
      std::fprintf(stderr, "--lesson: %s\n", lesson.error().c_str());
      return 2;
    }
  } else {
    std::string tmpl = (fs::temp_directory_path() / "dentar_learning_bench_XXXXXX").string();
    if (!::mkdtemp(tmpl.data())) {
      std::fprintf(stderr, "cannot make a scratch folder in %s\n",
                   fs::temp_directory_path().c_str());
      return 1;
    }
    scratch = tmpl;
    lesson = training::make_generated_lesson(exercise, scratch + "/lesson", 1);
    if (!lesson) {
      std::fprintf(stderr, "--exercise: %s\n", lesson.error().c_str());
      cleanup();
      return 2;
    }
  }

  std::FILE* out_csv = nullptr;
  if (!csv.empty()) {
    out_csv = std::fopen(csv.c_str(), "w");
    if (!out_csv) {
      std::fprintf(stderr, "--csv %s: cannot write\n", csv.c_str());
      cleanup();
      return 2;
    }
    std::fprintf(
        out_csv,
        "learner,condition,seed,repetition,mode,rule,train_mean_mm,train_p95_mm,mean_force_N,"
        "probe_mean_mm,probe_p95_mm,memory_mm\n");
  }

  const std::clock_t c0 = std::clock();
  std::printf("lesson %s, first %.0f s, %d repetitions, %d seeds, device %s", lesson->path.c_str(),
              opt.seconds, opt.repetitions, seeds, device.c_str());
  for (const auto& [k, y] : sets) std::printf(", %s = %g", k.c_str(), y);
  std::printf("\n");
  // results[learner][condition] = one curve per seed
  std::map<std::string, std::map<std::string, std::vector<training::LearningCurve>>> res;
  for (const auto& m : models) {
    for (auto c : cs) {
      for (int s = 1; s <= seeds; ++s) {
        auto r = training::run_learning_curve(*lesson, m, c, static_cast<std::uint64_t>(s), opt);
        if (!r) {
          std::fprintf(stderr, "%s, %s, seed %d: %s\n", m.name.c_str(), training::condition_name(c),
                       s, r.error().c_str());
          if (out_csv) std::fclose(out_csv);
          cleanup();
          return 1;
        }
        if (out_csv) {
          for (std::size_t k = 0; k < r->reps.size(); ++k) {
            const auto& q = r->reps[k];
            std::fprintf(out_csv, "%s,%s,%d,%zu,%d,%s,%.5f,%.5f,%.5f,%.5f,%.5f,%.5f\n",
                         m.name.c_str(), training::condition_name(c), s, k + 1, q.mode,
                         q.rule.c_str(), q.train_mean_m * 1e3, q.train_p95_m * 1e3, q.mean_force_N,
                         q.probe_mean_m * 1e3, q.probe_p95_m * 1e3, q.memory_m * 1e3);
          }
          std::fprintf(out_csv, "%s,%s,%d,retention,1,,%.5f,%.5f,0,,,\n", m.name.c_str(),
                       training::condition_name(c), s, r->retention_mean_m * 1e3,
                       r->retention_p95_m * 1e3);
          std::fflush(out_csv);
        }
        std::fprintf(stderr, "%s %s seed %d: retention %.3f mm (%.1f s CPU)\n", m.name.c_str(),
                     training::condition_name(c), s, r->retention_mean_m * 1e3, r->cpu_s);
        res[m.name][training::condition_name(c)].push_back(*r);
      }
    }
  }
  if (out_csv) std::fclose(out_csv);

  const int R = opt.repetitions;
  const std::vector<int> shown =
      R >= 3 ? std::vector<int>{0, R / 2 - 1 + (R % 2), R - 1} : std::vector<int>{0, R - 1};
  for (const auto& m : models) {
    std::printf(
        "\n### %s learner: training error per repetition and retention (mm, mean ± SD over %d "
        "seeds)\n\n",
        m.name.c_str(), seeds);
    std::printf("| condition | before (unguided) |");
    for (int k : shown) std::printf(" training rep %d |", k + 1);
    std::printf(
        " mean force rep 1 / %d (N) | retention mean | 95 %% CI | retention p95 | 95 %% CI "
        "|\n|---|---|",
        R);
    for (std::size_t k = 0; k < shown.size(); ++k) std::printf("---|");
    std::printf("---|---|---|---|---|\n");
    for (auto c : cs) {
      const auto& v = res[m.name][training::condition_name(c)];
      std::vector<double> before, rm, rp, f0, f1;
      std::vector<std::vector<double>> tr(shown.size());
      for (const auto& lc : v) {
        before.push_back(lc.before_mean_m);
        rm.push_back(lc.retention_mean_m);
        rp.push_back(lc.retention_p95_m);
        f0.push_back(lc.reps.front().mean_force_N);
        f1.push_back(lc.reps.back().mean_force_N);
        for (std::size_t k = 0; k < shown.size(); ++k)
          tr[k].push_back(lc.reps[static_cast<std::size_t>(shown[k])].train_mean_m);
      }
      std::printf("| %s | %s |", training::condition_name(c), pm(stat(before)).c_str());
      for (const auto& t : tr) std::printf(" %s |", pm(stat(t)).c_str());
      std::printf(" %.3f / %.3f | %s | %s | %s | %s |\n", stat(f0).mean, stat(f1).mean,
                  pm(stat(rm)).c_str(), ci(stat(rm)).c_str(), pm(stat(rp)).c_str(),
                  ci(stat(rp)).c_str());
    }
    // Paired differences of the retention error (condition - anchor), same seeds.
    for (const char* anchor : {"none", "fixed"}) {
      if (!res[m.name].count(anchor)) continue;
      const auto& a = res[m.name][anchor];
      std::printf(
          "\nRetention mean error, %s learner, paired difference against %s (mm; negative = "
          "better):\n\n",
          m.name.c_str(), anchor);
      std::printf(
          "| condition | difference mean ± SD | 95 %% CI | seeds better |\n|---|---|---|---|\n");
      for (auto c : cs) {
        if (std::string(training::condition_name(c)) == anchor) continue;
        const auto& v = res[m.name][training::condition_name(c)];
        std::vector<double> d;
        int better = 0;
        for (std::size_t i = 0; i < v.size() && i < a.size(); ++i) {
          d.push_back(v[i].retention_mean_m - a[i].retention_mean_m);
          better += d.back() < 0;
        }
        std::printf("| %s | %s | %s | %d of %zu |\n", training::condition_name(c),
                    pm(stat(d)).c_str(), ci(stat(d)).c_str(), better, d.size());
      }
    }
    // The lesson plan's choices against the curves.
    std::string best;
    double best_v = 1e9;
    for (auto c : cs) {
      if (c == training::GuidanceCondition::kPlan) continue;
      const double v = stat([&] {
                         std::vector<double> x;
                         for (const auto& lc : res[m.name][training::condition_name(c)])
                           x.push_back(lc.retention_mean_m);
                         return x;
                       }())
                           .mean;
      if (v < best_v) best_v = v, best = training::condition_name(c);
    }
    if (!best.empty())
      std::printf("\nLowest mean retention error among the single conditions: %s (%.3f mm).\n",
                  best.c_str(), best_v * 1e3);
    if (res[m.name].count("plan")) {
      const auto& v = res[m.name]["plan"];
      std::printf("The lesson plan's choices, seed 1 (repetition: mode, rule):");
      for (std::size_t k = 0; k < v.front().reps.size(); ++k) {
        const auto& q = v.front().reps[k];
        std::printf(" %zu: %d %s%s", k + 1, q.mode, q.rule.c_str(),
                    k + 1 < v.front().reps.size() ? ";" : "\n");
      }
    }
  }
  std::printf("\ntotal CPU %.1f s\n", static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC);
  cleanup();
  return 0;
}
