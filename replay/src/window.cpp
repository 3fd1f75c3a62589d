// See window.h.
#include "window.h"

#define GLFW_INCLUDE_NONE
#include <GLES3/gl3.h>
#include <GLFW/glfw3.h>
#define GLFW_EXPOSE_NATIVE_EGL
#include <EGL/egl.h>
#include <GLFW/glfw3native.h>
#include <imgui.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace dentar::replay {

Result<std::unique_ptr<ReplayWindow>> ReplayWindow::open(const std::string& title, int w, int h, bool vsync) {
  std::unique_ptr<ReplayWindow> rw(new ReplayWindow);
  if (!glfwInit()) return Error{"no display: GLFW cannot start (is $DISPLAY set? run under X, or xvfb-run)"};
  glfwWindowHint(GLFW_CLIENT_API, GLFW_OPENGL_ES_API);
  glfwWindowHint(GLFW_CONTEXT_CREATION_API, GLFW_EGL_CONTEXT_API);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 0);
  glfwWindowHint(GLFW_RESIZABLE, GLFW_FALSE);  // the HUD's layout and the view are made for one size
  rw->win_ = glfwCreateWindow(w, h, title.c_str(), nullptr, nullptr);
  if (!rw->win_) {
    const char* why = nullptr;
    glfwGetError(&why);
    glfwTerminate();
    return Error{std::string("cannot open an OpenGL ES 3 window through EGL (") + (why ? why : "GLFW gave no reason") + ")"};
  }
  glfwMakeContextCurrent(rw->win_);
  glfwSwapInterval(vsync ? 1 : 0);
  {
    // Keep the back buffer between swaps where the driver can (llvmpipe can): the HUD's
    // unchanged pixels then need no copy (end_frame).
    EGLDisplay d = glfwGetEGLDisplay();
    EGLSurface sf = glfwGetEGLSurface(rw->win_);
    EGLint b = 0;
    rw->preserved_ = d != EGL_NO_DISPLAY && sf != EGL_NO_SURFACE &&
                     eglSurfaceAttrib(d, sf, EGL_SWAP_BEHAVIOR, EGL_BUFFER_PRESERVED) == EGL_TRUE &&
                     eglQuerySurface(d, sf, EGL_SWAP_BEHAVIOR, &b) == EGL_TRUE && b == EGL_BUFFER_PRESERVED;
    if (!rw->preserved_) (void)eglGetError();  // clear it: not preserving is fine
  }
  glfwSetWindowUserPointer(rw->win_, rw.get());
  glfwSetKeyCallback(rw->win_, &ReplayWindow::on_key);
  glfwGetFramebufferSize(rw->win_, &rw->w_, &rw->h_);
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;
  ImGui_ImplGlfw_InitForOpenGL(rw->win_, true);  // chains to on_key
  ImGui_ImplOpenGL3_Init("#version 300 es");
  rw->imgui_ = true;
  return rw;
}

ReplayWindow::~ReplayWindow() {
  if (cache_fbo_ != 0) {
    GLuint f = cache_fbo_;
    glDeleteFramebuffers(1, &f);
  }
  delete_texture(cache_tex_);
  if (imgui_) {
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
  }
  if (win_) glfwDestroyWindow(win_);
  glfwTerminate();
}

void ReplayWindow::on_key(GLFWwindow* gw, int key, int, int action, int) {
  auto* w = static_cast<ReplayWindow*>(glfwGetWindowUserPointer(gw));
  if (w && (action == GLFW_PRESS || action == GLFW_REPEAT)) w->presses_.push_back(key);
}

void finish_gl() { glFinish(); }

unsigned make_texture(const cv::Mat& rgba) {
  if (rgba.empty() || rgba.type() != CV_8UC4 || !rgba.isContinuous()) return 0;
  GLuint t = 0;
  glGenTextures(1, &t);
  glBindTexture(GL_TEXTURE_2D, t);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, rgba.cols, rgba.rows, 0, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data);
  glBindTexture(GL_TEXTURE_2D, 0);
  return t;
}

void delete_texture(unsigned tex) {
  if (tex == 0) return;
  GLuint t = tex;
  glDeleteTextures(1, &t);
}

bool ReplayWindow::should_close() const { return glfwWindowShouldClose(win_); }
void ReplayWindow::poll() { glfwPollEvents(); }

std::vector<int> ReplayWindow::take_presses() {
  std::vector<int> out;
  out.swap(presses_);
  return out;
}

void ReplayWindow::set_hud_areas(std::vector<std::array<int, 4>> areas) {
  areas_ = std::move(areas);
  cache_valid_ = false;
}

