// See eye_output.h. The per-eye pass: one full-viewport triangle whose fragment
// shader is headset.cpp's EyeMapping::map, channel by channel (render_eye_cpu
// is its CPU reference, and the tests hold the two together).
#include "dentar/live/eye_output.h"

#define GL_GLEXT_PROTOTYPES
#include <GL/gl.h>
#include <GL/glext.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace dentar::live {
namespace {

// kFull: one triangle covering the viewport.
const char* kVertFull = R"(
void main() {
  vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
)";

// The grid's live cells (headset.h WarpGrid): vertices in panel px; MESH: per-vertex
// texture coordinates of the red, green (a_rg) and blue (a_b) channels.
const char* kVertGrid = R"(
in vec2 a_xy;
in vec4 a_rg;
in vec2 a_b;
uniform vec4 u_pos;  // clip coordinates = a_xy * u_pos.xy + u_pos.zw
#if MESH
out vec4 v_rg;
out vec2 v_b;
#endif
void main() {
  gl_Position = vec4(a_xy * u_pos.xy + u_pos.zw, 0.0, 1.0);
#if MESH
  v_rg = a_rg;
  v_b = a_b;
#endif
}
)";

// EyeMapping::map with its affine parts folded on the CPU (EyePass::draw): the
// lens coordinates d from the fragment's position, one multiply-add from d to
// texture coordinates (the plain view or the full-view loupe), another inside the
// loupe's inset; no divisions and no branches: llvmpipe runs both sides of a
// branch under a mask, so the pre-warp's three fetches and the inset are
// compiled in or out (WARP, INSET) rather than switched by uniforms
// (docs/BENCHMARKS.md, "Issue 28 (session 15)"). MESH: the texture coordinates
// come interpolated from the vertices; LUT: the pre-warped d from a lookup texture.
const char* kFrag = R"(
uniform sampler2D u_tex;
uniform vec4 u_d;         // d = gl_FragCoord.xy * u_d.xy + u_d.zw (lens units)
uniform vec2 u_k;         // k1, k2
uniform vec3 u_chroma;    // radial scale per channel (R, G, B)
uniform vec4 u_view;      // texture coordinates = d' * u_view.xy + u_view.zw (d' = the pre-warped d)
uniform vec4 u_inset;     // inset centre and half size in lens units
uniform vec4 u_iview;     // inside the inset: (d' - centre) * u_iview.xy + u_iview.zw
#if LUT
uniform highp sampler2D u_lut;  // d' per viewport pixel (row 0 = the viewport's top)
uniform vec4 u_l;         // its texel = floor(gl_FragCoord.xy * u_l.xy + u_l.zw)
uniform ivec2 u_lsize;
#endif
#if MESH
in vec4 v_rg;
in vec2 v_b;
#endif
out vec4 o_color;

vec4 tap(vec2 uv) {
  vec2 ok = step(vec2(0.0), uv) * step(uv, vec2(1.0));
  return textureLod(u_tex, uv, 0.0) * (ok.x * ok.y);
}

vec4 fetch(vec2 dp) {
  vec2 uv = dp * u_view.xy + u_view.zw;
#if INSET
  vec2 e = dp - u_inset.xy;
  vec2 in2 = step(abs(e), u_inset.zw);
  uv = mix(uv, e * u_iview.xy + u_iview.zw, in2.x * in2.y);
#endif
  return tap(uv);
}

void main() {
#if MESH
#if WARP
  o_color = vec4(tap(v_rg.xy).r, tap(v_rg.zw).g, tap(v_b).b, 1.0);
#else
  o_color = vec4(tap(v_rg.zw).rgb, 1.0);
#endif
#elif LUT
  ivec2 t = clamp(ivec2(floor(gl_FragCoord.xy * u_l.xy + u_l.zw)), ivec2(0), u_lsize - 1);
  vec2 dg = texelFetch(u_lut, t, 0).rg;
#if WARP
  o_color = vec4(fetch(dg * u_chroma.x).r, fetch(dg * u_chroma.y).g, fetch(dg * u_chroma.z).b, 1.0);
#else
  o_color = vec4(fetch(dg).rgb, 1.0);
#endif
#else
  vec2 d = gl_FragCoord.xy * u_d.xy + u_d.zw;
  float r2 = dot(d, d);
  float g = 1.0 + u_k.x * r2 + u_k.y * r2 * r2;
#if WARP
  o_color = vec4(fetch(d * (g * u_chroma.x)).r, fetch(d * (g * u_chroma.y)).g, fetch(d * (g * u_chroma.z)).b, 1.0);
#else
  o_color = vec4(fetch(d * g).rgb, 1.0);
#endif
#endif
}
)";

