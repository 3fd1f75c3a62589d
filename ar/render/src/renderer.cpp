#include "dentar/ar/renderer.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <opencv2/imgproc.hpp>

namespace dentar::ar {
namespace {

// ---- shaders ---------------------------------------------------------------

constexpr const char* kLitVertex = R"(#version 300 es
uniform highp mat4 u_clip_from_obj;
uniform highp mat3 u_cam_from_obj;  // rotation only: poses are rigid
layout(location = 0) in highp vec3 a_position_m;
layout(location = 1) in highp vec3 a_normal;
out highp vec3 v_normal_cam;
void main() {
  gl_Position = u_clip_from_obj * vec4(a_position_m, 1.0);
  v_normal_cam = u_cam_from_obj * a_normal;
}
)";

constexpr const char* kLitFragment = R"(#version 300 es
precision highp float;
uniform vec4 u_color;  // linear RGB, alpha
uniform vec3 u_to_light_cam;
uniform float u_ambient;
uniform float u_diffuse;
in vec3 v_normal_cam;
out vec4 o_color;
vec3 srgb_encode(vec3 c) {
  c = clamp(c, 0.0, 1.0);
  return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
}
void main() {
  vec3 n = normalize(v_normal_cam);
  float light = u_ambient + u_diffuse * max(dot(n, u_to_light_cam), 0.0);
  o_color = vec4(srgb_encode(u_color.rgb * light), u_color.a);
}
)";

// Drawn with the full-screen triangle; each output pixel looks up where it
// samples the pinhole canvas. Map and canvas have no mipmaps; the map is
// fetched exactly.
constexpr const char* kWarpFragment = R"(#version 300 es
precision highp float;
uniform highp sampler2D u_map;  // RG32F: canvas texture coordinate, or negative
uniform highp sampler2D u_canvas;
uniform vec4 u_clear;
out vec4 o_color;
void main() {
  vec2 st = texelFetch(u_map, ivec2(gl_FragCoord.xy), 0).xy;
  // Explicit LOD 0: no derivatives/LOD per pixel (halves llvmpipe's cost).
  o_color = st.x < 0.0 ? u_clear : textureLod(u_canvas, st, 0.0);
}
)";

float srgb_to_linear(float c) {
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

struct LitUniforms {
  GLint clip_from_obj, cam_from_obj, color, to_light, ambient, diffuse;
};

Result<Program> make_lit_program(LitUniforms& u, const char* name) {
  auto p = link_program(kLitVertex, kLitFragment, name);
  if (!p) return p;
  const GLuint id = p->id();
  u.clip_from_obj = glGetUniformLocation(id, "u_clip_from_obj");
  u.cam_from_obj = glGetUniformLocation(id, "u_cam_from_obj");
  u.color = glGetUniformLocation(id, "u_color");
  u.to_light = glGetUniformLocation(id, "u_to_light_cam");
  u.ambient = glGetUniformLocation(id, "u_ambient");
  u.diffuse = glGetUniformLocation(id, "u_diffuse");
  return p;
}

// Sets the pose and lighting uniforms of a bound lit program. The combined
// matrix is formed in double so float rounding happens once.
void set_pose_uniforms(const LitUniforms& u, const Eigen::Matrix4d& clip_from_cam,
                       const Eigen::Isometry3d& T_cam_obj, const Lighting& light) {
  const Eigen::Matrix4f clip_from_obj = (clip_from_cam * T_cam_obj.matrix()).cast<float>();
  const Eigen::Matrix3f cam_from_obj = T_cam_obj.linear().cast<float>();
  // Eigen is column-major like GL: no transpose.
  glUniformMatrix4fv(u.clip_from_obj, 1, GL_FALSE, clip_from_obj.data());
  glUniformMatrix3fv(u.cam_from_obj, 1, GL_FALSE, cam_from_obj.data());
  const Eigen::Vector3f L = light.to_light_cam.normalized();
  glUniform3f(u.to_light, L.x(), L.y(), L.z());
  glUniform1f(u.ambient, light.ambient);
  glUniform1f(u.diffuse, light.diffuse);
}

void set_color_uniform(const LitUniforms& u, const MaterialStyle& s) {
  glUniform4f(u.color, srgb_to_linear(s.rgb.x()), srgb_to_linear(s.rgb.y()),
              srgb_to_linear(s.rgb.z()), std::clamp(s.alpha, 0.0f, 1.0f));
}

// Opaque: depth writes, no blending. Translucent: blend "over" (alpha
// accumulates as coverage), depth test but no depth writes.
void set_blend_state(bool translucent) {
  if (translucent) {
    glEnable(GL_BLEND);
    glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
    glDepthMask(GL_FALSE);
  } else {
    glDisable(GL_BLEND);
    glDepthMask(GL_TRUE);
  }
}

void set_surface_state() {
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glEnable(GL_CULL_FACE);
  glCullFace(GL_BACK);
  glFrontFace(GL_CCW);  // projection.h keeps camera-CCW triangles CCW in window space
}

LitUniforms to_lit(GLint a, GLint b, GLint c, GLint d, GLint e, GLint f) {
  return {a, b, c, d, e, f};
}

}  // namespace

