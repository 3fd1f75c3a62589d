// Training modes 2-5 in the engine (issue 27): the seed's guidance field, conditional
// replay, force reversal, hints, and the expert's bur cutting; closed loop against every
// device profile with a relaxed hand and 2 ms of jitter.
#include "dentar/haptics/guidance.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <thread>
#include <cmath>
#include <numbers>

#include "closed_loop.h"
#include "dentar/haptics/engine.h"
#include "dentar/haptics/replay.h"
#include "dentar/haptics/session_log.h"
#include "dentar/haptics/profile_sim_device.h"
#include "dentar/haptics/simulated_device.h"
#include "testutil.h"

namespace dentar::haptics {
namespace {

namespace fs = std::filesystem;
using closed_loop::expert_path;
using closed_loop::expert_recording;
using closed_loop::kDown;

ExpertTrack track_of(const std::vector<StepRecord>& rec) {
  auto t = ExpertTrack::from_records(rec, Eigen::Isometry3d::Identity(), Eigen::Isometry3d::Identity(), "expert.dlog");
  EXPECT_TRUE(t.ok()) << t.error();
  return std::move(t).value();
}

Eigen::Isometry3d pose(const Eigen::Vector3d& p, const Eigen::Quaterniond& q = kDown) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q.toRotationMatrix();
  T.translation() = p;
  return T;
}

TEST(Guidance, FieldIsTheSeedsLaw) {
  GuidanceParams p;
  p.k_N_per_m = 200;
  p.eps1_m = 0.5e-3;
  p.eps2_m = 10e-3;
  const Eigen::Vector3d u = Eigen::Vector3d(1, 2, -2).normalized();
  // Beyond eps2: nothing.
  EXPECT_EQ(guidance_force(u * 10.01e-3, p).norm(), 0.0);
  // Between: k |dx|, toward the expert (along delta).
  const Eigen::Vector3d f = guidance_force(u * 4e-3, p);
  EXPECT_NEAR(f.norm(), 0.8, 1e-12);
  EXPECT_NEAR(f.normalized().dot(u), 1.0, 1e-12);
  // Below eps1: k |dx|^2 / eps1, continuous at eps1 (k eps1 = 0.1 N from both sides).
  EXPECT_NEAR(guidance_force(u * 0.25e-3, p).norm(), 200 * 0.25e-3 * 0.25e-3 / 0.5e-3, 1e-12);
  EXPECT_NEAR(guidance_force(u * (0.5e-3 - 1e-12), p).norm(), 0.1, 1e-9);
  EXPECT_NEAR(guidance_force(u * (0.5e-3 + 1e-12), p).norm(), 0.1, 1e-9);
  EXPECT_EQ(guidance_force(Eigen::Vector3d::Zero(), p).norm(), 0.0);
  // Across the path only: the part along the tangent is free.
  p.across_path_only = true;
  const Eigen::Vector3d g = guidance_force(Eigen::Vector3d(3e-3, 4e-3, 0), p, Eigen::Vector3d(2, 0, 0));
  EXPECT_NEAR(g.x(), 0.0, 1e-12);
  EXPECT_NEAR(g.y(), 0.8, 1e-12);
  // Non-finite input gives no force.
  EXPECT_EQ(guidance_force(Eigen::Vector3d(NAN, 0, 0), p).norm(), 0.0);
}

TEST(Guidance, BadParametersNameTheField) {
  TrainingParams t;
  t.mode = TrainingModeKind::kPassiveGuidance;
  EXPECT_EQ(t.validate(), "");
  TrainingParams b = t;
  b.guidance.eps1_m = 10e-3;  // = eps2
  EXPECT_NE(b.validate().find("eps2 = 10 mm must be greater than eps1 = 10 mm"), std::string::npos) << b.validate();
  b = t;
  b.guidance.k_N_per_m = -1;
  EXPECT_NE(b.validate().find("guidance stiffness k = -1"), std::string::npos) << b.validate();
  b = t;
  b.guidance.eps1_m = -0.1e-3;
  EXPECT_NE(b.validate().find("eps1 = -0.1 mm must be > 0"), std::string::npos) << b.validate();
  b = t;
  b.guidance.damping_N_s_per_m = NAN;
  EXPECT_NE(b.validate().find("guidance damping"), std::string::npos) << b.validate();
  b = t;
  b.tolerance.theta_rad[1] = 0;
  EXPECT_NE(b.validate().find("theta2"), std::string::npos) << b.validate();
  b = t;
  b.tolerance.eps_m = -1e-3;
  EXPECT_NE(b.validate().find("follow tolerance eps = -1 mm"), std::string::npos) << b.validate();
  b = t;
  b.speed = 3;
  EXPECT_NE(b.validate().find("expert speed = 3"), std::string::npos) << b.validate();
  b = t;
  b.mode = static_cast<TrainingModeKind>(9);
  EXPECT_NE(b.validate().find("mode = 9"), std::string::npos) << b.validate();
}

TEST(ExpertTrackTest, InterpolatesInTheToothFrameAndRefusesBadRecordings) {
  const auto rec = expert_recording(2e-3);
  // Another station: the recording's device sits 30 mm along x of the tooth and its stylus
  // tip is 20 mm down the stylus; the track is the tip in the tooth frame.
  Eigen::Isometry3d T_tooth_dev = Eigen::Isometry3d::Identity(), T_sty_tip = Eigen::Isometry3d::Identity();
  T_tooth_dev.translation() = Eigen::Vector3d(30e-3, 0, 0);
  T_tooth_dev.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_sty_tip.translation() = Eigen::Vector3d(0, 0, 20e-3);
  auto tr = ExpertTrack::from_records(rec, T_tooth_dev, T_sty_tip, "expert.dlog");
  ASSERT_TRUE(tr.ok()) << tr.error();
  EXPECT_NEAR(tr->duration_s(), 3.5, 1e-9);
  for (double t : {0.0, 0.7305, 1.5, 3.5, 9.0}) {
    const double tc = std::min(t, 3.5);
    const Eigen::Vector3d want = (T_tooth_dev * pose(expert_path(tc, 2e-3)) * T_sty_tip).translation();
    EXPECT_LT((tr->at(t).T_tooth_tip.translation() - want).norm(), 1e-7) << t;
  }
  EXPECT_TRUE(tr->at(1.5).drilling);
  EXPECT_FALSE(tr->at(2.5).drilling);
  // The force turns with the recording's device.
  const Eigen::Vector3d f = tr->at(3.0).force_N;
  EXPECT_LT((f - T_tooth_dev.linear() * Eigen::Vector3d(0.3, -0.2, 0.8)).norm(), 1e-12);

  const Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
  auto one = ExpertTrack::from_records({rec.front()}, I, I, "short.dlog");
  ASSERT_FALSE(one.ok());
  EXPECT_NE(one.error().find("short.dlog: the expert recording has 1 haptic steps"), std::string::npos) << one.error();
  auto back = rec;
  back[100].time_s = back[99].time_s;
  auto b = ExpertTrack::from_records(back, I, I, "repeat.dlog");
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().find("repeat.dlog: haptic step 100 does not come after"), std::string::npos) << b.error();
  auto nan = rec;
  nan[7].position_m[1] = NAN;
  auto n = ExpertTrack::from_records(nan, I, I, "nan.dlog");
  ASSERT_FALSE(n.ok());
  EXPECT_NE(n.error().find("nan.dlog: haptic step 7 has a non-finite"), std::string::npos) << n.error();
}

