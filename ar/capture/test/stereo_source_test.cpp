// StereoSource (issue 28): two paced stand-ins paired by capture time, one eye stopped and
// restarted (single-eye frames, then pairs again), side-by-side recordings and stand-ins split
// into eyes, and the refusals (odd width, eyes of different sizes or rates, live with recorded).
// Each eye's frames carry their index and eye in their pixels, so a pair is checked by content.
#include "dentar/ar/stereo_source.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <thread>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "testutil.h"

namespace dentar::ar {
namespace {

namespace fs = std::filesystem;

// Frame k of an eye: grey 40 + 2k, with a white 20 px square top-left (left eye) or top-right
// (right eye); grey, so Motion JPEG's chroma subsampling leaves the code alone.
cv::Mat eye_frame(int k, bool left, int w = 160, int h = 120) {
  cv::Mat m(h, w, CV_8UC3, cv::Scalar::all(40 + 2 * k));
  m(cv::Rect(left ? 0 : w - 20, 0, 20, 20)).setTo(cv::Scalar::all(255));
  return m;
}
int frame_code(const cv::Mat& m) {
  return static_cast<int>(std::lround((cv::mean(m(cv::Rect(0, m.rows / 2, m.cols, m.rows / 2)))[0] - 40) / 2));
}
bool is_left(const cv::Mat& m) {
  return cv::mean(m(cv::Rect(0, 0, 20, 20)))[0] > cv::mean(m(cv::Rect(m.cols - 20, 0, 20, 20)))[0];
}

fs::path write_eye(const fs::path& dir, const std::string& name, int frames, double fps, bool left, int w = 160,
                   int h = 120) {
  const fs::path p = dir / name;
  cv::VideoWriter wr(p.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps, {w, h});
  EXPECT_TRUE(wr.isOpened());
  for (int k = 0; k < frames; ++k) wr.write(eye_frame(k, left, w, h));
  return p;
}

// The side-by-side layout of `dentar synth --stereo` (docs/formats.md): left | right.
fs::path write_side_by_side(const fs::path& dir, int frames, int eye_w = 160, int h = 120) {
  const fs::path p = dir / "sbs.avi";
  cv::VideoWriter wr(p.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 30, {2 * eye_w, h});
  EXPECT_TRUE(wr.isOpened());
  for (int k = 0; k < frames; ++k) {
    cv::Mat f;
    cv::hconcat(eye_frame(k, true, eye_w, h), eye_frame(k, false, eye_w, h), f);
    wr.write(f);
  }
  return p;
}

TEST(StereoSource, PacedStandInsArePairedByCaptureTime) {
  const fs::path dir = test::temp_dir("stereo_paced");
  const auto l = write_eye(dir, "l.avi", 45, 30, true), r = write_eye(dir, "r.avi", 45, 30, false);
  StereoSourceOptions o;
  o.left_capture.reopen = o.right_capture.reopen = false;
  auto s = StereoSource::open_pair("live:" + l.string(), "live:" + r.string(), o);
  ASSERT_TRUE(s.ok()) << s.error();
  EXPECT_EQ((*s)->width(), 160);
  EXPECT_NE((*s)->description().find("stereo pair"), std::string::npos);
  StereoFrame f;
  int pairs = 0, singles = 0;
  while (!(*s)->ended()) {
    if (!(*s)->read(f, 0.3)) continue;
    if (!f.paired()) {
      ++singles;
      continue;
    }
    ++pairs;
    EXPECT_TRUE(is_left(f.left.image));
    EXPECT_FALSE(is_left(f.right.image));
    // Both stand-ins expose frame k at k / fps after their open: a pair is one instant.
    EXPECT_EQ(frame_code(f.left.image), frame_code(f.right.image)) << "pair " << f.index;
    EXPECT_LE(std::abs(f.skew_s), 0.5 / 30 + 1e-9);
  }
  const StereoCaptureStats st = (*s)->stats();
  std::printf("[ paced ] %s\n", st.summary().c_str());
  EXPECT_EQ(st.pairs, pairs);
  EXPECT_GE(pairs, 30);  // 45 frames each; a loaded machine may drop some, never mispair
  EXPECT_LE(singles, 3);  // only at the ends, when one stand-in finished first
  EXPECT_LE(st.skew_max_ms, 0.5 / 30 * 1e3 + 1e-6);
  EXPECT_NE(st.summary().find("pairs"), std::string::npos);
}

// The right eye stops delivering for 0.7 s after 20 frames (the stall hook of the live fault
// tests: its cable pulled, then back): the left eye's frames come alone, then pairs again.
TEST(StereoSource, OneEyeStoppedFallsBackToSingleViewAndRecovers) {
  const fs::path dir = test::temp_dir("stereo_stall");
  const auto l = write_eye(dir, "l.avi", 90, 30, true), r = write_eye(dir, "r.avi", 90, 30, false);
  StereoSourceOptions o;
  o.left_capture.reopen = o.right_capture.reopen = false;
  o.right_capture.stall_after_frames = 20;
  o.right_capture.stall_s = 0.7;
  auto s = StereoSource::open_pair("live:" + l.string(), "live:" + r.string(), o);
  ASSERT_TRUE(s.ok()) << s.error();
  StereoFrame f;
  int pairs_before = 0, left_only = 0, pairs_after = 0, right_only = 0;
  std::string status_while_lost;
  while (!(*s)->ended()) {
    if (!(*s)->read(f, 0.3)) continue;
    if (f.paired()) {
      EXPECT_EQ(frame_code(f.left.image), frame_code(f.right.image));
      (left_only > 0 ? pairs_after : pairs_before) += 1;
    } else if (f.has_left()) {
      EXPECT_TRUE(is_left(f.left.image));
      if (pairs_after == 0) {
        ++left_only;
        if (status_while_lost.empty()) status_while_lost = (*s)->status();
      }
    } else {
      ++right_only;
    }
  }
  const StereoCaptureStats st = (*s)->stats();
  std::printf("[ stall ] %s\n", st.summary().c_str());
  EXPECT_GE(pairs_before, 12);
  EXPECT_GE(left_only, 10);   // 0.7 s at 30 fps, minus the 0.1 s before the fallback
  EXPECT_GE(pairs_after, 20);
  EXPECT_EQ(right_only, 0);
  EXPECT_GE(st.fallbacks, 1);
  EXPECT_GE(st.recoveries, 1);
  EXPECT_NE(status_while_lost.find("right eye"), std::string::npos) << status_while_lost;
  // Promised within 200 ms (0.1 s of silence + one period); loose here (a loaded test machine),
  // measured in docs/BENCHMARKS.md.
  EXPECT_GT(st.fallback_latency_max_ms, 90);
  EXPECT_LT(st.fallback_latency_max_ms, 1000);
}

TEST(StereoSource, SideBySideRecordingAndStandInSplitIntoEyes) {
  const fs::path dir = test::temp_dir("stereo_sbs");
  const auto v = write_side_by_side(dir, 12);
  auto s = StereoSource::open_side_by_side(v.string());
  ASSERT_TRUE(s.ok()) << s.error();
  EXPECT_TRUE((*s)->side_by_side());
  EXPECT_EQ((*s)->width(), 160);
  EXPECT_EQ((*s)->height(), 120);
  StereoFrame f;
  int n = 0;
  while ((*s)->read(f, 1.0)) {
    ASSERT_TRUE(f.paired());
    EXPECT_EQ(f.left.image.size(), cv::Size(160, 120));
    EXPECT_TRUE(is_left(f.left.image));
    EXPECT_FALSE(is_left(f.right.image));
    EXPECT_EQ(frame_code(f.left.image), n);
    EXPECT_EQ(frame_code(f.right.image), n);
    EXPECT_EQ(f.skew_s, 0.0);
    ++n;
  }
  EXPECT_TRUE((*s)->ended());
  EXPECT_EQ(n, 12);  // a recording: every frame, none dropped
  EXPECT_EQ((*s)->stats().pairs, 12);

  StereoSourceOptions o;
  o.left_capture.reopen = false;
  auto live = StereoSource::open_side_by_side("live:" + v.string(), o);
  ASSERT_TRUE(live.ok()) << live.error();
  int got = 0;
  while (!(*live)->ended())
    if ((*live)->read(f, 0.3)) {
      EXPECT_EQ(frame_code(f.left.image), frame_code(f.right.image));
      ++got;
    }
  EXPECT_GE(got, 6);
}

TEST(StereoSource, RecordedPairReadsInStepAndEndsOnOneEye) {
  const fs::path dir = test::temp_dir("stereo_files");
  const auto l = write_eye(dir, "l.avi", 10, 30, true), r = write_eye(dir, "r.avi", 7, 30, false);
  auto s = StereoSource::open_pair(l.string(), r.string());
  ASSERT_TRUE(s.ok()) << s.error();
  StereoFrame f;
  int pairs = 0, left_only = 0;
  while ((*s)->read(f, 1.0)) {
    if (f.paired()) {
      EXPECT_EQ(frame_code(f.left.image), frame_code(f.right.image));
      ++pairs;
    } else {
      ASSERT_TRUE(f.has_left());
      ++left_only;
    }
  }
  EXPECT_TRUE((*s)->error().empty()) << (*s)->error();
  EXPECT_EQ(pairs, 7);
  EXPECT_EQ(left_only, 3);  // the right recording ended: the single-view path
}

TEST(StereoSource, BadInputIsRefusedNamingBothEyes) {
  const fs::path dir = test::temp_dir("stereo_bad");
  const auto l = write_eye(dir, "l.avi", 3, 30, true);
  const auto big = write_eye(dir, "big.avi", 3, 30, false, 320, 240);
  auto sz = StereoSource::open_pair("live:" + l.string(), "live:" + big.string());
  ASSERT_FALSE(sz.ok());
  EXPECT_NE(sz.error().find("l.avi"), std::string::npos) << sz.error();
  EXPECT_NE(sz.error().find("big.avi"), std::string::npos) << sz.error();
  EXPECT_NE(sz.error().find("320x240"), std::string::npos) << sz.error();

  const auto slow = write_eye(dir, "slow.avi", 3, 15, false);
  auto rate = StereoSource::open_pair("live:" + l.string(), "live:" + slow.string());
  ASSERT_FALSE(rate.ok());
  EXPECT_NE(rate.error().find("l.avi"), std::string::npos) << rate.error();
  EXPECT_NE(rate.error().find("slow.avi"), std::string::npos) << rate.error();
  EXPECT_NE(rate.error().find("fps"), std::string::npos) << rate.error();

  auto mixed = StereoSource::open_pair("live:" + l.string(), slow.string());
  ASSERT_FALSE(mixed.ok());
  EXPECT_NE(mixed.error().find("recording"), std::string::npos) << mixed.error();

  auto same = StereoSource::open_pair("camera:0", "camera:0");
  ASSERT_FALSE(same.ok());
  EXPECT_NE(same.error().find("same source"), std::string::npos) << same.error();

  auto missing = StereoSource::open_pair("live:" + l.string(), "live:" + (dir / "nope.avi").string());
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().find("right eye"), std::string::npos) << missing.error();

