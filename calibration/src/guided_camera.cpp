// LiveCameraViews: see guided.h.
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <opencv2/calib3d.hpp>
#include <sstream>

#include "cell_place.h"
#include "dentar/calibration/guided.h"

namespace dentar::calibration {
namespace {
std::string fmt(double v, int p = 1) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(p) << v;
  return os.str();
}

// RMS distance of the image points from the homography of the board layout that fits them
// best (least squares): small for the right board (lens distortion only), large when the spec
// puts the points elsewhere (another size, another first id). -1 with too few points.
double layout_rms_px(const BoardView& v) {
  if (v.image_points.size() < 8) return -1;
  std::vector<cv::Point2f> a, b;
  for (std::size_t i = 0; i < v.image_points.size(); ++i) {
    a.emplace_back(static_cast<float>(v.object_points[i].x()), static_cast<float>(v.object_points[i].y()));
    b.emplace_back(static_cast<float>(v.image_points[i].x()), static_cast<float>(v.image_points[i].y()));
  }
  cv::Mat H;
  try {
    H = cv::findHomography(a, b, 0);
  } catch (const cv::Exception&) {
    return -1;
  }
  if (H.empty()) return 1e9;
  std::vector<cv::Point2f> p;
  cv::perspectiveTransform(a, p, H);
  double s = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double dx = p[i].x - b[i].x, dy = p[i].y - b[i].y;
    s += dx * dx + dy * dy;
  }
  return std::sqrt(s / p.size());
}

double diag_px(const std::vector<Eigen::Vector2d>& px) {
  if (px.empty()) return 0;
  Eigen::Vector2d lo = px[0], hi = px[0];
  for (const auto& p : px) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  return (hi - lo).norm();
}

// Mean distance of the points the two views share (matched by board point), px; -1 when
// they share fewer than 4.
double mean_shared_distance(const BoardView& a, const BoardView& b) {
  double s = 0;
  int n = 0;
  for (std::size_t i = 0; i < a.object_points.size(); ++i)
    for (std::size_t j = 0; j < b.object_points.size(); ++j)
      if ((a.object_points[i] - b.object_points[j]).squaredNorm() < 1e-12) {
        s += (a.image_points[i] - b.image_points[j]).norm();
        ++n;
        break;
      }
  return n >= 4 ? s / n : -1;
}
}  // namespace

std::string LiveCameraOptions::validate() const {
  if (std::string e = intrinsics.validate(); !e.empty()) return e;
  if (target_views < intrinsics.min_views) return "target_views must be >= intrinsics.min_views";
  if (max_views < target_views) return "max_views must be >= target_views";
  if (!(still_window_s > 0 && still_window_s < 10)) return "still_window_s must be in (0, 10) s";
  if (!(max_speed_px_per_s > 0)) return "max_speed_px_per_s must be > 0";
  if (!(min_new_fraction >= 0 && min_new_fraction < 1)) return "min_new_fraction must be in [0, 1)";
  if (!(min_sharpness_ratio >= 0 && min_sharpness_ratio < 1)) return "min_sharpness_ratio must be in [0, 1)";
  if (!(done_trusted_fraction > 0 && done_trusted_fraction <= 1)) return "done_trusted_fraction must be in (0, 1]";
  return {};
}

LiveCameraViews::LiveCameraViews(int width, int height, const LiveCameraOptions& options)
    : options_(options), width_(width), height_(height) {}

double LiveCameraViews::speed(const Seen& a, const Seen& b) const {
  const double dt = b.t_s - a.t_s;
  if (!(dt > 0)) return 0;
  double s = 0;
  int n = 0;
  for (std::size_t i = 0; i < b.obj.size(); ++i)
    for (std::size_t j = 0; j < a.obj.size(); ++j)
      if ((b.obj[i] - a.obj[j]).squaredNorm() < 1e-12) {
        s += (b.px[i] - a.px[j]).norm();
        ++n;
        break;
      }
  return n > 0 ? s / n / dt : 1e9;  // nothing shared: a different view
}

