// See hud_window.h. Desktop GL 3.0 + Dear ImGui's GL3 backend; `dentar live` and `dentar calibrate live`.
#include "dentar/live/hud_window.h"

#include "dentar/live/eye_output.h"

#define GLFW_INCLUDE_NONE
#define GL_GLEXT_PROTOTYPES
#include <GL/gl.h>
#include <GL/glext.h>
#include <GLFW/glfw3.h>
// glfwGetEGLDisplay/Context; EGL without X11's headers (their macros clash).
#define EGL_NO_X11
#define MESA_EGL_NO_X11_HEADERS
#define GLFW_EXPOSE_NATIVE_EGL
#include <GLFW/glfw3native.h>
#include <imgui.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>

#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace dentar::live {

const char* DisplayProfile::name(int p) {
  static const char* n[] = {"convert_left", "upload_left", "convert_right", "upload_right", "warp", "hud", "swap"};
  return p >= 0 && p < kParts ? n[p] : "?";
}

double thread_cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) * 1e-6;
}

namespace {
// One part of the profile: from construction to done() (a glFinish first when gl).
struct PartTimer {
  DisplayProfile& p;
  int part;
  double w0 = 0, c0 = 0;
  PartTimer(DisplayProfile& pr, int pt) : p(pr), part(pt) {
    if (!p.on) return;
    w0 = static_cast<double>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                 std::chrono::steady_clock::now().time_since_epoch()).count()) * 1e-6;
    c0 = thread_cpu_ms();
  }
  void done(bool gl) {
    if (!p.on) return;
    if (gl) glFinish();
    const double w1 = static_cast<double>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                              std::chrono::steady_clock::now().time_since_epoch()).count()) * 1e-6;
    p.wall_ms[part] = w1 - w0;
    p.cpu_ms[part] = thread_cpu_ms() - c0;
  }
};
}  // namespace

Result<std::unique_ptr<HudWindow>> HudWindow::open(const std::string& title, int video_w, int video_h, int win_w,
                                                   int win_h, int display, bool vsync, bool gles_egl) {
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
  int ww = win_w > 0 ? win_w : video_w, wh = win_h > 0 ? win_h : video_h;
  if (monitor) {
    const GLFWvidmode* mode = glfwGetVideoMode(monitor);
    ww = mode->width;
    wh = mode->height;
  }
  if (gles_egl) {
    // OpenGL ES 3.0 through EGL: its display and context can be shared with
    // the compositor's thread (egl_context.h, shared mode).
    glfwWindowHint(GLFW_CLIENT_API, GLFW_OPENGL_ES_API);
    glfwWindowHint(GLFW_CONTEXT_CREATION_API, GLFW_EGL_CONTEXT_API);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 0);
    w->win_ = glfwCreateWindow(ww, wh, title.c_str(), monitor, nullptr);
    if (w->win_) {
      w->gles_ = true;
    } else {
      const char* why = nullptr;
      glfwGetError(&why);
      w->note_ = std::string("no OpenGL ES 3 context through EGL for the window (") +
                 (why ? why : "GLFW gave no reason") + "); desktop OpenGL instead";
      glfwDefaultWindowHints();
    }
  }
  if (!w->win_) {
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 0);
    w->win_ = glfwCreateWindow(ww, wh, title.c_str(), monitor, nullptr);
  }
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
  // went through Mesa's per-pixel format conversion). OpenGL ES: RGBA.
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, video_w, video_h, 0, w->gles_ ? GL_RGBA : GL_BGRA, GL_UNSIGNED_BYTE,
               nullptr);
  w->tex_w_ = video_w;
  w->tex_h_ = video_h;
  {
    // The mono window until the driver sets another output (the loupe's
    // mapping needs intrinsics: a nominal camera until then).
    calibration::CameraIntrinsics nominal;
    nominal.width = video_w;
    nominal.height = video_h;
    nominal.fx = nominal.fy = video_w;
    nominal.cx = (video_w - 1) / 2.0;
    nominal.cy = (video_h - 1) / 2.0;
    auto out = make_mono_output(w->gles_, nominal);
    if (!out) return Error{"window: " + out.error()};
    w->output_ = std::move(*out);
  }
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;
  ImGui_ImplGlfw_InitForOpenGL(w->win_, true);
  ImGui_ImplOpenGL3_Init(w->gles_ ? "#version 300 es" : "#version 130");
  w->imgui_ = true;
  return w;
}

