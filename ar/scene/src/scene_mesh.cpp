#include "dentar/ar/scene_mesh.h"

#include <array>
#include <cmath>
#include <cstddef>
#include <functional>

namespace dentar::ar::scene {
namespace {

using V3 = Eigen::Vector3f;
constexpr float kPi = static_cast<float>(M_PI);

// Deterministic per-cell brightness jitter (a mottled, tiled look without
// textures): a hash of the cell, not an RNG stream.
float jitter(int a, int b, int c) {
  std::uint32_t h = static_cast<std::uint32_t>(a) * 73856093u ^
                    static_cast<std::uint32_t>(b) * 19349663u ^
                    static_cast<std::uint32_t>(c) * 83492791u;
  h ^= h >> 13;
  h *= 0x5bd1e995u;
  h ^= h >> 15;
  return static_cast<float>(h & 0xffff) / 65535.0f - 0.5f;
}

// Adds a triangle, turned so that its winding agrees with the vertex normals
// (counter-clockwise seen from where they point): the builders below then
// need not track orientation through every parametrisation.
void add_tri(Mesh& m, std::uint32_t a, std::uint32_t b, std::uint32_t c) {
  const auto& va = m.vertices[a];
  const auto& vb = m.vertices[b];
  const auto& vc = m.vertices[c];
  const V3 n = (vb.position_m - va.position_m).cross(vc.position_m - va.position_m);
  if (n.dot(va.normal + vb.normal + vc.normal) < 0) std::swap(b, c);
  m.indices.insert(m.indices.end(), {a, b, c});
}

// Smooth grid surface p(u, v), u in [0, nu], v in [0, nv]; wrap_u closes it.
void add_grid(Mesh& m, int nu, int nv, bool wrap_u,
              const std::function<void(int, int, V3&, V3&)>& at, const V3& rgb,
              const std::function<bool(const V3&)>& skip = {}) {
  const auto base = static_cast<std::uint32_t>(m.vertices.size());
  const int cols = wrap_u ? nu : nu + 1;
  for (int j = 0; j <= nv; ++j)
    for (int i = 0; i < cols; ++i) {
      Vertex v;
      at(i, j, v.position_m, v.normal);
      v.rgb = rgb;
      m.vertices.push_back(v);
    }
  auto idx = [&](int i, int j) {
    return base + static_cast<std::uint32_t>(j * cols + (wrap_u ? i % nu : i));
  };
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const std::uint32_t a = idx(i, j), b = idx(i + 1, j), c = idx(i + 1, j + 1),
                          d = idx(i, j + 1);
      if (skip) {
        const V3 centre = 0.25f * (m.vertices[a].position_m + m.vertices[b].position_m +
                                   m.vertices[c].position_m + m.vertices[d].position_m);
        if (skip(centre)) continue;
      }
      // Degenerate triangles at poles are harmless (zero area).
      add_tri(m, a, b, c);
      add_tri(m, a, c, d);
    }
}

// Flat face of a room/box made of separate quads with per-quad brightness
// jitter. n: the side it is seen from.
void add_panel(Mesh& m, const V3& centre, const V3& n, const V3& u, float half_u, float half_v,
               int cells_u, int cells_v, const std::function<V3(const V3&)>& colour, float mottle,
               int salt) {
  const V3 v = n.cross(u);
  for (int j = 0; j < cells_v; ++j)
    for (int i = 0; i < cells_u; ++i) {
      const float a0 = -half_u + 2 * half_u * i / cells_u,
                  a1 = -half_u + 2 * half_u * (i + 1) / cells_u;
      const float b0 = -half_v + 2 * half_v * j / cells_v,
                  b1 = -half_v + 2 * half_v * (j + 1) / cells_v;
      const V3 mid = centre + 0.5f * (a0 + a1) * u + 0.5f * (b0 + b1) * v;
      const V3 rgb = (colour(mid) * (1.0f + mottle * jitter(i, j, salt))).cwiseMin(1.0f);
      const auto base = static_cast<std::uint32_t>(m.vertices.size());
      for (const auto& [a, b] : {std::pair{a0, b0}, {a1, b0}, {a1, b1}, {a0, b1}}) {
        Vertex vx;
        vx.position_m = centre + a * u + b * v;
        vx.normal = n;
        vx.rgb = rgb;
        m.vertices.push_back(vx);
      }
      add_tri(m, base, base + 1, base + 2);
      add_tri(m, base, base + 2, base + 3);
    }
}

// Tube along a polyline (open), radius r, smooth normals.
void add_tube(Mesh& m, const std::vector<V3>& line, float r, const V3& rgb, int segments = 16) {
  const int n = static_cast<int>(line.size());
  add_grid(
      m, segments, n - 1, true,
      [&](int i, int j, V3& p, V3& nn) {
        const V3 t = (line[static_cast<std::size_t>(std::min(j + 1, n - 1))] -
                      line[static_cast<std::size_t>(std::max(j - 1, 0))])
                         .normalized();
        V3 a = std::abs(t.y()) < 0.9f ? V3::UnitY() : V3::UnitX();
        a = (a - a.dot(t) * t).normalized();
        const V3 b = t.cross(a);
        const float ang = 2 * kPi * i / segments;
        nn = std::cos(ang) * a + std::sin(ang) * b;
        p = line[static_cast<std::size_t>(j)] + r * nn;
      },
      rgb);
}

}  // namespace

