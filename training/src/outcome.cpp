#include "dentar/training/outcome.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include <Eigen/Geometry>

namespace dentar::training {
namespace {

using volume::kIsoDensity;

// Issue 25, session 19: a formed access wall earns its points in full from this share of its span.
constexpr double kFullShare = 0.9;
// ... and the pulpal floor its points in full from this share of the floor reached (below).
constexpr double kFloorFullReach = 0.9;
// The floor's integrity reaches 0 at this much dentin removed below the floor level (mm3).
constexpr double kFloorZeroMm3 = 1.0;
// Issue 25, session 20: the straight-line access criterion (continuous access points). Each file
// path starts on a disk of this radius around the orifice (an ISO size 40 file's 0.40 mm tip)...
constexpr double kFileRadius = 0.2e-3;
// ... and the paths' share clear, and the chamber's roof removed, each earn in full from 90 %.
constexpr double kStraightFull = 0.9;
constexpr double kRoofFull = 0.9;

bool open_at(const volume::VoxelVolume& v, const Eigen::Vector3d& p) {
  const Eigen::Vector3d q = (p - v.origin()).cwiseQuotient(v.spacing());
  const int i = static_cast<int>(std::lround(q.x())), j = static_cast<int>(std::lround(q.y())),
            k = static_cast<int>(std::lround(q.z()));
  return v.density(i, j, k) < kIsoDensity;  // outside the volume reads as air
}

std::string fmt(double x, int prec = 2) {
  std::ostringstream os;
  os.setf(std::ios::fixed);
  os.precision(prec);
  os << x;
  std::string r = os.str();
  // A value that rounds to zero prints as 0, not -0.0 (a wall at -0.04 deg read "-0.0 deg").
  if (r.size() > 1 && r[0] == '-' && r.find_first_not_of("0.", 1) == std::string::npos) r.erase(0, 1);
  return r;
}

// The p-th percentile (0..100) of v, linear between the order statistics (0 for no values).
double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double x = std::clamp(p, 0.0, 100.0) / 100.0 * static_cast<double>(v.size() - 1);
  const std::size_t i = static_cast<std::size_t>(std::floor(x));
  if (i + 1 >= v.size()) return v.back();
  return v[i] + (x - static_cast<double>(i)) * (v[i + 1] - v[i]);
}

int band(double v, double t3, double t2, double t1) {  // higher is better
  return v >= t3 ? 3 : v >= t2 ? 2 : v >= t1 ? 1 : 0;
}

}  // namespace

std::string OutcomeScores::headline() const {
  return fmt(points, 1) + " / " + fmt(max_points, 0) + " points" + (complete ? "" : ", INCOMPLETE");
}

namespace {
std::vector<double> ranks(const std::vector<double>& v) {
  std::vector<std::size_t> idx(v.size());
  for (std::size_t i = 0; i < idx.size(); ++i) idx[i] = i;
  std::sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) { return v[a] < v[b]; });
  std::vector<double> r(v.size());
  for (std::size_t i = 0; i < idx.size();) {
    std::size_t j = i;
    while (j + 1 < idx.size() && v[idx[j + 1]] == v[idx[i]]) ++j;
    for (std::size_t k = i; k <= j; ++k) r[idx[k]] = 0.5 * static_cast<double>(i + j) + 1.0;
    i = j + 1;
  }
  return r;
}
}  // namespace

double spearman_rho(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size() || a.size() < 2) return std::nan("");
  const std::vector<double> ra = ranks(a), rb = ranks(b);
  const double n = static_cast<double>(a.size());
  double ma = 0, mb = 0;
  for (std::size_t i = 0; i < ra.size(); ++i) ma += ra[i], mb += rb[i];
  ma /= n;
  mb /= n;
  double sab = 0, saa = 0, sbb = 0;
  for (std::size_t i = 0; i < ra.size(); ++i) {
    sab += (ra[i] - ma) * (rb[i] - mb);
    saa += (ra[i] - ma) * (ra[i] - ma);
    sbb += (rb[i] - mb) * (rb[i] - mb);
  }
  return saa > 0 && sbb > 0 ? sab / std::sqrt(saa * sbb) : std::nan("");
}

double line_of_sight(const volume::VoxelVolume& cut, const Eigen::Vector3d& from, double top_z,
                     double cone_deg) {
  if (!open_at(cut, from)) return 0.0;
  const double step = 0.5 * cut.spacing().minCoeff();
  int rays = 0, clear = 0;
  const double cone = cone_deg * M_PI / 180.0;
  auto cast = [&](double tilt, double az) {
    const Eigen::Vector3d d(std::sin(tilt) * std::cos(az), std::sin(tilt) * std::sin(az), std::cos(tilt));
    ++rays;
    for (double s = step; ; s += step) {
      const Eigen::Vector3d p = from + s * d;
      if (p.z() >= top_z) break;
      if (!open_at(cut, p)) return;
    }
    ++clear;
  };
  cast(0, 0);
  for (int ring = 1; ring <= 2; ++ring)
    for (int a = 0; a < 8; ++a) cast(cone * ring / 2.0, a * M_PI / 4.0);
  return static_cast<double>(clear) / rays;
}

double straight_line_access(const volume::VoxelVolume& cut, const Eigen::Vector3d& orifice, const Eigen::Vector3d& axis_up,
                            double top_z, double radius, double cone_deg) {
  const Eigen::Vector3d u = axis_up.normalized();
  if (!(u.z() > 0.1)) return 0.0;  // a canal axis must rise toward the opening
  // Two unit vectors across the axis.
  const Eigen::Vector3d e1 = (std::abs(u.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY()).cross(u).normalized();
  const Eigen::Vector3d e2 = u.cross(e1);
  const double step = 0.5 * cut.spacing().minCoeff();
  const double tilt = cone_deg * M_PI / 180.0;
  int rays = 0, clear = 0;
  for (int o = 0; o < 9; ++o) {
    const double ao = (o - 1) * M_PI / 4.0;
    const Eigen::Vector3d from = o == 0 ? orifice : Eigen::Vector3d(orifice + radius * (std::cos(ao) * e1 + std::sin(ao) * e2));
    for (int t = 0; t < 9; ++t) {
      const double at = (t - 1) * M_PI / 4.0;
      const Eigen::Vector3d d = t == 0 ? u
                                       : Eigen::Vector3d(std::cos(tilt) * u +
                                                         std::sin(tilt) * (std::cos(at) * e1 + std::sin(at) * e2));
      ++rays;
      if (d.z() <= 0 || !open_at(cut, from)) continue;
      bool ok = true;
      for (double s = step;; s += step) {
        const Eigen::Vector3d p = from + s * d;
        if (p.z() >= top_z) break;
        if (!open_at(cut, p)) { ok = false; break; }
      }
      clear += ok;
    }
  }
  return static_cast<double>(clear) / rays;
}

double roof_removed(const volume::VoxelVolume& start, const volume::VoxelVolume& cut, double from_z) {
  const Eigen::Vector3i d = start.dims();
  const int k0 = std::max(0, static_cast<int>(std::ceil((from_z - start.origin().z()) / start.spacing().z() - 1e-9)));
  int foot = 0, open = 0;
  for (int j = 0; j < d.y(); ++j)
    for (int i = 0; i < d.x(); ++i) {
      int top = -1;
      for (int k = d.z() - 1; k >= k0; --k)
        if (start.density(i, j, k) > 0 && start.material(i, j, k) == volume::Material::kPulp) { top = k; break; }
      if (top < 0) continue;
      ++foot;
      int k = d.z() - 1;
      while (k > top && cut.density(i, j, k) < kIsoDensity) --k;
      if (k == top) ++open;
    }
  return foot > 0 ? static_cast<double>(open) / foot : 0.0;
}

WallProfile wall_profile(const volume::VoxelVolume& cut, const Eigen::Vector3d& axis, const Eigen::Vector3d& dir,
                         double z0, double z1, const volume::VoxelVolume* start) {
  WallProfile w;
  const double h = cut.spacing().minCoeff();
  const double step = 0.25 * h;
  std::vector<double> levels;
  for (double z = z0; z <= z1 + 1e-12; z += cut.spacing().z()) levels.push_back(z);
  // Which levels are measured. Without the starting tooth: every level whose axis voxel is open.
  // With it (issue 25, session 19): only the levels opened from the opening down without a gap.
  // Walking down the axis from the top level, a level counts when its axis voxel is open now and
  // was either outside the tooth (the space above the occlusal surface, as before), or removed by
  // the bur (denser before), or is the pulp chamber's own space (pulp, open before any cut)
  // directly under a counted level: once the bur has broken through the roof at the axis, the
  // chamber below the break is reached. The first level that is none of these ends the walls:
  // uncut dentin (the roof, a ledge) or a chamber not yet broken into. (The untouched chamber used
  // to count as open space, so a cut that never reached it had its walls "formed" over the
  // chamber's span and their slopes fitted through the chamber's side.)
  std::vector<char> use(levels.size(), 0);
  if (!start) {
    for (std::size_t q = 0; q < levels.size(); ++q) use[q] = open_at(cut, {axis.x(), axis.y(), levels[q]});
  } else {
    for (std::size_t q = levels.size(); q-- > 0;) {
      const Eigen::Vector3d c(axis.x(), axis.y(), levels[q]);
      const Eigen::Vector3d g = (c - start->origin()).cwiseQuotient(start->spacing());
      const int i = static_cast<int>(std::lround(g.x())), j = static_cast<int>(std::lround(g.y())),
                k = static_cast<int>(std::lround(g.z()));
      const std::uint8_t d0 = start->density(i, j, k), d1 = cut.density(i, j, k);
      if (d1 >= kIsoDensity) break;
      const bool outside = d0 == 0, removed = d1 < d0;
      const bool chamber = d0 < kIsoDensity && start->material(i, j, k) == volume::Material::kPulp;
      if (!(outside || removed || chamber)) break;  // a chamber level here lies under the break
      use[q] = 1;
    }
  }
  for (std::size_t q = 0; q < levels.size(); ++q) {
    if (!use[q]) continue;
    const Eigen::Vector3d c(axis.x(), axis.y(), levels[q]);
    double s = 0;
    const double max_s = 0.02;  // 20 mm
    while (s < max_s && open_at(cut, c + (s + step) * dir)) s += step;
    if (s >= max_s) continue;  // no wall in that direction at this level
    w.z_m.push_back(levels[q]);
    w.extent_m.push_back(s + 0.5 * h);  // the wall surface lies half a voxel past the last open centre
  }
  const std::size_t n = w.z_m.size();
  if (n >= 2) {
    double mz = 0, me = 0;
    for (std::size_t i = 0; i < n; ++i) {
      mz += w.z_m[i];
      me += w.extent_m[i];
    }
    mz /= n;
    me /= n;
    double szz = 0, sze = 0;
    for (std::size_t i = 0; i < n; ++i) {
      szz += (w.z_m[i] - mz) * (w.z_m[i] - mz);
      sze += (w.z_m[i] - mz) * (w.extent_m[i] - me);
    }
    const double b = szz > 0 ? sze / szz : 0;
    const double a = me - b * mz;
    double ss = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double r = w.extent_m[i] - (a + b * w.z_m[i]);
      ss += r * r;
    }
    w.divergence_deg = std::atan(b) * 180.0 / M_PI;
    w.rms_mm = std::sqrt(ss / n) * 1e3;
  }
  return w;
}

