// End-to-end tests of `dentar live` as a user runs it: a real window under
// Xvfb, footage paced in real time as the camera (live:PATH), the haptic
// engine on its own thread, recording; then `dentar offline` on the
// recording. Skips (with a message) when xvfb-run is not installed, unless
// DENTAR_REQUIRE_GL=1 (CI installs it).
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <sstream>
#include <thread>

#include "dentar/ar/apriltags.h"
#include "dentar/ar/frame_gray.h"
#include "dentar/ar/frame_source.h"
#include "dentar/ar/station_scene.h"
#include "dentar/haptics/engine.h"
#include "dentar/haptics/replay.h"
#include "dentar/haptics/session_log.h"
#include "dentar/session/lesson_clock.h"
#include "dentar/session/run.h"
#include "dentar/training/exercise.h"
#include "dentar/volume/bur.h"
#include "tag_drawing.h"
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

std::vector<std::vector<std::string>> read_csv(const fs::path& p) {
  std::ifstream f(p);
  std::vector<std::vector<std::string>> rows;
  std::string line;
  while (std::getline(f, line)) {
    std::vector<std::string> v;
    std::stringstream ss(line);
    std::string c;
    while (std::getline(ss, c, ',')) v.push_back(c);
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

// Live rows against offline rows of the same frames: the same tracking
// state, and the same mannequin position (live writes full precision,
// offline 9 significant digits of mm). Returns the frames compared.
int compare_poses(const std::vector<std::vector<std::string>>& lr,
                  const std::vector<std::vector<std::string>>& orows) {
  const int l_state = col(lr[0], "man_state"), l_T = col(lr[0], "man_T");
  const int o_state = col(orows[0], "man_state"), o_tx = col(orows[0], "man_tx_mm");
  int compared = 0;
  for (std::size_t i = 1; i < lr.size() && i < orows.size(); ++i) {
    EXPECT_EQ(lr[i][l_state], orows[i][o_state]) << "frame " << i - 1;
    if (lr[i][l_state] == "lost") continue;
    std::stringstream ss(lr[i][l_T]);
    double m[12];
    for (double& x : m) ss >> x;
    for (int k = 0; k < 3; ++k) {
      const double live_mm = m[k * 4 + 3] * 1e3, off_mm = std::stod(orows[i][o_tx + k]);
      EXPECT_NEAR(live_mm, off_mm, 1e-6 * std::max(1.0, std::abs(live_mm))) << "frame " << i - 1;
    }
    ++compared;
  }
  return compared;
}

}  // namespace

// Live on footage with the replayed stylus, recorded; the window's pixels
// against the offline composite of the same frame; the recording replayed
// offline gives the same poses and the same final cut.
TEST(LiveXvfb, WindowMatchesOfflineAndRecordingReplays) {
  REQUIRE_XVFB();
  const fs::path c = clip();
  const fs::path t = dentar::test::temp_dir("live_e2e");
  const fs::path rec = t / "rec", off = t / "off";
  // The window is saved when frame k shows; under load the display may skip a frame for a newer
  // one (CI stop 38 lost frame 8), so ask for 8..16 and compare the first one shown.
  std::string shots;
  for (int k = 8; k <= 16; ++k) shots += " --screenshot " + std::to_string(k) + ":" + (t / ("shot" + std::to_string(k) + ".png")).string();
  auto r = run_command(xvfb(kBin + " live --camera live:" + (c / "video.mkv").string() + " --station " +
                            (c / "station.json").string() + " --stylus replay:" + (c / "session.dlog").string() +
                            " --record " + rec.string() + " --display-path gl --no-hud --quiet --loop --frames 150" + shots + " --summary " +
                            (t / "live.json").string() + " --exercise molar_class1_cavity 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  const auto meta = read_json(rec / "recording.json");
  EXPECT_TRUE(meta["complete"].get<bool>());
  // The live default: the full-frame tag search off the frame path.
  EXPECT_EQ(meta["discovery"], "async");
  EXPECT_EQ(meta["exercise"], "molar_class1_cavity");
  // The finished recorded session is scored against the recorded exercise,
  // with mirror use from the recording's frames and station.
  ASSERT_TRUE(fs::exists(rec / "score.html")) << r.out;
  const auto score = read_json(rec / "score.json");
  EXPECT_EQ(score["exercise"]["name"], "molar_class1_cavity");
  EXPECT_GE(score["outcome"]["points"].get<double>(), 0.0);
  EXPECT_LE(score["outcome"]["points"].get<double>(), 10.0);
  EXPECT_GT(score["outcome"]["removed_total_mm3"].get<double>(), 0.0);
  EXPECT_TRUE(score["process"]["mirror_use"].contains("available"));
  if (score["process"]["mirror_use"]["available"].get<bool>()) {
    EXPECT_GT(score["process"]["mirror_use"]["frames_tracked"].get<int>(), 0);
  }
  const auto live_sum = read_json(t / "live.json");
  // Sized in frames, not seconds: a slow machine takes longer, not fewer
  // frames. 150 frames (5 s of footage) cover the replayed session's first
  // cut, which comes by the session's clock (20 frames, 0.7 s, cut nothing
  // on a quiet machine).
  EXPECT_GE(live_sum["frames"]["displayed"].get<int>(), 150);
  EXPECT_EQ(live_sum["stop_reason"], "frame limit");
  EXPECT_GT(live_sum["engine"]["steps"].get<int>(), 1000);
  // The default display path: the composite stayed on the GPU, every frame,
  // and nothing was read back or blended on the CPU.
  EXPECT_EQ(live_sum["display"]["path"], "gl") << live_sum["display"]["note"];
  EXPECT_EQ(live_sum["display"]["gpu_frames"].get<int>(), live_sum["frames"]["processed"].get<int>());
  EXPECT_EQ(live_sum["display"]["readback_px"].get<long long>(), 0);
  EXPECT_EQ(live_sum["display"]["cpu_blend_px"].get<long long>(), 0);
  EXPECT_EQ(live_sum["display"]["gl_ready_timeouts"].get<int>(), 0);
  // Issue 24: the replayed stylus is drawn at each frame's exposure (no latency measured for this
  // station: 33 ms assumed), and the recording says which pose was drawn (frames.csv pose_step),
  // so the offline replay below draws the same bur (the screenshot comparison).
  EXPECT_EQ(live_sum["latency_compensation"]["source"], "assumed");
  EXPECT_EQ(live_sum["latency_compensation"]["camera_latency_ms"].get<double>(), 33.0);
  EXPECT_GT(live_sum["latency_compensation"]["frames_pose_at_exposure"].get<int>(),
            live_sum["frames"]["processed"].get<int>() / 2);

  r = run_command(kBin + " offline --footage " + rec.string() + " --out " + off.string() +
                  " --video-codec ffv1 --quiet 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  const auto off_sum = read_json(off / "summary.json");
  // Offline on the recording scores it against the recorded exercise too.
  EXPECT_EQ(read_json(off / "score.json")["exercise"]["name"], "molar_class1_cavity");
  // Same final cut, bit for bit.
  EXPECT_EQ(off_sum["volume_hash"], meta["volume_hash"]);
  EXPECT_EQ(off_sum["volume_hash"], live_sum["volume_hash"]);

  // Same tracked poses: the async searches are replayed on the same frames
  // and merged where the live run merged them. Live writes full precision,
  // offline 9 significant digits of mm.
  const auto lr = read_csv(rec / "frames.csv"), orows = read_csv(off / "frames.csv");
  ASSERT_GT(lr.size(), 10u);
  ASSERT_EQ(lr.size(), orows.size());
  {
    const int ds = col(lr[0], "disc_start"), dm = col(lr[0], "disc_merged");
    ASSERT_GE(ds, 0);
    ASSERT_GE(dm, 0);
    int starts = 0, merges = 0;
    for (std::size_t i = 1; i < lr.size(); ++i) {
      starts += lr[i][ds] == "1" ? 1 : 0;
      merges += lr[i][dm] != "-1" ? 1 : 0;
    }
    EXPECT_GE(starts, 1);
    EXPECT_GE(merges, 1);  // at least the first frame's search was merged
  }
  EXPECT_GT(compare_poses(lr, orows), 10);
  {
    const int ps = col(lr[0], "pose_step"), hs = col(lr[0], "haptic_steps");
    ASSERT_GE(ps, 0);
    // A pose the engine had made when the frame was drawn (the newest is haptic_steps - 1), and
    // on some frames an older one than the newest (33 steps at 1 kHz; fewer when the loaded
    // engine misses deadlines, so no number is asserted).
    // Session 23: an older pose can only be seen while the engine still steps. The replayed
    // session is 2 s from the engine's start; at load 23 the pipeline came up after it had
    // ended (haptic_steps 1967 from the second frame on, every pose the last one): counted, and
    // the check holds on the frames processed while it stepped.
    double h_last = 0;
    for (std::size_t i = 1; i < lr.size(); ++i) h_last = std::max(h_last, std::stod(lr[i][hs]));
    int drawn_at_exposure = 0, older = 0, while_stepping = 0;
    for (std::size_t i = 1; i < lr.size(); ++i) {
      const double p = std::stod(lr[i][ps]), h = std::stod(lr[i][hs]);
      if (p < 0) continue;
      ++drawn_at_exposure;
      EXPECT_LE(p, h - 1) << "row " << i;
      if (p < h - 2) ++older;
      if (h < h_last) ++while_stepping;
    }
    EXPECT_GT(drawn_at_exposure, static_cast<int>(lr.size()) / 2);
    std::printf("[ poses ] %d frames drawn at exposure, %d while the replay stepped, %d of them an older pose\n",
                drawn_at_exposure, while_stepping, older);
    EXPECT_TRUE(older > 0 || while_stepping == 0)
        << "frames drawn while the engine stepped, none with a pose older than the newest";
  }

  // The window showed the composite of frame k (the first of 8..16 shown): compare with the
  // offline composite of the same frame (lossless video).
  int k_shot = 8;
  cv::Mat shot;
  for (; k_shot <= 16 && shot.empty(); ++k_shot) {
    const fs::path f = t / ("shot" + std::to_string(k_shot) + ".png");
    if (fs::exists(f)) shot = cv::imread(f.string());
  }
  --k_shot;
  ASSERT_FALSE(shot.empty()) << "no screenshot of frames 8..16 was taken";
  cv::VideoCapture vc((off / "composite.mkv").string());
  cv::Mat frame;
  for (int k = 0; k <= k_shot; ++k) ASSERT_TRUE(vc.read(frame));
  ASSERT_EQ(shot.size(), frame.size());
  cv::Mat diff;
  cv::absdiff(shot, frame, diff);
  const double mean = cv::mean(diff)[0];
  cv::Mat gray;
  cv::cvtColor(diff, gray, cv::COLOR_BGR2GRAY);
  const double big = cv::countNonZero(gray > 24) / double(gray.total());
  EXPECT_LT(mean, 1.5) << "mean abs difference";
  EXPECT_LT(big, 0.005) << "fraction of pixels off by more than 24";
  // The overlay is really in both (not two raw frames): the composite differs from the raw frame.
  // Lossless: PNG, or PPM when the writer was behind (recorder.h).
  char name[32];
  std::snprintf(name, sizeof name, "frame_%06d", k_shot);
  const fs::path png = rec / "frames" / (std::string(name) + ".png");
  const cv::Mat raw = cv::imread((fs::exists(png) ? png : rec / "frames" / (std::string(name) + ".ppm")).string());
  ASSERT_FALSE(raw.empty());
  cv::absdiff(raw, frame, diff);
  cv::cvtColor(diff, gray, cv::COLOR_BGR2GRAY);
  EXPECT_GT(cv::countNonZero(gray > 24), 100) << "no overlay drawn in frame " << k_shot;
}

// A Motion JPEG camera (a webcam at 720p): the recording keeps the camera's
// own JPEG bytes (no encoding on the live path) and still replays bit for
// bit: the same final cut and the same poses. Run with a linear camera
// response (not the default): recording.json keeps it, and the replay,
// told nothing, tracks with it (with sRGB the poses would differ).
TEST(LiveXvfb, MotionJpegCameraRecordsItsOwnBytesAndReplays) {
  REQUIRE_XVFB();
  const fs::path c = clip();
  const fs::path t = dentar::test::temp_dir("live_mjpg");
  const fs::path cam = c / "camera.avi", rec = t / "rec", off = t / "off";
  ASSERT_TRUE(fs::exists(cam)) << "dentar synth --webcam wrote no camera.avi";
  auto r = run_command(xvfb(kBin + " live --camera live:" + cam.string() + " --station " +
                            (c / "station.json").string() + " --stylus replay:" + (c / "session.dlog").string() +
                            " --record " + rec.string() +
                            " --camera-response linear --no-hud --quiet --loop --frames 12 --summary " +
                            (t / "live.json").string() + " 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  const auto meta = read_json(rec / "recording.json");
  EXPECT_EQ(meta["camera_response"], "linear") << meta.dump();
  EXPECT_EQ(meta["mirror_rim"], false) << meta.dump();
  const int frames = meta["frames"].get<int>();
  EXPECT_GE(frames, 12);
  EXPECT_EQ(meta["frames_not_written"].get<int>(), 0);
  EXPECT_EQ(meta["frame_files"]["jpg"].get<int>(), frames) << meta.dump();
  EXPECT_TRUE(fs::exists(rec / "frames" / "frame_000000.jpg"));
  r = run_command(kBin + " offline --footage " + rec.string() + " --out " + off.string() + " --quiet 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(read_json(off / "summary.json")["volume_hash"], meta["volume_hash"]);
  const auto lr = read_csv(rec / "frames.csv"), orows = read_csv(off / "frames.csv");
  ASSERT_EQ(lr.size(), orows.size());
  EXPECT_GT(compare_poses(lr, orows), 3);
}

// Issue 28: a YUYV camera's own pixels through live capture. The stand-in is the shared
// clip as a UVC camera sends it (raw YUY2); the frame thread gets YUYV (tracked from its
// luma, converted only by the compositor), the recording keeps the camera's pixels (as
// BGR, OpenCV's conversion of exactly the bytes sent), and the overlay is drawn. Asking a
// camera for a format it does not deliver is refused with both named (exit 2).
TEST(LiveXvfb, YuyvCameraIsCarriedAsItCameAndRecorded) {
  REQUIRE_XVFB();
  const fs::path c = clip();
  const fs::path t = dentar::test::temp_dir("live_yuyv");
  const fs::path cam = t / "camera_yuyv.avi", rec = t / "rec";
  std::vector<cv::Mat> yuyv;
  {
    cv::VideoCapture v((c / "video.mkv").string(), cv::CAP_FFMPEG);
    ASSERT_TRUE(v.isOpened());
    cv::Mat bgr;
    while (yuyv.size() < 30 && v.read(bgr)) dentar::ar::bgr_to_yuyv(bgr, yuyv.emplace_back());
  }
  ASSERT_EQ(yuyv.size(), 30u);
  ASSERT_TRUE(dentar::ar::write_yuyv_avi(cam.string(), yuyv, 30).ok());
  const std::string common = " --station " + (c / "station.json").string() + " --stylus replay:" +
                             (c / "session.dlog").string() + " --camera-response linear --no-hud --loop";
  auto r = run_command(xvfb(kBin + " live --camera live:" + cam.string() + common + " --record " + rec.string() +
                            " --frames 20 --summary " + (t / "live.json").string() + " 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("YUYV as the camera sent it"), std::string::npos) << r.out;
  const auto meta = read_json(rec / "recording.json");
  const int frames = meta["frames"].get<int>();
  EXPECT_GE(frames, 12);
  EXPECT_EQ(meta["frames_not_written"].get<int>(), 0);
  // Each recorded frame is one of the camera's frames exactly (OpenCV's conversion of its bytes).
  std::vector<cv::Mat> want(yuyv.size());
  for (std::size_t k = 0; k < yuyv.size(); ++k) cv::cvtColor(yuyv[k], want[k], cv::COLOR_YUV2BGR_YUYV);
  const auto lr = read_csv(rec / "frames.csv");
  const int state_col = col(lr[0], "man_state");
  ASSERT_GE(state_col, 0);
  int checked = 0, tracked = 0, after_first = 0;
  for (std::size_t i = 1; i < lr.size(); ++i) {
    const bool t_i = lr[i][static_cast<std::size_t>(state_col)] != "lost";
    if (t_i || tracked > 0) ++after_first;  // from the first tracked frame on (acquisition runs off the frame path)
    tracked += t_i ? 1 : 0;
    char stem[32];
    std::snprintf(stem, sizeof stem, "frame_%06zu", i - 1);
    fs::path f = rec / "frames" / (std::string(stem) + ".png");
    if (!fs::exists(f)) f = rec / "frames" / (std::string(stem) + ".ppm");
    const cv::Mat got = cv::imread(f.string());
    ASSERT_FALSE(got.empty()) << f;
    double best = 1e9;
    for (const cv::Mat& w : want) best = std::min(best, cv::norm(got, w, cv::NORM_INF));
    EXPECT_EQ(best, 0.0) << f;
    ++checked;
  }
  EXPECT_GE(checked, 20);
  EXPECT_GE(tracked, 5);
  EXPECT_GE(tracked, after_first * 9 / 10);  // tracked from the luma, once acquired: the overlay is drawn
  // The bare passthrough viewer: the window converts the YUYV frame once into its upload and
  // shows the camera's frame (the window is the video's size).
  std::string shots;
  for (int i = 2; i <= 10; ++i) shots += " --screenshot " + std::to_string(i) + ":" + (t / ("shot" + std::to_string(i) + ".png")).string();
  r = run_command(xvfb(kBin + " live --passthrough --camera live:" + cam.string() + " --station " +
                       (c / "station.json").string() + " --stylus none --no-hud --quiet --loop --frames 8" + shots + " 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  int shown = 0;
  for (int i = 2; i <= 10; ++i) {
    const cv::Mat shot = cv::imread((t / ("shot" + std::to_string(i) + ".png")).string(), cv::IMREAD_COLOR);
    if (shot.empty()) continue;
    double best_off = 1.0;
    for (const cv::Mat& w : want) {
      if (w.size() != shot.size()) continue;
      cv::Mat d, grey;
      cv::absdiff(w, shot, d);
      cv::cvtColor(d, grey, cv::COLOR_BGR2GRAY);
      best_off = std::min(best_off, cv::countNonZero(grey > 24) / double(grey.total()));
    }
    EXPECT_LT(best_off, 0.001) << "window frame " << i << ": share of pixels off by > 24 against the closest camera frame";
    ++shown;
  }
  EXPECT_GT(shown, 0) << "no screenshot of frames 2..10 was taken";
  // A format the camera does not deliver: refused, both named.
  r = run_command(xvfb(kBin + " live --camera live:" + cam.string() + common + " --camera-format mjpg --frames 3 2>&1"));
  EXPECT_EQ(r.code, 1) << r.out;  // as any camera that cannot be opened as asked (LiveCli.MissingCameraExplains)
  EXPECT_NE(r.out.find("asked for MJPG but it delivers YUY2"), std::string::npos) << r.out;
}

// When the window's context cannot share with the compositor's (here: made
// with GLX by a test hook), live falls back to the CPU composite, says why,
// and still composites the overlay; the counters show the CPU path's traffic.
TEST(LiveXvfb, FallsBackToTheCpuPathWhenContextsCannotBeShared) {
  REQUIRE_XVFB();
  const fs::path c = clip();
  const fs::path t = dentar::test::temp_dir("live_fallback");
  const fs::path rec = t / "rec";
  auto r = run_command(xvfb(kBin + " live --camera live:" + (c / "video.mkv").string() + " --station " +
                            (c / "station.json").string() + " --stylus replay:" + (c / "session.dlog").string() +
                            " --display-path gl --window-glx --record " + rec.string() + " --no-score --no-hud --loop --frames 8" +
                            " --discovery inline --summary " +
                            (t / "live.json").string() + " 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("display path cpu"), std::string::npos) << r.out;
  const auto s = read_json(t / "live.json");
  EXPECT_EQ(s["display"]["path"], "cpu");
  EXPECT_NE(s["display"]["note"].get<std::string>().find("GLX"), std::string::npos) << s["display"]["note"];
  EXPECT_EQ(s["display"]["gpu_frames"].get<int>(), 0);
  EXPECT_GT(s["display"]["readback_px"].get<long long>(), 0);
  EXPECT_GT(s["display"]["cpu_blend_px"].get<long long>(), 0);
  bool warned = false;
  for (const auto& w : s["warnings"]) warned = warned || w.get<std::string>().find("CPU path used") != std::string::npos;
  EXPECT_TRUE(warned) << s["warnings"];
  // The window kept showing frames, and the composites had the overlay (the
  // pixels themselves are compared on the default path above; a screenshot
  // here would depend on the machine's load: a starved capture thread shows
  // the raw video by design).
  EXPECT_GE(s["frames"]["displayed"].get<int>(), 8);
  const auto rows = read_csv(rec / "frames.csv");
  ASSERT_GT(rows.size(), 1u);
  const int ov = col(rows[0], "overlay");
  ASSERT_GE(ov, 0);
  int with_overlay = 0;
  for (std::size_t i = 1; i < rows.size(); ++i) with_overlay += rows[i][ov] == "1" ? 1 : 0;
  EXPECT_GT(with_overlay, 0);
}

// The camera goes quiet for 1 s: the overlay is hidden within 200 ms, then
// frames come back and are processed again.
TEST(LiveXvfb, CameraStallHidesOverlayThenRecovers) {
  REQUIRE_XVFB();
  const fs::path c = clip();
  const fs::path t = dentar::test::temp_dir("live_stall");
  auto r = run_command(xvfb(kBin + " live --camera live:" + (c / "video.mkv").string() + " --station " +
                            (c / "station.json").string() + " --stylus none --quiet --loop --frames 30 --inject-stall 10:0.8 --summary " +
                            (t / "live.json").string() + " 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  const auto s = read_json(t / "live.json");
  const int hidden = s["overlay_hidden_ms_after_stall"].get<int>();
  const int before = s["stall_previous_check_ms"].get<int>();
  EXPECT_GE(hidden, 150) << "the stall was never noticed, or noticed too early";
  // Hidden at the first window check after 150 ms of silence: the check
  // before it still saw a live camera.
  EXPECT_GE(before, 0);
  EXPECT_LE(before, 150);
  // The window loop checks every <= 30 ms (+ one frame's drawing), so the
  // overlay is gone within 200 ms, unless the machine held the loop itself
  // off (a loaded machine: seen 333 ms with a 180 ms gap between checks);
  // then nothing could be drawn at all, with or without the overlay.
  if (hidden - before <= 50) {
    EXPECT_LE(hidden, 200);
  }
  // 10 frames before the stall; the run stops at 30 shown, so at least 20
  // were shown after the camera came back.
  EXPECT_GE(s["frames"]["displayed"].get<int>(), 30);
  EXPECT_EQ(s["stop_reason"], "frame limit");
  // --stylus none: no hand works the tooth (it once ran the simulated hand's script).
  EXPECT_EQ(s["removed_mm3"]["total"].get<double>(), 0.0);
  EXPECT_GT(s["engine"]["steps"].get<long>(), 0);
}

// SIGINT and SIGTERM mid-run: force zeroed first, logs flushed, the
// recording finalised and replayable.
class LiveSignal : public ::testing::TestWithParam<int> {};

TEST_P(LiveSignal, StopsCleanlyAndRecordingReplays) {
  REQUIRE_XVFB();
  const int sig = GetParam();
  const fs::path c = clip();
  const fs::path t = dentar::test::temp_dir(sig == SIGINT ? "live_sigint" : "live_sigterm");
  const fs::path rec = t / "rec";
  // xvfb-run forwards nothing: start Xvfb ourselves and signal dentar itself. Xvfb picks a free
  // display and writes its number once it accepts connections (-displayfd): a fixed number
  // collided with any other X server on it, and a fixed 0.7 s sleep was a guess at a loaded
  // machine's start-up.
  int dfd[2];
  ASSERT_EQ(pipe(dfd), 0);
  pid_t xpid = 0;
  {
    std::vector<std::string> a = {"Xvfb", "-displayfd", std::to_string(dfd[1]), "-screen", "0", "1280x1024x24",
                                  "-nolisten", "tcp"};
    std::vector<char*> argv;
    for (auto& s : a) argv.push_back(s.data());
    argv.push_back(nullptr);
    ASSERT_EQ(posix_spawnp(&xpid, "Xvfb", nullptr, nullptr, argv.data(), environ), 0);
  }
  close(dfd[1]);
  std::string disp = ":";
  for (char ch; read(dfd[0], &ch, 1) == 1 && ch != '\n';) disp += ch;  // EOF: Xvfb exited
  close(dfd[0]);
  ASSERT_GT(disp.size(), 1u) << "Xvfb wrote no display number (it exited)";
  pid_t pid = 0;
  {
    setenv("DISPLAY", disp.c_str(), 1);
    std::vector<std::string> a = {kBin, "live", "--camera", "live:" + (c / "video.mkv").string(), "--station",
                                  (c / "station.json").string(), "--stylus", "replay:" + (c / "session.dlog").string(),
                                  "--record", rec.string(), "--quiet", "--loop"};
    std::vector<char*> argv;
    for (auto& s : a) argv.push_back(s.data());
    argv.push_back(nullptr);
    ASSERT_EQ(posix_spawn(&pid, kBin.c_str(), nullptr, nullptr, argv.data(), environ), 0);
  }
  // Mid-run: once a few frames are recorded (a loaded machine takes longer
  // to set up), at most 30 s. The footage loops, so only the signal ends the run: played once,
  // the 2 s clip (real-time paced from the camera's start, as a camera) could end before the
  // window and pipeline were up on a loaded machine ("footage ended", session 22 at load 20-30).
  for (int i = 0; i < 300; ++i) {
    std::ifstream f(rec / "frames.csv");
    int lines = 0;
    for (std::string l; std::getline(f, l);) ++lines;
    if (lines >= 5) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  kill(pid, sig);
  // The footage loops: only the signal ends the run. Bounded: a run that ignores it is killed
  // and named (finalising the recording is real work, so the bound is generous for a loaded
  // machine; quiet it takes well under a second).
  int status = 0;
  bool exited = false;
  for (int i = 0; i < 1200 && !exited; ++i) {
    exited = waitpid(pid, &status, WNOHANG) == pid;
    if (!exited) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  if (!exited) {
    kill(pid, SIGKILL);
    waitpid(pid, &status, 0);
  }
  kill(xpid, SIGTERM);
  waitpid(xpid, nullptr, 0);
  ASSERT_TRUE(exited) << "dentar live was still running 120 s after the signal (killed)";
  ASSERT_TRUE(WIFEXITED(status)) << "dentar live did not exit by itself after the signal";
  EXPECT_EQ(WEXITSTATUS(status), 0);
  const auto meta = read_json(rec / "recording.json");
  EXPECT_TRUE(meta["complete"].get<bool>());
  EXPECT_EQ(meta["stop_reason"], sig == SIGINT ? "SIGINT" : "SIGTERM");
  const std::string log = dentar::test::read_file(rec / "live.log");
  const auto zero = log.find("engine stopped: zero force sent"), fin = log.find("stopped: SIG");
  ASSERT_NE(zero, std::string::npos) << log;
  ASSERT_NE(fin, std::string::npos) << log;
  EXPECT_LT(zero, fin) << "the force must be zeroed before the recording is finalised";
  auto r = run_command(kBin + " offline --footage " + rec.string() + " --out " + (t / "off").string() +
                       " --no-video --quiet 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(read_json(t / "off" / "summary.json")["volume_hash"], meta["volume_hash"]);
}

INSTANTIATE_TEST_SUITE_P(Signals, LiveSignal, ::testing::Values(SIGINT, SIGTERM));

// Closing the window (Escape, as a window manager's close does the same
// through glfwWindowShouldClose) ends the run the same clean way.
TEST(LiveXvfb, WindowCloseStopsCleanly) {
  REQUIRE_XVFB();
  if (std::system("command -v xdotool >/dev/null 2>&1") != 0) {
    if (std::getenv("DENTAR_REQUIRE_GL")) FAIL() << "xdotool missing (apt install xdotool)";
    GTEST_SKIP() << "xdotool not installed";
  }
  const fs::path c = clip();
  const fs::path t = dentar::test::temp_dir("live_close");
  const fs::path rec = t / "rec";
  // One shell under xvfb-run: start live, wait for its window, press Escape in it.
  const std::string script = t.string() + "/close.sh";
  dentar::test::write_file(script,
      "#!/bin/sh\n" + kBin + " live --camera live:" + (c / "video.mkv").string() + " --station " +
      (c / "station.json").string() + " --stylus replay:" + (c / "session.dlog").string() + " --record " + rec.string() +
      " --loop --quiet &\npid=$!\n"
      "for i in $(seq 1 100); do w=$(xdotool search --name 'DentAR live' 2>/dev/null | head -1); [ -n \"$w\" ] && break; sleep 0.1; done\n"
      "sleep 1.5\nxdotool key --window \"$w\" Escape\nwait $pid\necho exit=$?\n");
  auto r = run_command(xvfb("sh " + script + " 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("exit=0"), std::string::npos) << r.out;
  const auto meta = read_json(rec / "recording.json");
  EXPECT_TRUE(meta["complete"].get<bool>());
  EXPECT_EQ(meta["stop_reason"], "window closed");
}

// Issue 28: the bare passthrough viewer (the latency benchmarks' rival) shows the camera's
// own frames: the window matches one decoded footage frame everywhere (an AR composite would
// differ over the tooth's few thousand pixels), no frame pipeline runs, the CPU path is used.
TEST(LiveXvfb, PassthroughShowsTheCameraFramesWithoutAr) {
  REQUIRE_XVFB();
  const fs::path c = clip();
  const fs::path t = dentar::test::temp_dir("live_passthrough");
  // The window for every frame index from 2 to 20 that shows (a loaded machine shows some of them).
  std::string shots;
  for (int i = 2; i <= 20; ++i) shots += " --screenshot " + std::to_string(i) + ":" + (t / ("shot" + std::to_string(i) + ".png")).string();
  auto r = run_command(xvfb(kBin + " live --passthrough --camera live:" + (c / "camera.avi").string() + " --station " +
                            (c / "station.json").string() + " --stylus none --no-hud --quiet --loop --frames 12" + shots +
                            " --summary " + (t / "s.json").string() + " 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  const auto s = read_json(t / "s.json");
  EXPECT_GE(s["frames"]["displayed"].get<int>(), 12);
  EXPECT_EQ(s["display"]["path"], "cpu");
  EXPECT_EQ(s["process_ms"]["p99"].get<double>(), 0.0);  // the frame pipeline never ran
  EXPECT_GT(s["latency_ms"]["p50"].get<double>(), 0.0);
  std::vector<cv::Mat> frames;
  cv::VideoCapture cap((c / "camera.avi").string());
  for (cv::Mat f; cap.read(f);) frames.push_back(f.clone());
  ASSERT_FALSE(frames.empty());
  int checked = 0;
  for (int i = 2; i <= 20; ++i) {
    const cv::Mat shot = cv::imread((t / ("shot" + std::to_string(i) + ".png")).string(), cv::IMREAD_COLOR);
    if (shot.empty()) continue;
    cv::Mat d, grey;
    double best_off = 1.0;
    for (const cv::Mat& f : frames) {
      if (f.size() != shot.size()) continue;
      cv::absdiff(f, shot, d);
      cv::cvtColor(d, grey, cv::COLOR_BGR2GRAY);
      best_off = std::min(best_off, cv::countNonZero(grey > 24) / double(grey.total()));
    }
    EXPECT_LT(best_off, 0.001) << "frame " << i << ": share of pixels off by > 24 against the closest footage frame";
    ++checked;
  }
  EXPECT_GT(checked, 0) << "no screenshot of frames 2..20 was taken";
  // Bad input: nothing to record without AR.
  auto b = run_command(kBin + " live --passthrough --record " + (t / "rec").string() + " --camera live:" +
                       (c / "camera.avi").string() + " 2>&1");
  EXPECT_EQ(b.code, 2) << b.out;
  EXPECT_NE(b.out.find("leave out --record"), std::string::npos) << b.out;
}

// A truncated recording (as after a crash: the last CSV row cut short, the
// session log cut mid-block) still replays.
TEST(LiveXvfb, TruncatedRecordingReplays) {
  REQUIRE_XVFB();
  const fs::path c = clip();
  const fs::path t = dentar::test::temp_dir("live_trunc");
  const fs::path rec = t / "rec";
  auto r = run_command(xvfb(kBin + " live --camera live:" + (c / "video.mkv").string() + " --station " +
                            (c / "station.json").string() + " --stylus replay:" + (c / "session.dlog").string() +
                            " --record " + rec.string() + " --quiet --loop --frames 10 --no-realtime --summary " +
                            (t / "live.json").string() + " 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  // Without real time the engine cannot preempt the background threads, so
  // they stay off its core whatever --background-cpu says.
  const auto live = read_json(t / "live.json");
  if (live["engine"]["cpu_pinned"].get<bool>()) {  // two CPUs or more: the engine has its own
    EXPECT_NE(live["engine"]["isolation"].get<std::string>().find("background threads kept off the engine CPU"),
              std::string::npos)
        << live.dump(2);
  }
  // The default display path chooses by renderer: the CPU path on a software
  // rasteriser (llvmpipe under Xvfb), the GPU path on a hardware renderer.
  EXPECT_EQ(live["display"]["requested"], "auto");
  const std::string note = live["display"]["note"].get<std::string>();
  if (note.find("software rasteriser") != std::string::npos) {
    EXPECT_EQ(live["display"]["path"], "cpu") << note;
  } else {
    EXPECT_NE(note.find("hardware renderer"), std::string::npos) << note;
  }
  EXPECT_EQ(live["stop_reason"], "frame limit");
  std::string csv = dentar::test::read_file(rec / "frames.csv");
  csv.resize(csv.size() - 10);  // the last row cut short
  dentar::test::write_file(rec / "frames.csv", csv);
  const auto size = fs::file_size(rec / "session.dlog");
  fs::resize_file(rec / "session.dlog", size - 100);
  r = run_command(kBin + " offline --footage " + rec.string() + " --out " + (t / "off").string() +
                  " --no-video --quiet 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  const auto s = read_json(t / "off" / "summary.json");
  EXPECT_GT(s["frames"].get<int>(), 3);
}

// A haptic device through its vendor runtime: the stand-in libHD.so built in
// the test tree, found through LD_LIBRARY_PATH as the real one would be.
TEST(LiveXvfb, HapticDeviceThroughTheStandInRuntime) {
  REQUIRE_XVFB();
  const fs::path c = clip();
  const fs::path t = dentar::test::temp_dir("live_device");
  const std::string standin = (fs::path(kBin).parent_path() / "standin").string();
  auto r = run_command(xvfb("env LD_LIBRARY_PATH=" + standin + " " + kBin + " live --device touch --camera live:" +
                            (c / "video.mkv").string() + " --station " + (c / "station.json").string() +
                            " --record " + (t / "rec").string() + " --seconds 2 --quiet --summary " +
                            (t / "live.json").string() + " 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  const auto s = read_json(t / "live.json");
  EXPECT_GT(s["engine"]["steps"].get<int>(), 500);
  // Missed deadlines and watchdog trips are timing (a VM's host can hold the
  // engine off even under SCHED_FIFO: 4 trips seen on this machine while
  // loaded): they are benchmark figures (docs/BENCHMARKS.md "live"), not
  // asserted here. What is asserted: without SCHED_FIFO the background
  // threads were kept off the engine's core.
  // (On a one-CPU machine there is no engine core to keep them off.)
  if (!s["engine"]["realtime_granted"].get<bool>() && s["engine"]["cpu_pinned"].get<bool>()) {
    EXPECT_NE(s["engine"]["isolation"].get<std::string>().find("kept off the engine CPU"), std::string::npos)
        << s.dump(2);
  }
  const std::string log = dentar::test::read_file(t / "rec" / "live.log");
  EXPECT_NE(log.find("device "), std::string::npos) << log;
  EXPECT_NE(log.find("engine stopped: zero force sent"), std::string::npos) << log;
  // Without the runtime: a clear message at start, never a crash.
  r = run_command(kBin + " live --device touch --camera live:" + (c / "video.mkv").string() + " --station " +
                  (c / "station.json").string() + " --quiet 2>&1");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("libHD"), std::string::npos) << r.out;
}

// No camera: a clear message naming the cameras found and the footage route.
TEST(LiveCli, MissingCameraExplains) {
  auto r = run_command(kBin + " live --camera /dev/video97 --quiet 2>&1");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("Cameras found"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("--camera live:"), std::string::npos) << r.out;
  r = run_command(kBin + " live --stylus wand 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("stylus"), std::string::npos) << r.out;
  r = run_command(kBin + " live --camera-response gamma22 --camera /dev/video97 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--camera-response"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("gamma22"), std::string::npos) << r.out;
}

// An exercise names the tooth drilled (issue: `--exercise incisor_partial_crown` used to drill
// a molar and then refuse to score): the simulated hand works the exercise's steps on the
// incisor, the session header names it, the session scores as the incisor, and the recording
// replays to the same cut on a rebuilt incisor.
TEST(LiveXvfb, ExerciseChoosesTheToothAndTheRecordingReplays) {
  REQUIRE_XVFB();
  const fs::path c = clip();
  const fs::path t = dentar::test::temp_dir("live_incisor");
  const fs::path rec = t / "rec", off = t / "off";
  auto r = run_command(xvfb(kBin + " live --camera live:" + (c / "video.mkv").string() + " --station " +
                            (c / "station.json").string() + " --stylus sim --exercise incisor_partial_crown --record " +
                            rec.string() + " --no-hud --quiet --loop --seconds 4 --summary " + (t / "live.json").string() +
                            " 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  // Sized in seconds, not frames: the engine runs in real time, and the simulated hand's expert
  // script of the exercise reaches the incisor's labial surface after about 2 s.
  const auto live_sum = read_json(t / "live.json");
  EXPECT_GT(live_sum["removed_mm3"]["enamel"].get<double>(), 0.0) << live_sum.dump(2);
  // The session header names the incisor at the station's voxel size.
  auto log = dentar::haptics::read_session_log((rec / "session.dlog").string());
  ASSERT_TRUE(log.ok()) << log.error();
  auto setup = dentar::haptics::parse_session_header(log->header_json);
  ASSERT_TRUE(setup.ok()) << setup.error();
  const auto tooth = nlohmann::json::parse(setup->tooth_json);
  EXPECT_EQ(tooth["kind"], "incisor") << setup->tooth_json;
  EXPECT_TRUE(tooth["voxel_mm"].is_number()) << setup->tooth_json;
  // With the exercise's bur (a cone, 0.4 to 0.6 mm), not live's default capsule.
  EXPECT_EQ(setup->bur.shape, dentar::volume::BurShape::kCone);
  EXPECT_NEAR(setup->bur.radius_m, 0.6e-3, 1e-9);
  // Scored as the incisor by the run itself (exit 0 above; a failure to score is only a warning).
  EXPECT_NE(r.out.find("(incisor_partial_crown)"), std::string::npos) << r.out;
  ASSERT_TRUE(fs::exists(rec / "score.json")) << r.out;
  EXPECT_EQ(read_json(rec / "score.json")["exercise"]["name"], "incisor_partial_crown") << r.out;
  EXPECT_GT(read_json(rec / "score.json")["outcome"]["removed_total_mm3"].get<double>(), 0.0);
  // The replay rebuilds the incisor from the header (volume_hash_start checked), ends on the
  // same cut bit for bit, and scores it as the incisor again (by the recorded exercise).
  r = run_command(kBin + " offline --footage " + rec.string() + " --out " + off.string() + " --quiet 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(read_json(off / "summary.json")["volume_hash"], live_sum["volume_hash"]);
  EXPECT_EQ(read_json(off / "score.json")["exercise"]["name"], "incisor_partial_crown");
  EXPECT_EQ(read_json(rec / "recording.json")["volume_hash"], live_sum["volume_hash"]);
  // The simulated person is recorded: the defaults, the expert script of seed 1 without style.
  const auto hand = read_json(rec / "recording.json")["hand"];
  EXPECT_EQ(hand["skill"].get<double>(), 1.0) << hand.dump();
  EXPECT_EQ(hand["style"].get<double>(), 0.0) << hand.dump();
  EXPECT_EQ(hand["seed"].get<int>(), 1) << hand.dump();
  // Stopped by the time limit: the hand's script of 13 steps takes minutes.
  EXPECT_EQ(live_sum["stop_reason"], "time limit") << live_sum.dump(2);
}

// An exercise for another tooth than the replayed log's: refused at once as bad input (exit 2),
// naming both teeth; no window is opened.
TEST(LiveCli, ExerciseForAnotherToothThanTheReplayedLogIsRefused) {
  const fs::path c = clip();
  auto r = run_command(kBin + " live --camera live:" + (c / "video.mkv").string() + " --station " +
                       (c / "station.json").string() + " --stylus replay:" + (c / "session.dlog").string() +
                       " --exercise incisor_partial_crown --quiet 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("incisor_partial_crown"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("incisor"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("molar"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("session.dlog"), std::string::npos) << r.out;
}

// ---- The webcam try-out: the box station and the printed pen ----

namespace {

// What a webcam sees at the try-out: the printed box board and the pen's
// flag, the pen tip going down into the virtual tooth and back (5 s at
// 30 fps). Writes pen.mkv (lossless) and station.json (the box station,
// no lens distortion) into dir.
void make_pen_clip(const fs::path& dir) {
  using namespace dentar::ar;
  StationScene st = box_station_scene();
  st.calibration.camera.dist.fill(0.0);
  const auto& k = st.calibration.camera;
  ASSERT_TRUE(write_station_scene(st, (dir / "station.json").string()).ok());
  // Camera 30 cm in front of and 25 cm above the board, looking at the tooth.
  const Eigen::Vector3d eye(0, -0.30, 0.25), target(0, 0, 0.02);
  Eigen::Matrix3d R_man_cam;
  R_man_cam.col(2) = (target - eye).normalized();
  R_man_cam.col(0) = Eigen::Vector3d::UnitX();
  R_man_cam.col(1) = R_man_cam.col(2).cross(R_man_cam.col(0));
  Eigen::Isometry3d T_man_cam = Eigen::Isometry3d::Identity();
  T_man_cam.linear() = R_man_cam;
  T_man_cam.translation() = eye;
  const Eigen::Isometry3d T_cam_man = T_man_cam.inverse();
  // The pen leans toward the camera's side, its flag facing the camera:
  // ptag y along the pen toward the tip, x along the board's x.
  const Eigen::Vector3d d = Eigen::Vector3d(0, 0.3, -1).normalized();
  Eigen::Matrix3d R_man_ptag;
  R_man_ptag.col(0) = Eigen::Vector3d::UnitX();
  R_man_ptag.col(1) = d;
  R_man_ptag.col(2) = R_man_ptag.col(0).cross(d);
  // Tip path: from 8 mm above the crown's centre to 4 mm above the cervical
  // plane (well inside the crown), held, then back out.
  const Eigen::Vector3d above = st.calibration.T_man_tooth * Eigen::Vector3d(0, 0, 0.016);
  const Eigen::Vector3d inside = st.calibration.T_man_tooth * Eigen::Vector3d(0, 0, 0.004);
  const TagFamily fam = TagFamily::create(st.family);
  cv::VideoWriter vw((dir / "pen.mkv").string(), cv::CAP_FFMPEG, cv::VideoWriter::fourcc('F', 'F', 'V', '1'), 30,
                     cv::Size(k.width, k.height));
  ASSERT_TRUE(vw.isOpened());
  for (int i = 0; i < 150; ++i) {
    const double s = i < 30 ? 0.0 : i < 60 ? (i - 30) / 30.0 : i < 130 ? 1.0 : std::max(0.0, 1.0 - (i - 130) / 15.0);
    const Eigen::Vector3d tip = above + s * (inside - above);
    Eigen::Isometry3d T_man_ptag = Eigen::Isometry3d::Identity();
    T_man_ptag.linear() = R_man_ptag;
    T_man_ptag.translation() = tip - R_man_ptag * st.pen.T_ptag_tip.translation();
    cv::Mat gray(k.height, k.width, CV_8UC1, cv::Scalar(170));
    for (const TagPlacement& t : st.mannequin_tags) dentar::ar::test::draw_tag_pinhole(gray, fam, t, T_cam_man, k);
    dentar::ar::test::draw_tag_pinhole(gray, fam, st.pen.tags[0], T_cam_man * T_man_ptag, k);  // the front of the flag
    cv::Mat bgr;
    cv::cvtColor(gray, bgr, cv::COLOR_GRAY2BGR);
    vw.write(bgr);
  }
}

}  // namespace

// The README's try-out, as a newcomer does it with a webcam: the box board
// and the pen tracked, the pen's tip driving the engine, the space bar as the
// pedal. With the space bar held the pen cuts the tooth (and the recording
// replays to the same cut); without it nothing is removed.
TEST(LiveXvfb, PenCutsTheToothWhileTheSpaceBarIsHeld) {
  REQUIRE_XVFB();
  if (std::system("command -v xdotool >/dev/null 2>&1") != 0) {
    if (std::getenv("DENTAR_REQUIRE_GL")) FAIL() << "xdotool missing (apt install xdotool)";
    GTEST_SKIP() << "xdotool not installed";
  }
  const fs::path t = dentar::test::temp_dir("live_pen");
  make_pen_clip(t);
  if (HasFatalFailure()) return;
  auto live = [&](const std::string& name, bool press) {
    const std::string script = (t / (name + ".sh")).string();
    // The space bar is held from when the window is visible and focused until the run ends: the
    // footage starts only after the pipeline's set-up (1-3 s under load), so a fixed hold timed
    // from the window's appearance covered a varying part of it (session 19). Without the focus,
    // xdotool falls back to a synthetic press whose release the X server then drops.
    const std::string find =
        "w=$(timeout 20 xdotool search --sync --onlyvisible --name 'DentAR live' | head -1)\n"
        "xdotool windowfocus --sync \"$w\"\n";
    const std::string keys = press ? find + "xdotool keydown --window \"$w\" space\nwait $pid\necho exit=$?\nxdotool keyup space\n"
                                   : find + "wait $pid\necho exit=$?\n";
    dentar::test::write_file(
        script, "#!/bin/sh\n" + kBin + " live --camera live:" + (t / "pen.mkv").string() + " --station " +
                    (t / "station.json").string() + " --stylus pen --no-occlusion --no-score --record " + (t / name).string() +
                    " --summary " + (t / (name + ".json")).string() + " --quiet &\npid=$!\n" + keys);
    return run_command(xvfb("sh " + script + " 2>&1"));
  };
  auto r = live("cut", true);
  ASSERT_EQ(r.code, 0) << r.out;
  ASSERT_NE(r.out.find("exit=0"), std::string::npos) << r.out;
  const auto sum = read_json(t / "cut.json");
  const auto rows = read_csv(t / "cut" / "frames.csv");
  ASSERT_GT(rows.size(), 20u);
  const int ps = col(rows[0], "pen_state"), ms = col(rows[0], "man_state"), pd = col(rows[0], "pedal");
  int pen_seen = 0, man_seen = 0, pedal_on = 0;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    pen_seen += rows[i][ps] != "lost" ? 1 : 0;
    man_seen += rows[i][ms] != "lost" ? 1 : 0;
    pedal_on += rows[i][pd] == "1" ? 1 : 0;
  }
  const double n = static_cast<double>(rows.size() - 1);
  EXPECT_GT(man_seen, 0.8 * n) << "the box board is tracked";
  EXPECT_GT(pen_seen, 0.8 * n) << "the pen is tracked";
  // Held through the whole footage: on from the first frames (the press is read when the display
  // loop starts) and never released before the end.
  EXPECT_GT(pedal_on, 0.8 * n) << "the space bar is the pedal";
  int first_on = -1, last_off_after_on = -1;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    if (rows[i][pd] == "1" && first_on < 0) first_on = static_cast<int>(i);
    if (rows[i][pd] != "1" && first_on >= 0) last_off_after_on = static_cast<int>(i);
  }
  EXPECT_EQ(last_off_after_on, -1) << "the pedal was released at frame row " << last_off_after_on << " while the key was held";
  const double removed = sum["removed_mm3"]["total"].get<double>();
  EXPECT_GT(removed, 0.05) << "the pen's tip inside the crown with the pedal down cuts it";

  // The recording replays offline to the same cut.
  r = run_command(kBin + " offline --footage " + (t / "cut").string() + " --out " + (t / "cut_off").string() +
                  " --no-occlusion --no-score --quiet 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(read_json(t / "cut_off" / "summary.json")["volume_hash"], sum["volume_hash"]);

  // The same motion without the space bar removes nothing.
  r = live("nocut", false);
  ASSERT_EQ(r.code, 0) << r.out;
  const auto sum0 = read_json(t / "nocut.json");
  EXPECT_EQ(sum0["removed_mm3"]["total"].get<double>(), 0.0);
}


// Issue 26: "Try it live" rehearsed without a camera. `dentar synth --station box` makes 720p
// footage of the box station (the board on a box), and `dentar live --station box` plays it as
// a 1280x720 webcam against the built-in 640x480 intrinsics: accepted with the intrinsics scaled
// to the width and cropped (a warning says so), which is exactly the camera the footage was made
// with; the board is tracked; the station is a note, never INSTRUCTOR NEEDED.
TEST(LiveXvfb, BoxTryOutRehearsedWithoutACameraAt720p) {
  REQUIRE_XVFB();
  const fs::path t = dentar::test::temp_dir("live_box_rehearsal");
  auto r = run_command(kBin + " synth --station box --frames 45 --resolution 1280x720 --seed 4 --webcam --out " +
                       (t / "box").string() + " 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  ASSERT_TRUE(fs::exists(t / "box" / "camera.avi"));
  EXPECT_EQ(r.out.find("cannot open the station file"), std::string::npos) << r.out;
  r = run_command(xvfb(kBin + " live --camera live:" + (t / "box" / "camera.avi").string() +
                       " --station box --stylus replay:" + (t / "box" / "session.dlog").string() +
                       " --no-occlusion --no-score --loop --frames 30 --record " + (t / "rec").string() + " --summary " +
                       (t / "sum.json").string() + " --quiet 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  const auto sum = read_json(t / "sum.json");
  bool cropped = false;
  for (const auto& w : sum["warnings"]) cropped |= w.get<std::string>().find("cropped top and bottom") != std::string::npos;
  EXPECT_TRUE(cropped) << sum["warnings"].dump(2);
  EXPECT_FALSE(sum["station_health"]["instructor_needed"].get<bool>()) << sum["station_health"].dump(2);
  bool note = false;
  for (const auto& s : sum["station_health"]["items"])
    note |= s.get<std::string>().find("note: station: uncalibrated (built-in intrinsics)") == 0;
  EXPECT_TRUE(note) << sum["station_health"].dump(2);
  // The intrinsics live used (the recording's station) are the footage's true camera.
  const auto used = read_json(t / "rec" / "station.json")["camera"];
  const auto truth = read_json(t / "box" / "station.json")["camera"];
  ASSERT_TRUE(used.is_object() && truth.is_object()) << used.dump() << truth.dump();
  for (const char* k : {"width", "height", "fx", "fy", "cx", "cy"})
    EXPECT_NEAR(used[k].get<double>(), truth[k].get<double>(), 1e-6) << k;
  const auto rows = read_csv(t / "rec" / "frames.csv");
  ASSERT_GT(rows.size(), 20u);
  const int ms = col(rows[0], "man_state");
  int seen = 0;
  for (std::size_t i = 1; i < rows.size(); ++i) seen += rows[i][ms] != "lost" ? 1 : 0;
  EXPECT_GT(seen, 0.8 * static_cast<double>(rows.size() - 1)) << "the box board is tracked";
}

// ---- Lessons (issue 27): `dentar live --lesson LESSON --mode N` ----

// A lesson made from the clip's own 2 s session, trained live in mode 2 (passive guidance)
// with the simulated student: the mode ran (the summary's lesson section, its following error
// from the display loop; the session log's training section), the run stopped by itself when
// the expert's recording ended, the session was scored as the lesson's exercise, and it
// replays bit-exactly with the mode rebuilt from the header.
TEST(LiveXvfb, LessonModeTwoRunsIsRecordedScoredAndReplays) {
  REQUIRE_XVFB();
  const fs::path c = clip();
  const fs::path t = dentar::test::temp_dir("live_lesson");
  const fs::path lesson = t / "lesson", rec = t / "rec";
  // A text annotation at 0.3 s and a 1 s pause point at 0.8 s of the expert's recording.
  auto r = run_command(kBin + " lesson make " + (c / "session.dlog").string() +
                       " --exercise molar_access_opening --note '0.3:Enter at the central pit' --pause 0.8:1 --out " +
                       lesson.string() + " 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  r = run_command(xvfb(kBin + " live --camera live:" + (c / "video.mkv").string() + " --station " +
                       (c / "station.json").string() + " --stylus sim --lesson " + lesson.string() +
                       " --mode 2 --record " + rec.string() + " --quiet --loop --seconds 20 --summary " +
                       (t / "live.json").string() + " 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  const auto sum = read_json(t / "live.json");
  ASSERT_TRUE(sum.contains("lesson")) << sum.dump(2);
  const auto& l = sum["lesson"];
  EXPECT_EQ(l["mode"], 2) << l.dump();
  EXPECT_EQ(l["mode_name"], "passive guidance") << l.dump();
  EXPECT_EQ(l["fallback"], "") << l.dump();
  // The expert's clock reached the end of its 2 s recording: the run stopped itself.
  EXPECT_EQ(sum["stop_reason"], "the lesson's recording ended") << sum.dump(2);
  EXPECT_GE(l["expert_s"].get<double>(), l["expert_end_s"].get<double>()) << l.dump();
  EXPECT_GT(l["expert_end_s"].get<double>(), 1.5) << l.dump();
  // The student (1 mm beside the expert at the start, 0.2 mm aim wander, 0.25 s lag) is held
  // on the expert's path: sampled, and within a few millimetres (measured ~0.3-0.5 mm).
  EXPECT_GT(l["follow_error_mm"]["samples"].get<int>(), 0) << l.dump();
  EXPECT_GT(l["follow_error_mm"]["max"].get<double>(), 0.0) << l.dump();
  EXPECT_LT(l["follow_error_mm"]["mean"].get<double>(), 3.0) << l.dump();
  // The pause point held the expert's clock for its second (device time), and the note was
  // on the HUD when the expert's clock reached it (and logged in the recording's log).
  EXPECT_EQ(l["pauses"]["taken"], 1) << l.dump();
  EXPECT_NEAR(l["pauses"]["paused_s"].get<double>(), 1.0, 0.01) << l.dump();
  EXPECT_EQ(l["pauses"]["resumed_by_button"], 0) << l.dump();
  ASSERT_EQ(l["notes_shown"].size(), 2u) << l.dump();
  EXPECT_EQ(l["notes_shown"][0]["text"], "Enter at the central pit") << l.dump();
  EXPECT_NEAR(l["notes_shown"][0]["time_s"].get<double>(), 0.3, 1e-9) << l.dump();
  // Shown at the first display pass that saw the expert's clock at or past the note: the pass
  // before saw it not yet due (-1: there was none). (Session 18: this asserted expert_s < 0.5 s,
  // a bound on the display loop's pace in wall time: CI at load ~36 showed it 0.8 s late.)
  for (const auto& n : l["notes_shown"]) {
    EXPECT_GE(n["expert_s"].get<double>(), n["time_s"].get<double>()) << n.dump();
    EXPECT_LT(n["expert_s_before"].get<double>(), n["time_s"].get<double>()) << "a pass saw it due unshown " << n.dump();
  }
  std::printf("[ lesson ] note at 0.3 s shown at the expert's %.3f s (the pass before: %.3f s)\n",
              l["notes_shown"][0]["expert_s"].get<double>(), l["notes_shown"][0]["expert_s_before"].get<double>());
  EXPECT_EQ(l["notes_shown"][1]["text"], "pause") << l.dump();  // `lesson make --pause`'s own text
  EXPECT_NEAR(l["notes_shown"][1]["expert_s"].get<double>(), 0.8, 0.01) << l.dump();  // shown while the clock held
  // And in the AR view beside the tooth, in the frames while a note was on show (the
  // expert's clock within kNoteShowS of it: the whole 2 s recording here).
  EXPECT_GT(l["note_frames_in_view"].get<int>(), 0) << l.dump();
  {
    std::ifstream f(rec / "live.log");
    const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find("on the HUD: Enter at the central pit"), std::string::npos) << text;
  }
  // The session log's header records the mode and the expert recording it replayed.
  auto log = dentar::haptics::read_session_log((rec / "session.dlog").string());
  ASSERT_TRUE(log.ok()) << log.error();
  auto setup = dentar::haptics::parse_session_header(log->header_json);
  ASSERT_TRUE(setup.ok()) << setup.error();
  ASSERT_TRUE(setup->training.has_value()) << log->header_json;
  EXPECT_EQ(static_cast<int>(setup->training->params.mode), 2);
  EXPECT_NE(setup->training->params.expert_file.find("expert.dlog"), std::string::npos);
  const auto meta = read_json(rec / "recording.json");
  EXPECT_EQ(meta["lesson"]["mode"], 2) << meta.dump(2);
  EXPECT_EQ(meta["exercise"], "molar_access_opening") << meta.dump(2);
  // Scored by the finish step as the lesson's exercise.
  ASSERT_TRUE(fs::exists(rec / "score.json")) << r.out;
  EXPECT_EQ(read_json(rec / "score.json")["exercise"]["name"], "molar_access_opening");
  // Replayable: the log alone, with the mode rebuilt, ends on the live run's cut bit for bit.
  auto fresh = dentar::training::make_tooth(setup->tooth_json);
  ASSERT_TRUE(fresh.ok()) << fresh.error();
  auto rep = dentar::haptics::replay_session(*log, *fresh);
  ASSERT_TRUE(rep.ok()) << rep.error();
  char h[17];
  std::snprintf(h, sizeof h, "%016llx", static_cast<unsigned long long>(rep->volume_hash));
  EXPECT_EQ(sum["volume_hash"], h);
  EXPECT_EQ(meta["volume_hash"], h);
  // And as `dentar offline` replays it: session::Run rebuilds the mode from the log's header.
  auto st = dentar::ar::read_station_scene((rec / "station.json").string());
  ASSERT_TRUE(st.ok()) << st.error();
  auto ls = dentar::session::read_session_setup((rec / "session.dlog").string());
  ASSERT_TRUE(ls.ok()) << ls.error();
  auto run = dentar::session::Run::from_session_log(std::move(*ls), *st, "station.json");
  ASSERT_TRUE(run.ok()) << run.error();
  ASSERT_NE((*run)->lesson(), nullptr);
  EXPECT_EQ((*run)->lesson()->mode_run(), 2);
  // The lesson beside the expert's recording: a replay draws its notes too.
  ASSERT_EQ((*run)->lesson()->lesson().annotations.size(), 2u);
  EXPECT_EQ((*run)->lesson()->lesson().annotations[0].text, "Enter at the central pit");
  // Step by step: the pause button the pause point held is in the recording, for 1 s in one
  // piece; while it is down the expert's clock stands still; the expert's tool moves no
  // further in any step (the resume included) than in the recording's own steps.
  const std::uint64_t n = (*run)->session_steps();
  ASSERT_EQ(n, log->records.size());
  std::vector<double> expert_t(n);
  std::vector<Eigen::Vector3d> expert_p(n);
  for (std::uint64_t i = 0; i < n; ++i) {
    ASSERT_EQ((*run)->engine()->run_steps(1), 1u) << i;
    const auto snap = (*run)->engine()->snapshot();
    expert_t[i] = snap.expert_time_s;
    expert_p[i] = Eigen::Vector3d(snap.T_tooth_expert_tip[12], snap.T_tooth_expert_tip[13], snap.T_tooth_expert_tip[14]);
  }
  EXPECT_EQ((*run)->volume().content_hash(), rep->volume_hash);
  std::int64_t first = -1, last = -1, held = 0;
  for (std::uint64_t i = 0; i < n; ++i)
    if (log->records[i].buttons & dentar::haptics::kButtonSecondary) {
      if (first < 0) first = static_cast<std::int64_t>(i);
      last = static_cast<std::int64_t>(i);
      ++held;
    }
  ASSERT_GE(first, 0) << "no pause in the recording";
  EXPECT_EQ(held, last - first + 1) << "one pause, in one piece";
  EXPECT_NEAR(static_cast<double>(held), 1000.0, 2.0);  // 1 s at 1 kHz
  EXPECT_NEAR(expert_t[static_cast<std::size_t>(first)], 0.8, 0.01);
  EXPECT_EQ(expert_t[static_cast<std::size_t>(first)], expert_t[static_cast<std::size_t>(last)]);
  double max_move = 0, resume_move = 0;
  for (std::uint64_t i = 1; i < n; ++i) {
    const double d = (expert_p[i] - expert_p[i - 1]).norm();
    if (static_cast<std::int64_t>(i) == last + 1) resume_move = d;
    else if (static_cast<std::int64_t>(i) < first || static_cast<std::int64_t>(i) > last) max_move = std::max(max_move, d);
    else EXPECT_EQ(d, 0.0) << "the expert's tool moved while paused, step " << i;
  }
  EXPECT_GT(max_move, 0.0);
  EXPECT_LE(resume_move, max_move) << "the expert's tool jumped when the pause ended";
  // The guidance force fades out at the pause and in at the resume (ramp_s 0.25 s): around
  // both (0.3 s either side), no step changes the force sent by more than 10 % of the force
  // when the pause began (measured: 1.3 mN a step against 27 mN; without the ramp the first
  // paused step would drop all of it).
  double step_max = 0;
  auto fnorm = [&](std::size_t i) { return Eigen::Vector3d(log->records[i].force_dev_N).norm(); };
  const double f_pause = fnorm(static_cast<std::size_t>(first - 1));
  for (const std::int64_t edge : {first, last + 1})
    for (std::int64_t i = std::max<std::int64_t>(1, edge - 300); i < std::min<std::int64_t>(n, edge + 300); ++i)
      step_max = std::max(step_max, std::abs(fnorm(static_cast<std::size_t>(i)) - fnorm(static_cast<std::size_t>(i - 1))));
  EXPECT_GT(f_pause, 0.005);
  EXPECT_LE(step_max, 0.1 * f_pause) << "force when the pause began " << f_pause << " N";
}

// A force mode on a stylus with no force (the pen) falls back to visual guidance (mode 3) and
// says so; guidance stiffer than the device renders stably is lowered to its limit, noted.
TEST(LiveLesson, PenFallsBackToVisualGuidanceAndGainsFollowTheDevice) {
  const fs::path c = clip();
  const fs::path t = dentar::test::temp_dir("live_lesson_clock");
  auto r = run_command(kBin + " lesson make " + (c / "session.dlog").string() +
                       " --exercise molar_access_opening --out " + (t / "lesson").string() + " 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  dentar::haptics::DeviceLimits pen;
  for (int mode : {2, 4}) {
    auto l = dentar::session::LessonClock::open((t / "lesson").string(), mode, pen, false);
    ASSERT_TRUE(l.ok()) << l.error();
    EXPECT_EQ((*l)->mode_asked(), mode);
    EXPECT_EQ((*l)->mode_run(), 3);
    EXPECT_NE((*l)->fallback().find("falls back to visual guidance, mode 3"), std::string::npos) << (*l)->fallback();
    EXPECT_EQ(static_cast<int>((*l)->mode()->params().mode), 3);
    EXPECT_TRUE((*l)->mode()->params().conditional_replay);
  }
  auto l5 = dentar::session::LessonClock::open((t / "lesson").string(), 5, pen, false);
  ASSERT_TRUE(l5.ok()) << l5.error();
  EXPECT_EQ(l5.value()->mode_run(), 5);  // hints need no force
  EXPECT_EQ(l5.value()->fallback(), "");
  dentar::haptics::DeviceLimits weak;
  weak.max_stiffness_N_per_m = 100;  // guidance limit 0.4 x 100 = 40 N/m, below the lesson's default
  auto lw = dentar::session::LessonClock::open((t / "lesson").string(), 2, weak, true);
  ASSERT_TRUE(lw.ok()) << lw.error();
  EXPECT_EQ(lw.value()->mode_run(), 2);
  EXPECT_LE(lw.value()->mode()->params().guidance.k_N_per_m, 40.0 + 1e-9);
  ASSERT_FALSE(lw.value()->notes().empty());
  EXPECT_NE(lw.value()->notes()[0].find("guidance k lowered"), std::string::npos) << lw.value()->notes()[0];
  auto bad = dentar::session::LessonClock::open((t / "lesson").string(), 6, pen, true);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("--mode 6 must be 1..5"), std::string::npos) << bad.error();
}

// A stylus whose pose stays put, with the pause button down over [press_s, release_s) of its
// own clock (1 ms a read).
class StillStylus final : public dentar::haptics::HapticDevice {
 public:
  StillStylus(double press_s, double release_s) : press_(press_s), release_(release_s) {}
  std::string name() const override { return "still"; }
  const dentar::haptics::DeviceLimits& limits() const override { return limits_; }
  bool read(dentar::haptics::DeviceState& out) noexcept override {
    out = {};
    out.time_s = 1e-3 * static_cast<double>(reads_++);
    out.T_dev_sty.translation() = Eigen::Vector3d(0, 0, 0.1);  // 10 cm above the tooth: no contact
    if (out.time_s >= press_ && out.time_s < release_) out.buttons = dentar::haptics::kButtonSecondary;
    return true;
  }
  void write_force(const Eigen::Vector3d&) noexcept override {}

 private:
  dentar::haptics::DeviceLimits limits_;
  double press_, release_;
  std::int64_t reads_ = 0;
};

// A lesson's pause point, live (session::LessonPauseDevice in front of the engine): it holds
// the pause button from the moment the expert's clock reaches the point, the expert's clock
// stands still while it holds, and the student ends it early by pressing and releasing the
// stylus's pause button (the clock stays held while the button is down, then runs again).
TEST(LiveLesson, PausePointHoldsTheExpertUntilItsTimeOrTheButton) {
  const fs::path c = clip();
  const fs::path t = dentar::test::temp_dir("live_lesson_pause");
  auto r = run_command(kBin + " lesson make " + (c / "session.dlog").string() +
                       " --exercise molar_access_opening --pause 0.5:2 --out " + (t / "lesson").string() + " 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  dentar::haptics::DeviceLimits pen;
  auto l = dentar::session::LessonClock::open((t / "lesson").string(), 1, pen, false);
  ASSERT_TRUE(l.ok()) << l.error();
  auto tooth = dentar::training::make_tooth((*l)->lesson().tooth_json);
  ASSERT_TRUE(tooth.ok()) << tooth.error();
  auto bur = dentar::volume::sample_bur((*l)->bur(), 500);
  ASSERT_TRUE(bur.ok()) << bur.error();
  StillStylus stylus(1.0, 1.1);  // pressed 0.5 s into the 2 s pause, released 0.1 s later
  dentar::session::LessonPauseDevice pauses(stylus, (*l)->lesson().annotations);
  dentar::haptics::EngineConfig cfg;
  cfg.training = (*l)->mode();
  auto engine = dentar::haptics::Engine::create(cfg, pauses, *tooth, *bur);
  ASSERT_TRUE(engine.ok()) << engine.error();
  pauses.attach(engine->get());
  auto& e = **engine;
  e.run_steps(490);  // device time 0.489 s: not yet
  EXPECT_EQ(pauses.pausing(), -1);
  EXPECT_EQ(pauses.pauses_taken(), 0);
  e.run_steps(100);  // 0.589 s: the expert's clock reached 0.5 s and stopped there
  ASSERT_EQ(pauses.pausing(), 0);
  EXPECT_NEAR(e.snapshot().expert_time_s, 0.5, 2e-3);
  EXPECT_NEAR(pauses.pause_left_s(), 2.0 - 0.088, 3e-3);
  const double held_at = e.snapshot().expert_time_s;
  e.run_steps(450);  // 1.039 s: the button is down (pressed at 1.0 s): still paused
  EXPECT_EQ(pauses.pausing(), 0);
  EXPECT_EQ(e.snapshot().expert_time_s, held_at);
  e.run_steps(100);  // 1.139 s: released at 1.1 s: the pause ended early and the clock runs
  EXPECT_EQ(pauses.pausing(), -1);
  EXPECT_EQ(pauses.resumed_by_button(), 1);
  EXPECT_EQ(pauses.pauses_taken(), 1);
  EXPECT_NEAR(pauses.paused_s(), 1.1 - 0.5, 3e-3);
  EXPECT_GT(e.snapshot().expert_time_s, held_at + 0.03);
  EXPECT_LT(e.snapshot().expert_time_s, held_at + 0.05);
}

// The pen stylus has no pause button: Enter in the window ends a lesson's pause point
// (LessonPauseDevice::request_resume, from the display thread); a request outside a pause
// point is dropped (the next pause point is still held). The student's own pause (the
// button held outside a pause point) is published for the HUD while it lasts, and holds the
// expert's clock.
TEST(LiveLesson, EnterEndsAPausePointAndTheStudentsOwnPauseIsShown) {
  const fs::path c = clip();
  const fs::path t = dentar::test::temp_dir("live_lesson_key");
  auto r = run_command(kBin + " lesson make " + (c / "session.dlog").string() +
                       " --exercise molar_access_opening --pause 0.5:2 --out " + (t / "lesson").string() + " 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  dentar::haptics::DeviceLimits pen;
  auto l = dentar::session::LessonClock::open((t / "lesson").string(), 1, pen, false);
  ASSERT_TRUE(l.ok()) << l.error();
  auto tooth = dentar::training::make_tooth((*l)->lesson().tooth_json);
  ASSERT_TRUE(tooth.ok()) << tooth.error();
  auto bur = dentar::volume::sample_bur((*l)->bur(), 500);
  ASSERT_TRUE(bur.ok()) << bur.error();
  StillStylus stylus(1.3, 1.4);  // the student's own pause, after the pause point
  dentar::session::LessonPauseDevice pauses(stylus, (*l)->lesson().annotations);
  dentar::haptics::EngineConfig cfg;
  cfg.training = (*l)->mode();
  auto engine = dentar::haptics::Engine::create(cfg, pauses, *tooth, *bur);
  ASSERT_TRUE(engine.ok()) << engine.error();
  pauses.attach(engine->get());
  auto& e = **engine;
  e.run_steps(300);
  pauses.request_resume();  // 0.3 s: no pause point yet: dropped
  e.run_steps(290);         // 0.589 s: the pause point at 0.5 s holds the clock
  ASSERT_EQ(pauses.pausing(), 0);
  EXPECT_FALSE(pauses.student_holding()) << "the lesson holds, not the student";
  const double held_at = e.snapshot().expert_time_s;
  pauses.request_resume();  // Enter
  e.run_steps(1);
  EXPECT_EQ(pauses.pausing(), -1);
  EXPECT_EQ(pauses.resumed_by_key(), 1);
  EXPECT_EQ(pauses.resumed_by_button(), 0);
  EXPECT_NEAR(pauses.paused_s(), 0.590 - 0.5, 3e-3);
  e.run_steps(100);
  EXPECT_GT(e.snapshot().expert_time_s, held_at + 0.05) << "the clock runs again";
  e.run_steps(1320 - 691);  // 1.32 s: the student's button is down
  EXPECT_TRUE(pauses.student_holding());
  EXPECT_EQ(pauses.pausing(), -1);
  const double own_at = e.snapshot().expert_time_s;
  e.run_steps(50);  // 1.37 s: still down: the expert waits
  EXPECT_TRUE(pauses.student_holding());
  EXPECT_EQ(e.snapshot().expert_time_s, own_at);
  e.run_steps(100);  // 1.47 s: released
  EXPECT_FALSE(pauses.student_holding());
  EXPECT_GT(e.snapshot().expert_time_s, own_at);
  EXPECT_EQ(pauses.pauses_taken(), 1);
  EXPECT_EQ(pauses.resumed_by_key(), 1);
}

// Bad input before any window: a mode without a lesson, a lesson beside an exercise, a
// lesson that does not exist (exit 2, naming the option and the file).
TEST(LiveCli, LessonBadInputIsRefused) {
  const fs::path c = clip();
  const std::string base = kBin + " live --camera live:" + (c / "video.mkv").string() + " --station " +
                           (c / "station.json").string() + " --quiet";
  auto r = run_command(base + " --mode 2 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--mode 2 needs --lesson"), std::string::npos) << r.out;
  r = run_command(base + " --lesson builtin:molar_access_opening --mode 2 --exercise molar_access_opening 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("the lesson names its exercise"), std::string::npos) << r.out;
  const fs::path t = dentar::test::temp_dir("live_lesson_bad");
  r = run_command(base + " --lesson " + (t / "nowhere").string() + " --mode 3 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("nowhere"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("--lesson"), std::string::npos) << r.out;
}
