// Issue 25: do outcome scores rank sessions by skill? Generates sessions of
// each exercise at skill levels from the expert's (separation 0) to the
// full novice's (separation 1) with the cohort generator, scores each
// (replay on the starting tooth, outcome against the exercise) and prints
// per exercise the Spearman rank correlation between the total and the
// generated skill (1 - separation), the expert and novice means, and how
// many sessions were marked incomplete. Not a Google Benchmark: one run,
// one table (docs/BENCHMARKS.md, "Issue 25: scores and feedback").
//   build/training/training_score_rank_bench [--levels 5] [--subjects 3] [--voxel-mm 0.15] [--seed 1]
//                                            [--exercise NAME|FILE.json]... [--keep DIR] [--over-reduction-rate X] [--tolerance-mm T]
//                                            [--overprep-price exercise|region] [--access-zone-rate R] [--access-zone-free-mm F]
//                                            [--access-points bands|continuous] [--taper-points P]
//                                            [--flare-free-deg D] [--flare-deg-per-point S]
//                                            [--seeds 2,3,4,5] [--bootstrap 2000] [--components 1]
//                                            [--pulp-full-mm D] [--pulp-min-fraction F] [--leftover 1] [--replay 1]
//                                            [--taper-reach-full-pct P] [--sample-jitter 0|1] [--overlap-cut 0|1]
//                                            [--wall-overext-rate R] [--wall-overext-free-mm F] [--wall-overext-pct P]
//                                            [--dump-walls FILE]
// --wall-overext-rate R, --wall-overext-free-mm F, --wall-overext-pct P: the access opening's
// wall_overextension_points_per_mm / _free_mm / _percentile (session 22). --dump-walls FILE: every
// session's wall direction-levels (exercise, seed, skill, subject, earned, costs, total, then
// a line P of the penalties, name|points;, a line X (session 23: coverage %, target mm3, mm3 removed below
// the floor, floor perforated 0/1, each wall's charged mm3 M D B P, each wall's area past the free margin
// mm2, each criterion's score), then wall dir z_mm e_mm outline_mm per sample) appended to FILE, for
// recomputing candidate rules.
// --exercise takes a built-in name or an exercise file (its sessions go in DIR/<its name>_<level>).
// --keep DIR keeps every generated session and its replayed cut volume in DIR
// and reuses them when present, so a change of the criteria is re-scored in
// seconds on the same sessions (the first run generates them).
// --seeds A,B,...: one cohort per seed (with --keep, in DIR/s<seed>), each
// seed's line as with --seed, then the seeds pooled and their mean +- SD.
// Every rho is printed with its 95 % bootstrap interval (sessions resampled
// with replacement within each skill level, --bootstrap resamples, fixed
// seed): how far rho could move from sampling the sessions alone.
// --components 1: also each region's points / coverage / cut too far, each criterion, the points
// before costs and the costs, each as its own rho against skill (which criterion mis-ranks).
// --pulp-full-mm D, --pulp-min-fraction F: the graded pulp exposure's fields (0 / 1: all or nothing).
// --replay 1: score each freshly generated session from a replay of its log (as before session
// 17) instead of the tooth the generator's engine left (the same voxels: the two give identical
// scores on seed 2 of every exercise, docs/BENCHMARKS.md "Issue 25 session 17"; the replay
// doubled a session's CPU time).
// --taper-reach-full-pct P: the wall taper's outline_reach_full_pct (0: off; session 19).
// --taper-points P: the exercise's wall taper (it must have one) is worth P
// points and its graded regions the rest of the exercise's total.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "dentar/haptics/replay.h"
#include "dentar/haptics/session_log.h"
#include "dentar/training/cohort.h"
#include "dentar/training/outcome.h"
#include "dentar/volume/material.h"

