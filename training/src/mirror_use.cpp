#include "dentar/training/mirror_use.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace dentar::training {

const char* sightline_name(Sightline s) {
  switch (s) {
    case Sightline::kDirect: return "direct";
    case Sightline::kMirror: return "mirror";
    case Sightline::kBoth: return "both";
    case Sightline::kNone: return "none";
  }
  return "?";
}

Sightline classify_sightline(const SightGeometry& g, const Eigen::Vector3d& p_tooth, const Eigen::Vector3d& n_tooth,
                             const Eigen::Isometry3d& T_cam_tooth, const std::optional<Eigen::Isometry3d>& T_cam_mir) {
  const double cos_max = std::cos(g.max_view_angle_deg * M_PI / 180.0);
  const Eigen::Vector3d p = T_cam_tooth * p_tooth;                          // site, camera frame
  const Eigen::Vector3d n = (T_cam_tooth.linear() * n_tooth).normalized();  // its outward normal
  auto in_view = [&](const Eigen::Vector3d& x) {
    if (x.z() <= 1e-4) return false;
    if (g.tan_half_fov_x > 0 && std::abs(x.x() / x.z()) > g.tan_half_fov_x) return false;
    if (g.tan_half_fov_y > 0 && std::abs(x.y() / x.z()) > g.tan_half_fov_y) return false;
    return true;
  };
  // Sight line from the site toward a point q: within the cone about the normal.
  auto faces = [&](const Eigen::Vector3d& q) {
    const Eigen::Vector3d d = q - p;
    const double len = d.norm();
    return len > 1e-9 && d.dot(n) >= cos_max * len;
  };
  const bool direct = in_view(p) && faces(Eigen::Vector3d::Zero());
  bool mirror = false;
  if (T_cam_mir) {
    const Eigen::Vector3d m = T_cam_mir->translation();
    const Eigen::Vector3d nm = T_cam_mir->linear().col(2);
    // The reflecting face must face the camera (at the origin) and the site.
    const double cam_side = (-m).dot(nm), site_side = (p - m).dot(nm);
    if (cam_side > 0 && site_side > 0) {
      const Eigen::Vector3d cam_image = -2.0 * cam_side * nm;  // camera reflected in the mirror plane (origin - 2 d n)
      // Where the line from the site to the reflected camera meets the plane.
      const double a = (p - m).dot(nm), b = (cam_image - m).dot(nm);
      if (a - b != 0) {
        const double t = a / (a - b);
        const Eigen::Vector3d q = p + t * (cam_image - p);
        mirror = (q - m).norm() <= g.mirror_radius_m && in_view(q) && faces(q);
      }
    }
  }
  if (direct && mirror) return Sightline::kBoth;
  if (direct) return Sightline::kDirect;
  if (mirror) return Sightline::kMirror;
  return Sightline::kNone;
}

double MirrorUse::drilling_pct(Sightline s) const {
  int n = 0;
  for (int c : drilling) n += c;
  const auto& src = n > 0 ? drilling : all;
  if (n == 0)
    for (int c : all) n += c;
  return n > 0 ? 100.0 * src[static_cast<std::size_t>(s)] / n : 0.0;
}

MirrorUse mirror_use(const std::vector<ViewFrame>& frames, const SightGeometry& g, const SessionTrack& track,
                     const Exercise& ex, const std::vector<int>& steps) {
  MirrorUse u;
  u.by_step.assign(ex.steps.size(), {});
  u.frames = static_cast<int>(frames.size());
  if (frames.empty()) {
    u.why = "no camera frames";
    return u;
  }
  if (track.size() == 0) {
    u.why = "the session log holds no frame";
    return u;
  }
  const std::vector<Eigen::Vector3d> focus = step_focus(ex, nullptr, nullptr);
  const double t0 = track.t_s.front();
  const double rate = track.rate_hz > 0 ? track.rate_hz : 100.0;
  for (const ViewFrame& f : frames) {
    if (f.T_cam_mtag) ++u.frames_mirror_tracked;
  }
  if (u.frames_mirror_tracked == 0) {
    u.why = "the mirror was never tracked in " + std::to_string(u.frames) + " camera frames";
    return u;
  }
  for (const ViewFrame& f : frames) {
    if (!f.T_cam_man) continue;
    ++u.frames_tracked;
    const long idx = std::lround((f.session_s - t0) * rate);
    const std::size_t i = static_cast<std::size_t>(std::clamp<long>(idx, 0, static_cast<long>(track.size()) - 1));
    const int k = i < steps.size() ? steps[i] : -1;
    Eigen::Vector3d n = Eigen::Vector3d::UnitZ(), p = track.tip_m[i];
    if (k >= 0 && static_cast<std::size_t>(k) < ex.steps.size()) {
      n = ex.steps[static_cast<std::size_t>(k)].approach.normalized();
      if (!f.pedal && static_cast<std::size_t>(k) < focus.size()) p = focus[static_cast<std::size_t>(k)];
    }
    const Eigen::Isometry3d T_cam_tooth = *f.T_cam_man * g.T_man_tooth;
    std::optional<Eigen::Isometry3d> T_cam_mir;
    if (f.T_cam_mtag) T_cam_mir = *f.T_cam_mtag * g.T_mtag_mir;
    const auto c = static_cast<std::size_t>(classify_sightline(g, p, n, T_cam_tooth, T_cam_mir));
    ++u.all[c];
    if (f.pedal) {
      ++u.drilling[c];
      if (k >= 0 && static_cast<std::size_t>(k) < u.by_step.size()) ++u.by_step[static_cast<std::size_t>(k)][c];
    }
  }
  if (u.frames_tracked == 0) {
    u.why = "the mannequin was never tracked";
    return u;
  }
  u.available = true;
  return u;
}

}  // namespace dentar::training
