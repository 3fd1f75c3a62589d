// Mirror use: how the student saw the working site, frame by frame, from the
// camera and mirror poses a live recording or an offline run writes
// (frames.csv) and the station's static transforms. Four sightline classes
// (docs/formats.md, "Mirror use"):
//   direct  the site is seen straight from the camera, not in the mirror;
//   mirror  the site is seen only in the mirror (indirect vision);
//   both    seen directly and in the mirror;
//   none    seen neither way (working blind).
// A session log alone has no camera or mirror poses: mirror use is then
// unavailable (with the reason), never zero.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "dentar/training/session.h"

namespace dentar::training {

// Static station geometry (metres) the drivers take from station.json.
struct SightGeometry {
  Eigen::Isometry3d T_man_tooth = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_mtag_mir = Eigen::Isometry3d::Identity();  // mirror plane (z = reflecting normal)
  double mirror_radius_m = 0.011;
  // Camera field of view as tan of the half angles (0: no field-of-view test).
  double tan_half_fov_x = 0, tan_half_fov_y = 0;
  // A surface is seen when the sight line makes at most this angle with its
  // outward normal (grazing views do not count).
  double max_view_angle_deg = 75;
};

// One camera frame: poses as drawn (tracking or predicted), the session time
// (haptic steps done / rate) and the pedal.
struct ViewFrame {
  double session_s = 0;
  bool pedal = false;
  std::optional<Eigen::Isometry3d> T_cam_man;   // empty: mannequin lost
  std::optional<Eigen::Isometry3d> T_cam_mtag;  // empty: mirror lost
};

// frames.csv is read by its one reader, session::read_view_frames (session/frames_csv.h,
// above this room), and handed in: ScoreOptions::read_frames, or the frames themselves.

enum class Sightline : int { kDirect = 0, kMirror = 1, kBoth = 2, kNone = 3 };
const char* sightline_name(Sightline s);

// Classifies one view of the site p (tooth frame, m) whose outward normal is
// n (unit, tooth frame). T_cam_mir: the mirror plane in the camera frame, or
// empty when the mirror is not tracked.
Sightline classify_sightline(const SightGeometry& g, const Eigen::Vector3d& p_tooth, const Eigen::Vector3d& n_tooth,
                             const Eigen::Isometry3d& T_cam_tooth, const std::optional<Eigen::Isometry3d>& T_cam_mir);

struct MirrorUse {
  bool available = false;
  std::string why;  // when unavailable: the reason
  int frames = 0, frames_tracked = 0, frames_mirror_tracked = 0;  // camera frames; mannequin tracked; mirror tracked too
  std::array<int, 4> all{};       // per class, frames with the mannequin tracked
  std::array<int, 4> drilling{};  // per class, those with the pedal down
  std::vector<std::array<int, 4>> by_step;  // per exercise step, drilling frames per class
  double drilling_pct(Sightline s) const;   // % of drilling frames (all tracked frames when none drilled)
};

// Site per frame: the bur tip while the pedal is down, else the focus of the
// step the frame falls in; its normal is that step's approach direction.
MirrorUse mirror_use(const std::vector<ViewFrame>& frames, const SightGeometry& g, const SessionTrack& track,
                     const Exercise& ex, const std::vector<int>& steps);

}  // namespace dentar::training
