#include "dentar/calibration/intrinsics.h"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <iomanip>
#include <limits>
#include <numbers>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <sstream>

#include "dentar/calibration/chessboard_grid.h"
#include "intrinsics_detail.h"

namespace dentar::calibration {
namespace detail {

CalibRun run_calibration(const std::vector<BoardView>& views, const std::vector<int>& subset,
                         int width, int height, DistortionModel model) {
  CalibRun r;
  std::vector<std::vector<cv::Point3f>> obj;
  std::vector<std::vector<cv::Point2f>> img;
  for (int i : subset) {
    std::vector<cv::Point3f> o;
    std::vector<cv::Point2f> p;
    for (std::size_t j = 0; j < views[i].image_points.size(); ++j) {
      const auto& q = views[i].object_points[j];
      const auto& x = views[i].image_points[j];
      o.emplace_back(static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()));
      p.emplace_back(static_cast<float>(x.x()), static_cast<float>(x.y()));
    }
    obj.push_back(std::move(o));
    img.push_back(std::move(p));
  }
  int flags = 0;
  if (model == DistortionModel::kRational8) flags |= cv::CALIB_RATIONAL_MODEL;
  if (model == DistortionModel::kK1)
    flags |= cv::CALIB_FIX_K2 | cv::CALIB_FIX_K3 | cv::CALIB_ZERO_TANGENT_DIST;
  if (model == DistortionModel::kK1K2) flags |= cv::CALIB_FIX_K3 | cv::CALIB_ZERO_TANGENT_DIST;
  cv::Mat std_ext, per_view;
  try {
    r.rms = cv::calibrateCamera(obj, img, cv::Size(width, height), r.K, r.D, r.rvecs, r.tvecs,
                                r.std_int, std_ext, per_view, flags,
                                cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS,
                                                 100, 1e-12));
  } catch (const cv::Exception& e) {
    r.error = "OpenCV calibrateCamera failed: " + e.err;
    return r;
  }
  if (!std::isfinite(r.rms) || !cv::checkRange(r.K) || !cv::checkRange(r.D)) {
    r.error = "the calibration did not converge (non-finite result)";
    return r;
  }
  per_view.convertTo(per_view, CV_64F);
  r.per_view.assign(per_view.begin<double>(), per_view.end<double>());
  r.ok = true;
  return r;
}

}  // namespace detail

namespace {
using detail::CalibRun;
using detail::run_calibration;

constexpr double kDeg = 180.0 / std::numbers::pi;

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace

Eigen::Isometry3d detail::to_iso(const cv::Mat& rvec, const cv::Mat& tvec) {
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) T.linear()(a, b) = R.at<double>(a, b);
    T.translation()(a) = tvec.at<double>(a);
  }
  return T;
}

namespace {
using detail::to_iso;
}  // namespace

const char* distortion_model_name(DistortionModel m) {
  switch (m) {
    case DistortionModel::kK1: return "k1";
    case DistortionModel::kK1K2: return "k1k2";
    case DistortionModel::kRadTan5: return "radtan5";
    case DistortionModel::kRational8: return "rational8";
  }
  return "?";
}

std::string ChessboardSpec::validate() const {
  std::ostringstream os;
  if (cols < 2 || rows < 2 || cols > 100 || rows > 100)
    os << "chessboard inner corners " << cols << "x" << rows << " must be 2..100 each";
  else if (!(std::isfinite(square_m) && square_m > 0 && square_m < 1))
    os << "chessboard square size " << square_m << " m must be in (0, 1) m";
  return os.str();
}

std::vector<Eigen::Vector3d> ChessboardSpec::object_points() const {
  std::vector<Eigen::Vector3d> p;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) p.emplace_back(c * square_m, r * square_m, 0.0);
  return p;
}

