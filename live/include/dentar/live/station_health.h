// Station health: what `dentar live` checks at the start of each student session, and says
// plainly when the station needs an instructor (docs/calibration.md, "Station health").
//  1. the station file (check_station_file): how old the calibration is against the
//     station's policy (station_policy.max_age_days), whether it was ever checked and passed,
//     whether it was calibrated with this camera (camera.device_id);
//  2. the mannequin's tag layout (TagLayoutCheck): over the first tracked frames, each
//     mannequin tag's corners are predicted from a bundle pose fitted WITHOUT that tag; a tag
//     that sits elsewhere than the file says (moved, re-stuck, bent) shows as a displacement
//     in mm at its own depth;
//  3. the stylus tip at a known divot (DivotTouchCheck): when the student holds the bur tip
//     still in the health divot (station_policy.health_divot), the calibrated chain must put
//     the tip there within station_policy.tip_check_mm.
// The checks run on the frame thread (2, 3: a few ms per frame, only until they are done);
// their results are plain values the HUD and live.log show.
#pragma once

#include <Eigen/Geometry>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "dentar/ar/station_scene.h"
#include "dentar/ar/tag_detector.h"
#include "dentar/calibration/touch.h"
#include "dentar/haptics/device_profiles.h"
#include "dentar/volume/result.h"

namespace dentar::live {

// kNote: worth knowing, nothing wrong (a built-in station: "uncalibrated (built-in
// intrinsics)"); kWarning: something to fix soon; kInstructor: the alarm, an instructor must act.
enum class HealthLevel { kOk = 0, kNote = 1, kWarning = 2, kInstructor = 3 };
const char* health_level_name(HealthLevel l);  // "ok", "note", "warning", "instructor needed"

struct HealthItem {
  std::string check;  // "calibration age", "station check", "camera", "tag layout", "stylus tip"
  HealthLevel level = HealthLevel::kOk;
  std::string message;  // one plain sentence, with what to do when not ok
};

struct StationHealth {
  std::vector<HealthItem> items;
  void set(const HealthItem& item);  // adds or replaces the item of item.check
  bool instructor_needed() const;
  HealthLevel worst() const;
  // One line for the HUD and the log: "station OK", "INSTRUCTOR NEEDED: <first reason>",
  // "station warning: <first reason>" or, for a note, "<check>: <message>".
  std::string headline() const;
};

// Days between an ISO 8601 UTC date ("2026-11-25T10:00:00Z") and now_unix (s since the epoch);
// nullopt when the text is not such a date.
std::optional<double> age_days(const std::string& iso_date, double now_unix);

// The file checks. `builtin` = a built-in station (never calibrated for a bench: a note,
// "uncalibrated (built-in intrinsics)", fine for a try-out); camera_identity = ar::FrameSource's identity of the opened camera
// (empty: unknown, not compared).
std::vector<HealthItem> check_station_file(const ar::StationScene& st, bool builtin,
                                           double now_unix, const std::string& camera_identity);

class TagLayoutCheck {
 public:
  // frames_needed: mannequin frames with >= 3 tags to look at before deciding.
  explicit TagLayoutCheck(const ar::StationScene& st, int frames_needed = 10);
  // One frame's detections (full-image OpenCV px, as the tracker reports them).
  void add(const std::vector<ar::DetectedTag>& detections);
  bool done() const { return frames_ >= frames_needed_; }
  int frames() const { return frames_; }
  // Median displacement of each tag seen, m (tag id -> mm-scale value in metres).
  std::map<int, double> displacement_m() const;
  // Once done(): ok, or the tags that moved (id and mm) with what to do.
  HealthItem result() const;

 private:
  ar::StationScene st_;
  int frames_needed_;
  int frames_ = 0;
  std::map<int, std::vector<double>> disp_;  // per tag, per frame, m
};

class DivotTouchCheck {
 public:
  explicit DivotTouchCheck(const ar::StationScene& st);
  // The stylus pose from the device (T_dev_sty) at t_s; valid = the device reports a pose.
  // Returns the item once, when the tip has been held still within capture radius of the
  // divot for a touch; nullopt otherwise.
  std::optional<HealthItem> add(double t_s, const Eigen::Isometry3d& T_dev_sty, bool valid);
  bool done() const { return done_; }
  bool available() const { return available_; }  // the station lists the divot
  double error_m() const { return error_m_; }     // tip to divot at the touch, m (-1 before)
  Eigen::Vector3d divot_man() const { return divot_man_; }

