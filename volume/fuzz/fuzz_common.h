// Shared body of the volume-parser fuzz targets: parse a header from the
// input, decode whatever follows it, and run the segmentation on small results.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "dentar/volume/image_volume.h"

namespace dentar::volume::fuzz {

inline void exercise_volume(const ImageVolume& v) {
  // Keep each input cheap: the segmentation is linear but not free.
  if (v.geometry.voxel_count() > 4096) return;
  (void)multi_otsu(v, 3);
  auto t = auto_thresholds(v);
  if (!t) return;
  SegmentationReport rep;
  (void)segment_ct(v, *t, &rep);
}

inline void decode_after_header(const Result<VolumeHeader>& h, std::span<const std::uint8_t> data,
                                std::string_view name) {
  if (!h) return;
  auto v = decode_volume_data(*h, data, name);
  if (v) exercise_volume(*v);
}

}  // namespace dentar::volume::fuzz