std::string AprilGridSpec::validate() const {
  std::ostringstream os;
  if (cols < 1 || rows < 1 || cols > 500 || rows > 500 || cols * rows > 500)  // no int overflow
    os << "AprilTag grid " << cols << "x" << rows << " must have 1..500 tags";
  else if (!(std::isfinite(tag_size_m) && tag_size_m > 0 && tag_size_m < 1))
    os << "AprilTag grid tag size " << tag_size_m << " m must be in (0, 1) m";
  else if (!(std::isfinite(gap_m) && gap_m >= 0 && gap_m < 1))
    os << "AprilTag grid gap " << gap_m << " m must be in [0, 1) m";
  else if (family != "tag36h11" && family != "tagStandard41h12")
    os << "AprilTag grid family \"" << family << "\" must be tag36h11 or tagStandard41h12";
  else if (first_id < 0)
    os << "AprilTag grid first id " << first_id << " must be >= 0";
  else if (kalibr && (family != "tag36h11" || !(gap_m > 0)))
    os << "Kalibr AprilGrid: family must be tag36h11 and the spacing > 0 (it is " << family << ", " << gap_m << " m)";
  return os.str();
}

std::array<Eigen::Vector3d, 4> AprilGridSpec::tag_corners(int id) const {
  const int k = id - first_id;
  // Kalibr prints its first tag bottom-left and counts rows up the page.
  const int r = kalibr ? rows - 1 - k / cols : k / cols, c = k % cols;
  const double s = tag_size_m, h = s / 2;
  const Eigen::Vector3d centre((c + 0.5) * s + c * gap_m, (r + 0.5) * s + r * gap_m, 0);
  return {centre + Eigen::Vector3d(-h, h, 0), centre + Eigen::Vector3d(h, h, 0),
          centre + Eigen::Vector3d(h, -h, 0), centre + Eigen::Vector3d(-h, -h, 0)};
}

namespace {
// findChessboardCornersSB's corners carry a bias that varies over the image: on generated views
// (ar::render_board_view, truth known) it pulls the calibrated principal point 0.2-0.6 px to the
// left on every seed, with 12 views as with 36, while the same views' corners refined by
// cornerSubPix (the saddle of the image gradient in a window) give errors centred on zero
// (docs/BENCHMARKS.md, issue 24 session 11). So the sector-based detector finds the board
// (robust ordering, blur and perspective) and cornerSubPix places the corners. Its window is
// kept inside the squares: half-width 0.4x the smallest corner spacing in the view, at most 11
// px (OpenCV's sample uses 11 at any size) and at least 2; a corner the refinement moves
// farther than half that window (it slid to another edge) keeps the finder's position. The
// classic finder's fallback is refined the same way: OpenCV's fixed 11 px window slides a whole
// column of left02.jpg's corners 2-8 px onto the board's edge (calibration session 19).
void refine_corners_in_squares(const cv::Mat& img, const ChessboardSpec& spec, std::vector<cv::Point2f>& corners) {
  std::vector<Eigen::Vector2d> p;
  p.reserve(corners.size());
  for (const cv::Point2f& q : corners) p.emplace_back(q.x, q.y);
  refine_chessboard_corners(img.data, img.cols, img.rows, static_cast<int>(img.step), spec.cols, spec.rows, p);
  for (std::size_t i = 0; i < corners.size(); ++i)
    corners[i] = cv::Point2f(static_cast<float>(p[i].x()), static_cast<float>(p[i].y()));
}

std::string grid_text(const GridSmoothness& g) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(2) << "corner (row " << g.row << ", column " << g.col << ") is "
     << g.worst_px << " px off the line of its two neighbours along the " << (g.along_row ? "row" : "column")
     << ", " << g.worst_ratio << " of their half-distance (a smooth grid stays within " << kMaxGridSecondDifference
     << ")";
  return os.str();
}
}  // namespace

