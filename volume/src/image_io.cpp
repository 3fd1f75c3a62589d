// Shared parts of the volume-image readers/writers: element types, decoding of
// the data stream, bounded gzip inflation, file access, load_volume dispatch.
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cassert>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "image_io_internal.h"

namespace dentar::volume {

std::string_view element_type_name(ElementType t) {
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
      return "float32";
    case ElementType::kFloat64:
      return "float64";
  }
  return "unknown";
}

std::size_t element_size(ElementType t) {
  switch (t) {
    case ElementType::kUInt8:
    case ElementType::kInt8:
      return 1;
    case ElementType::kUInt16:
    case ElementType::kInt16:
      return 2;
    case ElementType::kUInt32:
    case ElementType::kInt32:
    case ElementType::kFloat32:
      return 4;
    case ElementType::kFloat64:
      return 8;
  }
  return 1;
}

namespace detail {

Error file_error(std::string_view name, std::string_view problem) {
  std::string m(name.empty() ? std::string_view("<memory>") : name);
  m += ": ";
  m += problem;
  return Error{std::move(m)};
}

std::string_view trim(std::string_view s) {
  const auto ws = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; };
  while (!s.empty() && ws(s.front())) s.remove_prefix(1);
  while (!s.empty() && ws(s.back())) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split_ws(std::string_view s) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t' || s[i] == '\r')) ++i;
    std::size_t j = i;
    while (j < s.size() && s[j] != ' ' && s[j] != '\t' && s[j] != '\r') ++j;
    if (j > i) out.push_back(s.substr(i, j - i));
    i = j;
  }
  return out;
}

std::string lower(std::string_view s) {
  std::string r(s);
  for (char& c : r)
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  return r;
}

std::optional<std::int64_t> parse_int(std::string_view s) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  std::int64_t v = 0;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || p != s.data() + s.size() || s.empty()) return std::nullopt;
  return v;
}

std::optional<double> parse_double(std::string_view s) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  double v = 0;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  // Out-of-range numbers (1e999) are reported as non-finite by the callers.
  if (ec == std::errc::result_out_of_range && p == s.data() + s.size())
    return std::numeric_limits<double>::infinity();
  if (ec != std::errc() || p != s.data() + s.size() || s.empty()) return std::nullopt;
  return v;
}

std::string format_double(double x) {
  std::array<char, 64> buf{};
  const auto [p, ec] = std::to_chars(buf.data(), buf.data() + buf.size(), x);
  if (ec != std::errc()) return "nan";
  return std::string(buf.data(), p);
}

std::string resolve_beside(std::string_view header_name, std::string_view file) {
  namespace fs = std::filesystem;
  const fs::path f{std::string(file)};
  if (f.is_absolute()) return f.string();
  return (fs::path(std::string(header_name)).parent_path() / f).string();
}

std::string stem_of(const std::string& path) { return std::filesystem::path(path).stem().string(); }

Status validate_geometry(const VolumeGeometry& g, std::string_view name) {
  const std::string why = g.validate();
  if (!why.empty()) return file_error(name, why);
  return {};
}

Result<std::uint64_t> file_size(const std::string& path, std::string_view what) {
  std::error_code ec;
  const auto st = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(st))
    return file_error(path, std::string(what) + " does not exist");
  if (!std::filesystem::is_regular_file(st))
    return file_error(path, std::string(what) + " is not a regular file");
  const auto n = std::filesystem::file_size(path, ec);
  if (ec) return file_error(path, "cannot read the size of the " + std::string(what));
  return static_cast<std::uint64_t>(n);
}

Result<std::vector<std::uint8_t>> read_file_range(const std::string& path, std::uint64_t offset,
                                                  std::uint64_t count) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return file_error(path, "cannot open for reading");
  f.seekg(static_cast<std::streamoff>(offset));
  std::vector<std::uint8_t> buf(count);
  f.read(reinterpret_cast<char*>(buf.data()), static_cast<std::streamsize>(count));
  if (static_cast<std::uint64_t>(f.gcount()) != count) {
    std::ostringstream os;
    os << "truncated: read " << f.gcount() << " of " << count << " bytes at offset " << offset;
    return file_error(path, os.str());
  }
  return buf;
}