void Mesh::add(const PartMesh& part, const Eigen::Isometry3f& T, const Eigen::Vector3f& rgb) {
  const auto base = static_cast<std::uint32_t>(vertices.size());
  for (std::size_t i = 0; i < part.positions_m.size(); ++i) {
    Vertex v;
    v.position_m = T * part.positions_m[i];
    v.normal = T.linear() * part.normals[i];
    v.rgb = rgb;
    vertices.push_back(v);
  }
  for (auto i : part.indices) indices.push_back(base + i);
}

void Mesh::add(const Mesh& other) {
  const auto base = static_cast<std::uint32_t>(vertices.size());
  vertices.insert(vertices.end(), other.vertices.begin(), other.vertices.end());
  for (auto i : other.indices) indices.push_back(base + i);
}

Eigen::Vector3d arch_point(double phi, double y) {
  return {0.025 * std::sin(phi), y, -0.045 + 0.035 * std::cos(phi)};
}

Mesh capsule(const V3& a, const V3& b, float ra, float rb, const V3& rgb, int segments) {
  const float len = (b - a).norm();
  std::vector<ProfilePoint> prof;
  const int arc = 6;
  for (int k = 0; k <= arc; ++k) {  // back hemisphere, pole first
    const double t = -M_PI / 2 + (M_PI / 2) * k / arc;
    prof.push_back({ra * std::cos(t), ra * std::sin(t), std::cos(t), std::sin(t)});
  }
  for (int k = 0; k <= arc; ++k) {  // front hemisphere
    const double t = (M_PI / 2) * k / arc;
    prof.push_back({rb * std::cos(t), len + rb * std::sin(t), std::cos(t), std::sin(t)});
  }
  prof.back().r_m = 0.0;
  prof.front().r_m = 0.0;
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  T.linear() =
      Eigen::Quaternionf::FromTwoVectors(V3::UnitZ(), (b - a).normalized()).toRotationMatrix();
  T.translation() = a;
  Mesh m;
  m.add(revolve(prof, segments), T, rgb);
  return m;
}

Mesh ellipsoid(const V3& c, const Eigen::Matrix3f& R, const V3& radii, const V3& rgb,
               int segments) {
  std::vector<ProfilePoint> prof;
  const int arc = segments / 2;
  for (int k = 0; k <= arc; ++k) {
    const double t = -M_PI / 2 + M_PI * k / arc;
    prof.push_back({std::cos(t), std::sin(t), std::cos(t), std::sin(t)});
  }
  prof.front().r_m = prof.back().r_m = 0.0;
  const PartMesh s = revolve(prof, segments);
  Mesh m;
  for (std::size_t i = 0; i < s.positions_m.size(); ++i) {
    Vertex v;
    v.position_m = c + R * s.positions_m[i].cwiseProduct(radii);
    v.normal = (R * s.normals[i].cwiseQuotient(radii)).normalized();
    v.rgb = rgb;
    m.vertices.push_back(v);
  }
  m.indices = s.indices;
  return m;
}

