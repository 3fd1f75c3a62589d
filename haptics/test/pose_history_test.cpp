// PoseHistory (issue 24): the 1 kHz stylus poses sampled at a camera frame's exposure time.
// Also built with -fsanitize=thread (ctest label "tsan").
#include "dentar/haptics/pose_history.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <random>
#include <thread>
#include <vector>

#include "dentar/haptics/engine.h"
#include "dentar/haptics/scripts.h"
#include "dentar/haptics/simulated_device.h"
#include "dentar/volume/procedural_tooth.h"
#include "scripted_rig.h"

namespace dentar::haptics {
namespace {

// A stylus moving at constant velocity and turning at a constant rate about a fixed axis: linear
// interpolation of the translation and slerp of the rotation are both exact on it.
const Eigen::Vector3d kV(0.020, -0.007, 0.011);  // m/s (20 mm/s and more)
const Eigen::Vector3d kAxis = Eigen::Vector3d(1, 2, -0.5).normalized();
constexpr double kOmega = 1.3;  // rad/s
Eigen::Isometry3d truth(double t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(kOmega * t, kAxis) * Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitX())).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.01, 0.02, -0.03) + kV * t;
  return T;
}
double rot_err(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle();
}

TEST(PoseHistory, EmptyHistorySaysSo) {
  auto h = std::make_unique<PoseHistory>();
  EXPECT_EQ(h->sample(1.0).lookup, PoseHistory::Lookup::kEmpty);
  EXPECT_FALSE(h->sample(1.0).usable());
  EXPECT_EQ(h->latest().lookup, PoseHistory::Lookup::kEmpty);
  EXPECT_EQ(h->pushes(), 0u);
}

TEST(PoseHistory, InterpolatesBetweenStepsAndHitsStepsExactly) {
  auto h = std::make_unique<PoseHistory>();
  for (int i = 0; i < 500; ++i) h->push(10.0 + i * 1e-3, truth(i * 1e-3));
  for (double dt : {0.0, 0.00037, 0.0123456, 0.25, 0.4985, 0.499}) {
    const auto s = h->sample(10.0 + dt);
    ASSERT_EQ(s.lookup, PoseHistory::Lookup::kInterpolated) << dt;
    EXPECT_TRUE(s.usable());
    EXPECT_LT((s.T_dev_sty.translation() - truth(dt).translation()).norm(), 1e-9) << dt;
    EXPECT_LT(rot_err(s.T_dev_sty, truth(dt)), 1e-9) << dt;
    EXPECT_LE(s.t0_s, 10.0 + dt);
    EXPECT_LE(10.0 + dt, s.t1_s + 1e-12);
    EXPECT_LT(s.t1_s - s.t0_s, 1.001e-3) << dt;
  }
  // Not the newest pose: the pose of 33 ms ago differs by 33 ms of motion from it.
  const auto now = h->latest();
  const auto then = h->sample(now.t0_s - 0.033);
  EXPECT_NEAR((now.T_dev_sty.translation() - then.T_dev_sty.translation()).norm(), kV.norm() * 0.033, 1e-9);
}

// A replay that pushed the same sequence gets the same pose back from the lookup's index
// (offline replays of a live recording draw what the live window drew).
TEST(PoseHistory, TheIndexOfALookupGivesThePoseBack) {
  auto h = std::make_unique<PoseHistory>();
  for (int i = 0; i < 700; ++i) h->push(3.0 + i * 1e-3 + (i % 3) * 1e-5, truth(i * 1e-3));
  auto replay = std::make_unique<PoseHistory>();  // the same poses, another clock
  for (int i = 0; i < 700; ++i) replay->push(i * 1e-3, truth(i * 1e-3));
  for (double t : {3.1234567, 3.5, 3.0, 3.6989}) {
    const auto s = h->sample(t);
    ASSERT_EQ(s.lookup, PoseHistory::Lookup::kInterpolated) << t;
    const auto r = replay->at_index(s.index);
    ASSERT_EQ(r.lookup, PoseHistory::Lookup::kInterpolated) << t;
    EXPECT_LT((r.T_dev_sty.matrix() - s.T_dev_sty.matrix()).norm(), 1e-12) << t;
  }
  EXPECT_EQ(replay->at_index(-1).lookup, PoseHistory::Lookup::kEmpty);
  EXPECT_EQ(replay->at_index(699.5).lookup, PoseHistory::Lookup::kAfterNewest);
  EXPECT_EQ(replay->at_index(5000).lookup, PoseHistory::Lookup::kAfterNewest);
  for (int i = 700; i < 3000; ++i) replay->push(i * 1e-3, truth(i * 1e-3));
  EXPECT_EQ(replay->at_index(10.5).lookup, PoseHistory::Lookup::kBeforeOldest);
}