Status write_file_bytes(const std::string& path, std::span<const std::uint8_t> a,
                        std::span<const std::uint8_t> b) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  if (!f) return file_error(path, "cannot open for writing");
  f.write(reinterpret_cast<const char*>(a.data()), static_cast<std::streamsize>(a.size()));
  f.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
  f.close();
  if (!f) return file_error(path, "write failed (disk full?)");
  return {};
}

Result<std::vector<std::uint8_t>> inflate_limited(std::span<const std::uint8_t> in,
                                                  std::size_t max_out, std::string_view name) {
  z_stream zs{};
  // 15 + 32: accept both zlib and gzip wrappers (MetaImage writes zlib, NRRD gzip).
  if (inflateInit2(&zs, 15 + 32) != Z_OK) return file_error(name, "zlib initialisation failed");
  struct Guard {
    z_stream* z;
    ~Guard() { inflateEnd(z); }
  } guard{&zs};

  // Grow the output as data actually arrives, so a header that declares a huge
  // volume over a tiny stream costs nothing; one byte past max_out proves a bomb.
  constexpr std::size_t kStep = std::size_t{1} << 16;
  std::vector<std::uint8_t> out;
  std::size_t in_pos = 0, out_len = 0;
  int ret = Z_OK;
  while (true) {
    if (out_len == out.size()) {
      if (out.size() > max_out) break;
      const std::size_t want = std::min<std::size_t>(max_out + 1, std::max(kStep, out.size() * 2));
      out.resize(want);
    }
    if (zs.avail_in == 0 && in_pos < in.size()) {
      const std::size_t n = std::min<std::size_t>(in.size() - in_pos, 1u << 30);
      zs.next_in = const_cast<Bytef*>(in.data() + in_pos);  // zlib's API is not const
      zs.avail_in = static_cast<uInt>(n);
      in_pos += n;
    }
    const std::size_t room = std::min<std::size_t>(out.size() - out_len, 1u << 30);
    zs.next_out = out.data() + out_len;
    zs.avail_out = static_cast<uInt>(room);
    ret = inflate(&zs, Z_NO_FLUSH);
    out_len += room - zs.avail_out;
    if (ret == Z_STREAM_END) break;
    if (ret == Z_NEED_DICT || ret == Z_DATA_ERROR || ret == Z_MEM_ERROR) {
      std::string m = "corrupt gzip data";
      if (zs.msg) m += std::string(" (") + zs.msg + ")";
      std::ostringstream os;
      os << m << " at compressed byte " << (in_pos - zs.avail_in);
      return file_error(name, os.str());
    }
    if (ret == Z_BUF_ERROR && zs.avail_in == 0 && in_pos == in.size() && zs.avail_out > 0)
      return file_error(name, "corrupt gzip data: compressed stream ends early (truncated)");
  }
  if (out_len > max_out) {
    std::ostringstream os;
    os << "gzip data inflates to more than the " << max_out
       << " bytes the header declares (dims do not match the data size; refused)";
    return file_error(name, os.str());
  }
  if (zs.avail_in != 0 || in_pos != in.size()) {
    std::ostringstream os;
    os << (in.size() - in_pos + zs.avail_in) << " trailing bytes after the end of the gzip stream";
    return file_error(name, os.str());
  }
  out.resize(out_len);
  return out;
}