 private:
  ar::StationScene st_;
  bool available_ = false, done_ = false;
  Eigen::Vector3d divot_man_ = Eigen::Vector3d::Zero();
  double capture_radius_m_ = 4e-3;  // a tip this close to the divot is trying to touch it
  double error_m_ = -1;
  calibration::TouchDetector touch_;
};

// 4. the stylus reach (check_station_reach): can the connected device's stylus (or a chosen
//    profile's) reach the whole crown from where the station file puts the device? When not,
//    how far to move the device and in which direction, in the mannequin's words (toward the
//    patient's left/right, up/down, toward/away from the face) or, for the box station, the
//    board's (toward which tags, up off the board).
//
// The crown's bounding box in the tooth frame: the solid voxels of the station's procedural
// molar (tooth_voxel_m) above its cervical region (the top crown_height_mm), where the bur works.
// Builds the molar (a few ms at 0.1 mm). Errors name the tooth's parameters.
Result<Eigen::AlignedBox3d> crown_box_tooth(const ar::StationScene& st);
// The same for any tooth a session drills, from its description ({"kind": "molar"|"incisor",
// "voxel_mm": ...}, as in the session header): the top crown_height_mm of the molar, the top
// crown_length_mm of the incisor (their default parameters, as training::make_tooth builds them).
Result<Eigen::AlignedBox3d> crown_box_tooth(const std::string& tooth_json);

struct StationReach {
  haptics::ReachReport reach;                       // in the tooth frame
  Eigen::Vector3d move_man_m = Eigen::Vector3d::Zero();  // the suggested device move, mannequin frame
  std::vector<int> divots_out_of_reach;             // calibration_fixtures.divots indices the tip cannot touch
  HealthItem item;  // "stylus reach": ok, or instructor needed with the move in mm and words
};
// `device` names the device for the message ("3D Systems Touch (profile 'touch')").
StationReach check_station_reach(const ar::StationScene& st, const haptics::DeviceLimits& limits,
                                 const std::string& device, const Eigen::AlignedBox3d& crown_tooth);
// "48 mm: 40 mm toward the patient's left, 26 mm down" (mannequin station) or the board's words
// (the box station); components under 1 mm are left out.
std::string describe_move_man(const ar::StationScene& st, const Eigen::Vector3d& move_man_m);

// Everything above for one live session, safe to read from the display thread while the frame
// thread feeds it. The file checks run at construction. On a built-in station nothing was
// calibrated for this bench, so no check raises the alarm: a tag layout that differs from the
// built-in one (a kit taped by hand) is a warning that placement is approximate.
class StationHealthMonitor {
 public:
  StationHealthMonitor(const ar::StationScene& st, bool builtin, double now_unix,
                       const std::string& camera_identity);
  // Frame thread: one processed frame's detections and the stylus pose drawn with it
  // (T_dev_sty; stylus_valid = the device reported one). Returns the items that changed.
  std::vector<HealthItem> on_frame(const std::vector<ar::DetectedTag>& detections, double t_s,
                                   const Eigen::Isometry3d& T_dev_sty, bool stylus_valid);
  StationHealth health() const;
  // The file checks' item that must stop the session (a station file of another camera), if any.
  std::optional<HealthItem> refusal() const;
  // Adds or replaces an item found outside the monitor (the stylus reach, once the device is open).
  void set(const HealthItem& item);

 private:
  mutable std::mutex m_;
  StationHealth health_;
  TagLayoutCheck layout_;
  DivotTouchCheck divot_;
  bool builtin_;
};

// Which physical camera a FrameSource spec names, for camera.device_id: "<V4L2 card> @ <bus>"
// for camera:N and /dev/videoN (empty when it cannot be queried), "footage <folder>/<file>"
// for live:PATH and video files (the generator's and recorded footage stand in for cameras).
std::string camera_identity(const std::string& spec);

}  // namespace dentar::live
