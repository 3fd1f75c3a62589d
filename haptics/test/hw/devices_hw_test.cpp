// Hardware tests (ctest label "hw", excluded by default): run at a station
// with the devices plugged in and assets/udev/70-dentar.rules installed.
//   ctest --test-dir build -L hw --output-on-failure
// A runtime or pedal that is absent skips its test with the reason.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <thread>

#include "dentar/haptics/dhd_device.h"
#include "dentar/haptics/hd_device.h"
#include "dentar/haptics/open_device.h"

namespace dentar::haptics {
namespace {

void read_one_second(HapticDevice& d) {
  DeviceState st;
  int ok = 0;
  for (int i = 0; i < 1000; ++i) {
    if (d.read(st)) {
      ++ok;
      ASSERT_TRUE(st.T_dev_sty.matrix().allFinite());
      // Within the workspace sphere, with a 50% margin for the reported origin.
      EXPECT_LT(st.T_dev_sty.translation().norm(), 1.5 * d.limits().workspace_radius_m + 0.05);
    }
    d.write_force(Eigen::Vector3d::Zero());
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_GT(ok, 900) << d.status();
}

TEST(DevicesHw, OpenHapticsDevice) {
  const RuntimeInfo r = probe_hd_runtime();
  if (!r.present) GTEST_SKIP() << r.message;
  auto d = HdDevice::open({});
  ASSERT_TRUE(d.ok()) << d.error();
  std::printf("%s: %s, calibration %s\n", (*d)->name().c_str(), (*d)->info().runtime_version.c_str(),
              (*d)->info().calibration.c_str());
  read_one_second(**d);
}

TEST(DevicesHw, ForceDimensionDevice) {
  const RuntimeInfo r = probe_dhd_runtime();
  if (!r.present) GTEST_SKIP() << r.message;
  auto d = DhdDevice::open({});
  ASSERT_TRUE(d.ok()) << d.error();
  std::printf("%s: SDK %s, calibration %s\n", (*d)->name().c_str(),
              (*d)->info().runtime_version.c_str(), (*d)->info().calibration.c_str());
  read_one_second(**d);
}

TEST(DevicesHw, FootPedalPressAndRelease) {
  auto p = open_pedal("auto");
  if (!p.ok()) GTEST_SKIP() << p.error();
  std::printf("%s: press the pedal once within 10 s\n", (*p)->status().c_str());
  std::fflush(stdout);
  const auto t0 = std::chrono::steady_clock::now();
  bool pressed = false, released = false;
  while (std::chrono::steady_clock::now() - t0 < std::chrono::seconds(10) && !released) {
    if ((*p)->pressed()) pressed = true;
    if (pressed && !(*p)->pressed()) released = true;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_TRUE(pressed && released) << (*p)->status();
}

}  // namespace
}  // namespace dentar::haptics
