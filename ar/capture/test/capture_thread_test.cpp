// CaptureThread: latest frame wins (a slow consumer gets the newest frame,
// never a queue of stale ones, and the replaced frames are counted), the
// stream's end, and the stall hook the live fault tests use.
#include "dentar/ar/capture_thread.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <opencv2/imgcodecs.hpp>
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

// Session 22: a silence (no frame delivered for more than silence_s) is seen on the capture
// thread, frame by frame, whatever the consumer takes: here it takes nothing at all, as a
// stereo pairing that passes a right eye's frames over or leaves them waiting. (The frame
// thread timed the right eye's silences from the frames it took or passed over: frames it
// never saw made gaps that were not there.) silence_s 0.3: a loaded machine's held-off read
// (tenths of a second) is not taken for the 0.5 s stall.
TEST(CaptureThread, SilenceIsSeenWithoutAnyTake) {
  CaptureThreadOptions o;
  o.reopen = false;
  o.stall_after_frames = 30;
  o.stall_s = 0.5;
  o.silence_s = 0.3;
  auto cap = open(o);
  EXPECT_EQ(cap->last_silence().first_after_s, 0.0);
  cap->start();
  const auto t0 = std::chrono::steady_clock::now();
  while (!cap->ended() && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(60))
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_TRUE(cap->ended());
  const CaptureThread::Silence s = cap->last_silence();
  ASSERT_GT(s.first_after_s, 0.0) << "the stall was not seen";
  EXPECT_GE(s.first_after_s - s.last_before_s, 0.45);  // the stall hook's 0.5 s, less a frame
  EXPECT_GE(cap->last_frame_steady_s(), s.first_after_s);  // every frame delivered counts as seen
  EXPECT_GT(cap->delivered(), 5);
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

// ---- decode on demand (issue 28, session 20) ----

using Bytes = std::vector<std::uint8_t>;

// 60 JPEG frames of 320x240 (libjpeg via cv::imencode), each with its index drawn in;
// frames `bad` have their entropy data cut in half with the end marker kept (a packet
// that passes the header checks and fails only when decoded, as the session-19
// stand-in's frames did).
std::vector<Bytes> make_jpegs(const std::vector<int>& bad = {}) {
  std::vector<Bytes> out;
  for (int i = 0; i < 60; ++i) {
    cv::Mat f(240, 320, CV_8UC3, cv::Scalar(30 + i, 60, 90));
    cv::putText(f, std::to_string(i), {40, 160}, cv::FONT_HERSHEY_SIMPLEX, 3, {255, 255, 255}, 5);
    Bytes b;
    EXPECT_TRUE(cv::imencode(".jpg", f, b, {cv::IMWRITE_JPEG_QUALITY, 85}));
    if (std::find(bad.begin(), bad.end(), i) != bad.end()) {
      b.resize(b.size() * 2 / 3);
      b.push_back(0xFF), b.push_back(0xD9);
    }
    out.push_back(std::move(b));
  }
  return out;
}

std::string write_stand_in(const std::string& name, const std::vector<Bytes>& jpegs) {
  const std::string p = (dentar::test::temp_dir("capture_thread") / name).string();
  EXPECT_TRUE(write_mjpeg_avi(p, jpegs, 320, 240, 30).ok());
  return p;
}

struct DemandRun {
  int taken = 0;
  std::int64_t decodes = 0, skipped_undecoded = 0, delivered = 0, dropped_consumer = 0, corrupt = 0;
  std::string last_corrupt;
};

// A consumer that takes a frame, then is busy for `busy_ms` (slower than the 30 fps
// stand-in when busy_ms > 33). Every frame taken is checked against the file: its
// bytes are the packet its index names, its pixels that packet decoded (the eager
// decode of the same bytes), its capture time the packet's (index / fps exactly).
DemandRun run_consumer(const std::string& avi, bool defer, int busy_ms, bool eager = false) {
  FrameSourceOptions so;
  so.pixel_format = "native";
  so.defer_jpeg_decode = defer;
  const std::string spec = "live:" + avi;
  auto src = FrameSource::open(spec, so);
  EXPECT_TRUE(src.ok()) << src.error();
  if (!src.ok()) return {};
  EXPECT_EQ((*src)->description().find("decoded when taken") != std::string::npos, defer) << (*src)->description();
  CaptureThreadOptions o;
  o.reopen = false;
  o.eager_decode = eager;
  CaptureThread cap(std::move(*src), spec, so, o);
  EXPECT_EQ(cap.decode_on_demand(), defer && !eager);
  EXPECT_EQ(cap.decode_eager(), defer && eager);
  // The reference: every packet of the file and its eager decode, read unpaced.
  std::vector<cv::Mat> packets, images;
  {
    FrameSourceOptions eager = so;
    eager.defer_jpeg_decode = false;
    auto ref = FrameSource::open_live(std::make_unique<cv::VideoCapture>(avi, cv::CAP_FFMPEG), avi, 30, false, eager);
    EXPECT_TRUE(ref.ok()) << ref.error();
    // Read unpaced, every packet in file order (an unpaced reader numbers frames by its own
    // clock's gaps, so the count is the frame's number here; a refused packet keeps its place).
    Frame f;
    std::int64_t refused = 0;
    while (ref.ok()) {
      auto r = (*ref)->read(f);
      if (!r.ok() || !*r) break;
      for (; refused < (*ref)->corrupt_total(); ++refused) packets.emplace_back(), images.emplace_back();
      packets.push_back(f.encoded.clone());
      images.push_back(f.image.clone());
    }
  }
  cap.start();
  DemandRun run;
  Frame f;
  for (;;) {
    if (!cap.wait_take(f, 0.2)) {
      if (cap.ended()) break;
      continue;
    }
    ++run.taken;
    EXPECT_EQ(f.image.type(), CV_8UC2);
    EXPECT_EQ(f.time_s, static_cast<double>(f.index) / 30.0) << "the capture time is the packet's";
    if (f.index >= 0 && f.index < static_cast<std::int64_t>(images.size()) &&
        packets[f.index].size() == f.encoded.size()) {
      EXPECT_EQ(cv::norm(f.encoded, packets[f.index], cv::NORM_INF), 0.0) << "frame " << f.index << "'s bytes";
      EXPECT_EQ(cv::norm(f.image, images[f.index], cv::NORM_INF), 0.0) << "frame " << f.index << "'s pixels";
    } else {
      ADD_FAILURE() << "frame " << f.index << " taken, but the file's packet of that number is another size";
    }
    if (busy_ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(busy_ms));
  }
  cap.stop();  // the counters settled (an eager decode under way finishes)
  run.decodes = cap.decodes();
  run.skipped_undecoded = cap.skipped_undecoded();
  run.delivered = cap.delivered();
  run.dropped_consumer = cap.dropped_consumer();
  run.corrupt = cap.corrupt();
  run.last_corrupt = cap.last_corrupt();
  std::printf("[ demand ] defer %d eager %d busy %d ms: taken %d, decodes %lld, skipped undecoded %lld, delivered %lld, "
              "corrupt %lld\n",
              defer, eager, busy_ms, run.taken, static_cast<long long>(run.decodes),
              static_cast<long long>(run.skipped_undecoded), static_cast<long long>(run.delivered),
              static_cast<long long>(run.corrupt));
  return run;
}

// The camera captures faster than the consumer takes: with decode on demand only the
// frames taken are decoded (+1: the first, which the source decodes to learn the size),
// every replaced packet is dropped undecoded; the eager way decodes every frame delivered.
TEST(CaptureThreadDecodeOnDemand, SlowConsumerDecodesOnlyWhatItTakes) {
  const std::string avi = write_stand_in("demand.avi", make_jpegs());
  const DemandRun on = run_consumer(avi, true, 100);
  EXPECT_GE(on.taken, 8);
  EXPECT_LE(on.decodes, on.taken + 1);
  EXPECT_GT(on.skipped_undecoded, 0);
  EXPECT_EQ(on.delivered, on.taken + on.dropped_consumer);
  // Every replaced packet was still undecoded, but for the first frame (decoded by the source).
  EXPECT_GE(on.skipped_undecoded, on.dropped_consumer - 1);
  EXPECT_EQ(on.corrupt, 0);
  const DemandRun every = run_consumer(avi, false, 100);
  EXPECT_EQ(every.decodes, every.delivered);
  EXPECT_GT(every.decodes, every.taken + 1) << "every-frame decodes frames no one takes";
  EXPECT_EQ(every.skipped_undecoded, 0);
}

// Session 21, eager newest-packet decode: a camera faster than the consumer. The capture side
// decodes only the newest packet, and only once the previous decoded frame was taken: decodes
// <= taken + 1; a decoded frame is never replaced, so every packet dropped before anyone took
// it was dropped undecoded (a superseded packet is never decoded); each frame taken is its
// packet's bytes, pixels and capture time (run_consumer checks each one).
TEST(CaptureThreadEagerDecode, FasterCameraDecodesOnlyTheNewestPacketPerTake) {
  const std::string avi = write_stand_in("eager.avi", make_jpegs());
  const DemandRun e = run_consumer(avi, true, 100, true);
  EXPECT_GE(e.taken, 8);
  EXPECT_LE(e.decodes, e.taken + 1);
  EXPECT_GT(e.skipped_undecoded, 0);
  EXPECT_EQ(e.dropped_consumer, e.skipped_undecoded) << "a frame dropped after its decode: a decode wasted";
  // Every packet is taken, dropped undecoded, or (at most two) still waiting when the file ended.
  EXPECT_GE(e.delivered - e.taken - e.dropped_consumer, 0);
  EXPECT_LE(e.delivered - e.taken - e.dropped_consumer, 2);
  EXPECT_EQ(e.corrupt, 0);
}

// Eager, a consumer waiting for every frame: each packet decoded once as it arrives, on the
// capture side; a packet that passes the header checks but does not decode is dropped and
// counted with its reason, the next good one delivered.
TEST(CaptureThreadEagerDecode, FastConsumerAndACorruptPacket) {
  const std::string avi = write_stand_in("eager_bad.avi", make_jpegs({10, 11, 30}));
  const DemandRun e = run_consumer(avi, true, 0, true);
  EXPECT_GE(e.taken, 30);
  EXPECT_LE(e.decodes, e.taken + 1 + e.corrupt);
  EXPECT_GE(e.corrupt, 1);
  EXPECT_LE(e.corrupt, 3);
  if (e.corrupt > 0) {
    EXPECT_NE(e.last_corrupt.find("premature end"), std::string::npos) << e.last_corrupt;
  }
}

// A consumer waiting for every frame: each is decoded once, as it arrives (on the capture
// thread), and a packet that passes the header checks but does not decode is dropped and
// counted with its reason, the next good one delivered.
TEST(CaptureThreadDecodeOnDemand, FastConsumerAndACorruptPacket) {
  const std::string avi = write_stand_in("demand_bad.avi", make_jpegs({10, 11, 30}));
  const DemandRun on = run_consumer(avi, true, 0);
  EXPECT_GE(on.taken, 30);  // a loaded machine may skip some; most are taken
  EXPECT_LE(on.decodes, on.taken + 1 + on.corrupt);
  EXPECT_GE(on.corrupt, 1);  // the three cut ones, unless the paced source skipped past them
  EXPECT_LE(on.corrupt, 3);
  if (on.corrupt > 0) {
    EXPECT_NE(on.last_corrupt.find("premature end"), std::string::npos) << on.last_corrupt;
  }
}

}  // namespace
}  // namespace dentar::ar
