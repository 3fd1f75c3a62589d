// `dentar calibrate stereo` (issue 28): bad input named, exit 2, nothing written. The run on
// rendered photos of a known rig is cli_calibrate_stereo_long_test (label long).
#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "testutil.h"

namespace {

namespace fs = std::filesystem;

TEST(CliCalibrateStereo, BadInputIsNamed) {
  const fs::path t = dentar::test::temp_dir("stereo_bad");
  const fs::path d = t / "photos";  // blank photos: the refusals come before any detection
  for (const char* eye : {"left", "right"}) {
    fs::create_directories(d / eye);
    for (int i = 0; i < 12; ++i)
      cv::imwrite((d / eye / ("cap" + std::to_string(10 + i) + ".png")).string(), cv::Mat(48, 64, CV_8UC1, cv::Scalar(90)));
  }
  fs::create_directories(d / "odd");
  cv::imwrite((d / "odd" / "a.png").string(), cv::Mat(48, 65, CV_8UC1, cv::Scalar(90)));
  const fs::path st = t / "station.json";
  auto r = dentar::test::run_dentar("calibrate stereo --left " + (t / "nope").string() + " --right " +
                                    (d / "right").string() + " --station " + st.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("nope"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(st));

  fs::create_directories(t / "few");
  fs::copy_file(d / "left" / "cap10.png", t / "few" / "cap10.png");
  r = dentar::test::run_dentar("calibrate stereo --left " + (t / "few").string() + " --right " +
                               (d / "right").string() + " --station " + st.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("has 1 photos but"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("has 12"), std::string::npos) << r.out;

  r = dentar::test::run_dentar("calibrate stereo --images " + (d / "odd").string() + " --station " + st.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("even width"), std::string::npos) << r.out;

  r = dentar::test::run_dentar("calibrate stereo --station " + st.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--left"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(st));
}

// Live stereo (issue 28 session 15) and the board spec: refused before any capture, naming what.
TEST(CliCalibrateStereo, LiveAndBoardBadInputIsNamed) {
  const fs::path t = dentar::test::temp_dir("stereo_live_bad");
  const fs::path st = t / "station.json";
  auto r = dentar::test::run_dentar("calibrate stereo --left live:" + (t / "nope_l.mkv").string() + " --right live:" +
                                    (t / "nope_r.mkv").string() + " --station " + st.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("stereo --live"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("nope_l.mkv"), std::string::npos) << r.out;
  r = dentar::test::run_dentar("calibrate stereo --live --left camera:0 --station " + st.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--side-by-side"), std::string::npos) << r.out;
  r = dentar::test::run_dentar("calibrate stereo --simulate --board charuco:5x7:40:30 --station " + st.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("charuco:COLSxROWS:SQUARE_MM:MARKER_MM:DICT"), std::string::npos) << r.out;
  r = dentar::test::run_dentar("calibrate camera --simulate --board charuco:5x7:40:30:DICT_5X5_5 --station " + st.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("DICT \"DICT_5X5_5\""), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(st));
}

}  // namespace
