// LiveOptions checks and the display-path choice by renderer name.
#include <gtest/gtest.h>

#include <cmath>

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

// Session 21: the CPU display path's YUYV handling is an option (was DENTAR_KEEP_YUYV): keep by
// default, convert as the A/B arm, anything else refused naming the value.
TEST(LiveOptions, CpuDisplayYuyvKeepOrConvert) {
  LiveOptions o;
  EXPECT_EQ(o.cpu_display_yuyv, "keep");
  EXPECT_EQ(o.validate(), "");
  o.cpu_display_yuyv = "convert";
  EXPECT_EQ(o.validate(), "");
  o.cpu_display_yuyv = "0";
  EXPECT_NE(o.validate().find("cpu_display_yuyv = \"0\" must be keep or convert"), std::string::npos) << o.validate();
}

// Session 22: the headset view's camera textures and the right camera's CPUs, bad values refused by name.
TEST(LiveOptions, DisplayTextureAndCaptureRightCpu) {
  LiveOptions o;
  EXPECT_EQ(o.display_texture, "auto");
  EXPECT_EQ(o.capture_right_cpu, "engine");
  for (const char* t : {"auto", "full", "half"}) {
    o.display_texture = t;
    EXPECT_EQ(o.validate(), "") << t;
  }
  o.display_texture = "quarter";
  EXPECT_NE(o.validate().find("display_texture = \"quarter\" must be auto, full or half"), std::string::npos)
      << o.validate();
  o.display_texture = "auto";
  for (const char* c : {"engine", "frame", "any"}) {
    o.capture_right_cpu = c;
    EXPECT_EQ(o.validate(), "") << c;
  }
  o.capture_right_cpu = "1";
  EXPECT_NE(o.validate().find("capture_right_cpu = \"1\" must be any, engine or frame"), std::string::npos)
      << o.validate();
}

// Issue 28: two kinds of stereo head, not both at once; the right eye's stall hook needs it.
// Issue 28 session 18: the headset's pre-warp pass and its grid's cell size.
TEST(LiveOptions, WarpPassAndCellSize) {
  LiveOptions o;
  EXPECT_EQ(o.warp_pass, "exact");
  for (const char* p : {"exact", "mesh", "full", "lut"}) {
    o.warp_pass = p;
    EXPECT_EQ(o.validate(), "") << p;
  }
  o.warp_pass = "fast";
  EXPECT_NE(o.validate().find("warp_pass = \"fast\" must be exact, mesh, full or lut"), std::string::npos) << o.validate();
  o.warp_pass = "exact";
  o.warp_cell_px = 3;
  EXPECT_NE(o.validate().find("warp_cell_px = 3 must be in 4..128"), std::string::npos) << o.validate();
  o.warp_cell_px = 16;
  // Session 19: the idle redraw's period.
  EXPECT_EQ(o.idle_redraw_ms, 100);
  o.idle_redraw_ms = 0;
  EXPECT_EQ(o.validate(), "");
  for (const double bad : {-1.0, 1500.0, std::nan("")}) {
    o.idle_redraw_ms = bad;
    EXPECT_NE(o.validate().find("idle_redraw_ms = "), std::string::npos) << bad;
  }
}

TEST(LiveOptions, StereoIsTwoCamerasOrOneSideBySideNotBoth) {
  LiveOptions o;
  EXPECT_EQ(o.validate(), "");
  o.camera_right = "camera:1";
  EXPECT_EQ(o.validate(), "");
  o.side_by_side = true;
  EXPECT_NE(o.validate().find("give one"), std::string::npos) << o.validate();
  o.camera_right.clear();
  EXPECT_EQ(o.validate(), "");
  o.side_by_side = false;
  o.stall_right_after_frames = 5;
  EXPECT_NE(o.validate().find("needs camera_right"), std::string::npos) << o.validate();
}

TEST(LiveOptions, FrameLimitMustNotBeNegative) {
  LiveOptions o;
  o.frames = 30;
  EXPECT_EQ(o.validate(), "");
  o.frames = -1;
  EXPECT_NE(o.validate().find("frames = -1"), std::string::npos) << o.validate();
}

