#include "dentar/volume/cutter.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "bur_sdf.h"

namespace dentar::volume {

std::string CutParams::validate() const {
  std::ostringstream os;
  if (!std::isfinite(base_rate_per_s) || base_rate_per_s < 0)
    os << "base_rate_per_s = " << base_rate_per_s << " must be finite and >= 0";
  else if (!std::isfinite(reference_force_N) || reference_force_N <= 0)
    os << "reference_force_N = " << reference_force_N << " must be > 0";
  else if (!std::isfinite(max_effective_force_N) || max_effective_force_N <= 0)
    os << "max_effective_force_N = " << max_effective_force_N << " must be > 0";
  else if (!std::isfinite(min_force_N) || min_force_N < 0 || min_force_N > max_effective_force_N)
    os << "min_force_N = " << min_force_N << " must be in [0, max_effective_force_N]";
  return os.str();
}

std::uint64_t CutResult::total_removed() const {
  std::uint64_t s = 0;
  for (auto r : removed) s += r;
  return s;
}

namespace {
// Volume fraction of a voxel represented by `units` of density of material m.
double units_to_voxels(std::uint64_t units, int m) {
  const double full = material_info(m).full_density;
  return full > 0 ? static_cast<double>(units) / full : 0.0;
}
}  // namespace

Cutter::Cutter(VoxelVolume& volume, const CutParams& params) : vol_(&volume), params_(params) {
  const auto sums = volume.density_sum_by_material();
  for (int m = 1; m < kMaxMaterials; ++m) original_units_ += units_to_voxels(sums[static_cast<std::size_t>(m)], m);
}

inline void Cutter::cut_voxel(CutResult& res, VoxelVolume::Chunk& c, std::size_t li,
                              std::uint8_t mat, int i, int j, int k, double overlap_m3,
                              std::uint32_t amount_fx, std::uint32_t dither, bool cutting,
                              std::uint64_t step_index, Eigen::Vector3i& lo,
                              Eigen::Vector3i& hi) noexcept {
  ++res.samples_in_solid;
  res.overlap_m3 += overlap_m3;
  if (mat == static_cast<std::uint8_t>(Material::kPulp)) {
    res.touched_pulp = true;
    if (cutting && !exposure_) exposure_ = PulpExposure{step_index, vol_->voxel_center(i, j, k)};
  }
  const std::uint32_t units = (amount_fx + dither) >> 16;
  if (units == 0) return;
  std::uint8_t& d = c.density[li];
  const std::uint8_t removed = static_cast<std::uint8_t>(std::min<std::uint32_t>(units, d));
  d = static_cast<std::uint8_t>(d - removed);
  if (d == 0) c.material[li] = 0;  // fully removed: becomes air
  res.removed[mat & (kMaxMaterials - 1)] += removed;
  lo = lo.cwiseMin(Eigen::Vector3i(i, j, k));
  hi = hi.cwiseMax(Eigen::Vector3i(i, j, k));
}

inline void Cutter::finish_step(const CutResult& res, const Eigen::Vector3i& lo,
                                const Eigen::Vector3i& hi) noexcept {
  if (hi.x() < 0) return;
  // A changed voxel moves vertices of cells down to lo-1 and, through the
  // gradient, normals of cells down to lo-2 and up to hi+1.
  vol_->mark_dirty_box(lo - Eigen::Vector3i::Constant(2), hi + Eigen::Vector3i::Constant(1));
  for (int m = 0; m < kMaxMaterials; ++m)
    removed_total_[static_cast<std::size_t>(m)] += res.removed[static_cast<std::size_t>(m)];
}

CutResult Cutter::step(const BurSamples& bur, const Eigen::Isometry3d& T_tooth_tip,
                       double force_N, double dt_s) noexcept {
  CutResult res;
  const std::uint64_t step_index = step_++;
  if (!std::isfinite(force_N) || !std::isfinite(dt_s) || dt_s <= 0 ||
      !T_tooth_tip.matrix().allFinite())
    return res;
  if (params_.overlap) {
    const double f = std::min(force_N, params_.max_effective_force_N);
    const bool cutting = f >= params_.min_force_N && f > 0;
    return step_overlap(bur.params, T_tooth_tip, f, cutting, dt_s, step_index);
  }

  const VolumeGeometry& g = vol_->geometry();
  // Map tip-frame metres straight to continuous voxel coordinates:
  // v = diag(1/spacing) * (R p + t - origin).
  const Eigen::Vector3d inv_s = g.spacing.cwiseInverse();
  const Eigen::Matrix3f M = (inv_s.asDiagonal() * T_tooth_tip.linear()).cast<float>();
  // +0.5 so that floor() rounds to the nearest voxel centre.
  Eigen::Vector3d t = T_tooth_tip.translation();
  if (params_.sample_jitter) {
    // R3 sequence (fractional parts of n * (1/phi3, 1/phi3^2, 1/phi3^3)),
    // centred: an offset in [-s/2, s/2)^3 for the mean sample spacing s.
    const double n = static_cast<double>(step_index % 1000003u);
    const double s = std::cbrt(bur.sample_volume_m3);
    Eigen::Vector3d u(0.5 + n * 0.8191725133961645, 0.5 + n * 0.6710436067037893,
                      0.5 + n * 0.5497004779019703);
    for (int a = 0; a < 3; ++a) u(a) -= std::floor(u(a));
    t += T_tooth_tip.linear() * ((u - Eigen::Vector3d::Constant(0.5)) * s);
  }
  const Eigen::Vector3f b =
      (inv_s.cwiseProduct(t - g.origin) + Eigen::Vector3d::Constant(0.5)).cast<float>();

  // Density units each sample removes per material this step. A sample
  // stands for sample_volume of bur, so the per-voxel rate does not depend on
  // the sample count.
  const double f = std::min(force_N, params_.max_effective_force_N);
  const bool cutting = f >= params_.min_force_N && f > 0;
  const double per_sample = cutting ? params_.base_rate_per_s * (f / params_.reference_force_N) *
                                          dt_s * (bur.sample_volume_m3 / vol_->voxel_volume_m3())
                                    : 0.0;
  // Fixed point, 16 fractional bits; ordered dithering turns the fraction into
  // whole units deterministically (a sample index / step index sequence).
  std::array<std::uint32_t, kMaxMaterials> amount_fx{};
  for (int m = 1; m < kMaxMaterials; ++m) {
    const double a = per_sample * material_info(m).removal_rate * 65536.0;
    amount_fx[static_cast<std::size_t>(m)] =
        static_cast<std::uint32_t>(std::clamp(a, 0.0, 255.0 * 65536.0));
  }

  const int nx = g.dims.x(), ny = g.dims.y(), nz = g.dims.z();
  const float fx = static_cast<float>(nx), fy = static_cast<float>(ny), fz = static_cast<float>(nz);
  Eigen::Vector3i lo(nx, ny, nz), hi(-1, -1, -1);
  const std::uint32_t step_phase = static_cast<std::uint32_t>(step_index) * 0x632BE5ABu;
  const std::size_t n = bur.points_m.size();
  for (std::size_t s = 0; s < n; ++s) {
    const Eigen::Vector3f v = M * bur.points_m[s] + b;
    // In-bounds coordinates are >= 0, where truncation equals floor (and is
    // much cheaper than std::floor without SSE4.1). NaN fails the tests too.
    if (!(v.x() >= 0.f && v.y() >= 0.f && v.z() >= 0.f && v.x() < fx && v.y() < fy &&
          v.z() < fz))
      continue;
    const int i = static_cast<int>(v.x()), j = static_cast<int>(v.y()), k = static_cast<int>(v.z());
    VoxelVolume::Chunk* c = vol_->chunk(vol_->chunk_id(i >> 4, j >> 4, k >> 4));
    if (!c) continue;  // absent chunk: all air
    const auto li = static_cast<std::size_t>(chunk_local_index(i & 15, j & 15, k & 15));
    const std::uint8_t mat = c->material[li];
    if (mat == 0 || c->density[li] == 0) continue;
    const std::uint32_t dither = (static_cast<std::uint32_t>(s) * 0x9E3779B9u + step_phase) >> 16;
    cut_voxel(res, *c, li, mat, i, j, k, bur.sample_volume_m3,
              amount_fx[mat & (kMaxMaterials - 1)], dither, cutting, step_index, lo, hi);
  }
  finish_step(res, lo, hi);
  return res;
}

// The overlap cutter. Visits the voxels whose centre lies within half a voxel
// of the bur (coarse to fine: 16^3 chunks, then 4^3 blocks, each skipped when
// the bur's signed distance at its centre proves it is out of reach, or taken
// whole when it proves it is inside), and lowers each solid voxel's density by
// share x base_rate x force factor x material rate x dt, share = the part of
// the voxel inside the bur (linear in the signed distance across one voxel:
// exact for a plane through the voxel along an axis, and the shares of a
// voxel grid sum to the bur's volume). No sample is involved, so the count the
// bur is sampled at does not change what it removes.
CutResult Cutter::step_overlap(const BurParams& bp, const Eigen::Isometry3d& T_tooth_tip,
                               double f, bool cutting, double dt_s,
                               std::uint64_t step_index) noexcept {
  CutResult res;
  const VolumeGeometry& g = vol_->geometry();
  const double h = std::cbrt(vol_->voxel_volume_m3());
  const double inv_h = 1.0 / h;
  // Tip-frame position of voxel (i, j, k)'s centre: c0 + i ax + j ay + k az.
  const Eigen::Matrix3d Rt = T_tooth_tip.linear().transpose();
  const Eigen::Vector3d c0 = Rt * (g.origin - T_tooth_tip.translation());
  const Eigen::Vector3d ax = Rt.col(0) * g.spacing.x(), ay = Rt.col(1) * g.spacing.y(),
                        az = Rt.col(2) * g.spacing.z();

  // Voxel index range: centres within 0.5 h of the bur's tip-frame box.
  const double r = bp.radius_m + 0.5 * h;
  const double z_lo = -(bp.shape == BurShape::kSphere ? 2.0 * bp.radius_m : bp.length_m) - 0.5 * h;
  const double z_hi = 0.5 * h;
  Eigen::Vector3d vmin = Eigen::Vector3d::Constant(1e300), vmax = Eigen::Vector3d::Constant(-1e300);
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3d p_tip((c & 1) ? r : -r, (c & 2) ? r : -r, (c & 4) ? z_hi : z_lo);
    const Eigen::Vector3d v =
        (T_tooth_tip * p_tip - g.origin).cwiseQuotient(g.spacing);  // continuous voxel index
    vmin = vmin.cwiseMin(v);
    vmax = vmax.cwiseMax(v);
  }
  Eigen::Vector3i lo, hi;
  for (int a = 0; a < 3; ++a) {
    lo(a) = std::max(0, static_cast<int>(std::ceil(vmin(a))));
    hi(a) = std::min(g.dims(a) - 1, static_cast<int>(std::floor(vmax(a))));
    if (lo(a) > hi(a)) return res;
  }