HudWindow::~HudWindow() {
  if (imgui_) {
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
  }
  output_.reset();  // its GL objects before the context
  if (tex_) {
    GLuint t = tex_;
    glDeleteTextures(1, &t);
  }
  for (unsigned tx : {tex_right_, tex_half_, tex_half_right_})
    if (tx) {
      GLuint t = tx;
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

// The upload's one conversion: BGR, or the camera's own YUYV (issue 28: a bare
// passthrough, a stalled camera's raw frame, or a keep_yuyv composite's video) straight to
// the texture's layout; a keep_yuyv composite's patch converted over it (session 20: the
// frame path no longer converts the whole frame to BGR for this one copy).
std::string upload_pixels(const cv::Mat& img, const cv::Mat& patch, const cv::Rect& patch_rect, bool gles,
                          cv::Mat& out) {
  if (img.type() != CV_8UC3 && img.type() != CV_8UC2)
    return "upload: the frame must be BGR (CV_8UC3) or YUYV (CV_8UC2); got " + cv::typeToString(img.type());
  if (!patch.empty()) {
    if (patch.type() != CV_8UC3)
      return "upload: the composite's patch must be BGR (CV_8UC3); got " + cv::typeToString(patch.type());
    if (patch.size() != patch_rect.size() || (patch_rect & cv::Rect(0, 0, img.cols, img.rows)) != patch_rect)
      return "upload: the composite's patch (" + std::to_string(patch.cols) + "x" + std::to_string(patch.rows) +
             ") does not fit its rectangle (" + std::to_string(patch_rect.x) + ", " + std::to_string(patch_rect.y) +
             ", " + std::to_string(patch_rect.width) + "x" + std::to_string(patch_rect.height) + ") in the " +
             std::to_string(img.cols) + "x" + std::to_string(img.rows) + " frame";
  }
  if (img.type() == CV_8UC2)
    cv::cvtColor(img, out, gles ? cv::COLOR_YUV2RGBA_YUYV : cv::COLOR_YUV2BGRA_YUYV);
  else
    cv::cvtColor(img, out, gles ? cv::COLOR_BGR2RGBA : cv::COLOR_BGR2BGRA);
  if (!patch.empty()) {
    cv::Mat dst = out(patch_rect);
    cv::cvtColor(patch, dst, gles ? cv::COLOR_BGR2RGBA : cv::COLOR_BGR2BGRA);
    if (dst.data != out(patch_rect).data) return "upload: the patch's conversion did not write in place";
  }
  return {};
}

namespace {
// The mean of two rows, rounded up (one byte each; vectorises to one average instruction).
void mean_rows(const std::uint8_t* __restrict a, const std::uint8_t* __restrict b, std::uint8_t* __restrict d, int n) {
  for (int i = 0; i < n; ++i) d[i] = static_cast<std::uint8_t>((a[i] + b[i] + 1) >> 1);
}
// The mean of each horizontal pair of 4-byte pixels, rounded up.
void mean_pairs(const std::uint8_t* __restrict s, std::uint8_t* __restrict d, int out_px) {
  for (int p = 0; p < out_px; ++p)
    for (int c = 0; c < 4; ++c) d[4 * p + c] = static_cast<std::uint8_t>((s[8 * p + c] + s[8 * p + 4 + c] + 1) >> 1);
}

// A video texture of w x h in the window's layout (BGRA; RGBA with GLES), linear filtering.
unsigned make_video_texture(int w, int h, bool gles) {
  GLuint t = 0;
  glGenTextures(1, &t);
  glBindTexture(GL_TEXTURE_2D, t);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, w, h, 0, gles ? GL_RGBA : GL_BGRA, GL_UNSIGNED_BYTE, nullptr);
  return t;
}

// The converted frame at the upload's scale: itself, or box-averaged 2x2 into `half`.
const cv::Mat& at_scale(const cv::Mat& full, int scale, cv::Mat& half) {
  if (scale != 2) return full;
  cv::resize(full, half, cv::Size(full.cols / 2, full.rows / 2), 0, 0, cv::INTER_AREA);
  return half;
}
}  // namespace

namespace {
cv::Mat& half_rows_scratch() {
  thread_local cv::Mat m;
  return m;
}
cv::Mat& half_conv_scratch() {
  thread_local cv::Mat m;
  return m;
}
}  // namespace

std::string upload_pixels_half(const cv::Mat& img, const cv::Mat& patch, const cv::Rect& patch_rect, bool gles,
                               cv::Mat& out) {
  if (img.type() != CV_8UC2 || img.cols % 2 != 0 || img.rows % 2 != 0)
    return "upload at half size: the frame must be YUYV (CV_8UC2) of even width and height; got " +
           cv::typeToString(img.type()) + " " + std::to_string(img.cols) + "x" + std::to_string(img.rows);
  if (!patch.empty() && (patch.type() != CV_8UC3 || patch.size() != patch_rect.size() ||
                         (patch_rect & cv::Rect(0, 0, img.cols, img.rows)) != patch_rect)) {
    cv::Mat none;
    return upload_pixels(img, patch, patch_rect, gles, none);  // its error names what is wrong
  }
  const int w = img.cols / 2, h = img.rows / 2;
  // The two rows of each texel averaged in the YUYV (a pixel pair keeps its shared chroma),
  // converted at full width (OpenCV's SIMD conversion, half the full frame's pixels), then each
  // pixel pair averaged: a quarter of the bytes of converting the whole frame first.
  cv::Mat& rows = half_rows_scratch();
  rows.create(h, img.cols, CV_8UC2);
  for (int y = 0; y < h; ++y)
    mean_rows(img.ptr<std::uint8_t>(2 * y), img.ptr<std::uint8_t>(2 * y + 1), rows.ptr<std::uint8_t>(y), img.cols * 2);
  cv::Mat& conv = half_conv_scratch();
  cv::cvtColor(rows, conv, gles ? cv::COLOR_YUV2RGBA_YUYV : cv::COLOR_YUV2BGRA_YUYV);
  out.create(h, w, CV_8UC4);
  for (int y = 0; y < h; ++y) mean_pairs(conv.ptr<std::uint8_t>(y), out.ptr<std::uint8_t>(y), w);
  if (!patch.empty() && !patch_rect.empty()) {
    // The patch's texels as the full-size path gives them: its rectangle grown to even bounds,
    // converted at full size with the patch over it, then the 2x2 mean.
    const int x0 = patch_rect.x & ~1, y0 = patch_rect.y & ~1;
    const int x1 = std::min(img.cols, (patch_rect.x + patch_rect.width + 1) & ~1);
    const int y1 = std::min(img.rows, (patch_rect.y + patch_rect.height + 1) & ~1);
    const cv::Rect even(x0, y0, x1 - x0, y1 - y0);
    cv::Mat full;
    cv::cvtColor(img(even), full, gles ? cv::COLOR_YUV2RGBA_YUYV : cv::COLOR_YUV2BGRA_YUYV);
    cv::Mat dst = full(patch_rect - even.tl());
    cv::cvtColor(patch, dst, gles ? cv::COLOR_BGR2RGBA : cv::COLOR_BGR2BGRA);
    cv::Mat half_dst = out(cv::Rect(x0 / 2, y0 / 2, even.width / 2, even.height / 2));
    cv::resize(full, half_dst, half_dst.size(), 0, 0, cv::INTER_AREA);
  }
  return {};
}

void HudWindow::set_video(const cv::Mat& bgr, const cv::Mat& patch, const cv::Rect& patch_rect) {
  if (bgr.empty() || bgr.cols != tex_w_ || bgr.rows != tex_h_ || (bgr.type() != CV_8UC3 && bgr.type() != CV_8UC2))
    return;
  // SIMD; the buffer is kept between frames.
  PartTimer conv(prof_, DisplayProfile::kConvertLeft);
  scale_ = want_scale_;
  // Session 23: a half-size texture of the camera's YUYV converted at half size, straight.
  const bool direct = scale_ == 2 && bgr.type() == CV_8UC2 && half_direct_;
  if (direct ? !upload_pixels_half(bgr, patch, patch_rect, gles_, half_).empty()
             : !upload_pixels(bgr, patch, patch_rect, gles_, bgra_).empty())
    return;
  const cv::Mat& px = direct ? half_ : at_scale(bgra_, scale_, half_);
  conv.done(false);
  PartTimer up(prof_, DisplayProfile::kUploadLeft);
  if (scale_ == 2 && tex_half_ == 0) tex_half_ = make_video_texture(tex_w_ / 2, tex_h_ / 2, gles_);
  glBindTexture(GL_TEXTURE_2D, scale_ == 2 ? tex_half_ : tex_);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, px.cols, px.rows, gles_ ? GL_RGBA : GL_BGRA, GL_UNSIGNED_BYTE, px.data);
  up.done(true);
  frame_video_ = 0;
}

