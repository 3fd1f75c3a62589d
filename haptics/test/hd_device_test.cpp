// HdDevice against the stand-in libHD.so: open paths, pose and units,
// forces reaching the servo, and every fault (unplug, HD error codes, NaN,
// pose jump, late servo ticks, calibration, missing/wrong/old runtime).
#include "dentar/haptics/hd_device.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <new>
#include <limits>
#include <thread>

#include "dentar/haptics/engine.h"
#include "dentar/haptics/scripts.h"
#include "dentar/volume/procedural_tooth.h"
#include "standin_util.h"

#include "alloc_counter.h"  // counts this thread's heap allocations

namespace dentar::haptics {
namespace {

using standin::wait_for;

class HdStandin : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(lib.ok()) << "stand-in missing at " << standin::hd_path();
    reset = lib.fn<void (*)()>("standin_hd_reset");
    set_device = lib.fn<void (*)(const char*, const char*, const char*, unsigned, int)>("standin_hd_set_device");
    set_motion = lib.fn<void (*)(double, double, double, double, double)>("standin_hd_set_motion");
    set_buttons = lib.fn<void (*)(int)>("standin_hd_set_buttons");
    inject = lib.fn<void (*)(int, long, double)>("standin_hd_inject");
    ticks = lib.fn<long (*)()>("standin_hd_ticks");
    forces_fn = lib.fn<long (*)(double*, long)>("standin_hd_forces");
    force_enabled = lib.fn<int (*)()>("standin_hd_force_enabled");
    reset();
    opts.library = standin::hd_path();
    opts.stale_limit_s = 0.05;  // generous: the test machine is shared; stall tests lower it
  }
  void TearDown() override { reset(); }

  std::vector<Eigen::Vector3d> forces() const {
    const long n = forces_fn(nullptr, 0);
    std::vector<double> buf(static_cast<std::size_t>(3 * n));
    forces_fn(buf.data(), n);
    std::vector<Eigen::Vector3d> out;
    for (long i = 0; i < n; ++i) out.emplace_back(buf[3 * i], buf[3 * i + 1], buf[3 * i + 2]);
    return out;
  }
  std::unique_ptr<HdDevice> open_ok() {
    auto d = HdDevice::open(opts);
    EXPECT_TRUE(d.ok()) << d.error();
    return d.ok() ? std::move(d).value() : nullptr;
  }
  // Reads until the device reports a fault (or 2 s pass); returns whether it did.
  static bool read_until_fault(HdDevice& d, DeviceState& st) {
    return wait_for([&] { return !d.read(st) && st.fault; });
  }

  standin::Lib lib{standin::hd_path()};
  void (*reset)();
  void (*set_device)(const char*, const char*, const char*, unsigned, int);
  void (*set_motion)(double, double, double, double, double);
  void (*set_buttons)(int);
  void (*inject)(int, long, double);
  long (*ticks)();
  long (*forces_fn)(double*, long);
  int (*force_enabled)();
  DeviceOpenOptions opts;
};

TEST(HdRuntime, MissingLibraryIsAClearErrorNotACrash) {
  DeviceOpenOptions o;
  o.library = "/nonexistent/libHD.so";
  auto d = HdDevice::open(o);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.error().find("OpenHaptics runtime not found"), std::string::npos) << d.error();
  EXPECT_NE(d.error().find("DENTAR_HD_LIBRARY"), std::string::npos) << d.error();
  const RuntimeInfo r = probe_hd_runtime("/nonexistent/libHD.so");
  EXPECT_FALSE(r.present);
  EXPECT_NE(r.message.find("Install OpenHaptics"), std::string::npos) << r.message;
}

TEST(HdRuntime, WrongLibraryNamesTheMissingFunction) {
  DeviceOpenOptions o;
  o.library = standin::dhd_path();  // a real shared library, but not libHD
  auto d = HdDevice::open(o);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.error().find("has no hdInitDevice"), std::string::npos) << d.error();
  const RuntimeInfo r = probe_hd_runtime(standin::dhd_path());
  EXPECT_FALSE(r.present);
  EXPECT_NE(r.message.find("hdInitDevice"), std::string::npos);
}

