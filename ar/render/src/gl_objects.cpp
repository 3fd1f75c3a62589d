#include "dentar/ar/gl_objects.h"

#include <cassert>
#include <cstdio>
#include <cstring>

namespace dentar::ar {
namespace gl_detail {
void delete_buffer(GLuint id) { glDeleteBuffers(1, &id); }
void delete_vertex_array(GLuint id) { glDeleteVertexArrays(1, &id); }
void delete_framebuffer(GLuint id) { glDeleteFramebuffers(1, &id); }
void delete_renderbuffer(GLuint id) { glDeleteRenderbuffers(1, &id); }
void delete_texture(GLuint id) { glDeleteTextures(1, &id); }
void delete_shader(GLuint id) { glDeleteShader(id); }
void delete_program(GLuint id) { glDeleteProgram(id); }
}  // namespace gl_detail

Buffer make_buffer() {
  GLuint id = 0;
  glGenBuffers(1, &id);
  return Buffer(id);
}
VertexArray make_vertex_array() {
  GLuint id = 0;
  glGenVertexArrays(1, &id);
  return VertexArray(id);
}
Framebuffer make_framebuffer() {
  GLuint id = 0;
  glGenFramebuffers(1, &id);
  return Framebuffer(id);
}
Renderbuffer make_renderbuffer() {
  GLuint id = 0;
  glGenRenderbuffers(1, &id);
  return Renderbuffer(id);
}
Texture make_texture() {
  GLuint id = 0;
  glGenTextures(1, &id);
  return Texture(id);
}

Texture make_texture_2d(GLenum internal_format, int width_px, int height_px) {
  Texture t = make_texture();
  glBindTexture(GL_TEXTURE_2D, t.id());
  glTexStorage2D(GL_TEXTURE_2D, 1, internal_format, width_px, height_px);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  return t;
}

std::string full_screen_triangle_vertex_shader(bool far_plane) {
  // Vertices (-1,-1), (3,-1), (-1,3): the viewport is inside, clipped once.
  return std::string(R"(#version 300 es
void main() {
  vec2 p = vec2(gl_VertexID == 1 ? 3.0 : -1.0, gl_VertexID == 2 ? 3.0 : -1.0);
  gl_Position = vec4(p, )") +
         (far_plane ? "1.0" : "0.0") + R"(, 1.0);
}
)";
}

std::string gl_error_message(std::string_view where) {
  std::string msg;
  for (GLenum e = glGetError(); e != GL_NO_ERROR; e = glGetError()) {
    const char* name = "GL error";
    switch (e) {
      case GL_INVALID_ENUM:
        name = "GL_INVALID_ENUM";
        break;
      case GL_INVALID_VALUE:
        name = "GL_INVALID_VALUE";
        break;
      case GL_INVALID_OPERATION:
        name = "GL_INVALID_OPERATION";
        break;
      case GL_INVALID_FRAMEBUFFER_OPERATION:
        name = "GL_INVALID_FRAMEBUFFER_OPERATION";
        break;
      case GL_OUT_OF_MEMORY:
        name = "GL_OUT_OF_MEMORY";
        break;
      default:
        break;
    }
    char buf[64];
    std::snprintf(buf, sizeof(buf), "%s (0x%04X)", name, e);
    msg += msg.empty() ? std::string(where) + ": " + buf : std::string(", ") + buf;
  }
  return msg;
}

Result<Shader> compile_shader(GLenum stage, std::string_view source, std::string_view name) {
  Shader s(glCreateShader(stage));
  if (!s) return Error{"glCreateShader failed for shader '" + std::string(name) + "'"};
  const char* src = source.data();
  const GLint len = static_cast<GLint>(source.size());
  glShaderSource(s.id(), 1, &src, &len);
  glCompileShader(s.id());
  GLint ok = GL_FALSE;
  glGetShaderiv(s.id(), GL_COMPILE_STATUS, &ok);
  if (ok != GL_TRUE) {
    GLint log_len = 0;
    glGetShaderiv(s.id(), GL_INFO_LOG_LENGTH, &log_len);
    std::string log(static_cast<std::size_t>(log_len > 0 ? log_len : 1), '\0');
    glGetShaderInfoLog(s.id(), static_cast<GLsizei>(log.size()), nullptr, log.data());
    return Error{"shader '" + std::string(name) + "' (" +
                 (stage == GL_VERTEX_SHADER ? "vertex" : "fragment") +
                 ") does not compile: " + log.c_str()};
  }
  return s;
}

Result<Program> link_program(std::string_view vertex_source, std::string_view fragment_source,
                             std::string_view name) {
  auto vs = compile_shader(GL_VERTEX_SHADER, vertex_source, name);
  if (!vs) return Error{vs.error()};
  auto fs = compile_shader(GL_FRAGMENT_SHADER, fragment_source, name);
  if (!fs) return Error{fs.error()};
  Program p(glCreateProgram());
  glAttachShader(p.id(), vs->id());
  glAttachShader(p.id(), fs->id());
  glLinkProgram(p.id());
  GLint ok = GL_FALSE;
  glGetProgramiv(p.id(), GL_LINK_STATUS, &ok);
  if (ok != GL_TRUE) {
    GLint log_len = 0;
    glGetProgramiv(p.id(), GL_INFO_LOG_LENGTH, &log_len);
    std::string log(static_cast<std::size_t>(log_len > 0 ? log_len : 1), '\0');
    glGetProgramInfoLog(p.id(), static_cast<GLsizei>(log.size()), nullptr, log.data());
    return Error{"program '" + std::string(name) + "' does not link: " + log.c_str()};
  }
  // The program keeps the compiled code; the shader objects can go.
  glDetachShader(p.id(), vs->id());
  glDetachShader(p.id(), fs->id());
  return p;
}

Result<RenderTarget> RenderTarget::create(int width_px, int height_px, ColorKind color) {
  GLint max_size = 0;
  glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_size);
  const std::string size_str = std::to_string(width_px) + "x" + std::to_string(height_px);
  if (width_px <= 0 || height_px <= 0 || width_px > max_size || height_px > max_size) {
    return Error{"render target " + size_str + " px: each side must be in 1.." +
                 std::to_string(max_size) + " (GL_MAX_RENDERBUFFER_SIZE)"};
  }
  RenderTarget t;
  t.width_ = width_px;
  t.height_ = height_px;
  t.fbo_ = make_framebuffer();
  glBindFramebuffer(GL_FRAMEBUFFER, t.fbo_.id());
  if (color == ColorKind::kTexture) {
    t.color_tex_ = make_texture();
    glBindTexture(GL_TEXTURE_2D, t.color_tex_.id());
    glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA8, width_px, height_px);
    // Linear: the warp pass interpolates between texel centres.
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, t.color_tex_.id(),
                           0);
    glBindTexture(GL_TEXTURE_2D, 0);
  } else {
    t.color_rb_ = make_renderbuffer();
    glBindRenderbuffer(GL_RENDERBUFFER, t.color_rb_.id());
    glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width_px, height_px);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER,
                              t.color_rb_.id());
  }
  t.depth_rb_ = make_renderbuffer();
  glBindRenderbuffer(GL_RENDERBUFFER, t.depth_rb_.id());
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH24_STENCIL8, width_px, height_px);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_STENCIL_ATTACHMENT, GL_RENDERBUFFER,
                            t.depth_rb_.id());
  glBindRenderbuffer(GL_RENDERBUFFER, 0);
  const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  if (status != GL_FRAMEBUFFER_COMPLETE) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "0x%04X", status);
    return Error{"render target " + size_str + " px (RGBA8 + DEPTH24_STENCIL8) is incomplete: " +
                 "glCheckFramebufferStatus = " + buf};
  }
  if (auto e = gl_error_message("RenderTarget::create " + size_str); !e.empty()) return Error{e};
  return t;
}

void RenderTarget::bind() const {
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_.id());
  glViewport(0, 0, width_, height_);
}

void RenderTarget::read_rgba(std::vector<std::uint8_t>& out) const {
  out.resize(static_cast<std::size_t>(width_) * height_ * 4);
  read_rgba(out.data(), static_cast<std::size_t>(width_) * 4);
}

void RenderTarget::read_rgba(std::uint8_t* dst, std::size_t stride_bytes) const {
  assert(stride_bytes >= static_cast<std::size_t>(width_) * 4 &&
         "dentar::ar::RenderTarget::read_rgba: stride smaller than a row");
  const std::size_t row = static_cast<std::size_t>(width_) * 4;
  scratch_.resize(row * height_);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_.id());
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  // RGBA/UNSIGNED_BYTE is the one format/type pair GLES always accepts.
  glReadPixels(0, 0, width_, height_, GL_RGBA, GL_UNSIGNED_BYTE, scratch_.data());
  glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
  for (int y = 0; y < height_; ++y) {
    std::memcpy(dst + stride_bytes * y, scratch_.data() + row * (height_ - 1 - y), row);
  }
}

}  // namespace dentar::ar