namespace {

// The wall-taper criterion of a graded exercise (issue 25, session 14): each of the four axial walls
// earns points/4 when its divergence lies in the ideal range, less linearly to 0 at zero_beyond_deg
// outside it; a wall the cavity does not reach over half the measured height earns nothing. An
// untouched tooth has no cavity (the axis point is solid at every level) and so no wall.
// The target outline's distance from `c` along `dir` (a layer of the wall taper): the target voxels of
// the masks walked in quarter-voxel steps from c, plus half a voxel (where the outline's surface lies,
// as a wall's extent is measured); 0 when c is not in the target.
double outline_distance(const RegionMasks& m, const volume::VoxelVolume& v, const Eigen::Vector3d& c,
                        const Eigen::Vector3d& dir) {
  const auto in_target = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector3d q = (p - v.origin()).cwiseQuotient(v.spacing());
    const int i = static_cast<int>(std::lround(q.x())), j = static_cast<int>(std::lround(q.y())),
              k = static_cast<int>(std::lround(q.z()));
    if (i < 0 || j < 0 || k < 0 || i >= m.dims.x() || j >= m.dims.y() || k >= m.dims.z()) return false;
    return (m.bits[m.index(i, j, k)] & m.target_bits) != 0;
  };
  if (!in_target(c)) return 0;
  const double h = v.spacing().minCoeff(), step = 0.25 * h;
  double s = 0;
  while (s < 0.02 && in_target(c + (s + step) * dir)) s += step;
  return s + 0.5 * h;
}

Criterion wall_taper_criterion(const WallTaper& t, const volume::VoxelVolume& start, const RegionMasks& m,
                               const volume::VoxelVolume& cut) {
  Criterion c;
  c.name = "wall taper";
  c.unit = "deg mean distance outside the ideal taper";
  c.max_score = t.points;
  const struct { const char* name; Eigen::Vector3d dir; } walls[4] = {
      {"mesial", {-1, 0, 0}}, {"distal", {1, 0, 0}}, {"buccal", {0, -1, 0}}, {"palatal", {0, 1, 0}}};
  const double height = t.to_z_m - t.from_z_m;
  const double each = t.points / 4.0;
  std::string parts;
  double off_sum = 0;
  for (const auto& w : walls) {
    const WallProfile p = wall_profile(cut, t.axis_point_m, w.dir, t.from_z_m, t.to_z_m, &start);
    const double covered = p.z_m.size() >= 2 ? p.z_m.back() - p.z_m.front() : 0;
    std::string part = std::string(w.name) + " ";
    if (covered < 0.5 * height) {
      part += "not formed (reached over " + fmt(covered * 1e3) + " of " + fmt(height * 1e3) + " mm), 0";
      off_sum += t.zero_beyond_deg;
    } else {
      const double d = p.divergence_deg;
      const double off = d < t.ideal_min_deg ? t.ideal_min_deg - d : d > t.ideal_max_deg ? d - t.ideal_max_deg : 0.0;
      double pts = each * std::clamp(1.0 - off / t.zero_beyond_deg, 0.0, 1.0);
      // Outline reach (session 19): the wall's mean reach toward the target outline over the measured
      // layers (a layer it does not reach counts 0); its points scale with reach / the full reach.
      std::string reach_part;
      if (t.outline_reach_full_pct > 0) {
        double sum = 0;
        int layers = 0;
        std::size_t q = 0;
        for (double z = t.from_z_m; z <= t.to_z_m + 1e-12; z += cut.spacing().z()) {
          const Eigen::Vector3d c0(t.axis_point_m.x(), t.axis_point_m.y(), z);
          const double o = outline_distance(m, cut, c0, w.dir);
          while (q < p.z_m.size() && p.z_m[q] < z - 1e-9) ++q;
          if (o <= 0) continue;  // the axis point is outside the target here: no outline to reach
          ++layers;
          if (q < p.z_m.size() && std::abs(p.z_m[q] - z) < 1e-9) sum += std::min(1.0, p.extent_m[q] / o);
        }
        const double reach = layers > 0 ? sum / layers : 0.0;
        const double f = std::clamp(100.0 * reach / t.outline_reach_full_pct, 0.0, 1.0);
        if (f < 1.0) reach_part = " x " + fmt(100 * reach, 0) + " % reach of the outline";
        pts *= f;
      }
      c.score += pts;
      off_sum += std::min(off, t.zero_beyond_deg);
      part += fmt(d, 1) + " deg" +
              (off > 0 ? std::string(d < t.ideal_min_deg ? " (converging " : " (diverging ") + fmt(off, 1) + " deg too much)"
                       : "") +
              reach_part + ", " + fmt(pts);
    }
    parts += (parts.empty() ? "" : "; ") + part;
  }
  c.value = off_sum / 4.0;
  c.detail = fmt(c.score) + " of " + fmt(t.points, 0) + ": the walls' taper (divergence toward occlusal, > 0 opens) " +
             parts + "; each wall earns " + fmt(each) + " between " + fmt(t.ideal_min_deg, 0) + " and " +
             fmt(t.ideal_max_deg, 0) + " deg (parallel to slightly converging occlusally, for retention), less " +
             "linearly to 0 at " + fmt(t.zero_beyond_deg, 0) + " deg outside that range" +
             (t.outline_reach_full_pct > 0
                  ? ", in proportion to how far it reaches toward the outline (full at " + fmt(t.outline_reach_full_pct, 0) +
                        " %: a wall not cut out to the outline is not the finished wall)."
                  : ".");
  return c;
}

