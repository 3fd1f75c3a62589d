// Issue 25: do outcome scores rank sessions by skill? Generates sessions of
// each exercise at skill levels from the expert's (separation 0) to the
// full novice's (separation 1) with the cohort generator, scores each
// (replay on the starting tooth, outcome against the exercise) and prints
// per exercise the Spearman rank correlation between the total and the
// generated skill (1 - separation), the expert and novice means, and how
// many sessions were marked incomplete. Not a Google Benchmark: one run,
// one table (docs/BENCHMARKS.md, "Issue 25: scores and feedback").
//   build/training/training_score_rank_bench [--levels 5] [--subjects 3] [--voxel-mm 0.15] [--seed 1]
//                                            [--exercise NAME]... [--keep DIR] [--over-reduction-rate X] [--tolerance-mm T]
//                                            [--overprep-price exercise|region] [--access-zone-rate R]
// --keep DIR keeps every generated session and its replayed cut volume in DIR
// and reuses them when present, so a change of the criteria is re-scored in
// seconds on the same sessions (the first run generates them).
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "dentar/haptics/replay.h"
#include "dentar/haptics/session_log.h"
#include "dentar/training/cohort.h"
#include "dentar/training/outcome.h"

namespace {

using namespace dentar::training;

struct Row {
  double skill = 0;
  OutcomeScores o;
  double seconds = 0;
};

}  // namespace

