// Full-frame tag discovery off the frame path (tracker.h, "Discovery"):
// deferred and async searches merged at a later frame, the replay of an
// async run's decisions bit for bit, and bad cues. No GL: the box station's
// flat tag board is drawn into each frame through the true camera
// homography (a pinhole camera without distortion), so this test also runs
// under ThreadSanitizer (label tsan).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <thread>
#include <vector>

#include "dentar/ar/apriltags.h"
#include "dentar/ar/station_scene.h"
#include "dentar/ar/tracker.h"
#include "tag_drawing.h"

namespace dentar::ar {
namespace {

// OpenCV's own worker threads are not instrumented: under TSan their writes
// would look unsynchronised. One thread for OpenCV here (the tracker's
// worker is what is under test).
[[maybe_unused]] const bool kOpenCvSerial = (cv::setNumThreads(0), true);

StationScene board_station() {
  StationScene s = box_station_scene();
  s.calibration.camera.dist.fill(0.0);
  return s;
}

// Camera pose at frame i: 0.35 m in front of the board, looking at it,
// drifting sideways and turning slowly (about 6 mm and 1.5 deg a second).
Eigen::Isometry3d T_cam_man_at(int i) {
  Eigen::Isometry3d T_man_cam = Eigen::Isometry3d::Identity();
  const double t = i / 30.0;
  T_man_cam.linear() = (Eigen::AngleAxisd(0.026 * t, Eigen::Vector3d::UnitY()) *
                        Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()))
                           .toRotationMatrix();
  T_man_cam.translation() = Eigen::Vector3d(0.006 * t, 0.004, 0.35);
  return T_man_cam.inverse();
}

// The board's tags drawn on a grey background (blank = background only).
cv::Mat render(const StationScene& st, const Eigen::Isometry3d& T_cam_man, bool blank) {
  const auto& k = st.calibration.camera;
  cv::Mat img(k.height, k.width, CV_8UC1, cv::Scalar(150));
  if (blank) return img;
  const TagFamily fam = TagFamily::create(st.family);
  for (const TagPlacement& t : st.mannequin_tags) test::draw_tag_pinhole(img, fam, t, T_cam_man, k);
  return img;
}

struct Clip {
  StationScene station = board_station();
  std::vector<cv::Mat> frames;
  std::vector<Eigen::Isometry3d> truth;
  // Frames before `first_visible` show no board.
  explicit Clip(int n, int first_visible = 0) {
    for (int i = 0; i < n; ++i) {
      truth.push_back(T_cam_man_at(i));
      frames.push_back(render(station, truth.back(), i < first_visible));
    }
  }
};

double mm(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm() * 1e3;
}

TrackerOptions options(DiscoveryMode mode) {
  TrackerOptions o;
  o.discovery = mode;
  o.detector.families = {box_station_scene().family};
  return o;
}

std::vector<TrackFrame> run(const Clip& c, Tracker& tr, double pace_s = 0,
                            const std::vector<DiscoveryCue>* cues = nullptr) {
  std::vector<TrackFrame> out;
  for (std::size_t i = 0; i < c.frames.size(); ++i) {
    const double t = i / 30.0;
    auto f = tr.track(c.frames[i], t, t, cues ? &(*cues)[i] : nullptr);
    EXPECT_TRUE(f.ok()) << (f.ok() ? "" : f.error());
    if (!f) break;
    out.push_back(std::move(f).value());
    if (pace_s > 0) std::this_thread::sleep_for(std::chrono::duration<double>(pace_s));
  }
  return out;
}

TEST(Discovery, DeferredNeverSearchesTheFullFrameInTheFramePath) {
  const Clip c(40);
  auto tr = Tracker::create(c.station, options(DiscoveryMode::kDeferred));
  ASSERT_TRUE(tr.ok()) << tr.error();
  const auto fs = run(c, *tr);
  ASSERT_EQ(fs.size(), 40u);
  // Frame 0: nothing known, nothing searched in the frame, its image posted.
  EXPECT_EQ(fs[0].mannequin.state, TrackState::kLost);
  EXPECT_TRUE(fs[0].discovery_started);
  EXPECT_EQ(fs[0].searched_fraction, 0.0);
  // Frame 1 merges frame 0's search, and its regions find the board.
  EXPECT_EQ(fs[1].discovery_merged, 0);
  EXPECT_EQ(fs[1].discovery_tags, 6);
  int starts = 0, last_start = 0, widest_gap = 0;
  for (const TrackFrame& f : fs) {
    EXPECT_FALSE(f.full_frame) << "frame " << f.index;
    EXPECT_LT(f.searched_fraction, 0.9) << "frame " << f.index;
    if (f.discovery_started) {
      widest_gap = std::max(widest_gap, static_cast<int>(f.index) - last_start);
      last_start = static_cast<int>(f.index);
      ++starts;
    }
    if (f.index >= 1) {
      EXPECT_EQ(f.mannequin.state, TrackState::kTracking) << "frame " << f.index;
      EXPECT_TRUE(f.mannequin.measured);
      EXPECT_EQ(f.mannequin.tags_used, 6);
      EXPECT_LT(mm(f.mannequin.T_cam_body_measured, c.truth[f.index]), 0.3) << "frame " << f.index;
    }
  }
  // The mirror is not in view: it is searched for every full_frame_interval
  // frames, not on every frame.
  EXPECT_GE(starts, 3);
  EXPECT_LE(starts, 4);
  EXPECT_EQ(widest_gap, TrackerOptions{}.full_frame_interval);
}

TEST(Discovery, DeferredFindsABodyOneFrameAfterItAppears) {
  const Clip c(20, 8);  // the board is visible from frame 8 on
  auto inl = Tracker::create(c.station, options(DiscoveryMode::kInline));
  auto def = Tracker::create(c.station, options(DiscoveryMode::kDeferred));
  ASSERT_TRUE(inl.ok() && def.ok());
  const auto a = run(c, *inl), b = run(c, *def);
  ASSERT_EQ(a.size(), 20u);
  ASSERT_EQ(b.size(), 20u);
  for (int i = 0; i < 20; ++i) {
    EXPECT_EQ(a[i].mannequin.state, i < 8 ? TrackState::kLost : TrackState::kTracking) << i;
    EXPECT_EQ(b[i].mannequin.state, i < 9 ? TrackState::kLost : TrackState::kTracking) << i;
    // While lost, every frame is handed to a search (the previous one is
    // merged by then).
    if (i < 9) {
      EXPECT_TRUE(b[i].discovery_started) << i;
    }
  }
  EXPECT_EQ(b[9].discovery_merged, 8);
  // Found in frame 8's image, merged at frame 9 as a measurement at frame 8's
  // time, then measured in frame 9's own regions.
  EXPECT_LT(mm(b[9].mannequin.T_cam_body_measured, c.truth[9]), 0.3);
}

TEST(Discovery, DeferredIsDeterministic) {
  const Clip c(30);
  auto t1 = Tracker::create(c.station, options(DiscoveryMode::kDeferred));
  auto t2 = Tracker::create(c.station, options(DiscoveryMode::kDeferred));
  ASSERT_TRUE(t1.ok() && t2.ok());
  const auto a = run(c, *t1), b = run(c, *t2);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].discovery_started, b[i].discovery_started);
    EXPECT_EQ(a[i].discovery_merged, b[i].discovery_merged);
    EXPECT_TRUE(a[i].mannequin.T_cam_body.matrix() == b[i].mannequin.T_cam_body.matrix()) << i;
  }
}

