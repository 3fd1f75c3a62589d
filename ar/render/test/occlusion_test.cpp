// Foreground segmentation and mask metrics on synthetic images (no GL).
#include "dentar/ar/occlusion.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>

namespace dentar::ar {
namespace {

cv::Mat square(int size, int x, int y, int side) {
  cv::Mat m = cv::Mat::zeros(size, size, CV_8UC1);
  m(cv::Rect(x, y, side, side)).setTo(255);
  return m;
}

TEST(CompareMasks, IdenticalShiftedAndEmpty) {
  const cv::Mat a = square(64, 10, 10, 20);
  MaskScore s = compare_masks(a, a);
  EXPECT_DOUBLE_EQ(s.iou, 1.0);
  EXPECT_DOUBLE_EQ(s.boundary_f, 1.0);
  EXPECT_EQ(s.intersection_px, 400);

  // One pixel right: 19x20 overlap of 21x20 union.
  const cv::Mat b = square(64, 11, 10, 20);
  s = compare_masks(b, a);
  EXPECT_NEAR(s.iou, 380.0 / 420.0, 1e-12);
  EXPECT_DOUBLE_EQ(s.boundary_f, 1.0);  // within 2 px everywhere
  // Three pixels: the left/right edges are no longer matched within 2 px.
  const cv::Mat c = square(64, 13, 10, 20);
  s = compare_masks(c, a);
  EXPECT_NEAR(s.iou, 340.0 / 460.0, 1e-12);
  EXPECT_LT(s.boundary_f, 0.95);
  EXPECT_GT(s.boundary_f, 0.5);
  EXPECT_LT(compare_masks(c, a, 0.5).boundary_f, s.boundary_f);

  const cv::Mat z = cv::Mat::zeros(64, 64, CV_8UC1);
  s = compare_masks(z, z);
  EXPECT_DOUBLE_EQ(s.iou, 1.0);
  EXPECT_DOUBLE_EQ(s.boundary_f, 1.0);
  s = compare_masks(z, a);
  EXPECT_DOUBLE_EQ(s.iou, 0.0);
  EXPECT_DOUBLE_EQ(s.boundary_f, 0.0);
}

// sRGB colour at a relative light level (shading in linear light).
cv::Vec3b shade(const Eigen::Vector3d& rgb, double light) {
  cv::Vec3b out;
  for (int c = 0; c < 3; ++c)
    out[2 - c] = static_cast<std::uint8_t>(
        std::lround(255.0 * std::pow(std::pow(rgb[c], 2.2) * light, 1.0 / 2.2)));
  return out;
}

// A mouth-like scene: gum on the left half, cavity (dark red) bottom right,
// a neighbouring tooth (white) top right; the expected albedo matches.
struct Scene {
  cv::Mat video, expected;
  Scene() : video(120, 160, CV_8UC3), expected(120, 160, CV_8UC4) {
    const Eigen::Vector3d gum(0.85, 0.45, 0.48), cavity(0.45, 0.13, 0.15), tooth(0.93, 0.91, 0.84);
    for (int v = 0; v < video.rows; ++v)
      for (int u = 0; u < video.cols; ++u) {
        const Eigen::Vector3d& c = u < 80 ? gum : (v < 60 ? tooth : cavity);
        const double light = 0.35 + 0.6 * u / video.cols;  // a gradient of shading
        video.at<cv::Vec3b>(v, u) = shade(c, light);
        expected.at<cv::Vec4b>(v, u) =
            cv::Vec4b(static_cast<std::uint8_t>(c.x() * 255), static_cast<std::uint8_t>(c.y() * 255),
                      static_cast<std::uint8_t>(c.z() * 255), 255);
      }
  }
};

TEST(ForegroundSegmenter, FindsAFingerAndNothingElse) {
  Scene sc;
  SyntheticFinger f;
  f.a_px = {20, 100};
  f.b_px = {140, 30};
  f.radius_px = 12;
  const cv::Mat truth = paint_synthetic_finger(sc.video, f);
  ASSERT_GT(cv::countNonZero(truth), 1500);
  ForegroundSegmenter seg;
  cv::Mat fg;
  const cv::Mat region(sc.video.size(), CV_8UC1, cv::Scalar(255));
  seg.segment(sc.video, sc.expected, region, fg);
  const MaskScore s = compare_masks(fg > 127, truth);
  EXPECT_GE(s.iou, 0.97);
  EXPECT_GE(s.boundary_f, 0.97);

  // Without the finger: no foreground at all.
  Scene clean;
  seg.segment(clean.video, clean.expected, region, fg);
  EXPECT_EQ(cv::countNonZero(fg > 127), 0);

  // Outside the region nothing is classified.
  cv::Mat half = region.clone();
  half(cv::Rect(0, 0, 80, 120)).setTo(0);
  seg.segment(sc.video, sc.expected, half, fg);
  EXPECT_EQ(cv::countNonZero(fg(cv::Rect(0, 0, 80, 120))), 0);
  EXPECT_GT(cv::countNonZero(fg(cv::Rect(80, 0, 80, 120)) > 127), 300);
}

TEST(ForegroundSegmenter, ExpectedSkinColouredSurfaceIsNotForeground) {
  // The mannequin's own skin (face) expected and seen: close to the finger's
  // colour, but closer still to what is expected there.
  const Eigen::Vector3d face(0.87, 0.72, 0.62);
  cv::Mat video(40, 40, CV_8UC3, shade(face, 0.7));
  cv::Mat expected(40, 40, CV_8UC4, cv::Vec4b(222, 184, 158, 255));
  cv::Mat fg;
  ForegroundSegmenter seg;
  seg.segment(video, expected, cv::Mat(40, 40, CV_8UC1, cv::Scalar(255)), fg);
  EXPECT_EQ(cv::countNonZero(fg > 127), 0);
  // With nothing expected there (alpha 0), the same pixels are foreground.
  expected.setTo(cv::Scalar::all(0));
  seg.segment(video, expected, cv::Mat(40, 40, CV_8UC1, cv::Scalar(255)), fg);
  EXPECT_EQ(cv::countNonZero(fg > 127), 40 * 40);
}

TEST(ForegroundSegmenter, AdaptsWithinItsBound) {
  Scene sc;
  SyntheticFinger f;
  f.a_px = {20, 60};
  f.b_px = {140, 60};
  f.radius_px = 15;
  f.rgb = Eigen::Vector3d(0.84, 0.62, 0.50);  // a slightly ruddier hand than the seed
  paint_synthetic_finger(sc.video, f);
  SegmenterOptions o;
  ForegroundSegmenter seg(o);
  const Eigen::Vector2d seed = seg.model_chroma();
  const Eigen::Vector2d target(0.62 / 0.84, 0.50 / 0.84);
  cv::Mat fg;
  const cv::Mat region(sc.video.size(), CV_8UC1, cv::Scalar(255));
  for (int i = 0; i < 30; ++i) seg.segment(sc.video, sc.expected, region, fg);
  const Eigen::Vector2d m = seg.model_chroma();
  EXPECT_LT((m - target).norm(), (seed - target).norm() * 0.5) << m.transpose();
  EXPECT_LE((m - seed).norm(), o.max_adapt + 1e-9);
  seg.reset();
  EXPECT_EQ(seg.model_chroma(), seed);
  // A fixed model does not move.
  o.adapt_rate = 0;
  ForegroundSegmenter fixed(o);
  fixed.segment(sc.video, sc.expected, region, fg);
  EXPECT_EQ(fixed.model_chroma(), seed);
}

TEST(SegmenterOptions, ValidateNamesTheField) {
  SegmenterOptions o;
  EXPECT_EQ(o.validate(), "");
  o.max_distance = 0;
  EXPECT_NE(o.validate().find("max_distance"), std::string::npos);
  o = {};
  o.seed_rgb = Eigen::Vector3d(1.5, 0, 0);
  EXPECT_NE(o.validate().find("seed_rgb"), std::string::npos);
  o = {};
  o.adapt_rate = 2;
  EXPECT_NE(o.validate().find("adapt_rate"), std::string::npos);
}

}  // namespace
}  // namespace dentar::ar
