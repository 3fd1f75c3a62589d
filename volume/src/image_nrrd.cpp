// NRRD (teem) volumes: .nrrd with attached data after a blank line, .nhdr with
// a detached "data file". Encodings raw and gzip; 3-D scalar, axis-aligned.
// Spacings/origin are in "space units" (mm when absent).
#include <array>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "image_io_internal.h"

namespace dentar::volume {

using detail::file_error;

namespace {

constexpr std::int64_t kMaxSkipBytes = std::int64_t{1} << 40;

struct TypeAlias {
  std::string_view name;
  ElementType type;
};
// The NRRD spec's spellings of the types we support.
constexpr std::array<TypeAlias, 30> kTypeAliases = {{
    {"signed char", ElementType::kInt8},
    {"int8", ElementType::kInt8},
    {"int8_t", ElementType::kInt8},
    {"uchar", ElementType::kUInt8},
    {"unsigned char", ElementType::kUInt8},
    {"uint8", ElementType::kUInt8},
    {"uint8_t", ElementType::kUInt8},
    {"short", ElementType::kInt16},
    {"short int", ElementType::kInt16},
    {"signed short", ElementType::kInt16},
    {"signed short int", ElementType::kInt16},
    {"int16", ElementType::kInt16},
    {"int16_t", ElementType::kInt16},
    {"ushort", ElementType::kUInt16},
    {"unsigned short", ElementType::kUInt16},
    {"unsigned short int", ElementType::kUInt16},
    {"uint16", ElementType::kUInt16},
    {"uint16_t", ElementType::kUInt16},
    {"int", ElementType::kInt32},
    {"signed int", ElementType::kInt32},
    {"int32", ElementType::kInt32},
    {"int32_t", ElementType::kInt32},
    {"uint", ElementType::kUInt32},
    {"unsigned int", ElementType::kUInt32},
    {"uint32", ElementType::kUInt32},
    {"uint32_t", ElementType::kUInt32},
    {"float", ElementType::kFloat32},
    {"float32", ElementType::kFloat32},
    {"double", ElementType::kFloat64},
    {"float64", ElementType::kFloat64},
}};

// Fields we accept but do not need.
constexpr std::array<std::string_view, 20> kIgnoredFields = {
    "content",    "kinds",       "labels",       "units",       "centers",
    "centerings", "thicknesses", "axis mins",    "axismins",    "axis maxs",
    "axismaxs",   "min",         "max",          "old min",     "oldmin",
    "old max",    "oldmax",      "sample units", "sampleunits", "measurement frame"};

// Parses "(x,y,z)" into out; false on any syntax error.
bool parse_vector(std::string_view s, double* out) {
  s = detail::trim(s);
  if (s.size() < 2 || s.front() != '(' || s.back() != ')') return false;
  s = s.substr(1, s.size() - 2);
  for (int a = 0; a < 3; ++a) {
    const std::size_t c = s.find(',');
    if ((a < 2) != (c != std::string_view::npos)) return false;
    const auto x = detail::parse_double(a < 2 ? s.substr(0, c) : s);
    if (!x) return false;
    out[a] = *x;
    if (a < 2) s = s.substr(c + 1);
  }
  return true;
}

// Splits a "space directions" value into its three "(..)" groups (or "none").
std::vector<std::string_view> split_groups(std::string_view s) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t')) ++i;
    if (i >= s.size()) break;
    std::size_t j = i;
    if (s[i] == '(') {
      j = s.find(')', i);
      j = j == std::string_view::npos ? s.size() : j + 1;
    } else {
      while (j < s.size() && s[j] != ' ' && s[j] != '\t') ++j;
    }
    out.push_back(s.substr(i, j - i));
    i = j;
  }
  return out;
}

// Metres per unit of a "space units" entry.
std::optional<double> unit_scale(std::string_view u) {
  std::string l = detail::lower(detail::trim(u));
  if (l.size() >= 2 && l.front() == '"' && l.back() == '"') l = l.substr(1, l.size() - 2);
  if (l == "mm" || l == "millimeter" || l == "millimeters" || l.empty()) return 1e-3;
  if (l == "m" || l == "meter" || l == "meters") return 1.0;
  if (l == "cm") return 1e-2;
  if (l == "um" || l == "micron" || l == "microns") return 1e-6;
  return std::nullopt;
}