// An async run's decisions (which frame was searched, where it was merged),
// replayed with kScheduled, give the same poses bit for bit: what makes a
// live recording reproducible offline.
TEST(Discovery, AsyncRunReplaysBitForBitFromItsCues) {
  const Clip c(45, 5);
  auto live = Tracker::create(c.station, options(DiscoveryMode::kAsync));
  ASSERT_TRUE(live.ok()) << live.error();
  // Paced a little, like frames from a camera, so searches finish and merge.
  const auto a = run(c, *live, 0.004);
  ASSERT_EQ(a.size(), 45u);
  std::vector<DiscoveryCue> cues;
  int merges = 0;
  for (const TrackFrame& f : a) {
    cues.push_back(DiscoveryCue{f.discovery_started, f.discovery_merged});
    merges += f.discovery_merged >= 0 ? 1 : 0;
    EXPECT_FALSE(f.full_frame);
  }
  EXPECT_GE(merges, 2);
  int tracked = 0;
  for (const TrackFrame& f : a) tracked += f.mannequin.state == TrackState::kTracking ? 1 : 0;
  EXPECT_GE(tracked, 30);  // found within a few frames of appearing at frame 5

  auto replay = Tracker::create(c.station, options(DiscoveryMode::kScheduled));
  ASSERT_TRUE(replay.ok());
  const auto b = run(c, *replay, 0, &cues);
  ASSERT_EQ(b.size(), a.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].mannequin.state, b[i].mannequin.state) << i;
    EXPECT_EQ(a[i].discovery_merged, b[i].discovery_merged) << i;
    EXPECT_TRUE(a[i].mannequin.T_cam_body.matrix() == b[i].mannequin.T_cam_body.matrix()) << i;
  }
}