TEST(RampTest, MovesAtItsRateAndStaysInRange) {
  Ramp r(0.25);
  r.set_target(1);
  for (int i = 0; i < 100; ++i) r.step(1e-3);
  EXPECT_NEAR(r.value(), 0.4, 1e-12);
  for (int i = 0; i < 1000; ++i) r.step(1e-3);
  EXPECT_EQ(r.value(), 1.0);
  r.set_target(7);  // clamped
  EXPECT_EQ(r.target(), 1.0);
  r.set_target(0);
  r.step(NAN);  // a bad period does not move it
  EXPECT_EQ(r.value(), 1.0);
  r.step(0.125);
  EXPECT_NEAR(r.value(), 0.5, 1e-12);
}

// Mode 3: the expert's clock runs while the student is on the expert's tool, waits while
// the student strays, and resumes from where it stopped (no jump in pose).
TEST(TrainingModes, ConditionalReplayWaitsForTheStudentAndResumesWithoutAJump) {
  const auto rec = expert_recording(2e-3);
  const ExpertTrack tr = track_of(rec);
  TrainingParams p;
  p.mode = TrainingModeKind::kActiveFollowing;
  auto m = TrainingMode::create(p, tr);
  ASSERT_TRUE(m.ok()) << m.error();
  const double dt = 1e-3;
  Eigen::Vector3d last = tr.at(0).T_tooth_tip.translation();
  double max_jump = 0, waited_s = 0, t = 0;
  int stray_steps = 0;
  // The student follows 0.5 mm off the expert, except from 1.2 to 1.6 s, when it is 5 mm off.
  for (int i = 0; i < 5000 && !m->finished(); ++i, t += dt) {
    const bool stray = t >= 1.2 && t < 1.6;
    const Eigen::Vector3d at = tr.at(m->step(pose(last), Eigen::Vector3d::Zero(), 0).expert_time_s).T_tooth_tip.translation();
    const Eigen::Vector3d student = at + Eigen::Vector3d(0, stray ? 5e-3 : 0.5e-3, 0);
    const TrainingStep s = m->step(pose(student), Eigen::Vector3d::Zero(), dt);
    const Eigen::Vector3d e = s.expert.T_tooth_tip.translation();
    max_jump = std::max(max_jump, (e - last).norm());
    last = e;
    if (s.expert_waiting) {
      waited_s += dt;
      EXPECT_TRUE(stray) << t;
      EXPECT_FALSE(s.expert_cuts) << "a waiting expert does not cut";
    }
    stray_steps += stray;
    EXPECT_FALSE(s.contact_forces);
    EXPECT_FALSE(s.student_cuts);
    EXPECT_EQ(s.force_tooth_N.norm(), 0.0);
  }
  EXPECT_NEAR(waited_s, 0.4, 2e-3) << "the expert waits exactly while the student strays";
  // No step moves the expert's tool further than its own recording moves in one step, also
  // across the pause (11 um at the path's fastest).
  double fastest = 0;
  for (double u = 0; u < tr.duration_s(); u += dt)
    fastest = std::max(fastest, (tr.at(u + dt).T_tooth_tip.translation() - tr.at(u).T_tooth_tip.translation()).norm());
  EXPECT_GT(max_jump, 0.5 * fastest);
  EXPECT_LE(max_jump, fastest + 1e-9);
  EXPECT_TRUE(m->finished());
  EXPECT_NEAR(t, 3.5 + 0.4, 3e-3) << "the replay took its length plus the wait";
  // Without conditional replay the expert does not wait.
  p.conditional_replay = false;
  auto free_run = TrainingMode::create(p, tr);
  ASSERT_TRUE(free_run.ok());
  EXPECT_FALSE(free_run->step(pose(Eigen::Vector3d(1, 1, 1)), Eigen::Vector3d::Zero(), dt).expert_waiting);
}

