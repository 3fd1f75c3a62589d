// Recorded-footage generator with exact ground truth (`dentar synth`).
//
// The scene (station_scene.h): the phantom head with its tag bundle, a
// head-mounted camera moving around it on a smooth random path (25-45 cm,
// looking at the mouth), a hand holding the handpiece on the haptic stylus,
// drilling the virtual tooth on a scripted path, and the mouth mirror moving
// in the mouth. The stylus is driven by the haptic engine itself
// (SimulatedDevice + Engine, 1 kHz simulated time, run in step with the
// frames), so the image, the ground truth and the session log agree exactly.
// The virtual tooth is not in the video (it is virtual); it is in the masks.
//
// Determinism: the same options and station give identical frames, truth
// and log on the same machine (one RNG stream per purpose, seeded from
// `seed`; GL rasterisation on llvmpipe is deterministic).
//
// Thread/context: a SynthGenerator needs the EGL context (egl_context.h)
// current on the calling thread for its whole life.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "dentar/ar/station_scene.h"
#include "dentar/volume/result.h"

namespace dentar::haptics {
class PoseHistory;
}

namespace dentar::ar {

// The rendering model's version, written to synth.json as "generator".
// Footage of different versions differs in its pixels (not in its truth):
// 1: tag texture treated as sRGB after filtering, optical and motion blur on
//    the encoded values: in linear light the tags' black cells ~0.2 px too
//    wide (libapriltag on the encoded image: outline -0.09 px).
// 2 (2026-11-25): texture value = ink coverage (reflectance linear in it),
//    optical blur and the motion-blur average in linear light, then sRGB:
//    edges where the truth says in linear light (docs/BENCHMARKS.md, issue
//    16 third part). Gain, vignetting and noise act on the encoded values
//    as before.
// 3 (2026-11-29): `hard` renders its motion blur with sub-frames that follow
//    the motion (blur_step_px 1: no tag corner moves more than 1 px between
//    two, 5..63) instead of 5 fixed ones; the other presets' pixels are
//    unchanged (blur_step_px 0). Issue 28 session 20.
inline constexpr int kSynthGeneratorVersion = 3;

// The failure-mode presets (hand ... offframe) each add one way tracking
// fails to an otherwise `standard` scene (glare: to `mirror`), so that an
// error can be traced to its cause; `hard` mixes several at once.
// webcam and headset (issue 24) are `standard`'s scene seen through a
// physical camera model (CameraSensorModel below) of a USB webcam and of a
// head-mounted camera.
enum class SynthPreset {
  kStandard, kHard, kMirror, kHand, kGlare, kLowLight, kFastTurns, kOffFrame, kWebcam, kHeadset
};
const char* synth_preset_name(SynthPreset p);  // "standard", ..., "fast", "offframe", "webcam", "headset"
std::optional<SynthPreset> parse_synth_preset(std::string_view name);
// Every preset, in the enum's order (for CLI checks and test loops).
const std::vector<SynthPreset>& all_synth_presets();
// "standard|hard|mirror|hand|glare|lowlight|fast|offframe|webcam|headset"
std::string synth_preset_names(const char* separator = "|");

// A physical model of the camera (issue 24; docs/synth_camera.md has each
// effect's source). Off by default: the classic presets keep their sensor
// model (noise, gain and vignetting on the encoded values; SynthOptions'
// read_noise_dn, shot_noise_gain, vignetting), and their footage is
// unchanged. When on, those three are not used; instead, in this order:
//   scene radiance (linear light), motion blur (sub-frames over the
//   exposure) and rolling shutter (each band of rows at its own time) ->
//   defocus (a disc of diameter fx * aperture * |1/depth - 1/focus| px, the
//   thin-lens circle of confusion at the tooth's depth) and the optical
//   Gaussian (optical_blur_px) -> vignetting cos^n of the field angle ->
//   exposure (SynthOptions' drift and jumps x the auto-exposure loop) ->
//   photo-electrons with shot noise (Poisson, as a Gaussian of variance =
//   signal) and read noise, clipped at the full well -> sRGB encoding ->
//   JPEG at a webcam's quality (libjpeg through OpenCV, 4:2:0).
// The truth of a rolling-shutter frame is the middle row's (time t).
struct CameraSensorModel {
  bool enabled = false;
  double full_well_e = 6000;      // electrons at linear 1.0 (white) and exposure 1, per output pixel
  double read_noise_e = 3.0;      // read noise, electrons RMS
  double aperture_m = 0;          // entrance pupil diameter (focal length / f-number); 0 = no defocus
  double focus_distance_m = 1.0;  // distance the lens is focused at
  double cos_power = 0;           // vignetting: cos^n of the field angle (4 = natural fall-off; 0 = off)
  int jpeg_quality = 0;           // 0 = uncompressed; 1..100: JPEG/MJPG quality of each frame
  double ae_step_ev = 0;          // auto-exposure: step size (EV); 0 = no auto-exposure loop
  double ae_deadband_ev = 0.3;    // AE acts when the mean is this far (EV) from its target
  int ae_delay_frames = 2;        // a step takes effect this many frames after it is decided
  double rolling_readout_s = 0;   // rolling shutter: first to last row; 0 = global shutter
  int rolling_bands = 7;          // rows rendered in this many bands, each at its own time (odd)
  std::string validate() const;   // empty or names the field ("camera.jpeg_quality = 0 ...")
};

struct SynthOptions {
  SynthPreset preset = SynthPreset::kStandard;
  int frames = 150;
  double fps = 30.0;
  int width = 640, height = 480;  // output size; the station camera is rescaled to it
  std::uint64_t seed = 1;
  bool distortion = true;  // render the station camera's lens distortion (off: pinhole, dist = 0)