std::string_view nrrd_type_name(ElementType t) {
  switch (t) {
    case ElementType::kUInt8:
      return "uint8";
    case ElementType::kInt8:
      return "int8";
    case ElementType::kUInt16:
      return "uint16";
    case ElementType::kInt16:
      return "int16";
    case ElementType::kUInt32:
      return "uint32";
    case ElementType::kInt32:
      return "int32";
    case ElementType::kFloat32:
      return "float";
    case ElementType::kFloat64:
      return "double";
  }
  return "uint8";
}

}  // namespace

Result<VolumeHeader> parse_nrrd_header(std::string_view text, std::string_view name,
                                       std::size_t* header_bytes) {
  const auto err = [&](int line, const std::string& problem) {
    return file_error(name, "line " + std::to_string(line) + ": " + problem);
  };
  if (text.size() < 8 || text.substr(0, 7) != "NRRD000" || text[7] < '1' || text[7] > '5')
    return file_error(name, "not a NRRD file: it must start with the magic NRRD0001..NRRD0005");

  VolumeHeader h;
  bool have_type = false, have_dim = false, have_sizes = false, have_endian = false,
       have_spacings = false, have_dirs = false, have_encoding = false;
  Eigen::Vector3d spacing_units(0, 0, 0), origin_units(0, 0, 0);
  double scale = 1e-3;  // metres per space unit
  std::int64_t byte_skip = 0;
  std::size_t pos = text.find('\n');
  pos = pos == std::string_view::npos ? text.size() : pos + 1;
  int line_no = 1;
  bool blank_seen = false;
  while (pos < text.size()) {
    std::size_t eol = text.find('\n', pos);
    const std::size_t next = eol == std::string_view::npos ? text.size() : eol + 1;
    if (eol == std::string_view::npos) eol = text.size();
    std::string_view line = text.substr(pos, eol - pos);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos = next;
    ++line_no;
    if (line.empty()) {
      blank_seen = true;  // end of header; attached data follows
      break;
    }
    if (line.front() == '#') continue;
    if (line.find(":=") != std::string_view::npos) continue;  // key/value pair
    const std::size_t colon = line.find(": ");
    if (colon == std::string_view::npos)
      return err(line_no, "expected 'field: value', got '" + std::string(line.substr(0, 40)) + "'");
    const std::string field = detail::lower(line.substr(0, colon));
    const std::string_view val = detail::trim(line.substr(colon + 2));

    if (field == "type") {
      const std::string l = detail::lower(val);
      bool found = false;
      for (const auto& a : kTypeAliases) {
        if (l == a.name) {
          h.type = a.type;
          found = true;
        }
      }
      if (!found)
        return err(line_no, "unknown or unsupported element type '" + std::string(val) +
                                "' (int8/uint8/int16/uint16/int32/uint32/float/double)");
      have_type = true;
    } else if (field == "dimension") {
      const auto d = detail::parse_int(val);
      if (!d || *d != 3)
        return err(line_no,
                   "dimension " + std::string(val) + ": only 3-D scalar volumes are supported");
      have_dim = true;
    } else if (field == "sizes") {
      const auto parts = detail::split_ws(val);
      if (parts.size() != 3) return err(line_no, "sizes needs 3 integers");
      for (int a = 0; a < 3; ++a) {
        const auto d = detail::parse_int(parts[static_cast<std::size_t>(a)]);
        if (!d || *d < 1 || *d > kMaxDim)
          return err(line_no, "sizes[" + std::to_string(a) + "] = '" +
                                  std::string(parts[static_cast<std::size_t>(a)]) +
                                  "' must be an integer in [1, " + std::to_string(kMaxDim) + "]");
        h.geometry.dims[a] = static_cast<int>(*d);
      }
      have_sizes = true;
    } else if (field == "encoding") {
      const std::string l = detail::lower(val);
      if (l == "raw") {
        h.gzip = false;
      } else if (l == "gzip" || l == "gz") {
        h.gzip = true;
      } else {
        return err(line_no, "encoding '" + std::string(val) + "' is not supported (raw or gzip)");
      }
      have_encoding = true;
    } else if (field == "endian") {
      const std::string l = detail::lower(val);
      if (l != "little" && l != "big") return err(line_no, "endian must be little or big");
      h.big_endian = l == "big";
      have_endian = true;
    } else if (field == "spacings") {
      const auto parts = detail::split_ws(val);
      if (parts.size() != 3) return err(line_no, "spacings needs 3 numbers");
      for (int a = 0; a < 3; ++a) {
        const auto x = detail::parse_double(parts[static_cast<std::size_t>(a)]);
        if (!x || !std::isfinite(*x) || *x <= 0)
          return err(line_no, "spacings[" + std::to_string(a) + "] = '" +
                                  std::string(parts[static_cast<std::size_t>(a)]) +
                                  "' must be a finite number > 0");
        spacing_units[a] = *x;
      }
      have_spacings = true;
    } else if (field == "space directions") {
      const auto groups = split_groups(val);
      if (groups.size() != 3) return err(line_no, "space directions needs 3 vectors '(x,y,z)'");
      for (int a = 0; a < 3; ++a) {
        std::array<double, 3> d{};
        if (!parse_vector(groups[static_cast<std::size_t>(a)], d.data()))
          return err(line_no, "space directions: '" +
                                  std::string(groups[static_cast<std::size_t>(a)]) +
                                  "' is not a vector '(x,y,z)' of 3 numbers");
        for (int b = 0; b < 3; ++b) {
          if (!std::isfinite(d[static_cast<std::size_t>(b)]))
            return err(line_no, "space directions: values must be finite");
          if (b != a && d[static_cast<std::size_t>(b)] != 0.0)
            return err(line_no,
                       "space directions are not axis-aligned: rotated volumes are not "
                       "supported (resample to axis-aligned first)");
        }
        const double s = d[static_cast<std::size_t>(a)];
        if (!(s > 0))
          return err(line_no, "space directions: axis " + std::to_string(a) + " has spacing " +
                                  std::to_string(s) +
                                  " (must be > 0; flipped axes are not supported)");
        spacing_units[a] = s;
      }
      have_dirs = true;
    } else if (field == "space origin") {
      std::array<double, 3> o{};
      if (!parse_vector(val, o.data()))
        return err(line_no, "space origin must be '(x,y,z)' of 3 numbers");
      for (int a = 0; a < 3; ++a) {
        if (!std::isfinite(o[static_cast<std::size_t>(a)]))
          return err(line_no, "space origin must be finite");
        origin_units[a] = o[static_cast<std::size_t>(a)];
      }
    } else if (field == "space" || field == "space dimension") {
      if (field == "space dimension" && detail::parse_int(val) != std::optional<std::int64_t>(3))
        return err(line_no, "space dimension must be 3");
    } else if (field == "space units") {
      std::optional<double> common;
      const auto parts = detail::split_ws(val);
      if (parts.size() != 3) return err(line_no, "space units needs 3 entries");
      for (const auto part : parts) {
        const auto s = unit_scale(part);
        if (!s || (common && *common != *s))
          return err(line_no, "space units '" + std::string(val) +
                                  "': use one of mm, cm, m, um for all axes");
        common = s;
      }
      scale = *common;
    } else if (field == "byte skip" || field == "byteskip") {
      const auto n = detail::parse_int(val);
      if (!n || *n < -1 || *n > kMaxSkipBytes)
        return err(line_no, "byte skip must be an integer in [-1, 2^40]");
      byte_skip = *n;
    } else if (field == "line skip" || field == "lineskip") {
      if (detail::parse_int(val) != std::optional<std::int64_t>(0))
        return err(line_no, "line skip is not supported (use byte skip)");
    } else if (field == "data file" || field == "datafile") {
      const std::string l = detail::lower(val);
      if (val.empty() || l.starts_with("list") || val.find('%') != std::string_view::npos ||
          detail::split_ws(val).size() > 1)
        return err(line_no, "data file '" + std::string(val) +
                                "': file lists and patterns are not supported");
      h.data_file = detail::resolve_beside(name, val);
    } else if (std::find(kIgnoredFields.begin(), kIgnoredFields.end(), field) ==
               kIgnoredFields.end()) {
      return err(line_no, "unknown field '" + field + "'");
    }
  }
  if (header_bytes) *header_bytes = pos;

  if (!have_type) return file_error(name, "missing field 'type'");
  if (!have_dim) return file_error(name, "missing field 'dimension'");
  if (!have_sizes) return file_error(name, "missing field 'sizes'");
  if (!have_encoding) return file_error(name, "missing field 'encoding'");
  if (element_size(h.type) > 1 && !have_endian)
    return file_error(name, "missing field 'endian' (required for multi-byte types)");
  if (have_spacings && have_dirs)
    return file_error(name, "both 'spacings' and 'space directions' given; use one");
  if (!have_spacings && !have_dirs)
    return file_error(name, "missing 'spacings' or 'space directions' (voxel spacing)");
  if (h.data_file.empty() && !blank_seen)
    return file_error(name, "header has no 'data file' and no blank line before attached data");
  h.geometry.spacing = spacing_units * scale;
  h.geometry.origin = origin_units * scale;
  if (byte_skip == -1) {
    if (h.gzip) return file_error(name, "byte skip -1 is only allowed with raw encoding");
    h.data_at_end = true;
  } else {
    h.data_offset = static_cast<std::size_t>(byte_skip);
  }
  if (auto s = detail::validate_geometry(h.geometry, name); !s) return Error{s.error()};
  return h;
}