void LiveCameraViews::add_frame(double t_s, const BoardView* view, const std::string& reason, double sharpness) {
  last_t_ = t_s;
  last_sharpness_ = sharpness;
  const bool found = view && view->image_points.size() >= static_cast<std::size_t>(options_.intrinsics.min_points_per_view);
  if (!found) {
    last_found_ = false;
    last_view_ = BoardView{};
    still_since_ = -1;
    recent_.clear();
    status_ = reason.empty() ? "board not found" : reason;
    return;
  }
  last_view_ = *view;
  const double lr = layout_rms_px(*view);
  last_layout_ok_ = lr < std::max(options_.max_layout_px, options_.max_layout_fraction * diag_px(view->image_points));
  Seen s{t_s, view->image_points, view->object_points};
  double v = 0;
  // Consecutive detections up to 1.5 s apart are compared (speed is per second): a loaded
  // machine that processes 2 frames a second still sees a held board as still.
  if (last_found_ && !recent_.empty() && t_s - recent_.back().t_s < 1.5) {
    v = speed(recent_.back(), s);
    if (v > options_.max_speed_px_per_s || still_since_ < 0) still_since_ = t_s;
  } else {
    still_since_ = t_s;
  }
  last_found_ = true;
  recent_.push_back(std::move(s));
  if (recent_.size() > 4) recent_.erase(recent_.begin());
  if (!last_layout_ok_)
    status_ = "wrong board: the points lie " + fmt(lr, 1) +
              " px (RMS) from the layout --board gives; check the board spec (columns x rows, tag size, first id)";
  else if (still())
    status_ = "board still: press SPACE (or the pedal) to take the view";
  else
    status_ = "board moving (" + fmt(v, 0) + " px/s): hold it still";
}

bool LiveCameraViews::still() const { return last_found_ && still_for_s() >= options_.still_window_s; }
double LiveCameraViews::still_for_s() const {
  return last_found_ && still_since_ >= 0 ? last_t_ - still_since_ : 0;
}

CameraTake LiveCameraViews::take() {
  CameraTake r;
  const int next = views() + 1;
  auto refuse = [&](const std::string& m) {
    ++refused_;
    r.message = "view refused: " + m;
    return r;
  };
  if (views() >= options_.max_views) return refuse("already " + std::to_string(views()) + " views, the most this step takes");
  if (!last_found_) return refuse(status_ + " (the whole board must be in view; check --board if it is)");
  if (!last_layout_ok_) return refuse(status_);
  if (!still())
    return refuse("the board moved during the last " + fmt(options_.still_window_s, 1) +
                  " s: hold it still (rest your elbows) and press again");
  if (!sharpness_.empty()) {
    std::vector<double> s = sharpness_;
    std::nth_element(s.begin(), s.begin() + s.size() / 2, s.end());
    const double med = s[s.size() / 2];
    if (last_sharpness_ < options_.min_sharpness_ratio * med)
      return refuse("blurred: sharpness " + fmt(100 * last_sharpness_ / med, 0) +
                    "% of the views taken so far; check the focus and the light, hold still");
  }
  const double diag = std::hypot(width_, height_);
  for (std::size_t i = 0; i < views_.size(); ++i) {
    const double d = mean_shared_distance(last_view_, views_[i]);
    if (d >= 0 && d < options_.min_new_fraction * diag) {
      int c = 0, rr = 0;
      std::string where;
      const bool sug = suggestion(c, rr, where);
      return refuse("too similar to view " + std::to_string(i + 1) + " (points " + fmt(d, 0) +
                    " px away on average): move or tilt the board" + (sug ? "; " + where : ""));
    }
  }
  last_view_.name = "live-view-" + std::to_string(next);
  views_.push_back(last_view_);
  sharpness_.push_back(last_sharpness_);
  r.ok = true;
  r.message = "view " + std::to_string(next) + " taken (" + std::to_string(last_view_.image_points.size()) + " points)";
  if (views() >= options_.intrinsics.min_views) {
    IntrinsicsOptions io = options_.intrinsics;
    io.model = DistortionModel::kRadTan5;
    running_ = calibrate_intrinsics(views_, width_, height_, io);
    if (running_.calibrations_run > 0 && running_.std_devs.size() >= 4)
      r.message += ": RMS " + fmt(running_.rms_px, 3) + " px, fx " + fmt(running_.camera.fx, 1) + " +- " +
                   fmt(running_.std_devs[0], 2) + " px, cx " + fmt(running_.camera.cx, 1) + " +- " +
                   fmt(running_.std_devs[2], 2) + " px";
  } else {
    r.message += "; " + std::to_string(options_.intrinsics.min_views - views()) + " more before the first calibration";
  }
  return r;
}

