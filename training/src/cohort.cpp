#include "dentar/training/cohort.h"
#include "dentar/training/hand_script.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <unordered_map>

#include "dentar/haptics/engine.h"
#include "dentar/haptics/scripts.h"
#include "dentar/haptics/simulated_device.h"
#include "dentar/training/session.h"

namespace dentar::training {
namespace fs = std::filesystem;

SkillParams expert_skill() { return {}; }

SkillParams novice_skill(double s) {
  s = std::clamp(s, 0.0, 1.0);
  const SkillParams e = expert_skill();
  SkillParams full;
  full.tremor_mm = 0.12;
  full.force_factor = 1.8;
  full.force_jitter = 0.35;
  full.detour_mm = 1.5;
  full.pause_prob = 0.5;
  full.pause_s = 1.0;
  full.swap_prob = 0.3;
  full.tilt_deg = 10.0;
  full.sweep_mm_s = 2.0;
  full.outline_mm = 0.6;
  full.depth_mm = 0.6;
  full.skip_prob = 0.4;
  full.stop_prob = 0.7;
  auto lerp = [s](double a, double b) { return a + s * (b - a); };
  SkillParams n;
  n.tremor_mm = lerp(e.tremor_mm, full.tremor_mm);
  n.force_factor = lerp(e.force_factor, full.force_factor);
  n.force_jitter = lerp(e.force_jitter, full.force_jitter);
  n.detour_mm = lerp(e.detour_mm, full.detour_mm);
  n.pause_prob = lerp(e.pause_prob, full.pause_prob);
  n.pause_s = lerp(e.pause_s, full.pause_s);
  n.swap_prob = lerp(e.swap_prob, full.swap_prob);
  n.tilt_deg = lerp(e.tilt_deg, full.tilt_deg);
  n.sweep_mm_s = lerp(e.sweep_mm_s, full.sweep_mm_s);
  n.outline_mm = lerp(e.outline_mm, full.outline_mm);
  n.depth_mm = lerp(e.depth_mm, full.depth_mm);
  n.skip_prob = lerp(e.skip_prob, full.skip_prob);
  n.stop_prob = lerp(e.stop_prob, full.stop_prob);
  return n;
}

std::string CohortOptions::validate() const {
  if (experts < 0 || novices < 0 || intermediates < 0 || experts > 100 || novices > 100 || intermediates > 100 ||
      experts + novices + intermediates < 1)
    return "experts, intermediates and novices must be in [0, 100], at least one subject";
  if (!(style >= 0 && style <= 3)) return "style must be in [0, 3]";
  if (trials < 1 || trials > 50) return "trials must be in [1, 50]";
  if (!(separation >= 0 && separation <= 1)) return "separation must be in [0, 1]";
  if (!(voxel_mm >= 0.05 && voxel_mm <= 0.5)) return "voxel_mm must be in [0.05, 0.5]";
  if (bur_samples < 100 || bur_samples > 30000) return "bur_samples must be in [100, 30000]";
  return {};
}

StyleParams draw_style(double s, std::uint64_t seed) {
  StyleParams st;
  if (!(s > 0)) return st;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01(0, 1);
  std::uniform_real_distribution<double> u01(0, 1);
  // Spreads at strength 1 (log factors: SD; skill gap expert -> novice beside it):
  st.time_scale = std::exp(s * 0.6 * n01(rng));   // sweep speed gap log(3/2) = 0.41
  st.tremor_hz = 6.0 + 6.0 * u01(rng);             // no skill gap in frequency
  st.tremor_gain = std::exp(s * 0.5 * n01(rng));
  st.tremor_h2 = std::min(1.0, s * 0.5 * u01(rng));
  st.force_bias = std::exp(s * 0.8 * n01(rng));    // force gap log(1.8) = 0.59
  st.pause_gain = std::exp(s * 1.2 * n01(rng));    // pause length gap log(1.0/0.3) = 1.2
  for (int a = 0; a < 3; ++a) st.rest_offset_mm(a) = s * 3.0 * n01(rng);   // detour gap: 1.5 mm SD
  const double az = 6.283185307179586 * u01(rng);
  st.tilt_axis = Eigen::Vector3d(std::cos(az), std::sin(az), 0);
  st.tilt_bias_deg = s * 12.0 * n01(rng);          // tilt gap: SD 2 -> 10 deg
  for (int a = 0; a < 3; ++a) st.mirror_rest_mm(a) = s * 5.0 * n01(rng);
  return st;
}

int CohortTrial::true_step_at(double t) const {
  for (std::size_t i = 0; i < step_order.size(); ++i)
    if (t >= step_start_s[i] && t < step_end_s[i]) return step_order[i];
  return -1;
}

namespace {

// Subject-level variation: each factor times exp(0.2 N(0,1)), probabilities clamped.
SkillParams vary(SkillParams p, std::mt19937_64& rng) {
  std::normal_distribution<double> n(0, 0.2);
  auto f = [&] { return std::exp(n(rng)); };
  p.tremor_mm *= f();
  p.force_factor *= f();
  p.force_jitter *= f();
  p.detour_mm *= f();
  p.pause_prob = std::clamp(p.pause_prob * f(), 0.0, 1.0);
  p.pause_s *= f();
  p.swap_prob = std::clamp(p.swap_prob * f(), 0.0, 1.0);
  p.tilt_deg *= f();
  p.sweep_mm_s *= f();
  p.outline_mm *= f();
  p.depth_mm *= f();
  p.skip_prob = std::clamp(p.skip_prob * f(), 0.0, 1.0);
  p.stop_prob = std::clamp(p.stop_prob * f(), 0.0, 1.0);
  return p;
}

// Where each step works, in its own coordinates: h along the approach from
// the focus (m), u and v across it. `region`: every voxel of the step's target
// region (the outline the bur must stay inside); `cell`: the solid voxels of
// that region this step removes, those whose nearest focus (by the automatic
// step finder's own measure: off-axis distance, 0.3 x the distance still
// ahead) is this step's. Empty cell: the step plunges at its focus.
struct StepGeom {
  Eigen::Vector3d f = Eigen::Vector3d::Zero(), a = Eigen::Vector3d::UnitZ(), U = Eigen::Vector3d::UnitX(),
                  V = Eigen::Vector3d::UnitY();
  std::vector<Eigen::Vector3d> region, cell;  // (h, u, v)
  // Solid voxels outside every target, projected along the approach: per
  // column (u, v on kGrid, packed by column_key) the highest h. Where a column
  // has none the bur may overhang (air beside the tooth).
  std::unordered_map<std::int64_t, double> other_top;
  double voxel_m = 0;  // the tooth's voxel size: a region's face lies half a voxel past its outermost voxel centres
};

constexpr double kGrid = 0.2e-3;  // raster grid of the sweeps (m)
std::int64_t column_key(double u, double v) {
  return (static_cast<std::int64_t>(std::lround(u / kGrid)) << 32) ^
         static_cast<std::int64_t>(static_cast<std::uint32_t>(static_cast<std::int32_t>(std::lround(v / kGrid))));
}

std::vector<StepGeom> step_geometry(const Exercise& ex, const RegionMasks& m, const volume::VoxelVolume& start) {
  const std::vector<Eigen::Vector3d> focus = step_focus(ex, &m, &start);
  const std::size_t S = ex.steps.size();
  std::vector<StepGeom> g(S);
  std::vector<int> region_of(S, -1);
  for (std::size_t k = 0; k < S; ++k) {
    g[k].f = focus[k];
    g[k].voxel_m = start.spacing().minCoeff();
    g[k].a = ex.steps[k].approach.normalized();
    g[k].U = g[k].a.unitOrthogonal();
    g[k].V = g[k].a.cross(g[k].U);
    for (std::size_t r = 0; r < ex.regions.size(); ++r)
      if (ex.regions[r].name == ex.steps[k].region && ex.regions[r].role == RegionRole::kTarget) region_of[k] = static_cast<int>(r);
  }
  // The plan follows the solid voxels of `solid`/`shell` targets, as before
  // the masks took in the tooth's partial-volume skin (issue 25, session 11):
  // the generator's sessions are unchanged by that scoring fix.
  std::uint32_t skin_free = 0;
  for (std::size_t r = 0; r < ex.regions.size() && r < 32; ++r)
    for (const auto& pr : ex.regions[r].all)
      if (!pr.negate && (pr.kind == PrimitiveKind::kShell || pr.kind == PrimitiveKind::kSolid)) skin_free |= 1u << r;
  const auto d = m.dims;
  for (int kk = 0; kk < d.z(); ++kk)
    for (int j = 0; j < d.y(); ++j)
      for (int i = 0; i < d.x(); ++i) {
        const bool solid = start.density(i, j, kk) > volume::kIsoDensity;
        const std::uint32_t bits = m.bits[m.index(i, j, kk)] & (solid ? ~0u : ~skin_free);
        if (!(bits & m.target_bits)) {
          if (!solid) continue;
          const Eigen::Vector3d p = start.voxel_center(i, j, kk);
          for (std::size_t k = 0; k < S; ++k) {
            if (region_of[k] < 0) continue;
            const Eigen::Vector3d q = p - g[k].f;
            const double h = q.dot(g[k].a);
            auto [it, fresh] = g[k].other_top.emplace(column_key(q.dot(g[k].U), q.dot(g[k].V)), h);
            if (!fresh) it->second = std::max(it->second, h);
          }
          continue;
        }
        const Eigen::Vector3d p = start.voxel_center(i, j, kk);
        double best = 1e300;
        int arg = -1;
        for (std::size_t k = 0; k < S; ++k) {
          if (region_of[k] < 0) continue;
          g[k].region.emplace_back((p - g[k].f).dot(g[k].a), (p - g[k].f).dot(g[k].U), (p - g[k].f).dot(g[k].V));
          if (!(bits >> region_of[k] & 1u)) continue;
          const Eigen::Vector3d dd = g[k].f - p;
          const double ahead = dd.dot(-g[k].a);  // along the bur axis (-approach)
          const double w = ahead > 0 ? 0.3 : 1.0;
          const double c = (dd - ahead * -g[k].a).squaredNorm() + w * w * ahead * ahead;
          if (solid && c < best) {
            best = c;
            arg = static_cast<int>(k);
          }
        }
        if (arg >= 0) {
          const StepGeom& s = g[static_cast<std::size_t>(arg)];
          g[static_cast<std::size_t>(arg)].cell.emplace_back((p - s.f).dot(s.a), (p - s.f).dot(s.U), (p - s.f).dot(s.V));
        }
      }
  return g;
}

// One layer's sweep: raster rows (runs of neighbouring tip positions (h, u, v)).
using Rows = std::vector<std::vector<Eigen::Vector3d>>;

// Plans a step's sweep. The outline is every target voxel (all target
// regions, so the bur may overlap a neighbouring target but nothing else),
// projected along the approach: per column (u, v) the region's floor, the
// lowest h of a target voxel there. The tip may go down to that floor
// dilated by the tip radius (no point under the bur's end lies below its own
// column's floor, so a thin curved shell is followed, not cut through by a
// flat layer), and only where the outline eroded by the bur's radius (minus
// the outline error, > 0 wider) contains the tip. Layers dz apart from the
// top of the step's cell down to its bottom; in each, a boustrophedon raster
// of rows 0.4 mm apart where the cell still has material within 0.8 bur
// radii and the column is not finished; each tip at max(layer, floor) + the
// sink compensation - half a voxel - the depth error (> 0 deeper). `finish`,
// when given, receives the finishing pass along the walls (below; empty when
// the part touches no wall).
std::vector<Rows> plan_sweep(const StepGeom& g, const volume::BurParams& bur, double outline_err_m, double depth_err_m,
                             double skip_prob, double sink_m, std::mt19937_64& rng, Rows* finish) {
  if (finish) finish->clear();
  std::vector<Rows> layers;
  if (g.cell.empty()) return layers;
  std::uniform_real_distribution<double> u01(0, 1);
  const double grid = kGrid, dz = 0.5e-3;
  double hmax = -1e9, hmin = 1e9, umin = 1e9, umax = -1e9, vmin = 1e9, vmax = -1e9;
  for (const auto& c : g.cell) {
    hmax = std::max(hmax, c.x());
    hmin = std::min(hmin, c.x());
  }
  // The bur's end radius, and its radius as deep into the tooth as this step
  // cuts (a cone widens from its end: 0.4 mm at the end, 0.43 mm 1 mm up).
  double tip_radius_m = bur.radius_m, erode_radius_m = bur.radius_m;
  if (bur.shape == volume::BurShape::kCone) {
    tip_radius_m = bur.tip_radius_m;
    const double up = std::clamp(hmax - hmin + dz, 0.0, bur.length_m);
    erode_radius_m = bur.tip_radius_m + (bur.radius_m - bur.tip_radius_m) * up / bur.length_m;
  }
  for (const auto& c : g.region) {
    umin = std::min(umin, c.y());
    umax = std::max(umax, c.y());
    vmin = std::min(vmin, c.z());
    vmax = std::max(vmax, c.z());
  }
  // Grid on kGrid (so other_top's columns line up), padded by 1 mm for the erosion.
  umin = (std::round(umin / grid) - 5) * grid;
  vmin = (std::round(vmin / grid) - 5) * grid;
  umax += 5 * grid;
  vmax += 5 * grid;
  const int nu = static_cast<int>((umax - umin) / grid) + 1, nv = static_cast<int>((vmax - vmin) / grid) + 1;
  if (nu <= 0 || nv <= 0 || nu > 400 || nv > 400) return layers;
  const auto N = static_cast<std::size_t>(nu * nv);
  auto cu = [&](double x) { return std::clamp(static_cast<int>(std::lround((x - umin) / grid)), 0, nu - 1); };
  auto cv = [&](double x) { return std::clamp(static_cast<int>(std::lround((x - vmin) / grid)), 0, nv - 1); };
  auto at = [&](int i, int j) { return static_cast<std::size_t>(j * nu + i); };
  constexpr double kNone = 1e9;
  std::vector<double> floor(N, kNone);
  for (const auto& c : g.region) {
    double& f = floor[at(cu(c.y()), cv(c.z()))];
    f = std::min(f, c.x());
  }
  {  // Columns the voxel lattice left empty (grid finer than the voxels, oblique approach): from both neighbours.
    std::vector<double> filled = floor;
    for (int j = 0; j < nv; ++j)
      for (int i = 0; i < nu; ++i) {
        if (floor[at(i, j)] < kNone) continue;
        double best = kNone;
        if (i > 0 && i + 1 < nu && floor[at(i - 1, j)] < kNone && floor[at(i + 1, j)] < kNone)
          best = std::max(floor[at(i - 1, j)], floor[at(i + 1, j)]);
        if (j > 0 && j + 1 < nv && floor[at(i, j - 1)] < kNone && floor[at(i, j + 1)] < kNone)
          best = std::min(best, std::max(floor[at(i, j - 1)], floor[at(i, j + 1)]));
        filled[at(i, j)] = best;
      }
    floor.swap(filled);
  }
  // The tip may reach each column's floor dilated by its radius.
  std::vector<double> tip_floor(N, kNone);
  const int tr = static_cast<int>(std::ceil(tip_radius_m / grid));
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      if (floor[at(i, j)] >= kNone) continue;
      double f = -kNone;
      for (int dj = -tr; dj <= tr; ++dj)
        for (int di = -tr; di <= tr; ++di) {
          const int x = i + di, y = j + dj;
          if ((di * di + dj * dj) * grid * grid > tip_radius_m * tip_radius_m + 1e-12) continue;
          if (x < 0 || y < 0 || x >= nu || y >= nv || floor[at(x, y)] >= kNone) continue;
          f = std::max(f, floor[at(x, y)]);
        }
      tip_floor[at(i, j)] = f;
    }
  // Where the tip may go: the outline eroded by the bur's radius, against
  // columns with material outside the targets within the bur's reach
  // (columns of air beside the tooth the bur may overhang).
  std::vector<std::uint8_t> blocked(N, 0);
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      if (floor[at(i, j)] < kNone) continue;
      const auto it = g.other_top.find(column_key(umin + i * grid, vmin + j * grid));
      blocked[at(i, j)] = i == 0 || j == 0 || i + 1 == nu || j + 1 == nv ||
                          (it != g.other_top.end() && it->second > hmin - 1e-3);
    }
  const double erode = std::max(0.0, erode_radius_m - outline_err_m);
  const int er = static_cast<int>(std::ceil(erode / grid));
  std::vector<std::uint8_t> inside(N, 0);
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      if (floor[at(i, j)] >= kNone) continue;
      bool in = true;
      for (int dj = -er; dj <= er && in; ++dj)
        for (int di = -er; di <= er && in; ++di) {
          if ((di * di + dj * dj) * grid * grid > erode * erode + 1e-12) continue;
          const int x = i + di, y = j + dj;
          in = x >= 0 && y >= 0 && x < nu && y < nv && !blocked[at(x, y)];
        }
      inside[at(i, j)] = in;
    }
  const int reach = static_cast<int>(std::ceil(0.8 * erode_radius_m / grid));
  // The tip is aimed this far above its column's floor (the lowest target voxel centre): the
  // bur's sink, less half a voxel to the region's face, less the depth error.
  const double shift = sink_m - 0.5 * g.voxel_m - depth_err_m;
  std::vector<double> heights;
  for (double h = hmax - dz; h > hmin + shift; h -= dz) heights.push_back(h);
  heights.push_back(hmin + shift);
  bool reverse = false;
  // Per column: the lowest tip height any layer planned there (kNone: never worked).
  std::vector<double> lowest(N, kNone);
  for (std::size_t L = 0; L < heights.size(); ++L) {
    const double hL = heights[L];
    std::vector<std::uint8_t> need(N, 0), work(N, 0);
    for (const auto& c : g.cell)
      if (c.x() >= hL - 0.5 * dz) {
        const int i0 = cu(c.y()), j0 = cv(c.z());
        for (int dj = -reach; dj <= reach; ++dj)
          for (int di = -reach; di <= reach; ++di) {
            const int i = i0 + di, j = j0 + dj;
            if (i < 0 || j < 0 || i >= nu || j >= nv || di * di + dj * dj > reach * reach) continue;
            need[at(i, j)] = 1;
          }
      }
    for (std::size_t q = 0; q < N; ++q)
      // A column whose floor lies above the previous layer was finished there.
      work[q] = need[q] && inside[q] && (L == 0 || tip_floor[q] + shift < heights[L - 1]);
    for (std::size_t q = 0; q < N; ++q)
      if (work[q]) lowest[q] = std::min(lowest[q], std::max(hL, tip_floor[q] + shift));
    Rows rows;
    int last_row = -100;
    for (int j = 0; j < nv; ++j) {
      bool any = false;
      for (int i = 0; i < nu && !any; ++i) any = work[at(i, j)];
      if (!any) continue;
      bool next_any = false;  // the outermost row of the outline is always swept
      if (j + 1 < nv)
        for (int i = 0; i < nu && !next_any; ++i) next_any = work[at(i, j + 1)];
      if (j - last_row < 2 && next_any) continue;
      last_row = j;
      if (u01(rng) < skip_prob) continue;
      std::vector<std::vector<Eigen::Vector3d>> runs;  // contiguous pieces of the row
      for (int i = 0; i < nu; ++i) {
        if (!work[at(i, j)]) continue;
        if (i == 0 || !work[at(i - 1, j)]) runs.emplace_back();
        runs.back().emplace_back(std::max(hL, tip_floor[at(i, j)] + shift), umin + i * grid, vmin + j * grid);
      }
      if (reverse) {
        std::reverse(runs.begin(), runs.end());
        for (auto& r : runs) std::reverse(r.begin(), r.end());
      }
      reverse = !reverse;
      for (auto& r : runs) rows.push_back(std::move(r));
    }
    if (!rows.empty()) layers.push_back(std::move(rows));
  }
  // The finishing pass along the outline's walls (generator v5): the tip follows the edge of the
  // columns this step worked where the outline, not air, stops it (a wall lies within the bur's
  // radius), at each column's lowest planned height, so the bur's side planes the walls down to
  // the floor. The raster reaches a wall across its rows only at their ends (a row every 0.4 mm
  // leaves scallops there); an operator finishes a preparation by running the bur along its
  // outline.
  if (finish && !layers.empty()) {
    const int wr = static_cast<int>(std::ceil((erode + 1.5 * grid) / grid));
    std::vector<std::pair<double, Eigen::Vector3d>> edge;  // (angle, (h, u, v))
    double cu0 = 0, cv0 = 0;
    int n = 0;
    for (int j = 0; j < nv; ++j)
      for (int i = 0; i < nu; ++i)
        if (lowest[at(i, j)] < kNone) cu0 += i, cv0 += j, ++n;
    if (n > 0) {
      cu0 /= n;
      cv0 /= n;
    }
    for (int j = 0; j < nv; ++j)
      for (int i = 0; i < nu; ++i) {
        const std::size_t q = at(i, j);
        if (lowest[q] >= kNone) continue;
        bool rim = false;  // a neighbour the tip may not enter
        const int nb[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
        for (const auto& o : nb) {
          const int x = i + o[0], y = j + o[1];
          rim |= x < 0 || y < 0 || x >= nu || y >= nv || !inside[at(x, y)];
        }
        if (!rim) continue;
        bool wall = false;  // the outline (material outside the targets) within the bur's reach
        for (int dj = -wr; dj <= wr && !wall; ++dj)
          for (int di = -wr; di <= wr && !wall; ++di) {
            const int x = i + di, y = j + dj;
            if (di * di + dj * dj > wr * wr || x < 0 || y < 0 || x >= nu || y >= nv) continue;
            wall = blocked[at(x, y)] != 0;
          }
        if (!wall) continue;
        edge.emplace_back(std::atan2(j - cv0, i - cu0), Eigen::Vector3d(lowest[q], umin + i * grid, vmin + j * grid));
      }
    if (!edge.empty()) {
      std::sort(edge.begin(), edge.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
      // Start after the widest angular gap, so a wall that is not closed (a step's part of the
      // outline) is followed from one end to the other.
      std::size_t start = 0;
      double widest = -1;
      for (std::size_t e = 0; e < edge.size(); ++e) {
        const double next = e + 1 < edge.size() ? edge[e + 1].first : edge.front().first + 2 * M_PI;
        if (next - edge[e].first > widest) widest = next - edge[e].first, start = (e + 1) % edge.size();
      }
      std::vector<Eigen::Vector3d> run;
      for (std::size_t e = 0; e < edge.size(); ++e) {
        const Eigen::Vector3d& p = edge[(start + e) % edge.size()].second;
        // A jump along the edge (another wall's part) starts a new run, reached with the bur lifted.
        if (!run.empty() && (p.tail<2>() - run.back().tail<2>()).norm() > 0.45e-3) {
          finish->push_back(std::move(run));
          run.clear();
        }
        run.push_back(p);
      }
      if (!run.empty()) finish->push_back(std::move(run));
    }
  }
  return layers;
}

struct Script {
  std::vector<haptics::TipWaypoint> tips;
  std::vector<double> force_N;  // per tip: the force the hand means to press with (0: not pressing)
  std::vector<int> order;
  std::vector<double> start, end;
};

Script make_script(const Exercise& ex, const SkillParams& p, std::mt19937_64& rng, const std::vector<StepGeom>* geom,
                   const StyleParams& style) {
  std::normal_distribution<double> n01(0, 1);
  std::uniform_real_distribution<double> u01(0, 1);
  Script sc;
  std::vector<int> order(ex.steps.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  for (std::size_t i = 0; i + 1 < order.size(); ++i)
    if (u01(rng) < p.swap_prob) std::swap(order[i], order[i + 1]);
  const double z_top = 7.5e-3;
  const Eigen::Vector3d down(0, 0, -1);
  double t = 0;
  double tremor_hz = 9.0 + 2.0 * u01(rng);
  const double phase = 6.28 * u01(rng);
  // A person's tremor band: their centre frequency +- 0.5 Hz from trial to trial.
  if (style.tremor_hz > 0) tremor_hz = style.tremor_hz + (tremor_hz - 10.0) * 0.5;
  const double h2 = style.tremor_h2;
  auto tremor = [&](double tt) {
    const double a = p.tremor_mm * 1e-3;
    const double w = 2 * M_PI * tremor_hz * tt;
    return Eigen::Vector3d(a * (std::sin(w + phase) + h2 * std::sin(2 * w + 0.7 * phase)) + 0.3 * a * n01(rng),
                           a * (std::cos(w + 1.3 * phase) + h2 * std::cos(2 * w + 0.4 * phase)) + 0.3 * a * n01(rng), 0);
  };
  // The tool-orientation habit: a constant rotation of every planned axis.
  const Eigen::Matrix3d habit =
      Eigen::AngleAxisd(style.tilt_bias_deg * M_PI / 180.0, style.tilt_axis.normalized()).toRotationMatrix();
  const Eigen::Vector3d rest = style.rest_offset_mm * 1e-3;
  // pos and axis by value: callers pass elements of sc.tips, which push_back moves.
  auto add = [&](double dt, Eigen::Vector3d pos, Eigen::Vector3d axis, bool pedal, double force_N = 0.0) {
    dt *= style.time_scale;
    // Dense waypoints (10 ms) so the tremor acts on the whole path.
    const Eigen::Vector3d from = sc.tips.empty() ? pos : sc.tips.back().tip_tooth_m;
    const Eigen::Vector3d afrom = sc.tips.empty() ? axis : sc.tips.back().axis_tooth;
    const int n = std::max(1, static_cast<int>(dt / 0.01));
    for (int i = 1; i <= n; ++i) {
      const double f = static_cast<double>(i) / n;
      const double tt = t + f * dt;
      sc.tips.push_back({tt, from + f * (pos - from) + tremor(tt), (afrom + f * (axis - afrom)).normalized(), pedal});
      sc.force_N.push_back(force_N);
    }
    t += dt;
  };
  sc.tips.push_back({0.0, Eigen::Vector3d(0, 0, 9e-3) + rest, down, false});
  sc.force_N.push_back(0.0);
  t = 0.0;
  const std::vector<Eigen::Vector3d> focus = step_focus(ex, nullptr, nullptr);
  for (int s : order) {
    const Eigen::Vector3d f = focus[static_cast<std::size_t>(s)];
    const Eigen::Vector3d app = ex.steps[static_cast<std::size_t>(s)].approach;
    // Retract point: 5.5 mm from the focus along the approach direction, and
    // at least 1.5 mm clear above the occlusal level when approaching from +z.
    Eigen::Vector3d retract = f + 5.5e-3 * app;
    if (app.z() > 0.9) retract.z() = std::max(retract.z(), z_top);
    retract += rest;
    const double start = t;
    if (u01(rng) < p.pause_prob)
      add(p.pause_s * style.pause_gain, sc.tips.back().tip_tooth_m, sc.tips.back().axis_tooth, false);
    if (p.detour_mm > 0) {
      const Eigen::Vector3d d(p.detour_mm * 1e-3 * n01(rng), p.detour_mm * 1e-3 * n01(rng), p.detour_mm * 1e-3 * n01(rng));
      add(0.3, retract + d - (d.dot(app)) * app, habit * -app, false);
    }
    // Tilt: a random direction perpendicular to the planned axis.
    const double tilt = p.tilt_deg * M_PI / 180.0 * n01(rng);
    Eigen::Vector3d perp = app.unitOrthogonal();
    perp = Eigen::AngleAxisd(6.28 * u01(rng), app) * perp;
    const Eigen::Vector3d axis = (habit * (-app * std::cos(tilt) + perp * std::sin(tilt))).normalized();
    add(0.3, retract, axis, true);
    const double force = 1.0 * p.force_factor * style.force_bias * std::max(0.2, 1.0 + p.force_jitter * n01(rng));
    // The hand with a finger rest (3000 N/m) in series with the proxy coupling
    // (0.8 x 2000 N/m): a target this far past the surface asks for `force`.
    const double lead = force / haptics::kFingerRestStiffness_N_per_m + force / 1600.0;
    const StepGeom* sg = geom && static_cast<std::size_t>(s) < geom->size() ? &(*geom)[static_cast<std::size_t>(s)] : nullptr;
    std::vector<Rows> layers;
    // The hand aims `over` past each layer; the bur sinks on until the force
    // falls under the cutter's 0.05 N threshold (the hand and coupling in
    // series: 1 / (1/3000 + 1/1600) = 1043 N/m). The expert plans for the sink
    // of the nominal 1 N, not for the trial's own force (novices press harder).
    // The whole static sink (0.30 mm) since generator v5: the finishing pass along the walls
    // dwells at the floor, and a bur that stays sinks the whole of it. (v4 aimed half of it,
    // tuned on the incisor's labial enamel without a finishing pass; its experts then cut
    // 0.1-0.2 mm past the floor: docs/BENCHMARKS.md, "Issue 25 session 16".)
    const double over = 0.35e-3 * force;
    const double sink = std::max(0.0, 0.35e-3 - 0.05 / 1043.0);
    Rows finish;
    if (sg) layers = plan_sweep(*sg, ex.bur, p.outline_mm * 1e-3 * n01(rng), p.depth_mm * 1e-3 * n01(rng),
                                p.skip_prob, sink, rng, &finish);
    // Stopping early: the step's deeper layers are never reached, nor its walls finished.
    if (layers.size() > 1 && u01(rng) < p.stop_prob)
      layers.resize(std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(layers.size() * (0.3 + 0.5 * u01(rng))))));
    else if (!finish.empty())
      layers.push_back(std::move(finish));
    if (layers.empty()) {
      // No target voxels for this step (or no geometry): press toward the
      // focus with small circles (0.3 mm, 4 Hz) for 2.5 s.
      const double work_s = 2.5;
      const int n = std::max(2, static_cast<int>(work_s / 0.05));
      const Eigen::Vector3d top = f + std::min(3.5e-3, (retract - f).norm()) * app;
      const Eigen::Vector3d u = app.unitOrthogonal(), v = app.cross(u);
      add(0.2, top, axis, true);
      for (int i = 1; i <= n; ++i) {
        const double fr = static_cast<double>(i) / n;
        const double a = 2 * M_PI * 4.0 * fr * work_s;
        const Eigen::Vector3d c = top + fr * (f - top) + 0.3e-3 * (std::cos(a) * u + std::sin(a) * v) + lead * axis;
        add(work_s / n, c, axis, true, force);
      }
    } else {
      // Sweep the step's part of the target layer by layer; the hand aims
      // `over` past each layer along the bur axis, so it presses with about
      // `force` while material is left and the bur slows as it reaches the layer.
      const double speed = std::max(0.2, p.sweep_mm_s) * 1e-3;
      auto at = [&](const Eigen::Vector3d& huv) { return Eigen::Vector3d(sg->f + huv.x() * sg->a + huv.y() * sg->U + huv.z() * sg->V); };
      Eigen::Vector3d cur = sc.tips.back().tip_tooth_m;
      auto go = [&](const Eigen::Vector3d& target, bool press) {
        const Eigen::Vector3d dst = target + (press ? over : 0.0) * axis;
        const double dist = (dst - cur).norm();
        add(std::max(0.02, dist / speed), dst, axis, true, press ? force : 0.0);
        cur = dst;
      };
      const Eigen::Vector3d first = at(layers.front().front().front());
      go(first + 1.0e-3 * app, false);
      Eigen::Vector3d last = first;
      for (const Rows& rows : layers)
        for (const auto& row : rows) {
          const Eigen::Vector3d a0 = at(row.front());
          // The next row 0.4 mm on is reached in the material; a farther
          // start (a gap in the outline, the next layer) with the bur lifted.
          const Eigen::Vector3d jump = a0 - last;
          if ((jump - jump.dot(app) * app).norm() > 0.5e-3) {
            go(last + 1.0e-3 * app, false);
            go(a0 + 1.0e-3 * app, false);
          }
          go(a0, true);
          // Every tip position (0.2 mm apart; each column has its own floor):
          // the dense interpolation of add() does the rest.
          for (std::size_t q = 1; q < row.size(); ++q) go(at(row[q]), true);
          last = at(row.back());
        }
    }
    add(0.3, retract, habit * -app, false);
    sc.order.push_back(s);
    sc.start.push_back(start);
    sc.end.push_back(t);
  }
  add(0.2, Eigen::Vector3d(0, 0, 9e-3) + rest, down, false);
  return sc;
}

