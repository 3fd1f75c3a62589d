// DhdDevice against the stand-in libdhd.so: open paths, profile by system
// type, forces, and every fault (unplug, error codes, NaN, pose jump, late
// calls, not initialised, no device, missing/wrong/old runtime).
#include "dentar/haptics/dhd_device.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "standin_util.h"

namespace dentar::haptics {
namespace {

class DhdStandin : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(lib.ok()) << "stand-in missing at " << standin::dhd_path();
    reset = lib.fn<void (*)()>("standin_dhd_reset");
    set_device = lib.fn<void (*)(int, const char*, int, int, int)>("standin_dhd_set_device");
    set_buttons = lib.fn<void (*)(unsigned)>("standin_dhd_set_buttons");
    inject = lib.fn<void (*)(int, long, double)>("standin_dhd_inject");
    forces_fn = lib.fn<long (*)(double*, long)>("standin_dhd_forces");
    force_enabled = lib.fn<int (*)()>("standin_dhd_force_enabled");
    reset();
    opts.library = standin::dhd_path();
    opts.stale_limit_s = 0.05;
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
  std::unique_ptr<DhdDevice> open_ok() {
    auto d = DhdDevice::open(opts);
    EXPECT_TRUE(d.ok()) << d.error();
    return d.ok() ? std::move(d).value() : nullptr;
  }
  // Engine-like steps: read, then write `f` (zero when the read faulted, as the engine does).
  int steps_until_fault(DhdDevice& d, const Eigen::Vector3d& f, int max_steps) {
    DeviceState st;
    for (int i = 0; i < max_steps; ++i) {
      ++calls;  // one dhdGetPosition (one stand-in tick) per read
      const bool ok = d.read(st);
      d.write_force(ok ? f : Eigen::Vector3d::Zero());
      if (!ok && st.fault) return i;
    }
    return -1;
  }

  bool read(DhdDevice& d, DeviceState& st) {
    ++calls;
    return d.read(st);
  }

  long calls = 0;  // reads made so far = the stand-in's tick
  standin::Lib lib{standin::dhd_path()};
  void (*reset)();
  void (*set_device)(int, const char*, int, int, int);
  void (*set_buttons)(unsigned);
  void (*inject)(int, long, double);
  long (*forces_fn)(double*, long);
  int (*force_enabled)();
  DeviceOpenOptions opts;
};

TEST(DhdRuntime, MissingLibraryIsAClearError) {
  DeviceOpenOptions o;
  o.library = "/nonexistent/libdhd.so";
  auto d = DhdDevice::open(o);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.error().find("Force Dimension runtime not found"), std::string::npos) << d.error();
  EXPECT_NE(d.error().find("DENTAR_DHD_LIBRARY"), std::string::npos) << d.error();
  EXPECT_FALSE(probe_dhd_runtime("/nonexistent/libdhd.so").present);
}

TEST(DhdRuntime, WrongLibraryNamesTheMissingFunction) {
  DeviceOpenOptions o;
  o.library = standin::hd_path();
  auto d = DhdDevice::open(o);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.error().find("has no dhdGetDeviceCount"), std::string::npos) << d.error();
}

TEST_F(DhdStandin, ProbeReportsTheSdkVersion) {
  const RuntimeInfo r = probe_dhd_runtime(standin::dhd_path());
  EXPECT_TRUE(r.present) << r.message;
  EXPECT_EQ(r.version, "3.7.2-1234");
  set_device(33, "omega.3", 1, 2, 1);
  const RuntimeInfo old = probe_dhd_runtime(standin::dhd_path());
  EXPECT_FALSE(old.present);
  EXPECT_NE(old.message.find("too old"), std::string::npos) << old.message;
  auto d = DhdDevice::open(opts);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.error().find("too old"), std::string::npos) << d.error();
}

TEST_F(DhdStandin, NoDeviceSaysWhatToCheck) {
  inject(6, 0, 0);
  auto d = DhdDevice::open(opts);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.error().find("no Force Dimension device found"), std::string::npos) << d.error();
  EXPECT_NE(d.error().find("70-dentar.rules"), std::string::npos) << d.error();
  std::string why;
  EXPECT_TRUE(DhdDevice::list(standin::dhd_path(), why).empty());
  EXPECT_NE(why.find("sees no device"), std::string::npos) << why;
}

TEST_F(DhdStandin, ProfileFromSystemTypeAndOpenBySerialOrName) {
  set_device(60, "Falcon", 777, 3, 1);
  opts.name_or_serial = "777";
  auto d = open_ok();
  ASSERT_TRUE(d);
  EXPECT_EQ(d->profile().id, "falcon");
  EXPECT_EQ(d->limits().max_force_N, 8.0);
  EXPECT_EQ(d->limits().max_stiffness_N_per_m, 3000.0);
  EXPECT_EQ(d->limits().max_damping_N_s_per_m, 20.0);
  EXPECT_EQ(d->limits().workspace_radius_m, 0.04);
  EXPECT_EQ(d->info().serial, "777");
  EXPECT_EQ(d->info().calibration, "ok");
  EXPECT_EQ(force_enabled(), 1);
  d.reset();
  EXPECT_EQ(force_enabled(), 0);  // closing turns forces off
  opts.name_or_serial = "Falcon";
  EXPECT_TRUE(DhdDevice::open(opts).ok());
  opts.name_or_serial = "778";
  auto none = DhdDevice::open(opts);
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.error().find("'778'"), std::string::npos) << none.error();
  std::string why;
  const auto l = DhdDevice::list(standin::dhd_path(), why);
  ASSERT_EQ(l.size(), 1u);
  EXPECT_NE(l[0].find("Falcon, serial 777, profile falcon, calibration ok"), std::string::npos) << l[0];
}

