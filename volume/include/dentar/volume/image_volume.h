// Scalar CT/MR images and their loaders. An ImageVolume is what a file holds;
// segment_ct() turns it into a VoxelVolume of materials.
//
// Every loader returns an Error naming the file and the problem (truncated
// data, dims that do not match the size, dims over kMaxDim/kMaxVoxels, an
// unknown element type, NaN/zero/negative spacing, non-finite voxel values,
// corrupt gzip, a missing data file). They never crash, never return a
// partially filled volume, and check every size against the header and the
// file before allocating voxel memory (a gzip stream is inflated only up to
// the declared size). File formats and limits: docs/formats.md.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "dentar/volume/result.h"
#include "dentar/volume/voxel_volume.h"

namespace dentar::volume {

enum class ElementType : std::uint8_t {
  kUInt8,
  kInt8,
  kUInt16,
  kInt16,
  kUInt32,
  kInt32,
  kFloat32,
  kFloat64
};
inline constexpr int kNumElementTypes = 8;
std::string_view element_type_name(ElementType t);  // "uint8", "int16", "float32", ...
std::size_t element_size(ElementType t);            // bytes

struct ImageVolume {
  VolumeGeometry geometry;                        // dims, spacing (m), origin (m)
  ElementType source_type = ElementType::kUInt8;  // element type in the file (writers use it)
  std::vector<float> values;                      // x fastest, size = dims.prod(); all finite

  std::size_t index(int i, int j, int k) const {
    return static_cast<std::size_t>(i) +
           static_cast<std::size_t>(geometry.dims.x()) *
               (static_cast<std::size_t>(j) +
                static_cast<std::size_t>(geometry.dims.y()) * static_cast<std::size_t>(k));
  }
  float at(int i, int j, int k) const { return values[index(i, j, k)]; }
};

// Largest header we parse (bytes). Longer headers are refused, so a loader
// reads at most this much before it knows the data size.
inline constexpr std::size_t kMaxHeaderBytes = std::size_t{1} << 20;

// Parsed header of any of the three formats, before the data is read.
struct VolumeHeader {
  VolumeGeometry geometry;
  ElementType type = ElementType::kUInt8;
  bool big_endian = false;
  // Data is zlib/gzip compressed (NRRD "encoding: gzip", MetaImage
  // "CompressedData = True"); inflated up to the declared size only.
  bool gzip = false;
  // Detached data path (resolved against the header's folder); empty = inline,
  // i.e. the data follows the header in the same file.
  std::string data_file;
  // Bytes to skip in the decoded data stream before the voxels (raw
  // "header_bytes", MetaImage "HeaderSize", NRRD "byte skip").
  std::size_t data_offset = 0;
  // The voxels are the last bytes of the stream (MetaImage "HeaderSize = -1",
  // NRRD "byte skip: -1"; raw encoding only). Otherwise the stream must hold
  // exactly data_offset + voxel bytes.
  bool data_at_end = false;

