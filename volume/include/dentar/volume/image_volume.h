// Scalar CT/MR images and their loaders. An ImageVolume is what a file holds;
// segment_ct() turns it into a VoxelVolume of materials.
//
// Every loader returns an Error naming the file and the problem (truncated
// data, dims that do not match the size, dims over kMaxDim/kMaxVoxels, an
// unknown element type, NaN/zero/negative spacing). They never crash and never
// return a partially filled volume.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "dentar/volume/result.h"
#include "dentar/volume/voxel_volume.h"

namespace dentar::volume {

enum class ElementType : std::uint8_t {
  kUInt8, kInt8, kUInt16, kInt16, kUInt32, kInt32, kFloat32, kFloat64
};
std::string_view element_type_name(ElementType t);  // "uint8", "int16", "float32", ...
std::size_t element_size(ElementType t);

struct ImageVolume {
  VolumeGeometry geometry;   // dims, spacing (m), origin (m)
  ElementType source_type = ElementType::kUInt8;  // element type in the file
  std::vector<float> values; // x fastest, size = dims.prod(); all finite

  float at(int i, int j, int k) const {
    return values[static_cast<std::size_t>(i) +
                  static_cast<std::size_t>(geometry.dims.x()) *
                      (static_cast<std::size_t>(j) +
                       static_cast<std::size_t>(geometry.dims.y()) * static_cast<std::size_t>(k))];
  }
};

// Parsed header of any of the three formats, before the data is read.
struct VolumeHeader {
  VolumeGeometry geometry;
  ElementType type = ElementType::kUInt8;
  bool big_endian = false;
  bool gzip = false;           // NRRD "encoding: gzip"
  std::string data_file;       // detached data path (resolved against the header's folder); empty = inline
  std::size_t data_offset = 0; // bytes to skip in the data (raw "header_bytes", NRRD "byte skip")
};

// Loads by extension: .json (raw + JSON sidecar, see docs/formats.md), .mhd/.mha
// (MetaImage), .nrrd/.nhdr (NRRD, raw or gzip encoding).
Result<ImageVolume> load_volume(const std::string& path);
Result<ImageVolume> load_raw_json(const std::string& json_path);
Result<ImageVolume> load_metaimage(const std::string& path);
Result<ImageVolume> load_nrrd(const std::string& path);

// In-memory parsers (used by the loaders and the fuzz targets). `name` is used
// in error messages. For formats with detached data, the returned header names
// the data file; parse_*_bytes() also accept inline data after the header.
Result<VolumeHeader> parse_raw_json_header(std::string_view text, std::string_view name);
Result<VolumeHeader> parse_metaimage_header(std::string_view text, std::string_view name,
                                            std::size_t* header_bytes = nullptr);
Result<VolumeHeader> parse_nrrd_header(std::string_view text, std::string_view name,
                                       std::size_t* header_bytes = nullptr);
// Decodes element data (after any gzip) into values; checks size and finiteness.
Result<ImageVolume> decode_volume_data(const VolumeHeader& h, std::span<const std::uint8_t> bytes,
                                       std::string_view name);

// Writers (for tests, tools and exchange). Spacing/origin written in mm.
Status write_raw_json(const ImageVolume& v, const std::string& json_path);
Status write_metaimage(const ImageVolume& v, const std::string& mhd_path);
Status write_nrrd(const ImageVolume& v, const std::string& nrrd_path, bool gzip);

// CT -> materials by thresholds on the intensity.
struct Thresholds {
  // intensity <  dark_max                       : dark (pulp if enclosed by tooth, else air)
  // dark_max <= intensity < tooth_min           : background / mount -> air
  // tooth_min <= intensity < enamel_min         : dentin
  // intensity >= enamel_min                     : enamel
  float dark_max = 0, tooth_min = 0, enamel_min = 0;
  std::string validate() const;  // ordered and finite
};

// Multi-level Otsu on a 256-bin histogram: returns `levels` thresholds
// (ascending) that maximise the between-class variance. levels in [1, 4].
std::vector<float> multi_otsu(const ImageVolume& v, int levels);
// Automatic thresholds for dental CT (3-level Otsu, robust to a non-zero background).
Result<Thresholds> auto_thresholds(const ImageVolume& v);

struct SegmentationReport {
  Thresholds thresholds;
  std::array<std::int64_t, kMaxMaterials> voxels{};  // voxel count per material label
};

// Segments into a VoxelVolume with the same geometry. Density is the intensity
// remapped so tooth_min sits at kIsoDensity (the surface follows the tooth
// boundary with sub-voxel accuracy); pulp keeps material kPulp.
Result<VoxelVolume> segment_ct(const ImageVolume& v, const Thresholds& t,
                               SegmentationReport* report = nullptr);

}  // namespace dentar::volume