TEST(Discovery, ResetDropsARunningSearch) {
  const Clip c(6);
  auto tr = Tracker::create(c.station, options(DiscoveryMode::kAsync));
  ASSERT_TRUE(tr.ok());
  for (int round = 0; round < 3; ++round) {
    auto f = tr->track(c.frames[0], 0, 0);
    ASSERT_TRUE(f.ok());
    EXPECT_TRUE(f->discovery_started);
    tr->reset();  // the search may still be running: waited for, dropped
    auto g = tr->track(c.frames[1], 1 / 30.0, 1 / 30.0);
    ASSERT_TRUE(g.ok());
    EXPECT_EQ(g->index, 0);
    EXPECT_EQ(g->discovery_merged, -1);  // nothing from before the reset
    tr->reset();
  }
}

TEST(Discovery, BadCuesAndOptionsGiveClearErrors) {
  const Clip c(2);
  {
    auto tr = Tracker::create(c.station, options(DiscoveryMode::kInline));
    ASSERT_TRUE(tr.ok());
    DiscoveryCue cue{true, -1};
    auto f = tr->track(c.frames[0], 0, 0, &cue);
    ASSERT_FALSE(f.ok());
    EXPECT_NE(f.error().find("not scheduled"), std::string::npos) << f.error();
  }
  {
    auto tr = Tracker::create(c.station, options(DiscoveryMode::kScheduled));
    ASSERT_TRUE(tr.ok());
    DiscoveryCue cue{false, 7};
    auto f = tr->track(c.frames[0], 0, 0, &cue);
    ASSERT_FALSE(f.ok());
    EXPECT_NE(f.error().find("frame 7"), std::string::npos) << f.error();
    EXPECT_NE(f.error().find("never started"), std::string::npos) << f.error();
  }
  TrackerOptions o = options(DiscoveryMode::kAsync);
  o.predicted_regions = false;
  EXPECT_NE(o.validate().find("predicted_regions"), std::string::npos) << o.validate();
  EXPECT_FALSE(Tracker::create(c.station, o).ok());
  auto m = parse_discovery_mode("sideways");
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.error().find("sideways"), std::string::npos);
  for (auto d : {DiscoveryMode::kInline, DiscoveryMode::kDeferred, DiscoveryMode::kAsync,
                 DiscoveryMode::kScheduled}) {
    auto p = parse_discovery_mode(discovery_mode_name(d));
    ASSERT_TRUE(p.ok());
    EXPECT_EQ(*p, d);
  }
}

// Regions padded for the motion as an ellipse along it
// (TrackerOptions::roi_motion_across): on a fast sideways move (7 mm a
// frame at 0.35 m) the narrower padding searches fewer
// pixels and still finds the board in every frame; 1 (the default) pads a
// square. Bad values are refused by name.
TEST(Discovery, RegionsPaddedAlongTheMotion) {
  const StationScene st = board_station();
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 20; ++i) {
    Eigen::Isometry3d T_man_cam = Eigen::Isometry3d::Identity();
    T_man_cam.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
    T_man_cam.translation() = Eigen::Vector3d(-0.06 + 0.007 * i, 0.004, 0.35);
    frames.push_back(render(st, T_man_cam.inverse(), false));
  }
  auto searched = [&](double across, int& measured) {
    TrackerOptions o = options(DiscoveryMode::kInline);
    o.roi_motion_across = across;
    o.full_frame_interval = 1000;
    o.max_prediction_turn_rad = 0;  // the flat grey image gives the motion check nothing to correlate
    auto tr = Tracker::create(st, o);
    EXPECT_TRUE(tr.ok()) << (tr.ok() ? "" : tr.error());
    double sum = 0;
    measured = 0;
    for (std::size_t i = 0; i < frames.size(); ++i) {
      auto f = tr->track(frames[i], i / 30.0, i / 30.0);
      EXPECT_TRUE(f.ok()) << (f.ok() ? "" : f.error());
      if (!f) break;
      if (i >= 3) {  // the filter has a velocity
        EXPECT_FALSE(f->full_frame) << "frame " << i;
        sum += f->searched_fraction;
      }
      measured += f->mannequin.measured ? 1 : 0;
    }
    return sum;
  };
  int m_square = 0, m_half = 0, m_line = 0;
  const double square = searched(1.0, m_square), half = searched(0.5, m_half), line = searched(0.0, m_line);
  std::printf("searched (frames 3-19, sum of fractions): square %.3f, across 0.5 %.3f, across 0 %.3f\n", square,
              half, line);
  EXPECT_EQ(m_square, 20);
  EXPECT_EQ(m_half, 20);
  EXPECT_EQ(m_line, 20);
  EXPECT_LT(half, 0.95 * square) << half << " vs " << square;
  EXPECT_LT(line, half) << line << " vs " << half;

  TrackerOptions o = options(DiscoveryMode::kInline);
  for (double bad : {-0.1, 1.5, std::nan("")}) {
    o.roi_motion_across = bad;
    EXPECT_NE(o.validate().find("roi_motion_across"), std::string::npos) << bad;
    EXPECT_FALSE(Tracker::create(st, o).ok());
  }
}

}  // namespace
}  // namespace dentar::ar