  // Head motion: camera distance to the look-at point (m), azimuth about the
  // head's vertical axis (0 = straight in front, + toward the patient's
  // left), elevation above the horizontal, roll; amplitudes are the largest
  // excursion from the centre. `motion_speed` scales all frequencies
  // (1 = calm work, ~0.05-0.3 Hz).
  double distance_min_m = 0.28, distance_max_m = 0.42;
  double azimuth_centre_rad = -0.45, azimuth_amplitude_rad = 0.25;
  double elevation_centre_rad = 0.45, elevation_amplitude_rad = 0.12;
  double roll_amplitude_rad = 0.08;
  double motion_speed = 1.0;
  double look_at_jitter_m = 0.01;

  // Sensor and optics.
  CameraSensorModel camera;          // physical camera model (off: the classic model below)
  double read_noise_dn = 1.5;        // Gaussian read noise, 8-bit digital numbers (0 = off)
  double shot_noise_gain = 0.04;     // shot-noise variance per DN of signal (0 = off)
  double optical_blur_px = 0.5;      // Gaussian PSF sigma (0 = off)
  double vignetting = 0.2;           // brightness loss at the image corners (0..0.9)
  bool motion_blur = false;          // average sub-frames over the exposure time
  double shutter_fraction = 0.5;     // exposure time / frame period (motion blur)
  int blur_subframes = 5;            // odd, >= 3; with blur_step_px > 0 the fewest
  // Sub-frames that follow the motion (issue 28 session 20): > 0 renders each exposure with
  // enough sub-frames that no tag corner (mannequin or mirror, projected through the lens) moves
  // more than blur_step_px between two of them, at least blur_subframes and at most
  // blur_subframes_max (odd); the count is chosen per exposure from the head's and mirror's
  // path (occluders and the finger are not measured). 0 = always blur_subframes (a fixed count
  // steps a fast motion's blur into blur_subframes ghosts; a real exposure integrates it).
  double blur_step_px = 0.0;         // px, 0 or [0.25, 10]
  int blur_subframes_max = 63;       // odd, blur_subframes..127
  double exposure = 1.0;             // base exposure gain (lowlight: 0.3), 0.05..4
  double exposure_variation = 0.05;  // slow auto-exposure drift, relative amplitude
  bool exposure_jumps = false;       // occasional sudden +-25 % gain steps, settling in 0.5 s

  // Tag occlusion: skin-coloured occluders (an assistant's fingers) hovering
  // over random head tags, each covering part of one.
  int tag_occluders = 0;
  // Fraction of the footage with the mirror in the mouth (the rest of the
  // time it is pulled out of view): standard 0.6, mirror 1.
  double mirror_in_mouth_fraction = 0.6;

  // Failure modes (all off by default).
  // Camera aimed away from the mouth by a yaw about its own vertical axis
  // that swings between -aim_offset_rad and +aim_offset_rad (4 s period,
  // resting at each side): the head's tags on that side leave the frame.
  double aim_offset_rad = 0.0;
  // Sudden head turns: every head_turn_period_s the camera yaws by
  // head_turn_rad in head_turn_s (smoothstep: peak speed 1.5 x amplitude /
  // duration), holds, and turns back as fast half a period later.
  double head_turn_rad = 0.0;
  double head_turn_s = 0.12;
  double head_turn_period_s = 1.5;
  // A gloved finger sweeps across the tooth between it and the camera,
  // once per hand_crossing_period_s (a 0.8 s sweep, then out of view).
  bool hand_crossing = false;
  double hand_crossing_period_s = 2.0;
  // A specular highlight (0 = none, 1 = saturating) wandering over the
  // mirror's tag paddle and face: washes out part of the mirror's tags.
  double mirror_glare = 0.0;
  // Drilling: the "access" script (haptics/scripts.h), stretched to the
  // footage length, pressing force (N).
  double drill_force_N = 2.5;
  int bur_samples = 4000;