void ReplayWindow::begin_frame() {
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glViewport(0, 0, w_, h_);
  glDisable(GL_SCISSOR_TEST);
  if (areas_.empty()) {  // with areas, the caller's blits and the HUD's cover every pixel
    glClearColor(0, 0, 0, 1);
    glClear(GL_COLOR_BUFFER_BIT);
  }
  ImGui_ImplOpenGL3_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  ImGui::NewFrame();
}

void ReplayWindow::blit(unsigned fbo, std::pair<int, int> from, int w, int h, int x, int y) {
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, 0);
  glDisable(GL_SCISSOR_TEST);
  // Both bottom-up: the source's rows go as they are; window y from the top -> GL's.
  const int gy = h_ - y - h;
  const bool scaled = from.first != w || from.second != h;
  glBlitFramebuffer(0, 0, from.first, from.second, x, gy, x + w, gy + h, GL_COLOR_BUFFER_BIT,
                    scaled ? GL_LINEAR : GL_NEAREST);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
}

namespace {

template <class T>
void append(std::vector<char>& k, const T* p, std::size_t n) {
  const auto* b = reinterpret_cast<const char*>(p);
  k.insert(k.end(), b, b + n * sizeof(T));
}

// Everything a draw list makes the back end draw: vertices, indices, and per command its clip
// rectangle, texture, offsets and count (no callbacks are used here).
void append_list(std::vector<char>& k, const ImDrawList& l) {
  const int n[3] = {l.VtxBuffer.Size, l.IdxBuffer.Size, l.CmdBuffer.Size};
  append(k, n, 3);
  append(k, l.VtxBuffer.Data, static_cast<std::size_t>(l.VtxBuffer.Size));
  append(k, l.IdxBuffer.Data, static_cast<std::size_t>(l.IdxBuffer.Size));
  for (const ImDrawCmd& c : l.CmdBuffer) {
    append(k, &c.ClipRect, 1);
    append(k, &c.TextureId, 1);
    append(k, &c.VtxOffset, 1);
    append(k, &c.IdxOffset, 1);
    append(k, &c.ElemCount, 1);
  }
}

}  // namespace

// The window-pixel box a draw list's commands draw into (each command's triangles' box cut
// by its clip rectangle), one per command that draws anything.
std::vector<std::array<float, 4>> drawn_boxes(const ImDrawList& l) {
  std::vector<std::array<float, 4>> out;
  for (const ImDrawCmd& c : l.CmdBuffer) {
    float x0 = 1e30f, y0 = 1e30f, x1 = -1e30f, y1 = -1e30f;
    for (unsigned i = c.IdxOffset; i < c.IdxOffset + c.ElemCount; ++i) {
      const ImVec2 p = l.VtxBuffer[static_cast<int>(c.VtxOffset + l.IdxBuffer[static_cast<int>(i)])].pos;
      x0 = std::min(x0, p.x);
      y0 = std::min(y0, p.y);
      x1 = std::max(x1, p.x);
      y1 = std::max(y1, p.y);
    }
    x0 = std::max(x0, c.ClipRect.x);
    y0 = std::max(y0, c.ClipRect.y);
    x1 = std::min(x1, c.ClipRect.z);
    y1 = std::min(y1, c.ClipRect.w);
    if (x0 < x1 && y0 < y1) out.push_back({x0, y0, x1, y1});
  }
  return out;
}

