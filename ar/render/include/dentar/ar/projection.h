// OpenCV intrinsics -> OpenGL clip space, and the plan for drawing a distorted
// (real-lens) image: render a pinhole image over a slightly larger field, then
// warp it through a per-pixel distortion map.
//
// Conventions (see docs/conventions.md):
//  - camera frame `cam`: x right, y down, z forward (OpenCV), metres;
//  - OpenCV pixel (u, v): u right, v down, pixel centres at integer
//    coordinates, so pixel (u, v) covers [u-0.5, u+0.5] x [v-0.5, v+0.5];
//  - GL window coordinates: x right, y up, pixel centres at +0.5; the renderer
//    reads rows back bottom-up and flips them, so image row 0 is the top.
//
// Derivation of clip_from_cam (W x H image, near n, far f, all > 0):
//   OpenCV u = fx X/Z + cx must land at GL window x_w = u + 0.5, i.e.
//   x_ndc = 2 x_w / W - 1 = (2 fx X/Z + 2 cx + 1 - W) / W.
//   Row v (from the top) lands at window y_w = H - (v + 0.5), i.e.
//   y_ndc = 2 y_w / H - 1 = (H - 2 fy Y/Z - 2 cy - 1) / H.
//   With w_clip = Z (perspective divide by depth) and depth z_ndc = -1 at
//   Z = n, +1 at Z = f:
//        | 2fx/W    0       (2cx + 1 - W)/W      0          |
//    P = | 0      -2fy/H    (H - 2cy - 1)/H      0          |
//        | 0        0       (f + n)/(f - n)   -2fn/(f - n)  |
//        | 0        0        1                   0          |
//   applied directly to (X, Y, Z, 1) in `cam` (no GL "eye" frame in between).
//   The y flip keeps front faces counter-clockwise in window space: a
//   triangle counter-clockwise as seen by the camera stays counter-clockwise
//   after P, so glFrontFace(GL_CCW) + back-face culling work unchanged.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "dentar/calibration/station.h"
#include "dentar/volume/result.h"

namespace dentar::ar {

// Clip-from-camera matrix P above for a pinhole camera (k.dist is ignored).
// Asserts 0 < near_m < far_m and a positive image size and focal lengths.
Eigen::Matrix4d clip_from_cam(const calibration::CameraIntrinsics& k, double near_m, double far_m);

// Inverse of the viewport + flip: OpenCV pixel (u, v) of a clip-space point
// (after the perspective divide). Used by tests and by CPU-side checks.
Eigen::Vector2d pixel_from_clip(const Eigen::Vector4d& clip, int width_px, int height_px);

struct UndistortOptions {
  // The pinhole canvas may grow to at most this many times the output size
  // per axis; distorted pixels whose ray falls outside it are left empty.
  // Strong barrel lenses (fisheye-like corners) hit this bound.
  double max_canvas_scale = 2.0;
  // Extra pinhole pixels on each side so bilinear sampling at the border
  // pixel never reads outside the canvas.
  int margin_px = 2;
};

// How to draw what the distorted camera `k` sees.
struct UndistortedView {
  // The pinhole camera to render: same fx, fy as k (same pixel scale at the
  // image centre), no distortion, canvas size and principal point enlarged so
  // that it contains the undistorted ray of every output pixel.
  calibration::CameraIntrinsics pinhole;
  // Row-major, k.width * k.height entries: for output (distorted) pixel
  // (u, v), the pinhole pixel (OpenCV coordinates, in `pinhole`) it shows.
  // NaN where the distortion model cannot be inverted (beyond the field where
  // it is monotonic) or the ray leaves the canvas.
  std::vector<Eigen::Vector2f> map_px;
  int invalid_pixels = 0;
  // Largest |distort(undistort(x)) - x| over the valid pixels, px (accuracy
  // of the inversion; ~1e-9 in practice).
  double max_inversion_error_px = 0.0;
  bool identity() const;  // true when k had no distortion (map is the identity)
};

// Computes the pinhole canvas and the per-pixel map. Inverts OpenCV's
// (k1, k2, p1, p2, k3) model per pixel (fixed-point iteration as
// cv::undistortPoints, then Newton steps to machine precision). Fails (with a
// message naming the field) when k does not validate or when no output pixel
// can be inverted.
Result<UndistortedView> plan_undistorted_view(const calibration::CameraIntrinsics& k,
                                              const UndistortOptions& options = {});

}  // namespace dentar::ar
