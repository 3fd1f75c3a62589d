// The stylus poses file (CSV) the station steps read instead of a live device: one pose of the
// stylus in the haptic device's frame per row, optionally with the mirror tag's pose.
//   label,tx_mm,ty_mm,tz_mm,rx_deg,ry_deg,rz_deg[,mtag_tx_mm,mtag_ty_mm,mtag_tz_mm,mtag_rx_deg,
//   mtag_ry_deg,mtag_rz_deg]
// The first non-comment line is that header. Each row is T_dev_sty (translation in mm, rotation
// vector in degrees); the optional 6 columns are T_mtag_man from the tracker at that moment
// (mirror rows). Labels: pivot, divot:<i>, landmark:<i>, rim, centre. Lines starting with '#'
// and empty lines are skipped; CRLF line ends are accepted. See docs/formats.md.
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "dentar/core/result.h"

namespace dentar::calibration {

struct StylusPoseRow {
  std::string label;
  Eigen::Isometry3d T_dev_sty = Eigen::Isometry3d::Identity();
  std::optional<Eigen::Isometry3d> T_mtag_man;
  int line = 0;  // 1-based line in the file
};

// Limits a row must respect (a pose file in other units or a corrupted one is refused):
// |translation| <= 10 m, |rotation vector| <= 360 degrees, labels 1..64 printable characters.
inline constexpr double kStylusPoseMaxTranslationMm = 10000.0;
inline constexpr double kStylusPoseMaxRotationDeg = 360.0;

// Parses the text of a poses file; `name` (the path) starts every error message, with the line
// number and the column at fault.
Result<std::vector<StylusPoseRow>> parse_stylus_poses(std::string_view text, const std::string& name);
// Reads and parses a file (at most 64 MiB).
Result<std::vector<StylusPoseRow>> read_stylus_poses(const std::string& path);

// The rows whose label starts with prefix ("pivot", "divot:").
std::vector<StylusPoseRow> stylus_rows_with(const std::vector<StylusPoseRow>& rows,
                                            const std::string& prefix);
// The index of a "divot:3"-style label, which must be in 0..limit-1.
Result<int> stylus_label_index(const StylusPoseRow& row, const std::string& name, std::size_t limit);

}  // namespace dentar::calibration
