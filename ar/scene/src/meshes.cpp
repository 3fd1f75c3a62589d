#include "dentar/ar/meshes.h"

#include <algorithm>
#include <cassert>
#include <cmath>

namespace dentar::ar {

void PartMesh::append(const PartMesh& other, const Eigen::Isometry3f& T_this_other) {
  const auto base = static_cast<std::uint32_t>(positions_m.size());
  for (std::size_t i = 0; i < other.positions_m.size(); ++i) {
    positions_m.push_back(T_this_other * other.positions_m[i]);
    normals.push_back(T_this_other.linear() * other.normals[i]);
  }
  for (std::uint32_t idx : other.indices) indices.push_back(base + idx);
}

PartMesh revolve(const std::vector<ProfilePoint>& profile, int segments) {
  assert(segments >= 3 && "dentar::ar::revolve: segments must be >= 3");
  PartMesh m;
  const auto n_seg = static_cast<std::uint32_t>(segments);
  for (const ProfilePoint& p : profile) {
    const double len = std::hypot(p.n_r, p.n_z);
    for (int j = 0; j < segments; ++j) {
      const double a = 2.0 * M_PI * j / segments;
      const double c = std::cos(a), s = std::sin(a);
      m.positions_m.emplace_back(static_cast<float>(p.r_m * c), static_cast<float>(p.r_m * s),
                                 static_cast<float>(p.z_m));
      m.normals.emplace_back(static_cast<float>(p.n_r * c / len),
                             static_cast<float>(p.n_r * s / len), static_cast<float>(p.n_z / len));
    }
  }
  for (std::size_t i = 0; i + 1 < profile.size(); ++i) {
    const ProfilePoint& p0 = profile[i];
    const ProfilePoint& p1 = profile[i + 1];
    if (p0.r_m == p1.r_m && p0.z_m == p1.z_m) continue;  // crease: no band
    const auto row0 = static_cast<std::uint32_t>(i) * n_seg;
    const auto row1 = row0 + n_seg;
    for (std::uint32_t j = 0; j < n_seg; ++j) {
      const std::uint32_t j1 = (j + 1) % n_seg;
      const std::uint32_t a = row0 + j, b = row0 + j1, c = row1 + j1, d = row1 + j;
      // Walking the profile toward +z (or inward on a front cap) with the
      // angle increasing gives outward-facing counter-clockwise triangles.
      if (p0.r_m > 0) m.indices.insert(m.indices.end(), {a, b, c});
      if (p1.r_m > 0) m.indices.insert(m.indices.end(), {a, c, d});
    }
  }
  return m;
}

namespace {

// Closed cylinder (or frustum) along +z from z0 (radius r0) to z1 (radius r1).
std::vector<ProfilePoint> frustum_profile(double z0, double r0, double z1, double r1) {
  // Side normal: perpendicular to the slant (r1 - r0, z1 - z0), pointing out.
  const double nr = z1 - z0, nz = r0 - r1;
  return {{0, z0, 0, -1},   {r0, z0, 0, -1}, {r0, z0, nr, nz},
          {r1, z1, nr, nz}, {r1, z1, 0, 1},  {0, z1, 0, 1}};
}

// Quarter or half circle of radius R centred on the axis at zc, from polar
// angle phi0 to phi1 (phi = 0 at the equator, +pi/2 at the +z pole).
void append_arc(std::vector<ProfilePoint>& p, double R, double zc, double phi0, double phi1,
                int steps) {
  for (int i = 0; i <= steps; ++i) {
    const double phi = phi0 + (phi1 - phi0) * i / steps;
    double r = R * std::cos(phi);
    if (std::abs(r) < 1e-15) r = 0;  // exact poles
    p.push_back({r, zc + R * std::sin(phi), std::cos(phi), std::sin(phi)});
  }
}

double cutting_back_z(const volume::BurParams& bur) {
  return bur.shape == volume::BurShape::kSphere ? -2.0 * bur.radius_m : -bur.length_m;
}

}  // namespace

std::string BurMeshOptions::validate() const {
  if (segments < 3 || segments > 1024)
    return "segments = " + std::to_string(segments) + " must be in 3..1024";
  if (arc_steps < 1 || arc_steps > 256)
    return "arc_steps = " + std::to_string(arc_steps) + " must be in 1..256";
  if (!(neck_length_m >= 0)) return "neck_length_m must be >= 0";
  if (!(neck_radius_m > 0)) return "neck_radius_m must be > 0";
  if (!(shank_length_m >= 0)) return "shank_length_m must be >= 0";
  if (!(shank_radius_m > 0)) return "shank_radius_m must be > 0";
  return {};
}

double bur_shank_end_z_m(const volume::BurParams& bur, const BurMeshOptions& o) {
  return cutting_back_z(bur) - o.neck_length_m - o.shank_length_m;
}

PartMesh make_bur_mesh(const volume::BurParams& bur, const BurMeshOptions& o) {
  assert(bur.validate().empty() && "dentar::ar::make_bur_mesh: invalid BurParams");
  assert(o.validate().empty() && "dentar::ar::make_bur_mesh: invalid BurMeshOptions");
  const double R = bur.radius_m;
  std::vector<ProfilePoint> cut;
  double back_radius = R;
  switch (bur.shape) {
    case volume::BurShape::kSphere:
      append_arc(cut, R, -R, -M_PI / 2, M_PI / 2, 2 * o.arc_steps);
      break;
    case volume::BurShape::kCylinder:
      cut = frustum_profile(-bur.length_m, R, 0.0, R);
      break;
    case volume::BurShape::kCapsule:
      cut = {{0, -bur.length_m, 0, -1}, {R, -bur.length_m, 0, -1}, {R, -bur.length_m, 1, 0}};
      append_arc(cut, R, -R, 0.0, M_PI / 2, o.arc_steps);
      break;
    case volume::BurShape::kCone:
      cut = frustum_profile(-bur.length_m, R, 0.0, bur.tip_radius_m);
      break;
  }
  PartMesh m = revolve(cut, o.segments);
  const double z_back = cutting_back_z(bur);
  // The neck starts inside the cutting part (at the sphere's centre) so the
  // two closed surfaces overlap instead of leaving a gap.
  const double neck_r = std::min(o.neck_radius_m, 0.8 * back_radius);
  const double neck_front = bur.shape == volume::BurShape::kSphere ? -R : z_back;
  const double z_shank_front = z_back - o.neck_length_m;
  const Eigen::Isometry3f I = Eigen::Isometry3f::Identity();
  if (o.neck_length_m > 0) {
    m.append(revolve(frustum_profile(z_shank_front, neck_r, neck_front, neck_r), o.segments), I);
  }
  if (o.shank_length_m > 0) {
    m.append(revolve(frustum_profile(z_shank_front - o.shank_length_m, o.shank_radius_m,
                                     z_shank_front, o.shank_radius_m),
                     o.segments),
             I);
  }
  return m;
}

std::string HandpieceParams::validate() const {
  auto pos = [](double v) { return std::isfinite(v) && v > 0; };
  if (!pos(head_radius_m)) return "head_radius_m must be finite and > 0";
  if (!pos(head_height_m)) return "head_height_m must be finite and > 0";
  if (!pos(neck_radius_m)) return "neck_radius_m must be finite and > 0";
  if (!pos(neck_length_m)) return "neck_length_m must be finite and > 0";
  if (!pos(body_radius_m)) return "body_radius_m must be finite and > 0";
  if (!pos(body_length_m)) return "body_length_m must be finite and > 0";
  if (!(handle_angle_rad >= M_PI / 4 && handle_angle_rad <= M_PI)) {
    return "handle_angle_rad must be in [pi/4, pi]";
  }
  if (segments < 3 || segments > 1024) return "segments must be in 3..1024";
  return {};
}

PartMesh make_handpiece_mesh(const volume::BurParams& bur, const HandpieceParams& p,
                             const BurMeshOptions& bo) {
  assert(p.validate().empty() && "dentar::ar::make_handpiece_mesh: invalid HandpieceParams");
  const double z_head_front = bur_shank_end_z_m(bur, bo);
  const double z_head_back = z_head_front - p.head_height_m;
  PartMesh m = revolve(frustum_profile(z_head_back, p.head_radius_m, z_head_front, p.head_radius_m),
                       p.segments);
  // Handle: neck (frustum) + body (cylinder) along its own +z, rotated so +z
  // becomes the handle direction and started at the head's centre.
  PartMesh handle =
      revolve(frustum_profile(0.0, p.neck_radius_m, p.neck_length_m, p.body_radius_m), p.segments);
  handle.append(revolve(frustum_profile(p.neck_length_m, p.body_radius_m,
                                        p.neck_length_m + p.body_length_m, p.body_radius_m),
                        p.segments),
                Eigen::Isometry3f::Identity());
  const Eigen::Vector3f dir(static_cast<float>(-std::sin(p.handle_angle_rad)), 0.f,
                            static_cast<float>(std::cos(p.handle_angle_rad)));
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  T.linear() = Eigen::Quaternionf::FromTwoVectors(Eigen::Vector3f::UnitZ(), dir).toRotationMatrix();
  T.translation() = Eigen::Vector3f(0, 0, static_cast<float>(0.5 * (z_head_front + z_head_back)));
  m.append(handle, T);
  return m;
}

std::string MirrorMeshParams::validate() const {
  auto pos = [](double v) { return std::isfinite(v) && v > 0; };
  if (!pos(radius_m)) return "radius_m must be finite and > 0";
  if (!pos(thickness_m)) return "thickness_m must be finite and > 0";
  if (!pos(neck_length_m)) return "neck_length_m must be finite and > 0";
  if (!pos(neck_radius_m)) return "neck_radius_m must be finite and > 0";
  if (!pos(handle_length_m)) return "handle_length_m must be finite and > 0";
  if (!pos(handle_radius_m)) return "handle_radius_m must be finite and > 0";
  if (!(std::abs(stem_tilt_rad) <= M_PI / 2)) return "stem_tilt_rad must be in [-pi/2, pi/2]";
  if (segments < 3 || segments > 1024) return "segments must be in 3..1024";
  return {};
}

MirrorMeshes make_mirror_meshes(const MirrorMeshParams& p) {
  assert(p.validate().empty() && "dentar::ar::make_mirror_meshes: invalid MirrorMeshParams");
  MirrorMeshes out;
  // Face: one band from the rim inward at z = 0, normal +z.
  out.face = revolve({{p.radius_m, 0.0, 0, 1}, {0.0, 0.0, 0, 1}}, p.segments);
  // Body: back cap and rim, open at z = 0 where the face closes it.
  const double t = p.thickness_m;
  out.body = revolve(
      {{0, -t, 0, -1}, {p.radius_m, -t, 0, -1}, {p.radius_m, -t, 1, 0}, {p.radius_m, 0, 1, 0}},
      p.segments);
  // Stem (neck + handle) along its own +z, rotated onto -y tilted toward -z,
  // starting behind the disc just inside the rim.
  PartMesh stem = revolve(frustum_profile(0.0, p.neck_radius_m, p.neck_length_m, p.neck_radius_m),
                          p.segments / 2 < 3 ? 3 : p.segments / 2);
  stem.append(revolve(frustum_profile(p.neck_length_m, p.handle_radius_m,
                                      p.neck_length_m + p.handle_length_m, p.handle_radius_m),
                      p.segments / 2 < 3 ? 3 : p.segments / 2),
              Eigen::Isometry3f::Identity());
  const Eigen::Vector3f dir(0.f, static_cast<float>(-std::cos(p.stem_tilt_rad)),
                            static_cast<float>(-std::sin(p.stem_tilt_rad)));
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  T.linear() = Eigen::Quaternionf::FromTwoVectors(Eigen::Vector3f::UnitZ(), dir).toRotationMatrix();
  // Centred deep enough that the stem never pokes through the face (z <= 0).
  const double z0 = -std::max(0.5 * t, p.neck_radius_m + 0.1e-3);
  T.translation() =
      Eigen::Vector3f(0.f, static_cast<float>(-0.9 * p.radius_m), static_cast<float>(z0));
  out.body.append(stem, T);
  return out;
}

}  // namespace dentar::ar
