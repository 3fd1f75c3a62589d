// The factories the live trainer calls, and `dentar devices`, against the
// stand-in runtimes.
#include "dentar/haptics/open_device.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "dentar/haptics/dhd_device.h"
#include "dentar/haptics/evdev_pedal.h"
#include "dentar/haptics/hd_device.h"
#include "standin_util.h"
#include "testutil.h"

namespace dentar::haptics {
namespace {

class OpenDevice : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(hd.ok() && dhd.ok());
    hd_reset = hd.fn<void (*)()>("standin_hd_reset");
    hd_set = hd.fn<void (*)(const char*, const char*, const char*, unsigned, int)>("standin_hd_set_device");
    dhd_reset = dhd.fn<void (*)()>("standin_dhd_reset");
    dhd_set = dhd.fn<void (*)(int, const char*, int, int, int)>("standin_dhd_set_device");
    hd_reset();
    dhd_reset();
  }
  void TearDown() override {
    hd_reset();
    dhd_reset();
  }
  DeviceOpenOptions hd_opts() const {
    DeviceOpenOptions o;
    o.library = standin::hd_path();
    o.stale_limit_s = 0.05;
    return o;
  }
  DeviceOpenOptions dhd_opts() const {
    DeviceOpenOptions o;
    o.library = standin::dhd_path();
    return o;
  }
  standin::Lib hd{standin::hd_path()}, dhd{standin::dhd_path()};
  void (*hd_reset)();
  void (*hd_set)(const char*, const char*, const char*, unsigned, int);
  void (*dhd_reset)();
  void (*dhd_set)(int, const char*, int, int, int);
};

TEST_F(OpenDevice, KindsOpenTheRightBackendAndProfile) {
  {
    auto t = open_haptic_device("touch", hd_opts());
    ASSERT_TRUE(t.ok()) << t.error();
    EXPECT_EQ((*t)->limits().max_stiffness_N_per_m, 400.0);
    EXPECT_NE((*t)->name().find("HD Touch"), std::string::npos);
  }
  EXPECT_TRUE(open_haptic_device("hd", hd_opts()).ok());
  {
    auto o = open_haptic_device("omega", dhd_opts());
    ASSERT_TRUE(o.ok()) << o.error();
    EXPECT_EQ((*o)->limits().max_force_N, 12.0);
  }
  dhd_set(60, "Falcon", 9, 3, 1);
  auto f = open_haptic_device("dhd", dhd_opts());
  ASSERT_TRUE(f.ok()) << f.error();
  EXPECT_EQ((*f)->limits().max_force_N, 8.0);
}

TEST_F(OpenDevice, AProfileThatContradictsTheDeviceIsRefused) {
  hd_set("PHANTOM Omni", "S9", "3.4.0", 0x5000, 2);
  auto t = open_haptic_device("touch", hd_opts());
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.error().find("'PHANTOM Omni'"), std::string::npos) << t.error();
  EXPECT_NE(t.error().find("--device omni"), std::string::npos) << t.error();
  // The refused device was closed again: the right kind opens it.
  EXPECT_TRUE(open_haptic_device("omni", hd_opts()).ok());
  // A DHD profile on the HD backend is refused as well.
  auto x = open_haptic_device("falcon", hd_opts());
  EXPECT_FALSE(x.ok());
}

TEST_F(OpenDevice, UnknownKindListsTheKinds) {
  auto d = open_haptic_device("phantasm", hd_opts());
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.error().find("touch|omni"), std::string::npos) << d.error();
  EXPECT_NE(d.error().find("|hd|dhd"), std::string::npos) << d.error();
}

TEST_F(OpenDevice, PedalSpecsAreParsedWithClearErrors) {
  auto bad = open_pedal("usb:05f3");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("VID:PID"), std::string::npos) << bad.error();
  bad = open_pedal("usb:0c45:7403");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("--pedal pcsensor"), std::string::npos) << bad.error();
  bad = open_pedal("evdev:/dev/input/event999:KEY_NOPE");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("KEY_NOPE"), std::string::npos) << bad.error();
  bad = open_pedal("evdev:/dev/input/event999");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("event999"), std::string::npos) << bad.error();
  bad = open_pedal("footswitch9000");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("usb:VID:PID"), std::string::npos) << bad.error();
  // No pedal on this machine: auto says which ones it knows.
  if (find_event_node(0x0c45, 0x7403).empty()) {
    auto a = open_pedal("auto");
    if (!a.ok()) {
      EXPECT_NE(a.error().find("05f3:00ff"), std::string::npos) << a.error();
      EXPECT_NE(a.error().find("0c45:7403"), std::string::npos) << a.error();
    }
  }
}

