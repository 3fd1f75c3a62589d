// Tracker on the generator's footage against its exact truth: accuracy,
// recall of the predicted-region path vs full-frame search, no rotation
// jumps, tracking states when the tags vanish, bad input.
#include "dentar/ar/tracker.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <opencv2/imgproc.hpp>
#include <set>
#include <vector>

#include "dentar/ar/pose_filter.h"
#include "dentar/ar/synth.h"
#include "gl_test_context.h"

namespace dentar::ar {
namespace {

double rot_deg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return rotation_log(a.linear() * b.linear().transpose()).norm() * 180 / M_PI;
}
double trans_mm(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm() * 1e3;
}
double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::min<double>(v.size() - 1, std::floor(p * v.size())))];
}

struct Footage {
  StationScene station;
  std::vector<SynthFrame> frames;
  std::string error;
};

// Rendered once per (preset, frames, size) and shared by the tests.
const Footage& footage(SynthPreset preset, int frames, int width, int height) {
  static std::map<std::tuple<int, int, int, int>, Footage> cache;
  auto key = std::make_tuple(static_cast<int>(preset), frames, width, height);
  auto it = cache.find(key);
  if (it != cache.end()) return it->second;
  Footage& f = cache[key];
  SynthOptions o = synth_preset(preset);
  o.frames = frames;
  o.fps = 30;
  o.width = width;
  o.height = height;
  o.seed = 5;
  o.bur_samples = 1000;
  auto g = SynthGenerator::create(default_station_scene(), o);
  if (!g) {
    f.error = g.error();
    return f;
  }
  f.station = (*g)->station();
  for (int i = 0; i < frames; ++i) {
    SynthFrame s;
    if (Status st = (*g)->next(s); !st) {
      f.error = st.error();
      return f;
    }
    s.mask.release();
    f.frames.push_back(std::move(s));
  }
  return f;
}

// Mannequin tags a detector should find: whole, mostly visible, not tiny,
// not grazing.
std::set<int> expected_tags(const FrameTruth& t) {
  std::set<int> ids;
  for (const TagTruth& g : t.tags)
    if (!g.on_mirror && g.in_image && g.visible_fraction > 0.95 && g.side_px >= 14 &&
        g.view_angle_rad < 70 * M_PI / 180)
      ids.insert(g.id);
  return ids;
}

struct TrackRun {
  int frames = 0, measured = 0, expected = 0, found = 0, roi_frames = 0;
  std::vector<double> t_mm, r_deg, filt_t_mm, filt_r_deg;
  std::vector<double> mirror_t_mm, mirror_r_deg;  // measured mirror (mtag) pose errors
  double worst_jump_deg = 0;  // measured frame-to-frame rotation minus the true one
  int jumps_over_5deg = 0;
  std::map<TrackState, int> states;
};

