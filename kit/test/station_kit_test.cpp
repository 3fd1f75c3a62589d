// The station kit rendered back to pixels: the PDF through poppler's pdftoppm and the SVG
// through librsvg's rsvg-convert, at a known resolution. Every tag must be detected with its id
// by dentar's TagDetector where the layout put it, and the printed border squares and the 50 mm
// scale bar must measure right to 0.1 mm. Plus layout invariants and bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "dentar/ar/tag_detector.h"
#include "dentar/kit/station_kit.h"
#include "testutil.h"

namespace {

namespace fs = std::filesystem;
using dentar::ar::StationScene;
using dentar::kit::KitLayout;
using dentar::kit::KitOptions;
using dentar::kit::Paper;

constexpr double kDpi = 600;
constexpr double kPxPerM = kDpi / 0.0254;
constexpr double kTolMm = 0.1;

std::string quote(const fs::path& p) { return "'" + p.string() + "'"; }

// The rasterisers are Debian packages (tools/bootstrap.sh); CMake found them at configure time.
bool have_tool(const std::string& path, const char* package) {
  const bool ok = !path.empty() && path.find("NOTFOUND") == std::string::npos && fs::exists(path);
  EXPECT_TRUE(ok) << "no " << path << ": apt-get install " << package
                  << " (tools/bootstrap.sh lists it), then re-run cmake";
  return ok;
}

cv::Mat render_pdf_page(const fs::path& pdf, int page, const fs::path& dir, double dpi) {
  if (!have_tool(DENTAR_PDFTOPPM, "poppler-utils")) return {};
  const fs::path prefix = dir / ("pdf_page" + std::to_string(page + 1));
  const std::string cmd = std::string(DENTAR_PDFTOPPM) + " -r " + std::to_string(int(dpi)) +
                          " -gray -singlefile -f " + std::to_string(page + 1) + " -l " +
                          std::to_string(page + 1) + " " + quote(pdf) + " " + quote(prefix);
  const auto r = dentar::test::run_command(cmd);
  EXPECT_EQ(r.code, 0) << cmd << "\n" << r.out;
  return cv::imread(prefix.string() + ".pgm", cv::IMREAD_GRAYSCALE);
}

cv::Mat render_svg(const fs::path& svg, const fs::path& dir, double dpi) {
  if (!have_tool(DENTAR_RSVG_CONVERT, "librsvg2-bin")) return {};
  const fs::path png = dir / (svg.stem().string() + "_svg.png");
  const std::string d = std::to_string(int(dpi));
  const std::string cmd = std::string(DENTAR_RSVG_CONVERT) + " --dpi-x " + d + " --dpi-y " + d +
                          " -b white -f png -o " + quote(png) + " " + quote(svg);
  const auto r = dentar::test::run_command(cmd);
  EXPECT_EQ(r.code, 0) << cmd << "\n" << r.out;
  return cv::imread(png.string(), cv::IMREAD_GRAYSCALE);
}

// Page point (m, top-left origin) to OpenCV pixel coordinates (pixel centres at integers).
Eigen::Vector2d to_px(const Eigen::Vector2d& m, double px_per_m) {
  return m * px_per_m - Eigen::Vector2d::Constant(0.5);
}

struct PageErrors {
  double max_side_err_mm = 0;   // |measured border side - size_m|, over all tags and sides
  double max_corner_err_mm = 0;  // detected corner vs layout
  double bar_err_mm = 0;         // measured bar length - 50 mm
  int tags = 0;
};

// Checks one rendered page against the layout; prints one line per tag (the record quoted in
// docs/BENCHMARKS.md).
PageErrors check_page(const cv::Mat& img, const KitLayout& L, dentar::ar::TagFamilyId family,
                      int page, double dpi, const std::string& what) {
  PageErrors pe;
  const double ppm = dpi / 0.0254;
  EXPECT_FALSE(img.empty()) << what;
  if (img.empty()) return pe;
  // True page size: the rasteriser made the page as large as the paper at this resolution.
  EXPECT_NEAR(img.cols, L.page_size_m.x() * ppm, 1.5) << what;
  EXPECT_NEAR(img.rows, L.page_size_m.y() * ppm, 1.5) << what;

  dentar::ar::TagDetectorOptions o;
  o.families = {family};
  o.decimation = 2;
  auto det = dentar::ar::TagDetector::create(o);
  EXPECT_TRUE(det) << det.error();
  if (!det) return pe;
  auto found = det->detect(img);
  EXPECT_TRUE(found) << found.error();
  if (!found) return pe;

  std::vector<bool> used(found->size(), false);
  for (const dentar::kit::KitTag& t : L.tags) {
    if (t.page != page) continue;
    ++pe.tags;
    const std::string name = what + " " + dentar::kit::tag_role_name(t.role) + " id " +
                             std::to_string(t.id);
    const Eigen::Vector2d c = to_px(t.centre_m, ppm);
    int match = -1;
    for (std::size_t i = 0; i < found->size(); ++i) {
      const auto& d = (*found)[i];
      Eigen::Vector2d dc = Eigen::Vector2d::Zero();
      for (const auto& p : d.corners_px) dc += 0.25 * p;
      if (d.id == t.id && (dc - c).norm() < 2e-3 * ppm) {
        EXPECT_EQ(match, -1) << name << " detected twice";
        match = static_cast<int>(i);
      }
    }
    EXPECT_GE(match, 0) << name << " not detected";
    if (match < 0) continue;
    used[match] = true;
    const auto& d = (*found)[match];
    EXPECT_EQ(d.hamming, 0) << name;
    const double h = 0.5 * t.size_m;
    // Tag-frame corners (-h,+h), (+h,+h), (+h,-h), (-h,-h); tag x/y = page x/y (upright print).
    const Eigen::Vector2d corner_m[4] = {{-h, h}, {h, h}, {h, -h}, {-h, -h}};
    double side_err = 0, corner_err = 0;
    for (int k = 0; k < 4; ++k) {
      const double side_mm = (d.corners_px[(k + 1) % 4] - d.corners_px[k]).norm() / ppm * 1e3;
      side_err = std::max(side_err, std::abs(side_mm - t.size_m * 1e3));
      EXPECT_NEAR(side_mm, t.size_m * 1e3, kTolMm) << name << " side " << k;
      const Eigen::Vector2d want = to_px(t.centre_m + corner_m[k], ppm);
      const double ce = (d.corners_px[k] - want).norm() / ppm * 1e3;
      corner_err = std::max(corner_err, ce);
      EXPECT_LT(ce, 0.2) << name << " corner " << k;
    }
    std::printf("kit-measure %s: border %.1f mm, max side error %.4f mm, max corner offset %.4f mm\n",
                name.c_str(), t.size_m * 1e3, side_err, corner_err);
    pe.max_side_err_mm = std::max(pe.max_side_err_mm, side_err);
    pe.max_corner_err_mm = std::max(pe.max_corner_err_mm, corner_err);
  }
  for (std::size_t i = 0; i < found->size(); ++i)
    EXPECT_TRUE(used[i]) << what << ": unexpected detection id " << (*found)[i].id;

  // Scale bar: ink summed along rows through the bar's middle half, over a window 3 mm wider
  // than the bar on each side (antialiased edges count by their coverage).
  for (const auto& b : L.scale_bars) {
    if (b.page != page) continue;
    const int x0 = int(std::floor((b.top_left_m.x() - 3e-3) * ppm));
    const int x1 = int(std::ceil((b.top_left_m.x() + b.length_m + 3e-3) * ppm));
    const int y0 = int(std::ceil((b.top_left_m.y() + 0.25 * b.height_m) * ppm));
    const int y1 = int(std::floor((b.top_left_m.y() + 0.75 * b.height_m) * ppm));
    double sum = 0;
    int rows = 0;
    for (int y = y0; y <= y1; ++y, ++rows)
      for (int x = x0; x <= x1; ++x) sum += (255.0 - img.at<std::uint8_t>(y, x)) / 255.0;
    const double len_mm = sum / std::max(rows, 1) / ppm * 1e3;
    pe.bar_err_mm = len_mm - 50.0;
    EXPECT_NEAR(len_mm, 50.0, kTolMm) << what << " scale bar";
    std::printf("kit-measure %s scale bar: %.4f mm (error %+.4f mm)\n", what.c_str(), len_mm,
                len_mm - 50.0);
  }
  return pe;
}

// Every tag of every page of both outputs.
void check_kit(const StationScene& s, const KitOptions& o, const std::string& label,
               double dpi = kDpi) {
  const fs::path dir = dentar::test::temp_dir("kit_" + label);
  auto files = dentar::kit::write_station_kit(s, o, dir.string());
  ASSERT_TRUE(files) << files.error();
  const KitLayout& L = files->layout;
  ASSERT_EQ(files->svgs.size(), std::size_t(L.pages));
  const std::size_t expected_tags =
      s.mannequin_tags.size() + s.mirror_tags.size() + s.pen.tags.size();
  ASSERT_EQ(L.tags.size(), expected_tags);
  int pdf_tags = 0, svg_tags = 0;
  PageErrors worst;
  for (int pg = 0; pg < L.pages; ++pg) {
    const std::string p = label + " p" + std::to_string(pg + 1);
    const PageErrors a =
        check_page(render_pdf_page(files->pdf, pg, dir, dpi), L, s.family, pg, dpi, p + " pdf");
    const PageErrors b =
        check_page(render_svg(files->svgs[pg], dir, dpi), L, s.family, pg, dpi, p + " svg");
    pdf_tags += a.tags;
    svg_tags += b.tags;
    for (const PageErrors& e : {a, b}) {
      worst.max_side_err_mm = std::max(worst.max_side_err_mm, e.max_side_err_mm);
      worst.max_corner_err_mm = std::max(worst.max_corner_err_mm, e.max_corner_err_mm);
      worst.bar_err_mm = std::max(worst.bar_err_mm, std::abs(e.bar_err_mm));
    }
  }
  EXPECT_EQ(pdf_tags, int(expected_tags));
  EXPECT_EQ(svg_tags, int(expected_tags));
  std::printf("kit-measure %s summary at %.0f dpi: %d pages, %zu tags; worst border side error "
              "%.4f mm, worst corner offset %.4f mm, worst scale bar error %.4f mm\n",
              label.c_str(), dpi, L.pages, expected_tags, worst.max_side_err_mm,
              worst.max_corner_err_mm, worst.bar_err_mm);
  fs::remove_all(dir);
}

TEST(StationKit, DefaultStationA4EveryTagDetectedAtTrueScale) {
  check_kit(dentar::ar::default_station_scene(), KitOptions{}, "default_a4");
}

TEST(StationKit, Tag36h11OnLetterManyPages) {
  // 40 mannequin tags of four sizes in the normal-border family: several pages, every page's
  // tags and scale bar checked (at 300 dpi to keep the test short; 0.1 mm is 1.2 px there).
  StationScene s = dentar::ar::default_station_scene();
  s.family = dentar::ar::TagFamilyId::kTag36h11;
  s.name = "many tags";
  const double sizes[4] = {0.010, 0.020, 0.030, 0.050};
  s.mannequin_tags.clear();
  for (int i = 0; i < 40; ++i) {
    dentar::ar::TagPlacement t;
    t.id = 100 + i;
    t.size_m = sizes[i % 4];
    t.T_parent_tag.translation() = Eigen::Vector3d(0.01 * i, 0, 0);
    s.mannequin_tags.push_back(t);
  }
  KitOptions o;
  o.paper = Paper::kLetter;
  auto L = dentar::kit::layout_station_kit(s, o);
  ASSERT_TRUE(L) << L.error();
  EXPECT_GE(L->pages, 2);
  check_kit(s, o, "many_letter", 300);
}

// No tag's cut square or pen panel crosses a page margin, and no two items overlap.
void check_layout(const StationScene& s, const KitOptions& o) {
  auto L = dentar::kit::layout_station_kit(s, o);
  ASSERT_TRUE(L) << L.error();
  const Eigen::Vector2d lo = Eigen::Vector2d::Constant(o.margin_m);
  const Eigen::Vector2d hi = L->page_size_m - lo;
  for (const auto& t : L->tags) {
    const std::string n = std::string(dentar::kit::tag_role_name(t.role)) + " " +
                          std::to_string(t.id) + " on " + dentar::kit::paper_name(o.paper);
    EXPECT_TRUE((t.cut_min_m.array() >= lo.array() - 1e-12).all()) << n;
    EXPECT_TRUE((t.cut_max_m.array() <= hi.array() + 1e-12).all()) << n;
    // The pattern and its quiet zone lie inside the cut square / panel.
    const double half = 0.5 * t.pattern_m + t.quiet_m;
    EXPECT_TRUE((t.centre_m.array() - half >= t.cut_min_m.array() - 1e-12).all()) << n;
    EXPECT_TRUE((t.centre_m.array() + half <= t.cut_max_m.array() + 1e-12).all()) << n;
    EXPECT_LT(t.page, L->pages);
    for (const auto& u : L->tags) {
      if (&u == &t || u.page != t.page) continue;
      if (t.role == dentar::kit::TagRole::kPen && u.role == t.role) continue;  // same flag
      if (t.cut_min_m == u.cut_min_m && t.cut_max_m == u.cut_max_m) continue;  // same board
      const bool apart = (t.cut_max_m.array() <= u.cut_min_m.array() + 1e-12).any() ||
                         (u.cut_max_m.array() <= t.cut_min_m.array() + 1e-12).any();
      EXPECT_TRUE(apart) << n << " overlaps " << u.id;
    }
    for (const auto& b : L->scale_bars) {
      if (b.page == t.page) {
        EXPECT_GT(t.cut_min_m.y(), b.top_left_m.y() + b.height_m) << n << " under the header";
      }
    }
  }
  ASSERT_EQ(L->scale_bars.size(), std::size_t(L->pages));
  if (!s.pen.tags.empty()) {
    ASSERT_TRUE(L->pen.has_value());
    EXPECT_NEAR(L->pen->tip_distance_m, s.pen.T_ptag_tip.translation().norm(), 1e-12);
    EXPECT_TRUE((L->pen->tip_m.array() >= lo.array()).all());
    EXPECT_TRUE((L->pen->tip_m.array() <= hi.array()).all());
    // The tip mark sits where the station puts the tip, seen on the front panel.
    const Eigen::Vector3d tip = s.pen.T_ptag_tip.translation();
    EXPECT_NEAR((L->pen->tip_m - L->pen->front_centre_m - tip.head<2>()).norm(), 0, 1e-12);
    EXPECT_GE(L->pen->side_m, s.pen.flag_size_m);
  }
}

TEST(StationKit, LayoutStaysInsideThePageMarginsOnBothPapers) {
  for (Paper p : {Paper::kA4, Paper::kLetter}) {
    KitOptions o;
    o.paper = p;
    check_layout(dentar::ar::default_station_scene(), o);
  }
  StationScene big = dentar::ar::default_station_scene();
  for (auto& t : big.mannequin_tags) t.size_m = 0.05;  // 90 mm printed: several pages
  check_layout(big, KitOptions{});
}

// Issue 26: the kit's title ran off the page. Every line of text (its ink box at the weight it
// is drawn with) lies inside the page's margins, for the built-in stations and a station with
// a long name, on both papers; and the PDF as printed has no ink outside the margins.
TEST(StationKit, EveryLineOfTextFitsInsideThePageMargins) {
  StationScene long_name = dentar::ar::box_station_scene();
  long_name.name = "box: a flat board of 6 tags, printed for the third-floor skills laboratory, bench 12 of 24";
  int checked = 0;
  for (const StationScene& s : {dentar::ar::default_station_scene(), dentar::ar::box_station_scene(), long_name})
    for (Paper p : {Paper::kA4, Paper::kLetter}) {
      KitOptions o;
      o.paper = p;
      auto L = dentar::kit::layout_station_kit(s, o);
      ASSERT_TRUE(L) << L.error();
      ASSERT_FALSE(L->texts.empty());
      const Eigen::Vector2d lo = Eigen::Vector2d::Constant(o.margin_m), hi = L->page_size_m - lo;
      bool title_seen = false;
      for (const auto& t : L->texts) {
        EXPECT_GE(t.ink_min_m.x(), lo.x() - 1e-6) << s.name << ": " << t.text;
        EXPECT_GE(t.ink_min_m.y(), lo.y() - 1e-6) << s.name << ": " << t.text;
        EXPECT_LE(t.ink_max_m.x(), hi.x() + 1e-6) << s.name << ": " << t.text << " ends at "
                                                 << t.ink_max_m.x() * 1e3 << " mm, margin at " << hi.x() * 1e3;
        EXPECT_LE(t.ink_max_m.y(), hi.y() + 1e-6) << s.name << ": " << t.text;
        EXPECT_GT(t.ink_max_m.x(), t.ink_min_m.x()) << t.text;
        if (t.text.find(s.name) != std::string::npos) title_seen = true;
        ++checked;
      }
      EXPECT_TRUE(title_seen) << "the title names the station: " << s.name;
    }
  EXPECT_GT(checked, 50);
  // What cairo drew: the long-named kit's first page has no ink right of the margin.
  const fs::path dir = dentar::test::temp_dir("kit_text_fits");
  auto files = dentar::kit::write_station_kit(long_name, KitOptions{}, dir.string());
  ASSERT_TRUE(files) << files.error();
  const double dpi = 150, px_per_m = dpi / 0.0254;
  const cv::Mat img = render_pdf_page(files->pdf, 0, dir, dpi);
  ASSERT_FALSE(img.empty());
  const int x0 = static_cast<int>(std::ceil((files->layout.page_size_m.x() - KitOptions{}.margin_m) * px_per_m)) + 1;
  ASSERT_LT(x0, img.cols);
  double darkest = 255;
  cv::minMaxLoc(img.colRange(x0, img.cols), &darkest);
  EXPECT_GT(darkest, 200) << "ink right of the page margin (column " << x0 << " of " << img.cols << ")";
}

// The 20-tag head layout measured for issue 16 (MannequinLayout::kWrap20) prints on
// the same two pages as the default 12 on both papers, every tag placed once.
TEST(StationKit, WrapHeadLayoutPrintsOnTwoPages) {
  StationScene s = dentar::ar::default_station_scene();
  dentar::ar::set_mannequin_layout(s, dentar::ar::MannequinLayout::kWrap20);
  for (Paper p : {Paper::kA4, Paper::kLetter}) {
    KitOptions o;
    o.paper = p;
    check_layout(s, o);
    auto L = dentar::kit::layout_station_kit(s, o);
    ASSERT_TRUE(L) << L.error();
    EXPECT_EQ(L->pages, 2) << dentar::kit::paper_name(p);
    EXPECT_EQ(L->tags.size(), s.mannequin_tags.size() + s.mirror_tags.size() + s.pen.tags.size());
  }
}

// Six 20 mm tags on a box face around the mouth (coplanar, one orientation): tag x along the
// mannequin's x, tag y down (mannequin -y), facing the camera (+z of the mannequin).
StationScene box_station() {
  StationScene s = dentar::ar::default_station_scene();
  s.name = "box";
  s.mannequin_tags.clear();
  const double xs[3] = {-0.055, 0.0, 0.055}, ys[2] = {0.040, -0.040};
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 3; ++c) {
      dentar::ar::TagPlacement t;
      t.id = 3 * r + c;
      t.size_m = 0.020;
      t.T_parent_tag.linear() =
          Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
      t.T_parent_tag.translation() = Eigen::Vector3d(xs[c], ys[r], 0.0);
      s.mannequin_tags.push_back(t);
    }
  return s;
}