Mesh box(const V3& lo, const V3& hi, const V3& rgb) {
  Mesh m;
  const V3 c = 0.5f * (lo + hi), h = 0.5f * (hi - lo);
  for (int axis = 0; axis < 3; ++axis)
    for (int s : {-1, 1}) {
      V3 n = V3::Zero();
      n[axis] = static_cast<float>(s);
      V3 u = V3::Zero();
      u[(axis + 1) % 3] = 1;
      const V3 centre = c + n.cwiseProduct(h);
      add_panel(
          m, centre, n, u, h[(axis + 1) % 3], h[(axis + 2) % 3], 1, 1,
          [&](const V3&) { return rgb; }, 0.0f, 0);
    }
  return m;
}

Mesh paddle_mesh(const MirrorSceneParams& mp, const V3& rgb, float inset_m) {
  const float w = 0.5f * static_cast<float>(mp.paddle_width_m);
  const float h = 0.5f * static_cast<float>(mp.paddle_height_m);
  const float t = static_cast<float>(mp.paddle_thickness_m);
  // Only the tag-carrying faces (front, back) need the inset.
  if (mp.paddle_roof_rad <= 0) return box({-w, -h, inset_m}, {w, h, t - inset_m}, rgb);
  // Cross-section in the y/z plane (a pentagon: ridge, eaves, back corners),
  // each edge moved inward by inset_m, extruded along x.
  const float a = static_cast<float>(mp.paddle_roof_rad), ta = std::tan(a), d = inset_m;
  const float zr = -0.5f * h * ta + d / std::cos(a);  // ridge (y = 0)
  const float ye = h - d, ze = zr + ye * ta, zb = t - d;
  const std::array<Eigen::Vector2f, 5> sec = {Eigen::Vector2f(0, zr), Eigen::Vector2f(ye, ze),
                                              Eigen::Vector2f(ye, zb), Eigen::Vector2f(-ye, zb),
                                              Eigen::Vector2f(-ye, ze)};
  Mesh m;
  auto vert = [&](float x, const Eigen::Vector2f& yz, const V3& n) {
    Vertex v;
    v.position_m = V3(x, yz.x(), yz.y());
    v.normal = n;
    v.rgb = rgb;
    m.vertices.push_back(v);
    return static_cast<std::uint32_t>(m.vertices.size() - 1);
  };
  // Side faces: flat-shaded quads, normal = outward normal of the edge.
  for (std::size_t i = 0; i < sec.size(); ++i) {
    const Eigen::Vector2f p = sec[i], q = sec[(i + 1) % sec.size()];
    const Eigen::Vector2f e = (q - p).normalized();
    Eigen::Vector2f n2(e.y(), -e.x());  // one of the two normals; outward = away from the centroid
    const Eigen::Vector2f mid = 0.5f * (p + q), c(0, 0.5f * (zr + zb));
    if (n2.dot(mid - c) < 0) n2 = -n2;
    const V3 n(0, n2.x(), n2.y());
    const std::uint32_t a0 = vert(-w, p, n), a1 = vert(w, p, n), b0 = vert(-w, q, n), b1 = vert(w, q, n);
    add_tri(m, a0, a1, b1);
    add_tri(m, a0, b1, b0);
  }
  // End caps: convex pentagons, fans from the ridge.
  for (float x : {-w, w}) {
    const V3 n(x > 0 ? 1.0f : -1.0f, 0, 0);
    std::array<std::uint32_t, 5> id{};
    for (std::size_t i = 0; i < sec.size(); ++i) id[i] = vert(x, sec[i], n);
    for (std::size_t i = 1; i + 1 < sec.size(); ++i) add_tri(m, id[0], id[i], id[i + 1]);
  }
  return m;
}

