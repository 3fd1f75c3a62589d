#include "dentar/ar/synth.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <optional>
#include <random>
#include <sstream>

#include "dentar/ar/camera_model.h"
#include "dentar/ar/renderer.h"
#include "dentar/ar/srgb.h"
#include "dentar/haptics/engine.h"
#include "dentar/haptics/scripts.h"
#include "dentar/haptics/simulated_device.h"
#include "dentar/volume/procedural_tooth.h"
#include "synth_scene.h"

namespace dentar::ar {

// ---- presets and options ------------------------------------------------------

const char* synth_preset_name(SynthPreset p) {
  switch (p) {
    case SynthPreset::kStandard:
      return "standard";
    case SynthPreset::kHard:
      return "hard";
    case SynthPreset::kMirror:
      return "mirror";
    case SynthPreset::kHand:
      return "hand";
    case SynthPreset::kGlare:
      return "glare";
    case SynthPreset::kLowLight:
      return "lowlight";
    case SynthPreset::kFastTurns:
      return "fast";
    case SynthPreset::kOffFrame:
      return "offframe";
    case SynthPreset::kWebcam:
      return "webcam";
    case SynthPreset::kHeadset:
      return "headset";
  }
  return "?";
}

const std::vector<SynthPreset>& all_synth_presets() {
  static const std::vector<SynthPreset> all = {
      SynthPreset::kStandard, SynthPreset::kHard,      SynthPreset::kMirror,    SynthPreset::kHand,
      SynthPreset::kGlare,    SynthPreset::kLowLight,  SynthPreset::kFastTurns, SynthPreset::kOffFrame,
      SynthPreset::kWebcam,   SynthPreset::kHeadset};
  return all;
}

std::string synth_preset_names(const char* separator) {
  std::string out;
  for (SynthPreset p : all_synth_presets()) {
    if (!out.empty()) out += separator;
    out += synth_preset_name(p);
  }
  return out;
}

std::optional<SynthPreset> parse_synth_preset(std::string_view name) {
  for (auto p : all_synth_presets())
    if (name == synth_preset_name(p)) return p;
  return std::nullopt;
}

SynthOptions synth_preset(SynthPreset p) {
  SynthOptions o;
  o.preset = p;
  // Defaults (standard): the operator's head on the patient's right, from
  // where the lower-left molar is seen through the open mouth.
  if (p == SynthPreset::kHard) {
    // Fast, wide head swings (cheek tags seen at 70 deg and more), farther
    // away (small tags), blur, occluders, auto-exposure jumps, more noise.
    o.distance_min_m = 0.34;
    o.distance_max_m = 0.45;
    o.azimuth_centre_rad = -0.1;
    o.azimuth_amplitude_rad = 1.0;
    o.elevation_centre_rad = 0.45;
    o.elevation_amplitude_rad = 0.3;
    o.roll_amplitude_rad = 0.2;
    o.motion_speed = 3.5;
    o.look_at_jitter_m = 0.03;
    o.motion_blur = true;
    o.shutter_fraction = 0.7;
    // A real exposure's continuous blur (issue 28 session 20): 5 fixed sub-frames stepped a
    // 40 px blur into 5 ghosts 10 px apart and cost detections a camera would make.
    o.blur_step_px = 1.0;
    o.read_noise_dn = 3.0;
    o.shot_noise_gain = 0.08;
    o.exposure_variation = 0.15;
    o.exposure_jumps = true;
    o.tag_occluders = 4;
    o.mirror_in_mouth_fraction = 0.5;
  } else if (p == SynthPreset::kMirror || p == SynthPreset::kGlare) {
    // The camera stays on the side from which the mirror face is seen.
    o.azimuth_centre_rad = -0.3;
    o.azimuth_amplitude_rad = 0.25;
    o.elevation_centre_rad = 0.42;
    o.elevation_amplitude_rad = 0.1;
    o.mirror_in_mouth_fraction = 1.0;
    if (p == SynthPreset::kGlare) o.mirror_glare = 1.0;
  } else if (p == SynthPreset::kHand) {
    o.hand_crossing = true;
  } else if (p == SynthPreset::kLowLight) {
    // A dim room without the head lamp: a third of the light, the sensor's
    // read noise and shot noise at high gain.
    o.exposure = 0.3;
    o.read_noise_dn = 4.0;
    o.shot_noise_gain = 0.25;
  } else if (p == SynthPreset::kFastTurns) {
    // 25 deg in 0.12 s: 312 deg/s peak, 208 deg/s mean, blurred.
    o.head_turn_rad = 25.0 * M_PI / 180.0;
    o.head_turn_s = 0.12;
    o.head_turn_period_s = 1.5;
    o.motion_blur = true;
    o.shutter_fraction = 0.5;
  } else if (p == SynthPreset::kOffFrame) {
    o.aim_offset_rad = 24.0 * M_PI / 180.0;
  } else if (p == SynthPreset::kWebcam || p == SynthPreset::kHeadset) {
    // Issue 24: standard's scene through a real camera's faults (docs/synth_camera.md has the
    // figures' sources). The scene light drifts (+-30 %: a room, not a lab) and jumps by
    // +-25 % now and then (a lamp, a shadow); the auto-exposure follows in 1/3 EV steps.
    CameraSensorModel& c = o.camera;
    c.enabled = true;
    o.exposure_variation = 0.3;
    o.exposure_jumps = true;
    o.motion_blur = true;
    o.blur_subframes = 3;
    c.ae_step_ev = 1.0 / 3.0;
    c.ae_deadband_ev = 0.25;
    if (p == SynthPreset::kWebcam) {
      // A 1080p USB webcam (1/2.9"-1/3" sensor, ~3 um pixels, f ~ 3.7 mm, f/2.0) streaming MJPG,
      // scaled to the output size: the per-output-pixel full well of the binned pixels.
      c.full_well_e = 6000;
      c.read_noise_e = 3.0;
      c.aperture_m = 3.7e-3 / 2.0;
      c.focus_distance_m = 0.6;  // autofocus locked a little behind the mouth
      c.cos_power = 2.0;         // the ISP's lens-shading correction leaves part of cos^4
      c.jpeg_quality = 80;
      c.ae_delay_frames = 2;
      c.rolling_readout_s = 0.020;
      c.rolling_bands = 5;
      o.shutter_fraction = 0.5;  // 1/60 s at 30 fps, indoor light
    } else {
      // A head-mounted pass-through camera: global shutter, fixed focus, wide uncorrected lens,
      // raw frames over MIPI (no compression), short exposure against head-motion blur.
      c.full_well_e = 10000;
      c.read_noise_e = 4.0;
      c.aperture_m = 2.4e-3 / 2.0;
      c.focus_distance_m = 1.0;
      c.cos_power = 4.0;
      c.jpeg_quality = 0;
      c.ae_delay_frames = 1;
      c.rolling_readout_s = 0;
      o.shutter_fraction = 0.3;  // 10 ms at 30 fps
    }
  }
  return o;
}

std::string CameraSensorModel::validate() const {
  std::ostringstream os;
  auto in = [](double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; };
  if (!in(full_well_e, 100, 1e6))
    os << "camera.full_well_e = " << full_well_e << " must be in [100, 1e6] electrons";
  else if (!in(read_noise_e, 0, 1000))
    os << "camera.read_noise_e = " << read_noise_e << " must be in [0, 1000] electrons";
  else if (!in(aperture_m, 0, 0.05))
    os << "camera.aperture_m = " << aperture_m << " must be in [0, 0.05] m";
  else if (!in(focus_distance_m, 0.05, 1e4))
    os << "camera.focus_distance_m = " << focus_distance_m << " must be in [0.05, 10000] m";
  else if (!in(cos_power, 0, 8))
    os << "camera.cos_power = " << cos_power << " must be in [0, 8]";
  else if (jpeg_quality < 0 || jpeg_quality > 100)
    os << "camera.jpeg_quality = " << jpeg_quality << " must be 0 (off) or 1..100";
  else if (!in(ae_step_ev, 0, 2) || !in(ae_deadband_ev, 0, 2))
    os << "camera.ae_step_ev and ae_deadband_ev must be in [0, 2] EV";
  else if (ae_delay_frames < 0 || ae_delay_frames > 30)
    os << "camera.ae_delay_frames = " << ae_delay_frames << " must be in 0..30";
  else if (!in(rolling_readout_s, 0, 1))
    os << "camera.rolling_readout_s = " << rolling_readout_s << " must be in [0, 1] s";
  else if (rolling_bands < 1 || rolling_bands > 61 || rolling_bands % 2 == 0)
    os << "camera.rolling_bands = " << rolling_bands << " must be odd, 1..61";
  return os.str();
}

std::string SynthOptions::validate() const {
  std::ostringstream os;
  auto in = [](double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; };
  if (frames < 1 || frames > 100000)
    os << "frames = " << frames << " must be in 1..100000";
  else if (!in(fps, 1, 240))
    os << "fps = " << fps << " must be in [1, 240]";
  else if (width < 64 || height < 48 || width > 4096 || height > 4096)
    os << "resolution " << width << "x" << height << " must be within 64x48..4096x4096";
  else if (!in(distance_min_m, 0.1, 2.0) || !in(distance_max_m, distance_min_m, 2.0))
    os << "distance range [" << distance_min_m << ", " << distance_max_m
       << "] m must satisfy 0.1 <= min <= max <= 2";
  else if (!in(azimuth_amplitude_rad, 0, 1.6) || !in(std::abs(azimuth_centre_rad), 0, 1.6))
    os << "azimuth centre/amplitude must be within [-1.6, 1.6] rad";
  else if (!in(elevation_centre_rad + elevation_amplitude_rad, -1.5, 1.5) ||
           !in(elevation_centre_rad - elevation_amplitude_rad, -1.5, 1.5) ||
           elevation_amplitude_rad < 0)
    os << "elevation centre +- amplitude must stay within [-1.5, 1.5] rad";
  else if (!in(stereo_baseline_m, 0.01, 0.3))
    os << "stereo_baseline_m = " << stereo_baseline_m << " m must be in [0.01, 0.3] (a head's eyes: 60-65 mm)";
  else if (eye < 0 || eye > 1)
    os << "eye = " << eye << " must be 0 (left) or 1 (right)";
  else if (!T_rig_eye.matrix().allFinite() ||
           !(T_rig_eye.linear() * T_rig_eye.linear().transpose()).isIdentity(1e-6) || T_rig_eye.translation().norm() > 0.3)
    os << "T_rig_eye must be a rigid transform within 0.3 m of the rig";
  else if (!in(roll_amplitude_rad, 0, 1.0))
    os << "roll amplitude must be in [0, 1] rad";
  else if (!in(motion_speed, 0, 20))
    os << "motion speed = " << motion_speed << " must be in [0, 20]";
  else if (!in(look_at_jitter_m, 0, 0.1))
    os << "look-at jitter must be in [0, 0.1] m";
  else if (!in(read_noise_dn, 0, 50) || !in(shot_noise_gain, 0, 5))
    os << "noise: read noise must be in [0, 50] DN and shot-noise gain in [0, 5]";
  else if (!in(optical_blur_px, 0, 10))
    os << "optical blur must be in [0, 10] px";
  else if (!in(vignetting, 0, 0.9))
    os << "vignetting must be in [0, 0.9]";
  else if (!in(shutter_fraction, 0.01, 1.0))
    os << "shutter fraction must be in [0.01, 1]";
  else if (blur_subframes < 3 || blur_subframes > 31 || blur_subframes % 2 == 0)
    os << "blur subframes = " << blur_subframes << " must be odd, 3..31";
  else if (blur_step_px != 0 && !in(blur_step_px, 0.25, 10))
    os << "blur step = " << blur_step_px << " px must be 0 (fixed sub-frames) or in [0.25, 10]";
  else if (blur_subframes_max < blur_subframes || blur_subframes_max > 127 || blur_subframes_max % 2 == 0)
    os << "blur subframes max = " << blur_subframes_max << " must be odd, blur subframes (" << blur_subframes
       << ")..127";
  else if (!in(exposure_variation, 0, 0.5))
    os << "exposure variation must be in [0, 0.5]";
  else if (!in(exposure, 0.05, 4.0))
    os << "exposure = " << exposure << " must be in [0.05, 4]";
  else if (!in(aim_offset_rad, 0, 0.6))
    os << "aim offset = " << aim_offset_rad << " rad must be in [0, 0.6]";
  else if (!in(head_turn_rad, 0, 1.0))
    os << "head turn = " << head_turn_rad << " rad must be in [0, 1]";
  else if (!in(head_turn_period_s, 0.2, 60) || !in(head_turn_s, 0.01, 0.25 * head_turn_period_s))
    os << "head turn duration " << head_turn_s << " s must be in [0.01, period/4] (period "
       << head_turn_period_s << " s, in [0.2, 60])";
  else if (!in(hand_crossing_period_s, 1.0, 60))
    os << "hand crossing period = " << hand_crossing_period_s << " s must be in [1, 60]";
  else if (!in(mirror_glare, 0, 1))
    os << "mirror glare = " << mirror_glare << " must be in [0, 1]";
  else if (tag_occluders < 0 || tag_occluders > 32)
    os << "tag occluders must be in 0..32";
  else if (!in(mirror_in_mouth_fraction, 0, 1))
    os << "mirror fraction must be in [0, 1]";
  else if (!in(drill_force_N, 0.1, 3.0))
    os << "drill force must be in [0.1, 3] N";
  else if (bur_samples < 500 || bur_samples > 30000)
    os << "bur samples must be in 500..30000";
  else if (camera.enabled && !camera.validate().empty())
    os << camera.validate();
  else if (camera.enabled && camera.rolling_readout_s >= 1.0 / fps)
    os << "camera.rolling_readout_s = " << camera.rolling_readout_s << " must be shorter than a frame (1/fps)";
  return os.str();
}

namespace {

using Iso = Eigen::Isometry3d;
using V3d = Eigen::Vector3d;

Iso from_colmajor(const double* m) {
  Iso T = Iso::Identity();
  T.matrix() = Eigen::Map<const Eigen::Matrix4d>(m);
  return T;
}

// Sum of sinusoids with random frequencies and phases, in [-1, 1]: a smooth
// random walk that is a pure function of time (any frame can be rendered on
// its own, and sub-frames for motion blur need no state).
struct Smooth {
  std::array<double, 4> w{}, f{}, ph{};
  static Smooth make(std::mt19937_64& rng, double speed, double tremor_weight) {
    std::uniform_real_distribution<double> u(0, 1);
    Smooth s;
    double sum = 0;
    for (int k = 0; k < 3; ++k) {
      s.w[k] = 0.5 + u(rng);
      sum += s.w[k];
      s.f[k] = speed * (0.04 + 0.09 * k + 0.08 * u(rng));
      s.ph[k] = 2 * M_PI * u(rng);
    }
    for (int k = 0; k < 3; ++k) s.w[k] *= (1 - tremor_weight) / sum;
    // Physiological head tremor: small and fast.
    s.w[3] = tremor_weight;
    s.f[3] = 1.5 + 2.0 * u(rng);
    s.ph[3] = 2 * M_PI * u(rng);
    return s;
  }
  double operator()(double t) const {
    double v = 0;
    for (int k = 0; k < 4; ++k) v += w[k] * std::sin(2 * M_PI * f[k] * t + ph[k]);
    return v;
  }
};

double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3 - 2 * x);
}