TEST_F(HdStandin, ProbeFindsTheStandin) {
  const RuntimeInfo r = probe_hd_runtime(standin::hd_path());
  EXPECT_TRUE(r.present) << r.message;
  EXPECT_NE(r.path.find("libHD.so"), std::string::npos);
}

TEST_F(HdStandin, TooOldRuntimeIsRefused) {
  set_device("Touch", "S1", "2.0.1", 0x5000, 2);
  auto d = HdDevice::open(opts);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.error().find("too old"), std::string::npos) << d.error();
  // The refused device was released: a good runtime opens it again.
  set_device("Touch", "S1", "3.4.0", 0x5000, 2);
  EXPECT_TRUE(HdDevice::open(opts).ok());
}

TEST_F(HdStandin, InitFailureNamesTheErrorAndWhatToDo) {
  inject(6, 0, 0x0300);  // HD_DEVICE_FAULT at hdInitDevice
  auto d = HdDevice::open(opts);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.error().find("HD_DEVICE_FAULT"), std::string::npos) << d.error();
  EXPECT_NE(d.error().find("cable"), std::string::npos) << d.error();
}

TEST_F(HdStandin, SecondOpenSaysAnotherProgramHoldsIt) {
  auto a = open_ok();
  ASSERT_TRUE(a);
  auto b = HdDevice::open(opts);
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().find("another program"), std::string::npos) << b.error();
}

TEST_F(HdStandin, OpensByNameOrSerialAndRefusesAnUnknownOne) {
  opts.name_or_serial = "STANDIN-HD-0001";
  EXPECT_TRUE(HdDevice::open(opts).ok());
  opts.name_or_serial = "Default Device";
  EXPECT_TRUE(HdDevice::open(opts).ok());
  opts.name_or_serial = "NOPE-42";
  auto d = HdDevice::open(opts);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.error().find("NOPE-42"), std::string::npos) << d.error();
  EXPECT_NE(d.error().find("STANDIN-HD-0001"), std::string::npos) << d.error();
}

TEST_F(HdStandin, ProfileFollowsTheModelAndNeverExceedsTheDevice) {
  set_device("PHANTOM Omni", "S2", "3.4.0", 0x5000, 2);
  auto d = open_ok();
  ASSERT_TRUE(d);
  EXPECT_EQ(d->profile().id, "omni");
  EXPECT_EQ(d->info().model, "PHANTOM Omni");
  EXPECT_EQ(d->limits().max_force_N, 3.3);
  // The Omni profile says 700 N/m; the (stand-in) device reports 0.8 N/mm.
  EXPECT_EQ(d->limits().max_stiffness_N_per_m, 700.0);
  EXPECT_EQ(d->limits().max_damping_N_s_per_m, 5.0);
  EXPECT_EQ(d->limits().workspace_radius_m, 0.10);
  EXPECT_EQ(d->limits().validate(), "");
}

TEST_F(HdStandin, PoseVelocityAndButtonsInSIUnits) {
  set_motion(5, -20, 30, 10, 0.5);  // mm
  set_buttons(3);
  auto d = open_ok();
  ASSERT_TRUE(d);
  ASSERT_TRUE(wait_for([&] { return d->servo_ticks() > 20; }));
  DeviceState st;
  ASSERT_TRUE(d->read(st)) << d->status();
  const Eigen::Vector3d p = st.T_dev_sty.translation();
  EXPECT_NEAR((p - Eigen::Vector3d(5e-3, -20e-3, 30e-3)).norm(), 10e-3, 1e-9);
  EXPECT_NEAR(st.velocity_m_per_s.norm(), 10e-3 * 2 * M_PI * 0.5, 1e-9);
  EXPECT_EQ(st.buttons, kButtonPrimary | kButtonSecondary);
  EXPECT_TRUE(st.T_dev_sty.linear().isIdentity(1e-12));
  // Device time: seconds since open, advancing with the servo ticks.
  EXPECT_GT(st.time_s, 0.0);
  EXPECT_LT(st.time_s, 5.0);
  const double t1 = st.time_s;
  ASSERT_TRUE(wait_for([&] { return d->read(st) && st.time_s > t1 + 0.002; }));
  EXPECT_EQ(d->info().calibration, "ok");
  EXPECT_EQ(force_enabled(), 1);
  EXPECT_NE(d->status().find(": ok"), std::string::npos) << d->status();
}