TEST_F(OpenDevice, ProbeReportsRuntimesDevicesAndAbsences) {
  DeviceReport r = probe_devices(standin::hd_path(), standin::dhd_path());
  ASSERT_EQ(r.runtimes.size(), 2u);
  EXPECT_TRUE(r.runtimes[0].present) << r.runtimes[0].message;
  EXPECT_TRUE(r.runtimes[1].present) << r.runtimes[1].message;
  EXPECT_EQ(r.runtimes[1].version, "3.7.2-1234");
  ASSERT_EQ(r.haptic_devices.size(), 2u);
  EXPECT_NE(r.haptic_devices[0].find("Touch, serial STANDIN-HD-0001"), std::string::npos) << r.haptic_devices[0];
  EXPECT_NE(r.haptic_devices[0].find("calibration ok"), std::string::npos) << r.haptic_devices[0];
  EXPECT_NE(r.haptic_devices[1].find("omega.3, serial 12345"), std::string::npos) << r.haptic_devices[1];
  // Without the runtimes: every absence has a reason.
  r = probe_devices("/nonexistent/libHD.so", "/nonexistent/libdhd.so");
  EXPECT_FALSE(r.runtimes[0].present);
  EXPECT_TRUE(r.haptic_devices.empty());
  ASSERT_EQ(r.haptic_absent.size(), 2u);
  EXPECT_NE(r.haptic_absent[0].find("no runtime"), std::string::npos) << r.haptic_absent[0];
  EXPECT_TRUE(!r.pedals.empty() || !r.pedal_absent.empty());
}

// The command line, run as a user would, with the stand-ins on the loader path.
TEST(DevicesCli, ListsTheStandinsAndExplainsAbsences) {
  if (!std::filesystem::exists(DENTAR_BINARY)) GTEST_SKIP() << DENTAR_BINARY << " not built";
  const auto r = test::run_command("LD_LIBRARY_PATH=" + std::string(DENTAR_STANDIN_DIR) + " " +
                                   DENTAR_BINARY + " devices --profiles 2>&1");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("OpenHaptics HD: found"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("HD \"Default Device\": Touch"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("DHD #0: omega.3"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("Foot pedals:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("falcon"), std::string::npos) << r.out;  // the profile table
  const auto none = test::run_command(std::string(DENTAR_BINARY) +
                                      " devices --hd-library /nonexistent/libHD.so --json 2>&1");
  EXPECT_EQ(none.code, 0) << none.out;
  EXPECT_NE(none.out.find("\"present\": false"), std::string::npos) << none.out;
  const auto bad = test::run_command(std::string(DENTAR_BINARY) + " devices --bogus 2>&1");
  EXPECT_EQ(bad.code, 2) << bad.out;
  // The default station (issue 24) puts the workspace centre 28 mm above the tooth: every
  // profile reaches it, the Touch and the Falcon included.
  const auto reach = test::run_command(std::string(DENTAR_BINARY) +
                                       " devices --no-open --station assets/station_default.json 2>&1");
  EXPECT_EQ(reach.code, 0) << reach.out;
  EXPECT_NE(reach.out.find("touch     OK  3D Systems Touch reaches the whole crown"), std::string::npos) << reach.out;
  EXPECT_NE(reach.out.find("falcon    OK"), std::string::npos) << reach.out;
  EXPECT_EQ(reach.out.find(" NO "), std::string::npos) << reach.out;
  // The built-in box station by name.
  const auto box = test::run_command(std::string(DENTAR_BINARY) + " devices --no-open --station box 2>&1");
  EXPECT_EQ(box.code, 0) << box.out;
  EXPECT_NE(box.out.find("falcon    OK"), std::string::npos) << box.out;
  const auto nofile = test::run_command(std::string(DENTAR_BINARY) +
                                        " devices --no-open --station /nonexistent.json 2>&1");
  EXPECT_EQ(nofile.code, 2) << nofile.out;
  EXPECT_NE(nofile.out.find("/nonexistent.json"), std::string::npos) << nofile.out;
}

}  // namespace
}  // namespace dentar::haptics