  // Stereo footage (issue 28): run_synth writes both eyes of the station's
  // stereo rig, or of make_stereo_rig(camera, stereo_baseline_m) when the
  // station has none (docs/formats.md: one side-by-side video, truth per eye).
  bool stereo = false;
  double stereo_baseline_m = 0.063;  // 63 mm: a typical head's; 60-65 mm in headsets
  // The eye this generator renders (StereoSynthGenerator sets both): 0 = the
  // left eye, which is the rig frame and the mono footage; 1 = the right eye
  // at T_rig_eye (= T_caml_camr) on the head. Each eye has its own sensor
  // noise and auto-exposure; the scene, head path and light are shared.
  int eye = 0;
  Eigen::Isometry3d T_rig_eye = Eigen::Isometry3d::Identity();

  // Empty when valid; else names the option ("frames = 0 must be in 1..100000").
  std::string validate() const;
};

// The options a preset starts from (before command-line overrides).
//  standard: calm head motion, mirror 60 % of the time, mild noise;
//  hard: fast head motion with motion blur, wide azimuth swings (tags at
//   70 deg and more to the view), longer distances (tags under 20 px at
//   640x480), 4 tag occluders, exposure jumps, stronger noise;
//  mirror: as standard with the mirror in the mouth all the time, the
//   camera kept where the mirror face is seen;
//  hand: standard + a finger crossing the tooth every 2 s;
//  glare: mirror + a moving saturating highlight on the mirror;
//  lowlight: standard at 0.3 exposure with strong read and shot noise;
//  fast: standard + sudden 25 deg head turns in 0.12 s (>= 200 deg/s),
//   with motion blur;
//  offframe: standard with the camera aimed 24 deg away from the mouth,
//   alternating sides: the tags on that side are cut by the frame edge;
//  webcam: standard's scene through a USB webcam (rolling shutter, MJPG at
//   quality 80, small pixels, autofocus slightly behind the mouth, lens
//   shading half corrected, 1/3 EV auto-exposure steps following a
//   +-15 % light drift);
//  headset: standard's scene through a head-mounted camera (global
//   shutter, uncompressed, fixed focus at 1 m, natural cos^4 vignetting of a
//   wide lens, a short exposure with motion blur, 1/3 EV auto-exposure).
// docs/synth_camera.md gives each figure and its source.
SynthOptions synth_preset(SynthPreset p);

// One tag's ground truth in one frame.
struct TagTruth {
  int id = 0;
  bool on_mirror = false;
  // Corners in OpenCV pixels (distortion applied when on), libapriltag's order.
  std::array<Eigen::Vector2d, 4> corners_px;
  double visible_fraction = 0;  // of the tag plate's pixels not hidden by anything
  double side_px = 0;           // sqrt of the corner quadrilateral's area
  double view_angle_rad = 0;    // between the tag normal and the direction to the camera
  bool in_image = false;        // all four corners inside the image
};

struct FrameTruth {
  int frame = 0;
  double time_s = 0;  // mid-exposure time of the frame
  // Exact poses (metres) at time_s; T_cam_tip uses the haptic step at
  // haptic_time_s (the last 1 kHz step not after time_s).
  Eigen::Isometry3d T_cam_man, T_cam_tooth, T_cam_mtag, T_cam_mir, T_cam_tip, T_dev_sty;
  std::uint64_t haptic_step = 0;
  double haptic_time_s = 0;
  bool pedal = false;
  std::vector<TagTruth> tags;   // tags with at least one visible pixel
  bool mirror_in_view = false;  // >= 30 px of the reflecting face visible
  int mirror_face_px = 0;
  int tooth_px = 0;          // tooth silhouette area
  int tooth_hidden_px = 0;   // of which covered by real foreground
  double exposure_gain = 1;  // multiplier applied to this frame (camera model: light x auto-exposure)
  double defocus_px = 0;     // camera model: blur-circle diameter at the tooth's depth, px
  int ae_steps = 0;          // camera model: auto-exposure steps taken so far
  // Camera angular speed at time_s (|rotation rate| of T_man_cam, deg/s).
  double camera_speed_deg_s = 0;
  // Sub-frames averaged into this frame's exposure (1 = no motion blur; the middle band's with a
  // rolling shutter).
  int blur_subframes = 1;
  bool hand_crossing = false;   // the crossing finger is in front of the tooth's region
  bool glare = false;           // a glare spot was drawn on the mirror
};

// Mask values (CV_8UC1, one per frame): the virtual tooth's silhouette and
// what real geometry lies in front of it.
inline constexpr std::uint8_t kMaskOutside = 0;        // not the tooth
inline constexpr std::uint8_t kMaskToothVisible = 64;  // tooth, nothing real in front
inline constexpr std::uint8_t kMaskMannequin = 128;   // tooth behind lips, cheeks, gum, other teeth
inline constexpr std::uint8_t kMaskForeground = 255;  // tooth behind fingers, instruments, mirror

struct SynthFrame {
  cv::Mat image;  // CV_8UC3 BGR, the camera image
  cv::Mat mask;   // CV_8UC1, kMask* values
  FrameTruth truth;
};

class SynthGenerator {
 public:
  // Builds the scene for `station` (its camera is rescaled to the options'
  // size and its distortion zeroed when distortion is off; see station()).
  // Writes the haptic session log to `session_log_path` unless empty.
  // Errors name the option or file.
  static Result<std::unique_ptr<SynthGenerator>> create(const StationScene& station,
                                                        const SynthOptions& options,
                                                        const std::string& session_log_path = {});
  ~SynthGenerator();
  SynthGenerator(const SynthGenerator&) = delete;
  SynthGenerator& operator=(const SynthGenerator&) = delete;