TrackRun run_tracker(const Footage& fo, TrackerOptions opt) {
  TrackRun r;
  auto tr = Tracker::create(fo.station, opt);
  EXPECT_TRUE(tr.ok()) << (tr.ok() ? "" : tr.error());
  if (!tr) return r;
  std::optional<Eigen::Isometry3d> prev_meas, prev_truth;
  for (const SynthFrame& s : fo.frames) {
    auto f = tr->track(s.image, s.truth.time_s, s.truth.time_s);
    EXPECT_TRUE(f.ok()) << (f.ok() ? "" : f.error());
    if (!f) return r;
    ++r.frames;
    r.roi_frames += f->full_frame ? 0 : 1;
    ++r.states[f->mannequin.state];
    const std::set<int> want = expected_tags(s.truth);
    r.expected += static_cast<int>(want.size());
    for (const DetectedTag& t : f->tags) r.found += want.count(t.id) ? 1 : 0;
    if (f->mirror.measured) {
      r.mirror_t_mm.push_back(trans_mm(f->mirror.T_cam_body_measured, s.truth.T_cam_mtag));
      r.mirror_r_deg.push_back(rot_deg(f->mirror.T_cam_body_measured, s.truth.T_cam_mtag));
    }
    if (!f->mannequin.measured) {
      prev_meas.reset();
      continue;
    }
    ++r.measured;
    const Eigen::Isometry3d& m = f->mannequin.T_cam_body_measured;
    r.t_mm.push_back(trans_mm(m, s.truth.T_cam_man));
    r.r_deg.push_back(rot_deg(m, s.truth.T_cam_man));
    r.filt_t_mm.push_back(trans_mm(f->mannequin.T_cam_body, s.truth.T_cam_man));
    r.filt_r_deg.push_back(rot_deg(f->mannequin.T_cam_body, s.truth.T_cam_man));
    if (prev_meas) {
      // Frame-to-frame motion measured vs true: a flip shows as a jump.
      const Eigen::Isometry3d dm = m * prev_meas->inverse();
      const Eigen::Isometry3d dt = s.truth.T_cam_man * prev_truth->inverse();
      const double jump = rot_deg(dm, dt);
      r.worst_jump_deg = std::max(r.worst_jump_deg, jump);
      r.jumps_over_5deg += jump > 5 ? 1 : 0;
    }
    prev_meas = m;
    prev_truth = s.truth.T_cam_man;
  }
  return r;
}

void print(const char* what, const TrackRun& r) {
  std::printf(
      "[ tracker ] %s: %d frames (%d on regions), mannequin measured %d; recall %d/%d; "
      "measured p95 %.3f mm %.4f deg, max %.3f mm %.4f deg; filtered p95 %.3f mm %.4f deg; "
      "worst f2f rotation jump %.3f deg (%d > 5 deg); states tracking %d predicted %d lost %d\n",
      what, r.frames, r.roi_frames, r.measured, r.found, r.expected, percentile(r.t_mm, 0.95),
      percentile(r.r_deg, 0.95), percentile(r.t_mm, 1.0), percentile(r.r_deg, 1.0),
      percentile(r.filt_t_mm, 0.95), percentile(r.filt_r_deg, 0.95), r.worst_jump_deg,
      r.jumps_over_5deg, r.states.count(TrackState::kTracking) ? r.states.at(TrackState::kTracking) : 0,
      r.states.count(TrackState::kPredicted) ? r.states.at(TrackState::kPredicted) : 0,
      r.states.count(TrackState::kLost) ? r.states.at(TrackState::kLost) : 0);
}

