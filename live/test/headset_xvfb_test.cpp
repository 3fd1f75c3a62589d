// `dentar live --output sbs` as a user runs it, under Xvfb: the window's
// screenshot, eye by eye, against the offline composite of the same frame put
// through the headset's mapping on the CPU (headset.h render_eye_cpu), without
// and with the lens pre-warp; and bad headset profiles refused before any
// window opens.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "dentar/ar/station_scene.h"
#include "dentar/live/headset.h"
#include "testutil.h"
#include "xvfb_util.h"

namespace fs = std::filesystem;
using dentar::test::read_json;
using dentar::test::run_command;
using dentar::test::xvfb;

namespace {

const std::string kBin = DENTAR_BINARY;

// The live tests' shared footage (live_xvfb_test.cpp makes the same folder:
// whichever test comes first generates it, keyed by the binary's time stamp).
const fs::path& clip() {
  static fs::path dir = [] {
    const auto stamp = fs::last_write_time(kBin).time_since_epoch().count();
    const fs::path d = fs::temp_directory_path() / ("dentar_live_clip_" + std::to_string(stamp));
    if (fs::exists(d / "session.dlog")) return d;
    const fs::path tmp = fs::temp_directory_path() / ("dentar_live_clip_tmp_" + std::to_string(getpid()));
    fs::remove_all(tmp);
    auto r = run_command(kBin + " synth --preset standard --frames 60 --resolution 640x480 --seed 3 --webcam --out " +
                         tmp.string() + " 2>&1");
    EXPECT_EQ(r.code, 0) << r.out;
    std::error_code ec;
    fs::rename(tmp, d, ec);
    if (ec) fs::remove_all(tmp);
    return d;
  }();
  return dir;
}

// A 1280x600 panel of two 640x600 eyes; the Rift DK1's lens figures when warp.
nlohmann::json profile_json(bool warp) {
  nlohmann::json j = {{"format", "dentar-headset"},
                      {"version", 1},
                      {"name", warp ? "test with pre-warp" : "test without pre-warp"},
                      {"provenance", "test"},
                      {"panel_px", {1280, 600}},
                      {"eyes", {{{"viewport_px", {0, 0, 640, 600}}, {"lens_center_px", {368.6, 300}}},
                                {{"viewport_px", {640, 0, 640, 600}}, {"lens_center_px", {271.4, 300}}}}},
                      {"fov_deg", {80, 85}},
                      {"ipd_mm", 64}};
  if (warp) j["distortion"] = {{"k1", 0.22}, {"k2", 0.24}, {"chroma_scale_r", 0.996}, {"chroma_scale_b", 1.014}};
  return j;
}

}  // namespace

