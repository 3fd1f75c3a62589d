// The window's upload of a keep_yuyv composite (hud_window.h upload_pixels, issue 28
// session 20): the camera's YUYV converted straight into the texture's layout with the
// overlay's BGR patch over it gives the bytes the whole BGR composite's upload gave.
#include "dentar/live/hud_window.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "dentar/ar/frame_gray.h"

namespace {

using dentar::live::upload_pixels;
using dentar::live::upload_pixels_half;

struct Frame {
  cv::Mat yuyv, bgr, patch;  // bgr: the whole composite (the YUYV converted, patch over it)
  cv::Rect rect;
};

Frame make_frame(int w, int h, cv::Rect rect) {
  Frame f;
  cv::Mat scene(h, w, CV_8UC3);
  cv::randu(scene, 0, 256);
  dentar::ar::bgr_to_yuyv(scene, f.yuyv);
  cv::cvtColor(f.yuyv, f.bgr, cv::COLOR_YUV2BGR_YUYV);
  f.patch.create(rect.size(), CV_8UC3);
  cv::randu(f.patch, 0, 256);
  f.patch.copyTo(f.bgr(rect));
  f.rect = rect;
  return f;
}

TEST(UploadPixels, YuyvWithItsPatchGivesTheWholeCompositesUpload) {
  for (const bool gles : {false, true}) {
    for (const cv::Rect rect : {cv::Rect(100, 40, 64, 50), cv::Rect(0, 0, 2, 1), cv::Rect(254, 100, 66, 140)}) {
      SCOPED_TRACE(gles ? "RGBA" : "BGRA");
      const Frame f = make_frame(320, 240, rect);
      cv::Mat want, got;
      cv::cvtColor(f.bgr, want, gles ? cv::COLOR_BGR2RGBA : cv::COLOR_BGR2BGRA);
      ASSERT_EQ(upload_pixels(f.yuyv, f.patch, f.rect, gles, got), "");
      ASSERT_EQ(got.type(), CV_8UC4);
      EXPECT_EQ(cv::norm(got, want, cv::NORM_INF), 0.0) << rect;
      // No patch: the frame's own conversion, BGR or YUYV alike.
      cv::Mat video, a, b;
      cv::cvtColor(f.yuyv, video, cv::COLOR_YUV2BGR_YUYV);
      ASSERT_EQ(upload_pixels(f.yuyv, {}, {}, gles, a), "");
      ASSERT_EQ(upload_pixels(video, {}, {}, gles, b), "");
      EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
      EXPECT_GT(cv::norm(a, want, cv::NORM_INF), 0.0);  // the patch did change something above
    }
  }
}

TEST(UploadPixels, BadPatchesRefusedWithTheReasonAndNothingWritten) {
  const Frame f = make_frame(320, 240, cv::Rect(10, 10, 40, 30));
  cv::Mat out(240, 320, CV_8UC4, cv::Scalar::all(7));
  const auto untouched = [&] { return cv::countNonZero(out.reshape(1) != 7) == 0; };
  std::string e = upload_pixels(f.yuyv, f.patch, cv::Rect(10, 10, 40, 31), false, out);
  EXPECT_NE(e.find("does not fit"), std::string::npos) << e;
  EXPECT_TRUE(untouched());
  e = upload_pixels(f.yuyv, f.patch, cv::Rect(300, 10, 40, 30), false, out);  // past the right edge
  EXPECT_NE(e.find("does not fit"), std::string::npos) << e;
  EXPECT_TRUE(untouched());
  cv::Mat grey(30, 40, CV_8UC1, cv::Scalar(1));
  e = upload_pixels(f.yuyv, grey, cv::Rect(10, 10, 40, 30), false, out);
  EXPECT_NE(e.find("must be BGR"), std::string::npos) << e;
  EXPECT_TRUE(untouched());
  cv::Mat f32(240, 320, CV_32FC1, cv::Scalar(0));
  e = upload_pixels(f32, {}, {}, false, out);
  EXPECT_NE(e.find("CV_8UC3"), std::string::npos) << e;
  EXPECT_TRUE(untouched());
}

// Session 23: the half-size upload straight from the YUYV against the full-size upload then the
// 2x2 mean (session 22's path): the patch's texels equal to the bit, the rest within the
// rounding of a mean taken before the conversion instead of after it (clamping aside: a block
// whose pixels convert outside 0..255 is clamped once, not per pixel).
TEST(UploadPixels, HalfSizeFromYuyvMatchesFullSizeThenBoxMean) {
  for (const bool noise : {false, true}) {
    for (const bool gles : {false, true}) {
      SCOPED_TRACE(std::string(noise ? "noise" : "smooth") + (gles ? " RGBA" : " BGRA"));
      for (const cv::Rect rect : {cv::Rect(101, 41, 63, 49), cv::Rect(0, 0, 2, 1), cv::Rect(254, 100, 66, 140)}) {
        Frame f = make_frame(320, 240, rect);
        if (!noise) {  // a camera-like picture: smooth shading and edges, in the legal range
          cv::Mat scene(240, 320, CV_8UC3);
          for (int y = 0; y < 240; ++y)
            for (int x = 0; x < 320; ++x)
              scene.at<cv::Vec3b>(y, x) = cv::Vec3b(static_cast<uchar>(40 + x / 2), static_cast<uchar>(60 + y / 2),
                                                    static_cast<uchar>((x / 16 + y / 16) % 2 ? 200 : 50));
          dentar::ar::bgr_to_yuyv(scene, f.yuyv);
        }
        cv::Mat full, want, got;
        ASSERT_EQ(upload_pixels(f.yuyv, f.patch, f.rect, gles, full), "");
        cv::resize(full, want, cv::Size(160, 120), 0, 0, cv::INTER_AREA);
        ASSERT_EQ(upload_pixels_half(f.yuyv, f.patch, f.rect, gles, got), "");
        ASSERT_EQ(got.size(), want.size());
        ASSERT_EQ(got.type(), CV_8UC4);
        // The patch's texels (its rectangle grown to even bounds, halved): equal.
        const int x0 = rect.x / 2, y0 = rect.y / 2, x1 = (rect.x + rect.width + 1) / 2, y1 = (rect.y + rect.height + 1) / 2;
        const cv::Rect hp(x0, y0, x1 - x0, y1 - y0);
        EXPECT_EQ(cv::norm(got(hp), want(hp), cv::NORM_INF), 0.0);
        cv::Mat diff;
        cv::absdiff(got, want, diff);
        const double mean = cv::mean(diff.reshape(1))[0];
        double mx = 0;
        cv::minMaxLoc(diff.reshape(1), nullptr, &mx);
        std::vector<uchar> v(diff.begin<uchar>(), diff.end<uchar>());
        std::sort(v.begin(), v.end());
        const int p99 = v[v.size() * 99 / 100];
        RecordProperty(std::string("half_") + (noise ? "noise" : "smooth") + (gles ? "_rgba" : "_bgra"), 
                       std::to_string(mean) + " / " + std::to_string(p99) + " / " + std::to_string(mx));
        std::printf("%s %s rect %dx%d: mean %.3f p99 %d max %.0f\n", noise ? "noise" : "smooth", gles ? "RGBA" : "BGRA",
                    rect.width, rect.height, mean, p99, mx);
        if (noise) {
          EXPECT_LT(mean, 1.5);
          EXPECT_LE(p99, 12);
        } else {
          EXPECT_LT(mean, 0.5);
          EXPECT_LE(mx, 2.0);
        }
      }
    }
  }
  // Refused: not YUYV, or odd sides; a bad patch with upload_pixels' reason.
  cv::Mat out;
  const Frame f = make_frame(320, 240, cv::Rect(10, 10, 40, 30));
  cv::Mat bgr(240, 320, CV_8UC3, cv::Scalar::all(0));
  EXPECT_NE(upload_pixels_half(bgr, {}, {}, false, out).find("must be YUYV"), std::string::npos);
  EXPECT_NE(upload_pixels_half(f.yuyv(cv::Rect(0, 0, 320, 239)), {}, {}, false, out).find("even width and height"),
            std::string::npos);
  EXPECT_NE(upload_pixels_half(f.yuyv, f.patch, cv::Rect(10, 10, 40, 31), false, out).find("does not fit"),
            std::string::npos);
}

}  // namespace
