// The instructor's page names metrics in words with units (issue 25), never
// by their raw score.json keys.
#include "dentar/store/metric_names.h"

#include <gtest/gtest.h>

namespace dentar::store {
namespace {

TEST(MetricNames, KnownMetricsInWordsWithUnits) {
  const MetricLabel wall = metric_label("outcome.criteria.buccal wall.value", "");
  EXPECT_EQ(wall.label, "Buccal wall: divergence toward the occlusal surface");
  EXPECT_EQ(wall.unit, "deg");
  EXPECT_EQ(metric_label("outcome.criteria.buccal wall.score", "").unit, "of 3");
  // The class I wall taper (issue 25, session 14) is worth its exercise's points, and its value is
  // the walls' mean excess over the ideal taper, not one wall's divergence.
  EXPECT_EQ(metric_label("outcome.criteria.wall taper.score", "").unit, "points");
  const MetricLabel taper = metric_label("outcome.criteria.wall taper.value", "");
  EXPECT_EQ(taper.label, "Wall taper: mean outside the ideal taper");
  EXPECT_EQ(taper.unit, "deg");
  EXPECT_EQ(metric_label("outcome.criteria.wall taper.max_score", "").label, "Wall taper: points possible");
  const MetricLabel en = metric_label("outcome.removed_mm3.enamel", "");
  EXPECT_EQ(en.label, "Enamel removed");
  EXPECT_EQ(en.unit, "mm³");
  const MetricLabel cov = metric_label("outcome.target_coverage_pct", "pct");
  EXPECT_EQ(cov.label, "Target removed");
  EXPECT_EQ(cov.unit, "%");
  EXPECT_EQ(metric_label("outcome.regions.labial_incisal.coverage_pct", "pct").label, "Region labial incisal: removed");
  EXPECT_EQ(metric_label("outcome.penalties.pulp exposure.points", "").label, "Cost of pulp exposure");
  EXPECT_EQ(metric_label("process.path_mm", "mm").label, "Bur tip path");
  EXPECT_EQ(metric_label("process.force_by_material.dentin.mean_N", "N").unit, "N");
}

TEST(MetricNames, FlagsAreYesNoAndUnknownKeysAreWords) {
  const MetricLabel c = metric_label("outcome.complete", "bool");
  EXPECT_EQ(c.label, "Preparation finished");
  EXPECT_TRUE(c.yes_no);
  EXPECT_EQ(metric_value_text(c, 0), "no");
  EXPECT_EQ(metric_value_text(c, 1), "yes");
  EXPECT_EQ(metric_value_text(metric_label("process.path_mm", "mm"), 12.345, 1), "12.3");
  // A key this table does not know: its segments in words, no underscores, no dotted path.
  const MetricLabel u = metric_label("process.new_thing.sub_part_mm", "mm");
  EXPECT_EQ(u.label, "New thing, sub part");
  EXPECT_EQ(u.unit, "mm");
  EXPECT_EQ(u.label.find('.'), std::string::npos);
}

}  // namespace
}  // namespace dentar::store
