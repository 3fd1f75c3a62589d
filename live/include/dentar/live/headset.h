// Issue 28, item 5: the headset's output geometry, on the CPU. A headset
// profile (a JSON file, docs/formats.md "Headset profile"), the mapping from a
// panel pixel of one eye to the camera pixel it shows (lens pre-warp with
// chromatic aberration, the eye's field of view, the interpupillary shift of a
// mono camera, the digital loupe), a CPU reference of that mapping (what the GL
// pass in eye_output.h must match), and the loupe's centre filter.
//
// Conventions (docs/headset.md):
// - Panel and viewport pixels: x right, y down, origin at the top-left corner of
//   the panel; a pixel's centre at (x + 0.5, y + 0.5) (GL's convention).
// - Camera pixels (the composite, camera size): OpenCV's convention, pixel
//   centre at integers; intrinsics as the station's.
// - Lens coordinates: d = (p - lens_centre) / (viewport width / 2), the
//   radius r = |d| (1 = the viewport's half width), as the Oculus DK1 SDK
//   normalised its distortion.
// - Pre-warp (the inverse of the lens's pincushion): the panel pixel at d
//   shows the undistorted eye image at d * (1 + k1 r^2 + k2 r^4) * s_c with
//   s_c = chroma_scale_r, 1, chroma_scale_b for the red, green, blue channel.
// - The undistorted eye image is a pinhole view with the profile's field of
//   view (before pre-warp, as OpenXR's XrFovf): f_x = (w/2) / tan(fov_h/2),
//   f_y = (h/2) / tan(fov_v/2), its optical centre at the lens centre. It shows
//   the camera orthoscopically: one radian of the eye's view is one radian of
//   the camera's (tan angles equal), so the world is seen at its own size.
// - A mono camera shown to both eyes: the left eye's view is shifted by
//   +(ipd/2) / convergence (tan units), the right's by the opposite, so a point
//   on the midline at the convergence distance is seen there by both eyes.
//   A stereo pair (one camera per eye) gets no shift.
// - The loupe (magnification m, centre c in camera px): inside its area the
//   eye image shows the camera at m times the angular size around c.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "dentar/calibration/station.h"
#include "dentar/volume/result.h"

