#include "dentar/training/kinematics.h"

#include <Eigen/Geometry>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

namespace dentar::training {
namespace {

using nlohmann::json;

std::string read_all(const std::string& path, bool& ok) {
  std::ifstream f(path, std::ios::binary);
  ok = static_cast<bool>(f);
  std::ostringstream ss;
  if (ok) ss << f.rdbuf();
  return ss.str();
}

std::vector<std::string> split(const std::string& line, char delim) {
  std::vector<std::string> out;
  if (delim == ' ') {
    std::istringstream is(line);
    for (std::string w; is >> w;) out.push_back(w);
    return out;
  }
  std::string cur;
  for (char c : line) {
    if (c == delim) {
      out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  out.push_back(cur);
  for (auto& s : out) {  // trim
    const auto a = s.find_first_not_of(" \t\"");
    const auto b = s.find_last_not_of(" \t\"");
    s = a == std::string::npos ? "" : s.substr(a, b - a + 1);
  }
  return out;
}

bool parse_double(const std::string& s, double& v) {
  const char* b = s.data();
  const char* e = s.data() + s.size();
  auto r = std::from_chars(b, e, v);
  return r.ec == std::errc() && r.ptr == e && std::isfinite(v);
}

}  // namespace

Result<ColumnMap> parse_column_map(const std::string& text, const std::string& name) {
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return Error{name + ": the column map must be a JSON object"};
  ColumnMap m;
  auto ref = [&](const json& v) -> std::string {
    if (v.is_string()) return v.get<std::string>();
    if (v.is_number_integer()) return std::to_string(v.get<long long>());
    return {};
  };
  auto list = [&](const char* key, std::vector<std::string>& out, std::size_t n) -> std::string {
    if (!j.contains(key)) return {};
    if (!j[key].is_array() || j[key].size() != n)
      return name + ": field '" + key + "': must be an array of " + std::to_string(n) + " column names or numbers";
    for (const auto& v : j[key]) {
      const std::string r = ref(v);
      if (r.empty()) return name + ": field '" + key + "': entries must be column names or numbers";
      out.push_back(r);
    }
    return {};
  };
  try {
    m.delimiter = j.value("delimiter", "auto");
    m.header = j.value("header", true);
    m.rate_hz = j.value("rate_hz", 0.0);
    m.decimate = j.value("decimate", 1);
    m.position_scale = j.value("position_scale", 1.0);
  } catch (const json::exception& e) {
    return Error{name + ": " + e.what()};
  }
  if (m.delimiter != "auto" && m.delimiter != "," && m.delimiter != ";" && m.delimiter != "tab" && m.delimiter != "whitespace")
    return Error{name + ": field 'delimiter': must be auto, \",\", \";\", tab or whitespace"};
  if (!(m.rate_hz >= 0 && m.rate_hz < 1e6)) return Error{name + ": field 'rate_hz': must be in [0, 1e6)"};
  if (m.decimate < 1 || m.decimate > 10000) return Error{name + ": field 'decimate': must be in [1, 10000]"};
  if (!(m.position_scale > 0)) return Error{name + ": field 'position_scale': must be > 0"};
  if (j.contains("time")) m.time = ref(j["time"]);
  if (j.contains("gripper")) m.gripper = ref(j["gripper"]);
  if (j.contains("pedal")) m.pedal = ref(j["pedal"]);
  for (auto [k, v, n] : {std::tuple{"position", &m.position, 3u}, std::tuple{"quaternion", &m.quaternion, 4u},
                         std::tuple{"matrix", &m.matrix, 9u}, std::tuple{"force", &m.force, 3u}})
    if (std::string e = list(k, *v, n); !e.empty()) return Error{e};
  if (m.position.empty()) return Error{name + ": field 'position': missing (3 columns)"};
  if (!m.quaternion.empty() && !m.matrix.empty())
    return Error{name + ": give either 'quaternion' or 'matrix', not both"};
  if (m.rate_hz == 0 && m.time.empty()) return Error{name + ": give 'rate_hz' or a 'time' column"};
  return m;
}

Result<ColumnMap> load_column_map(const std::string& path) {
  bool ok;
  const std::string t = read_all(path, ok);
  if (!ok) return Error{path + ": cannot open the column map"};
  return parse_column_map(t, path);
}

Result<KinematicsTable> parse_kinematics(const std::string& text, const std::string& name, const ColumnMap& map) {
  std::istringstream is(text);
  std::string line;
  std::vector<std::string> header;
  char delim = ',';
  if (map.delimiter == ";") delim = ';';
  else if (map.delimiter == "tab") delim = '\t';
  else if (map.delimiter == "whitespace") delim = ' ';
  int ln = 0;
  std::size_t ncols = 0;
  std::vector<std::vector<double>> rows;
  bool first = true;
  while (std::getline(is, line)) {
    ++ln;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos || line[line.find_first_not_of(" \t")] == '#') continue;
    if (first && map.delimiter == "auto")
      delim = line.find(',') != std::string::npos ? ',' : line.find(';') != std::string::npos ? ';'
              : line.find('\t') != std::string::npos && line.find(' ') == std::string::npos ? '\t' : ' ';
    std::vector<std::string> f = split(line, delim);
    if (first) {
      first = false;
      ncols = f.size();
      if (map.header) {
        header = f;
        continue;
      }
    }
    if (f.size() != ncols)
      return Error{name + ": line " + std::to_string(ln) + ": " + std::to_string(f.size()) + " columns, expected " +
                   std::to_string(ncols) + " (a ragged row; every row needs the same columns)"};
    std::vector<double> r(ncols);
    for (std::size_t c = 0; c < ncols; ++c)
      if (!parse_double(f[c], r[c]))
        return Error{name + ": line " + std::to_string(ln) + ", column " + std::to_string(c + 1) +
                     (header.empty() ? "" : " ('" + header[c] + "')") + ": '" + f[c] + "' is not a finite number"};
    rows.push_back(std::move(r));
  }
  if (rows.size() < 2) return Error{name + ": fewer than 2 data rows"};
  auto col = [&](const std::string& r, const char* role, std::size_t& out) -> std::string {
    for (std::size_t c = 0; c < header.size(); ++c)
      if (header[c] == r) {
        out = c;
        return {};
      }
    std::size_t k = 0;
    auto res = std::from_chars(r.data(), r.data() + r.size(), k);
    if (res.ec == std::errc() && res.ptr == r.data() + r.size() && k >= 1 && k <= ncols) {
      out = k - 1;
      return {};
    }
    return name + ": line 1: the " + role + " column '" + r + "' of the column map is not in the table (" +
           std::to_string(ncols) + " columns" + (header.empty() ? ", no header" : "") + ")";
  };
  KinematicsTable t;
  std::vector<std::size_t> pos(3), rot, frc, extra;
  for (int i = 0; i < 3; ++i)
    if (std::string e = col(map.position[static_cast<std::size_t>(i)], "position", pos[static_cast<std::size_t>(i)]); !e.empty()) return Error{e};
  for (const auto& r : map.quaternion.empty() ? map.matrix : map.quaternion) {
    std::size_t c;
    if (std::string e = col(r, map.quaternion.empty() ? "matrix" : "quaternion", c); !e.empty()) return Error{e};
    rot.push_back(c);
  }
  for (const auto& r : map.force) {
    std::size_t c;
    if (std::string e = col(r, "force", c); !e.empty()) return Error{e};
    frc.push_back(c);
  }
  std::size_t tcol = 0, gcol = 0, pcol = 0;
  if (!map.time.empty())
    if (std::string e = col(map.time, "time", tcol); !e.empty()) return Error{e};
  if (!map.gripper.empty())
    if (std::string e = col(map.gripper, "gripper", gcol); !e.empty()) return Error{e};
  if (!map.pedal.empty())
    if (std::string e = col(map.pedal, "pedal", pcol); !e.empty()) return Error{e};
  t.feature_names = {"pos_x_mm", "pos_y_mm", "pos_z_mm"};
  if (!rot.empty()) t.feature_names.insert(t.feature_names.end(), {"axis_x", "axis_y", "axis_z"});
  if (!frc.empty()) t.feature_names.insert(t.feature_names.end(), {"force_x_N", "force_y_N", "force_z_N"});
  if (!map.gripper.empty()) t.feature_names.push_back("gripper");
  if (!map.pedal.empty()) t.feature_names.push_back("pedal");
  const std::size_t n = (rows.size() + static_cast<std::size_t>(map.decimate) - 1) / static_cast<std::size_t>(map.decimate);
  t.x.resize(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(t.feature_names.size()));
  for (std::size_t i = 0; i < n; ++i) {
    const auto& r = rows[i * static_cast<std::size_t>(map.decimate)];
    const auto ri = static_cast<Eigen::Index>(i);
    Eigen::Index c = 0;
    for (int a = 0; a < 3; ++a) t.x(ri, c++) = r[pos[static_cast<std::size_t>(a)]] * map.position_scale;
    if (!rot.empty()) {
      Eigen::Vector3d axis;
      // Table line of this row, for messages (header + skipped lines are approximate: report the data row).
      const std::string where = name + ": data row " + std::to_string(i * static_cast<std::size_t>(map.decimate) + 1);
      if (rot.size() == 4) {
        Eigen::Quaterniond q(r[rot[0]], r[rot[1]], r[rot[2]], r[rot[3]]);
        if (!(q.norm() > 1e-6)) return Error{where + ": quaternion of zero length"};
        axis = q.normalized().toRotationMatrix().col(2);
      } else {
        Eigen::Matrix3d R;
        for (int k = 0; k < 9; ++k) R(k / 3, k % 3) = r[rot[static_cast<std::size_t>(k)]];
        if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-2 || std::abs(R.determinant() - 1) > 1e-2)
          return Error{where + ": the 9 matrix columns are not a rotation (R^T R != I or det != 1); check the column order (row major)"};
        axis = R.col(2);
      }
      for (int a = 0; a < 3; ++a) t.x(ri, c++) = axis(a);
    }
    for (std::size_t k = 0; k < frc.size(); ++k) t.x(ri, c++) = r[frc[k]];
    if (!map.gripper.empty()) t.x(ri, c++) = r[gcol];
    if (!map.pedal.empty()) t.x(ri, c++) = r[pcol];
  }
  if (map.rate_hz > 0) {
    t.rate_hz = map.rate_hz / map.decimate;
  } else {
    const double span = rows.back()[tcol] - rows.front()[tcol];
    if (!(std::isfinite(span) && span > 0)) return Error{name + ": the time column '" + map.time + "' does not increase (or spans more than a double holds)"};
    t.rate_hz = static_cast<double>(rows.size() - 1) / span / map.decimate;
  }
  return t;
}

Result<KinematicsTable> read_kinematics(const std::string& path, const ColumnMap& map) {
  bool ok;
  const std::string t = read_all(path, ok);
  if (!ok) return Error{path + ": cannot open the kinematics table"};
  return parse_kinematics(t, path, map);
}

Result<std::vector<Trial>> import_trials(const std::string& csv, const ColumnMap& map, std::vector<std::string>* names) {
  bool ok;
  const std::string text = read_all(csv, ok);
  if (!ok) return Error{csv + ": cannot open the trials table"};
  std::istringstream is(text);
  std::string line;
  int ln = 0;
  std::vector<Trial> out;
  std::size_t cf = 0, cs = 1, ct = 2, cl = 3;
  while (std::getline(is, line)) {
    ++ln;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    const auto f = split(line, line.find(',') != std::string::npos ? ',' : ' ');
    if (ln == 1) {
      std::size_t found = 0;
      for (std::size_t c = 0; c < f.size(); ++c) {
        if (f[c] == "file") { cf = c; ++found; }
        if (f[c] == "subject") { cs = c; ++found; }
        if (f[c] == "trial") { ct = c; ++found; }
        if (f[c] == "label") { cl = c; ++found; }
      }
      if (found != 4) return Error{csv + ": line 1: the header must name the columns file, subject, trial, label"};
      continue;
    }
    if (f.size() <= std::max({cf, cs, ct, cl}))
      return Error{csv + ": line " + std::to_string(ln) + ": " + std::to_string(f.size()) + " columns, expected 4"};
    Trial t;
    t.subject = f[cs];
    t.label = f[cl];
    double tr;
    if (!parse_double(f[ct], tr)) return Error{csv + ": line " + std::to_string(ln) + ", column trial: '" + f[ct] + "' is not a number"};
    t.trial = static_cast<int>(tr);
    t.source = (std::filesystem::path(csv).parent_path() / f[cf]).string();
    auto k = read_kinematics(t.source, map);
    if (!k) return Error{k.error() + " (listed in " + csv + " line " + std::to_string(ln) + ")"};
    if (names) *names = k->feature_names;
    t.x = std::move(k->x);
    out.push_back(std::move(t));
  }
  if (out.empty()) return Error{csv + ": no trial listed"};
  return out;
}

}  // namespace dentar::training
