// Frame sources: video file, image folder, a video file standing in for a
// live camera (real-time pacing, dropped frames), and bad inputs.
#include "dentar/ar/frame_source.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <thread>

#include "testutil.h"

namespace dentar::ar {
namespace {

namespace fs = std::filesystem;

// Frame k: a gray level that encodes k (lossless FFV1 keeps it exact).
cv::Mat make_frame(int k, int w = 160, int h = 120) {
  cv::Mat m(h, w, CV_8UC3, cv::Scalar(10 * k % 250, 100, 200));
  cv::putText(m, std::to_string(k), {10, 60}, cv::FONT_HERSHEY_SIMPLEX, 1.0, {255, 255, 255});
  return m;
}

int frame_code(const cv::Mat& m) { return (m.at<cv::Vec3b>(2, 2)[0] + 5) / 10; }

fs::path write_video(const fs::path& dir, int frames, double fps) {
  const fs::path p = dir / "v.mkv";
  cv::VideoWriter w(p.string(), cv::CAP_FFMPEG, cv::VideoWriter::fourcc('F', 'F', 'V', '1'), fps,
                    {160, 120});
  EXPECT_TRUE(w.isOpened());
  for (int k = 0; k < frames; ++k) w.write(make_frame(k));
  w.release();
  return p;
}

TEST(FrameSource, VideoFileFramesTimesAndCount) {
  const fs::path dir = test::temp_dir("fs_video");
  const fs::path v = write_video(dir, 20, 25);
  auto s = FrameSource::open(v.string());
  ASSERT_TRUE(s.ok()) << s.error();
  FrameSource& src = **s;
  EXPECT_EQ(src.width(), 160);
  EXPECT_EQ(src.height(), 120);
  EXPECT_NEAR(src.fps(), 25, 1e-6);
  EXPECT_EQ(src.frame_count(), 20);
  EXPECT_NE(src.description().find("v.mkv"), std::string::npos);
  Frame f;
  int n = 0;
  double last = -1;
  for (;;) {
    auto r = src.read(f);
    ASSERT_TRUE(r.ok()) << r.error();
    if (!*r) break;
    EXPECT_EQ(f.index, n);
    EXPECT_EQ(f.image.type(), CV_8UC3);
    EXPECT_EQ(frame_code(f.image), n % 25);
    EXPECT_NEAR(f.time_s, n / 25.0, 1e-3);
    EXPECT_GT(f.time_s, last);
    EXPECT_EQ(f.dropped_before, 0);
    last = f.time_s;
    ++n;
  }
  EXPECT_EQ(n, 20);
  EXPECT_EQ(src.dropped_total(), 0);
  auto again = src.read(f);  // stays at the end
  ASSERT_TRUE(again.ok());
  EXPECT_FALSE(*again);
}

TEST(FrameSource, ImageFolderSortedTimesAndBadFiles) {
  const fs::path dir = test::temp_dir("fs_folder");
  for (int k = 0; k < 5; ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%06d.png", k);
    cv::imwrite((dir / name).string(), make_frame(k));
  }
  test::write_file(dir / "notes.txt", "not an image");  // ignored: not an image extension
  FrameSourceOptions o;
  o.folder_fps = 10;
  auto s = FrameSource::open(dir.string(), o);
  ASSERT_TRUE(s.ok()) << s.error();
  EXPECT_EQ((*s)->frame_count(), 5);
  Frame f;
  for (int k = 0; k < 5; ++k) {
    auto r = (*s)->read(f);
    ASSERT_TRUE(r.ok() && *r) << (r.ok() ? "end" : r.error());
    EXPECT_EQ(frame_code(f.image), k);
    EXPECT_NEAR(f.time_s, k / 10.0, 1e-12);
  }
  auto end = (*s)->read(f);
  ASSERT_TRUE(end.ok());
  EXPECT_FALSE(*end);

  // An undecodable frame is counted, not silently skipped.
  test::write_file(dir / "frame_000002.png", "garbage, not a png");
  auto s2 = FrameSource::open(dir.string(), o);
  ASSERT_TRUE(s2.ok()) << s2.error();
  int got = 0, dropped = 0;
  while (true) {
    auto r = (*s2)->read(f);
    ASSERT_TRUE(r.ok()) << r.error();
    if (!*r) break;
    ++got;
    dropped += f.dropped_before;
    if (f.dropped_before > 0) {
      EXPECT_EQ(frame_code(f.image), 3);
      EXPECT_NEAR(f.time_s, 0.3, 1e-12);  // the time keeps the gap
    }
  }
  EXPECT_EQ(got, 4);
  EXPECT_EQ(dropped, 1);
  EXPECT_EQ((*s2)->dropped_total(), 1);

  // An image of another size mid-sequence is refused, naming the file.
  cv::imwrite((dir / "frame_000004.png").string(), make_frame(4, 320, 240));
  auto s3 = FrameSource::open(dir.string(), o);
  ASSERT_TRUE(s3.ok()) << s3.error();
  std::string err;
  for (int i = 0; i < 10 && err.empty(); ++i) {
    auto r = (*s3)->read(f);
    if (!r.ok()) err = r.error();
    else if (!*r) break;
  }
  EXPECT_NE(err.find("frame_000004.png"), std::string::npos) << err;
  EXPECT_NE(err.find("320x240"), std::string::npos) << err;
}

TEST(FrameSource, BadInputsGiveClearErrors) {
  const fs::path dir = test::temp_dir("fs_bad");
  auto missing = FrameSource::open((dir / "nope.mkv").string());
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().find("nope.mkv"), std::string::npos);
  EXPECT_NE(missing.error().find("no such file"), std::string::npos) << missing.error();