int main(int argc, char** argv) {
  int levels = 5, subjects = 3;
  double voxel_mm = 0.15;
  std::uint64_t seed = 1;
  std::vector<std::string> exercises;
  std::string keep;
  double over_rate = -1, tol = -1;  // --over-reduction-rate: overrides the exercises' (comparison runs)
  std::string price;                // --overprep-price exercise|region: the same
  double zone_rate = -1;            // --access-zone-rate: the same
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--levels") levels = std::atoi(v.c_str());
    else if (a == "--subjects") subjects = std::atoi(v.c_str());
    else if (a == "--voxel-mm") voxel_mm = std::atof(v.c_str());
    else if (a == "--seed") seed = std::strtoull(v.c_str(), nullptr, 10);
    else if (a == "--exercise") exercises.push_back(v);
    else if (a == "--keep") keep = v;
    else if (a == "--over-reduction-rate") over_rate = std::atof(v.c_str());
    else if (a == "--tolerance-mm") tol = std::atof(v.c_str());
    else if (a == "--overprep-price") price = v;
    else if (a == "--access-zone-rate") zone_rate = std::atof(v.c_str());
    else {
      std::fprintf(stderr, "score_rank_bench: unknown option %s\n", a.c_str());
      return 2;
    }
  }
  if (!price.empty() && price != "exercise" && price != "region") {
    std::fprintf(stderr, "score_rank_bench: --overprep-price must be exercise or region, not %s\n", price.c_str());
    return 2;
  }
  if (levels < 2 || subjects < 1) {
    std::fprintf(stderr, "score_rank_bench: --levels must be >= 2 and --subjects >= 1\n");
    return 2;
  }
  if (exercises.empty()) exercises = {"incisor_partial_crown", "molar_access_opening", "molar_class1_cavity"};
  const std::string dir = !keep.empty() ? keep
                         : (std::filesystem::temp_directory_path() / ("dentar_score_rank_" + std::to_string(::getpid()))).string();
  std::printf("exercise | sessions | Spearman rho (total vs skill) | expert mean | novice mean | max | incomplete (expert / novice) | s per session\n");
  for (const auto& name : exercises) {
    auto ex = load_builtin_exercise(name);
    if (!ex) {
      std::fprintf(stderr, "%s\n", ex.error().c_str());
      return 2;
    }
    if (over_rate >= 0) ex->over_reduction_rate = over_rate;
    if (tol >= 0) ex->tolerance_mm = tol;
    if (!price.empty()) ex->overprep_exercise_price = price == "exercise";
    if (zone_rate >= 0) ex->access_zone_rate = zone_rate;
    std::vector<Row> rows;
    for (int l = 0; l < levels; ++l) {
      const double sep = static_cast<double>(l) / (levels - 1);
      CohortOptions co;
      co.experts = 0;
      co.novices = subjects;
      co.trials = 1;
      co.separation = sep;
      co.voxel_mm = voxel_mm;
      co.bur_samples = 500;
      co.seed = seed * 1000 + static_cast<std::uint64_t>(l);
      const std::string d = dir + "/" + name + "_" + std::to_string(l);
      const auto t0 = std::chrono::steady_clock::now();
      const bool reuse = !keep.empty() && std::filesystem::exists(d + "/trials.csv");
      auto trials = reuse ? read_cohort(d) : generate_cohort(*ex, co, d);
      if (!trials) {
        std::fprintf(stderr, "%s\n", trials.error().c_str());
        return 1;
      }
      for (const auto& t : *trials) {
        auto log = dentar::haptics::read_session_log(t.session_path);
        if (!log) return std::fprintf(stderr, "%s\n", log.error().c_str()), 1;
        auto setup = dentar::haptics::parse_session_header(log->header_json);
        if (!setup) return std::fprintf(stderr, "%s\n", setup.error().c_str()), 1;
        auto start = make_tooth(setup->tooth_json);
        if (!start) return std::fprintf(stderr, "%s\n", start.error().c_str()), 1;
        dentar::volume::VoxelVolume cut = start->clone();
        const std::string cut_path = t.session_path + ".cut";
        const auto dm = start->dims();
        const std::size_t nvox = static_cast<std::size_t>(dm.x()) * dm.y() * dm.z();
        std::vector<char> raw;
        if (!keep.empty() && std::filesystem::exists(cut_path) && std::filesystem::file_size(cut_path) == 2 * nvox) {
          raw.resize(2 * nvox);
          std::ifstream(cut_path, std::ios::binary).read(raw.data(), static_cast<std::streamsize>(raw.size()));
          std::size_t q = 0;
          for (int k = 0; k < dm.z(); ++k)
            for (int j = 0; j < dm.y(); ++j)
              for (int i = 0; i < dm.x(); ++i, q += 2)
                cut.set(i, j, k, static_cast<std::uint8_t>(raw[q]), static_cast<dentar::volume::Material>(raw[q + 1]));
        } else {
          if (auto r = dentar::haptics::replay_session(*log, cut); !r) return std::fprintf(stderr, "%s\n", r.error().c_str()), 1;
          if (!keep.empty()) {
            raw.reserve(2 * nvox);
            for (int k = 0; k < dm.z(); ++k)
              for (int j = 0; j < dm.y(); ++j)
                for (int i = 0; i < dm.x(); ++i) {
                  raw.push_back(static_cast<char>(cut.density(i, j, k)));
                  raw.push_back(static_cast<char>(cut.material(i, j, k)));
                }
            std::ofstream(cut_path, std::ios::binary).write(raw.data(), static_cast<std::streamsize>(raw.size()));
          }
        }
        auto masks = build_masks(*ex, *start);
        if (!masks) return std::fprintf(stderr, "%s\n", masks.error().c_str()), 1;
        auto sc = score_outcome(*ex, *masks, *start, cut);
        if (!sc) return std::fprintf(stderr, "%s\n", sc.error().c_str()), 1;
        rows.push_back({1.0 - sep, *sc, 0});
        std::string costs;
        for (const auto& p : sc->penalties) costs += ", -" + std::to_string(p.points) + " " + p.name + " (" + p.why + ")";
        std::string parts;
        for (const auto& r : sc->regions)
          parts += " " + r.name + " " + std::to_string(r.points).substr(0, 4) + "(cov " + std::to_string(static_cast<int>(r.coverage_pct)) +
                   " over " + std::to_string(r.overprep_mm3).substr(0, 5) + ")";
        for (const auto& c : sc->criteria) parts += " [" + c.name + " " + std::to_string(c.score) + " " + std::to_string(c.value).substr(0, 6) + "]";
        for (const auto& [fn, fv] : sc->forbidden_by_region) parts += " {" + fn + " " + std::to_string(fv).substr(0, 5) + "}";
        std::fprintf(stderr, "%s skill %.2f %s: %s (earned %.1f), coverage %.0f %%, over-prep %.2f mm3 (beyond zones %.2f), forbidden %.2f mm3%s; %s |%s\n",
                     name.c_str(), 1.0 - sep, t.subject.c_str(), sc->headline().c_str(), sc->earned_points,
                     sc->target_coverage_pct, sc->overprep_mm3, sc->beyond_zone_mm3, sc->forbidden_mm3, costs.c_str(), sc->completion.c_str(),
                     parts.c_str());
      }
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      for (std::size_t i = rows.size() - trials->size(); i < rows.size(); ++i) rows[i].seconds = s / trials->size();
      if (keep.empty()) std::filesystem::remove_all(d);
    }
    std::vector<double> x, y;
    double em = 0, nm = 0, secs = 0;
    int ne = 0, nn = 0, ie = 0, in = 0;
    for (const auto& r : rows) {
      x.push_back(r.o.points);
      y.push_back(r.skill);
      secs += r.seconds;
      if (r.skill == 1.0) em += r.o.points, ++ne, ie += !r.o.complete;
      if (r.skill == 0.0) nm += r.o.points, ++nn, in += !r.o.complete;
    }
    std::printf("%s | %zu | %.3f | %.1f | %.1f | %.0f | %d/%d / %d/%d | %.1f\n", name.c_str(), rows.size(), spearman_rho(x, y),
                em / std::max(ne, 1), nm / std::max(nn, 1), rows.front().o.max_points, ie, ne, in, nn, secs / rows.size());
    std::fflush(stdout);
  }
  if (keep.empty()) std::filesystem::remove_all(dir);
  return 0;
}