// ---- Renderer ----------------------------------------------------------------

std::string RendererOptions::validate() const {
  if (!(std::isfinite(near_m) && near_m > 0)) return "near_m must be finite and > 0";
  if (!(std::isfinite(far_m) && far_m > near_m)) return "far_m must be finite and > near_m";
  return {};
}

Result<Renderer> Renderer::create(const calibration::CameraIntrinsics& camera,
                                  const RendererOptions& options) {
  if (std::string e = options.validate(); !e.empty()) return Error{"RendererOptions." + e};
  if (std::string e = camera.validate(); !e.empty()) return Error{"camera intrinsics: " + e};
  Renderer r;
  r.camera_ = camera;
  r.options_ = options;
  if (options.apply_distortion) {
    auto view = plan_undistorted_view(camera, options.undistort);
    if (!view) return Error{view.error()};
    r.view_ = std::move(view).value();
  } else {
    r.view_.pinhole = camera;
    r.view_.pinhole.dist = {0, 0, 0, 0, 0};
  }
  r.clip_from_cam_ = ar::clip_from_cam(r.view_.pinhole, options.near_m, options.far_m);

  auto out = RenderTarget::create(camera.width, camera.height);
  if (!out) return Error{out.error()};
  r.output_ = std::move(out).value();
  if (r.view_.identity()) return r;

  const int cw = r.view_.pinhole.width, ch = r.view_.pinhole.height;
  bool gpu = options.warp == RendererOptions::WarpMode::kGpu;
  if (options.warp == RendererOptions::WarpMode::kAuto) {
    const auto* name = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
    const std::string renderer = name != nullptr ? name : "";
    gpu = renderer.find("llvmpipe") == std::string::npos &&
          renderer.find("softpipe") == std::string::npos;
  }
  auto canvas = RenderTarget::create(
      cw, ch, gpu ? RenderTarget::ColorKind::kTexture : RenderTarget::ColorKind::kRenderbuffer);
  if (!canvas) return Error{"undistorted canvas: " + canvas.error()};
  r.canvas_ = std::move(canvas).value();
  const int W = camera.width, H = camera.height;
  if (!gpu) {
    // cv::remap samples at (map_x, map_y) in OpenCV pixel coordinates of the
    // canvas read back top-down: exactly UndistortedView::map_px. Invalid
    // pixels point far outside so they take the border (clear) colour.
    cv::Mat map(H, W, CV_32FC2);
    for (int v = 0; v < H; ++v) {
      for (int u = 0; u < W; ++u) {
        const Eigen::Vector2f p = r.view_.map_px[static_cast<std::size_t>(v) * W + u];
        map.at<cv::Vec2f>(v, u) =
            std::isnan(p.x()) ? cv::Vec2f(-100.f, -100.f) : cv::Vec2f(p.x(), p.y());
      }
    }
    // Fixed point (1/32 px, OpenCV's INTER_TAB_SIZE): what remap uses anyway, precomputed.
    cv::convertMaps(map, cv::noArray(), r.remap1_, r.remap2_, CV_16SC2);
    return r;
  }

  // The map in GL row order (row 0 = bottom = image row H-1), as texture
  // coordinates of the canvas: pixel centre (u, v) in OpenCV terms is at
  // s = (u + 0.5) / W', t = (H' - v - 0.5) / H' in GL's bottom-up texture.
  std::vector<float> map(static_cast<std::size_t>(W) * H * 2);
  for (int y = 0; y < H; ++y) {
    const int v = H - 1 - y;
    for (int u = 0; u < W; ++u) {
      const Eigen::Vector2f p = r.view_.map_px[static_cast<std::size_t>(v) * W + u];
      float* dst = &map[(static_cast<std::size_t>(y) * W + u) * 2];
      if (std::isnan(p.x())) {
        dst[0] = dst[1] = -1.0f;
      } else {
        dst[0] = static_cast<float>((p.x() + 0.5) / cw);
        dst[1] = static_cast<float>((ch - p.y() - 0.5) / ch);
      }
    }
  }
  r.map_ = make_texture();
  glBindTexture(GL_TEXTURE_2D, r.map_.id());
  glTexStorage2D(GL_TEXTURE_2D, 1, GL_RG32F, W, H);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, W, H, GL_RG, GL_FLOAT, map.data());
  // Float textures are not filterable in GLES 3.0; texelFetch ignores the filter anyway.
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glBindTexture(GL_TEXTURE_2D, 0);

  auto prog = link_program(full_screen_triangle_vertex_shader(), kWarpFragment, "distortion warp");
  if (!prog) return Error{prog.error()};
  r.warp_program_ = std::move(prog).value();
  glUseProgram(r.warp_program_.id());
  glUniform1i(glGetUniformLocation(r.warp_program_.id(), "u_canvas"), 0);
  glUniform1i(glGetUniformLocation(r.warp_program_.id(), "u_map"), 1);
  r.u_clear_ = glGetUniformLocation(r.warp_program_.id(), "u_clear");
  glUseProgram(0);
  r.empty_vao_ = make_vertex_array();
  if (auto e = gl_error_message("Renderer::create (distortion map " + std::to_string(W) + "x" +
                                std::to_string(H) + ")");
      !e.empty()) {
    return Error{e};
  }
  return r;
}

