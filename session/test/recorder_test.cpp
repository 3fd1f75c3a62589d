// The live recording's writer (live/src/recorder.h, private): every pushed
// frame reaches the disk with its row, in order; JPEG bytes are written as
// they came; a writer that falls behind switches to uncompressed PPM instead
// of losing frames; no partial file is left with an image name.
#include "dentar/session/recorder.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "testutil.h"

namespace fs = std::filesystem;
using dentar::session::Recorder;

namespace {

cv::Mat noisy_frame(int k) {
  cv::Mat m(240, 320, CV_8UC3);
  cv::randu(m, cv::Scalar::all(0), cv::Scalar::all(255));  // incompressible: PNG is slow on it
  cv::putText(m, std::to_string(k), {20, 120}, cv::FONT_HERSHEY_SIMPLEX, 2.0, {255, 255, 255}, 3);
  return m;
}

std::vector<std::string> lines(const fs::path& p) {
  std::ifstream f(p);
  std::vector<std::string> v;
  for (std::string l; std::getline(f, l);) v.push_back(l);
  return v;
}

}  // namespace

TEST(Recorder, EveryFrameWrittenInOrderFasterFormatWhenBehind) {
  const fs::path dir = dentar::test::temp_dir("recorder_burst");
  auto r = Recorder::open(dir);
  ASSERT_TRUE(r.ok()) << r.error();
  const int n = 40;  // pushed at once: the writer is far behind (> kFastFromQueued)
  std::vector<cv::Mat> frames;
  for (int k = 0; k < n; ++k) {
    frames.push_back(noisy_frame(k));
    dentar::ar::FrameRecord rec;
    rec.time_s = k / 30.0;
    (*r)->push(frames.back(), cv::Mat(), rec, k, k, 100.0 + k / 30.0);
  }
  (*r)->close();
  EXPECT_EQ((*r)->written(), n);
  EXPECT_EQ((*r)->dropped(), 0);
  EXPECT_GT((*r)->written_ppm(), 0) << "a writer far behind must take the fast format";
  EXPECT_EQ((*r)->written_png() + (*r)->written_ppm(), n);
  EXPECT_EQ((*r)->written_jpg(), 0);
  // Rows 0..n-1 in order, each naming a frame on disk whose pixels are the pushed ones.
  const auto rows = lines(dir / "frames.csv");
  ASSERT_EQ(rows.size(), static_cast<std::size_t>(n + 1));
  for (int k = 0; k < n; ++k) {
    EXPECT_EQ(rows[k + 1].substr(0, rows[k + 1].find(',')), std::to_string(k));
    char stem[32];
    std::snprintf(stem, sizeof stem, "frame_%06d", k);
    const fs::path png = dir / "frames" / (std::string(stem) + ".png"), ppm = dir / "frames" / (std::string(stem) + ".ppm");
    ASSERT_NE(fs::exists(png), fs::exists(ppm)) << stem;
    const cv::Mat back = cv::imread((fs::exists(png) ? png : ppm).string());
    ASSERT_EQ(back.size(), frames[k].size()) << stem;
    EXPECT_EQ(cv::norm(back, frames[k], cv::NORM_INF), 0.0) << stem << ": lossless";
  }
  for (const auto& e : fs::directory_iterator(dir / "frames"))
    EXPECT_NE(e.path().extension(), ".part") << e.path();
}

