#include "dentar/haptics/scripts.h"

#include <cmath>

namespace dentar::haptics {

Station default_station() {
  Station s;
  // Device y up -> tooth +z; device z toward the student -> tooth -y.
  s.T_tooth_dev = Eigen::Isometry3d::Identity();
  s.T_tooth_dev.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  // The workspace centre (the dev origin) where the stylus origin sits while the bur cuts the
  // occlusal table: 22 mm (the bur offset) above the ~6 mm crown, so the work happens where the
  // device is stiffest and the whole crown is within reach of every profile (Falcon: 62 mm of
  // reach, the crown's farthest corner 29 mm away). Until issue 24 the device stood 19 cm away,
  // out of reach of all but the Premium 3.0 (docs/devices.md, "Where the device stands").
  s.T_tooth_dev.translation() = Eigen::Vector3d(0.0, 0.0, kDefaultWorkspaceAboveTooth_m);
  s.T_sty_tip = Eigen::Isometry3d::Identity();
  s.T_sty_tip.translation() = Eigen::Vector3d(0, 0, 0.022);
  return s;
}

std::vector<HandWaypoint> to_hand_script(const std::vector<TipWaypoint>& tips, const Station& s) {
  std::vector<HandWaypoint> out;
  out.reserve(tips.size());
  const Eigen::Isometry3d T_dev_tooth = s.T_tooth_dev.inverse();
  const Eigen::Isometry3d T_tip_sty = s.T_sty_tip.inverse();
  for (const auto& t : tips) {
    Eigen::Isometry3d T_tooth_tip = Eigen::Isometry3d::Identity();
    T_tooth_tip.linear() =
        Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), t.axis_tooth.normalized())
            .toRotationMatrix();
    T_tooth_tip.translation() = t.tip_tooth_m;
    const Eigen::Isometry3d T_dev_sty = T_dev_tooth * T_tooth_tip * T_tip_sty;
    HandWaypoint w;
    w.time_s = t.time_s;
    w.position_m = T_dev_sty.translation();
    w.orientation = Eigen::Quaterniond(T_dev_sty.linear());
    w.pedal = t.pedal;
    out.push_back(w);
  }
  return out;
}

std::vector<TipWaypoint> tip_script(const std::string& name, double press_force_N,
                                    double seconds) {
  const Eigen::Vector3d down(0, 0, -1);
  // The hand spring is 400 N/m by default: a target this far below the
  // surface asks for the wanted force once the bur rests on it.
  // The hand spring (400 N/m) and the proxy coupling (0.8 x 2000 N/m) act in
  // series: a target this far below the surface asks for the wanted force.
  const double offset = press_force_N / 400.0 + press_force_N / 1600.0;
  std::vector<TipWaypoint> s;
  if (name == "press") {
    // Central fossa: a local minimum of the occlusal surface (~5.8 mm), so a
    // frictionless bur pressed straight down stays put instead of sliding
    // off a cusp slope.
    const Eigen::Vector3d cusp(0.0, 0.0, 0);
    s.push_back({0.0, cusp + Eigen::Vector3d(0, 0, 9e-3), down, false});
    s.push_back({0.3, cusp + Eigen::Vector3d(0, 0, 6.2e-3), down, false});
    s.push_back({0.5, cusp + Eigen::Vector3d(0, 0, 5.9e-3 - offset), down, false});
    s.push_back({seconds > 0 ? 0.5 + seconds : 1.5, cusp + Eigen::Vector3d(0, 0, 5.9e-3 - offset),
                 down, false});
  } else if (name == "slide") {
    const double T = seconds > 0 ? seconds : 2.0;
    const double off = 1.5 / 400.0 + 1.5 / 1600.0;
    // Along the central groove (a valley between the buccal and palatal
    // cusps), so a frictionless bur stays on the occlusal table.
    // (The molar has no marginal ridges: past the cusps, |x| > 2 mm, the
    // groove runs downhill off the crown.)
    s.push_back({0.0, {-1.4e-3, 0, 9e-3}, down, false});
    s.push_back({0.3, {-1.4e-3, 0, 6.0e-3 - off}, down, false});
    s.push_back({0.3 + T, {1.4e-3, 0, 6.0e-3 - off}, down, false});
    s.push_back({0.5 + T, {1.4e-3, 0, 9e-3}, down, false});
  } else if (name == "probe") {
    const Eigen::Vector3d p(0.0, -0.5e-3, 0);
    const double off = 1.0 / 400.0 + 1.0 / 1600.0;
    s.push_back({0.0, p + Eigen::Vector3d(0, 0, 9e-3), down, false});
    s.push_back({0.3, p + Eigen::Vector3d(0, 0, 6.3e-3 - off), down, false});
    // Tilt from vertical (tip contact) to 80 degrees (side contact) while pressing.
    for (int i = 1; i <= 8; ++i) {
      const double a = i * 10.0 * M_PI / 180.0;
      s.push_back({0.3 + 0.25 * i, p + Eigen::Vector3d(0, 0, 6.3e-3 - off),
                   Eigen::Vector3d(std::sin(a), 0, -std::cos(a)), false});
    }
    s.push_back({2.6, p + Eigen::Vector3d(0, 0, 9e-3), down, false});
  } else {  // "access"
    // Depth control as a dentist does it, with a finger rest on the next
    // teeth (a stiff hand, kFingerRestStiffness): the hand aims just below the
    // pass depth, so the pressing force and with it the cutting rate fall
    // off as the bur reaches it.
    const double lead = press_force_N / 3000.0;
    const double pass_s = seconds > 0 ? seconds / 14.0 : 1.0;
    double t = 0, z = 6.4e-3;
    s.push_back({t, {-1.2e-3, 0, 9e-3}, down, false});
    t += 0.3;
    s.push_back({t, {-1.2e-3, 0, z}, down, true});
    for (int pass = 0; pass < 6; ++pass) {
      z -= 0.3e-3;
      const double x = pass % 2 ? -1.2e-3 : 1.2e-3;
      t += 2 * pass_s;
      s.push_back({t, {x, 0, z - lead}, down, true});
    }
    t += 0.5;
    s.push_back({t, {0, 0, z - lead}, down, true});
    t += 1.5;
    s.push_back({t, {0, 0, 2.9e-3 - lead}, down, true});  // plunge toward the chamber roof
    t += 0.5;
    s.push_back({t, {0, 0, 9e-3}, down, false});
  }
  return s;
}

}  // namespace dentar::haptics
