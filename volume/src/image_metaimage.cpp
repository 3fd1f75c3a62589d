// MetaImage (ITK/VTK .mhd with detached data, .mha with inline data).
// "Key = Value" lines; ElementDataFile is the last header line. Spacing and
// offset are in mm.
#include <array>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "image_io_internal.h"

namespace dentar::volume {

using detail::file_error;

namespace {

constexpr std::int64_t kMaxSkipBytes = std::int64_t{1} << 40;

struct MetaType {
  std::string_view name;
  ElementType type;
};
constexpr std::array<MetaType, 8> kMetaTypes = {{{"MET_UCHAR", ElementType::kUInt8},
                                                 {"MET_CHAR", ElementType::kInt8},
                                                 {"MET_USHORT", ElementType::kUInt16},
                                                 {"MET_SHORT", ElementType::kInt16},
                                                 {"MET_UINT", ElementType::kUInt32},
                                                 {"MET_INT", ElementType::kInt32},
                                                 {"MET_FLOAT", ElementType::kFloat32},
                                                 {"MET_DOUBLE", ElementType::kFloat64}}};

std::string_view meta_type_name(ElementType t) {
  for (const auto& m : kMetaTypes)
    if (m.type == t) return m.name;
  return "MET_UCHAR";
}

class Parser {
 public:
  explicit Parser(std::string_view name) : name_(name) {}

  Error err(int line, std::string_view problem) const {
    return file_error(name_, "line " + std::to_string(line) + ": " + std::string(problem));
  }

  // Parses n numbers (mm -> m with `scale`) of a field.
  Status numbers(int line, std::string_view key, std::string_view value, int n, double scale,
                 double* out) const {
    const auto parts = detail::split_ws(value);
    if (static_cast<int>(parts.size()) != n)
      return err(line, std::string(key) + " needs " + std::to_string(n) + " numbers, got " +
                           std::to_string(parts.size()));
    for (int a = 0; a < n; ++a) {
      const auto x = detail::parse_double(parts[static_cast<std::size_t>(a)]);
      if (!x)
        return err(line, std::string(key) + ": '" +
                             std::string(parts[static_cast<std::size_t>(a)]) + "' is not a number");
      if (!std::isfinite(*x)) return err(line, std::string(key) + ": values must be finite");
      out[a] = *x * scale;
    }
    return {};
  }

  std::optional<bool> boolean(std::string_view v) const {
    const std::string l = detail::lower(detail::trim(v));
    if (l == "true" || l == "1") return true;
    if (l == "false" || l == "0") return false;
    return std::nullopt;
  }

