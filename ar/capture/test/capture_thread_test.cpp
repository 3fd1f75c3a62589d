// CaptureThread: latest frame wins (a slow consumer gets the newest frame,
// never a queue of stale ones, and the replaced frames are counted), the
// stream's end, and the stall hook the live fault tests use.
#include "dentar/ar/capture_thread.h"

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <thread>

#include "testutil.h"

namespace dentar::ar {
namespace {

// 45 frames of 160x120 at 30 fps, each frame's index drawn into it.
std::string make_video() {
  static std::string path = [] {
    const auto dir = dentar::test::temp_dir("capture_thread");
    const std::string p = (dir / "clip.avi").string();
    cv::VideoWriter w(p, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 30, cv::Size(160, 120));
    EXPECT_TRUE(w.isOpened());
    for (int i = 0; i < 45; ++i) {
      cv::Mat f(120, 160, CV_8UC3, cv::Scalar(40, 40, 40));
      cv::putText(f, std::to_string(i), {20, 80}, cv::FONT_HERSHEY_SIMPLEX, 1.5, {255, 255, 255}, 3);
      w.write(f);
    }
    return p;
  }();
  return path;
}

std::unique_ptr<CaptureThread> open(const CaptureThreadOptions& o) {
  const std::string spec = "live:" + make_video();
  auto src = FrameSource::open(spec);
  EXPECT_TRUE(src.ok()) << src.error();
  return std::make_unique<CaptureThread>(std::move(*src), spec, FrameSourceOptions{}, o);
}

TEST(CaptureThread, SlowConsumerGetsTheNewestFrameAndDropsAreCounted) {
  CaptureThreadOptions o;
  o.reopen = false;
  auto cap = open(o);
  cap->start();
  std::int64_t last = -1;
  int taken = 0;
  Frame f;
  for (;;) {
    if (!cap->wait_take(f, 0.2)) {
      if (cap->ended()) break;
      continue;
    }
    ++taken;
    EXPECT_GT(f.index, last);
    last = f.index;
    // What we got is the newest delivered frame, not a stale one from a queue.
    EXPECT_GE(f.steady_s, cap->last_frame_steady_s() - 1.5 / 30.0);
    std::this_thread::sleep_for(std::chrono::milliseconds(110));  // a slow consumer (~9 fps)
  }
  EXPECT_TRUE(cap->ended());
  EXPECT_GE(taken, 8);
  EXPECT_LT(taken, 30);
  // Every frame of the file was either taken, replaced before use, or skipped by the paced source.
  EXPECT_GT(cap->dropped_consumer() + cap->dropped_source(), 15);
  EXPECT_EQ(cap->delivered(), taken + cap->dropped_consumer());
  EXPECT_FALSE(cap->status().empty()) << "the end of the stream must be explained";
}

TEST(CaptureThread, StallHookDeliversNothingThenResumes) {
  CaptureThreadOptions o;
  o.reopen = false;
  o.stall_after_frames = 5;
  o.stall_s = 0.5;
  auto cap = open(o);
  cap->start();
  Frame f;
  std::vector<double> times;
  for (;;) {
    if (cap->wait_take(f, 0.2)) times.push_back(f.steady_s);
    else if (cap->ended()) break;
  }
  ASSERT_GE(times.size(), 10u);
  double max_gap = 0;
  for (std::size_t i = 1; i < times.size(); ++i) max_gap = std::max(max_gap, times[i] - times[i - 1]);
  EXPECT_GT(max_gap, 0.45);
  EXPECT_LT(max_gap, 0.65);
}

TEST(CaptureThread, ReopensASourceThatEnded) {
  CaptureThreadOptions o;
  o.reopen = true;
  o.reopen_period_s = 0.05;
  auto cap = open(o);
  cap->start();
  Frame f;
  const auto t0 = std::chrono::steady_clock::now();
  while (cap->reopens() == 0 && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(6))
    cap->wait_take(f, 0.1);
  EXPECT_GE(cap->reopens(), 1) << "an ended stand-in camera is opened again";
  EXPECT_FALSE(cap->ended());
  cap->stop();
}

}  // namespace
}  // namespace dentar::ar
