// The replay's window: GLFW with an OpenGL ES 3 context through EGL (the context the view's
// renderer draws in, so a frame goes from its framebuffer to the window by one blit: no read
// back, no upload), and a Dear ImGui HUD (its GLFW and OpenGL 3 back ends, GLSL ES 3.00).
// The same set-up as live::HudWindow's EGL context, without its video texture. Key presses
// are queued (GLFW key codes); ImGui sees the mouse and keys too. Main thread only.
#pragma once

#include <utility>

#include <memory>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "dentar/volume/result.h"

struct GLFWwindow;

namespace dentar::replay {

// glFinish() in the current context.
void finish_gl();

// An RGBA8 texture of the current context made from a CV_8UC4 RGBA image (row 0 = top, as
// ImGui::Image draws it with uv (0,0)-(1,1)); 0 on failure. Deleted by delete_texture.
unsigned make_texture(const cv::Mat& rgba);
void delete_texture(unsigned tex);

class ReplayWindow {
 public:
  // Errors: no display (GLFW cannot start), no OpenGL ES 3 context through EGL.
  static Result<std::unique_ptr<ReplayWindow>> open(const std::string& title, int w, int h, bool vsync);
  ~ReplayWindow();
  ReplayWindow(const ReplayWindow&) = delete;
  ReplayWindow& operator=(const ReplayWindow&) = delete;

  bool should_close() const;
  void poll();
  std::vector<int> take_presses();
  // Starts a frame: binds the window's framebuffer, clears, starts the ImGui frame.
  void begin_frame();
  // Copies a framebuffer of the current context (w x h, GL rows bottom-up) to the window at
  // (x, y) (window pixels from the top left; 1:1, nearest).
  // `from` (w, h): the source's size; a different size is scaled (bilinear) into w x h.
  void blit(unsigned framebuffer, std::pair<int, int> from, int w, int h, int x, int y);
  // Renders the HUD and swaps; with `capture`, returns the window's pixels (BGR, row 0 =
  // top) first.
  cv::Mat end_frame(bool capture);
  int width() const { return w_; }
  int height() const { return h_; }

 private:
  ReplayWindow() = default;
  static void on_key(GLFWwindow* w, int key, int scancode, int action, int mods);
  GLFWwindow* win_ = nullptr;
  bool imgui_ = false;
  int w_ = 0, h_ = 0;
  std::vector<int> presses_;
};

}  // namespace dentar::replay
