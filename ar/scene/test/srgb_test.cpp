// The sRGB decoding shared by the tracker and the footage generator.
#include "dentar/ar/srgb.h"

#include <gtest/gtest.h>

#include <cmath>

namespace dentar::ar {
namespace {

TEST(Srgb, DecodesTheStandardsCurve) {
  EXPECT_EQ(srgb_decode(0.0), 0.0);
  EXPECT_DOUBLE_EQ(srgb_decode(1.0), 1.0);
  // The linear segment below 0.04045, the power segment above (IEC 61966-2-1).
  EXPECT_DOUBLE_EQ(srgb_decode(0.02), 0.02 / 12.92);
  EXPECT_NEAR(srgb_decode(0.5), 0.214041, 1e-6);
  // The two segments meet at the threshold (the standard's rounded constants
  // leave a step of ~2e-9).
  EXPECT_NEAR(srgb_decode(0.04045), srgb_decode(std::nextafter(0.04045, 1.0)), 1e-8);
  // Monotonic over the codes.
  for (int i = 1; i < 256; ++i) EXPECT_GT(srgb_decode(i / 255.0), srgb_decode((i - 1) / 255.0)) << i;
}

TEST(Srgb, TableHoldsTheCodes) {
  const cv::Mat& t = srgb_decode_table();
  ASSERT_EQ(t.type(), CV_32F);
  ASSERT_EQ(t.rows, 1);
  ASSERT_EQ(t.cols, 256);
  for (int i = 0; i < 256; ++i) EXPECT_EQ(t.at<float>(0, i), static_cast<float>(srgb_decode(i / 255.0))) << i;
  EXPECT_EQ(&srgb_decode_table(), &t);  // built once
}

}  // namespace
}  // namespace dentar::ar