GLuint compile(GLenum type, const std::string& src, std::string& err) {
  const GLuint s = glCreateShader(type);
  const char* p = src.c_str();
  glShaderSource(s, 1, &p, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048] = {0};
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    err = std::string("eye pass shader: ") + log;
    glDeleteShader(s);
    return 0;
  }
  return s;
}

}  // namespace

// What a mapping's grid depends on (EyeMapping's numbers, the grid's size). The loupe's
// fields only while it is on: with the loupe off (mag <= 0) eye_to_camera never reads them,
// and the display loop moves the loupe's centre with the tracked tooth on every frame
// (loupe on or off), which remade both eyes' grids on every frame (issue 28 session 19's
// profile: ~1.4 ms CPU a drawn frame at 2x1280x720).
std::vector<double> warp_grid_key(const EyeMapping& m, int cols, int rows) {
  const bool loupe = m.loupe.mag > 0;
  auto l = [&](double v) { return loupe ? v : 0.0; };
  return {double(m.vp[0]), double(m.vp[1]), double(m.vp[2]), double(m.vp[3]), m.lens_c[0], m.lens_c[1], m.norm, m.k1, m.k2,
          m.chroma[0], m.chroma[1], m.chroma[2], m.f_eye[0], m.f_eye[1], m.shift_tan, m.f_cam[0], m.f_cam[1], m.c_cam[0],
          m.c_cam[1], double(m.cam_w), double(m.cam_h), l(m.loupe.mag), l(m.loupe.inset ? 1.0 : 0.0), l(m.loupe.inset_cx),
          l(m.loupe.inset_cy), l(m.loupe.inset_w), l(m.loupe.inset_h), l(m.loupe_c[0]), l(m.loupe_c[1]), double(cols),
          double(rows)};
}

namespace {

// The GL pass of one EyeMapping, and the composed source texture of the GPU path.
class EyePass {
 public:
  ~EyePass() {
    for (GLuint p : prog_)
      if (p) glDeleteProgram(p);
    if (vao_) glDeleteVertexArrays(1, &vao_);
    for (Slot& s : slot_) {
      if (s.vao) glDeleteVertexArrays(1, &s.vao);
      if (s.buf[0]) glDeleteBuffers(2, s.buf);
      if (s.lut) glDeleteTextures(1, &s.lut);
    }
    if (comp_tex_) glDeleteTextures(1, &comp_tex_);
    if (fbo_[0]) glDeleteFramebuffers(2, fbo_);
  }

  // pass: the pre-warp's pass (eye_output.h); cell_px: the grid's cell size, panel px.
  Status init(bool gles, WarpPass pass = WarpPass::kFull, int cell_px = 16) {
    gles_ = gles;
    pass_ = pass;
    cell_px_ = cell_px;
    // The programs this pass draws with, compiled now (a shader error is an init error).
    const int kind = kind_of(pass_);
    for (int v = 0; v < 4; ++v)
      if (auto s = program(kind | v); !s) return Error{s.error()};
    if (kind != kFullTriangle)  // the loupe's inset is drawn as kFull
      for (int v = 0; v < 4; ++v)
        if (auto s = program(kFullTriangle | v); !s) return Error{s.error()};
    glGenVertexArrays(1, &vao_);
    glGenFramebuffers(2, fbo_);
    return {};
  }