// An engine over a volume with a simulated hand and a training mode.
struct ModeRig {
  volume::VoxelVolume vol = closed_loop::enamel_half_space().clone();
  volume::BurSamples bur = std::move(volume::sample_bur(volume::BurParams::sphere(0.5), 2000)).value();
  std::vector<StepRecord> rec;
  ExpertTrack track;
  std::unique_ptr<TrainingMode> mode;
  std::unique_ptr<HapticDevice> device;
  std::unique_ptr<Engine> engine;
  std::string error;

  ModeRig(const TrainingParams& p, double expert_z, std::unique_ptr<HapticDevice> dev)
      : rec(expert_recording(expert_z)), track(track_of(rec)), device(std::move(dev)) {
    auto m = TrainingMode::create(p, track);
    if (!m.ok()) {
      error = m.error();
      return;
    }
    mode = std::make_unique<TrainingMode>(std::move(m).value());
    EngineConfig cfg;
    cfg.try_realtime = false;
    cfg.training = mode.get();
    auto e = Engine::create(cfg, *device, vol, bur);
    if (!e.ok()) {
      error = e.error();
      return;
    }
    engine = std::move(e).value();
  }
};

std::unique_ptr<HapticDevice> hand_at(const std::vector<HandWaypoint>& script, bool pedal = false) {
  DeviceLimits limits;
  limits.workspace_min_m = Eigen::Vector3d::Constant(-0.1);
  limits.workspace_max_m = Eigen::Vector3d::Constant(0.1);
  std::vector<HandWaypoint> s = script;
  for (auto& w : s) w.pedal = pedal;
  auto d = SimulatedDevice::create(s, limits);
  EXPECT_TRUE(d.ok()) << d.error();
  return std::move(d).value();
}

