#include "dentar/training/kinematics.h"

#include <Eigen/Geometry>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
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

namespace {

// A table cell or map value quoted in a message, cut to a readable length.
std::string cut(const std::string& v, std::size_t n = 40) {
  std::string o;
  for (char c : v) o += (static_cast<unsigned char>(c) < 32 || c == 127) ? '?' : c;
  return o.size() <= n ? o : o.substr(0, n) + "...(" + std::to_string(o.size()) + " chars)";
}

// A column reference: a string or a non-negative integer; anything else (a
// list, an object, a fraction) is an error naming the key.
std::string column_ref(const json& v, const std::string& name, const std::string& key, std::string& out) {
  if (v.is_string()) {
    out = v.get<std::string>();
    if (out.empty()) return name + ": field '" + key + "': an empty column name";
    return {};
  }
  if (v.is_number_integer() || v.is_number_unsigned()) {
    const long long k = v.get<long long>();
    if (k < 1) return name + ": field '" + key + "': column numbers start at 1 (got " + std::to_string(k) + ")";
    out = std::to_string(k);
    return {};
  }
  if (v.is_array())
    return name + ": field '" + key + "': one column is expected (a name or a number), not a list";
  return name + ": field '" + key + "': must be a column name (string) or a 1-based column number, not " +
         cut(v.dump());
}

std::string column_list(const json& j, const char* key, std::size_t n, const std::string& name, const std::string& where,
                        std::vector<std::string>& out) {
  if (!j.contains(key)) return {};
  const std::string k = where + key;
  if (!j[key].is_array() || j[key].size() != n)
    return name + ": field '" + k + "': must be a list of " + std::to_string(n) + " columns (names or numbers)" +
           (j[key].is_array() ? ", got " + std::to_string(j[key].size()) : "");
  for (std::size_t i = 0; i < n; ++i) {
    std::string r;
    if (std::string e = column_ref(j[key][i], name, k + "[" + std::to_string(i) + "]", r); !e.empty()) return e;
    out.push_back(r);
  }
  return {};
}

std::string parse_tool(const json& j, const std::string& name, const std::string& where, bool top, ToolColumns& t) {
  static const std::set<std::string> tool_keys = {"name", "position", "quaternion", "matrix", "axis", "force", "gripper"};
  if (!top)
    for (auto it = j.begin(); it != j.end(); ++it)
      if (!tool_keys.count(it.key()))
        return name + ": unknown key '" + where + cut(it.key()) +
               "' (a tool has name, position, quaternion, matrix, axis, force, gripper)";
  for (auto [k, v, n] : {std::tuple{"position", &t.position, 3u}, std::tuple{"quaternion", &t.quaternion, 4u},
                         std::tuple{"matrix", &t.matrix, 9u}, std::tuple{"axis", &t.axis, 3u},
                         std::tuple{"force", &t.force, 3u}})
    if (std::string e = column_list(j, k, n, name, where, *v); !e.empty()) return e;
  if (j.contains("gripper"))
    if (std::string e = column_ref(j["gripper"], name, where + "gripper", t.gripper); !e.empty()) return e;
  if (t.position.empty()) return name + ": field '" + where + "position': missing (3 columns)";
  if ((!t.quaternion.empty()) + (!t.matrix.empty()) + (!t.axis.empty()) > 1)
    return name + ": " + (where.empty() ? "" : "tool '" + where + "': ") +
           "give one of 'quaternion', 'matrix' or 'axis', not several";
  return {};
}

std::string number_field(const json& j, const char* key, const std::string& name, double& out) {
  if (!j.contains(key)) return {};
  if (j[key].is_array()) return name + ": field '" + key + "': must be a number, not a list";
  if (!j[key].is_number()) return name + ": field '" + key + "': must be a number, not " + cut(j[key].dump());
  out = j[key].get<double>();
  return {};
}

}  // namespace

