// LiveOptions checks and the display-path choice by renderer name.
#include <gtest/gtest.h>

#include "dentar/live/live_app.h"

namespace dentar::live {
namespace {

TEST(LiveOptions, DisplayPathAutoGlOrCpuAndNothingElse) {
  LiveOptions o;
  EXPECT_EQ(o.display_path, "auto");
  EXPECT_EQ(o.validate(), "");
  for (const char* p : {"gl", "cpu"}) {
    o.display_path = p;
    EXPECT_EQ(o.validate(), "") << p;
  }
  o.display_path = "gpu";
  EXPECT_NE(o.validate().find("must be auto, gl or cpu"), std::string::npos) << o.validate();
}

TEST(LiveOptions, FrameLimitMustNotBeNegative) {
  LiveOptions o;
  o.frames = 30;
  EXPECT_EQ(o.validate(), "");
  o.frames = -1;
  EXPECT_NE(o.validate().find("frames = -1"), std::string::npos) << o.validate();
}

TEST(HudDrillLine, DrillAndPedalAgreeOrTheLineSaysWhy) {
  // The pedal drives the drill: the two agree, nothing to explain.
  EXPECT_EQ(hud_drill_line(true, false, "pressed", true, false, "pen"), "drill: ON   pedal: pressed");
  EXPECT_EQ(hud_drill_line(false, false, "released", false, false, "pen"), "drill: off   pedal: released");
  // The simulated hand drills without the pedal: said beside "released".
  const std::string sim = hud_drill_line(true, true, "released", false, true, "sim");
  EXPECT_NE(sim.find("drill: ON  (contact)   pedal: released"), std::string::npos) << sim;
  EXPECT_NE(sim.find("the simulated hand drills without the pedal"), std::string::npos) << sim;
  const std::string rep = hud_drill_line(true, false, "released", false, true, "replay:out/clip/session.dlog");
  EXPECT_NE(rep.find("recorded pedal"), std::string::npos) << rep;
  // The simulated hand resting: nothing to explain.
  EXPECT_EQ(hud_drill_line(false, false, "released", false, true, "sim"), "drill: off   pedal: released");
}

TEST(SoftwareRenderer, MesaSoftwareRasterisersAndOthersByName) {
  // GL_RENDERER strings as drivers report them.
  EXPECT_TRUE(software_renderer("llvmpipe (LLVM 15.0.6, 256 bits)"));
  EXPECT_TRUE(software_renderer("softpipe"));
  EXPECT_TRUE(software_renderer("Google SwiftShader"));
  EXPECT_TRUE(software_renderer("ANGLE (Google, Vulkan 1.3.0 (SwiftShader Device (Subzero)), SwiftShader driver)"));
  EXPECT_TRUE(software_renderer("Microsoft Basic Render Driver"));
  EXPECT_FALSE(software_renderer("Mesa Intel(R) UHD Graphics 620 (KBL GT2)"));
  EXPECT_FALSE(software_renderer("AMD Radeon RX 6600 (navi23, LLVM 15.0.6, DRM 3.49, 6.1.0-13-amd64)"));
  EXPECT_FALSE(software_renderer("NVIDIA GeForce RTX 3060/PCIe/SSE2"));
  EXPECT_FALSE(software_renderer("Mali-G610 (Panfrost)"));
  EXPECT_FALSE(software_renderer(""));
}

}  // namespace
}  // namespace dentar::live