cv::Mat ReplayWindow::end_frame(bool capture) {
  ImGui::Render();
  ImDrawData* dd = ImGui::GetDrawData();
  // The layer that can be cached (the windows) and the overlay (the foreground list).
  const ImDrawList* fg = ImGui::GetForegroundDrawList();
  std::vector<ImDrawList*> layer, over;
  for (int i = 0; i < dd->CmdListsCount; ++i) (dd->CmdLists[i] == fg ? over : layer).push_back(dd->CmdLists[i]);
  // Cacheable when all the layer draws lies in the HUD's areas (2 px more for the windows'
  // borders' anti-aliased fringe, which the copy then leaves out).
  bool cacheable = !areas_.empty();
  for (const ImDrawList* l : layer) {
    for (const auto& bx : drawn_boxes(*l)) {
      bool in = false;
      for (const auto& a : areas_)
        in = in || (bx[0] >= a[0] - 2 && bx[2] <= a[0] + a[2] + 2 && bx[1] >= a[1] - 2 && bx[3] <= a[1] + a[3] + 2);
      cacheable = cacheable && in;
    }
  }
  ImDrawData part = *dd;
  auto draw = [&](std::vector<ImDrawList*>& lists) {
    if (lists.empty()) return;
    part.CmdLists = lists.data();
    part.CmdListsCount = static_cast<int>(lists.size());
    part.TotalVtxCount = part.TotalIdxCount = 0;
    for (const ImDrawList* l : lists) {
      part.TotalVtxCount += l->VtxBuffer.Size;
      part.TotalIdxCount += l->IdxBuffer.Size;
    }
    ImGui_ImplOpenGL3_RenderDrawData(&part);
  };
  // Copies a window rectangle (x0, y0, x1, y1 from the top left) of the cache into the window.
  auto copy = [&](int x0, int y0, int x1, int y1) {
    if (x0 >= x1 || y0 >= y1) return;
    glBlitFramebuffer(x0, h_ - y1, x1, h_ - y0, x0, h_ - y1, x1, h_ - y0, GL_COLOR_BUFFER_BIT, GL_NEAREST);
  };
  if (cacheable) {
    key_scratch_.clear();
    for (const ImDrawList* l : layer) append_list(key_scratch_, *l);
    bool redrawn = false;
    if (!cache_valid_ || key_scratch_ != cache_key_) {
      if (cache_fbo_ == 0) {
        GLuint t = 0, f = 0;
        glGenTextures(1, &t);
        glBindTexture(GL_TEXTURE_2D, t);
        glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA8, w_, h_);
        glBindTexture(GL_TEXTURE_2D, 0);
        glGenFramebuffers(1, &f);
        glBindFramebuffer(GL_FRAMEBUFFER, f);
        glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, t, 0);
        cache_tex_ = t;
        cache_fbo_ = f;
      }
      glBindFramebuffer(GL_FRAMEBUFFER, cache_fbo_);
      glViewport(0, 0, w_, h_);
      glDisable(GL_SCISSOR_TEST);
      glClearColor(0, 0, 0, 1);  // as the window under an uncached HUD
      glClear(GL_COLOR_BUFFER_BIT);
      draw(layer);
      cache_key_.swap(key_scratch_);
      cache_valid_ = true;
      redrawn = true;
      ++hud_draws_;
    }
    // The cached HUD into its areas (1:1): all of them when it changed or the window's back
    // buffer holds something else; else (a preserved back buffer) only where the last
    // frame's overlay drew. Then the overlay over it.
    glBindFramebuffer(GL_READ_FRAMEBUFFER, cache_fbo_);
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, 0);
    glDisable(GL_SCISSOR_TEST);
    const bool whole = redrawn || !preserved_ || !window_has_cache_;
    for (const auto& a : areas_) {
      if (whole) {
        copy(a[0], a[1], a[0] + a[2], a[1] + a[3]);
        continue;
      }
      for (const auto& r : overlay_boxes_)  // 2 px out for the lines' anti-aliased fringe
        copy(std::max(a[0], r[0] - 2), std::max(a[1], r[1] - 2), std::min(a[0] + a[2], r[2] + 2),
             std::min(a[1] + a[3], r[3] + 2));
    }
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    draw(over);
    window_has_cache_ = true;
  } else {
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    if (!areas_.empty()) {  // the HUD's areas hold the last frame's (or nothing defined)
      glEnable(GL_SCISSOR_TEST);
      glClearColor(0, 0, 0, 1);
      for (const auto& a : areas_) {
        glScissor(a[0], h_ - a[1] - a[3], a[2], a[3]);
        glClear(GL_COLOR_BUFFER_BIT);
      }
      glDisable(GL_SCISSOR_TEST);
    }
    ImGui_ImplOpenGL3_RenderDrawData(dd);
    window_has_cache_ = false;
    ++hud_draws_;
  }
  overlay_boxes_.clear();
  bool overlay_inside = true;
  for (const ImDrawList* l : over)
    for (const auto& bx : drawn_boxes(*l)) {
      overlay_boxes_.push_back({static_cast<int>(std::floor(bx[0])), static_cast<int>(std::floor(bx[1])),
                                static_cast<int>(std::ceil(bx[2])), static_cast<int>(std::ceil(bx[3]))});
      bool in = false;
      for (const auto& a : areas_)
        in = in || (bx[0] >= a[0] && bx[2] <= a[0] + a[2] && bx[1] >= a[1] && bx[3] <= a[1] + a[3]);
      overlay_inside = overlay_inside && in;
    }
  caller_kept_ = preserved_ && cacheable && overlay_inside;
  cv::Mat px;
  if (capture) {
    cv::Mat rgba(h_, w_, CV_8UC4);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadPixels(0, 0, w_, h_, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data);
    cv::cvtColor(rgba, px, cv::COLOR_RGBA2BGR);
    cv::flip(px, px, 0);
  }
  glfwSwapBuffers(win_);
  return px;
}

}  // namespace dentar::replay
