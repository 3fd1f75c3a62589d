// Issue 28, item 5: where `dentar live` draws the frame. One interface, the
// DisplayOutput, that the window's frame loop draws through; two
// implementations:
//   - the mono window (as before: the composite letterboxed into the window by
//     a framebuffer blit, exact pixels at 1:1), with an optional loupe;
//   - a side-by-side view for a headset that appears as a display (docs/headset.md):
//     per eye, one GL pass maps the panel's pixels to the camera's through the
//     headset profile (headset.h: field of view, interpupillary shift, lens
//     pre-warp with chromatic aberration, the loupe).
// An OpenXR backend (no OpenXR runtime in Debian 12) would be a third: it
// would draw the same per-eye pass into the runtime's swapchain images, with
// the runtime's per-eye field of view, and leave the lens pre-warp to the
// runtime (no pre-warp in its mapping).
//
// GL: runs in the window's context (desktop GL 3.0 or OpenGL ES 3.0, the
// shader's version line follows the context), main thread; also on a headless
// EGL context (tests, the benchmark). Draws into the bound draw framebuffer.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "dentar/live/headset.h"
#include "dentar/volume/result.h"

namespace dentar::live {

// The frame to draw: textures in the current context (RGBA8, camera size, row 0 =
// image top). video: the camera image or the CPU composite; overlay != 0 (the
// GPU path, gl_handoff.h): the composite inside `region` (x0, y0, x1, y1 px) is
// in overlay. right_video != 0: a stereo pair's right eye (then the left eye
// uses `video`), else mono.
struct OutputFrame {
  unsigned video = 0, overlay = 0, right_video = 0;
  int region[4] = {0, 0, 0, 0};
  int tex_w = 0, tex_h = 0;
  // The loupe's centre per eye, camera px (OpenCV); used when the loupe is on.
  double loupe_c[2][2] = {{0, 0}, {0, 0}};
};

// Issue 28 session 18: how the side-by-side view's per-eye pass draws the lens pre-warp
// (docs/headset.md "The pre-warp pass"; docs/BENCHMARKS.md "Issue 28 session 18 - the
// headset window's display stage"). On llvmpipe the pass's cost is its fragments times
// their texture taps; most of an eye's viewport shows no camera (black), so every pass but
// kFull draws only the cells of a grid over the viewport where the camera may be seen
// (headset.h WarpGrid: the cull is checked on every pixel), the rest is the clear's black.
enum class WarpPass {
  kFull,   // sessions 15-17: the exact mapping per fragment, one triangle over the whole viewport
  kExact,  // the same fragment program over the live cells only: the same pixels as kFull (default)
  kMesh,   // the live cells with per-vertex texture coordinates per channel (the exact mapping at the
           // vertices, linear between): three plain taps per fragment; its error is warp_grid_error's.
  // Every pass draws an eye with the loupe's inset on as kFull (the inset's mapping jumps at its
  // border, and every cell would be live).
  kLut,    // kExact with the pre-warp's polynomial read from a per-pixel lookup texture (RG16F,
           // headset.h warp_lut; exact at a 1:1 window only)
};
const char* warp_pass_name(WarpPass p);
// "full", "exact", "mesh", "lut"; false otherwise.
bool parse_warp_pass(const std::string& s, WarpPass& p);

class DisplayOutput {
 public:
  virtual ~DisplayOutput() = default;
  virtual const char* kind() const = 0;  // "mono" or "sbs"
  // Draws the frame into the bound draw framebuffer of fb_w x fb_h px.
  virtual void draw(const OutputFrame& f, int fb_w, int fb_h) = 0;
  virtual void set_loupe(const LoupeView& l) = 0;
  virtual void set_prewarp(bool on) = 0;  // sbs: the lens pre-warp on or off (a key toggles it)
  // Where each eye's view lies in a framebuffer of fb_w x fb_h px for frames of tex_w x tex_h
  // (px, top-left origin): the mono window's letterboxed video (1 rect) or each eye's
  // viewport of the side-by-side panel (2). Returns the count. The HUD and the GPU path's
  // note label are placed through it (HudWindow).
  virtual int eye_rects(int fb_w, int fb_h, int tex_w, int tex_h, PanelRect rects[2]) const = 0;
  // How many times an eye's pre-warp grid was made (exact, mesh and lut passes): once per eye,
  // then only when its mapping changes (warp_grid_key). The live summary reports it.
  virtual std::int64_t warp_grid_builds() const { return 0; }
};

// What an eye's pre-warp grid depends on: the mapping's numbers and the grid's size; the
// loupe's fields (magnification, inset, centre) only while the loupe is on (mag > 0).
std::vector<double> warp_grid_key(const EyeMapping& m, int cols, int rows);

// The mono window; `gles`: the context is OpenGL ES (shader version line).
// cam: the intrinsics of the composite's size (the loupe's mapping).
Result<std::unique_ptr<DisplayOutput>> make_mono_output(bool gles, const calibration::CameraIntrinsics& cam);
// The side-by-side view of `profile`. A frame with right_video is drawn as a
// stereo pair (each eye its own camera, no IPD shift), one without as mono;
// `stereo` says which the driver expects (for its log; the frame decides).
// cam_right: the right eye's camera of a stereo pair (the rig's camera_right; null: `cam`),
// used for the right eye's mapping when the frame has right_video.
// pass: the pre-warp's pass (above); cell_px: the grid's cell size in panel px (4..128; the
// grid has ceil(viewport / cell_px) cells a side).
Result<std::unique_ptr<DisplayOutput>> make_sbs_output(bool gles, const HeadsetProfile& profile,
                                                       const calibration::CameraIntrinsics& cam, bool stereo,
                                                       const calibration::CameraIntrinsics* cam_right = nullptr,
                                                       WarpPass pass = WarpPass::kExact, int cell_px = 16);

}  // namespace dentar::live