namespace {

using namespace dentar::training;

struct Row {
  double skill = 0;
  OutcomeScores o;
  double seconds = 0;
};

// rho of the totals against skill, and its 95 % percentile interval over `b` stratified
// bootstrap resamples (each skill level's sessions drawn with replacement).
struct RhoCi {
  double rho = 0, lo = 0, hi = 0;
};
RhoCi rho_with_interval(const std::vector<Row>& rows, int b) {
  std::vector<double> x, y;
  for (const auto& r : rows) x.push_back(r.o.points), y.push_back(r.skill);
  RhoCi c;
  c.rho = spearman_rho(x, y);
  c.lo = c.hi = c.rho;
  if (b <= 0) return c;
  std::vector<std::vector<std::size_t>> levels;
  std::vector<double> skills;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    std::size_t l = 0;
    while (l < skills.size() && skills[l] != rows[i].skill) ++l;
    if (l == skills.size()) skills.push_back(rows[i].skill), levels.emplace_back();
    levels[l].push_back(i);
  }
  std::mt19937_64 rng(20261128);
  std::vector<double> rs;
  for (int k = 0; k < b; ++k) {
    std::vector<double> bx, by;
    for (const auto& lv : levels) {
      std::uniform_int_distribution<std::size_t> pick(0, lv.size() - 1);
      for (std::size_t q = 0; q < lv.size(); ++q) {
        const Row& r = rows[lv[pick(rng)]];
        bx.push_back(r.o.points);
        by.push_back(r.skill);
      }
    }
    const double v = spearman_rho(bx, by);
    if (std::isfinite(v)) rs.push_back(v);
  }
  if (rs.empty()) return c;
  std::sort(rs.begin(), rs.end());
  c.lo = rs[static_cast<std::size_t>(0.025 * (rs.size() - 1))];
  c.hi = rs[static_cast<std::size_t>(0.975 * (rs.size() - 1))];
  return c;
}