Result<ColumnMap> parse_column_map(const std::string& text, const std::string& name) {
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return Error{name + ": the column map must be a JSON object"};
  static const std::set<std::string> keys = {"delimiter", "header",     "rate_hz", "decimate", "position_scale", "time",
                                             "pedal",     "position",   "quaternion", "matrix", "axis",         "force",
                                             "gripper",   "tools"};
  for (auto it = j.begin(); it != j.end(); ++it)
    if (!keys.count(it.key()))
      return Error{name + ": unknown key '" + cut(it.key()) +
                   "' (known: delimiter, header, rate_hz, decimate, position_scale, time, pedal, position, quaternion, "
                   "matrix, axis, force, gripper, tools)"};
  ColumnMap m;
  if (j.contains("delimiter")) {
    if (!j["delimiter"].is_string()) return Error{name + ": field 'delimiter': must be a string"};
    m.delimiter = j["delimiter"].get<std::string>();
  }
  if (j.contains("header")) {
    if (!j["header"].is_boolean()) return Error{name + ": field 'header': must be true or false (or left out: detected)"};
    m.header = j["header"].get<bool>() ? 1 : 0;
  }
  double dec = 1;
  for (auto [k, v] : {std::pair{"rate_hz", &m.rate_hz}, std::pair{"decimate", &dec}, std::pair{"position_scale", &m.position_scale}})
    if (std::string e = number_field(j, k, name, *v); !e.empty()) return Error{e};
  if (m.delimiter != "auto" && m.delimiter != "," && m.delimiter != ";" && m.delimiter != "tab" && m.delimiter != "whitespace")
    return Error{name + ": field 'delimiter': must be auto, \",\", \";\", tab or whitespace"};
  if (!(m.rate_hz >= 0 && m.rate_hz < 1e6)) return Error{name + ": field 'rate_hz': must be in [0, 1e6)"};
  if (!(dec >= 1 && dec <= 10000 && dec == std::floor(dec))) return Error{name + ": field 'decimate': must be an integer in [1, 10000]"};
  m.decimate = static_cast<int>(dec);
  if (!(m.position_scale > 0 && std::isfinite(m.position_scale))) return Error{name + ": field 'position_scale': must be > 0"};
  if (j.contains("time"))
    if (std::string e = column_ref(j["time"], name, "time", m.time); !e.empty()) return Error{e};
  if (j.contains("pedal"))
    if (std::string e = column_ref(j["pedal"], name, "pedal", m.pedal); !e.empty()) return Error{e};
  const bool top = j.contains("position") || j.contains("quaternion") || j.contains("matrix") || j.contains("axis") ||
                   j.contains("force") || j.contains("gripper");
  if (j.contains("tools")) {
    if (top) return Error{name + ": give the tool columns either at the top level (one tool) or in 'tools', not both"};
    if (!j["tools"].is_array() || j["tools"].empty() || j["tools"].size() > 16)
      return Error{name + ": field 'tools': must be a list of 1 to 16 tools"};
    std::set<std::string> seen;
    for (std::size_t i = 0; i < j["tools"].size(); ++i) {
      const json& tj = j["tools"][i];
      const std::string where = "tools[" + std::to_string(i) + "].";
      if (!tj.is_object()) return Error{name + ": field 'tools[" + std::to_string(i) + "]': must be an object"};
      ToolColumns t;
      if (!tj.contains("name") || !tj["name"].is_string() || tj["name"].get<std::string>().empty() ||
          tj["name"].get<std::string>().find('.') != std::string::npos)
        return Error{name + ": field '" + where + "name': a tool needs a name (a string without '.')"};
      t.name = tj["name"].get<std::string>();
      if (!seen.insert(t.name).second) return Error{name + ": field '" + where + "name': '" + cut(t.name) + "' is used twice"};
      if (std::string e = parse_tool(tj, name, where, false, t); !e.empty()) return Error{e};
      m.tools.push_back(std::move(t));
    }
  } else {
    ToolColumns t;
    if (std::string e = parse_tool(j, name, "", true, t); !e.empty()) return Error{e};
    m.tools.push_back(std::move(t));
  }
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
  int ln = 0, data_line0 = 0;
  std::size_t ncols = 0;
  std::vector<std::vector<double>> rows;
  bool first = true, detected_no_header = false;
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
      std::size_t numbers = 0;
      double v;
      for (const auto& c : f) numbers += parse_double(c, v);
      const bool all_numbers = numbers == f.size();
      if (map.header == 1 && all_numbers)
        return Error{name + ": line " + std::to_string(ln) + ": the column map says \"header\": true, but this first line "
                     "is all numbers (" + cut(line, 60) + "); set \"header\": false or leave the key out to detect it"};
      if (map.header == 0 && numbers == 0 && !f.empty())
        return Error{name + ": line " + std::to_string(ln) + ": the column map says \"header\": false, but this first "
                     "line has no number (" + cut(line, 60) + "); it looks like a header: set \"header\": true or leave the key out"};
      const bool is_header = map.header == 1 || (map.header == -1 && !all_numbers);
      if (is_header) {
        header = f;
        continue;
      }
      detected_no_header = map.header == -1;
      data_line0 = ln;
    }
    if (f.size() != ncols)
      return Error{name + ": line " + std::to_string(ln) + ": " + std::to_string(f.size()) + " columns, expected " +
                   std::to_string(ncols) + " (a ragged row; every row needs the same columns)"};
    std::vector<double> r(ncols);
    for (std::size_t c = 0; c < ncols; ++c)
      if (!parse_double(f[c], r[c]))
        return Error{name + ": line " + std::to_string(ln) + ", column " + std::to_string(c + 1) +
                     (header.empty() ? "" : " ('" + cut(header[c]) + "')") + ": '" + cut(f[c]) + "' is not a finite number"};
    if (data_line0 == 0) data_line0 = ln;
    rows.push_back(std::move(r));
  }
  if (rows.size() < 2) return Error{name + ": fewer than 2 data rows"};
  auto col = [&](const std::string& r, const std::string& role, std::size_t& out) -> std::string {
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
    if (header.empty())
      return name + ": the " + role + " column '" + cut(r) + "' of the column map is not in the table: the table has no " +
             "header (" + (detected_no_header ? "detected: its first line, line " + std::to_string(data_line0) +
                           ", is all numbers and was kept as data" : "\"header\": false") +
             "), so columns are numbers 1 to " + std::to_string(ncols) +
             "; refer to them by number or add a header line";
    return name + ": line 1: the " + role + " column '" + cut(r) + "' of the column map is not in the table (" +
           std::to_string(ncols) + " columns: " + cut([&] {
             std::string h;
             for (const auto& x : header) h += (h.empty() ? "" : ",") + x;
             return h;
           }(), 80) + ")";
  };
  struct ToolIdx {
    std::vector<std::size_t> pos, rot, frc;
    std::size_t grip = 0;
    bool has_grip = false;
  };
  KinematicsTable t;
  std::vector<ToolIdx> idx(map.tools.size());
  for (std::size_t ti = 0; ti < map.tools.size(); ++ti) {
    const ToolColumns& tc = map.tools[ti];
    ToolIdx& x = idx[ti];
    const std::string who = tc.name.empty() ? "" : "tool '" + tc.name + "' ";
    const std::string pre = tc.name.empty() ? "" : tc.name + ".";
    auto get = [&](const std::vector<std::string>& refs, const std::string& role, std::vector<std::size_t>& out) -> std::string {
      for (const auto& r : refs) {
        std::size_t c;
        if (std::string e = col(r, who + role, c); !e.empty()) return e;
        out.push_back(c);
      }
      return {};
    };
    if (std::string e = get(tc.position, "position", x.pos); !e.empty()) return Error{e};
    const auto& rref = !tc.quaternion.empty() ? tc.quaternion : !tc.matrix.empty() ? tc.matrix : tc.axis;
    const std::string rrole = !tc.quaternion.empty() ? "quaternion" : !tc.matrix.empty() ? "matrix" : "axis";
    if (std::string e = get(rref, rrole, x.rot); !e.empty()) return Error{e};
    if (std::string e = get(tc.force, "force", x.frc); !e.empty()) return Error{e};
    if (!tc.gripper.empty()) {
      if (std::string e = col(tc.gripper, who + "gripper", x.grip); !e.empty()) return Error{e};
      x.has_grip = true;
    }
    for (const char* n : {"pos_x_mm", "pos_y_mm", "pos_z_mm"}) t.feature_names.push_back(pre + n);
    if (!x.rot.empty())
      for (const char* n : {"axis_x", "axis_y", "axis_z"}) t.feature_names.push_back(pre + n);
    if (!x.frc.empty())
      for (const char* n : {"force_x_N", "force_y_N", "force_z_N"}) t.feature_names.push_back(pre + n);
    if (x.has_grip) t.feature_names.push_back(pre + "gripper");
  }
  std::size_t tcol = 0, pcol = 0;
  if (!map.time.empty())
    if (std::string e = col(map.time, "time", tcol); !e.empty()) return Error{e};
  if (!map.pedal.empty()) {
    if (std::string e = col(map.pedal, "pedal", pcol); !e.empty()) return Error{e};
    t.feature_names.push_back("pedal");
  }
  const std::size_t n = (rows.size() + static_cast<std::size_t>(map.decimate) - 1) / static_cast<std::size_t>(map.decimate);
  t.x.resize(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(t.feature_names.size()));
  for (std::size_t i = 0; i < n; ++i) {
    const auto& r = rows[i * static_cast<std::size_t>(map.decimate)];
    const auto ri = static_cast<Eigen::Index>(i);
    Eigen::Index c = 0;
    const std::string where = name + ": data row " + std::to_string(i * static_cast<std::size_t>(map.decimate) + 1);
    for (std::size_t ti = 0; ti < idx.size(); ++ti) {
      const ToolIdx& x = idx[ti];
      const std::string who = map.tools[ti].name.empty() ? "" : " (tool '" + map.tools[ti].name + "')";
      for (int a = 0; a < 3; ++a) t.x(ri, c++) = r[x.pos[static_cast<std::size_t>(a)]] * map.position_scale;
      if (!x.rot.empty()) {
        Eigen::Vector3d axis;
        if (x.rot.size() == 4) {
          Eigen::Quaterniond q(r[x.rot[0]], r[x.rot[1]], r[x.rot[2]], r[x.rot[3]]);
          if (!(q.norm() > 1e-6)) return Error{where + who + ": quaternion of zero length"};
          axis = q.normalized().toRotationMatrix().col(2);
        } else if (x.rot.size() == 9) {
          Eigen::Matrix3d R;
          for (int k = 0; k < 9; ++k) R(k / 3, k % 3) = r[x.rot[static_cast<std::size_t>(k)]];
          if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-2 || std::abs(R.determinant() - 1) > 1e-2)
            return Error{where + who + ": the 9 matrix columns are not a rotation (R^T R != I or det != 1); check the column order (row major)"};
          axis = R.col(2);
        } else {
          axis = Eigen::Vector3d(r[x.rot[0]], r[x.rot[1]], r[x.rot[2]]);
          if (!(axis.norm() > 1e-9)) return Error{where + who + ": the tool axis has zero length"};
          axis.normalize();
        }
        for (int a = 0; a < 3; ++a) t.x(ri, c++) = axis(a);
      }
      for (std::size_t k = 0; k < x.frc.size(); ++k) t.x(ri, c++) = r[x.frc[k]];
      if (x.has_grip) t.x(ri, c++) = r[x.grip];
    }
    if (!map.pedal.empty()) t.x(ri, c++) = r[pcol];
  }
  if (map.rate_hz > 0) {
    t.rate_hz = map.rate_hz / map.decimate;
  } else {
    const double span = rows.back()[tcol] - rows.front()[tcol];
    if (!(std::isfinite(span) && span > 0)) return Error{name + ": the time column '" + cut(map.time) + "' does not increase (or spans more than a double holds)"};
    t.rate_hz = static_cast<double>(rows.size() - 1) / span / map.decimate;
    if (!(t.rate_hz > 0 && std::isfinite(t.rate_hz))) return Error{name + ": the time column '" + cut(map.time) + "' gives no usable rate"};
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
    if (!parse_double(f[ct], tr)) return Error{csv + ": line " + std::to_string(ln) + ", column trial: '" + cut(f[ct]) + "' is not a number"};
    t.trial = static_cast<int>(tr);
    t.source = (std::filesystem::path(csv).parent_path() / f[cf]).string();
    auto k = read_kinematics(t.source, map);
    if (!k) return Error{k.error() + " (listed in " + csv + " line " + std::to_string(ln) + ")"};
    if (names && !out.empty() && *names != k->feature_names)
      return Error{csv + ": line " + std::to_string(ln) + ": " + t.source + " gives other features than the first trial"};
    if (names) *names = k->feature_names;
    t.x = std::move(k->x);
    t.rate_hz = k->rate_hz;
    out.push_back(std::move(t));
  }
  if (out.empty()) return Error{csv + ": no trial listed"};
  return out;
}

}  // namespace dentar::training
