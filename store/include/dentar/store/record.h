// One stored session: who, where, which exercise, the scores, metrics,
// per-step forces and feedback from `dentar score` (score.json), the report
// (score.html) and the path and SHA-256 of the session log and recording.
#pragma once

#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "dentar/core/result.h"

namespace dentar::store {

struct Metric {
  std::string name;  // dotted path in score.json, e.g. "process.path_mm", "criteria.Mesial wall.score"
  double value = 0;
  std::string unit;  // from the name's suffix (mm, mm3, s, N, pct, points) or empty
};

struct FeedbackItem {
  std::string step, kind, text;  // kind: well_done | instruct | ask | caution
};

struct StepScore {
  std::string name;
  double start_s = 0, end_s = 0, drilling_s = 0, path_mm = 0, removed_mm3 = 0;
  std::array<double, 3> force_N{}, force_sd_N{};            // student, tooth axes
  bool has_expert = false;
  std::array<double, 3> expert_force_N{}, expert_sd_N{};    // expert band
};

struct SessionRecord {
  std::string key;             // idempotent key: SHA-256 (hex) of the session log
  std::string student;         // student code ([A-Za-z0-9._@-], 1-64 chars)
  std::string station;         // station code (same alphabet)
  std::string exercise, exercise_title;
  std::string started_utc;     // ISO 8601, UTC ("2026-11-25T14:03:00Z")
  double points = 0, max_points = 0, coverage_pct = 0, overprep_mm3 = 0, forbidden_mm3 = 0, removed_mm3 = 0;
  bool pulp_exposed = false, perforation = false;
  double duration_s = 0, drilling_s = 0, path_mm = 0, excessive_force_s = 0;
  std::vector<Metric> metrics;
  std::vector<FeedbackItem> feedback;
  std::vector<StepScore> steps;
  std::string log_path, log_sha256, log_warning;
  std::int64_t log_bytes = 0;
  std::string recording_path, recording_sha256;  // live recordings only
  std::string report_dir;                        // folder of score.html on the machine that scored it
  std::string score_json, score_html;            // verbatim
  // Filled when read back from a store:
  std::int64_t id = 0;
  std::string stored_utc;
};

// Student/station/exercise codes: 1-64 of [A-Za-z0-9._@-], not starting with
// '.' (they appear in URLs and file names). Empty string = valid.
std::string validate_code(const std::string& what, const std::string& code);

nlohmann::json to_json(const SessionRecord& r);
// Errors name the field.
Result<SessionRecord> record_from_json(const nlohmann::json& j);

struct ImportOptions {
  std::string student;   // required
  std::string station;   // required (dentar commands default to the host name)
  std::string report_dir;  // where score.json/score.html are; empty: the session folder
};

// A scored session folder (session.dlog + score.json [+ score.html] [+
// recording.json, station.json, frames.csv]) or a .dlog whose folder holds
// score.json. Errors name the file and what to do ("run `dentar score DIR`").
Result<SessionRecord> record_from_session_dir(const std::string& path, const ImportOptions& opt);

// SHA-256 of a file as 64 lowercase hex digits (streamed).
Result<std::string> sha256_file(const std::string& path);
std::string sha256_hex(std::string_view bytes);
std::string utc_now_iso();

}  // namespace dentar::store