TEST(StationKit, CoplanarBundlePrintsAsOneBoardAtTheStationsSpacing) {
  const StationScene s = box_station();
  EXPECT_EQ(s.validate(), "");
  auto L = dentar::kit::layout_station_kit(s, KitOptions{});
  ASSERT_TRUE(L) << L.error();
  EXPECT_TRUE(L->mannequin_board);
  const dentar::kit::KitTag* t0 = nullptr;
  for (const auto& t : L->tags)
    if (t.role == dentar::kit::TagRole::kMannequin && t.index == 0) t0 = &t;
  ASSERT_NE(t0, nullptr);
  const Eigen::Matrix3d R0 = s.mannequin_tags[0].T_parent_tag.linear();
  for (const auto& t : L->tags) {
    if (t.role != dentar::kit::TagRole::kMannequin) continue;
    EXPECT_EQ(t.page, t0->page);
    // Page offset between tags = the station's offset in tag 0's image axes.
    const Eigen::Vector3d d = R0.transpose() * (s.mannequin_tags[t.index].T_parent_tag.translation() -
                                                s.mannequin_tags[0].T_parent_tag.translation());
    EXPECT_NEAR((t.centre_m - t0->centre_m - d.head<2>()).norm(), 0, 1e-9) << t.id;
  }
  check_layout(s, KitOptions{});
  // Rendered: every tag detected where the layout put it, sizes and corners within 0.1/0.2 mm
  // (check_page), so the printed spacing is the station's.
  check_kit(s, KitOptions{}, "box_board");

  // One tag tilted: loose tags again.
  StationScene bent = s;
  bent.mannequin_tags[4].T_parent_tag.linear() =
      bent.mannequin_tags[4].T_parent_tag.linear() *
      Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY()).toRotationMatrix();
  auto L2 = dentar::kit::layout_station_kit(bent, KitOptions{});
  ASSERT_TRUE(L2) << L2.error();
  EXPECT_FALSE(L2->mannequin_board);
  // The built-in station's tags sit on a curved head: loose tags.
  auto L3 = dentar::kit::layout_station_kit(dentar::ar::default_station_scene(), KitOptions{});
  ASSERT_TRUE(L3) << L3.error();
  EXPECT_FALSE(L3->mannequin_board);
}

