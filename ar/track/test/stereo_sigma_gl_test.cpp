// Issue 28 (session 16): on `hard` (fast head turns with motion blur), is
// the mannequin's stated error (the covariance behind the 0.6 mm drawing
// gate) the error it actually makes? Stereo and mono (the left eye) on the
// same generated frames, against the generator's truth.
//
// What the figures showed (docs/BENCHMARKS.md, "Issue 28 session 16 - hard
// frames in fast turns"): the stated error covers the actual one as a 95 %
// bound should, also in the fast turns and in the frames the gate refuses;
// those frames' corners are 0.4-0.7 px off the truth (0.1-0.25 px around
// them), mostly in each tag's shape, and that shape error does move the
// pose. A single frame's error below its stated RMS is one draw, not an
// over-statement.
//
// Default suite: StereoSigma.HeldOutClip (12 frames of a seed no figure was
// tuned on) and StereoSigma.BlurFitBeatsPerCornerFitOnTheSameFrames (session
// 17: the blur model in the bundle fit against each corner alone, 8 frames). `long` (whole binary, StereoSigma.InOneProcess): three held-out
// seeds of 60 frames. DENTAR_SIGMA_SEEDS=a,b,c and DENTAR_SIGMA_FRAMES=N
// choose the long run's footage, DENTAR_SIGMA_SHAPE_WEIGHT=w sets
// BundlePoseOptions::shape_weight for both paths (the measurement of that
// option; the bounds are the default's), DENTAR_SIGMA_BLUR=s sets
// BundlePoseOptions::blur_stretch_sigma_px the same way; DENTAR_SIGMA_PARTS=seed prints each frame's
// corner errors split into the tags' centres and shapes (not asserted). Session 19:
// DENTAR_SIGMA_STEREO_ONLY=1 (no mono rows), DENTAR_SIGMA_REFUSED=1 (each refused frame's fit).
// Session 21: DENTAR_SIGMA_EDGE=1 (TrackerOptions::edge_fit). Session 22: DENTAR_SIGMA_PATTERN=1
// (TrackerOptions::pattern_fit, over the footage's exposure time).
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "dentar/ar/bundle_pose.h"
#include "dentar/ar/pose_uncertainty.h"
#include "dentar/ar/stereo_tracker.h"
#include "dentar/ar/synth.h"
#include "dentar/ar/tracker.h"
#include "accuracy_test_util.h"
#include "gl_test_context.h"