Result<ImageVolume> load_nrrd(const std::string& path) {
  return detail::load_with_parser(path, &parse_nrrd_header);
}

Status write_nrrd(const ImageVolume& v, const std::string& path, const WriteOptions& o) {
  const std::string ext = detail::lower(std::filesystem::path(path).extension().string());
  if (ext != ".nrrd" && ext != ".nhdr")
    return file_error(path, "NRRD files end in .nrrd (attached data) or .nhdr (detached)");
  if (auto s = detail::validate_geometry(v.geometry, path); !s) return s;
  auto payload = detail::encode_payload(v, o.big_endian, o.gzip, path);
  if (!payload) return Error{payload.error()};
  const std::vector<std::uint8_t> data = std::move(payload).value();
  const bool attached = ext == ".nrrd";
  const std::string data_name = detail::stem_of(path) + (o.gzip ? ".raw.gz" : ".raw");
  const auto& g = v.geometry;
  std::ostringstream os;
  const auto f = detail::format_double;
  os << "NRRD0004\n# written by DentAR\n";
  os << "type: " << nrrd_type_name(v.source_type) << "\n";
  os << "dimension: 3\nspace: 3D-right-handed\n";
  os << "sizes: " << g.dims.x() << " " << g.dims.y() << " " << g.dims.z() << "\n";
  const Eigen::Vector3d s = g.spacing * 1e3, org = g.origin * 1e3;
  os << "space directions: (" << f(s.x()) << ",0,0) (0," << f(s.y()) << ",0) (0,0," << f(s.z())
     << ")\n";
  os << "space origin: (" << f(org.x()) << "," << f(org.y()) << "," << f(org.z()) << ")\n";
  os << "space units: \"mm\" \"mm\" \"mm\"\n";
  os << "kinds: domain domain domain\n";
  if (element_size(v.source_type) > 1)
    os << "endian: " << (o.big_endian ? "big" : "little") << "\n";
  os << "encoding: " << (o.gzip ? "gzip" : "raw") << "\n";
  if (!attached) os << "data file: " << data_name << "\n";
  os << "\n";
  const std::string head = os.str();
  const std::span<const std::uint8_t> head_bytes(reinterpret_cast<const std::uint8_t*>(head.data()),
                                                 head.size());
  if (attached) return detail::write_file_bytes(path, head_bytes, data);
  if (auto st = detail::write_file_bytes(detail::resolve_beside(path, data_name), data); !st)
    return st;
  return detail::write_file_bytes(path, head_bytes);
}

}  // namespace dentar::volume