// The bur's hand and the mirror's hand as a 100 Hz table: the script's tip
// targets (resampled), a first-order hand lag of 30 ms, 5 um of measurement
// noise; the force the hand means to press with, along the bur axis, with 5 %
// noise per frame; the mirror held at the person's rest posture near the
// tooth, drifting slowly (skill: the novice's hand wanders 5x more) with the
// person's tremor.
Status write_kinematics(const Script& sc, const StyleParams& style, const SkillParams& p, std::mt19937_64& rng,
                        const std::string& path) {
  std::ofstream f(path);
  if (!f) return Error{"cannot write " + path};
  std::normal_distribution<double> n01(0, 1);
  const double rate = 100.0, T = sc.tips.back().time_s;
  const double tremor_hz = style.tremor_hz > 0 ? style.tremor_hz : 10.0;
  // The mirror's drift: 0.3 mm (expert) to 1.5 mm (novice at separation 1), from the skill's tremor amplitude.
  const double drift_mm = 0.3 + 12.0 * std::max(0.0, p.tremor_mm / std::max(1e-9, style.tremor_gain) - 0.02);
  const Eigen::Vector3d mirror0 = Eigen::Vector3d(-8.0, 6.0, 6.0) + style.mirror_rest_mm;
  f << "t_s,tip_x_mm,tip_y_mm,tip_z_mm,axis_x,axis_y,axis_z,force_x_N,force_y_N,force_z_N,pedal,"
       "mirror_x_mm,mirror_y_mm,mirror_z_mm\n";
  f.setf(std::ios::fixed);
  f.precision(4);
  std::size_t k = 0;
  Eigen::Vector3d hand = sc.tips.front().tip_tooth_m * 1e3, drift = Eigen::Vector3d::Zero();
  const double lag = 1.0 - std::exp(-1.0 / (rate * 0.030));
  const double phase = 6.28 * std::uniform_real_distribution<double>(0, 1)(rng);
  for (int i = 0; i * (1.0 / rate) <= T; ++i) {
    const double t = i / rate;
    while (k + 1 < sc.tips.size() && sc.tips[k + 1].time_s <= t) ++k;
    const auto& a = sc.tips[k];
    const auto& b = sc.tips[std::min(k + 1, sc.tips.size() - 1)];
    const double w = b.time_s > a.time_s ? std::clamp((t - a.time_s) / (b.time_s - a.time_s), 0.0, 1.0) : 0.0;
    const Eigen::Vector3d target = (a.tip_tooth_m + w * (b.tip_tooth_m - a.tip_tooth_m)) * 1e3;
    const Eigen::Vector3d axis = (a.axis_tooth + w * (b.axis_tooth - a.axis_tooth)).normalized();
    hand += lag * (target - hand);
    const double F = sc.force_N[k] * (1.0 + 0.05 * n01(rng));
    const Eigen::Vector3d force = sc.force_N[k] > 0 ? Eigen::Vector3d(F * axis) : Eigen::Vector3d::Zero();
    // Drift: an Ornstein-Uhlenbeck walk (time constant 2 s) whose SD is drift_mm.
    for (int c = 0; c < 3; ++c) drift(c) += -drift(c) * (1.0 / rate) / 2.0 + drift_mm * std::sqrt(2.0 / rate / 2.0) * n01(rng);
    const double tw = 2 * M_PI * tremor_hz * t;
    const Eigen::Vector3d tremor = 1e3 * p.tremor_mm * 0.5 *
        Eigen::Vector3d(std::sin(tw + phase) + style.tremor_h2 * std::sin(2 * tw), std::cos(tw + 0.5 * phase), 0);
    const Eigen::Vector3d mirror = mirror0 + drift + tremor;
    const Eigen::Vector3d meas = hand + 0.005 * Eigen::Vector3d(n01(rng), n01(rng), n01(rng));
    f << t << ',' << meas.x() << ',' << meas.y() << ',' << meas.z() << ',' << axis.x() << ',' << axis.y() << ','
      << axis.z() << ',' << force.x() << ',' << force.y() << ',' << force.z() << ',' << (a.pedal ? 1 : 0) << ','
      << mirror.x() << ',' << mirror.y() << ',' << mirror.z() << '\n';
  }
  if (!f) return Error{"write failed: " + path};
  return {};
}

}  // namespace

