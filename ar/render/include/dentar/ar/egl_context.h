// Headless EGL display + OpenGL ES 3 context (no window, no X11).
//
// Platforms, in the order kAuto tries them:
//  - surfaceless: EGL_MESA_platform_surfaceless (Mesa; llvmpipe on CPU-only
//    machines, the GPU's render node otherwise);
//  - device: EGL_EXT_platform_device (also NVIDIA's driver), first device
//    unless device_index says otherwise.
// EGL_DEFAULT_DISPLAY is never used: on a headless machine it silently tries
// X11 and fails in a confusing way.
//
// The environment variable DENTAR_EGL_PLATFORM (surfaceless | device) forces
// one platform when the options say kAuto (useful to check CI against a
// specific path).
//
// Shared mode (EglContextOptions::share_display/share_context): the context
// is made on a display someone else initialised (a window's: GLFW's
// glfwGetEGLDisplay()) and shares objects (textures, sync objects) with that
// display's context share_context (the window's). This is how the live
// compositor's texture reaches the window without a CPU copy. The display is
// neither initialised nor terminated here; its owner must outlive this
// object. The context is made current without a surface when the display
// has EGL_KHR_surfaceless_context, else on a 1x1 pbuffer.
//
// Thread: an EGL context is current on at most one thread. create() makes it
// current on the calling thread; every GL object and renderer of this module
// must be created, used and destroyed on the thread where it is current.
#pragma once

#include <string>

#include "dentar/volume/result.h"

namespace dentar::ar {

enum class EglPlatform { kAuto, kSurfaceless, kDevice };
const char* egl_platform_name(EglPlatform p);

struct EglContextOptions {
  EglPlatform platform = EglPlatform::kAuto;
  int device_index = 0;  // kDevice only: which of eglQueryDevicesEXT's devices
  // Requested OpenGL ES version; the renderer needs 3.0 or later. A version
  // the driver cannot give makes create() fail (the tests use 9.0).
  int gles_major = 3;
  int gles_minor = 0;
  // Test hook: a raw EGL platform enum passed to eglGetPlatformDisplayEXT
  // instead of the one `platform` names (0 = unused). Lets a test provoke the
  // "unsupported platform" error without unplugging the GPU.
  unsigned int raw_platform_enum_for_test = 0;
  // Shared mode (see above): an initialised EGLDisplay and an EGLContext on
  // it, both as void* (EGL's headers stay out of this header). The new
  // context uses share_context's client API (OpenGL ES) and config. Both
  // null = a headless display of its own (platform above).
  void* share_display = nullptr;
  void* share_context = nullptr;
};

// Owns an EGLDisplay (initialised) and an EGLContext. Move-only; the
// destructor releases the context from this thread, destroys it and
// terminates the display.
class EglContext {
 public:
  // Creates the display and context and makes it current on this thread.
  // Errors name the platform(s) tried, the failing EGL call and the EGL error
  // code (e.g. "EGL_BAD_MATCH (0x3009)").
  static Result<EglContext> create(const EglContextOptions& options = {});

  EglContext(EglContext&& o) noexcept;
  EglContext& operator=(EglContext&& o) noexcept;
  EglContext(const EglContext&) = delete;
  EglContext& operator=(const EglContext&) = delete;
  ~EglContext();

  // Makes the context current on the calling thread (surfaceless).
  Status make_current() const;
  EglPlatform platform() const { return platform_; }
  // GL_RENDERER / GL_VERSION strings, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)".
  const std::string& gl_renderer() const { return renderer_; }
  const std::string& gl_version() const { return version_; }
  bool shared() const { return !owns_display_; }
  // The EGLDisplay / EGLContext (as void*): what another EglContext's shared
  // mode takes (EglContextOptions::share_display/share_context).
  void* native_display() const { return display_; }
  void* native_context() const { return context_; }
  // One line for logs: platform, renderer, version.
  std::string description() const;

 private:
  EglContext() = default;
  void reset() noexcept;

  // EGLDisplay / EGLContext are opaque pointers; kept as void* so EGL's
  // headers (and their optional X11 includes) stay out of this header.
  void* display_ = nullptr;
  void* context_ = nullptr;
  void* surface_ = nullptr;     // shared mode without surfaceless: a 1x1 pbuffer
  bool owns_display_ = true;    // false in shared mode (the window's display)
  EglPlatform platform_ = EglPlatform::kAuto;
  std::string renderer_, version_;
};

// Readable name of an EGL error code: "EGL_BAD_MATCH (0x3009)".
std::string egl_error_string(int code);

}  // namespace dentar::ar
