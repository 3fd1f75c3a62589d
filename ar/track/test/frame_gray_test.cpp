// FrameGray (frame_gray.h): the tracker's grey levels made only where they are
// read, from BGR or from the camera's own YUYV (issue 28).
#include "dentar/ar/frame_gray.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace dentar::ar {
namespace {

// A real photograph of AprilTags (tests/data/apriltag_photos, issue 24), cropped to
// an even width: the colours and edges a camera delivers.
cv::Mat real_photo() {
  const std::filesystem::path p =
      std::filesystem::path(DENTAR_SOURCE_DIR) / "tests/data/apriltag_photos/34085369442_304b6bafd9_c.jpg";
  cv::Mat img = cv::imread(p.string(), cv::IMREAD_COLOR);
  if (img.empty()) return img;
  return img(cv::Rect(0, 0, img.cols & ~1, img.rows)).clone();
}

TEST(FrameGray, BgrRegionsEqualTheWholeFrameConvertedAndNothingElseIsConverted) {
  const cv::Mat bgr = real_photo();
  ASSERT_FALSE(bgr.empty()) << "tests/data/apriltag_photos is missing";
  cv::Mat ref;
  cv::cvtColor(bgr, ref, cv::COLOR_BGR2GRAY);
  FrameGray fg;
  fg.reset(bgr);
  const cv::Rect a(10, 20, 101, 57), b(200, 100, 64, 64);
  fg.region(a);
  const cv::Mat& g = fg.region(b);
  EXPECT_EQ(cv::norm(g(a), ref(a), cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(g(b), ref(b), cv::NORM_INF), 0.0);
  const double frac = double(a.area() + b.area()) / double(bgr.total());
  EXPECT_NEAR(fg.converted_fraction(), frac, 1e-12);
  fg.region(cv::Rect(12, 22, 20, 20));  // inside a: not converted again
  EXPECT_NEAR(fg.converted_fraction(), frac, 1e-12);
  fg.region(cv::Rect(-50, -50, 60, 60));  // clipped to the frame
  EXPECT_NEAR(fg.converted_fraction(), frac + 100.0 / double(bgr.total()), 1e-12);
  EXPECT_EQ(cv::norm(fg.whole(), ref, cv::NORM_INF), 0.0);
  // A new frame starts with nothing converted.
  fg.reset(bgr);
  EXPECT_EQ(fg.converted_fraction(), 0.0);
  // A grey frame is used as it is.
  fg.reset(ref);
  EXPECT_EQ(fg.region(a).data, ref.data);
  EXPECT_EQ(fg.converted_fraction(), 0.0);
}

// The camera's YUYV: the grey levels from the Y plane alone equal OpenCV's grey of its
// own YUYV-to-BGR conversion within 1 level wherever that conversion does not clip.
TEST(FrameGray, YuyvGreyFromTheLumaEqualsTheConvertedGreyWithinOneLevel) {
  const cv::Mat bgr = real_photo();
  ASSERT_FALSE(bgr.empty());
  cv::Mat yuyv, back, ref;
  bgr_to_yuyv(bgr, yuyv);
  ASSERT_EQ(yuyv.type(), CV_8UC2);
  cv::cvtColor(yuyv, back, cv::COLOR_YUV2BGR_YUYV);
  cv::cvtColor(back, ref, cv::COLOR_BGR2GRAY);
  // The YUYV round trip keeps the picture (chroma halved horizontally).
  cv::Mat g0;
  cv::cvtColor(bgr, g0, cv::COLOR_BGR2GRAY);
  EXPECT_LT(cv::norm(ref, g0, cv::NORM_L1) / double(ref.total()), 2.0);
  FrameGray fg;
  fg.reset(yuyv);
  const cv::Rect r(30, 40, 250, 180);
  const cv::Mat& g = fg.region(r);
  int compared = 0, clipped = 0, worst = 0;
  for (int y = r.y; y < r.br().y; ++y)
    for (int x = r.x; x < r.br().x; ++x) {
      const cv::Vec3b c = back.at<cv::Vec3b>(y, x);
      if (c[0] == 0 || c[1] == 0 || c[2] == 0 || c[0] == 255 || c[1] == 255 || c[2] == 255) {
        ++clipped;
        continue;
      }
      ++compared;
      worst = std::max(worst, std::abs(int(g.at<uchar>(y, x)) - int(ref.at<uchar>(y, x))));
    }
  EXPECT_LE(worst, 1);
  EXPECT_GT(compared, 9 * clipped) << "most of the region must be compared";
  EXPECT_NEAR(fg.converted_fraction(), double(r.area()) / double(yuyv.total()), 1e-12);
  // The whole frame, every pixel (clipped ones included) within 1 level but a few.
  const cv::Mat& w = fg.whole();
  cv::Mat diff;
  cv::absdiff(w, ref, diff);
  EXPECT_GT(cv::countNonZero(diff <= 1), 0.99 * double(diff.total()));
}

TEST(FrameGray, DecimatedGreyPicksEveryKthPixel) {
  const cv::Mat bgr = real_photo();
  ASSERT_FALSE(bgr.empty());
  cv::Mat ref, d;
  cv::cvtColor(bgr, ref, cv::COLOR_BGR2GRAY);
  decimated_gray(bgr, 3, d);
  ASSERT_EQ(d.cols, bgr.cols / 3);
  ASSERT_EQ(d.rows, bgr.rows / 3);
  for (int y = 0; y < d.rows; y += 7)
    for (int x = 0; x < d.cols; x += 5) ASSERT_EQ(d.at<uchar>(y, x), ref.at<uchar>(3 * y, 3 * x));
  cv::Mat yuyv, dy;
  bgr_to_yuyv(bgr, yuyv);
  decimated_gray(yuyv, 2, dy);
  FrameGray fg;
  fg.reset(yuyv);
  const cv::Mat& w = fg.whole();
  for (int y = 0; y < dy.rows; y += 7)
    for (int x = 0; x < dy.cols; x += 5) ASSERT_EQ(dy.at<uchar>(y, x), w.at<uchar>(2 * y, 2 * x));
}

TEST(FrameGray, RefusesFramesItCannotRead) {
  EXPECT_NE(frame_gray_error(cv::Mat()).find("empty"), std::string::npos);
  EXPECT_NE(frame_gray_error(cv::Mat(4, 5, CV_8UC2)).find("even width"), std::string::npos);
  EXPECT_NE(frame_gray_error(cv::Mat(4, 4, CV_32FC1)).find("32FC1"), std::string::npos);
  EXPECT_NE(frame_gray_error(cv::Mat(4, 4, CV_8UC4)).find("neither"), std::string::npos);
  EXPECT_EQ(frame_gray_error(cv::Mat(4, 4, CV_8UC3)), "");
  EXPECT_EQ(frame_gray_error(cv::Mat(4, 4, CV_8UC2)), "");
  EXPECT_EQ(frame_gray_error(cv::Mat(4, 4, CV_8UC1)), "");
}

}  // namespace
}  // namespace dentar::ar
