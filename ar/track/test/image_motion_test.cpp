// ImageMotion (image_motion.h): the global shift between two frames from
// thumbnails, and a low correlation when the content changed.
#include "dentar/ar/image_motion.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <random>

namespace dentar::ar {
namespace {

cv::Mat textured(int w, int h, unsigned seed) {
  cv::Mat img(h, w, CV_8UC1);
  cv::RNG rng(seed);
  rng.fill(img, cv::RNG::UNIFORM, 0, 255);
  cv::GaussianBlur(img, img, cv::Size(0, 0), 6.0);  // blobs a thumbnail still sees
  cv::normalize(img, img, 0, 255, cv::NORM_MINMAX);
  return img;
}

TEST(ImageMotion, RecoversAGlobalShiftAndFlagsNewContent) {
  const cv::Mat a = textured(640, 480, 1);
  cv::Mat b;
  const cv::Mat M = (cv::Mat_<double>(2, 3) << 1, 0, 24, 0, 1, -14);
  cv::warpAffine(a, b, M, a.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  ImageMotion m;
  cv::Mat ref;
  m.set_frame(a);
  m.keep(ref);
  m.set_frame(a);
  ImageMotion::Shift s0 = m.shift_since(ref);
  ASSERT_TRUE(s0.valid);
  EXPECT_LT(s0.px.norm(), 0.5);
  EXPECT_GT(s0.response, 0.5);
  m.set_frame(b);
  const ImageMotion::Shift s = m.shift_since(ref);
  ASSERT_TRUE(s.valid);
  EXPECT_NEAR(s.px.x(), 24, 3.0);  // 0.75 thumbnail px
  EXPECT_NEAR(s.px.y(), -14, 3.0);
  // Another scene correlates far less (measured ~0.2 against > 0.5 for the
  // same: smooth blobs give spurious peaks on a thumbnail, so the tracker
  // relies on the shift, the response threshold only on near-zero peaks).
  m.set_frame(textured(640, 480, 2));
  EXPECT_LT(m.shift_since(ref).response, 0.5 * s0.response);
  EXPECT_FALSE(m.shift_since(cv::Mat()).valid);
  m.set_frame(textured(320, 200, 3));  // another aspect: thumbnail of another size
  EXPECT_FALSE(m.shift_since(ref).valid);
}

}  // namespace
}  // namespace dentar::ar