TEST(StationKit, SmallPenFlagIsEnlargedWithANote) {
  // The default pen's 25 mm tagStandard41h12 tags print 45 mm wide (+ quiet zone): its 55 mm
  // flag fits them. A 40 mm flag does not: the kit keeps the tag size (tracking measures it),
  // prints the flag 55 mm wide and says so.
  StationScene s = dentar::ar::default_station_scene();
  auto L0 = dentar::kit::layout_station_kit(s, KitOptions{});
  ASSERT_TRUE(L0) << L0.error();
  ASSERT_TRUE(L0->pen.has_value());
  EXPECT_NEAR(L0->pen->side_m, 0.055, 1e-9);
  EXPECT_TRUE(L0->notes.empty());
  s.pen.flag_size_m = 0.04;
  auto L = dentar::kit::layout_station_kit(s, KitOptions{});
  ASSERT_TRUE(L) << L.error();
  ASSERT_TRUE(L->pen.has_value());
  EXPECT_NEAR(L->pen->side_m, 0.055, 1e-9);
  ASSERT_EQ(L->notes.size(), 1u);
  EXPECT_NE(L->notes[0].find("pen.flag_size"), std::string::npos) << L->notes[0];
  // A flag that is large enough is printed at its size, without a note.
  StationScene t = s;
  t.pen.flag_size_m = 0.06;
  auto L2 = dentar::kit::layout_station_kit(t, KitOptions{});
  ASSERT_TRUE(L2) << L2.error();
  EXPECT_NEAR(L2->pen->side_m, 0.06, 1e-12);
  EXPECT_TRUE(L2->notes.empty());
  // Front tag on the front panel, back tag on the back panel, both centred.
  int seen = 0;
  for (const auto& k : L2->tags) {
    if (k.role != dentar::kit::TagRole::kPen) continue;
    ++seen;
    const Eigen::Vector2d want = k.id == 30 ? L2->pen->front_centre_m : L2->pen->back_centre_m;
    EXPECT_NEAR((k.centre_m - want).norm(), 0, 1e-12) << k.id;
  }
  EXPECT_EQ(seen, 2);
}

