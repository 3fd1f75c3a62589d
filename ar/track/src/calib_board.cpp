#include "dentar/ar/calib_board.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <sstream>

#include "dentar/ar/apriltags.h"
#include "dentar/ar/camera_model.h"
#include "charuco_detail.h"

namespace dentar::ar {
namespace {

using calibration::AprilGridSpec;
using calibration::BoardView;
using calibration::ChessboardSpec;

bool parse_wxh(const std::string& s, int& a, int& b) {
  const auto x = s.find('x');
  if (x == std::string::npos) return false;
  try {
    std::size_t n1 = 0, n2 = 0;
    a = std::stoi(s.substr(0, x), &n1);
    b = std::stoi(s.substr(x + 1), &n2);
    return n1 == x && n2 == s.size() - x - 1;
  } catch (...) {
    return false;
  }
}

bool parse_num(const std::string& s, double& v) {
  try {
    std::size_t n = 0;
    v = std::stod(s, &n);
    return n == s.size() && std::isfinite(v);
  } catch (...) {
    return false;
  }
}

// Board intensity (0 black .. 255 white) at board point (x, y), m.
struct BoardPainter {
  const BoardSpec& spec;
  std::vector<TagFamily> family;  // one entry for AprilTag grids
  std::vector<cv::Mat> cells;     // per tag

  explicit BoardPainter(const BoardSpec& s) : spec(s) {
    if (const auto* h = std::get_if<CharucoSpec>(&spec)) cells = charuco_marker_cells(*h);
    if (const auto* g = std::get_if<AprilGridSpec>(&spec)) {
      family.push_back(TagFamily::create(*parse_tag_family(g->family)));
      for (int k = 0; k < g->tag_count(); ++k)
        cells.push_back(family[0].cells((g->first_id + k) % family[0].code_count()));
    }
  }

