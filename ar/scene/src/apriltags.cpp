#include "dentar/ar/apriltags.h"

#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
#include <apriltag/tagStandard41h12.h>

#include <cassert>
#include <memory>
#include <opencv2/core.hpp>
#include <utility>

namespace dentar::ar {

TagFamily TagFamily::create(TagFamilyId id) {
  TagFamily f;
  f.id_ = id;
  f.family_ = id == TagFamilyId::kStandard41h12 ? tagStandard41h12_create() : tag36h11_create();
  return f;
}

TagFamily::TagFamily(TagFamily&& o) noexcept
    : family_(std::exchange(o.family_, nullptr)), id_(o.id_) {}

TagFamily& TagFamily::operator=(TagFamily&& o) noexcept {
  if (this != &o) {
    reset();
    family_ = std::exchange(o.family_, nullptr);
    id_ = o.id_;
  }
  return *this;
}

TagFamily::~TagFamily() { reset(); }

void TagFamily::reset() noexcept {
  if (family_ == nullptr) return;
  if (id_ == TagFamilyId::kStandard41h12)
    tagStandard41h12_destroy(family_);
  else
    tag36h11_destroy(family_);
  family_ = nullptr;
}

int TagFamily::code_count() const { return static_cast<int>(family_->ncodes); }
int TagFamily::total_width() const { return family_->total_width; }
int TagFamily::width_at_border() const { return family_->width_at_border; }
bool TagFamily::reversed_border() const { return family_->reversed_border; }

cv::Mat TagFamily::cells(int code) const {
  assert(code >= 0 && code < code_count() && "dentar::ar::TagFamily::cells: code out of range");
  const int tw = total_width(), b0 = border_start(), wb = width_at_border();
  const bool rev = reversed_border();
  cv::Mat m(tw, tw, CV_8UC1);
  // Rings first (distance from the border square's edge), then data bits.
  for (int r = 0; r < tw; ++r) {
    for (int c = 0; c < tw; ++c) {
      auto ring = [&](int inset) {  // on the ring `inset` cells inside the border square's edge
        const int lo = b0 + inset, hi = b0 + wb - 1 - inset;
        const bool inside = r >= lo && r <= hi && c >= lo && c <= hi;
        return inside && (r == lo || r == hi || c == lo || c == hi);
      };
      std::uint8_t v = 255;
      if (ring(0)) v = rev ? 255 : 0;
      if (ring(-1)) v = rev ? 0 : 255;
      m.at<std::uint8_t>(r, c) = v;
    }
  }
  const std::uint64_t bits = family_->codes[code];
  const unsigned n = family_->nbits;
  for (unsigned i = 0; i < n; ++i) {
    // bit_x/bit_y are stored unsigned but hold small negative offsets for
    // bits outside the border square (reversed-border families).
    const int x = static_cast<int>(static_cast<std::int32_t>(family_->bit_x[i])) + b0;
    const int y = static_cast<int>(static_cast<std::int32_t>(family_->bit_y[i])) + b0;
    assert(x >= 0 && x < tw && y >= 0 && y < tw);
    const bool white = (bits >> (n - 1 - i)) & 1u;
    m.at<std::uint8_t>(y, x) = white ? 255 : 0;
  }
  return m;
}

cv::Mat render_tag_image(const TagFamily& family, int code, int px_per_cell, int margin_px) {
  assert(px_per_cell >= 1 && margin_px >= 0);
  const cv::Mat cells = family.cells(code);
  const int tw = cells.rows;
  cv::Mat img(tw * px_per_cell + 2 * margin_px, tw * px_per_cell + 2 * margin_px, CV_8UC1,
              cv::Scalar(255));
  for (int r = 0; r < tw; ++r)
    for (int c = 0; c < tw; ++c)
      img(cv::Rect(margin_px + c * px_per_cell, margin_px + r * px_per_cell, px_per_cell,
                   px_per_cell))
          .setTo(cells.at<std::uint8_t>(r, c));
  return img;
}

double tag_plate_half_size_m(const TagFamily& family, double size_m) {
  const double cell = size_m / family.width_at_border();
  return 0.5 * (family.total_width() + 1) * cell;
}

}  // namespace dentar::ar
