// Report plots: tick choice, percentiles, gaps for lost frames, escaping.
#include "dentar/ar/report.h"

#include <gtest/gtest.h>

#include <cmath>
#include <regex>

namespace dentar::ar {
namespace {

int count(const std::string& s, const std::string& what) {
  int n = 0;
  for (std::size_t p = s.find(what); p != std::string::npos; p = s.find(what, p + 1)) ++n;
  return n;
}

TEST(Report, NiceTicksAreRoundAndCoverTheRange) {
  const auto t = nice_ticks(0.0, 0.93, 5);
  ASSERT_GE(t.size(), 4u);
  EXPECT_DOUBLE_EQ(t.front(), 0.0);
  EXPECT_NEAR(t[1] - t[0], 0.2, 1e-12);
  EXPECT_LE(t.back(), 0.93 + 1e-12);
  const auto u = nice_ticks(-37.0, 512.0, 6);
  EXPECT_NEAR(u[1] - u[0], 100.0, 1e-9);
  EXPECT_DOUBLE_EQ(u.front(), 0.0);
  EXPECT_TRUE(nice_ticks(1.0, 1.0).empty());
  EXPECT_TRUE(nice_ticks(0.0, NAN).empty());
}

TEST(Report, PercentileInterpolatesAndSkipsNonFinite) {
  EXPECT_DOUBLE_EQ(percentile({1, 2, 3, 4, 5}, 50), 3.0);
  EXPECT_DOUBLE_EQ(percentile({1, 2, 3, 4}, 50), 2.5);
  EXPECT_DOUBLE_EQ(percentile({NAN, 10, INFINITY, 20}, 100), 20.0);
  EXPECT_DOUBLE_EQ(percentile({5}, 99), 5.0);
  EXPECT_TRUE(std::isnan(percentile({NAN}, 50)));
}

TEST(Report, LostFramesAreGapsNotZeros) {
  LinePlot p;
  p.title = "error";
  p.series.push_back({"e", {0, 1, 2, 3, 4, 5}, {1, 2, NAN, NAN, 3, 4}, ""});
  const std::string svg = svg_line_plot(p);
  // Two runs of two points: two polylines, and no point drawn at y = 0.
  EXPECT_EQ(count(svg, "<polyline"), 2);
  EXPECT_EQ(svg.find("nan"), std::string::npos);
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
}

TEST(Report, IsolatedPointIsADotAndGoalIsDashed) {
  LinePlot p;
  p.title = "t";
  p.series.push_back({"a", {0, 1, 2}, {NAN, 2.0, NAN}, ""});
  p.goal_y = 0.3;
  const std::string svg = svg_line_plot(p);
  EXPECT_EQ(count(svg, "<circle"), 1);
  EXPECT_EQ(count(svg, "<polyline"), 0);
  EXPECT_GE(count(svg, "stroke-dasharray"), 2);  // line + legend swatch
}

TEST(Report, EmptyInputsSayNoData) {
  EXPECT_NE(svg_line_plot(LinePlot{}).find("no data"), std::string::npos);
  Histogram h;
  h.samples = {NAN};
  EXPECT_NE(svg_histogram(h).find("no data"), std::string::npos);
}

TEST(Report, HistogramCountsEverySample) {
  Histogram h;
  h.title = "t";
  h.bins = 10;
  for (int i = 0; i < 1000; ++i) h.samples.push_back(i % 100);
  h.samples.push_back(1e6);  // an outlier is clamped into the last bin, not lost
  const std::string svg = svg_histogram(h);
  EXPECT_NE(svg.find("n = 1001"), std::string::npos);
  EXPECT_NE(svg.find("1 outliers clamped"), std::string::npos);
  // Bar heights add up to the sample count: read back the bars' heights
  // through the plot scale (top bar = max count).
  std::regex bar("<rect x=\"[0-9.]+\" y=\"[0-9.]+\" width=\"[0-9.]+\" height=\"([0-9.]+)\" fill=\"#0072B2\"");
  int bars = 0;
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), bar); it != std::sregex_iterator(); ++it) ++bars;
  EXPECT_GE(bars, 9);
  EXPECT_LE(bars, 10);
}

TEST(Report, TitlesAreEscaped) {
  LinePlot p;
  p.title = "a<b & \"c\"";
  p.series.push_back({"<x>", {0, 1}, {0, 1}, ""});
  const std::string svg = svg_line_plot(p);
  EXPECT_NE(svg.find("a&lt;b &amp; &quot;c&quot;"), std::string::npos);
  EXPECT_EQ(svg.find("<x>"), std::string::npos);
  EXPECT_EQ(html_escape("<&>"), "&lt;&amp;&gt;");
}

}  // namespace
}  // namespace dentar::ar
