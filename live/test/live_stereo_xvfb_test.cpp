// `dentar live` with a stereo head (issue 28) as a user runs it, under Xvfb: two cameras (paced
// Motion JPEG stand-ins, as two UVC webcams deliver), the right one unplugged for 0.8 s mid-run,
// then the left one (the stall hooks); each time the other eye tracks and draws alone and pairs
// come back. The run recorded with both eyes and replayed by `dentar offline` through the
// stereo path: the same eyes, states and poses per frame, and the same final cut. Skips without
// xvfb-run unless DENTAR_REQUIRE_GL=1 (CI installs it).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "testutil.h"
#include "xvfb_util.h"

namespace fs = std::filesystem;
using dentar::test::read_json;
using dentar::test::run_command;
using dentar::test::xvfb;

namespace {

const std::string kBin = DENTAR_BINARY;

std::vector<std::vector<std::string>> read_csv(const fs::path& p) {
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
}

int col(const std::vector<std::string>& header, const std::string& name) {
  for (std::size_t i = 0; i < header.size(); ++i)
    if (header[i] == name) return static_cast<int>(i);
  return -1;
}

// The side-by-side clip's eyes as two Motion JPEG files (a UVC webcam's format), 30 fps. The
// clip's frames are written kRepeats times over (as the stand-in's --loop would play them): the
// stand-in reopens its file at each end, and a 4-frame file reopened every 133 ms under load
// (session 21: load 15-18, the reopen's open and seek > 0.1 s) made a camera look lost (silent
// for 0.1 s) on its own: the GPU run below had the right eye "silent" 21 frames, one frame of
// the right eye alone and no switch. Once every ~1 s leaves the injected stalls the only ones.
constexpr int kRepeats = 8;
void write_eyes(const fs::path& sbs, const fs::path& left, const fs::path& right) {
  cv::VideoCapture in(sbs.string());
  ASSERT_TRUE(in.isOpened()) << sbs;
  std::vector<cv::Mat> f;
  for (cv::Mat m; in.read(m);) f.push_back(m.clone());
  ASSERT_FALSE(f.empty());
  const int w = f[0].cols / 2, h = f[0].rows;
  const int mjpg = cv::VideoWriter::fourcc('M', 'J', 'P', 'G');
  cv::VideoWriter L(left.string(), cv::CAP_FFMPEG, mjpg, 30, cv::Size(w, h));
  cv::VideoWriter R(right.string(), cv::CAP_FFMPEG, mjpg, 30, cv::Size(w, h));
  ASSERT_TRUE(L.isOpened() && R.isOpened());
  for (int rep = 0; rep < kRepeats; ++rep)
    for (const cv::Mat& m : f) {
      L.write(m(cv::Rect(0, 0, w, h)));
      R.write(m(cv::Rect(w, 0, w, h)));
    }
}

}  // namespace