  // The texture holding the whole composite: the video itself, or (GPU path)
  // video and overlay region composed into a texture of our own.
  GLuint source(const OutputFrame& f) {
    if (f.overlay == 0) return f.video;
    if (!comp_tex_ || comp_w_ != f.tex_w || comp_h_ != f.tex_h) {
      if (comp_tex_) glDeleteTextures(1, &comp_tex_);
      glGenTextures(1, &comp_tex_);
      glBindTexture(GL_TEXTURE_2D, comp_tex_);
      glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, f.tex_w, f.tex_h, 0, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
      comp_w_ = f.tex_w;
      comp_h_ = f.tex_h;
    }
    GLint prev_draw = 0, prev_read = 0;
    glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &prev_draw);
    glGetIntegerv(GL_READ_FRAMEBUFFER_BINDING, &prev_read);
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, fbo_[1]);
    glFramebufferTexture2D(GL_DRAW_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, comp_tex_, 0);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_[0]);
    glFramebufferTexture2D(GL_READ_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, f.video, 0);
    glBlitFramebuffer(0, 0, f.tex_w, f.tex_h, 0, 0, f.tex_w, f.tex_h, GL_COLOR_BUFFER_BIT, GL_NEAREST);
    const int* r = f.region;
    if (r[2] > r[0] && r[3] > r[1]) {
      glFramebufferTexture2D(GL_READ_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, f.overlay, 0);
      glBlitFramebuffer(r[0], r[1], r[2], r[3], r[0], r[1], r[2], r[3], GL_COLOR_BUFFER_BIT, GL_NEAREST);
    }
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, static_cast<GLuint>(prev_draw));
    glBindFramebuffer(GL_READ_FRAMEBUFFER, static_cast<GLuint>(prev_read));
    return comp_tex_;
  }

  // Draws m into the bound draw framebuffer (fb_h px high), the panel placed at
  // (off_x, off_y) (top-left) with `scale` framebuffer px per panel px.
  // scissor: only inside the loupe's inset (the mono window's loupe over the blit).
  // slot: which eye's grid and lookup texture (kept between frames while m is unchanged):
  // 0-1 the eyes of a stereo pair, 2-3 the eyes of the mono view.
  void draw(GLuint tex, const EyeMapping& m, int fb_h, double off_x, double off_y, double scale, bool inset_only = false,
            int slot = 0) {
    const int x = static_cast<int>(std::lround(off_x + m.vp[0] * scale));
    const int y_top = static_cast<int>(std::lround(off_y + m.vp[1] * scale));
    const int w = static_cast<int>(std::lround(m.vp[2] * scale)), h = static_cast<int>(std::lround(m.vp[3] * scale));
    const int y_gl = fb_h - y_top - h;
    glViewport(x, y_gl, w, h);
    if (inset_only) {
      const double cx = m.vp[0] + m.loupe.inset_cx * m.vp[2], cy = m.vp[1] + m.loupe.inset_cy * m.vp[3];
      const double hw = m.loupe.inset_w * m.vp[2] / 2, hh = m.loupe.inset_h * m.vp[3] / 2;
      const int sx0 = static_cast<int>(std::lround(off_x + (cx - hw) * scale));
      const int sy0 = static_cast<int>(std::lround(off_y + (cy - hh) * scale));
      const int sx1 = static_cast<int>(std::lround(off_x + (cx + hw) * scale));
      const int sy1 = static_cast<int>(std::lround(off_y + (cy + hh) * scale));
      glEnable(GL_SCISSOR_TEST);
      glScissor(sx0, fb_h - sy1, sx1 - sx0, sy1 - sy0);
    }
    glDisable(GL_BLEND);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    // The radial pre-warp is in every program; the three fetches only with a chromatic scale.
    const bool chroma = m.chroma[0] != 1 || m.chroma[1] != 1 || m.chroma[2] != 1;
    const bool inset = m.loupe.mag > 0 && m.loupe.inset;
    // The loupe's inset: its mapping jumps at the inset's border (no mesh across it) and every
    // cell would be live (make_warp_grid): the one triangle, as kFull, is the cheaper draw.
    const int kind = inset ? kFullTriangle : kind_of(pass_);
    const Result<GLuint> pr = program(kind | (chroma ? 1 : 0) | (inset ? 2 : 0));
    if (!pr) return;  // compiled in init(): not reached
    const GLuint prog = *pr;
    glUseProgram(prog);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, tex);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    auto loc = [&](const char* n) { return glGetUniformLocation(prog, n); };
    glUniform1i(loc("u_tex"), 0);
    // Lens coordinates from the fragment: p (panel px, top-left) = ((x, fb_h - y) - off) / scale;
    // d = (p - vp - lens) / norm.
    const double sn = scale * m.norm;
    glUniform4f(loc("u_d"), float(1 / sn), float(-1 / sn),
                float(-off_x / sn - (m.vp[0] + m.lens_c[0]) / m.norm),
                float((fb_h - off_y) / sn - (m.vp[1] + m.lens_c[1]) / m.norm));
    glUniform2f(loc("u_k"), float(m.k1), float(m.k2));
    glUniform3f(loc("u_chroma"), float(m.chroma[0]), float(m.chroma[1]), float(m.chroma[2]));
    // Texture coordinates of the pre-warped d' (EyeMapping::eye_to_camera with q = lens + d' norm),
    // +0.5 from OpenCV's pixel centres to GL's, over the camera's size.
    const double W = m.cam_w, H = m.cam_h;
    const bool full = m.loupe.mag > 0 && !m.loupe.inset;
    const double mag = full ? m.loupe.mag : 1.0;
    const double bx = full ? m.loupe_c[0] : m.c_cam[0], by = full ? m.loupe_c[1] : m.c_cam[1];
    glUniform4f(loc("u_view"), float(m.f_cam[0] * m.norm / (m.f_eye[0] * mag * W)),
                float(m.f_cam[1] * m.norm / (m.f_eye[1] * mag * H)),
                float((bx - m.f_cam[0] * m.shift_tan / mag + 0.5) / W), float((by + 0.5) / H));
    glUniform4f(loc("u_inset"), float((m.loupe.inset_cx * m.vp[2] - m.lens_c[0]) / m.norm),
                float((m.loupe.inset_cy * m.vp[3] - m.lens_c[1]) / m.norm), float(m.loupe.inset_w * m.vp[2] / 2 / m.norm),
                float(m.loupe.inset_h * m.vp[3] / 2 / m.norm));
    const double im = inset ? m.loupe.mag : 1.0;
    glUniform4f(loc("u_iview"), float(m.f_cam[0] * m.norm / (m.f_eye[0] * im * W)),
                float(m.f_cam[1] * m.norm / (m.f_eye[1] * im * H)), float((m.loupe_c[0] + 0.5) / W),
                float((m.loupe_c[1] + 0.5) / H));
    if (kind == kFullTriangle) {
      glBindVertexArray(vao_);
      glDrawArrays(GL_TRIANGLES, 0, 3);
    } else {
      Slot& s = slot_[std::clamp(slot, 0, kSlots - 1)];
      update_grid(s, m);
      // Panel px to clip coordinates in this viewport (the unrounded placement, as u_d).
      glUniform4f(loc("u_pos"), float(2 * scale / w), float(-2 * scale / h), float(2 * (off_x - x) / w - 1),
                  float(2 * (fb_h - off_y - y_gl) / h - 1));
      if (kind == kGridLut) {
        glActiveTexture(GL_TEXTURE1);
        update_lut(s, m);
        glBindTexture(GL_TEXTURE_2D, s.lut);
        glUniform1i(loc("u_lut"), 1);
        // The viewport's pixel under the fragment: p - vp, p = ((x, fb_h - y) - off) / scale.
        glUniform4f(loc("u_l"), float(1 / scale), float(-1 / scale), float(-off_x / scale - m.vp[0]),
                    float((fb_h - off_y) / scale - m.vp[1]));
        glUniform2i(loc("u_lsize"), m.vp[2], m.vp[3]);
        glActiveTexture(GL_TEXTURE0);
      }
      glBindVertexArray(s.vao);
      glDrawElements(GL_TRIANGLES, s.count, GL_UNSIGNED_INT, nullptr);
    }
    glBindVertexArray(0);
    glUseProgram(0);
    if (inset_only) glDisable(GL_SCISSOR_TEST);
  }

  // The live cells drawn in the last draw of eye `slot` (tests, benchmark).
  int live_cells(int slot) const { return slot_[std::clamp(slot, 0, kSlots - 1)].count / 6; }
  // How many times an eye's grid was made (the first draw of each eye, then a mapping changed).
  std::int64_t grid_builds() const { return grid_builds_; }

 private:
  // Program kinds (bits 2-3 of a program's index; bit 0 WARP, bit 1 INSET).
  static constexpr int kFullTriangle = 0, kGridExact = 4, kGridMesh = 8, kGridLut = 12;
  static int kind_of(WarpPass p) {
    switch (p) {
      case WarpPass::kFull: return kFullTriangle;
      case WarpPass::kExact: return kGridExact;
      case WarpPass::kMesh: return kGridMesh;
      case WarpPass::kLut: return kGridLut;
    }
    return kGridExact;
  }

  Result<GLuint> program(int i) {
    if (prog_[i]) return prog_[i];
    const std::string head = gles_ ? "#version 300 es\nprecision highp float;\nprecision highp int;\n" : "#version 130\n";
    const int kind = i & 12;
    const std::string defs = std::string("#define WARP ") + (i & 1 ? "1" : "0") + "\n#define INSET " + (i & 2 ? "1" : "0") +
                             "\n#define MESH " + (kind == kGridMesh ? "1" : "0") + "\n#define LUT " +
                             (kind == kGridLut ? "1" : "0") + "\n";
    std::string err;
    const GLuint vs = compile(GL_VERTEX_SHADER, head + defs + (kind == kFullTriangle ? kVertFull : kVertGrid), err);
    if (!vs) return Error{err};
    const GLuint fs = compile(GL_FRAGMENT_SHADER, head + defs + kFrag, err);
    if (!fs) {
      glDeleteShader(vs);
      return Error{err};
    }
    const GLuint p = glCreateProgram();
    glAttachShader(p, vs);
    glAttachShader(p, fs);
    if (kind != kFullTriangle) {
      glBindAttribLocation(p, 0, "a_xy");
      glBindAttribLocation(p, 1, "a_rg");
      glBindAttribLocation(p, 2, "a_b");
    }
    glLinkProgram(p);
    glDeleteShader(vs);
    glDeleteShader(fs);
    GLint ok = 0;
    glGetProgramiv(p, GL_LINK_STATUS, &ok);
    if (!ok) {
      char log[2048] = {0};
      glGetProgramInfoLog(p, sizeof log, nullptr, log);
      glDeleteProgram(p);
      return Error{std::string("eye pass shader link: ") + log};
    }
    prog_[i] = p;
    return p;
  }

  // One eye's grid (vertex and index buffers) and lookup texture, remade when its mapping changes.
  struct Slot {
    GLuint vao = 0, buf[2] = {0, 0}, lut = 0;
    GLsizei count = 0;
    std::vector<double> key, lut_key;
  };

  void update_grid(Slot& s, const EyeMapping& m) {
    const int cols = std::max(1, (m.vp[2] + cell_px_ - 1) / cell_px_), rows = std::max(1, (m.vp[3] + cell_px_ - 1) / cell_px_);
    std::vector<double> key = warp_grid_key(m, cols, rows);
    if (s.vao && key == s.key) return;
    ++grid_builds_;
    const WarpGrid g = make_warp_grid(m, cols, rows);
    const int nx = g.cols + 1, nv = nx * (g.rows + 1);
    std::vector<float> v(static_cast<std::size_t>(8 * nv));
    for (std::size_t k = 0; k < static_cast<std::size_t>(nv); ++k) {
      v[8 * k] = g.xy[2 * k];
      v[8 * k + 1] = g.xy[2 * k + 1];
      for (std::size_t c = 0; c < 6; ++c) v[8 * k + 2 + c] = g.uv[6 * k + c];
    }
    std::vector<GLuint> idx;
    idx.reserve(static_cast<std::size_t>(6 * g.live_cells()));
    for (int j = 0; j < g.rows; ++j)
      for (int i = 0; i < g.cols; ++i) {
        if (!g.live[static_cast<std::size_t>(j * g.cols + i)]) continue;
        const GLuint a = static_cast<GLuint>(j * nx + i), b = a + 1, c = a + static_cast<GLuint>(nx), d = c + 1;
        // Split along b-c, as warp_grid_error interpolates.
        for (const GLuint t : {a, b, c, b, d, c}) idx.push_back(t);
      }
    if (!s.vao) {
      glGenVertexArrays(1, &s.vao);
      glGenBuffers(2, s.buf);
      glBindVertexArray(s.vao);
      glBindBuffer(GL_ARRAY_BUFFER, s.buf[0]);
      glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, s.buf[1]);
      const GLsizei stride = 8 * sizeof(float);
      glEnableVertexAttribArray(0);
      glVertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(0));
      glEnableVertexAttribArray(1);
      glVertexAttribPointer(1, 4, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(2 * sizeof(float)));
      glEnableVertexAttribArray(2);
      glVertexAttribPointer(2, 2, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(6 * sizeof(float)));
    }
    glBindVertexArray(s.vao);
    glBindBuffer(GL_ARRAY_BUFFER, s.buf[0]);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(v.size() * sizeof(float)), v.data(), GL_STATIC_DRAW);
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(idx.size() * sizeof(GLuint)), idx.data(), GL_STATIC_DRAW);
    glBindVertexArray(0);
    glBindBuffer(GL_ARRAY_BUFFER, 0);
    s.count = static_cast<GLsizei>(idx.size());
    s.key = std::move(key);
  }

  void update_lut(Slot& s, const EyeMapping& m) {
    std::vector<double> key = {double(m.vp[2]), double(m.vp[3]), m.lens_c[0], m.lens_c[1], m.norm, m.k1, m.k2};
    if (s.lut && key == s.lut_key) return;
    const std::vector<float> lut = warp_lut(m, true);
    if (!s.lut) glGenTextures(1, &s.lut);
    glBindTexture(GL_TEXTURE_2D, s.lut);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RG16F, m.vp[2], m.vp[3], 0, GL_RG, GL_FLOAT, lut.data());
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    s.lut_key = std::move(key);
  }

  bool gles_ = true;
  std::int64_t grid_builds_ = 0;
  WarpPass pass_ = WarpPass::kFull;
  int cell_px_ = 16;
  GLuint prog_[16] = {};  // by WARP (bit 0), INSET (bit 1) and kind (bits 2-3)
  GLuint vao_ = 0;        // kFull's attribute-less triangle
  // Each eye's grid as a stereo pair's eye (slots 0, 1) and as the mono view's (2, 3): a pair
  // whose right eye is missing for a frame (unpaired, or its camera silent) draws the mono
  // view, and back; one slot per eye remade both grids at every switch (session 19: a third
  // of the frames under load).
  static constexpr int kSlots = 4;
  Slot slot_[kSlots];
  GLuint fbo_[2] = {0, 0};  // read (video / overlay) and draw (composed texture)
  GLuint comp_tex_ = 0;
  int comp_w_ = 0, comp_h_ = 0;
};

