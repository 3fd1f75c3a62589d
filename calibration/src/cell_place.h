// Where a cell of an image grid lies, in an instructor's words (private): the
// camera model's trust map and the guided camera step both name cells this way.
#pragma once

#include <string>

namespace dentar::calibration::detail {

// Row r of rows, column c of cols: "top-left corner", "left edge",
// "upper right part of the image", "middle of the image", ...
inline std::string cell_place(int r, int c, int rows, int cols) {
  const bool top = r == 0, bottom = r == rows - 1, left = c == 0, right = c == cols - 1;
  if (top && left) return "top-left corner";
  if (top && right) return "top-right corner";
  if (bottom && left) return "bottom-left corner";
  if (bottom && right) return "bottom-right corner";
  if (top) return "top edge";
  if (bottom) return "bottom edge";
  if (left) return "left edge";
  if (right) return "right edge";
  // Inner cells: thirds of the image, with a dead band so a cell near a third's
  // border is not called both ways by neighbouring frames.
  const double x = (c + 0.5) / cols, y = (r + 0.5) / rows;
  const std::string v = y < 0.4 ? "upper " : y > 0.6 ? "lower " : "";
  const std::string h = x < 0.4 ? "left" : x > 0.6 ? "right" : "middle";
  if (v.empty() && h == "middle") return "middle of the image";
  return v + h + " part of the image";
}

}  // namespace dentar::calibration::detail