  test::write_file(dir / "empty.mkv", "");
  auto empty = FrameSource::open((dir / "empty.mkv").string());
  ASSERT_FALSE(empty.ok());
  EXPECT_NE(empty.error().find("empty"), std::string::npos) << empty.error();

  std::string junk(20000, '\0');
  for (std::size_t i = 0; i < junk.size(); ++i) junk[i] = static_cast<char>((i * 7919) % 251);
  test::write_file(dir / "junk.mkv", junk);
  auto bad = FrameSource::open((dir / "junk.mkv").string());
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("junk.mkv"), std::string::npos) << bad.error();

  // Truncated video: an error, not a silent short stream.
  const fs::path v = write_video(dir, 30, 30);
  const std::string bytes = test::read_file(v);
  test::write_file(dir / "cut.mkv", bytes.substr(0, bytes.size() / 2));
  auto cut = FrameSource::open((dir / "cut.mkv").string());
  std::string err = cut.ok() ? "" : cut.error();
  if (cut.ok()) {
    Frame f;
    for (int i = 0; i < 100 && err.empty(); ++i) {
      auto r = (*cut)->read(f);
      if (!r.ok()) err = r.error();
      else if (!*r) break;
    }
  }
  EXPECT_NE(err.find("cut.mkv"), std::string::npos) << "truncated video read without error";

  auto empty_dir = FrameSource::open(test::temp_dir("fs_empty_dir").string());
  ASSERT_FALSE(empty_dir.ok());
  EXPECT_NE(empty_dir.error().find("no image files"), std::string::npos) << empty_dir.error();

  // No camera on this machine (or not that one): a clear error, no hang.
  auto cam = FrameSource::open("camera:63");
  ASSERT_FALSE(cam.ok());
  EXPECT_NE(cam.error().find("camera:63"), std::string::npos) << cam.error();
  auto dev = FrameSource::open("/dev/video63");
  ASSERT_FALSE(dev.ok());
  EXPECT_NE(dev.error().find("/dev/video63"), std::string::npos) << dev.error();
  auto idx = FrameSource::open("camera:x");
  ASSERT_FALSE(idx.ok());
  EXPECT_NE(idx.error().find("number"), std::string::npos) << idx.error();