  // Renders the next frame (0, 1, ...). Fails after options.frames frames
  // or on a GL error.
  Status next(SynthFrame& out);
  int frames_done() const;
  // Closes the session log (call after the last frame); idempotent.
  Status finish();
  // The station as rendered (camera actually used).
  const StationScene& station() const;
  const SynthOptions& options() const;
  // The scripted stylus's poses of the last ~1 s, one per 1 kHz haptic step, stamped with the
  // footage's time (FrameTruth::time_s's clock): what a live station's engine keeps for drawing
  // a frame with the pose of its exposure (issue 24). Valid while the generator lives.
  const haptics::PoseHistory& haptic_history() const;

  // The tooth silhouette alone (CV_8UC1, 255 inside) at a given pose, drawn
  // by the same tooth renderer the masks use (tests).
  Result<cv::Mat> render_tooth_silhouette(const Eigen::Isometry3d& T_cam_tooth);

  struct Impl;

 private:
  SynthGenerator() = default;
  std::unique_ptr<Impl> impl_;
};

struct SynthSummary {
  int frames = 0;
  double seconds = 0;      // wall time
  std::string video_path;  // video.mkv, or the frames/ folder with --png
  int frames_with_mirror = 0;
  double mean_visible_tags = 0;
};

// The whole job: writes into out_dir
//   station.json  the station as rendered (station_scene.h format)
//   video.mkv     FFV1 lossless (or frames/frame_NNNNNN.png when png)
//   truth.jsonl   one JSON object per frame (docs/formats.md)
//   masks/mask_NNNNNN.png
//   session.dlog  the haptic session log of the scripted drilling
//   synth.json    the options used and a summary
// With options.stereo (issue 28): video.mkv (or the PNGs) side by side
// (left | right, 2W x H), truth.jsonl and masks/ of the left eye (the rig
// frame), truth_right.jsonl and masks_right/ of the right eye, the rig in
// station.json ("stereo") and synth.json ("stereo").
// Needs a current EGL context. `progress` (may be empty) is called after
// each frame with the frame count.
Result<SynthSummary> run_synth(const StationScene& station, const SynthOptions& options,
                               const std::string& out_dir, bool png,
                               const std::function<void(int)>& progress = {});

// Both eyes of a stereo head (issue 28) over the same scene: two generators,
// the left one (the rig frame) writing the session log, the right one at the
// station's stereo.T_caml_camr with station.stereo.camera_right as its
// camera. Each eye's frame carries its own truth (FrameTruth in that eye's
// optical frame) and mask. The station must have a stereo rig.
struct StereoSynthFrame {
  SynthFrame left, right;
};
class StereoSynthGenerator {
 public:
  static Result<std::unique_ptr<StereoSynthGenerator>> create(const StationScene& station,
                                                              const SynthOptions& options,
                                                              const std::string& session_log_path = {});
  Status next(StereoSynthFrame& out);
  Status finish();
  // The station as rendered: the left eye's camera, stereo.camera_right the right's.
  const StationScene& station() const { return station_; }
  SynthGenerator& left() { return *left_; }
  SynthGenerator& right() { return *right_; }

 private:
  std::unique_ptr<SynthGenerator> left_, right_;
  StationScene station_;
};

// The side-by-side frame of a stereo pair (left | right), both the same size
// and type; an error names both sizes otherwise.
Result<cv::Mat> side_by_side(const cv::Mat& left, const cv::Mat& right);
// Splits a side-by-side frame into its halves (views, no copy). An odd width
// or an empty frame is an error that says so (`what` names the source).
Status split_side_by_side(const cv::Mat& frame, cv::Mat& left, cv::Mat& right, const std::string& what);

// One truth.jsonl line (no newline).
std::string frame_truth_json(const FrameTruth& t);

}  // namespace dentar::ar