TEST(Recorder, CameraJpegBytesAreWrittenAsTheyCame) {
  const fs::path dir = dentar::test::temp_dir("recorder_jpg");
  auto r = Recorder::open(dir);
  ASSERT_TRUE(r.ok()) << r.error();
  const cv::Mat img = noisy_frame(7);
  std::vector<uchar> bytes;
  ASSERT_TRUE(cv::imencode(".jpg", img, bytes));
  const cv::Mat encoded(1, static_cast<int>(bytes.size()), CV_8UC1, bytes.data());
  const cv::Mat decoded = cv::imdecode(encoded, cv::IMREAD_COLOR);
  dentar::ar::FrameRecord rec;
  (*r)->push(decoded, encoded, rec, 0, 0, 1.0);
  (*r)->close();
  EXPECT_EQ((*r)->written_jpg(), 1);
  const fs::path jpg = dir / "frames" / "frame_000000.jpg";
  ASSERT_TRUE(fs::exists(jpg));
  std::ifstream f(jpg, std::ios::binary);
  const std::vector<uchar> on_disk((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  EXPECT_EQ(on_disk, bytes);
  EXPECT_EQ(cv::norm(cv::imread(jpg.string()), decoded, cv::NORM_INF), 0.0);
}

// A stereo run (issue 28) keeps both eyes: the right eye's image of a frame in frames_right/
// under the frame's own number, lossless (PNG) or its camera's JPEG bytes, and nothing for a
// frame that had no right eye (the single-view path: eyes "left"); the row says which.
TEST(Recorder, StereoKeepsTheRightEyeBesideTheLeft) {
  const fs::path dir = dentar::test::temp_dir("recorder_stereo");
  auto r = Recorder::open(dir, true);
  ASSERT_TRUE(r.ok()) << r.error();
  const cv::Mat left0 = noisy_frame(0), right0 = noisy_frame(100), left1 = noisy_frame(1), left2 = noisy_frame(2);
  const cv::Mat right2 = noisy_frame(102);
  std::vector<uchar> bytes;
  ASSERT_TRUE(cv::imencode(".jpg", right2, bytes));
  const cv::Mat right2_jpg(1, static_cast<int>(bytes.size()), CV_8UC1, bytes.data());
  dentar::ar::FrameRecord rec;
  rec.eyes = dentar::ar::FrameRecord::kEyesBoth;
  (*r)->push(left0, cv::Mat(), rec, 0, 0, 1.0, right0, cv::Mat());
  rec.eyes = dentar::ar::FrameRecord::kEyesLeft;
  (*r)->push(left1, cv::Mat(), rec, 1, 1, 1.1);
  rec.eyes = dentar::ar::FrameRecord::kEyesBoth;
  (*r)->push(left2, cv::Mat(), rec, 2, 2, 1.2, cv::imdecode(right2_jpg, cv::IMREAD_COLOR), right2_jpg);
  (*r)->close();
  EXPECT_EQ((*r)->written(), 3);
  EXPECT_EQ((*r)->written_png(), 3);
  EXPECT_EQ((*r)->written_right_png(), 1);
  EXPECT_EQ((*r)->written_right_jpg(), 1);
  const cv::Mat back0 = cv::imread((dir / "frames_right" / "frame_000000.png").string());
  ASSERT_FALSE(back0.empty());
  EXPECT_EQ(cv::norm(back0, right0, cv::NORM_INF), 0.0) << "lossless";
  EXPECT_FALSE(fs::exists(dir / "frames_right" / "frame_000001.png"));
  EXPECT_FALSE(fs::exists(dir / "frames_right" / "frame_000001.ppm"));
  std::ifstream f(dir / "frames_right" / "frame_000002.jpg", std::ios::binary);
  const std::vector<uchar> on_disk((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  EXPECT_EQ(on_disk, bytes);
  const auto rows = lines(dir / "frames.csv");
  ASSERT_EQ(rows.size(), 4u);
  // The eyes, then the right eye's own composite (none here: not the headset's view).
  const std::string eyes_cols = ",eyes,right_composited,right_overlay,right_mirror_drawn,right_composite_ms";
  EXPECT_EQ(rows[0].substr(rows[0].size() - eyes_cols.size()), eyes_cols);
  EXPECT_NE(rows[1].find(",both,0,0,0,0"), std::string::npos) << rows[1];
  EXPECT_NE(rows[2].find(",left,0,0,0,0"), std::string::npos) << rows[2];
  // One camera: no right-eye folder, whatever is pushed.
  const fs::path mono = dentar::test::temp_dir("recorder_mono_right");
  auto m = Recorder::open(mono);
  ASSERT_TRUE(m.ok()) << m.error();
  (*m)->push(left0, cv::Mat(), dentar::ar::FrameRecord{}, 0, 0, 1.0, right0, cv::Mat());
  (*m)->close();
  EXPECT_FALSE(fs::exists(mono / "frames_right"));
  EXPECT_EQ((*m)->written_right_png(), 0);
}