Mesh room_mesh() {
  Mesh m;
  const V3 lo(-1.6f, -0.9f, -1.8f), hi(1.6f, 1.3f, 1.8f);
  auto wall = [](const V3& p) -> V3 {
    // Pale green-grey walls with a darker band below 0.1 m (a dado rail).
    if (p.y() < 0.1f) return {0.52f, 0.60f, 0.62f};
    const float g = 0.9f + 0.1f * std::clamp((p.y() - 0.1f) / 1.2f, 0.0f, 1.0f);
    return V3(0.76f, 0.82f, 0.80f) * g;
  };
  const V3 c = 0.5f * (lo + hi), h = 0.5f * (hi - lo);
  // Inward-facing panels.
  add_panel(
      m, {c.x(), lo.y(), c.z()}, V3::UnitY(), V3::UnitZ(), h.z(), h.x(), 12, 10,
      [](const V3&) { return V3(0.45f, 0.47f, 0.50f); }, 0.25f, 1);  // floor tiles
  add_panel(
      m, {c.x(), hi.y(), c.z()}, -V3::UnitY(), V3::UnitX(), h.x(), h.z(), 6, 6,
      [](const V3&) { return V3(0.93f, 0.93f, 0.91f); }, 0.06f, 2);  // ceiling panels
  add_panel(m, {c.x(), c.y(), lo.z()}, V3::UnitZ(), V3::UnitX(), h.x(), h.y(), 16, 11, wall, 0.05f,
            3);
  add_panel(m, {c.x(), c.y(), hi.z()}, -V3::UnitZ(), V3::UnitX(), h.x(), h.y(), 16, 11, wall, 0.05f,
            4);
  add_panel(m, {lo.x(), c.y(), c.z()}, V3::UnitX(), V3::UnitZ(), h.z(), h.y(), 16, 11, wall, 0.05f,
            5);
  add_panel(m, {hi.x(), c.y(), c.z()}, -V3::UnitX(), V3::UnitZ(), h.z(), h.y(), 16, 11, wall, 0.05f,
            6);
  // Cabinets and a worktop along the back wall, a bright window on the left,
  // a wall cupboard on the right, the operating lamp above.
  m.add(box({-1.3f, -0.9f, -1.8f}, {0.5f, -0.02f, -1.25f}, {0.90f, 0.90f, 0.88f}));
  m.add(box({-1.32f, -0.02f, -1.8f}, {0.52f, 0.02f, -1.22f}, {0.28f, 0.29f, 0.31f}));
  for (int i = 0; i < 6; ++i)
    m.add(box({-1.25f + 0.3f * i, -0.2f, -1.25f}, {-1.05f + 0.3f * i, -0.18f, -1.23f},
              {0.55f, 0.55f, 0.57f}));
  m.add(box({-0.9f, 0.45f, -1.8f}, {0.4f, 1.0f, -1.45f}, {0.78f, 0.64f, 0.48f}));
  m.add(box({-1.6f, 0.2f, -0.9f}, {-1.58f, 1.0f, 0.6f}, {0.97f, 0.98f, 1.0f}));
  m.add(box({1.45f, 0.3f, -0.5f}, {1.6f, 1.1f, 0.7f}, {0.85f, 0.86f, 0.88f}));
  m.add(box({-0.15f, 0.75f, -0.2f}, {0.15f, 0.82f, 0.05f}, {0.25f, 0.26f, 0.28f}));
  m.add(capsule({0.0f, 0.82f, -0.1f}, {0.0f, 1.3f, -0.1f}, 0.02f, 0.02f, {0.6f, 0.6f, 0.62f}));
  // Patient chair: headrest behind the head, the gown over the shoulders.
  m.add(box({-0.11f, -0.55f, -0.27f}, {0.11f, 0.12f, -0.17f}, {0.16f, 0.22f, 0.36f}));
  m.add(box({-0.3f, -0.9f, -0.45f}, {0.3f, -0.5f, 0.1f}, {0.16f, 0.22f, 0.36f}));
  return m;
}