int refine_chessboard_corners(const std::uint8_t* gray, int width, int height, int stride_bytes, int cols, int rows,
                              std::vector<Eigen::Vector2d>& points) {
  if (gray == nullptr || width < 1 || height < 1 || stride_bytes < width || cols < 1 || rows < 1 ||
      points.size() != static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows))
    return 0;
  const cv::Mat img(height, width, CV_8UC1, const_cast<std::uint8_t*>(gray), static_cast<std::size_t>(stride_bytes));
  double spacing = 1e9;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      const Eigen::Vector2d& p = points[static_cast<std::size_t>(r * cols + c)];
      if (c + 1 < cols) spacing = std::min(spacing, (points[static_cast<std::size_t>(r * cols + c + 1)] - p).norm());
      if (r + 1 < rows) spacing = std::min(spacing, (points[static_cast<std::size_t>((r + 1) * cols + c)] - p).norm());
    }
  const int half = std::clamp(static_cast<int>(0.4 * spacing), 2, 11);
  std::vector<cv::Point2f> refined;
  refined.reserve(points.size());
  for (const Eigen::Vector2d& p : points) refined.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
  cv::cornerSubPix(img, refined, cv::Size(half, half), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-3));
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector2d q(refined[i].x, refined[i].y);
    if (q.allFinite() && (q - points[i]).norm() <= 0.5 * half) points[i] = q;
  }
  return half;
}

GridSmoothness chessboard_grid_smoothness(const std::vector<Eigen::Vector2d>& p, int cols, int rows) {
  GridSmoothness g;
  if (cols < 1 || rows < 1 || p.size() != static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows)) {
    g.worst_ratio = std::numeric_limits<double>::infinity();
    return g;
  }
  auto at = [&](int r, int c) -> const Eigen::Vector2d& { return p[static_cast<std::size_t>(r * cols + c)]; };
  auto check = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& m, const Eigen::Vector2d& b, int r, int c,
                   bool along_row) {
    const double off = (a - 2 * m + b).norm(), half = 0.5 * (b - a).norm();
    // A corner on top of its neighbours (half = 0) or a non-finite corner is not a grid.
    const double ratio = half > 1e-9 && std::isfinite(off) ? off / half : std::numeric_limits<double>::infinity();
    if (!(ratio <= g.worst_ratio)) {
      g.worst_ratio = ratio;
      g.worst_px = off;
      g.row = r;
      g.col = c;
      g.along_row = along_row;
    }
  };
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      if (c > 0 && c + 1 < cols) check(at(r, c - 1), at(r, c), at(r, c + 1), r, c, true);
      if (r > 0 && r + 1 < rows) check(at(r - 1, c), at(r, c), at(r + 1, c), r, c, false);
    }
  return g;
}

