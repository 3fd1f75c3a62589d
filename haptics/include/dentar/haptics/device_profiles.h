// Device profiles: what each haptic device can render, with units and the
// source of every figure. The force model's stiffness, damping and force
// clamp follow the profile of the device in use; a user value above it is
// refused (apply_profile), never clamped silently.
//
// Figures (docs/devices.md has the table and the citations):
//  - max force, max stable stiffness, max damping and workspace radius are
//    CHAI3D 3.2's device specifications (src/devices/CPhantomDevices.cpp and
//    CDeltaDevices.cpp, github.com/chai3d/chai3d), the figures CHAI3D's own
//    examples scale their materials to;
//  - the apparent tip mass is the vendor's data sheet figure where one
//    exists, else an estimate (marked so); it is used only by the simulated
//    device of the closed-loop stability suite.
// Units SI. Thread: any (the table is constant).
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <string_view>
#include <vector>

#include "dentar/haptics/device.h"
#include "dentar/haptics/force_model.h"
#include "dentar/volume/result.h"

namespace dentar::haptics {

struct DeviceProfile {
  std::string id;            // "touch", "omni", ... (the --device name)
  std::string display_name;  // "3D Systems Touch"
  std::string backend;       // "hd" (OpenHaptics) or "dhd" (Force Dimension)
  double max_force_N = 0;                // max force the device renders (the clamp)
  double max_stiffness_N_per_m = 0;      // max stable stiffness at 1 kHz
  double max_damping_N_s_per_m = 0;      // max stable virtual damping
  double workspace_radius_m = 0;         // usable workspace sphere around the dev origin
  double tip_mass_kg = 0;                // apparent mass at the stylus tip (simulation only)
  std::string source;                    // where the force/stiffness/damping/workspace come from
  std::string mass_source;               // where tip_mass_kg comes from
  // Model names the vendor runtime reports for this device (HD_DEVICE_MODEL_TYPE,
  // dhdGetSystemName), and other accepted spellings; matched case-insensitively.
  std::vector<std::string> aliases;
};

// Every profile, in a fixed order (HD devices first).
const std::vector<DeviceProfile>& device_profiles();

// By id or alias, case-insensitive ("Touch", "PHANTOM Omni", "omega.3",
// "Falcon"); null when unknown.
const DeviceProfile* find_device_profile(const std::string& name);

// The profile's limits: force, stiffness, damping, workspace (a box of
// +-radius and the radius itself).
DeviceLimits limits_from_profile(const DeviceProfile& p);

// What the user asked for on the command line or in a config; 0 = "from the
// profile" (stiffness: 0.8 x the profile's max; damping: the force model's
// default, lowered to the profile's max; force: the profile's max).
struct GainRequest {
  double stiffness_N_per_m = 0;
  double damping_N_s_per_m = 0;
  double max_force_N = 0;
};

// Sets `limits` from the profile (max force lowered to the request when one
// is given) and the force model's gains in `params` from the request.
// Refuses (error naming the value, the profile's figure and its source) any
// request above the profile or not finite/negative. Never raises a limit
// above the profile.
Status apply_profile(const DeviceProfile& p, const GainRequest& request, DeviceLimits& limits,
                     ForceModelParams& params);

// Can the stylus reach the tooth? The dev-frame origin is the workspace
// centre (as the HD and DHD runtimes report positions); the stylus origin
// must lie within the workspace radius while the bur tip is on the tooth,
// which it can when |p_dev| <= radius + |t_sty_tip| for every point p of
// the tooth's bounding box. Errors name the farthest corner and by how much
// it is out of reach, and say what to move.
//
// When the tooth is out of reach, move_tooth_m is the shortest move of the
// device (straight toward the tooth's box centre, in the tooth frame) after
// which every corner lies at least kReachMargin_m inside the reach; callers
// that know the station say it in the instructor's words
// (live/station_health.h, check_station_reach). Zero when reachable.
inline constexpr double kReachMargin_m = 5e-3;
struct ReachReport {
  double worst_distance_m = 0;  // farthest box corner from the workspace centre
  double reach_m = 0;           // radius + tip offset
  bool reachable = false;
  Eigen::Vector3d move_tooth_m = Eigen::Vector3d::Zero();  // suggested device move (tooth frame)
  bool movable = true;          // false: the box is larger than the reach (no move helps)
  std::string message;          // one line for the user
};
ReachReport check_reach(const DeviceLimits& limits, const Eigen::Isometry3d& T_tooth_dev,
                        const Eigen::Isometry3d& T_sty_tip, const Eigen::AlignedBox3d& tooth_box_tooth);

}  // namespace dentar::haptics