Iso look_at(const V3d& eye, const V3d& target, double roll) {
  const V3d z = (target - eye).normalized();
  V3d y = -V3d::UnitY();  // image down = world down
  y = (y - y.dot(z) * z).normalized();
  const V3d x = y.cross(z);
  Iso T = Iso::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = y;
  T.linear().col(2) = z;
  T.linear() = T.linear() * Eigen::AngleAxisd(roll, V3d::UnitZ()).toRotationMatrix();
  T.translation() = eye;
  return T;
}

// Fast deterministic Gaussian noise: xorshift64* and the sum of four 16-bit
// uniforms (Irwin-Hall, rescaled to unit variance; tails cut at 3.5 sigma).
struct Noise {
  std::uint64_t s;
  explicit Noise(std::uint64_t seed) : s(seed * 0x9E3779B97F4A7C15ull + 0x2545F4914F6CDD1Dull) {
    if (s == 0) s = 1;
  }
  std::uint64_t next() {
    s ^= s >> 12;
    s ^= s << 25;
    s ^= s >> 27;
    return s * 0x2545F4914F6CDD1Dull;
  }
  float gauss() {
    const std::uint64_t r = next();
    const float sum =
        static_cast<float>((r & 0xffff) + ((r >> 16) & 0xffff) + ((r >> 32) & 0xffff) + (r >> 48)) *
        (1.0f / 65536.0f);
    return (sum - 2.0f) * 1.7320508f;
  }
};

constexpr int kTagCodeStep = 4;  // id pass: tag i is drawn with green = 4 (i + 1) / 255

}  // namespace

// ---- the generator --------------------------------------------------------------

struct SynthGenerator::Impl {
  StationScene station;
  SynthOptions opt;
  std::unique_ptr<CameraModel> camera;
  std::optional<TagFamily> family;
  std::optional<Renderer> renderer;
  // Video pass with lens distortion (generator v2): the pinhole canvas is
  // rendered undistorted (this renderer, renderer's canvas camera) and
  // resampled through the distortion map in linear light (`distort_map`,
  // CV_32FC2), not on the encoded values as Renderer does (which darkened
  // the edges: tag outlines -0.10 px). Empty without distortion.
  std::optional<Renderer> video_renderer;
  cv::Mat distort_map;
  std::optional<synth::SceneProgram> program;
  std::optional<ToothRenderer> tooth_renderer;

  synth::GpuMesh room, mannequin, hand, handpiece, bur, mirror_face, mirror_body, paddle, occluder;
  synth::GpuMesh finger;  // the crossing finger (hand_crossing)
  struct GpuTag {
    synth::GpuMesh quad;
    Texture texture;
    bool on_mirror = false;
    const TagPlacement* placement = nullptr;
  };
  std::vector<GpuTag> tags;

  // Haptics: the tooth, the scripted hand and the engine, in simulated time.
  std::optional<volume::VoxelVolume> volume;
  std::optional<volume::BurSamples> bur_samples;
  std::unique_ptr<haptics::SimulatedDevice> device;
  std::unique_ptr<haptics::SessionLogWriter> log;
  std::unique_ptr<haptics::Engine> engine;
  std::unique_ptr<volume::Surface> surface;
  std::uint64_t steps_done = 0;
  bool finished = false;

  // Motion.
  Smooth s_dist, s_az, s_el, s_roll, s_tx, s_ty, s_tz, s_exposure;
  std::array<Smooth, 6> s_mirror;
  std::array<Smooth, 3> s_glare;  // glare spot: x, y on the paddle, intensity
  struct Occluder {
    int tag = 0;
    std::array<Smooth, 4> s;
  };
  std::vector<Occluder> occluders;
  std::vector<std::pair<double, double>> exposure_jumps;  // (time, relative step)
  Iso T_tooth_mir_nominal = Iso::Identity();
  V3d mirror_out_dir = V3d::UnitZ();  // man frame

  cv::Mat vignette;  // CV_32F gain map

  // ---- the physical camera model (issue 24; synth.h CameraSensorModel) ----
  cv::Mat vignette_cos;  // CV_32F: cos^n of each pixel's field angle
  double ae_gain = 1.0;          // the auto-exposure loop's exposure factor
  double ae_target_lin = -1;     // its target: the first frame's centre-weighted mean (linear luma)
  std::vector<std::pair<int, double>> ae_pending;  // (frame it takes effect, step in EV)
  int ae_steps = 0;

  cv::Mat linear;    // scratch: the frame in linear light (CV_32FC3)
  int frame = 0;

  // Scene state at one instant.
  struct State {
    Iso T_cam_man, T_man_mir, T_man_tip, T_dev_sty;
    std::vector<Iso> T_man_occ;
    std::optional<Iso> T_man_finger;  // the crossing finger when in view
    bool finger_in_front = false;     // within 2 cm of the tooth's line of sight
    std::uint64_t step = 0;
    double haptic_time_s = 0;
    bool pedal = false;
  };

  // Each eye's sensor has its own noise (the left eye's is the mono footage's).
  std::uint64_t eye_noise_salt() const { return opt.eye == 0 ? 0 : 0x9E3779B97F4A7C15ull * static_cast<std::uint64_t>(opt.eye); }

  Iso T_man_cam(double t) const {
    const SynthOptions& o = opt;
    const double d = 0.5 * (o.distance_min_m + o.distance_max_m) +
                     0.5 * (o.distance_max_m - o.distance_min_m) * s_dist(t);
    const double az = o.azimuth_centre_rad + o.azimuth_amplitude_rad * s_az(t);
    const double el = o.elevation_centre_rad + o.elevation_amplitude_rad * s_el(t);
    const V3d target =
        V3d(0.008, -0.006, -0.02) + o.look_at_jitter_m * V3d(s_tx(t), s_ty(t), s_tz(t));
    const V3d eye =
        target + d * V3d(std::sin(az) * std::cos(el), std::sin(el), std::cos(az) * std::cos(el));
    Iso T = look_at(eye, target, o.roll_amplitude_rad * s_roll(t));
    const double yaw = aim_yaw(t) + turn_yaw(t);
    if (yaw != 0) T.linear() = T.linear() * Eigen::AngleAxisd(yaw, V3d::UnitY()).toRotationMatrix();
    return T;
  }