  // Density units a voxel wholly inside the bur loses this step, per material,
  // 16 fractional bits.
  std::array<double, kMaxMaterials> amount_fx{};
  if (cutting)
    for (int m = 1; m < kMaxMaterials; ++m)
      amount_fx[static_cast<std::size_t>(m)] =
          std::min(params_.base_rate_per_s * (f / params_.reference_force_N) * dt_s *
                       material_info(m).removal_rate * 65536.0,
                   255.0 * 65536.0);
  const double voxel_m3 = vol_->voxel_volume_m3();
  const double chunk_reach = 0.5 * h + 0.5 * (15.0 * g.spacing).norm();
  const double block_reach = 0.5 * h + 0.5 * (3.0 * g.spacing).norm();
  // 2^3 sub-blocks of a block the bur's surface passes through: every voxel centre lies
  // within half the sub-block's diagonal of its centre, and the signed distance is
  // 1-Lipschitz, so a sub-block centre further than pair_reach outside the bur proves
  // each voxel's share 0 (the per-voxel path would skip it) and one further than
  // pair_reach inside proves each share exactly 1 (the clamp's value). The margin (a
  // millionth of a voxel) covers the rounding of the two centres, so either way the
  // voxel gets the bits the per-voxel path would give it.
  const double pair_reach = 0.5 * h + 0.5 * g.spacing.norm() + 1e-6 * h;
  const std::uint32_t step_phase = static_cast<std::uint32_t>(step_index) * 0x632BE5ABu;
  Eigen::Vector3i clo(g.dims), chi(-1, -1, -1);

