#include "dentar/ar/egl_context.h"

// Keep X11 out of EGL's platform header: this module never talks to X.
#ifndef EGL_NO_X11
#define EGL_NO_X11
#endif
#ifndef MESA_EGL_NO_X11_HEADERS
#define MESA_EGL_NO_X11_HEADERS
#endif
#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl3.h>

#include <cstdio>
#include <cstdlib>
#include <map>
#include <mutex>
#include <string_view>
#include <utility>
#include <vector>

namespace dentar::ar {
namespace {

// EGL display handles are per (platform, native display) singletons, and
// eglTerminate invalidates every context on them. Two EglContext objects in
// one process (two renderers, a test fixture and a test) must not terminate
// each other's display, so initialisations are counted here.
std::mutex g_display_mutex;
std::map<EGLDisplay, int>& display_refs() {
  static std::map<EGLDisplay, int> refs;
  return refs;
}
bool initialize_display(EGLDisplay d, EGLint* major, EGLint* minor) {
  std::lock_guard<std::mutex> lock(g_display_mutex);
  if (!eglInitialize(d, major, minor)) return false;
  ++display_refs()[d];
  return true;
}
void release_display(EGLDisplay d) {
  std::lock_guard<std::mutex> lock(g_display_mutex);
  auto it = display_refs().find(d);
  if (it == display_refs().end()) return;
  if (--it->second == 0) {
    display_refs().erase(it);
    eglTerminate(d);
  }
}

bool has_extension(const char* list, std::string_view name) {
  if (list == nullptr) return false;
  std::string_view all(list);
  std::size_t pos = 0;
  while ((pos = all.find(name, pos)) != std::string_view::npos) {
    const bool start_ok = pos == 0 || all[pos - 1] == ' ';
    const std::size_t end = pos + name.size();
    const bool end_ok = end == all.size() || all[end] == ' ';
    if (start_ok && end_ok) return true;
    pos = end;
  }
  return false;
}

std::string last_egl_error() { return egl_error_string(eglGetError()); }

struct Attempt {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
  std::string error;  // empty on success
};

// One platform: display, initialise, context, make current. Cleans up after
// itself on failure.
Attempt try_platform(EglPlatform platform, const EglContextOptions& o) {
  Attempt a;
  const char* client_ext = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (client_ext == nullptr) {
    a.error =
        "EGL client extensions are unavailable (needs EGL 1.5 or EGL_EXT_client_extensions; " +
        last_egl_error() + ")";
    return a;
  }
  auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
      eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (get_platform_display == nullptr || !has_extension(client_ext, "EGL_EXT_platform_base")) {
    a.error = "EGL_EXT_platform_base is missing from the client extensions";
    return a;
  }

  EGLenum platform_enum = 0;
  void* native = nullptr;
  if (o.raw_platform_enum_for_test != 0) {
    platform_enum = static_cast<EGLenum>(o.raw_platform_enum_for_test);
  } else if (platform == EglPlatform::kSurfaceless) {
    if (!has_extension(client_ext, "EGL_MESA_platform_surfaceless")) {
      a.error = "EGL_MESA_platform_surfaceless is not a client extension of this EGL";
      return a;
    }
    platform_enum = EGL_PLATFORM_SURFACELESS_MESA;
  } else {
    if (!has_extension(client_ext, "EGL_EXT_platform_device")) {
      a.error = "EGL_EXT_platform_device is not a client extension of this EGL";
      return a;
    }
    auto query_devices =
        reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    if (query_devices == nullptr) {
      a.error = "eglQueryDevicesEXT is unavailable (EGL_EXT_device_enumeration missing)";
      return a;
    }
    EGLint n = 0;
    if (!query_devices(0, nullptr, &n) || n <= 0) {
      a.error = "eglQueryDevicesEXT found no EGL device (" + last_egl_error() + ")";
      return a;
    }
    std::vector<EGLDeviceEXT> devices(static_cast<std::size_t>(n));
    query_devices(n, devices.data(), &n);
    if (o.device_index < 0 || o.device_index >= n) {
      a.error = "device_index " + std::to_string(o.device_index) + " is out of range (" +
                std::to_string(n) + " EGL devices)";
      return a;
    }
    native = devices[static_cast<std::size_t>(o.device_index)];
    platform_enum = EGL_PLATFORM_DEVICE_EXT;
  }

  char enum_hex[16];
  std::snprintf(enum_hex, sizeof(enum_hex), "0x%04X", static_cast<unsigned>(platform_enum));
  a.display = get_platform_display(platform_enum, native, nullptr);
  if (a.display == EGL_NO_DISPLAY) {
    a.error = std::string("eglGetPlatformDisplayEXT(platform ") + enum_hex +
              ") failed: " + last_egl_error();
    return a;
  }
  EGLint egl_major = 0, egl_minor = 0;
  if (!initialize_display(a.display, &egl_major, &egl_minor)) {
    a.error = "eglInitialize failed: " + last_egl_error();
    a.display = EGL_NO_DISPLAY;
    return a;
  }
  auto fail = [&](std::string msg) {
    if (a.context != EGL_NO_CONTEXT) eglDestroyContext(a.display, a.context);
    a.context = EGL_NO_CONTEXT;
    release_display(a.display);
    a.display = EGL_NO_DISPLAY;
    a.error = std::move(msg);
    return a;
  };
  const char* display_ext = eglQueryString(a.display, EGL_EXTENSIONS);
  // We render into FBOs only, so the context is made current with no surface.
  if (!has_extension(display_ext, "EGL_KHR_surfaceless_context")) {
    return fail(
        "the display lacks EGL_KHR_surfaceless_context (needed to render without a surface)");
  }
  if (!eglBindAPI(EGL_OPENGL_ES_API))
    return fail("eglBindAPI(EGL_OPENGL_ES_API) failed: " + last_egl_error());

  // The config only matters for default framebuffers, which we never use; any
  // GLES3-renderable one will do.
  const EGLint config_attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_ES3_BIT, EGL_SURFACE_TYPE, 0,
                                   EGL_NONE};
  EGLConfig config = nullptr;
  EGLint n_configs = 0;
  if (!eglChooseConfig(a.display, config_attribs, &config, 1, &n_configs) || n_configs < 1) {
    return fail("eglChooseConfig found no OpenGL ES 3 config (" + last_egl_error() + ")");
  }
  const EGLint context_attribs[] = {EGL_CONTEXT_MAJOR_VERSION, o.gles_major,
                                    EGL_CONTEXT_MINOR_VERSION, o.gles_minor, EGL_NONE};
  a.context = eglCreateContext(a.display, config, EGL_NO_CONTEXT, context_attribs);
  if (a.context == EGL_NO_CONTEXT) {
    return fail("eglCreateContext(OpenGL ES " + std::to_string(o.gles_major) + "." +
                std::to_string(o.gles_minor) + ") failed: " + last_egl_error());
  }
  if (!eglMakeCurrent(a.display, EGL_NO_SURFACE, EGL_NO_SURFACE, a.context)) {
    return fail("eglMakeCurrent(surfaceless) failed: " + last_egl_error());
  }
  GLint gl_major = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &gl_major);
  if (gl_major < 3) {
    eglMakeCurrent(a.display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    return fail("the context reports OpenGL ES major version " + std::to_string(gl_major) +
                "; the renderer needs 3.0 or later");
  }
  return a;
}

}  // namespace