  std::uint8_t at(double x, double y) const {
    if (const auto* c = std::get_if<ChessboardSpec>(&spec)) {
      const int i = static_cast<int>(std::floor(x / c->square_m)) + 1;  // square column 0..cols
      const int j = static_cast<int>(std::floor(y / c->square_m)) + 1;
      if (i < 0 || j < 0 || i > c->cols || j > c->rows) return 255;
      return (i + j) % 2 == 0 ? 0 : 255;
    }
    if (const auto* h = std::get_if<CharucoSpec>(&spec)) {
      // Square (i, j), column i of cols, row j of rows from the top-left.
      const int i = static_cast<int>(std::floor(x / h->square_m)) + 1;
      const int j = static_cast<int>(std::floor(y / h->square_m)) + 1;
      if (i < 0 || j < 0 || i >= h->cols || j >= h->rows) return 255;
      if (!h->white(i, j)) return 0;
      // The white squares, row-major: index (j * cols + i) / 2 in either layout.
      const cv::Mat& m = cells[static_cast<std::size_t>((j * h->cols + i) / 2)];
      const double pad = 0.5 * (h->square_m - h->marker_m);
      const double u = x - (i - 1) * h->square_m - pad, v = y - (j - 1) * h->square_m - pad;
      if (u < 0 || v < 0 || u >= h->marker_m || v >= h->marker_m) return 255;
      const int n = m.cols;
      const int cu = std::min(n - 1, static_cast<int>(std::floor(u / h->marker_m * n)));
      const int cv_ = std::min(n - 1, static_cast<int>(std::floor(v / h->marker_m * n)));
      return m.at<std::uint8_t>(cv_, cu);
    }
    const auto& g = std::get<AprilGridSpec>(spec);
    const TagFamily& f = family[0];
    const double pitch = g.tag_size_m + g.gap_m;
    if (g.kalibr) {
      // Kalibr: the tag's black square is 10 cells (2-cell border around the 6x6 bits); a black
      // square of side gap_m fills every gap crossing, the outside ones included.
      const int c = static_cast<int>(std::floor(x / pitch)), r = static_cast<int>(std::floor(y / pitch));
      const double u = x - c * pitch, v = y - r * pitch;  // from tag (r, c)'s top-left corner
      const bool in_gap_x = u >= g.tag_size_m, in_gap_y = v >= g.tag_size_m;
      if (c < -1 || r < -1 || c >= g.cols || r >= g.rows) return 255;
      if (in_gap_x && in_gap_y) return 0;  // a corner square (crossing right-below tag (r, c))
      if (c < 0 || r < 0 || in_gap_x || in_gap_y) return 255;
      const double cell = g.tag_size_m / 10;
      const int ci = std::min(9, static_cast<int>(std::floor(u / cell)));
      const int ri = std::min(9, static_cast<int>(std::floor(v / cell)));
      if (ci < 2 || ri < 2 || ci > 7 || ri > 7) return 0;
      // Kalibr's numbering (first tag bottom-left); tag36h11's bits sit at cells 2..7 too.
      return cells[(g.rows - 1 - r) * g.cols + c].at<std::uint8_t>(ri, ci);
    }
    const double cell = g.tag_size_m / f.width_at_border();
    const int c = static_cast<int>(std::floor((x + 0.5 * g.gap_m) / pitch));
    const int r = static_cast<int>(std::floor((y + 0.5 * g.gap_m) / pitch));
    if (c < 0 || r < 0 || c >= g.cols || r >= g.rows) return 255;
    // Offset from the tag's top-left image corner (the image extends border_start cells
    // beyond the border square).
    const double x0 = c * pitch - f.border_start() * cell, y0 = r * pitch - f.border_start() * cell;
    const int ci = static_cast<int>(std::floor((x - x0) / cell));
    const int ri = static_cast<int>(std::floor((y - y0) / cell));
    const int tw = f.total_width();
    if (ci < 0 || ri < 0 || ci >= tw || ri >= tw) return 255;
    return cells[r * g.cols + c].at<std::uint8_t>(ri, ci);
  }
};

}  // namespace

namespace {
// The forms of the --board text, for error messages.
constexpr const char* kFormChessboard = "chessboard:COLSxROWS:SQUARE_MM (inner corners, e.g. chessboard:9x6:25)";
constexpr const char* kFormAprilgrid = "aprilgrid:COLSxROWS:TAG_MM:GAP_MM[:FAMILY[:FIRST_ID]] (e.g. aprilgrid:6x5:24:8)";
constexpr const char* kFormKalibr =
    "kalibr:COLSxROWS:TAG_MM:SPACING_RATIO[:FIRST_ID] (tagCols x tagRows, tagSize, tagSpacing of Kalibr's "
    "aprilgrid.yaml; e.g. kalibr:6x6:88:0.3)";
constexpr const char* kFormCharuco =
    "charuco:COLSxROWS:SQUARE_MM:MARKER_MM:DICT[:FIRST_ID][:legacy] (squares, not inner corners; DICT one of "
    "OpenCV's; legacy: a board printed by OpenCV before 4.6; e.g. charuco:5x7:40:30:DICT_4X4_50)";

struct SpecFields {
  const std::string& text;
  const std::vector<std::string>& f;
  const char* form;
  Error bad(std::size_t i, const char* field, const std::string& want) const {
    return Error{"board \"" + text + "\": " + field + " \"" + (i < f.size() ? f[i] : std::string()) + "\" " + want +
                 "; the form is " + form};
  }
  Error count(std::size_t lo, std::size_t hi) const {
    std::string n = std::to_string(lo - 1);
    if (hi > lo) n += " to " + std::to_string(hi - 1);
    return Error{"board \"" + text + "\": " + f[0] + " takes " + n + " fields after the kind, got " +
                 std::to_string(f.size() - 1) + "; the form is " + form};
  }
};

// A whole id in 0..100000 (FIRST_ID).
bool parse_id(const std::string& s, int& id) {
  double v = 0;
  if (!parse_num(s, v) || !(v >= 0 && v <= 100000) || v != std::floor(v)) return false;
  id = static_cast<int>(v);
  return true;
}
}  // namespace

Result<BoardSpec> parse_board_spec(const std::string& text) {
  std::vector<std::string> f;
  std::stringstream ss(text);
  for (std::string part; std::getline(ss, part, ':');) f.push_back(part);
  const std::string help = std::string("; the forms are ") + kFormChessboard + ", " + kFormAprilgrid + ", " +
                           kFormKalibr + " or " + kFormCharuco;
  if (f.empty()) return Error{"board \"" + text + "\" is empty" + help};
  const std::string wxh = "must be two whole numbers joined by x (e.g. 9x6)";
  const std::string mm = "must be a number of millimetres";
  if (f[0] == "chessboard") {
    const SpecFields F{text, f, kFormChessboard};
    if (f.size() != 3) return F.count(3, 3);
    ChessboardSpec c;
    double sq = 0;
    if (!parse_wxh(f[1], c.cols, c.rows)) return F.bad(1, "COLSxROWS", wxh);
    if (!parse_num(f[2], sq)) return F.bad(2, "SQUARE_MM", mm);
    c.square_m = sq * 1e-3;
    if (std::string e = c.validate(); !e.empty()) return Error{"board \"" + text + "\": " + e + "; the form is " + kFormChessboard};
    return BoardSpec(c);
  }
  if (f[0] == "aprilgrid") {
    const SpecFields F{text, f, kFormAprilgrid};
    if (f.size() < 4 || f.size() > 6) return F.count(4, 6);
    AprilGridSpec g;
    double tag = 0, gap = 0;
    if (!parse_wxh(f[1], g.cols, g.rows)) return F.bad(1, "COLSxROWS", wxh);
    if (!parse_num(f[2], tag)) return F.bad(2, "TAG_MM", mm);
    if (!parse_num(f[3], gap)) return F.bad(3, "GAP_MM", mm);
    g.tag_size_m = tag * 1e-3;
    g.gap_m = gap * 1e-3;
    if (f.size() >= 5) {
      if (!parse_tag_family(f[4])) return F.bad(4, "FAMILY", "must be tag36h11 or tagStandard41h12");
      g.family = f[4];
    }
    if (f.size() == 6 && !parse_id(f[5], g.first_id)) return F.bad(5, "FIRST_ID", "must be a whole number in 0..100000");
    if (std::string e = g.validate(); !e.empty()) return Error{"board \"" + text + "\": " + e + "; the form is " + kFormAprilgrid};
    const TagFamily fam = TagFamily::create(*parse_tag_family(g.family));
    if (g.first_id + g.tag_count() > fam.code_count())
      return Error{"board \"" + text + "\": FIRST_ID: ids " + std::to_string(g.first_id) + ".." +
                   std::to_string(g.first_id + g.tag_count() - 1) + " exceed the family's " +
                   std::to_string(fam.code_count()) + " codes"};
    return BoardSpec(g);
  }
  if (f[0] == "kalibr") {
    const SpecFields F{text, f, kFormKalibr};
    if (f.size() < 4 || f.size() > 5) return F.count(4, 5);
    AprilGridSpec g;
    g.kalibr = true;
    g.family = "tag36h11";
    double tag = 0, ratio = 0;
    if (!parse_wxh(f[1], g.cols, g.rows)) return F.bad(1, "COLSxROWS", wxh);
    if (!parse_num(f[2], tag)) return F.bad(2, "TAG_MM", mm);
    if (!parse_num(f[3], ratio) || !(ratio > 0.05 && ratio <= 1))
      return F.bad(3, "SPACING_RATIO", "must be a number in (0.05, 1] (Kalibr's tagSpacing, e.g. 0.3)");
    g.tag_size_m = tag * 1e-3;
    g.gap_m = ratio * g.tag_size_m;
    if (f.size() == 5 && !parse_id(f[4], g.first_id)) return F.bad(4, "FIRST_ID", "must be a whole number in 0..100000");
    if (std::string e = g.validate(); !e.empty()) return Error{"board \"" + text + "\": " + e + "; the form is " + kFormKalibr};
    const TagFamily fam = TagFamily::create(TagFamilyId::kTag36h11);
    if (g.first_id + g.tag_count() > fam.code_count())
      return Error{"board \"" + text + "\": FIRST_ID: ids exceed tag36h11's " + std::to_string(fam.code_count()) + " codes"};
    return BoardSpec(g);
  }
  if (f[0] == "charuco") {
    CharucoSpec h;
    if (f.size() > 5 && f.back() == "legacy") {
      h.legacy = true;
      f.pop_back();
    }
    const SpecFields F{text, f, kFormCharuco};
    if (f.size() < 5 || f.size() > 6) return F.count(5, 6);
    double sq = 0, mk = 0;
    if (!parse_wxh(f[1], h.cols, h.rows)) return F.bad(1, "COLSxROWS", wxh + ", the squares (e.g. 5x7)");
    if (!parse_num(f[2], sq) || !(sq > 0)) return F.bad(2, "SQUARE_MM", "must be a positive number of millimetres");
    if (!parse_num(f[3], mk) || !(mk > 0)) return F.bad(3, "MARKER_MM", "must be a positive number of millimetres");
    const detail::CharucoDictionary d = detail::charuco_dictionary(f[4]);
    if (d.name.empty()) return F.bad(4, "DICT", "is not one of OpenCV's dictionaries: " + detail::charuco_dictionary_names());
    h.dictionary = d.name;
    if (f.size() == 6 && !parse_id(f[5], h.first_id)) return F.bad(5, "FIRST_ID", "must be a whole number in 0..100000");
    h.square_m = sq * 1e-3;
    h.marker_m = mk * 1e-3;
    if (std::string e = h.validate(); !e.empty()) return Error{"board \"" + text + "\": " + e + "; the form is " + kFormCharuco};
    return BoardSpec(h);
  }
  return Error{"board \"" + text + "\": unknown kind \"" + f[0] + "\"" + help};
}

std::string board_spec_to_string(const BoardSpec& spec) {
  std::ostringstream os;
  if (const auto* c = std::get_if<ChessboardSpec>(&spec)) {
    os << "chessboard:" << c->cols << "x" << c->rows << ":" << c->square_m * 1e3;
  } else if (const auto* h = std::get_if<CharucoSpec>(&spec)) {
    os << "charuco:" << h->cols << "x" << h->rows << ":" << h->square_m * 1e3 << ":" << h->marker_m * 1e3 << ":"
       << h->dictionary << ":" << h->first_id << (h->legacy ? ":legacy" : "");
  } else {
    const auto& g = std::get<AprilGridSpec>(spec);
    if (g.kalibr) {
      os << "kalibr:" << g.cols << "x" << g.rows << ":" << g.tag_size_m * 1e3 << ":" << g.gap_m / g.tag_size_m
         << ":" << g.first_id;
      return os.str();
    }
    os << "aprilgrid:" << g.cols << "x" << g.rows << ":" << g.tag_size_m * 1e3 << ":"
       << g.gap_m * 1e3 << ":" << g.family << ":" << g.first_id;
  }
  return os.str();
}

double board_width_m(const BoardSpec& spec) {
  if (const auto* c = std::get_if<ChessboardSpec>(&spec)) return (c->cols - 1) * c->square_m;
  if (const auto* h = std::get_if<CharucoSpec>(&spec)) return (h->cols - 2) * h->square_m;
  return std::get<AprilGridSpec>(spec).width_m();
}
double board_height_m(const BoardSpec& spec) {
  if (const auto* c = std::get_if<ChessboardSpec>(&spec)) return (c->rows - 1) * c->square_m;
  if (const auto* h = std::get_if<CharucoSpec>(&spec)) return (h->rows - 2) * h->square_m;
  return std::get<AprilGridSpec>(spec).height_m();
}

Result<BoardView> detect_aprilgrid(TagDetector& detector, const cv::Mat& gray,
                                   const AprilGridSpec& spec, const std::string& name,
                                   int min_tags) {
  auto fam = parse_tag_family(spec.family);
  if (!fam) return Error{name + ": unknown tag family " + spec.family};
  auto det = detector.detect(gray);
  if (!det) return Error{name + ": " + det.error()};
  BoardView v;
  v.name = name;
  int tags = 0;
  for (const DetectedTag& t : *det) {
    if (t.family != *fam || !spec.has_id(t.id)) continue;
    const auto corners = spec.tag_corners(t.id);
    for (int k = 0; k < 4; ++k) {
      v.image_points.push_back(t.corners_px[k]);
      v.object_points.push_back(corners[k]);
    }
    ++tags;
  }
  if (tags < min_tags) {
    std::ostringstream os;
    os << "board not found in " << name << " (" << tags << " tags of the " << spec.family
       << " grid seen, need " << min_tags << "): check --board (family, first id), focus and "
       << "lighting, and that the board fills a good part of the image";
    return Error{os.str()};
  }
  return v;
}

struct BoardDetector::Impl {
  BoardSpec spec;
  std::unique_ptr<TagDetector> tags;            // our AprilTag grids
  std::shared_ptr<detail::CharucoCv> charuco;  // ChArUco boards
};

Result<BoardDetector> BoardDetector::create(const BoardSpec& spec) {
  BoardDetector d;
  d.impl_ = std::make_shared<Impl>();
  d.impl_->spec = spec;
  if (const auto* g = std::get_if<AprilGridSpec>(&spec)) {
    if (std::string e = g->validate(); !e.empty()) return Error{"board: " + e};
    if (!g->kalibr) {
      TagDetectorOptions o;
      o.families = {*parse_tag_family(g->family)};
      o.decimation = 1.0;
      auto det = TagDetector::create(o);
      if (!det) return Error{"board: " + det.error()};
      d.impl_->tags = std::make_unique<TagDetector>(std::move(*det));
    }
  } else if (const auto* h = std::get_if<CharucoSpec>(&spec)) {
    if (std::string e = h->validate(); !e.empty()) return Error{"board: " + e};
    d.impl_->charuco = detail::make_charuco_cv(*h);
  } else if (std::string e = std::get<ChessboardSpec>(spec).validate(); !e.empty()) {
    return Error{"board: " + e};
  }
  return d;
}

const BoardSpec& BoardDetector::spec() const { return impl_->spec; }

Result<BoardView> BoardDetector::detect(const cv::Mat& image, const std::string& name) {
  if (image.empty()) return Error{name + ": empty image"};
  cv::Mat gray;
  if (image.type() == CV_8UC3)
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  else if (image.type() == CV_8UC1)
    gray = image;
  else
    return Error{name + ": unsupported pixel type (need 8-bit gray or BGR)"};
  if (!gray.isContinuous()) gray = gray.clone();
  const BoardSpec& spec = impl_->spec;
  if (const auto* c = std::get_if<ChessboardSpec>(&spec))
    return calibration::detect_chessboard(gray.data, gray.cols, gray.rows,
                                          static_cast<int>(gray.step[0]), *c, name);
  if (const auto* h = std::get_if<CharucoSpec>(&spec))
    return detail::detect_charuco_with(*impl_->charuco, gray, *h, name, 6, nullptr);
  const auto& g = std::get<AprilGridSpec>(spec);
  if (g.kalibr) return detect_kalibr_aprilgrid(gray, g, name);
  return detect_aprilgrid(*impl_->tags, gray, g, name);
}

Result<BoardView> detect_board(const cv::Mat& image, const BoardSpec& spec, const std::string& name) {
  auto d = BoardDetector::create(spec);
  if (!d) return Error{name + ": " + d.error()};
  return d->detect(image, name);
}

Result<BoardView> detect_board_file(const std::string& path, const BoardSpec& spec, int& width,
                                    int& height) {
  if (!std::filesystem::is_regular_file(path)) return Error{path + ": no such image file"};
  cv::Mat img;
  try {
    img = cv::imread(path, cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception& e) {
    return Error{path + ": cannot read the image: " + e.err};
  }
  if (img.empty())
    return Error{path + ": not an image OpenCV can read (give PNG or JPEG board photos)"};
  width = img.cols;
  height = img.rows;
  return detect_board(img, spec, path);
}

BoardTexture make_board_texture(const BoardSpec& spec, double px_per_m) {
  BoardPainter paint(spec);
  double margin = 0;
  if (const auto* c = std::get_if<ChessboardSpec>(&spec))
    margin = 2 * c->square_m;  // one square of pattern plus one of white margin
  else if (const auto* h = std::get_if<CharucoSpec>(&spec))
    margin = 1.5 * h->square_m;  // the outer squares plus half a square of white margin
  else
    margin = std::get<AprilGridSpec>(spec).tag_size_m * 0.5 + std::get<AprilGridSpec>(spec).gap_m;
  BoardTexture t;
  t.px_per_m = px_per_m;
  t.origin_m = Eigen::Vector2d(-margin, -margin);
  const double w = board_width_m(spec) + 2 * margin, h = board_height_m(spec) + 2 * margin;
  t.image.create(static_cast<int>(std::ceil(h * px_per_m)), static_cast<int>(std::ceil(w * px_per_m)),
                 CV_8UC1);
  for (int r = 0; r < t.image.rows; ++r)
    for (int c = 0; c < t.image.cols; ++c)
      t.image.at<std::uint8_t>(r, c) =
          paint.at(t.origin_m.x() + (c + 0.5) / px_per_m, t.origin_m.y() + (r + 0.5) / px_per_m);
  return t;
}

std::string BoardRenderOptions::validate() const {
  if (supersample < 1 || supersample > 8) return "supersample must be 1..8";
  if (!(blur_sigma_px >= 0 && blur_sigma_px < 20)) return "blur_sigma_px must be in [0, 20)";
  if (!(noise_sigma_dn >= 0 && noise_sigma_dn < 100)) return "noise_sigma_dn must be in [0, 100)";
  if (!(std::abs(warp_m) < 0.05)) return "warp_m must be below 5 cm";
  return {};
}

namespace {
// Undistorted normalised rays of every sample of an image, for one camera and supersampling:
// the iterative undistortion dominates a render, and a calibration session renders many views
// through the same camera. One cached table (the last camera used), guarded for safety.
struct RayTable {
  calibration::CameraIntrinsics k;
  int ss = 0;
  std::vector<Eigen::Vector2f> xn;  // row-major over (v, u, sy, sx)
};

bool same_camera(const calibration::CameraIntrinsics& a, const calibration::CameraIntrinsics& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy &&
         a.cx == b.cx && a.cy == b.cy && a.dist == b.dist;
}

std::shared_ptr<const RayTable> ray_table(const calibration::CameraIntrinsics& k, int ss) {
  static std::mutex mu;
  static std::shared_ptr<const RayTable> cached;
  std::lock_guard<std::mutex> lock(mu);
  if (cached && cached->ss == ss && same_camera(cached->k, k)) return cached;
  auto t = std::make_shared<RayTable>();
  t->k = k;
  t->ss = ss;
  t->xn.resize(static_cast<std::size_t>(k.width) * k.height * ss * ss);
  const CameraModel cam(k);
  std::size_t i = 0;
  for (int v = 0; v < k.height; ++v)
    for (int u = 0; u < k.width; ++u)
      for (int sy = 0; sy < ss; ++sy)
        for (int sx = 0; sx < ss; ++sx) {
          // Pixel (u, v) covers [u - 0.5, u + 0.5] (OpenCV convention).
          const double pu = u - 0.5 + (sx + 0.5) / ss, pv = v - 0.5 + (sy + 0.5) / ss;
          t->xn[i++] = cam.undistort(Eigen::Vector2d((pu - k.cx) / k.fx, (pv - k.cy) / k.fy))
                           .cast<float>();
        }
  cached = t;
  return cached;
}
}  // namespace

cv::Mat render_board_view(const BoardTexture& tex, const calibration::CameraIntrinsics& k,
                          const Eigen::Isometry3d& T_cam_board, const BoardRenderOptions& o) {
  const auto rays = ray_table(k, o.supersample);
  std::size_t ri = 0;
  const Eigen::Isometry3d T_board_cam = T_cam_board.inverse();
  const Eigen::Vector3d o_b = T_board_cam.translation();
  const Eigen::Matrix3d R_bc = T_board_cam.linear();
  // Board extent for the warp (points' bounding box).
  const double bx0 = tex.origin_m.x(), by0 = tex.origin_m.y();
  const double bw = tex.image.cols / tex.px_per_m, bh = tex.image.rows / tex.px_per_m;
  const int ss = o.supersample;
  cv::Mat acc(k.height, k.width, CV_32F, cv::Scalar(0));
  for (int v = 0; v < k.height; ++v)
    for (int u = 0; u < k.width; ++u) {
      float sum = 0;
      for (int sy = 0; sy < ss; ++sy)
        for (int sx = 0; sx < ss; ++sx) {
          const Eigen::Vector2d xn = rays->xn[ri++].cast<double>();
          const Eigen::Vector3d d_b = R_bc * Eigen::Vector3d(xn.x(), xn.y(), 1.0);
          double z0 = 0;
          double s = -1;
          Eigen::Vector3d p;
          // Plane z = z0 in the board frame; with a warp, re-intersect at the surface height
          // found at the previous hit (converges in a few steps for mm-scale bulges).
          for (int it = 0; it < (o.warp_m != 0 ? 5 : 1); ++it) {
            if (std::abs(d_b.z()) < 1e-12) break;
            s = (z0 - o_b.z()) / d_b.z();
            p = o_b + s * d_b;
            if (o.warp_m == 0) break;
            const double a = 2 * (p.x() - bx0) / bw - 1, b = 2 * (p.y() - by0) / bh - 1;
            z0 = (std::abs(a) < 1 && std::abs(b) < 1) ? -o.warp_m * (1 - a * a) * (1 - b * b) : 0;
          }
          float val = o.background;
          if (s > 0) {
            const double tx = (p.x() - tex.origin_m.x()) * tex.px_per_m - 0.5;
            const double ty = (p.y() - tex.origin_m.y()) * tex.px_per_m - 0.5;
            if (tx >= 0 && ty >= 0 && tx < tex.image.cols - 1 && ty < tex.image.rows - 1) {
              const int x0 = static_cast<int>(tx), y0 = static_cast<int>(ty);
              const double fx = tx - x0, fy = ty - y0;
              const auto T = [&](int yy, int xx) { return static_cast<double>(tex.image.at<std::uint8_t>(yy, xx)); };
              // Printed paper is not pure black/white: map 0..255 to 25..230.
              const double t = (1 - fy) * ((1 - fx) * T(y0, x0) + fx * T(y0, x0 + 1)) +
                               fy * ((1 - fx) * T(y0 + 1, x0) + fx * T(y0 + 1, x0 + 1));
              val = static_cast<float>(25 + t * (205.0 / 255.0));
            }
          }
          sum += val;
        }
      acc.at<float>(v, u) = sum / (ss * ss);
    }
  if (o.blur_sigma_px > 0) cv::GaussianBlur(acc, acc, cv::Size(0, 0), o.blur_sigma_px);
  if (o.noise_sigma_dn > 0) {
    std::mt19937_64 rng(o.seed);
    std::normal_distribution<float> n(0.0f, static_cast<float>(o.noise_sigma_dn));
    for (int v = 0; v < acc.rows; ++v)
      for (int u = 0; u < acc.cols; ++u) acc.at<float>(v, u) += n(rng);
  }
  cv::Mat out;
  acc.convertTo(out, CV_8U);  // saturating
  return out;
}

std::vector<Eigen::Vector2d> project_board_points(const BoardSpec& spec,
                                                  const calibration::CameraIntrinsics& k,
                                                  const Eigen::Isometry3d& T_cam_board) {
  std::vector<Eigen::Vector3d> pts;
  if (const auto* c = std::get_if<ChessboardSpec>(&spec))
    pts = c->object_points();
  else if (const auto* h = std::get_if<CharucoSpec>(&spec))
    pts = h->object_points();
  else {
    const auto& g = std::get<AprilGridSpec>(spec);
    for (int id = g.first_id; id < g.first_id + g.tag_count(); ++id)
      for (const auto& p : g.tag_corners(id)) pts.push_back(p);
  }
  std::vector<Eigen::Vector2d> out;
  for (const auto& p : pts) {
    Eigen::Vector2d px(NAN, NAN);
    calibration::project_point(k, T_cam_board * p, px);
    out.push_back(px);
  }
  return out;
}

SimulatedBoardSession simulate_board_session(const BoardSpec& spec,
                                             const calibration::CameraIntrinsics& k, int count,
                                             std::uint64_t seed, int bad_view, double bad_warp_m,
                                             const BoardRenderOptions& options) {
  SimulatedBoardSession s;
  const BoardTexture tex = make_board_texture(spec);
  s.T_cam_board = calibration::plan_board_poses(k, board_width_m(spec), board_height_m(spec), count, seed);
  for (int i = 0; i < count; ++i) {
    BoardRenderOptions o = options;
    o.seed = seed * 1000 + i;
    if (i == bad_view) o.warp_m = bad_warp_m;
    s.images.push_back(render_board_view(tex, k, s.T_cam_board[i], o));
  }
  return s;
}

}  // namespace dentar::ar