Result<std::vector<std::uint8_t>> gzip_compress(std::span<const std::uint8_t> in,
                                                std::string_view name) {
  z_stream zs{};
  if (deflateInit2(&zs, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK)
    return file_error(name, "zlib initialisation failed");
  std::vector<std::uint8_t> out(deflateBound(&zs, static_cast<uLong>(in.size())) + 64);
  zs.next_in = const_cast<Bytef*>(in.data());  // zlib's API is not const
  zs.avail_in = static_cast<uInt>(in.size());
  zs.next_out = out.data();
  zs.avail_out = static_cast<uInt>(out.size());
  const int ret = deflate(&zs, Z_FINISH);
  const std::size_t n = out.size() - zs.avail_out;
  deflateEnd(&zs);
  if (ret != Z_STREAM_END || in.size() > std::numeric_limits<uInt>::max())
    return file_error(name, "gzip compression failed");
  out.resize(n);
  return out;
}

namespace {

template <typename T>
T load_elem(const std::uint8_t* p, bool swap) {
  std::array<std::uint8_t, sizeof(T)> b;
  std::memcpy(b.data(), p, sizeof(T));
  if (swap) std::reverse(b.begin(), b.end());
  T v;
  std::memcpy(&v, b.data(), sizeof(T));
  return v;
}

template <typename T>
void store_elem(T v, std::uint8_t* p, bool swap) {
  std::array<std::uint8_t, sizeof(T)> b;
  std::memcpy(b.data(), &v, sizeof(T));
  if (swap) std::reverse(b.begin(), b.end());
  std::memcpy(p, b.data(), sizeof(T));
}

// Converts n elements; returns the index of the first non-finite value or n.
template <typename T>
std::size_t convert(const std::uint8_t* src, std::size_t n, bool swap, float* dst) {
  for (std::size_t i = 0; i < n; ++i) {
    const T x = load_elem<T>(src + i * sizeof(T), swap);
    if constexpr (std::is_floating_point_v<T>) {
      // Doubles beyond the float range would silently become inf.
      if (!std::isfinite(x) || std::fabs(static_cast<double>(x)) >
                                   static_cast<double>(std::numeric_limits<float>::max()))
        return i;
    }
    dst[i] = static_cast<float>(x);
  }
  return n;
}

template <typename T>
bool encode_one(float x, std::uint8_t* p, bool swap) {
  if constexpr (std::is_floating_point_v<T>) {
    store_elem<T>(static_cast<T>(x), p, swap);
    return std::isfinite(x);
  } else {
    const double d = x;
    if (!(d >= static_cast<double>(std::numeric_limits<T>::min()) &&
          d <= static_cast<double>(std::numeric_limits<T>::max()) && d == std::floor(d)))
      return false;
    store_elem<T>(static_cast<T>(d), p, swap);
    return true;
  }
}

constexpr bool kHostBig = std::endian::native == std::endian::big;

}  // namespace

Result<std::vector<std::uint8_t>> encode_values(const ImageVolume& v, bool big_endian,
                                                std::string_view name) {
  const auto n = static_cast<std::size_t>(v.geometry.voxel_count());
  if (v.values.size() != n) {
    std::ostringstream os;
    os << "cannot write: " << v.values.size() << " values for dims " << v.geometry.dims.x() << "x"
       << v.geometry.dims.y() << "x" << v.geometry.dims.z();
    return file_error(name, os.str());
  }
  const std::size_t es = element_size(v.source_type);
  const bool swap = big_endian != kHostBig;
  std::vector<std::uint8_t> out(n * es);
  for (std::size_t i = 0; i < n; ++i) {
    std::uint8_t* p = out.data() + i * es;
    const float x = v.values[i];
    bool ok = false;
    switch (v.source_type) {
      case ElementType::kUInt8:
        ok = encode_one<std::uint8_t>(x, p, swap);
        break;
      case ElementType::kInt8:
        ok = encode_one<std::int8_t>(x, p, swap);
        break;
      case ElementType::kUInt16:
        ok = encode_one<std::uint16_t>(x, p, swap);
        break;
      case ElementType::kInt16:
        ok = encode_one<std::int16_t>(x, p, swap);
        break;
      case ElementType::kUInt32:
        ok = encode_one<std::uint32_t>(x, p, swap);
        break;
      case ElementType::kInt32:
        ok = encode_one<std::int32_t>(x, p, swap);
        break;
      case ElementType::kFloat32:
        ok = encode_one<float>(x, p, swap);
        break;
      case ElementType::kFloat64:
        ok = encode_one<double>(x, p, swap);
        break;
    }
    if (!ok) {
      std::ostringstream os;
      os << "cannot write: value " << x << " at voxel index " << i << " is not representable as "
         << element_type_name(v.source_type);
      return file_error(name, os.str());
    }
  }
  return out;
}

Result<std::vector<std::uint8_t>> encode_payload(const ImageVolume& v, bool big_endian, bool gzip,
                                                 std::string_view name) {
  auto raw = encode_values(v, big_endian, name);
  if (!raw || !gzip) return raw;
  return gzip_compress(raw.value(), name);
}

std::optional<ElementType> element_type_from_name(std::string_view s) {
  const std::string l = lower(trim(s));
  for (int t = 0; t < kNumElementTypes; ++t)
    if (l == element_type_name(static_cast<ElementType>(t))) return static_cast<ElementType>(t);
  return std::nullopt;
}

Result<ImageVolume> load_with_parser(const std::string& path, HeaderParser parse) {
  auto size = file_size(path, "header file");
  if (!size) return Error{size.error()};
  const std::uint64_t prefix_len = std::min<std::uint64_t>(*size, kMaxHeaderBytes);
  auto prefix = read_file_range(path, 0, prefix_len);
  if (!prefix) return Error{prefix.error()};
  std::size_t header_bytes = 0;
  auto h = parse(std::string_view(reinterpret_cast<const char*>(prefix->data()), prefix->size()),
                 path, &header_bytes);
  if (!h) return Error{h.error()};

  // Where the data stream lives: after the header, or in its own file.
  std::string src = path;
  std::string label = path;
  std::uint64_t start = header_bytes;
  std::uint64_t avail = *size - std::min<std::uint64_t>(*size, header_bytes);
  if (!h->data_file.empty()) {
    src = h->data_file;
    label = h->data_file + " (data file of " + path + ")";
    auto dsize = file_size(src, "data file named in " + path);
    if (!dsize) return Error{dsize.error()};
    start = 0;
    avail = *dsize;
  }
  // Size checks before reading: for raw data the file must hold exactly what
  // the header declares (or at least that much when the data sits at the end).
  if (!h->gzip) {
    const std::uint64_t need =
        std::uint64_t{h->voxel_bytes()} + (h->data_at_end ? 0 : h->data_offset);
    if (avail < need || (!h->data_at_end && avail > need)) {
      std::ostringstream os;
      const auto& d = h->geometry.dims;
      os << (avail < need ? "truncated data: " : "dims do not match the data size: ") << avail
         << " data bytes, but dims " << d.x() << "x" << d.y() << "x" << d.z() << " of "
         << element_type_name(h->type) << " need " << h->voxel_bytes();
      if (h->data_offset && !h->data_at_end) os << " + " << h->data_offset << " skipped";
      os << " bytes";
      return file_error(label, os.str());
    }
    if (h->data_at_end) {
      start += avail - need;
      avail = need;
    } else {
      // Skip the offset here so only voxel bytes are read.
      start += h->data_offset;
      avail = need - h->data_offset;
      h->data_offset = 0;
    }
    h->data_at_end = false;
  }
  auto bytes = read_file_range(src, start, avail);
  if (!bytes) return Error{bytes.error()};
  return decode_volume_data(*h, *bytes, label);
}

}  // namespace detail