void Renderer::begin_frame(const Eigen::Vector4f& clear_rgba) {
  clear_rgba_ = clear_rgba;
  const RenderTarget& target = distorted() ? canvas_ : output_;
  target.bind();
  glDisable(GL_SCISSOR_TEST);
  glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  glDepthMask(GL_TRUE);
  glStencilMask(0xFF);
  glClearColor(clear_rgba.x(), clear_rgba.y(), clear_rgba.z(), clear_rgba.w());
  glClearDepthf(1.0f);
  glClearStencil(0);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT | GL_STENCIL_BUFFER_BIT);
}

void Renderer::end_frame() {
  if (!warp_program_) return;
  output_.bind();
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);
  glUseProgram(warp_program_.id());
  glUniform4f(u_clear_, clear_rgba_.x(), clear_rgba_.y(), clear_rgba_.z(), clear_rgba_.w());
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, canvas_.color_texture());
  glActiveTexture(GL_TEXTURE1);
  glBindTexture(GL_TEXTURE_2D, map_.id());
  glBindVertexArray(empty_vao_.id());
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glBindVertexArray(0);
  glBindTexture(GL_TEXTURE_2D, 0);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, 0);
  glUseProgram(0);
}

void Renderer::read_rgba(cv::Mat& out) const {
  if (distorted() && !warp_program_) {
    canvas_rgba_.create(canvas_.height(), canvas_.width(), CV_8UC4);
    canvas_.read_rgba(canvas_rgba_.data, canvas_rgba_.step[0]);
    const cv::Scalar border(clear_rgba_.x() * 255.0, clear_rgba_.y() * 255.0,
                            clear_rgba_.z() * 255.0, clear_rgba_.w() * 255.0);
    cv::remap(canvas_rgba_, out, remap1_, remap2_, cv::INTER_LINEAR, cv::BORDER_CONSTANT, border);
    return;
  }
  out.create(camera_.height, camera_.width, CV_8UC4);
  output_.read_rgba(out.data, out.step[0]);
}

void Renderer::read_bgr(cv::Mat& out) const {
  read_rgba(rgba_scratch_);
  cv::cvtColor(rgba_scratch_, out, cv::COLOR_RGBA2BGR);
}

// ---- ToothRenderer -----------------------------------------------------------

Result<ToothRenderer> ToothRenderer::create() {
  ToothRenderer t;
  LitUniforms u{};
  auto p = make_lit_program(u, "tooth (lit)");
  if (!p) return Error{p.error()};
  t.program_ = std::move(p).value();
  t.u_clip_from_obj_ = u.clip_from_obj;
  t.u_cam_from_obj_ = u.cam_from_obj;
  t.u_color_ = u.color;
  t.u_to_light_ = u.to_light;
  t.u_ambient_ = u.ambient;
  t.u_diffuse_ = u.diffuse;
  for (int m = 0; m < volume::kMaxMaterials; ++m) {
    const auto& rgb = volume::material_info(m).rgb;
    t.styles_[static_cast<std::size_t>(m)] = {Eigen::Vector3f(rgb[0], rgb[1], rgb[2]) / 255.0f,
                                              m == 0 ? 0.0f : 1.0f};
  }
  return t;
}

void ToothRenderer::set_style(volume::Material m, const MaterialStyle& style) {
  styles_[static_cast<std::size_t>(m)] = style;
}