// Outline extension (issue 25, session 20): see OutlineExtension (exercise.h) and docs/formats.md.
Criterion outline_extension_criterion(const OutlineExtension& t, const volume::VoxelVolume& start,
                                      const RegionMasks& m, const volume::VoxelVolume& cut) {
  Criterion c;
  c.name = "outline extension";
  c.unit = "mm mean |distance| of the cut outline from the target outline";
  c.max_score = t.points;
  const struct { const char* name; Eigen::Vector3d dir, across; } walls[4] = {
      {"mesial", {-1, 0, 0}, {0, 1, 0}}, {"distal", {1, 0, 0}, {0, 1, 0}},
      {"buccal", {0, -1, 0}, {1, 0, 0}}, {"palatal", {0, 1, 0}, {1, 0, 0}}};
  const double h = start.spacing().minCoeff(), step = 0.25 * h;
  const auto voxel = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector3d q = (p - start.origin()).cwiseQuotient(start.spacing());
    return Eigen::Vector3i(static_cast<int>(std::lround(q.x())), static_cast<int>(std::lround(q.y())),
                           static_cast<int>(std::lround(q.z())));
  };
  const auto opened = [&](const Eigen::Vector3i& v) {  // solid in the starting tooth, open now
    return start.density(v.x(), v.y(), v.z()) >= kIsoDensity && cut.density(v.x(), v.y(), v.z()) < kIsoDensity;
  };
  const auto in_target = [&](const Eigen::Vector3i& v) {
    if ((v.array() < 0).any() || (v.array() >= m.dims.array()).any()) return false;
    return (m.bits[m.index(v.x(), v.y(), v.z())] & m.target_bits) != 0;
  };
  const auto along = [&](const Eigen::Vector3i& v, const Eigen::Vector3d& c0, const Eigen::Vector3d& dir) {
    return (start.voxel_center(v.x(), v.y(), v.z()) - c0).dot(dir);
  };
  const double each = t.points / 4.0;
  const double search = 1.5e-3;  // past the outline: beyond the modification band either way
  std::string parts;
  double abs_sum = 0;
  int abs_n = 0;
  for (const auto& w : walls) {
    std::vector<double> d;  // signed distances (m) over the wall's length and height
    for (double z = t.from_z_m; z <= t.to_z_m + 1e-12; z += start.spacing().z()) {
      const Eigen::Vector3d a(t.axis_point_m.x(), t.axis_point_m.y(), z);
      const double lo = outline_distance(m, start, a, -w.across), hi = outline_distance(m, start, a, w.across);
      if (lo <= 0 || hi <= 0) continue;  // the axis is outside the target at this level
      const double u0 = -(lo - 0.5 * h) + t.end_margin_m, u1 = (hi - 0.5 * h) - t.end_margin_m;
      std::vector<double> us;
      if (u1 < u0) us.push_back(0.5 * (u0 + u1));
      else
        for (double u = u0; u <= u1 + 1e-12; u += h) us.push_back(u);
      for (const double u : us) {
        // Along the ray, in voxels: the last target voxel from c0 on (the target outline lies half a voxel
        // past its centre) and the farthest voxel the cut opened (the cut outline likewise), each as its
        // centre's distance along the ray, so that a wall a whole number of voxels off measures exactly.
        const Eigen::Vector3d c0 = a + u * w.across;
        if (!in_target(voxel(c0))) continue;
        Eigen::Vector3i last = voxel(c0);
        int n = 1;
        for (; n * step < 0.02; ++n) {
          const Eigen::Vector3i v = voxel(c0 + n * step * w.dir);
          if (!in_target(v)) break;
          last = v;
        }
        const double o = along(last, c0, w.dir) + 0.5 * h;
        if (start.density(last.x(), last.y(), last.z()) < kIsoDensity) continue;  // the outline is above the tooth here
        double e = -1;
        for (int q = 0; q * step <= o + search; ++q) {
          const Eigen::Vector3i v = voxel(c0 + q * step * w.dir);
          if (opened(v)) e = std::max(e, along(v, c0, w.dir) + 0.5 * h);
        }
        d.push_back((e > 0 ? e : 0.0) - o);
      }
    }
    std::string part = std::string(w.name) + " wall ";
    if (d.empty()) {
      part += "not measured (the target's outline lies outside the tooth between the levels), 0";
      parts += (parts.empty() ? "" : "; ") + part;
      continue;
    }
    int n[4] = {0, 0, 0, 0};  // ideal, acceptable, modification, unacceptable
    double worst = 0;
    for (const double x : d) {
      const double ax = std::abs(x);
      n[ax <= t.ideal_m + 1e-9 ? 0 : ax <= t.acceptable_m + 1e-9 ? 1 : ax <= t.modification_m + 1e-9 ? 2 : 3]++;
      if (ax > std::abs(worst)) worst = x;
      abs_sum += ax;
      ++abs_n;
    }
    std::vector<double> sorted = d;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
    const double median = sorted[sorted.size() / 2];
    const double N = static_cast<double>(d.size());
    const double grade = (n[0] + t.accept_fraction * n[1] + t.modify_fraction * n[2]) / N;
    const double pts = each * grade;
    c.score += pts;
    const auto side = [](double x) { return x < 0 ? " short of" : x > 0 ? " past" : " on"; };
    part += "median " + fmt(std::abs(median) * 1e3) + " mm" + side(median) + " the outline, worst " +
            fmt(std::abs(worst) * 1e3) + " mm" + side(worst) + " it; of its length " + fmt(100 * n[0] / N, 0) +
            " % within " + fmt(t.ideal_m * 1e3) + " mm, " + fmt(100 * n[1] / N, 0) + " % within " +
            fmt(t.acceptable_m * 1e3) + ", " + fmt(100 * n[2] / N, 0) + " % within " + fmt(t.modification_m * 1e3) +
            ", " + fmt(100 * n[3] / N, 0) + " % beyond: " + fmt(pts) + " of " + fmt(each);
    parts += (parts.empty() ? "" : "; ") + part;
  }
  c.value = abs_n > 0 ? 1e3 * abs_sum / abs_n : 0.0;
  c.detail = fmt(c.score) + " of " + fmt(t.points, 0) + ": the cut outline against the target outline, per wall " +
             "(between " + fmt(t.from_z_m * 1e3, 1) + " and " + fmt(t.to_z_m * 1e3, 1) + " mm): " + parts +
             ". Each wall earns " + fmt(each) + " x the mean grade of its length: 1 within " + fmt(t.ideal_m * 1e3) +
             " mm of the outline either way (ideal), " + fmt(t.accept_fraction) + " within " +
             fmt(t.acceptable_m * 1e3) + " (acceptable), " + fmt(t.modify_fraction) + " within " +
             fmt(t.modification_m * 1e3) + " (needs modification), 0 beyond; short and past are judged alike.";
  return c;
}

// A form criterion's coverage share (issue 25, session 22; WallTaper / FloorDepth coverage_full_pct):
// the taper of the walls and the depth of the floor are the finished cavity's; a preparation that
// removed only part of the target made only part of that form, so the criterion earns its points in
// proportion to the coverage, full from `full_pct` ("scale"), or at most that share ("cap"). The
// detail's first figure stays the final score; the measured grade and the share follow it.
void apply_coverage_share(Criterion& c, double full_pct, bool cap, double coverage_pct, const std::string& of_what) {
  if (full_pct <= 0) return;
  const double f = std::clamp(coverage_pct / full_pct, 0.0, 1.0);
  if (f >= 1.0) return;
  const double measured = c.score;
  c.score = cap ? std::min(measured, c.max_score * f) : measured * f;
  const std::string head = fmt(c.max_score, 0) + ": ";
  const std::size_t at = c.detail.find(head);
  const std::string what = at == std::string::npos ? c.detail : c.detail.substr(at + head.size());
  const std::string share = fmt(coverage_pct, 0) + " % of " + of_what + " removed (the finished form's points in full from " +
                            fmt(full_pct, 0) + " %: the form of an unfinished cavity is the form of part of it)";
  c.detail = fmt(c.score) + " of " + head + share +
             (cap ? ", so at most " + fmt(c.max_score) + " x " + fmt(f) + " = " + fmt(c.max_score * f) + " of the " +
                        fmt(measured) + " measured: "
                  : ", so " + fmt(measured) + " measured x " + fmt(f) + ": ") +
             what;
}

// Floor depth (issue 25, session 21): see FloorDepth (exercise.h) and docs/formats.md.
Criterion floor_depth_criterion(const FloorDepth& t, std::size_t region, const volume::VoxelVolume& start,
                                const RegionMasks& m, const volume::VoxelVolume& cut) {
  Criterion c;
  c.name = "floor depth";
  c.unit = "mm mean |distance| of the cut floor from the target floor";
  c.max_score = t.points;
  const Eigen::Vector3i d = m.dims;
  const double hz = start.spacing().z();
  const auto in_r = [&](int i, int j, int k) { return (m.bits[m.index(i, j, k)] >> region & 1u) != 0; };
  // Per column: the lowest voxel of the region (-1: none).
  std::vector<int> low(static_cast<std::size_t>(d.x()) * d.y(), -1);
  for (int j = 0; j < d.y(); ++j)
    for (int i = 0; i < d.x(); ++i)
      for (int k = 0; k < d.z(); ++k)
        if (in_r(i, j, k)) {
          low[static_cast<std::size_t>(i) + static_cast<std::size_t>(d.x()) * j] = k;
          break;
        }
  const auto low_at = [&](int i, int j) {
    if (i < 0 || j < 0 || i >= d.x() || j >= d.y()) return -1;
    return low[static_cast<std::size_t>(i) + static_cast<std::size_t>(d.x()) * j];
  };
  const int nx = static_cast<int>(std::lround(t.margin_m / start.spacing().x()));
  const int ny = static_cast<int>(std::lround(t.margin_m / start.spacing().y()));
  const int search = static_cast<int>(std::ceil(1.5e-3 / hz - 1e-9));
  std::vector<double> e;  // signed: > 0 below the target floor, < 0 short of it
  for (int j = 0; j < d.y(); ++j)
    for (int i = 0; i < d.x(); ++i) {
      const int k0 = low_at(i, j);
      if (k0 < 0) continue;
      if (low_at(i - nx, j) < 0 || low_at(i + nx, j) < 0 || low_at(i, j - ny) < 0 || low_at(i, j + ny) < 0) continue;
      if (start.density(i, j, k0) < kIsoDensity) continue;  // the floor lies outside the tooth here
      const double floor = start.voxel_center(i, j, k0).z() - 0.5 * hz;
      int lowest = -1, top = -1;
      for (int k = std::max(0, k0 - search); k < d.z(); ++k) {
        const bool solid = start.density(i, j, k) >= kIsoDensity;
        if (solid) top = k;
        if (lowest < 0 && solid && cut.density(i, j, k) < kIsoDensity) lowest = k;
      }
      // The cut floor: the bottom face of the lowest opened voxel; nothing opened: the tooth's top.
      const double cut_floor = lowest >= 0 ? start.voxel_center(i, j, lowest).z() - 0.5 * hz
                                           : start.voxel_center(i, j, top).z() + 0.5 * hz;
      e.push_back(floor - cut_floor);
    }
  if (e.empty()) {
    c.detail = "0 of " + fmt(t.points, 0) + ": the floor was not measured (no column of the target's floor lies in the tooth).";
    return c;
  }
  int n[4] = {0, 0, 0, 0};  // ideal, acceptable, modification, unacceptable
  int deep = 0, shallow = 0;
  double abs_sum = 0, deepest = 0, linear = 0;
  for (const double x : e) {
    const double ax = std::abs(x);
    const int b = ax <= t.ideal_m + 1e-9 ? 0 : ax <= t.acceptable_m + 1e-9 ? 1 : ax <= t.modification_m + 1e-9 ? 2 : 3;
    n[b]++;
    linear += std::clamp(1.0 - (ax - t.ideal_m) / std::max(1e-12, t.modification_m - t.ideal_m), 0.0, 1.0);
    if (b > 0) (x > 0 ? deep : shallow)++;
    deepest = std::max(deepest, x);
    abs_sum += ax;
  }
  std::vector<double> sorted = e;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
  const double median = sorted[sorted.size() / 2];
  const double N = static_cast<double>(e.size());
  const double grade = t.continuous ? linear / N : (n[0] + t.accept_fraction * n[1] + t.modify_fraction * n[2]) / N;
  c.score = t.points * grade;
  c.value = 1e3 * abs_sum / N;
  const auto side = [](double x) { return x > 0 ? " below" : x < 0 ? " short of" : " on"; };
  c.detail = fmt(c.score) + " of " + fmt(t.points, 0) + ": the cut floor against the target floor over " +
             std::to_string(e.size()) + " columns of its footprint (" + fmt(t.margin_m * 1e3) +
             " mm in from the outline): median " + fmt(std::abs(median) * 1e3) + " mm" + side(median) +
             " it, deepest " + fmt(std::max(0.0, deepest) * 1e3) + " mm below it; of the floor " +
             fmt(100 * n[0] / N, 0) + " % within " + fmt(t.ideal_m * 1e3) + " mm, " + fmt(100 * n[1] / N, 0) +
             " % within " + fmt(t.acceptable_m * 1e3) + ", " + fmt(100 * n[2] / N, 0) + " % within " +
             fmt(t.modification_m * 1e3) + ", " + fmt(100 * n[3] / N, 0) + " % beyond (" + fmt(100 * deep / N, 0) +
             " % too deep, " + fmt(100 * shallow / N, 0) + " % too shallow, past " + fmt(t.ideal_m * 1e3) +
             " mm). It earns " + fmt(t.points, 0) + " x the mean grade of the floor: 1 within " + fmt(t.ideal_m * 1e3) +
             " mm of the target floor either way (ideal), " +
             (t.continuous ? "falling linearly to 0 at " + fmt(t.modification_m * 1e3) + " mm"
                           : fmt(t.accept_fraction) + " within " + fmt(t.acceptable_m * 1e3) + " (acceptable), " +
                                 fmt(t.modify_fraction) + " within " + fmt(t.modification_m * 1e3) +
                                 " (needs modification), 0 beyond") +
             "; too deep and too shallow are judged alike.";
  return c;
}

}  // namespace