  const fs::path odd = dir / "odd";  // an image folder keeps the odd width exactly
  fs::create_directories(odd);
  cv::imwrite((odd / "0.png").string(), eye_frame(0, true, 161, 120));
  auto o = StereoSource::open_side_by_side(odd.string());
  ASSERT_FALSE(o.ok());
  EXPECT_NE(o.error().find("even width"), std::string::npos) << o.error();
  EXPECT_NE(o.error().find("161x120"), std::string::npos) << o.error();

  StereoSourceOptions bad;
  bad.single_after_s = 0;
  auto b = StereoSource::open_side_by_side(l.string(), bad);
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().find("single_after_s"), std::string::npos) << b.error();
}

// Measurement (docs/BENCHMARKS.md, issue 28 session 14), not part of the suite's assertions:
//   DENTAR_STEREO_CAPTURE_LEFT=live:a.mkv DENTAR_STEREO_CAPTURE_RIGHT=live:b.mkv (or
//   DENTAR_STEREO_CAPTURE_SBS=live:video.mkv) [DENTAR_STEREO_CAPTURE_STALL=1]
//   [DENTAR_STEREO_CAPTURE_CONSUMER_MS=N] ./build/ar/capture/ar_stereo_source_test --gtest_filter=*Benchmark*
TEST(StereoSource, BenchmarkPairing) {
  const char* L = std::getenv("DENTAR_STEREO_CAPTURE_LEFT");
  const char* R = std::getenv("DENTAR_STEREO_CAPTURE_RIGHT");
  const char* S = std::getenv("DENTAR_STEREO_CAPTURE_SBS");
  if (!(L && R) && !S) GTEST_SKIP() << "set DENTAR_STEREO_CAPTURE_LEFT/RIGHT or _SBS";
  StereoSourceOptions o;
  o.left_capture.reopen = o.right_capture.reopen = false;
  if (std::getenv("DENTAR_STEREO_CAPTURE_STALL")) {
    o.right_capture.stall_after_frames = 60;
    o.right_capture.stall_s = 1.0;
  }
  const char* cms = std::getenv("DENTAR_STEREO_CAPTURE_CONSUMER_MS");
  const int consumer_ms = cms ? std::atoi(cms) : 0;
  auto s = S ? StereoSource::open_side_by_side(S, o) : StereoSource::open_pair(L, R, o);
  ASSERT_TRUE(s.ok()) << s.error();
  StereoFrame f;
  const double t0 = steady_now_s();
  int n = 0;
  while (!(*s)->ended()) {
    if (!(*s)->read(f, 0.3)) continue;
    ++n;
    if (consumer_ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(consumer_ms));
  }
  std::printf("[ bench ] %s: %d frames read in %.2f s\n[ bench ] %s\n", (*s)->description().c_str(), n,
              steady_now_s() - t0, (*s)->stats().summary().c_str());
}

}  // namespace
}  // namespace dentar::ar