TEST(Tracker, StandardFootageAccurateNoJumpsAndRegionsKeepRecall) {
  DENTAR_GL_TEST_CONTEXT();
  const Footage& fo = footage(SynthPreset::kStandard, 90, 640, 480);
  ASSERT_TRUE(fo.error.empty()) << fo.error;
  // The mirror's 1 mm gate off in both: this compares how often the regions
  // *find* the mirror; a gated-out mirror has no prediction and waits for the
  // next full-frame search, which counts against the regions (with the gate,
  // generator v2: 20 vs 25 frames).
  TrackerOptions roi;
  roi.mirror_max_sigma_m = 0;
  const TrackRun a = run_tracker(fo, roi);
  TrackerOptions full = roi;
  full.predicted_regions = false;
  const TrackRun b = run_tracker(fo, full);
  print("standard 640x480 regions", a);
  print("standard 640x480 full frame dec 2", b);
  std::printf("[ tracker ] mirror measured in %zu (regions) / %zu (full) frames; p95 %.3f mm "
              "%.3f deg (regions), %.3f mm %.3f deg (full)\n",
              a.mirror_t_mm.size(), b.mirror_t_mm.size(), percentile(a.mirror_t_mm, 0.95),
              percentile(a.mirror_r_deg, 0.95), percentile(b.mirror_t_mm, 0.95),
              percentile(b.mirror_r_deg, 0.95));
  // The mirror: one or two 12 mm tags, far weaker geometry than the head's
  // bundle; the regions must find it about as often as the full frame.
  EXPECT_GE(a.mirror_t_mm.size() + 3, b.mirror_t_mm.size());
  if (!a.mirror_t_mm.empty()) {
    // Known weakness (docs/BENCHMARKS.md): ~3 mm p95, mostly depth, as on
    // full frames; the rotation is good.
    EXPECT_LT(percentile(a.mirror_t_mm, 0.95), 5.0);
    EXPECT_LT(percentile(a.mirror_r_deg, 0.95), 2.0);
  }
  ASSERT_EQ(a.frames, 90);
  EXPECT_EQ(a.measured, 90);  // the head is in view all along
  EXPECT_GT(a.roi_frames, 60);  // the fast path actually ran
  // Recall: the region path finds at least what full-frame search finds.
  EXPECT_GE(a.found, b.found - 2);
  EXPECT_GE(a.found, static_cast<int>(0.97 * a.expected));
  EXPECT_LT(percentile(a.t_mm, 0.95), 0.4);
  EXPECT_LT(percentile(a.r_deg, 0.95), 0.3);  // 640x480; the 0.1 deg goal is at 1280x720
  EXPECT_LT(percentile(a.t_mm, 1.0), 1.0);
  EXPECT_LT(percentile(a.r_deg, 1.0), 0.5);
  // Filtered (at the capture time): the One Euro filter must follow the
  // head's motion and tremor without adding lag error.
  EXPECT_LT(percentile(a.filt_t_mm, 0.95), 0.4);
  EXPECT_LT(percentile(a.filt_r_deg, 0.95), 0.3);
  EXPECT_EQ(a.jumps_over_5deg, 0);
  EXPECT_LT(a.worst_jump_deg, 1.0);
  EXPECT_EQ(a.states.count(TrackState::kLost), 0u);
}

TEST(Tracker, HardFootageReportedSeparately) {
  DENTAR_GL_TEST_CONTEXT();
  const Footage& fo = footage(SynthPreset::kHard, 60, 640, 480);
  ASSERT_TRUE(fo.error.empty()) << fo.error;
  const TrackRun a = run_tracker(fo, TrackerOptions{});
  TrackerOptions full;
  full.predicted_regions = false;
  const TrackRun b = run_tracker(fo, full);
  print("hard 640x480 regions", a);
  print("hard 640x480 full frame dec 2", b);
  ASSERT_EQ(a.frames, 60);
  // Blur, small grazing tags, occluders: looser, but never a wild pose.
  // Issue 24: 28 of 60 measured (was > 45) once libapriltag searched the
  // image as delivered; 39 with the second look in linear light where tags
  // are missed (TrackerOptions::linear_second_look; docs/BENCHMARKS.md
  // issue 24 session 11).
  EXPECT_GT(a.measured, 35);
  EXPECT_GE(a.found, b.found - 3);
  EXPECT_LT(percentile(a.t_mm, 0.95), 5.0);
  EXPECT_LT(percentile(a.r_deg, 0.95), 2.0);
}