const char* egl_platform_name(EglPlatform p) {
  switch (p) {
    case EglPlatform::kAuto:
      return "auto";
    case EglPlatform::kSurfaceless:
      return "surfaceless (EGL_PLATFORM_SURFACELESS_MESA)";
    case EglPlatform::kDevice:
      return "device (EGL_EXT_platform_device)";
  }
  return "?";
}

std::string egl_error_string(int code) {
  const char* name = "unknown EGL error";
  switch (code) {
    case EGL_SUCCESS:
      name = "EGL_SUCCESS";
      break;
    case EGL_NOT_INITIALIZED:
      name = "EGL_NOT_INITIALIZED";
      break;
    case EGL_BAD_ACCESS:
      name = "EGL_BAD_ACCESS";
      break;
    case EGL_BAD_ALLOC:
      name = "EGL_BAD_ALLOC";
      break;
    case EGL_BAD_ATTRIBUTE:
      name = "EGL_BAD_ATTRIBUTE";
      break;
    case EGL_BAD_CONFIG:
      name = "EGL_BAD_CONFIG";
      break;
    case EGL_BAD_CONTEXT:
      name = "EGL_BAD_CONTEXT";
      break;
    case EGL_BAD_CURRENT_SURFACE:
      name = "EGL_BAD_CURRENT_SURFACE";
      break;
    case EGL_BAD_DISPLAY:
      name = "EGL_BAD_DISPLAY";
      break;
    case EGL_BAD_MATCH:
      name = "EGL_BAD_MATCH";
      break;
    case EGL_BAD_NATIVE_PIXMAP:
      name = "EGL_BAD_NATIVE_PIXMAP";
      break;
    case EGL_BAD_NATIVE_WINDOW:
      name = "EGL_BAD_NATIVE_WINDOW";
      break;
    case EGL_BAD_PARAMETER:
      name = "EGL_BAD_PARAMETER";
      break;
    case EGL_BAD_SURFACE:
      name = "EGL_BAD_SURFACE";
      break;
    case EGL_CONTEXT_LOST:
      name = "EGL_CONTEXT_LOST";
      break;
    default:
      break;
  }
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%s (0x%04X)", name, static_cast<unsigned>(code));
  return buf;
}

