// See hud_window.h. Desktop GL 3.0 + Dear ImGui's GL3 backend; `dentar live` and `dentar calibrate live`.
#include "dentar/live/hud_window.h"

#define GLFW_INCLUDE_NONE
#define GL_GLEXT_PROTOTYPES
#include <GL/gl.h>
#include <GL/glext.h>
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace dentar::live {

Result<std::unique_ptr<HudWindow>> HudWindow::open(const std::string& title, int video_w, int video_h, int win_w,
                                                   int win_h, int display, bool vsync) {
  if (video_w <= 0 || video_h <= 0 || video_w > 16384 || video_h > 16384)
    return Error{"window: video size " + std::to_string(video_w) + "x" + std::to_string(video_h) + " is not usable"};
  std::unique_ptr<HudWindow> w(new HudWindow);
  if (!glfwInit()) return Error{"no display: GLFW cannot start (is $DISPLAY set? run under X, or Xvfb for tests)"};
  GLFWmonitor* monitor = nullptr;
  if (display >= 0) {
    int n = 0;
    GLFWmonitor** mons = glfwGetMonitors(&n);
    if (display >= n) {
      glfwTerminate();
      return Error{"--display " + std::to_string(display) + ": only " + std::to_string(n) + " monitor(s) connected (0.." + std::to_string(n - 1) + "); use -1 for a window"};
    }
    monitor = mons[display];
  }
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 0);
  int ww = win_w > 0 ? win_w : video_w, wh = win_h > 0 ? win_h : video_h;
  if (monitor) {
    const GLFWvidmode* mode = glfwGetVideoMode(monitor);
    ww = mode->width;
    wh = mode->height;
  }
  w->win_ = glfwCreateWindow(ww, wh, title.c_str(), monitor, nullptr);
  if (!w->win_) {
    glfwTerminate();
    return Error{"cannot open a window (no OpenGL 3.0 on this display?)"};
  }
  glfwMakeContextCurrent(w->win_);
  glfwSwapInterval(vsync ? 1 : 0);
  glfwSetWindowUserPointer(w->win_, w.get());
  glfwSetKeyCallback(w->win_, &HudWindow::on_key);
  GLuint tex = 0;
  glGenTextures(1, &tex);
  w->tex_ = tex;
  glBindTexture(GL_TEXTURE_2D, tex);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  // BGRA: llvmpipe's own layout, so an upload is a copy (GL_BGR into RGB8
  // went through Mesa's per-pixel format conversion).
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, video_w, video_h, 0, GL_BGRA, GL_UNSIGNED_BYTE, nullptr);
  w->tex_w_ = video_w;
  w->tex_h_ = video_h;
  GLuint fbo = 0;
  glGenFramebuffers(1, &fbo);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo);
  glFramebufferTexture2D(GL_READ_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, tex, 0);
  const GLenum fb_status = glCheckFramebufferStatus(GL_READ_FRAMEBUFFER);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
  w->fbo_ = fbo;
  if (fb_status != GL_FRAMEBUFFER_COMPLETE) return Error{"window: the video texture cannot be read as a framebuffer"};
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;
  ImGui_ImplGlfw_InitForOpenGL(w->win_, true);
  ImGui_ImplOpenGL3_Init("#version 130");
  w->imgui_ = true;
  return w;
}

HudWindow::~HudWindow() {
  if (imgui_) {
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
  }
  if (fbo_) {
    GLuint f = fbo_;
    glDeleteFramebuffers(1, &f);
  }
  if (tex_) {
    GLuint t = tex_;
    glDeleteTextures(1, &t);
  }
  if (win_) glfwDestroyWindow(win_);
  glfwTerminate();
}

void HudWindow::on_key(GLFWwindow* gw, int key, int, int action, int) {
  auto* w = static_cast<HudWindow*>(glfwGetWindowUserPointer(gw));
  if (!w) return;
  if (action == GLFW_PRESS) {
    w->presses_.push_back(key);
    w->held_.insert(key);
  } else if (action == GLFW_RELEASE) {
    w->held_.erase(key);
  }
}

bool HudWindow::should_close() const { return glfwWindowShouldClose(win_); }
void HudWindow::request_close() { glfwSetWindowShouldClose(win_, GLFW_TRUE); }
void HudWindow::poll() { glfwPollEvents(); }

std::vector<int> HudWindow::take_presses() {
  std::vector<int> out;
  out.swap(presses_);
  return out;
}

void HudWindow::inject_key(int key) { presses_.push_back(key); }
bool HudWindow::held(int key) const { return held_.count(key) > 0; }

void HudWindow::set_video(const cv::Mat& bgr) {
  if (bgr.empty() || bgr.cols != tex_w_ || bgr.rows != tex_h_ || bgr.type() != CV_8UC3) return;
  cv::cvtColor(bgr, bgra_, cv::COLOR_BGR2BGRA);  // SIMD; the buffer is kept between frames
  glBindTexture(GL_TEXTURE_2D, tex_);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, bgra_.cols, bgra_.rows, GL_BGRA, GL_UNSIGNED_BYTE, bgra_.data);
}

void HudWindow::begin_frame() {
  int fbw = 0, fbh = 0;
  glfwGetFramebufferSize(win_, &fbw, &fbh);
  glViewport(0, 0, fbw, fbh);
  // Video fills the window, aspect kept (letterbox), drawn by a framebuffer
  // blit, not a blended textured quad: at 1:1 (the default window) it is a
  // nearest-pixel copy, the window shows the composite's exact pixels, and
  // llvmpipe's cost per frame falls from a filtered, blended quad to a copy.
  const double s = std::min(double(fbw) / tex_w_, double(fbh) / tex_h_);
  const int dw = static_cast<int>(std::lround(tex_w_ * s)), dh = static_cast<int>(std::lround(tex_h_ * s));
  const int x0 = (fbw - dw) / 2, y0 = (fbh - dh) / 2;
  if (dw != fbw || dh != fbh) {
    glClearColor(0, 0, 0, 1);
    glClear(GL_COLOR_BUFFER_BIT);
  }
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, 0);
  // Image row 0 is the top; GL's window origin is the bottom: flip in the blit.
  glBlitFramebuffer(0, 0, tex_w_, tex_h_, x0, y0 + dh, x0 + dw, y0, GL_COLOR_BUFFER_BIT,
                    dw == tex_w_ && dh == tex_h_ ? GL_NEAREST : GL_LINEAR);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
  ImGui_ImplOpenGL3_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  ImGui::NewFrame();
}

cv::Mat HudWindow::end_frame(bool capture) {
  ImGui::Render();
  ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
  cv::Mat px;
  if (capture) {
    int fbw = 0, fbh = 0;
    glfwGetFramebufferSize(win_, &fbw, &fbh);
    px.create(fbh, fbw, CV_8UC3);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadBuffer(GL_BACK);
    glReadPixels(0, 0, fbw, fbh, GL_BGR, GL_UNSIGNED_BYTE, px.data);
    cv::flip(px, px, 0);
  }
  glfwSwapBuffers(win_);
  return px;
}

}  // namespace dentar::live