Result<ImageVolume> decode_volume_data(const VolumeHeader& h, std::span<const std::uint8_t> bytes,
                                       std::string_view name) {
  using detail::file_error;
  if (auto s = detail::validate_geometry(h.geometry, name); !s) return Error{s.error()};
  const std::size_t need = h.voxel_bytes();
  std::vector<std::uint8_t> inflated;
  std::span<const std::uint8_t> stream = bytes;
  if (h.gzip) {
    if (h.data_at_end)
      return file_error(name, "a skip of -1 (data at the end) is only allowed for raw data");
    if (h.data_offset > kMaxVoxels * 8)
      return file_error(name, "byte skip " + std::to_string(h.data_offset) + " is too large");
    auto r = detail::inflate_limited(bytes, h.data_offset + need, name);
    if (!r) return Error{r.error()};
    inflated = std::move(r.value());
    stream = inflated;
  }
  std::size_t begin = h.data_offset;
  if (h.data_at_end) {
    if (stream.size() < need)
      begin = need;  // reported as truncated below
    else
      begin = stream.size() - need;
  }
  if (begin > stream.size() || stream.size() - begin != need) {
    std::ostringstream os;
    const auto& d = h.geometry.dims;
    const bool shorter = begin > stream.size() || stream.size() - begin < need;
    os << (shorter ? "truncated data: " : "dims do not match the data size: ")
       << (h.gzip ? "inflated data holds " : "data holds ") << stream.size() << " bytes, but dims "
       << d.x() << "x" << d.y() << "x" << d.z() << " of " << element_type_name(h.type) << " need "
       << need;
    if (h.data_offset) os << " + " << h.data_offset << " skipped";
    os << " bytes";
    return file_error(name, os.str());
  }

  ImageVolume v;
  v.geometry = h.geometry;
  v.source_type = h.type;
  const auto n = static_cast<std::size_t>(h.geometry.voxel_count());
  v.values.resize(n);
  const std::uint8_t* src = stream.data() + begin;
  const bool swap = h.big_endian != detail::kHostBig;
  std::size_t bad = n;
  switch (h.type) {
    case ElementType::kUInt8:
      bad = detail::convert<std::uint8_t>(src, n, swap, v.values.data());
      break;
    case ElementType::kInt8:
      bad = detail::convert<std::int8_t>(src, n, swap, v.values.data());
      break;
    case ElementType::kUInt16:
      bad = detail::convert<std::uint16_t>(src, n, swap, v.values.data());
      break;
    case ElementType::kInt16:
      bad = detail::convert<std::int16_t>(src, n, swap, v.values.data());
      break;
    case ElementType::kUInt32:
      bad = detail::convert<std::uint32_t>(src, n, swap, v.values.data());
      break;
    case ElementType::kInt32:
      bad = detail::convert<std::int32_t>(src, n, swap, v.values.data());
      break;
    case ElementType::kFloat32:
      bad = detail::convert<float>(src, n, swap, v.values.data());
      break;
    case ElementType::kFloat64:
      bad = detail::convert<double>(src, n, swap, v.values.data());
      break;
  }
  if (bad != n) {
    const auto& d = h.geometry.dims;
    const auto i = static_cast<std::int64_t>(bad % static_cast<std::size_t>(d.x()));
    const auto j = static_cast<std::int64_t>((bad / static_cast<std::size_t>(d.x())) %
                                             static_cast<std::size_t>(d.y()));
    const auto k = static_cast<std::int64_t>(
        bad / (static_cast<std::size_t>(d.x()) * static_cast<std::size_t>(d.y())));
    std::ostringstream os;
    os << "non-finite " << element_type_name(h.type)
       << " voxel value (NaN, inf or beyond the float range) at voxel (" << i << "," << j << ","
       << k << "), data byte offset " << begin + bad * element_size(h.type);
    return file_error(name, os.str());
  }
  return v;
}

Result<ImageVolume> load_volume(const std::string& path) {
  const std::string ext = detail::lower(std::filesystem::path(path).extension().string());
  if (ext == ".json") return load_raw_json(path);
  if (ext == ".mhd" || ext == ".mha") return load_metaimage(path);
  if (ext == ".nrrd" || ext == ".nhdr") return load_nrrd(path);
  return detail::file_error(
      path, "unknown volume extension '" + ext + "' (expected .json, .mhd, .mha, .nrrd or .nhdr)");
}

}  // namespace dentar::volume