// Intrinsics of the composite's size (the station's may be of another size: scaled).
calibration::CameraIntrinsics at_size(calibration::CameraIntrinsics c, int w, int h) {
  if (c.width == w && c.height == h) return c;
  const double sx = double(w) / c.width, sy = double(h) / c.height;
  c.fx *= sx;
  c.cx = (c.cx + 0.5) * sx - 0.5;
  c.fy *= sy;
  c.cy = (c.cy + 0.5) * sy - 0.5;
  c.width = w;
  c.height = h;
  return c;
}

class MonoOutput final : public DisplayOutput {
 public:
  MonoOutput(const calibration::CameraIntrinsics& cam) : cam_(cam) {}
  Status init(bool gles) {
    glGenFramebuffers(1, &read_fbo_);
    return pass_.init(gles);
  }
  ~MonoOutput() override {
    if (read_fbo_) glDeleteFramebuffers(1, &read_fbo_);
  }
  const char* kind() const override { return "mono"; }
  std::int64_t warp_grid_builds() const override { return pass_.grid_builds(); }
  void set_loupe(const LoupeView& l) override { loupe_ = l; }
  void set_prewarp(bool) override {}
  int eye_rects(int fbw, int fbh, int tw, int th, PanelRect rects[2]) const override {
    rects[0] = letterbox(fbw, fbh, tw, th);
    return 1;
  }