namespace {

// Shared mode: a context on the window's display, sharing with its context,
// made current. Returns the error, or empty with the three handles set.
std::string create_shared(const EglContextOptions& o, void*& display_out, void*& context_out,
                          void*& surface_out) {
  auto dpy = static_cast<EGLDisplay>(o.share_display);
  auto share = static_cast<EGLContext>(o.share_context);
  if (share == EGL_NO_CONTEXT)
    return std::string("shared EGL context: share_display given without share_context");
  EGLint api = 0, config_id = 0, version = 0;
  if (!eglQueryContext(dpy, share, EGL_CONTEXT_CLIENT_TYPE, &api))
    return std::string("shared EGL context: eglQueryContext(share_context) failed: " + last_egl_error() +
                 " (is it a context of that display?)");
  if (api != EGL_OPENGL_ES_API)
    return std::string("shared EGL context: the window's context is not OpenGL ES (it is desktop "
                       "OpenGL); the compositor needs OpenGL ES 3");
  eglQueryContext(dpy, share, EGL_CONTEXT_CLIENT_VERSION, &version);
  if (version < 3)
    return std::string("shared EGL context: the window's context is OpenGL ES " + std::to_string(version) +
                 "; sharing needs OpenGL ES 3");
  if (!eglQueryContext(dpy, share, EGL_CONFIG_ID, &config_id))
    return std::string("shared EGL context: no EGL_CONFIG_ID on the window's context: " + last_egl_error());
  const EGLint by_id[] = {EGL_CONFIG_ID, config_id, EGL_NONE};
  EGLConfig config = nullptr;
  EGLint n = 0;
  if (!eglChooseConfig(dpy, by_id, &config, 1, &n) || n < 1)
    return std::string("shared EGL context: the window's config " + std::to_string(config_id) +
                 " cannot be found: " + last_egl_error());
  if (!eglBindAPI(EGL_OPENGL_ES_API))
    return std::string("shared EGL context: eglBindAPI(EGL_OPENGL_ES_API) failed: " + last_egl_error());
  const EGLint attribs[] = {EGL_CONTEXT_MAJOR_VERSION, o.gles_major, EGL_CONTEXT_MINOR_VERSION,
                            o.gles_minor, EGL_NONE};
  EGLContext ctx = eglCreateContext(dpy, config, share, attribs);
  if (ctx == EGL_NO_CONTEXT)
    return std::string("shared EGL context: eglCreateContext(OpenGL ES " + std::to_string(o.gles_major) +
                 "." + std::to_string(o.gles_minor) + ", shared with the window's) failed: " +
                 last_egl_error());
  EGLSurface surf = EGL_NO_SURFACE;
  if (!has_extension(eglQueryString(dpy, EGL_EXTENSIONS), "EGL_KHR_surfaceless_context")) {
    // A 1x1 pbuffer to be current on: we draw into FBOs only.
    const EGLint pb_cfg[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_ES3_BIT, EGL_SURFACE_TYPE,
                             EGL_PBUFFER_BIT, EGL_NONE};
    EGLConfig pc = nullptr;
    EGLint pn = 0;
    const EGLint pb_attr[] = {EGL_WIDTH, 1, EGL_HEIGHT, 1, EGL_NONE};
    if (eglChooseConfig(dpy, pb_cfg, &pc, 1, &pn) && pn > 0)
      surf = eglCreatePbufferSurface(dpy, pc, pb_attr);
    if (surf == EGL_NO_SURFACE) {
      eglDestroyContext(dpy, ctx);
      return std::string("shared EGL context: the window's display has neither "
                   "EGL_KHR_surfaceless_context nor a pbuffer config: " + last_egl_error());
    }
  }
  if (!eglMakeCurrent(dpy, surf, surf, ctx)) {
    const std::string e = last_egl_error();
    if (surf != EGL_NO_SURFACE) eglDestroySurface(dpy, surf);
    eglDestroyContext(dpy, ctx);
    return std::string("shared EGL context: eglMakeCurrent failed: " + e);
  }
  display_out = dpy;
  context_out = ctx;
  surface_out = surf;
  return {};
}

}  // namespace

