// `dentar replay` as a user runs it (issue 27, mode 1 as a window): the window under Xvfb
// against the headless offline render of the same state, the student-against-expert views,
// and bad input. The window tests skip without xvfb-run unless DENTAR_REQUIRE_GL=1.
//
// Fixture: one generated expert lesson (molar class I cavity, 53 s), made once by ctest's
// fixture in the build folder (replay/CMakeLists.txt), or here in a temporary folder.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <cstdio>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dentar/replay/app.h"
#include "testutil.h"
#include "xvfb_util.h"

namespace fs = std::filesystem;
using dentar::test::run_command;
using dentar::test::xvfb;

namespace {

const std::string kBin = DENTAR_BINARY;

// The fixture's lesson (replay/CMakeLists.txt) when ctest made it, else one made here.
const fs::path& lesson() {
  static const fs::path p = [] {
    const fs::path fixture = DENTAR_REPLAY_TEST_LESSON;
    if (fs::exists(fixture / "lesson.json")) return fixture;
    const fs::path d = dentar::test::temp_dir("replay_lesson") / "lesson";
    auto r = run_command(kBin + " lesson make --generated --exercise molar_class1_cavity --out " + d.string() + " 2>&1");
    EXPECT_EQ(r.code, 0) << r.out;
    return d;
  }();
  return p;
}

// A headless render needs an EGL device: without one the GL tests skip (ar/'s do the same),
// unless DENTAR_REQUIRE_GL says the machine must have it.
#define SKIP_WITHOUT_EGL(result)                                                              \
  do {                                                                                        \
    if ((result).code == 1 && (result).out.find("no headless OpenGL ES 3 context") != std::string::npos) { \
      if (std::getenv("DENTAR_REQUIRE_GL")) FAIL() << (result).out;                            \
      GTEST_SKIP() << "no EGL device: " << (result).out;                                      \
    }                                                                                         \
  } while (0)

void expect_has(const std::string& s, const std::string& what) {
  EXPECT_NE(s.find(what), std::string::npos) << "output: " << s << "\nexpected to contain: " << what;
}

// The 3D area the HUD leaves free (app.h), in the window; --render writes an image of its size.
cv::Rect free_area(int w, int h) {
  return cv::Rect(dentar::replay::kPanelWidth, 0, w - dentar::replay::kPanelWidth, h - dentar::replay::kTimelineHeight);
}

// Pixels (of the area) whose largest channel difference exceeds `levels`, and the mean
// absolute difference over all channels.
std::pair<double, double> compare(const cv::Mat& x, const cv::Mat& y) {
  cv::Mat d;
  cv::absdiff(x, y, d);
  cv::Mat dmax;
  cv::Mat ch[3];
  cv::split(d, ch);
  dmax = cv::max(ch[0], cv::max(ch[1], ch[2]));
  const double frac_over = cv::countNonZero(dmax > 3) / static_cast<double>(dmax.total());
  return {frac_over, cv::mean(d)[0] / 3 + cv::mean(d)[1] / 3 + cv::mean(d)[2] / 3};
}

// The window's view at a time equals the offline (headless) render of the same state: same
// recording, time, camera and opacities. Tolerance: at most 0.5 % of the free area's pixels
// differ by more than 3 grey levels, and the mean difference is under 1 level (both are
// llvmpipe and the window blits the view 1:1, so they agree exactly unless the window's
// context rasterises differently; the HUD's border may reach 2 px in). The render at 0 s
// differs from the one at 30 s (the cut was recomputed), and the window shows the HUD.
TEST(ReplayXvfb, WindowMatchesTheOfflineRenderAtATime) {
  REQUIRE_XVFB();
  const fs::path d = dentar::test::temp_dir("replay_shot");
  const std::string view = " --at 30 --yaw 10 --pitch 60 --zoom 1.6 --enamel 0.5 --size 1280x720";
  auto r = run_command(kBin + " replay " + lesson().string() + view + " --render " + (d / "offline.png").string() + " 2>&1");
  SKIP_WITHOUT_EGL(r);
  ASSERT_EQ(r.code, 0) << r.out;
  r = run_command(kBin + " replay " + lesson().string() + " --at 0 --yaw 10 --pitch 60 --zoom 1.6 --enamel 0.5 --render " +
                  (d / "start.png").string() + " 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  r = run_command(xvfb(kBin + " replay " + lesson().string() + view + " --frames 4 --no-vsync --screenshot " +
                       (d / "window.png").string() + " --stats " + (d / "stats.json").string() + " 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  const cv::Mat off = cv::imread((d / "offline.png").string()), start = cv::imread((d / "start.png").string()),
                win = cv::imread((d / "window.png").string());
  ASSERT_FALSE(off.empty());
  ASSERT_FALSE(win.empty());
  ASSERT_EQ(win.size(), cv::Size(1280, 720));
  const cv::Rect a = free_area(1280, 720);
  ASSERT_EQ(off.size(), a.size());
  // A margin of 2 px inside the area, where the HUD windows' borders may reach.
  const cv::Rect in(2, 2, a.width - 4, a.height - 4);
  const cv::Mat shown = win(a);
  const auto [over, mean] = compare(off(in), shown(in));
  EXPECT_LE(over, 0.005) << "pixels differing by more than 3 levels";
  EXPECT_LT(mean, 1.0);
  // Not a blank view: the tooth covers a good part of the area.
  cv::Mat bg(off.size(), CV_8UC3, off.at<cv::Vec3b>(2, 2));
  EXPECT_GT(compare(off, bg).first, 0.10) << "the tooth is drawn";
  // The cut at 30 s is not the tooth at 0 s.
  EXPECT_GT(compare(off, start).first, 0.002) << "the cut changed the view between 0 and 30 s";
  // The HUD is there: the control panel and the timeline with its plot are not blank.
  cv::Scalar m, sd;
  cv::meanStdDev(win(cv::Rect(0, 0, dentar::replay::kPanelWidth, 720 - dentar::replay::kTimelineHeight)), m, sd);
  EXPECT_GT(sd[0], 10.0) << "the control panel";
  cv::meanStdDev(win(cv::Rect(0, 720 - dentar::replay::kTimelineHeight, 1280, dentar::replay::kTimelineHeight)), m, sd);
  EXPECT_GT(sd[0], 20.0) << "the timeline and the force plot";
  const auto stats = dentar::test::read_json(d / "stats.json");
  EXPECT_EQ(stats.at("frames").get<int>(), 4);
  EXPECT_NEAR(stats.at("end_s").get<double>(), 30.0, 1e-9) << "paused: the clock stays at --at";
}

// Playing, the view renders at the reduced level of detail (--play-scale); the frame a
// --screenshot captures is rendered at full resolution, so it still matches the offline
// render at the time the window reached. The same frame at --play-scale 0.5 throughout (a
// reduced frame) would not: checked by the stats' scale and a reduced render beside it.
TEST(ReplayXvfb, PlayingScreenshotIsFullQualityAtTheTimeReached) {
  REQUIRE_XVFB();
  const fs::path d = dentar::test::temp_dir("replay_play_shot");
  const std::string view = " --yaw 10 --pitch 60 --zoom 1.6 --size 1280x720";
  auto r = run_command(xvfb(kBin + " replay " + lesson().string() + view + " --at 30 --play --speed 0.0625 --frames 5 " +
                            "--play-scale 0.5 --no-vsync --screenshot " + (d / "window.png").string() + " --stats " +
                            (d / "stats.json").string() + " 2>&1"));
  SKIP_WITHOUT_EGL(r);
  ASSERT_EQ(r.code, 0) << r.out;
  const auto stats = dentar::test::read_json(d / "stats.json");
  const double end_s = stats.at("end_s").get<double>();
  EXPECT_GT(end_s, 30.0) << "it played";
  EXPECT_DOUBLE_EQ(stats.at("play_scale").get<double>(), 0.5);
  char at[64];
  std::snprintf(at, sizeof at, "%.17g", end_s);
  r = run_command(kBin + " replay " + lesson().string() + view + " --at " + at + " --render " + (d / "offline.png").string() +
                  " 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  const cv::Mat off = cv::imread((d / "offline.png").string()), win = cv::imread((d / "window.png").string());
  ASSERT_FALSE(off.empty());
  ASSERT_FALSE(win.empty());
  const cv::Rect a = free_area(1280, 720);
  const cv::Rect in(2, 2, a.width - 4, a.height - 4);
  const cv::Mat shown = win(a);
  const auto [over, mean] = compare(off(in), shown(in));
  EXPECT_LE(over, 0.005) << "pixels differing by more than 3 levels: the captured frame is not full quality";
  EXPECT_LT(mean, 1.0);
  // A half-resolution render scaled up differs from it visibly (so the check above can fail).
  cv::Mat half, up;
  cv::resize(off, half, cv::Size(), 0.5, 0.5, cv::INTER_AREA);
  cv::resize(half, up, off.size(), 0, 0, cv::INTER_LINEAR);
  EXPECT_GT(compare(off(in), up(in)).first, 0.005);
}

// Playing (issue 27, session 15): the tooth is drawn coarse (--play-lod 2: under half the
// full mesh's triangles), the HUD is drawn again only when it changed (a handful of times in
// 40 frames, not every frame), and what changes every frame, the play heads, is drawn over the
// cached HUD at the time reached, with no trace left where earlier frames drew them: in the
// captured window the force plot shows exactly one play head, at end_s. The screenshot's
// view is the full mesh (PlayingScreenshotIsFullQualityAtTheTimeReached).
TEST(ReplayXvfb, PlayingDrawsACoarseToothAndTheHudOnlyWhenItChanges) {
  REQUIRE_XVFB();
  const fs::path d = dentar::test::temp_dir("replay_play_cache");
  const int frames = 40;
  auto r = run_command(xvfb(kBin + " replay " + lesson().string() + " --at 10 --play --speed 4 --frames " +
                            std::to_string(frames) + " --play-lod 2 --no-vsync --screenshot " + (d / "w.png").string() +
                            " --stats " + (d / "s.json").string() + " 2>&1"));
  SKIP_WITHOUT_EGL(r);
  ASSERT_EQ(r.code, 0) << r.out;
  const auto s = dentar::test::read_json(d / "s.json");
  const double end_s = s.at("end_s").get<double>(), dur = s.at("duration_s").get<double>();
  ASSERT_GT(end_s, 10.5) << "it played";
  EXPECT_LT(s.at("triangles_playing").get<double>(), 0.45 * s.at("triangles").get<double>());
  EXPECT_GT(s.at("triangles_playing").get<double>(), 0.1 * s.at("triangles").get<double>());
  EXPECT_LE(s.at("hud_draws").get<int>(), 8) << "the HUD is redrawn only when it changed";
  EXPECT_GE(s.at("hud_draws").get<int>(), 1);
  // The force plot: the window's bottom strip (app.h's layout: 8 px padding, the timeline's
  // 22 px bar, the plot under it). A play head is a dark column through the plot's height.
  const cv::Mat win = cv::imread((d / "w.png").string());
  ASSERT_EQ(win.size(), cv::Size(1280, 720));
  cv::Mat grey;
  cv::cvtColor(win(cv::Rect(0, 540, 1280, 150)), grey, cv::COLOR_BGR2GRAY);
  std::vector<int> dark_columns;
  for (int x = 10; x < 1270; ++x)  // inside the plot (the window's dark margins outside)
    if (cv::countNonZero(grey.col(x) < 60) >= grey.rows * 9 / 10) dark_columns.push_back(x);
  ASSERT_FALSE(dark_columns.empty()) << "no play head in the force plot";
  const double x_expected = 8 + end_s / dur * (1280 - 16 - 1);
  for (int x : dark_columns) EXPECT_NEAR(x, x_expected, 2.5) << "a play head away from end_s: a stale one";
}

// The keyboard drives the same code as a user's keys: N twice jumps two steps on (to the
// third span's start, paused), Left orbits 10 degrees, ] doubles the speed.
TEST(ReplayXvfb, KeysJumpToStepsOrbitAndChangeSpeed) {
  REQUIRE_XVFB();
  const fs::path d = dentar::test::temp_dir("replay_keys");
  auto r = run_command(xvfb(kBin + " replay " + lesson().string() + " --at 0 --yaw -35 --frames 6 --no-vsync --stats " +
                            (d / "k.json").string() + " --keys n n left ] 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  const auto s = dentar::test::read_json(d / "k.json");
  const auto starts = s.at("step_starts_s").get<std::vector<double>>();
  ASSERT_GE(starts.size(), 3u);
  EXPECT_NEAR(s.at("end_s").get<double>(), starts[2], 1e-9);
  EXPECT_NEAR(s.at("camera").at("yaw_rad").get<double>(), (-35.0 - 10.0) * M_PI / 180, 1e-9);
  EXPECT_DOUBLE_EQ(s.at("speed").get<double>(), 2.0);
  r = run_command(kBin + " replay " + lesson().string() + " --render " + (d / "x.png").string() + " --keys f13 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  expect_has(r.out, "--keys: unknown key 'f13'");
}

// Student against expert: side by side and superimposed render, the alignment ran per step
// (the lesson against itself: the warp is the identity, steps all aligned).
TEST(ReplayXvfb, AgainstAlignsPerStepSideBySideAndSuperimposed) {
  const fs::path d = dentar::test::temp_dir("replay_against");
  for (const std::string mode : {"", " --superimpose"}) {
    auto r = run_command(kBin + " replay " + lesson().string() + " --against " + lesson().string() + mode +
                         " --at 5 --render " + (d / "a.png").string() + " --stats " + (d / "s.json").string() + " 2>&1");
    SKIP_WITHOUT_EGL(r);
    ASSERT_EQ(r.code, 0) << r.out;
    expect_has(r.out, "aligned by DTW in");
    const auto s = dentar::test::read_json(d / "s.json");
    EXPECT_GE(s.at("steps_aligned").size(), 1u);
    const cv::Mat img = cv::imread((d / "a.png").string());
    ASSERT_EQ(img.size(), free_area(1280, 720).size());
  }
}

// Bad input: exit code 2 and a message naming the file, option or value; nothing written.
TEST(ReplayXvfb, BadInputIsRefusedWithExitCode2) {
  const fs::path d = dentar::test::temp_dir("replay_bad");
  const std::string out = " --render " + (d / "x.png").string() + " 2>&1";
  auto r = run_command(kBin + " replay " + (d / "missing.dlog").string() + out);
  EXPECT_EQ(r.code, 2) << r.out;
  expect_has(r.out, (d / "missing.dlog").string() + ": no such file or folder");
  r = run_command(kBin + " replay " + lesson().string() + " --play-scale 0.1" + out);
  EXPECT_EQ(r.code, 2) << r.out;
  expect_has(r.out, "--play-scale 0.100: must be 0.25 to 1");
  r = run_command(kBin + " replay " + lesson().string() + " --play-lod 3" + out);
  EXPECT_EQ(r.code, 2) << r.out;
  expect_has(r.out, "--play-lod 3: must be 0 (the full mesh), 2, 4 or 8 voxels");
  dentar::test::write_file(d / "junk.dlog", std::string(4096, 'x'));
  r = run_command(kBin + " replay " + (d / "junk.dlog").string() + out);
  EXPECT_EQ(r.code, 2) << r.out;
  expect_has(r.out, (d / "junk.dlog").string());
  // A lesson whose recording was damaged (truncated).
  const fs::path bad = d / "bad_lesson";
  fs::create_directories(bad);
  fs::copy_file(lesson() / "lesson.json", bad / "lesson.json");
  const std::string rec = dentar::test::read_file(lesson() / "expert.dlog");
  dentar::test::write_file(bad / "expert.dlog", rec.substr(0, rec.size() / 2));
  r = run_command(kBin + " replay " + bad.string() + out);
  EXPECT_EQ(r.code, 2) << r.out;
  expect_has(r.out, (bad / "lesson.json").string());
  // An exercise for another tooth.
  r = run_command(kBin + " replay " + lesson().string() + " --exercise incisor_partial_crown" + out);
  EXPECT_EQ(r.code, 2) << r.out;
  expect_has(r.out, "is for tooth kind 'incisor'");
  // Times outside the recording, and other bad options.
  r = run_command(kBin + " replay " + lesson().string() + " --at 1e6" + out);
  EXPECT_EQ(r.code, 2) << r.out;
  expect_has(r.out, "--at 1000000.000: must be a time within the recording, 0 to ");
  r = run_command(kBin + " replay " + lesson().string() + " --at -1" + out);
  EXPECT_EQ(r.code, 2) << r.out;
  r = run_command(kBin + " replay " + lesson().string() + " --size 12x7" + out);
  EXPECT_EQ(r.code, 2) << r.out;
  expect_has(r.out, "--size 12x7");
  r = run_command(kBin + " replay " + lesson().string() + " --enamel 1.5" + out);
  EXPECT_EQ(r.code, 2) << r.out;
  r = run_command(kBin + " replay " + lesson().string() + " --screenshot " + (d / "s.png").string() + " 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  expect_has(r.out, "--screenshot needs --frames N");
  EXPECT_FALSE(fs::exists(d / "x.png")) << "nothing written on bad input";
}

}  // namespace