HandWaypoint wp(double t, const Eigen::Vector3d& p) {
  HandWaypoint w;
  w.time_s = t;
  w.position_m = p;
  w.orientation = kDown;
  return w;
}

// Mode 4: the device renders minus the recorded force (after the mode's fade-in), and the
// expert's bur, not the student's, cuts.
TEST(TrainingModes, ForceReversalRendersMinusTheRecordedForce) {
  TrainingParams p;
  p.mode = TrainingModeKind::kForceReversal;
  // The student holds the stylus 2 mm above the enamel, pedal down: it must not cut.
  ModeRig rig(p, 2e-3, hand_at({wp(0, Eigen::Vector3d(0, 0, 2e-3))}, true));
  ASSERT_TRUE(rig.error.empty()) << rig.error;
  double worst = 0;
  for (int i = 0; i < 3400; ++i) {
    ASSERT_EQ(rig.engine->run_steps(1), 1u);
    const HapticSnapshot s = rig.engine->snapshot();
    const Eigen::Vector3d sent(s.force_dev_N[0], s.force_dev_N[1], s.force_dev_N[2]);
    const Eigen::Vector3d want = -rig.track.at(s.expert_time_s).force_N;
    EXPECT_EQ(s.mode, 4);
    if (s.expert_time_s > p.ramp_s + 0.01) worst = std::max(worst, (sent - want).norm());
    EXPECT_LE(sent.norm(), want.norm() + 1e-9) << "never more than the recording's force";
  }
  EXPECT_LT(worst, 1e-9) << "-F exactly once faded in";
  double removed = 0;
  for (double r : rig.engine->snapshot().removed_mm3) removed += r;
  EXPECT_EQ(removed, 0.0) << "the expert drills 2 mm above the enamel and the student does not cut";
}

// Mode 5: the snapshot says the expert drills exactly while the recording's pedal is down;
// the student cuts as usual. Mode 3 with the expert's path in the enamel: the expert's bur
// cuts, the student's (pedal down, in the enamel too) does not.
TEST(TrainingModes, HintsFollowTheRecordingsPedalAndTheExpertsBurCuts) {
  TrainingParams p;
  p.mode = TrainingModeKind::kHints;
  {
    // Student pressing into the enamel with the pedal down: it cuts in hints mode.
    ModeRig rig(p, 2e-3, hand_at({wp(0, Eigen::Vector3d(0, 0, 1e-3)), wp(0.5, Eigen::Vector3d(0, 0, -0.3e-3))}, true));
    ASSERT_TRUE(rig.error.empty()) << rig.error;
    int mismatched = 0, drilling = 0;
    for (int i = 0; i < 3000; ++i) {
      ASSERT_EQ(rig.engine->run_steps(1), 1u);
      const HapticSnapshot s = rig.engine->snapshot();
      const bool want = s.expert_time_s >= 1.0 && s.expert_time_s < 2.0;
      mismatched += (s.expert_drilling != 0) != want;
      drilling += s.expert_drilling;
    }
    EXPECT_LE(mismatched, 1) << "one step's rounding at each pedal edge at most";
    EXPECT_NEAR(drilling, 1000, 2);
    double removed = 0;
    for (double r : rig.engine->snapshot().removed_mm3) removed += r;
    EXPECT_GT(removed, 0.0) << "the student drills as usual in hints mode";
  }
  p.mode = TrainingModeKind::kActiveFollowing;
  p.conditional_replay = false;
  {
    // The expert's path 0.2 mm into the enamel; the student's tool pressed in 3 mm away.
    ModeRig rig(p, -0.2e-3, hand_at({wp(0, Eigen::Vector3d(0, 3e-3, 1e-3)), wp(0.3, Eigen::Vector3d(0, 3e-3, -0.3e-3))}, true));
    ASSERT_TRUE(rig.error.empty()) << rig.error;
    const volume::VoxelVolume before = rig.vol.clone();
    rig.engine->run_steps(2600);
    double removed = 0;
    for (double r : rig.engine->snapshot().removed_mm3) removed += r;
    EXPECT_GT(removed, 0.01) << "the expert's bur cut along its drilled path (mm^3)";
    // Around the student's tip nothing was removed.
    const Eigen::Vector3d stud(0, 3e-3, -0.3e-3);
    int changed_near_student = 0, changed = 0;
    const auto& g = rig.vol.geometry();
    for (int k = 0; k < g.dims.z(); ++k)
      for (int j = 0; j < g.dims.y(); ++j)
        for (int i = 0; i < g.dims.x(); ++i) {
          if (rig.vol.density(i, j, k) == before.density(i, j, k)) continue;
          ++changed;
          changed_near_student += (rig.vol.voxel_center(i, j, k) - stud).norm() < 0.8e-3;
        }
    EXPECT_GT(changed, 0);
    EXPECT_EQ(changed_near_student, 0);
  }
}

