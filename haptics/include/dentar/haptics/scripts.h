// Scripted sessions for the simulated hand: a default station geometry and
// the hand paths used by the demo, the tests and the benchmarks. Paths are
// written for the bur tip in the tooth frame and converted to stylus poses
// in the device frame through the station transforms.
#pragma once

#include <string>
#include <vector>

#include "dentar/haptics/simulated_device.h"

namespace dentar::haptics {

struct Station {
  Eigen::Isometry3d T_tooth_dev;  // device base in the tooth frame
  Eigen::Isometry3d T_sty_tip;    // bur tip on the stylus
};
// A bench as a dental simulator sets it up: the device's workspace centre
// (the dev origin) 28 mm straight above the tooth frame's origin (the crown's
// cervical centre), i.e. where the stylus origin sits while the bur works on
// the occlusal table; dev y up (tooth +z), dev z toward the student (tooth
// -y); the bur tip 22 mm along the stylus axis. The device's body stands in
// front of the mannequin with its arm reaching into the mouth. The whole
// crown is then within reach of the Touch, Omni and Falcon profiles
// (docs/devices.md, "Where the device stands").
inline constexpr double kDefaultWorkspaceAboveTooth_m = 0.028;
Station default_station();

// One keyframe for the bur tip (tooth frame).
struct TipWaypoint {
  double time_s;
  Eigen::Vector3d tip_tooth_m;     // target position of the bur tip
  Eigen::Vector3d axis_tooth;      // bur axis (+z of tip: out of the handpiece, toward the tooth)
  bool pedal;
};
std::vector<HandWaypoint> to_hand_script(const std::vector<TipWaypoint>& tips, const Station& s);

// Hand stiffness with a finger rest on the neighbouring teeth (N/m), as the
// "access" script assumes; the other scripts use the default free hand.
inline constexpr double kFingerRestStiffness_N_per_m = 3000.0;

// Scripts, all for the default procedural molar:
//  "access": an occlusal access preparation (passes along the central
//     groove, 0.4 mm deeper each time, then a plunge that exposes the pulp);
//  "press": tip pressed straight down into the central fossa enamel with a
//     hand offset that asks for about `press_force_N` (pedal up);
//  "slide": the tip dragged along the central groove with ~1.5 N (pedal up);
//  "probe": pedal up, touching enamel, dentin (in a pre-cut cavity) and
//     rotating from tip contact to side contact.
// `seconds` scales the script duration where it applies (<= 0: default).
std::vector<TipWaypoint> tip_script(const std::string& name, double press_force_N = 3.0,
                                    double seconds = 0.0);

}  // namespace dentar::haptics
