// Metric names in words for the instructor's page (issue 25): a stored
// metric is named by its dotted path in score.json ("outcome.criteria.buccal
// wall.value", "process.path_mm"); the page shows "Buccal wall: divergence"
// in "deg" instead. Pure functions, no I/O.
#pragma once

#include <string>

namespace dentar::store {

struct MetricLabel {
  std::string label;  // words, first letter capital ("Enamel removed")
  std::string unit;   // display unit ("mm³", "%", "s", "N", "deg", "points", "" for yes/no and counts)
  bool yes_no = false;  // a 0/1 flag: shown as yes/no
};

// `name`: the stored dotted path; `stored_unit`: the unit stored with it
// (from the name's suffix, "bool" for flags). Unknown paths get their last
// segments in words with the suffix's unit, never the raw key.
MetricLabel metric_label(const std::string& name, const std::string& stored_unit);

// The value as the page shows it: "yes"/"no" for flags, else fixed with
// `decimals`.
std::string metric_value_text(const MetricLabel& l, double value, int decimals = 2);

}  // namespace dentar::store