void HudWindow::set_video_right(const cv::Mat& bgr, const cv::Mat& patch, const cv::Rect& patch_rect) {
  right_ = false;
  if (bgr.empty() || bgr.cols != tex_w_ || bgr.rows != tex_h_ || (bgr.type() != CV_8UC3 && bgr.type() != CV_8UC2))
    return;
  if (tex_right_ == 0) {
    GLuint t = 0;
    glGenTextures(1, &t);
    tex_right_ = t;
    glBindTexture(GL_TEXTURE_2D, t);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, tex_w_, tex_h_, 0, gles_ ? GL_RGBA : GL_BGRA, GL_UNSIGNED_BYTE, nullptr);
  }
  PartTimer conv(prof_, DisplayProfile::kConvertRight);
  const bool direct = scale_ == 2 && bgr.type() == CV_8UC2 && half_direct_;  // the left eye's scale
  if (direct ? !upload_pixels_half(bgr, patch, patch_rect, gles_, half_right_).empty()
             : !upload_pixels(bgr, patch, patch_rect, gles_, bgra_right_).empty())
    return;
  const cv::Mat& px = direct ? half_right_ : at_scale(bgra_right_, scale_, half_right_);
  conv.done(false);
  PartTimer up(prof_, DisplayProfile::kUploadRight);
  if (scale_ == 2 && tex_half_right_ == 0) tex_half_right_ = make_video_texture(tex_w_ / 2, tex_h_ / 2, gles_);
  glBindTexture(GL_TEXTURE_2D, scale_ == 2 ? tex_half_right_ : tex_right_);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, px.cols, px.rows, gles_ ? GL_RGBA : GL_BGRA, GL_UNSIGNED_BYTE, px.data);
  up.done(true);
  right_ = true;
}

