// Tag images drawn from libapriltag's code tables are detected by
// libapriltag with the right id and corners where the layout puts them.
#include "dentar/ar/apriltags.h"
#include "dentar/ar/tag_detector.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "tag_test_util.h"

namespace dentar::ar {
namespace {

using test::detect_full_resolution;

class TagImages : public ::testing::TestWithParam<TagFamilyId> {};

TEST_P(TagImages, DetectedWithTheRightIdAndCorners) {
  const TagFamily fam = TagFamily::create(GetParam());
  const int ppc = 12, margin = 40;
  for (int id : {0, 1, 7, 20, 21, 137, fam.code_count() - 1}) {
    const cv::Mat img = render_tag_image(fam, id, ppc, margin);
    const auto found = detect_full_resolution(img, GetParam());
    ASSERT_EQ(found.size(), 1u) << tag_family_name(GetParam()) << " id " << id;
    EXPECT_EQ(found[0].id, id);
    EXPECT_EQ(found[0].hamming, 0);
    // The border square's outer edge, in OpenCV pixels: a pixel-aligned
    // edge between pixels k-1 and k lies at k - 0.5. Order: (-,+), (+,+),
    // (+,-), (-,-) in tag x right / y down.
    const double lo = margin + fam.border_start() * ppc - 0.5;
    const double hi = lo + fam.width_at_border() * ppc;
    const Eigen::Vector2d want[4] = {{lo, hi}, {hi, hi}, {hi, lo}, {lo, lo}};
    for (int k = 0; k < 4; ++k)
      EXPECT_LT((found[0].corners_px[k] - want[k]).norm(), 0.25)
          << "id " << id << " corner " << k << ": " << found[0].corners_px[k].transpose();
  }
}

INSTANTIATE_TEST_SUITE_P(Families, TagImages,
                         ::testing::Values(TagFamilyId::kStandard41h12, TagFamilyId::kTag36h11),
                         [](const auto& info) { return std::string(tag_family_name(info.param)); });

TEST(TagFamily, LayoutFacts) {
  const TagFamily a = TagFamily::create(TagFamilyId::kStandard41h12);
  EXPECT_EQ(a.total_width(), 9);
  EXPECT_EQ(a.width_at_border(), 5);
  EXPECT_TRUE(a.reversed_border());
  const TagFamily b = TagFamily::create(TagFamilyId::kTag36h11);
  EXPECT_EQ(b.total_width(), 10);
  EXPECT_EQ(b.width_at_border(), 8);
  EXPECT_FALSE(b.reversed_border());
  // 36h11: black border ring, white quiet ring outside.
  const cv::Mat c = b.cells(0);
  EXPECT_EQ(c.at<std::uint8_t>(1, 1), 0);
  EXPECT_EQ(c.at<std::uint8_t>(0, 0), 255);
  // 41h12: white border ring, black ring outside it.
  const cv::Mat d = a.cells(0);
  EXPECT_EQ(d.at<std::uint8_t>(2, 2), 255);
  EXPECT_EQ(d.at<std::uint8_t>(1, 1), 0);
}

}  // namespace
}  // namespace dentar::ar
