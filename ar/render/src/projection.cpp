#include "dentar/ar/projection.h"

#include <Eigen/LU>
#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

#include "dentar/ar/camera_model.h"

namespace dentar::ar {

Eigen::Matrix4d clip_from_cam(const calibration::CameraIntrinsics& k, double near_m, double far_m) {
  assert(near_m > 0 && far_m > near_m && "dentar::ar::clip_from_cam: need 0 < near < far");
  assert(k.width > 0 && k.height > 0 && k.fx > 0 && k.fy > 0 &&
         "dentar::ar::clip_from_cam: need a positive image size and focal lengths");
  const double W = k.width, H = k.height, n = near_m, f = far_m;
  Eigen::Matrix4d P = Eigen::Matrix4d::Zero();
  P(0, 0) = 2 * k.fx / W;
  P(0, 2) = (2 * k.cx + 1 - W) / W;
  P(1, 1) = -2 * k.fy / H;
  P(1, 2) = (H - 2 * k.cy - 1) / H;
  P(2, 2) = (f + n) / (f - n);
  P(2, 3) = -2 * f * n / (f - n);
  P(3, 2) = 1;
  return P;
}

Eigen::Vector2d pixel_from_clip(const Eigen::Vector4d& clip, int width_px, int height_px) {
  const double x_ndc = clip.x() / clip.w(), y_ndc = clip.y() / clip.w();
  const double x_w = (x_ndc + 1) * 0.5 * width_px;   // GL window, centres at +0.5
  const double y_w = (y_ndc + 1) * 0.5 * height_px;  // from the bottom
  return {x_w - 0.5, height_px - y_w - 0.5};
}

bool UndistortedView::identity() const { return map_px.empty() && invalid_pixels == 0; }

namespace {

Eigen::Matrix2d distortion_jacobian(const CameraModel& cam, const Eigen::Vector2d& x) {
  constexpr double kH = 1e-7;  // normalised units; central differences
  Eigen::Matrix2d J;
  J.col(0) = (cam.distort(x + Eigen::Vector2d(kH, 0)) - cam.distort(x - Eigen::Vector2d(kH, 0))) /
             (2 * kH);
  J.col(1) = (cam.distort(x + Eigen::Vector2d(0, kH)) - cam.distort(x - Eigen::Vector2d(0, kH))) /
             (2 * kH);
  return J;
}

// Solves distort(x) = xd for x. Newton steps from `guess` (the neighbouring
// pixel's solution) or, without one, from the fixed-point iteration
// cv::undistortPoints uses, which alone converges slowly near the edge of
// strong lenses. Returns false when it does not converge or where the model
// folds over (Jacobian determinant <= 0), i.e. beyond the field where the
// polynomial describes a lens.
bool invert_distortion(const CameraModel& cam, const Eigen::Vector2d& xd,
                       const Eigen::Vector2d* guess, Eigen::Vector2d& x, double& residual) {
  x = guess != nullptr ? *guess : cam.undistort(xd, 20);
  for (int it = 0; it < 10; ++it) {
    const Eigen::Vector2d r = cam.distort(x) - xd;
    if (r.norm() < 1e-13) break;
    const Eigen::Matrix2d J = distortion_jacobian(cam, x);
    if (!(J.determinant() > 0)) return false;
    x -= J.inverse() * r;
    if (!x.allFinite()) return false;
  }
  residual = (cam.distort(x) - xd).norm();
  return residual < 1e-9 && distortion_jacobian(cam, x).determinant() > 0;
}

}  // namespace

Result<UndistortedView> plan_undistorted_view(const calibration::CameraIntrinsics& k,
                                              const UndistortOptions& options) {
  if (std::string e = k.validate(); !e.empty()) return Error{"camera intrinsics: " + e};
  if (!(options.max_canvas_scale >= 1.0) || options.max_canvas_scale > 8.0) {
    return Error{"UndistortOptions.max_canvas_scale = " + std::to_string(options.max_canvas_scale) +
                 " must be in [1, 8]"};
  }
  if (options.margin_px < 0 || options.margin_px > 64) {
    return Error{"UndistortOptions.margin_px = " + std::to_string(options.margin_px) +
                 " must be in [0, 64]"};
  }
  UndistortedView view;
  view.pinhole = k;
  view.pinhole.dist = {0, 0, 0, 0, 0};
  const bool distorted = std::any_of(k.dist.begin(), k.dist.end(), [](double d) { return d != 0; });
  if (!distorted) return view;  // identity: render straight into the output

  const CameraModel cam(k);
  const int W = k.width, H = k.height;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<Eigen::Vector2d> px(static_cast<std::size_t>(W) * H, Eigen::Vector2d(nan, nan));
  // Bounds the canvas may reach, in pinhole pixels with k's principal point.
  const double grow_u = 0.5 * (options.max_canvas_scale - 1.0) * W;
  const double grow_v = 0.5 * (options.max_canvas_scale - 1.0) * H;
  double min_u = std::numeric_limits<double>::infinity(), max_u = -min_u;
  double min_v = min_u, max_v = -min_u;
  double max_err_norm = 0.0;
  int valid = 0;
  for (int v = 0; v < H; ++v) {
    bool have_prev = false;
    Eigen::Vector2d prev;
    for (int u = 0; u < W; ++u) {
      const Eigen::Vector2d xd((u - k.cx) / k.fx, (v - k.cy) / k.fy);
      Eigen::Vector2d x;
      double residual = 0;
      bool ok = have_prev && invert_distortion(cam, xd, &prev, x, residual);
      if (!ok) ok = invert_distortion(cam, xd, nullptr, x, residual);
      have_prev = ok;
      if (!ok) continue;
      prev = x;
      const Eigen::Vector2d p(k.fx * x.x() + k.cx, k.fy * x.y() + k.cy);
      if (p.x() < -grow_u || p.x() > W - 1 + grow_u || p.y() < -grow_v || p.y() > H - 1 + grow_v) {
        continue;
      }
      px[static_cast<std::size_t>(v) * W + u] = p;
      min_u = std::min(min_u, p.x());
      max_u = std::max(max_u, p.x());
      min_v = std::min(min_v, p.y());
      max_v = std::max(max_v, p.y());
      max_err_norm = std::max(max_err_norm, residual);
      ++valid;
    }
  }
  if (valid == 0) {
    return Error{
        "camera intrinsics: the distortion coefficients (dist) cannot be inverted at any "
        "pixel of the " +
        std::to_string(W) + "x" + std::to_string(H) + " image"};
  }
  // Canvas: integer shift so pinhole pixel centres stay on integer coordinates.
  const int m = options.margin_px;
  const int u0 = static_cast<int>(std::floor(min_u)) - m;
  const int v0 = static_cast<int>(std::floor(min_v)) - m;
  const int u1 = static_cast<int>(std::ceil(max_u)) + m;
  const int v1 = static_cast<int>(std::ceil(max_v)) + m;
  view.pinhole.width = u1 - u0 + 1;
  view.pinhole.height = v1 - v0 + 1;
  view.pinhole.cx = k.cx - u0;
  view.pinhole.cy = k.cy - v0;
  view.map_px.resize(px.size());
  for (std::size_t i = 0; i < px.size(); ++i) {
    if (std::isnan(px[i].x())) {
      view.map_px[i] = Eigen::Vector2f(NAN, NAN);
      ++view.invalid_pixels;
    } else {
      view.map_px[i] =
          Eigen::Vector2f(static_cast<float>(px[i].x() - u0), static_cast<float>(px[i].y() - v0));
    }
  }
  view.max_inversion_error_px = max_err_norm * std::max(k.fx, k.fy);
  return view;
}

}  // namespace dentar::ar
