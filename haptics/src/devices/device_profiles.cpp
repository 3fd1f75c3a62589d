#include "dentar/haptics/device_profiles.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <sstream>

namespace dentar::haptics {
namespace {

const char* kChaiHd =
    "CHAI3D 3.2 device specifications, src/devices/CPhantomDevices.cpp (github.com/chai3d/chai3d)";
const char* kChaiDhd =
    "CHAI3D 3.2 device specifications, src/devices/CDeltaDevices.cpp (github.com/chai3d/chai3d)";

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string num(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

}  // namespace

const std::vector<DeviceProfile>& device_profiles() {
  static const std::vector<DeviceProfile> table = {
      {"touch", "3D Systems Touch", "hd", 3.3, 400.0, 4.0, 0.075, 0.045, kChaiHd,
       "estimate: 45 g, the apparent tip mass on the Phantom Omni/Touch data sheets",
       {"Touch", "Geomagic Touch", "Phantom Touch", "Sensable Phantom Touch"}},
      // CHAI3D 3.2 gives the Omni 3.3 N (the vendor's sheet); CHAI3D 2.x gave 4.0 N.
      {"omni", "SensAble PHANTOM Omni", "hd", 3.3, 700.0, 5.0, 0.10, 0.045, kChaiHd,
       "estimate: 45 g, the apparent tip mass on the Phantom Omni data sheet",
       {"PHANTOM Omni", "Phantom Omni", "Omni"}},
      {"desktop", "PHANTOM Desktop / Touch X", "hd", 7.9, 1000.0, 5.0, 0.10, 0.045, kChaiHd,
       "estimate: 45 g, the apparent tip mass on the Phantom Desktop data sheet",
       {"PHANTOM Desktop", "Phantom Desktop", "Touch X", "Geomagic Touch X"}},
      {"premium", "PHANTOM Premium 1.5", "hd", 8.5, 800.0, 5.0, 0.12, 0.075, kChaiHd,
       "estimate: 75 g, the apparent tip mass on the Phantom Premium 1.5 data sheet",
       {"PHANTOM Premium 1.5 6DOF", "PHANTOM Premium 1.5", "Phantom Premium", "Premium 1.5"}},
      {"premium3", "PHANTOM Premium 3.0", "hd", 22.0, 1000.0, 5.0, 0.25, 0.15, kChaiHd,
       "estimate: 150 g (twice the Premium 1.5)", {"PHANTOM Premium 3.0 6DOF", "Premium 3.0"}},
      {"omega", "Force Dimension omega.3/6/7", "dhd", 12.0, 5000.0, 30.0, 0.075, 0.20, kChaiDhd,
       "estimate: 200 g (parallel delta stage)",
       {"omega.3", "omega.6", "omega.7", "omega"}},
      {"sigma", "Force Dimension sigma.7 / sigma.6+", "dhd", 12.0, 4000.0, 30.0, 0.075, 0.30,
       kChaiDhd, "estimate: 300 g (delta stage with active wrist)",
       {"sigma.7", "sigma.6+", "sigma"}},
      {"delta", "Force Dimension delta.3/6", "dhd", 20.0, 5000.0, 30.0, 0.15, 0.40, kChaiDhd,
       "estimate: 400 g (large delta stage)", {"delta.3", "delta.6", "delta"}},
      {"falcon", "Novint Falcon", "dhd", 8.0, 3000.0, 20.0, 0.04, 0.15, kChaiDhd,
       "estimate: 150 g", {"Falcon", "Novint Falcon"}},
  };
  return table;
}

const DeviceProfile* find_device_profile(const std::string& name) {
  const std::string n = lower(name);
  if (n.empty()) return nullptr;
  for (const DeviceProfile& p : device_profiles()) {
    if (lower(p.id) == n) return &p;
    for (const std::string& a : p.aliases)
      if (lower(a) == n) return &p;
  }
  return nullptr;
}

DeviceLimits limits_from_profile(const DeviceProfile& p) {
  DeviceLimits l;
  l.max_force_N = p.max_force_N;
  l.max_stiffness_N_per_m = p.max_stiffness_N_per_m;
  l.max_damping_N_s_per_m = p.max_damping_N_s_per_m;
  l.workspace_radius_m = p.workspace_radius_m;
  l.workspace_min_m = Eigen::Vector3d::Constant(-p.workspace_radius_m);
  l.workspace_max_m = Eigen::Vector3d::Constant(p.workspace_radius_m);
  return l;
}

Status apply_profile(const DeviceProfile& p, const GainRequest& r, DeviceLimits& limits,
                     ForceModelParams& params) {
  const std::string who = p.display_name + " (profile '" + p.id + "')";
  const auto check = [&](double v, double max, const char* what, const char* unit,
                         const char* option) -> std::string {
    if (!std::isfinite(v) || v < 0)
      return std::string(what) + " = " + num(v) + " " + unit + " must be finite and >= 0 (0 = from the profile)";
    if (v > max)
      return std::string(what) + " = " + num(v) + " " + unit + " is above the " + who + "'s " +
             num(max) + " " + unit + " (" + p.source + "); the device would buzz or kick. Use " +
             option + " <= " + num(max) + " or leave it out to use the profile";
    return {};
  };
  if (std::string e = check(r.stiffness_N_per_m, p.max_stiffness_N_per_m, "stiffness", "N/m",
                            "--stiffness");
      !e.empty())
    return Error{e};
  if (std::string e = check(r.damping_N_s_per_m, p.max_damping_N_s_per_m, "damping", "N s/m",
                            "--damping");
      !e.empty())
    return Error{e};
  if (std::string e = check(r.max_force_N, p.max_force_N, "max force", "N", "--max-force");
      !e.empty())
    return Error{e};
  limits = limits_from_profile(p);
  if (r.max_force_N > 0) limits.max_force_N = r.max_force_N;
  params.proxy.stiffness_N_per_m =
      r.stiffness_N_per_m > 0 ? r.stiffness_N_per_m : 0.8 * p.max_stiffness_N_per_m;
  if (r.damping_N_s_per_m > 0) {
    params.proxy.damping_N_s_per_m = r.damping_N_s_per_m;
    params.seed.c2_N_s_per_m = r.damping_N_s_per_m;
  } else {
    params.proxy.damping_N_s_per_m = std::min(params.proxy.damping_N_s_per_m, p.max_damping_N_s_per_m);
    params.seed.c2_N_s_per_m = std::min(params.seed.c2_N_s_per_m, p.max_damping_N_s_per_m);
  }
  return {};
}

ReachReport check_reach(const DeviceLimits& limits, const Eigen::Isometry3d& T_tooth_dev,
                        const Eigen::Isometry3d& T_sty_tip, const Eigen::AlignedBox3d& box) {
  ReachReport r;
  const double radius = limits.workspace_radius_m > 0
                            ? limits.workspace_radius_m
                            : 0.5 * (limits.workspace_max_m - limits.workspace_min_m).minCoeff();
  const Eigen::Vector3d centre_dev =
      limits.workspace_radius_m > 0 ? Eigen::Vector3d::Zero()
                                    : Eigen::Vector3d(0.5 * (limits.workspace_max_m + limits.workspace_min_m));
  r.reach_m = radius + T_sty_tip.translation().norm();
  const Eigen::Isometry3d T_dev_tooth = T_tooth_dev.inverse();
  Eigen::Vector3d worst = Eigen::Vector3d::Zero();
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3d p_tooth = box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c));
    const Eigen::Vector3d p_dev = T_dev_tooth * p_tooth - centre_dev;
    if (p_dev.norm() >= r.worst_distance_m) {
      r.worst_distance_m = p_dev.norm();
      worst = p_tooth;
    }
  }
  r.reachable = box.isEmpty() ? false : r.worst_distance_m <= r.reach_m;
  // The shortest move toward the box centre that brings every corner kReachMargin_m inside the
  // reach: the farthest-corner distance is convex along the line, so bisect on the distance moved.
  const Eigen::Vector3d centre_tooth = T_tooth_dev * centre_dev;
  auto farthest = [&](const Eigen::Vector3d& c) {
    double d = 0;
    for (int k = 0; k < 8; ++k)
      d = std::max(d, (box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(k)) - c).norm());
    return d;
  };
  if (!box.isEmpty() && !r.reachable) {
    const Eigen::Vector3d to_box = box.center() - centre_tooth;
    const double len = to_box.norm();
    const double goal = std::max(r.reach_m - kReachMargin_m, 0.5 * box.diagonal().norm());
    if (farthest(box.center()) > r.reach_m || len <= 0) {
      r.movable = false;
    } else if (farthest(box.center()) > goal) {
      r.move_tooth_m = to_box;  // only the centred placement fits (the margin is not available)
    } else {
      double lo = 0, hi = len;
      for (int i = 0; i < 60; ++i) {
        const double mid = 0.5 * (lo + hi);
        (farthest(centre_tooth + mid * to_box / len) <= goal ? hi : lo) = mid;
      }
      r.move_tooth_m = hi * to_box / len;
    }
  }
  std::ostringstream os;
  os.precision(3);
  if (box.isEmpty()) {
    os << "the tooth has no extent: cannot check the reach";
  } else if (r.reachable) {
    os << "the stylus reaches the whole tooth: farthest point " << 1e3 * r.worst_distance_m
       << " mm from the workspace centre, reach " << 1e3 * r.reach_m << " mm";
  } else {
    os << "the stylus cannot reach the tooth: its corner (" << 1e3 * worst.x() << ", "
       << 1e3 * worst.y() << ", " << 1e3 * worst.z() << ") mm (tooth frame) is "
       << 1e3 * r.worst_distance_m << " mm from the device's workspace centre, "
       << 1e3 * (r.worst_distance_m - r.reach_m) << " mm beyond its reach of " << 1e3 * r.reach_m
       << " mm (workspace radius " << 1e3 * radius
       << " mm + bur offset); ";
    if (r.movable)
      os << "move the device closer to the mannequin, " << 1e3 * r.move_tooth_m.norm()
         << " mm toward the tooth, and recalibrate the station";
    else
      os << "the tooth is larger than this device's reach: no placement reaches all of it";
  }
  r.message = os.str();
  return r;
}

}  // namespace dentar::haptics
