// Helpers shared by the volume-image readers and writers (private to volume/).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "dentar/volume/image_volume.h"

namespace dentar::volume::detail {

// "name: problem" — every loader error starts with the file it is about.
Error file_error(std::string_view name, std::string_view problem);

// Text helpers for the line-based headers.
std::string_view trim(std::string_view s);
std::vector<std::string_view> split_ws(std::string_view s);
std::string lower(std::string_view s);
std::optional<std::int64_t> parse_int(std::string_view s);
std::optional<double> parse_double(std::string_view s);  // any double incl. nan/inf
// Shortest text that reads back as the same double ("0.1", not "0.10000000000000001").
std::string format_double(double x);

// A relative data file name resolved against the folder of header_name.
std::string resolve_beside(std::string_view header_name, std::string_view file);
// Header-folder-relative name for a data file written beside `header_path`.
std::string stem_of(const std::string& path);

// Checks dims (1..kMaxDim, <= kMaxVoxels), spacing (finite, > 0) and origin;
// returns an error naming `name` and the header field.
Status validate_geometry(const VolumeGeometry& g, std::string_view name);

// Files. read_file_range() refuses to read past the end (truncated files).
Result<std::uint64_t> file_size(const std::string& path, std::string_view what);
Result<std::vector<std::uint8_t>> read_file_range(const std::string& path, std::uint64_t offset,
                                                  std::uint64_t count);
Status write_file_bytes(const std::string& path, std::span<const std::uint8_t> a,
                        std::span<const std::uint8_t> b = {});

// Inflates a zlib or gzip stream; refuses more than max_out bytes of output
// (gzip bombs) without allocating more than max_out + 64 KiB.
Result<std::vector<std::uint8_t>> inflate_limited(std::span<const std::uint8_t> in,
                                                  std::size_t max_out, std::string_view name);
// gzip-compresses (level 6).
Result<std::vector<std::uint8_t>> gzip_compress(std::span<const std::uint8_t> in,
                                                std::string_view name);

// Values -> element bytes of v.source_type; errors name the first voxel that
// does not fit the type exactly.
Result<std::vector<std::uint8_t>> encode_values(const ImageVolume& v, bool big_endian,
                                                std::string_view name);
// encode_values, then gzip when `gzip` is set: the data part of a file.
Result<std::vector<std::uint8_t>> encode_payload(const ImageVolume& v, bool big_endian, bool gzip,
                                                 std::string_view name);

// Reads header + data of a file whose header is parsed by `parse` (which gets
// at most kMaxHeaderBytes of the file) and decodes it.
using HeaderParser = Result<VolumeHeader> (*)(std::string_view text, std::string_view name,
                                              std::size_t* header_bytes);
Result<ImageVolume> load_with_parser(const std::string& path, HeaderParser parse);

// Element type names accepted in headers (format-specific aliases aside).
std::optional<ElementType> element_type_from_name(std::string_view s);

}  // namespace dentar::volume::detail