TEST(Tracker, StatesGoPredictedThenLostAndRecover) {
  DENTAR_GL_TEST_CONTEXT();
  const Footage& fo = footage(SynthPreset::kStandard, 90, 640, 480);
  ASSERT_TRUE(fo.error.empty()) << fo.error;
  TrackerOptions o;
  o.stale_limit_s = 0.2;
  o.max_prediction_drift_m = 0;  // the time limit alone (the drift limit: below)
  o.max_prediction_turn_rad = 0;  // a blank image no longer correlates (that check: below)
  auto tr = Tracker::create(fo.station, o);
  ASSERT_TRUE(tr.ok()) << tr.error();
  const cv::Mat blank(fo.frames[0].image.size(), CV_8UC3, cv::Scalar(128, 128, 128));
  const double dt = 1.0 / 30;
  int k = 0;
  for (; k < 10; ++k) {
    auto f = tr->track(fo.frames[k].image, k * dt, k * dt + 0.02);
    ASSERT_TRUE(f.ok()) << f.error();
    EXPECT_EQ(f->mannequin.state, TrackState::kTracking);
    EXPECT_TRUE(f->mannequin.measured);
    EXPECT_EQ(f->mannequin.name, "mannequin");
  }
  // Tags gone (covered camera): predicted for <= 0.2 s, then lost.
  int predicted = 0;
  bool lost = false;
  for (; k < 25; ++k) {
    auto f = tr->track(blank, k * dt, k * dt + 0.02);
    ASSERT_TRUE(f.ok()) << f.error();
    EXPECT_FALSE(f->mannequin.measured);
    EXPECT_TRUE(f->full_frame);  // the expected tags were not in their regions
    if (f->mannequin.state == TrackState::kPredicted) {
      EXPECT_FALSE(lost) << "predicted after lost";
      EXPECT_LE(f->mannequin.since_measurement_s, 0.2 + 1e-9);
      EXPECT_TRUE(f->mannequin.T_cam_body.matrix().allFinite());
      ++predicted;
    } else {
      EXPECT_EQ(f->mannequin.state, TrackState::kLost);
      lost = true;
    }
  }
  EXPECT_EQ(predicted, 6);  // 6 frames at 30 fps = 0.2 s
  EXPECT_TRUE(lost);
  // Tags back: tracking again at once, from a full-frame search.
  auto f = tr->track(fo.frames[k].image, k * dt, k * dt);
  ASSERT_TRUE(f.ok()) << f.error();
  EXPECT_EQ(f->mannequin.state, TrackState::kTracking);
  EXPECT_TRUE(f->full_frame);
  EXPECT_LT(trans_mm(f->mannequin.T_cam_body, fo.frames[k].truth.T_cam_man), 1.0);
}

TEST(Tracker, FastMotionDropsThePredictionEarly) {
  DENTAR_GL_TEST_CONTEXT();
  const Footage& fo = footage(SynthPreset::kStandard, 90, 640, 480);
  ASSERT_TRUE(fo.error.empty()) << fo.error;
  const cv::Mat blank(fo.frames[0].image.size(), CV_8UC3, cv::Scalar(128, 128, 128));
  const double dt = 1.0 / 30;
  // The same tracking history, then the tags vanish: with a drift limit far
  // below what the head moves in one frame (10 um), the body is lost at once;
  // without it, it is predicted.
  for (double limit : {1e-5, 0.0}) {
    TrackerOptions o;
    o.max_prediction_drift_m = limit;
    o.max_prediction_turn_rad = 0;  // the drift limit alone
    auto tr = Tracker::create(fo.station, o);
    ASSERT_TRUE(tr.ok()) << tr.error();
    int k = 0;
    for (; k < 10; ++k) ASSERT_TRUE(tr->track(fo.frames[k].image, k * dt, k * dt).ok());
    auto f = tr->track(blank, k * dt, k * dt);
    ASSERT_TRUE(f.ok()) << f.error();
    EXPECT_EQ(f->mannequin.state, limit > 0 ? TrackState::kLost : TrackState::kPredicted) << limit;
  }
}