Result<OutcomeScores> score_outcome(const Exercise& ex, const RegionMasks& m, const volume::VoxelVolume& start,
                                    const volume::VoxelVolume& cut) {
  if (start.dims() != cut.dims() || !start.spacing().isApprox(cut.spacing()) ||
      !start.origin().isApprox(cut.origin()))
    return Error{"score_outcome: the cut volume's geometry differs from the starting volume's (" +
                 std::to_string(cut.dims().x()) + "x" + std::to_string(cut.dims().y()) + "x" +
                 std::to_string(cut.dims().z()) + " vs " + std::to_string(start.dims().x()) + "x" +
                 std::to_string(start.dims().y()) + "x" + std::to_string(start.dims().z()) + ")"};
  if (m.dims != start.dims()) return Error{"score_outcome: masks were built on another volume"};
  OutcomeScores o;
  // mm3 per density unit of each material (a voxel at its material's full density is one voxel).
  std::array<double, volume::kMaxMaterials> unit_mm3{};
  for (int mt = 0; mt < volume::kMaxMaterials; ++mt) {
    const double full = volume::material_info(mt).full_density;
    unit_mm3[static_cast<std::size_t>(mt)] = full > 0 ? start.voxel_volume_m3() * 1e9 / full : 0.0;
  }
  const std::size_t nr = ex.regions.size();
  std::vector<double> reg_vol(nr, 0), reg_rem(nr, 0), reg_over(nr, 0);
  // Floor depth (session 21): each region's floor level (its lowest voxel's bottom face, m) and the
  // part of its cut too far that lies below it.
  std::vector<double> reg_floor(nr, 1e9), reg_over_below(nr, 0);
  // Session 22 (overflow_cost): what the regions' cut too far cost beyond their coverage's points.
  double overflow_points = 0, overflow_mm3 = 0;
  bool overflow_split = false;
  std::string overflow_what;
  bool need_dist = false;
  for (const auto& r : ex.regions)
    for (const auto& p : r.all) need_dist |= p.kind == PrimitiveKind::kShell;
  std::vector<float> dist;
  if (need_dist) dist = distance_to_air_m(start);
  // Zone membership of a voxel for region r (primitives grown by g, m).
  auto in_zone = [&](std::size_t r, int i, int j, int k, std::size_t id, double g) {
    const Region& R = ex.regions[r];
    const Eigen::Vector3d p = start.voxel_center(i, j, k);
    const std::uint8_t d0 = start.density(i, j, k);
    for (const auto& pr : R.all) {
      bool v;
      switch (pr.kind) {
        case PrimitiveKind::kMaterial: v = d0 > 0 && start.material(i, j, k) == pr.material; break;
        case PrimitiveKind::kShell: v = d0 > 0 && dist[id] <= pr.depth_m + g; break;  // as build_masks: skin included
        case PrimitiveKind::kSolid: v = d0 > 0; break;
        default:
          // contains() applies `negate` itself; a complement grows when its shape shrinks.
          if (!pr.contains(p, pr.negate ? -g : g)) return false;
          continue;
      }
      if (pr.negate) v = !v;
      if (!v) return false;
    }
    return true;
  };
  const AccessGeometry* access = ex.outcome == OutcomeKind::kAccessOpening && ex.access ? &*ex.access : nullptr;
  const Eigen::Vector3i d = start.dims();
  std::size_t floor_region = nr;  // the floor depth's region (nr: none)
  if (ex.floor_depth)
    for (std::size_t r = 0; r < nr; ++r)
      if (ex.regions[r].name == ex.floor_depth->from_region) floor_region = r;
  if (floor_region < nr) {
    for (int k = 0; k < d.z() && reg_floor[floor_region] > 1e8; ++k)
      for (int j = 0; j < d.y(); ++j)
        for (int i = 0; i < d.x(); ++i)
          if (m.bits[m.index(i, j, k)] >> floor_region & 1u)
            reg_floor[floor_region] = std::min(reg_floor[floor_region], start.voxel_center(i, j, k).z() - 0.5 * start.spacing().z());
  }
  static const int nb[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (int k = 0; k < d.z(); ++k)
    for (int j = 0; j < d.y(); ++j)
      for (int i = 0; i < d.x(); ++i) {
        const std::uint8_t d0 = start.density(i, j, k);
        if (d0 == 0) continue;
        const std::uint8_t d1 = cut.density(i, j, k);
        const std::size_t id = m.index(i, j, k);
        const double vmm3 = unit_mm3[static_cast<std::size_t>(start.material(i, j, k))];
        const std::uint32_t bits = m.bits[id];
        const double rem = d1 < d0 ? (d0 - d1) * vmm3 : 0.0;
        for (std::size_t r = 0; r < nr; ++r)
          if (bits >> r & 1u) {
            reg_vol[r] += d0 * vmm3;
            reg_rem[r] += rem;
          }
        if (rem <= 0) continue;
        const auto mat = static_cast<std::size_t>(start.material(i, j, k));
        o.removed_mm3[mat] += rem;
        o.removed_total_mm3 += rem;
        if (mat == static_cast<std::size_t>(volume::Material::kPulp)) o.pulp_removed_mm3 += rem;
        if (!(bits & m.target_bits)) {
          o.overprep_mm3 += rem;
          // Charged once, to the nearest target region whose zone holds the
          // voxel (the smallest growth, in 0.05 mm steps, that reaches it;
          // a tie is shared): zones overlap where targets meet, and a cut too
          // deep under one region is not the neighbouring region's fault.
          double best = 1e9;
          std::uint32_t who = 0;
          for (std::size_t r = 0; r < nr; ++r) {
            const Region& R = ex.regions[r];
            if (R.role != RegionRole::kTarget || R.points <= 0) continue;
            const int n = static_cast<int>(std::ceil(R.zone_mm / 0.05 - 1e-9));
            for (int q = 1; q <= n; ++q) {
              const double g = std::min(R.zone_mm, 0.05 * q) * 1e-3;
              if (g > best + 1e-12) break;
              if (!in_zone(r, i, j, k, id, g)) continue;
              if (g < best - 1e-12) who = 0;
              best = g;
              who |= 1u << r;
              break;
            }
          }
          if (who && best <= ex.tolerance_mm * 1e-3 + 1e-12) {
            o.tolerated_mm3 += rem;  // within the clinical tolerance of the outline: not charged
          } else if (who) {
            const double share = rem / std::popcount(who);
            for (std::size_t r = 0; r < nr; ++r)
              if (who >> r & 1u) {
                reg_over[r] += share;
                if (start.voxel_center(i, j, k).z() < reg_floor[r]) reg_over_below[r] += share;
              }
          } else if (mat != static_cast<std::size_t>(volume::Material::kPulp) &&
                     !(access && start.voxel_center(i, j, k).z() < access->floor_z_m)) {
            // Beyond every zone: over-reduction (pulp has its own cost, the
            // access opening's floor its own criterion).
            bool near = false;
            for (std::size_t r = 0; r < nr && !near; ++r) {
              const Region& R = ex.regions[r];
              near = R.role == RegionRole::kTarget && R.points <= 0 && in_zone(r, i, j, k, id, R.zone_mm * 1e-3);
            }
            if (!near) o.beyond_zone_mm3 += rem;
            else if (access) {
              o.access_zone_mm3 += rem;
              // How far outside the access outline (its target regions without points).
              int band = -1;
              for (std::size_t r = 0; r < nr && band < 0; ++r) {
                const Region& R = ex.regions[r];
                if (R.role != RegionRole::kTarget || R.points > 0) continue;
                const int n = static_cast<int>(std::ceil(R.zone_mm / 0.05 - 1e-9));
                for (int q = 1; q <= n; ++q)
                  if (in_zone(r, i, j, k, id, std::min(R.zone_mm, 0.05 * q) * 1e-3)) {
                    band = q - 1;
                    break;
                  }
              }
              if (band >= 0) {
                if (o.access_zone_by_band_mm3.size() <= static_cast<std::size_t>(band))
                  o.access_zone_by_band_mm3.resize(static_cast<std::size_t>(band) + 1, 0.0);
                o.access_zone_by_band_mm3[static_cast<std::size_t>(band)] += rem;
                // Session 23: and by wall, the voxel's quarter around the access axis (the walls'
                // directions' quarters: distal +x, palatal +y, mesial -x, buccal -y).
                const Eigen::Vector3d pc = start.voxel_center(i, j, k);
                double ang = std::atan2(pc.y() - access->axis_point_m.y(), pc.x() - access->axis_point_m.x());
                if (ang < 0) ang += 2 * M_PI;
                const int quarter = static_cast<int>(std::floor(std::fmod(ang + M_PI / 4, 2 * M_PI) / (M_PI / 2))) & 3;
                static const int to_wall[4] = {1, 3, 0, 2};
                auto& wb = o.access_zone_by_wall_band_mm3[static_cast<std::size_t>(to_wall[quarter])];
                if (wb.size() <= static_cast<std::size_t>(band)) wb.resize(static_cast<std::size_t>(band) + 1, 0.0);
                wb[static_cast<std::size_t>(band)] += rem;
              }
            }
          }
        }
        if (bits & m.forbidden_bits) o.forbidden_mm3 += rem;
        // Opened voxel (solid before, open now): exposure and perforation.
        if (d0 > kIsoDensity && d1 < kIsoDensity) {
          bool exterior = false;
          for (const auto& n : nb) {
            const int a = i + n[0], b = j + n[1], c = k + n[2];
            const std::uint8_t nd = start.density(a, b, c);
            const auto nm = start.material(a, b, c);
            if (nm == volume::Material::kPulp && nd > 0) o.pulp_wall_opened = true;
            if (nd == 0) exterior = true;
          }
          if (exterior && !(bits & m.entry_bits)) {
            o.perforation = true;
            o.perforation_mm3 += d0 * vmm3;
          }
        }
      }
  // The exercise's price of a mm3 (its graded points over its whole target
  // volume): what a mm3 cut too far costs in every region with
  // overprep_exercise_price, and what over-reduction costs at rate 1.
  double graded_points = 0, graded_vol = 0;
  for (std::size_t r = 0; r < nr; ++r)
    if (ex.regions[r].role == RegionRole::kTarget && ex.regions[r].points > 0) {
      graded_points += ex.regions[r].points;
      graded_vol += reg_vol[r];
    }
  const double exercise_price = graded_vol > 0 ? graded_points / graded_vol : 0;
  for (std::size_t r = 0; r < nr; ++r) {
    const Region& R = ex.regions[r];
    if (R.role == RegionRole::kTarget) {
      o.target_mm3 += reg_vol[r];
      o.target_removed_mm3 += reg_rem[r];
      RegionScore s;
      s.name = R.name;
      s.volume_mm3 = reg_vol[r];
      s.removed_mm3 = reg_rem[r];
      s.coverage_pct = reg_vol[r] > 0 ? 100.0 * reg_rem[r] / reg_vol[r] : 0;
      s.overprep_mm3 = reg_over[r];
      s.max_points = R.points;
      // Points per mm3 cut too far: this region's own (the default) or the exercise's (overprep_price "exercise").
      const double price0 = ex.overprep_exercise_price ? exercise_price : reg_vol[r] > 0 ? R.points / reg_vol[r] : 0;
      // Outline extension (session 20): its points come out of this region's coverage share; the
      // region's price of a mm3 cut too far stays its own points' (depth costs unchanged).
      const bool has_oe = ex.outline_extension && ex.outline_extension->from_region == R.name;
      const double oe = has_oe ? ex.outline_extension->points : 0.0;
      // Floor depth (session 21): its points come out of the coverage share too, and the cut too far is
      // split at the region's floor: below it the floor depth's, past the walls the outline extension's
      // (when there is one), neither then priced by volume.
      const bool split = r == floor_region;
      const double fd = split ? ex.floor_depth->points : 0.0;
      const double cov_points = R.points - oe - fd;
      s.max_points = cov_points;
      s.below_floor_mm3 = split ? reg_over_below[r] : 0.0;
      s.past_walls_mm3 = split ? reg_over[r] - reg_over_below[r] : 0.0;
      const double charged_mm3 = !split ? reg_over[r] : has_oe ? 0.0 : s.past_walls_mm3;
      const double price =
          oe > 0 && ex.outline_extension->price_follows_coverage && reg_vol[r] > 0 ? cov_points / reg_vol[r] : price0;
      if (R.points > 0 && reg_vol[r] > 0)
        s.points = std::clamp(cov_points * reg_rem[r] / reg_vol[r] - price * charged_mm3, 0.0, cov_points);
      // Overflow (session 22): the charge the region's coverage could not pay.
      double overflow = 0;
      if (ex.overflow_cost && R.points > 0 && reg_vol[r] > 0)
        overflow = std::max(0.0, price * charged_mm3 - cov_points * reg_rem[r] / reg_vol[r]);
      if (overflow > 0) {
        overflow_points += overflow;
        overflow_mm3 += charged_mm3;
        overflow_split |= split;
        overflow_what += (overflow_what.empty() ? "" : "; ") + R.name + ": " + fmt(charged_mm3) + " mm3 at " +
                         fmt(price, 3) + " points per mm3 = " + fmt(price * charged_mm3) + ", of which its coverage paid " +
                         fmt(price * charged_mm3 - overflow);
      }
      if (reg_rem[r] <= 0 && reg_over[r] <= 0) {
        s.why = "nothing of this region was removed.";
      } else if (R.points <= 0) {
        // A region without points of its own (the access opening's: its criteria score it). The sum
        // read "(0 x 96.9 % = 0.00 points), nothing cut beyond it" beside 5.48 mm3 of
        // over-preparation on the same page (issue 25, session 20): such a region is not charged
        // for a zone, so it says nothing about what was cut beyond it.
        s.why = fmt(s.coverage_pct, 0) + " % of the region removed; the region carries no points of its own (the "
                "exercise's criteria score the preparation).";
      } else {
        // The sum is written with the figures it is made of, to 2 decimals (issue 25, session 20:
        // at 1 decimal "5.9 points, less 0.3 ... = 5.5 points" did not add up for a reader).
        const double gross = cov_points * s.coverage_pct / 100;
        const double charge = price * charged_mm3;
        std::string others;
        if (oe > 0 && fd > 0) others = "; its other " + fmt(oe + fd, 0) + " points are the outline extension's " + fmt(oe, 0) +
                                       " and the floor depth's " + fmt(fd, 0);
        else if (oe > 0) others = "; its other " + fmt(oe, 0) + " points are the outline extension's";
        else if (fd > 0) others = "; its other " + fmt(fd, 0) + " points are the floor depth's";
        // Split (session 21): say where the cut too far lies and which criterion judges each part.
        std::string judged;
        if (split && reg_over[r] > 0)
          judged = "; of what was cut beyond it (within " + fmt(R.zone_mm, 1) + " mm), " + fmt(s.below_floor_mm3) +
                   " mm3 below the floor is judged by the floor depth" +
                   (has_oe ? " and " + fmt(s.past_walls_mm3) + " mm3 past the walls by the outline extension, in mm, not by volume"
                           : ", in mm, not by volume");
        s.why = fmt(s.coverage_pct, 0) + " % of the region removed (" + fmt(cov_points, 0) + " x " +
                fmt(s.coverage_pct, 1) + " % = " + fmt(gross) + " points" + others + ")" + judged +
                (charged_mm3 > 0 ? ", less " + fmt(charge) + " for " + fmt(charged_mm3) +
                                       (split ? " mm3 cut too far past its walls (within " : " mm3 cut too far beyond it (within ") +
                                       fmt(R.zone_mm, 1) + " mm, " + fmt(price, 3) +
                                       (ex.overprep_exercise_price ? " points per mm3, the exercise's price)"
                                                                   : " points per mm3 of this region)")
                 : reg_over[r] > 0 ? "" : ", nothing cut beyond it") +
                " = " + fmt(s.points) + " points" +
                (gross - charge < 0 ? (overflow > 0 ? " (a region's points do not go below 0; the other " + fmt(overflow) +
                                                          " are charged below, as " +
                                                          (split ? "over-extended outline)." : "cut too far).")
                                                    : " (a region's points do not go below 0).")
                                    : ".");
      }
      o.regions.push_back(s);
    } else if (R.role == RegionRole::kForbidden) {
      o.forbidden_by_region.emplace_back(R.name, reg_rem[r]);
    }
  }
  o.target_coverage_pct = o.target_mm3 > 0 ? 100.0 * o.target_removed_mm3 / o.target_mm3 : 0;

  std::vector<double> sight;  // access opening: clear fraction per orifice
  if (ex.outcome == OutcomeKind::kAccessOpening && ex.access) {
    const AccessGeometry& a = *ex.access;
    const bool continuous = ex.access_points == AccessPoints::kContinuous;
    // 1. Orifice visibility.
    double vis = 0;
    std::string det;
    for (const auto& f : a.orifices) {
      const double v = line_of_sight(cut, f.position_m, a.opening_z_m, a.sight_cone_deg);
      sight.push_back(v);
      vis += v;
      det += (det.empty() ? "" : ", ") + f.name + " " + fmt(100 * v, 0) + " %";
    }
    vis /= static_cast<double>(a.orifices.size());
    if (!continuous) {
      const int vs = band(vis, 0.9, 0.6, 0.3);
      o.criteria.push_back({"canal orifices visible", static_cast<double>(vs), 100 * vis, "% of sight lines",
                            std::to_string(vs) + " of 3: " + fmt(100 * vis, 0) +
                                " % of the sight lines from the canal orifices to the opening are clear (" + det +
                                "); 3 needs 90 %, 2 needs 60 %, 1 needs 30 %."});
    } else {
      // Straight-line access (issue 25, session 20). The sight lines above (a 10 deg cone around +z
      // from each orifice) are clear once a hole lies over each orifice, which a novice's partial
      // unroofing also gives: they hardly separated skill (pooled rank correlation 0.380). What an
      // endodontist grades is a file entering each canal along its axis without touching a wall
      // or a shelf, with the chamber's roof removed completely. So the criterion is the product of
      //   s: the share of file paths clear from each orifice along its canal's axis, widened
      //      occlusally by the sight cone (straight_line_access), averaged over the orifices, and
      //   r: the share of the chamber's footprint (chamber and horns, from the orifices' level up)
      //      with no dentin left over it (roof_removed),
      // 3 x min(1, s / 0.9) x min(1, r / 0.9): a roof shelf over an orifice or a horn costs in
      // proportion, even where the paths are clear; an untouched tooth has neither (0).
      double low = a.orifices.front().position_m.z(), sl = 0;
      std::string sdet;
      for (const auto& f : a.orifices) {
        low = std::min(low, f.position_m.z());
        const double v = straight_line_access(cut, f.position_m, f.canal_axis, a.opening_z_m, kFileRadius,
                                              a.sight_cone_deg);
        sl += v;
        sdet += (sdet.empty() ? "" : ", ") + f.name + " " + fmt(100 * v, 0) + " %";
      }
      sl /= static_cast<double>(a.orifices.size());
      const double roof = roof_removed(start, cut, low);
      const double fs = std::clamp(sl / kStraightFull, 0.0, 1.0), fr = std::clamp(roof / kRoofFull, 0.0, 1.0);
      const double vs = 3.0 * fs * fr;
      o.criteria.push_back(
          {"straight-line access", vs, 100 * sl, "% of file paths",
           fmt(vs) + " of 3: " + fmt(100 * sl, 0) + " % of the file paths from the canal orifices along their canals' " +
               "axes (widened " + fmt(a.sight_cone_deg, 0) + " deg occlusally) reach the opening clear (" + sdet +
               "), and " + fmt(100 * roof, 0) + " % of the pulp chamber's roof and horns is removed; 3 x min(1, " +
               fmt(100 * sl, 0) + " / 90) x min(1, " + fmt(100 * roof, 0) + " / 90). (Sight lines straight up from " +
               "the orifices: " + fmt(100 * vis, 0) + " % clear: " + det + ".)"});
    }
    // 2-5. Axial walls.
    const struct { const char* name; Eigen::Vector3d dir; } walls[4] = {
        {"mesial wall", {-1, 0, 0}}, {"distal wall", {1, 0, 0}}, {"buccal wall", {0, -1, 0}}, {"palatal wall", {0, 1, 0}}};
    const double span = a.opening_z_m - a.walls_from_z_m;
    {
      // Over-extension past the access outline (issue 25, session 21): 32 directions around the
      // axis, each wall's quarter (mesial -x, distal +x, buccal -y, palatal +y) 8 of them; at every
      // measured level of each direction, max(0, the cavity's extent - the outline's), mm.
      constexpr int kDirs = 32;
      for (int q = 0; q < kDirs; ++q) {
        const double ang = 2 * M_PI * (q + 0.5) / kDirs;
        const Eigen::Vector3d dir(std::cos(ang), std::sin(ang), 0);
        // Quarter: distal (+x) 0, palatal (+y) 1, mesial (-x) 2, buccal (-y) 3 -> M D B P order.
        const int quarter = static_cast<int>(std::floor(std::fmod(ang + M_PI / 4, 2 * M_PI) / (M_PI / 2)));
        static const int to_wall[4] = {1, 3, 0, 2};
        const std::size_t wi = static_cast<std::size_t>(to_wall[quarter]);
        const WallProfile p = wall_profile(cut, a.axis_point_m, dir, a.walls_from_z_m, a.opening_z_m, &start);
        for (std::size_t l = 0; l < p.z_m.size(); ++l) {
          const double od =
              outline_distance(m, start, Eigen::Vector3d(a.axis_point_m.x(), a.axis_point_m.y(), p.z_m[l]), dir);
          if (od <= 0) continue;
          const double e = std::max(0.0, p.extent_m[l] - od) * 1e3;
          o.wall_overextension_mean_mm[wi] += e;
          o.wall_overextension_max_mm[wi] = std::max(o.wall_overextension_max_mm[wi], e);
          o.wall_overextension_levels[wi] += 1;
          o.wall_overextension_samples.push_back({static_cast<int>(wi), q, p.z_m[l], e, od * 1e3});
        }
      }
      for (std::size_t wi = 0; wi < 4; ++wi)
        if (o.wall_overextension_levels[wi] > 0) o.wall_overextension_mean_mm[wi] /= o.wall_overextension_levels[wi];
      // Session 22: each wall's over-extension as a robust statistic (a percentile of its
      // direction-levels, linear between order statistics: one voxel column's value moves it by a
      // share of a step, not by the step), and the length along the outline it spans past the free
      // margin (each direction's arc times its share of levels beyond it).
      for (std::size_t wi = 0; wi < 4; ++wi) {
        std::vector<double> e;
        std::array<int, kDirs> n{}, beyond{};
        std::array<double, kDirs> arc{};
        for (const auto& s : o.wall_overextension_samples)
          if (s.wall == static_cast<int>(wi)) {
            e.push_back(s.e_mm);
            n[static_cast<std::size_t>(s.dir)] += 1;
            arc[static_cast<std::size_t>(s.dir)] += 2 * M_PI / kDirs * s.outline_mm;
            if (s.e_mm > ex.wall_overextension_free_mm + 1e-9) beyond[static_cast<std::size_t>(s.dir)] += 1;
          }
        o.wall_overextension_mm[wi] = percentile(e, ex.wall_overextension_percentile);
        // Session 23: the wall's area lying more than access_zone_free_mm past the outline (mm2).
        for (const auto& s : o.wall_overextension_samples)
          if (s.wall == static_cast<int>(wi) && s.e_mm > ex.access_zone_free_mm + 1e-9)
            o.wall_overextended_area_mm2[wi] += 2 * M_PI / kDirs * s.outline_mm * start.spacing().z() * 1e3;
        for (int q = 0; q < kDirs; ++q)
          if (n[static_cast<std::size_t>(q)] > 0)
            o.wall_overextension_length_mm[wi] += arc[static_cast<std::size_t>(q)] / n[static_cast<std::size_t>(q)] *
                                                  beyond[static_cast<std::size_t>(q)] / n[static_cast<std::size_t>(q)];
      }
    }
    for (const auto& w : walls) {
      const WallProfile p = wall_profile(cut, a.axis_point_m, w.dir, a.walls_from_z_m, a.opening_z_m, &start);
      Criterion c;
      c.name = w.name;
      c.value = p.divergence_deg;
      c.unit = "deg divergence";
      const double needed = 0.5 * (a.opening_z_m - a.walls_from_z_m);
      const double covered = p.z_m.size() >= 2 ? p.z_m.back() - p.z_m.front() : 0;
      if (covered < needed) {
        c.score = 0;
        c.value = 0;
        c.detail = "0 of 3: the wall is not formed: the cavity reaches it over " + fmt(covered * 1e3) + " mm of the " +
                   fmt((a.opening_z_m - a.walls_from_z_m) * 1e3) + " mm it should span (at least half is needed).";
      } else if (!continuous) {
        int s = 3;
        std::string why;
        if (p.divergence_deg < -10) { s -= 2; why += "a strong undercut (-2); "; }
        else if (p.divergence_deg < -2) { s -= 1; why += "an undercut, converging occlusally (-1); "; }
        if (p.divergence_deg > 25) { s -= 1; why += "over-flared beyond 25 deg (-1); "; }
        if (p.rms_mm > 0.3) { s -= 2; why += "rough, RMS above 0.3 mm (-2); "; }
        else if (p.rms_mm > 0.15) { s -= 1; why += "uneven, RMS above 0.15 mm (-1); "; }
        c.score = std::max(0, s);
        c.detail = std::to_string(static_cast<int>(c.score)) + " of 3: divergence " + fmt(p.divergence_deg, 1) +
                   " deg, smoothness RMS " + fmt(p.rms_mm) + " mm: " +
                   (why.empty() ? "straight and opening toward the occlusal surface." : why.substr(0, why.size() - 2) + ".");
      } else {
        // The bands' deductions as ramps: each starts where its band's tolerance ends and reaches the
        // band's deduction at the band's next threshold (undercut 1 at -10 deg, 2 at -18; roughness
        // 1 at 0.15 mm RMS, 2 at 0.30: 1 point per 0.15 mm); over-flare 1 point per
        // flare_deg_per_point past flare_free_deg (exercise fields), at most 2.
        const double under = std::clamp((-2.0 - p.divergence_deg) / 8.0, 0.0, 2.0);
        const double flare =
            std::clamp((p.divergence_deg - ex.access_flare_free_deg) / ex.access_flare_deg_per_point, 0.0, 2.0);
        const double rough = std::clamp(p.rms_mm / 0.15, 0.0, 2.0);
        c.score = std::max(0.0, 3.0 - under - flare - rough);
        std::string why = "less " + fmt(rough) + " for its roughness (1 point per 0.15 mm RMS)";
        if (under > 0) why += ", less " + fmt(under) + " for the undercut (1 point per 8 deg past -2 deg)";
        if (flare > 0)
          why += ", less " + fmt(flare) + " for over-flaring (1 point per " + fmt(ex.access_flare_deg_per_point, 0) +
                 " deg past " + fmt(ex.access_flare_free_deg, 0) + " deg)";
        c.detail = fmt(c.score) + " of 3: divergence " + fmt(p.divergence_deg, 1) + " deg, smoothness RMS " +
                   fmt(p.rms_mm) + " mm: 3 points " + why + ".";
      }
      // A formed wall earns its points for the part of the span it covers (issue 25, session 19:
      // a cut that stopped part way has not formed the rest): full from 90 % of the span (the
      // voxel layers at its two ends), in proportion below.
      if (covered >= needed) {
        const double share = std::clamp(covered / (kFullShare * span), 0.0, 1.0);
        const double quality = c.score;
        c.score = quality * share;
        if (share < 1.0)
          c.detail = fmt(c.score) + " of 3: the wall spans " + fmt(covered * 1e3) + " of the " + fmt(span * 1e3) +
                     " mm from the opening down (full points from 90 %), so " + fmt(quality) + " x " + fmt(share) +
                     ". Its shape: " + c.detail;
        else
          c.detail += " It spans " + fmt(covered * 1e3) + " of the " + fmt(span * 1e3) + " mm from the opening down.";
      }
      o.criteria.push_back(c);
    }
    // 6. Floor integrity: material removed below the pulpal floor level.
    // Judged only once the chamber is open (a clear sight line from an
    // orifice): an intact floor under an untouched roof earns nothing.
    const bool chamber_open = std::any_of(sight.begin(), sight.end(), [](double v) { return v > 0; });
    double below = 0;
    bool perf_below = false;
    const int kf = static_cast<int>(std::floor((a.floor_z_m - start.origin().z()) / start.spacing().z()));
    for (int k = 0; k <= std::min(kf, d.z() - 1); ++k)
      for (int j = 0; j < d.y(); ++j)
        for (int i = 0; i < d.x(); ++i) {
          const std::uint8_t d0 = start.density(i, j, k);
          if (d0 == 0 || start.material(i, j, k) == volume::Material::kPulp) continue;
          const std::uint8_t d1 = cut.density(i, j, k);
          if (d1 < d0) below += (d0 - d1) * unit_mm3[static_cast<std::size_t>(start.material(i, j, k))];
        }
    if (o.perforation)
      for (int k = 0; k <= std::min(kf, d.z() - 1) && !perf_below; ++k)
        for (int j = 0; j < d.y() && !perf_below; ++j)
          for (int i = 0; i < d.x(); ++i)
            if (start.density(i, j, k) > kIsoDensity && cut.density(i, j, k) < kIsoDensity &&
                !(m.bits[m.index(i, j, k)] & m.entry_bits)) {
              for (const auto& n : nb)
                if (start.density(i + n[0], j + n[1], k + n[2]) == 0) perf_below = true;
              if (perf_below) break;
            }
    // 6. How much of the floor the access reached: the access outline's footprint at the floor (the
    // columns holding a target voxel between floor_z and floor_z + 0.5 mm), and of it the columns
    // open from above the tooth straight down to within 0.5 mm of floor_z (cut, or the chamber's
    // own space under a removed roof).
    int foot = 0, reached = 0;
    {
      const double slab = 0.5e-3;
      const int k0 = std::max(0, static_cast<int>(std::ceil((a.floor_z_m - start.origin().z()) / start.spacing().z() - 1e-9)));
      const int k1 = std::min(d.z() - 1, static_cast<int>(std::floor((a.floor_z_m + slab - start.origin().z()) / start.spacing().z() + 1e-9)));
      for (int j = 0; j < d.y(); ++j)
        for (int i = 0; i < d.x(); ++i) {
          bool in = false;
          for (int k = k0; k <= k1 && !in; ++k) in = (m.bits[m.index(i, j, k)] & m.target_bits) != 0;
          if (!in) continue;
          ++foot;
          int k = d.z() - 1;
          while (k >= 0 && cut.density(i, j, k) < kIsoDensity) --k;
          if (k < k1) ++reached;  // open down to (below) the slab's top layer
        }
    }
    o.floor_below_mm3 = below;
    o.floor_perforated = perf_below;
    const double reach = foot > 0 ? static_cast<double>(reached) / foot : 0.0;
    const double share = std::clamp(reach / kFloorFullReach, 0.0, 1.0);
    Criterion fl;
    fl.name = "pulpal floor";
    fl.value = below;
    fl.unit = "mm3 removed below the floor";
    if (perf_below) {
      fl.score = 0;
      fl.detail = "0 of 3: the floor is perforated.";
    } else if (!chamber_open) {
      fl.score = 0;
      fl.detail = "0 of 3: the pulp chamber was not opened (no clear sight line from any orifice), so there is no "
                  "floor to judge yet.";
    } else if (!continuous) {
      fl.score = below < 0.05 ? 3 : below < 0.3 ? 2 : below < kFloorZeroMm3 ? 1 : 0;
      fl.detail = std::to_string(static_cast<int>(fl.score)) + " of 3: " + fmt(below, 3) +
                  " mm3 of dentin removed below the floor level; 3 needs less than 0.05 mm3, 2 less than 0.3, 1 less "
                  "than 1.0.";
    } else {
      // 3 points less 3 per mm3 removed below the floor: nothing left at the bands' 1.0 mm3.
      fl.score = 3.0 * std::clamp(1.0 - below / kFloorZeroMm3, 0.0, 1.0);
      fl.detail = fmt(fl.score) + " of 3: " + fmt(below, 3) +
                  " mm3 of dentin removed below the floor level; 3 points less 3 for every mm3 (none left at 1 mm3).";
    }
    if (!perf_below && chamber_open) {
      // The floor pays only for the part of it the access reached (issue 25, session 19: a session
      // that stopped with one sight line clear used to earn all 3 points for a floor it never
      // opened). The detail's first figure is then the final score.
      const double intact = fl.score;
      fl.score = intact * share;
      const std::string what = fl.detail.substr(fl.detail.find(" of 3: ") + 7);
      const bool whole = fl.score == std::floor(fl.score);
      fl.detail = (continuous || !whole ? fmt(fl.score) : std::to_string(static_cast<int>(fl.score))) + " of 3: " +
                  fmt(100 * reach, 0) + " % of the floor reached (the access outline's " +
                  "footprint open from above to within 0.5 mm of the floor level; full points from " +
                  fmt(100 * kFloorFullReach, 0) + " %), times " + fmt(intact) + " for its integrity: " + what;
    }
    o.criteria.push_back(fl);
    o.max_points = 18;
    for (const auto& c : o.criteria) o.earned_points += c.score;
  } else {
    o.max_points = ex.max_points();
    for (const auto& r : o.regions) o.earned_points += r.points;
    if (ex.wall_taper) {
      o.criteria.push_back(wall_taper_criterion(*ex.wall_taper, start, m, cut));
      apply_coverage_share(o.criteria.back(), ex.wall_taper->coverage_full_pct, ex.wall_taper->coverage_cap,
                           o.target_coverage_pct, "the target");
      o.earned_points += o.criteria.back().score;
    }
    if (ex.outline_extension) {
      o.criteria.push_back(outline_extension_criterion(*ex.outline_extension, start, m, cut));
      o.earned_points += o.criteria.back().score;
    }
    if (floor_region < nr) {
      o.criteria.push_back(floor_depth_criterion(*ex.floor_depth, floor_region, start, m, cut));
      double cov = o.target_coverage_pct;
      for (const auto& r : o.regions)
        if (r.name == ex.floor_depth->from_region) cov = r.coverage_pct;
      apply_coverage_share(o.criteria.back(), ex.floor_depth->coverage_full_pct, ex.floor_depth->coverage_cap, cov,
                           "region " + ex.floor_depth->from_region);
      o.earned_points += o.criteria.back().score;
    }
  }
  // Pulp exposure: the bur entered the pulp (pulp tissue removed). Opening
  // the last dentin voxel over it without removing pulp is reported
  // (pulp_wall_opened) but not charged: at 0.1-0.2 mm voxels that is a
  // remaining dentin layer under one voxel, which the voxel grid cannot tell
  // from an exposure (issue 25: it charged a generated expert's class I
  // cavity all 10 points with 0.000 mm3 of pulp removed).
  o.pulp_exposed = o.pulp_removed_mm3 > 0;
  // Costs the exercise charges.
  if (o.pulp_exposed) {
    const double full = ex.pulp_exposure_points();
    const double c = ex.pulp_exposure_charge(o.pulp_removed_mm3);
    o.pulp_exposure_mm = Exercise::pulp_exposure_size_mm(o.pulp_removed_mm3);
    std::string why;
    if (full <= 0) {
      why = "the cut opened into the pulp, as this exercise requires (it charges nothing for it).";
    } else if (ex.pulp_exposure_full_mm <= 0) {
      why = "the cut opened into the pulp (" + fmt(o.pulp_removed_mm3, 3) + " mm3 of pulp removed); this exercise "
            "charges " + fmt(full, 1) + " points for it.";
    } else {
      // Graded (issue 25, session 15): a pinpoint exposure is not the same fault as a wide one.
      why = "the cut opened into the pulp (" + fmt(o.pulp_removed_mm3, 3) + " mm3 of pulp removed, an exposure about " +
            fmt(o.pulp_exposure_mm) + " mm across); this exercise charges " + fmt(full, 1) +
            " points for an exposure " + fmt(ex.pulp_exposure_full_mm, 1) + " mm across or wider and " +
            (ex.pulp_exposure_min_fraction > 0 ? "at least " + fmt(full * ex.pulp_exposure_min_fraction, 1) + " for any, "
                                               : "") +
            "in proportion to its size in between: " + fmt(c, 1) + " points.";
    }
    o.penalties.push_back({"pulp exposure", c, why});
  }
  if (o.perforation) {
    const double c = ex.perforation_points();
    o.penalties.push_back({"perforation", c,
                           "the cut opened the tooth to the outside away from the entry surface (" +
                               fmt(o.perforation_mm3, 3) + " mm3); this exercise charges " + fmt(c, 1) + " points for it."});
  }
  if (overflow_points > 0) {
    o.penalties.push_back(
        {overflow_split ? "over-extended outline" : "cut too far", overflow_points,
         fmt(overflow_mm3) + (overflow_split ? " mm3 cut too far past the walls" : " mm3 cut too far") +
             " (within the zone) cost more than the region's coverage earned (" + overflow_what +
             "); the rest is a cost of the whole preparation, not dropped: " + fmt(overflow_points) + " points."});
  }
  // Over-reduction: sound tooth cut away beyond the tolerance around the
  // outline, at the exercise's price per mm3 of target (issue 25, session 11).
  if (ex.over_reduction_rate > 0 && o.beyond_zone_mm3 > 0 && o.target_mm3 > 0) {
    const double per_mm3 = ex.over_reduction_rate * o.max_points / o.target_mm3;
    const double c = std::min(o.max_points, per_mm3 * o.beyond_zone_mm3);
    std::string zones;
    for (const auto& R : ex.regions)
      if (R.role == RegionRole::kTarget)
        zones += (zones.empty() ? "" : ", ") + R.name + " " + fmt(R.zone_mm, 1) + " mm";
    o.penalties.push_back(
        {"over-reduction", c,
         fmt(o.beyond_zone_mm3) + " mm3 of sound tooth was cut away beyond the tolerance around the outline (" + zones +
             "); this exercise charges " + fmt(per_mm3, 3) + " points per mm3 (" + fmt(ex.over_reduction_rate, 2) +
             // The price's own figures (issue 25, session 20): "what a mm3 of target left standing costs"
             // read as 0.579 beside the class I cavity's 0.405 per mm3 (its 7 of the 10 points).
             " x the exercise's " + fmt(o.max_points, 0) + " points over its " + fmt(o.target_mm3) +
             " mm3 of target): " + fmt(c, 1) + " points."});
  }
  if (access && ex.access_zone_rate > 0 && o.access_zone_mm3 > 0 && o.target_mm3 > 0) {
    // Over-extended outline (issue 25, session 21: shipped at rate 1 with 0.15 mm free). Tooth cut
    // away outside the access outline weakens the walls and cannot be undone: an endodontist marks
    // an over-extended access down however good its walls' shape. What lies more than
    // access_zone_free_mm outside the outline costs rate x (the exercise's points over the access
    // target's volume) per mm3, what a mm3 of the access left standing would cost.
    double access_zone = 0;
    for (const auto& R : ex.regions)
      if (R.role == RegionRole::kTarget) access_zone = std::max(access_zone, R.zone_mm);
    const double per_mm3 = ex.access_zone_rate * o.max_points / o.target_mm3;
    // Session 23: one penalty per wall, the wall's own mm3 past the free margin (the voxels in its
    // quarter around the axis), so that a local gouge costs by its size and the sentences add up to
    // the whole charge; each names the wall's area past the margin and how far past it reaches.
    static const char* kWall[4] = {"mesial", "distal", "buccal", "palatal"};
    double left = o.max_points;  // the charges together cost at most the exercise's points
    for (std::size_t w = 0; w < 4; ++w) {
      double cw = 0, all = 0;
      const auto& wb = o.access_zone_by_wall_band_mm3[w];
      for (std::size_t q = 0; q < wb.size(); ++q) {
        all += wb[q];
        if (0.05 * static_cast<double>(q) >= ex.access_zone_free_mm - 1e-9) cw += wb[q];
      }
      // Less than 0.005 mm3 (a voxel's sliver, "0.00 mm3" in its sentence) is not charged.
      if (cw < 0.005) cw = 0;
      o.access_zone_charged_by_wall_mm3[w] = cw;
      if (cw <= 0) continue;
      const double raw = per_mm3 * cw;
      const double c = std::min(left, raw);
      left -= c;
      o.penalties.push_back(
          {std::string("over-extended outline, ") + kWall[w] + " wall", c,
           std::string(kWall[w]) + " wall: " + fmt(cw) + " mm3 of sound tooth above the floor was cut away more than " +
               fmt(ex.access_zone_free_mm) + " mm outside the access outline (within its " + fmt(access_zone, 1) +
               " mm zone" + (all - cw > 0.005 ? "; " + fmt(all - cw) + " mm3 nearer, not charged" : "") + "), over " +
               fmt(o.wall_overextended_area_mm2[w], 1) + " mm2 of the wall, up to " +
               fmt(o.wall_overextension_max_mm[w]) + " mm past the outline (mean depth past the margin " +
               fmt(o.wall_overextended_area_mm2[w] > 0.05 ? cw / o.wall_overextended_area_mm2[w] : 0.0) +
               " mm); an over-extended access weakens the tooth; this exercise charges " + fmt(per_mm3, 3) +
               " points per mm3 (" + fmt(ex.access_zone_rate, 2) + " x its " + fmt(o.max_points, 0) +
               " points over the access's " + fmt(o.target_mm3) + " mm3): " + fmt(per_mm3, 3) + " x " + fmt(cw) +
               " = " + fmt(raw) + " points" +
               (raw > c ? " (the charges together at most the exercise's " + fmt(o.max_points, 0) + ": " + fmt(c) + ")."
                        : ".")});
    }
    // The whole charge: the walls' own (what lies past the margin, less the walls' slivers).
    o.access_zone_charged_mm3 = 0;
    for (double v : o.access_zone_charged_by_wall_mm3) o.access_zone_charged_mm3 += v;
  }
  if (access && ex.under_extension_rate > 0 && o.target_mm3 > 0 &&
      o.target_coverage_pct < ex.under_extension_full_pct - 1e-9) {
    // The access left standing (issue 25, session 23): the walls and the floor earn by the span and
    // the footprint they reach, but nothing measured an outline that stops short of the access's
    // outline; an endodontist marks an under-extended access (a roof or dentin left over the
    // chamber's corners, files bent around it) as surely as an over-extended one. What is left of
    // the access target below the exercise's full share costs what a mm3 cut outside it costs.
    const double short_mm3 = (ex.under_extension_full_pct - o.target_coverage_pct) / 100 * o.target_mm3;
    const double per_mm3 = ex.under_extension_rate * o.max_points / o.target_mm3;
    const double raw = per_mm3 * short_mm3;
    const double c = std::min(o.max_points, raw);
    o.penalties.push_back(
        {"under-extended access", c,
         fmt(100 - o.target_coverage_pct, 0) + " % of the access (" +
             fmt((100 - o.target_coverage_pct) / 100 * o.target_mm3) + " mm3 of " + fmt(o.target_mm3) +
             " mm3) was left standing, " + fmt(short_mm3) + " mm3 more than the " +
             fmt(100 - ex.under_extension_full_pct, 0) + " % a finished access may leave (full from " +
             fmt(ex.under_extension_full_pct, 0) + " % removed); an under-extended access leaves dentin over the " +
             "chamber and bends the files; this exercise charges " + fmt(per_mm3, 3) + " points per mm3 (" +
             fmt(ex.under_extension_rate, 2) + " x its " + fmt(o.max_points, 0) + " points over the access's " +
             fmt(o.target_mm3) + " mm3): " + fmt(per_mm3, 3) + " x " + fmt(short_mm3) + " = " + fmt(raw) + " points" +
             (raw > c ? " (at most the exercise's " + fmt(o.max_points, 0) + ")." : ".")});
  }
  if (access && ex.floor_overflow_rate > 0 && o.target_mm3 > 0 && !o.floor_perforated &&
      o.floor_below_mm3 > kFloorZeroMm3 + 1e-9) {
    // The floor gouged past its criterion (issue 25, session 23): the floor's integrity reaches 0 at
    // 1 mm3 removed below the floor level, and removal below the floor is not counted as cut outside
    // the access, so 7 mm3 gouged into the furcation cost what 1 mm3 did. What lies past that 1 mm3
    // costs what sound tooth cut outside the outline costs.
    const double past = o.floor_below_mm3 - kFloorZeroMm3;
    const double per_mm3 = ex.floor_overflow_rate * o.max_points / o.target_mm3;
    const double raw = per_mm3 * past;
    const double c = std::min(o.max_points, raw);
    o.penalties.push_back(
        {"floor gouged", c,
         fmt(o.floor_below_mm3) + " mm3 of dentin was removed below the pulpal floor level, " + fmt(past) +
             " mm3 past the " + fmt(kFloorZeroMm3, 0) + " mm3 at which the floor's integrity reaches 0; a gouged " +
             "floor risks the furcation; this exercise charges " + fmt(per_mm3, 3) + " points per mm3 (" +
             fmt(ex.floor_overflow_rate, 2) + " x its " + fmt(o.max_points, 0) + " points over the access's " +
             fmt(o.target_mm3) + " mm3): " + fmt(per_mm3, 3) + " x " + fmt(past) + " = " + fmt(raw) + " points" +
             (raw > c ? " (at most the exercise's " + fmt(o.max_points, 0) + ")." : ".")});
  }
  if (access && ex.wall_overextension_points_per_mm > 0) {
    // Over-extended walls (issue 25, session 22): an endodontist reads an over-extended access by how
    // far each wall lies past the outline, in mm, as class I's outline extension is graded. Each wall
    // costs points_per_mm x (its over-extension - the free margin), its over-extension the
    // exercise's percentile of its direction-levels (docs/formats.md "Over-extended access walls").
    static const char* kWallName[4] = {"mesial", "distal", "buccal", "palatal"};
    for (std::size_t w = 0; w < 4; ++w) {
      // Priced as reported, to 0.01 mm, so that the sentence's product is its points.
      const double shown = std::round(100 * o.wall_overextension_mm[w]) / 100;
      const double over = shown - ex.wall_overextension_free_mm;
      if (over <= 1e-9 || o.wall_overextension_levels[w] == 0) continue;
      const double raw = ex.wall_overextension_points_per_mm * over;
      const double c = std::min(o.max_points, raw);
      o.penalties.push_back(
          {std::string(kWallName[w]) + " wall over-extended", c,
           std::string(kWallName[w]) + " wall over-extended " + fmt(shown) + " mm past the access outline over " +
               fmt(o.wall_overextension_length_mm[w], 1) + " mm of its length (percentile " +
               fmt(ex.wall_overextension_percentile, 0) + " of its " + std::to_string(o.wall_overextension_levels[w]) +
               " direction-levels, mean " +
               fmt(o.wall_overextension_mean_mm[w]) + ", largest " + fmt(o.wall_overextension_max_mm[w]) +
               " mm); an over-extended wall weakens the tooth; this exercise charges " +
               fmt(ex.wall_overextension_points_per_mm, 2) + " points per mm past " +
               fmt(ex.wall_overextension_free_mm) + " mm: " + fmt(ex.wall_overextension_points_per_mm, 2) + " x " +
               fmt(over) + " = " + fmt(raw) + " points" +
               (raw > c ? " (at most the exercise's " + fmt(o.max_points, 0) + ": " + fmt(c) + ")." : ".")});
    }
  }
  double cost = 0;
  for (const auto& p : o.penalties) cost += p.points;
  o.points = std::max(0.0, o.earned_points - cost);
  // Finished or not.
  std::string missing;
  if (o.target_coverage_pct < ex.complete_coverage_pct)
    missing = fmt(o.target_coverage_pct, 0) + " % of the target was removed, a finished preparation removes at least " +
              fmt(ex.complete_coverage_pct, 0) + " %";
  if (ex.outcome == OutcomeKind::kAccessOpening && ex.access)
    for (std::size_t i = 0; i < sight.size(); ++i)
      if (sight[i] < ex.complete_orifice_sight) {
        missing += std::string(missing.empty() ? "" : "; ") + "the " + ex.access->orifices[i].name +
                   " orifice cannot be seen (" + fmt(100 * sight[i], 0) + " % of its sight lines clear, at least " +
                   fmt(100 * ex.complete_orifice_sight, 0) + " % needed)";
      }
  o.complete = missing.empty();
  o.completion = o.complete ? "finished: " + fmt(o.target_coverage_pct, 0) + " % of the target removed."
                            : "incomplete: " + missing + ".";
  return o;
}

}  // namespace dentar::training