// Mode 2 against every device profile at the stiffest guidance it allows, a relaxed hand
// (10 N/m to where it started), 2 ms of jitter on every period and HD's one-period delay:
// the expert's tip pulls the stylus along its path; no kick when the mode starts, no buzz
// when the tools rest together. (At 0.8 x the contact limit, a linear field buzzes or
// diverges on 6 of 9 profiles with this jitter: haptics_guidance_bench.)
TEST(TrainingModes, PassiveGuidancePullsARelaxedHandOnEveryProfile) {
  for (const DeviceProfile& prof : device_profiles()) {
    SCOPED_TRACE(prof.id);
    GuidanceParams g;
    g.k_N_per_m = guidance_stiffness_limit(prof.max_stiffness_N_per_m);  // the stiffest allowed
    g.damping_N_s_per_m = std::min(1.0, 0.5 * prof.max_damping_N_s_per_m);
    const closed_loop::GuidanceResult r = closed_loop::guidance_run(prof, g, 2e-3);
    ASSERT_TRUE(r.error.empty()) << r.error;
    std::printf("%-9s k %5.0f N/m  following error mean %.3f mm p95 %.3f mm  start peak %.3f N  rest ripple %.4f N\n",
                prof.id.c_str(), g.k_N_per_m, r.mean_m * 1e3, r.p95_m * 1e3, r.start_peak_N, r.rest_ripple_N);
    EXPECT_LT(r.mean_m, 1.0e-3);
    EXPECT_LT(r.p95_m, 1.5e-3);
    // No kick: at the start the pull never exceeds the field at the initial 1 mm offset.
    EXPECT_LT(r.start_peak_N, g.k_N_per_m * 1e-3 + 0.02);
    // No buzz where the tools rest together (inside eps1's quadratic core).
    EXPECT_LT(r.rest_ripple_N, 0.02);
    EXPECT_LE(r.max_step_N, 2000.0 * 3e-3 + 1e-9) << "the guard's spike limit holds";
  }
}

