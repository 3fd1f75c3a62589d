// Fuzz target: parse_stylus_poses (the stylus poses CSV of `dentar calibrate pivot|register|
// tooth|mirror --poses`) on arbitrary bytes.
//
// Contracts: errors name the file; every row read back is a finite rigid pose within the
// documented limits, with a printable label and increasing line numbers; and what was read,
// written back as CSV at full precision, reads again to the same rows.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>

#include "dentar/calibration/station.h"
#include "dentar/calibration/stylus_poses.h"

namespace {

namespace cal = dentar::calibration;

void append_pose(std::string& out, const Eigen::Isometry3d& T) {
  const Eigen::AngleAxisd aa(T.linear());
  const Eigen::Vector3d w = aa.axis() * aa.angle() * 180.0 / M_PI;
  const Eigen::Vector3d t = T.translation() * 1e3;
  char buf[256];
  std::snprintf(buf, sizeof buf, ",%.17g,%.17g,%.17g,%.17g,%.17g,%.17g", t.x(), t.y(), t.z(), w.x(),
                w.y(), w.z());
  out += buf;
}

bool same_pose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.matrix() - b.matrix()).cwiseAbs().maxCoeff() < 1e-9;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > (1u << 16)) return 0;
  const std::string name = "poses.csv";
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const auto r = cal::parse_stylus_poses(text, name);
  if (!r) {
    if (r.error().rfind(name + ":", 0) != 0) __builtin_trap();  // errors name the file
    return 0;
  }
  std::string back = "label,tx_mm,ty_mm,tz_mm,rx_deg,ry_deg,rz_deg\n";
  int last_line = 0;
  for (const auto& row : *r) {
    if (row.line <= last_line) __builtin_trap();
    last_line = row.line;
    if (row.label.empty() || row.label.size() > 64 || row.label.find(',') != std::string::npos)
      __builtin_trap();
    for (unsigned char ch : row.label)
      if (ch < 0x20 || ch > 0x7e) __builtin_trap();
    if (!cal::check_rigid(row.T_dev_sty, "T_dev_sty").empty()) __builtin_trap();
    if (row.T_mtag_man && !cal::check_rigid(*row.T_mtag_man, "T_mtag_man").empty()) __builtin_trap();
    back += row.label;
    append_pose(back, row.T_dev_sty);
    if (row.T_mtag_man) append_pose(back, *row.T_mtag_man);
    back += "\n";
    // An index label either parses into the range or is refused with the file's name.
    const auto idx = cal::stylus_label_index(row, name, 8);
    if (idx ? (*idx < 0 || *idx >= 8) : idx.error().rfind(name + ":", 0) != 0) __builtin_trap();
  }
  const auto again = cal::parse_stylus_poses(back, name);
  if (!again || again->size() != r->size()) __builtin_trap();
  for (std::size_t i = 0; i < r->size(); ++i) {
    const auto& a = (*r)[i];
    const auto& b = (*again)[i];
    if (a.label != b.label || !same_pose(a.T_dev_sty, b.T_dev_sty) ||
        a.T_mtag_man.has_value() != b.T_mtag_man.has_value() ||
        (a.T_mtag_man && !same_pose(*a.T_mtag_man, *b.T_mtag_man)))
      __builtin_trap();
  }
  return 0;
}
