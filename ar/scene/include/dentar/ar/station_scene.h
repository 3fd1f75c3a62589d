// Station scene description: what physically stands at a training station
// (phantom head with its AprilTag bundle, tooth site, mouth mirror with its
// tag paddle) plus the station calibration values. Read by the footage
// generator (synth.h) and, later, by the live trainer. File format: JSON,
// docs/formats.md ("Station scene"). Files store mm and degrees; code holds
// metres and radians.
//
// Tag frames follow libapriltag's pose convention so a tracker can use the
// layout directly: origin at the tag centre, x to the right and y down in the
// tag image, z into the tag (away from a viewer who reads it). The four
// corners of the border square (side `size_m`) are, in order,
// (-s/2, +s/2), (+s/2, +s/2), (+s/2, -s/2), (-s/2, -s/2): the order in which
// libapriltag reports its detections' corners.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "dentar/calibration/response.h"
#include "dentar/calibration/station.h"
#include "dentar/volume/result.h"

namespace dentar::ar {

enum class TagFamilyId { kStandard41h12, kTag36h11 };
// "tagStandard41h12" / "tag36h11".
const char* tag_family_name(TagFamilyId f);
std::optional<TagFamilyId> parse_tag_family(std::string_view name);

struct TagPlacement {
  int id = 0;           // code index in the family
  double size_m = 0.0;  // side of the border square (libapriltag's "tagsize"), m
  // Pose of the tag frame in its parent: `man` for the head's tags, `mtag`
  // for the mirror's.
  Eigen::Isometry3d T_parent_tag = Eigen::Isometry3d::Identity();
  // Corner k (0..3, order above) in the parent frame, metres.
  Eigen::Vector3d corner(int k) const;
};

// The procedural phantom head, in the mannequin frame `man`: origin between
// the lips, +y up, +z out of the face, +x to the patient's left.
struct MannequinParams {
  Eigen::Vector3d head_centre_m = Eigen::Vector3d(0.0, 0.03, -0.085);
  Eigen::Vector3d head_radii_m = Eigen::Vector3d(0.075, 0.105, 0.095);  // ellipsoid semi-axes
  double mouth_half_width_m = 0.031;   // open mouth, an ellipse around the origin (x)
  double mouth_half_height_m = 0.024;  // (y)
  double lip_radius_m = 0.005;         // lips: a tube around the mouth opening
  // sRGB colours, 0..1.
  Eigen::Vector3d skin_rgb = Eigen::Vector3d(0.87, 0.72, 0.62);
  Eigen::Vector3d lip_rgb = Eigen::Vector3d(0.72, 0.38, 0.38);
  Eigen::Vector3d gum_rgb = Eigen::Vector3d(0.85, 0.45, 0.48);
  Eigen::Vector3d teeth_rgb = Eigen::Vector3d(0.93, 0.91, 0.84);
  std::string validate() const;
};

// The mouth mirror body (see meshes.h MirrorMeshParams; its radius is the
// calibration's mirror_radius_m) and the paddle on its handle that carries
// the mirror's tags.
struct MirrorSceneParams {
  double thickness_m = 1.5e-3;
  double neck_length_m = 20e-3;
  double neck_radius_m = 1.0e-3;
  double handle_length_m = 100e-3;
  double handle_radius_m = 3.0e-3;
  double stem_tilt_rad = 0.35;
  // Paddle: a plastic block in the mtag frame's x/y plane, centred on the
  // mtag origin, `paddle_width_m` along x (the handle, which runs through
  // it), `paddle_height_m` along y, its back face at z = `paddle_thickness_m`
  // (the back tag). Its front (toward -z) is
  // - flat at z = 0 when `paddle_roof_rad` = 0 (the front tag lies on it;
  //   station files without "paddle_roof_deg" read this way), or
  // - a roof when > 0: two faces meeting in a ridge along x at y = 0, each
  //   sloping `paddle_roof_rad` back from the x/y plane, and crossing z = 0
  //   half-way between ridge and eave (y = +-height/4): the ridge at
  //   z = -height/4 tan(roof), the eaves at z = +height/4 tan(roof). A tag on
  //   each face gives two views of the paddle 2 x roof apart, which fixes its
  //   depth (issue 16: mirror centre sigma 5.95 -> 2.39 mm, docs/BENCHMARKS.md).
  double paddle_width_m = 0.03;
  double paddle_height_m = 0.03;
  double paddle_thickness_m = 7.0e-3;
  double paddle_roof_rad = 0;
  std::string validate() const;
};

// Points the instructor touches with the calibrated stylus during the station calibration
// (`dentar calibrate register` and `tooth`). File: "calibration_fixtures" (mm).
struct CalibrationFixtures {
  // Divots on the mannequin (cone-shaped dimples the bur tip seats in), mannequin frame, m.
  std::vector<Eigen::Vector3d> divots_man;
  // Landmarks on the tooth model (cusp tips, cervical points), tooth frame, m.
  std::vector<Eigen::Vector3d> landmarks_tooth;
  std::string validate() const;  // empty or names the field
};

// A pen with a paper tag flag that stands in for the haptic stylus when no
// device is at hand (`dentar live --stylus pen`, the printable station kit).
// Frame `ptag`: the flag's front tag frame. The pen runs along +y of `ptag`
// (down the flag, toward the writing tip); the tip frame has z along the pen
// toward the tip (the bur axis convention of `tip`).
struct PenParams {
  std::vector<TagPlacement> tags;  // T_parent_tag = T_ptag_tag (front and back of the flag); empty = no pen
  Eigen::Isometry3d T_ptag_tip = Eigen::Isometry3d::Identity();  // pen tip in the flag frame
  double flag_size_m = 0.055;  // printed flag square (the tag and its white margin), m
  std::string validate() const;
};

// Where the camera intrinsics came from (file "camera" block extras; all optional).
struct CameraProvenance {
  std::string model;  // "pinhole-k1" / "pinhole-k1k2" / "pinhole-radtan5" / "rational8"; empty when unknown
  double rms_px = -1;  // calibration reprojection RMS, px; < 0 unknown
  std::vector<double> std_devs;  // fx fy cx cy k1 k2 p1 p2 k3 (px for the first four)
  std::string date, device;
  // v3: which physical camera this is (V4L2 "card @ bus" as ar::FrameSource::identity() reports,
  // or the footage file for live:PATH); empty when unknown. A station file calibrated with
  // another camera is refused by `dentar live` and `dentar calibrate` (station health).
  std::string device_id;
  // v4: the camera's response curve as measured by `dentar calibrate camera` (issue 24);
  // kind empty = unknown (the tracker then refits no edges in linear light and says so).
  calibration::CameraResponseCurve response;
  // v4, optional (issue 24, session 12): the camera's latency, ms: from the middle of a frame's
  // exposure to the moment the frame source stamps it (ar::Frame::steady_s, the grab), as
  // measured at this station (`dentar calibrate --camera-latency-ms MS` records it). < 0 =
  // unknown: the frame path then assumes kAssumedCameraLatency_ms and says so.
  double latency_ms = -1;
  // Non-empty when the station references a camera file ({"file": "cam.yaml"}) instead of
  // embedding the numbers: the path as written (relative to the station file's directory).
  std::string file;
};

// The camera latency assumed when a station has none measured (issue 24): one frame period at
// 30 fps, the least a UVC camera's exposure -> readout -> USB -> grab takes (mid-exposure to
// grab: half an exposure + readout + transfer). A guess, not a measurement: measure it at the
// station (docs/formats.md, camera.latency_ms).
inline constexpr double kAssumedCameraLatency_ms = 33.0;

// One step of the station calibration as recorded in the file ("calibration_report").
struct CalibrationStepReport {
  std::string step;  // camera, hand_eye, pivot, register, tooth, mirror, check
  std::string date;  // ISO 8601 UTC
  bool pass = false;
  std::string summary;  // one line for people
  // Quality figures, name (with its unit: "rms_px", "tre_mm") and value, in file order.
  std::vector<std::pair<std::string, double>> figures;
};

// v3: the camera fixed to the HMD or to a tracked frame (hand-eye, calibration/hand_eye.h).
// File: "hand_eye" (optional).
struct HandEyeRecord {
  bool present = false;
  Eigen::Isometry3d T_hand_cam = Eigen::Isometry3d::Identity();  // camera on the carrying body
  std::string hand;    // what carries the camera: "HMD", "tracked frame", ...
  std::string method;  // "ours" (linear start + LM) or an OpenCV method name
  double rot_sd_rad = -1, trans_sd_m = -1;  // 1 sigma, worst axis; < 0 unknown
  double rms_rot_rad = 0, rms_m = 0;        // residuals of the fit
  int observations = 0;
  std::string date;  // ISO 8601 UTC
};

// v3: the station's own thresholds (file "station_policy"; all optional, these defaults).
// The check step passes at or below check_threshold_m; `dentar live` asks for an instructor
// when the calibration is older than max_age_days, a mannequin tag moved by more than
// tag_moved_m, or the stylus tip misses the health divot by more than tip_check_m.
struct StationPolicy {
  double check_threshold_m = 0.5e-3;  // end-to-end co-location, mean
  double max_age_days = 30;
  double tag_moved_m = 1.0e-3;
  double tip_check_m = 1.0e-3;
  int health_divot = 0;  // index into calibration_fixtures.divots_mm touched at session start
  std::string validate() const;
};

// Issue 28: a stereo head, two cameras fixed to each other (file: "stereo",
// optional; absent = one camera, as every older file). The left eye is the
// station's camera (calibration.camera) and the rig frame (`rig` = `cam_l`);
// the right eye has its own intrinsics. T_caml_camr (file "T_left_right")
// maps the right eye's optical frame into the left's: the right eye's centre
// is T_caml_camr.translation() in `cam_l` (+x by the baseline for a
// side-by-side head). Both eyes must have the same image size (the
// side-by-side frame, docs/formats.md).
struct StereoRig {
  bool present = false;
  calibration::CameraIntrinsics camera_right;
  Eigen::Isometry3d T_caml_camr = Eigen::Isometry3d::Identity();
  double baseline_m() const { return T_caml_camr.translation().norm(); }
  // Empty when valid; else names the field (left = the station's camera).
  std::string validate(const calibration::CameraIntrinsics& left) const;
};
// A side-by-side head: the right eye `baseline_m` along the left eye's +x,
// the same orientation, with the intrinsics `right` (the left's when empty).
StereoRig make_stereo_rig(const calibration::CameraIntrinsics& left, double baseline_m,
                          const std::optional<calibration::CameraIntrinsics>& right = std::nullopt);

// File versions: 1 (no calibration_fixtures / calibration_report; files without "version" are
// read as 1), 2 (fixtures and report), 3 (current: camera.device_id, hand_eye, station_policy,
// and a "hand_eye" step in the report). Older versions are read and migrated in memory (the
// missing parts get their defaults; `migrated_from` says from which); writers always write
// the current version.
inline constexpr int kStationFileVersion = 4;

struct StationScene {
  int version = kStationFileVersion;  // as read (writers always write the current version)
  int migrated_from = 0;              // the file's version when older than the current; else 0
  std::string name = "default";
  TagFamilyId family = TagFamilyId::kStandard41h12;
  MannequinParams mannequin;
  std::vector<TagPlacement> mannequin_tags;  // T_parent_tag = T_man_tag
  MirrorSceneParams mirror;
  std::vector<TagPlacement> mirror_tags;  // T_parent_tag = T_mtag_tag
  double tooth_voxel_m = 0.1e-3;          // procedural molar's voxel size
  // Camera, T_man_tooth, T_man_dev, T_sty_tip, T_mtag_mir, mirror_radius_m.
  calibration::StationCalibration calibration;
  CameraProvenance camera_provenance;
  PenParams pen;  // optional in files ("pen"); the default pen when absent
  CalibrationFixtures fixtures;  // empty in version 1 files
  std::vector<CalibrationStepReport> calibration_report;  // latest entry per step
  HandEyeRecord hand_eye;  // v3, optional
  StationPolicy policy;    // v3, optional in the file
  StereoRig stereo;        // issue 28, optional in the file ("stereo")
  // Adds or replaces the report of r.step (one entry per step, in workflow order).
  void set_step_report(const CalibrationStepReport& r);
  const CalibrationStepReport* step_report(const std::string& step) const;