CoverageMap LiveCameraViews::coverage() const {
  CoverageMap cm;
  cm.cols = options_.intrinsics.coverage_cols;
  cm.rows = options_.intrinsics.coverage_rows;
  cm.counts.assign(cm.cols * cm.rows, 0);
  for (const auto& v : views_)
    for (const auto& p : v.image_points) {
      const int c = std::clamp(static_cast<int>((p.x() + 0.5) / width_ * cm.cols), 0, cm.cols - 1);
      const int r = std::clamp(static_cast<int>((p.y() + 0.5) / height_ * cm.rows), 0, cm.rows - 1);
      ++cm.counts[r * cm.cols + c];
    }
  const auto& tr = options_.intrinsics.tooth_region;
  int filled = 0, tooth = 0, tooth_filled = 0;
  for (int r = 0; r < cm.rows; ++r)
    for (int c = 0; c < cm.cols; ++c) {
      const bool has = cm.counts[r * cm.cols + c] > 0;
      filled += has;
      const double x = (c + 0.5) / cm.cols, y = (r + 0.5) / cm.rows;
      if (x >= tr[0] && x <= tr[2] && y >= tr[1] && y <= tr[3]) {
        ++tooth;
        tooth_filled += has;
      }
    }
  cm.image_fraction = static_cast<double>(filled) / (cm.cols * cm.rows);
  cm.tooth_fraction = tooth ? static_cast<double>(tooth_filled) / tooth : 0;
  return cm;
}

void LiveCameraViews::set_trust(const TrustMap& trust, int views) {
  trust_ = trust;
  trust_views_ = views;
}

bool LiveCameraViews::suggestion(int& col, int& row, std::string& text) const {
  const CoverageMap cm = coverage();
  const auto& tr = options_.intrinsics.tooth_region;
  const bool use_trust = trust_views_ > 0 && trust_.cols == cm.cols && trust_.rows == cm.rows &&
                         trust_.trusted.size() == cm.counts.size();
  if (use_trust && trust_.trusted_fraction >= options_.done_trusted_fraction && trust_.tooth_trusted_fraction >= 1)
    return false;
  // The weakest cell: untrusted (or empty) first, the tooth region before the rest, then the
  // fewest points, then the nearest the centre (the tooth is drawn there).
  double best = 1e300;
  col = row = -1;
  for (int r = 0; r < cm.rows; ++r)
    for (int c = 0; c < cm.cols; ++c) {
      const int i = r * cm.cols + c;
      const double x = (c + 0.5) / cm.cols, y = (r + 0.5) / cm.rows;
      const bool in_tooth = x >= tr[0] && x <= tr[2] && y >= tr[1] && y <= tr[3];
      const bool weak = use_trust ? !trust_.trusted[i] : cm.counts[i] == 0;
      const double score = (weak ? 0 : 1e6) + (in_tooth ? 0 : 1e4) + std::min(cm.counts[i], 999) * 10 +
                           std::hypot(x - 0.5, y - 0.5);
      if (score < best) {
        best = score;
        col = c;
        row = r;
      }
    }
  if (col < 0) return false;
  const int i = row * cm.cols + col;
  const bool weak = use_trust ? !trust_.trusted[i] : cm.counts[i] == 0;
  if (!weak && views() >= options_.target_views) return false;
  text = "next: hold the board over the " + detail::cell_place(row, col, cm.rows, cm.cols) + ", tilted 15-45 degrees" +
         (use_trust && weak ? " (the model is not trusted there yet)" : weak ? " (no board points there yet)" : "");
  return true;
}

bool LiveCameraViews::done() const {
  if (views() >= options_.max_views) return true;
  return views() >= options_.target_views && trust_views_ == views() &&
         trust_.trusted_fraction >= options_.done_trusted_fraction && trust_.tooth_trusted_fraction >= 1;
}

}  // namespace dentar::calibration