void HudWindow::set_frame(unsigned video, unsigned overlay, const int region[4]) {
  frame_video_ = video;
  frame_overlay_ = overlay;
  for (int i = 0; i < 4; ++i) frame_region_[i] = region != nullptr ? region[i] : 0;
}

void HudWindow::set_output(std::unique_ptr<DisplayOutput> out) {
  if (out) output_ = std::move(out);
}

void HudWindow::set_loupe_centre(const double left[2], const double right[2]) {
  for (int i = 0; i < 2; ++i) {
    loupe_c_[0][i] = left[i];
    loupe_c_[1][i] = right[i];
  }
}

void* HudWindow::egl_display() const { return gles_ ? static_cast<void*>(glfwGetEGLDisplay()) : nullptr; }
void* HudWindow::egl_context() const { return gles_ ? static_cast<void*>(glfwGetEGLContext(win_)) : nullptr; }

int HudWindow::eye_rects(float rects[2][4]) const {
  int fbw = 0, fbh = 0, ww = 0, wh = 0;
  glfwGetFramebufferSize(win_, &fbw, &fbh);
  glfwGetWindowSize(win_, &ww, &wh);
  PanelRect r[2];
  const int n = fbw > 0 && fbh > 0 ? output_->eye_rects(fbw, fbh, tex_w_, tex_h_, r) : 0;
  const float sx = fbw > 0 ? float(ww) / float(fbw) : 1.0f, sy = fbh > 0 ? float(wh) / float(fbh) : 1.0f;
  for (int e = 0; e < n; ++e) {
    rects[e][0] = float(r[e].x) * sx;
    rects[e][1] = float(r[e].y) * sy;
    rects[e][2] = float(r[e].w) * sx;
    rects[e][3] = float(r[e].h) * sy;
  }
  return n;
}

