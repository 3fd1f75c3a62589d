#include "dentar/calibration/stylus_poses.h"

#include <gtest/gtest.h>

#include <cmath>

namespace dentar::calibration {
namespace {

constexpr const char* kHeader = "label,tx_mm,ty_mm,tz_mm,rx_deg,ry_deg,rz_deg\n";

TEST(StylusPoses, ReadsRowsInMetresAndRadians) {
  const std::string text = std::string("# poses\n") + kHeader +
                           "pivot,10,-20,30,0,0,90\r\n\n"
                           "divot:2,1,2,3,0,0,0,5,6,7,90,0,0\n";
  const auto r = parse_stylus_poses(text, "p.csv");
  ASSERT_TRUE(r) << r.error();
  ASSERT_EQ(r->size(), 2u);
  const auto& a = (*r)[0];
  EXPECT_EQ(a.label, "pivot");
  EXPECT_EQ(a.line, 3);
  EXPECT_LT((a.T_dev_sty.translation() - Eigen::Vector3d(0.010, -0.020, 0.030)).norm(), 1e-15);
  EXPECT_LT((a.T_dev_sty.linear() * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY()).norm(), 1e-12);
  EXPECT_FALSE(a.T_mtag_man.has_value());
  const auto& b = (*r)[1];
  ASSERT_TRUE(b.T_mtag_man.has_value());
  EXPECT_LT((b.T_mtag_man->linear() * Eigen::Vector3d::UnitY() - Eigen::Vector3d::UnitZ()).norm(), 1e-12);
  EXPECT_EQ(b.line, 5);
  EXPECT_EQ(*stylus_label_index(b, "p.csv", 8), 2);
  EXPECT_EQ(stylus_rows_with(*r, "divot:").size(), 1u);
}

void expect_error(const std::string& text, const std::string& what) {
  const auto r = parse_stylus_poses(text, "p.csv");
  ASSERT_FALSE(r) << text;
  EXPECT_EQ(r.error().rfind("p.csv:", 0), 0u) << r.error();
  EXPECT_NE(r.error().find(what), std::string::npos) << r.error();
}

TEST(StylusPoses, BadInputNamesTheLineAndColumn) {
  expect_error("", "no header");
  expect_error("pivot,1,2,3,0,0,0\n", "header");
  expect_error(std::string(kHeader) + "pivot,1,2,3,0,0\n", "p.csv:2: expected 7 or 13 columns, found 6");
  expect_error(std::string(kHeader) + "pivot,1,2,x,0,0,0\n", "column 4 (tz_mm) \"x\"");
  expect_error(std::string(kHeader) + "pivot,1,2,nan,0,0,0\n", "not a finite number");
  expect_error(std::string(kHeader) + "pivot,1,2,1e999,0,0,0\n", "not a finite number");
  expect_error(std::string(kHeader) + "pivot,1,2,3 4,0,0,0\n", "column 4");
  expect_error(std::string(kHeader) + "pivot,20000,0,0,0,0,0\n", "millimetres");
  expect_error(std::string(kHeader) + "pivot,0,0,0,400,0,0\n", "degrees");
  expect_error(std::string(kHeader) + ",0,0,0,0,0,0\n", "label");
  expect_error(std::string(kHeader) + "pivot,1,2,3,0,0,0,1,2,3,4,5,6,7\n", "more than 13");
}

TEST(StylusPoses, LabelIndexIsCheckedAgainstTheFixtures) {
  StylusPoseRow r;
  r.line = 7;
  for (const char* bad : {"divot:9", "divot:", "divot", "divot:-1", "divot:1x", "divot:99999999999"}) {
    r.label = bad;
    const auto i = stylus_label_index(r, "p.csv", 8);
    ASSERT_FALSE(i) << bad;
    EXPECT_NE(i.error().find("p.csv:7: label"), std::string::npos) << i.error();
    EXPECT_NE(i.error().find("0..7"), std::string::npos) << i.error();
  }
}

TEST(StylusPoses, MissingFileIsAClearError) {
  const auto r = read_stylus_poses("/nonexistent/poses.csv");
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("cannot open"), std::string::npos);
}

}  // namespace
}  // namespace dentar::calibration
