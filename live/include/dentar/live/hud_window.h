// A GLFW window showing video with a Dear ImGui HUD over it, for the live tools
// (`dentar calibrate live`; the same set-up as `dentar live`'s window: desktop GL 3.0, the
// video as a letterboxed texture in the background, ImGui on top, optional fullscreen on a
// monitor, vsync). Main thread only. The video is drawn by the window's output
// (eye_output.h): by default the mono window, a blit (1:1 = exact pixels); or a headset's
// side-by-side view (set_output); the HUD is drawn over it. Keys are collected as presses (for take-a-view /
// take-a-touch) and held states (the space bar as a pedal); scripted presses go through the
// same queue (inject_key), so a test drives exactly the code an instructor's keys drive.
//
// Two kinds of context: desktop GL 3.0 (GLFW's default, GLX on X11), or, with
// `gles_egl`, OpenGL ES 3.0 made through EGL (GLFW_EGL_CONTEXT_API), whose
// display and context another thread can share (egl_context.h "Shared mode"):
// `dentar live`'s GPU display path leaves the frame in shared textures and
// the window draws them (set_frame) with no CPU copy. When the EGL
// context cannot be made, the window falls back to desktop GL and says why
// (context_note()).
#pragma once

#include <memory>
#include <opencv2/core/mat.hpp>
#include <set>
#include <string>
#include <vector>

#include "dentar/volume/result.h"

struct GLFWwindow;

namespace dentar::live {

// The window's upload of one frame (set_video): `img` (BGR, or the camera's YUYV) in the
// texture's layout (gles: RGBA, else BGRA; `out` reused), and a BGR `patch` (empty: none)
// over it inside patch_rect. Empty string, or why not (nothing written: a patch that is not
// BGR, not patch_rect's size, or not inside the frame).
std::string upload_pixels(const cv::Mat& img, const cv::Mat& patch, const cv::Rect& patch_rect, bool gles,
                          cv::Mat& out);
// Issue 28 session 23: the same at half size (the headset's half-size textures), straight from
// the camera's YUYV: each texel from its 2x2 block's luma mean and its two rows' chroma mean
// (a YUYV pixel pair shares its chroma), converted once (BT.601 limited range, OpenCV's
// fixed-point coefficients), so the 3/4 of the frame's pixels that the half-size texture never
// shows are not converted first (upload_pixels then a 2x2 box mean did). Inside the patch's
// texels (its rectangle grown to even bounds) the pixels are exactly upload_pixels' then the
// box mean. `img` must be YUYV of even width and height; else the error (nothing written).
std::string upload_pixels_half(const cv::Mat& img, const cv::Mat& patch, const cv::Rect& patch_rect, bool gles,
                               cv::Mat& out);

class DisplayOutput;

// Issue 28 session 22: where one drawn frame's display stage goes (DENTAR_DISPLAY_PROFILE=1,
// a profiling hook: each GL part is closed by a glFinish, so the parts do not overlap and the
// run is slower than without it). Wall ms and the calling thread's CPU ms (with
// LP_NUM_THREADS=0 llvmpipe rasterises on the calling thread, so the CPU column holds the
// rasteriser's work too); -1: not done in this frame.
struct DisplayProfile {
  enum Part { kConvertLeft, kUploadLeft, kConvertRight, kUploadRight, kWarp, kHud, kSwap, kParts };
  static const char* name(int p);
  bool on = false;
  double wall_ms[kParts], cpu_ms[kParts];
  void clear() {
    for (int i = 0; i < kParts; ++i) wall_ms[i] = cpu_ms[i] = -1;
  }
};
double thread_cpu_ms();  // CLOCK_THREAD_CPUTIME_ID, ms

class HudWindow {
 public:
  // video_w x video_h: the texture size (the camera's); win_w/win_h 0 = the video's; display
  // >= 0: fullscreen on that monitor. Errors: no display, no GL 3.0, no such monitor.
  static Result<std::unique_ptr<HudWindow>> open(const std::string& title, int video_w, int video_h,
                                                 int win_w = 0, int win_h = 0, int display = -1,
                                                 bool vsync = true, bool gles_egl = false);
  ~HudWindow();
  HudWindow(const HudWindow&) = delete;
  HudWindow& operator=(const HudWindow&) = delete;