TEST(PoseHistory, OutsideTheStoredSpanSaysWhichSide) {
  auto h = std::make_unique<PoseHistory>();
  const int n = static_cast<int>(PoseHistory::kCapacity) * 3 + 17;  // the ring wraps 3 times
  for (int i = 0; i < n; ++i) h->push(i * 1e-3, truth(i * 1e-3));
  const double newest = (n - 1) * 1e-3, oldest = (n - PoseHistory::kCapacity) * 1e-3;
  auto s = h->sample(newest + 0.004);
  EXPECT_EQ(s.lookup, PoseHistory::Lookup::kAfterNewest);
  EXPECT_TRUE(s.usable());
  EXPECT_NEAR(s.age_s, 0.004, 1e-12);
  EXPECT_LT((s.T_dev_sty.translation() - truth(newest).translation()).norm(), 1e-12);
  s = h->sample(oldest - 0.010);
  EXPECT_EQ(s.lookup, PoseHistory::Lookup::kBeforeOldest);
  EXPECT_FALSE(s.usable());
  EXPECT_NEAR(s.t0_s, oldest, 1e-12);
  // The oldest one still stored is exact; one step later interpolates.
  s = h->sample(oldest + 0.0005);
  EXPECT_EQ(s.lookup, PoseHistory::Lookup::kInterpolated);
  EXPECT_LT((s.T_dev_sty.translation() - truth(oldest + 0.0005).translation()).norm(), 1e-9);
  EXPECT_EQ(h->pushes(), static_cast<std::uint64_t>(n));
}

TEST(PoseHistory, FaultedPosesAreNotDrawnAndTimeNeverGoesBack) {
  auto h = std::make_unique<PoseHistory>();
  h->push(0.000, truth(0));
  h->push(0.001, truth(0.001), false);  // a device fault
  h->push(0.002, truth(0.002));
  Eigen::Isometry3d nan = truth(0.003);
  nan.translation().x() = std::nan("");
  h->push(0.003, nan);  // non-finite: stored invalid
  h->push(0.004, truth(0.004));
  EXPECT_EQ(h->sample(0.0005).lookup, PoseHistory::Lookup::kInvalid);
  EXPECT_FALSE(h->sample(0.0015).usable());
  EXPECT_EQ(h->sample(0.0035).lookup, PoseHistory::Lookup::kInvalid);
  EXPECT_EQ(h->sample(0.0041).lookup, PoseHistory::Lookup::kAfterNewest);
  // A clock that steps back: the entry keeps the newest time, the search stays sorted.
  h->push(0.0020, truth(0.005));
  h->push(0.0060, truth(0.006));
  const auto s = h->sample(0.0045);
  EXPECT_EQ(s.lookup, PoseHistory::Lookup::kInterpolated);
  EXPECT_EQ(s.t0_s, 0.004);
  EXPECT_EQ(h->sample(std::nan("")).lookup, PoseHistory::Lookup::kEmpty);
}