  // The composite letterboxed into the window by a framebuffer blit (at 1:1
  // a nearest-pixel copy: the window shows the composite's exact pixels, and
  // llvmpipe's cost falls from a filtered, blended quad to a copy); then the
  // loupe's pass, when it is on.
  void draw(const OutputFrame& f, int fbw, int fbh) override {
    glViewport(0, 0, fbw, fbh);
    const int tw = f.tex_w, th = f.tex_h;
    const PanelRect lb = letterbox(fbw, fbh, tw, th);
    // GL's window origin is the bottom-left: the letterbox's bottom edge.
    const int dw = lb.w, dh = lb.h, x0 = lb.x, y0 = fbh - lb.y - lb.h;
    if (dw != fbw || dh != fbh) {
      glClearColor(0, 0, 0, 1);
      glClear(GL_COLOR_BUFFER_BIT);
    }
    const GLenum filter = dw == tw && dh == th ? GL_NEAREST : GL_LINEAR;
    GLint prev_read = 0;
    glGetIntegerv(GL_READ_FRAMEBUFFER_BINDING, &prev_read);
    // (Re)attached every frame: another context may have written the pixels,
    // and an attachment is where GL looks again.
    glBindFramebuffer(GL_READ_FRAMEBUFFER, read_fbo_);
    glFramebufferTexture2D(GL_READ_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, f.video, 0);
    // Image row 0 is the top; GL's window origin is the bottom: flip in the blit.
    glBlitFramebuffer(0, 0, tw, th, x0, y0 + dh, x0 + dw, y0, GL_COLOR_BUFFER_BIT, filter);
    const int* r = f.region;
    if (f.overlay != 0 && r[2] > r[0] && r[3] > r[1]) {
      // The overlay's region of a shared frame over the video, same mapping.
      auto wx = [&](int x) { return x0 + static_cast<int>(std::lround(double(x) * dw / tw)); };
      auto wy = [&](int y) { return y0 + dh - static_cast<int>(std::lround(double(y) * dh / th)); };
      glFramebufferTexture2D(GL_READ_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, f.overlay, 0);
      glBlitFramebuffer(r[0], r[1], r[2], r[3], wx(r[0]), wy(r[1]), wx(r[2]), wy(r[3]), GL_COLOR_BUFFER_BIT, GL_NEAREST);
    }
    glBindFramebuffer(GL_READ_FRAMEBUFFER, static_cast<GLuint>(prev_read));
    if (loupe_.mag > 0) {
      const calibration::CameraIntrinsics cam = at_size(cam_, tw, th);
      const EyeMapping m = make_window_mapping(fbw, fbh, cam, loupe_, f.loupe_c[0]);
      pass_.draw(pass_.source(f), m, fbh, 0, 0, 1, loupe_.inset);
      glViewport(0, 0, fbw, fbh);
    }
  }