  bool should_close() const;
  void request_close();
  void poll();  // window events and key callbacks
  // Key presses (GLFW key codes) since the last call, in order; scripted ones included.
  std::vector<int> take_presses();
  void inject_key(int glfw_key);  // a scripted press (test and benchmark drivers)
  bool held(int glfw_key) const;
  // Uploads a BGR frame, or the camera's own YUYV (CV_8UC2, converted once into the
  // texture's layout), of the video size (others are ignored with no effect);
  // the window shows it from now on.
  // patch, patch_rect (issue 28 session 20): a keep_yuyv composite (ar::CompositeResult):
  // the camera's YUYV frame, and the BGR composite inside patch_rect drawn over it, each
  // converted once into the upload (no whole-frame BGR made on the frame path).
  void set_video(const cv::Mat& bgr, const cv::Mat& patch = {}, const cv::Rect& patch_rect = {});
  // A stereo pair's right eye (BGR, the video size; set after set_video): the
  // headset's output shows it to the right eye (eye_output.h). An empty image
  // goes back to mono (both eyes from set_video's frame). patch: as set_video's.
  void set_video_right(const cv::Mat& bgr, const cv::Mat& patch = {}, const cv::Rect& patch_rect = {});
  // Shows, from now on, a frame from a context sharing with this window's
  // (the caller has waited for its fence): the video (RGBA8 texture of the
  // video size) and, inside region (x0, y0, x1, y1; image px), the composite
  // from an RGBA8 texture of the video size (both row 0 = image top;
  // ar::GlFrameTarget). Two blits into the back buffer. video = 0: back to
  // the set_video texture.
  void set_frame(unsigned video, unsigned overlay, const int region[4]);
  // The context: OpenGL ES 3 over EGL (shareable), or desktop GL.
  bool gles_egl() const { return gles_; }
  // Why the EGL context was not made when it was asked for (empty otherwise).
  const std::string& context_note() const { return note_; }
  // EGLDisplay / EGLContext of the window (null unless gles_egl()).
  void* egl_display() const;
  void* egl_context() const;
  // Where the frame is drawn (eye_output.h): the mono window (the default,
  // made by open()) or a headset's side-by-side view. The output is made in
  // this window's context (gles_egl()).
  void set_output(std::unique_ptr<DisplayOutput> out);
  DisplayOutput& output() { return *output_; }
  // The loupe's centre per eye for the frames from now on (camera px, OpenCV).
  void set_loupe_centre(const double left[2], const double right[2]);
  // A point of the video image (px) in ImGui's window coordinates, where the output draws
  // it in eye `eye`'s view (mono: the letterboxed video), scaled to that view's rectangle
  // (eye_rects; no lens pre-warp).
  void image_to_window(double x, double y, float& wx, float& wy, int eye = 0) const;
  // Where each eye's view lies in ImGui's window coordinates (top-left origin): the output's
  // DisplayOutput::eye_rects. Returns the count (1 mono, 2 side by side).
  int eye_rects(float rects[2][4]) const;
  // Starts a frame: clear, ImGui frame, the video in the background (drawn by the output). ImGui calls follow.
  void begin_frame();
  // Renders the HUD and swaps; with `capture`, returns the window's pixels (BGR) first.
  cv::Mat end_frame(bool capture = false);
  // Issue 28 session 22: the scale of the uploads from set_video / set_video_right: 1 (the
  // camera's size) or 2 (each frame box-averaged 2x2 into a texture of half the size, a
  // quarter of the bytes converted, copied and sampled; the output's mapping scales the
  // intrinsics to the texture's size). An odd video size keeps 1. Takes effect at the next
  // set_video; the GPU path's frames (set_frame) are not scaled.
  void set_upload_scale(int s) { want_scale_ = s == 2 && tex_w_ % 2 == 0 && tex_h_ % 2 == 0 ? 2 : 1; }
  // Session 23: a half-size texture of a YUYV frame converted at half size straight
  // (upload_pixels_half, default) or, false, converted at full size then box-averaged (session 22).
  void set_half_direct(bool direct) { half_direct_ = direct; }
  int upload_scale() const { return scale_; }
  // The display stage's profile (DisplayProfile): on/off, and the last frame's parts.
  void set_profile(bool on) { prof_.on = on, prof_.clear(); }
  DisplayProfile& profile() { return prof_; }

 private:
  DisplayProfile prof_;
  double hud_w0_ = 0, hud_c0_ = 0;  // the profile's HUD part started (begin_frame's end)
  HudWindow() = default;
  static void on_key(GLFWwindow* w, int key, int scancode, int action, int mods);
  GLFWwindow* win_ = nullptr;
  unsigned tex_ = 0;  // the video texture (BGRA; RGBA with GLES)
  unsigned tex_right_ = 0;  // set_video_right's texture (made on first use)
  bool right_ = false;      // a right eye's frame is shown
  unsigned frame_video_ = 0, frame_overlay_ = 0;  // set_frame's textures; shown when frame_video_ != 0
  int frame_region_[4] = {0, 0, 0, 0};
  double loupe_c_[2][2] = {{0, 0}, {0, 0}};
  std::unique_ptr<DisplayOutput> output_;
  bool gles_ = false;
  std::string note_;
  int tex_w_ = 0, tex_h_ = 0;
  cv::Mat bgra_, bgra_right_;  // upload buffers, reused
  // Session 22: the half-size uploads' buffers and textures (made on first use), the scale asked
  // for and the scale of the textures now shown (the right eye follows the left's).
  cv::Mat half_, half_right_;
  unsigned tex_half_ = 0, tex_half_right_ = 0;
  int want_scale_ = 1, scale_ = 1;
  bool half_direct_ = true;
  bool imgui_ = false;
  std::vector<int> presses_;
  std::set<int> held_;
};

}  // namespace dentar::live