 private:
  std::string name_;
};

}  // namespace

Result<VolumeHeader> parse_metaimage_header(std::string_view text, std::string_view name,
                                            std::size_t* header_bytes) {
  Parser p(name);
  VolumeHeader h;
  bool have_ndims = false, have_dims = false, have_type = false, have_spacing = false,
       have_size = false;
  Eigen::Vector3d element_size_m(0, 0, 0);
  bool compressed = false;
  std::int64_t header_size = 0;
  std::size_t pos = 0;
  int line_no = 0;
  while (true) {
    if (pos >= text.size())
      return file_error(name,
                        "header ends without an ElementDataFile line (it must be the last "
                        "header line)");
    std::size_t eol = text.find('\n', pos);
    const std::size_t next = eol == std::string_view::npos ? text.size() : eol + 1;
    if (eol == std::string_view::npos) eol = text.size();
    const std::string_view line = detail::trim(text.substr(pos, eol - pos));
    pos = next;
    ++line_no;
    if (line.empty() || line.front() == '#') continue;
    const std::size_t eq = line.find('=');
    if (eq == std::string_view::npos)
      return p.err(line_no,
                   "expected 'Key = Value', got '" + std::string(line.substr(0, 40)) + "'");
    const std::string key = detail::lower(detail::trim(line.substr(0, eq)));
    const std::string_view val = detail::trim(line.substr(eq + 1));

    if (key == "objecttype") {
      if (detail::lower(val) != "image") return p.err(line_no, "ObjectType must be Image");
    } else if (key == "ndims") {
      const auto n = detail::parse_int(val);
      if (!n || *n != 3)
        return p.err(line_no, "NDims = " + std::string(val) + ": only 3-D images are supported");
      have_ndims = true;
    } else if (key == "dimsize") {
      const auto parts = detail::split_ws(val);
      if (parts.size() != 3) return p.err(line_no, "DimSize needs 3 integers");
      for (int a = 0; a < 3; ++a) {
        const auto d = detail::parse_int(parts[static_cast<std::size_t>(a)]);
        if (!d || *d < 1 || *d > kMaxDim)
          return p.err(line_no, "DimSize[" + std::to_string(a) + "] = '" +
                                    std::string(parts[static_cast<std::size_t>(a)]) +
                                    "' must be an integer in [1, " + std::to_string(kMaxDim) + "]");
        h.geometry.dims[a] = static_cast<int>(*d);
      }
      have_dims = true;
    } else if (key == "elementtype") {
      bool found = false;
      for (const auto& m : kMetaTypes) {
        if (val == m.name) {
          h.type = m.type;
          found = true;
        }
      }
      if (!found)
        return p.err(line_no, "unknown or unsupported ElementType '" + std::string(val) +
                                  "' (MET_UCHAR, MET_CHAR, MET_USHORT, MET_SHORT, MET_UINT, "
                                  "MET_INT, MET_FLOAT, MET_DOUBLE)");
      have_type = true;
    } else if (key == "elementspacing") {
      if (auto s = p.numbers(line_no, "ElementSpacing", val, 3, 1e-3, h.geometry.spacing.data());
          !s)
        return Error{s.error()};
      have_spacing = true;
    } else if (key == "elementsize") {
      if (auto s = p.numbers(line_no, "ElementSize", val, 3, 1e-3, element_size_m.data()); !s)
        return Error{s.error()};
      have_size = true;
    } else if (key == "offset" || key == "origin" || key == "position") {
      if (auto s = p.numbers(line_no, "Offset", val, 3, 1e-3, h.geometry.origin.data()); !s)
        return Error{s.error()};
    } else if (key == "transformmatrix" || key == "rotation" || key == "orientation") {
      std::array<double, 9> m{};
      if (auto s = p.numbers(line_no, "TransformMatrix", val, 9, 1.0, m.data()); !s)
        return Error{s.error()};
      for (int r = 0; r < 9; ++r)
        if (std::fabs(m[static_cast<std::size_t>(r)] - (r % 4 == 0 ? 1.0 : 0.0)) > 1e-6)
          return p.err(line_no,
                       "TransformMatrix is not the identity: rotated or flipped volumes "
                       "are not supported (resample to axis-aligned first)");
    } else if (key == "elementnumberofchannels") {
      const auto n = detail::parse_int(val);
      if (!n || *n != 1) return p.err(line_no, "ElementNumberOfChannels must be 1 (scalar images)");
    } else if (key == "binarydata") {
      const auto b = p.boolean(val);
      if (!b || !*b) return p.err(line_no, "BinaryData must be True (ASCII data is not supported)");
    } else if (key == "binarydatabyteordermsb" || key == "byteordermsb") {
      const auto b = p.boolean(val);
      if (!b) return p.err(line_no, std::string(key) + " must be True or False");
      h.big_endian = *b;
    } else if (key == "compresseddata") {
      const auto b = p.boolean(val);
      if (!b) return p.err(line_no, "CompressedData must be True or False");
      compressed = *b;
    } else if (key == "headersize") {
      const auto n = detail::parse_int(val);
      if (!n || *n < -1 || *n > kMaxSkipBytes)
        return p.err(line_no, "HeaderSize must be an integer in [-1, 2^40]");
      header_size = *n;
    } else if (key == "elementdatafile") {
      if (val.empty()) return p.err(line_no, "ElementDataFile is empty");
      const std::string l = detail::lower(val);
      if (l == "local") {
        h.data_file.clear();
      } else if (l == "list" || l.find('%') != std::string::npos ||
                 detail::split_ws(val).size() > 1) {
        return p.err(line_no, "ElementDataFile '" + std::string(val) +
                                  "': file lists and patterns are not supported");
      } else {
        h.data_file = detail::resolve_beside(name, val);
      }
      if (header_bytes) *header_bytes = pos;
      break;  // ElementDataFile ends the header
    }
    // Other keys (Comment, AnatomicalOrientation, CenterOfRotation, ElementMin,
    // CompressedDataSize, ...) carry nothing we need.
  }

  if (!have_ndims) return file_error(name, "missing NDims");
  if (!have_dims) return file_error(name, "missing DimSize");
  if (!have_type) return file_error(name, "missing ElementType");
  if (!have_spacing) {
    // A silent 1 mm default would make a tooth 10 cm wide.
    if (!have_size) return file_error(name, "missing ElementSpacing (voxel spacing in mm)");
    h.geometry.spacing = element_size_m;
  }
  for (int a = 0; a < 3; ++a)
    if (!(h.geometry.spacing[a] > 0))
      return file_error(name, "ElementSpacing must be > 0 (got " +
                                  std::to_string(h.geometry.spacing[a] * 1e3) + " mm)");
  h.gzip = compressed;
  if (header_size == -1) {
    if (compressed) return file_error(name, "HeaderSize = -1 is not allowed with CompressedData");
    h.data_at_end = true;
  } else if (header_size > 0) {
    if (compressed) return file_error(name, "HeaderSize > 0 with CompressedData is not supported");
    h.data_offset = static_cast<std::size_t>(header_size);
  }
  if (auto s = detail::validate_geometry(h.geometry, name); !s) return Error{s.error()};
  return h;
}

Result<ImageVolume> load_metaimage(const std::string& path) {
  return detail::load_with_parser(path, &parse_metaimage_header);
}

Status write_metaimage(const ImageVolume& v, const std::string& path, const WriteOptions& o) {
  const std::string ext = detail::lower(std::filesystem::path(path).extension().string());
  if (ext != ".mha" && ext != ".mhd")
    return file_error(path, "MetaImage files end in .mha (inline data) or .mhd (detached)");
  if (auto s = detail::validate_geometry(v.geometry, path); !s) return s;
  auto payload = detail::encode_payload(v, o.big_endian, o.gzip, path);
  if (!payload) return Error{payload.error()};
  const std::vector<std::uint8_t> data = std::move(payload).value();
  const bool inline_data = ext == ".mha";
  const std::string data_name = detail::stem_of(path) + (o.gzip ? ".zraw" : ".raw");
  const auto& g = v.geometry;
  std::ostringstream os;
  const auto f = detail::format_double;
  os << "ObjectType = Image\nNDims = 3\n";
  os << "BinaryData = True\nBinaryDataByteOrderMSB = " << (o.big_endian ? "True" : "False") << "\n";
  os << "CompressedData = " << (o.gzip ? "True" : "False") << "\n";
  if (o.gzip) os << "CompressedDataSize = " << data.size() << "\n";
  os << "TransformMatrix = 1 0 0 0 1 0 0 0 1\n";
  os << "Offset = " << f(g.origin.x() * 1e3) << " " << f(g.origin.y() * 1e3) << " "
     << f(g.origin.z() * 1e3) << "\n";
  os << "ElementSpacing = " << f(g.spacing.x() * 1e3) << " " << f(g.spacing.y() * 1e3) << " "
     << f(g.spacing.z() * 1e3) << "\n";
  os << "DimSize = " << g.dims.x() << " " << g.dims.y() << " " << g.dims.z() << "\n";
  os << "ElementType = " << meta_type_name(v.source_type) << "\n";
  os << "ElementDataFile = " << (inline_data ? "LOCAL" : data_name) << "\n";
  const std::string head = os.str();
  const std::span<const std::uint8_t> head_bytes(reinterpret_cast<const std::uint8_t*>(head.data()),
                                                 head.size());
  if (inline_data) return detail::write_file_bytes(path, head_bytes, data);
  if (auto s = detail::write_file_bytes(detail::resolve_beside(path, data_name), data); !s)
    return s;
  return detail::write_file_bytes(path, head_bytes);
}

}  // namespace dentar::volume
