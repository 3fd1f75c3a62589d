// A GLFW window showing video with a Dear ImGui HUD over it, for the live tools
// (`dentar calibrate live`; the same set-up as `dentar live`'s window: desktop GL 3.0, the
// video as a letterboxed texture in the background, ImGui on top, optional fullscreen on a
// monitor, vsync). Main thread only. The video is blitted into the window (1:1 = exact
// pixels), the HUD drawn over it. Keys are collected as presses (for take-a-view /
// take-a-touch) and held states (the space bar as a pedal); scripted presses go through the
// same queue (inject_key), so a test drives exactly the code an instructor's keys drive.
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
                                                 bool vsync = true);
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
  // Uploads a BGR frame of the video size (others are ignored with no effect).
  void set_video(const cv::Mat& bgr);
  // Starts a frame: clear, ImGui frame, the video in the background. ImGui calls follow.
  void begin_frame();
  // Renders the HUD and swaps; with `capture`, returns the window's pixels (BGR) first.
  cv::Mat end_frame(bool capture = false);

 private:
  HudWindow() = default;
  static void on_key(GLFWwindow* w, int key, int scancode, int action, int mods);
  GLFWwindow* win_ = nullptr;
  unsigned tex_ = 0, fbo_ = 0;  // the video texture (BGRA) and a read framebuffer on it
  int tex_w_ = 0, tex_h_ = 0;
  cv::Mat bgra_;  // upload buffer, reused
  bool imgui_ = false;
  std::vector<int> presses_;
  std::set<int> held_;
};

}  // namespace dentar::live