 private:
  calibration::CameraIntrinsics cam_;
  LoupeView loupe_{};
  EyePass pass_;
  GLuint read_fbo_ = 0;
};

class SbsOutput final : public DisplayOutput {
 public:
  SbsOutput(const HeadsetProfile& h, const calibration::CameraIntrinsics& cam, bool stereo,
            const calibration::CameraIntrinsics& cam_right, WarpPass pass, int cell_px)
      : h_(h), cam_(cam), cam_right_(cam_right), warp_pass_(pass), cell_px_(cell_px) {
    (void)stereo;
    loupe_.mag = 0;
  }
  int eye_rects(int fbw, int fbh, int, int, PanelRect rects[2]) const override {
    const double s = std::min(double(fbw) / h_.panel_w, double(fbh) / h_.panel_h);
    const double ox = (fbw - h_.panel_w * s) / 2, oy = (fbh - h_.panel_h * s) / 2;
    for (int e = 0; e < 2; ++e) {
      const int* vp = h_.eyes[static_cast<std::size_t>(e)].viewport;
      rects[e].x = static_cast<int>(std::lround(ox + vp[0] * s));
      rects[e].y = static_cast<int>(std::lround(oy + vp[1] * s));
      rects[e].w = static_cast<int>(std::lround(vp[2] * s));
      rects[e].h = static_cast<int>(std::lround(vp[3] * s));
    }
    return 2;
  }
  Status init(bool gles) { return pass_.init(gles, warp_pass_, cell_px_); }
  const char* kind() const override { return "sbs"; }
  std::int64_t warp_grid_builds() const override { return pass_.grid_builds(); }
  void set_loupe(const LoupeView& l) override { loupe_ = l; }
  void set_prewarp(bool on) override { prewarp_ = on; }

