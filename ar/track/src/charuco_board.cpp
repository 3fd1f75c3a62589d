// ChArUco boards: see calib_board.h (CharucoSpec, detect_charuco) for the layout and the method.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <opencv2/aruco.hpp>
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "charuco_detail.h"

namespace dentar::ar {
namespace detail {

namespace {
struct DictName {
  const char* name;
  cv::aruco::PREDEFINED_DICTIONARY_NAME id;
};
// OpenCV 4.6's predefined dictionaries, by their enum names.
constexpr DictName kDictionaries[] = {
    {"DICT_4X4_50", cv::aruco::DICT_4X4_50},       {"DICT_4X4_100", cv::aruco::DICT_4X4_100},
    {"DICT_4X4_250", cv::aruco::DICT_4X4_250},     {"DICT_4X4_1000", cv::aruco::DICT_4X4_1000},
    {"DICT_5X5_50", cv::aruco::DICT_5X5_50},       {"DICT_5X5_100", cv::aruco::DICT_5X5_100},
    {"DICT_5X5_250", cv::aruco::DICT_5X5_250},     {"DICT_5X5_1000", cv::aruco::DICT_5X5_1000},
    {"DICT_6X6_50", cv::aruco::DICT_6X6_50},       {"DICT_6X6_100", cv::aruco::DICT_6X6_100},
    {"DICT_6X6_250", cv::aruco::DICT_6X6_250},     {"DICT_6X6_1000", cv::aruco::DICT_6X6_1000},
    {"DICT_7X7_50", cv::aruco::DICT_7X7_50},       {"DICT_7X7_100", cv::aruco::DICT_7X7_100},
    {"DICT_7X7_250", cv::aruco::DICT_7X7_250},     {"DICT_7X7_1000", cv::aruco::DICT_7X7_1000},
    {"DICT_ARUCO_ORIGINAL", cv::aruco::DICT_ARUCO_ORIGINAL},
    {"DICT_APRILTAG_16h5", cv::aruco::DICT_APRILTAG_16h5},
    {"DICT_APRILTAG_25h9", cv::aruco::DICT_APRILTAG_25h9},
    {"DICT_APRILTAG_36h10", cv::aruco::DICT_APRILTAG_36h10},
    {"DICT_APRILTAG_36h11", cv::aruco::DICT_APRILTAG_36h11},
};

std::string upper(std::string s) {
  for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}
}  // namespace

CharucoDictionary charuco_dictionary(const std::string& name) {
  std::string u = upper(name);
  if (u.rfind("DICT_", 0) != 0) u = "DICT_" + u;
  for (const DictName& d : kDictionaries)
    if (upper(d.name) == u) {
      const cv::Ptr<cv::aruco::Dictionary> dict = cv::aruco::getPredefinedDictionary(d.id);
      return CharucoDictionary{d.name, static_cast<int>(d.id), dict->bytesList.rows};
    }
  return {};
}

std::string charuco_dictionary_names() {
  std::string s;
  for (const DictName& d : kDictionaries) s += (s.empty() ? "" : ", ") + std::string(d.name);
  return s;
}

struct CharucoCv {
  cv::Ptr<cv::aruco::Dictionary> dictionary;
  cv::Ptr<cv::aruco::CharucoBoard> board;
  cv::Ptr<cv::aruco::DetectorParameters> params;
};

std::shared_ptr<CharucoCv> make_charuco_cv(const CharucoSpec& spec) {
  auto c = std::make_shared<CharucoCv>();
  c->dictionary = cv::aruco::getPredefinedDictionary(charuco_dictionary(spec.dictionary).id);
  c->board = cv::aruco::CharucoBoard::create(spec.cols, spec.rows, static_cast<float>(spec.square_m),
                                             static_cast<float>(spec.marker_m), c->dictionary);
  if (spec.legacy && spec.rows % 2 == 0) {
    // The pre-4.6 layout: the markers on the other squares. OpenCV 4.6 builds only its own
    // layout; its board's public geometry is rewritten here: each marker's corners (in OpenCV's
    // corner order, taken from its own first marker relative to that marker's square) moved to
    // the legacy squares, then for every chessboard corner the markers next to it and their
    // nearest corners (what interpolateCornersCharuco's local homographies use).
    const float sq = static_cast<float>(spec.square_m);
    const std::vector<cv::Point3f> ref = c->board->objPoints[0];  // the marker in square (1, 0)
    std::vector<std::vector<cv::Point3f>> obj;
    for (int j = 0; j < spec.rows; ++j)
      for (int i = 0; i < spec.cols; ++i) {
        if (!spec.white(i, j)) continue;
        std::vector<cv::Point3f> m;
        for (const cv::Point3f& p : ref) m.emplace_back(p.x + (i - 1) * sq, p.y + j * sq, p.z);
        obj.push_back(m);
      }
    c->board->objPoints = obj;
    c->board->nearestMarkerIdx.assign(c->board->chessboardCorners.size(), {});
    c->board->nearestMarkerCorners.assign(c->board->chessboardCorners.size(), {});
    for (std::size_t k = 0; k < c->board->chessboardCorners.size(); ++k) {
      const cv::Point3f q = c->board->chessboardCorners[k];
      // The markers whose centre is nearest (the two beside an inner corner, at sqrt(2)/2 squares).
      std::vector<std::pair<double, int>> d;
      for (std::size_t m = 0; m < obj.size(); ++m) {
        const cv::Point3f ctr = (obj[m][0] + obj[m][1] + obj[m][2] + obj[m][3]) * 0.25f;
        d.emplace_back(cv::norm(ctr - q), static_cast<int>(m));
      }
      std::sort(d.begin(), d.end());
      for (const auto& [dist, m] : d) {
        if (dist > d[0].first + 1e-3 * sq) break;
        int best = 0;
        for (int e = 1; e < 4; ++e)
          if (cv::norm(obj[static_cast<std::size_t>(m)][static_cast<std::size_t>(e)] - q) <
              cv::norm(obj[static_cast<std::size_t>(m)][static_cast<std::size_t>(best)] - q))
            best = e;
        c->board->nearestMarkerIdx[k].push_back(m);
        c->board->nearestMarkerCorners[k].push_back(best);
      }
    }
  }
  // OpenCV numbers the markers from 0; a board printed with an offset (several boards in one
  // room) starts at first_id.
  std::vector<int> ids(c->board->ids.size());
  for (std::size_t k = 0; k < ids.size(); ++k) ids[k] = spec.first_id + static_cast<int>(k);
  c->board->ids = ids;
  c->params = cv::aruco::DetectorParameters::create();
  return c;
}

Result<calibration::BoardView> detect_charuco_with(CharucoCv& c, const cv::Mat& gray, const CharucoSpec& spec,
                                                   const std::string& name, int min_corners, CharucoStats* stats) {
  if (gray.empty() || gray.type() != CV_8UC1) return Error{name + ": need an 8-bit grey image"};
  std::vector<std::vector<cv::Point2f>> corners, rejected;
  std::vector<int> ids;
  cv::aruco::detectMarkers(gray, c.dictionary, corners, ids, c.params, rejected);
  // Keep the board's own markers only (another board or stray markers in view).
  std::vector<std::vector<cv::Point2f>> mc;
  std::vector<int> mi;
  for (std::size_t i = 0; i < ids.size(); ++i)
    if (ids[i] >= spec.first_id && ids[i] < spec.first_id + spec.marker_count()) {
      mc.push_back(corners[i]);
      mi.push_back(ids[i]);
    }
  if (!mi.empty())
    cv::aruco::refineDetectedMarkers(gray, c.board, mc, mi, rejected);
  std::vector<cv::Point2f> cc;
  std::vector<int> ci;
  if (mi.size() >= 2) cv::aruco::interpolateCornersCharuco(mc, mi, gray, c.board, cc, ci);
  // OpenCV 4.6 places every ChArUco corner (+0.5, +0.5) px from the truth on our rendered views
  // (measured: mean offset 0.51, 0.50 px over 48 corners; docs/BENCHMARKS.md issue 28 session 15),
  // a half-pixel convention slip. Each corner is placed again here by cornerSubPix on the image,
  // its window inside the white margin between the corner and the markers around it (the
  // margin in pixels from the distance to the nearest other corner, about one square); a corner
  // whose refinement moves farther than its window is dropped.
  std::vector<cv::Point2f> refined;
  std::vector<int> keep;
  for (std::size_t i = 0; i < ci.size() && i < cc.size(); ++i) {
    double near = 1e9;
    for (std::size_t j = 0; j < cc.size(); ++j)
      if (j != i) near = std::min(near, static_cast<double>(cv::norm(cc[i] - cc[j])));
    if (near > 1e8) near = 2 * std::sqrt(static_cast<double>(gray.total()));  // a lone corner
    const double margin_px = near * 0.5 * (spec.square_m - spec.marker_m) / spec.square_m;
    // 0.8 of the margin: 1.0 was as good (0.097 against 0.101 px on the benchmark's views),
    // 1.3 and more reach into the markers' borders and double the error (docs/BENCHMARKS.md).
    const int win = std::clamp(static_cast<int>(std::floor(0.8 * margin_px)), 2, 10);
    const cv::Point2f p = cc[i];
    if (p.x < win + 1 || p.y < win + 1 || p.x >= gray.cols - win - 2 || p.y >= gray.rows - win - 2) continue;
    std::vector<cv::Point2f> one{p};
    cv::cornerSubPix(gray, one, cv::Size(win, win), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 40, 0.01));
    if (cv::norm(one[0] - p) > win) continue;
    refined.push_back(one[0]);
    keep.push_back(ci[i]);
  }
  cc = refined;
  ci = keep;
  calibration::BoardView v;
  v.name = name;
  const std::vector<Eigen::Vector3d> obj = spec.object_points();
  for (std::size_t i = 0; i < ci.size() && i < cc.size(); ++i) {
    if (ci[i] < 0 || ci[i] >= static_cast<int>(obj.size())) continue;
    v.image_points.emplace_back(cc[i].x, cc[i].y);
    v.object_points.push_back(obj[static_cast<std::size_t>(ci[i])]);
  }
  if (stats) {
    stats->markers = static_cast<int>(mi.size());
    stats->corners = static_cast<int>(v.image_points.size());
  }
  if (static_cast<int>(v.image_points.size()) < min_corners) {
    std::ostringstream os;
    os << "board not found in " << name << " (" << mi.size() << " markers and " << v.image_points.size()
       << " corners of the ChArUco board seen, need " << min_corners
       << " corners): check --board (charuco:COLSxROWS squares, not inner corners; the dictionary "
       << spec.dictionary << "; first id), focus and lighting";
    return Error{os.str()};
  }
  return v;
}

}  // namespace detail