TEST(HeadsetXvfb, SideBySideEyesMatchOfflineComposite) {
  REQUIRE_XVFB();
  const fs::path c = clip();
  const fs::path t = dentar::test::temp_dir("headset_sbs");
  auto station = dentar::ar::read_station_scene((c / "station.json").string());
  ASSERT_TRUE(station.ok()) << station.error();
  for (const bool warp : {false, true}) {
    SCOPED_TRACE(warp ? "with pre-warp" : "without pre-warp");
    const fs::path dir = t / (warp ? "warp" : "flat"), rec = dir / "rec", off = dir / "off";
    fs::create_directories(dir);
    const fs::path prof = dir / "headset.json";
    std::ofstream(prof) << profile_json(warp).dump(2);
    // Frames sized, not timed; the CPU display path (the window's upload), and a loupe
    // off: the eyes must be the composite itself.
    auto r = run_command(xvfb(kBin + " live --camera live:" + (c / "video.mkv").string() + " --station " +
                              (c / "station.json").string() + " --stylus replay:" + (c / "session.dlog").string() +
                              " --output sbs --headset " + prof.string() + " --display-path cpu --no-hud --quiet" +
                              " --frames 10 --screenshot 6:" + (dir / "shot.png").string() + " --record " +
                              rec.string() + " --no-score --summary " + (dir / "live.json").string() + " 2>&1"));
    ASSERT_EQ(r.code, 0) << r.out;
    r = run_command(kBin + " offline --footage " + rec.string() + " --out " + off.string() +
                    " --video-codec ffv1 --quiet 2>&1");
    ASSERT_EQ(r.code, 0) << r.out;
    const cv::Mat shot = cv::imread((dir / "shot.png").string());
    ASSERT_EQ(shot.cols, 1280);  // the window is the panel's size
    ASSERT_EQ(shot.rows, 600);
    cv::VideoCapture vc((off / "composite.mkv").string());
    cv::Mat frame;
    for (int k = 0; k <= 6; ++k) ASSERT_TRUE(vc.read(frame));
    auto prof_r = dentar::live::read_headset_profile(prof.string());
    ASSERT_TRUE(prof_r.ok()) << prof_r.error();
    cv::Mat ref(600, 1280, CV_8UC3, cv::Scalar::all(0));
    const double c0[2] = {0, 0};
    for (int e = 0; e < 2; ++e)
      dentar::live::render_eye_cpu(
          frame, dentar::live::make_eye_mapping(*prof_r, e, station->calibration.camera, false, {}, c0), ref);
    for (int e = 0; e < 2; ++e) {
      const cv::Rect roi(640 * e, 0, 640, 600);
      cv::Mat diff, gray;
      cv::absdiff(shot(roi), ref(roi), diff);
      cv::cvtColor(diff, gray, cv::COLOR_BGR2GRAY);
      const double mean = cv::mean(diff)[0], big = cv::countNonZero(gray > 24) / double(gray.total());
      // As the mono window against the offline composite (live_xvfb_test), plus the GPU's
      // 8-bit filtering weights.
      EXPECT_LT(mean, 2.0) << "eye " << e;
      EXPECT_LT(big, 0.005) << "eye " << e;
      EXPECT_GT(cv::mean(shot(roi))[1], 20) << "eye " << e << " is dark";
    }
    // The picture is the composite's, overlay included: not the raw frame's.
    cv::Mat raw_ref(600, 1280, CV_8UC3, cv::Scalar::all(0));
    const fs::path png = rec / "frames" / "frame_000006.png";
    const cv::Mat raw = cv::imread((fs::exists(png) ? png : rec / "frames" / "frame_000006.ppm").string());
    ASSERT_FALSE(raw.empty());
    dentar::live::render_eye_cpu(
        raw, dentar::live::make_eye_mapping(*prof_r, 0, station->calibration.camera, false, {}, c0), raw_ref);
    cv::Mat d, g;
    cv::absdiff(raw_ref(cv::Rect(0, 0, 640, 600)), ref(cv::Rect(0, 0, 640, 600)), d);
    cv::cvtColor(d, g, cv::COLOR_BGR2GRAY);
    EXPECT_GT(cv::countNonZero(g > 24), 100) << "no overlay in the left eye";
    const auto sum = read_json(dir / "live.json");
    EXPECT_EQ(sum["stop_reason"], "frame limit");
  }
}

// Impossible headset values stop `dentar live` before anything starts: exit 2,
// the file and the field named.
TEST(HeadsetXvfb, BadProfileIsRefusedWithExit2) {
  const fs::path t = dentar::test::temp_dir("headset_bad");
  nlohmann::json j = profile_json(true);
  j["fov_deg"][0] = 185;
  const fs::path bad = t / "bad.json";
  std::ofstream(bad) << j.dump();
  auto r = run_command(kBin + " live --camera live:/nonexistent.mkv --output sbs --headset " + bad.string() + " 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("headset profile " + bad.string() + ": fov_deg[0] = 185 must be in (1, 180)"), std::string::npos)
      << r.out;
  j = profile_json(true);
  j["ipd_mm"] = -60;
  std::ofstream(bad) << j.dump();
  r = run_command(kBin + " live --output sbs --headset " + bad.string() + " 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("ipd_mm = -60 must be positive"), std::string::npos) << r.out;
  r = run_command(kBin + " live --output sbs 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("needs a headset profile"), std::string::npos) << r.out;
  r = run_command(kBin + " live --loupe 20 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("loupe = 20"), std::string::npos) << r.out;
}