TEST(StationKit, StationWithoutAPenHasNoFlag) {
  StationScene s = dentar::ar::default_station_scene();
  s.pen.tags.clear();
  auto L = dentar::kit::layout_station_kit(s, KitOptions{});
  ASSERT_TRUE(L) << L.error();
  EXPECT_FALSE(L->pen.has_value());
  EXPECT_EQ(L->pages, 1);
  EXPECT_EQ(L->tags.size(), s.mannequin_tags.size() + s.mirror_tags.size());
}

TEST(StationKit, PenTipBehindTheFlagIsStatedAndStillFits) {
  StationScene s = dentar::ar::default_station_scene();
  s.pen.T_ptag_tip.translation() = Eigen::Vector3d(0.01, 0.12, 0.004);  // 4 mm behind (pen radius)
  auto L = dentar::kit::layout_station_kit(s, KitOptions{});
  ASSERT_TRUE(L) << L.error();
  ASSERT_TRUE(L->pen.has_value());
  EXPECT_NEAR((L->pen->tip_m - L->pen->front_centre_m - Eigen::Vector2d(0.01, 0.12)).norm(), 0,
              1e-12);
  EXPECT_NEAR(L->pen->tip_distance_m, s.pen.T_ptag_tip.translation().norm(), 1e-12);
  check_layout(s, KitOptions{});
}

