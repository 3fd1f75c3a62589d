#include "dentar/calibration/stylus_poses.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <sstream>

namespace dentar::calibration {
namespace {

constexpr double kDeg = M_PI / 180.0;

Eigen::Isometry3d pose_from(const double* v) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d r(v[3], v[4], v[5]);
  if (r.norm() > 0) T.linear() = Eigen::AngleAxisd(r.norm() * kDeg, r.normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(v[0], v[1], v[2]) * 1e-3;
  return T;
}

// A whole field as a finite double (leading/trailing spaces allowed, nothing else).
bool parse_number(const std::string& f, double& out) {
  std::size_t a = 0, b = f.size();
  while (a < b && (f[a] == ' ' || f[a] == '\t')) ++a;
  while (b > a && (f[b - 1] == ' ' || f[b - 1] == '\t')) --b;
  if (a == b) return false;
  const std::string t = f.substr(a, b - a);
  char* end = nullptr;
  errno = 0;
  out = std::strtod(t.c_str(), &end);
  return end == t.c_str() + t.size() && errno != ERANGE && std::isfinite(out);
}

std::string at(const std::string& name, int line) { return name + ":" + std::to_string(line) + ": "; }

const char* kColumnNames[12] = {"tx_mm",      "ty_mm",      "tz_mm",      "rx_deg",
                                "ry_deg",     "rz_deg",     "mtag_tx_mm", "mtag_ty_mm",
                                "mtag_tz_mm", "mtag_rx_deg", "mtag_ry_deg", "mtag_rz_deg"};

}  // namespace

Result<std::vector<StylusPoseRow>> parse_stylus_poses(std::string_view text, const std::string& name) {
  std::vector<StylusPoseRow> rows;
  bool header = false;
  int n = 0;
  std::size_t pos = 0;
  while (pos < text.size()) {
    std::size_t eol = text.find('\n', pos);
    if (eol == std::string_view::npos) eol = text.size();
    std::string line(text.substr(pos, eol - pos));
    pos = eol + 1;
    ++n;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    if (line.find('\0') != std::string::npos)
      return Error{at(name, n) + "contains a NUL byte: this is not a text CSV file"};
    std::vector<std::string> f;
    std::size_t a = 0;
    for (;;) {
      const std::size_t c = line.find(',', a);
      f.push_back(line.substr(a, c == std::string::npos ? std::string::npos : c - a));
      if (c == std::string::npos) break;
      a = c + 1;
      if (f.size() > 13) break;  // too many columns: reported below
    }
    if (!header) {
      if (f[0] != "label")
        return Error{at(name, n) +
                     "the first line must be the header label,tx_mm,ty_mm,tz_mm,rx_deg,ry_deg,"
                     "rz_deg[,mtag_tx_mm,...] (see docs/formats.md)"};
      header = true;
      continue;
    }
    if (f.size() != 7 && f.size() != 13)
      return Error{at(name, n) + "expected 7 or 13 columns, found " +
                   (f.size() > 13 ? std::string("more than 13") : std::to_string(f.size()))};
    StylusPoseRow r;
    r.label = f[0];
    r.line = n;
    if (r.label.empty() || r.label.size() > 64)
      return Error{at(name, n) + "the label (column 1) must have 1..64 characters"};
    for (unsigned char ch : r.label)
      if (ch < 0x20 || ch > 0x7e)
        return Error{at(name, n) + "the label (column 1) has a non-printable character"};
    double v[12];
    for (std::size_t i = 1; i < f.size(); ++i)
      if (!parse_number(f[i], v[i - 1]))
        return Error{at(name, n) + "column " + std::to_string(i + 1) + " (" + kColumnNames[i - 1] +
                     ") \"" + f[i].substr(0, 40) + "\" is not a finite number"};
    for (std::size_t p = 0; p + 6 <= f.size() - 1; p += 6) {
      const Eigen::Vector3d t(v[p], v[p + 1], v[p + 2]), w(v[p + 3], v[p + 4], v[p + 5]);
      if (t.norm() > kStylusPoseMaxTranslationMm)
        return Error{at(name, n) + "translation " + kColumnNames[p] + ".." + kColumnNames[p + 2] +
                     " is over 10 m: the columns are millimetres"};
      if (w.norm() > kStylusPoseMaxRotationDeg)
        return Error{at(name, n) + "rotation vector " + kColumnNames[p + 3] + ".." +
                     kColumnNames[p + 5] + " is over 360 degrees: the columns are degrees"};
    }
    r.T_dev_sty = pose_from(v);
    if (f.size() == 13) r.T_mtag_man = pose_from(v + 6);
    rows.push_back(std::move(r));
  }
  if (!header) return Error{name + ": empty poses file (no header line)"};
  return rows;
}

Result<std::vector<StylusPoseRow>> read_stylus_poses(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Error{path + ": cannot open the poses file"};
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size > (64 << 20)) return Error{path + ": larger than 64 MiB; not a poses file"};
  in.seekg(0);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return parse_stylus_poses(text, path);
}

std::vector<StylusPoseRow> stylus_rows_with(const std::vector<StylusPoseRow>& rows,
                                            const std::string& prefix) {
  std::vector<StylusPoseRow> out;
  for (const auto& r : rows)
    if (r.label.rfind(prefix, 0) == 0) out.push_back(r);
  return out;
}

Result<int> stylus_label_index(const StylusPoseRow& r, const std::string& name, std::size_t limit) {
  const auto colon = r.label.find(':');
  const std::string digits = colon == std::string::npos ? std::string() : r.label.substr(colon + 1);
  bool ok = !digits.empty() && digits.size() <= 6 && limit > 0;
  for (char ch : digits) ok = ok && ch >= '0' && ch <= '9';
  const long i = ok ? std::strtol(digits.c_str(), nullptr, 10) : -1;
  if (!ok || i < 0 || static_cast<std::size_t>(i) >= limit)
    return Error{at(name, r.line) + "label \"" + r.label + "\" needs an index 0.." +
                 (limit > 0 ? std::to_string(limit - 1) : std::string("(none available)"))};
  return static_cast<int>(i);
}

}  // namespace dentar::calibration