// The variants beyond the seed scale the field as documented: linear core, fading, guidance
// as needed, error amplification (one student held 2 mm beside a still expert).
TEST(TrainingModes, GuidanceVariantsScaleTheField) {
  GuidanceParams lin;
  lin.quadratic_core = false;
  EXPECT_NEAR(guidance_force(Eigen::Vector3d(0.25e-3, 0, 0), lin).norm(), lin.k_N_per_m * 0.25e-3, 1e-12);
  const auto rec = expert_recording(2e-3);
  const ExpertTrack tr = track_of(rec);
  // |f| after 0.45 s (past the 0.25 s fade-in, the expert still until 0.5 s).
  auto force_after = [&](const GuidanceParams& g, double offset_m) {
    TrainingParams p;
    p.mode = TrainingModeKind::kPassiveGuidance;
    p.guidance = g;
    auto m = TrainingMode::create(p, tr);
    EXPECT_TRUE(m.ok()) << m.error();
    const Eigen::Isometry3d student = pose(expert_path(0, 2e-3) + Eigen::Vector3d(0, offset_m, 0));
    Eigen::Vector3d f = Eigen::Vector3d::Zero();
    for (int i = 0; i < 450; ++i) f = m->step(student, Eigen::Vector3d::Zero(), 1e-3).force_tooth_N;
    return f;
  };
  GuidanceParams base;
  const Eigen::Vector3d f0 = force_after(base, 2e-3);
  EXPECT_NEAR(f0.norm(), base.k_N_per_m * 2e-3, 1e-9);
  EXPECT_LT(f0.y(), 0) << "toward the expert";
  GuidanceParams faded = base;
  faded.fade = 0.5;
  faded.repetition = 2;
  EXPECT_NEAR(force_after(faded, 2e-3).norm(), 0.25 * f0.norm(), 1e-9);
  GuidanceParams needed = base;
  needed.as_needed = true;
  // After 0.45 s at 2 mm the low-passed error is 2 mm * (1 - e^-0.45) = 0.73 mm: scale 0.29.
  const double scale = 2e-3 * (1 - std::exp(-0.45)) / 10e-3 * 4.0;
  EXPECT_NEAR(force_after(needed, 2e-3).norm(), scale * f0.norm(), 0.01 * f0.norm());
  EXPECT_LT(force_after(needed, 0.1e-3).norm(), force_after(base, 0.1e-3).norm()) << "little for a student on the path";
  GuidanceParams amp = base;
  amp.amplify = 0.5;
  const Eigen::Vector3d fa = force_after(amp, 2e-3);
  EXPECT_NEAR(fa.norm(), 0.5 * f0.norm(), 1e-9);
  EXPECT_GT(fa.y(), 0) << "away from the expert";
  GuidanceParams bad = base;
  bad.fade = 0;
  EXPECT_NE(bad.validate().find("fade = 0 must be in (0, 1]"), std::string::npos) << bad.validate();
  bad = base;
  bad.amplify = 2;
  EXPECT_NE(bad.validate().find("amplify = 2"), std::string::npos) << bad.validate();
}

TEST(TrainingModes, GuidanceStifferThanTheDeviceIsRefused) {
  TrainingParams p;
  p.mode = TrainingModeKind::kPassiveGuidance;
  p.guidance.k_N_per_m = 500;
  DeviceLimits limits = limits_from_profile(*find_device_profile("touch"));
  auto dev = SimulatedDevice::create({wp(0, Eigen::Vector3d(0, 0, 2e-3))}, limits);
  ASSERT_TRUE(dev.ok());
  ModeRig rig(p, 2e-3, std::move(dev).value());
  EXPECT_NE(rig.error.find("guidance stiffness 500 N/m is above what 'simulated-hand' renders stably as guidance (160 N/m"),
            std::string::npos)
      << rig.error;
  EXPECT_NE(rig.error.find("lower k"), std::string::npos) << rig.error;
}

}  // namespace
}  // namespace dentar::haptics