namespace dentar::live {

inline constexpr int kHeadsetProfileVersion = 1;

struct HeadsetEye {
  int viewport[4] = {0, 0, 0, 0};      // x, y, width, height on the panel, px (top-left origin)
  double lens_center_px[2] = {0, 0};   // the lens axis on the panel, px from the viewport's top-left
};

struct HeadsetProfile {
  std::string name;
  std::string provenance;  // where each number comes from (free text, required)
  int panel_w = 0, panel_h = 0;  // px, the display mode the headset asks for
  std::array<HeadsetEye, 2> eyes;  // left, right
  double fov_h_deg = 90, fov_v_deg = 90;  // each eye's image before pre-warp, symmetric about the lens axis
  double ipd_m = 0.063;
  double k1 = 0, k2 = 0;  // radial pre-warp (lens coordinates, see above)
  double chroma_scale_r = 1, chroma_scale_b = 1;  // per-channel radial scale of the pre-warp
  double mono_convergence_m = 0.4;  // mono camera: where both eyes' views meet (the working distance)
  // Empty when valid; else names the field, its value and the constraint.
  std::string validate() const;
  // The pre-warp's radial factor at r^2 (1 + k1 r^2 + k2 r^4).
  double warp_factor(double r2) const { return 1 + k1 * r2 + k2 * r2 * r2; }
  // The largest lens radius a viewport pixel of eye e has (its farthest corner).
  double max_radius(int e) const;
  bool has_warp() const { return k1 != 0 || k2 != 0 || chroma_scale_r != 1 || chroma_scale_b != 1; }
};

// Reads and validates a profile. Errors name the file, the field and the constraint
// ("headset profile H.json: fov_deg[0] = 190 must be in (1, 180) degrees").
Result<HeadsetProfile> read_headset_profile(const std::string& path);
Result<HeadsetProfile> parse_headset_profile(const std::string& json_text, const std::string& path);

// The digital loupe as drawn (per frame).
struct LoupeView {
  double mag = 0;  // 0 = off
  bool inset = true;  // picture-in-picture (else the whole eye view)
  // Inset area in the eye image, fractions of the viewport: centre and size
  // (bottom centre, 45 % wide, as a loupe through the lower part of glasses).
  double inset_cx = 0.5, inset_cy = 0.72, inset_w = 0.45, inset_h = 0.45;
};

// How one eye's panel pixels map to camera pixels. Made by make_eye_mapping.
struct EyeMapping {
  int vp[4] = {0, 0, 0, 0};  // viewport on the panel (x, y, w, h), top-left origin
  double lens_c[2] = {0, 0};  // px, in the viewport
  double norm = 1;            // px per lens unit (viewport width / 2)
  double k1 = 0, k2 = 0, chroma[3] = {1, 1, 1};  // per channel, in RGB order
  double f_eye[2] = {1, 1};   // the eye image's focal lengths, px
  double shift_tan = 0;       // the mono camera's interpupillary shift, tan units (+ = to the right)
  // Camera: focal lengths and principal point (OpenCV px), image size.
  double f_cam[2] = {1, 1}, c_cam[2] = {0, 0};
  int cam_w = 0, cam_h = 0;
  LoupeView loupe;
  double loupe_c[2] = {0, 0};  // the loupe's centre, camera px (OpenCV)
  // The camera pixel (OpenCV convention) panel pixel centre (px, py) (panel
  // coordinates, top-left origin) shows in channel ch (0 R, 1 G, 2 B); false
  // outside the viewport.
  bool map(double px, double py, int ch, double& u, double& v) const;
  // Undistorted eye-image point q (viewport px) to camera px (no pre-warp).
  void eye_to_camera(double qx, double qy, double& u, double& v) const;
};

// eye: 0 left, 1 right. stereo: each eye has its own camera (no IPD shift).
// The camera is the station's (OpenCV intrinsics of the composite's size).
EyeMapping make_eye_mapping(const HeadsetProfile& h, int eye, const calibration::CameraIntrinsics& cam, bool stereo,
                            const LoupeView& loupe, const double loupe_c[2], bool prewarp = true);

// Where a w x h image sits letterboxed in a win_w x win_h window (scaled to fit, aspect
// kept, centred): x, y, width, height in window px with a top-left origin. The one
// letterbox of the mono window: its blit, its loupe mapping and HudWindow::image_to_window.
struct PanelRect {
  int x = 0, y = 0, w = 0, h = 0;
};
PanelRect letterbox(int win_w, int win_h, int w, int h);

// A profile for the mono window: one "eye" covering the letterboxed video in a
// window of win_w x win_h (no pre-warp, the camera at the window's scale); only
// the loupe differs from the plain blit.
EyeMapping make_window_mapping(int win_w, int win_h, const calibration::CameraIntrinsics& cam, const LoupeView& loupe,
                               const double loupe_c[2]);

// CPU reference of the GL pass: draws the eye (its viewport) into `panel`
// (BGR, panel size; the caller clears it) from `src` (BGR, camera size):
// bilinear per channel, black outside the camera image.
void render_eye_cpu(const cv::Mat& src, const EyeMapping& m, cv::Mat& panel);

// Issue 28 session 18: the per-eye pass drawn over a grid of cells instead of one
// triangle over the viewport (eye_output.h, WarpPass). The eye's viewport is cut into
// cols x rows cells (two triangles each, split along the top-right to bottom-left
// diagonal as GL draws them here); per vertex, its panel position and the camera pixel it
// shows per channel (EyeMapping::map at the vertex). A cell is "live" when the camera's
// image may be seen in some pixel of it in some channel; only live cells are drawn (the
// rest of the viewport stays the clear's black, which is what the exact pass draws there).
// Cull rule: the camera px of 9 points of the cell (corners, edge middles, centre) per
// channel, their bounding box grown by half its size plus 2 px on every side, against the
// image's texel area; the loupe's inset (its mapping jumps at the inset's border) makes
// every cell live. warp_grid_error checks the rule on every pixel (culled_seen).
struct WarpGrid {
  int cols = 0, rows = 0;
  std::vector<float> xy;   // per vertex (row-major, (rows+1) x (cols+1)): panel px, top-left origin
  std::vector<float> uv;   // per vertex: R, G, B texture coordinates ((u + 0.5) / W, (v + 0.5) / H; row 0 = image top)
  std::vector<std::uint8_t> live;  // per cell (row-major), 1 = drawn
  int live_cells() const;
};
// cols, rows >= 1.
WarpGrid make_warp_grid(const EyeMapping& m, int cols, int rows);

// The grid's warp (texture coordinates interpolated linearly over each triangle, as GL
// does) against the exact mapping, over every panel pixel centre of the viewport whose
// exact camera pixel lies on the image (in that channel). Camera px: the sampled
// position's error; panel px: the same error as a displacement on the panel (through the
// mapping's local Jacobian). culled_seen: pixels of culled cells that show the camera in
// some channel (the cull rule's failures; 0 when it holds).
struct WarpError {
  double max_cam_px[3] = {0, 0, 0}, max_panel_px[3] = {0, 0, 0};
  double p99_cam_px = 0;  // all channels together
  long pixels = 0, culled_seen = 0;
};
WarpError warp_grid_error(const WarpGrid& g, const EyeMapping& m);

// The lookup-texture warp's values (WarpPass::kLut): per viewport pixel (row-major, row 0
// = the viewport's top), the pre-warped lens coordinates d' = d (1 + k1 r^2 + k2 r^4) of
// the pixel's centre (the green channel's; red and blue scale it by chroma). half: rounded
// to IEEE half floats as an RG16F texture holds them.
std::vector<float> warp_lut(const EyeMapping& m, bool half);
// The lookup's error against the exact mapping, as warp_grid_error (culled_seen 0).
WarpError warp_lut_error(const EyeMapping& m, bool half);

// The loupe's centre on the tracked tooth: the tooth's centre projected with the
// frame's pose, held in a deadband. The frame's own pose draws the frame's own
// image, so following the projection does not lag; what moves the view is the
// tracking's jitter, which the deadband keeps out: the centre moves only when
// the projection leaves a circle of radius deadband_px around it, and then by
// the excess (dragged), so the tooth stays within deadband_px of the view's
// centre (times the magnification, in the loupe). A jump larger than
// snap_px (the tracker re-acquiring after a loss) moves it at once. No pose:
// the centre holds; never a pose: the image centre. docs/headset.md says why
// not a low-pass filter (its lag moves the tooth in the view by m x the
// head's motion).
class LoupeCentre {
 public:
  explicit LoupeCentre(double deadband_px = 0.75, double snap_px = 80) : deadband_(deadband_px), snap_(snap_px) {}
  // One frame: the projected centre (camera px) when the tooth's pose is known.
  void update(bool valid, double u, double v);
  void reset(double u, double v) { c_[0] = u, c_[1] = v, init_ = true; }
  bool initialised() const { return init_; }
  const double* centre() const { return c_; }

 private:
  double deadband_, snap_;
  double c_[2] = {0, 0};
  bool init_ = false;
};

// The tooth volume's centre (tooth frame, m) projected into the camera (OpenCV
// px, the station's intrinsics with their distortion); false behind the camera.
bool project_point(const calibration::CameraIntrinsics& cam, const Eigen::Isometry3d& T_cam_x, const Eigen::Vector3d& p_x,
                   double& u, double& v);

}  // namespace dentar::live