Result<BoardView> detect_chessboard(const std::uint8_t* gray, int width, int height,
                                    int stride_bytes, const ChessboardSpec& spec,
                                    const std::string& name) {
  if (std::string e = spec.validate(); !e.empty()) return Error{name + ": " + e};
  if (gray == nullptr || width < 16 || height < 16 || stride_bytes < width)
    return Error{name + ": image is empty or smaller than 16x16 px"};
  const cv::Mat img(height, width, CV_8UC1, const_cast<std::uint8_t*>(gray),
                    static_cast<std::size_t>(stride_bytes));
  const cv::Size pattern(spec.cols, spec.rows);
  const std::size_t n = static_cast<std::size_t>(spec.cols * spec.rows);
  auto smoothness = [&](const std::vector<cv::Point2f>& c) {
    std::vector<Eigen::Vector2d> p;
    for (const auto& q : c) p.emplace_back(q.x, q.y);
    return chessboard_grid_smoothness(p, spec.cols, spec.rows);
  };
  // OpenCV's sector-based finder can return a board with a whole column 26-38 px off the grid
  // (right02.jpg and right04.jpg of opencv-doc with one grey level of noise: calibration session
  // 19). Such a board is never returned: the classic finder is tried instead, and a view where
  // neither gives a smooth grid is refused with the reason.
  std::vector<cv::Point2f> corners;
  bool found = false;
  std::string rough;  // why a board the finders returned was not used
  try {
    if (spec.detector != ChessboardDetector::kClassic) {
      found = cv::findChessboardCornersSB(img, pattern, corners,
                                          cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY);
      if (found && corners.size() == n) {
        if (spec.detector == ChessboardDetector::kSectorBased) refine_corners_in_squares(img, spec, corners);
        if (const GridSmoothness g = smoothness(corners); !g.smooth()) {
          rough = "the sector-based finder's board is not a smooth grid: " + grid_text(g);
          found = false;
        }
      } else {
        found = false;
      }
    }
    if (!found) {
      corners.clear();
      found = cv::findChessboardCorners(
          img, pattern, corners, cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
      if (found && corners.size() == n) {
        if (spec.detector == ChessboardDetector::kClassic)
          cv::cornerSubPix(img, corners, cv::Size(11, 11), cv::Size(-1, -1),
                           cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-3));
        else
          refine_corners_in_squares(img, spec, corners);
        if (const GridSmoothness g = smoothness(corners); !g.smooth()) {
          rough += std::string(rough.empty() ? "" : "; ") + "the classic finder's board is not a smooth grid: " +
                   grid_text(g);
          found = false;
        }
      } else {
        found = false;
      }
    }
  } catch (const cv::Exception& e) {
    return Error{name + ": chessboard detection failed: " + e.err};
  }
  if (!found) {
    std::ostringstream os;
    if (!rough.empty())
      os << name << " refused: " << rough << " (looked for " << spec.cols << "x" << spec.rows
         << " inner corners); retake the photo with the whole board sharp and evenly lit";
    else
      os << "board not found in " << name << " (looked for " << spec.cols << "x" << spec.rows
         << " inner corners): check --board, that the whole board is in view, sharp and evenly lit";
    return Error{os.str()};
  }
  BoardView v;
  v.name = name;
  v.object_points = spec.object_points();
  for (const auto& c : corners) v.image_points.emplace_back(c.x, c.y);
  return v;
}

std::string IntrinsicsOptions::validate() const {
  std::ostringstream os;
  if (min_views < 3) os << "min_views = " << min_views << " must be >= 3";
  else if (min_points_per_view < 4) os << "min_points_per_view = " << min_points_per_view << " must be >= 4";
  else if (!(mad_k > 0)) os << "mad_k = " << mad_k << " must be > 0";
  else if (!(min_outlier_rms_px >= 0)) os << "min_outlier_rms_px must be >= 0";
  else if (!(max_view_rms_px > 0)) os << "max_view_rms_px must be > 0";
  else if (!(min_tilt_spread_rad >= 0)) os << "min_tilt_spread_rad must be >= 0";
  else if (coverage_cols < 1 || coverage_rows < 1 || coverage_cols > 64 || coverage_rows > 64)
    os << "coverage grid " << coverage_cols << "x" << coverage_rows << " must be 1..64 each";
  else if (!(tooth_region[0] >= 0 && tooth_region[2] <= 1 && tooth_region[0] < tooth_region[2] &&
             tooth_region[1] >= 0 && tooth_region[3] <= 1 && tooth_region[1] < tooth_region[3]))
    os << "tooth_region must be 0 <= x0 < x1 <= 1 and 0 <= y0 < y1 <= 1";
  return os.str();
}

std::string CoverageMap::ascii() const {
  std::ostringstream os;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const int n = counts[r * cols + c];
      os << (n >= 5 ? '#' : n > 0 ? '+' : '.');
    }
    os << "\n";
  }
  return os.str();
}