Mesh mannequin_mesh(const MannequinParams& mp) {
  Mesh m;
  const V3 c = mp.head_centre_m.cast<float>(), r = mp.head_radii_m.cast<float>();
  const V3 skin = mp.skin_rgb.cast<float>(), lip = mp.lip_rgb.cast<float>();
  const V3 gum = mp.gum_rgb.cast<float>(), teeth = mp.teeth_rgb.cast<float>();
  const float mw = static_cast<float>(mp.mouth_half_width_m);
  const float mh = static_cast<float>(mp.mouth_half_height_m);
  const float lr = static_cast<float>(mp.lip_radius_m);
  auto face_z = [&](float x, float y) {
    const float q = 1 - std::pow((x - c.x()) / r.x(), 2.f) - std::pow((y - c.y()) / r.y(), 2.f);
    return c.z() + r.z() * std::sqrt(std::max(q, 0.f));
  };
  // Head shell with the open mouth cut out (the lips hide the ragged edge).
  add_grid(
      m, 128, 80, true,
      [&](int i, int j, V3& p, V3& n) {
        const float az = -kPi + 2 * kPi * i / 128, el = -kPi / 2 + kPi * j / 80;
        const V3 d(std::sin(az) * std::cos(el), std::sin(el), std::cos(az) * std::cos(el));
        p = c + r.cwiseProduct(d);
        n = (p - c).cwiseQuotient(r.cwiseProduct(r)).normalized();
      },
      skin,
      [&](const V3& q) {
        const float ex = q.x() / (mw + 0.3f * lr), ey = q.y() / (mh + 0.3f * lr);
        return q.z() > c.z() && ex * ex + ey * ey < 1.0f;
      });
  // Nose.
  m.add(ellipsoid({0.f, 0.05f, face_z(0.f, 0.05f) - 0.002f}, Eigen::Matrix3f::Identity(),
                  {0.011f, 0.014f, 0.015f}, skin));
  // Lips: a tube on the face around the mouth opening.
  std::vector<V3> ring;
  for (int k = 0; k <= 72; ++k) {
    const float t = 2 * kPi * k / 72;
    const float x = mw * std::cos(t), y = mh * std::sin(t);
    ring.push_back({x, y, face_z(x, y) - 0.3f * lr});
  }
  add_tube(m, ring, lr, lip, 14);
  // Oral cavity, seen from inside (normals inward).
  Mesh cavity = ellipsoid({0.f, -0.002f, -0.048f}, Eigen::Matrix3f::Identity(),
                          {0.036f, 0.030f, 0.052f}, {0.45f, 0.13f, 0.15f}, 32);
  for (auto& v : cavity.vertices) v.normal = -v.normal;
  for (std::size_t i = 0; i + 2 < cavity.indices.size(); i += 3)
    std::swap(cavity.indices[i + 1], cavity.indices[i + 2]);
  m.add(cavity);
  m.add(ellipsoid({0.f, -0.026f, -0.05f}, Eigen::Matrix3f::Identity(), {0.016f, 0.008f, 0.028f},
                  {0.74f, 0.36f, 0.40f}));  // tongue
  // Gums along the lower and upper arches, teeth on them; the lower-left
  // first molar site (phi = +56 deg) is left empty for the virtual tooth.
  for (const bool upper : {false, true}) {
    std::vector<V3> line;
    const float y = upper ? 0.028f : -0.024f, sx = upper ? 1.06f : 1.0f;
    for (int k = 0; k <= 40; ++k) {
      const double phi = (-85.0 + 170.0 * k / 40) * M_PI / 180;
      V3 p = arch_point(phi, y).cast<float>();
      p.x() *= sx;
      line.push_back(p);
    }
    add_tube(m, line, 0.008f, gum, 16);
    m.add(ellipsoid(line.front(), Eigen::Matrix3f::Identity(), V3::Constant(0.008f), gum, 16));
    m.add(ellipsoid(line.back(), Eigen::Matrix3f::Identity(), V3::Constant(0.008f), gum, 16));
    struct T {
      float phi_deg, md, bl, h;
    };
    const T kTeeth[] = {{5, 2.8f, 2.5f, 4.5f},  {15, 2.9f, 2.6f, 4.5f}, {25, 3.4f, 3.4f, 5.0f},
                        {34, 3.5f, 4.0f, 4.0f}, {43, 3.6f, 4.2f, 4.0f}, {56, 5.0f, 5.3f, 3.8f},
                        {74, 4.8f, 5.1f, 3.6f}};
    for (const T& t : kTeeth)
      for (const float s : {-1.f, 1.f}) {
        if (!upper && s > 0 && t.phi_deg == 56)
          continue;  // the virtual tooth's site (station_scene.cpp)
        const double phi = s * t.phi_deg * M_PI / 180;
        const float gum_edge = upper ? 0.020f : -0.016f;
        const float h = t.h * 1e-3f;
        V3 p = arch_point(phi, gum_edge + (upper ? -0.7f : 0.7f) * h).cast<float>();
        p.x() *= sx;
        const V3 tang = V3(0.025f * std::cos(static_cast<float>(phi)), 0,
                           -0.035f * std::sin(static_cast<float>(phi)))
                            .normalized();
        Eigen::Matrix3f R;
        R.col(0) = tang;
        R.col(1) = V3::UnitY();
        R.col(2) = tang.cross(V3::UnitY());
        m.add(ellipsoid(p, R, {t.md * 1e-3f, h, t.bl * 1e-3f},
                        teeth * (1.0f + 0.05f * jitter(static_cast<int>(t.phi_deg), upper, s > 0)),
                        20));
      }
  }
  // Neck down to the chair.
  m.add(capsule({0.f, -0.05f, -0.095f}, {0.f, -0.25f, -0.11f}, 0.05f, 0.06f, skin * 0.95f));
  return m;
}

