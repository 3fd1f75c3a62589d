// Issue 27 (session 12): adaptive guidance against the fixed field, with the simulated
// student, on the generated expert lesson of a built-in exercise. For a passive hand (relaxed,
// 0.5 s late) and an active student (grips, 0.25 s late), over several seeds: mode 2's
// following error (mean, p95) and the mean force the guidance applied, for the fixed seed
// field, guidance as needed, across the path only, fading over repetitions 1..4 (0.7^rep) and
// error amplification (0.5); mode 1 (no guidance) as the baseline.
//   build/training/training_lesson_guidance_bench [--exercise molar_class1_cavity] [--seconds 30] [--seeds 3]
// This student does not learn: this measures what each variant does to the following error
// and the work the field does, not retention (training_learning_bench measures learning
// curves and retention with a learner model, learner.h).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <unistd.h>
#include <vector>

#include "dentar/training/lesson.h"
#include "dentar/training/lesson_run.h"

using namespace dentar;
namespace fs = std::filesystem;

int main(int argc, char** argv) {
  std::string exercise = "molar_class1_cavity";
  double seconds = 30;
  int seeds = 3;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--exercise")) exercise = argv[i + 1];
    else if (!std::strcmp(argv[i], "--seconds")) seconds = std::atof(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--seeds")) seeds = std::atoi(argv[i + 1]);
  }
  char tmpl[] = "/tmp/dentar_guidance_bench_XXXXXX";
  const char* dir = ::mkdtemp(tmpl);
  if (!dir) return 1;
  const auto t0 = std::chrono::steady_clock::now();
  auto lesson = training::make_generated_lesson(exercise, std::string(dir) + "/lesson", 1);
  if (!lesson) {
    std::fprintf(stderr, "%s\n", lesson.error().c_str());
    fs::remove_all(dir);
    return 1;
  }
  struct Variant {
    const char* name;
    int mode;
    void (*set)(haptics::GuidanceParams&);
  };
  const std::vector<Variant> variants = {
      {"no guidance (mode 1)", 1, [](haptics::GuidanceParams&) {}},
      {"fixed seed field", 2, [](haptics::GuidanceParams&) {}},
      {"as needed", 2, [](haptics::GuidanceParams& g) { g.as_needed = true; }},
      {"across the path only", 2, [](haptics::GuidanceParams& g) { g.across_path_only = true; }},
      {"faded, repetition 1", 2, [](haptics::GuidanceParams& g) { g.fade = 0.7; g.repetition = 1; }},
      {"faded, repetition 2", 2, [](haptics::GuidanceParams& g) { g.fade = 0.7; g.repetition = 2; }},
      {"faded, repetition 4", 2, [](haptics::GuidanceParams& g) { g.fade = 0.7; g.repetition = 4; }},
      {"error amplification 0.5", 2, [](haptics::GuidanceParams& g) { g.amplify = 0.5; }},
  };
  std::printf("exercise %s, %.0f s of the expert, %d seeds, device touch\n", exercise.c_str(), seconds, seeds);
  std::printf("| student | guidance | following error mean (mm) | p95 (mm) | mean force (N) |\n|---|---|---|---|---|\n");
  for (int passive = 1; passive >= 0; --passive) {
    for (const Variant& v : variants) {
      double mean = 0, p95 = 0, force = 0;
      for (int s = 1; s <= seeds; ++s) {
        training::Lesson l = *lesson;
        v.set(l.params.guidance);
        training::LessonRunOptions o;
        o.mode = v.mode;
        o.student = passive ? training::StudentModel::passive_hand() : training::StudentModel{};
        o.student.seed = static_cast<std::uint64_t>(s);
        o.seconds = seconds;
        o.pauses = false;
        auto r = training::run_lesson(l, o);
        if (!r) {
          std::fprintf(stderr, "%s: %s\n", v.name, r.error().c_str());
          fs::remove_all(dir);
          return 1;
        }
        mean += r->follow_mean_m * 1e3 / seeds;
        p95 += r->follow_p95_m * 1e3 / seeds;
        force += r->mean_force_N / seeds;
      }
      std::printf("| %s | %s | %.3f | %.3f | %.3f |\n", passive ? "passive" : "active", v.name, mean, p95, force);
    }
  }
  std::printf("total %.1f s\n", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  fs::remove_all(dir);
  return 0;
}
