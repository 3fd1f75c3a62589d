// Station kit layout and cairo drawing. Layout works in metres (page frame: top-left origin,
// y down); drawing sets cairo's user unit to the millimetre (PDF and SVG surfaces measure in
// points, 1/72 in) so the printed size is the layout's size.
#include "dentar/kit/station_kit.h"

#include <cairo-pdf.h>
#include <cairo-svg.h>
#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>

#include "dentar/ar/apriltags.h"

namespace dentar::kit {
namespace {

constexpr double kPtPerMm = 72.0 / 25.4;

// Typography and spacing, millimetres (drawing units).
constexpr double kTitleFont = 3.6;
constexpr double kTextFont = 2.4;
constexpr double kLabelFont = 2.2;
constexpr double kHeadingFont = 3.0;
constexpr double kLabelLine = 2.8;   // baseline to baseline
constexpr double kLabelGap = 1.2;    // cut square to the first label line's top
constexpr double kItemGapX = 4.0;
constexpr double kItemGapY = 3.0;
constexpr double kHeaderHeight = 20.0;  // title, instructions, scale bar
constexpr double kHeadingHeight = 10.0;  // section heading + one instruction line

std::string mm_text(double m, int decimals = 1) {
  char b[32];
  std::snprintf(b, sizeof b, "%.*f mm", decimals, m * 1e3);
  return b;
}

// Where each mirror tag goes, from its placement on the paddle (station_scene.h
// MirrorSceneParams). Seen from the reflecting side with the mirror head up, the
// paddle's -y side is on the right (mtag: x along the handle away from the head,
// z into the paddle).
std::string mirror_instructions(const ar::StationScene& s) {
  if (s.mirror.paddle_roof_rad <= 0)
    return s.mirror_tags.size() == 2
               ? "Tape the first onto the front of the mirror's paddle (the reflecting side), the "
                 "second onto its back."
               : "Tape each onto the mirror's paddle as the station file places it.";
  std::string right, left, back;
  for (const ar::TagPlacement& t : s.mirror_tags) {
    std::string& to = t.T_parent_tag.linear().col(2).z() < 0 ? back
                      : t.T_parent_tag.translation().y() < 0 ? right
                                                              : left;
    to += (to.empty() ? "" : " and ") + std::to_string(t.id);
  }
  char b[200];
  std::snprintf(b, sizeof b, "Reflecting side toward you, head up: id %s on the roof's right face (%.0f deg), "
                "%s on its left, %s on the flat back.",
                right.empty() ? "-" : right.c_str(), s.mirror.paddle_roof_rad * 180 / M_PI,
                left.empty() ? "-" : left.c_str(), back.empty() ? "-" : back.c_str());
  return b;
}

// Text widths need a cairo context with the drawing font; a 1x1 image surface serves.
class TextMeasure {
 public:
  TextMeasure()
      : surface_(cairo_image_surface_create(CAIRO_FORMAT_A8, 1, 1)), cr_(cairo_create(surface_)) {
    cairo_select_font_face(cr_, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  }
  ~TextMeasure() {
    cairo_destroy(cr_);
    cairo_surface_destroy(surface_);
  }
  TextMeasure(const TextMeasure&) = delete;
  TextMeasure& operator=(const TextMeasure&) = delete;
  double width_mm(const std::string& s, double font_mm) {
    cairo_set_font_size(cr_, font_mm);
    cairo_text_extents_t e;
    cairo_text_extents(cr_, s.c_str(), &e);
    return e.x_advance;
  }
  // Ink extents at the weight the text is drawn with, unhinted: measured at 100 times the size
  // (on this 1-unit-per-mm surface a 3.6 mm font is 3.6 device pixels, whose hinted metrics
  // are far from the PDF's vector glyphs) and scaled back.
  cairo_text_extents_t extents(const std::string& s, double font_mm, bool bold) {
    constexpr double kUp = 100.0;
    cairo_font_options_t* fo = cairo_font_options_create();
    cairo_font_options_set_hint_metrics(fo, CAIRO_HINT_METRICS_OFF);
    cairo_font_options_set_hint_style(fo, CAIRO_HINT_STYLE_NONE);
    cairo_set_font_options(cr_, fo);
    cairo_font_options_destroy(fo);
    cairo_select_font_face(cr_, "sans-serif", CAIRO_FONT_SLANT_NORMAL,
                           bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
    cairo_set_font_size(cr_, font_mm * kUp);
    cairo_text_extents_t e;
    cairo_text_extents(cr_, s.c_str(), &e);
    cairo_select_font_face(cr_, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
    for (double* v : {&e.x_bearing, &e.y_bearing, &e.width, &e.height, &e.x_advance, &e.y_advance}) *v /= kUp;
    return e;
  }

 private:
  cairo_surface_t* surface_;
  cairo_t* cr_;
};

struct Text {
  int page = 0;
  double x_mm = 0, y_mm = 0;  // baseline start
  double font_mm = kTextFont;
  bool bold = false;
  std::string text;
};

struct CutRect {
  int page = 0;
  double x0, y0, x1, y1;  // mm
};

struct PenDrawing {
  double fold_x_mm = 0;      // fold line x (between the panels)
  double top_mm = 0, bottom_mm = 0;
  double centre_x_mm = 0, centre_y_mm = 0;  // front flag centre
};

// Everything drawn: the public layout plus texts and guide lines.
struct Plan {
  KitLayout layout;
  std::vector<Text> texts;
  std::vector<CutRect> cuts;
  std::optional<PenDrawing> pen;
  std::optional<Eigen::Vector2d> origin_mark_mm;  // the mannequin origin on a board
  ar::TagFamilyId family = ar::TagFamilyId::kStandard41h12;
};

// Cell pattern geometry of one tag.
struct TagGeometry {
  double pattern_m, quiet_m;
};
TagGeometry tag_geometry(const ar::TagFamily& fam, double size_m) {
  const double cell = size_m / fam.width_at_border();
  return {cell * fam.total_width(), std::max(cell, 2e-3)};
}

bool near(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) { return (a - b).norm() < 1e-6; }

// Flows items left to right in rows, rows down pages.
class Flow {
 public:
  Flow(double left, double right, double top, double bottom)
      : left_(left), right_(right), top_(top), bottom_(bottom), x_(left), y_(top) {}
  int pages() const { return page_ + 1; }
  double usable_width() const { return right_ - left_; }
  double usable_height() const { return bottom_ - top_; }
  void new_row() {
    if (x_ > left_) {
      y_ += row_h_ + kItemGapY;
      x_ = left_;
      row_h_ = 0;
    }
  }
  // Starts a row that needs at least `h` of height (keeps a heading with its first item).
  void new_row_needing(double h) {
    new_row();
    if (y_ + h > bottom_) new_page();
  }
  // Top-left of a w x h item (fits: checked by the caller).
  Eigen::Vector2d place(double w, double h, int& page) {
    if (x_ + w > right_ + 1e-9) new_row();
    if (y_ + h > bottom_ + 1e-9) new_page();
    const Eigen::Vector2d p(x_, y_);
    page = page_;
    x_ += w + kItemGapX;
    row_h_ = std::max(row_h_, h);
    return p;
  }

 private:
  void new_page() {
    ++page_;
    x_ = left_;
    y_ = top_;
    row_h_ = 0;
  }
  double left_, right_, top_, bottom_;
  double x_, y_, row_h_ = 0;
  int page_ = 0;
};

Result<Plan> make_plan(const ar::StationScene& s, const KitOptions& o) {
  if (std::string e = o.validate(); !e.empty()) return Error{"station kit: " + e};
  if (std::string e = s.validate(); !e.empty()) return Error{"station kit: " + e};
  Plan plan;
  plan.family = s.family;
  KitLayout& L = plan.layout;
  L.paper = o.paper;
  L.page_size_m = paper_size_m(o.paper);
  const double W = L.page_size_m.x() * 1e3, H = L.page_size_m.y() * 1e3, M = o.margin_m * 1e3;
  const ar::TagFamily fam = ar::TagFamily::create(s.family);
  TextMeasure tm;
  Flow flow(M, W - M, M + kHeaderHeight, H - M);
  const std::string page_name = std::string(paper_name(o.paper)) + " page (" +
                                mm_text(flow.usable_width() * 1e-3, 0) + " x " +
                                mm_text(flow.usable_height() * 1e-3, 0) + " usable)";

  auto heading = [&](const std::string& title, const std::string& line, double first_item_h) {
    flow.new_row_needing(kHeadingHeight + first_item_h);
    int page = 0;
    const Eigen::Vector2d p = flow.place(flow.usable_width(), kHeadingHeight - kItemGapY, page);
    plan.texts.push_back({page, p.x(), p.y() + kHeadingFont, kHeadingFont, true, title});
    plan.texts.push_back({page, p.x(), p.y() + kHeadingFont + 3.6, kTextFont, false, line});
    flow.new_row();
  };

  // Loose tags (mannequin and mirror): cut square + two label lines below.
  auto loose_tags = [&](const std::vector<ar::TagPlacement>& tags, TagRole role,
                        const char* field) -> Status {
    struct Item {
      double cut_mm, w_mm, h_mm;
      std::string line1, line2;
    };
    std::vector<Item> items;
    for (std::size_t i = 0; i < tags.size(); ++i) {
      const TagGeometry g = tag_geometry(fam, tags[i].size_m);
      Item it;
      it.cut_mm = (g.pattern_m + 2 * g.quiet_m) * 1e3;
      it.line1 = std::string(tag_role_name(role)) + " id " + std::to_string(tags[i].id);
      it.line2 = mm_text(tags[i].size_m) + " border";
      it.w_mm = std::max({it.cut_mm, tm.width_mm(it.line1, kLabelFont),
                          tm.width_mm(it.line2, kLabelFont)});
      it.h_mm = it.cut_mm + kLabelGap + 2 * kLabelLine;
      if (it.w_mm > flow.usable_width() || it.h_mm + kHeadingHeight > flow.usable_height())
        return Error{std::string("station kit: ") + field + "[" + std::to_string(i) + "] (id " +
                     std::to_string(tags[i].id) + ", " + mm_text(tags[i].size_m) +
                     " border, printed " + mm_text(it.cut_mm * 1e-3) +
                     " with its quiet zone) does not fit on an " + page_name +
                     ": use smaller tags or --paper"};
      items.push_back(std::move(it));
    }
    for (std::size_t i = 0; i < tags.size(); ++i) {
      const Item& it = items[i];
      int page = 0;
      const Eigen::Vector2d p = flow.place(it.w_mm, it.h_mm, page);
      const TagGeometry g = tag_geometry(fam, tags[i].size_m);
      KitTag t;
      t.role = role;
      t.index = static_cast<int>(i);
      t.id = tags[i].id;
      t.size_m = tags[i].size_m;
      t.page = page;
      t.pattern_m = g.pattern_m;
      t.quiet_m = g.quiet_m;
      const double cx = p.x() + 0.5 * it.w_mm, half = 0.5 * it.cut_mm;
      t.cut_min_m = Eigen::Vector2d(cx - half, p.y()) * 1e-3;
      t.cut_max_m = Eigen::Vector2d(cx + half, p.y() + it.cut_mm) * 1e-3;
      // The border square is centred in the pattern, which is centred in the cut square.
      t.centre_m = 0.5 * (t.cut_min_m + t.cut_max_m);
      L.tags.push_back(t);
      plan.cuts.push_back({page, cx - half, p.y(), cx + half, p.y() + it.cut_mm});
      const double ty = p.y() + it.cut_mm + kLabelGap + kLabelFont * 0.8;
      plan.texts.push_back({page, cx - 0.5 * tm.width_mm(it.line1, kLabelFont), ty, kLabelFont,
                            false, it.line1});
      plan.texts.push_back({page, cx - 0.5 * tm.width_mm(it.line2, kLabelFont), ty + kLabelLine,
                            kLabelFont, false, it.line2});
    }
    return {};
  };

  const std::string fam_name = ar::tag_family_name(s.family);
  // Coplanar mannequin tags with one orientation (a box face): one board at the station's
  // exact spacing, when it fits on the page.
  struct BoardTag {
    Eigen::Vector2d offset_mm;  // border square centre relative to tag 0, board = tag-0 image axes
    double half_mm;             // half side of pattern + quiet zone
  };
  std::vector<BoardTag> board;
  Eigen::Vector2d board_lo(1e9, 1e9), board_hi(-1e9, -1e9);
  Eigen::Vector3d origin_in_t0 = Eigen::Vector3d::Zero();
  if (s.mannequin_tags.size() >= 2) {
    const Eigen::Isometry3d& T0 = s.mannequin_tags[0].T_parent_tag;
    const Eigen::Matrix3d R0 = T0.linear();
    bool flat = true;
    for (const ar::TagPlacement& t : s.mannequin_tags) {
      const Eigen::Vector3d d = R0.transpose() * (t.T_parent_tag.translation() - T0.translation());
      const double angle = Eigen::AngleAxisd(R0.transpose() * t.T_parent_tag.linear()).angle();
      if (std::abs(d.z()) > 0.05e-3 || angle > 0.1 * M_PI / 180) {
        flat = false;
        break;
      }
      const TagGeometry g = tag_geometry(fam, t.size_m);
      const BoardTag b{d.head<2>() * 1e3, (0.5 * g.pattern_m + g.quiet_m) * 1e3};
      board_lo = board_lo.cwiseMin(b.offset_mm - Eigen::Vector2d::Constant(b.half_mm));
      board_hi = board_hi.cwiseMax(b.offset_mm + Eigen::Vector2d::Constant(b.half_mm));
      board.push_back(b);
    }
    // Tags whose pattern + quiet zone overlap cannot be printed as one board.
    for (std::size_t i = 0; flat && i < board.size(); ++i)
      for (std::size_t j = i + 1; j < board.size(); ++j)
        if (((board[i].offset_mm - board[j].offset_mm).cwiseAbs().array() <
             board[i].half_mm + board[j].half_mm - 1e-6)
                .all())
          flat = false;
    origin_in_t0 = R0.transpose() * (-T0.translation()) * 1e3;
    const Eigen::Vector2d size = board_hi - board_lo;
    if (!flat || size.x() > flow.usable_width() ||
        size.y() + 3 * kLabelLine + kHeadingHeight > flow.usable_height())
      board.clear();
  }
  if (!board.empty()) {
    const Eigen::Vector2d size = board_hi - board_lo;
    const double h = size.y() + kLabelGap + 2 * kLabelLine;
    heading("Mannequin tags (" + std::to_string(s.mannequin_tags.size()) + ", " + fam_name +
                ") on one board",
            "Cut along the dashed outline and tape the whole board flat onto the box: the tags "
            "keep the station's spacing.",
            h);
    int page = 0;
    const Eigen::Vector2d p = flow.place(size.x(), h, page);
    const Eigen::Vector2d o = p - board_lo;  // page position (mm) of tag 0's centre
    plan.cuts.push_back({page, p.x(), p.y(), p.x() + size.x(), p.y() + size.y()});
    for (std::size_t i = 0; i < board.size(); ++i) {
      const ar::TagPlacement& tp = s.mannequin_tags[i];
      const TagGeometry g = tag_geometry(fam, tp.size_m);
      KitTag t;
      t.role = TagRole::kMannequin;
      t.index = static_cast<int>(i);
      t.id = tp.id;
      t.size_m = tp.size_m;
      t.page = page;
      t.pattern_m = g.pattern_m;
      t.quiet_m = g.quiet_m;
      t.centre_m = (o + board[i].offset_mm) * 1e-3;
      t.cut_min_m = p * 1e-3;
      t.cut_max_m = (p + size) * 1e-3;
      L.tags.push_back(t);
    }
    const Eigen::Vector2d om = o + origin_in_t0.head<2>();
    if ((om.array() >= p.array()).all() && (om.array() <= (p + size).array()).all()) {
      // Only where no tag's pattern or quiet zone is.
      bool clear = true;
      for (const BoardTag& b : board)
        if (((o + b.offset_mm - om).cwiseAbs().array() < b.half_mm + 3.0).all()) clear = false;
      if (clear) plan.origin_mark_mm = om;
    }
    std::string ids;
    for (const ar::TagPlacement& t : s.mannequin_tags)
      ids += (ids.empty() ? "" : ", ") + std::to_string(t.id);
    char b[160];
    std::snprintf(b, sizeof b, "%s border; the + is the mannequin origin (the mouth), %.1f mm %s the board",
                  mm_text(s.mannequin_tags[0].size_m).c_str(), std::abs(origin_in_t0.z()),
                  origin_in_t0.z() >= 0 ? "behind" : "in front of");
    const double ty = p.y() + size.y() + kLabelGap + kLabelFont * 0.8;
    plan.texts.push_back({page, p.x(), ty, kLabelFont, false, "mannequin ids " + ids});
    plan.texts.push_back({page, p.x(), ty + kLabelLine, kLabelFont, false, b});
    L.mannequin_board = true;
  } else if (!s.mannequin_tags.empty()) {
    const TagGeometry g0 = tag_geometry(fam, s.mannequin_tags[0].size_m);
    heading("Mannequin tags (" + std::to_string(s.mannequin_tags.size()) + ", " + fam_name + ")",
            "Cut along the dashed squares and tape each tag flat onto the box, upright (its label "
            "below it).",
            (g0.pattern_m + 2 * g0.quiet_m) * 1e3 + kLabelGap + 2 * kLabelLine);
    if (Status st = loose_tags(s.mannequin_tags, TagRole::kMannequin, "mannequin_tags"); !st)
      return Error{st.error()};
  }
  if (!s.mirror_tags.empty()) {
    const TagGeometry g0 = tag_geometry(fam, s.mirror_tags[0].size_m);
    heading("Mirror tags (" + std::to_string(s.mirror_tags.size()) + ")", mirror_instructions(s),
            (g0.pattern_m + 2 * g0.quiet_m) * 1e3 + kLabelGap + 2 * kLabelLine);
    if (Status st = loose_tags(s.mirror_tags, TagRole::kMirror, "mirror_tags"); !st)
      return Error{st.error()};
  }

  // Pen flag: front panel | back panel, fold line between them.
  if (!s.pen.tags.empty()) {
    const Eigen::Matrix3d back_R =
        Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY()).toRotationMatrix();
    double need_mm = 0;
    std::vector<bool> is_back(s.pen.tags.size());
    for (std::size_t i = 0; i < s.pen.tags.size(); ++i) {
      const ar::TagPlacement& t = s.pen.tags[i];
      const Eigen::Matrix3d R = t.T_parent_tag.linear();
      if (near(R, Eigen::Matrix3d::Identity())) {
        is_back[i] = false;
      } else if (near(R, back_R)) {
        is_back[i] = true;
      } else {
        return Error{"station kit: pen.tags[" + std::to_string(i) + "] (id " +
                     std::to_string(t.id) +
                     "): T_ptag_tag must put the tag flat on the flag's front (identity "
                     "rotation) or its back (turned 180 deg about y); the kit prints flat flags "
                     "only"};
      }
      const TagGeometry g = tag_geometry(fam, t.size_m);
      const Eigen::Vector3d tr = t.T_parent_tag.translation();
      need_mm = std::max(need_mm, 2e3 * (std::max(std::abs(tr.x()), std::abs(tr.y())) +
                                         0.5 * g.pattern_m + g.quiet_m));
    }
    double f = s.pen.flag_size_m * 1e3;
    if (need_mm > f + 1e-9) {
      char b[256];
      std::snprintf(b, sizeof b,
                    "pen flag printed %.1f mm wide instead of pen.flag_size %.1f mm: the %s "
                    "tags (%.1f mm border) and their quiet zone need it",
                    need_mm, f, fam_name.c_str(), s.pen.tags[0].size_m * 1e3);
      L.notes.push_back(b);
      f = need_mm;
    }
    const Eigen::Vector3d tip = s.pen.T_ptag_tip.translation() * 1e3;
    std::string tip_label = "pen tip: " + mm_text(tip.norm() * 1e-3) + " from the flag centre";
    if (std::abs(tip.z()) > 0.5) {  // the tip mark shows (x, y) only
      tip_label += ", " + mm_text(std::abs(tip.z()) * 1e-3) +
                   (tip.z() > 0 ? " behind the flag" : " in front of the flag");
    }
    const double label_top = kLabelFont + kLabelLine + 1.0;  // panel labels above the panels
    // Item box (local mm, origin at the front panel's top-left minus the label band).
    const double cx = 0.5 * f, cy = label_top + 0.5 * f;
    double x0 = 0, y0 = 0, x1 = 2 * f, y1 = label_top + f;
    const double tx = cx + tip.x(), ty = cy + tip.y();
    x0 = std::min(x0, tx - 3);
    x1 = std::max(x1, tx + 3 + tm.width_mm(tip_label, kLabelFont));
    y0 = std::min(y0, ty - 3 - kLabelLine);
    y1 = std::max(y1, ty + 3 + 2 * kLabelLine);
    const double w = x1 - x0, h = y1 - y0;
    if (w > flow.usable_width() || h + kHeadingHeight > flow.usable_height())
      return Error{"station kit: the pen flag (" + mm_text(f * 1e-3) + " panels, tip " +
                   mm_text(tip.norm() * 1e-3) + " from the flag centre) does not fit on an " +
                   page_name + ": check pen.flag_size, pen.T_ptag_tip, or use --paper"};
    heading("Pen flag (" + std::to_string(s.pen.tags.size()) + " tags)",
            "Cut out both panels as one piece, fold along the middle line (printed sides out) "
            "around the pen, tip on the mark.",
            h);
    int page = 0;
    const Eigen::Vector2d p = flow.place(w, h, page);
    const double ox = p.x() - x0, oy = p.y() - y0;  // local -> page, mm
    KitPenFlag pf;
    pf.page = page;
    pf.side_m = f * 1e-3;
    pf.front_centre_m = Eigen::Vector2d(ox + cx, oy + cy) * 1e-3;
    pf.back_centre_m = Eigen::Vector2d(ox + cx + f, oy + cy) * 1e-3;
    pf.tip_m = Eigen::Vector2d(ox + tx, oy + ty) * 1e-3;
    pf.tip_distance_m = tip.norm() * 1e-3;
    L.pen = pf;
    PenDrawing pd;
    pd.fold_x_mm = ox + f;
    pd.top_mm = oy + label_top;
    pd.bottom_mm = oy + label_top + f;
    pd.centre_x_mm = ox + cx;
    pd.centre_y_mm = oy + cy;
    plan.pen = pd;
    plan.cuts.push_back({page, ox, oy + label_top, ox + 2 * f, oy + label_top + f});
    for (std::size_t i = 0; i < s.pen.tags.size(); ++i) {
      const ar::TagPlacement& t = s.pen.tags[i];
      const TagGeometry g = tag_geometry(fam, t.size_m);
      const Eigen::Vector3d tr = t.T_parent_tag.translation() * 1e3;
      KitTag k;
      k.role = TagRole::kPen;
      k.index = static_cast<int>(i);
      k.id = t.id;
      k.size_m = t.size_m;
      k.page = page;
      k.pattern_m = g.pattern_m;
      k.quiet_m = g.quiet_m;
      // Folding the back panel behind the front about the fold line maps back-panel point
      // (fold + d) onto flag point (fold - d): a tag printed upright there is turned 180 deg
      // about y, as the station's back tags are.
      const Eigen::Vector2d panel_centre = is_back[i] ? pf.back_centre_m : pf.front_centre_m;
      k.centre_m = panel_centre + Eigen::Vector2d(is_back[i] ? -tr.x() : tr.x(), tr.y()) * 1e-3;
      k.cut_min_m = panel_centre - Eigen::Vector2d::Constant(0.5 * f * 1e-3);
      k.cut_max_m = panel_centre + Eigen::Vector2d::Constant(0.5 * f * 1e-3);
      L.tags.push_back(k);
    }
    // Panel labels above the panels; the tip label beside the tip mark.
    auto panel_label = [&](bool back) {
      std::string ids;
      for (std::size_t i = 0; i < s.pen.tags.size(); ++i)
        if (is_back[i] == back)
          ids += (ids.empty() ? "" : ", ") + std::to_string(s.pen.tags[i].id);
      if (ids.empty()) return;
      const std::string t1 = std::string(back ? "back" : "front") + ": pen id " + ids + ", " +
                             mm_text(s.pen.tags[0].size_m) + " border";
      plan.texts.push_back({page, ox + (back ? f : 0.0), oy + kLabelFont, kLabelFont, false, t1});
    };
    panel_label(false);
    panel_label(true);
    plan.texts.push_back({page, ox + f + 1.0, oy + kLabelFont + kLabelLine, kLabelFont, false,
                          "fold"});
    plan.texts.push_back({page, ox + tx + 3, oy + ty + 0.35 * kLabelFont, kLabelFont, false,
                          tip_label});
    plan.texts.push_back({page, ox + tx + 3, oy + ty + 0.35 * kLabelFont + kLabelLine, kLabelFont,
                          false, "(lay the pen on the dashed line)"});
  }

  // Page headers: title, instructions and the scale bar on every page.
  L.pages = flow.pages();
  for (int pg = 0; pg < L.pages; ++pg) {
    std::string title = "DentAR station kit: " + s.name + " (" + fam_name + ")";
    if (L.pages > 1)
      title += ", page " + std::to_string(pg + 1) + " of " + std::to_string(L.pages);
    plan.texts.push_back({pg, M, M + kTitleFont, kTitleFont, true, title});
    plan.texts.push_back({pg, M, M + kTitleFont + 4.0, kTextFont, false,
                          "Print at 100 % / actual size (no \"fit to page\"), on " +
                              std::string(paper_name(o.paper)) + " paper."});
    KitScaleBar bar;
    bar.page = pg;
    bar.top_left_m = Eigen::Vector2d(M, M + 11.0) * 1e-3;
    L.scale_bars.push_back(bar);
    plan.texts.push_back({pg, M + 50.0 + 6.0, M + 11.0 + 2.4, kTextFont, false,
                          "<- this bar must measure 50 mm; if not, the printer scaled the page"});
  }

  // Every line inside the margins: one that would run past the right margin (a long station
  // name in the title, a long instruction) is drawn in the font size that fits.
  for (Text& t : plan.texts) {
    cairo_text_extents_t e = tm.extents(t.text, t.font_mm, t.bold);
    const double room = (W - M) - (t.x_mm + e.x_bearing);
    for (int k = 0; k < 4 && t.x_mm + e.x_bearing + e.width > W - M && room > 0 && e.width > 0; ++k) {
      t.font_mm *= 0.995 * room / e.width;  // unhinted extents scale with the font size
      e = tm.extents(t.text, t.font_mm, t.bold);
    }
    KitText k;
    k.page = t.page;
    k.text = t.text;
    k.font_m = t.font_mm * 1e-3;
    k.ink_min_m = Eigen::Vector2d(t.x_mm + e.x_bearing, t.y_mm + e.y_bearing) * 1e-3;
    k.ink_max_m = Eigen::Vector2d(t.x_mm + e.x_bearing + e.width, t.y_mm + e.y_bearing + e.height) * 1e-3;
    L.texts.push_back(k);
  }
  return plan;
}

// Black cells of one tag as one path (no seams between neighbouring cells), filled once.
void draw_tag(cairo_t* cr, const ar::TagFamily& fam, int id, double size_mm,
              const Eigen::Vector2d& centre_mm) {
  const cv::Mat cells = fam.cells(id);
  const int tw = cells.rows;
  const double cell = size_mm / fam.width_at_border();
  // Border square starts border_start() cells into the pattern.
  const double x0 = centre_mm.x() - 0.5 * size_mm - fam.border_start() * cell;
  const double y0 = centre_mm.y() - 0.5 * size_mm - fam.border_start() * cell;
  cairo_new_path(cr);
  for (int r = 0; r < tw; ++r) {
    int c = 0;
    while (c < tw) {
      if (cells.at<std::uint8_t>(r, c) != 0) {
        ++c;
        continue;
      }
      int e = c;
      while (e < tw && cells.at<std::uint8_t>(r, e) == 0) ++e;
      cairo_rectangle(cr, x0 + c * cell, y0 + r * cell, (e - c) * cell, cell);
      c = e;
    }
  }
  cairo_set_source_rgb(cr, 0, 0, 0);
  cairo_set_fill_rule(cr, CAIRO_FILL_RULE_WINDING);
  cairo_fill(cr);
}

void draw_page(cairo_t* cr, const Plan& plan, const ar::TagFamily& fam, int page) {
  cairo_save(cr);
  cairo_scale(cr, kPtPerMm, kPtPerMm);  // user unit: mm
  const KitLayout& L = plan.layout;
  // Cut lines: thin dashed grey.
  const double dash[] = {1.5, 1.0};
  cairo_set_source_rgb(cr, 0.55, 0.55, 0.55);
  cairo_set_line_width(cr, 0.15);
  cairo_set_dash(cr, dash, 2, 0);
  for (const CutRect& c : plan.cuts) {
    if (c.page != page) continue;
    cairo_rectangle(cr, c.x0, c.y0, c.x1 - c.x0, c.y1 - c.y0);
    cairo_stroke(cr);
  }
  if (L.pen && L.pen->page == page && plan.pen) {
    const PenDrawing& pd = *plan.pen;
    // Fold line: dash-dot, darker.
    const double fold_dash[] = {3.0, 1.0, 0.5, 1.0};
    cairo_set_source_rgb(cr, 0.3, 0.3, 0.3);
    cairo_set_dash(cr, fold_dash, 4, 0);
    cairo_move_to(cr, pd.fold_x_mm, pd.top_mm - 1.0);
    cairo_line_to(cr, pd.fold_x_mm, pd.bottom_mm + 1.0);
    cairo_stroke(cr);
    // Pen axis: from the flag centre to the tip, drawn under the panel (the panel is painted
    // white over it so the tag stays clean).
    const double pen_dash[] = {2.0, 1.0};
    cairo_set_dash(cr, pen_dash, 2, 0);
    cairo_set_line_width(cr, 0.3);
    cairo_set_source_rgb(cr, 0.1, 0.1, 0.6);
    const Eigen::Vector2d tip = L.pen->tip_m * 1e3;
    cairo_move_to(cr, pd.centre_x_mm, pd.centre_y_mm);
    cairo_line_to(cr, tip.x(), tip.y());
    cairo_stroke(cr);
    cairo_set_dash(cr, nullptr, 0, 0);
    const double f = L.pen->side_m * 1e3;
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_rectangle(cr, pd.centre_x_mm - 0.5 * f + 0.2, pd.top_mm + 0.2, f - 0.4, f - 0.4);
    cairo_fill(cr);
    // Tip mark: a cross in a circle.
    cairo_set_source_rgb(cr, 0.1, 0.1, 0.6);
    cairo_set_line_width(cr, 0.2);
    cairo_arc(cr, tip.x(), tip.y(), 1.5, 0, 2 * M_PI);
    cairo_stroke(cr);
    cairo_move_to(cr, tip.x() - 2.5, tip.y());
    cairo_line_to(cr, tip.x() + 2.5, tip.y());
    cairo_move_to(cr, tip.x(), tip.y() - 2.5);
    cairo_line_to(cr, tip.x(), tip.y() + 2.5);
    cairo_stroke(cr);
  }
  cairo_set_dash(cr, nullptr, 0, 0);
  if (plan.origin_mark_mm && !L.tags.empty()) {
    int board_page = -1;
    for (const KitTag& t : L.tags)
      if (t.role == TagRole::kMannequin) board_page = t.page;
    if (board_page == page) {
      const Eigen::Vector2d& m = *plan.origin_mark_mm;
      cairo_set_source_rgb(cr, 0.6, 0.1, 0.1);
      cairo_set_line_width(cr, 0.25);
      cairo_move_to(cr, m.x() - 2.5, m.y());
      cairo_line_to(cr, m.x() + 2.5, m.y());
      cairo_move_to(cr, m.x(), m.y() - 2.5);
      cairo_line_to(cr, m.x(), m.y() + 2.5);
      cairo_stroke(cr);
    }
  }
  for (const KitTag& t : L.tags)
    if (t.page == page) draw_tag(cr, fam, t.id, t.size_m * 1e3, t.centre_m * 1e3);
  for (const KitScaleBar& b : L.scale_bars) {
    if (b.page != page) continue;
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_rectangle(cr, b.top_left_m.x() * 1e3, b.top_left_m.y() * 1e3, b.length_m * 1e3,
                    b.height_m * 1e3);
    cairo_fill(cr);
    // 10 mm ticks below the bar, clear of it (the bar's length is what is measured).
    cairo_set_line_width(cr, 0.2);
    for (int k = 0; k <= 5; ++k) {
      const double x = b.top_left_m.x() * 1e3 + 10.0 * k;
      const double y = (b.top_left_m.y() + b.height_m) * 1e3 + 0.8;
      cairo_move_to(cr, x, y);
      cairo_line_to(cr, x, y + (k == 0 || k == 5 ? 2.0 : 1.2));
    }
    cairo_stroke(cr);
  }
  cairo_set_source_rgb(cr, 0, 0, 0);
  for (const Text& t : plan.texts) {
    if (t.page != page) continue;
    cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL,
                           t.bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
    cairo_set_font_size(cr, t.font_mm);
    cairo_move_to(cr, t.x_mm, t.y_mm);
    cairo_show_text(cr, t.text.c_str());
  }
  cairo_restore(cr);
}

// Finishes a surface and reports a write failure naming the file.
Status finish(cairo_surface_t* surface, cairo_t* cr, const std::string& path) {
  const cairo_status_t cs = cairo_status(cr);
  cairo_destroy(cr);
  cairo_surface_finish(surface);
  const cairo_status_t ss = cairo_surface_status(surface);
  cairo_surface_destroy(surface);
  const cairo_status_t bad = cs != CAIRO_STATUS_SUCCESS ? cs : ss;
  if (bad != CAIRO_STATUS_SUCCESS)
    return Error{path + ": cannot write the station kit (" + cairo_status_to_string(bad) + ")"};
  return {};
}

}  // namespace

std::optional<Paper> parse_paper(std::string_view name) {
  if (name == "a4") return Paper::kA4;
  if (name == "letter") return Paper::kLetter;
  return std::nullopt;
}

const char* paper_name(Paper p) { return p == Paper::kA4 ? "a4" : "letter"; }

Eigen::Vector2d paper_size_m(Paper p) {
  return p == Paper::kA4 ? Eigen::Vector2d(0.210, 0.297)
                         : Eigen::Vector2d(8.5 * 0.0254, 11.0 * 0.0254);
}

std::string KitOptions::validate() const {
  if (!(margin_m >= 3e-3 && margin_m <= 40e-3))
    return "margin = " + mm_text(margin_m) + " must be in [3, 40] mm";
  return {};
}

const char* tag_role_name(TagRole r) {
  switch (r) {
    case TagRole::kMannequin: return "mannequin";
    case TagRole::kMirror: return "mirror";
    case TagRole::kPen: return "pen";
  }
  return "?";
}

Result<KitLayout> layout_station_kit(const ar::StationScene& station, const KitOptions& options) {
  auto plan = make_plan(station, options);
  if (!plan) return Error{plan.error()};
  return std::move(plan->layout);
}

Result<KitFiles> write_station_kit(const ar::StationScene& station, const KitOptions& options,
                                   const std::string& out_dir) {
  namespace fs = std::filesystem;
  auto plan_r = make_plan(station, options);
  if (!plan_r) return Error{plan_r.error()};
  const Plan& plan = *plan_r;
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec || !fs::is_directory(out_dir))
    return Error{out_dir + ": cannot create the output folder (" +
                 (ec ? ec.message() : std::string("a file of that name exists")) + ")"};
  const ar::TagFamily fam = ar::TagFamily::create(station.family);
  const double w_pt = plan.layout.page_size_m.x() * 1e3 * kPtPerMm;
  const double h_pt = plan.layout.page_size_m.y() * 1e3 * kPtPerMm;
  KitFiles files;
  files.layout = plan.layout;
  files.pdf = (fs::path(out_dir) / "station_kit.pdf").string();
  {
    cairo_surface_t* surface = cairo_pdf_surface_create(files.pdf.c_str(), w_pt, h_pt);
    cairo_pdf_surface_set_metadata(surface, CAIRO_PDF_METADATA_TITLE,
                                   ("DentAR station kit: " + station.name).c_str());
    cairo_pdf_surface_set_metadata(surface, CAIRO_PDF_METADATA_CREATOR, "dentar tags");
    cairo_t* cr = cairo_create(surface);
    for (int pg = 0; pg < plan.layout.pages; ++pg) {
      draw_page(cr, plan, fam, pg);
      cairo_show_page(cr);
    }
    if (Status s = finish(surface, cr, files.pdf); !s) return Error{s.error()};
  }
  for (int pg = 0; pg < plan.layout.pages; ++pg) {
    const std::string name =
        pg == 0 ? "station_kit.svg" : "station_kit_page" + std::to_string(pg + 1) + ".svg";
    const std::string path = (fs::path(out_dir) / name).string();
    cairo_surface_t* surface = cairo_svg_surface_create(path.c_str(), w_pt, h_pt);
    cairo_svg_surface_restrict_to_version(surface, CAIRO_SVG_VERSION_1_1);
    // Width and height in pt (not the default user units, which viewers take as 96 dpi px).
    cairo_svg_surface_set_document_unit(surface, CAIRO_SVG_UNIT_PT);
    cairo_t* cr = cairo_create(surface);
    draw_page(cr, plan, fam, pg);
    if (Status s = finish(surface, cr, path); !s) return Error{s.error()};
    files.svgs.push_back(path);
  }
  // Page files of an earlier, longer kit in the same folder would be mistaken for this one's.
  for (int pg = plan.layout.pages + 1;; ++pg) {
    const fs::path stale = fs::path(out_dir) / ("station_kit_page" + std::to_string(pg) + ".svg");
    if (!fs::exists(stale, ec)) break;
    fs::remove(stale, ec);
  }
  return files;
}

}  // namespace dentar::kit