TEST(StationKitBadInput, TagTooLargeForThePaperNamesTheTagAndPaper) {
  StationScene s = dentar::ar::default_station_scene();
  s.mannequin_tags[3].size_m = 0.15;  // 270 mm printed
  auto L = dentar::kit::layout_station_kit(s, KitOptions{});
  ASSERT_FALSE(L);
  EXPECT_NE(L.error().find("mannequin_tags[3]"), std::string::npos) << L.error();
  EXPECT_NE(L.error().find("a4"), std::string::npos) << L.error();
  EXPECT_NE(L.error().find("--paper"), std::string::npos) << L.error();
}

TEST(StationKitBadInput, PenTagNotFlatOnTheFlag) {
  StationScene s = dentar::ar::default_station_scene();
  s.pen.tags[1].T_parent_tag.linear() =
      Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitX()).toRotationMatrix();
  auto L = dentar::kit::layout_station_kit(s, KitOptions{});
  ASSERT_FALSE(L);
  EXPECT_NE(L.error().find("pen.tags[1]"), std::string::npos) << L.error();
}

TEST(StationKitBadInput, PenTipTooFarForThePage) {
  StationScene s = dentar::ar::default_station_scene();
  s.pen.T_ptag_tip.translation() = Eigen::Vector3d(0, 0.40, 0);
  auto L = dentar::kit::layout_station_kit(s, KitOptions{});
  ASSERT_FALSE(L);
  EXPECT_NE(L.error().find("pen.T_ptag_tip"), std::string::npos) << L.error();
}