void HudWindow::image_to_window(double x, double y, float& wx, float& wy, int eye) const {
  float r[2][4];
  const int n = eye_rects(r);
  if (n <= 0 || tex_w_ <= 0 || tex_h_ <= 0) {
    wx = static_cast<float>(x), wy = static_cast<float>(y);
    return;
  }
  const float* e = r[std::clamp(eye, 0, n - 1)];
  wx = e[0] + static_cast<float>(x) * e[2] / static_cast<float>(tex_w_);
  wy = e[1] + static_cast<float>(y) * e[3] / static_cast<float>(tex_h_);
}

void HudWindow::begin_frame() {
  int fbw = 0, fbh = 0;
  glfwGetFramebufferSize(win_, &fbw, &fbh);
  OutputFrame f;
  // The set_video textures at their scale (session 22); the GPU path's frames at the video's size.
  const bool half = frame_video_ == 0 && scale_ == 2;
  f.video = frame_video_ != 0 ? frame_video_ : half ? tex_half_ : tex_;
  f.overlay = frame_video_ != 0 ? frame_overlay_ : 0;
  f.right_video = right_ ? (half ? tex_half_right_ : tex_right_) : 0;
  for (int i = 0; i < 4; ++i) f.region[i] = frame_region_[i];
  f.tex_w = half ? tex_w_ / 2 : tex_w_;
  f.tex_h = half ? tex_h_ / 2 : tex_h_;
  for (int e = 0; e < 2; ++e)  // camera px (OpenCV) of the texture's size
    for (int i = 0; i < 2; ++i) f.loupe_c[e][i] = half ? (loupe_c_[e][i] + 0.5) / 2 - 0.5 : loupe_c_[e][i];
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, 0);
  PartTimer warp(prof_, DisplayProfile::kWarp);
  output_->draw(f, fbw, fbh);
  warp.done(true);
  hud_w0_ = prof_.on ? static_cast<double>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                               std::chrono::steady_clock::now().time_since_epoch()).count()) * 1e-6
                     : 0;
  hud_c0_ = prof_.on ? thread_cpu_ms() : 0;
  glViewport(0, 0, fbw, fbh);
  ImGui_ImplOpenGL3_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  ImGui::NewFrame();
}

cv::Mat HudWindow::end_frame(bool capture) {
  ImGui::Render();
  ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
  if (prof_.on) {  // the HUD: from begin_frame's end (ImGui's widgets built by the caller) to here
    glFinish();
    prof_.wall_ms[DisplayProfile::kHud] = static_cast<double>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                              std::chrono::steady_clock::now().time_since_epoch()).count()) * 1e-6 -
                                          hud_w0_;
    prof_.cpu_ms[DisplayProfile::kHud] = thread_cpu_ms() - hud_c0_;
  }
  cv::Mat px;
  if (capture) {
    int fbw = 0, fbh = 0;
    glfwGetFramebufferSize(win_, &fbw, &fbh);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadBuffer(GL_BACK);
    if (gles_) {  // OpenGL ES reads RGBA only
      cv::Mat rgba(fbh, fbw, CV_8UC4);
      glReadPixels(0, 0, fbw, fbh, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data);
      cv::cvtColor(rgba, px, cv::COLOR_RGBA2BGR);
    } else {
      px.create(fbh, fbw, CV_8UC3);
      glReadPixels(0, 0, fbw, fbh, GL_BGR, GL_UNSIGNED_BYTE, px.data);
    }
    cv::flip(px, px, 0);
  }
  PartTimer swap(prof_, DisplayProfile::kSwap);
  glfwSwapBuffers(win_);
  swap.done(false);
  return px;
}

}  // namespace dentar::live
