// The replay's window: GLFW with an OpenGL ES 3 context through EGL (the context the view's
// renderer draws in, so a frame goes from its framebuffer to the window by one blit: no read
// back, no upload), and a Dear ImGui HUD (its GLFW and OpenGL 3 back ends, GLSL ES 3.00).
// The same set-up as live::HudWindow's EGL context, without its video texture. Key presses
// are queued (GLFW key codes); ImGui sees the mouse and keys too. Main thread only.
#pragma once

#include <array>
#include <memory>
#include <utility>
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
  // The areas of the window the HUD owns (x, y, w, h from the top left; the rest is the
  // caller's blits, which must cover it every frame). With areas set, the HUD is drawn into
  // a cached texture, again only when what it draws changed (its vertices, indices, draw
  // commands or textures), and copied into its areas each frame; what ImGui's foreground
  // draw list holds (the play heads, the clock: what changes every frame) is drawn over it
  // directly. Where the driver keeps the back buffer between swaps (EGL_BUFFER_PRESERVED,
  // asked for at open; llvmpipe does), only the pixels under the last frame's overlay are
  // copied again. A frame whose HUD reaches out of the areas (a tooltip over the view) is
  // drawn directly, uncached. Without areas: the whole window is cleared and the HUD drawn
  // every frame.
  void set_hud_areas(std::vector<std::array<int, 4>> areas);
  // Renders the HUD and swaps; with `capture`, returns the window's pixels (BGR, row 0 =
  // top) first.
  cv::Mat end_frame(bool capture);
  // True when the window's back buffer still holds, outside the HUD's areas, what the
  // caller blitted last frame (a preserved back buffer, and the last frame's HUD and overlay
  // drew only in their areas): an unchanged view then need not be blitted again.
  bool keeps_caller_pixels() const { return caller_kept_; }
  // Frames whose HUD was drawn (into the cache or directly) since open; the others reused it.
  long hud_draws() const { return hud_draws_; }
  int width() const { return w_; }
  int height() const { return h_; }

 private:
  ReplayWindow() = default;
  static void on_key(GLFWwindow* w, int key, int scancode, int action, int mods);
  GLFWwindow* win_ = nullptr;
  bool imgui_ = false;
  int w_ = 0, h_ = 0;
  std::vector<int> presses_;
  std::vector<std::array<int, 4>> areas_;
  unsigned cache_tex_ = 0, cache_fbo_ = 0;
  bool cache_valid_ = false;
  std::vector<char> cache_key_, key_scratch_;
  long hud_draws_ = 0;
  bool preserved_ = false;         // the back buffer survives a swap (EGL_BUFFER_PRESERVED)
  bool window_has_cache_ = false;  // the window's HUD areas hold the cache (+ the overlay)
  bool caller_kept_ = false;
  std::vector<std::array<int, 4>> overlay_boxes_;  // where the last overlay drew (x0, y0, x1, y1)
};

}  // namespace dentar::replay