std::string kinematics_column_map_json() {
  return R"({"time": "t_s", "pedal": "pedal",
 "tools": [{"name": "bur", "position": ["tip_x_mm", "tip_y_mm", "tip_z_mm"], "axis": ["axis_x", "axis_y", "axis_z"],
            "force": ["force_x_N", "force_y_N", "force_z_N"]},
           {"name": "mirror", "position": ["mirror_x_mm", "mirror_y_mm", "mirror_z_mm"]}]})";
}

Result<std::vector<CohortTrial>> generate_cohort(const Exercise& ex, const CohortOptions& opt, const std::string& out_dir) {
  if (std::string why = opt.validate(); !why.empty()) return Error{"cohort: " + why};
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) return Error{"cohort: cannot create '" + out_dir + "': " + ec.message()};
  auto tj = nlohmann::json::parse(ex.tooth_json);
  tj["voxel_mm"] = opt.voxel_mm;
  auto tooth0 = make_tooth(tj.dump());
  if (!tooth0) return Error{"cohort: " + tooth0.error()};
  auto bur = volume::sample_bur(ex.bur, opt.bur_samples);
  if (!bur) return Error{"cohort: " + bur.error()};
  auto masks = build_masks(ex, *tooth0);
  if (!masks) return Error{"cohort: " + masks.error()};
  const std::vector<StepGeom> geom = step_geometry(ex, *masks, *tooth0);
  const haptics::Station station = haptics::default_station();
  std::vector<CohortTrial> out;
  std::ofstream csv(out_dir + "/trials.csv");
  if (!csv) return Error{"cohort: cannot write " + out_dir + "/trials.csv"};
  csv << "file,subject,trial,label\n";
  std::mt19937_64 rng(opt.seed);
  const int n_subjects = opt.experts + opt.intermediates + opt.novices;
  if (opt.kinematics_only) {
    std::ofstream(out_dir + "/columns.json") << kinematics_column_map_json() << "\n";
    if (!fs::exists(out_dir + "/columns.json")) return Error{"cohort: cannot write " + out_dir + "/columns.json"};
  }
  for (int sub = 0; sub < n_subjects; ++sub) {
    const bool expert = sub < opt.experts;
    const bool inter = !expert && sub < opt.experts + opt.intermediates;
    const std::string subject = expert  ? "E" + std::to_string(sub + 1)
                                : inter ? "I" + std::to_string(sub - opt.experts + 1)
                                        : "N" + std::to_string(sub - opt.experts - opt.intermediates + 1);
    const std::string label = expert ? "expert" : inter ? "intermediate" : "novice";
    SkillParams base = vary(expert ? expert_skill() : novice_skill(inter ? 0.5 * opt.separation : opt.separation), rng);
    // The style has its own random stream, so style 0 leaves the sessions of earlier versions unchanged.
    const StyleParams style = draw_style(opt.style, opt.seed * 1000003ull + static_cast<std::uint64_t>(sub) * 7919ull + 11ull);
    base.tremor_mm *= style.tremor_gain;
    for (int tr = 1; tr <= opt.trials; ++tr) {
      const Script sc = make_script(ex, base, rng, &geom, style);
      const std::string rel = subject + "_t" + std::to_string(tr);
      // What the cohort lists for this trial, whichever file (kinematics or session log) holds it.
      auto trial_of = [&](const std::string& path) {
        CohortTrial ct;
        ct.subject = subject;
        ct.label = label;
        ct.trial = tr;
        ct.session_path = path;
        ct.step_order = sc.order;
        ct.step_start_s = sc.start;
        ct.step_end_s = sc.end;
        return ct;
      };
      if (opt.kinematics_only) {
        fs::create_directories(out_dir + "/" + rel, ec);
        const std::string path = out_dir + "/" + rel + "/kinematics.csv";
        if (Status st = write_kinematics(sc, style, base, rng, path); !st) return Error{"cohort: " + st.error()};
        CohortTrial ct = trial_of(path);
        csv << rel << "/kinematics.csv," << subject << "," << tr << "," << label << "\n";
        out.push_back(std::move(ct));
        continue;
      }
      volume::VoxelVolume vol = tooth0->clone();
      haptics::HandParams hand;
      hand.stiffness_N_per_m = haptics::kFingerRestStiffness_N_per_m;  // finger rest on the neighbouring teeth
      auto dev = haptics::SimulatedDevice::create(haptics::to_hand_script(sc.tips, station), haptics::DeviceLimits{}, hand);
      if (!dev) return Error{"cohort: " + dev.error()};
      haptics::EngineConfig cfg;
      cfg.T_tooth_dev = station.T_tooth_dev;
      cfg.T_sty_tip = station.T_sty_tip;
      cfg.try_realtime = false;
      cfg.cut.sample_jitter = opt.sample_jitter;
      if (opt.overlap_cut) haptics::use_overlap_cut(cfg);
      std::string header;
      {
        auto probe = haptics::Engine::create(cfg, **dev, vol, *bur, nullptr);
        if (!probe) return Error{"cohort: " + probe.error()};
        header = (*probe)->header_json(tj.dump());
      }
      fs::create_directories(out_dir + "/" + rel, ec);
      const std::string path = out_dir + "/" + rel + "/session.dlog";
      haptics::LogWriterOptions lo;
      lo.fsync = false;
      lo.ring_capacity = 1 << 18;
      // Blocks of a fixed record count: the same seed gives the same bytes (cut by
      // wall time, two runs wrote the same records in differently sized blocks).
      lo.block_records = 4096;
      auto log = haptics::SessionLogWriter::open(path, header, lo);
      if (!log) return Error{"cohort: " + log.error()};
      auto eng = haptics::Engine::create(cfg, **dev, vol, *bur, log->get());
      if (!eng) return Error{"cohort: " + eng.error()};
      const auto steps = static_cast<std::uint64_t>((*dev)->script_end_s() * 1000.0);
      for (std::uint64_t done = 0; done < steps; done += 1000) (*eng)->run_steps(std::min<std::uint64_t>(1000, steps - done));
      if (Status st = (*log)->close(); !st) return Error{"cohort: " + st.error()};
      // The engine runs faster than real time here; a record the writer refused
      // would make the session depend on the machine's load, so it is an error.
      if (const std::uint64_t lost = (*log)->dropped(); lost > 0)
        return Error{"cohort: " + path + ": the session log writer dropped " + std::to_string(lost) +
                     " of " + std::to_string(steps) + " records (ring full: the machine too loaded?); run again"};
      CohortTrial ct = trial_of(path);
      nlohmann::json sj = {{"subject", subject}, {"trial", tr}, {"label", ct.label}, {"step_order", sc.order},
                           {"step_start_s", sc.start}, {"step_end_s", sc.end}};
      std::ofstream(out_dir + "/" + rel + "/steps.json") << sj.dump(1) << "\n";
      csv << rel << "/session.dlog," << subject << "," << tr << "," << ct.label << "\n";
      if (opt.on_session) opt.on_session(ct, vol);
      out.push_back(std::move(ct));
    }
  }
  return out;
}

