// Move-only owning wrappers for OpenGL ES 3 objects, shader compilation and
// an offscreen render target (FBO) with readback.
//
// Thread/context: every object here belongs to the EGL context that was
// current when it was created (see egl_context.h) and must be destroyed on the
// thread where that context is current, before the context itself. A
// default-constructed (or moved-from) handle holds 0 and destroys nothing.
#pragma once

#include <GLES3/gl3.h>

#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "dentar/volume/result.h"

namespace dentar::ar {

namespace gl_detail {
void delete_buffer(GLuint id);
void delete_vertex_array(GLuint id);
void delete_framebuffer(GLuint id);
void delete_renderbuffer(GLuint id);
void delete_texture(GLuint id);
void delete_shader(GLuint id);
void delete_program(GLuint id);
}  // namespace gl_detail

// One GL object name with a deleter; move-only like a unique_ptr.
template <void (*Deleter)(GLuint)>
class GlHandle {
 public:
  GlHandle() = default;
  explicit GlHandle(GLuint id) : id_(id) {}
  GlHandle(GlHandle&& o) noexcept : id_(std::exchange(o.id_, 0)) {}
  GlHandle& operator=(GlHandle&& o) noexcept {
    if (this != &o) {
      reset();
      id_ = std::exchange(o.id_, 0);
    }
    return *this;
  }
  GlHandle(const GlHandle&) = delete;
  GlHandle& operator=(const GlHandle&) = delete;
  ~GlHandle() { reset(); }

  GLuint id() const { return id_; }
  explicit operator bool() const { return id_ != 0; }
  // Gives up ownership: the caller deletes the name (as unique_ptr::release).
  GLuint release() { return std::exchange(id_, 0); }
  void reset() {
    if (id_ != 0) Deleter(id_);
    id_ = 0;
  }

 private:
  GLuint id_ = 0;
};

using Buffer = GlHandle<gl_detail::delete_buffer>;
using VertexArray = GlHandle<gl_detail::delete_vertex_array>;
using Framebuffer = GlHandle<gl_detail::delete_framebuffer>;
using Renderbuffer = GlHandle<gl_detail::delete_renderbuffer>;
using Texture = GlHandle<gl_detail::delete_texture>;
using Shader = GlHandle<gl_detail::delete_shader>;
using Program = GlHandle<gl_detail::delete_program>;

// glGen* wrappers: a fresh, owned name.
Buffer make_buffer();
VertexArray make_vertex_array();
Framebuffer make_framebuffer();
Renderbuffer make_renderbuffer();
Texture make_texture();
// A 2D texture of one level of `internal_format` (immutable storage), nearest
// sampling and clamped edges: for passes that fetch texels exactly. Leaves it
// bound to GL_TEXTURE_2D of the active unit.
Texture make_texture_2d(GLenum internal_format, int width_px, int height_px);

// Vertex shader source of one triangle covering the viewport, made from
// gl_VertexID alone (glDrawArrays(GL_TRIANGLES, 0, 3) with an empty vertex
// array), at NDC depth 0, or on the far plane (depth 1) when far_plane.
std::string full_screen_triangle_vertex_shader(bool far_plane = false);

// Compiles one shader stage; the error names the shader and carries the
// driver's info log.
Result<Shader> compile_shader(GLenum stage, std::string_view source, std::string_view name);
// Compiles and links a vertex + fragment program.
Result<Program> link_program(std::string_view vertex_source, std::string_view fragment_source,
                             std::string_view name);

// Empty when glGetError() reports nothing; else "where: GL_INVALID_ENUM (0x0500)"
// (drains every queued error).
std::string gl_error_message(std::string_view where);

// Offscreen framebuffer: RGBA8 colour + DEPTH24_STENCIL8 depth/stencil. The
// colour attachment is a renderbuffer, or a texture when it is to be sampled
// by a later pass (the distortion warp).
class RenderTarget {
 public:
  enum class ColorKind { kRenderbuffer, kTexture };
  RenderTarget() = default;
  // Needs a current GLES 3 context. Errors name the size and the framebuffer status.
  static Result<RenderTarget> create(int width_px, int height_px,
                                     ColorKind color = ColorKind::kRenderbuffer);

  // Binds as GL_FRAMEBUFFER and sets the viewport to the whole target.
  void bind() const;
  int width() const { return width_; }
  int height() const { return height_; }
  GLuint framebuffer() const { return fbo_.id(); }
  GLuint color_texture() const { return color_tex_.id(); }  // 0 for kRenderbuffer

  // Reads the colour attachment as tightly packed RGBA8, row 0 = image top
  // (OpenCV convention; GL's row 0 is the bottom, so rows are flipped).
  // out is resized to width*height*4.
  void read_rgba(std::vector<std::uint8_t>& out) const;
  // Same into a caller buffer of at least width*height*4 bytes with the given
  // row stride (bytes), e.g. a cv::Mat's data/step.
  void read_rgba(std::uint8_t* dst, std::size_t stride_bytes) const;

 private:
  int width_ = 0, height_ = 0;
  Framebuffer fbo_;
  Renderbuffer color_rb_, depth_rb_;
  Texture color_tex_;
  mutable std::vector<std::uint8_t> scratch_;  // GL-order rows before flipping
};

}  // namespace dentar::ar
