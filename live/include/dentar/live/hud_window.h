// A GLFW window showing video with a Dear ImGui HUD over it, for the live tools
// (`dentar calibrate live`; the same set-up as `dentar live`'s window: desktop GL 3.0, the
// video as a letterboxed texture in the background, ImGui on top, optional fullscreen on a
// monitor, vsync). Main thread only. The video is blitted into the window (1:1 = exact
// pixels), the HUD drawn over it. Keys are collected as presses (for take-a-view /
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
  // Uploads a BGR frame of the video size (others are ignored with no effect);
  // the window shows it from now on.
  void set_video(const cv::Mat& bgr);
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
  // A point of the video image (px) in ImGui's window coordinates, where begin_frame draws
  // it (the video fills the window, aspect kept).
  void image_to_window(double x, double y, float& wx, float& wy) const;
  // Starts a frame: clear, ImGui frame, the video in the background. ImGui calls follow.
  void begin_frame();
  // Renders the HUD and swaps; with `capture`, returns the window's pixels (BGR) first.
  cv::Mat end_frame(bool capture = false);

 private:
  HudWindow() = default;
  static void on_key(GLFWwindow* w, int key, int scancode, int action, int mods);
  GLFWwindow* win_ = nullptr;
  unsigned tex_ = 0, fbo_ = 0;  // the video texture (BGRA; RGBA with GLES) and a read framebuffer on it
  unsigned frame_video_ = 0;           // set_frame's video texture; shown when != 0
  unsigned frame_fbo_[2] = {0, 0};      // read framebuffers on set_frame's video and overlay
  int frame_region_[4] = {0, 0, 0, 0};
  bool gles_ = false;
  std::string note_;
  int tex_w_ = 0, tex_h_ = 0;
  cv::Mat bgra_;  // upload buffer, reused
  bool imgui_ = false;
  std::vector<int> presses_;
  std::set<int> held_;
};

}  // namespace dentar::live