  std::size_t voxel_bytes() const {
    return static_cast<std::size_t>(geometry.voxel_count()) * element_size(type);
  }
};

// Loads by extension: .json (raw + JSON sidecar), .mhd/.mha (MetaImage),
// .nrrd/.nhdr (NRRD, raw or gzip encoding).
Result<ImageVolume> load_volume(const std::string& path);
Result<ImageVolume> load_raw_json(const std::string& json_path);
Result<ImageVolume> load_metaimage(const std::string& path);
Result<ImageVolume> load_nrrd(const std::string& path);

// In-memory parsers (used by the loaders and the fuzz targets). `name` is the
// header's path: it is used in error messages and its folder resolves relative
// data file names. No file is opened. For formats with inline data,
// *header_bytes receives the offset of the first data byte in `text`.
Result<VolumeHeader> parse_raw_json_header(std::string_view text, std::string_view name);
Result<VolumeHeader> parse_metaimage_header(std::string_view text, std::string_view name,
                                            std::size_t* header_bytes = nullptr);
Result<VolumeHeader> parse_nrrd_header(std::string_view text, std::string_view name,
                                       std::size_t* header_bytes = nullptr);
// Decodes a data stream as stored (starting at the first data byte: gzip is
// inflated here, then data_offset / data_at_end applied) into values; checks the
// exact size and that every value is finite as float.
Result<ImageVolume> decode_volume_data(const VolumeHeader& h, std::span<const std::uint8_t> bytes,
                                       std::string_view name);

// Writers (for tests, tools and exchange). Spacing/origin are written in mm,
// elements as v.source_type; a value not exactly representable in that type
// (fraction, out of range) is an error, nothing is half-written on such errors.
struct WriteOptions {
  bool big_endian = false;
  bool gzip = false;  // MetaImage and NRRD only
};
// Writes json_path and the data beside it, named <stem>.raw.
Status write_raw_json(const ImageVolume& v, const std::string& json_path,
                      const WriteOptions& o = {});
// .mha: inline data (ElementDataFile = LOCAL); .mhd: detached <stem>.raw (or <stem>.zraw).
Status write_metaimage(const ImageVolume& v, const std::string& path, const WriteOptions& o = {});
// .nrrd: attached data; .nhdr: detached <stem>.raw (or <stem>.raw.gz).
Status write_nrrd(const ImageVolume& v, const std::string& path, const WriteOptions& o = {});

// CT -> materials by thresholds on the intensity (same units as values).
struct Thresholds {
  // intensity <  dark_max                       : dark (pulp if inside the tooth, else air)
  // dark_max <= intensity < tooth_min           : background / mount -> air, or pulp when
  //                                               enclosed by tooth (partial volume at the
  //                                               pulp wall, see segment_ct)
  // tooth_min <= intensity < enamel_min         : dentin
  // intensity >= enamel_min                     : enamel
  float dark_max = 0, tooth_min = 0, enamel_min = 0;
  // Background level: maps to density 0 (tooth_min maps to kIsoDensity).
  float background = 0;
  std::string validate()
      const;  // finite, background < tooth_min, dark_max <= tooth_min < enamel_min
};

// Multi-level Otsu on a 256-bin histogram over [min, max] of the values:
// returns `levels` thresholds (ascending, in intensity units; a voxel is in
// class c when thresholds[c-1] <= value < thresholds[c]) that maximise the
// between-class variance. levels outside [1, 4] is a programmer error (assert);
// a constant image returns `levels` copies of its value.
std::vector<float> multi_otsu(const ImageVolume& v, int levels);

// Automatic thresholds for dental CT with a non-zero background. A plain
// 3-level Otsu splits the dominant background peak instead of isolating the
// small dark pulp class, so: background = histogram mode below the tooth;
// dark_max = below the background peak by 4 sigma (from its left half-width);
// tooth_min / enamel_min = 2-level Otsu on the voxels at or above dark_max.
// Errors (empty/constant image, no separable classes) name the problem.
Result<Thresholds> auto_thresholds(const ImageVolume& v);

struct SegmentationReport {
  Thresholds thresholds;
  std::array<std::int64_t, kMaxMaterials> voxels{};  // voxel count per material label
  std::int64_t pulp_enclosed = 0;                    // pulp voxels cut off from the border by tooth
  std::int64_t pulp_open = 0;  // dark voxels in an open canal (directional test)
};

// Segments into a VoxelVolume with the same geometry. Density is the intensity
// remapped linearly so background -> 0 and tooth_min -> kIsoDensity, clamped
// to 0..255 (tooth voxels >= 128, others <= 127, so the surface follows the
// tooth boundary with sub-voxel accuracy); pulp keeps material kPulp with its
// (low) remapped density, so an opened chamber shows as a cavity surface.
// Air voxels with density 0 allocate no chunk.
Result<VoxelVolume> segment_ct(const ImageVolume& v, const Thresholds& t,
                               SegmentationReport* report = nullptr);

}  // namespace dentar::volume
