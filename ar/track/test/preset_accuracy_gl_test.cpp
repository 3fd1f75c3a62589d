// Tracker accuracy per footage preset against the generator's truth, as
// regression bounds (issue 16), and where the error comes from on the hard
// presets: corner error against truth split by blur, tag size, view angle,
// occlusion and corner bias, and the pose from the true corners of the same
// tags (the bundle's 3D layout alone).
//
// The bounds are the figures measured at 640x480, 60 frames, seed 5, with a
// margin (docs/BENCHMARKS.md); DENTAR_PRESET_FRAMES / DENTAR_PRESET_SIZE
// (e.g. 150 / 1280x720) print the same tables for the benchmark record
// without asserting the bounds.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <opencv2/imgproc.hpp>
#include <string>
#include <tuple>
#include <vector>

#include "dentar/ar/bundle_pose.h"
#include "dentar/ar/pose_filter.h"
#include "dentar/ar/synth.h"
#include "dentar/ar/tracker.h"
#include "accuracy_test_util.h"
#include "gl_test_context.h"

namespace dentar::ar {
namespace {

using Iso = Eigen::Isometry3d;
using namespace test;  // accuracy_test_util.h: footage, run size, error figures

// The default station (roof paddle on the mirror, the 12 head tags of
// MannequinLayout::kFront12), or with the flat paddle it had before issue 16
// (MirrorPaddle::kFlat), or with another head layout (kWrap20,
// kFront12Large: measured, not the default). (Until 2026-11-27 the default
// here was kWrap20, left from its trial: the bounds below were measured
// with the 12 tags.)
const Footage& footage(SynthPreset preset, MirrorPaddle paddle = MirrorPaddle::kRoof,
                       MannequinLayout layout = MannequinLayout::kFront12) {
  static std::map<std::tuple<int, int, int>, Footage> cache;
  const std::tuple<int, int, int> key(static_cast<int>(preset), static_cast<int>(paddle),
                                      static_cast<int>(layout));
  auto it = cache.find(key);
  if (it != cache.end()) return it->second;
  const SynthOptions o = accuracy_options(preset);
  StationScene st = default_station_scene();
  set_mirror_paddle(st, paddle);
  set_mannequin_layout(st, layout);
  // Measurement only: DENTAR_BROW_MM=f,b sets kFront12Large's forehead (ids
  // 0, 1) and brow (ids 2..5) tags to f and b mm, printable or not (20,20:
  // the overlapping upper bound of docs/BENCHMARKS.md).
  if (const char* e = std::getenv("DENTAR_BROW_MM"); e && layout == MannequinLayout::kFront12Large) {
    double f = 0, b = 0;
    if (std::sscanf(e, "%lf,%lf", &f, &b) == 2 && f > 0 && b > 0)
      for (int i = 0; i < 6; ++i) st.mannequin_tags[static_cast<std::size_t>(i)].size_m = (i < 2 ? f : b) * 1e-3;
  }
  return cache[key] = make_footage(st, o);
}

struct PresetRun {
  int frames = 0, drawn = 0, mirror_seen = 0, mirror_drawn = 0;
  std::vector<double> t_mm, r_deg;        // drawn mannequin pose (filtered) vs truth
  std::vector<double> mir_mm, mir_deg;    // mirror plane (T_cam_mtag T_mtag_mir) vs truth
  // Measured (unfiltered) poses: the gate sigma (BodyTrack::sigma_m) and
  // the error of the same point, for the honesty check of the covariance.
  std::vector<double> man_sigma_mm, man_meas_mm, mir_sigma_mm, mir_meas_mm;
  std::vector<double> man_sigma_pt_mm, mir_sigma_pt_mm;  // per-tag noise (BodyTrack::sigma_per_tag_m)
  std::vector<double> man_sigma_raw_mm;  // residual noise estimate alone (no floor), at the origin
  std::vector<double> track_ms;          // Tracker::track wall time per frame
  std::vector<double> man_tags;          // mannequin tags used per measured frame
  std::vector<double> frame_mm;          // per frame: the drawn pose's error, NaN when not drawn
  int man_rejected = 0;                  // measured frames whose fit dropped a tag (BundlePoseOptions::outlier_px)
  std::vector<int> frame_rejected;       // per frame: the id it dropped, -1 none
  std::string frame_state;               // per frame: M measured, P predicted (drawn unmeasured), - lost
};

PresetRun run(const Footage& fo, const TrackerOptions& opt = {}) {
  PresetRun r;
  auto tr = Tracker::create(fo.station, opt);
  EXPECT_TRUE(tr.ok()) << (tr.ok() ? "" : tr.error());
  if (!tr) return r;
  const Iso T_mtag_mir = fo.station.calibration.T_mtag_mir;
  for (const SynthFrame& s : fo.frames) {
    auto f = tr->track(s.image, s.truth.time_s, s.truth.time_s);
    EXPECT_TRUE(f.ok()) << (f.ok() ? "" : f.error());
    if (!f) return r;
    ++r.frames;
    r.track_ms.push_back(f->timing.total_ms);
    if (f->mannequin.measured) r.man_tags.push_back(f->mannequin.tags_used);
    if (f->mannequin.measured && f->mannequin.rejected_id >= 0) ++r.man_rejected;
    r.frame_rejected.push_back(f->mannequin.measured ? f->mannequin.rejected_id : -1);
    r.frame_state.push_back(f->mannequin.measured ? 'M' : f->mannequin.state == TrackState::kPredicted ? 'P' : '-');
    r.frame_mm.push_back(f->mannequin.state != TrackState::kLost
                             ? trans_mm(f->mannequin.T_cam_body, s.truth.T_cam_man)
                             : NAN);
    if (f->mannequin.state != TrackState::kLost) {
      ++r.drawn;
      r.t_mm.push_back(trans_mm(f->mannequin.T_cam_body, s.truth.T_cam_man));
      r.r_deg.push_back(rot_deg(f->mannequin.T_cam_body, s.truth.T_cam_man));
    }
    if (f->mannequin.measured) {
      r.man_sigma_mm.push_back(f->mannequin.sigma_m * 1e3);
      r.man_sigma_pt_mm.push_back(f->mannequin.sigma_per_tag_m * 1e3);
      r.man_sigma_raw_mm.push_back(std::sqrt(f->mannequin.covariance.bottomRightCorner<3, 3>().trace()) * 1e3);
      r.man_meas_mm.push_back(trans_mm(f->mannequin.T_cam_body_measured, s.truth.T_cam_man));
    }
    if (f->mirror.measured) {
      r.mir_sigma_mm.push_back(f->mirror.sigma_m * 1e3);
      r.mir_sigma_pt_mm.push_back(f->mirror.sigma_per_tag_m * 1e3);
      r.mir_meas_mm.push_back(trans_mm(f->mirror.T_cam_body_measured * T_mtag_mir, s.truth.T_cam_mir));
    }
    r.mirror_seen += s.truth.mirror_in_view ? 1 : 0;
    if (f->mirror.state != TrackState::kLost) {
      ++r.mirror_drawn;
      const Iso T_cam_mir = f->mirror.T_cam_body * T_mtag_mir;
      r.mir_mm.push_back(trans_mm(T_cam_mir, s.truth.T_cam_mir));
      r.mir_deg.push_back(rot_deg(T_cam_mir, s.truth.T_cam_mir));
    }
  }
  return r;
}

double rms(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x * x;
  return v.empty() ? NAN : std::sqrt(s / v.size());
}

// Predicted (RMS of the gate sigma) against observed (RMS error) over the
// measured frames; fraction of frames whose error is within 2 sigma.
void print_honesty(const char* name, const PresetRun& r) {
  auto within2 = [](const std::vector<double>& sg, const std::vector<double>& e) {
    int n = 0;
    for (std::size_t i = 0; i < e.size(); ++i) n += e[i] <= 2 * sg[i] ? 1 : 0;
    return e.empty() ? NAN : double(n) / e.size();
  };
  std::printf("| %s | %zu | %.3f / %.3f / %.3f | %.3f | %.2f / %.2f | %zu | %.3f / %.3f | %.3f | %.2f / %.2f |\n", name,
              r.man_meas_mm.size(), rms(r.man_sigma_mm), rms(r.man_sigma_pt_mm), rms(r.man_sigma_raw_mm),
              rms(r.man_meas_mm),
              within2(r.man_sigma_mm, r.man_meas_mm), within2(r.man_sigma_pt_mm, r.man_meas_mm),
              r.mir_meas_mm.size(), rms(r.mir_sigma_mm), rms(r.mir_sigma_pt_mm), rms(r.mir_meas_mm),
              within2(r.mir_sigma_mm, r.mir_meas_mm), within2(r.mir_sigma_pt_mm, r.mir_meas_mm));
}

void print_row(const char* name, const PresetRun& r) {
  std::printf("| %s | %d | %.1f %% | %.3f / %.3f | %.3f / %.3f | %d / %d | %.3f / %.3f |\n", name,
              r.frames, 100.0 * r.drawn / std::max(1, r.frames), pct(r.t_mm, 0.5), pct(r.r_deg, 0.5),
              pct(r.t_mm, 0.95), pct(r.r_deg, 0.95), r.mirror_drawn, r.mirror_seen,
              pct(r.mir_mm, 0.95), pct(r.mir_deg, 0.95));
}

// Regression bounds per preset at the default size (measured x ~1.5).
struct Bound {
  SynthPreset preset;
  double min_drawn;           // fraction of frames with the overlay
  double t_p95_mm, r_p95_deg;  // mannequin
  double mir_p95_mm;           // mirror plane, when the mirror was tracked (0 = not checked)
};

TEST(PresetAccuracy, EveryPresetWithinItsBounds) {
  DENTAR_GL_TEST_CONTEXT();
  const RunSize z = run_size();
  static const Bound kBounds[] = {
      {SynthPreset::kStandard, 1.0, 0.35, 0.4, 3.0},
      // hard: 90 % drawn on generator v1 footage; 76.7 % (0.735 mm p95) on
      // v2's, whose tag edges are right in linear light (issue 16 third part:
      // v1's outline bias had cancelled part of libapriltag's own error).
      // Issue 24 (libapriltag on the image as delivered, the sRGB refit
      // after): 48.3 % drawn, 0.976 mm / 0.351 deg p95 (was 76.7 %, 0.735 /
      // 0.199 with the search on the linearised image). Session 11: with the
      // tracker's second look in linear light where tags are missed
      // (TrackerOptions::linear_second_look) 65.0 %, 0.626 mm / 0.265 deg
      // (docs/BENCHMARKS.md issue 24 session 11); drawn still below 76.7 %.
      {SynthPreset::kHard, 0.6, 0.95, 0.4, 3.0},
      {SynthPreset::kMirror, 1.0, 0.4, 0.4, 3.0},
      {SynthPreset::kHand, 1.0, 0.35, 0.4, 3.0},
      {SynthPreset::kGlare, 1.0, 0.4, 0.4, 3.0},
      // Issue 24: 0.377 mm p95 (was 0.302) after the search moved to the image
      // as delivered; 0.335 mm / 0.207 deg with the second look in linear
      // light (docs/BENCHMARKS.md issue 24 session 11).
      {SynthPreset::kLowLight, 1.0, 0.37, 0.4, 3.0},
      {SynthPreset::kFastTurns, 0.5, 3.0, 1.5, 3.0},
      // offframe (24 deg aim): measured drawn in 50 % of frames, 0.273 mm /
      // 0.111 deg p95 (2026-11-25): in the other half too few tags stay in the
      // image for the 0.6 mm gate. Below the 95 % goal; this bound
      // only guards against getting worse.
      // Generator v2 (issue 16 third part): 50 % drawn, 0.600 mm / 0.138 deg p95.
      {SynthPreset::kOffFrame, 0.45, 0.8, 0.3, 3.0},
  };
  std::printf("\n[ presets ] %dx%d, %d frames, seed 5, default tracker; drawn pose (filtered) vs truth\n",
              z.w, z.h, z.frames);
  std::printf("| preset | frames | drawn | median mm / deg | p95 mm / deg | mirror drawn / in view | mirror p95 mm / deg |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  std::vector<std::pair<const char*, PresetRun>> runs;
  const char* only = std::getenv("DENTAR_PRESETS");  // e.g. "hard,fast": a quick look
  // The default suite's subset (PresetAccuracy.InOneProcess.Quick): these presets only, with
  // their bounds asserted; the whole table runs under `ctest -L long`.
  const char* check = std::getenv("DENTAR_CHECK_PRESETS");
  for (const Bound& b : kBounds) {
    if (only && std::string(only).find(synth_preset_name(b.preset)) == std::string::npos) continue;
    if (check && std::string(check).find(synth_preset_name(b.preset)) == std::string::npos) continue;
    const Footage& fo = footage(b.preset);
    ASSERT_TRUE(fo.error.empty()) << fo.error;
    const PresetRun r = run(fo);
    print_row(synth_preset_name(b.preset), r);
    runs.emplace_back(synth_preset_name(b.preset), r);
    if (!z.is_default() || only) continue;
    const char* name = synth_preset_name(b.preset);
    ASSERT_EQ(r.frames, z.frames) << name;
    EXPECT_GE(r.drawn, b.min_drawn * r.frames) << name;
    EXPECT_LE(pct(r.t_mm, 0.95), b.t_p95_mm) << name;
    EXPECT_LE(pct(r.r_deg, 0.95), b.r_p95_deg) << name;
    if (b.mir_p95_mm > 0 && !r.mir_mm.empty()) { EXPECT_LE(pct(r.mir_mm, 0.95), b.mir_p95_mm) << name; }
  }
  std::printf("\n[ presets ] covariance honesty on measured poses (gate sigma vs error of the same point)\n");
  std::printf("| preset | mannequin frames | RMS sigma mm (shared / per-tag noise / no floor) | RMS error mm | within 2 sigma | "
              "mirror frames | RMS sigma mm (shared / per-tag) | RMS error mm | within 2 sigma |\n"
              "|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& [name, r] : runs) print_honesty(name, r);
}

// The mirror's gate: with mirror_max_sigma_m = 1 mm the reflection is
// hidden when its centre's sigma is worse, rather than drawn off. Drawn
// frames must then be more accurate than without the gate.
TEST(PresetAccuracy, MirrorGateHidesImpreciseReflections) {
  DENTAR_GL_TEST_CONTEXT();
  const Footage& fo = footage(SynthPreset::kMirror);
  ASSERT_TRUE(fo.error.empty()) << fo.error;
  TrackerOptions off;
  off.mirror_max_sigma_m = 0;
  TrackerOptions on;
  on.mirror_max_sigma_m = 1e-3;
  const PresetRun a = run(fo, off), b = run(fo, on);
  std::printf("[ presets ] mirror without gate: drawn %d, p50 %.3f p95 %.3f mm; with the 1 mm gate: drawn %d, "
              "p50 %.3f p95 %.3f mm\n",
              a.mirror_drawn, pct(a.mir_mm, 0.5), pct(a.mir_mm, 0.95), b.mirror_drawn, pct(b.mir_mm, 0.5),
              pct(b.mir_mm, 0.95));
  ASSERT_GT(a.mirror_drawn, 0);
  EXPECT_LE(b.mirror_drawn, a.mirror_drawn);
  // Every measurement the gate let through claims sigma <= 1 mm.
  for (double sg : b.mir_sigma_mm) EXPECT_LE(sg, 1.0 + 1e-9);
  if (b.mirror_drawn > 5) { EXPECT_LT(pct(b.mir_mm, 0.95), pct(a.mir_mm, 0.95)); }
}

// The mirror's paddle: the roof (two 12 mm tags 70 deg apart, the default
// station since issue 16) against the flat paddle (one 12 mm tag per side)
// on the same scenes: mirror centre error with and without the 1 mm gate.
TEST(PresetAccuracy, MirrorRoofPaddleAgainstFlat) {
  DENTAR_GL_TEST_CONTEXT();
  const RunSize z = run_size();
  std::printf("\n[ mirror ] %dx%d, %d frames, seed 5: mirror plane pose vs truth, ungated (and with the 1 mm gate)\n",
              z.w, z.h, z.frames);
  std::printf("| preset | paddle | tracked / in view | p50 mm / deg | p95 mm / deg | RMS sigma / RMS error mm | "
              "gated: drawn | gated p95 mm / deg |\n|---|---|---|---|---|---|---|---|\n");
  const char* only = std::getenv("DENTAR_PRESETS");
  for (SynthPreset p : {SynthPreset::kStandard, SynthPreset::kHard, SynthPreset::kMirror}) {
    if (only && std::string(only).find(synth_preset_name(p)) == std::string::npos) continue;
    if (!only && p == SynthPreset::kMirror) continue;  // CI: standard and hard
    double p95[2] = {0, 0}, p50[2] = {0, 0};
    int k = 0;
    for (MirrorPaddle paddle : {MirrorPaddle::kFlat, MirrorPaddle::kRoof}) {
      const Footage& fo = footage(p, paddle);
      ASSERT_TRUE(fo.error.empty()) << fo.error;
      TrackerOptions off;
      off.mirror_max_sigma_m = 0;
      const PresetRun a = run(fo, off), b = run(fo);
      std::printf("| %s | %s | %d / %d | %.3f / %.3f | %.3f / %.3f | %.3f / %.3f | %d | %.3f / %.3f |\n",
                  synth_preset_name(p), paddle == MirrorPaddle::kFlat ? "flat" : "roof", a.mirror_drawn,
                  a.mirror_seen, pct(a.mir_mm, 0.5), pct(a.mir_deg, 0.5), pct(a.mir_mm, 0.95),
                  pct(a.mir_deg, 0.95), rms(a.mir_sigma_mm), rms(a.mir_meas_mm), b.mirror_drawn,
                  pct(b.mir_mm, 0.95), pct(b.mir_deg, 0.95));
      p50[k] = pct(a.mir_mm, 0.5);
      p95[k++] = pct(a.mir_mm, 0.95);
      // The mannequin does not care which paddle the mirror has.
      EXPECT_GT(a.drawn, 0);
    }
    if (!z.is_default() || only) continue;
    // Measured (docs/BENCHMARKS.md): the roof halves the typical error on
    // `standard` (median 2.02 -> 1.48 mm) but not its p95 (3.08 -> 3.68 mm:
    // the generator's -0.09 px corner bias is systematic and a second tag at
    // 70 deg does not average it out); on `hard` it ends the flips of the
    // single tag (p95 99.8 -> 19.0 mm). The bounds guard those.
    if (p == SynthPreset::kStandard) {
      EXPECT_LT(p50[1], 0.85 * p50[0]);
      EXPECT_LT(p95[1], 1.4 * p95[0]);
    }
    // On `hard` the flat paddle's single tag flips, and each flip used to be
    // predicted onward from that one measurement (ungated p95 104 mm, roof
    // 14.8). Since a hand-held body is predicted only from its second
    // measurement (TrackerOptions::hand_held_measurements_to_predict) the
    // flat paddle measures 8.7 mm p95 and the roof still 14.8 (2026-11-26):
    // the roof's lead on hard was those predictions. Neither passes the
    // 1 mm gate. The bound guards against one-measurement predictions.
    if (p == SynthPreset::kHard) {
      EXPECT_LT(p95[0], 20.0);
      EXPECT_LT(p95[1], 20.0);
    }
  }
}

// The head's tag layout: the default station's 12 tags (kFront12) against
// 20 (kWrap20, issue 16) and against the same 12 with larger forehead and
// brow tags (kFront12Large, issue 16) on the same camera motion, with the
// tracker's default options (for 20 tags with
// TrackerOptions::pool_comparable_tags) and with a second variant of the
// bundle fit (environment below; by default the leave-one-out outlier test,
// BundlePoseOptions::outlier_px at 1 px, x4; until 2026-11-27 dropping tags
// beyond 60 deg; all measured, not adopted, docs/BENCHMARKS.md):
// drawn frames, drawn pose error (also on the frames every layout draws),
// tags used, the covariance's honesty (RMS gate sigma / RMS error of the
// measured poses at the origin) and the tracker's wall time per frame, the
// layouts run alternately (a paired ratio: the machine may be loaded). CI:
// standard and hard; DENTAR_PRESETS=... for others.
TEST(PresetAccuracy, HeadLayoutAgainstTheTwelveTags) {
  DENTAR_GL_TEST_CONTEXT();
  // The second variant: DENTAR_VIEW_WEIGHT_DEG (corner weights by view angle
  // beyond it, 0 = off), DENTAR_DROP_DEG (tags seen more obliquely leave
  // the fit, 0 = off), DENTAR_OUTLIER_PX / DENTAR_OUTLIER_RATIO (the
  // leave-one-out test, 0 = off).
  auto env_num = [](const char* name, double def) {
    const char* v = std::getenv(name);
    return v ? std::atof(v) : def;
  };
  const double kViewWeightFrom = env_num("DENTAR_VIEW_WEIGHT_DEG", 0) * M_PI / 180,
               kDropBeyond = env_num("DENTAR_DROP_DEG", 0) * M_PI / 180,
               kOutlierPx = env_num("DENTAR_OUTLIER_PX", 1.0), kOutlierRatio = env_num("DENTAR_OUTLIER_RATIO", 4.0);
  // And the tracker's prediction checks (measurement only): DENTAR_MAX_TURN_DEG
  // (max_prediction_turn_rad), DENTAR_MAX_DRIFT_MM (max_prediction_drift_m),
  // DENTAR_MAN_TO_PREDICT (mannequin_measurements_to_predict).
  const TrackerOptions defaults;
  const double kMaxTurn = env_num("DENTAR_MAX_TURN_DEG", defaults.max_prediction_turn_rad * 180 / M_PI) * M_PI / 180,
               kMaxDrift = env_num("DENTAR_MAX_DRIFT_MM", defaults.max_prediction_drift_m * 1e3) * 1e-3;
  const int kManToPredict = static_cast<int>(env_num("DENTAR_MAN_TO_PREDICT", defaults.mannequin_measurements_to_predict));
  const bool prediction_default = kMaxTurn == defaults.max_prediction_turn_rad &&
                                  kMaxDrift == defaults.max_prediction_drift_m &&
                                  kManToPredict == defaults.mannequin_measurements_to_predict;
  char variant[160];
  std::snprintf(variant, sizeof variant, "weights %.0f, drop %.0f deg, outlier %.2g px x%.2g%s",
                kViewWeightFrom * 180 / M_PI, kDropBeyond * 180 / M_PI, kOutlierPx, kOutlierRatio,
                prediction_default ? "" : ", prediction checks changed");
  constexpr int kLayouts = 3;
  const MannequinLayout layouts[kLayouts] = {MannequinLayout::kFront12, MannequinLayout::kWrap20,
                                             MannequinLayout::kFront12Large};
  const char* names[kLayouts] = {"12 tags", "20 tags", "12 large"};
  const RunSize z = run_size();
  std::printf("\n[ layout ] %dx%d, %d frames, seed 5: 12 head tags against 20 and 12 large\n", z.w, z.h, z.frames);
  std::printf("| preset | layout | bundle options | drawn | p50 mm / deg | p95 mm / deg | tags used p50 | "
              "mannequin RMS sigma / RMS error mm (ratio) | mirror RMS sigma / RMS error mm (ratio) | "
              "mirror drawn | track ms p50 | outlier drops |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  const char* only = std::getenv("DENTAR_PRESETS");
  for (SynthPreset p : all_synth_presets()) {
    if (only && std::string(only).find(synth_preset_name(p)) == std::string::npos) continue;
    if (!only && p != SynthPreset::kStandard && p != SynthPreset::kHard) continue;
    PresetRun runs[kLayouts][2];
    std::vector<double> ms[kLayouts][2];
    for (int li = 0; li < kLayouts; ++li) {
      const Footage& fo = footage(p, MirrorPaddle::kRoof, layouts[li]);
      ASSERT_TRUE(fo.error.empty()) << fo.error;
    }
    // Alternate the layouts and variants so that all see the same load.
    for (int rep = 0; rep < 2; ++rep)
      for (int vw = 0; vw < 2; ++vw)
        for (int li = 0; li < kLayouts; ++li) {
          const Footage& fo = footage(p, MirrorPaddle::kRoof, layouts[li]);
          TrackerOptions o;
          // The 20-tag head pools the mirror's noise with its comparable tags only.
          o.pool_comparable_tags = layouts[li] == MannequinLayout::kWrap20;
          if (vw == 1) {
            o.pose.view_weight_from_rad = kViewWeightFrom;
            o.pose.max_view_angle_rad = kDropBeyond;
            o.pose.outlier_px = kOutlierPx;
            o.pose.outlier_ratio = kOutlierRatio;
            o.max_prediction_turn_rad = kMaxTurn;
            o.max_prediction_drift_m = kMaxDrift;
            o.mannequin_measurements_to_predict = kManToPredict;
          }
          const PresetRun r = run(fo, o);
          if (rep == 0) runs[li][vw] = r;
          ms[li][vw].insert(ms[li][vw].end(), r.track_ms.begin(), r.track_ms.end());
        }
    for (int vw = 0; vw < 2; ++vw)
      for (int li = 0; li < kLayouts; ++li) {
        const PresetRun& r = runs[li][vw];
        std::printf("| %s | %s | %s | %d / %d | %.3f / %.3f | %.3f / %.3f | %.0f | %.3f / %.3f (%.2f) | "
                    "%.3f / %.3f (%.2f) | %d / %d | %.2f | %d |\n",
                    synth_preset_name(p), names[li], vw == 0 ? "default" : variant, r.drawn, r.frames,
                    pct(r.t_mm, 0.5), pct(r.r_deg, 0.5), pct(r.t_mm, 0.95), pct(r.r_deg, 0.95),
                    pct(r.man_tags, 0.5), rms(r.man_sigma_mm), rms(r.man_meas_mm),
                    rms(r.man_sigma_mm) / rms(r.man_meas_mm), rms(r.mir_sigma_mm), rms(r.mir_meas_mm),
                    rms(r.mir_sigma_mm) / rms(r.mir_meas_mm), r.mirror_drawn, r.mirror_seen,
                    pct(r.track_ms, 0.5), r.man_rejected);
      }
    for (int vw = 0; vw < 2; ++vw) {
      // The same frames: those every layout draws.
      std::vector<double> e[kLayouts];
      for (std::size_t i = 0; i < runs[0][vw].frame_mm.size(); ++i) {
        bool all = true;
        for (int li = 0; li < kLayouts; ++li)
          all = all && i < runs[li][vw].frame_mm.size() && !std::isnan(runs[li][vw].frame_mm[i]);
        if (all)
          for (int li = 0; li < kLayouts; ++li) e[li].push_back(runs[li][vw].frame_mm[i]);
      }
      std::printf("[ layout ] %s, %s: on the %zu frames all draw, p50 / p95 mm: 12 tags %.3f / %.3f, "
                  "20 tags %.3f / %.3f, 12 large %.3f / %.3f\n",
                  synth_preset_name(p), vw == 0 ? "default" : variant, e[0].size(), pct(e[0], 0.5), pct(e[0], 0.95),
                  pct(e[1], 0.5), pct(e[1], 0.95), pct(e[2], 0.5), pct(e[2], 0.95));
    }
    if (std::getenv("DENTAR_PRESET_FRAMELOG"))
      for (std::size_t i = 0; i < runs[0][0].frame_mm.size(); ++i)
        std::printf("  %s frame %2zu drawn error mm (default / second variant, dropped id; M measured, P predicted): "
                    "12 tags %.3f %c / %.3f %d, 20 tags %.3f %c / %.3f %d, 12 large %.3f %c / %.3f %d\n",
                    synth_preset_name(p), i, runs[0][0].frame_mm[i], runs[0][0].frame_state[i], runs[0][1].frame_mm[i],
                    runs[0][1].frame_rejected[i], runs[1][0].frame_mm[i], runs[1][0].frame_state[i],
                    runs[1][1].frame_mm[i], runs[1][1].frame_rejected[i], runs[2][0].frame_mm[i],
                    runs[2][0].frame_state[i], runs[2][1].frame_mm[i], runs[2][1].frame_rejected[i]);
    std::printf("[ layout ] %s: tracker time per frame p50, ratio to 12 tags default (%zu frames each, alternated): "
                "20 tags %.2f, 12 large %.2f; second variant (%s): 12 tags %.2f, 20 tags %.2f, 12 large %.2f\n",
                synth_preset_name(p), ms[0][0].size(), pct(ms[1][0], 0.5) / pct(ms[0][0], 0.5),
                pct(ms[2][0], 0.5) / pct(ms[0][0], 0.5), variant, pct(ms[0][1], 0.5) / pct(ms[0][0], 0.5),
                pct(ms[1][1], 0.5) / pct(ms[0][0], 0.5), pct(ms[2][1], 0.5) / pct(ms[0][0], 0.5));
    if (!z.is_default() || only) continue;
    // Measured 2026-11-27, issue 24 session 11 (tags searched on the image
    // as delivered, a second look in linear light where tags are missed,
    // edges refit in linear light; before issue 24 and after its first
    // part: docs/BENCHMARKS.md issue 16 head layout, issue 24): 20 tags give
    // a smaller median error than 12 (standard 0.177 -> 0.169 mm, hard 0.348
    // -> 0.237) and on hard draw more frames again (39 -> 50 of 60; 46 -> 52
    // before issue 24, 29 -> 23 after its first part).
    EXPECT_LT(pct(runs[1][0].t_mm, 0.5), pct(runs[0][0].t_mm, 0.5)) << synth_preset_name(p);
    EXPECT_GE(runs[1][0].drawn, runs[0][0].drawn) << synth_preset_name(p);
    if (p == SynthPreset::kHard) {
      EXPECT_GT(runs[1][0].drawn, runs[0][0].drawn + 5);
    }
    // The larger forehead/brow tags: standard p95 0.240 -> 0.211 mm (0.296 ->
    // 0.193 before issue 24); hard 39 -> 40 frames drawn at a worse p95,
    // 0.626 -> 0.895 mm (before issue 24: 46 -> 52 frames, 0.735 -> 1.009
    // mm, why they were not adopted: that holds again).
    if (p == SynthPreset::kStandard) {
      EXPECT_LE(pct(runs[2][0].t_mm, 0.95), pct(runs[0][0].t_mm, 0.95));
    } else {
      EXPECT_GE(runs[2][0].drawn, runs[0][0].drawn);
      EXPECT_GT(pct(runs[2][0].t_mm, 0.95), pct(runs[0][0].t_mm, 0.95));
    }
    // The outlier test at its measured setting (1 px, x4) leaves 640x480
    // footage as it was: no tag is that far off there (docs/BENCHMARKS.md).
    if (kOutlierPx == 1.0 && kOutlierRatio == 4.0 && kViewWeightFrom == 0 && kDropBeyond == 0 && prediction_default)
      for (int li = 0; li < kLayouts; ++li) {
        EXPECT_EQ(runs[li][1].drawn, runs[li][0].drawn) << names[li];
        EXPECT_NEAR(pct(runs[li][1].t_mm, 0.95), pct(runs[li][0].t_mm, 0.95), 0.02) << names[li];
      }
  }
}

// Why frames go undrawn on `hard`: drawn fraction and error with each of the
// tracker's refusals switched off in turn (the mannequin's sigma gate, the
// drift gate, the image-motion check, the stale limit), and per undrawn
// frame what the footage held (DENTAR_PRESET_FRAMELOG=1 prints them).
TEST(PresetAccuracy, WhyHardFramesAreNotDrawn) {
  DENTAR_GL_TEST_CONTEXT();
  // DENTAR_LAYOUT=wrap20 / front12large: another head layout (default: the station's 12 tags).
  MannequinLayout layout = MannequinLayout::kFront12;
  if (const char* l = std::getenv("DENTAR_LAYOUT")) {
    if (std::string(l) == "wrap20") layout = MannequinLayout::kWrap20;
    if (std::string(l) == "front12large") layout = MannequinLayout::kFront12Large;
  }
  const Footage& fo = footage(SynthPreset::kHard, MirrorPaddle::kRoof, layout);
  ASSERT_TRUE(fo.error.empty()) << fo.error;
  struct Variant {
    const char* name;
    TrackerOptions o;
  };
  std::vector<Variant> vs;
  vs.push_back({"default", {}});
  vs.push_back({"no sigma gate", {}});
  vs.back().o.mannequin_max_sigma_m = 0;
  vs.push_back({"no image-motion check", {}});
  vs.back().o.max_prediction_turn_rad = 0;
  vs.push_back({"no drift gate", {}});
  vs.back().o.max_prediction_drift_m = 0;
  vs.push_back({"stale limit 0.4 s", {}});
  vs.back().o.stale_limit_s = 0.4;

  std::printf("\n[ hard ] drawn and p95 with one refusal off at a time\n| variant | drawn | measured | p95 mm / deg |\n|---|---|---|---|\n");
  std::vector<PresetRun> rs;
  for (const Variant& v : vs) {
    const PresetRun r = run(fo, v.o);
    std::printf("| %s | %d / %d | %zu | %.3f / %.3f |\n", v.name, r.drawn, r.frames, r.man_meas_mm.size(),
                pct(r.t_mm, 0.95), pct(r.r_deg, 0.95));
    rs.push_back(r);
  }
  // Without the sigma gate at least as many frames are measured.
  EXPECT_GE(rs[1].man_meas_mm.size(), rs[0].man_meas_mm.size());
  // Which of the truly visible mannequin tags (>= 90 % of the plate, all
  // corners in the image) the default tracker detected, by view angle and
  // size: the gate refuses frames with too few tags.
  {
    auto tr = Tracker::create(fo.station, {});
    ASSERT_TRUE(tr.ok());
    struct Bin {
      int seen = 0, found = 0;
    };
    std::map<std::string, Bin> bins;
    for (const SynthFrame& s : fo.frames) {
      auto f = tr->track(s.image, s.truth.time_s, s.truth.time_s);
      ASSERT_TRUE(f.ok());
      for (const TagTruth& g : s.truth.tags) {
        if (g.on_mirror || !g.in_image || g.visible_fraction < 0.9) continue;
        bool found = false;
        for (const DetectedTag& d : f->tags) found = found || d.id == g.id;
        const double a = g.view_angle_rad * 180 / M_PI;
        const std::string ab = a < 40 ? "angle < 40" : a < 55 ? "angle 40-55" : a < 70 ? "angle 55-70" : "angle >= 70";
        const std::string sb = g.side_px < 15 ? "side < 15 px" : g.side_px < 20 ? "side 15-20 px" : "side >= 20 px";
        for (const std::string& key : {ab, sb, std::string("all")}) {
          bins[key].seen++;
          bins[key].found += found ? 1 : 0;
        }
      }
    }
    std::printf("\n[ hard ] visible mannequin tags detected (default tracker)\n| bin | visible | detected |\n|---|---|---|\n");
    for (const auto& [k, b] : bins)
      std::printf("| %s | %d | %.0f %% |\n", k.c_str(), b.seen, 100.0 * b.found / std::max(1, b.seen));
    EXPECT_GT(bins["all"].found, 0);
  }
  if (std::getenv("DENTAR_PRESET_FRAMELOG")) {
    auto tr = Tracker::create(fo.station, {});
    ASSERT_TRUE(tr.ok());
    TrackerOptions nogate;
    nogate.mannequin_max_sigma_m = 0;
    auto tr2 = Tracker::create(fo.station, nogate);
    ASSERT_TRUE(tr2.ok());
    for (std::size_t i = 0; i < fo.frames.size(); ++i) {
      const SynthFrame& s = fo.frames[i];
      auto f = tr->track(s.image, s.truth.time_s, s.truth.time_s);
      auto f2 = tr2->track(s.image, s.truth.time_s, s.truth.time_s);
      ASSERT_TRUE(f.ok() && f2.ok());
      int in_img = 0, vis = 0;
      double min_side = 1e9;
      for (const TagTruth& g : s.truth.tags)
        if (!g.on_mirror && g.in_image) {
          ++in_img;
          if (g.visible_fraction > 0.9) ++vis;
          min_side = std::min(min_side, g.side_px);
        }
      // The camera seen from the head: azimuth (about +y from +z toward +x)
      // and elevation of its centre in `man`, as head_point spots are given.
      const Eigen::Vector3d eye = s.truth.T_cam_man.inverse().translation();
      const double cam_az = std::atan2(eye.x(), eye.z() + 0.02) * 180 / M_PI;
      const double cam_el = std::atan2(eye.y(), std::hypot(eye.x(), eye.z() + 0.02)) * 180 / M_PI;
      std::printf("frame %2zu cam az %4.0f el %3.0f | %-9s meas %d full %d det %2d used %2d sigma %.3f | nogate: %-9s used %2d sigma %.3f "
                  "err %.3f | truth tags in image %2d visible %2d\n",
                  i, cam_az, cam_el,
                  track_state_name(f->mannequin.state), f->mannequin.measured, f->full_frame, f->tags_detected,
                  f->mannequin.tags_used, f->mannequin.sigma_m * 1e3, track_state_name(f2->mannequin.state),
                  f2->mannequin.tags_used, f2->mannequin.sigma_m * 1e3,
                  f2->mannequin.measured ? trans_mm(f2->mannequin.T_cam_body_measured, s.truth.T_cam_man) : -1.0,
                  in_img, vis);
      // Each mannequin tag facing the camera (< 70 deg, whole, in the image):
      // id, detected (+) or not (-), side px, view angle, blur smear px (its
      // corner's motion to the neighbour frames times the shutter fraction),
      // and the detected corners' RMS error against the truth.
      const SynthOptions so = synth_preset(SynthPreset::kHard);
      const double shutter = so.motion_blur ? so.shutter_fraction : 0.0;
      std::printf("         tags:");
      for (const TagTruth& g : s.truth.tags) {
        if (g.on_mirror || !g.in_image || g.visible_fraction < 0.9 || g.view_angle_rad > 70 * M_PI / 180) continue;
        double blur = 0;
        for (int nb : {-1, 1}) {
          const long j = static_cast<long>(i) + nb;
          if (j < 0 || j >= static_cast<long>(fo.frames.size())) continue;
          for (const TagTruth& h : fo.frames[static_cast<std::size_t>(j)].truth.tags)
            if (!h.on_mirror && h.id == g.id) blur = std::max(blur, (h.corners_px[0] - g.corners_px[0]).norm() * shutter);
        }
        double err = -1;
        for (const DetectedTag& d : f2->tags)
          if (d.id == g.id && d.family == fo.station.family) {
            double ss = 0;
            for (int c = 0; c < 4; ++c) ss += (d.corners_px[c] - g.corners_px[c]).squaredNorm();
            err = std::sqrt(ss / 4);
          }
        std::printf(" %d%c %.0fpx %.0fdeg blur %.1f err %.2f;", g.id, err >= 0 ? '+' : '-', g.side_px,
                    g.view_angle_rad * 180 / M_PI, blur, err);
      }
      std::printf(" nogate rms %.2f px%s\n", f2->mannequin.rms_px,
                  f2->mannequin.rejected_id >= 0 ? " (outlier dropped)" : "");
    }
  }
}

// Per-corner Huber weighting in the bundle PnP (BundlePoseOptions::
// robust_px) against plain least squares, per preset.
TEST(PresetAccuracy, RobustCornerWeighting) {
  DENTAR_GL_TEST_CONTEXT();
  std::printf("\n[ presets ] Huber corner weighting: drawn %% and p95 mm / deg, plain vs robust\n");
  std::printf("| preset | robust_px | drawn | p95 mm / deg | mirror p95 mm |\n|---|---|---|---|---|\n");
  // (hand, offframe, fast and glare were measured too: identical to the
  // last digit, docs/BENCHMARKS.md; kept out of CI for time.)
  for (SynthPreset p : {SynthPreset::kStandard, SynthPreset::kHard}) {
    const Footage& fo = footage(p);
    ASSERT_TRUE(fo.error.empty()) << fo.error;
    double p95[2] = {0, 0};
    int k = 0;
    for (double rp : {0.0, 1.0}) {
      TrackerOptions o;
      o.pose.robust_px = rp;
      const PresetRun r = run(fo, o);
      std::printf("| %s | %.1f | %.1f %% | %.3f / %.3f | %.3f |\n", synth_preset_name(p), rp,
                  100.0 * r.drawn / std::max(1, r.frames), pct(r.t_mm, 0.95), pct(r.r_deg, 0.95),
                  pct(r.mir_mm, 0.95));
      p95[k++] = pct(r.t_mm, 0.95);
    }
    // On clean footage the weights are all 1: the same poses.
    if (p == SynthPreset::kStandard) { EXPECT_NEAR(p95[1], p95[0], 0.02); }
  }
}

// ---- where the error comes from ------------------------------------------------

struct CornerSample {
  double err_px;      // |detected - true|
  double outward_px;  // along the centre-to-corner direction (+ = outline too large)
  double side_px, angle_deg, visible, blur_px;
};

// Every mannequin tag the full-resolution detector finds, against its true
// corners; blur = the true corners' motion between the previous and next
// frame's mid-exposure, times the shutter fraction (the smear length).
std::vector<CornerSample> corner_samples(const Footage& fo, double shutter) {
  std::vector<CornerSample> out;
  TagDetectorOptions d;
  d.families = {fo.station.family};
  d.decimation = 1;
  auto det = TagDetector::create(d);
  EXPECT_TRUE(det.ok());
  if (!det) return out;
  cv::Mat gray;
  for (std::size_t i = 0; i < fo.frames.size(); ++i) {
    const FrameTruth& t = fo.frames[i].truth;
    cv::cvtColor(fo.frames[i].image, gray, cv::COLOR_BGR2GRAY);
    auto tags = det->detect(gray);
    if (!tags) continue;
    for (const DetectedTag& dt : *tags) {
      const TagTruth* tt = nullptr;
      for (const TagTruth& g : t.tags)
        if (!g.on_mirror && g.id == dt.id) tt = &g;
      if (!tt || !tt->in_image) continue;
      // Smear: the same corner one frame before and after.
      double blur = 0;
      for (int nb : {-1, 1}) {
        const long j = static_cast<long>(i) + nb;
        if (j < 0 || j >= static_cast<long>(fo.frames.size())) continue;
        for (const TagTruth& g : fo.frames[static_cast<std::size_t>(j)].truth.tags)
          if (!g.on_mirror && g.id == dt.id)
            blur = std::max(blur, (g.corners_px[0] - tt->corners_px[0]).norm() * shutter);
      }
      Eigen::Vector2d c = Eigen::Vector2d::Zero();
      for (const auto& p : tt->corners_px) c += p / 4;
      for (int k = 0; k < 4; ++k) {
        const Eigen::Vector2d e = dt.corners_px[k] - tt->corners_px[k];
        const Eigen::Vector2d dir = (tt->corners_px[k] - c).normalized();
        out.push_back({e.norm(), e.dot(dir), tt->side_px, tt->view_angle_rad * 180 / M_PI,
                       tt->visible_fraction, blur});
      }
    }
  }
  return out;
}

void print_bins(const char* what, const std::vector<CornerSample>& s,
                double (*key)(const CornerSample&), std::vector<double> edges) {
  std::printf("| %s | corners | median err px | p95 err px | mean outward px |\n|---|---|---|---|---|\n", what);
  for_each_bin(s, key, std::move(edges), [](double lo, double hi, const std::vector<const CornerSample*>& in) {
    std::vector<double> e, o;
    for (const CornerSample* c : in) {
      e.push_back(c->err_px);
      o.push_back(c->outward_px);
    }
    std::printf("| [%g, %g) | %zu | %.3f | %.3f | %+.3f |\n", lo, hi, e.size(), pct(e, 0.5), pct(e, 0.95), mean(o));
  });
}

// Pose of the same detected tag set from the detected and from the true
// corners: the second is what the bundle's layout gives with perfect corners.
struct LayoutSplit {
  std::vector<double> det_mm, true_mm, tags;
};
LayoutSplit layout_split(const Footage& fo) {
  LayoutSplit r;
  TagDetectorOptions d;
  d.families = {fo.station.family};
  d.decimation = 1;
  auto det = TagDetector::create(d);
  if (!det) return r;
  const TagBundle bundle = mannequin_bundle(fo.station);
  cv::Mat gray;
  for (const SynthFrame& s : fo.frames) {
    cv::cvtColor(s.image, gray, cv::COLOR_BGR2GRAY);
    auto tags = det->detect(gray);
    if (!tags) continue;
    std::vector<DetectedTag> truth_tags;
    for (const DetectedTag& dt : *tags)
      for (const TagTruth& g : s.truth.tags)
        if (!g.on_mirror && g.id == dt.id && g.in_image) {
          DetectedTag t = dt;
          t.corners_px = g.corners_px;
          truth_tags.push_back(t);
        }
    const BundlePose a = estimate_bundle_pose(bundle, fo.station.calibration.camera, *tags, {}, s.truth.T_cam_man);
    const BundlePose b =
        estimate_bundle_pose(bundle, fo.station.calibration.camera, truth_tags, {}, s.truth.T_cam_man);
    if (!a.ok() || !b.ok()) continue;
    r.det_mm.push_back(trans_mm(a.T_cam_body, s.truth.T_cam_man));
    r.true_mm.push_back(trans_mm(b.T_cam_body, s.truth.T_cam_man));
    r.tags.push_back(a.tags_used);
  }
  return r;
}

TEST(PresetAccuracy, WhereTheHardErrorComesFrom) {
  DENTAR_GL_TEST_CONTEXT();
  for (SynthPreset p : {SynthPreset::kHard, SynthPreset::kStandard, SynthPreset::kFastTurns}) {
    const Footage& fo = footage(p);
    ASSERT_TRUE(fo.error.empty()) << fo.error;
    const SynthOptions o = synth_preset(p);
    const auto s = corner_samples(fo, o.motion_blur ? o.shutter_fraction : 0.0);
    std::printf("\n[ sources ] %s: %zu detected mannequin corners against truth (full resolution)\n",
                synth_preset_name(p), s.size());
    ASSERT_GT(s.size(), 40u);
    print_bins("blur smear px", s, [](const CornerSample& c) { return c.blur_px; }, {1, 3, 6, 12});
    print_bins("tag side px", s, [](const CornerSample& c) { return c.side_px; }, {20, 30, 50});
    print_bins("view angle deg", s, [](const CornerSample& c) { return c.angle_deg; }, {40, 55, 70});
    print_bins("visible fraction", s, [](const CornerSample& c) { return c.visible; }, {0.8, 0.95, 0.999});
    const LayoutSplit l = layout_split(fo);
    std::printf("[ sources ] %s: bundle pose of the detected tag sets: detected corners p50 %.3f p95 %.3f mm; "
                "true corners of the same tags p50 %.4f p95 %.4f mm; tags used median %.0f\n",
                synth_preset_name(p), pct(l.det_mm, 0.5), pct(l.det_mm, 0.95), pct(l.true_mm, 0.5),
                pct(l.true_mm, 0.95), pct(l.tags, 0.5));
    // The decomposition holds: with the true corners the layout is exact
    // (the solver and the truth agree to a few micrometres), so all of the
    // error above comes from the corners.
    ASSERT_FALSE(l.true_mm.empty());
    EXPECT_LT(pct(l.true_mm, 0.95), 0.01);
    // Sharp, whole, large, frontal tags: the detector's corners are good.
    std::vector<double> clean;
    for (const auto& c : s)
      if (c.blur_px < 1 && c.visible > 0.999 && c.side_px > 30 && c.angle_deg < 40) clean.push_back(c.err_px);
    if (clean.size() > 20) { EXPECT_LT(pct(clean, 0.5), 0.3) << synth_preset_name(p); }
  }
}

}  // namespace
}  // namespace dentar::ar