  for (int ck = lo.z() >> 4; ck <= hi.z() >> 4; ++ck)
    for (int cj = lo.y() >> 4; cj <= hi.y() >> 4; ++cj)
      for (int ci = lo.x() >> 4; ci <= hi.x() >> 4; ++ci) {
        const int cid = vol_->chunk_id(ci, cj, ck);
        VoxelVolume::Chunk* c = vol_->chunk(cid);
        if (!c) continue;  // absent chunk: all air
        const Eigen::Vector3d cc = c0 + (16.0 * ci + 7.5) * ax + (16.0 * cj + 7.5) * ay + (16.0 * ck + 7.5) * az;
        if (detail::bur_signed_distance(bp, cc) >= chunk_reach) continue;
        for (int bk = 0; bk < 16; bk += 4)
          for (int bj = 0; bj < 16; bj += 4)
            for (int bi = 0; bi < 16; bi += 4) {
              const int x0 = 16 * ci + bi, y0 = 16 * cj + bj, z0 = 16 * ck + bk;  // block origin
              const int i0 = std::max(x0, lo.x()), i1 = std::min(x0 + 3, hi.x());
              const int j0 = std::max(y0, lo.y()), j1 = std::min(y0 + 3, hi.y());
              const int k0 = std::max(z0, lo.z()), k1 = std::min(z0 + 3, hi.z());
              if (i0 > i1 || j0 > j1 || k0 > k1) continue;
              // No solid voxel in the block's part in range: nothing to do, no distance.
              bool any_solid = false;
              for (int k = k0; k <= k1 && !any_solid; ++k)
                for (int j = j0; j <= j1 && !any_solid; ++j) {
                  const std::uint8_t* row = c->material.data() + chunk_local_index(i0 & 15, j & 15, k & 15);
                  for (int i = 0; i <= i1 - i0; ++i) any_solid = any_solid || row[i] != 0;
                }
              if (!any_solid) continue;
              const Eigen::Vector3d bc = c0 + (16.0 * ci + bi + 1.5) * ax +
                                         (16.0 * cj + bj + 1.5) * ay + (16.0 * ck + bk + 1.5) * az;
              const double bd = detail::bur_signed_distance(bp, bc);
              if (bd >= block_reach) continue;
              const bool whole = bd <= -block_reach;  // every voxel wholly inside
              // Sub-block classes, found at the first solid voxel of each: -1 not yet,
              // 0 out of reach, 1 wholly inside, 2 per voxel. The voxels are still
              // visited in the same order (the first pulp exposure and the overlap sum
              // depend on it).
              std::int8_t pair_class[8] = {-1, -1, -1, -1, -1, -1, -1, -1};
              for (int k = k0; k <= k1; ++k)
                for (int j = j0; j <= j1; ++j)
                  for (int i = i0; i <= i1; ++i) {
                    const auto li = static_cast<std::size_t>(chunk_local_index(i & 15, j & 15, k & 15));
                    const std::uint8_t mat = c->material[li];
                    if (mat == 0 || c->density[li] == 0) continue;
                    double share = 1.0;
                    if (!whole) {
                      const int sx = (i - x0) >> 1, sy = (j - y0) >> 1, sz = (k - z0) >> 1;
                      std::int8_t& pc = pair_class[sx + 2 * sy + 4 * sz];
                      if (pc < 0) {
                        const Eigen::Vector3d pcen = c0 + (x0 + 2.0 * sx + 0.5) * ax +
                                                     (y0 + 2.0 * sy + 0.5) * ay + (z0 + 2.0 * sz + 0.5) * az;
                        const double pd = detail::bur_signed_distance(bp, pcen);
                        pc = pd >= pair_reach ? 0 : pd <= -pair_reach ? 1 : 2;
                      }
                      if (pc == 0) continue;
                      if (pc == 2) {
                        const double sd = detail::bur_signed_distance(bp, c0 + i * ax + j * ay + k * az);
                        share = std::clamp(0.5 - sd * inv_h, 0.0, 1.0);
                        if (share <= 0.0) continue;
                      }
                    }
                    const std::uint32_t dither =
                        (static_cast<std::uint32_t>(li) * 0x9E3779B9u +
                         static_cast<std::uint32_t>(cid) * 0x85EBCA6Bu + step_phase) >> 16;
                    cut_voxel(res, *c, li, mat, i, j, k, share * voxel_m3,
                              static_cast<std::uint32_t>(amount_fx[mat & (kMaxMaterials - 1)] * share),
                              dither, cutting, step_index, clo, chi);
                  }
            }
      }
  finish_step(res, clo, chi);
  return res;
}

CutMetrics Cutter::metrics() const {
  CutMetrics out;
  const double voxel_mm3 = vol_->voxel_volume_m3() * 1e9;
  for (int m = 1; m < kMaxMaterials; ++m) {
    const double v = units_to_voxels(removed_total_[static_cast<std::size_t>(m)], m) * voxel_mm3;
    out.removed_mm3[static_cast<std::size_t>(m)] = v;
    out.removed_total_mm3 += v;
  }
  out.original_tooth_mm3 = original_units_ * voxel_mm3;
  out.removed_percent =
      out.original_tooth_mm3 > 0 ? 100.0 * out.removed_total_mm3 / out.original_tooth_mm3 : 0.0;
  out.pulp_exposure = exposure_;
  return out;
}

}  // namespace dentar::volume