Result<std::vector<CohortTrial>> read_cohort(const std::string& dir) {
  const std::string path = dir + "/trials.csv";
  std::ifstream f(path);
  if (!f) return Error{path + ": cannot open (a cohort folder needs trials.csv: file,subject,trial,label)"};
  std::string line;
  std::vector<CohortTrial> out;
  int ln = 0;
  while (std::getline(f, line)) {
    ++ln;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (ln == 1 || line.empty()) continue;
    std::vector<std::string> c;
    std::stringstream ss(line);
    for (std::string x; std::getline(ss, x, ',');) c.push_back(x);
    if (c.size() != 4)
      return Error{path + ": line " + std::to_string(ln) + ": " + std::to_string(c.size()) +
                   " columns, expected 4 (file,subject,trial,label)"};
    CohortTrial t;
    t.session_path = (fs::path(dir) / c[0]).string();
    t.subject = c[1];
    try {
      t.trial = std::stoi(c[2]);
    } catch (...) {
      return Error{path + ": line " + std::to_string(ln) + ", column 3 (trial): '" + c[2] + "' is not an integer"};
    }
    t.label = c[3];
    const fs::path sj = fs::path(t.session_path).parent_path() / "steps.json";
    if (fs::exists(sj)) {
      std::ifstream g(sj);
      auto j = nlohmann::json::parse(g, nullptr, false);
      if (!j.is_discarded() && j.contains("step_order")) {
        t.step_order = j["step_order"].get<std::vector<int>>();
        t.step_start_s = j["step_start_s"].get<std::vector<double>>();
        t.step_end_s = j["step_end_s"].get<std::vector<double>>();
      }
    }
    out.push_back(std::move(t));
  }
  if (out.empty()) return Error{path + ": no trial listed"};
  return out;
}

