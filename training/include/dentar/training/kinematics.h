// Generic kinematics import: a CSV or whitespace table plus a column map
// (time, tool position, orientation as a quaternion or a rotation matrix,
// force, gripper, pedal) and a table of trials (file, subject, trial,
// label), so assessment runs on surgical-skill kinematics a user brings, at
// its own sampling rate. Formats: docs/formats.md ("Kinematics import").
#pragma once

#include <string>
#include <vector>

#include "dentar/training/assess.h"

namespace dentar::training {

struct ColumnMap {
  std::string delimiter = "auto";  // "auto", ",", ";", "tab", "whitespace"
  bool header = true;              // first line names the columns
  double rate_hz = 0;              // sampling rate; 0: from the time column
  int decimate = 1;                // keep every n-th row
  double position_scale = 1.0;     // table units -> mm
  // Column references: a header name, or a 1-based column number written as a string ("3").
  std::string time;
  std::vector<std::string> position;    // 3
  std::vector<std::string> quaternion;  // 4, order w x y z
  std::vector<std::string> matrix;      // 9, row major
  std::vector<std::string> force;       // 3 (optional)
  std::string gripper, pedal;           // optional
};
Result<ColumnMap> parse_column_map(const std::string& json_text, const std::string& name);
Result<ColumnMap> load_column_map(const std::string& path);

struct KinematicsTable {
  std::vector<std::string> feature_names;
  Sequence x;  // rows: samples; columns: position (mm), tool axis (3), force, gripper, pedal as mapped
  double rate_hz = 0;
};
// Errors name the file, line and column (missing column, ragged row, a value
// that is not a number, a rotation matrix that is not a rotation).
Result<KinematicsTable> read_kinematics(const std::string& path, const ColumnMap& map);
Result<KinematicsTable> parse_kinematics(const std::string& text, const std::string& name, const ColumnMap& map);

// Trials table (CSV with header file,subject,trial,label; file relative to
// the table's folder) -> trials ready for train_model / cross-validation.
Result<std::vector<Trial>> import_trials(const std::string& trials_csv, const ColumnMap& map,
                                         std::vector<std::string>* feature_names);

}  // namespace dentar::training