// A lesson needs a mode 1..5 and names its own exercise; a mode needs a lesson; a lesson is
// trained with the simulated student, the pen or a device (not a replayed log, not "none").
TEST(LiveOptions, LessonNeedsAModeAndAStudentsStylus) {
  LiveOptions o;
  o.lesson = "builtin:molar_access_opening";
  EXPECT_NE(o.validate().find("--lesson needs --mode 1..5"), std::string::npos) << o.validate();
  for (int m = 1; m <= 5; ++m) {
    o.lesson_mode = m;
    EXPECT_EQ(o.validate(), "") << m;
  }
  o.lesson_mode = 6;
  EXPECT_NE(o.validate().find("--mode 1..5"), std::string::npos) << o.validate();
  o.lesson_mode = 2;
  o.exercise = "molar_access_opening";
  EXPECT_NE(o.validate().find("the lesson names its exercise"), std::string::npos) << o.validate();
  o.exercise.clear();
  o.stylus = "pen";
  EXPECT_EQ(o.validate(), "");
  for (const char* s : {"none", "replay:x.dlog"}) {
    o.stylus = s;
    EXPECT_NE(o.validate().find("a lesson is trained with --stylus sim"), std::string::npos) << s << ": " << o.validate();
  }
  LiveOptions m;
  m.lesson_mode = 3;
  EXPECT_NE(m.validate().find("--mode 3 needs --lesson"), std::string::npos) << m.validate();
}

// The tooth a live run drills: the molar (the bytes every earlier run wrote in its header)
// without an exercise or with a molar exercise, the incisor for the incisor's exercise, both
// at the station's voxel size; a replayed log's own tooth, refused under an exercise for another.
TEST(LiveTooth, FollowsTheExerciseAndTheReplayedLog) {
  auto t = live_tooth_json("", "", 0.1);
  ASSERT_TRUE(t.ok()) << t.error();
  EXPECT_EQ(*t, R"({"kind":"molar","voxel_mm":0.1})");
  t = live_tooth_json("molar_access_opening", "", 0.1);
  ASSERT_TRUE(t.ok()) << t.error();
  EXPECT_EQ(*t, R"({"kind":"molar","voxel_mm":0.1})");
  t = live_tooth_json("incisor_partial_crown", "", 0.15);
  ASSERT_TRUE(t.ok()) << t.error();
  EXPECT_EQ(*t, R"({"kind":"incisor","voxel_mm":0.15})");
  const std::string log_incisor = R"({"kind":"incisor","voxel_mm":0.2})";
  t = live_tooth_json("", log_incisor, 0.1);
  ASSERT_TRUE(t.ok()) << t.error();
  EXPECT_EQ(*t, log_incisor);
  t = live_tooth_json("incisor_partial_crown", log_incisor, 0.1);
  ASSERT_TRUE(t.ok()) << t.error();
  EXPECT_EQ(*t, log_incisor);
  t = live_tooth_json("molar_class1_cavity", log_incisor, 0.1);
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.error().find("molar_class1_cavity"), std::string::npos) << t.error();
  EXPECT_NE(t.error().find("is for a molar"), std::string::npos) << t.error();
  EXPECT_NE(t.error().find(log_incisor), std::string::npos) << t.error();
  t = live_tooth_json("no_such_exercise", "", 0.1);
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.error().find("--exercise no_such_exercise"), std::string::npos) << t.error();
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

TEST(HudSoundLine, OnMutedOrNoDevice) {
  EXPECT_EQ(hud_sound_line(true, true, false, "volume 70 %"), "sound: on (volume 70 %)");
  EXPECT_EQ(hud_sound_line(true, true, false, ""), "sound: on");
  EXPECT_EQ(hud_sound_line(true, false, false, "volume 70 %"), "sound: no device (silent)");
  EXPECT_EQ(hud_sound_line(false, false, true, ""), "sound: muted");
  EXPECT_EQ(hud_sound_line(false, false, false, ""), "") << "no sound hook (tests, tools without sound): no line";
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
// Issue 28: the passthrough viewer shows the camera without AR, so it records nothing and
// trains no lesson; the wake-up latency hold is -1 (off) or a latency in microseconds.
TEST(LiveOptions, PassthroughRecordsNothingAndWakeLatencyInRange) {
  LiveOptions o;
  o.passthrough = true;
  EXPECT_EQ(o.validate(), "");
  o.record_dir = "out/rec";
  EXPECT_NE(o.validate().find("leave out --record"), std::string::npos) << o.validate();
  o.record_dir.clear();
  o.lesson = "builtin:molar_class1_cavity";
  o.lesson_mode = 1;
  EXPECT_NE(o.validate().find("leave out --lesson"), std::string::npos) << o.validate();
  LiveOptions w;
  EXPECT_EQ(w.cpu_wake_latency_us, -1);
  for (int v : {-1, 0, 50}) {
    w.cpu_wake_latency_us = v;
    EXPECT_EQ(w.validate(), "") << v;
  }
  w.cpu_wake_latency_us = -2;
  EXPECT_NE(w.validate().find("cpu_wake_latency_us = -2"), std::string::npos) << w.validate();
}

}  // namespace dentar::live