namespace dentar::haptics {
namespace {

// Writes records as a session log file (the expert's recording, as `dentar live --record`
// would keep it).
void write_log(const std::string& path, const std::string& header, const std::vector<StepRecord>& rec) {
  LogWriterOptions o;
  o.ring_capacity = 1 << 13;
  o.fsync = false;
  auto w = SessionLogWriter::open(path, header, o);
  ASSERT_TRUE(w.ok()) << w.error();
  for (const auto& r : rec)
    while (!(*w)->push(r)) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  ASSERT_TRUE((*w)->close().ok());
}

// A session trained in mode 3 (the expert drills 0.2 mm into the enamel, waits while the
// student strays) is recorded, then replayed from its log alone: the header names the mode
// and the expert's recording, and the replay recomputes the expert's cut bit-exactly.
TEST(TrainingModes, ATrainedSessionReplaysBitExactly) {
  const fs::path dir = dentar::test::temp_dir("guidance_replay");
  const std::string expert_file = (dir / "expert.dlog").string(), student_file = (dir / "student.dlog").string();
  const auto rec = expert_recording(-0.2e-3);
  write_log(expert_file, R"({"format":"dentar-session","note":"expert"})", rec);
  const ExpertTrack tr = track_of(rec);
  TrainingParams p;
  p.mode = TrainingModeKind::kActiveFollowing;
  p.expert_file = expert_file;
  // The student follows 1 mm beside the expert's path, strays 6 mm at 1.2-1.5 s, comes back.
  std::vector<HandWaypoint> script;
  for (double t = 0; t <= 4.0; t += 0.05) {
    const double stray = t >= 1.2 && t < 1.5 ? 6e-3 : 1e-3;
    script.push_back(wp(t, expert_path(std::min(t, 3.5), -0.2e-3) + Eigen::Vector3d(0, stray, 0)));
  }
  volume::VoxelVolume vol = closed_loop::enamel_half_space().clone();
  const volume::BurSamples bur = std::move(volume::sample_bur(volume::BurParams::sphere(0.5), 2000)).value();
  auto mode = TrainingMode::create(p, tr);
  ASSERT_TRUE(mode.ok()) << mode.error();
  auto dev = hand_at(script);
  EngineConfig cfg;
  cfg.try_realtime = false;
  cfg.training = &*mode;
  std::uint64_t live_hash = 0;
  {
    volume::VoxelVolume probe_vol = vol.clone();
    auto probe = Engine::create(cfg, *dev, probe_vol, bur);
    ASSERT_TRUE(probe.ok()) << probe.error();
    LogWriterOptions o;
    o.fsync = false;
    auto w = SessionLogWriter::open(student_file, (*probe)->header_json(R"({"kind":"half-space"})"), o);
    ASSERT_TRUE(w.ok()) << w.error();
    auto eng = Engine::create(cfg, *dev, vol, bur, w->get());
    ASSERT_TRUE(eng.ok()) << eng.error();
    int waited = 0;
    for (int i = 0; i < 4000; ++i) {
      ASSERT_EQ((*eng)->run_steps(1), 1u);
      waited += (*eng)->snapshot().expert_waiting;
    }
    EXPECT_GT(waited, 100) << "the expert waited for the straying student";
    ASSERT_TRUE((*w)->close().ok());
    live_hash = vol.content_hash();
  }
  auto log = read_session_log(student_file);
  ASSERT_TRUE(log.ok()) << log.error();
  auto setup = parse_session_header(log->header_json);
  ASSERT_TRUE(setup.ok()) << setup.error();
  ASSERT_TRUE(setup->training.has_value());
  EXPECT_EQ(setup->training->params.mode, TrainingModeKind::kActiveFollowing);
  EXPECT_EQ(setup->training->params.expert_file, expert_file);
  volume::VoxelVolume again = closed_loop::enamel_half_space().clone();
  auto r = replay_session(*log, again);
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->volume_hash, live_hash);
  EXPECT_GT(r->metrics.removed_total_mm3, 0.01) << "the expert's cut, recomputed";
  EXPECT_NE(live_hash, closed_loop::enamel_half_space().content_hash());
  // Without its expert recording, or with another one, the replay refuses and says why.
  fs::rename(expert_file, dir / "moved.dlog");
  volume::VoxelVolume v2 = closed_loop::enamel_half_space().clone();
  auto missing = replay_session(*log, v2);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().find("the session was trained on " + expert_file), std::string::npos) << missing.error();
  auto other = rec;
  other[5].force_dev_N[0] += 0.01;
  write_log(expert_file, R"({"format":"dentar-session","note":"another"})", other);
  volume::VoxelVolume v3 = closed_loop::enamel_half_space().clone();
  auto wrong = replay_session(*log, v3);
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.error().find("is not the expert recording this session was trained on"), std::string::npos)
      << wrong.error();
}

}  // namespace
}  // namespace dentar::haptics