const MaterialStyle& ToothRenderer::style(volume::Material m) const {
  return styles_[static_cast<std::size_t>(m)];
}

std::size_t ToothRenderer::triangle_count() const {
  std::size_t n = 0;
  for (const GpuChunk& c : chunks_) n += c.triangles;
  return n;
}

int ToothRenderer::sync(const volume::Surface& surface) { return sync(surface.chunks()); }

int ToothRenderer::sync(const std::vector<volume::ChunkMesh>& meshes) {
  if (chunks_.size() != meshes.size()) {
    // A different volume layout: start over.
    chunks_.clear();
    chunks_.resize(meshes.size());
  }
  last_uploaded_.clear();
  for (std::size_t i = 0; i < meshes.size(); ++i) {
    if (meshes[i].version == chunks_[i].version) continue;
    if (meshes[i].empty() && !chunks_[i].vao) {
      chunks_[i].version = meshes[i].version;  // empty before and after: no GPU work
      continue;
    }
    upload(meshes[i], chunks_[i]);
    last_uploaded_.push_back(static_cast<int>(i));
  }
  total_uploads_ += last_uploaded_.size();
  return static_cast<int>(last_uploaded_.size());
}

void ToothRenderer::upload(const volume::ChunkMesh& mesh, GpuChunk& gpu) {
  gpu.version = mesh.version;
  gpu.first.fill(0);
  gpu.count.fill(0);
  gpu.triangles = mesh.triangle_count();
  if (mesh.empty()) {
    gpu.vbo.reset();
    gpu.ibo.reset();
    gpu.vao.reset();
    return;
  }
  // Group triangles by material (majority of the three vertex labels; the
  // first vertex's label when all differ) with a counting sort.
  const std::size_t n_tri = mesh.triangle_count();
  auto label = [&](std::uint32_t v) {
    const std::uint8_t m = mesh.vertices[v].material;
    return m < volume::kMaxMaterials ? m : std::uint8_t{volume::kMaxMaterials - 1};
  };
  auto tri_material = [&](std::size_t t) {
    const std::uint8_t a = label(mesh.indices[3 * t]), b = label(mesh.indices[3 * t + 1]),
                       c = label(mesh.indices[3 * t + 2]);
    return (b == c && a != b) ? b : a;
  };
  std::array<std::uint32_t, volume::kMaxMaterials> tri_count{};
  for (std::size_t t = 0; t < n_tri; ++t) ++tri_count[tri_material(t)];
  std::array<std::uint32_t, volume::kMaxMaterials> cursor{};
  std::uint32_t acc = 0;
  for (int m = 0; m < volume::kMaxMaterials; ++m) {
    gpu.first[m] = acc * 3;
    gpu.count[m] = tri_count[m] * 3;
    cursor[m] = acc * 3;
    acc += tri_count[m];
  }
  sorted_indices_.resize(mesh.indices.size());
  for (std::size_t t = 0; t < n_tri; ++t) {
    std::uint32_t& dst = cursor[tri_material(t)];
    sorted_indices_[dst] = mesh.indices[3 * t];
    sorted_indices_[dst + 1] = mesh.indices[3 * t + 1];
    sorted_indices_[dst + 2] = mesh.indices[3 * t + 2];
    dst += 3;
  }

  if (!gpu.vao) {
    gpu.vao = make_vertex_array();
    gpu.vbo = make_buffer();
    gpu.ibo = make_buffer();
    glBindVertexArray(gpu.vao.id());
    glBindBuffer(GL_ARRAY_BUFFER, gpu.vbo.id());
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, gpu.ibo.id());
    // MeshVertex is uploaded as is (no repacking): position, normal, then
    // the material byte and padding, which the shader does not read.
    constexpr auto kStride = static_cast<GLsizei>(sizeof(volume::MeshVertex));
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, kStride,
                          reinterpret_cast<const void*>(offsetof(volume::MeshVertex, position_m)));
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, kStride,
                          reinterpret_cast<const void*>(offsetof(volume::MeshVertex, normal)));
  } else {
    glBindVertexArray(gpu.vao.id());
    glBindBuffer(GL_ARRAY_BUFFER, gpu.vbo.id());
  }
  // Re-specifying the whole store lets the driver orphan the old one instead
  // of waiting for frames still reading it.
  glBufferData(GL_ARRAY_BUFFER,
               static_cast<GLsizeiptr>(mesh.vertices.size() * sizeof(volume::MeshVertex)),
               mesh.vertices.data(), GL_STATIC_DRAW);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER,
               static_cast<GLsizeiptr>(sorted_indices_.size() * sizeof(std::uint32_t)),
               sorted_indices_.data(), GL_STATIC_DRAW);
  glBindVertexArray(0);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
}