// One writer at full speed (far faster than 1 kHz, so it laps the ring many times during the
// readers' searches) against three readers sampling as fast as they can: every usable pose
// is a pose of the trajectory between its two bracketing steps (never a torn mix of two
// pushes), and the writer finishes all its pushes while the readers keep reading (a reader
// never holds it up: a writer that waited on readers would hang here, as they stop only when
// it is done).
TEST(PoseHistory, ConcurrentReadersSeeWholePosesAndNeverHoldTheWriterUp) {
  auto h = std::make_unique<PoseHistory>();
#ifdef DENTAR_UNDER_TSAN
  constexpr int kPushes = 60000;
#else
  constexpr int kPushes = 400000;
#endif
  std::atomic<bool> writer_done{false};
  std::atomic<int> readers_running{0};
  std::atomic<std::uint64_t> usable{0}, bad{0}, reads{0};
  std::vector<std::thread> readers;
  for (int r = 0; r < 3; ++r)
    readers.emplace_back([&, r] {
      std::mt19937 rng(static_cast<unsigned>(r + 1));
      std::uniform_real_distribution<double> back(0.0, 1.3);  // s behind the newest: some too old
      readers_running.fetch_add(1);
      while (!writer_done.load()) {
        const auto l = h->latest();
        const double tq = l.t1_s - back(rng);
        const auto s = h->sample(tq);
        reads.fetch_add(1, std::memory_order_relaxed);
        if (!s.usable()) continue;
        usable.fetch_add(1, std::memory_order_relaxed);
        // The time the pose's translation says (x runs at kV.x()); it must lie between the
        // brackets and agree with y, z and the rotation.
        const double t_pose = (s.T_dev_sty.translation().x() - 0.01) / kV.x();
        const bool ok = t_pose >= s.t0_s - 1e-9 && t_pose <= s.t1_s + 1e-9 &&
                        (s.T_dev_sty.translation() - truth(t_pose).translation()).norm() < 1e-9 &&
                        rot_err(s.T_dev_sty, truth(t_pose)) < 1e-7;
        if (!ok) bad.fetch_add(1);
      }
      readers_running.fetch_sub(1);
    });
  while (readers_running.load() < 3) std::this_thread::yield();
  for (int i = 0; i < kPushes; ++i) h->push(i * 1e-3, truth(i * 1e-3));
  writer_done.store(true);
  for (auto& t : readers) t.join();
  EXPECT_EQ(h->pushes(), static_cast<std::uint64_t>(kPushes));
  EXPECT_EQ(bad.load(), 0u) << usable.load() << " usable of " << reads.load();
  EXPECT_GT(usable.load(), 0u);
}

// The engine keeps one pose per step: under run_steps, stamped with the device's time.
TEST(PoseHistory, EngineStoresEveryStepsPose) {
  test::ScriptedRig rig;
  auto engine = rig.engine();
  ASSERT_EQ(engine->run_steps(300), 300u);
  const HapticSnapshot snap = engine->snapshot();
  EXPECT_EQ(engine->pose_history().pushes(), 300u);
  const auto s = engine->pose_history().sample(snap.time_s);
  ASSERT_EQ(s.lookup, PoseHistory::Lookup::kInterpolated);
  Eigen::Matrix4d m = Eigen::Map<const Eigen::Matrix4d>(snap.T_dev_sty);
  EXPECT_LT((s.T_dev_sty.matrix() - m).norm(), 1e-12);
  // 100 steps earlier: another pose (the scripted hand moves), stamped 0.1 s earlier.
  const auto e = engine->pose_history().sample(snap.time_s - 0.1);
  ASSERT_EQ(e.lookup, PoseHistory::Lookup::kInterpolated);
  EXPECT_NEAR(e.t0_s, snap.time_s - 0.1, 1e-6);
}

// In its own thread the engine stamps the poses with CLOCK_MONOTONIC, the clock of the camera
// frames' capture times (std::chrono::steady_clock, ar::steady_now_s()): the newest and the
// oldest stored pose lie between the steady clock's readings before start() and after stop().
TEST(PoseHistory, EngineThreadStampsWithTheSteadyClock) {
  test::ScriptedRig rig;
  rig.cfg.watchdog_missed_deadlines = 1000000;
  auto engine = rig.engine();
  auto steady = [] { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); };
  const double before = steady();
  ASSERT_TRUE(engine->start().ok());
  while (engine->pose_history().pushes() < 20) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  engine->stop();
  const double after = steady();
  const auto& h = engine->pose_history();
  const auto newest = h.latest();
  ASSERT_EQ(newest.lookup, PoseHistory::Lookup::kInterpolated);
  EXPECT_GE(newest.t0_s, before);
  EXPECT_LE(newest.t0_s, after);
  const auto first = h.sample(before);  // before the first step: the oldest pose
  EXPECT_EQ(first.lookup, PoseHistory::Lookup::kBeforeOldest);
  EXPECT_GE(first.t0_s, before);
  EXPECT_LE(first.t0_s, newest.t0_s);
}

}  // namespace
}  // namespace dentar::haptics