namespace dentar::ar {
namespace {

using Iso = Eigen::Isometry3d;
using namespace test;

constexpr double kChi2_3_95 = 7.815;  // 95 % quantile of chi-square with 3 dof

// `hard` stereo footage, 2 x 640x480, baseline 63 mm.
struct Footage {
  StationScene station;
  std::vector<StereoSynthFrame> frames;
  std::string error;
  double exposure_s = 0;  // the generator's exposure time, 0 = no motion blur
};
Footage make_hard(int seed, int frames) {
  Footage f;
  SynthOptions o = synth_preset(SynthPreset::kHard);
  o.frames = frames;
  // DENTAR_SIGMA_SYNTH=key=value,...: the footage with one effect changed, for the corner
  // error's causes (issue 28 session 18): subframes=N (blur_subframes), blur=0 (no motion
  // blur), step=PX (blur_step_px; 0 = the fixed count, session 20), maxsub=N, noise=0 (no read or shot noise), jumps=0 (no exposure jumps), occluders=N.
  if (const char* v = std::getenv("DENTAR_SIGMA_SYNTH")) {
    std::stringstream ss(v);
    std::string kv;
    while (std::getline(ss, kv, ',')) {
      const auto eq = kv.find('=');
      if (eq == std::string::npos) continue;
      const std::string k = kv.substr(0, eq);
      const int x = std::atoi(kv.c_str() + eq + 1);
      if (k == "subframes") o.blur_subframes = x;
      if (k == "step") o.blur_step_px = std::atof(kv.c_str() + eq + 1);  // 0: fixed sub-frames
      if (k == "maxsub") o.blur_subframes_max = x;
      if (k == "blur") o.motion_blur = x != 0;
      if (k == "noise" && x == 0) o.read_noise_dn = o.shot_noise_gain = 0;
      if (k == "jumps") o.exposure_jumps = x != 0;
      if (k == "occluders") o.tag_occluders = x;
      if (k == "shutter") o.shutter_fraction = x / 100.0;
    }
  }
  o.seed = static_cast<std::uint64_t>(seed);
  o.bur_samples = 1000;
  f.exposure_s = o.motion_blur ? o.shutter_fraction / o.fps : 0.0;
  StationScene st = default_station_scene();
  st.stereo = make_stereo_rig(st.calibration.camera, 0.063);
  auto g = StereoSynthGenerator::create(st, o);
  if (!g) {
    f.error = g.error();
    return f;
  }
  f.station = (*g)->station();
  for (int i = 0; i < frames; ++i) {
    StereoSynthFrame s;
    if (Status e = (*g)->next(s); !e) {
      f.error = e.error();
      return f;
    }
    for (SynthFrame* e : {&s.left, &s.right}) {
      e->mask.release();
      e->image = e->image.clone();
    }
    f.frames.push_back(std::move(s));
  }
  return f;
}

// The p-quantile of |e| for e ~ N(0, S) (S 3x3): Monte Carlo, fixed seed,
// 4000 draws (~1 % on the quantile).
double norm_quantile(const Eigen::Matrix3d& S, double p) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(S);
  const Eigen::Vector3d sd = es.eigenvalues().cwiseMax(0).cwiseSqrt();
  std::mt19937 rng(7);
  std::normal_distribution<double> n01;
  std::vector<double> v(4000);
  for (double& x : v) x = Eigen::Vector3d(sd.x() * n01(rng), sd.y() * n01(rng), sd.z() * n01(rng)).norm();
  return pct(v, p);
}

// A measured mannequin pose's stated error against its actual error at the
// mannequin's origin (the gate's point): the covariance's shape scaled to
// the gate's floored sigma (BodyTrack::sigma_m = sqrt(trace)); its 95 %
// radius and the error's squared Mahalanobis distance.
struct Check {
  double speed_deg_s = 0, err_mm = 0, sigma_mm = 0, p95_mm = 0, maha2 = 0;
};
Check check(const BodyTrack& m, const Iso& T_true, double speed_deg_s) {
  Check c;
  c.speed_deg_s = speed_deg_s;
  c.err_mm = trans_mm(m.T_cam_body_measured, T_true);
  c.sigma_mm = m.sigma_m * 1e3;
  Eigen::Matrix3d S = point_covariance(m.covariance, m.T_cam_body_measured, Eigen::Vector3d::Zero());
  if (S.trace() > 0) S *= m.sigma_m * m.sigma_m / S.trace();
  c.p95_mm = norm_quantile(S, 0.95) * 1e3;
  const Eigen::Vector3d e = m.T_cam_body_measured.translation() - T_true.translation();
  c.maha2 = e.dot(S.ldlt().solve(e));
  return c;
}

struct Coverage {
  int n = 0, in_p95 = 0, in_ellipsoid = 0;
  double maha2_sum = 0;
  void add(const Check& c) {
    ++n;
    in_p95 += c.err_mm <= c.p95_mm;
    in_ellipsoid += c.maha2 <= kChi2_3_95;
    maha2_sum += c.maha2;
  }
  double frac() const { return n ? static_cast<double>(in_p95) / n : NAN; }
  double mean_maha2() const { return n ? maha2_sum / n : NAN; }
};

// One path (stereo, or mono on the left eye) over a clip.
struct PathRun {
  int frames = 0, drawn = 0;
  std::vector<double> err_mm;  // drawn frames, the drawn pose against truth
  std::vector<double> ms;      // tracking per frame (both eyes for stereo)
  std::vector<Check> checks;   // every measured frame of the ungated tracker
  Coverage all, fast, refused;  // fast: >= 100 deg/s; refused: stated sigma above the default gate
  // The gated tracker's mannequin detections in both eyes against the generator's truth (issue 28
  // session 20): tags detected, tags the truth shows (in the image, > 90 % visible), detections
  // whose largest corner error is over 2 px (a wrong corner set), each detection's largest
  // corner error; edge fits (session 21): tried, accepted, refused by reason, and the accepted
  // squares' largest corner error against the truth and how many are over 2 px (false accepts).
  int det = 0, shown = 0, wrong = 0, edge_tried = 0, edge_accepted = 0, edge_wrong = 0;
  std::array<int, 4> edge_refused{};
  std::vector<double> corner_err_px, edge_err_px;
  // Pattern fits (session 22): tried, accepted, refused by reason, accepted squares' largest
  // corner error and how many over 2 px, thread CPU ms per stereo frame (both eyes).
  int pat_tried = 0, pat_accepted = 0, pat_wrong = 0;
  std::array<int, 5> pat_refused{};
  std::vector<double> pat_err_px, pat_ms;
};

// Counts one eye's mannequin detections against its truth (PathRun's fields).
void add_detections(PathRun& r, const TrackFrame& f, const FrameTruth& truth) {
  r.edge_tried += f.edge_fit_tried;
  r.edge_accepted += f.edge_fit_accepted;
  for (std::size_t k = 0; k < 4; ++k) r.edge_refused[k] += f.edge_fit_refused[k];
  r.pat_tried += f.pattern_fit_tried;
  r.pat_accepted += f.pattern_fit_accepted;
  for (std::size_t k = 0; k < 5; ++k) r.pat_refused[k] += f.pattern_fit_refused[k];
  for (const TagTruth& tt : truth.tags) r.shown += !tt.on_mirror && tt.in_image && tt.visible_fraction > 0.9;
  for (const DetectedTag& d : f.tags)
    for (const TagTruth& tt : truth.tags) {
      if (tt.on_mirror || tt.id != d.id) continue;
      double e = 0;
      for (int k = 0; k < 4; ++k) e = std::max(e, (d.corners_px[k] - tt.corners_px[k]).norm());
      ++r.det;
      r.wrong += e > 2.0;
      r.corner_err_px.push_back(e);
      if (d.edge_fit) {
        r.edge_err_px.push_back(e);
        r.edge_wrong += e > 2.0;
      }
      if (d.pattern_fit) {
        r.pat_err_px.push_back(e);
        r.pat_wrong += e > 2.0;
      }
    }
}

void add_checks(PathRun& r, const Check& c, double gate_mm) {
  r.checks.push_back(c);
  r.all.add(c);
  if (c.speed_deg_s >= 100) r.fast.add(c);
  if (c.sigma_mm > gate_mm) r.refused.add(c);
}

// The default tracker (what is drawn) and the same tracker without the
// mannequin's gate (the stated error of every measured frame).
PathRun run_path(const Footage& fo, bool stereo) {
  PathRun r;
  TrackerOptions gated;
  if (const char* w = std::getenv("DENTAR_SIGMA_SHAPE_WEIGHT")) gated.pose.shape_weight = std::atof(w);
  if (const char* w = std::getenv("DENTAR_SIGMA_BLUR")) gated.pose.blur_stretch_sigma_px = std::atof(w);
  // DENTAR_SIGMA_EDGE=1: TrackerOptions::edge_fit (issue 28 session 21), 0 = off.
  if (const char* w = std::getenv("DENTAR_SIGMA_EDGE")) gated.edge_fit = std::atoi(w) > 0;
  // DENTAR_SIGMA_PATTERN=1: TrackerOptions::pattern_fit (session 22) over the footage's exposure.
  if (const char* w = std::getenv("DENTAR_SIGMA_PATTERN")) gated.pattern_fit = std::atoi(w) > 0;
  if (gated.pattern_fit) gated.pattern_fit_exposure_s = fo.exposure_s;
  if (const char* w = std::getenv("DENTAR_SIGMA_PATTERN_REPROJ")) gated.pattern_fit_max_reproj_px = std::atof(w);
  TrackerOptions open = gated;
  open.mannequin_max_sigma_m = 0;
  const double gate_mm = gated.mannequin_max_sigma_m * 1e3;
  StationScene mono_st = fo.station;
  mono_st.stereo = StereoRig{};
  std::optional<StereoTracker> sg, so;
  std::optional<Tracker> mg, mo;
  if (stereo) {
    auto a = StereoTracker::create(fo.station, gated);
    auto b = StereoTracker::create(fo.station, open);
    EXPECT_TRUE(a.ok() && b.ok());
    if (!a || !b) return r;
    sg.emplace(std::move(a).value());
    so.emplace(std::move(b).value());
  } else {
    auto a = Tracker::create(mono_st, gated);
    auto b = Tracker::create(mono_st, open);
    EXPECT_TRUE(a.ok() && b.ok());
    if (!a || !b) return r;
    mg.emplace(std::move(a).value());
    mo.emplace(std::move(b).value());
  }
  for (const StereoSynthFrame& s : fo.frames) {
    const double t = s.left.truth.time_s;
    BodyTrack drawn, measured;
    if (stereo) {
      auto a = sg->track(s.left.image, s.right.image, t, t);
      auto b = so->track(s.left.image, s.right.image, t, t);
      EXPECT_TRUE(a.ok() && b.ok());
      if (!a || !b) return r;
      drawn = a->mannequin.track;
      measured = b->mannequin.track;
      add_detections(r, a->left, s.left.truth);
      add_detections(r, a->right, s.right.truth);
      r.ms.push_back(a->total_ms);
      r.pat_ms.push_back(a->left.pattern_fit_ms + a->right.pattern_fit_ms);
      // DENTAR_SIGMA_REFUSED=1: each frame the gate refuses (or the gated tracker does not draw),
      // what the ungated fit saw (issue 28 session 19: why frames are refused).
      if (std::getenv("DENTAR_SIGMA_REFUSED") && (measured.sigma_m * 1e3 > gate_mm || drawn.state == TrackState::kLost)) {
        int truth_l = 0, truth_r = 0;
        for (const TagTruth& tt : s.left.truth.tags) truth_l += !tt.on_mirror && tt.in_image && tt.visible_fraction > 0.9;
        for (const TagTruth& tt : s.right.truth.tags) truth_r += !tt.on_mirror && tt.in_image && tt.visible_fraction > 0.9;
        std::printf("refused? frame %d %.0f deg/s: drawn %s, ungated %s err %.3f mm sigma %.3f mm rms %.2f px tags %d "
                    "(eyes %d; left fit %d, right fit %d; truth visible L %d R %d) rejected %d\n",
                    s.left.truth.frame, s.left.truth.camera_speed_deg_s, drawn.state == TrackState::kLost ? "no" : "yes",
                    measured.measured ? "measured" : "not measured",
                    measured.measured ? trans_mm(measured.T_cam_body_measured, s.left.truth.T_cam_man) : NAN,
                    measured.sigma_m * 1e3, measured.rms_px, measured.tags_used, b->mannequin.views_used,
                    b->left.mannequin.tags_used, b->right.mannequin.tags_used, truth_l, truth_r, measured.rejected_id);
      }
    } else {
      auto a = mg->track(s.left.image, t, t);
      auto b = mo->track(s.left.image, t, t);
      EXPECT_TRUE(a.ok() && b.ok());
      if (!a || !b) return r;
      drawn = a->mannequin;
      measured = b->mannequin;
      r.ms.push_back(a->timing.total_ms);
    }
    ++r.frames;
    if (drawn.state != TrackState::kLost) {
      ++r.drawn;
      r.err_mm.push_back(trans_mm(drawn.T_cam_body, s.left.truth.T_cam_man));
    }
    if (measured.measured) add_checks(r, check(measured, s.left.truth.T_cam_man, s.left.truth.camera_speed_deg_s), gate_mm);
  }
  return r;
}

void print_header() {
  std::printf("| seed | path | overlay drawn | mannequin p50 / p95 mm (drawn) | measured frames within stated p95 "
              "| ... >= 100 deg/s | ... stated sigma > 0.6 mm (refused) | mean Mahalanobis^2 (3 = exact) | track ms p50 |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
}
void print_row(const std::string& seed, const char* path, const PathRun& r) {
  auto frac = [](const Coverage& c) {
    char b[64];
    std::snprintf(b, sizeof b, "%d / %d", c.in_p95, c.n);
    return std::string(b);
  };
  std::printf("| %s | %s | %d / %d (%.1f %%) | %.3f / %.3f | %s | %s | %s | %.2f | %.0f |\n", seed.c_str(), path, r.drawn,
              r.frames, 100.0 * r.drawn / std::max(1, r.frames), pct(r.err_mm, 0.5), pct(r.err_mm, 0.95),
              frac(r.all).c_str(), frac(r.fast).c_str(), frac(r.refused).c_str(), r.all.mean_maha2(), pct(r.ms, 0.5));
  // Why frames are refused (issue 28 session 19): the ungated tracker's measured frames whose
  // stated sigma is above the gate, their actual error against the stated one, and the
  // accepted ones' for comparison.
  std::vector<double> ref_err, ref_sig, acc_err, acc_sig;
  int ref_small = 0;
  const double gate_mm = TrackerOptions{}.mannequin_max_sigma_m * 1e3;
  for (const Check& c : r.checks) {
    if (c.sigma_mm > gate_mm) {
      ref_err.push_back(c.err_mm);
      ref_sig.push_back(c.sigma_mm);
      ref_small += c.err_mm <= 0.4;
    } else {
      acc_err.push_back(c.err_mm);
      acc_sig.push_back(c.sigma_mm);
    }
  }
  std::printf("|  | %s: mannequin detections %d of %d shown (both eyes), corner error max per tag p50 / p95 %.2f / %.2f px, "
              "over 2 px: %d; edge fits tried %d, accepted %d (corner error max per tag p50 / p95 / max %.2f / %.2f / %.2f px, "
              "over 2 px: %d), refused ambiguous %d, no edges %d, off prediction %d, inconsistent %d |\n",
              path, r.det, r.shown, pct(r.corner_err_px, 0.5), pct(r.corner_err_px, 0.95), r.wrong, r.edge_tried,
              r.edge_accepted, pct(r.edge_err_px, 0.5), pct(r.edge_err_px, 0.95), pct(r.edge_err_px, 1.0), r.edge_wrong,
              r.edge_refused[0], r.edge_refused[1], r.edge_refused[2], r.edge_refused[3]);
  if (r.pat_tried > 0)
    std::printf("|  | %s: pattern fits tried %d, accepted %d (corner error max per tag p50 / p95 / max %.2f / %.2f / %.2f px, "
                "over 2 px: %d), refused overlap %d, no fit %d, wrong cells %d, off prediction %d, inconsistent %d; "
                "pattern fit thread CPU ms per stereo frame p50 / p95 / max %.2f / %.2f / %.2f |\n",
                path, r.pat_tried, r.pat_accepted, pct(r.pat_err_px, 0.5), pct(r.pat_err_px, 0.95), pct(r.pat_err_px, 1.0),
                r.pat_wrong, r.pat_refused[0], r.pat_refused[1], r.pat_refused[2], r.pat_refused[3], r.pat_refused[4],
                pct(r.pat_ms, 0.5), pct(r.pat_ms, 0.95), pct(r.pat_ms, 1.0));
  std::printf("|  | %s: stated sigma > gate: %zu frames, actual err p50 / p95 %.3f / %.3f mm (%d <= 0.4 mm), stated sigma p50 %.3f mm; "
              "below: %zu frames, err p50 / p95 %.3f / %.3f, sigma p50 %.3f |\n",
              path, ref_err.size(), pct(ref_err, 0.5), pct(ref_err, 0.95), ref_small, pct(ref_sig, 0.5), acc_err.size(),
              pct(acc_err, 0.5), pct(acc_err, 0.95), pct(acc_sig, 0.5));
  std::fflush(stdout);
}

// Default suite: 12 frames of seed 11 (a seed no figure or option was
// chosen on; frames 6-11 turn at 107-171 deg/s), stereo only.
TEST(StereoSigma, HeldOutClip) {
  DENTAR_GL_TEST_CONTEXT();
  const Footage fo = make_hard(11, 12);
  ASSERT_TRUE(fo.error.empty()) << fo.error;
  const PathRun r = run_path(fo, true);
  print_header();
  print_row("11 (12 frames)", "stereo", r);
  // Measured 2026-11-28: 12 / 12 measured, 12 within the stated p95 (11
  // before the generator centred the first frame's exposure on its truth,
  // session 17: frame 0 was 0.40 mm off with 0.12 mm stated), 6 / 6 of the
  // fast frames, median Mahalanobis^2 3.04 (4.94 before); drawn 12 / 12,
  // p95 0.80 mm. Bounds with a margin; a stated sigma half or twice
  // its size moves the median 4x, out of (1.5, 9).
  ASSERT_GE(r.all.n, 11);
  EXPECT_GE(r.all.in_p95, r.all.n - 2);
  EXPECT_GE(r.fast.n, 4);
  EXPECT_GE(r.fast.in_p95, r.fast.n - 1);
  std::vector<double> m2;
  for (const Check& c : r.checks) m2.push_back(c.maha2);
  const double median_m2 = pct(m2, 0.5);  // chi-square 3: median 2.37
  std::printf("median Mahalanobis^2 %.2f\n", median_m2);
  EXPECT_GT(median_m2, 1.5);
  EXPECT_LT(median_m2, 9.0);
  EXPECT_GE(r.drawn, 10);
  EXPECT_LT(pct(r.err_mm, 0.95), 1.1);
}

// Blur in the fit (BundlePoseOptions::blur_stretch_sigma_px, issue 28
// session 17) against each corner fitted alone, on the same detections of a
// short `hard` clip (DENTAR_BLUR_CLIP=seed,frames; default a tuning seed's
// first frames, which turn fast): the mannequin's position error against the
// generator's truth, stereo and mono (the left eye); DENTAR_BLUR_DIAG=1 also
// prints, per fast frame and eye, how much of the tags' shape error (corner
// error less each tag's mean) a shared stretch, a +-e push along one
// direction, each tag's own image motion, or a stretch per tag explains
// (not asserted; docs/BENCHMARKS.md, issue 28 session 17). The tracker runs once
// (without the gate, so every frame is measured) to give each frame its
// detections and the previous pose; both fits see the same corners.
TEST(StereoSigma, BlurFitBeatsPerCornerFitOnTheSameFrames) {
  DENTAR_GL_TEST_CONTEXT();
  int seed = 5, frames = 8;  // seed 5's frames 0-7 turn at 144-205 deg/s
  if (const char* e = std::getenv("DENTAR_BLUR_CLIP")) std::sscanf(e, "%d,%d", &seed, &frames);
  double sigma_px = 8;
  if (const char* e = std::getenv("DENTAR_SIGMA_BLUR")) sigma_px = std::atof(e);
  const Footage fo = make_hard(seed, frames);
  ASSERT_TRUE(fo.error.empty()) << fo.error;
  TrackerOptions open;
  open.mannequin_max_sigma_m = 0;
  auto tr = StereoTracker::create(fo.station, open);
  ASSERT_TRUE(tr.ok()) << tr.error();
  const TagBundle bundle = mannequin_bundle(fo.station);
  const Iso T_camr_caml = fo.station.stereo.T_caml_camr.inverse();
  BundlePoseOptions plain = open.pose, blur = open.pose;
  blur.blur_stretch_sigma_px = sigma_px;
  std::vector<double> err[2][2], fast[2][2];  // [mono, stereo][plain, blur]
  std::optional<Iso> prev;
  for (const StereoSynthFrame& s : fo.frames) {
    const double t = s.left.truth.time_s;
    auto f = tr->track(s.left.image, s.right.image, t, t);
    ASSERT_TRUE(f.ok()) << f.error();
    const Iso& T_true = s.left.truth.T_cam_man;
    const std::vector<BundleView> views = {BundleView{&fo.station.calibration.camera, Iso::Identity(), &f->left.tags},
                                           BundleView{&fo.station.stereo.camera_right, T_camr_caml, &f->right.tags}};
    for (int k = 0; k < 2; ++k) {
      const BundlePoseOptions& o = k == 0 ? plain : blur;
      const BundlePose mo = estimate_bundle_pose_views(bundle, {views[0]}, o, prev);
      const BundlePose st = estimate_bundle_pose_views(bundle, views, o, prev);
      for (int p = 0; p < 2; ++p) {
        const BundlePose& b = p == 0 ? mo : st;
        if (!b.ok()) continue;
        err[p][k].push_back(trans_mm(b.T_cam_body, T_true));
        if (s.left.truth.camera_speed_deg_s >= 100) fast[p][k].push_back(err[p][k].back());
      }
    }
    if (std::getenv("DENTAR_BLUR_DIAG") && s.left.truth.camera_speed_deg_s >= 100) {
      // Shape error explained: per eye, corner errors (detected - truth) less each tag's mean,
      // fitted by (a) the edge model S (3 shared), (b) +-e along one direction (2 shared, angle grid).
      for (int e = 0; e < 2; ++e) {
        const FrameTruth& truth = e == 0 ? s.left.truth : s.right.truth;
        std::map<int, const TagTruth*> tt;
        for (const TagTruth& x : truth.tags)
          if (!x.on_mirror) tt[x.id] = &x;
        std::vector<Eigen::Vector2d> res, offs;
        std::vector<Eigen::Matrix<double, 2, 3>> Bs;
        std::vector<Eigen::Vector2d> Mv;  // (c) per corner: displacement for k = 1 from the tag's own image motion
        double ssT = 0;                   // (d) per-tag S left
        const std::size_t fi = static_cast<std::size_t>(truth.frame);
        auto tag_in = [&](std::size_t j, int id) -> const TagTruth* {
          if (j >= fo.frames.size()) return nullptr;
          const FrameTruth& tj = e == 0 ? fo.frames[j].left.truth : fo.frames[j].right.truth;
          for (const TagTruth& x : tj.tags)
            if (!x.on_mirror && x.id == id) return &x;
          return nullptr;
        };
        for (const DetectedTag& d : e == 0 ? f->left.tags : f->right.tags) {
          auto it = tt.find(d.id);
          if (it == tt.end()) continue;
          Eigen::Vector2d err[4], c = Eigen::Vector2d::Zero(), m = Eigen::Vector2d::Zero();
          for (std::size_t k = 0; k < 4; ++k) {
            err[k] = d.corners_px[k] - it->second->corners_px[k];
            c += err[k] / 4;
            m += it->second->corners_px[k] / 4;
          }
          if (c.norm() > 5) continue;
          // The fit's own blur model of the true quad (bundle_pose.h).
          const QuadBlurModel qb = quad_blur_model(it->second->corners_px);
          const auto& n = qb.edge_normal;
          Eigen::Matrix<double, 8, 3> Bt;
          for (std::size_t k = 0; k < 4; ++k) Bt.block<2, 3>(2 * static_cast<int>(k), 0) = qb.d_corner_d_S[k];
          // Remove each tag's mean from the model columns too (the centre is free).
          for (int col = 0; col < 3; ++col) {
            Eigen::Vector2d mc = Eigen::Vector2d::Zero();
            for (int k = 0; k < 4; ++k) mc += Bt.block<2, 1>(2 * k, col) / 4;
            for (int k = 0; k < 4; ++k) Bt.block<2, 1>(2 * k, col) -= mc;
          }
          // (c): motion over the exposure (0.7 of the frame period) from the neighbouring frames.
          const TagTruth* pa = tag_in(fi == 0 ? 0 : fi - 1, d.id);
          const TagTruth* pb = tag_in(fi + 1, d.id);
          Eigen::Vector2d mv = Eigen::Vector2d::Zero();
          if (pa && pb) {
            for (int k = 0; k < 4; ++k) mv += (pb->corners_px[k] - pa->corners_px[k]) / 4;
            mv *= 0.7 / (fi == 0 ? 1.0 : 2.0);
          }
          Eigen::Vector2d Mt[4];
          {
            Eigen::Vector2d mm = Eigen::Vector2d::Zero();
            for (int k = 0; k < 4; ++k) {
              const Eigen::Vector2d& n1 = n[(k + 3) % 4];
              const Eigen::Vector2d& n2 = n[k];
              Eigen::Matrix2d N;
              N << n1.transpose(), n2.transpose();
              Mt[k] = N.inverse() * Eigen::Vector2d(std::abs(n1.dot(mv)), std::abs(n2.dot(mv))) / 2;
              mm += Mt[k] / 4;
            }
            for (int k = 0; k < 4; ++k) Mt[k] -= mm;
          }
          // (d): this tag's own S.
          {
            Eigen::Matrix3d a = Eigen::Matrix3d::Identity() * 1e-6;
            Eigen::Vector3d b = Eigen::Vector3d::Zero();
            for (int k = 0; k < 4; ++k) {
              a += Bt.block<2, 3>(2 * k, 0).transpose() * Bt.block<2, 3>(2 * k, 0);
              b += Bt.block<2, 3>(2 * k, 0).transpose() * (err[k] - c);
            }
            const Eigen::Vector3d St = a.ldlt().solve(b);
            for (int k = 0; k < 4; ++k) ssT += (err[k] - c - Bt.block<2, 3>(2 * k, 0) * St).squaredNorm();
          }
          for (int k = 0; k < 4; ++k) {
            res.push_back(err[k] - c);
            offs.push_back(it->second->corners_px[k] - m);
            Bs.push_back(Bt.block<2, 3>(2 * k, 0));
            Mv.push_back(Mt[k]);
          }
        }
        if (res.size() < 8) continue;
        double ss0 = 0;
        Eigen::Matrix3d AtA = Eigen::Matrix3d::Zero();
        Eigen::Vector3d Atb = Eigen::Vector3d::Zero();
        for (std::size_t i = 0; i < res.size(); ++i) {
          ss0 += res[i].squaredNorm();
          AtA += Bs[i].transpose() * Bs[i];
          Atb += Bs[i].transpose() * res[i];
        }
        AtA.diagonal().array() += 1e-6;
        const Eigen::Vector3d S = AtA.ldlt().solve(Atb);
        double ssS = 0;
        for (std::size_t i = 0; i < res.size(); ++i) ssS += (res[i] - Bs[i] * S).squaredNorm();
        double best = ss0, best_a = 0, best_len = 0;
        for (int deg = 0; deg < 180; deg += 3) {
          const Eigen::Vector2d u(std::cos(deg * M_PI / 180), std::sin(deg * M_PI / 180));
          // per tag the mean of sign(u.o) u over its 4 corners is removed
          double num = 0, den = 0;
          std::vector<Eigen::Vector2d> g(res.size());
          for (std::size_t t0 = 0; t0 < res.size(); t0 += 4) {
            Eigen::Vector2d mg = Eigen::Vector2d::Zero();
            for (std::size_t k = 0; k < 4; ++k) {
              g[t0 + k] = (u.dot(offs[t0 + k]) > 0 ? 1.0 : -1.0) * u;
              mg += g[t0 + k] / 4;
            }
            for (std::size_t k = 0; k < 4; ++k) g[t0 + k] -= mg;
          }
          for (std::size_t i = 0; i < res.size(); ++i) {
            num += g[i].dot(res[i]);
            den += g[i].squaredNorm();
          }
          const double len = den > 0 ? num / den : 0;
          double ss = 0;
          for (std::size_t i = 0; i < res.size(); ++i) ss += (res[i] - len * g[i]).squaredNorm();
          if (ss < best) {
            best = ss;
            best_a = deg;
            best_len = len;
          }
        }
        double num = 0, den = 0;
        for (std::size_t i = 0; i < res.size(); ++i) {
          num += Mv[i].dot(res[i]);
          den += Mv[i].squaredNorm();
        }
        const double kk = den > 0 ? num / den : 0;
        double ssM = 0;
        for (std::size_t i = 0; i < res.size(); ++i) ssM += (res[i] - kk * Mv[i]).squaredNorm();
        const double nn = static_cast<double>(res.size());
        std::printf("[ diag2 ] frame %d eye %d: own-motion model left %.3f (k %.3f), per-tag S left %.3f\n", truth.frame, e,
                    std::sqrt(ssM / nn), kk, std::sqrt(ssT / nn));
        std::printf("[ diag ] frame %d eye %d %.0f deg/s: shape RMS %.3f px, edge-S left %.3f (S %.2f %.2f %.2f), +-e left %.3f (%.0f deg, %.2f px)\n",
                    truth.frame, e, truth.camera_speed_deg_s, std::sqrt(ss0 / nn), std::sqrt(ssS / nn), S(0), S(1), S(2),
                    std::sqrt(best / nn), best_a, best_len);
      }
    }
    if (f->mannequin.track.measured) prev = f->mannequin.track.T_cam_body_measured;
  }
  auto rms = [](const std::vector<double>& v) {
    double ss = 0;
    for (double x : v) ss += x * x;
    return v.empty() ? NAN : std::sqrt(ss / static_cast<double>(v.size()));
  };
  std::printf("[ blur fit ] hard seed %d, %d frames (%zu turning >= 100 deg/s), sigma %.1f px: mannequin position mm, "
              "per-corner -> blur model\n",
              seed, frames, fast[1][0].size(), sigma_px);
  for (int p = 0; p < 2; ++p)
    std::printf("  %-6s p50 %.3f -> %.3f, p95 %.3f -> %.3f, RMS %.3f -> %.3f, fast RMS %.3f -> %.3f (%zu / %zu fits)\n",
                p == 0 ? "mono" : "stereo", pct(err[p][0], 0.5), pct(err[p][1], 0.5), pct(err[p][0], 0.95),
                pct(err[p][1], 0.95), rms(err[p][0]), rms(err[p][1]), rms(fast[p][0]), rms(fast[p][1]), err[p][1].size(),
                err[p][0].size());
  if (std::getenv("DENTAR_BLUR_CLIP") != nullptr) return;  // a measurement, not the default clip's bounds
  for (int p = 0; p < 2; ++p) {
    ASSERT_EQ(err[p][0].size(), err[p][1].size());
    ASSERT_GE(err[p][0].size(), static_cast<std::size_t>(frames - 1));
  }
  // Measured 2026-11-28 (seed 5, frames 0-7): position RMS mono 0.482 ->
  // 0.157 mm, stereo 0.135 -> 0.098 mm; p50 stereo 0.158 -> 0.072 mm. Bounds
  // with a margin; the per-corner fit fails each.
  auto rms_of = [&](int p, int k) { return rms(err[p][k]); };
  EXPECT_LT(rms_of(0, 1), 0.6 * rms_of(0, 0));
  EXPECT_LT(rms_of(1, 1), 0.95 * rms_of(1, 0));
  EXPECT_LT(pct(err[1][1], 0.5), 0.8 * pct(err[1][0], 0.5));
}

// `long`: held-out seeds, mono against stereo on the same frames.
TEST(StereoSigma, CoverageOnHeldOutSeeds) {
  DENTAR_GL_TEST_CONTEXT();
  std::string seeds = "11,12,13";
  int frames = 60;
  if (const char* s = std::getenv("DENTAR_SIGMA_SEEDS")) seeds = s;
  if (const char* f = std::getenv("DENTAR_SIGMA_FRAMES")) frames = std::max(5, std::atoi(f));
  std::printf("\n[ stated vs actual ] hard, stereo 2 x 640x480 (baseline 63 mm) and mono (left eye), %d frames per seed\n", frames);
  print_header();
  PathRun pooled_s, pooled_m;
  std::stringstream ss(seeds);
  std::string seed;
  while (std::getline(ss, seed, ',')) {
    const Footage fo = make_hard(std::atoi(seed.c_str()), frames);
    ASSERT_TRUE(fo.error.empty()) << fo.error;
    // DENTAR_SIGMA_STEREO_ONLY=1: the stereo path alone (the motion model is the stereo tracker's).
    const PathRun m = std::getenv("DENTAR_SIGMA_STEREO_ONLY") ? PathRun{} : run_path(fo, false);
    const PathRun s = run_path(fo, true);
    print_row(seed, "mono (left eye)", m);
    print_row(seed, "stereo", s);
    for (auto [from, to] : {std::pair{&m, &pooled_m}, std::pair{&s, &pooled_s}}) {
      to->frames += from->frames;
      to->drawn += from->drawn;
      to->err_mm.insert(to->err_mm.end(), from->err_mm.begin(), from->err_mm.end());
      to->ms.insert(to->ms.end(), from->ms.begin(), from->ms.end());
      for (const Check& c : from->checks) add_checks(*to, c, 0.6);
    }
  }
  print_row("pooled", "mono (left eye)", pooled_m);
  print_row("pooled", "stereo", pooled_s);
  // A 95 % bound should hold in ~95 % of frames: within 88-99.5 % pooled
  // (3 x 60 frames), and no worse in the fast turns or in the refused frames
  // (where the stated error would be an over-statement if it were wrong).
  EXPECT_GE(pooled_s.all.frac(), 0.88);
  EXPECT_LE(pooled_s.all.frac(), 0.995);
  EXPECT_GE(pooled_s.fast.frac(), 0.85);
  if (pooled_s.refused.n >= 5) {
    EXPECT_GE(pooled_s.refused.frac(), 0.75);
  }
  if (!std::getenv("DENTAR_SIGMA_STEREO_ONLY")) {
    EXPECT_GE(pooled_m.all.frac(), 0.85);
  }
}

// Each frame's corner errors (detected - true, the mannequin's tags in both
// eyes) split into the tags' centres and shapes, and the pose error each
// part alone makes (the truth's corners plus that part, fitted as the
// tracker fits): what moves the pose in fast turns. Not asserted.
TEST(StereoSigma, CornerErrorParts) {
  const char* env = std::getenv("DENTAR_SIGMA_PARTS");
  if (env == nullptr) GTEST_SKIP() << "set DENTAR_SIGMA_PARTS=seed[,frames]";
  DENTAR_GL_TEST_CONTEXT();
  int seed = 5, frames = 60;
  std::sscanf(env, "%d,%d", &seed, &frames);
  const Footage fo = make_hard(seed, frames);
  ASSERT_TRUE(fo.error.empty()) << fo.error;
  TrackerOptions open;
  open.mannequin_max_sigma_m = 0;
  auto tr = StereoTracker::create(fo.station, open);
  ASSERT_TRUE(tr.ok()) << tr.error();
  const TagBundle bundle = mannequin_bundle(fo.station);
  const Iso T_camr_caml = fo.station.stereo.T_caml_camr.inverse();
  std::printf("| frame | deg/s | corner RMS px (per axis): all / centre / shape | pose error mm: actual / from centres "
              "/ from shapes | stated sigma mm | Mahalanobis^2 |\n|---|---|---|---|---|---|\n");
  // Pooled over the measured frames, fast (>= 100 deg/s) and slow: the shape error split
  // along / across each tag's image motion (its true corners' mean shift from the previous
  // frame of the same eye), and the tags' own size (side px).
  struct Pool {
    double ss_along = 0, ss_across = 0, ss_shape = 0, ss_centre = 0, ss_all = 0;
    int corners = 0, tags_n = 0;
    std::vector<double> err_mm, shape_mm;
  } pool[2];
  std::map<int, Eigen::Vector2d> prev_centre[2];  // tag id -> its true centre in the previous frame, per eye
  double small_ss = 0, large_ss = 0;
  int small_n = 0, large_n = 0;
  for (const StereoSynthFrame& s : fo.frames) {
    const double t = s.left.truth.time_s;
    auto f = tr->track(s.left.image, s.right.image, t, t);
    ASSERT_TRUE(f.ok()) << f.error();
    const BodyTrack& m = f->mannequin.track;
    std::map<int, Eigen::Vector2d> now_centre[2];
    for (int e = 0; e < 2; ++e)
      for (const TagTruth& x : (e == 0 ? s.left.truth : s.right.truth).tags) {
        if (x.on_mirror) continue;
        Eigen::Vector2d c = Eigen::Vector2d::Zero();
        for (const auto& q : x.corners_px) c += q / 4;
        now_centre[e][x.id] = c;
      }
    struct Restore {
      std::map<int, Eigen::Vector2d>* to;
      std::map<int, Eigen::Vector2d>* from;
      ~Restore() {
        for (int e = 0; e < 2; ++e) to[e] = from[e];
      }
    } restore{prev_centre, now_centre};
    if (!m.measured) continue;
    Pool& pl = pool[s.left.truth.camera_speed_deg_s >= 100 ? 1 : 0];
    double ss_all = 0, ss_c = 0, ss_s = 0;
    int tags = 0;
    std::vector<DetectedTag> centre_only[2], shape_only[2];
    for (int e = 0; e < 2; ++e) {
      const FrameTruth& truth = e == 0 ? s.left.truth : s.right.truth;
      std::map<int, const TagTruth*> tt;
      for (const TagTruth& x : truth.tags)
        if (!x.on_mirror) tt[x.id] = &x;
      for (const DetectedTag& d : e == 0 ? f->left.tags : f->right.tags) {
        auto it = tt.find(d.id);
        if (it == tt.end()) continue;
        Eigen::Vector2d err[4], c = Eigen::Vector2d::Zero();
        for (std::size_t k = 0; k < 4; ++k) {
          err[k] = d.corners_px[k] - it->second->corners_px[k];
          c += err[k] / 4;
        }
        if (c.norm() > 5) continue;  // a mirror tag of the same id
        {
          auto pv = prev_centre[e].find(d.id);
          Eigen::Vector2d dir(1, 0);
          const bool moving = pv != prev_centre[e].end() && (now_centre[e][d.id] - pv->second).norm() > 0.5;
          if (moving) dir = (now_centre[e][d.id] - pv->second).normalized();
          for (std::size_t k = 0; k < 4; ++k) {
            const Eigen::Vector2d sh = err[k] - c;
            if (moving) {
              pl.ss_along += std::pow(sh.dot(dir), 2);
              pl.ss_across += std::pow(sh.x() * dir.y() - sh.y() * dir.x(), 2);
            }
            pl.ss_shape += sh.squaredNorm() / 2;
            pl.ss_centre += c.squaredNorm() / 2;
            pl.ss_all += err[k].squaredNorm() / 2;
            (it->second->side_px < 20 ? small_ss : large_ss) += sh.squaredNorm() / 2;
          }
          (it->second->side_px < 20 ? small_n : large_n) += 4;
          pl.corners += moving ? 4 : 0;
          ++pl.tags_n;
        }
        DetectedTag dc = d, ds = d;
        for (std::size_t k = 0; k < 4; ++k) {
          ss_all += err[k].squaredNorm();
          ss_s += (err[k] - c).squaredNorm();
          dc.corners_px[k] = it->second->corners_px[k] + c;
          ds.corners_px[k] = it->second->corners_px[k] + (err[k] - c);
        }
        ss_c += 4 * c.squaredNorm();
        ++tags;
        centre_only[e].push_back(dc);
        shape_only[e].push_back(ds);
      }
    }
    auto fit_err = [&](const std::vector<DetectedTag>* d) {
      const BundlePose p = estimate_bundle_pose_views(
          bundle, {BundleView{&fo.station.calibration.camera, Iso::Identity(), &d[0]},
                   BundleView{&fo.station.stereo.camera_right, T_camr_caml, &d[1]}},
          open.pose, s.left.truth.T_cam_man);
      return p.ok() ? trans_mm(p.T_cam_body, s.left.truth.T_cam_man) : NAN;
    };
    const double n = std::max(1, 8 * tags);  // per corner and axis: centre x4 (a mean of 4), shape x4/3 (6 of 8 dof)
    const Check c = check(m, s.left.truth.T_cam_man, s.left.truth.camera_speed_deg_s);
    const double from_shape = fit_err(shape_only);
    pl.err_mm.push_back(c.err_mm);
    pl.shape_mm.push_back(from_shape);
    std::printf("| %d | %.0f | %.2f / %.2f / %.2f | %.3f / %.3f / %.3f | %.3f | %.2f |\n", s.left.truth.frame,
                c.speed_deg_s, std::sqrt(ss_all / n), std::sqrt(ss_c / n * 4), std::sqrt(ss_s / n * 4 / 3), c.err_mm,
                fit_err(centre_only), from_shape, c.sigma_mm, c.maha2);
  }
  std::printf("\n| frames | measured | corner RMS px per axis: all / centre / shape | shape along / across the image "
              "motion px | mannequin error p50 / p95 mm | from shapes alone p50 / p95 mm |\n|---|---|---|---|---|---|\n");
  for (int k = 0; k < 2; ++k) {
    const Pool& pl = pool[k];
    const double n = std::max(1, 4 * pl.tags_n), nm = std::max(1, pl.corners);
    std::printf("| %s | %zu | %.3f / %.3f / %.3f | %.3f / %.3f | %.3f / %.3f | %.3f / %.3f |\n",
                k ? "fast (>= 100 deg/s)" : "slow", pl.err_mm.size(), std::sqrt(pl.ss_all / n),
                std::sqrt(pl.ss_centre / n), std::sqrt(pl.ss_shape / n), std::sqrt(pl.ss_along / nm),
                std::sqrt(pl.ss_across / nm), pct(pl.err_mm, 0.5), pct(pl.err_mm, 0.95), pct(pl.shape_mm, 0.5),
                pct(pl.shape_mm, 0.95));
  }
  std::printf("shape RMS px per axis by tag side: < 20 px %.3f (%d corners), >= 20 px %.3f (%d)\n",
              std::sqrt(small_ss / std::max(1, small_n)), small_n, std::sqrt(large_ss / std::max(1, large_n)), large_n);
}

}  // namespace
}  // namespace dentar::ar
