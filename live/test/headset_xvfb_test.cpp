// `dentar live --output sbs` as a user runs it, under Xvfb: the window's
// screenshot, eye by eye, against the offline composite of the same frame put
// through the headset's mapping on the CPU (headset.h render_eye_cpu), without
// and with the lens pre-warp; and bad headset profiles refused before any
// window opens.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "dentar/ar/station_scene.h"
#include "dentar/live/headset.h"
#include "live_clip.h"
#include "testutil.h"
#include "xvfb_util.h"

namespace fs = std::filesystem;
using dentar::test::read_json;
using dentar::test::run_command;
using dentar::test::xvfb;

namespace {

const std::string kBin = DENTAR_BINARY;

const fs::path& clip() { return dentar::test::live_clip(kBin); }

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
  const fs::path dir = dentar::test::temp_dir("headset_sbs"), rec = dir / "rec", off = dir / "off";
  auto station = dentar::ar::read_station_scene((c / "station.json").string());
  ASSERT_TRUE(station.ok()) << station.error();
  const fs::path prof = dir / "headset.json";
  std::ofstream(prof) << profile_json(true).dump(2);
  // One run: frames 3..7 with the pre-warp, then the W key (scripted at frame 8) turns it
  // off, frames 10..14 without. Sized in frames, not time; the CPU display path (the
  // window's upload); loupe off: the eyes are the composite itself.
  std::string shots;
  for (const int k : {3, 4, 5, 6, 7, 10, 11, 12, 13, 14})
    shots += " --screenshot " + std::to_string(k) + ":" + (dir / ("shot" + std::to_string(k) + ".png")).string();
  auto r = run_command(xvfb(kBin + " live --camera live:" + (c / "video.mkv").string() + " --station " +
                            (c / "station.json").string() + " --stylus replay:" + (c / "session.dlog").string() +
                            " --output sbs --headset " + prof.string() + " --display-path cpu --no-hud --quiet" +
                            " --loop --frames 16 --inject-key 8:W" + shots + " --record " + rec.string() +
                            " --no-score --summary " + (dir / "live.json").string() + " 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(read_json(dir / "live.json")["stop_reason"], "frame limit");
  r = run_command(kBin + " offline --footage " + rec.string() + " --out " + off.string() +
                  " --video-codec ffv1 --quiet 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  auto prof_r = dentar::live::read_headset_profile(prof.string());
  ASSERT_TRUE(prof_r.ok()) << prof_r.error();
  const double c0[2] = {0, 0};
  // A frame through the headset's mapping on the CPU, with or without the pre-warp.
  auto eyes = [&](const cv::Mat& img, bool warp) {
    cv::Mat out(600, 1280, CV_8UC3, cv::Scalar::all(0));
    for (int e = 0; e < 2; ++e)
      dentar::live::render_eye_cpu(
          img, dentar::live::make_eye_mapping(*prof_r, e, station->calibration.camera, false, {}, c0, warp), out);
    return out;
  };
  std::vector<cv::Mat> composites;
  {
    cv::VideoCapture vc((off / "composite.mkv").string());
    cv::Mat frame;
    for (int k = 0; k <= 14 && vc.read(frame); ++k) composites.push_back(frame.clone());
    ASSERT_EQ(composites.size(), 15u);
  }
  for (const bool warp : {true, false}) {
    SCOPED_TRACE(warp ? "with pre-warp" : "without pre-warp");
    // The first screenshot that shows the composite: a window that found the camera silent
    // for 150 ms shows the raw frame instead (the stall path; on an overloaded machine).
    int k_shot = -1, k_raw = -1;
    cv::Mat shot, ref, raw_shot, raw_ref;
    for (int k = warp ? 3 : 10; k <= (warp ? 7 : 14) && k_shot < 0; ++k) {
      const fs::path sp = dir / ("shot" + std::to_string(k) + ".png");
      if (!fs::exists(sp)) continue;
      const cv::Mat s = cv::imread(sp.string());
      ASSERT_EQ(s.cols, 1280);  // the window is the panel's size
      ASSERT_EQ(s.rows, 600);
      char name[32];
      std::snprintf(name, sizeof name, "frame_%06d", k);
      const fs::path png = rec / "frames" / (std::string(name) + ".png");
      const cv::Mat raw = cv::imread((fs::exists(png) ? png : rec / "frames" / (std::string(name) + ".ppm")).string());
      ASSERT_FALSE(raw.empty());
      const cv::Mat r_comp = eyes(composites[static_cast<std::size_t>(k)], warp), r_raw = eyes(raw, warp);
      cv::Mat d, g;
      const cv::Rect left(0, 0, 640, 600);
      cv::absdiff(r_raw(left), r_comp(left), d);
      cv::cvtColor(d, g, cv::COLOR_BGR2GRAY);
      const cv::Mat overlay = g > 24;  // where the overlay changed the picture (the tooth and bur, drawn small)
      ASSERT_GT(cv::countNonZero(overlay), 20) << "no overlay in frame " << k;
      cv::Mat to_comp, to_raw;
      cv::absdiff(s(left), r_comp(left), to_comp);
      cv::absdiff(s(left), r_raw(left), to_raw);
      if (cv::mean(to_comp, overlay)[1] * 3 < cv::mean(to_raw, overlay)[1]) k_shot = k, shot = s, ref = r_comp;
      else if (k_raw < 0) k_raw = k, raw_shot = s, raw_ref = r_raw;
    }
    if (k_shot < 0) {
      // Every screenshot came from the stall path (the camera silent for 150 ms when the
      // window drew: an overloaded machine). The output's mapping is still checked, on the
      // raw frame it showed; the composite's pixels through the same pass are checked by
      // EyeOutputGl.ComposesTheGpuPathsOverlayRegion and the mono window's by LiveXvfb.
      ASSERT_GE(k_raw, 0) << "no screenshot";
      std::printf("[ note ] the %s screenshots were all raw frames (stall path; capture-to-display p50 %.0f ms): "
                  "compared with raw frame %d\n",
                  warp ? "pre-warped" : "flat", read_json(dir / "live.json")["latency_ms"]["p50"].get<double>(), k_raw);
      k_shot = k_raw, shot = raw_shot, ref = raw_ref;
    }
    for (int e = 0; e < 2; ++e) {
      const cv::Rect roi(640 * e, 0, 640, 600);
      cv::Mat diff, gray;
      cv::absdiff(shot(roi), ref(roi), diff);
      cv::cvtColor(diff, gray, cv::COLOR_BGR2GRAY);
      const double mean = cv::mean(diff)[0], big = cv::countNonZero(gray > 24) / double(gray.total());
      // As the mono window against the offline composite (live_xvfb_test), plus the GPU's
      // 8-bit filtering weights.
      EXPECT_LT(mean, 2.0) << "eye " << e << " frame " << k_shot;
      EXPECT_LT(big, 0.005) << "eye " << e << " frame " << k_shot;
      EXPECT_GT(cv::mean(shot(roi))[1], 20) << "eye " << e << " is dark";
    }
    // The other mode's reference is far off: the screenshot really is (not) pre-warped.
    cv::Mat other_d;
    cv::absdiff(shot, eyes(composites[static_cast<std::size_t>(k_shot)], !warp), other_d);
    EXPECT_GT(cv::mean(other_d)[0], 8.0) << "frame " << k_shot;
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

// Issue 28 (session 16): a stereo rig into the headset. `dentar live --stereo --output sbs`
// on generated side-by-side footage: the screenshot's left eye against the offline left
// composite and its right eye against the offline right composite (`dentar offline --stereo
// --eye both`: composite_right.mkv), each through the headset's mapping of its own camera
// (no IPD shift). The right eye is not the left composite shown again: that reference is
// far off. Tracking runs in each process, so poses may differ by the live run's dropped
// frames: the bounds are the sbs test's, the overlay checked where it changed the picture.
TEST(HeadsetXvfb, StereoPairEachEyeMatchesItsOfflineComposite) {
  REQUIRE_XVFB();
  const fs::path dir = dentar::test::temp_dir("headset_stereo"), st = dir / "st", off = dir / "off";
  auto r = run_command(kBin + " synth --preset standard --stereo --frames 10 --resolution 640x480 --seed 3 --out " +
                       st.string() + " 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  auto station = dentar::ar::read_station_scene((st / "station.json").string());
  ASSERT_TRUE(station.ok()) << station.error();
  ASSERT_TRUE(station->stereo.present);
  const fs::path prof = dir / "headset.json";
  std::ofstream(prof) << profile_json(false).dump(2);
  std::string shots;
  for (int k = 4; k <= 7; ++k)
    shots += " --screenshot " + std::to_string(k) + ":" + (dir / ("shot" + std::to_string(k) + ".png")).string();
  r = run_command(xvfb(kBin + " live --stereo --camera live:" + (st / "video.mkv").string() + " --station " +
                       (st / "station.json").string() + " --stylus none --output sbs --headset " + prof.string() +
                       " --display-path cpu --no-hud --quiet --loop --frames 8" + shots + " --record " +
                       (dir / "rec").string() + " --no-score --summary " + (dir / "live.json").string() + " 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  const auto live = read_json(dir / "live.json");
  ASSERT_TRUE(live.contains("stereo")) << live.dump();
  EXPECT_GT(live["stereo"]["frames_right_eye_composited"].get<int>(), 0) << live.dump();
  // Session 17: the right eye ran on its own thread (the default for a stereo pair into the
  // headset), and the summary says where the frames' time went, the right eye's composite too.
  EXPECT_EQ(live["stereo"]["eye_threads"].get<int>(), 2) << live.dump();
  // Session 18: the pre-warp pass that drew the view, named in the summary (default exact).
  EXPECT_EQ(live["display"]["warp_pass"], "exact") << live["display"].dump();
  EXPECT_EQ(live["display"]["warp_cell_px"].get<int>(), 16) << live["display"].dump();
  // Session 22: --display-texture auto keeps this 640x480 camera's textures full size (its pixels
  // are not twice as fine as this panel's at the lens centre), the choice named in the summary.
  EXPECT_EQ(live["display"]["texture"], "auto") << live["display"].dump();
  EXPECT_EQ(live["display"]["texture_scale"].get<int>(), 1) << live["display"].dump();
  EXPECT_LT(live["display"]["texture_camera_px_per_window_px"].get<double>(), 2.0) << live["display"].dump();
  for (const char* stage : {"pickup", "track", "compose_left", "compose_right", "process_cpu", "display"})
    EXPECT_TRUE(live["stages_ms"].contains(stage)) << stage << ": " << live["stages_ms"].dump();
  r = run_command(kBin + " offline --stereo --eye both --footage " + (st / "video.mkv").string() + " --station " +
                  (st / "station.json").string() + " --out " + off.string() + " --video-codec ffv1 --quiet 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  const auto sum = read_json(off / "summary.json");
  ASSERT_TRUE(sum.contains("right_eye")) << sum.dump();
  EXPECT_EQ(sum["right_eye"]["frames_composited"].get<int>(), 10);
  // The right eye's tooth against its own truth, through the driver (generated footage).
  EXPECT_LT(sum["right_eye"]["tooth_err_px"]["p95"].get<double>(), 3.0) << sum["right_eye"].dump();
  auto prof_r = dentar::live::read_headset_profile(prof.string());
  ASSERT_TRUE(prof_r.ok()) << prof_r.error();
  auto read_video = [](const fs::path& p) {
    std::vector<cv::Mat> v;
    cv::VideoCapture vc(p.string());
    for (cv::Mat f; vc.read(f);) v.push_back(f.clone());
    return v;
  };
  const auto left = read_video(off / "composite.mkv"), right = read_video(off / "composite_right.mkv");
  ASSERT_EQ(left.size(), 10u);
  ASSERT_EQ(right.size(), 10u);
  const double c0[2] = {0, 0};
  const auto& cam_l = station->calibration.camera;
  const auto& cam_r = station->stereo.camera_right;
  // One eye's view of an image through the headset's mapping (stereo: no IPD shift).
  auto eye = [&](const cv::Mat& img, int e, const dentar::calibration::CameraIntrinsics& cam) {
    cv::Mat out(600, 1280, CV_8UC3, cv::Scalar::all(0));
    dentar::live::render_eye_cpu(img, dentar::live::make_eye_mapping(*prof_r, e, cam, true, {}, c0, false), out);
    return out;
  };
  // frames.csv per eye (session 17): the live recording's rows say which frames gave the right
  // eye its own composite (as many as the summary counts), the offline rows carry the right
  // eye's tooth against its truth.
  {
    auto table = [](const fs::path& p) {
      std::ifstream f(p);
      std::vector<std::vector<std::string>> rows;
      for (std::string line; std::getline(f, line);) {
        std::vector<std::string> v;
        std::stringstream ss(line);
        for (std::string c; std::getline(ss, c, ',');) v.push_back(c);
        if (!line.empty() && line.back() == ',') v.emplace_back();
        rows.push_back(v);
      }
      return rows;
    };
    auto col = [](const std::vector<std::string>& h, const char* n) {
      return static_cast<int>(std::find(h.begin(), h.end(), n) - h.begin());
    };
    const auto lr = table(dir / "rec" / "frames.csv");
    ASSERT_GT(lr.size(), 1u);
    const int lc = col(lr[0], "right_composited");
    ASSERT_LT(lc, static_cast<int>(lr[0].size()));
    int own = 0;
    for (std::size_t i = 1; i < lr.size(); ++i) own += lr[i][static_cast<std::size_t>(lc)] == "1";
    EXPECT_EQ(own, live["stereo"]["frames_right_eye_composited"].get<int>());
    const auto orows = table(off / "frames.csv");
    ASSERT_EQ(orows.size(), 11u);
    const int oc = col(orows[0], "right_composited"), oe = col(orows[0], "right_tooth_err_px");
    ASSERT_LT(oe, static_cast<int>(orows[0].size()));
    for (std::size_t i = 1; i < orows.size(); ++i) {
      EXPECT_EQ(orows[i][static_cast<std::size_t>(oc)], "1") << "frame " << i - 1;
      ASSERT_FALSE(orows[i][static_cast<std::size_t>(oe)].empty()) << "frame " << i - 1;
      EXPECT_LT(std::stod(orows[i][static_cast<std::size_t>(oe)]), 3.0) << "frame " << i - 1;
    }
  }
  const auto footage = read_video(st / "video.mkv");  // side by side: the raw eyes
  ASSERT_EQ(footage.size(), 10u);
  // The footage frame each shown frame came from (a loaded machine drops frames; --loop
  // wraps): the recording's frames.csv, column source_index.
  std::map<int, int> source;
  {
    std::ifstream csv(dir / "rec" / "frames.csv");
    std::string line;
    std::getline(csv, line);
    int col = -1, c = 0;
    std::stringstream hs(line);
    for (std::string h; std::getline(hs, h, ','); ++c)
      if (h == "source_index") col = c;
    ASSERT_GE(col, 0) << "frames.csv has no source_index: " << line;
    while (std::getline(csv, line)) {
      std::stringstream ls(line);
      std::string cell, frame;
      for (int i = 0; std::getline(ls, cell, ','); ++i) {
        if (i == 0) frame = cell;
        if (i == col) source[std::stoi(frame)] = std::stoi(cell) % 10;
      }
    }
  }
  int compared = 0, raw_k = -1;
  cv::Mat raw_shot, raw_ref[2], raw_wrong;
  for (int k = 4; k <= 7; ++k) {
    const fs::path sp = dir / ("shot" + std::to_string(k) + ".png");
    if (!fs::exists(sp)) continue;
    const cv::Mat s = cv::imread(sp.string());
    ASSERT_EQ(s.cols, 1280);
    ASSERT_EQ(s.rows, 600);
    ASSERT_TRUE(source.count(k)) << "frame " << k << " not in the recording's frames.csv";
    SCOPED_TRACE("frame " + std::to_string(k) + " (footage frame " + std::to_string(source[k]) + ")");
    const std::size_t ki = static_cast<std::size_t>(source[k]);
    const cv::Mat& sbs = footage[ki];
    const cv::Mat raw_l = sbs(cv::Rect(0, 0, sbs.cols / 2, sbs.rows)), raw_r = sbs(cv::Rect(sbs.cols / 2, 0, sbs.cols / 2, sbs.rows));
    const cv::Mat ref[2] = {eye(left[ki], 0, cam_l), eye(right[ki], 1, cam_r)};
    const cv::Mat raw[2] = {eye(raw_l, 0, cam_l), eye(raw_r, 1, cam_r)};
    // Per eye: where the overlay changed the picture, is the screenshot the composite (3x
    // closer to it than to the raw frame)? A shot whose left eye shows the raw frame came
    // from the stall path (the camera silent 150 ms: an overloaded machine): not compared.
    bool left_composited = false;
    for (int e = 0; e < 2; ++e) {
      const cv::Rect roi(640 * e, 0, 640, 600);
      cv::Mat d, g;
      cv::absdiff(raw[e](roi), ref[e](roi), d);
      cv::cvtColor(d, g, cv::COLOR_BGR2GRAY);
      const cv::Mat overlay = g > 24;
      ASSERT_GT(cv::countNonZero(overlay), 20) << "no overlay in eye " << e << "'s offline composite";
      cv::Mat to_comp, to_raw;
      cv::absdiff(s(roi), ref[e](roi), to_comp);
      cv::absdiff(s(roi), raw[e](roi), to_raw);
      const bool shows_overlay = cv::mean(to_comp, overlay)[1] * 3 < cv::mean(to_raw, overlay)[1];
      if (e == 0) {
        left_composited = shows_overlay;
        if (!left_composited) {
          if (raw_k < 0) {
            raw_k = k, raw_shot = s, raw_ref[0] = raw[0], raw_ref[1] = raw[1];
            raw_wrong = eye(raw_l, 1, cam_r);
          }
          break;
        }
      } else {
        EXPECT_TRUE(shows_overlay) << "the right eye shows no overlay where its offline composite has one";
      }
      cv::cvtColor(to_comp, g, cv::COLOR_BGR2GRAY);
      const double mean = cv::mean(to_comp)[0], big = cv::countNonZero(g > 24) / double(g.total());
      EXPECT_LT(mean, 2.0) << "eye " << e;
      EXPECT_LT(big, 0.005) << "eye " << e;
      EXPECT_GT(cv::mean(s(roi))[1], 20) << "eye " << e << " is dark";
    }
    if (!left_composited) continue;
    ++compared;
    // The right eye is its own view: the left composite through the right eye's mapping is far off.
    const cv::Rect rr(640, 0, 640, 600);
    cv::Mat wrong = eye(left[ki], 1, cam_r), d;
    cv::absdiff(s(rr), wrong(rr), d);
    EXPECT_GT(cv::mean(d)[0], 6.0) << "the right eye shows the left eye's image";
  }
  if (compared == 0) {
    // Every screenshot came from the stall path (the camera silent for 150 ms when the window
    // drew: an overloaded machine). The pair's mapping is still checked on the raw frames it
    // showed: each eye its own camera's frame; the right eye's composite itself is checked by
    // RightEyeGl.OverlayLandsOnTheRightEyesTruth.
    ASSERT_GE(raw_k, 0) << "no screenshot";
    std::printf("[ note ] every screenshot was a raw frame (stall path; capture-to-display p50 %.0f ms): the pair "
                "compared with raw frame %d\n",
                live["latency_ms"]["p50"].get<double>(), raw_k);
    for (int e = 0; e < 2; ++e) {
      const cv::Rect roi(640 * e, 0, 640, 600);
      cv::Mat d, g;
      cv::absdiff(raw_shot(roi), raw_ref[e](roi), d);
      cv::cvtColor(d, g, cv::COLOR_BGR2GRAY);
      EXPECT_LT(cv::mean(d)[0], 2.0) << "eye " << e;
      EXPECT_LT(cv::countNonZero(g > 24) / double(g.total()), 0.005) << "eye " << e;
    }
    const cv::Rect rr(640, 0, 640, 600);
    cv::Mat d;
    cv::absdiff(raw_shot(rr), raw_wrong(rr), d);
    EXPECT_GT(cv::mean(d)[0], 6.0) << "the right eye shows the left eye's image";
  }
}

// Issue 28 (session 17): the headset's pair shows the same HUD in each eye, and a lesson's
// note label beside the tooth in each eye's composite also when the left eye takes the GPU
// path (before: the left eye had none). A stereo run into the side-by-side view with a
// lesson whose pause point holds its note on show: the summary counts frames whose note went
// into both eyes (and none where an eye anchored it without drawing it); the screenshot's HUD
// text, eye by eye, is there and the same (the HUD is drawn at one place of each eye's view).
// Session 18: run with the right eye's own GL context refused (the test hook
// DENTAR_TEST_FAIL_EYE_CONTEXT, as a driver out of contexts): the run goes on with one eye
// thread, says so in the summary's warnings and counts it in stereo.eye_threads, and both eyes
// still get their composite (before: the pipeline was not made and the run stopped).
TEST(HeadsetXvfb, HudAndLessonNoteInBothEyes) {
  REQUIRE_XVFB();
  const fs::path dir = dentar::test::temp_dir("headset_hud"), st = dir / "st", lesson = dir / "lesson";
  auto r = run_command(kBin + " synth --preset standard --stereo --frames 4 --resolution 640x480 --seed 3 --out " +
                       st.string() + " 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  r = run_command(kBin + " lesson make " + (st / "session.dlog").string() +
                  " --exercise molar_access_opening --note '0.0:Mind the pulp horn' --pause 0.1:60 --out " +
                  lesson.string() + " 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  const fs::path prof = dir / "headset.json";
  std::ofstream(prof) << profile_json(false).dump(2);
  // Session 21: frames 4..7 asked for, the first shown compared (a loaded machine's window may
  // skip frame 4 for a newer one and write no shot4.png; as LiveXvfb's 928b6df).
  std::string shots;
  for (int k = 4; k <= 7; ++k) shots += " --screenshot " + std::to_string(k) + ":" + (dir / ("shot" + std::to_string(k) + ".png")).string();
  r = run_command("DENTAR_TEST_FAIL_EYE_CONTEXT=1 " +
                  xvfb(kBin + " live --stereo --camera live:" + (st / "video.mkv").string() + " --station " +
                       (st / "station.json").string() + " --stylus sim --lesson " + lesson.string() +
                       " --mode 2 --output sbs --headset " + prof.string() +
                       " --display-path gl --quiet --loop --frames 8" + shots +
                       " --no-score --summary " + (dir / "live.json").string() + " 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  const auto live = read_json(dir / "live.json");
  ASSERT_TRUE(live.contains("stereo")) << live.dump();
  const auto& ls = live["stereo"];
  EXPECT_GT(ls["frames_note_both_eyes"].get<int>(), 0) << ls.dump();
  EXPECT_EQ(ls["frames_note_missing_in_an_eye"].get<int>(), 0) << ls.dump();
  // The right eye's thread could not have its context: one eye thread, said and counted.
  EXPECT_EQ(ls["eye_threads"].get<int>(), 1) << ls.dump();
  EXPECT_GT(ls["frames_right_eye_composited"].get<int>(), 0) << ls.dump();
  bool warned = false;
  for (const auto& w : live["warnings"])
    warned = warned || (w.get<std::string>().find("the right eye's own thread could not start") != std::string::npos &&
                        w.get<std::string>().find("DENTAR_TEST_FAIL_EYE_CONTEXT") != std::string::npos);
  EXPECT_TRUE(warned) << live["warnings"].dump();
  if (live["display"]["path"] != "gl")
    std::printf("[ note ] the GPU display path did not come up here (%s): the note went the CPU path anyway\n",
                live["display"]["note"].get<std::string>().c_str());

  // The HUD's top lines, eye by eye (each eye's viewport 640x600; the HUD 12 % in from its
  // top-left corner): bright text pixels (the HUD's background darkens the video behind it
  // below them), present in each eye and at the same places.
  fs::path shot;
  for (int k = 4; k <= 7 && shot.empty(); ++k)
    if (fs::exists(dir / ("shot" + std::to_string(k) + ".png"))) shot = dir / ("shot" + std::to_string(k) + ".png");
  ASSERT_FALSE(shot.empty()) << "the window showed none of frames 4..7";
  const cv::Mat s = cv::imread(shot.string());
  ASSERT_EQ(s.cols, 1280) << shot;
  ASSERT_EQ(s.rows, 600) << shot;
  cv::Mat text[2];
  for (int e = 0; e < 2; ++e) {
    const cv::Rect hud(e * 640 + 77, 72, 384, 150);
    cv::Mat ch[3];
    cv::split(s(hud), ch);
    text[e] = cv::max(cv::max(ch[0], ch[1]), ch[2]) > 180;
    EXPECT_GT(cv::countNonZero(text[e]), 400) << "eye " << e << ": no HUD text";
  }
  const int inter = cv::countNonZero(text[0] & text[1]), uni = cv::countNonZero(text[0] | text[1]);
  ASSERT_GT(uni, 0);
  EXPECT_GT(static_cast<double>(inter) / uni, 0.7) << "the eyes' HUDs differ";
}
