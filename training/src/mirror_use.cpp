#include "dentar/training/mirror_use.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace dentar::training {

namespace {

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> v;
  std::string cur;
  for (char c : line) {
    if (c == ',') {
      v.push_back(cur);
      cur.clear();
    } else if (c != '\r') {
      cur += c;
    }
  }
  v.push_back(cur);
  return v;
}

bool to_double(const std::string& s, double& out) {
  if (s.empty()) return false;
  char* end = nullptr;
  out = std::strtod(s.c_str(), &end);
  return end && *end == '\0' && std::isfinite(out);
}

}  // namespace

const char* sightline_name(Sightline s) {
  switch (s) {
    case Sightline::kDirect: return "direct";
    case Sightline::kMirror: return "mirror";
    case Sightline::kBoth: return "both";
    case Sightline::kNone: return "none";
  }
  return "?";
}

Result<std::vector<ViewFrame>> read_view_frames(const std::string& path, double rate_hz) {
  std::ifstream f(path);
  if (!f) return Error{path + ": cannot open"};
  if (!(rate_hz > 0)) return Error{path + ": the session's haptic rate must be positive"};
  std::string line;
  if (!std::getline(f, line)) return Error{path + ": empty (expected a header row)"};
  const std::vector<std::string> head = split(line);
  auto col = [&](const std::string& n) -> int {
    for (std::size_t i = 0; i < head.size(); ++i)
      if (head[i] == n) return static_cast<int>(i);
    return -1;
  };
  const bool live = col("man_T") >= 0;
  const int c_step = live ? col("haptic_steps") : col("haptic_step");
  const int c_pedal = col("pedal");
  const int c_mst = col("man_state"), c_rst = col("mirror_state");
  int c_man = live ? col("man_T") : col("man_tx_mm");
  int c_mir = live ? col("mirror_T") : col("mirror_tx_mm");
  if (c_step < 0 || c_pedal < 0 || c_mst < 0 || c_rst < 0 || c_man < 0 || c_mir < 0)
    return Error{path + ": line 1: not a frames.csv of `dentar offline` or `dentar live --record` (needs " +
                 std::string(live ? "haptic_steps, man_T, mirror_T" : "haptic_step, man_tx_mm.., mirror_tx_mm..") +
                 ", man_state, mirror_state and pedal)"};
  if (!live && (col("man_qz") != c_man + 6 || col("mirror_qz") != c_mir + 6))
    return Error{path + ": line 1: expected man_tx_mm..man_qz and mirror_tx_mm..mirror_qz as 7 adjacent columns"};
  std::vector<ViewFrame> out;
  int ln = 1;
  while (std::getline(f, line)) {
    ++ln;
    if (line.empty() || line == "\r") continue;
    const std::vector<std::string> v = split(line);
    const auto need = static_cast<std::size_t>(std::max({c_step, c_pedal, c_mst, c_rst, c_man + (live ? 0 : 6),
                                                         c_mir + (live ? 0 : 6)}));
    // A row cut short by a crash ends the table (as the offline replay reads it).
    if (v.size() <= need) break;
    auto where = [&](int c) {
      return path + ": line " + std::to_string(ln) + ", column " + std::to_string(c + 1) + " (" + head[static_cast<std::size_t>(c)] + ")";
    };
    ViewFrame fr;
    double steps = 0;
    if (!to_double(v[static_cast<std::size_t>(c_step)], steps) || steps < 0)
      return Error{where(c_step) + ": '" + v[static_cast<std::size_t>(c_step)] + "' is not a step count"};
    fr.session_s = steps / rate_hz;
    fr.pedal = v[static_cast<std::size_t>(c_pedal)] == "1";
    auto pose = [&](int c_state, int c0, std::optional<Eigen::Isometry3d>& T) -> Status {
      const std::string& st = v[static_cast<std::size_t>(c_state)];
      if (st != "tracking" && st != "predicted") return {};
      Eigen::Isometry3d M = Eigen::Isometry3d::Identity();
      if (live) {
        std::istringstream ss(v[static_cast<std::size_t>(c0)]);
        double x[12];
        for (double& e : x)
          if (!(ss >> e) || !std::isfinite(e)) return Error{where(c0) + ": expected 12 numbers (3x4 pose, row-major, m)"};
        for (int i = 0; i < 12; ++i) M.matrix()(i / 4, i % 4) = x[i];
      } else {
        double x[7];
        for (int i = 0; i < 7; ++i)
          if (!to_double(v[static_cast<std::size_t>(c0 + i)], x[i]))
            return Error{where(c0 + i) + ": '" + v[static_cast<std::size_t>(c0 + i)] + "' is not a number (state " + st + ")"};
        Eigen::Quaterniond q(x[3], x[4], x[5], x[6]);
        if (q.norm() < 0.5) return Error{where(c0 + 3) + ": quaternion of length " + std::to_string(q.norm())};
        M.linear() = q.normalized().toRotationMatrix();
        M.translation() = Eigen::Vector3d(x[0], x[1], x[2]) * 1e-3;
      }
      T = M;
      return {};
    };
    if (Status s = pose(c_mst, c_man, fr.T_cam_man); !s) return Error{s.error()};
    if (Status s = pose(c_rst, c_mir, fr.T_cam_mtag); !s) return Error{s.error()};
    out.push_back(std::move(fr));
  }
  if (out.empty()) return Error{path + ": no frame rows"};
  return out;
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
