// AprilTag families from libapriltag's code tables: tag images drawn from
// the family structs (no image files), and a plain detector used to check
// rendered footage against its ground truth.
//
// Cell grid: a tag is total_width x total_width cells, row 0 at the top.
// The border square (width_at_border cells) starts at cell
// (total_width - width_at_border) / 2 on both axes; libapriltag's corners
// and "tagsize" refer to that square's outer edge. Normal border (tag36h11):
// black border ring, white ring outside it. Reversed border
// (tagStandard41h12): white border ring, black ring outside it, data bits
// also in the outermost ring. Data bit i (bit_x[i], bit_y[i], relative to
// the border square's first cell) is the code's bit nbits-1-i; 1 = white.
#pragma once

#include <Eigen/Core>
#include <array>
#include <opencv2/core/mat.hpp>
#include <vector>

#include "dentar/ar/station_scene.h"
#include "dentar/volume/result.h"

struct apriltag_family;

namespace dentar::ar {

// Owns a libapriltag family (its create/destroy pair). Move-only.
class TagFamily {
 public:
  static TagFamily create(TagFamilyId id);
  TagFamily(TagFamily&& o) noexcept;
  TagFamily& operator=(TagFamily&& o) noexcept;
  TagFamily(const TagFamily&) = delete;
  TagFamily& operator=(const TagFamily&) = delete;
  ~TagFamily();

  TagFamilyId id() const { return id_; }
  int code_count() const;
  int total_width() const;
  int width_at_border() const;
  int border_start() const { return (total_width() - width_at_border()) / 2; }
  bool reversed_border() const;
  apriltag_family* raw() const { return family_; }

  // total_width x total_width CV_8UC1 cells, 0 black / 255 white. Asserts
  // 0 <= code < code_count().
  cv::Mat cells(int code) const;

 private:
  TagFamily() = default;
  void reset() noexcept;
  apriltag_family* family_ = nullptr;
  TagFamilyId id_ = TagFamilyId::kStandard41h12;
};

// A tag's printed image: the cells, each px_per_cell pixels, inside a white
// margin of margin_px pixels on every side. CV_8UC1.
cv::Mat render_tag_image(const TagFamily& family, int code, int px_per_cell, int margin_px);

// Half side of the printed tag plate (the cells plus half a cell of white
// margin) for a tag whose border square has side size_m.
double tag_plate_half_size_m(const TagFamily& family, double size_m);

}  // namespace dentar::ar
