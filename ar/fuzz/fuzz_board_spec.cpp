// Fuzz target: parse_board_spec, the --board text of `dentar calibrate camera`
// ("chessboard:9x6:25", "aprilgrid:6x5:24:8:tag36h11:3", "kalibr:6x6:88:0.3",
// "charuco:5x7:40:30:DICT_4X4_50:0").
//
// Every accepted spec must describe a board the calibration can use: the sizes the
// validators promise (checked here in 64-bit arithmetic, so an int overflow in the parser
// cannot hide), finite extents, and tag ids inside the family.
//
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <set>
#include <string>
#include <variant>

#include "dentar/ar/apriltags.h"
#include "dentar/ar/calib_board.h"
#include "dentar/ar/station_scene.h"

namespace {

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dentar;
  if (size > 256) return 0;  // a command-line argument
  const std::string text(reinterpret_cast<const char*>(data), size);
  const auto r = ar::parse_board_spec(text);
  if (!r) {
    if (r.error().rfind("board \"", 0) != 0) __builtin_trap();  // errors quote the text
    // ... and give the allowed form (a field's problem with its kind's form, else all forms).
    if (r.error().find("the form") == std::string::npos && r.error().find("must be") == std::string::npos &&
        r.error().find("exceed") == std::string::npos && r.error().find("is not one of") == std::string::npos)
      __builtin_trap();
    return 0;
  }

  const double w = ar::board_width_m(*r), h = ar::board_height_m(*r);
  if (!std::isfinite(w) || !std::isfinite(h) || w <= 0 || h <= 0) __builtin_trap();
  if (const auto* c = std::get_if<calibration::ChessboardSpec>(&*r)) {
    if (!c->validate().empty()) __builtin_trap();
    if (c->cols < 2 || c->rows < 2 || c->cols > 100 || c->rows > 100) __builtin_trap();
    if (c->object_points().size() != static_cast<std::size_t>(c->cols) * c->rows) __builtin_trap();
  } else if (const auto* h = std::get_if<ar::CharucoSpec>(&*r)) {
    if (!h->validate().empty()) __builtin_trap();
    if (h->cols < 3 || h->rows < 3 || h->cols > 100 || h->rows > 100) __builtin_trap();
    if (!(h->marker_m > 0 && h->marker_m < h->square_m)) __builtin_trap();
    if (h->first_id < 0) __builtin_trap();
    if (h->object_points().size() != static_cast<std::size_t>(h->corner_count())) __builtin_trap();
    if (board_spec_to_string(*r).rfind("charuco:", 0) != 0) __builtin_trap();
  } else {
    const auto& g = std::get<calibration::AprilGridSpec>(*r);
    if (!g.validate().empty()) __builtin_trap();
    const std::int64_t tags = std::int64_t{g.cols} * g.rows;
    if (g.cols < 1 || g.rows < 1) __builtin_trap();
    if (tags > 500) __builtin_trap();  // "1..500 tags" (was an int overflow, fixed)
    const auto family = ar::parse_tag_family(g.family);
    if (!family) __builtin_trap();
    const std::int64_t codes = ar::TagFamily::create(*family).code_count();
    if (g.first_id < 0) __builtin_trap();
    if (g.first_id + tags > codes) __builtin_trap();  // was an int overflow, fixed
    for (const auto& p : g.tag_corners(g.first_id))
      if (!p.allFinite()) __builtin_trap();
  }
  return 0;
}