Result<std::vector<haptics::TipWaypoint>> expert_tip_script(const Exercise& ex, const volume::VoxelVolume& start,
                                                            std::uint64_t seed) {
  auto masks = build_masks(ex, start);
  if (!masks) return Error{"hand script for " + ex.name + ": " + masks.error()};
  const std::vector<StepGeom> geom = step_geometry(ex, *masks, start);
  std::mt19937_64 rng(seed);
  return make_script(ex, expert_skill(), rng, &geom, StyleParams{}).tips;
}

std::string HandOptions::validate() const {
  if (!(skill >= 0 && skill <= 1)) return "hand skill = " + std::to_string(skill) + " must be in [0, 1] (1 = expert)";
  if (!(style >= 0 && style <= 3)) return "hand style = " + std::to_string(style) + " must be in [0, 3] (0 = none)";
  return {};
}

Result<std::vector<haptics::TipWaypoint>> hand_tip_script(const Exercise& ex, const volume::VoxelVolume& start,
                                                          const HandOptions& o) {
  if (auto v = o.validate(); !v.empty()) return Error{"hand script for " + ex.name + ": " + v};
  if (o.skill >= 1.0 && !(o.style > 0)) return expert_tip_script(ex, start, o.seed);
  auto masks = build_masks(ex, start);
  if (!masks) return Error{"hand script for " + ex.name + ": " + masks.error()};
  const std::vector<StepGeom> geom = step_geometry(ex, *masks, start);
  std::mt19937_64 rng(o.seed);
  // As generate_cohort draws a subject: the skill varied per person, the style on its own stream.
  SkillParams p = vary(o.skill >= 1.0 ? expert_skill() : novice_skill(1.0 - o.skill), rng);
  const StyleParams style = draw_style(o.style, o.seed * 1000003ull + 11ull);
  p.tremor_mm *= style.tremor_gain;
  return make_script(ex, p, rng, &geom, style).tips;
}

}  // namespace dentar::training