  FrameSourceOptions o;
  o.folder_fps = 0;
  EXPECT_NE(o.validate().find("folder_fps"), std::string::npos);
  o = {};
  o.width = -1;
  EXPECT_NE(o.validate().find("width"), std::string::npos);
  auto badopt = FrameSource::open(v.string(), o);
  ASSERT_FALSE(badopt.ok());
  EXPECT_NE(badopt.error().find("width"), std::string::npos);
}

// A Motion JPEG stand-in (what a UVC webcam delivers at 720p): each frame
// carries the camera's own JPEG bytes, and the image is exactly their
// decoding, so writing the bytes to a file and reading it back gives the same
// pixels (a recording replays bit for bit). An FFV1 stand-in carries none.
TEST(FrameSource, MotionJpegStandInKeepsTheCamerasBytes) {
  const fs::path dir = test::temp_dir("fs_mjpg");
  const fs::path v = dir / "cam.avi";
  {
    // OpenCV's own MJPG AVI writer: no FFmpeg encoder needed.
    cv::VideoWriter w(v.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 30, {160, 120});
    ASSERT_TRUE(w.isOpened());
    for (int k = 0; k < 6; ++k) w.write(make_frame(k));
  }
  auto s = FrameSource::open("live:" + v.string());
  ASSERT_TRUE(s.ok()) << s.error();
  Frame f;
  int got = 0, last_code = -1, dropped = 0;
  while (true) {
    auto r = (*s)->read(f);
    ASSERT_TRUE(r.ok()) << r.error();
    if (!*r) break;
    ASSERT_FALSE(f.encoded.empty()) << "frame " << got;
    ASSERT_EQ(f.encoded.type(), CV_8UC1);
    ASSERT_GE(f.encoded.total(), 4u);
    EXPECT_EQ(f.encoded.data[0], 0xFF);
    EXPECT_EQ(f.encoded.data[1], 0xD8);
    ASSERT_EQ(f.image.type(), CV_8UC3);
    EXPECT_EQ(f.image.size(), cv::Size(160, 120));
    // The frame's content survives (JPEG is lossy, the code is coarse).
    const int code = frame_code(f.image);
    EXPECT_EQ(code, last_code + 1 + f.dropped_before) << "frame " << got;
    last_code = code;
    dropped += f.dropped_before;
    const fs::path jpg = dir / ("f" + std::to_string(got) + ".jpg");
    {
      std::ofstream o(jpg, std::ios::binary);
      o.write(reinterpret_cast<const char*>(f.encoded.data), static_cast<std::streamsize>(f.encoded.total()));
    }
    const cv::Mat back = cv::imread(jpg.string());
    ASSERT_FALSE(back.empty());
    EXPECT_EQ(cv::norm(back, f.image, cv::NORM_INF), 0.0) << "frame " << got;
    ++got;
  }
  EXPECT_GE(got, 1);
  EXPECT_EQ(got + dropped, 6);  // a slow test machine may drop, never lose count

  // Lossless FFV1: no camera bytes, the backend decodes.
  auto l = FrameSource::open("live:" + write_video(dir, 3, 30).string());
  ASSERT_TRUE(l.ok()) << l.error();
  auto r = (*l)->read(f);
  ASSERT_TRUE(r.ok() && *r);
  EXPECT_TRUE(f.encoded.empty());
}