TEST_F(HdStandin, ReadAndWriteDoNotAllocateEvenWhenFaulted) {
  auto d = open_ok();
  ASSERT_TRUE(d);
  DeviceState st;
  ASSERT_TRUE(wait_for([&] { return d->read(st); }));
  inject(4, ticks() + 2, 8.0);  // a jump: the fault path runs too
  const long before = dentar::test::this_thread_allocations();
  bool faulted = false;
  for (int i = 0; i < 2000; ++i) {
    faulted |= !d->read(st);
    d->write_force({0.5, 0, 0});
    if (i % 10 == 0) std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  EXPECT_EQ(dentar::test::this_thread_allocations() - before, 0);
  EXPECT_TRUE(faulted);
}

TEST_F(HdStandin, ForcesReachTheServoClampedAndZeroWhenStaleOrNaN) {
  auto d = open_ok();
  ASSERT_TRUE(d);
  DeviceState st;
  // Before the engine writes anything the servo sends zero.
  ASSERT_TRUE(wait_for([&] { return forces().size() > 5; }));
  for (const auto& f : forces()) EXPECT_EQ(f.norm(), 0.0);
  // Writes f every 0.5 ms until the servo's latest force passes `reached`
  // (or 10 s pass). Sized by what the servo shows, not by wall time: a loaded
  // machine under TSan can hold either thread off past the stale limit, and
  // the servo then rightly sends zero for a while.
  auto write_until = [&](const Eigen::Vector3d& f, auto reached) {
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; std::chrono::steady_clock::now() - t0 < std::chrono::seconds(10); ++i) {
      d->read(st);
      d->write_force(f);
      if (i % 20 == 19) {
        const auto fs = forces();
        if (!fs.empty() && reached(fs.back())) return true;
      }
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
    return false;
  };
  const Eigen::Vector3d f1(1.0, -0.5, 0.25);
  EXPECT_TRUE(write_until(f1, [&](const Eigen::Vector3d& f) { return (f - f1).norm() < 1e-12; }))
      << forces().back().transpose();
  // Above the Touch's 3.3 N: clamped to 3.3 N along the asked direction.
  EXPECT_TRUE(write_until({10.0, 0, 0}, [](const Eigen::Vector3d& f) {
    return std::abs(f.norm() - 3.3) < 1e-9 && f.x() > 0;
  })) << forces().back().transpose();
  auto fs = forces();
  for (const auto& f : fs) EXPECT_LE(f.norm(), 3.3 + 1e-9);
  // NaN asked: the servo gets zero, never the NaN.
  EXPECT_TRUE(write_until({std::numeric_limits<double>::quiet_NaN(), 0, 0},
                          [](const Eigen::Vector3d& f) { return f.norm() == 0.0; }));
  // The engine stops writing: after stale_limit_s the servo sends zero by itself.
  ASSERT_TRUE(write_until({1.0, 0, 0}, [](const Eigen::Vector3d& f) { return f.norm() > 0.5; }));
  EXPECT_TRUE(wait_for([&] { return forces().back().norm() == 0.0; }));  // 50 ms stale limit
  for (const auto& f : forces()) EXPECT_TRUE(f.allFinite());
}

TEST_F(HdStandin, UnplugGivesZeroForceAndAClearStatus) {
  auto d = open_ok();
  ASSERT_TRUE(d);
  DeviceState st;
  ASSERT_TRUE(wait_for([&] { d->write_force({1, 0, 0}); return d->read(st) && forces().size() > 10 && forces().back().norm() > 0.5; }));
  const long at = ticks() + 5;
  inject(1, at, 0);
  ASSERT_TRUE(read_until_fault(*d, st));
  d->write_force({1, 0, 0});  // the engine would send zero; even this must not get through
  EXPECT_NE(d->status().find("unplugged"), std::string::npos) << d->status();
  EXPECT_NE(d->status().find("HD_COMM_ERROR"), std::string::npos) << d->status();
  EXPECT_NE(d->status().find("cable"), std::string::npos) << d->status();
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const auto fs = forces();
  // Every tick from the first failing one on got zero from the servo itself.
  for (std::size_t i = static_cast<std::size_t>(at) + 1; i < fs.size(); ++i)
    EXPECT_EQ(fs[i].norm(), 0.0) << "tick " << i;
  EXPECT_FALSE(d->read(st));  // stays faulted while unplugged
}

TEST_F(HdStandin, RuntimeErrorFaultsThenRecovers) {
  opts.fault_clear_steps = 20;
  auto d = open_ok();
  ASSERT_TRUE(d);
  DeviceState st;
  ASSERT_TRUE(wait_for([&] { return d->read(st); }));
  inject(2, ticks() + 3, 0x0203);  // HD_EXCEEDED_MAX_VELOCITY once
  ASSERT_TRUE(read_until_fault(*d, st));
  EXPECT_EQ(d->faults().latest(), DeviceFault::kRuntimeError);
  EXPECT_NE(d->status().find("HD_EXCEEDED_MAX_VELOCITY"), std::string::npos) << d->status();
  // 20 good readings later it clears.
  ASSERT_TRUE(wait_for([&] { std::this_thread::sleep_for(std::chrono::microseconds(800)); return d->read(st); }));
  EXPECT_FALSE(st.fault);
}

TEST_F(HdStandin, NaNAndPoseJumpAreFaults) {
  auto d = open_ok();
  ASSERT_TRUE(d);
  DeviceState st;
  ASSERT_TRUE(wait_for([&] { return d->read(st); }));
  // NaN for one servo tick: the servo judges every sample and latches it
  // (session 21), so a reader held off by a loaded machine cannot miss it
  // (before, the NaN had to last 200 ticks for a reader under TSan to see it).
  inject(3, ticks() + 3, 1);
  ASSERT_TRUE(read_until_fault(*d, st));
  EXPECT_EQ(d->faults().latest(), DeviceFault::kNonFinite);
  EXPECT_NE(d->status().find("NaN"), std::string::npos) << d->status();
  // A jump is lasting (an offset), so it cannot be missed.
  ASSERT_TRUE(wait_for([&] { return d->read(st); }));
  inject(4, ticks() + 3, 8.0);  // +8 mm in one tick
  ASSERT_TRUE(read_until_fault(*d, st));
  EXPECT_EQ(d->faults().latest(), DeviceFault::kPoseJump);
  EXPECT_NEAR(d->faults().last_jump_m(), 8e-3, 0.2e-3);  // + the circle's motion in 1-2 ticks
  // The message gives the jump it measured (8 mm plus the motion of 1-2
  // ticks: 7.9-8.1 mm), not a fixed text.
  const std::string s = d->status();
  const auto at = s.find("pose jump of ");
  ASSERT_NE(at, std::string::npos) << s;
  const double said_mm = std::atof(s.c_str() + at + 13);
  EXPECT_NEAR(said_mm, 8.0, 0.25) << s;
  EXPECT_NE(s.find(" mm in one reading"), std::string::npos) << s;
}

// Session 21 (failed 1 in 100 under `stress -c 2` before): jumps are judged between the device's
// own samples, 1 ms apart, not between readings. A reader held off for 30 ms while the stylus
// moves at 0.31 m/s (a 10 mm circle at 5 Hz: >= 9 mm of chord between the readings) sees no
// jump; judged between readings it was a false 5 mm fault, and an 8 mm jump read 10 ticks late
// was measured as 7.7 mm.
TEST_F(HdStandin, AReaderHeldOffSeesNoJumpFromTheStylusMotion) {
  set_motion(0, 0, 0, 10, 5);
  auto d = open_ok();
  ASSERT_TRUE(d);
  DeviceState st;
  ASSERT_TRUE(wait_for([&] { return d->read(st); }));
  // Gaps with a real move of more than the 5 mm limit between two readings (the test's premise;
  // a loaded machine may also hold the servo off, or stall it past the stale limit: a stall is
  // another fault, and the gap then counts only if the stylus still moved > 5 mm).
  int big_gaps = 0;
  for (int i = 0; i < 40 && big_gaps < 5; ++i) {
    const Eigen::Vector3d before = st.T_dev_sty.translation();
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
    d->read(st);
    EXPECT_NE(d->faults().latest(), DeviceFault::kPoseJump) << d->status();
    if (!st.fault && (st.T_dev_sty.translation() - before).norm() > 5e-3) ++big_gaps;
    if (st.fault) wait_for([&] { return d->read(st); });  // a stall: wait until it clears
  }
  EXPECT_GE(big_gaps, 1) << "the stylus never moved > 5 mm between two readings";
  EXPECT_EQ(d->faults().last_jump_m(), 0.0) << d->status();
}

TEST_F(HdStandin, LateServoTickIsAStall) {
  opts.stale_limit_s = 0.005;
  auto d = open_ok();
  ASSERT_TRUE(d);
  DeviceState st;
  wait_for([&] { return d->read(st); });
  inject(5, ticks() + 3, 60.0);  // one tick 60 ms late
  ASSERT_TRUE(read_until_fault(*d, st));
  EXPECT_EQ(d->faults().latest(), DeviceFault::kStalled);
  EXPECT_NE(d->status().find("servo stalled"), std::string::npos) << d->status();
}

TEST_F(HdStandin, CalibrationAutomaticOrWaitsForTheInkwell) {
  set_device("Touch", "S3", "3.4.0", 0x5001, 2);  // needs update, auto style
  {
    auto d = open_ok();
    ASSERT_TRUE(d);
    EXPECT_EQ(d->info().calibration, "ok");
  }
  set_device("Touch", "S3", "3.4.0", 0x5002, 4);  // needs the inkwell
  auto d = open_ok();
  ASSERT_TRUE(d);
  EXPECT_NE(d->info().calibration.find("inkwell"), std::string::npos);
  DeviceState st;
  ASSERT_TRUE(read_until_fault(*d, st));
  EXPECT_EQ(d->faults().latest(), DeviceFault::kNotCalibrated);
  EXPECT_NE(d->status().find("inkwell"), std::string::npos) << d->status();
}

// The engine's real-time thread against the HD servo thread: forces flow,
// an unplug mid-run is zero force at once, flagged in the snapshot.
TEST_F(HdStandin, EngineThreadMeetsTheServoAndZerosOnUnplug) {
  set_motion(0, 80, 0, 5, 0.2);  // far from the tooth (free space)
  auto d = open_ok();
  ASSERT_TRUE(d);
  volume::MolarParams mp;
  mp.voxel_mm = 0.2;
  auto tooth = volume::make_molar(mp);
  ASSERT_TRUE(tooth.ok());
  auto bur = volume::sample_bur(volume::BurParams::sphere(0.5), 500);
  ASSERT_TRUE(bur.ok());
  EngineConfig cfg;
  cfg.try_realtime = false;
  cfg.T_tooth_dev = default_station().T_tooth_dev;
  auto e = Engine::create(cfg, *d, *tooth, *bur);
  ASSERT_TRUE(e.ok()) << e.error();
  ASSERT_TRUE((*e)->start().ok());
  // Forces flow with no fault. (A loaded machine can hold either thread off
  // past the 50 ms stale limit, a kStalled fault that clears by itself, so
  // wait for a clean state rather than sampling one instant.)
  ASSERT_TRUE(wait_for([&] {
    const auto s = (*e)->snapshot();
    return s.step > 100 && !s.fault;
  }));
  ASSERT_TRUE(wait_for([&] { return !forces().empty(); }));
  inject(1, ticks() + 5, 0);
  ASSERT_TRUE(wait_for([&] { return (*e)->snapshot().fault != 0 && d->faults().latest() == DeviceFault::kUnplugged; }));
  (*e)->stop();
  EXPECT_GT((*e)->stats().device_faults, 0u);
  EXPECT_EQ(forces().back().norm(), 0.0);
}

}  // namespace
}  // namespace dentar::haptics
