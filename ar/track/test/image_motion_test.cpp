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

namespace dentar::ar {
namespace {

// Issue 28: the thumbnail from every 3rd pixel of a 1920x1080 frame (as delivered:
// BGR) measures the shift the whole grey frame measures.
TEST(ImageMotion, DecimatedThumbnailOfALargeFrameMeasuresTheSameShift) {
  const cv::Mat g = textured(1920, 1080, 4);
  cv::Mat a;
  cv::cvtColor(g, a, cv::COLOR_GRAY2BGR);
  // Colour that the grey level follows (green stronger than red).
  a.forEach<cv::Vec3b>([](cv::Vec3b& p, const int* pos) {
    p[2] = static_cast<uchar>((p[2] + pos[1] / 8) % 256);
  });
  EXPECT_EQ(ImageMotion::decimation_for_width(1920), 3);
  EXPECT_EQ(ImageMotion::decimation_for_width(1280), 2);
  EXPECT_EQ(ImageMotion::decimation_for_width(640), 1);
  cv::Mat b;
  const cv::Mat M = (cv::Mat_<double>(2, 3) << 1, 0, 37.4, 0, 1, -21.7);
  cv::warpAffine(a, b, M, a.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  cv::Mat ga, gb;
  cv::cvtColor(a, ga, cv::COLOR_BGR2GRAY);
  cv::cvtColor(b, gb, cv::COLOR_BGR2GRAY);
  ImageMotion whole, dec;
  cv::Mat ref_w, ref_d;
  whole.set_frame(ga);
  whole.keep(ref_w);
  dec.set_frame_from_image(a);
  dec.keep(ref_d);
  ASSERT_EQ(ref_w.size(), ref_d.size());  // the same thumbnail size: references stay usable
  whole.set_frame(gb);
  dec.set_frame_from_image(b);
  const ImageMotion::Shift sw = whole.shift_since(ref_w), sd = dec.shift_since(ref_d);
  ASSERT_TRUE(sw.valid && sd.valid);
  EXPECT_NEAR(sd.px.x(), 37.4, 3.0);
  EXPECT_NEAR(sd.px.y(), -21.7, 3.0);
  EXPECT_LT((sd.px - sw.px).norm(), 0.5) << "decimated " << sd.px.transpose() << " whole " << sw.px.transpose();
  EXPECT_GT(sd.response, 0.8 * sw.response);
  // A grey frame at 640 px is exactly the whole frame's thumbnail.
  const cv::Mat small = textured(640, 480, 5);
  ImageMotion p, q;
  cv::Mat rp, rq;
  p.set_frame(small);
  p.keep(rp);
  q.set_frame_from_image(small);
  q.keep(rq);
  EXPECT_EQ(cv::norm(rp, rq, cv::NORM_INF), 0.0);
}

}  // namespace
}  // namespace dentar::ar