std::string IntrinsicsSummary::report() const {
  std::ostringstream os;
  os << std::fixed << std::setprecision(3);
  os << (ok ? "camera calibration OK: " : "camera calibration FAILED: ") << message << "\n";
  if (calibrations_run > 0) {
    os << "  fx fy = " << camera.fx << " " << camera.fy << " px, cx cy = " << camera.cx << " "
       << camera.cy << " px, model " << model << "\n";
    if (std_devs.size() >= 4)
      os << "  std dev fx fy cx cy = " << std_devs[0] << " " << std_devs[1] << " " << std_devs[2]
         << " " << std_devs[3] << " px\n";
    os << "  RMS " << rms_px << " px over " << used_views.size() << " views, board tilt spread "
       << std::setprecision(1) << tilt_spread_rad * kDeg << " deg\n" << std::setprecision(3);
    for (std::size_t i = 0; i < used_views.size(); ++i)
      os << "    view " << used_views[i] << ": RMS " << per_view_rms_px[used_views[i]] << " px\n";
  }
  for (const auto& r : rejected)
    os << "  rejected view " << r.index << " (" << r.name << "): " << r.reason << "\n";
  if (coverage.cols > 0) {
    os << "  coverage (" << std::setprecision(0) << coverage.image_fraction * 100
       << "% of the image, " << coverage.tooth_fraction * 100 << "% of the tooth region):\n";
    std::istringstream lines(coverage.ascii());
    for (std::string l; std::getline(lines, l);) os << "    " << l << "\n";
  }
  for (const auto& w : warnings) os << "  WARNING: " << w << "\n";
  return os.str();
}

CameraFile IntrinsicsSummary::to_camera_file(const std::string& device, const std::string& date) const {
  CameraFile f;
  f.camera = camera;
  f.model = model;
  f.dist = dist;
  f.rms_px = rms_px;
  f.std_devs = std_devs;
  f.device = device;
  f.date = date;
  if (f.date.empty()) {
    const std::time_t t = std::time(nullptr);
    std::tm tm{};
    gmtime_r(&t, &tm);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
    f.date = buf;
  }
  f.views_used = static_cast<int>(used_views.size());
  return f;
}