  // Camera yaw about its own vertical axis (rad): aim offset (offframe).
  // -1 -> +1 in 1 s, held 1 s, back in 1 s, held 1 s.
  double aim_yaw(double t) const {
    if (opt.aim_offset_rad <= 0) return 0;
    const double q = std::fmod(t, 4.0) / 4.0;
    const double s = q < 0.5 ? 2 * smoothstep(q / 0.25) - 1 : 1 - 2 * smoothstep((q - 0.5) / 0.25);
    return opt.aim_offset_rad * s;
  }
  // Sudden head turns: away at 1/4 of each period, back at 3/4.
  double turn_yaw(double t) const {
    if (opt.head_turn_rad <= 0) return 0;
    const double P = opt.head_turn_period_s, D = opt.head_turn_s;
    const double q = std::fmod(t, P);
    return opt.head_turn_rad * (smoothstep((q - 0.25 * P) / D) - smoothstep((q - 0.75 * P) / D));
  }
  // |angular velocity| of the camera (rad/s), central difference.
  double camera_speed(double t) const {
    const double h = 5e-4;
    const Iso a = T_man_cam(std::max(0.0, t - h)), b = T_man_cam(t + h);
    return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle() / (t + h - std::max(0.0, t - h));
  }

  // The crossing finger (hand_crossing): 7 cm in front of the tooth toward
  // the camera, vertical in the image, sweeping sideways across the tooth's
  // line of sight from -5 to +5 cm in 0.8 s, once per period; absent (out of
  // view) for the rest of the period. The finger capsule lies along x.
  std::optional<Iso> T_man_finger(double t, const Iso& T_man_cam_t, bool& in_front) const {
    in_front = false;
    if (!opt.hand_crossing) return std::nullopt;
    const double ph = (std::fmod(t, opt.hand_crossing_period_s) - 0.3) / 0.8;
    if (ph < 0 || ph > 1) return std::nullopt;
    const V3d p_tooth = station.calibration.T_man_tooth.translation();
    const V3d to_cam = (T_man_cam_t.translation() - p_tooth).normalized();
    const V3d side = T_man_cam_t.linear().col(0), down = T_man_cam_t.linear().col(1);
    const double offset = -0.05 + 0.1 * ph;
    in_front = std::abs(offset) < 0.02;
    Iso T = Iso::Identity();
    T.linear().col(0) = down;
    T.linear().col(1) = to_cam.cross(down).normalized();
    T.linear().col(2) = T.linear().col(0).cross(T.linear().col(1));
    T.translation() = p_tooth + 0.07 * to_cam + offset * side + 0.02 * down;
    return T;
  }

  Iso T_man_mir(double t) const {
    // Small wobble about the nominal pose in the mouth; pulled out along the
    // handle (out of view) for part of each 8 s cycle.
    Iso W = Iso::Identity();
    W.linear() = (Eigen::AngleAxisd(0.14 * s_mirror[0](t), V3d::UnitX()) *
                  Eigen::AngleAxisd(0.14 * s_mirror[1](t), V3d::UnitY()) *
                  Eigen::AngleAxisd(0.2 * s_mirror[2](t), V3d::UnitZ()))
                     .toRotationMatrix();
    W.translation() = 2.5e-3 * V3d(s_mirror[3](t), s_mirror[4](t), s_mirror[5](t));
    Iso T = station.calibration.T_man_tooth * T_tooth_mir_nominal * W;
    const double f = opt.mirror_in_mouth_fraction;
    if (f < 1.0) {
      const double period = 8.0, ramp = 0.6;
      const double ph = std::fmod(t, period);
      const double in_end = f * period;
      double out = 0;  // 0 in the mouth, 1 out of view
      if (ph >= in_end) out = smoothstep((ph - in_end) / ramp);
      if (ph > period - ramp) out = std::min(out, smoothstep((period - ph) / ramp));
      if (f <= 0) out = 1;
      T.translation() += out * 0.4 * mirror_out_dir + out * 0.15 * V3d(0, -1, 0);
    }
    return T;
  }

  Iso T_man_occ(std::size_t i, double t) const {
    const Occluder& o = occluders[i];
    const TagPlacement& tag = station.mannequin_tags[static_cast<std::size_t>(o.tag)];
    const Iso& T = tag.T_parent_tag;
    const double h = 0.5 * tag.size_m;
    const V3d out = -T.linear().col(2);
    const V3d c = T.translation() + out * (0.014 + 0.006 * o.s[0](t)) +
                  T.linear().col(0) * (1.3 * h * o.s[1](t)) +
                  T.linear().col(1) * (1.3 * h * o.s[2](t));
    Iso R = Iso::Identity();
    R.linear() = T.linear() * Eigen::AngleAxisd(1.2 * o.s[3](t), V3d::UnitZ()).toRotationMatrix();
    R.translation() = c;
    return R;  // the occluder capsule lies along x of this frame
  }

  double exposure_gain(double t) const {
    double g = 1.0 + opt.exposure_variation * s_exposure(t);
    for (const auto& [tj, a] : exposure_jumps)
      if (t >= tj) g *= 1.0 + a * std::exp(-(t - tj) / 0.15);
    return opt.exposure * std::clamp(g, 0.3, 2.5);
  }

  // Runs the haptic engine up to time t (the last 1 kHz step not after t).
  // Before 0 (the first frame's exposure starts before its centre) the
  // engine stays at its first step; the head, mirror, finger and occluders
  // move at t itself, so every exposure is centred on its truth's time.
  State state_at(double t) {
    State s;
    const std::uint64_t want = static_cast<std::uint64_t>(std::floor(std::max(t, 0.0) * 1000.0 + 1e-9)) + 1;
    if (want > steps_done) {
      steps_done += engine->run_steps(want - steps_done);
      surface_dirty = true;
    }
    const haptics::HapticSnapshot snap = engine->snapshot();
    s.step = snap.step;
    s.haptic_time_s = snap.time_s;
    s.pedal = snap.pedal != 0;
    s.T_dev_sty = from_colmajor(snap.T_dev_sty);
    const auto& c = station.calibration;
    s.T_man_tip = c.T_man_dev * s.T_dev_sty * c.T_sty_tip;
    // T_man_cam(t) is the head (the rig's left eye); this generator's eye
    // sits at T_rig_eye on it (identity: the left eye, mono footage).
    const Iso T_man_cam_t = T_man_cam(t);
    s.T_cam_man = (T_man_cam_t * opt.T_rig_eye).inverse();
    s.T_man_finger = T_man_finger(t, T_man_cam_t, s.finger_in_front);
    s.T_man_mir = T_man_mir(t);
    for (std::size_t i = 0; i < occluders.size(); ++i) s.T_man_occ.push_back(T_man_occ(i, t));
    return s;
  }
  bool surface_dirty = true;
  int last_subframes = 1;  // the sub-frames of the last exposure rendered (1: no motion blur)

  // Scene light under the camera model: the slow drift times the jumps, which persist (a lamp
  // switched, a shadow) instead of settling as the classic model's do; the AE answers them.
  double light_level(double t) const {
    double g = 1.0 + opt.exposure_variation * s_exposure(t);
    for (const auto& [tj, a] : exposure_jumps)
      if (t >= tj) g *= 1.0 + a;
    return opt.exposure * std::clamp(g, 0.2, 5.0);
  }

  // The number of sub-frames for the exposure [tc - e/2, tc + e/2]: blur_subframes, or with
  // blur_step_px > 0 enough (odd, bounded) that no tag corner moves more than blur_step_px
  // between two sub-frames. The path is measured on 16 steps of the head's and the mirror's
  // motion (pure functions of time: the haptic engine is not run).
  int blur_subframe_count(double tc, double exposure) const {
    const int K0 = opt.blur_subframes;
    if (opt.blur_step_px <= 0) return K0;
    const auto& c = station.calibration;
    constexpr int kSteps = 16;
    std::vector<std::optional<Eigen::Vector2d>> prev;
    std::vector<double> path;
    for (int j = 0; j <= kSteps; ++j) {
      const double ts = tc + (static_cast<double>(j) / kSteps - 0.5) * exposure;
      const Iso T_cam_man = (T_man_cam(ts) * opt.T_rig_eye).inverse();
      const Iso T_cam_mtag = T_cam_man * T_man_mir(ts) * c.T_mtag_mir.inverse();
      std::size_t n = 0;
      for (const auto& g : tags) {
        const Iso T_cam_tag = (g.on_mirror ? T_cam_mtag : T_cam_man) * g.placement->T_parent_tag;
        const double h = 0.5 * g.placement->size_m;
        static constexpr double kS[4][2] = {{-1, 1}, {1, 1}, {1, -1}, {-1, -1}};
        for (int k = 0; k < 4; ++k, ++n) {
          const std::optional<Eigen::Vector2d> px = camera->project(T_cam_tag * V3d(kS[k][0] * h, kS[k][1] * h, 0));
          if (j == 0) {
            prev.push_back(px);
            path.push_back(0);
            continue;
          }
          if (px && prev[n]) path[n] += (*px - *prev[n]).norm();
          prev[n] = px;
        }
      }
    }
    double longest = 0;
    for (double l : path) longest = std::max(longest, l);
    int K = static_cast<int>(std::ceil(longest / opt.blur_step_px)) + 1;
    if (K % 2 == 0) ++K;
    return std::clamp(K, K0, opt.blur_subframes_max);
  }

  // One exposure in linear light centred at tc: with motion blur, sub-frames across the
  // exposure time averaged; `centre` is the middle sub-frame's state.
  void render_exposure(double tc, cv::Mat& out, State& centre) {
    cv::Mat lin;
    if (!opt.motion_blur) {
      centre = state_at(tc);
      draw_video(centre);
      read_video_linear(out);
      return;
    }
    const double exposure = opt.shutter_fraction / opt.fps;
    const int K = blur_subframe_count(tc, exposure);
    last_subframes = K;
    out.create(station.calibration.camera.height, station.calibration.camera.width, CV_32FC3);
    out.setTo(cv::Scalar::all(0));
    for (int j = 0; j < K; ++j) {
      const double ts = tc + (static_cast<double>(j) / (K - 1) - 0.5) * exposure;
      State s = state_at(ts);
      if (j == K / 2) centre = s;
      draw_video(s);
      read_video_linear(lin);
      out += lin;
    }
    out *= 1.0 / K;
  }