TEST(StationKitBadInput, InvalidStationAndOptions) {
  StationScene s = dentar::ar::default_station_scene();
  s.mirror_tags[0].id = 99999;
  auto L = dentar::kit::layout_station_kit(s, KitOptions{});
  ASSERT_FALSE(L);
  EXPECT_NE(L.error().find("mirror_tags[0]"), std::string::npos) << L.error();
  KitOptions o;
  o.margin_m = 0.001;
  auto L2 = dentar::kit::layout_station_kit(dentar::ar::default_station_scene(), o);
  ASSERT_FALSE(L2);
  EXPECT_NE(L2.error().find("margin"), std::string::npos) << L2.error();
  EXPECT_FALSE(dentar::kit::parse_paper("A5").has_value());
  EXPECT_EQ(dentar::kit::parse_paper("letter"), Paper::kLetter);
}

TEST(StationKitBadInput, OutputFolderIsAFile) {
  const fs::path dir = dentar::test::temp_dir("kit_outfile");
  const fs::path file = dir / "not_a_dir";
  dentar::test::write_file(file, "x");
  auto r = dentar::kit::write_station_kit(dentar::ar::default_station_scene(), KitOptions{},
                                          file.string());
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find(file.string()), std::string::npos) << r.error();
  fs::remove_all(dir);
}

TEST(StationKit, StaleSvgPagesAreRemoved) {
  // A many-page kit, then a one-page kit into the same folder: no leftover page files.
  const fs::path dir = dentar::test::temp_dir("kit_stale");
  StationScene big = dentar::ar::default_station_scene();
  for (auto& t : big.mannequin_tags) t.size_m = 0.05;
  auto a = dentar::kit::write_station_kit(big, KitOptions{}, dir.string());
  ASSERT_TRUE(a) << a.error();
  ASSERT_GE(a->svgs.size(), 2u);
  EXPECT_TRUE(fs::exists(dir / "station_kit_page2.svg"));
  StationScene small = dentar::ar::default_station_scene();
  small.pen.tags.clear();  // one page
  auto b = dentar::kit::write_station_kit(small, KitOptions{}, dir.string());
  ASSERT_TRUE(b) << b.error();
  EXPECT_EQ(b->svgs.size(), 1u);
  EXPECT_FALSE(fs::exists(dir / "station_kit_page2.svg"));
  fs::remove_all(dir);
}

}  // namespace
