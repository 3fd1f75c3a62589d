// See window.h.
#include "window.h"

#define GLFW_INCLUDE_NONE
#include <GLES3/gl3.h>
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>

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

void ReplayWindow::begin_frame() {
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glViewport(0, 0, w_, h_);
  glDisable(GL_SCISSOR_TEST);
  glClearColor(0, 0, 0, 1);
  glClear(GL_COLOR_BUFFER_BIT);
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

cv::Mat ReplayWindow::end_frame(bool capture) {
  ImGui::Render();
  ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
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
