#include "dentar/store/metric_names.h"

#include <cctype>
#include <cstdio>
#include <utility>
#include <vector>

namespace dentar::store {
namespace {

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> v;
  std::string cur;
  for (char c : s) {
    if (c == '.') {
      v.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  v.push_back(cur);
  return v;
}

bool ends_with(const std::string& s, const std::string& t) {
  return s.size() >= t.size() && s.compare(s.size() - t.size(), t.size(), t) == 0;
}

// "labial_incisal" -> "labial incisal"; a unit suffix is dropped.
std::string words(std::string s) {
  for (const char* u : {"_mm3", "_mm", "_s", "_N", "_pct", "_deg"})
    if (ends_with(s, u) && s.size() > std::string(u).size()) {
      s.resize(s.size() - std::string(u).size());
      break;
    }
  for (char& c : s)
    if (c == '_') c = ' ';
  return s;
}

std::string capital(std::string s) {
  if (!s.empty()) s[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(s[0])));
  return s;
}

std::string display_unit(const std::string& u) {
  if (u == "mm3") return "mm³";
  if (u == "pct") return "%";
  return u;
}

}  // namespace

MetricLabel metric_label(const std::string& name, const std::string& stored_unit) {
  const std::vector<std::string> p = split(name);
  const std::string leaf = p.back();
  MetricLabel l;
  l.unit = display_unit(stored_unit);
  if (stored_unit == "bool") {
    l.unit.clear();
    l.yes_no = true;
  }
  static const std::vector<std::pair<std::string, std::pair<const char*, const char*>>> fixed = {
      {"outcome.points", {"Points", "points"}},
      {"outcome.max_points", {"Points possible", "points"}},
      {"outcome.earned_points", {"Points earned before costs", "points"}},
      {"outcome.complete", {"Preparation finished", ""}},
      {"outcome.removed_total_mm3", {"Removed in total", "mm³"}},
      {"outcome.target_mm3", {"Target volume", "mm³"}},
      {"outcome.target_coverage_pct", {"Target removed", "%"}},
      {"outcome.overprep_mm3", {"Removed outside the target (over-preparation)", "mm³"}},
      {"outcome.forbidden_mm3", {"Removed in forbidden regions", "mm³"}},
      {"outcome.pulp_exposed", {"Pulp exposed", ""}},
      {"outcome.perforation", {"Perforation", ""}},
      {"outcome.perforation_mm3", {"Perforation volume", "mm³"}},
      {"process.duration_s", {"Session time", "s"}},
      {"process.drilling_s", {"Drilling time", "s"}},
      {"process.path_mm", {"Bur tip path", "mm"}},
      {"process.excessive_force_s", {"Drilling with excessive force", "s"}},
      {"process.excessive_force_N", {"Excessive force threshold", "N"}},
      {"process.mirror_tracked", {"Mirror use measured", ""}},
      {"process.watchdog_frames", {"Haptic watchdog frames", "frames"}},
  };
  for (const auto& [k, v] : fixed)
    if (name == k) {
      l.label = v.first;
      if (!l.yes_no) l.unit = v.second;
      return l;
    }
  const std::string sect = p.size() >= 2 ? p[1] : "";
  if (p[0] == "outcome" && sect == "removed_mm3" && p.size() == 3) {
    l.label = capital(p[2]) + " removed";
    l.unit = "mm³";
  } else if (p[0] == "outcome" && sect == "criteria" && p.size() == 4) {
    const std::string& c = p[2];
    if (leaf == "score") {
      l.label = capital(c) + ": points";
      l.unit = c.find("taper") != std::string::npos ? "points" : "of 3";  // the wall taper has its exercise's points
    } else if (leaf == "value") {
      if (c.find("taper") != std::string::npos) {
        l.label = capital(c) + ": mean outside the ideal taper";
        l.unit = "deg";
      } else if (c.find("wall") != std::string::npos) {
        l.label = capital(c) + ": divergence toward the occlusal surface";
        l.unit = "deg";
      } else if (c.find("orifice") != std::string::npos) {
        l.label = capital(c) + ": clear sight lines";
        l.unit = "%";
      } else if (c.find("floor") != std::string::npos) {
        l.label = capital(c) + ": removed below the floor";
        l.unit = "mm³";
      } else {
        l.label = capital(c) + ": measured value";
      }
    } else if (leaf == "max_score") {
      l.label = capital(c) + ": points possible";
      l.unit = "points";
    } else {
      l.label = capital(c) + ": " + words(leaf);
    }
  } else if (p[0] == "outcome" && sect == "regions" && p.size() == 4) {
    const std::string r = "Region " + words(p[2]);
    if (leaf == "coverage_pct") l.label = r + ": removed";
    else if (leaf == "overprep_mm3") l.label = r + ": over-preparation nearby";
    else if (leaf == "points") { l.label = r + ": points"; l.unit = "points"; }
    else if (leaf == "max_points") { l.label = r + ": points possible"; l.unit = "points"; }
    else l.label = r + ": " + words(leaf);
  } else if (p[0] == "outcome" && sect == "penalties" && p.size() == 4) {
    l.label = "Cost of " + p[2];
    l.unit = "points";
  } else if (p[0] == "process" && sect == "force_by_material" && p.size() == 4) {
    const std::string m = capital(p[2]);
    if (leaf == "frames") { l.label = m + ": frames removing it"; l.unit = "frames"; }
    else if (leaf == "mean_N") l.label = m + ": mean force while removing it";
    else if (leaf == "max_N") l.label = m + ": largest force while removing it";
    else l.label = m + ": " + words(leaf);
  } else if (p[0] == "process" && sect == "mirror_use") {
    std::string rest;
    for (std::size_t i = 2; i < p.size(); ++i) rest += (rest.empty() ? "" : ", ") + words(p[i]);
    l.label = "Mirror use: " + rest;
    if (p.size() >= 3 && (p[2] == "frames" || ends_with(p[2], "frames") || p[2].rfind("frames", 0) == 0) && l.unit.empty())
      l.unit = "frames";
  } else {
    // Anything else: its path after the section, in words.
    std::string rest;
    for (std::size_t i = 1; i < p.size(); ++i) rest += (rest.empty() ? "" : ", ") + words(p[i]);
    l.label = capital(rest.empty() ? words(name) : rest);
  }
  return l;
}

std::string metric_value_text(const MetricLabel& l, double value, int decimals) {
  if (l.yes_no) return value != 0 ? "yes" : "no";
  char b[64];
  std::snprintf(b, sizeof b, "%.*f", decimals, value);
  return b;
}

}  // namespace dentar::store
