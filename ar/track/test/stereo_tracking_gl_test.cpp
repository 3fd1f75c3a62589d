// Stereo tracking (issue 28) on the stereo generator's footage against its
// truth per eye, beside the mono tracker on the left eye's frames (the same
// frames): accuracy bounds with margin, stereo better than mono in depth,
// a frame one eye does not see, and bad input.
//
// The default run is a short clip (20 frames of `mirror` at 640x480, seed
// 5, ~8 s of CPU) whose bounds are the measured figures with a margin. For the benchmark
// record (docs/BENCHMARKS.md, issue 28): DENTAR_STEREO_FRAMES=N,
// DENTAR_STEREO_SIZE=WxH and DENTAR_STEREO_PRESETS=standard,mirror,hard
// print the table without asserting.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstdlib>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "dentar/ar/camera_model.h"
#include "dentar/ar/stereo_tracker.h"
#include "dentar/ar/synth.h"
#include "dentar/ar/tracker.h"
#include "accuracy_test_util.h"
#include "gl_test_context.h"

namespace dentar::ar {
namespace {

using Iso = Eigen::Isometry3d;
using namespace test;

// Issue 28 session 22: DENTAR_STEREO_EDGE_FIT=1 (TrackerOptions::edge_fit) and
// DENTAR_STEREO_PATTERN_FIT=1 (TrackerOptions::pattern_fit), 0 = off, applied to every
// tracker this file creates: the default tests' bounds checked with the fits on.
TrackerOptions with_env(TrackerOptions o) {
  if (const char* v = std::getenv("DENTAR_STEREO_EDGE_FIT")) o.edge_fit = std::atoi(v) > 0;
  if (const char* v = std::getenv("DENTAR_STEREO_PATTERN_FIT")) o.pattern_fit = std::atoi(v) > 0;
  return o;
}

struct StereoFootage {
  StationScene station;  // as rendered, with its rig
  std::vector<StereoSynthFrame> frames;
  std::string error;
  double exposure_s = 0;  // the generator's exposure time (motion blur), 0 = rendered without
};

StereoFootage make_stereo_footage(SynthPreset preset, int frames, int w, int h, double baseline_m = 0.063,
                                  std::uint64_t seed = 5) {
  StereoFootage f;
  SynthOptions o = synth_preset(preset);
  o.frames = frames;
  o.width = w;
  o.height = h;
  o.seed = seed;
  o.bur_samples = 1000;
  f.exposure_s = o.motion_blur ? o.shutter_fraction / o.fps : 0.0;
  StationScene st = default_station_scene();
  st.stereo = make_stereo_rig(st.calibration.camera, baseline_m);
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

struct Run {
  int frames = 0, drawn = 0, mirror_seen = 0, mirror_drawn = 0;
  std::vector<double> man_mm, mir_mm;  // drawn poses vs truth
  std::vector<double> man_depth_mm;    // measured mannequin origin, along the left eye's line of sight
  std::vector<double> mir_depth_mm;    // measured mirror centre, along the line of sight
  std::vector<double> mir_meas_mm;     // measured mirror centre (unfiltered) vs truth
  std::vector<double> ms;              // tracking time per frame (both eyes for stereo)
  int two_views = 0, one_view = 0;     // stereo: measured mannequin frames from both eyes / one
  std::vector<double> mir_deg;         // drawn mirror's rotation error
  std::vector<double> refl_px;         // the reflected tooth drawn (drawn mannequin, drawn mirror) vs truth, left eye px
  int mir_predicted = 0;               // mirror drawn from the prediction (not measured this frame)
  int pred_covered = 0;                // of which the actual error <= 2 x the stated sigma (when stated)
  std::vector<double> pred_mm;         // their errors
};

// The tooth's centre (T_man_tooth's origin) mirrored in the disc's plane
// (z = 0 of `mir`, normal +z), projected into the camera: where the reflection
// of the tooth is drawn.
std::optional<Eigen::Vector2d> reflected_tooth_px(const CameraModel& cam, const Iso& T_cam_man, const Iso& T_man_tooth,
                                                  const Iso& T_cam_mir) {
  const Eigen::Vector3d p = (T_cam_man * T_man_tooth).translation();
  const Eigen::Vector3d n = T_cam_mir.linear().col(2), c = T_cam_mir.translation();
  return cam.project(p - 2 * n.dot(p - c) * n);
}

struct ScoreContext {
  Iso T_mtag_mir = Iso::Identity();
  Iso T_man_tooth = Iso::Identity();
  const CameraModel* cam = nullptr;
};

double depth_err_mm(const Iso& T_est, const Iso& T_true, const Eigen::Vector3d& p) {
  const Eigen::Vector3d t = T_true * p;
  return t.normalized().dot(T_est * p - t) * 1e3;
}

// One body's drawn and measured pose against truth (left eye = rig frame).
void score(Run& r, const BodyTrack& man, const BodyTrack& mir, const FrameTruth& truth, const ScoreContext& sc) {
  const Iso& T_mtag_mir = sc.T_mtag_mir;
  ++r.frames;
  if (man.state != TrackState::kLost) {
    ++r.drawn;
    r.man_mm.push_back(trans_mm(man.T_cam_body, truth.T_cam_man));
  }
  if (man.measured)
    r.man_depth_mm.push_back(depth_err_mm(man.T_cam_body_measured, truth.T_cam_man, Eigen::Vector3d::Zero()));
  r.mirror_seen += truth.mirror_in_view ? 1 : 0;
  if (mir.state != TrackState::kLost) {
    ++r.mirror_drawn;
    const Iso T_cam_mir = mir.T_cam_body * T_mtag_mir;
    r.mir_mm.push_back(trans_mm(T_cam_mir, truth.T_cam_mir));
    r.mir_deg.push_back(rot_deg(T_cam_mir, truth.T_cam_mir));
    if (sc.cam != nullptr && man.state != TrackState::kLost) {
      const auto a = reflected_tooth_px(*sc.cam, man.T_cam_body, sc.T_man_tooth, T_cam_mir);
      const auto b = reflected_tooth_px(*sc.cam, truth.T_cam_man, sc.T_man_tooth, truth.T_cam_mir);
      if (a && b) r.refl_px.push_back((*a - *b).norm());
    }
    if (!mir.measured) {
      ++r.mir_predicted;
      r.pred_mm.push_back(r.mir_mm.back());
      if (mir.sigma_m > 0 && r.mir_mm.back() <= 2 * mir.sigma_m * 1e3) ++r.pred_covered;
    }
  }
  if (mir.measured) r.mir_meas_mm.push_back(trans_mm(mir.T_cam_body_measured * T_mtag_mir, truth.T_cam_mir));
  if (mir.measured)
    r.mir_depth_mm.push_back(depth_err_mm(mir.T_cam_body_measured * T_mtag_mir, truth.T_cam_mir, Eigen::Vector3d::Zero()));
}

double rms(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x * x;
  return v.empty() ? NAN : std::sqrt(s / v.size());
}

struct Pair {
  Run mono, stereo;
  Run mono_ungated;  // the left eye's own tracker inside the stereo one (gates off): depth of every measured frame
};

Pair run_both(const StereoFootage& fo, const TrackerOptions& opt = {}, bool with_mono = true) {
  Pair p;
  StationScene mono_st = fo.station;
  mono_st.stereo = StereoRig{};
  auto mono = Tracker::create(mono_st, with_env(opt));
  EXPECT_TRUE(mono.ok()) << (mono.ok() ? "" : mono.error());
  auto st = StereoTracker::create(fo.station, with_env(opt));
  EXPECT_TRUE(st.ok()) << (st.ok() ? "" : st.error());
  if (!mono || !st) return p;
  const CameraModel cam(fo.station.calibration.camera);
  ScoreContext sc;
  sc.T_mtag_mir = fo.station.calibration.T_mtag_mir;
  sc.T_man_tooth = fo.station.calibration.T_man_tooth;
  sc.cam = &cam;
  const bool per_frame = std::getenv("DENTAR_STEREO_PER_FRAME") != nullptr;
  std::optional<StereoTracker> tags_only;
  if (per_frame) {
    TrackerOptions to = opt;
    to.stereo_mirror_rim = false;
    auto t = StereoTracker::create(fo.station, with_env(to));
    if (t) tags_only.emplace(std::move(t).value());
  }
  for (const StereoSynthFrame& s : fo.frames) {
    const double t = s.left.truth.time_s;
    Result<TrackFrame> m = with_mono ? mono->track(s.left.image, t, t) : Result<TrackFrame>(TrackFrame{});
    EXPECT_TRUE(m.ok()) << (m.ok() ? "" : m.error());
    auto f = st->track(s.left.image, s.right.image, t, t);
    EXPECT_TRUE(f.ok()) << (f.ok() ? "" : f.error());
    if (!m || !f) return p;
    if (with_mono) {
      score(p.mono, m->mannequin, m->mirror, s.left.truth, sc);
      p.mono.ms.push_back(m->timing.total_ms);
    }
    score(p.stereo, f->mannequin.track, f->mirror.track, s.left.truth, sc);
    std::optional<StereoTrackFrame> ft;  // DENTAR_STEREO_PER_FRAME: the tags-only stereo tracker on the same frame
    if (tags_only) {
      auto g = tags_only->track(s.left.image, s.right.image, t, t);
      if (g) ft = std::move(g).value();
    }
    if (per_frame && (f->mirror.track.state != TrackState::kLost || s.left.truth.mirror_in_view)) {
      const BodyTrack& b = f->mirror.track;
      // Where the error comes from (issue 28, session 17): the measured mirror against the
      // tags-only fit of the same frame, split along / across the left eye's line of sight,
      // and what each eye saw of the mirror's tags (truth: side, view angle, visible part;
      // detected: each eye's own fit).
      const Iso T_true = s.left.truth.T_cam_mir;
      auto across = [&](const Iso& T) {
        const Eigen::Vector3d d = (T * sc.T_mtag_mir).translation() - T_true.translation();
        const Eigen::Vector3d ray = T_true.translation().normalized();
        return (d - ray.dot(d) * ray).norm() * 1e3;
      };
      auto eye_tags = [](const SynthFrame& e, double& side, double& ang, double& vis) {
        int n = 0;
        side = 1e9, ang = 0, vis = 1;
        for (const TagTruth& tt : e.truth.tags) {
          if (!tt.on_mirror || !tt.in_image) continue;
          ++n;
          side = std::min(side, tt.side_px);
          ang = std::max(ang, tt.view_angle_rad * 180 / M_PI);
          vis = std::min(vis, tt.visible_fraction);
        }
        if (n == 0) side = 0;
        return n;
      };
      double sl, al, vl, sr, ar_, vr;
      const int nl = eye_tags(s.left, sl, al, vl), nr = eye_tags(s.right, sr, ar_, vr);
      std::printf("frame %d mirror %s err %.3f mm (measured %.3f, depth %.3f, across %.3f) %.2f deg sigma %.3f mm "
                  "tags %d views %d rim %d rms %.2f px | eye fits L %d R %d | truth tags L %d side %.1f px %.0f deg vis %.2f, "
                  "R %d side %.1f px %.0f deg vis %.2f | hand %d face %d px",
                  s.left.truth.frame, b.state == TrackState::kLost ? "lost" : b.measured ? "measured" : "predicted",
                  b.state == TrackState::kLost ? NAN : p.stereo.mir_mm.back(),
                  b.measured ? trans_mm(b.T_cam_body_measured * sc.T_mtag_mir, T_true) : NAN,
                  b.measured ? depth_err_mm(b.T_cam_body_measured * sc.T_mtag_mir, T_true, Eigen::Vector3d::Zero()) : NAN,
                  b.measured ? across(b.T_cam_body_measured) : NAN,
                  b.state == TrackState::kLost ? NAN : p.stereo.mir_deg.back(), b.sigma_m * 1e3, b.tags_used,
                  f->mirror.views_used, b.rim_points, b.rms_px, f->left.mirror.tags_used, f->right.mirror.tags_used, nl,
                  sl, al, vl, nr, sr, ar_, vr, s.left.truth.hand_crossing ? 1 : 0, s.left.truth.mirror_face_px);
      if (ft && ft->mirror.track.measured) {
        const Iso& Tt = ft->mirror.track.T_cam_body_measured;
        std::printf(" | tags-only %.3f (depth %.3f, across %.3f) sigma %.3f", trans_mm(Tt * sc.T_mtag_mir, T_true),
                    depth_err_mm(Tt * sc.T_mtag_mir, T_true, Eigen::Vector3d::Zero()), across(Tt),
                    ft->mirror.track.sigma_m * 1e3);
      }
      std::printf("\n");
    }
    p.stereo.ms.push_back(f->total_ms);
    p.stereo.two_views += f->mannequin.views_used == 2;
    p.stereo.one_view += f->mannequin.views_used == 1;
    score(p.mono_ungated, f->left.mannequin, f->left.mirror, s.left.truth, sc);
  }
  return p;
}

void print_row(const char* preset, const char* what, const Run& r, const Run& depth) {
  std::printf("| %s | %s | %d | %.1f %% | %.3f / %.3f | %d / %d | %.3f / %.3f | %.3f / %.3f | %.1f |\n", preset, what,
              r.frames, 100.0 * r.drawn / std::max(1, r.frames), pct(r.man_mm, 0.5), pct(r.man_mm, 0.95),
              r.mirror_drawn, r.mirror_seen, pct(r.mir_mm, 0.5), pct(r.mir_mm, 0.95), rms(depth.man_depth_mm),
              rms(depth.mir_depth_mm), pct(r.ms, 0.5));
}

void print_header(int frames, int w, int h) {
  std::printf("\n[ stereo ] %d frames, 2 x %dx%d, baseline 63 mm, seed 5, default tracker options\n", frames, w, h);
  std::printf("| preset | tracker | frames | mannequin drawn | mannequin p50 / p95 mm | mirror drawn / in view | "
              "mirror p50 / p95 mm | depth RMS mannequin / mirror centre (measured) mm | track ms p50 |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
}

// The default run's clip, generated once for the tests below.
constexpr std::size_t kHideFrom = 10, kHideFrames = 6;  // HiddenMirror...: the mirror is measured in frames 0-9
const StereoFootage& mirror_clip() {
  static const StereoFootage f = make_stereo_footage(SynthPreset::kMirror, 20, 640, 480);
  return f;
}

TEST(StereoTracking, MirrorClipMeetsItsBoundsAndBeatsMonoInDepth) {
  DENTAR_GL_TEST_CONTEXT();
  const StereoFootage& fo = mirror_clip();
  ASSERT_TRUE(fo.error.empty()) << fo.error;
  // Truth per eye: the right eye's poses are the left's seen from T_caml_camr.
  const Iso T_camr_caml = fo.station.stereo.T_caml_camr.inverse();
  for (const StereoSynthFrame& s : fo.frames) {
    EXPECT_TRUE(s.right.truth.T_cam_man.isApprox(T_camr_caml * s.left.truth.T_cam_man, 1e-9));
    EXPECT_TRUE(s.right.truth.T_cam_mir.isApprox(T_camr_caml * s.left.truth.T_cam_mir, 1e-9));
  }
  EXPECT_NEAR(fo.station.stereo.baseline_m(), 0.063, 1e-12);
  const Pair p = run_both(fo);
  print_header(20, 640, 480);
  print_row("mirror", "mono (left eye)", p.mono, p.mono_ungated);
  print_row("mirror", "stereo", p.stereo, p.stereo);
  // Bounds: measured 2026-11-28 (mannequin 20/20 drawn, p95 0.248 mm, 20
  // frames from both eyes; mirror 11/20 drawn, p95 0.423 mm with the rim in
  // both eyes, 0.883 mm without it; mono: 0.315 mm, the mirror 0/20 through
  // its gate), with a margin.
  EXPECT_EQ(p.stereo.drawn, p.stereo.frames);
  EXPECT_GE(p.stereo.two_views, 18);
  EXPECT_GE(p.stereo.mirror_drawn, 8);
  EXPECT_LT(pct(p.stereo.man_mm, 0.95), 0.35);
  EXPECT_LT(pct(p.stereo.mir_mm, 0.95), 0.6);
  // The reflected tooth where it is drawn, in the left eye's pixels.
  std::printf("reflected tooth px p50 / p95: %.2f / %.2f\n", pct(p.stereo.refl_px, 0.5), pct(p.stereo.refl_px, 0.95));
  EXPECT_LT(pct(p.stereo.refl_px, 0.95), 1.5);
  // The rims in both eyes (TrackerOptions::stereo_mirror_rim) against the
  // tags alone on the same frames: the mirror's p95 falls by more than a
  // third.
  TrackerOptions tags_only;
  tags_only.stereo_mirror_rim = false;
  const Pair q = run_both(fo, tags_only);
  std::printf("mirror p95 stereo, tags only: %.3f mm over %d drawn\n", pct(q.stereo.mir_mm, 0.95), q.stereo.mirror_drawn);
  EXPECT_LT(pct(p.stereo.mir_mm, 0.95), 0.67 * pct(q.stereo.mir_mm, 0.95));
  // Depth along the line of sight: stereo's measured poses against the
  // left eye's own (ungated) fits of the same frames (measured 0.097 vs
  // 0.182 mm at the mannequin's origin, 0.374 vs 0.804 mm at the mirror's
  // centre).
  EXPECT_LT(rms(p.stereo.man_depth_mm), 0.75 * rms(p.mono_ungated.man_depth_mm));
  EXPECT_LT(rms(p.stereo.mir_depth_mm), 0.75 * rms(p.mono_ungated.mir_depth_mm));
  // The reflection is drawn in more frames than mono's gate lets through.
  EXPECT_GT(p.stereo.mirror_drawn, p.mono.mirror_drawn);
}

// Issue 28's mirror goal on `standard` (p95 <= 0.5 mm, stereo): a short seeded clip of the
// preset (20 frames at 640x480, development seed 3), the stereo tracker with its defaults,
// and the same frames with the rims off (session 15's tags-only stereo fit).
TEST(StereoTracking, StandardClipMirrorWithinTheGoal) {
  DENTAR_GL_TEST_CONTEXT();
  const StereoFootage fo = make_stereo_footage(SynthPreset::kStandard, 20, 640, 480, 0.063, 3);
  ASSERT_TRUE(fo.error.empty()) << fo.error;
  auto run = [&](const TrackerOptions& o) {
    dentar::ar::Run r;
    auto st = StereoTracker::create(fo.station, with_env(o));
    EXPECT_TRUE(st.ok()) << (st.ok() ? "" : st.error());
    if (!st) return r;
    ScoreContext sc;
    sc.T_mtag_mir = fo.station.calibration.T_mtag_mir;
    sc.T_man_tooth = fo.station.calibration.T_man_tooth;
    for (const StereoSynthFrame& s : fo.frames) {
      const double t = s.left.truth.time_s;
      auto f = st->track(s.left.image, s.right.image, t, t);
      EXPECT_TRUE(f.ok()) << (f.ok() ? "" : f.error());
      if (!f) return r;
      score(r, f->mannequin.track, f->mirror.track, s.left.truth, sc);
    }
    return r;
  };
  const auto d = run(TrackerOptions{});
  TrackerOptions tags;
  tags.stereo_mirror_rim = false;
  const auto t = run(tags);
  std::printf("standard seed 3, 20 frames: mirror drawn %d / %d in view, p50 / p95 %.3f / %.3f mm (tags only: %d drawn, "
              "p95 %.3f mm)\n",
              d.mirror_drawn, d.mirror_seen, pct(d.mir_mm, 0.5), pct(d.mir_mm, 0.95), t.mirror_drawn,
              pct(t.mir_mm, 0.95));
  // Bounds: measured 2026-11-28 (20 / 20 drawn, p95 0.358 mm; 0.381 mm with each eye's rim
  // counted as 12 points, session 16; tags only 0.884 mm), under the goal with a margin.
  EXPECT_GE(d.mirror_drawn, 18);
  EXPECT_LT(pct(d.mir_mm, 0.95), 0.45);
  EXPECT_LT(pct(d.mir_mm, 0.95), pct(t.mir_mm, 0.95));
}

// The mirror's tags covered in both eyes for a few frames (a finger, the
// lip): the reflection is drawn from the filter's prediction only while the
// error it states (TrackerOptions::mirror_prediction_sigma) stays within the
// gate, and that stated error covers the actual one.
cv::Mat hide_mirror_tags(const SynthFrame& e) {
  cv::Mat img = e.image.clone();
  for (const TagTruth& t : e.truth.tags) {
    if (!t.on_mirror) continue;
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    for (const auto& q : t.corners_px) c += q / 4;
    std::vector<cv::Point> poly;
    for (const auto& q : t.corners_px) {
      const Eigen::Vector2d g = c + 1.4 * (q - c);  // the white border too
      poly.emplace_back(static_cast<int>(std::lround(g.x())), static_cast<int>(std::lround(g.y())));
    }
    cv::fillConvexPoly(img, poly, cv::Scalar(120, 110, 105));
  }
  return img;
}

TEST(StereoTracking, HiddenMirrorIsDrawnOnlyWhileItsStatedErrorCoversIt) {
  DENTAR_GL_TEST_CONTEXT();
  const StereoFootage& fo = mirror_clip();
  ASSERT_TRUE(fo.error.empty()) << fo.error;
  const Iso T_mtag_mir = fo.station.calibration.T_mtag_mir;
  struct Seen {
    int predicted = 0, lost_after_prediction = 0, measured_before = 0;
  };
  auto run = [&](bool stated, Seen& seen, std::vector<double>& err_mm, std::vector<double>& sigma_mm) {
    TrackerOptions o;
    o.mirror_prediction_sigma = stated;
    // The shared drift bound off in both runs: on this clip's fast hand it
    // alone already drops the mirror in the first hidden frame, so the rule
    // under test is seen by itself.
    o.max_prediction_drift_m = 0;
    auto st = StereoTracker::create(fo.station, with_env(o));
    ASSERT_TRUE(st.ok()) << st.error();
    bool was_predicted = false;
    for (std::size_t i = 0; i < fo.frames.size(); ++i) {
      const StereoSynthFrame& s = fo.frames[i];
      const double t = s.left.truth.time_s;
      const bool hidden = i >= kHideFrom && i < kHideFrom + kHideFrames;
      auto f = hidden ? st->track(hide_mirror_tags(s.left), hide_mirror_tags(s.right), t, t)
                      : st->track(s.left.image, s.right.image, t, t);
      ASSERT_TRUE(f.ok()) << f.error();
      const BodyTrack& m = f->mirror.track;
      if (i + 1 == kHideFrom) seen.measured_before = m.measured ? 1 : 0;
      if (!hidden) continue;
      EXPECT_FALSE(m.measured) << "frame " << i << ": a mirror tag was still found";
      if (m.state == TrackState::kPredicted) {
        ++seen.predicted;
        err_mm.push_back(trans_mm(m.T_cam_body * T_mtag_mir, s.left.truth.T_cam_mir));
        sigma_mm.push_back(m.sigma_m * 1e3);
      }
      if (was_predicted && m.state == TrackState::kLost) ++seen.lost_after_prediction;
      was_predicted = m.state == TrackState::kPredicted;
    }
  };
  Seen on, off;
  std::vector<double> err_on, sig_on, err_off, sig_off;
  run(true, on, err_on, sig_on);
  run(false, off, err_off, sig_off);
  for (std::size_t k = 0; k < err_off.size(); ++k)
    std::printf("no stated error: predicted frame %zu error %.3f mm\n", k, err_off[k]);
  for (std::size_t k = 0; k < err_on.size(); ++k)
    std::printf("stated prediction: predicted frame %zu error %.3f mm, stated sigma %.3f mm\n", k, err_on[k], sig_on[k]);
  ASSERT_EQ(on.measured_before, 1) << "the clip must measure the mirror just before the tags are hidden";
  // Without the stated error the prediction coasts on to the stale limit
  // (measured: all 6 hidden frames, 0.47 mm growing to 3.78 mm off; with
  // the stated error one frame, 0.47 mm off stating 0.61 mm).
  EXPECT_GE(off.predicted, 4);
  EXPECT_GT(*std::max_element(err_off.begin(), err_off.end()), 2.0);
  // With the stated error: each predicted frame's sigma is within the gate
  // and covers the actual error at 2 sigma, and the mirror is then lost
  // (not coasting on to the stale limit).
  EXPECT_LT(on.predicted, off.predicted);
  EXPECT_EQ(on.lost_after_prediction + (on.predicted == 0 ? 1 : 0), 1);
  for (std::size_t k = 0; k < err_on.size(); ++k) {
    EXPECT_GT(sig_on[k], 0.0);
    EXPECT_LE(sig_on[k], 1.0 + 1e-9);
    EXPECT_LE(err_on[k], 2 * sig_on[k]) << "predicted frame " << k;
  }
}

// One eye blind (a flat grey frame: covered, or its camera dropped a frame):
// the body is measured from the other eye alone, in the rig's frame.
TEST(StereoTracking, OneBlindEyeFallsBackToTheSingleView) {
  DENTAR_GL_TEST_CONTEXT();
  const StereoFootage& fo = mirror_clip();
  ASSERT_TRUE(fo.error.empty()) << fo.error;
  auto st = StereoTracker::create(fo.station, with_env({}));
  ASSERT_TRUE(st.ok()) << st.error();
  const cv::Mat grey(480, 640, CV_8UC3, cv::Scalar(128, 128, 128));
  // Frames 8-9 the right eye is lost (no image: StereoSource's left-only frames), frame 11 the
  // left; from frame 12 both are back and the fit uses both eyes again.
  for (int i = 0; i < 14; ++i) {
    const StereoSynthFrame& s = fo.frames[static_cast<std::size_t>(i)];
    const double t = s.left.truth.time_s;
    const bool blind_right = i == 3 || i == 4, blind_left = i == 6;
    const bool lost_right = i == 8 || i == 9, lost_left = i == 11;
    const cv::Mat left = lost_left ? cv::Mat() : blind_left ? grey : s.left.image;
    const cv::Mat right = lost_right ? cv::Mat() : blind_right ? grey : s.right.image;
    auto f = st->track(left, right, t, t);
    ASSERT_TRUE(f.ok()) << f.error();
    SCOPED_TRACE("frame " + std::to_string(i));
    ASSERT_TRUE(f->mannequin.track.measured);
    const bool one = blind_left || blind_right || lost_left || lost_right;
    EXPECT_EQ(f->mannequin.views_used, one ? 1 : 2);
    EXPECT_EQ(f->mannequin.track.state, TrackState::kTracking);
    EXPECT_LT(trans_mm(f->mannequin.track.T_cam_body_measured, s.left.truth.T_cam_man), 1.0);
    if (blind_left || lost_left) {
      EXPECT_TRUE(f->left.tags.empty());
    }
    if (blind_right || lost_right) {
      EXPECT_TRUE(f->right.tags.empty());
    }
  }
}

TEST(StereoTracking, BadInputIsNamed) {
  StationScene st = default_station_scene();
  auto no_rig = StereoTracker::create(st);
  ASSERT_FALSE(no_rig.ok());
  EXPECT_NE(no_rig.error().find("no stereo rig"), std::string::npos) << no_rig.error();
  st.stereo = make_stereo_rig(st.calibration.camera, 0.063);
  auto t = StereoTracker::create(st);
  ASSERT_TRUE(t.ok()) << t.error();
  const cv::Mat a(480, 640, CV_8UC3, cv::Scalar(0)), b(240, 320, CV_8UC3, cv::Scalar(0));
  auto f = t->track(a, b, 0, 0);
  ASSERT_FALSE(f.ok());
  EXPECT_NE(f.error().find("differ in size (left 640x480, right 320x240"), std::string::npos) << f.error();
  f = t->track(cv::Mat(), cv::Mat(), 0, 0);
  ASSERT_FALSE(f.ok());
  EXPECT_NE(f.error().find("both eyes' images are empty"), std::string::npos) << f.error();
  // A side-by-side frame of odd width cannot be split into two eyes.
  cv::Mat l, r;
  const Status s = split_side_by_side(cv::Mat(480, 1279, CV_8UC3, cv::Scalar(0)), l, r, "video.mkv");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("even width"), std::string::npos) << s.error();
  EXPECT_NE(s.error().find("1279x480"), std::string::npos) << s.error();
  ASSERT_TRUE(split_side_by_side(cv::Mat(480, 1280, CV_8UC3, cv::Scalar(0)), l, r, "video.mkv").ok());
  EXPECT_EQ(l.cols, 640);
  EXPECT_EQ(r.cols, 640);
  auto sbs = side_by_side(a, b);
  ASSERT_FALSE(sbs.ok());
  EXPECT_NE(sbs.error().find("same size"), std::string::npos) << sbs.error();
}

// What the mirror's corner errors are made of (issue 28 session 18; not asserted, off unless
// DENTAR_MIRROR_PARTS=preset:seed[:seed...] is set; DENTAR_STEREO_FRAMES as below): each
// detected tag observation (each eye's own tracker) against the generator's true corners,
// split into its centre (2 numbers), a common outline offset e (every edge out by e px; least
// squares along u = d corners / d e) and the rest, for the mirror's and the mannequin's tags;
// and the left eye's mirror fit alone from the true corners plus each part: the centre's
// error along the line of sight each part makes.
TEST(StereoTracking, MirrorCornerParts) {
  const char* env = std::getenv("DENTAR_MIRROR_PARTS");
  if (env == nullptr) GTEST_SKIP() << "set DENTAR_MIRROR_PARTS=preset:seed[:seed...]";
  DENTAR_GL_TEST_CONTEXT();
  int frames = 60;
  if (const char* f = std::getenv("DENTAR_STEREO_FRAMES")) frames = std::max(5, std::atoi(f));
  std::stringstream es(env);
  std::string preset_name, x;
  std::getline(es, preset_name, ':');
  auto preset = parse_synth_preset(preset_name);
  ASSERT_TRUE(preset.has_value()) << preset_name;
  struct Acc {
    double ss_c = 0, ss_e = 0, ss_rest = 0, ss_all = 0;
    int n = 0;  // tag observations
    void add(double c2, double e2, double rest2, double all2) {
      ss_c += c2, ss_e += e2, ss_rest += rest2, ss_all += all2, ++n;
    }
  };
  Acc mir_small, mir_large, man;  // mirror tags < 18 px side / >= 18 px; mannequin tags
  std::vector<double> depth_all, depth_e, depth_rest;  // left-eye mirror fits: centre along the line of sight, mm
  while (std::getline(es, x, ':')) {
    const StereoFootage fo = make_stereo_footage(*preset, frames, 640, 480, 0.063, std::stoull(x));
    ASSERT_TRUE(fo.error.empty()) << fo.error;
    TrackerOptions open;
    open.mirror_max_sigma_m = 0;
    open.mannequin_max_sigma_m = 0;
    auto tr = StereoTracker::create(fo.station, with_env(open));
    ASSERT_TRUE(tr.ok()) << tr.error();
    const TagBundle mb = mirror_bundle(fo.station);
    std::map<int, bool> on_mirror;
    for (const TagPlacement& t : mb.tags) on_mirror[t.id] = true;
    for (const StereoSynthFrame& s : fo.frames) {
      const double t = s.left.truth.time_s;
      auto f = tr->track(s.left.image, s.right.image, t, t);
      ASSERT_TRUE(f.ok()) << f.error();
      std::vector<DetectedTag> parts[3];  // left eye's mirror tags: true + e u, true + rest, detected
      for (int eye = 0; eye < 2; ++eye) {
        const FrameTruth& truth = eye == 0 ? s.left.truth : s.right.truth;
        for (const DetectedTag& d : eye == 0 ? f->left.tags : f->right.tags) {
          const TagTruth* tt = nullptr;
          for (const TagTruth& c : truth.tags)
            if (c.id == d.id && c.on_mirror == (on_mirror.count(d.id) > 0) && c.in_image) tt = &c;
          if (tt == nullptr) continue;
          Eigen::Matrix<double, 8, 1> err, u;
          Eigen::Vector2d c = Eigen::Vector2d::Zero(), m = Eigen::Vector2d::Zero();
          for (int k = 0; k < 4; ++k) {
            err.segment<2>(2 * k) = d.corners_px[k] - tt->corners_px[k];
            c += err.segment<2>(2 * k) / 4;
            m += d.corners_px[k] / 4;
          }
          if (c.norm() > 5) continue;  // a different tag of the same id
          // u: each corner where its two edges, moved out by 1 px, meet.
          for (int k = 0; k < 4; ++k) {
            auto normal = [&](int a, int b) {
              const Eigen::Vector2d p = d.corners_px[a], q = d.corners_px[b];
              Eigen::Vector2d n(q.y() - p.y(), p.x() - q.x());
              n.normalize();
              return n.dot((p + q) / 2 - m) < 0 ? Eigen::Vector2d(-n) : n;
            };
            const Eigen::Vector2d n1 = normal((k + 3) % 4, k), n2 = normal(k, (k + 1) % 4);
            Eigen::Matrix2d N;
            N << n1.transpose(), n2.transpose();
            u.segment<2>(2 * k) = N.inverse() * Eigen::Vector2d(1, 1);
          }
          Eigen::Matrix<double, 8, 1> ec = err;
          for (int k = 0; k < 4; ++k) ec.segment<2>(2 * k) -= c;
          const double e = u.dot(ec) / u.squaredNorm();
          const Eigen::Matrix<double, 8, 1> rest = ec - e * u;
          Acc& a = !on_mirror.count(d.id) ? man : tt->side_px < 18 ? mir_small : mir_large;
          a.add(c.squaredNorm(), e * e, rest.squaredNorm() / 6, err.squaredNorm() / 8);  // rest: per axis, 6 of 8 dof
          if (eye == 0 && on_mirror.count(d.id)) {
            DetectedTag pe = d, pr = d;
            for (int k = 0; k < 4; ++k) {
              pe.corners_px[k] = tt->corners_px[k] + e * u.segment<2>(2 * k);
              pr.corners_px[k] = tt->corners_px[k] + rest.segment<2>(2 * k);
            }
            parts[0].push_back(pe);
            parts[1].push_back(pr);
            parts[2].push_back(d);
          }
        }
      }
      if (parts[2].empty()) continue;
      const Iso T_true = s.left.truth.T_cam_mir;
      auto depth = [&](const std::vector<DetectedTag>& d) {
        const BundlePose p = estimate_bundle_pose(mb, fo.station.calibration.camera, d, open.pose, s.left.truth.T_cam_mtag);
        return p.ok() ? depth_err_mm(p.T_cam_body * fo.station.calibration.T_mtag_mir, T_true, Eigen::Vector3d::Zero())
                      : NAN;
      };
      depth_e.push_back(depth(parts[0]));
      depth_rest.push_back(depth(parts[1]));
      depth_all.push_back(depth(parts[2]));
    }
  }
  auto row = [](const char* what, const Acc& a) {
    const double n = std::max(1, a.n);
    std::printf("| %s | %d | %.3f | %.3f | %.3f | %.3f | %.2f |\n", what, a.n, std::sqrt(a.ss_all / n),
                std::sqrt(a.ss_c / n / 2), std::sqrt(a.ss_e / n), std::sqrt(a.ss_rest / n),
                std::sqrt(a.ss_e / std::max(1e-12, a.ss_rest)));
  };
  std::printf("\n[ mirror corner parts ] %s seeds %s, %d frames\n", preset_name.c_str(), env, frames);
  std::printf("| tags | observations | corner RMS px per axis | centre RMS px per axis | outline offset e RMS px | rest RMS px per axis | e / rest |\n|---|---|---|---|---|---|---|\n");
  row("mirror, side < 18 px", mir_small);
  row("mirror, side >= 18 px", mir_large);
  row("mannequin", man);
  auto fin = [](std::vector<double> v) {
    v.erase(std::remove_if(v.begin(), v.end(), [](double d) { return !std::isfinite(d); }), v.end());
    return v;
  };
  std::printf("left eye's mirror fit alone, centre depth error RMS mm (n %zu): detected %.3f, true + outline offset %.3f, "
              "true + rest %.3f\n",
              depth_all.size(), rms(fin(depth_all)), rms(fin(depth_e)), rms(fin(depth_rest)));
}

// The benchmark record (not asserted; off unless DENTAR_STEREO_PRESETS is set).
// DENTAR_STEREO_SEEDS=5,6,...: the generator's seeds (default 5);
// DENTAR_STEREO_RIM=0|1 (TrackerOptions::stereo_mirror_rim),
// DENTAR_STEREO_PRED_SIGMA=0|1 (mirror_prediction_sigma): set them to
// compare a variant against the defaults on the same frames
// (DENTAR_STEREO_COMPARE=1: both on each clip, one row each).
void print_mirror_row(const char* preset, std::uint64_t seed, const char* what, const Run& r) {
  std::printf("| %s | %llu | %s | %d / %d | %.3f / %.3f | %d / %d | %.3f / %.3f | %.3f (%zu) | %.2f | %.2f / %.2f | %d (%d covered) %.3f | %.1f |\n",
              preset, static_cast<unsigned long long>(seed), what, r.drawn, r.frames, pct(r.man_mm, 0.5),
              pct(r.man_mm, 0.95), r.mirror_drawn, r.mirror_seen, pct(r.mir_mm, 0.5), pct(r.mir_mm, 0.95),
              pct(r.mir_meas_mm, 0.95), r.mir_meas_mm.size(), pct(r.mir_deg, 0.95), pct(r.refl_px, 0.5),
              pct(r.refl_px, 0.95), r.mir_predicted, r.pred_covered, pct(r.pred_mm, 0.95), pct(r.ms, 0.5));
}

TEST(StereoTracking, BenchmarkTable) {
  const char* presets = std::getenv("DENTAR_STEREO_PRESETS");
  if (presets == nullptr) GTEST_SKIP() << "set DENTAR_STEREO_PRESETS=standard,mirror,hard for the benchmark table";
  DENTAR_GL_TEST_CONTEXT();
  int frames = 60, w = 640, h = 480;
  if (const char* f = std::getenv("DENTAR_STEREO_FRAMES")) frames = std::max(5, std::atoi(f));
  if (const char* z = std::getenv("DENTAR_STEREO_SIZE")) std::sscanf(z, "%dx%d", &w, &h);
  // DENTAR_STEREO_MIRROR_GATE_MM: the mirror centre's sigma gate (mm) for
  // both trackers (default TrackerOptions: 1 mm).
  TrackerOptions opt;
  if (const char* g = std::getenv("DENTAR_STEREO_MIRROR_GATE_MM")) opt.mirror_max_sigma_m = std::atof(g) * 1e-3;
  if (const char* v = std::getenv("DENTAR_STEREO_RIM")) opt.stereo_mirror_rim = std::atoi(v) != 0;
  if (const char* v = std::getenv("DENTAR_STEREO_PRED_SIGMA")) opt.mirror_prediction_sigma = std::atoi(v) != 0;
  // DENTAR_STEREO_RIM_STEP=1: the rim's blurred-step edge fit with the joint edge selection
  // (MirrorRimOptions::step_fit, joint_select), issue 16's best mono variant.
  // DENTAR_STEREO_RIM_DEPTH=1: the rims may move the disc's depth (stereo_mirror_rim_keep_depth = false), 0: not.
  if (const char* v = std::getenv("DENTAR_STEREO_RIM_DEPTH")) opt.stereo_mirror_rim_keep_depth = std::atoi(v) == 0;
  if (const char* v = std::getenv("DENTAR_STEREO_RIM_STEP")) opt.mirror_rim.step_fit = opt.mirror_rim.joint_select = std::atoi(v) != 0;
  // DENTAR_STEREO_RIM_EFF=N (TrackerOptions::stereo_mirror_rim_effective_points);
  // DENTAR_STEREO_RIM_MIN_TAGS=N (stereo_mirror_rim_min_tags).
  if (const char* v = std::getenv("DENTAR_STEREO_RIM_EFF")) opt.stereo_mirror_rim_effective_points = std::atof(v);
  if (const char* v = std::getenv("DENTAR_STEREO_RIM_MIN_TAGS")) opt.stereo_mirror_rim_min_tags = std::atoi(v);
  // DENTAR_STEREO_RIM_SIGHTINGS=0|1 (stereo_mirror_rim_count_sightings).
  if (const char* v = std::getenv("DENTAR_STEREO_RIM_SIGHTINGS")) opt.stereo_mirror_rim_count_sightings = std::atoi(v) != 0;
  // DENTAR_STEREO_RIM_ONE_TAG_CHI2=x (stereo_mirror_rim_one_tag_chi2; 0 = no check).
  if (const char* v = std::getenv("DENTAR_STEREO_RIM_ONE_TAG_CHI2")) opt.stereo_mirror_rim_one_tag_chi2 = std::atof(v);
  std::vector<std::uint64_t> seeds;
  {
    std::stringstream ss(std::getenv("DENTAR_STEREO_SEEDS") ? std::getenv("DENTAR_STEREO_SEEDS") : "5");
    std::string x;
    while (std::getline(ss, x, ',')) seeds.push_back(std::stoull(x));
  }
  print_header(frames, w, h);
  std::printf("mirror gate %.2f mm, stereo_mirror_rim %d, mirror_prediction_sigma %d\n", opt.mirror_max_sigma_m * 1e3,
              opt.stereo_mirror_rim ? 1 : 0, opt.mirror_prediction_sigma ? 1 : 0);
  std::stringstream ss(presets);
  std::string name;
  std::vector<std::string> mirror_rows;
  while (std::getline(ss, name, ',')) {
    auto preset = parse_synth_preset(name);
    ASSERT_TRUE(preset.has_value()) << name;
    for (std::uint64_t seed : seeds) {
      const StereoFootage fo = make_stereo_footage(*preset, frames, w, h, 0.063, seed);
      ASSERT_TRUE(fo.error.empty()) << fo.error;
      if (const char* ks = std::getenv("DENTAR_STEREO_OUTLINE")) {
        // TrackerOptions::stereo_mirror_outline_sigma: each value on the same frames (with the
        // options above), one stereo row each, after one mono row.
        std::stringstream ksl(ks);
        std::string k;
        bool first = true;
        while (std::getline(ksl, k, ',')) {
          TrackerOptions ok = opt;
          ok.stereo_mirror_outline_sigma = std::atof(k.c_str());
          const Pair v = run_both(fo, ok, first);
          if (first) print_mirror_row(name.c_str(), seed, "mono", v.mono);
          first = false;
          const std::string what = "stereo, outline " + k;
          print_mirror_row(name.c_str(), seed, what.c_str(), v.stereo);
          std::fflush(stdout);
        }
        continue;
      }
      if (std::getenv("DENTAR_STEREO_COMPARE") != nullptr) {
        // The defaults and the variant (the options above) on the same frames, one row each.
        const Pair d = run_both(fo, TrackerOptions{});
        const Pair v = run_both(fo, opt);
        print_mirror_row(name.c_str(), seed, "mono", d.mono);
        print_mirror_row(name.c_str(), seed, "stereo (defaults)", d.stereo);
        print_mirror_row(name.c_str(), seed, "stereo (variant)", v.stereo);
        std::fflush(stdout);
        continue;
      }
      const Pair p = run_both(fo, opt);
      print_row(name.c_str(), "mono (left eye)", p.mono, p.mono_ungated);
      print_row(name.c_str(), "stereo", p.stereo, p.stereo);
      std::printf("|  | stereo: mannequin measured from two / one eye(s) %d / %d; mirror measured frames mono %zu (p95 %.3f mm), stereo %zu (p95 %.3f mm) |\n",
                  p.stereo.two_views, p.stereo.one_view, p.mono.mir_meas_mm.size(), pct(p.mono.mir_meas_mm, 0.95),
                  p.stereo.mir_meas_mm.size(), pct(p.stereo.mir_meas_mm, 0.95));
      std::printf("| preset | seed | tracker | overlay drawn | mannequin p50 / p95 mm | mirror drawn / in view | mirror p50 / p95 mm (drawn) | mirror p95 measured (n) | mirror deg p95 | reflected tooth px p50 / p95 | mirror predicted (err <= 2 sigma) p95 mm | track ms p50 |\n");
      print_mirror_row(name.c_str(), seed, "mono", p.mono);
      print_mirror_row(name.c_str(), seed, "stereo", p.stereo);
      std::fflush(stdout);
    }
  }
}

}  // namespace
}  // namespace dentar::ar