  // The frame in linear light at time t: one exposure (global shutter), or rolling_bands bands
  // of rows, each exposed at its own time across the readout; `mid` = the middle row's state.
  void render_physical(double t, cv::Mat& out, State& mid) {
    const CameraSensorModel& c = opt.camera;
    const int H = station.calibration.camera.height;
    if (c.rolling_readout_s <= 0) {
      render_exposure(t, out, mid);
      return;
    }
    const int B = c.rolling_bands;
    cv::Mat band;
    for (int b = 0; b < B; ++b) {
      const double tb = t + ((b + 0.5) / B - 0.5) * c.rolling_readout_s;
      State s;
      render_exposure(tb, band, s);
      if (b == B / 2) mid = s;
      if (b == 0) out.create(band.size(), band.type());
      const int r0 = b * H / B, r1 = (b + 1) * H / B;
      band.rowRange(r0, r1).copyTo(out.rowRange(r0, r1));
    }
  }

  // Defocus: the thin lens's circle of confusion at the tooth's depth, diameter in px.
  double defocus_px(const State& mid) const {
    const CameraSensorModel& c = opt.camera;
    if (c.aperture_m <= 0) return 0;
    const double depth = (mid.T_cam_man * station.calibration.T_man_tooth).translation().z();
    if (depth <= 0) return 0;
    return station.calibration.camera.fx * c.aperture_m * std::abs(1.0 / depth - 1.0 / c.focus_distance_m);
  }