IntrinsicsSummary calibrate_intrinsics(const std::vector<BoardView>& views, int width, int height,
                                       const IntrinsicsOptions& o) {
  IntrinsicsSummary s;
  // The file names the model as fitted (issue 24): a k1-only fit is not radtan5.
  s.model = o.model == DistortionModel::kRational8 ? kModelRational8
            : o.model == DistortionModel::kK1      ? kModelK1
            : o.model == DistortionModel::kK1K2    ? kModelK1K2
                                                   : kModelRadTan5;
  s.terms = o.model;
  s.per_view_rms_px.assign(views.size(), 0.0);
  if (std::string e = o.validate(); !e.empty()) {
    s.message = "invalid options: " + e;
    return s;
  }
  if (width < 16 || height < 16 || width > 16384 || height > 16384) {
    s.message = "image size " + std::to_string(width) + "x" + std::to_string(height) +
                " px is outside 16..16384";
    return s;
  }
  // Usable views: enough finite points, paired, inside the image.
  std::vector<int> used;
  for (std::size_t i = 0; i < views.size(); ++i) {
    const BoardView& v = views[i];
    std::string why;
    if (v.image_points.size() != v.object_points.size())
      why = "image and board point counts differ";
    else if (static_cast<int>(v.image_points.size()) < o.min_points_per_view)
      why = "only " + std::to_string(v.image_points.size()) + " board points (need " +
            std::to_string(o.min_points_per_view) + ")";
    else
      for (std::size_t j = 0; j < v.image_points.size() && why.empty(); ++j) {
        const auto& p = v.image_points[j];
        if (!p.allFinite() || !v.object_points[j].allFinite() || p.x() < -0.5 ||
            p.y() < -0.5 || p.x() > width - 0.5 || p.y() > height - 0.5)
          why = "point " + std::to_string(j) + " is not finite or outside the image";
        else if (std::abs(v.object_points[j].z()) > 1e-9)
          why = "board points must have z = 0 (planar board)";
      }
    if (why.empty())
      used.push_back(static_cast<int>(i));
    else
      s.rejected.push_back({static_cast<int>(i), v.name, 0.0, why});
  }
  if (static_cast<int>(used.size()) < o.min_views) {
    std::ostringstream os;
    os << "too few usable views: " << used.size() << " of " << views.size() << " (need "
       << o.min_views << "); take more photos of the board, tilted 15-45 degrees in different "
       << "directions and covering the whole image";
    s.message = os.str();
    return s;
  }

  CalibRun run;
  for (;;) {
    run = run_calibration(views, used, width, height, o.model);
    ++s.calibrations_run;
    if (!run.ok) {
      s.message = run.error + "; check the board size options and take more varied views";
      return s;
    }
    for (std::size_t j = 0; j < used.size(); ++j) s.per_view_rms_px[used[j]] = run.per_view[j];
    if (!o.reject_outliers || static_cast<int>(used.size()) <= o.min_views) break;
    const double med = median(run.per_view);
    std::vector<double> dev;
    for (double e : run.per_view) dev.push_back(std::abs(e - med));
    const double mad = median(dev);
    const double thresh = std::max(med + o.mad_k * 1.4826 * mad, o.min_outlier_rms_px);
    int worst = -1;
    for (std::size_t j = 0; j < used.size(); ++j)
      if ((run.per_view[j] > thresh || run.per_view[j] > o.max_view_rms_px) &&
          (worst < 0 || run.per_view[j] > run.per_view[worst]))
        worst = static_cast<int>(j);
    if (worst < 0) break;
    std::ostringstream why;
    why << std::fixed << std::setprecision(3) << "RMS " << run.per_view[worst] << " px";
    if (run.per_view[worst] > o.max_view_rms_px)
      why << " above the hard limit " << o.max_view_rms_px << " px";
    else
      why << " above the outlier threshold " << thresh << " px (median " << med << " + "
          << o.mad_k << " robust sigma)";
    why << ": blurred, mis-detected, moved during the shot or the board is not flat";
    const int vi = used[worst];
    s.rejected.push_back({vi, views[vi].name, run.per_view[worst], why.str()});
    used.erase(used.begin() + worst);
  }

  s.used_views = used;
  s.rms_px = run.rms;
  s.camera.width = width;
  s.camera.height = height;
  s.camera.fx = run.K.at<double>(0, 0);
  s.camera.fy = run.K.at<double>(1, 1);
  s.camera.cx = run.K.at<double>(0, 2);
  s.camera.cy = run.K.at<double>(1, 2);
  cv::Mat D;
  run.D.convertTo(D, CV_64F);
  const int nd = o.model == DistortionModel::kRational8 ? 8 : 5;
  for (int i = 0; i < nd; ++i) s.dist.push_back(i < static_cast<int>(D.total()) ? D.at<double>(i) : 0.0);
  for (int i = 0; i < 5; ++i) s.camera.dist[i] = s.dist[i];
  cv::Mat sd;
  run.std_int.convertTo(sd, CV_64F);
  // OpenCV 4.6 estimates the noise variance as |r|^2 / (N - p) with N the number of points, but
  // |r|^2 sums both pixel coordinates (2N residuals): its std devs are ~sqrt(2) too large (our
  // Monte-Carlo test measured observed/reported = 0.70). Rescale to |r|^2 / (2N - p).
  std::size_t npts = 0;
  for (int i : used) npts += views[i].image_points.size();
  const double p = 4 + nd + 6.0 * used.size();
  const double fix = std::sqrt(std::max(0.0, npts - p) / std::max(1.0, 2.0 * npts - p));
  for (int i = 0; i < 4 + nd && i < static_cast<int>(sd.total()); ++i)
    s.std_devs.push_back(sd.at<double>(i) * fix);
  for (std::size_t j = 0; j < used.size(); ++j) s.T_cam_board.push_back(to_iso(run.rvecs[j], run.tvecs[j]));

  // Degenerate geometry: spread of the board normals (board z in the camera frame).
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& T : s.T_cam_board) mean += T.linear().col(2);
  mean.normalize();
  double sum2 = 0;
  for (const auto& T : s.T_cam_board) {
    const double a = std::acos(std::clamp(T.linear().col(2).dot(mean), -1.0, 1.0));
    sum2 += a * a;
  }
  s.tilt_spread_rad = std::sqrt(sum2 / s.T_cam_board.size());

  // Coverage map over the used views' points.
  CoverageMap& cm = s.coverage;
  cm.cols = o.coverage_cols;
  cm.rows = o.coverage_rows;
  cm.counts.assign(cm.cols * cm.rows, 0);
  for (int i : used)
    for (const auto& p : views[i].image_points) {
      const int c = std::clamp(static_cast<int>((p.x() + 0.5) / width * cm.cols), 0, cm.cols - 1);
      const int r = std::clamp(static_cast<int>((p.y() + 0.5) / height * cm.rows), 0, cm.rows - 1);
      ++cm.counts[r * cm.cols + c];
    }
  int filled = 0, tooth_cells = 0, tooth_filled = 0;
  for (int r = 0; r < cm.rows; ++r)
    for (int c = 0; c < cm.cols; ++c) {
      const bool has = cm.counts[r * cm.cols + c] > 0;
      filled += has;
      // A cell belongs to the tooth region when its centre lies inside it.
      const double x = (c + 0.5) / cm.cols, y = (r + 0.5) / cm.rows;
      if (x >= o.tooth_region[0] && x <= o.tooth_region[2] && y >= o.tooth_region[1] &&
          y <= o.tooth_region[3]) {
        ++tooth_cells;
        tooth_filled += has;
      }
    }
  cm.image_fraction = static_cast<double>(filled) / (cm.cols * cm.rows);
  cm.tooth_fraction = tooth_cells ? static_cast<double>(tooth_filled) / tooth_cells : 0.0;
  if (cm.tooth_fraction < o.min_tooth_coverage) {
    std::ostringstream os;
    os << std::fixed << std::setprecision(0) << "the region where the tooth is drawn is poorly "
       << "covered (" << cm.tooth_fraction * 100 << "% of its cells hold board points); add views "
       << "with the board in the middle of the image";
    s.warnings.push_back(os.str());
  }
  if (o.model == DistortionModel::kRational8)
    s.warnings.push_back("rational model: the tracker and renderer use only k1 k2 p1 p2 k3");

  if (s.tilt_spread_rad < o.min_tilt_spread_rad) {
    std::ostringstream os;
    os << std::fixed << std::setprecision(1) << "degenerate geometry: the board normals spread only "
       << s.tilt_spread_rad * kDeg << " deg (need " << o.min_tilt_spread_rad * kDeg
       << "); the focal length is not observable from boards that all face the same way. Tilt "
       << "the board 15-45 degrees toward the left, right, top and bottom in different views";
    s.message = os.str();
    return s;
  }
  std::ostringstream os;
  os << std::fixed << std::setprecision(3) << "RMS " << s.rms_px << " px, " << used.size()
     << " views used, " << (s.rejected.size()) << " rejected";
  s.message = os.str();
  s.ok = true;
  return s;
}