std::string CharucoSpec::validate() const {
  std::ostringstream os;
  if (cols < 3 || rows < 3 || cols > 100 || rows > 100)
    os << "ChArUco squares " << cols << "x" << rows << " must be 3..100 each";
  else if (!(std::isfinite(square_m) && square_m > 0 && square_m < 1))
    os << "ChArUco square size " << square_m << " m must be in (0, 1) m";
  else if (!(std::isfinite(marker_m) && marker_m > 0.2 * square_m && marker_m < square_m))
    os << "ChArUco marker size " << marker_m << " m must be between 0.2 and 1 times the square (" << square_m
       << " m)";
  else if (first_id < 0 || first_id > 100000)
    os << "ChArUco first id " << first_id << " must be in 0..100000";
  else {
    const detail::CharucoDictionary d = detail::charuco_dictionary(dictionary);
    if (d.name.empty())
      os << "ChArUco dictionary \"" << dictionary << "\" is not one of OpenCV's: " << detail::charuco_dictionary_names();
    else if (first_id + marker_count() > d.codes)
      os << "ChArUco board needs marker ids " << first_id << ".." << first_id + marker_count() - 1 << " but "
         << d.name << " has " << d.codes << " codes";
  }
  return os.str();
}

std::vector<Eigen::Vector3d> CharucoSpec::object_points() const {
  std::vector<Eigen::Vector3d> p;
  for (int r = 0; r + 1 < rows; ++r)
    for (int c = 0; c + 1 < cols; ++c) p.emplace_back(c * square_m, r * square_m, 0.0);
  return p;
}

Result<calibration::BoardView> detect_charuco(const cv::Mat& gray, const CharucoSpec& spec, const std::string& name,
                                              int min_corners, CharucoStats* stats) {
  if (std::string e = spec.validate(); !e.empty()) return Error{name + ": " + e};
  auto c = detail::make_charuco_cv(spec);
  return detail::detect_charuco_with(*c, gray, spec, name, min_corners, stats);
}

std::vector<cv::Mat> charuco_marker_cells(const CharucoSpec& spec) {
  const detail::CharucoDictionary d = detail::charuco_dictionary(spec.dictionary);
  std::vector<cv::Mat> out;
  if (d.name.empty()) return out;
  const cv::Ptr<cv::aruco::Dictionary> dict =
      cv::aruco::getPredefinedDictionary(static_cast<cv::aruco::PREDEFINED_DICTIONARY_NAME>(d.id));
  for (int k = 0; k < spec.marker_count(); ++k) {
    cv::Mat m;
    cv::aruco::drawMarker(dict, spec.first_id + k, dict->markerSize + 2, m, 1);
    out.push_back(m);
  }
  return out;
}

}  // namespace dentar::ar
