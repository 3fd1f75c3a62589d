// Procedural maxillary first molar built from signed distance functions (mm).
// Anatomy (typical textbook values): crown 10 x 11 mm, crown height ~7 mm,
// four cusps, enamel ~1.5 mm occlusally thinning to 0 at the cervical line,
// an adult pulp chamber (roof 0.8 mm above the cervical line, 6.2 mm under the
// cusp tips: MolarParams::pulp_roof_mm) with four horns toward the cusps, and
// three roots (mesiobuccal, distobuccal, palatal) with one canal each.
#include "dentar/volume/procedural_tooth.h"

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <thread>

namespace dentar::volume {

std::string MolarParams::validate() const {
  std::ostringstream os;
  auto check = [&](const char* name, double v, double lo, double hi) {
    if (!os.str().empty()) return;
    if (!std::isfinite(v) || v < lo || v > hi)
      os << name << " = " << v << " mm is outside [" << lo << ", " << hi << "]";
  };
  check("voxel_mm", voxel_mm, 0.02, 0.5);
  check("crown_mesiodistal_mm", crown_mesiodistal_mm, 6, 14);
  check("crown_buccolingual_mm", crown_buccolingual_mm, 6, 14);
  check("crown_height_mm", crown_height_mm, 4.5, 10);
  check("enamel_mm", enamel_mm, 0.3, 2.5);
  check("root_length_mm", root_length_mm, 6, 20);
  check("cusp_height_mm", cusp_height_mm, 0.3, 3);
  check("pulp_horn_mm", pulp_horn_mm, 0, 2.5);
  check("pulp_roof_mm", pulp_roof_mm, 0, crown_height_mm - 1.0);
  check("canal_radius_mm", canal_radius_mm, 0.1, 0.6);
  check("margin_mm", margin_mm, 0, 5);
  return os.str();
}

namespace {

using V3 = Eigen::Vector3d;

// Polynomial smooth minimum (blend width k, mm); k = 0 is min().
double smin(double a, double b, double k) {
  if (k <= 0) return std::min(a, b);
  const double h = std::clamp(0.5 + 0.5 * (b - a) / k, 0.0, 1.0);
  return b + (a - b) * h - k * h * (1 - h);
}
double smax(double a, double b, double k) { return -smin(-a, -b, k); }
double smoothstep(double e0, double e1, double x) {
  const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

// Tapered capsule from a (radius ra) to b (radius rb): distance to the
// segment minus the interpolated radius. Slightly conservative for tapers.
double tapered_capsule(const V3& p, const V3& a, const V3& b, double ra, double rb) {
  const V3 ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (p - (a + t * ab)).norm() - (ra + (rb - ra) * t);
}

// Approximate distance to a superellipse of half-axes (ax, ay), exponent 2.5.
double superellipse(double x, double y, double ax, double ay) {
  constexpr double n = 2.5;
  const double f = std::pow(std::pow(std::abs(x) / ax, n) + std::pow(std::abs(y) / ay, n), 1.0 / n);
  return (f - 1.0) * std::min(ax, ay);
}

class Molar {
 public:
  explicit Molar(const MolarParams& p) : p_(p) {
    a_ = p.crown_mesiodistal_mm / 2;
    b_ = p.crown_buccolingual_mm / 2;
    fossa_z_ = p.crown_height_mm - p.cusp_height_mm;  // occlusal table at the fossa
    // Cusps: mesiobuccal, distobuccal, mesiopalatal (largest), distopalatal.
    // x mesial < 0, y buccal < 0.
    cusps_ = {{{-0.45 * a_, -0.47 * b_, 1.0},
               {0.45 * a_, -0.47 * b_, 0.9},
               {-0.40 * a_, 0.45 * b_, 1.05},
               {0.48 * a_, 0.50 * b_, 0.7}}};
    const double L = p.root_length_mm;
    roots_ = {{{V3(-0.36 * a_, -0.33 * b_, -2.5), V3(-0.62 * a_, -0.58 * b_, -L), 1.45, 0.45},
               {V3(0.36 * a_, -0.33 * b_, -2.5), V3(0.58 * a_, -0.55 * b_, -0.94 * L), 1.3, 0.42},
               {V3(0.0, 0.36 * b_, -2.5), V3(0.0, 0.85 * b_, -1.04 * L), 1.6, 0.5}}};
  }

  // Height of the occlusal surface above (x, y), mm, and its gradient.
  double occlusal_z(double x, double y, double* gx, double* gy) const {
    constexpr double sigma2 = 1.55 * 1.55;
    double z = fossa_z_, dx = 0, dy = 0;
    for (const auto& c : cusps_) {
      const double ex = x - c[0], ey = y - c[1];
      const double w = p_.cusp_height_mm * c[2] * std::exp(-(ex * ex + ey * ey) / (2 * sigma2));
      z += w;
      dx -= w * ex / sigma2;
      dy -= w * ey / sigma2;
    }
    *gx = dx;
    *gy = dy;
    return z;
  }

  // Outer surface of the whole tooth (negative inside), mm.
  double outer(const V3& q) const {
    // Crown: bulbous profile, widest at the height of contour.
    const double hc = 0.4 * p_.crown_height_mm;
    const double u = (q.z() - hc) / (0.8 * p_.crown_height_mm);
    const double s = std::max(0.6, 1.0 - 0.5 * u * u);
    double crown = superellipse(q.x(), q.y(), a_ * s, b_ * s);
    double gx, gy;
    const double oz = occlusal_z(q.x(), q.y(), &gx, &gy);
    const double occl = (q.z() - oz) / std::sqrt(1 + gx * gx + gy * gy);
    crown = smax(crown, occl, 0.8);
    crown = smax(crown, -0.5 - q.z(), 0.3);  // crown ends just below the cervix
    // Root trunk down to the furcation.
    const double ts = 0.78 - 0.06 * std::clamp(-q.z() / 3.0, 0.0, 1.0);
    double trunk = superellipse(q.x(), q.y(), a_ * ts, b_ * ts);
    trunk = smax(trunk, std::max(q.z() - 0.5, -3.2 - q.z()), 0.4);
    double d = smin(crown, trunk, 0.8);
    for (const auto& r : roots_) d = smin(d, tapered_capsule(q, r.a, r.b, r.ra, r.rb), 0.9);
    return d;
  }

  // Enamel thickness at height z: 0 below the cervical line, full occlusally.
  double enamel_thickness(const V3& q) const {
    const double lateral = 0.7 * p_.enamel_mm * smoothstep(0.0, 2.5, q.z());
    return lateral + 0.3 * p_.enamel_mm * smoothstep(fossa_z_ - 2.0, fossa_z_, q.z());
  }

  // Pulp (chamber + horns + canals), negative inside, mm.
  double pulp(const V3& q) const {
    const double roof = p_.pulp_roof_mm;  // chamber roof height above the cervical line
    const V3 c(0, 0, roof - 1.0);
    const V3 e = (q - c).cwiseQuotient(V3(0.3 * a_, 0.3 * b_, 1.0));
    double d = (e.norm() - 1.0) * std::min(0.3 * a_, 1.0);
    for (const auto& cp : cusps_) {
      const V3 base(0.5 * cp[0], 0.5 * cp[1], roof - 0.6);
      const V3 tip(0.55 * cp[0], 0.55 * cp[1], roof + 0.8 * p_.pulp_horn_mm * cp[2]);
      d = smin(d, tapered_capsule(q, base, tip, 0.55, 0.22), 0.4);
    }
    for (const auto& r : roots_) {
      const V3 start(0.6 * r.a.x(), 0.6 * r.a.y(), c.z());
      const V3 apex = r.b + (r.a - r.b).normalized() * 0.4;  // canal ends 0.4 mm short of the apex
      d = smin(d, tapered_capsule(q, start, r.a, 0.7, p_.canal_radius_mm * 1.6), 0.3);
      d = smin(d, tapered_capsule(q, r.a, apex, p_.canal_radius_mm * 1.6, p_.canal_radius_mm * 0.6),
               0.2);
    }
    return d;
  }

  // Bounding box of the tooth in mm (tooth frame).
  V3 lo() const { return V3(-a_ - 0.2, -b_ - 0.2, -1.05 * p_.root_length_mm - 0.6); }
  V3 hi() const { return V3(a_ + 0.2, b_ + 1.2, p_.crown_height_mm + 0.3); }

 private:
  struct Root {
    V3 a, b;
    double ra, rb;
  };
  MolarParams p_;
  double a_, b_, fossa_z_;
  std::array<std::array<double, 3>, 4> cusps_;
  std::array<Root, 3> roots_;
};

}  // namespace

Result<VoxelVolume> make_molar(const MolarParams& p) {
  const std::string why = p.validate();
  if (!why.empty()) return Error{"molar: " + why};
  const Molar m(p);
  const double h = p.voxel_mm;
  const V3 lo = m.lo() - V3::Constant(p.margin_mm + h);
  const V3 hi = m.hi() + V3::Constant(p.margin_mm + h);
  VolumeGeometry g;
  for (int a = 0; a < 3; ++a) g.dims[a] = static_cast<int>(std::ceil((hi[a] - lo[a]) / h)) + 1;
  g.spacing = V3::Constant(h * 1e-3);
  g.origin = lo * 1e-3;  // tooth frame: crown centre on the cervical plane is (0,0,0)
  auto created = VoxelVolume::create(g);
  if (!created) return Error{"molar: " + created.error()};
  VoxelVolume vol = std::move(created).value();

  const std::uint8_t enamel = material_info(Material::kEnamel).full_density;
  const std::uint8_t dentin = material_info(Material::kDentin).full_density;
  const std::uint8_t pulp = material_info(Material::kPulp).full_density;
  const Eigen::Vector3i cd = vol.chunk_dims();
  const double chunk_half_diag = std::sqrt(3.0) * 8.0 * h + h;

  // Decide and fill per chunk; chunks are independent, so z-slabs of chunks
  // run on two threads with identical results to one thread. The outer SDF
  // is 1-Lipschitz up to the smooth blends, so a chunk whose centre is
  // farther than its half diagonal (plus a voxel) outside stays absent.
  std::vector<std::unique_ptr<VoxelVolume::Chunk>> filled(static_cast<std::size_t>(vol.num_chunks()));
  auto work = [&](int ck_begin, int ck_step) {
    for (int ck = ck_begin; ck < cd.z(); ck += ck_step)
      for (int cj = 0; cj < cd.y(); ++cj)
        for (int ci = 0; ci < cd.x(); ++ci) {
          const V3 centre = lo + h * V3(ci * 16 + 7.5, cj * 16 + 7.5, ck * 16 + 7.5);
          if (m.outer(centre) > 1.3 * chunk_half_diag) continue;
          auto chunk = std::make_unique<VoxelVolume::Chunk>();
          bool any = false;
          for (int z = 0; z < 16; ++z)
            for (int y = 0; y < 16; ++y)
              for (int x = 0; x < 16; ++x) {
                const int i = ci * 16 + x, j = cj * 16 + y, k = ck * 16 + z;
                if (i >= g.dims.x() || j >= g.dims.y() || k >= g.dims.z()) continue;
                const V3 q = lo + h * V3(i, j, k);
                const double d_out = m.outer(q);
                // Occupancy: 1 inside, 0 outside, linear across a 2-voxel band so the
                // density gradient (surface normals) is smooth.
                const double occ = std::clamp(0.5 - d_out / (2 * h), 0.0, 1.0);
                if (occ <= 0) continue;
                Material mat = Material::kDentin;
                double full = dentin;
                if (const double t = m.enamel_thickness(q); t > 0 && d_out > -t) {
                  mat = Material::kEnamel;
                  full = enamel;
                } else {
                  const double d_p = m.pulp(q);
                  if (d_p < 2 * h) {  // within the 2-voxel blend band
                    // Blend dentin -> pulp density across the chamber wall.
                    const double w = std::clamp(0.5 - d_p / (2 * h), 0.0, 1.0);
                    full = dentin + (pulp - dentin) * w;
                    if (d_p < 0) mat = Material::kPulp;
                  }
                }
                const auto dens = static_cast<std::uint8_t>(std::lround(occ * full));
                if (dens == 0) continue;
                const auto li = static_cast<std::size_t>(chunk_local_index(x, y, z));
                chunk->density[li] = dens;
                chunk->material[li] = static_cast<std::uint8_t>(mat);
                any = true;
              }
          if (any) filled[static_cast<std::size_t>(vol.chunk_id(ci, cj, ck))] = std::move(chunk);
        }
  };
  std::thread t1(work, 1, 2);
  work(0, 2);
  t1.join();
  for (int c = 0; c < vol.num_chunks(); ++c)
    if (filled[static_cast<std::size_t>(c)]) vol.adopt_chunk(c, std::move(filled[static_cast<std::size_t>(c)]));
  return vol;
}

}  // namespace dentar::volume