// --leftover 1: where a session left each target region's material and where it cut past the
// targets, in the tooth frame. Per target region: the material left (mm3 of the starting
// density still in place) against the region's material, in 0.5 mm bands of z and in bands of
// depth inside the outline (the distance from a voxel to the nearest voxel outside the region,
// 0.15 mm steps); then the material removed outside every target, in bands of z and of distance
// outside the nearest target (same steps). Reads the plan's result, not the score.
void print_leftover(const std::string& tag, const Exercise& ex, const RegionMasks& m, const dentar::volume::VoxelVolume& start,
                    const dentar::volume::VoxelVolume& cut) {
  const Eigen::Vector3i d = start.dims();
  const double h = start.spacing().minCoeff();
  const double vox_mm3 = start.voxel_volume_m3() * 1e9;
  const int reach = static_cast<int>(std::ceil(1.2e-3 / h));
  // Distance (in units of h) from voxel (i, j, k) to the nearest voxel for which `other` holds, up to reach + 1.
  int side = 0;  // of the last dist_to: 0..5 = the nearest such voxel lies toward -x, +x, -y, +y, -z, +z
  auto dist_to = [&](int i, int j, int k, const std::function<bool(int, int, int)>& other) {
    double best = reach + 1;
    for (int c = -reach; c <= reach; ++c)
      for (int b = -reach; b <= reach; ++b)
        for (int a = -reach; a <= reach; ++a) {
          const double r = std::sqrt(double(a * a + b * b + c * c));
          if (r >= best) continue;
          const int x = i + a, y = j + b, z = k + c;
          if (x < 0 || y < 0 || z < 0 || x >= d.x() || y >= d.y() || z >= d.z()) continue;
          if (!other(x, y, z)) continue;
          best = r;
          const int ax = std::abs(a) >= std::abs(b) && std::abs(a) >= std::abs(c) ? 0 : std::abs(b) >= std::abs(c) ? 1 : 2;
          side = 2 * ax + ((ax == 0 ? a : ax == 1 ? b : c) > 0);
        }
    return best * h * 1e3;  // mm
  };
  static const char* kSide[6] = {"-x", "+x", "-y", "+y", "-z", "+z"};
  auto band_line = [](const std::vector<std::pair<double, double>>& bands, double lo, double step) {
    std::string s;
    for (std::size_t b = 0; b < bands.size(); ++b) {
      if (bands[b].second <= 0 && bands[b].first <= 0) continue;
      char buf[96];
      std::snprintf(buf, sizeof buf, " [%.2f,%.2f) %.2f/%.2f", lo + b * step, lo + (b + 1) * step, bands[b].first, bands[b].second);
      s += buf;
    }
    return s;
  };
  for (std::size_t r = 0; r < ex.regions.size() && r < 32; ++r) {
    if (ex.regions[r].role != RegionRole::kTarget) continue;
    auto in_r = [&](int x, int y, int z) { return (m.bits[m.index(x, y, z)] >> r & 1u) != 0; };
    double zlo = 1e9, zhi = -1e9;
    for (int k = 0; k < d.z(); ++k)
      for (int j = 0; j < d.y(); ++j)
        for (int i = 0; i < d.x(); ++i)
          if (start.density(i, j, k) > 0 && in_r(i, j, k)) {
            zlo = std::min(zlo, start.voxel_center(i, j, k).z() * 1e3);
            zhi = std::max(zhi, start.voxel_center(i, j, k).z() * 1e3);
          }
    if (zlo > zhi) continue;
    zlo = std::floor(zlo * 2) / 2;
    const double dstep = 0.15;
    std::vector<std::pair<double, double>> zb(static_cast<std::size_t>((zhi - zlo) / 0.5) + 1), db(9), sb(6);
    double left = 0, total = 0;
    for (int k = 0; k < d.z(); ++k)
      for (int j = 0; j < d.y(); ++j)
        for (int i = 0; i < d.x(); ++i) {
          const int d0 = start.density(i, j, k);
          if (d0 == 0 || !in_r(i, j, k)) continue;
          const double full = std::max<int>(1, dentar::volume::material_info(start.material(i, j, k)).full_density);
          const double v = vox_mm3 * d0 / full, l = vox_mm3 * std::min<int>(d0, cut.density(i, j, k)) / full;
          auto& z = zb[static_cast<std::size_t>((start.voxel_center(i, j, k).z() * 1e3 - zlo) / 0.5)];
          z.first += l, z.second += v;
          const double in = dist_to(i, j, k, [&](int x, int y, int zz) { return !in_r(x, y, zz); });
          auto& q = db[std::min<std::size_t>(db.size() - 1, static_cast<std::size_t>(in / dstep))];
          q.first += l, q.second += v;
          if (in < 0.5) sb[static_cast<std::size_t>(side)].first += l, sb[static_cast<std::size_t>(side)].second += v;
          left += l, total += v;
        }
    std::string sides;
    for (int q = 0; q < 6; ++q)
      if (sb[q].second > 0) {
        char buf[64];
        std::snprintf(buf, sizeof buf, " %s %.2f/%.2f", kSide[q], sb[q].first, sb[q].second);
        sides += buf;
      }
    std::printf("%s leftover %s: %.2f of %.2f mm3 left (%.0f %%); by z mm (left/material):%s; by depth inside the outline mm:%s;"
                " within 0.5 mm of the outline, by the side it faces:%s\n",
                tag.c_str(), ex.regions[r].name.c_str(), left, total, 100 * left / std::max(total, 1e-9),
                band_line(zb, zlo, 0.5).c_str(), band_line(db, 0, dstep).c_str(), sides.c_str());
  }
  // Cut outside every target.
  auto in_target = [&](int x, int y, int z) { return (m.bits[m.index(x, y, z)] & m.target_bits) != 0; };
  std::vector<std::pair<double, double>> ob(9);
  std::vector<std::pair<double, double>> oz(30);
  double osb[6] = {0, 0, 0, 0, 0, 0};
  double over = 0;
  // The same for the pulp alone (session 17): whether it was opened past the floor or past a wall.
  std::vector<std::pair<double, double>> pb(9), pz(30);
  double psb[6] = {0, 0, 0, 0, 0, 0};
  double pulp = 0;
  for (int k = 0; k < d.z(); ++k)
    for (int j = 0; j < d.y(); ++j)
      for (int i = 0; i < d.x(); ++i) {
        const int d0 = start.density(i, j, k), d1 = cut.density(i, j, k);
        if (d1 >= d0 || in_target(i, j, k)) continue;
        const double rem = vox_mm3 * (d0 - d1) / std::max<int>(1, dentar::volume::material_info(start.material(i, j, k)).full_density);
        const double out = dist_to(i, j, k, in_target);
        osb[static_cast<std::size_t>(side)] += rem;
        ob[std::min<std::size_t>(ob.size() - 1, static_cast<std::size_t>(out / 0.15))].first += rem;
        const double z = start.voxel_center(i, j, k).z() * 1e3;
        oz[static_cast<std::size_t>(std::clamp(std::floor(z / 0.5) + 10, 0.0, 29.0))].first += rem;
        over += rem;
        if (start.material(i, j, k) == dentar::volume::Material::kPulp) {
          psb[static_cast<std::size_t>(side)] += rem;
          pb[std::min<std::size_t>(pb.size() - 1, static_cast<std::size_t>(out / 0.15))].first += rem;
          pz[static_cast<std::size_t>(std::clamp(std::floor(z / 0.5) + 10, 0.0, 29.0))].first += rem;
          pulp += rem;
        }
      }
  std::string sides;
  for (int q = 0; q < 6; ++q)
    if (osb[q] > 0) {
      char buf[64];
      std::snprintf(buf, sizeof buf, " %s %.2f", kSide[q], osb[q]);
      sides += buf;
    }
  std::printf("%s outside the targets: %.2f mm3 removed; by distance outside mm:%s; by z mm:%s; by the side of the target it lies on"
              " (the nearest target voxel lies toward):%s\n", tag.c_str(), over,
              band_line(ob, 0, 0.15).c_str(), band_line(oz, -5.0, 0.5).c_str(), sides.c_str());
  if (pulp > 0) {
    std::string ps;
    for (int q = 0; q < 6; ++q)
      if (psb[q] > 0) {
        char buf[64];
        std::snprintf(buf, sizeof buf, " %s %.3f", kSide[q], psb[q]);
        ps += buf;
      }
    std::printf("%s pulp removed: %.3f mm3; by distance outside the targets mm:%s; by z mm:%s; by the side of the target it lies on:%s\n",
                tag.c_str(), pulp, band_line(pb, 0, 0.15).c_str(), band_line(pz, -5.0, 0.5).c_str(), ps.c_str());
  }
}

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
  double zone_free = -1;            // --access-zone-free-mm: the same
  double wo_rate = -1, wo_free = -1, wo_pct = -1;  // --wall-overext-rate / -free-mm / -pct: the same
  std::string dump_walls;           // --dump-walls FILE
  std::string access_points;        // --access-points bands|continuous: the same
  double taper_points = -1;         // --taper-points: the wall taper's points (the regions keep the rest)
  double taper_reach = -1;          // --taper-reach-full-pct: the wall taper's outline reach for full points
  std::vector<std::uint64_t> seeds; // --seeds: several cohorts, pooled at the end
  int bootstrap = 2000;
  int components = 0;               // --components 1: per-criterion rho against skill
  int leftover = 0;                 // --leftover 1: where each session left target material and cut past it
  int replay = 0;                   // --replay 1: replay fresh sessions' logs instead of taking the engine's cut
  int sample_jitter = 0;            // --sample-jitter 1: generate with CutParams::sample_jitter (session 21)
  int overlap_cut = 0;              // --overlap-cut 1: generate with haptics::use_overlap_cut (session 22)
  double pulp_full_mm = -1, pulp_min_fraction = -1;  // --pulp-full-mm, --pulp-min-fraction: graded pulp exposure
  double flare_free = -1, flare_step = -1;  // --flare-free-deg, --flare-deg-per-point: continuous access walls
  if (argc % 2 == 0) {
    std::fprintf(stderr, "score_rank_bench: every option takes a value (%s has none)\n", argv[argc - 1]);
    return 2;
  }
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
    else if (a == "--access-zone-free-mm") zone_free = std::atof(v.c_str());
    else if (a == "--access-points") access_points = v;
    else if (a == "--wall-overext-rate") wo_rate = std::atof(v.c_str());
    else if (a == "--wall-overext-free-mm") wo_free = std::atof(v.c_str());
    else if (a == "--wall-overext-pct") wo_pct = std::atof(v.c_str());
    else if (a == "--dump-walls") dump_walls = v;
    else if (a == "--taper-points") taper_points = std::atof(v.c_str());
    else if (a == "--taper-reach-full-pct") taper_reach = std::atof(v.c_str());
    else if (a == "--flare-free-deg") flare_free = std::atof(v.c_str());
    else if (a == "--flare-deg-per-point") flare_step = std::atof(v.c_str());
    else if (a == "--bootstrap") bootstrap = std::atoi(v.c_str());
    else if (a == "--components") components = std::atoi(v.c_str());
    else if (a == "--leftover") leftover = std::atoi(v.c_str());
    else if (a == "--replay") replay = std::atoi(v.c_str());
    else if (a == "--sample-jitter") {
      if (v != "0" && v != "1") {
        std::fprintf(stderr, "score_rank_bench: --sample-jitter %s: expected 0 or 1\n", v.c_str());
        return 2;
      }
      sample_jitter = v == "1";
    }
    else if (a == "--overlap-cut") {
      if (v != "0" && v != "1") {
        std::fprintf(stderr, "score_rank_bench: --overlap-cut %s: expected 0 or 1\n", v.c_str());
        return 2;
      }
      overlap_cut = v == "1";
    }
    else if (a == "--pulp-full-mm") pulp_full_mm = std::atof(v.c_str());
    else if (a == "--pulp-min-fraction") pulp_min_fraction = std::atof(v.c_str());
    else if (a == "--seeds") {
      std::stringstream ss(v);
      for (std::string t; std::getline(ss, t, ',');) seeds.push_back(std::strtoull(t.c_str(), nullptr, 10));
    }
    else {
      std::fprintf(stderr, "score_rank_bench: unknown option %s\n", a.c_str());
      return 2;
    }
  }
  if (!price.empty() && price != "exercise" && price != "region") {
    std::fprintf(stderr, "score_rank_bench: --overprep-price must be exercise or region, not %s\n", price.c_str());
    return 2;
  }
  if (!access_points.empty() && access_points != "bands" && access_points != "continuous") {
    std::fprintf(stderr, "score_rank_bench: --access-points must be bands or continuous, not %s\n", access_points.c_str());
    return 2;
  }
  if (seeds.empty()) seeds.push_back(seed);
  if (levels < 2 || subjects < 1) {
    std::fprintf(stderr, "score_rank_bench: --levels must be >= 2 and --subjects >= 1\n");
    return 2;
  }
  if (exercises.empty()) exercises = {"incisor_partial_crown", "molar_access_opening", "molar_class1_cavity"};
  const std::string dir = !keep.empty() ? keep
                         : (std::filesystem::temp_directory_path() / ("dentar_score_rank_" + std::to_string(::getpid()))).string();
  std::printf("exercise | sessions | Spearman rho (total vs skill) [95 %% bootstrap interval] | expert mean | novice mean | max | incomplete (expert / novice) | s per session\n");
  for (const auto& name : exercises) {
    auto ex = load_named_exercise(name);
    if (!ex) {
      std::fprintf(stderr, "%s\n", ex.error().c_str());
      return 2;
    }
    // The file scored (a built-in name: DENTAR_ASSETS, else the source tree's, never the
    // working directory's): a run from another checkout says which copy it used.
    std::printf("# exercise %s: %s\n", name.c_str(), ex->source.c_str());
    if (over_rate >= 0) ex->over_reduction_rate = over_rate;
    if (tol >= 0) ex->tolerance_mm = tol;
    if (!price.empty()) ex->overprep_exercise_price = price == "exercise";
    if (zone_rate >= 0) ex->access_zone_rate = zone_rate;
    if (zone_free >= 0) ex->access_zone_free_mm = zone_free;
    if (wo_rate >= 0) ex->wall_overextension_points_per_mm = wo_rate;
    if (wo_free >= 0) ex->wall_overextension_free_mm = wo_free;
    if (wo_pct >= 0) ex->wall_overextension_percentile = wo_pct;
    if (!access_points.empty())
      ex->access_points = access_points == "continuous" ? AccessPoints::kContinuous : AccessPoints::kBands;
    if (flare_free >= 0) ex->access_flare_free_deg = flare_free;
    if (flare_step > 0) ex->access_flare_deg_per_point = flare_step;
    if (pulp_full_mm >= 0) ex->pulp_exposure_full_mm = pulp_full_mm;
    if (pulp_min_fraction >= 0) ex->pulp_exposure_min_fraction = pulp_min_fraction;
    if (taper_reach >= 0) {
      if (!ex->wall_taper) {
        std::fprintf(stderr, "score_rank_bench: --taper-reach-full-pct: %s has no wall_taper\n", name.c_str());
        return 2;
      }
      ex->wall_taper->outline_reach_full_pct = taper_reach;
    }
    if (taper_points >= 0) {
      if (!ex->wall_taper) {
        std::fprintf(stderr, "score_rank_bench: --taper-points: %s has no wall_taper\n", name.c_str());
        return 2;
      }
      const double total = ex->max_points(), regions = total - ex->wall_taper->points;
      for (auto& r : ex->regions)
        if (r.role == RegionRole::kTarget && regions > 0) r.points *= (total - taper_points) / regions;
      ex->wall_taper->points = taper_points;
    }
    // Sessions are generated with the exercise as shipped (the scoring options above change only the score).
    const auto gen_ex = load_named_exercise(name);
    if (!gen_ex) return std::fprintf(stderr, "%s\n", gen_ex.error().c_str()), 2;
    const auto line = [&](const std::string& label, const std::vector<Row>& rs) {
      double em = 0, nm = 0, secs = 0;
      int ne = 0, nn = 0, ie = 0, in = 0;
      for (const auto& r : rs) {
        secs += r.seconds;
        if (r.skill == 1.0) em += r.o.points, ++ne, ie += !r.o.complete;
        if (r.skill == 0.0) nm += r.o.points, ++nn, in += !r.o.complete;
      }
      const RhoCi c = rho_with_interval(rs, bootstrap);
      std::printf("%s %s | %zu | %.3f [%.3f, %.3f] | %.1f | %.1f | %.0f | %d/%d / %d/%d | %.1f\n", name.c_str(), label.c_str(),
                  rs.size(), c.rho, c.lo, c.hi, em / std::max(ne, 1), nm / std::max(nn, 1), rs.front().o.max_points, ie, ne,
                  in, nn, secs / rs.size());
      std::fflush(stdout);
      // Per criterion (--components 1): rho of each region's points and coverage, each criterion's
      // score, the points before costs and minus the costs, against skill: which part mis-ranks.
      if (components) {
        std::vector<double> sk;
        for (const auto& r : rs) sk.push_back(r.skill);
        const auto rho_of = [&](const std::function<double(const OutcomeScores&)>& f) {
          std::vector<double> v;
          for (const auto& r : rs) v.push_back(f(r.o));
          const double x = spearman_rho(v, sk);
          return std::isfinite(x) ? x : 0.0;
        };
        std::string out;
        const OutcomeScores& f0 = rs.front().o;
        for (std::size_t q = 0; q < f0.regions.size(); ++q) {
          out += " " + f0.regions[q].name + " points " + std::to_string(rho_of([q](const OutcomeScores& o) { return o.regions[q].points; })).substr(0, 6);
          out += " coverage " + std::to_string(rho_of([q](const OutcomeScores& o) { return o.regions[q].coverage_pct; })).substr(0, 6);
          out += " cut-too-far(-) " + std::to_string(rho_of([q](const OutcomeScores& o) { return -o.regions[q].overprep_mm3; })).substr(0, 6) + ";";
        }
        for (std::size_t q = 0; q < f0.criteria.size(); ++q)
          out += " " + f0.criteria[q].name + " " + std::to_string(rho_of([q](const OutcomeScores& o) { return o.criteria[q].score; })).substr(0, 6) + ";";
        out += " earned " + std::to_string(rho_of([](const OutcomeScores& o) { return o.earned_points; })).substr(0, 6);
        out += "; costs(-) " + std::to_string(rho_of([](const OutcomeScores& o) { return o.points - o.earned_points; })).substr(0, 6);
        out += "; pulp mm3(-) " + std::to_string(rho_of([](const OutcomeScores& o) { return -o.pulp_removed_mm3; })).substr(0, 6);
        out += "; earned-costs unfloored " + std::to_string(rho_of([](const OutcomeScores& o) {
                 double c = 0;
                 for (const auto& p : o.penalties) c += p.points;
                 return o.earned_points - c;
               })).substr(0, 6);
        int zeros = 0, exposed = 0;
        for (const auto& r : rs) zeros += r.o.points == 0, exposed += r.o.pulp_exposed;
        std::printf("%s %s components:%s; at 0: %d; pulp exposed: %d\n", name.c_str(), label.c_str(), out.c_str(), zeros, exposed);
      }
      return c.rho;
    };
    std::vector<Row> all;
    std::vector<double> seed_rhos;
    struct Base {
      dentar::volume::VoxelVolume start;
      RegionMasks masks;
    };
    std::map<std::string, Base> bases;  // by the session header's tooth JSON
    for (const std::uint64_t seed : seeds) {
    const std::string sdir = seeds.size() > 1 ? dir + "/s" + std::to_string(seed) : dir;
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
      co.sample_jitter = sample_jitter != 0;
      co.overlap_cut = overlap_cut != 0;
      co.seed = seed * 1000 + static_cast<std::uint64_t>(l);
      const std::string d = sdir + "/" + ex->name + "_" + std::to_string(l);
      const auto t0 = std::chrono::steady_clock::now();
      const bool reuse = !keep.empty() && std::filesystem::exists(d + "/trials.csv");
      // The tooth each fresh session's engine left: the cut a replay of its log gives, without
      // cutting everything a second time (--replay 1 replays instead).
      std::map<std::string, dentar::volume::VoxelVolume> engine_cut;
      if (!replay)
        co.on_session = [&engine_cut](const CohortTrial& t, const dentar::volume::VoxelVolume& v) {
          engine_cut.insert_or_assign(t.session_path, v.clone());
        };
      auto trials = reuse ? read_cohort(d) : generate_cohort(*gen_ex, co, d);
      if (!trials) {
        std::fprintf(stderr, "%s\n", trials.error().c_str());
        return 1;
      }
      for (const auto& t : *trials) {
        auto log = dentar::haptics::read_session_log(t.session_path);
        if (!log) return std::fprintf(stderr, "%s\n", log.error().c_str()), 1;
        auto setup = dentar::haptics::parse_session_header(log->header_json);
        if (!setup) return std::fprintf(stderr, "%s\n", setup.error().c_str()), 1;
        // The starting tooth and the exercise's masks on it, made once per tooth (every session of
        // a cohort starts from the same one): the same input gives the same voxels and masks.
        auto base = bases.find(setup->tooth_json);
        if (base == bases.end()) {
          auto tooth = make_tooth(setup->tooth_json);
          if (!tooth) return std::fprintf(stderr, "%s\n", tooth.error().c_str()), 1;
          auto mk = build_masks(*ex, *tooth);
          if (!mk) return std::fprintf(stderr, "%s\n", mk.error().c_str()), 1;
          base = bases.emplace(setup->tooth_json, Base{std::move(*tooth), std::move(*mk)}).first;
        }
        const dentar::volume::VoxelVolume* start = &base->second.start;
        const RegionMasks* masks = &base->second.masks;
        dentar::volume::VoxelVolume cut = start->clone();
        const std::string cut_path = t.session_path + ".cut";
        const auto dm = start->dims();
        const std::size_t nvox = static_cast<std::size_t>(dm.x()) * dm.y() * dm.z();
        std::vector<char> raw;
        const bool cached = !keep.empty() && std::filesystem::exists(cut_path) && std::filesystem::file_size(cut_path) == 2 * nvox;
        if (const auto fresh = engine_cut.find(t.session_path); fresh != engine_cut.end()) {
          if (fresh->second.dims() != dm)
            return std::fprintf(stderr, "score_rank_bench: %s: the engine's tooth and the log's differ in size\n",
                                t.session_path.c_str()), 1;
          cut = std::move(fresh->second);
          engine_cut.erase(fresh);
        } else if (cached) {
          raw.resize(2 * nvox);
          std::ifstream(cut_path, std::ios::binary).read(raw.data(), static_cast<std::streamsize>(raw.size()));
          std::size_t q = 0;
          for (int k = 0; k < dm.z(); ++k)
            for (int j = 0; j < dm.y(); ++j)
              for (int i = 0; i < dm.x(); ++i, q += 2)
                cut.set(i, j, k, static_cast<std::uint8_t>(raw[q]), static_cast<dentar::volume::Material>(raw[q + 1]));
        } else if (auto r = dentar::haptics::replay_session(*log, cut); !r) {
          return std::fprintf(stderr, "%s\n", r.error().c_str()), 1;
        }
        if (!keep.empty() && !cached) {
          raw.reserve(2 * nvox);
          for (int k = 0; k < dm.z(); ++k)
            for (int j = 0; j < dm.y(); ++j)
              for (int i = 0; i < dm.x(); ++i) {
                raw.push_back(static_cast<char>(cut.density(i, j, k)));
                raw.push_back(static_cast<char>(cut.material(i, j, k)));
              }
          std::ofstream(cut_path, std::ios::binary).write(raw.data(), static_cast<std::streamsize>(raw.size()));
        }
        auto sc = score_outcome(*ex, *masks, *start, cut);
        if (!sc) return std::fprintf(stderr, "%s\n", sc.error().c_str()), 1;
        rows.push_back({1.0 - sep, *sc, 0});
        if (!dump_walls.empty()) {
          std::ofstream f(dump_walls, std::ios::app);
          double pc = 0;
          for (const auto& p : sc->penalties) pc += p.points;
          f << "S " << name << ' ' << seed << ' ' << 1.0 - sep << ' ' << t.subject << ' ' << sc->earned_points << ' ' << pc
            << ' ' << sc->points << ' ' << sc->complete << '\n' << "P";
          for (const auto& p : sc->penalties) f << ' ' << p.name << '|' << p.points << ';';
          f << '\n';
          // Session 23: coverage %, target mm3, removed below the floor mm3, floor perforated, each
          // wall's charged mm3 (M D B P) and its area past the free margin mm2, and earned by criterion.
          f << "X " << sc->target_coverage_pct << ' ' << sc->target_mm3 << ' ' << sc->floor_below_mm3 << ' '
            << sc->floor_perforated;
          for (double v : sc->access_zone_charged_by_wall_mm3) f << ' ' << v;
          for (double v : sc->wall_overextended_area_mm2) f << ' ' << v;
          for (const auto& c : sc->criteria) f << ' ' << c.score;
          f << '\n';
          for (const auto& w : sc->wall_overextension_samples)
            f << w.wall << ' ' << w.dir << ' ' << w.z_m * 1e3 << ' ' << w.e_mm << ' ' << w.outline_mm << '\n';
        }
        if (leftover) {
          char tag[96];
          std::snprintf(tag, sizeof tag, "%s skill %.2f %s", name.c_str(), 1.0 - sep, t.subject.c_str());
          print_leftover(tag, *ex, *masks, *start, cut);
        }
        std::string costs;
        for (const auto& p : sc->penalties) costs += ", -" + std::to_string(p.points) + " " + p.name + " (" + p.why + ")";
        std::string parts;
        for (const auto& r : sc->regions)
          parts += " " + r.name + " " + std::to_string(r.points).substr(0, 4) + "(cov " + std::to_string(static_cast<int>(r.coverage_pct)) +
                   " over " + std::to_string(r.overprep_mm3).substr(0, 5) + ")";
        for (const auto& c : sc->criteria) parts += " [" + c.name + " " + std::to_string(c.score).substr(0, 4) + " " + std::to_string(c.value).substr(0, 6) + "]";
        for (const auto& [fn, fv] : sc->forbidden_by_region) parts += " {" + fn + " " + std::to_string(fv).substr(0, 5) + "}";
        if (ex->outcome == OutcomeKind::kAccessOpening) {
          char b[64];
          std::snprintf(b, sizeof b, " <zone %.3f target %.3f bands", sc->access_zone_mm3, sc->target_mm3);
          parts += b;
          for (double v : sc->access_zone_by_band_mm3) std::snprintf(b, sizeof b, " %.3f", v), parts += b;
          parts += " ; overext mean";
          for (double v : sc->wall_overextension_mean_mm) std::snprintf(b, sizeof b, " %.3f", v), parts += b;
          parts += " max";
          for (double v : sc->wall_overextension_max_mm) std::snprintf(b, sizeof b, " %.3f", v), parts += b;
          double pc = 0;
          for (const auto& p : sc->penalties) pc += p.points;
          std::snprintf(b, sizeof b, " ; earned %.4f costs %.4f>", sc->earned_points, pc);
          parts += b;
        }
        std::fprintf(stderr, "%s skill %.2f %s: %s (earned %.1f), coverage %.0f %%, over-prep %.2f mm3 (beyond zones %.2f), forbidden %.2f mm3%s; %s |%s\n",
                     name.c_str(), 1.0 - sep, t.subject.c_str(), sc->headline().c_str(), sc->earned_points,
                     sc->target_coverage_pct, sc->overprep_mm3, sc->beyond_zone_mm3, sc->forbidden_mm3, costs.c_str(), sc->completion.c_str(),
                     parts.c_str());
      }
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      for (std::size_t i = rows.size() - trials->size(); i < rows.size(); ++i) rows[i].seconds = s / trials->size();
      if (keep.empty()) std::filesystem::remove_all(d);
    }
    seed_rhos.push_back(line("seed " + std::to_string(seed), rows));
    all.insert(all.end(), rows.begin(), rows.end());
    }
    if (seeds.size() > 1) {
      double m = 0, v = 0;
      for (double r : seed_rhos) m += r;
      m /= seed_rhos.size();
      for (double r : seed_rhos) v += (r - m) * (r - m);
      line("pooled", all);
      std::printf("%s per-seed rho mean +- SD | %zu seeds | %.3f +- %.3f\n", name.c_str(), seed_rhos.size(), m,
                  std::sqrt(v / (seed_rhos.size() - 1)));
    }
  }
  if (keep.empty()) std::filesystem::remove_all(dir);
  return 0;
}
