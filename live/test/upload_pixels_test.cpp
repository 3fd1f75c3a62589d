// The window's upload of a keep_yuyv composite (hud_window.h upload_pixels, issue 28
// session 20): the camera's YUYV converted straight into the texture's layout with the
// overlay's BGR patch over it gives the bytes the whole BGR composite's upload gave.
#include "dentar/live/hud_window.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "dentar/ar/frame_gray.h"

namespace {

using dentar::live::upload_pixels;

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

}  // namespace