// The image-motion check (max_prediction_turn_rad, image_motion.h): the
// last frame again with its tags hidden by grey patches (nothing moved)
// keeps the prediction; the same frame shifted 40 px sideways (a 3.8 deg
// head turn the filter never saw) ends it at once.
TEST(Tracker, ImageMotionEndsThePredictionWhenTheViewChanges) {
  DENTAR_GL_TEST_CONTEXT();
  const Footage& fo = footage(SynthPreset::kStandard, 90, 640, 480);
  ASSERT_TRUE(fo.error.empty()) << fo.error;
  const double dt = 1.0 / 30;
  for (bool turned : {true, false}) {
    TrackerOptions o;
    o.max_prediction_drift_m = 0;
    auto tr = Tracker::create(fo.station, o);
    ASSERT_TRUE(tr.ok()) << tr.error();
    int k = 0;
    for (; k < 10; ++k) ASSERT_TRUE(tr->track(fo.frames[k].image, k * dt, k * dt).ok());
    cv::Mat hidden = fo.frames[9].image.clone();
    for (const TagTruth& t : fo.frames[9].truth.tags) {
      cv::Rect box(int(t.corners_px[0].x()), int(t.corners_px[0].y()), 1, 1);
      for (const auto& c : t.corners_px) box |= cv::Rect(int(c.x()), int(c.y()), 1, 1);
      const int g = box.width / 2 + 4;
      box = cv::Rect(box.x - g, box.y - g, box.width + 2 * g, box.height + 2 * g) &
            cv::Rect(0, 0, hidden.cols, hidden.rows);
      hidden(box).setTo(cv::Scalar(128, 128, 128));
    }
    cv::Mat shifted;
    const cv::Mat M = (cv::Mat_<double>(2, 3) << 1, 0, 40, 0, 1, 0);
    cv::warpAffine(hidden, shifted, M, hidden.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    auto f = tr->track(turned ? shifted : hidden, k * dt, k * dt);
    ASSERT_TRUE(f.ok()) << f.error();
    EXPECT_FALSE(f->mannequin.measured) << turned;
    EXPECT_EQ(f->mannequin.state, turned ? TrackState::kLost : TrackState::kPredicted) << turned;
  }
}

TEST(Tracker, OneSmallTagIsNotTrustedForTheMannequin) {
  DENTAR_GL_TEST_CONTEXT();
  const Footage& fo = footage(SynthPreset::kStandard, 90, 640, 480);
  ASSERT_TRUE(fo.error.empty()) << fo.error;
  // Keep one mannequin tag of frame 0 and grey out the rest of the image:
  // the smallest one the detector finds alone.
  const SynthFrame& s = fo.frames[0];
  std::vector<const TagTruth*> cands;
  for (const TagTruth& t : s.truth.tags)
    if (!t.on_mirror && t.in_image && t.visible_fraction > 0.99) cands.push_back(&t);
  std::sort(cands.begin(), cands.end(), [](auto* a, auto* b) { return a->side_px < b->side_px; });
  auto only = [&](const TagTruth& t) {
    double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
    for (const auto& c : t.corners_px) {
      x0 = std::min(x0, c.x()), y0 = std::min(y0, c.y()), x1 = std::max(x1, c.x()), y1 = std::max(y1, c.y());
    }
    const double pad = 0.4 * t.side_px;
    const cv::Rect roi =
        cv::Rect(cv::Point(int(x0 - pad), int(y0 - pad)), cv::Point(int(x1 + pad), int(y1 + pad))) &
        cv::Rect(0, 0, s.image.cols, s.image.rows);
    cv::Mat one(s.image.size(), CV_8UC3, cv::Scalar(128, 128, 128));
    s.image(roi).copyTo(one(roi));
    return one;
  };
  auto measured_with = [&](const cv::Mat& img, double gate) {
    TrackerOptions o;
    o.mannequin_max_sigma_m = gate;
    auto tr = Tracker::create(fo.station, o);
    EXPECT_TRUE(tr.ok());
    auto f = tr->track(img, 0.0, 0.0);
    EXPECT_TRUE(f.ok());
    return f.ok() && f->mannequin.measured;
  };
  const TagTruth* used = nullptr;
  for (const TagTruth* t : cands)
    if (measured_with(only(*t), 0.0)) {
      used = t;
      break;
    }
  ASSERT_NE(used, nullptr) << "no tag of frame 0 gives a pose on its own";
  // A single tag of ~20-30 px at 30-40 cm: millimetres of depth uncertainty.
  EXPECT_FALSE(measured_with(only(*used), 1.5e-3)) << "tag side " << used->side_px << " px";
  // The whole frame (7+ tags) passes the same gate.
  EXPECT_TRUE(measured_with(s.image, 1.5e-3));
}

TEST(Tracker, BadInputGivesClearErrors) {
  const StationScene st = default_station_scene();
  TrackerOptions o;
  o.full_frame_interval = 0;
  auto a = Tracker::create(st, o);
  ASSERT_FALSE(a.ok());
  EXPECT_NE(a.error().find("full_frame_interval"), std::string::npos) << a.error();
  o = {};
  o.detector.decimation = 0.5;
  auto b = Tracker::create(st, o);
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().find("detector.decimation"), std::string::npos) << b.error();
  o = {};
  o.detector.families = {TagFamilyId::kTag36h11};
  auto c = Tracker::create(st, o);
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().find("tagStandard41h12"), std::string::npos) << c.error();
  o = {};
  o.mannequin_measurements_to_predict = 0;
  auto d = Tracker::create(st, o);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.error().find("mannequin_measurements_to_predict"), std::string::npos) << d.error();
  o = {};
  o.pose.outlier_px = -1;
  auto f = Tracker::create(st, o);
  ASSERT_FALSE(f.ok());
  EXPECT_NE(f.error().find("pose.outlier_px"), std::string::npos) << f.error();

  auto t = Tracker::create(st, TrackerOptions{});
  ASSERT_TRUE(t.ok()) << t.error();
  auto e1 = t->track(cv::Mat(), 0, 0);
  ASSERT_FALSE(e1.ok());
  EXPECT_NE(e1.error().find("empty"), std::string::npos);
  auto e2 = t->track(cv::Mat(240, 320, CV_8UC3, cv::Scalar::all(0)), 0, 0);
  ASSERT_FALSE(e2.ok());
  EXPECT_NE(e2.error().find("320x240"), std::string::npos) << e2.error();
  EXPECT_NE(e2.error().find("640x480"), std::string::npos) << e2.error();
  auto e3 = t->track(cv::Mat(480, 640, CV_32FC1, cv::Scalar::all(0)), 0, 0);
  ASSERT_FALSE(e3.ok());
  EXPECT_NE(e3.error().find("CV_32F"), std::string::npos) << e3.error();
  // A frame without tags is not an error: the body is lost.
  auto ok = t->track(cv::Mat(480, 640, CV_8UC1, cv::Scalar::all(90)), 0, 0);
  ASSERT_TRUE(ok.ok()) << ok.error();
  EXPECT_EQ(ok->mannequin.state, TrackState::kLost);
  EXPECT_EQ(ok->mirror.state, TrackState::kLost);
}

TEST(Tracker, ScaleIntrinsicsAndSizeCheck) {
  calibration::CameraIntrinsics k = default_camera(640, 480);
  auto s = scale_intrinsics(k, 1280, 960);
  ASSERT_TRUE(s.ok()) << s.error();
  EXPECT_DOUBLE_EQ(s->fx, 2 * k.fx);
  EXPECT_DOUBLE_EQ(s->fy, 2 * k.fy);
  EXPECT_DOUBLE_EQ(s->cx, 2 * k.cx + 0.5);  // pixel centres at integers
  EXPECT_EQ(s->width, 1280);
  EXPECT_EQ(s->dist, k.dist);
  auto bad = scale_intrinsics(k, 1280, 720);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("aspect"), std::string::npos) << bad.error();
  auto refused = camera_for_image(k, 1280, 960, false, "cam.yaml");
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().find("cam.yaml"), std::string::npos);
  EXPECT_NE(refused.error().find("--scale-calib"), std::string::npos);
  EXPECT_TRUE(camera_for_image(k, 640, 480, false, "cam.yaml").ok());
  EXPECT_TRUE(camera_for_image(k, 320, 240, true, "cam.yaml").ok());
}

}  // namespace
}  // namespace dentar::ar