void ToothRenderer::draw(const Eigen::Matrix4d& clip_from_cam,
                         const Eigen::Isometry3d& T_cam_tooth) const {
  const LitUniforms u =
      to_lit(u_clip_from_obj_, u_cam_from_obj_, u_color_, u_to_light_, u_ambient_, u_diffuse_);
  glUseProgram(program_.id());
  set_surface_state();
  set_pose_uniforms(u, clip_from_cam, T_cam_tooth, lighting);
  // Pass 0: opaque materials; pass 1: translucent ones over them.
  for (int pass = 0; pass < 2; ++pass) {
    set_blend_state(pass == 1);
    for (int m = 1; m < volume::kMaxMaterials; ++m) {
      const MaterialStyle& s = styles_[static_cast<std::size_t>(m)];
      if (s.alpha <= 0.0f || (s.alpha >= 1.0f) != (pass == 0)) continue;
      set_color_uniform(u, s);
      for (const GpuChunk& c : chunks_) {
        if (c.count[m] == 0) continue;
        glBindVertexArray(c.vao.id());
        glDrawElements(
            GL_TRIANGLES, static_cast<GLsizei>(c.count[m]), GL_UNSIGNED_INT,
            reinterpret_cast<const void*>(std::size_t{c.first[m]} * sizeof(std::uint32_t)));
      }
    }
  }
  set_blend_state(false);
  glBindVertexArray(0);
  glUseProgram(0);
}

// ---- PartRenderer ------------------------------------------------------------

Result<PartRenderer> PartRenderer::create() {
  PartRenderer r;
  LitUniforms u{};
  auto p = make_lit_program(u, "part (lit)");
  if (!p) return Error{p.error()};
  r.program_ = std::move(p).value();
  r.u_clip_from_obj_ = u.clip_from_obj;
  r.u_cam_from_obj_ = u.cam_from_obj;
  r.u_color_ = u.color;
  r.u_to_light_ = u.to_light;
  r.u_ambient_ = u.ambient;
  r.u_diffuse_ = u.diffuse;
  return r;
}

GpuPart PartRenderer::upload(const PartMesh& mesh) const {
  assert(mesh.normals.size() == mesh.positions_m.size() &&
         "dentar::ar::PartRenderer::upload: one normal per position");
  // Interleaved position + normal (6 floats).
  std::vector<float> interleaved;
  interleaved.reserve(mesh.positions_m.size() * 6);
  for (std::size_t i = 0; i < mesh.positions_m.size(); ++i) {
    const auto& p = mesh.positions_m[i];
    const auto& n = mesh.normals[i];
    interleaved.insert(interleaved.end(), {p.x(), p.y(), p.z(), n.x(), n.y(), n.z()});
  }
  GpuPart g;
  g.vao = make_vertex_array();
  g.vbo = make_buffer();
  g.ibo = make_buffer();
  g.index_count = static_cast<GLsizei>(mesh.indices.size());
  glBindVertexArray(g.vao.id());
  glBindBuffer(GL_ARRAY_BUFFER, g.vbo.id());
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(interleaved.size() * sizeof(float)),
               interleaved.data(), GL_STATIC_DRAW);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g.ibo.id());
  glBufferData(GL_ELEMENT_ARRAY_BUFFER,
               static_cast<GLsizeiptr>(mesh.indices.size() * sizeof(std::uint32_t)),
               mesh.indices.data(), GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float),
                        reinterpret_cast<const void*>(3 * sizeof(float)));
  glBindVertexArray(0);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
  return g;
}

void PartRenderer::draw(const GpuPart& part, const Eigen::Matrix4d& clip_from_cam,
                        const Eigen::Isometry3d& T_cam_part, const MaterialStyle& style) const {
  if (style.alpha <= 0.0f || part.index_count == 0) return;
  const LitUniforms u =
      to_lit(u_clip_from_obj_, u_cam_from_obj_, u_color_, u_to_light_, u_ambient_, u_diffuse_);
  glUseProgram(program_.id());
  set_surface_state();
  set_blend_state(style.alpha < 1.0f);
  set_pose_uniforms(u, clip_from_cam, T_cam_part, lighting);
  set_color_uniform(u, style);
  glBindVertexArray(part.vao.id());
  glDrawElements(GL_TRIANGLES, part.index_count, GL_UNSIGNED_INT, nullptr);
  glBindVertexArray(0);
  set_blend_state(false);
  glUseProgram(0);
}

}  // namespace dentar::ar
