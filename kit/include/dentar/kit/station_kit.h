// The printable station kit (`dentar tags`): every AprilTag of a station printed at true scale
// for a webcam try-out without the phantom head's hardware. PDF (all pages in one file) and SVG
// (one file per page: SVG 1.1 has no pages) through cairo. What is on the sheet:
// docs/formats.md ("Station kit").
//
// - the mannequin tag bundle (the station's mannequin_tags, to tape onto a box), each with a
//   dashed cut square and a label (role, id, border size in mm); when the tags are coplanar
//   with one orientation (a box face), one board with the tags at their exact spacing;
// - the mirror tags (front and back of the mirror's paddle);
// - the pen flag: the front and back panels side by side, a fold line between them (fold with
//   the printed sides out, the pen between the layers), and the pen's axis drawn from the flag
//   to a tip mark at the station's tip position;
// - on every page a 50 mm scale bar to check that the printer did not scale the page.
//
// Sizes: a tag's `size_m` is its border square's side (libapriltag's "tagsize"); the printed
// pattern is total_width cells of size_m / width_at_border (tagStandard41h12: 9 cells of
// size/5, so a 14 mm tag prints 25.2 mm wide), inside a white quiet zone.
//
// Page frame: origin at the page's top-left corner, x to the right, y down, metres.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "dentar/ar/station_scene.h"
#include "dentar/volume/result.h"

namespace dentar::kit {

enum class Paper { kA4, kLetter };
std::optional<Paper> parse_paper(std::string_view name);  // "a4" / "letter"
const char* paper_name(Paper p);                           // "a4" / "letter"
Eigen::Vector2d paper_size_m(Paper p);  // width, height (portrait): A4 210 x 297 mm, letter 8.5 x 11 in

struct KitOptions {
  Paper paper = Paper::kA4;
  // Nothing is drawn within this distance of a page edge (printers' unprintable border).
  double margin_m = 10e-3;
  std::string validate() const;  // empty, or names the field and the allowed range
};

enum class TagRole { kMannequin, kMirror, kPen };
const char* tag_role_name(TagRole r);  // "mannequin" / "mirror" / "pen"

// One printed tag.
struct KitTag {
  TagRole role = TagRole::kMannequin;
  int index = 0;  // in the station's list: mannequin_tags[index], mirror_tags[index], pen.tags[index]
  int id = 0;
  double size_m = 0;  // border square side as printed (the station's size_m)
  int page = 0;       // 0-based
  Eigen::Vector2d centre_m = Eigen::Vector2d::Zero();  // border square centre, page frame
  double pattern_m = 0;  // side of the whole cell pattern (total_width cells)
  double quiet_m = 0;    // white margin around the pattern that belongs to the tag
  // Mannequin and mirror tags: the dashed cut square (pattern + quiet zone), page frame.
  // Pen tags: the flag panel the tag lies on.
  Eigen::Vector2d cut_min_m = Eigen::Vector2d::Zero(), cut_max_m = Eigen::Vector2d::Zero();
};

// The black bar, exactly length_m long; its top-left corner at top_left_m.
struct KitScaleBar {
  int page = 0;
  Eigen::Vector2d top_left_m = Eigen::Vector2d::Zero();
  double length_m = 0.05;
  double height_m = 3e-3;
};

struct KitPenFlag {
  int page = 0;
  double side_m = 0;  // printed panel side (the station's flag_size_m, or larger: see notes)
  Eigen::Vector2d front_centre_m = Eigen::Vector2d::Zero(), back_centre_m = Eigen::Vector2d::Zero();
  Eigen::Vector2d tip_m = Eigen::Vector2d::Zero();  // the tip mark (page frame)
  double tip_distance_m = 0;  // |T_ptag_tip.translation()|
};

// One line of text as drawn: its ink box (cairo's text extents at the font and weight used),
// page frame. Every line fits inside the page's margins: a line that would not (a long
// station name in the title) is drawn in a smaller font, never past the edge.
struct KitText {
  int page = 0;
  std::string text;
  double font_m = 0;  // as drawn (after any shrinking)
  Eigen::Vector2d ink_min_m = Eigen::Vector2d::Zero(), ink_max_m = Eigen::Vector2d::Zero();
};

struct KitLayout {
  Paper paper = Paper::kA4;
  Eigen::Vector2d page_size_m = Eigen::Vector2d::Zero();
  int pages = 0;
  std::vector<KitTag> tags;              // mannequin, mirror, then pen tags
  std::vector<KitScaleBar> scale_bars;   // one per page
  std::optional<KitPenFlag> pen;         // absent when the station has no pen tags
  // The mannequin tags are coplanar with one orientation (tags on a box face): printed as one
  // board at the station's exact spacing (their cut_min/max_m are the board's outline), with
  // the mannequin origin marked when it lies on the board clear of the tags.
  bool mannequin_board = false;
  // Things the user should know (e.g. the pen flag printed larger than flag_size_m because
  // the tag and its quiet zone do not fit on it).
  std::vector<std::string> notes;
  std::vector<KitText> texts;  // every line of text, as drawn
};

// Places everything on pages; no item is cut by a page margin. Errors name the station field
// ("mannequin_tags[3] (id 3, 300.0 mm) does not fit on an a4 page ..."), an invalid station
// (StationScene::validate) or a pen tag that lies neither on the flag's front nor its back.
Result<KitLayout> layout_station_kit(const ar::StationScene& station, const KitOptions& options);

struct KitFiles {
  std::string pdf;                // <out>/station_kit.pdf
  std::vector<std::string> svgs;  // <out>/station_kit.svg, then station_kit_page2.svg, ...
  KitLayout layout;
};

// Lays out and writes the kit into out_dir (created when missing). Errors name the directory or
// file that could not be written.
Result<KitFiles> write_station_kit(const ar::StationScene& station, const KitOptions& options,
                                   const std::string& out_dir);

}  // namespace dentar::kit