  // Lens (defocus disc, optical Gaussian), vignetting, exposure, photo-electrons with shot and
  // read noise, the full well, sRGB, JPEG: linear light in, the camera's 8-bit BGR out.
  Status sensor(cv::Mat& lin, double gain, double blur_px, int frame_index, cv::Mat& bgr) {
    const CameraSensorModel& c = opt.camera;
    if (blur_px >= 0.5) {
      // A uniform disc of diameter blur_px, its edge pixels weighted by their covered area (4x4).
      const int r = static_cast<int>(std::ceil(0.5 * blur_px));
      cv::Mat k(2 * r + 1, 2 * r + 1, CV_32F, cv::Scalar(0));
      const double R2 = 0.25 * blur_px * blur_px;
      for (int y = -r; y <= r; ++y)
        for (int x = -r; x <= r; ++x) {
          int in = 0;
          for (int sy = 0; sy < 4; ++sy)
            for (int sx = 0; sx < 4; ++sx) {
              const double px = x - 0.375 + 0.25 * sx, py = y - 0.375 + 0.25 * sy;
              in += px * px + py * py <= R2;
            }
          k.at<float>(y + r, x + r) = static_cast<float>(in);
        }
      k /= cv::sum(k)[0];
      cv::filter2D(lin, lin, -1, k, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
    }
    if (opt.optical_blur_px > 0) cv::GaussianBlur(lin, lin, cv::Size(0, 0), opt.optical_blur_px);
    Noise rng(opt.seed * 1000003ull + static_cast<std::uint64_t>(frame_index) + 17 + eye_noise_salt());
    const float fw = static_cast<float>(c.full_well_e), read2 = static_cast<float>(c.read_noise_e * c.read_noise_e);
    bgr.create(lin.size(), CV_8UC3);
    for (int v = 0; v < lin.rows; ++v) {
      const float* lp = lin.ptr<float>(v);
      const float* vg = vignette_cos.ptr<float>(v);
      auto* p = bgr.ptr<std::uint8_t>(v);
      for (int u = 0; u < lin.cols; ++u) {
        const float g = static_cast<float>(gain) * vg[u] * fw;
        for (int ch = 0; ch < 3; ++ch) {
          float e = std::max(lp[3 * u + ch], 0.0f) * g;  // photo-electrons
          e += std::sqrt(e + read2) * rng.gauss();
          e = std::clamp(e, 0.0f, fw);
          p[3 * u + ch] = static_cast<std::uint8_t>(std::clamp(std::lround(synth::srgb_encode_dn(e / fw)), 0L, 255L));
        }
      }
    }
    if (c.jpeg_quality > 0) {
      std::vector<std::uint8_t> buf;
      if (!cv::imencode(".jpg", bgr, buf, {cv::IMWRITE_JPEG_QUALITY, c.jpeg_quality}))
        return Error{"synth: JPEG encoding failed (OpenCV imencode)"};
      bgr = cv::imdecode(buf, cv::IMREAD_COLOR);
      if (bgr.empty()) return Error{"synth: JPEG decoding failed (OpenCV imdecode)"};
    }
    return {};
  }

  // The auto-exposure loop, after each frame: the centre-weighted mean (the middle half of the
  // image, linear luma) against the target; off by more than the deadband, one step the other
  // way, taking effect ae_delay_frames later (one decision at a time).
  void ae_update(const cv::Mat& bgr, int frame_index) {
    const CameraSensorModel& c = opt.camera;
    for (auto it = ae_pending.begin(); it != ae_pending.end();)
      if (it->first <= frame_index + 1) {
        ae_gain = std::clamp(ae_gain * std::exp2(it->second), 1.0 / 16, 16.0);
        ++ae_steps;
        it = ae_pending.erase(it);
      } else {
        ++it;
      }
    if (c.ae_step_ev <= 0) return;
    const cv::Mat centre = bgr(cv::Rect(bgr.cols / 4, bgr.rows / 4, bgr.cols / 2, bgr.rows / 2));
    const cv::Mat& dec = srgb_decode_table();
    double sum = 0;
    for (int v = 0; v < centre.rows; ++v) {
      const auto* p = centre.ptr<std::uint8_t>(v);
      for (int u = 0; u < centre.cols; ++u)
        sum += 0.114 * dec.at<float>(0, p[3 * u]) + 0.587 * dec.at<float>(0, p[3 * u + 1]) +
               0.299 * dec.at<float>(0, p[3 * u + 2]);
    }
    const double mean = std::max(sum / (static_cast<double>(centre.rows) * centre.cols), 1e-6);
    if (ae_target_lin < 0) {
      ae_target_lin = mean;
      return;
    }
    if (!ae_pending.empty()) return;
    const double err_ev = std::log2(mean / ae_target_lin);
    if (std::abs(err_ev) > c.ae_deadband_ev)
      ae_pending.emplace_back(frame_index + c.ae_delay_frames, err_ev > 0 ? -c.ae_step_ev : c.ae_step_ev);
  }

  Eigen::Vector3f light_cam(const State& s, const V3d& dir_man) const {
    return (s.T_cam_man.linear() * dir_man).cast<float>();
  }

  // What the camera sees (video pass).
  void draw_video(const State& s) {
    const auto& c = station.calibration;
    Renderer& vr = video_renderer ? *video_renderer : *renderer;
    vr.begin_frame(Eigen::Vector4f(kVideoClear, kVideoClear, kVideoClear, 1.0f));
    const auto& P = vr.clip_from_cam();
    using M = synth::SceneProgram::Mode;
    // Head lamp just above the camera; operating light above and in front.
    program->begin(Eigen::Vector3f(0.0f, -0.3f, -1.0f), light_cam(s, V3d(0.1, 1.0, 0.6)));
    program->draw(room, P, s.T_cam_man, M::kLit);
    program->draw(mannequin, P, s.T_cam_man, M::kLit);
    const Iso T_cam_tip = s.T_cam_man * s.T_man_tip;
    program->draw(hand, P, T_cam_tip, M::kLit);
    program->draw(handpiece, P, T_cam_tip, M::kLit);
    program->draw(bur, P, T_cam_tip, M::kLit);
    const Iso T_cam_mir = s.T_cam_man * s.T_man_mir;
    const Iso T_cam_mtag = T_cam_mir * c.T_mtag_mir.inverse();
    program->draw(mirror_body, P, T_cam_mir, M::kLit);
    program->draw(mirror_face, P, T_cam_mir, M::kMirror);
    program->draw(paddle, P, T_cam_mtag, M::kLit);
    for (std::size_t i = 0; i < s.T_man_occ.size(); ++i)
      program->draw(occluder, P, s.T_cam_man * s.T_man_occ[i], M::kLit);
    if (s.T_man_finger) program->draw(finger, P, s.T_cam_man * *s.T_man_finger, M::kLit);
    for (const auto& g : tags) {
      const Iso T = (g.on_mirror ? T_cam_mtag : s.T_cam_man) * g.placement->T_parent_tag;
      program->draw(g.quad, P, T, M::kTextured, {}, g.texture.id(), false);
    }
    vr.end_frame();
  }

  // The video pass just drawn, in linear light (CV_32FC3 BGR, camera size):
  // the distortion resampling happens here, in linear light.
  void read_video_linear(cv::Mat& lin) {
    if (!video_renderer) {
      renderer->read_bgr(video8);
      cv::LUT(video8, srgb_decode_table(), lin);
      return;
    }
    video_renderer->read_bgr(video8);
    cv::LUT(video8, srgb_decode_table(), canvas_linear);
    const float clear = srgb_decode_table().at<float>(0, static_cast<int>(std::lround(kVideoClear * 255)));
    cv::remap(canvas_linear, lin, distort_map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT,
              cv::Scalar::all(clear));
  }
  static constexpr float kVideoClear = 0.5f;  // background grey (sRGB) where nothing is drawn
  cv::Mat video8, canvas_linear;             // scratch

  // Id passes. m1: red = tooth silhouette alone; green/blue = tags alone.
  // m2: everything real plus the tooth: red where the tooth is frontmost,
  // green/blue = visible tag pixels, alpha = moving foreground (1) or
  // mirror face (0.5).
  void draw_ids(const State& s, bool all, cv::Mat& out) {
    const auto& c = station.calibration;
    renderer->begin_frame(Eigen::Vector4f::Zero());
    const auto& P = renderer->clip_from_cam();
    using M = synth::SceneProgram::Mode;
    const Iso T_cam_tooth = s.T_cam_man * c.T_man_tooth;
    glColorMask(GL_TRUE, GL_FALSE, GL_FALSE, GL_FALSE);
    tooth_renderer->draw(P, T_cam_tooth);
    if (!all) {
      glClear(GL_DEPTH_BUFFER_BIT);
      glColorMask(GL_FALSE, GL_TRUE, GL_TRUE, GL_FALSE);
    } else {
      glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    }
    program->begin(Eigen::Vector3f::UnitZ(), Eigen::Vector3f::UnitZ());
    const Iso T_cam_tip = s.T_cam_man * s.T_man_tip;
    const Iso T_cam_mir = s.T_cam_man * s.T_man_mir;
    const Iso T_cam_mtag = T_cam_mir * c.T_mtag_mir.inverse();
    if (all) {
      const Eigen::Vector4f none(0, 0, 0, 0), fg(0, 0, 0, 1), face(0, 0, 0, 0.5f);
      program->draw(mannequin, P, s.T_cam_man, M::kFlat, none);
      program->draw(hand, P, T_cam_tip, M::kFlat, fg);
      program->draw(handpiece, P, T_cam_tip, M::kFlat, fg);
      program->draw(bur, P, T_cam_tip, M::kFlat, fg);
      program->draw(mirror_body, P, T_cam_mir, M::kFlat, fg);
      program->draw(mirror_face, P, T_cam_mir, M::kFlat, face);
      program->draw(paddle, P, T_cam_mtag, M::kFlat, fg);
      for (std::size_t i = 0; i < s.T_man_occ.size(); ++i)
        program->draw(occluder, P, s.T_cam_man * s.T_man_occ[i], M::kFlat, fg);
      if (s.T_man_finger) program->draw(finger, P, s.T_cam_man * *s.T_man_finger, M::kFlat, fg);
    }
    for (std::size_t i = 0; i < tags.size(); ++i) {
      const auto& g = tags[i];
      const Iso T = (g.on_mirror ? T_cam_mtag : s.T_cam_man) * g.placement->T_parent_tag;
      const float code = static_cast<float>(kTagCodeStep * (i + 1)) / 255.0f;
      program->draw(g.quad, P, T, M::kFlat, Eigen::Vector4f(0, code, 1, g.on_mirror ? 1.f : 0.f), 0,
                    false);
    }
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    renderer->end_frame();
    renderer->read_rgba(out);
  }

  // Per-tag pixel counts from an id image (blue = coverage, green/blue = code).
  std::vector<int> count_tags(const cv::Mat& rgba) const {
    std::vector<int> n(tags.size(), 0);
    for (int v = 0; v < rgba.rows; ++v) {
      const auto* p = rgba.ptr<cv::Vec4b>(v);
      for (int u = 0; u < rgba.cols; ++u) {
        const int b = p[u][2];
        if (b < 128) continue;
        const double code = p[u][1] * 255.0 / b;
        const long i = std::lround(code / kTagCodeStep) - 1;
        if (i >= 0 && i < static_cast<long>(n.size())) ++n[static_cast<std::size_t>(i)];
      }
    }
    return n;
  }

  // A specular highlight on the mirror (mirror_glare): a saturating
  // Gaussian spot wandering over the tag paddle, drawn before the sensor
  // model (it is light, so it is blurred and noisy like the rest). True when
  // drawn (the paddle faces the camera and the spot is in the image).
  bool add_glare(cv::Mat& bgr, const State& s, double t) const {
    if (opt.mirror_glare <= 0) return false;
    const auto& c = station.calibration;
    const Iso T_cam_mtag = s.T_cam_man * s.T_man_mir * c.T_mtag_mir.inverse();
    const V3d centre = T_cam_mtag.translation();
    // Tag z points into the paddle: facing the camera when z . centre > 0.
    if (!(centre.z() > 0.02) || T_cam_mtag.linear().col(2).dot(centre.normalized()) < 0.1) return false;
    const V3d p_mtag(0.5 * station.mirror.paddle_width_m * s_glare[0](t),
                     0.5 * station.mirror.paddle_height_m * s_glare[1](t), 0.0);
    const V3d p = T_cam_mtag * p_mtag;
    const auto px = camera->project(p);
    if (!px) return false;
    const double sigma = std::max(1.0, c.camera.fx * 2.0e-3 / p.z());  // ~2 mm spot
    // From a faint sheen to a burnt-out spot as the angle to the lamp changes.
    const double peak = opt.mirror_glare * 255.0 * (0.9 + 0.6 * s_glare[2](t));
    const int r = static_cast<int>(std::ceil(3 * sigma));
    const int u0 = std::max(0, static_cast<int>(px->x()) - r), u1 = std::min(bgr.cols - 1, static_cast<int>(px->x()) + r);
    const int v0 = std::max(0, static_cast<int>(px->y()) - r), v1 = std::min(bgr.rows - 1, static_cast<int>(px->y()) + r);
    if (u0 > u1 || v0 > v1) return false;
    for (int v = v0; v <= v1; ++v) {
      auto* row = bgr.ptr<std::uint8_t>(v);
      for (int u = u0; u <= u1; ++u) {
        const double d2 = (u - px->x()) * (u - px->x()) + (v - px->y()) * (v - px->y());
        const double add = peak * std::exp(-0.5 * d2 / (sigma * sigma));
        for (int ch = 0; ch < 3; ++ch)
          row[3 * u + ch] = static_cast<std::uint8_t>(std::min(255.0, row[3 * u + ch] + add));
      }
    }
    return true;
  }

  // The sensor: the lens blurs light (linear: the encoded image is decoded,
  // blurred and encoded again, generator v2; v1 blurred the encoded values,
  // which moved blurred edges), then gain, vignetting and noise act on the
  // encoded digital numbers.
  void post_process(cv::Mat& bgr, double gain, int frame_index) {
    const bool blur = opt.optical_blur_px > 0;
    if (blur) {
      cv::LUT(bgr, srgb_decode_table(), linear);
      cv::GaussianBlur(linear, linear, cv::Size(0, 0), opt.optical_blur_px);
    }
    Noise rng(opt.seed * 1000003ull + static_cast<std::uint64_t>(frame_index) + 17 + eye_noise_salt());
    const float read2 = static_cast<float>(opt.read_noise_dn * opt.read_noise_dn);
    const float shot = static_cast<float>(opt.shot_noise_gain);
    const bool noisy = read2 > 0 || shot > 0;
    for (int v = 0; v < bgr.rows; ++v) {
      auto* p = bgr.ptr<std::uint8_t>(v);
      const float* lp = blur ? linear.ptr<float>(v) : nullptr;
      const float* vg = vignette.ptr<float>(v);
      for (int u = 0; u < bgr.cols; ++u) {
        const float g = static_cast<float>(gain) * vg[u];
        for (int ch = 0; ch < 3; ++ch) {
          float x = (blur ? synth::srgb_encode_dn(lp[3 * u + ch]) : p[3 * u + ch]) * g;
          if (noisy) x += std::sqrt(read2 + shot * std::max(x, 0.0f)) * rng.gauss();
          p[3 * u + ch] = static_cast<std::uint8_t>(std::clamp(std::lround(x), 0L, 255L));
        }
      }
    }
  }
};

SynthGenerator::~SynthGenerator() {
  if (impl_) (void)finish();
}

const StationScene& SynthGenerator::station() const { return impl_->station; }
const SynthOptions& SynthGenerator::options() const { return impl_->opt; }
const haptics::PoseHistory& SynthGenerator::haptic_history() const { return impl_->engine->pose_history(); }
int SynthGenerator::frames_done() const { return impl_->frame; }

Status SynthGenerator::finish() {
  if (impl_->finished) return {};
  impl_->finished = true;
  if (impl_->log) return impl_->log->close();
  return {};
}

namespace {
// A board station (`dentar live --station box`, the printed kit taped onto a box): every
// mannequin tag on one plane, facing one way, that plane normal to a mannequin axis. Such a
// station is drawn as a cardboard box whose top is the board (the tags' outline plus 15 mm,
// 80 mm deep), not as the phantom head. nullopt: any other layout (the head is drawn).
std::optional<synth::Mesh> board_box(const StationScene& st) {
  if (st.mannequin_tags.size() < 3) return std::nullopt;
  const V3d n = st.mannequin_tags[0].T_parent_tag.linear().col(2);  // into the tags
  int axis = -1;
  for (int a = 0; a < 3; ++a)
    if (std::abs(std::abs(n[a]) - 1.0) < 1e-6) axis = a;
  if (axis < 0) return std::nullopt;
  const double plane = st.mannequin_tags[0].T_parent_tag.translation()[axis];
  Eigen::Vector3d lo = V3d::Constant(1e9), hi = V3d::Constant(-1e9);
  for (const auto& t : st.mannequin_tags) {
    if ((t.T_parent_tag.linear().col(2) - n).norm() > 1e-6) return std::nullopt;
    if (std::abs(t.T_parent_tag.translation()[axis] - plane) > 1e-4) return std::nullopt;
    const double r = 0.5 * std::sqrt(2.0) * t.size_m * 1.8 + 0.015;  // pattern + quiet zone, margin
    lo = lo.cwiseMin(t.T_parent_tag.translation() - V3d::Constant(r));
    hi = hi.cwiseMax(t.T_parent_tag.translation() + V3d::Constant(r));
  }
  // The box lies behind the tags (along n, into them), its top 0.2 mm behind the tag plane
  // so the tags are never z-fought.
  const double top = plane + n[axis] * 0.2e-3, bottom = plane + n[axis] * 0.08;
  lo[axis] = std::min(top, bottom);
  hi[axis] = std::max(top, bottom);
  return synth::box(lo.cast<float>(), hi.cast<float>(), {0.72f, 0.58f, 0.40f});
}
}  // namespace

Result<std::unique_ptr<SynthGenerator>> SynthGenerator::create(const StationScene& station_in,
                                                               const SynthOptions& o,
                                                               const std::string& log_path) {
  if (std::string e = o.validate(); !e.empty()) return Error{"synth options: " + e};
  if (std::string e = station_in.validate(); !e.empty()) return Error{"station: " + e};
  std::unique_ptr<SynthGenerator> g(new SynthGenerator);
  g->impl_ = std::make_unique<Impl>();
  Impl& im = *g->impl_;
  im.opt = o;
  im.station = station_in;
  // Each eye's camera at the requested size: same horizontal field of view.
  auto to_size = [&o](calibration::CameraIntrinsics& c) {
    if (c.width != o.width || c.height != o.height) {
      const double s = static_cast<double>(o.width) / c.width;
      calibration::CameraIntrinsics n = c;
      n.width = o.width;
      n.height = o.height;
      n.fx = c.fx * s;
      n.fy = c.fy * s;
      n.cx = 0.5 * (o.width - 1) + (c.cx - 0.5 * (c.width - 1)) * s;
      n.cy = 0.5 * (o.height - 1) + (c.cy - 0.5 * (c.height - 1)) * s;
      c = n;
    }
    if (!o.distortion) c.dist = {0, 0, 0, 0, 0};
  };
  auto& k = im.station.calibration.camera;
  to_size(k);
  // The other eye of a stereo rig (issue 28) at the same size.
  if (im.station.stereo.present) to_size(im.station.stereo.camera_right);
  im.camera = std::make_unique<CameraModel>(k);

  RendererOptions ro;
  ro.near_m = 0.02;
  ro.far_m = 6.0;
  auto r = Renderer::create(k, ro);
  if (!r) return Error{r.error()};
  im.renderer.emplace(std::move(r).value());
  if (im.renderer->distorted()) {
    RendererOptions vo = ro;
    vo.apply_distortion = false;
    auto v = Renderer::create(im.renderer->draw_intrinsics(), vo);
    if (!v) return Error{"video canvas: " + v.error()};
    im.video_renderer.emplace(std::move(v).value());
    const auto& map_px = im.renderer->undistorted_view().map_px;
    im.distort_map.create(k.height, k.width, CV_32FC2);
    for (int v2 = 0; v2 < k.height; ++v2)
      for (int u = 0; u < k.width; ++u) {
        const Eigen::Vector2f p = map_px[static_cast<std::size_t>(v2) * k.width + u];
        im.distort_map.at<cv::Vec2f>(v2, u) = std::isnan(p.x()) ? cv::Vec2f(-100.f, -100.f) : cv::Vec2f(p.x(), p.y());
      }
  }
  auto prog = synth::SceneProgram::create();
  if (!prog) return Error{prog.error()};
  im.program.emplace(std::move(prog).value());
  auto tr = ToothRenderer::create();
  if (!tr) return Error{tr.error()};
  im.tooth_renderer.emplace(std::move(tr).value());
  for (int m = 0; m < volume::kMaxMaterials; ++m)
    im.tooth_renderer->set_style(static_cast<volume::Material>(m),
                                 MaterialStyle{Eigen::Vector3f::Ones(), 1.0f});
  im.tooth_renderer->lighting.ambient = 1.0f;
  im.tooth_renderer->lighting.diffuse = 0.0f;

  // Meshes.
  const StationScene& st = im.station;
  im.room = synth::upload(synth::room_mesh());
  if (auto board = board_box(st))
    im.mannequin = synth::upload(*board);
  else
    im.mannequin = synth::upload(synth::mannequin_mesh(st.mannequin));
  const volume::BurParams bp = volume::BurParams::capsule(0.5, 3.0);
  const HandpieceParams hp;
  const double head_z = bur_shank_end_z_m(bp) - 0.5 * hp.head_height_m;
  im.hand = synth::upload(synth::hand_mesh(hp, head_z));
  {
    synth::Mesh m;
    m.add(make_handpiece_mesh(bp, hp), Eigen::Isometry3f::Identity(), {0.62f, 0.64f, 0.68f});
    im.handpiece = synth::upload(m);
    synth::Mesh b;
    b.add(make_bur_mesh(bp), Eigen::Isometry3f::Identity(), {0.80f, 0.80f, 0.78f});
    im.bur = synth::upload(b);
  }
  {
    MirrorMeshParams mp;
    mp.radius_m = st.calibration.mirror_radius_m;
    mp.thickness_m = st.mirror.thickness_m;
    mp.neck_length_m = st.mirror.neck_length_m;
    mp.neck_radius_m = st.mirror.neck_radius_m;
    mp.handle_length_m = st.mirror.handle_length_m;
    mp.handle_radius_m = st.mirror.handle_radius_m;
    mp.stem_tilt_rad = st.mirror.stem_tilt_rad;
    const MirrorMeshes mm = make_mirror_meshes(mp);
    synth::Mesh face, body;
    face.add(mm.face, Eigen::Isometry3f::Identity(), {0.8f, 0.8f, 0.8f});
    body.add(mm.body, Eigen::Isometry3f::Identity(), {0.70f, 0.71f, 0.74f});
    im.mirror_face = synth::upload(face);
    im.mirror_body = synth::upload(body);
    // Slightly inside the tag planes so the tags are never z-fought.
    im.paddle = synth::upload(scene::paddle_mesh(st.mirror, {0.92f, 0.92f, 0.90f}, 0.2e-3f));
  }
  im.occluder = synth::upload(
      synth::capsule({-0.028f, 0, 0}, {0.028f, 0, 0}, 0.0085f, 0.0075f, {0.86f, 0.66f, 0.55f}));
  // A gloved (blue nitrile) finger for hand_crossing: 10 cm long, 9 mm radius.
  im.finger = synth::upload(
      synth::capsule({-0.05f, 0, 0}, {0.05f, 0, 0}, 0.009f, 0.008f, {0.42f, 0.52f, 0.82f}));
  im.family.emplace(TagFamily::create(st.family));
  const int ppc = 16;  // texels per cell: edges stay sharp down to ~1 mm/px
  for (const auto* list : {&st.mannequin_tags, &st.mirror_tags}) {
    for (const auto& t : *list) {
      Impl::GpuTag gt;
      gt.placement = &t;
      gt.on_mirror = list == &st.mirror_tags;
      gt.quad = synth::upload(synth::tag_quad(tag_plate_half_size_m(*im.family, t.size_m)));
      gt.texture = synth::make_tag_texture(render_tag_image(*im.family, t.id, ppc, ppc / 2));
      im.tags.push_back(std::move(gt));
    }
  }
  if (auto e = gl_error_message("SynthGenerator::create"); !e.empty()) return Error{e};

  // Motion signals, one RNG stream per purpose so changing one option does
  // not reshuffle the others.
  std::mt19937_64 rng(o.seed);
  const double sp = o.motion_speed, tremor = o.preset == SynthPreset::kHard ? 0.06 : 0.02;
  im.s_dist = Smooth::make(rng, sp, 0.0);
  im.s_az = Smooth::make(rng, sp, tremor);
  im.s_el = Smooth::make(rng, sp, tremor);
  im.s_roll = Smooth::make(rng, sp, tremor);
  im.s_tx = Smooth::make(rng, sp, tremor);
  im.s_ty = Smooth::make(rng, sp, tremor);
  im.s_tz = Smooth::make(rng, sp, tremor);
  im.s_exposure = Smooth::make(rng, 1.0, 0.0);
  for (auto& s : im.s_mirror) s = Smooth::make(rng, 2.0, 0.05);
  {
    std::mt19937_64 rng_glare(o.seed ^ 0x61a7eu);  // own stream: other signals unchanged
    for (auto& s : im.s_glare) s = Smooth::make(rng_glare, 4.0, 0.0);
  }
  std::mt19937_64 rng_occ(o.seed ^ 0x0cc1d3u);
  for (int i = 0; i < o.tag_occluders; ++i) {
    Impl::Occluder oc;
    oc.tag = static_cast<int>(rng_occ() % st.mannequin_tags.size());
    for (auto& s : oc.s) s = Smooth::make(rng_occ, 1.5, 0.0);
    im.occluders.push_back(oc);
  }
  const double duration = o.frames / o.fps;
  if (o.exposure_jumps) {
    std::mt19937_64 rng_exp(o.seed ^ 0xe4905u);
    std::uniform_real_distribution<double> u(0, 1);
    for (double t = 0.3 + 2.0 * u(rng_exp); t < duration; t += 0.4 + 3.0 * u(rng_exp))
      im.exposure_jumps.emplace_back(t, (u(rng_exp) < 0.5 ? -0.25 : 0.25));
  }
  // Mirror: face lingual of the tooth and a little above the crown, tilted
  // toward it; its handle leaves the mouth forward, toward the midline.
  {
    const V3d n = V3d(0.0, -0.5, 0.85).normalized();  // tooth frame
    const V3d h = V3d(-1.0, 0.25, 0.45).normalized();
    Iso T = Iso::Identity();
    const V3d y = -(h - h.dot(n) * n).normalized();
    T.linear().col(2) = n;
    T.linear().col(1) = y;
    T.linear().col(0) = y.cross(n);
    T.translation() = V3d(0.5e-3, 12e-3, 9e-3);
    im.T_tooth_mir_nominal = T;
    im.mirror_out_dir = st.calibration.T_man_tooth.linear() * h;
  }
  im.vignette.create(k.height, k.width, CV_32F);
  for (int v = 0; v < k.height; ++v)
    for (int u = 0; u < k.width; ++u) {
      const double x = (u - k.cx) / (0.5 * k.width), y = (v - k.cy) / (0.5 * k.width);
      im.vignette.at<float>(v, u) =
          static_cast<float>(1.0 - o.vignetting * std::min(1.0, 0.6 * (x * x + y * y)));
    }

  if (o.camera.enabled) {
    im.vignette_cos.create(k.height, k.width, CV_32F);
    for (int v = 0; v < k.height; ++v)
      for (int u = 0; u < k.width; ++u) {
        const double x = (u - k.cx) / k.fx, y = (v - k.cy) / k.fy;
        const double cos_a = 1.0 / std::sqrt(1.0 + x * x + y * y);
        im.vignette_cos.at<float>(v, u) = static_cast<float>(std::pow(cos_a, o.camera.cos_power));
      }
  }

  // Haptics: the molar, the bur, the scripted hand on the stylus and the
  // engine, exactly as `dentar demo` sets them up, in simulated time.
  volume::MolarParams molar;
  molar.voxel_mm = st.tooth_voxel_m * 1e3;
  auto vol = volume::make_molar(molar);
  if (!vol) return Error{"tooth: " + vol.error()};
  im.volume.emplace(std::move(vol).value());
  auto samples = volume::sample_bur(bp, o.bur_samples);
  if (!samples) return Error{"bur: " + samples.error()};
  im.bur_samples.emplace(std::move(samples).value());
  // The access script stretched over the footage (its passes take 12/14 of
  // `seconds` plus 2.8 s of approach and plunge).
  const double seconds = duration > 5.0 ? (duration - 3.3) * 14.0 / 12.0 : 0.0;
  const auto tips = haptics::tip_script("access", o.drill_force_N, seconds);
  // Stylus poses with the handle rolled to leave the mouth forward through
  // the left corner: the hand rests beside the left cheek, on the far side
  // from the operator's head (camera), and does not hide the mouth.
  std::vector<haptics::HandWaypoint> script;
  const Iso T_dev_tooth = st.calibration.T_tooth_dev().inverse();
  const V3d handle_man = V3d(0.5, 0.0, 0.87).normalized();
  const V3d handle_tooth = st.calibration.T_man_tooth.linear().transpose() * handle_man;
  for (const auto& w : tips) {
    const V3d z = w.axis_tooth.normalized();
    const V3d x = -(handle_tooth - handle_tooth.dot(z) * z).normalized();
    Iso T_tooth_tip = Iso::Identity();
    T_tooth_tip.linear().col(0) = x;
    T_tooth_tip.linear().col(1) = z.cross(x);
    T_tooth_tip.linear().col(2) = z;
    T_tooth_tip.translation() = w.tip_tooth_m;
    const Iso T_dev_sty = T_dev_tooth * T_tooth_tip * st.calibration.T_sty_tip.inverse();
    haptics::HandWaypoint hw;
    hw.time_s = w.time_s;
    hw.position_m = T_dev_sty.translation();
    hw.orientation = Eigen::Quaterniond(T_dev_sty.linear());
    hw.pedal = w.pedal;
    script.push_back(hw);
  }
  haptics::HandParams hand;
  hand.stiffness_N_per_m = haptics::kFingerRestStiffness_N_per_m;
  auto dev = haptics::SimulatedDevice::create(script, haptics::DeviceLimits{}, hand);
  if (!dev) return Error{"scripted hand: " + dev.error()};
  im.device = std::move(dev).value();
  haptics::EngineConfig cfg;
  cfg.T_tooth_dev = st.calibration.T_tooth_dev();
  cfg.T_sty_tip = st.calibration.T_sty_tip;
  cfg.try_realtime = false;
  if (!log_path.empty()) {
    nlohmann::json desc = {{"kind", "molar"},
                           {"voxel_mm", molar.voxel_mm},
                           {"source", "dentar synth"},
                           {"preset", synth_preset_name(o.preset)},
                           {"seed", o.seed}};
    std::string header;
    {
      auto probe = haptics::Engine::create(cfg, *im.device, *im.volume, *im.bur_samples, nullptr);
      if (!probe) return Error{"haptic engine: " + probe.error()};
      header = (*probe)->header_json(desc.dump());
    }
    haptics::LogWriterOptions lo;
    lo.fsync = false;  // offline footage: no power-loss guarantee needed
    lo.ring_capacity = std::size_t{1} << 16;
    lo.block_records = 4096;  // blocks of a fixed size, not cut by wall time: the same seed gives the same bytes
    auto log = haptics::SessionLogWriter::open(log_path, header, lo);
    if (!log) return Error{log.error()};
    im.log = std::move(log).value();
  }
  auto eng = haptics::Engine::create(cfg, *im.device, *im.volume, *im.bur_samples, im.log.get());
  if (!eng) return Error{"haptic engine: " + eng.error()};
  im.engine = std::move(eng).value();
  im.surface = std::make_unique<volume::Surface>(*im.volume);
  im.surface->extract_all();
  im.tooth_renderer->sync(*im.surface);
  return g;
}

Result<cv::Mat> SynthGenerator::render_tooth_silhouette(const Eigen::Isometry3d& T_cam_tooth) {
  Impl& im = *impl_;
  im.renderer->begin_frame(Eigen::Vector4f::Zero());
  im.tooth_renderer->draw(im.renderer->clip_from_cam(), T_cam_tooth);
  im.renderer->end_frame();
  cv::Mat rgba, out;
  im.renderer->read_rgba(rgba);
  cv::extractChannel(rgba, out, 0);
  cv::threshold(out, out, 127, 255, cv::THRESH_BINARY);
  if (auto e = gl_error_message("SynthGenerator::render_tooth_silhouette"); !e.empty())
    return Error{e};
  return out;
}

Status SynthGenerator::next(SynthFrame& out) {
  Impl& im = *impl_;
  if (im.frame >= im.opt.frames)
    return Error{"synth: all " + std::to_string(im.opt.frames) + " frames rendered"};
  const double t = im.frame / im.opt.fps;
  const auto& c = im.station.calibration;
  const int W = c.camera.width, H = c.camera.height;

  // Video: with motion blur, sub-frames across the exposure (time t is its
  // middle); the truth is the middle sub-frame's state.
  Impl::State mid;
  double gain = 0, blur_px = 0;
  bool glare = false;
  if (im.opt.camera.enabled) {
    cv::Mat lin;
    im.render_physical(t, lin, mid);
    gain = im.light_level(t) * im.ae_gain;
    blur_px = im.defocus_px(mid);
    if (Status st = im.sensor(lin, gain, blur_px, im.frame, out.image); !st.ok()) return st;
    glare = im.add_glare(out.image, mid, t);
    im.ae_update(out.image, im.frame);
  } else if (im.opt.motion_blur) {
    const double exposure = im.opt.shutter_fraction / im.opt.fps;
    const int K = im.blur_subframe_count(t, exposure);
    im.last_subframes = K;
    // The sensor integrates light: sub-frames are averaged in linear light
    // (generator v2; v1 averaged the encoded values).
    cv::Mat acc(H, W, CV_32FC3, cv::Scalar::all(0)), lin;
    // Centred on t also in the first frame (state_at takes t < 0; the clamp
    // at 0 that was here put frame 0's exposure after its truth: issue 28
    // session 17, the tags' centres 0.6 px off and the pose 0.40 mm).
    for (int j = 0; j < K; ++j) {
      const double ts = t + (static_cast<double>(j) / (K - 1) - 0.5) * exposure;
      Impl::State s = im.state_at(ts);
      if (j == K / 2) mid = s;
      im.draw_video(s);
      im.read_video_linear(lin);
      acc += lin;
    }
    out.image.create(H, W, CV_8UC3);
    const float inv_k = 1.0f / static_cast<float>(K);
    for (int v = 0; v < H; ++v) {
      const float* a = acc.ptr<float>(v);
      auto* o8 = out.image.ptr<std::uint8_t>(v);
      for (int i = 0; i < 3 * W; ++i)
        o8[i] = static_cast<std::uint8_t>(std::clamp(std::lround(synth::srgb_encode_dn(a[i] * inv_k)), 0L, 255L));
    }
  } else {
    mid = im.state_at(t);
    im.draw_video(mid);
    cv::Mat lin;
    im.read_video_linear(lin);
    out.image.create(H, W, CV_8UC3);
    for (int v = 0; v < H; ++v) {
      const float* a = lin.ptr<float>(v);
      auto* o8 = out.image.ptr<std::uint8_t>(v);
      for (int i = 0; i < 3 * W; ++i)
        o8[i] = static_cast<std::uint8_t>(std::clamp(std::lround(synth::srgb_encode_dn(a[i])), 0L, 255L));
    }
  }
  if (!im.opt.camera.enabled) {
    gain = im.exposure_gain(t);
    glare = im.add_glare(out.image, mid, t);
    im.post_process(out.image, gain, im.frame);
  }

  // Masks and tag visibility from the id passes, with the tooth as cut so far.
  if (im.surface_dirty) {
    im.surface->update();
    im.tooth_renderer->sync(*im.surface);
    im.surface_dirty = false;
  }
  cv::Mat m1, m2;
  im.draw_ids(mid, false, m1);
  im.draw_ids(mid, true, m2);
  if (auto e = gl_error_message("SynthGenerator::next"); !e.empty()) return Error{e};

  FrameTruth& tr = out.truth;
  tr = FrameTruth{};
  tr.frame = im.frame;
  tr.time_s = t;
  tr.T_cam_man = mid.T_cam_man;
  tr.T_cam_tooth = mid.T_cam_man * c.T_man_tooth;
  tr.T_cam_mir = mid.T_cam_man * mid.T_man_mir;
  tr.T_cam_mtag = tr.T_cam_mir * c.T_mtag_mir.inverse();
  tr.T_cam_tip = mid.T_cam_man * mid.T_man_tip;
  tr.T_dev_sty = mid.T_dev_sty;
  tr.haptic_step = mid.step;
  tr.haptic_time_s = mid.haptic_time_s;
  tr.pedal = mid.pedal;
  tr.exposure_gain = gain;
  tr.defocus_px = blur_px;
  tr.ae_steps = im.ae_steps;
  tr.camera_speed_deg_s = im.camera_speed(t) * 180.0 / M_PI;
  tr.blur_subframes = im.opt.motion_blur ? im.last_subframes : 1;
  tr.hand_crossing = mid.finger_in_front;
  tr.glare = glare;

  out.mask.create(H, W, CV_8UC1);
  for (int v = 0; v < H; ++v) {
    const auto* a = m1.ptr<cv::Vec4b>(v);
    const auto* b = m2.ptr<cv::Vec4b>(v);
    auto* m = out.mask.ptr<std::uint8_t>(v);
    for (int u = 0; u < W; ++u) {
      const int alpha = b[u][3];
      if (alpha >= 90 && alpha <= 170 && b[u][0] < 128) ++tr.mirror_face_px;
      if (a[u][0] < 128) {
        m[u] = kMaskOutside;
        continue;
      }
      ++tr.tooth_px;
      if (b[u][0] >= 128) {
        m[u] = kMaskToothVisible;
      } else {
        m[u] = alpha >= 64 ? kMaskForeground : kMaskMannequin;
        ++tr.tooth_hidden_px;
      }
    }
  }
  tr.mirror_in_view = tr.mirror_face_px >= 30;

  const std::vector<int> n_all = im.count_tags(m1), n_vis = im.count_tags(m2);
  for (std::size_t i = 0; i < im.tags.size(); ++i) {
    if (n_vis[i] == 0) continue;
    const auto& g = im.tags[i];
    const Iso T_cam_tag = (g.on_mirror ? tr.T_cam_mtag : tr.T_cam_man) * g.placement->T_parent_tag;
    TagTruth tt;
    tt.id = g.placement->id;
    tt.on_mirror = g.on_mirror;
    bool ok = true;
    for (int k = 0; k < 4; ++k) {
      const double h = 0.5 * g.placement->size_m;
      static constexpr double kS[4][2] = {{-1, 1}, {1, 1}, {1, -1}, {-1, -1}};
      const auto px = im.camera->project(T_cam_tag * V3d(kS[k][0] * h, kS[k][1] * h, 0));
      if (!px) {
        ok = false;
        break;
      }
      tt.corners_px[static_cast<std::size_t>(k)] = *px;
    }
    if (!ok) continue;
    tt.in_image = true;
    double area2 = 0;
    for (int k = 0; k < 4; ++k) {
      const auto& p = tt.corners_px[static_cast<std::size_t>(k)];
      const auto& q = tt.corners_px[static_cast<std::size_t>((k + 1) % 4)];
      area2 += p.x() * q.y() - q.x() * p.y();
      if (p.x() < 0 || p.y() < 0 || p.x() > W - 1 || p.y() > H - 1) tt.in_image = false;
    }
    tt.side_px = std::sqrt(0.5 * std::abs(area2));
    const V3d normal_out = -T_cam_tag.linear().col(2);
    const V3d to_cam = -T_cam_tag.translation().normalized();
    tt.view_angle_rad = std::acos(std::clamp(normal_out.dot(to_cam), -1.0, 1.0));
    tt.visible_fraction =
        n_all[i] > 0 ? std::min(1.0, static_cast<double>(n_vis[i]) / n_all[i]) : 0.0;
    tr.tags.push_back(tt);
  }
  ++im.frame;
  return {};
}

// ---- output files ------------------------------------------------------------------

namespace {

nlohmann::ordered_json mat_json(const Eigen::Isometry3d& T) {
  nlohmann::ordered_json a = nlohmann::ordered_json::array();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) a.push_back(T.matrix()(r, c));
  return a;
}

std::string frame_name(const char* prefix, int i, const char* ext) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%s_%06d.%s", prefix, i, ext);
  return buf;
}

}  // namespace