  // Empty when valid; else names the field ("mannequin_tags[3].id = 9999 is
  // not a tagStandard41h12 code (0..2114)").
  std::string validate() const;
  const TagPlacement* find_tag(int id) const;  // mannequin, mirror or pen tag, or nullptr
};

// The default pen: tags 30 (front) and 31 (back) of 25 mm (45 mm printed) on
// a 55 mm paper flag folded around an 8 mm pen: the back tag 8 mm behind the
// front one, the tip on the pen's axis (4 mm behind the front tag) 130 mm
// below the flag's centre.
PenParams default_pen();

// A station for trying the trainer with a cardboard box and a webcam: the
// default station with its head tags replaced by one flat board of 6 tags of
// 25 mm (45 mm printed), ids 0..5, at x = -60, 0, 60 mm and y = +55, -55 mm in
// the board plane (z = 0 of `man`, facing +z); the tooth stands on the
// board's centre, occlusal side up (+z), its cervical plane 14 mm above it.
// The device frame (the haptic device's workspace centre, or the pen's when
// `--stylus pen`) stands 60 mm above the board's centre, dev y up, dev z
// toward the tags 3..5 row: the default workspace box (+-60 mm along y)
// spans from the board up, over its centre.
// The head mesh is still the mannequin's: run it with occlusion off.
inline constexpr double kBoxWorkspaceAboveBoard_m = 0.060;
StationScene box_station_scene();
// Built-in stations by name: "default" and "box"; nullopt for another name.
std::optional<StationScene> builtin_station_scene(std::string_view name);

// The default fixtures: 8 divots on the face around the mouth (non-coplanar, surrounding the
// tooth site) and 6 molar landmarks (4 cusp tips, buccal and lingual cervical points).
CalibrationFixtures default_calibration_fixtures();

// The built-in station (assets/station_default.json is this, written out):
// 12 tags of 14 mm on the forehead, cheeks and chin (kFront12 below); a lower-left first molar
// site; the haptic device placed as haptics::default_station() says; a
// 640x480 head camera with mild barrel distortion; a mirror with two tags
// (front and back of its paddle).
StationScene default_station_scene();

// The mannequin's head tag layouts (tagStandard41h12, 14 mm border, 25 mm
// printed, each on a tangent plate 0.5 mm above the head ellipsoid, image
// "down" toward the chin). kFront12 (the default station's): ids 0..11 on
// the forehead, brow, cheeks and chin. kWrap20 (measured 2026-11-27, not the
// default): the same 12 plus ids 12..19 on the cheekbones (+-45, 5 deg
// azimuth, elevation), temples (+-50, 45), the sides above the ears
// (+-70, 25) and the jaw (+-40, -30). On `hard` it draws 52 instead of 46 of
// 60 frames and halves no error: its p95 is worse (0.838 vs 0.735 mm), and
// its covariance is 1.3x pessimistic on `lowlight` (docs/BENCHMARKS.md,
// "issue 16: the head tag layout"; the mirror's pooled noise with it:
// TrackerOptions::pool_comparable_tags). Ids 20..22 are the mirror's, 30..31
// the pen's. kFront12Large (issue 16, measured 2026-11-27, not the
// default): kFront12's ids and positions with larger tags where a face-on
// camera looks: the forehead pair (ids 0, 1) 16 mm (28.8 mm printed), the
// four brow tags (ids 2..5) 18 mm (32.4 mm); the largest the spacing allows
// (18 mm forehead tags would overlap each other, 19 mm inner brow tags each
// other and the forehead divot's clearance). It cuts the p95 of every
// preset but `hard` (standard 0.296 -> 0.193 mm) and draws 52 instead of 46
// `hard` frames, but its `hard` p95 is worse (0.735 -> 1.009 mm; 720p 0.664
// -> 0.890) and its covariance over-states the error 1.3-1.9x on the easy
// presets (docs/BENCHMARKS.md, "issue 16: larger brow tags").
// Rewrites s.mannequin_tags.
enum class MannequinLayout { kFront12, kWrap20, kFront12Large };
void set_mannequin_layout(StationScene& s, MannequinLayout kind);

// The mirror paddle's tag layouts. kRoof (the default station's since issue
// 16): a 30 x 40 x 9 mm paddle with a 35 deg roof, tag 20 on its -y face,
// 22 on its +y face, 21 on the flat back. kFlat (before): a 30 x 30 x 7 mm
// block, tag 20 on the front, 21 on the back. Both 12 mm tags; T_mtag_mir is
// kept (the mtag frame does not move). Rewrites s.mirror's paddle and
// s.mirror_tags.
enum class MirrorPaddle { kFlat, kRoof };
void set_mirror_paddle(StationScene& s, MirrorPaddle kind);

// Intrinsics of the default camera family at another image size: same
// horizontal field of view (fx = fy = 0.9375 W), principal point near the
// centre, the default distortion.
calibration::CameraIntrinsics default_camera(int width_px, int height_px);

// JSON text (2-space indent, numbers round-trip exactly).
std::string station_scene_to_json(const StationScene& s);
// Errors name `source` (the file name), the field path and the problem:
// "station.json: mannequin.tags[2].size_mm: must be a number > 0".
// A "camera": {"file": "cam.yaml"} reference is read with calibration::read_camera_file,
// relative to the directory of `source` (an OpenCV or ROS camera YAML).
Result<StationScene> parse_station_scene(std::string_view text, const std::string& source);
Result<StationScene> read_station_scene(const std::string& path);
// Writes via a temporary file and a rename: a failure leaves the old file untouched.
Status write_station_scene(const StationScene& s, const std::string& path);

}  // namespace dentar::ar
