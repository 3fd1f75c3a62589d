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

// One tool's columns (an arm, the bur's hand, the mirror's hand). Column
// references: a header name, or a 1-based column number (JSON integer or a
// string of digits).
struct ToolColumns {
  std::string name;                     // feature-name prefix "<name>."; empty only for the top-level form
  std::vector<std::string> position;    // 3 (required)
  std::vector<std::string> quaternion;  // 4, order w x y z
  std::vector<std::string> matrix;      // 9, row major
  std::vector<std::string> axis;        // 3: the tool axis as a vector (normalised on import)
  std::vector<std::string> force;       // 3 (optional)
  std::string gripper;                  // optional
};

struct ColumnMap {
  std::string delimiter = "auto";  // "auto", ",", ";", "tab", "whitespace"
  // First line names the columns: 1 yes, 0 no, -1 not given: detected (a
  // first line with any field that is not a number is a header).
  int header = -1;
  double rate_hz = 0;              // sampling rate; 0: from the time column
  int decimate = 1;                // keep every n-th row
  double position_scale = 1.0;     // table units -> mm
  std::string time, pedal;         // optional (time or rate_hz required)
  // One entry per tool. The top-level form (position, quaternion, matrix,
  // axis, force, gripper at the top of the map) is one tool without a name.
  std::vector<ToolColumns> tools;
};
// Unknown keys, a list where a single column or number is expected, and
// wrong list lengths are errors naming the file and the key.
Result<ColumnMap> parse_column_map(const std::string& json_text, const std::string& name);
Result<ColumnMap> load_column_map(const std::string& path);

struct KinematicsTable {
  std::vector<std::string> feature_names;
  // rows: samples; columns per tool: position (mm), tool axis (3), force (N),
  // gripper as mapped; then pedal. Names "pos_x_mm", ... for the top-level
  // form, "<tool>.pos_x_mm", ... for named tools.
  Sequence x;
  double rate_hz = 0;
};
// Errors name the file, line and column (missing column, ragged row, a value
// that is not a number, a rotation matrix that is not a rotation); quoted
// cells are cut to 40 characters.
Result<KinematicsTable> read_kinematics(const std::string& path, const ColumnMap& map);
Result<KinematicsTable> parse_kinematics(const std::string& text, const std::string& name, const ColumnMap& map);

// Trials table (CSV with header file,subject,trial,label; file relative to
// the table's folder) -> trials ready for train_model / cross-validation.
Result<std::vector<Trial>> import_trials(const std::string& trials_csv, const ColumnMap& map,
                                         std::vector<std::string>* feature_names);

}  // namespace dentar::training