std::string frame_truth_json(const FrameTruth& t) {
  nlohmann::ordered_json j;  // keys in a reader-friendly order
  j["frame"] = t.frame;
  j["time_s"] = t.time_s;
  j["T_cam_man"] = mat_json(t.T_cam_man);
  j["T_cam_tooth"] = mat_json(t.T_cam_tooth);
  j["T_cam_mtag"] = mat_json(t.T_cam_mtag);
  j["T_cam_mir"] = mat_json(t.T_cam_mir);
  j["T_cam_tip"] = mat_json(t.T_cam_tip);
  j["T_dev_sty"] = mat_json(t.T_dev_sty);
  j["haptic_step"] = t.haptic_step;
  j["haptic_time_s"] = t.haptic_time_s;
  j["pedal"] = t.pedal;
  j["mirror_in_view"] = t.mirror_in_view;
  j["mirror_face_px"] = t.mirror_face_px;
  j["tooth_px"] = t.tooth_px;
  j["tooth_hidden_px"] = t.tooth_hidden_px;
  j["exposure_gain"] = t.exposure_gain;
  if (t.defocus_px > 0 || t.ae_steps > 0) {  // the camera model's (issue 24); absent otherwise
    j["defocus_px"] = t.defocus_px;
    j["ae_steps"] = t.ae_steps;
  }
  j["camera_speed_deg_s"] = t.camera_speed_deg_s;
  j["hand_crossing"] = t.hand_crossing;
  j["glare"] = t.glare;
  nlohmann::ordered_json tags = nlohmann::ordered_json::array();
  for (const auto& g : t.tags) {
    nlohmann::ordered_json c = nlohmann::ordered_json::array();
    for (const auto& p : g.corners_px) c.push_back({p.x(), p.y()});
    tags.push_back(nlohmann::ordered_json{{"id", g.id},
                                          {"on", g.on_mirror ? "mirror" : "mannequin"},
                                          {"corners_px", c},
                                          {"visible_fraction", g.visible_fraction},
                                          {"side_px", g.side_px},
                                          {"view_angle_deg", g.view_angle_rad * 180.0 / M_PI},
                                          {"in_image", g.in_image}});
  }
  j["tags"] = tags;
  return j.dump();
}

