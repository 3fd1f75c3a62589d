#include "dentar/volume/procedural_incisor.h"

#include <algorithm>
#include <cmath>

#include "dentar/volume/material.h"

namespace dentar::volume {
namespace {

using V3 = Eigen::Vector3d;

double smoothstep(double e0, double e1, double x) {
  const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

// Superellipse (n = 2.5) cross-section distance, approximate (mm).
double section(double x, double y, double a, double b) {
  constexpr double n = 2.5;
  const double f = std::pow(std::pow(std::abs(x) / a, n) + std::pow(std::abs(y) / b, n), 1.0 / n);
  return (f - 1.0) * std::min(a, b);
}

struct Shape {
  explicit Shape(const IncisorParams& p) : p_(p) {}
  // Half-widths of the outer cross-section at height z (mm).
  void half_axes(double z, double& a, double& b) const {
    const double L = p_.crown_length_mm, R = p_.root_length_mm;
    if (z >= 0) {
      a = 0.5 * (p_.cervical_mesiodistal_mm +
                 (p_.crown_mesiodistal_mm - p_.cervical_mesiodistal_mm) * smoothstep(0, 0.6 * L, z));
      const double t = std::pow(std::clamp(z / L, 0.0, 1.0), 1.3);
      b = 0.5 * (p_.cervical_labiolingual_mm +
                 (p_.incisal_thickness_mm - p_.cervical_labiolingual_mm) * t);
    } else {
      const double u = std::clamp(1.0 + z / R, 0.0, 1.0);  // 1 at the cervix, 0 at the apex
      a = 0.4 + (0.5 * p_.cervical_mesiodistal_mm - 0.4) * u;
      b = 0.4 + (0.5 * p_.cervical_labiolingual_mm - 0.4) * u;
    }
  }
  double outer(const V3& q) const {
    double a, b;
    half_axes(q.z(), a, b);
    const double d = section(q.x(), q.y(), a, b);
    const double L = p_.crown_length_mm;
    // Incisal edge, rounded at the mesial and distal corners.
    const double xa = std::clamp(q.x() / (0.5 * p_.crown_mesiodistal_mm), -1.0, 1.0);
    const double edge = L - 0.8 * std::pow(xa, 4);
    return std::max({d, q.z() - edge, -q.z() - p_.root_length_mm});
  }
  double enamel_thickness(const V3& q) const {
    if (q.z() <= 0) return 0;
    const double e = q.y() < 0 ? p_.enamel_labial_mm : p_.enamel_lingual_mm;
    return e * smoothstep(0.0, 2.5, q.z());
  }
  double pulp(const V3& q) const {
    const double L = p_.crown_length_mm, R = p_.root_length_mm;
    const double top = p_.pulp_top_fraction * L;
    double a, b;
    if (q.z() >= 0) {
      half_axes(q.z(), a, b);
      a *= 0.3;
      b *= 0.3;
      // The chamber narrows toward its top (toward the incisal edge).
      const double s = 1.0 - 0.4 * smoothstep(0.2 * L, top, q.z());
      a *= s;
      b *= s;
    } else {
      const double u = std::clamp(1.0 + q.z() / R, 0.0, 1.0);
      a = b = 0.15 + 0.35 * u;
      half_axes(0, a, b);
      a = 0.15 + (0.3 * a - 0.15) * u;
      b = 0.15 + (0.3 * b - 0.15) * u;
    }
    return std::max({section(q.x(), q.y(), a, b), q.z() - top, -q.z() - (R - 0.5)});
  }
  IncisorParams p_;
};

}  // namespace

std::string IncisorParams::validate() const {
  if (!(voxel_mm >= 0.02 && voxel_mm <= 0.5)) return "voxel_mm must be in [0.02, 0.5]";
  if (!(crown_length_mm > 3 && crown_length_mm < 20)) return "crown_length_mm must be in (3, 20)";
  if (!(root_length_mm > 3 && root_length_mm < 30)) return "root_length_mm must be in (3, 30)";
  if (!(cervical_mesiodistal_mm > 2 && crown_mesiodistal_mm >= cervical_mesiodistal_mm &&
        crown_mesiodistal_mm < 15))
    return "crown_mesiodistal_mm must be >= cervical_mesiodistal_mm > 2 and < 15";
  if (!(cervical_labiolingual_mm > 2 && cervical_labiolingual_mm < 12))
    return "cervical_labiolingual_mm must be in (2, 12)";
  if (!(incisal_thickness_mm > 0.3 && incisal_thickness_mm < cervical_labiolingual_mm))
    return "incisal_thickness_mm must be in (0.3, cervical_labiolingual_mm)";
  if (!(enamel_labial_mm > 0 && enamel_labial_mm < 3 && enamel_lingual_mm > 0 && enamel_lingual_mm < 3))
    return "enamel_labial_mm and enamel_lingual_mm must be in (0, 3)";
  if (!(pulp_top_fraction > 0.1 && pulp_top_fraction < 0.8)) return "pulp_top_fraction must be in (0.1, 0.8)";
  if (!(margin_mm >= 0 && margin_mm < 10)) return "margin_mm must be in [0, 10)";
  return {};
}

double incisor_outer_distance_mm(const IncisorParams& p, const Eigen::Vector3d& q_mm) {
  return Shape(p).outer(q_mm);
}

Result<VoxelVolume> make_incisor(const IncisorParams& p) {
  const std::string why = p.validate();
  if (!why.empty()) return Error{"incisor: " + why};
  const Shape s(p);
  const double h = p.voxel_mm;
  const double m = p.margin_mm + h;
  const V3 lo(-0.5 * p.crown_mesiodistal_mm - m, -0.5 * p.cervical_labiolingual_mm - m,
              -p.root_length_mm - m);
  const V3 hi(0.5 * p.crown_mesiodistal_mm + m, 0.5 * p.cervical_labiolingual_mm + m,
              p.crown_length_mm + m);
  VolumeGeometry g;
  for (int a = 0; a < 3; ++a) g.dims[a] = static_cast<int>(std::ceil((hi[a] - lo[a]) / h)) + 1;
  g.spacing = V3::Constant(h * 1e-3);
  g.origin = lo * 1e-3;
  auto created = VoxelVolume::create(g);
  if (!created) return Error{"incisor: " + created.error()};
  VoxelVolume vol = std::move(created).value();
  const double enamel = material_info(Material::kEnamel).full_density;
  const double dentin = material_info(Material::kDentin).full_density;
  const double pulp = material_info(Material::kPulp).full_density;
  for (int k = 0; k < g.dims.z(); ++k)
    for (int j = 0; j < g.dims.y(); ++j)
      for (int i = 0; i < g.dims.x(); ++i) {
        const V3 q = lo + h * V3(i, j, k);
        const double d_out = s.outer(q);
        const double occ = std::clamp(0.5 - d_out / (2 * h), 0.0, 1.0);
        if (occ <= 0) continue;
        Material mat = Material::kDentin;
        double full = dentin;
        if (const double t = s.enamel_thickness(q); t > 0 && d_out > -t) {
          mat = Material::kEnamel;
          full = enamel;
        } else {
          const double d_p = s.pulp(q);
          if (d_p < 2 * h) {
            const double w = std::clamp(0.5 - d_p / (2 * h), 0.0, 1.0);
            full = dentin + (pulp - dentin) * w;
            if (d_p < 0) mat = Material::kPulp;
          }
        }
        const auto dens = static_cast<std::uint8_t>(std::lround(occ * full));
        if (dens == 0) continue;
        vol.set(i, j, k, dens, mat);
      }
  return vol;
}

}  // namespace dentar::volume
