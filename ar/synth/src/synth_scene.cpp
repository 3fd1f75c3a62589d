#include "synth_scene.h"

#include <GLES3/gl3.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace dentar::ar::synth {
using V3 = Eigen::Vector3f;
namespace {

constexpr const char* kVertex = R"(#version 300 es
uniform highp mat4 u_clip_from_obj;
uniform highp mat4 u_cam_from_obj;
layout(location = 0) in highp vec3 a_position_m;
layout(location = 1) in highp vec3 a_normal;
layout(location = 2) in mediump vec3 a_rgb;
layout(location = 3) in highp vec2 a_uv;
out highp vec3 v_pos_cam;
out highp vec3 v_normal_cam;
out mediump vec3 v_rgb;
out highp vec2 v_uv;
void main() {
  gl_Position = u_clip_from_obj * vec4(a_position_m, 1.0);
  v_pos_cam = (u_cam_from_obj * vec4(a_position_m, 1.0)).xyz;
  v_normal_cam = mat3(u_cam_from_obj) * a_normal;
  v_rgb = a_rgb;
  v_uv = a_uv;
}
)";

// Modes: 0 lit vertex colour, 1 lit and multiplied by the tag texture
// (printed ink reflects ~5 %; the texture value is coverage), 2 flat id colour, 3 mirror (a blurred
// environment: bright above, dark below, plus a strong highlight).
constexpr const char* kFragment = R"(#version 300 es
precision highp float;
uniform int u_mode;
uniform vec4 u_flat;
uniform sampler2D u_tex;
uniform vec3 u_light0;  // head lamp, toward the light, camera frame
uniform vec3 u_light1;  // overhead operating light
in vec3 v_pos_cam;
in vec3 v_normal_cam;
in vec3 v_rgb;
in vec2 v_uv;
out vec4 o_color;
vec3 to_linear(vec3 c) { return pow(c, vec3(2.2)); }
vec3 srgb_encode(vec3 c) {
  c = clamp(c, 0.0, 1.0);
  return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
}
void main() {
  if (u_mode == 2) { o_color = u_flat; return; }
  vec3 n = normalize(v_normal_cam);
  if (!gl_FrontFacing) n = -n;
  vec3 view = normalize(-v_pos_cam);
  vec3 albedo = to_linear(v_rgb);
  // The filtered texel is the ink's coverage of the pixel's footprint, so the
  // reflectance is linear in it (generator v1 took it as sRGB: edges ~0.2 px
  // into the white in linear light).
  if (u_mode == 1) albedo *= 0.05 + 0.95 * texture(u_tex, v_uv).r;
  float d0 = max(dot(n, u_light0), 0.0), d1 = max(dot(n, u_light1), 0.0);
  float spec = pow(max(dot(n, normalize(u_light0 + view)), 0.0), 40.0);
  vec3 c = albedo * (0.22 + 0.5 * d0 + 0.45 * d1) + vec3(0.06 * spec);
  if (u_mode == 3) {
    vec3 r = reflect(-view, n);
    float up = clamp(0.5 - 0.5 * dot(r, u_light1), 0.0, 1.0);
    c = mix(vec3(0.7, 0.68, 0.66), vec3(0.12, 0.08, 0.08), up) + vec3(0.6 * spec);
  }
  o_color = vec4(srgb_encode(c), 1.0);
}
)";

}  // namespace

Result<SceneProgram> SceneProgram::create() {
  auto p = link_program(kVertex, kFragment, "synth scene");
  if (!p) return Error{p.error()};
  SceneProgram s;
  s.program_ = std::move(p).value();
  const GLuint id = s.program_.id();
  s.u_clip_from_obj_ = glGetUniformLocation(id, "u_clip_from_obj");
  s.u_cam_from_obj_ = glGetUniformLocation(id, "u_cam_from_obj");
  s.u_mode_ = glGetUniformLocation(id, "u_mode");
  s.u_flat_ = glGetUniformLocation(id, "u_flat");
  s.u_tex_ = glGetUniformLocation(id, "u_tex");
  s.u_light0_ = glGetUniformLocation(id, "u_light0");
  s.u_light1_ = glGetUniformLocation(id, "u_light1");
  return s;
}

void SceneProgram::begin(const Eigen::Vector3f& l0, const Eigen::Vector3f& l1) const {
  glUseProgram(program_.id());
  const V3 a = l0.normalized(), b = l1.normalized();
  glUniform3f(u_light0_, a.x(), a.y(), a.z());
  glUniform3f(u_light1_, b.x(), b.y(), b.z());
  glUniform1i(u_tex_, 0);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_TRUE);
  glDisable(GL_BLEND);
  glFrontFace(GL_CCW);
  glCullFace(GL_BACK);
}

void SceneProgram::draw(const GpuMesh& mesh, const Eigen::Matrix4d& clip_from_cam,
                        const Eigen::Isometry3d& T_cam_obj, Mode mode, const Eigen::Vector4f& flat,
                        GLuint texture, bool cull) const {
  // The combined matrix is formed in double so float rounding happens once.
  const Eigen::Matrix4f clip_from_obj = (clip_from_cam * T_cam_obj.matrix()).cast<float>();
  const Eigen::Matrix4f cam_from_obj = T_cam_obj.matrix().cast<float>();
  glUniformMatrix4fv(u_clip_from_obj_, 1, GL_FALSE, clip_from_obj.data());
  glUniformMatrix4fv(u_cam_from_obj_, 1, GL_FALSE, cam_from_obj.data());
  glUniform1i(u_mode_, static_cast<GLint>(mode));
  glUniform4f(u_flat_, flat.x(), flat.y(), flat.z(), flat.w());
  if (cull)
    glEnable(GL_CULL_FACE);
  else
    glDisable(GL_CULL_FACE);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, texture);
  glBindVertexArray(mesh.vao.id());
  glDrawElements(GL_TRIANGLES, mesh.count, GL_UNSIGNED_INT, nullptr);
  glBindVertexArray(0);
}

float srgb_encode_dn(float linear) {
  static const std::vector<float> table = [] {
    std::vector<float> t(65536);
    for (std::size_t i = 0; i < t.size(); ++i) {
      const double c = static_cast<double>(i) / 65535.0;
      t[i] = static_cast<float>(255.0 * (c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1 / 2.4) - 0.055));
    }
    return t;
  }();
  const float x = std::clamp(linear, 0.0f, 1.0f) * 65535.0f;
  return table[static_cast<std::size_t>(x + 0.5f)];
}

Texture make_tag_texture(const cv::Mat& gray) {
  Texture t = make_texture();
  glBindTexture(GL_TEXTURE_2D, t.id());
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  cv::Mat g = gray.isContinuous() ? gray : gray.clone();
  glTexImage2D(GL_TEXTURE_2D, 0, GL_R8, g.cols, g.rows, 0, GL_RED, GL_UNSIGNED_BYTE, g.data);
  glGenerateMipmap(GL_TEXTURE_2D);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glBindTexture(GL_TEXTURE_2D, 0);
  return t;
}

}  // namespace dentar::ar::synth