Result<SynthSummary> run_synth(const StationScene& station, const SynthOptions& o,
                               const std::string& out_dir, bool png,
                               const std::function<void(int)>& progress) {
  namespace fs = std::filesystem;
  const auto t0 = std::chrono::steady_clock::now();
  std::error_code ec;
  fs::create_directories(fs::path(out_dir) / "masks", ec);
  if (!ec && png) fs::create_directories(fs::path(out_dir) / "frames", ec);
  if (ec) return Error{"cannot create output folder '" + out_dir + "': " + ec.message()};
  const fs::path dir(out_dir);
  // Stereo (issue 28): both eyes, the side-by-side video, truth and masks per eye.
  const bool stereo = o.stereo;
  StationScene st = station;
  if (stereo && !st.stereo.present) st.stereo = make_stereo_rig(st.calibration.camera, o.stereo_baseline_m);
  if (stereo) {
    fs::create_directories(dir / "masks_right", ec);
    if (ec) return Error{"cannot create output folder '" + (dir / "masks_right").string() + "': " + ec.message()};
  }
  std::unique_ptr<SynthGenerator> mono;
  std::unique_ptr<StereoSynthGenerator> pair;
  if (stereo) {
    auto g = StereoSynthGenerator::create(st, o, (dir / "session.dlog").string());
    if (!g) return Error{g.error()};
    pair = std::move(g).value();
  } else {
    auto g = SynthGenerator::create(st, o, (dir / "session.dlog").string());
    if (!g) return Error{g.error()};
    mono = std::move(g).value();
  }
  const StationScene& rendered = stereo ? pair->station() : mono->station();
  if (Status s = write_station_scene(rendered, (dir / "station.json").string()); !s)
    return Error{s.error()};

  SynthSummary sum;
  cv::VideoWriter video;
  const int eye_w = rendered.calibration.camera.width, eye_h = rendered.calibration.camera.height;
  if (png) {
    sum.video_path = (dir / "frames").string();
  } else {
    sum.video_path = (dir / "video.mkv").string();
    video.open(sum.video_path, cv::CAP_FFMPEG, cv::VideoWriter::fourcc('F', 'F', 'V', '1'), o.fps,
               cv::Size(stereo ? 2 * eye_w : eye_w, eye_h));
    if (!video.isOpened())
      return Error{sum.video_path + ": OpenCV cannot open an FFV1 video writer here (use --png)"};
  }
  std::ofstream truth(dir / "truth.jsonl", std::ios::binary | std::ios::trunc);
  if (!truth) return Error{(dir / "truth.jsonl").string() + ": cannot open for writing"};
  std::ofstream truth_r;
  if (stereo) {
    truth_r.open(dir / "truth_right.jsonl", std::ios::binary | std::ios::trunc);
    if (!truth_r) return Error{(dir / "truth_right.jsonl").string() + ": cannot open for writing"};
  }
  StereoSynthFrame sf;
  SynthFrame& f = sf.left;
  long visible = 0;
  const std::vector<int> png_params = {cv::IMWRITE_PNG_COMPRESSION, 1};
  for (int i = 0; i < o.frames; ++i) {
    if (Status s = stereo ? pair->next(sf) : mono->next(f); !s) return Error{s.error()};
    cv::Mat image = f.image;
    if (stereo) {
      auto sbs = side_by_side(sf.left.image, sf.right.image);
      if (!sbs) return Error{sbs.error()};
      image = std::move(sbs).value();
    }
    if (png) {
      const std::string p = (dir / "frames" / frame_name("frame", i, "png")).string();
      if (!cv::imwrite(p, image, png_params)) return Error{p + ": cannot write"};
    } else {
      video.write(image);
    }
    const std::string mp = (dir / "masks" / frame_name("mask", i, "png")).string();
    if (!cv::imwrite(mp, f.mask, png_params)) return Error{mp + ": cannot write"};
    truth << frame_truth_json(f.truth) << "\n";
    if (stereo) {
      const std::string mr = (dir / "masks_right" / frame_name("mask", i, "png")).string();
      if (!cv::imwrite(mr, sf.right.mask, png_params)) return Error{mr + ": cannot write"};
      truth_r << frame_truth_json(sf.right.truth) << "\n";
    }
    sum.frames_with_mirror += f.truth.mirror_in_view ? 1 : 0;
    for (const auto& t : f.truth.tags)
      visible += (!t.on_mirror && t.visible_fraction > 0.5) ? 1 : 0;
    if (progress) progress(i + 1);
  }
  video.release();
  truth.close();
  if (!truth) return Error{(dir / "truth.jsonl").string() + ": write failed"};
  if (stereo) {
    truth_r.close();
    if (!truth_r) return Error{(dir / "truth_right.jsonl").string() + ": write failed"};
  }
  if (Status s = stereo ? pair->finish() : mono->finish(); !s) return Error{s.error()};
  sum.frames = o.frames;
  sum.mean_visible_tags = static_cast<double>(visible) / o.frames;
  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  nlohmann::json meta;
  meta["format"] = "dentar-synth";
  meta["version"] = 1;
  meta["generator"] = kSynthGeneratorVersion;
  meta["preset"] = synth_preset_name(o.preset);
  meta["frames"] = o.frames;
  meta["fps"] = o.fps;
  meta["width"] = o.width;
  meta["height"] = o.height;
  meta["seed"] = o.seed;
  meta["distortion"] = o.distortion;
  meta["motion_blur"] = o.motion_blur;
  meta["shutter_fraction"] = o.shutter_fraction;
  meta["blur_step_px"] = o.blur_step_px;
  meta["blur_subframes"] = o.blur_subframes;
  meta["blur_subframes_max"] = o.blur_subframes_max;
  meta["read_noise_dn"] = o.read_noise_dn;
  meta["shot_noise_gain"] = o.shot_noise_gain;
  meta["exposure_variation"] = o.exposure_variation;
  meta["exposure_jumps"] = o.exposure_jumps;
  meta["tag_occluders"] = o.tag_occluders;
  meta["mirror_in_mouth_fraction"] = o.mirror_in_mouth_fraction;
  meta["exposure"] = o.exposure;
  meta["aim_offset_deg"] = o.aim_offset_rad * 180.0 / M_PI;
  meta["head_turn_deg"] = o.head_turn_rad * 180.0 / M_PI;
  meta["head_turn_s"] = o.head_turn_s;
  meta["head_turn_period_s"] = o.head_turn_period_s;
  meta["hand_crossing"] = o.hand_crossing;
  meta["hand_crossing_period_s"] = o.hand_crossing_period_s;
  meta["mirror_glare"] = o.mirror_glare;
  if (o.camera.enabled) {
    const CameraSensorModel& c = o.camera;
    meta["camera_model"] = {{"full_well_e", c.full_well_e},         {"read_noise_e", c.read_noise_e},
                            {"aperture_mm", c.aperture_m * 1e3},     {"focus_distance_m", c.focus_distance_m},
                            {"cos_power", c.cos_power},              {"jpeg_quality", c.jpeg_quality},
                            {"ae_step_ev", c.ae_step_ev},            {"ae_deadband_ev", c.ae_deadband_ev},
                            {"ae_delay_frames", c.ae_delay_frames},  {"rolling_readout_ms", c.rolling_readout_s * 1e3},
                            {"rolling_bands", c.rolling_bands},      {"blur_subframes", o.blur_subframes}};
  }
  meta["video"] = png ? "frames/frame_NNNNNN.png" : "video.mkv";
  if (stereo) {
    const Eigen::Isometry3d& T = rendered.stereo.T_caml_camr;
    const Eigen::AngleAxisd aa(T.linear());
    const Eigen::Vector3d rv = aa.axis() * (aa.angle() * 180.0 / M_PI), tv = T.translation() * 1e3;
    meta["stereo"] = {{"layout", "side_by_side"},
                      {"baseline_mm", rendered.stereo.baseline_m() * 1e3},
                      {"T_left_right", {{"translation_mm", {tv.x(), tv.y(), tv.z()}}, {"rvec_deg", {rv.x(), rv.y(), rv.z()}}}},
                      {"truth_right", "truth_right.jsonl"},
                      {"masks_right", "masks_right/mask_NNNNNN.png"}};
  }
  meta["summary"] = {{"frames_with_mirror_in_view", sum.frames_with_mirror},
                     {"mean_visible_mannequin_tags", sum.mean_visible_tags},
                     {"wall_seconds", sum.seconds}};
  std::ofstream mf(dir / "synth.json", std::ios::binary | std::ios::trunc);
  mf << meta.dump(2) << "\n";
  if (!mf) return Error{(dir / "synth.json").string() + ": cannot write"};
  return sum;
}

}  // namespace dentar::ar