TEST(LiveStereoXvfb, TwoCamerasEachEyeLostAndBackRecordedAndReplayed) {
  REQUIRE_XVFB();
  const fs::path t = dentar::test::temp_dir("live_stereo");
  const fs::path st = t / "st", rec = t / "rec", off = t / "off";
  // A short generated stereo clip (looped by the stand-ins): 4 frames, 2 x 640x480.
  auto r = run_command(kBin + " synth --preset standard --stereo --frames 4 --seed 3 --out " + st.string() + " 2>&1");
  if (r.code != 0 && !std::getenv("DENTAR_REQUIRE_GL")) GTEST_SKIP() << "dentar synth failed (no headless EGL?): " << r.out;
  ASSERT_EQ(r.code, 0) << r.out;
  write_eyes(st / "video.mkv", t / "l.avi", t / "r.avi");
  // The two stalls are apart by 1.0 s of the cameras' time (the right eye quiet from its frame
  // 12 for 0.8 s, the left from its frame 66): session 21 found them 0.2 s apart (left frame 42)
  // and under load (stress -c 2) the right camera, started later and reopened late, came back
  // only as the left went quiet: the run switched from the left eye alone straight to the right
  // eye alone, with no pair and so no "right camera back" between (1 failure in 1 run).
  r = run_command(xvfb(kBin + " live --camera live:" + (t / "l.avi").string() + " --camera-right live:" +
                       (t / "r.avi").string() + " --station " + (st / "station.json").string() + " --stylus replay:" +
                       (st / "session.dlog").string() + " --record " + rec.string() +
                       " --inject-stall-right 12:0.8 --inject-stall 66:0.8 --no-hud --loop --frames 90 --no-score --summary " +
                       (t / "live.json").string() + " 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  const auto live = read_json(t / "live.json");
  ASSERT_TRUE(live.contains("stereo")) << live.dump();
  const auto& ls = live["stereo"];
  std::printf("[ stereo ] %s\n", ls.dump().c_str());
  // The right eye went quiet and came back: single-view frames between pairs.
  EXPECT_GT(ls["frames_both_eyes"].get<int>(), 10);
  EXPECT_GE(ls["frames_left_eye_only"].get<int>(), 3);
  EXPECT_GE(ls["fallbacks"].get<int>(), 1);
  EXPECT_GE(ls["recoveries"].get<int>(), 1);
  // Issue 28: the single-view path takes over within 200 ms of the eye's last frame, and pairs
  // come back as soon as it returns. The pairing's own share is the first single-view frame's
  // wait for a partner: at most half a frame period (16.7 ms at 30 fps) plus a wake-up. The
  // rest is the next camera frame (33 ms) and that frame's trip through a busy machine: the
  // 200 ms is asserted whole when the frame went from capture to composite in under 100 ms (a
  // machine keeping up, as the mono stall test does), else printed.
  const double fb = ls["fallback_ms_max"].get<double>(), fb_frame = ls["fallback_frame_ms"].get<double>();
  const double back = ls["recovery_ms_max"].get<double>();
  EXPECT_GT(fb, 0);
  EXPECT_LE(ls["fallback_wait_ms"].get<double>(), 60) << "the frame waited for the lost eye";
  if (fb_frame < 100) {
    EXPECT_LE(fb, 200);
  } else if (fb > 200) {
    std::printf("[ note ] fallback %.0f ms, of which %.0f ms the frame's own capture-to-composite time on a loaded "
                "machine: the 200 ms is not asserted\n", fb, fb_frame);
  }
  EXPECT_GT(back, 0);
  EXPECT_LE(back, 1000);

  // Issue 28, session 17: the left camera lost too (it drives the loop): the right eye alone,
  // its overlay drawn (frames.csv below), then pairs again. Each switch is timed from the
  // capture of the lost camera's last frame (or the returning one's first) to the swap of the
  // first frame drawn in the new mode, and named with the camera's path.
  EXPECT_GE(ls["frames_right_eye_only"].get<int>(), 3);
  const auto& sw = ls["switches"];
  ASSERT_TRUE(sw.is_array());
  EXPECT_EQ(ls["mode_switches"].get<int>(), static_cast<int>(sw.size()));
  const std::string lcam = "live:" + (t / "l.avi").string(), rcam = "live:" + (t / "r.avi").string();
  int left_lost = -1, left_back = -1, right_lost = -1, right_back = -1;
  for (int i = 0; i < static_cast<int>(sw.size()); ++i) {
    const std::string what = sw[i]["what"], eyes = sw[i]["eyes"];
    const auto first = [&](int& at, const std::string& w, const char* want_eyes, bool after, const char* or_eyes = "") {
      if (what != w || at >= 0 || !after) return;
      at = i;
      EXPECT_TRUE(eyes == want_eyes || eyes == or_eyes) << sw.dump();
    };
    first(left_lost, "left camera lost (" + lcam + ")", "right", true);
    first(left_back, "left camera back (" + lcam + ")", "both", left_lost >= 0);
    first(right_lost, "right camera lost (" + rcam + ")", "left", true);
    // Session 22: the right camera back while the left one is lost (a loaded machine: left only
    // straight to right only) is its own switch, drawn with the right eye alone.
    first(right_back, "right camera back (" + rcam + ")", "both", right_lost >= 0, "right");
  }
  ASSERT_GE(left_lost, 0) << sw.dump();
  ASSERT_GT(left_back, left_lost) << sw.dump();
  ASSERT_GE(right_lost, 0) << sw.dump();
  ASSERT_GT(right_back, right_lost) << sw.dump();
  for (const int i : {left_lost, right_lost}) {
    const double drawn = sw[i]["drawn_ms"].get<double>(), frame = sw[i]["frame_ms"].get<double>();
    EXPECT_GT(drawn, 0);
    EXPECT_LE(frame, drawn);
    // As above: the 200 ms whole when the frame itself went from capture to swap in < 100 ms.
    if (frame < 100) {
      EXPECT_LE(drawn, 200) << sw[i].dump();
    } else if (drawn > 200) {
      std::printf("[ note ] %s drawn after %.0f ms, %.0f ms of it the frame's own (loaded machine)\n",
                  sw[i]["what"].get<std::string>().c_str(), drawn, frame);
    }
  }
  for (const int i : {left_back, right_back}) EXPECT_LE(sw[i]["drawn_ms"].get<double>(), 1000) << sw[i].dump();
  // The recovery figure is the right camera's return, timed from the same first frame back as
  // its switch (to the composite, before the swap): never longer than that switch. (Session 17's
  // CI run counted the left camera's return too, from a stamp set when the left was lost: 1033
  // ms against a 22 ms switch.)
  double right_back_drawn = 0;
  int right_backs = 0;
  for (const auto& s : sw)
    if (s["what"] == "right camera back (" + rcam + ")") {
      right_back_drawn = std::max(right_back_drawn, s["drawn_ms"].get<double>());
      ++right_backs;
    }
  // Session 23: every return of the right camera is a recovery, also one to the right eye alone
  // while the left camera is lost (listed, not counted until session 22).
  ASSERT_EQ(ls["switches_dropped"].get<int>(), 0) << ls.dump();
  EXPECT_EQ(ls["recoveries"].get<int>(), right_backs) << ls.dump();
  EXPECT_LE(back, right_back_drawn + 1.0) << ls.dump();
  EXPECT_NE(r.out.find("left camera lost (" + lcam + ")"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("left camera back (" + lcam + ")"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("right camera lost (" + rcam + ")"), std::string::npos) << r.out;

  // The recording keeps both eyes: the right eye's JPEG bytes beside the left's, only for the
  // frames that had it.
  const auto meta = read_json(rec / "recording.json");
  EXPECT_EQ(meta["stereo"]["head"], "two_cameras") << meta.dump();
  EXPECT_EQ(meta["frames_not_written"].get<int>(), 0);
  const int frames = meta["frames"].get<int>();
  EXPECT_EQ(meta["frame_files"]["jpg"].get<int>(), frames) << meta.dump();
  const auto lr = read_csv(rec / "frames.csv");
  ASSERT_EQ(static_cast<int>(lr.size()), frames + 1);
  const int l_eyes = col(lr[0], "eyes"), l_state = col(lr[0], "man_state"), l_T = col(lr[0], "man_T");
  ASSERT_GE(l_eyes, 0);
  const int l_overlay = col(lr[0], "overlay");
  ASSERT_GE(l_overlay, 0);
  int both = 0, left = 0, right = 0, right_drawn = 0;
  for (std::size_t i = 1; i < lr.size(); ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%06d.jpg", static_cast<int>(i - 1));
    const bool has_right = fs::exists(rec / "frames_right" / name);
    EXPECT_EQ(has_right, lr[i][l_eyes] == "both") << "frame " << i - 1 << " eyes " << lr[i][l_eyes];
    both += lr[i][l_eyes] == "both";
    left += lr[i][l_eyes] == "left";
    right += lr[i][l_eyes] == "right";
    right_drawn += lr[i][l_eyes] == "right" && lr[i][l_overlay] == "1";
  }
  EXPECT_EQ(both + left + right, frames);
  EXPECT_EQ(right, ls["frames_right_eye_only"].get<int>());
  // The overlay from the right eye alone (the footage's tooth is in view throughout).
  EXPECT_GE(right_drawn, right - 1) << right_drawn << " of " << right;
  EXPECT_EQ(meta["frame_files_right"]["jpg"].get<int>(), both);
  EXPECT_EQ(both, ls["frames_both_eyes"].get<int>());
  EXPECT_EQ(left, ls["frames_left_eye_only"].get<int>());

  // Replayed offline: through the stereo path, frame for frame as the live run tracked.
  r = run_command(kBin + " offline --footage " + rec.string() + " --out " + off.string() +
                  " --no-video --no-score --quiet 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("stereo: both eyes " + std::to_string(both) + " frames, left eye alone " + std::to_string(left) +
                       ", right eye alone " + std::to_string(right)),
            std::string::npos)
      << r.out;
  const auto off_sum = read_json(off / "summary.json");
  EXPECT_EQ(off_sum["volume_hash"], meta["volume_hash"]);
  EXPECT_EQ(off_sum["stereo"]["eyes"]["both"].get<int>(), both);
  const auto orows = read_csv(off / "frames.csv");
  ASSERT_EQ(orows.size(), lr.size());
  const int o_eyes = col(orows[0], "eyes"), o_state = col(orows[0], "man_state"), o_tx = col(orows[0], "man_tx_mm");
  ASSERT_GE(o_eyes, 0);
  int compared = 0;
  for (std::size_t i = 1; i < lr.size(); ++i) {
    EXPECT_EQ(orows[i][o_eyes], lr[i][l_eyes]) << "frame " << i - 1;
    EXPECT_EQ(orows[i][o_state], lr[i][l_state]) << "frame " << i - 1;
    if (lr[i][l_state] == "lost") continue;
    // Live writes full precision, offline 9 significant digits of mm.
    std::stringstream ss(lr[i][l_T]);
    double m[12];
    for (double& x : m) ss >> x;
    for (int k = 0; k < 3; ++k) {
      const double live_mm = m[k * 4 + 3] * 1e3, off_mm = std::stod(orows[i][o_tx + k]);
      EXPECT_NEAR(live_mm, off_mm, 1e-6 * std::max(1.0, std::abs(live_mm))) << "frame " << i - 1;
    }
    ++compared;
  }
  EXPECT_GT(compared, frames / 2);

  // Refused, saying why: one eye of a stereo recording (--eye); a right-eye file gone; the
  // session-15 form (the eyes column, no "stereo" in recording.json: the left eye only).
  r = run_command(kBin + " offline --footage " + rec.string() + " --eye left --out " + (t / "o_eye").string() +
                  " --quiet 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("drop --eye"), std::string::npos) << r.out;
  // --eye both stays allowed: the recording's pairs also give the right eye's composite.
  r = run_command(kBin + " offline --footage " + rec.string() + " --eye both --frames 6 --no-score --out " +
                  (t / "o_both").string() + " --quiet 2>&1");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_GT(fs::exists(t / "o_both" / "composite_right.mkv") ? fs::file_size(t / "o_both" / "composite_right.mkv") : 0u,
            0u);
  const fs::path bad = t / "rec_bad";
  fs::copy(rec, bad, fs::copy_options::recursive);
  std::size_t first_both = 1;
  while (first_both < lr.size() && lr[first_both][l_eyes] != "both") ++first_both;
  ASSERT_LT(first_both, lr.size());
  char gone[32];
  std::snprintf(gone, sizeof gone, "frame_%06d", static_cast<int>(first_both - 1));
  ASSERT_TRUE(fs::remove(bad / "frames_right" / (std::string(gone) + ".jpg")));
  r = run_command(kBin + " offline --footage " + bad.string() + " --out " + (t / "o_bad").string() +
                  " --no-video --no-score --quiet 2>&1");
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_NE(r.out.find(std::string(gone) + ".{jpg,png,ppm}: missing"), std::string::npos) << r.out;
  auto old_meta = meta;
  old_meta.erase("stereo");
  std::ofstream(bad / "recording.json") << old_meta.dump(2);
  r = run_command(kBin + " offline --footage " + bad.string() + " --out " + (t / "o_old").string() + " --quiet 2>&1");
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("recorded before `dentar live` kept the right eye"), std::string::npos) << r.out;

  // Session 18: the left camera lost on the GPU display path (`--display-path gl`: the left
  // eye's composite stays on the GPU, the right eye alone is the CPU path's). Every frame but
  // the right eye's alone went the GPU way, before the loss and after the return; the window
  // showed the right eye's own composite while the left was lost (its camera's frame, as
  // recorded, with the overlay drawn), not the last GPU composite of the left eye. The stall is
  // 1.0 s (0.6 until session 21): at load 27-29 the frame thread processed ~3 frames a second,
  // and a 0.6 s stall held fewer than the 3 right-eye-only frames asserted below.
  const fs::path g = t / "gpu";
  std::string shots;
  for (int k = 4; k <= 45; ++k) shots += " --screenshot " + std::to_string(k) + ":" + (g / ("shot" + std::to_string(k) + ".png")).string();
  fs::create_directories(g);
  r = run_command(xvfb(kBin + " live --camera live:" + (t / "l.avi").string() + " --camera-right live:" +
                       (t / "r.avi").string() + " --station " + (st / "station.json").string() + " --stylus replay:" +
                       (st / "session.dlog").string() + " --record " + (g / "rec").string() +
                       " --display-path gl --inject-stall 10:1.0 --no-hud --quiet --loop --frames 60 --no-score" + shots +
                       " --summary " + (g / "live.json").string() + " 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  const auto gs = read_json(g / "live.json");
  if (gs["display"]["path"] != "gl") {
    // No EGL window here (the test's machine): the CPU path, asserted above.
    std::printf("[ note ] the GPU display path did not come up (%s): not checked\n",
                gs["display"]["note"].get<std::string>().c_str());
    return;
  }
  std::printf("[ stereo gl ] %s\n", gs["stereo"].dump().c_str());
  const int g_right = gs["stereo"]["frames_right_eye_only"].get<int>();
  EXPECT_GE(g_right, 3) << gs["stereo"].dump();
  EXPECT_EQ(gs["display"]["gpu_frames"].get<int>(), gs["frames"]["processed"].get<int>() - g_right) << gs.dump();
  bool g_lost = false, g_back = false;
  for (const auto& s : gs["stereo"]["switches"]) {
    g_lost = g_lost || s["what"] == "left camera lost (" + lcam + ")";
    g_back = g_back || (g_lost && s["what"] == "left camera back (" + lcam + ")");
  }
  EXPECT_TRUE(g_lost && g_back) << gs["stereo"].dump();
  const auto gr = read_csv(g / "rec" / "frames.csv");
  ASSERT_GT(gr.size(), 1u);
  const int g_eyes = col(gr[0], "eyes");
  ASSERT_GE(g_eyes, 0);
  int g_compared = 0;
  for (int k = 4; k <= 45 && static_cast<std::size_t>(k + 1) < gr.size(); ++k) {
    const fs::path sp = g / ("shot" + std::to_string(k) + ".png");
    if (gr[static_cast<std::size_t>(k + 1)][g_eyes] != "right" || !fs::exists(sp)) continue;
    char name[32];
    std::snprintf(name, sizeof name, "frame_%06d.jpg", k);
    const cv::Mat shot = cv::imread(sp.string()), raw = cv::imread((g / "rec" / "frames" / name).string());
    ASSERT_FALSE(raw.empty()) << name;
    ASSERT_EQ(shot.size(), raw.size()) << sp;
    cv::Mat d, gray;
    cv::absdiff(shot, raw, d);
    cv::cvtColor(d, gray, cv::COLOR_BGR2GRAY);
    const cv::Mat over = gray > 24;
    const double changed = cv::countNonZero(over) / static_cast<double>(gray.total());
    // The overlay (the tooth and bur, drawn small) changed the picture; nothing else did.
    EXPECT_GT(cv::countNonZero(over), 100) << "frame " << k << ": no overlay on the right eye's frame";
    EXPECT_LT(changed, 0.05) << "frame " << k << ": the window is not the right eye's frame";
    EXPECT_LT(cv::mean(d, ~over)[0], 2.0) << "frame " << k;
    ++g_compared;
  }
  EXPECT_GT(g_compared, 0) << "no screenshot of a frame from the right eye alone";
}