bool project_point(const CameraIntrinsics& k, const Eigen::Vector3d& p, Eigen::Vector2d& px) {
  if (!(p.z() > 0)) return false;
  const double x = p.x() / p.z(), y = p.y() / p.z();
  const double r2 = x * x + y * y;
  const auto& d = k.dist;
  const double radial = 1 + r2 * (d[0] + r2 * (d[1] + r2 * d[4]));
  const double xd = x * radial + 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x);
  const double yd = y * radial + d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y;
  px = Eigen::Vector2d(k.fx * xd + k.cx, k.fy * yd + k.cy);
  return true;
}

std::vector<Eigen::Isometry3d> plan_board_poses(const CameraIntrinsics& k, double bw, double bh,
                                                int count, std::uint64_t seed) {
  return plan_board_poses_in_region(k, bw, bh, count, seed, 1.0);
}

std::vector<Eigen::Isometry3d> plan_board_poses_in_region(const CameraIntrinsics& k, double bw,
                                                          double bh, int count, std::uint64_t seed,
                                                          double area_fraction) {
  const double sc = std::sqrt(std::clamp(area_fraction, 0.01, 1.0));
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> tilt(15.0 / kDeg, 45.0 / kDeg), roll(-0.35, 0.35),
      jitter(-0.05, 0.05);
  // Image positions for the board centre (fractions), cycling so every region is visited and the
  // centre (where the tooth is drawn) is visited often.
  const double pos[][2] = {{0.5, 0.5}, {0.3, 0.3}, {0.7, 0.3}, {0.7, 0.7}, {0.3, 0.7},
                           {0.5, 0.5}, {0.5, 0.3}, {0.7, 0.5}, {0.5, 0.7}, {0.3, 0.5}};
  const Eigen::Vector3d centre_board(bw / 2, bh / 2, 0);
  std::vector<Eigen::Isometry3d> out;
  for (int i = 0; i < count; ++i) {
    const double phi = i * 2.399963 + jitter(rng) * 10;  // golden angle: varied tilt axes
    const Eigen::Vector3d axis(std::cos(phi), std::sin(phi), 0);
    Eigen::Matrix3d R = (Eigen::AngleAxisd(roll(rng), Eigen::Vector3d::UnitZ()) *
                         Eigen::AngleAxisd(tilt(rng), axis))
                            .toRotationMatrix();
    double u = 0.5 + sc * (pos[i % 10][0] + jitter(rng) - 0.5),
           v = 0.5 + sc * (pos[i % 10][1] + jitter(rng) - 0.5);
    double d = k.fx * std::max(bw, bh) / (0.55 * sc * k.width);
    const double lo = 0.5 - 0.47 * sc, hi = 0.5 + 0.47 * sc;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    for (int attempt = 0; attempt < 40; ++attempt) {
      const Eigen::Vector3d ray((u * k.width - k.cx) / k.fx, (v * k.height - k.cy) / k.fy, 1.0);
      T.linear() = R;
      T.translation() = ray * d - R * centre_board;
      bool inside = true;
      for (const Eigen::Vector3d& c : {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(bw, 0, 0),
                                       Eigen::Vector3d(bw, bh, 0), Eigen::Vector3d(0, bh, 0)}) {
        Eigen::Vector2d px;
        if (!project_point(k, T * c, px) || px.x() < lo * k.width || px.y() < lo * k.height ||
            px.x() > hi * k.width || px.y() > hi * k.height)
          inside = false;
      }
      if (inside) break;
      d *= 1.06;
      u = 0.5 + 0.9 * (u - 0.5);
      v = 0.5 + 0.9 * (v - 0.5);
    }
    out.push_back(T);
  }
  return out;
}

double board_homography_rms_px(const BoardView& v) {
  std::vector<cv::Point2f> o, i;
  for (std::size_t k = 0; k < v.image_points.size(); ++k) {
    o.emplace_back(static_cast<float>(v.object_points[k].x()), static_cast<float>(v.object_points[k].y()));
    i.emplace_back(static_cast<float>(v.image_points[k].x()), static_cast<float>(v.image_points[k].y()));
  }
  if (o.size() < 4) return NAN;
  const cv::Mat H = cv::findHomography(o, i, 0);
  if (H.empty()) return NAN;
  std::vector<cv::Point2f> p;
  cv::perspectiveTransform(o, p, H);
  double ss = 0;
  for (std::size_t k = 0; k < p.size(); ++k) ss += std::pow(cv::norm(p[k] - i[k]), 2);
  return std::sqrt(ss / static_cast<double>(p.size()));
}

}  // namespace dentar::calibration