// The live-camera reader on a video file standing in for the camera: real
// time pacing, steady-clock timestamps, frames dropped when the consumer is
// too slow (as a V4L2 driver drops them), no frame delivered twice.
TEST(FrameSource, LiveReaderOnAStandInVideo) {
  const fs::path dir = test::temp_dir("fs_live");
  const fs::path v = write_video(dir, 24, 30);
  auto s = FrameSource::open("live:" + v.string());
  ASSERT_TRUE(s.ok()) << s.error();
  EXPECT_EQ((*s)->frame_count(), -1);
  EXPECT_NE((*s)->description().find("live"), std::string::npos);
  const auto t0 = std::chrono::steady_clock::now();
  Frame f;
  int got = 0, dropped = 0, last_code = -1;
  double last_t = -1;
  while (true) {
    auto r = (*s)->read(f);
    ASSERT_TRUE(r.ok()) << r.error();
    if (!*r) break;
    const int code = frame_code(f.image);
    EXPECT_EQ(code, last_code + 1 + f.dropped_before) << "frame " << got;
    EXPECT_GT(f.time_s, last_t);
    EXPECT_NEAR(f.time_s, code / 30.0, 1e-9);  // the stand-in's capture time
    // Its number is the frame's in the file, the dropped ones counted (session 18: it was the
    // count delivered, so a recording's source_index named the wrong footage frame after a drop).
    EXPECT_EQ(f.index, code) << "frame " << got;
    last_code = code;
    last_t = f.time_s;
    dropped += f.dropped_before;
    ++got;
    if (got == 5) std::this_thread::sleep_for(std::chrono::milliseconds(150));  // slow consumer
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("[ live ] %d frames delivered, %d dropped, %.3f s wall for 24 frames at 30 fps\n",
              got, dropped, wall);
  EXPECT_EQ(got + dropped, 24);
  EXPECT_GE(dropped, 3);  // 150 ms at 30 fps = 4.5 periods
  EXPECT_EQ((*s)->dropped_total(), dropped);
  EXPECT_GT(wall, 0.6);  // paced in real time (23 periods = 0.77 s)

  // open_live over any cv::VideoCapture (what camera:N uses), unpaced.
  auto cap = std::make_unique<cv::VideoCapture>(v.string(), cv::CAP_FFMPEG);
  auto s2 = FrameSource::open_live(std::move(cap), "stand-in", 30, false);
  ASSERT_TRUE(s2.ok()) << s2.error();
  int n = 0;
  while (true) {
    auto r = (*s2)->read(f);
    ASSERT_TRUE(r.ok()) << r.error();
    if (!*r) break;
    ++n;
  }
  EXPECT_EQ(n, 24);
  auto closed = FrameSource::open_live(std::make_unique<cv::VideoCapture>(), "nothing", 30, false);
  ASSERT_FALSE(closed.ok());
  EXPECT_NE(closed.error().find("not open"), std::string::npos);
}


// YUYV frames as a UVC camera sends them: random bytes are valid YUYV; the first
// row's luma carries the frame's number.
std::vector<cv::Mat> yuyv_frames(int n, int w = 160, int h = 120) {
  std::vector<cv::Mat> v;
  cv::RNG rng(28);
  for (int k = 0; k < n; ++k) {
    cv::Mat m(h, w, CV_8UC2);
    rng.fill(m, cv::RNG::UNIFORM, 16, 236);
    for (int x = 0; x < 8; ++x) m.at<cv::Vec2b>(0, x)[0] = static_cast<std::uint8_t>(20 + 10 * k);
    v.push_back(m);
  }
  return v;
}

// The camera's own format through capture (issue 28): a YUYV stand-in (an AVI of
// raw YUY2 frames, read as the camera would deliver them) hands on its bytes
// unchanged with pixel_format "native", and BGR by default; frame_bgr of the
// native frame is OpenCV's conversion of exactly those bytes.
TEST(FrameSource, YuyvStandInKeepsTheCamerasOwnPixels) {
  const fs::path dir = test::temp_dir("fs_yuyv");
  const fs::path v = dir / "cam_yuyv.avi";
  const auto frames = yuyv_frames(6);
  ASSERT_TRUE(write_yuyv_avi(v.string(), frames, 30).ok());
  FrameSourceOptions native;
  native.pixel_format = "native";
  auto s = FrameSource::open("live:" + v.string(), native);
  ASSERT_TRUE(s.ok()) << s.error();
  EXPECT_EQ((*s)->width(), 160);
  EXPECT_EQ((*s)->height(), 120);
  Frame f;
  int got = 0, dropped = 0;
  for (;;) {
    auto r = (*s)->read(f);
    ASSERT_TRUE(r.ok()) << r.error();
    if (!*r) break;
    ASSERT_EQ(f.image.type(), CV_8UC2) << "frame " << got;
    ASSERT_EQ(f.image.size(), cv::Size(160, 120));
    EXPECT_TRUE(f.encoded.empty());
    const int k = (f.image.at<cv::Vec2b>(0, 0)[0] - 20) / 10;
    ASSERT_GE(k, 0);
    ASSERT_LT(k, 6);
    EXPECT_EQ(cv::norm(f.image, frames[static_cast<std::size_t>(k)], cv::NORM_INF), 0.0) << "frame " << k;
    cv::Mat want;
    cv::cvtColor(frames[static_cast<std::size_t>(k)], want, cv::COLOR_YUV2BGR_YUYV);
    EXPECT_EQ(cv::norm(frame_bgr(f.image), want, cv::NORM_INF), 0.0);
    dropped += f.dropped_before;
    ++got;
  }
  EXPECT_GE(got, 1);
  EXPECT_EQ(got + dropped, 6);

  // The default: BGR, FFmpeg's conversion of the same bytes (within rounding).
  auto b = FrameSource::open("live:" + v.string());
  ASSERT_TRUE(b.ok()) << b.error();
  auto r = (*b)->read(f);
  ASSERT_TRUE(r.ok() && *r);
  ASSERT_EQ(f.image.type(), CV_8UC3);
  cv::Mat want;
  cv::cvtColor(frames[0], want, cv::COLOR_YUV2BGR_YUYV);
  cv::Mat diff;
  cv::absdiff(f.image, want, diff);
  EXPECT_LE(cv::mean(diff)[0], 2.0);
  EXPECT_EQ(frame_bgr(f.image).data, f.image.data);  // BGR: a header, no copy
}

// Format negotiation against the stand-ins: what was asked against what the
// "driver" (the stand-in's file) delivers, refused with both named.
TEST(FrameSource, FormatNegotiationAgainstTheStandIns) {
  const fs::path dir = test::temp_dir("fs_negotiate");
  const fs::path yuyv = dir / "cam_yuyv.avi", mjpg = dir / "cam_mjpg.avi";
  ASSERT_TRUE(write_yuyv_avi(yuyv.string(), yuyv_frames(3), 30).ok());
  {
    cv::VideoWriter w(mjpg.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 30, {160, 120});
    ASSERT_TRUE(w.isOpened());
    for (int k = 0; k < 3; ++k) w.write(make_frame(k));
  }
  FrameSourceOptions o;
  o.fourcc = "MJPG";
  auto bad = FrameSource::open("live:" + yuyv.string(), o);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("asked for MJPG but it delivers YUY2"), std::string::npos) << bad.error();
  EXPECT_NE(bad.error().find("v4l2-ctl --list-formats-ext"), std::string::npos) << bad.error();
  o.fourcc = "YUYV";
  bad = FrameSource::open("live:" + mjpg.string(), o);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("asked for YUYV but it delivers MJPG"), std::string::npos) << bad.error();
  // Asked and delivered: YUYV kept (native), MJPG with its bytes.
  o.pixel_format = "native";
  auto good = FrameSource::open("live:" + yuyv.string(), o);
  ASSERT_TRUE(good.ok()) << good.error();
  Frame f;
  ASSERT_TRUE((*good)->read(f).ok());
  EXPECT_EQ(f.image.type(), CV_8UC2);
  o.fourcc = "MJPG";
  good = FrameSource::open("live:" + mjpg.string(), o);
  ASSERT_TRUE(good.ok()) << good.error();
  ASSERT_TRUE((*good)->read(f).ok());
  EXPECT_EQ(f.image.type(), CV_8UC2);  // decoded to YUYV from the JPEG's planes (session 18)
  EXPECT_FALSE(f.encoded.empty());
  EXPECT_NE((*good)->description().find("MJPG decoded to YUYV"), std::string::npos) << (*good)->description();
  o.pixel_format = "bgr";  // the whole-frame BGR path: straight to BGR, as cv::imdecode would
  good = FrameSource::open("live:" + mjpg.string(), o);
  ASSERT_TRUE(good.ok()) << good.error();
  ASSERT_TRUE((*good)->read(f).ok());
  EXPECT_EQ(f.image.type(), CV_8UC3);
  EXPECT_EQ(cv::norm(f.image, cv::imdecode(f.encoded, cv::IMREAD_COLOR), cv::NORM_INF), 0.0);

  // The rule itself (a V4L2 camera goes through the same function).
  const int YUYV = cv::VideoWriter::fourcc('Y', 'U', 'Y', 'V'), MJPG = cv::VideoWriter::fourcc('M', 'J', 'P', 'G');
  const int NV12 = cv::VideoWriter::fourcc('N', 'V', '1', '2');
  auto c = negotiate_format("", YUYV, "native", "cam");
  ASSERT_TRUE(c.ok());
  EXPECT_TRUE(c->yuyv);
  EXPECT_FALSE(c->jpeg);
  c = negotiate_format("", YUYV, "bgr", "cam");
  ASSERT_TRUE(c.ok());
  EXPECT_FALSE(c->yuyv);
  c = negotiate_format("", NV12, "native", "cam");  // another format: the backend's BGR
  ASSERT_TRUE(c.ok());
  EXPECT_FALSE(c->yuyv || c->jpeg);
  c = negotiate_format("MJPG", MJPG, "native", "cam");
  ASSERT_TRUE(c.ok());
  EXPECT_TRUE(c->jpeg);
  c = negotiate_format("YUYV", NV12, "native", "camera /dev/video2");
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().find("camera /dev/video2: asked for YUYV but it delivers NV12"), std::string::npos) << c.error();
  EXPECT_EQ(fourcc_name(0), "none");
  EXPECT_EQ(fourcc_name(0x01020304), "0x1020304");
  // Options.
  FrameSourceOptions v;
  v.pixel_format = "yuv";
  EXPECT_NE(v.validate().find("pixel_format = \"yuv\""), std::string::npos);
  v = {};
  v.fourcc = "H264";
  EXPECT_NE(v.validate().find("fourcc = \"H264\""), std::string::npos);
  EXPECT_FALSE(write_yuyv_avi((dir / "x.avi").string(), {cv::Mat(4, 3, CV_8UC2)}, 30).ok());  // odd width
}

// A camera whose frames are not what it announces: a clear error naming the
// sizes, never a garbled image (the stand-in's header says 162 px wide, its
// frames hold 160).
TEST(FrameSource, YuyvFramesOfAnotherSizeAreRefused) {
  const fs::path dir = test::temp_dir("fs_badyuyv");
  const fs::path v = dir / "bad.avi";
  ASSERT_TRUE(write_yuyv_avi(v.string(), yuyv_frames(3), 30).ok());
  {
    std::fstream io(v, std::ios::in | std::ios::out | std::ios::binary);
    // BITMAPINFOHEADER biWidth: RIFF 12 + LIST hdrl 12 + avih 64 + LIST strl 12 + strh 64 + strf 8 + biSize 4.
    io.seekp(176);
    const char w[4] = {char(162), 0, 0, 0};
    io.write(w, 4);
  }
  FrameSourceOptions native;
  native.pixel_format = "native";
  auto s = FrameSource::open("live:" + v.string(), native);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("announced YUYV 162x120 (38880 bytes a frame) but delivered 38400 bytes"),
            std::string::npos)
      << s.error();
}

}  // namespace
}  // namespace dentar::ar