  void draw(const OutputFrame& f, int fbw, int fbh) override {
    glViewport(0, 0, fbw, fbh);
    // The panel fills the framebuffer (full screen on the headset); a window
    // of another size shows it scaled, aspect kept.
    const double s = std::min(double(fbw) / h_.panel_w, double(fbh) / h_.panel_h);
    const double ox = (fbw - h_.panel_w * s) / 2, oy = (fbh - h_.panel_h * s) / 2;
    glClearColor(0, 0, 0, 1);
    glClear(GL_COLOR_BUFFER_BIT);
    const calibration::CameraIntrinsics cam = at_size(cam_, f.tex_w, f.tex_h);
    const calibration::CameraIntrinsics cam_r = at_size(cam_right_, f.tex_w, f.tex_h);
    const GLuint left = pass_.source(f);
    // A right eye's frame given: a stereo pair (no IPD shift, the right eye through its own
    // camera), whatever the output was made for.
    const bool stereo = f.right_video != 0;
    for (int e = 0; e < 2; ++e) {
      const EyeMapping m = make_eye_mapping(h_, e, e == 1 && stereo ? cam_r : cam, stereo, loupe_, f.loupe_c[e], prewarp_);
      pass_.draw(e == 1 && stereo ? f.right_video : left, m, fbh, ox, oy, s, false, e + (stereo ? 0 : 2));
    }
    glViewport(0, 0, fbw, fbh);
  }