Result<EglContext> EglContext::create(const EglContextOptions& options) {
  if (options.share_display != nullptr) {
    EglContext c;
    void *d = nullptr, *x = nullptr, *s = nullptr;
    if (std::string e = create_shared(options, d, x, s); !e.empty()) return Error{e};
    c.display_ = d;
    c.context_ = x;
    c.surface_ = s;
    c.owns_display_ = false;
    c.platform_ = EglPlatform::kAuto;
    auto str = [](GLenum name) {
      const auto* p = reinterpret_cast<const char*>(glGetString(name));
      return std::string(p != nullptr ? p : "?");
    };
    c.renderer_ = str(GL_RENDERER);
    c.version_ = str(GL_VERSION);
    return c;
  }
  std::vector<EglPlatform> order;
  EglPlatform requested = options.platform;
  if (requested == EglPlatform::kAuto) {
    if (const char* env = std::getenv("DENTAR_EGL_PLATFORM"); env != nullptr && *env != '\0') {
      const std::string_view v(env);
      if (v == "surfaceless") {
        requested = EglPlatform::kSurfaceless;
      } else if (v == "device") {
        requested = EglPlatform::kDevice;
      } else {
        return Error{"DENTAR_EGL_PLATFORM='" + std::string(v) +
                     "' is not a platform; use surfaceless or device (or unset it)"};
      }
    }
  }
  if (requested == EglPlatform::kAuto) {
    order = {EglPlatform::kSurfaceless, EglPlatform::kDevice};
  } else {
    order = {requested};
  }

  std::string errors;
  for (EglPlatform p : order) {
    Attempt a = try_platform(p, options);
    if (a.error.empty()) {
      EglContext c;
      c.display_ = a.display;
      c.context_ = a.context;
      c.platform_ = p;
      auto str = [](GLenum name) {
        const auto* s = reinterpret_cast<const char*>(glGetString(name));
        return std::string(s != nullptr ? s : "?");
      };
      c.renderer_ = str(GL_RENDERER);
      c.version_ = str(GL_VERSION);
      return c;
    }
    if (!errors.empty()) errors += "; ";
    errors += std::string("platform ") + egl_platform_name(p) + ": " + a.error;
  }
  return Error{"no headless EGL context: " + errors +
               ". Install Mesa's EGL (libegl-mesa0) or a GPU driver with EGL_EXT_platform_device"};
}

EglContext::EglContext(EglContext&& o) noexcept
    : display_(std::exchange(o.display_, nullptr)),
      context_(std::exchange(o.context_, nullptr)),
      surface_(std::exchange(o.surface_, nullptr)),
      owns_display_(o.owns_display_),
      platform_(o.platform_),
      renderer_(std::move(o.renderer_)),
      version_(std::move(o.version_)) {}

EglContext& EglContext::operator=(EglContext&& o) noexcept {
  if (this != &o) {
    reset();
    display_ = std::exchange(o.display_, nullptr);
    context_ = std::exchange(o.context_, nullptr);
    surface_ = std::exchange(o.surface_, nullptr);
    owns_display_ = o.owns_display_;
    platform_ = o.platform_;
    renderer_ = std::move(o.renderer_);
    version_ = std::move(o.version_);
  }
  return *this;
}

EglContext::~EglContext() { reset(); }

void EglContext::reset() noexcept {
  if (display_ == nullptr) return;
  if (context_ != nullptr) {
    if (eglGetCurrentContext() == static_cast<EGLContext>(context_)) {
      eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    }
    eglDestroyContext(display_, context_);
  }
  if (surface_ != nullptr) eglDestroySurface(display_, surface_);
  if (owns_display_) release_display(display_);
  display_ = nullptr;
  context_ = nullptr;
  surface_ = nullptr;
}

Status EglContext::make_current() const {
  if (display_ == nullptr) return Error{"EglContext::make_current: the context was moved from"};
  if (!eglMakeCurrent(display_, surface_, surface_, context_)) {
    return Error{"eglMakeCurrent failed: " + last_egl_error()};
  }
  return {};
}

std::string EglContext::description() const {
  if (!owns_display_)
    return "shared with the window's context (its EGL display), " + renderer_ + ", " + version_;
  return std::string(egl_platform_name(platform_)) + ", " + renderer_ + ", " + version_;
}

}  // namespace dentar::ar