Mesh hand_mesh(const HandpieceParams& hp, double head_centre_z_m) {
  // Pen grasp on the handpiece's neck: index finger on top, thumb and middle
  // finger on the sides, the other fingers curled, the palm and forearm
  // behind. "Top" = away from the bur (-z of tip), "side" = y of tip.
  const V3 skin(0.86f, 0.66f, 0.55f);
  const float a = static_cast<float>(hp.handle_angle_rad);
  const V3 head(0.f, 0.f, static_cast<float>(head_centre_z_m));
  const V3 d(-std::sin(a), 0.f, std::cos(a));  // handle direction
  V3 up = -V3::UnitZ();
  up = (up - up.dot(d) * d).normalized();
  const V3 side = V3::UnitY();
  auto P = [&](float s, float u, float w) { return V3(head + s * d + u * up + w * side); };
  const float rn = static_cast<float>(hp.neck_radius_m), rb = static_cast<float>(hp.body_radius_m);
  Mesh m;
  // Finger segments (proximal end, distal end) start ~40 mm up the handle,
  // outside the mouth.
  m.add(capsule(P(0.040f, rn + 0.006f, 0.f), P(0.072f, rb + 0.009f, 0.f), 0.0065f, 0.007f, skin));
  m.add(
      capsule(P(0.072f, rb + 0.009f, 0.f), P(0.094f, rb + 0.026f, 0.003f), 0.007f, 0.0085f, skin));
  m.add(capsule(P(0.042f, 0.002f, rn + 0.007f), P(0.074f, 0.010f, rb + 0.011f), 0.0075f, 0.0085f,
                skin));
  m.add(capsule(P(0.074f, 0.010f, rb + 0.011f), P(0.097f, 0.022f, 0.020f), 0.0085f, 0.010f, skin));
  m.add(capsule(P(0.046f, -0.004f, -rn - 0.006f), P(0.072f, 0.004f, -rb - 0.010f), 0.0065f, 0.0075f,
                skin));
  m.add(
      capsule(P(0.072f, 0.004f, -rb - 0.010f), P(0.094f, 0.020f, -0.022f), 0.0075f, 0.0085f, skin));
  m.add(capsule(P(0.082f, -0.006f, -0.026f), P(0.104f, 0.016f, -0.030f), 0.007f, 0.008f, skin));
  Eigen::Matrix3f R;
  R.col(0) = d;
  R.col(1) = up;
  R.col(2) = d.cross(up);
  m.add(ellipsoid(P(0.120f, 0.030f, -0.004f), R, {0.045f, 0.016f, 0.040f}, skin, 28));
  // The forearm drops steeply toward the operator's elbow, below the line of
  // sight of the head camera.
  m.add(capsule(P(0.145f, 0.026f, -0.004f), P(0.19f, -0.21f, -0.02f), 0.026f, 0.032f, skin, 24));
  return m;
}

Mesh tag_quad(double half_size_m) {
  Mesh m;
  const float h = static_cast<float>(half_size_m);
  const V3 n(0, 0, -1);  // toward the reader (tag z points into the tag)
  const float xs[4] = {-h, h, h, -h}, ys[4] = {-h, -h, h, h};
  for (int k = 0; k < 4; ++k) {
    Vertex v;
    v.position_m = V3(xs[k], ys[k], 0);
    v.normal = n;
    v.rgb = V3::Ones();
    // Texture row 0 (uploaded first) is the image top, at tag y = -h.
    v.uv = Eigen::Vector2f((xs[k] + h) / (2 * h), (ys[k] + h) / (2 * h));
    m.vertices.push_back(v);
  }
  add_tri(m, 0, 1, 2);
  add_tri(m, 0, 2, 3);
  return m;
}

}  // namespace dentar::ar::scene