 private:
  HeadsetProfile h_;
  calibration::CameraIntrinsics cam_, cam_right_;
  WarpPass warp_pass_;
  int cell_px_;
  bool prewarp_ = true;
  LoupeView loupe_{};
  EyePass pass_;
};

}  // namespace

Result<std::unique_ptr<DisplayOutput>> make_mono_output(bool gles, const calibration::CameraIntrinsics& cam) {
  auto o = std::make_unique<MonoOutput>(cam);
  if (auto s = o->init(gles); !s) return Error{s.error()};
  return std::unique_ptr<DisplayOutput>(std::move(o));
}

const char* warp_pass_name(WarpPass p) {
  switch (p) {
    case WarpPass::kFull: return "full";
    case WarpPass::kExact: return "exact";
    case WarpPass::kMesh: return "mesh";
    case WarpPass::kLut: return "lut";
  }
  return "?";
}

bool parse_warp_pass(const std::string& s, WarpPass& p) {
  for (const WarpPass q : {WarpPass::kFull, WarpPass::kExact, WarpPass::kMesh, WarpPass::kLut})
    if (s == warp_pass_name(q)) {
      p = q;
      return true;
    }
  return false;
}

Result<std::unique_ptr<DisplayOutput>> make_sbs_output(bool gles, const HeadsetProfile& profile,
                                                       const calibration::CameraIntrinsics& cam, bool stereo,
                                                       const calibration::CameraIntrinsics* cam_right, WarpPass pass,
                                                       int cell_px) {
  if (std::string v = profile.validate(); !v.empty()) return Error{"headset profile: " + v};
  if (cell_px < 4 || cell_px > 128)
    return Error{"warp grid: cell_px = " + std::to_string(cell_px) + " must be in 4..128 panel px"};
  auto o = std::make_unique<SbsOutput>(profile, cam, stereo, cam_right != nullptr ? *cam_right : cam, pass, cell_px);
  if (auto s = o->init(gles); !s) return Error{s.error()};
  return std::unique_ptr<DisplayOutput>(std::move(o));
}

}  // namespace dentar::live