TEST_F(DhdStandin, NotInitialisedIsRefusedUnlessAllowed) {
  set_device(104, "sigma.7", 5, 3, 0);
  auto d = DhdDevice::open(opts);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.error().find("autoinit"), std::string::npos) << d.error();
  opts.allow_uncalibrated = true;
  auto ok = open_ok();
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->profile().id, "sigma");
  EXPECT_EQ(ok->info().calibration, "not initialised");
}

TEST_F(DhdStandin, PoseButtonsAndForces) {
  set_buttons(1);
  auto d = open_ok();
  ASSERT_TRUE(d);
  DeviceState st;
  ASSERT_TRUE(d->read(st)) << d->status();
  EXPECT_NEAR(st.T_dev_sty.translation().norm(), 0.01, 1e-12);  // the circle, in m
  EXPECT_NEAR(st.velocity_m_per_s.norm(), 0.01 * M_PI, 1e-12);
  EXPECT_EQ(st.buttons, kButtonPrimary);
  EXPECT_GE(st.time_s, 0.0);  // seconds since open
  EXPECT_LT(st.time_s, 5.0);
  d->write_force({1, 2, 3});
  d->write_force({40, 0, 0});  // above the omega's 12 N
  d->write_force({std::numeric_limits<double>::quiet_NaN(), 0, 0});
  const auto fs = forces();
  ASSERT_GE(fs.size(), 3u);
  EXPECT_EQ(fs[fs.size() - 3], Eigen::Vector3d(1, 2, 3));
  EXPECT_NEAR(fs[fs.size() - 2].norm(), 12.0, 1e-12);
  EXPECT_EQ(fs.back().norm(), 0.0);
}

TEST_F(DhdStandin, UnplugIsZeroForceAtOnce) {
  auto d = open_ok();
  ASSERT_TRUE(d);
  inject(1, 50, 0);
  EXPECT_EQ(steps_until_fault(*d, {1, 0, 0}, 200), 50);  // the very call that failed
  EXPECT_NE(d->status().find("unplugged"), std::string::npos) << d->status();
  EXPECT_NE(d->status().find("USB cable"), std::string::npos) << d->status();
  d->write_force({1, 0, 0});
  // forces()[0] is the zero sent at open, [k] step k-1's: steps 0..49 only;
  // nothing (in particular no nonzero force) reached the device after the unplug.
  const auto fs = forces();
  EXPECT_EQ(fs.size(), 51u);
}

TEST_F(DhdStandin, ErrorCodeNaNJumpAndLateCallAreFaults) {
  opts.fault_clear_steps = 10;
  auto d = open_ok();
  ASSERT_TRUE(d);
  inject(2, calls + 20, 12);  // DHD_ERROR_DEVICE_NOT_READY once
  EXPECT_EQ(steps_until_fault(*d, {1, 0, 0}, 100), 20);
  EXPECT_EQ(d->faults().latest(), DeviceFault::kRuntimeError);
  EXPECT_NE(d->status().find("DHD error 12"), std::string::npos) << d->status();
  EXPECT_NE(d->status().find("not ready"), std::string::npos) << d->status();
  // Ten good steps later forces flow again.
  DeviceState st;
  int good = 0;
  for (int i = 0; i < 20; ++i) good += read(*d, st) ? 1 : 0;
  EXPECT_EQ(good, 11);  // the 10th good reading clears the fault

  inject(3, calls + 20, 0);  // NaN
  EXPECT_EQ(steps_until_fault(*d, {1, 0, 0}, 100), 20);
  EXPECT_EQ(d->faults().latest(), DeviceFault::kNonFinite);
  for (int i = 0; i < 20; ++i) read(*d, st);

  inject(4, calls + 20, 0.006);  // +6 mm
  EXPECT_EQ(steps_until_fault(*d, {1, 0, 0}, 100), 20);
  EXPECT_EQ(d->faults().latest(), DeviceFault::kPoseJump);
  EXPECT_NE(d->status().find("pose jump of 6.0 mm"), std::string::npos) << d->status();
  for (int i = 0; i < 20; ++i) read(*d, st);

  inject(5, calls + 20, 80.0);  // that call takes 80 ms (> 50 ms limit)
  EXPECT_EQ(steps_until_fault(*d, {1, 0, 0}, 100), 20);
  EXPECT_EQ(d->faults().latest(), DeviceFault::kStalled);
  for (const auto& f : forces()) EXPECT_TRUE(f.allFinite());
}

}  // namespace
}  // namespace dentar::haptics
