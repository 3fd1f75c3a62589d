#include "dentar/ar/compositor.h"

#include <GLES3/gl32.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <opencv2/imgproc.hpp>
#include <cstring>
#include <cstdio>
#include <cstdlib>
#include <initializer_list>
#include <sstream>
#include <unordered_map>

#include "dentar/ar/gl_objects.h"
#include "dentar/ar/mesh_lod.h"
#include "dentar/ar/projection.h"
#include "dentar/volume/material.h"
#include "dentar/ar/gpu_mesh.h"
#include "dentar/ar/scene_mesh.h"

namespace dentar::ar {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// ---- shaders ---------------------------------------------------------------

// One program for everything: lit colour into attachment 0, tooth coverage
// into 1, the surface's albedo into 2 (which attachments are written is
// chosen with glDrawBuffers per pass). u_plane (cam frame) discards the
// fragments on its negative side: the reflection's "behind the mirror".
constexpr const char* kVertex = R"(#version 300 es
uniform highp mat4 u_clip_from_obj;
uniform highp mat4 u_cam_from_obj;  // rigid, or rigid followed by the mirror reflection
layout(location = 0) in highp vec3 a_position_m;
layout(location = 1) in highp vec3 a_normal;
layout(location = 2) in mediump vec3 a_rgb;
out highp vec3 v_pos_cam;
out highp vec3 v_normal_cam;
out mediump vec3 v_rgb;
void main() {
  gl_Position = u_clip_from_obj * vec4(a_position_m, 1.0);
  v_pos_cam = (u_cam_from_obj * vec4(a_position_m, 1.0)).xyz;
  v_normal_cam = mat3(u_cam_from_obj) * a_normal;
  v_rgb = a_rgb;
}
)";

constexpr const char* kFragment = R"(#version 300 es
precision highp float;
uniform vec4 u_plane;
uniform vec3 u_to_light_cam;
uniform float u_ambient;
uniform float u_diffuse;
uniform float u_alpha;  // opacity; colour is written premultiplied
uniform float u_tooth;  // value for the tooth-coverage attachment
uniform vec3 u_tint;    // multiplies the vertex colour (sRGB)
in vec3 v_pos_cam;
in vec3 v_normal_cam;
in vec3 v_rgb;
layout(location = 0) out vec4 o_color;
layout(location = 1) out vec4 o_tooth;
layout(location = 2) out vec4 o_albedo;
vec3 srgb_encode(vec3 c) {
  c = clamp(c, 0.0, 1.0);
  return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
}
void main() {
  if (dot(u_plane.xyz, v_pos_cam) + u_plane.w < 0.0) discard;
  vec3 n = normalize(v_normal_cam);
  float light = u_ambient + u_diffuse * max(dot(n, u_to_light_cam), 0.0);
  vec3 albedo = clamp(v_rgb * u_tint, 0.0, 1.0);
  o_color = vec4(srgb_encode(pow(albedo, vec3(2.2)) * light) * u_alpha, u_alpha);
  o_tooth = vec4(u_tooth, 0.0, 0.0, 1.0);
  o_albedo = vec4(albedo, 1.0);
}
)";

// With the full-screen triangle on the far plane (depth 1): resets depth
// where the stencil test lets it through.
constexpr const char* kFarFragment = R"(#version 300 es
precision mediump float;
out vec4 o_color;
void main() { o_color = vec4(0.0); }
)";

// ---- the GPU path (compose_gl) -----------------------------------------------
// Output-space textures use image rows (row 0 = top): a pass drawn with
// glViewport over an output rectangle writes fragment (x, y) = pixel (x, y).
// The canvas attachments have GL rows (bottom first), as the lit passes draw.
// Every pass draws the full-screen triangle (full_screen_triangle_vertex_shader).

// Canvas -> output through the distortion map, as cv::remap with the
// fixed-point map does it (positions rounded to 1/32 px; bilinear for colour
// and coverage, OpenCV's "nearest" for the albedo; 0 outside the canvas rectangle).
constexpr const char* kResampleFragment = R"(#version 300 es
precision highp float;
precision highp int;
precision highp sampler2D;
uniform sampler2D u_map;
uniform sampler2D u_color;
uniform sampler2D u_tooth;
uniform sampler2D u_albedo;
uniform ivec2 u_canvas;
uniform ivec4 u_croi;  // the canvas rectangle drawn this frame (x0, y0, x1, y1): 0 outside, as the CPU's copy
layout(location = 0) out vec4 o_color;
layout(location = 1) out vec4 o_tooth;
layout(location = 2) out vec4 o_albedo;
vec4 tap(sampler2D t, ivec2 p) {
  if (p.x < u_croi.x || p.y < u_croi.y || p.x >= u_croi.z || p.y >= u_croi.w) return vec4(0.0);
  return texelFetch(t, ivec2(p.x, u_canvas.y - 1 - p.y), 0);
}
vec4 bilinear(sampler2D t, ivec2 p, vec2 f) {
  return mix(mix(tap(t, p), tap(t, p + ivec2(1, 0)), f.x),
             mix(tap(t, p + ivec2(0, 1)), tap(t, p + ivec2(1, 1)), f.x), f.y);
}
void main() {
  ivec2 o = ivec2(gl_FragCoord.xy);
  vec2 q = floor(texelFetch(u_map, o, 0).xy * 32.0 + 0.5);
  vec2 fl = floor(q / 32.0);
  ivec2 p = ivec2(fl);
  vec2 f = (q - fl * 32.0) / 32.0;
  o_color = bilinear(u_color, p, f);
  o_tooth = bilinear(u_tooth, p, f);
  // Nearest as cv::remap does it with a fixed-point map (OpenCV's NNDeltaTab):
  // one pixel further when the 1/32 fraction is below one half. Odd, but the
  // CPU path's (and so `dentar offline`'s) albedo is sampled so.
  o_albedo = tap(u_albedo, p + ivec2(lessThan(q - fl * 32.0, vec2(16.0))));
}
)";

// ForegroundSegmenter::segment (occlusion.cpp), per pixel of the overlay's
// output rectangle: region = tooth coverage dilated by u_grow (inside the
// rectangle, as cv::dilate on it); chromaticity of the video against the
// foreground model and the expected albedo around the pixel. Writes the
// probability (quantised to 1/255 as the CPU's 8-bit mask) and, for
// confident pixels, the chromaticity for the model's adaptation.
constexpr const char* kClassifyFragment = R"(#version 300 es
precision highp float;
precision highp int;
precision highp sampler2D;
uniform sampler2D u_video;
uniform sampler2D u_tooth;
uniform sampler2D u_albedo;
uniform sampler2D u_model;
uniform ivec4 u_roi;
uniform int u_grow;
uniform int u_r;
uniform int u_h;
uniform float u_dmax;
uniform float u_inv_soft;
uniform float u_reach2;
uniform int u_min_red;
out vec4 o_fg;
void main() {
  ivec2 o = ivec2(gl_FragCoord.xy);
  o_fg = vec4(0.0);
  // The cheap tests first (every condition must hold; most pixels fail here).
  vec3 px = floor(texelFetch(u_video, o, 0).rgb * 255.0 + 0.5);
  if (px.r < float(u_min_red)) return;
  float inv_r = 1.0 / px.r;
  vec2 c = vec2(px.g * inv_r, px.b * inv_r);
  vec2 m = texelFetch(u_model, ivec2(0, 0), 0).xy;
  float d2 = dot(c - m, c - m);
  if (d2 >= u_reach2) return;
  bool region = false;
  for (int dy = -u_grow; dy <= u_grow && !region; ++dy)
    for (int dx = -u_grow; dx <= u_grow; ++dx) {
      ivec2 q = o + ivec2(dx, dy);
      if (q.x < u_roi.x || q.y < u_roi.y || q.x >= u_roi.z || q.y >= u_roi.w) continue;
      if (texelFetch(u_tooth, q, 0).r > 0.0) region = true;
    }
  if (!region) return;
  float d_fg = sqrt(d2);
  ivec2 offs[9];
  int no = 1;
  offs[0] = ivec2(0, 0);
  if (u_r > 0) {
    for (int k = 0; k < 2; ++k) {
      int d = k == 0 ? u_r : u_h;
      if (d <= 0) continue;
      offs[no] = ivec2(d, 0);
      offs[no + 1] = ivec2(-d, 0);
      offs[no + 2] = ivec2(0, d);
      offs[no + 3] = ivec2(0, -d);
      no += 4;
    }
  }
  vec2 e[9];
  int n = 0;
  for (int k = 0; k < no; ++k) {
    ivec2 s = clamp(o + offs[k], u_roi.xy, u_roi.zw - 1);
    vec4 a = floor(texelFetch(u_albedo, s, 0) * 255.0 + 0.5);
    if (a.a < 0.5 || a.r < 8.5) continue;
    e[n] = vec2(a.g / a.r, a.b / a.r);
    n += 1;
  }
  float d_bg = 1e30;
  for (int i = 0; i < n; ++i) {
    d_bg = min(d_bg, length(c - e[i]));
    for (int j = i + 1; j < n; ++j) {
      vec2 ab = e[j] - e[i];
      float t = clamp(dot(c - e[i], ab) / max(dot(ab, ab), 1e-12), 0.0, 1.0);
      d_bg = min(d_bg, length(c - e[i] - t * ab));
    }
  }
  float p_rel = n == 0 ? 1.0 : clamp(0.5 + (d_bg - d_fg) * u_inv_soft, 0.0, 1.0);
  float p_abs = clamp(0.5 + (u_dmax - d_fg) * u_inv_soft, 0.0, 1.0);
  float p = p_rel * p_abs;
  float pq = floor(255.0 * p + 0.5) / 255.0;
  o_fg = p > 0.95 ? vec4(pq, c, 1.0) : vec4(pq, 0.0, 0.0, 0.0);
}
)";

// GLSL for the feather and blend passes: an index reflected into [lo, hi)
// without repeating the edge (OpenCV's BORDER_REFLECT_101). A macro so the
// shaders stay compile-time string literals.
#define DENTAR_GLSL_REFLECT101                                                                 \
  "int reflect101(int x, int lo, int hi) {\n"                                                  \
  "  if (hi - lo <= 1) return lo;\n"                                                           \
  "  for (int i = 0; i < 8 && (x < lo || x >= hi); ++i) x = x < lo ? 2 * lo - x : 2 * (hi - 1) - x;\n" \
  "  return clamp(x, lo, hi - 1);\n"                                                           \
  "}\n"

// Feathering, horizontal half of the separable Gaussian (BORDER_REFLECT_101
// inside the rectangle, as cv::GaussianBlur on it).
constexpr const char* kFeatherFragment = R"(#version 300 es
precision highp float;
precision highp int;
precision highp sampler2D;
uniform sampler2D u_fg;
uniform ivec4 u_roi;
uniform int u_k;
uniform float u_w[128];
out vec4 o_v;
)" DENTAR_GLSL_REFLECT101 R"(void main() {
  ivec2 o = ivec2(gl_FragCoord.xy);
  float s = 0.0;
  for (int i = -u_k; i <= u_k; ++i)
    s += u_w[i + u_k] * texelFetch(u_fg, ivec2(reflect101(o.x + i, u_roi.x, u_roi.z), o.y), 0).r;
  o_v = vec4(s, 0.0, 0.0, 1.0);
}
)";

// Adaptation, step 1: per column of the rectangle, the sums of the confident
// pixels' chromaticity and their count.
constexpr const char* kColumnSumFragment = R"(#version 300 es
precision highp float;
precision highp int;
precision highp sampler2D;
uniform sampler2D u_fg;
uniform ivec4 u_roi;
out vec4 o_s;
void main() {
  int x = int(gl_FragCoord.x);
  vec3 s = vec3(0.0);
  for (int y = u_roi.y; y < u_roi.w; ++y) s += texelFetch(u_fg, ivec2(x, y), 0).yzw;
  o_s = vec4(s, 0.0);
}
)";

// Adaptation, step 2 (one fragment): the model moves towards the mean of the
// confident pixels (>= 30 of them), at most max_adapt from the seed; as
// ForegroundSegmenter::segment's end. The model never leaves the GPU.
constexpr const char* kModelFragment = R"(#version 300 es
precision highp float;
precision highp int;
precision highp sampler2D;
uniform sampler2D u_colsum;
uniform sampler2D u_model;
uniform ivec4 u_roi;
uniform vec2 u_seed;
uniform float u_rate;
uniform float u_max_adapt;
out vec4 o_m;
void main() {
  vec3 s = vec3(0.0);
  for (int x = u_roi.x; x < u_roi.z; ++x) s += texelFetch(u_colsum, ivec2(x, 0), 0).xyz;
  vec2 m = texelFetch(u_model, ivec2(0, 0), 0).xy;
  if (s.z > 29.5 && u_rate > 0.0) {
    vec2 nm = m + u_rate * (s.xy / s.z - m);
    vec2 d = nm - u_seed;
    float len = length(d);
    if (len > u_max_adapt) nm = u_seed + d * (u_max_adapt / len);
    m = nm;
  }
  o_m = vec4(m, 0.0, 1.0);
}
)";

// The camera's own YUYV 4:2:2 (issue 28) into the video texture: the frame is
// uploaded as it came (2 bytes a pixel, one RGBA8 texel = Y0 U Y1 V of two
// pixels) and converted here, in OpenCV's integer arithmetic for
// COLOR_YUV2RGB_YUYV (BT.601, luma 16..235, 20-bit fixed point), so the GPU
// path's video equals the CPU path's conversion.
constexpr const char* kYuyvFragment = R"(#version 300 es
precision highp float;
precision highp int;
precision highp sampler2D;
uniform sampler2D u_yuyv;
out vec4 o_rgba;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  ivec4 t = ivec4(texelFetch(u_yuyv, ivec2(p.x >> 1, p.y), 0) * 255.0 + 0.5);
  int y = max(((p.x & 1) == 0 ? t.r : t.b) - 16, 0) * 1220542;
  int u = t.g - 128, v = t.a - 128;
  int r = (y + 524288 + 1673527 * v) >> 20;
  int g = (y + 524288 - 852492 * v - 409993 * u) >> 20;
  int b = (y + 524288 + 2116026 * u) >> 20;
  o_rgba = vec4(vec3(clamp(ivec3(r, g, b), 0, 255)) / 255.0, 1.0);
}
)";

// The composite inside the overlay's rectangle (the viewport): the video
// with the overlay (premultiplied) over it, its opacity times
// (1 - foreground), the foreground feathered vertically here and quantised
// to 1/255 as the CPU's mask. Outside the rectangle the composite is the
// video itself, and nothing is drawn.
constexpr const char* kBlendFragment = R"(#version 300 es
precision highp float;
precision highp int;
precision highp sampler2D;
uniform sampler2D u_video;
uniform sampler2D u_color;
uniform sampler2D u_fgh;
uniform ivec4 u_roi;
uniform int u_seg;
uniform int u_k;
uniform float u_w[128];
out vec4 o_rgba;
)" DENTAR_GLSL_REFLECT101 R"(void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec3 rgb = texelFetch(u_video, p, 0).rgb;
  vec4 c = texelFetch(u_color, p, 0);
  if (c.a > 0.0) {
    float f = 0.0;
    if (u_seg != 0) {
      for (int i = -u_k; i <= u_k; ++i)
        f += u_w[i + u_k] * texelFetch(u_fgh, ivec2(p.x, reflect101(p.y + i, u_roi.y, u_roi.w)), 0).r;
      f = floor(clamp(f, 0.0, 1.0) * 255.0 + 0.5) / 255.0;
    }
    float keep = 1.0 - f;
    rgb = rgb * (1.0 - c.a * keep) + c.rgb * keep;
  }
  o_rgba = vec4(rgb, 1.0);
}
)";

constexpr GLenum kAtt[3] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2};

void draw_buffers(bool color, bool tooth, bool albedo) {
  const GLenum b[3] = {color ? kAtt[0] : GL_NONE, tooth ? kAtt[1] : GL_NONE,
                       albedo ? kAtt[2] : GL_NONE};
  glDrawBuffers(3, b);
}

// Axis-aligned box, float, in some object frame.
struct Box {
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector3f hi = Eigen::Vector3f::Constant(-std::numeric_limits<float>::max());
  bool empty() const { return lo.x() > hi.x(); }
  void add(const Eigen::Vector3f& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  void add(const Box& b) {
    if (b.empty()) return;
    add(b.lo);
    add(b.hi);
  }
  Eigen::Vector3d corner(int i) const {
    return Eigen::Vector3d((i & 1) ? hi.x() : lo.x(), (i & 2) ? hi.y() : lo.y(),
                           (i & 4) ? hi.z() : lo.z());
  }
};

Box box_of(const scene::Mesh& m) {
  Box b;
  for (const auto& v : m.vertices) b.add(v.position_m);
  return b;
}

// The normal cone of a mesh's faces: every face's unit normal (from its winding:
// counter-clockwise seen from outside, so outward) lies within half_angle of axis.
// valid = false when there is no face or no cone narrower than 80 degrees (a piece
// that curves round): such a mesh is never culled by facing.
struct NormalCone {
  Eigen::Vector3d axis = Eigen::Vector3d::Zero();
  double half_angle = M_PI;
  bool valid = false;
};

// Unit face normal of triangle t (by its winding), or zero when degenerate.
Eigen::Vector3d face_normal(const scene::Mesh& m, std::size_t t) {
  const Eigen::Vector3d a = m.vertices[m.indices[t]].position_m.cast<double>();
  const Eigen::Vector3d b = m.vertices[m.indices[t + 1]].position_m.cast<double>();
  const Eigen::Vector3d d = m.vertices[m.indices[t + 2]].position_m.cast<double>();
  const Eigen::Vector3d n = (b - a).cross(d - a);
  const double len = n.norm();
  return len > 0 ? Eigen::Vector3d(n / len) : Eigen::Vector3d::Zero();
}

// The normal cone of triangles [t0, t1) (index positions / 3) of m.
NormalCone normal_cone(const scene::Mesh& m, std::size_t t0, std::size_t t1) {
  NormalCone c;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t t = t0; t < t1; ++t) sum += face_normal(m, 3 * t);  // degenerate: zero, covers no pixel
  if (!(sum.norm() > 1e-9)) return c;
  c.axis = sum.normalized();
  double cos_min = 1;
  for (std::size_t t = t0; t < t1; ++t) {
    const Eigen::Vector3d n = face_normal(m, 3 * t);
    if (!n.isZero()) cos_min = std::min(cos_min, n.dot(c.axis));
  }
  c.half_angle = std::acos(std::clamp(cos_min, -1.0, 1.0));
  c.valid = c.half_angle < 80.0 * M_PI / 180.0;
  return c;
}

// A phantom mesh with its triangles grouped by position (cubes of `cell`
// metres by triangle centroid), each group with its box: groups outside the
// overlay's region are not drawn (the mannequin is ~50k triangles, of which
// a few hundred lie near the tooth).
struct ClusteredMesh {
  scene::GpuMesh gpu;
  struct Part {
    Box box;
    GLsizei first = 0, count = 0;  // indices
    NormalCone cone;               // its faces' normals (session 23: the facing test)
  };
  std::vector<Part> parts;
  Box box;
};

ClusteredMesh cluster_phantom(const scene::Mesh& m, float cell) {
  std::map<std::uint64_t, std::vector<std::uint32_t>> groups;  // ordered: facing, then z, y, x
  for (std::size_t t = 0; t + 2 < m.indices.size(); t += 3) {
    const Eigen::Vector3f c = (m.vertices[m.indices[t]].position_m +
                               m.vertices[m.indices[t + 1]].position_m +
                               m.vertices[m.indices[t + 2]].position_m) /
                              3.0f;
    const Eigen::Vector3i q = (c / cell).array().floor().cast<int>();
    // Session 23: also by the axis the face turns to (6 ways, as the tooth's groups), so
    // each part has a narrow normal cone and the parts that all turn away from the eye are
    // not drawn (back-face culling would drop them after their vertex work); the facing
    // axis is the key's top bits, so a view's parts of one facing lie in runs.
    const Eigen::Vector3d fn = face_normal(m, t);
    int axis = 0;
    fn.cwiseAbs().maxCoeff(&axis);
    const auto facing = static_cast<std::uint64_t>(2 * axis + (fn[axis] < 0 ? 1 : 0));
    const std::uint64_t key = (static_cast<std::uint64_t>(q.x() + 100000) & 0x3ffff) |
                              ((static_cast<std::uint64_t>(q.y() + 100000) & 0x3ffff) << 18) |
                              ((static_cast<std::uint64_t>(q.z() + 100000) & 0x3ffff) << 36) |
                              (facing << 54);
    auto& g = groups[key];
    g.insert(g.end(), {m.indices[t], m.indices[t + 1], m.indices[t + 2]});
  }
  ClusteredMesh out;
  scene::Mesh sorted;
  sorted.vertices = m.vertices;
  for (const auto& [key, idx] : groups) {
    ClusteredMesh::Part p;
    p.first = static_cast<GLsizei>(sorted.indices.size());
    p.count = static_cast<GLsizei>(idx.size());
    for (std::uint32_t i : idx) p.box.add(m.vertices[i].position_m);
    out.box.add(p.box);
    sorted.indices.insert(sorted.indices.end(), idx.begin(), idx.end());
    p.cone = normal_cone(sorted, static_cast<std::size_t>(p.first) / 3,
                         static_cast<std::size_t>(p.first + p.count) / 3);
    out.parts.push_back(p);
  }
  out.gpu = scene::upload(sorted);
  return out;
}

// Pixel rectangle [x0, x1) x [y0, y1) on the canvas (OpenCV rows, top = 0).
struct PxRect {
  double x0 = std::numeric_limits<double>::max(), y0 = std::numeric_limits<double>::max();
  double x1 = -std::numeric_limits<double>::max(), y1 = -std::numeric_limits<double>::max();
  bool all = false;  // a point was behind the near plane: assume everything
  bool empty() const { return !all && x0 > x1; }
  void add(const Eigen::Vector2d& p) {
    x0 = std::min(x0, p.x());
    y0 = std::min(y0, p.y());
    x1 = std::max(x1, p.x());
    y1 = std::max(y1, p.y());
  }
  void add(const PxRect& r) {
    all = all || r.all;
    if (r.x0 <= r.x1) {
      add(Eigen::Vector2d(r.x0, r.y0));
      add(Eigen::Vector2d(r.x1, r.y1));
    }
  }
  bool overlaps(const PxRect& r) const {
    if (all || r.all) return true;
    if (empty() || r.empty()) return false;
    return x0 <= r.x1 && r.x0 <= x1 && y0 <= r.y1 && r.y0 <= y1;
  }
  // Integer rectangle grown by `margin` and clipped to w x h.
  cv::Rect clip(int w, int h, int margin) const {
    if (all) return {0, 0, w, h};
    if (empty()) return {};
    const int a = std::max(0, static_cast<int>(std::floor(x0)) - margin);
    const int b = std::max(0, static_cast<int>(std::floor(y0)) - margin);
    const int c = std::min(w, static_cast<int>(std::ceil(x1)) + 1 + margin);
    const int d = std::min(h, static_cast<int>(std::ceil(y1)) + 1 + margin);
    if (c <= a || d <= b) return {};
    return {a, b, c - a, d - b};
  }
};

// Screen box of an object box under an affine cam-from-object transform,
// on a pinhole camera.
PxRect project_box(const Box& b, const Eigen::Affine3d& T_cam_obj,
                   const calibration::CameraIntrinsics& k, double near_m) {
  PxRect r;
  if (b.empty()) return r;
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d p = T_cam_obj * b.corner(i);
    if (p.z() < near_m) {
      r.all = true;
      return r;
    }
    r.add(Eigen::Vector2d(k.fx * p.x() / p.z() + k.cx, k.fy * p.y() / p.z() + k.cy));
  }
  return r;
}

Eigen::Vector3f material_rgb(int label) {
  const int m = std::clamp(label, 0, volume::kMaxMaterials - 1);
  const auto& rgb = volume::material_info(m).rgb;
  return Eigen::Vector3f(rgb[0], rgb[1], rgb[2]) / 255.0f;
}


// A chunk's triangles grouped by the direction their faces turn to (the largest
// component of the face normal: +x, -x, +y, -y, +z, -z; each group's normals lie
// within 55 degrees of its axis), each group a contiguous run of the index buffer
// with its normal cone: a group turned away from the eye is not drawn.
struct FacingGroup {
  GLsizei first = 0, count = 0;  // indices
  NormalCone cone;
};
using FacingGroups = std::array<FacingGroup, 6>;

FacingGroups group_by_facing(scene::Mesh& m) {
  const std::size_t n = m.indices.size() / 3;
  std::vector<int> key(n);
  for (std::size_t t = 0; t < n; ++t) {
    const Eigen::Vector3d f = face_normal(m, 3 * t);
    int axis = 0;
    f.cwiseAbs().maxCoeff(&axis);
    key[t] = 2 * axis + (f[axis] < 0 ? 1 : 0);
  }
  std::vector<std::uint32_t> sorted;
  sorted.reserve(m.indices.size());
  FacingGroups g;
  for (int b = 0; b < 6; ++b) {
    g[static_cast<std::size_t>(b)].first = static_cast<GLsizei>(sorted.size());
    for (std::size_t t = 0; t < n; ++t)
      if (key[t] == b) sorted.insert(sorted.end(), m.indices.begin() + 3 * t, m.indices.begin() + 3 * t + 3);
    g[static_cast<std::size_t>(b)].count = static_cast<GLsizei>(sorted.size()) - g[static_cast<std::size_t>(b)].first;
  }
  m.indices.swap(sorted);
  for (auto& x : g) x.cone = normal_cone(m, x.first / 3, (x.first + x.count) / 3);
  return g;
}

// True when every face of a mesh with normal cone `cone`, lying in the sphere
// (centre, radius) (object frame), faces away from the eye at `eye` (object frame):
// each face's normal then makes less than 90 degrees with the ray from the eye to any
// of its points, so back-face culling would drop all of them. Conservative, with a
// margin of 0.01 rad for faces seen edge-on.
bool faces_away(const NormalCone& cone, const Eigen::Vector3d& centre, double radius,
                const Eigen::Vector3d& eye) {
  if (!cone.valid) return false;
  const Eigen::Vector3d d = centre - eye;
  const double dist = d.norm();
  if (!(dist > radius)) return false;
  const double to_axis = std::acos(std::clamp(cone.axis.dot(d / dist), -1.0, 1.0));
  return cone.half_angle + to_axis + std::asin(radius / dist) < 0.5 * M_PI - 0.01;
}

// Level 0: the chunk mesh as is, coloured by material.
void full_mesh(const volume::ChunkMesh& cm, scene::Mesh& out) {
  out.vertices.resize(cm.vertices.size());
  for (std::size_t i = 0; i < cm.vertices.size(); ++i) {
    scene::Vertex& v = out.vertices[i];
    v.position_m = cm.vertices[i].position_m;
    v.normal = cm.vertices[i].normal;
    v.rgb = material_rgb(cm.vertices[i].material);
  }
  out.indices = cm.indices;
}

// The level of detail of a chunk (mesh_lod.h's vertex clustering in cells of `cell` voxels),
// coloured by material. Returns the level's geometric error, m.
double cluster_mesh(const volume::ChunkMesh& cm, int cell, scene::Mesh& out, volume::ChunkMesh& coarse,
                    MeshLodScratch& scratch) {
  const double err = cluster_chunk_mesh(cm, cell, coarse, scratch);
  out.vertices.resize(coarse.vertices.size());
  for (std::size_t i = 0; i < coarse.vertices.size(); ++i) {
    scene::Vertex& v = out.vertices[i];
    v.position_m = coarse.vertices[i].position_m;
    v.normal = coarse.vertices[i].normal;
    v.rgb = material_rgb(coarse.vertices[i].material);
  }
  out.indices = coarse.indices;
  return err;
}

// GL objects of the GPU path (compose_gl), built on first use.
struct GpuPath {
  std::string error;  // why the path cannot run here (then nothing else is set)
  int W = 0, H = 0;
  Texture map, r_color, r_tooth, r_albedo, fg, fgh, colsum, model[2];
  cv::Mat rgba;  // the frame converted for the upload, reused
  Texture yuyv;        // a YUYV frame as it came (W/2 x H RGBA8), made on its first use
  Program yuyv_p;      // kYuyvFragment
  // YUYV converted by the shader (2 bytes a pixel uploaded), or on the CPU straight into the
  // RGBA upload (one pass): the shader on a GPU, the CPU on a software rasteriser, where the
  // shader's pass over every pixel measured slower (docs/BENCHMARKS.md, issue 28 session 17).
  // DENTAR_YUYV_GL=shader|cpu overrides (tests, benches).
  bool yuyv_shader = false;
  std::unordered_map<GLuint, Framebuffer> video_fbs;  // video texture -> its framebuffer (YUYV pass)
  Framebuffer fb_resample, fb_fg, fb_fgh, fb_colsum, fb_model[2];
  Program resample, classify, feather, colsum_p, model_p, blend;
  int cur_model = 0;
  bool model_reset = true;  // upload the seed before the next classification
  std::vector<float> weights;  // Gaussian of feather_px, 2k+1 taps
  double weights_sigma = -1;
  std::unordered_map<GLuint, Framebuffer> targets;  // overlay texture -> its framebuffer
};

// A framebuffer on `n` textures (colour attachments 0..n-1); error text or empty.
std::string make_fb(Framebuffer& fb, std::initializer_list<GLuint> textures, const char* name) {
  fb = make_framebuffer();
  glBindFramebuffer(GL_FRAMEBUFFER, fb.id());
  int i = 0;
  for (GLuint t : textures)
    glFramebufferTexture2D(GL_FRAMEBUFFER, kAtt[i++], GL_TEXTURE_2D, t, 0);
  const GLenum st = glCheckFramebufferStatus(GL_FRAMEBUFFER);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  if (st == GL_FRAMEBUFFER_COMPLETE) return {};
  std::ostringstream os;
  os << "GPU compositing framebuffer '" << name << "' is incomplete: status 0x" << std::hex << st;
  return os.str();
}

bool has_gl_extension(const char* name) {
  GLint n = 0;
  glGetIntegerv(GL_NUM_EXTENSIONS, &n);
  for (GLint i = 0; i < n; ++i) {
    const auto* e = reinterpret_cast<const char*>(glGetStringi(GL_EXTENSIONS, static_cast<GLuint>(i)));
    if (e != nullptr && std::strcmp(e, name) == 0) return true;
  }
  return false;
}

void bind_tex(int unit, GLuint tex, GLint loc) {
  glActiveTexture(GL_TEXTURE0 + static_cast<GLenum>(unit));
  glBindTexture(GL_TEXTURE_2D, tex);
  glUniform1i(loc, unit);
}

GLint uloc(const Program& p, const char* name) { return glGetUniformLocation(p.id(), name); }

struct Lit {
  GLint clip_from_obj = -1, cam_from_obj = -1, plane = -1, to_light = -1, ambient = -1,
        diffuse = -1, alpha = -1, tooth = -1, tint = -1;
};

}  // namespace

// ---- options -------------------------------------------------------------------

std::string CompositorOptions::validate() const {
  std::ostringstream os;
  if (!(std::isfinite(lod_max_error_px) && lod_max_error_px >= 0 && lod_max_error_px <= 100)) {
    os << "lod_max_error_px = " << lod_max_error_px << " must be in [0, 100]";
  } else if (!(std::isfinite(lod_reference_width_px) && lod_reference_width_px >= 0 &&
               lod_reference_width_px <= 16384)) {
    os << "lod_reference_width_px = " << lod_reference_width_px << " must be in [0, 16384] (0 = off)";
  } else if (!(std::isfinite(lod_min_triangle_px) && lod_min_triangle_px >= 0 && lod_min_triangle_px <= 100)) {
    os << "lod_min_triangle_px = " << lod_min_triangle_px << " must be in [0, 100] (0 = off)";
  } else if (!(std::isfinite(lod_triangle_max_error_px) && lod_triangle_max_error_px >= 0 &&
               lod_triangle_max_error_px <= 100)) {
    os << "lod_triangle_max_error_px = " << lod_triangle_max_error_px << " must be in [0, 100]";
  } else if (!(std::isfinite(phantom_cell_m) && phantom_cell_m >= 0.002 && phantom_cell_m <= 0.1)) {
    os << "phantom_cell_m = " << phantom_cell_m << " must be in [0.002, 0.1] m";
  } else if (lod_cell_voxels.size() > 4) {
    os << "lod_cell_voxels has " << lod_cell_voxels.size() << " levels; at most 4";
  } else if (!(std::isfinite(feather_px) && feather_px >= 0 && feather_px <= 20)) {
    os << "feather_px = " << feather_px << " must be in [0, 20]";
  } else if (!(std::isfinite(mirror_reflectance) && mirror_reflectance > 0 &&
               mirror_reflectance <= 1)) {
    os << "mirror_reflectance = " << mirror_reflectance << " must be in (0, 1]";
  } else if (!(std::isfinite(near_m) && near_m > 0 && std::isfinite(far_m) && far_m > near_m)) {
    os << "near_m = " << near_m << ", far_m = " << far_m << " must satisfy 0 < near < far";
  } else if (std::string e = bur.validate(); !e.empty()) {
    os << "bur: " << e;
  } else if (std::string e2 = handpiece.validate(); !e2.empty()) {
    os << "handpiece: " << e2;
  } else if (std::string e3 = segmenter.validate(); !e3.empty()) {
    os << "segmenter." << e3;
  } else {
    int prev = 1;
    for (std::size_t i = 0; i < lod_cell_voxels.size(); ++i) {
      const int c = lod_cell_voxels[i];
      if (!(c > prev && c <= 16 && 16 % c == 0)) {
        os << "lod_cell_voxels[" << i << "] = " << c
           << " must be increasing, > 1 and divide the chunk size 16 (2, 4, 8, 16)";
        break;
      }
      prev = c;
    }
  }
  return os.str();
}

// ---- implementation ----------------------------------------------------------------

struct Compositor::Impl {
  StationScene station;
  CompositorOptions opt;
  calibration::CameraIntrinsics camera;  // output (distorted)
  UndistortedView view;                  // canvas plan
  Eigen::Matrix4d P = Eigen::Matrix4d::Identity();  // clip from cam, canvas
  cv::Mat map1, map2;                               // fixed-point canvas->output maps
  int cw = 0, ch = 0;                               // canvas size

  Framebuffer fbo;
  // Canvas attachments: textures, so the GPU path can sample them (the CPU
  // path reads them back; the pixels are the same either way).
  Texture t_color, t_tooth, t_albedo;
  Renderbuffer rb_depth;
  Program lit, far;
  Lit u;
  VertexArray empty_vao;

  ClusteredMesh mannequin;
  scene::GpuMesh handpiece, bur, mirror_face, mirror_body, paddle;
  Box handpiece_box, bur_box, mirror_box;
  Box tool_box;  // handpiece + bur (tip frame): the expert's tool

  struct GpuChunk {
    std::uint64_t version = 0;
    Box box;  // tooth frame
    std::vector<scene::GpuMesh> levels;
    std::vector<std::size_t> tris;
    std::vector<double> error_m;  // per level, see cluster_mesh
    std::vector<double> area_m2;  // per level: its triangles' total area
    std::vector<FacingGroups> groups;  // per level: its triangles by facing
  };
  std::vector<GpuChunk> chunks;
  std::vector<std::size_t> level_tris;  // totals per level
  std::vector<double> level_error_m;    // largest per level
  std::vector<double> level_area_m2;    // totals per level
  scene::Mesh scratch_mesh;
  volume::ChunkMesh scratch_coarse;
  MeshLodScratch scratch_lod;

  ForegroundSegmenter segmenter;
  // Canvas-size CPU copies of the attachments; only `last_canvas` is non-zero.
  cv::Mat c_color, c_tooth, c_albedo, flip_scratch;
  cv::Rect last_canvas;
  // Output-size scratch (ROI views are used).
  cv::Mat o_color, o_tooth, o_albedo, fg, region, fgf;

  std::unique_ptr<GpuPath> gpu;  // compose_gl's objects, built on first use

  int levels() const { return 1 + static_cast<int>(opt.lod_cell_voxels.size()); }

  void sync(const volume::Surface& surface) {
    const auto& meshes = surface.chunks();
    if (chunks.size() != meshes.size()) {
      chunks.clear();
      chunks.resize(meshes.size());
    }
    const int L = levels();
    for (std::size_t i = 0; i < meshes.size(); ++i) {
      GpuChunk& g = chunks[i];
      const volume::ChunkMesh& cm = meshes[i];
      if (cm.version == g.version) continue;
      g.version = cm.version;
      g.levels.clear();
      g.tris.assign(static_cast<std::size_t>(L), 0);
      g.error_m.assign(static_cast<std::size_t>(L), 0.0);
      g.area_m2.assign(static_cast<std::size_t>(L), 0.0);
      g.groups.assign(static_cast<std::size_t>(L), FacingGroups{});
      g.box = Box{};
      if (cm.empty()) continue;
      for (const auto& v : cm.vertices) g.box.add(v.position_m);
      for (int l = 0; l < L; ++l) {
        if (l == 0)
          full_mesh(cm, scratch_mesh);
        else
          g.error_m[static_cast<std::size_t>(l)] =
              cluster_mesh(cm, opt.lod_cell_voxels[static_cast<std::size_t>(l - 1)],
                           scratch_mesh, scratch_coarse, scratch_lod);
        g.tris[static_cast<std::size_t>(l)] = scratch_mesh.indices.size() / 3;
        double area = 0;
        for (std::size_t t = 0; t + 2 < scratch_mesh.indices.size(); t += 3) {
          const Eigen::Vector3f& a = scratch_mesh.vertices[scratch_mesh.indices[t]].position_m;
          const Eigen::Vector3f& b = scratch_mesh.vertices[scratch_mesh.indices[t + 1]].position_m;
          const Eigen::Vector3f& c = scratch_mesh.vertices[scratch_mesh.indices[t + 2]].position_m;
          area += 0.5 * static_cast<double>((b - a).cross(c - a).norm());
        }
        g.area_m2[static_cast<std::size_t>(l)] = area;
        g.groups[static_cast<std::size_t>(l)] = group_by_facing(scratch_mesh);
        g.levels.push_back(scene::upload(scratch_mesh));
      }
    }
    level_tris.assign(static_cast<std::size_t>(L), 0);
    level_error_m.assign(static_cast<std::size_t>(L), 0.0);
    level_area_m2.assign(static_cast<std::size_t>(L), 0.0);
    for (const GpuChunk& g : chunks)
      for (std::size_t l = 0; l < g.tris.size(); ++l) {
        level_tris[l] += g.tris[l];
        level_area_m2[l] += g.area_m2[l];
        level_error_m[l] = std::max(level_error_m[l], g.error_m[l]);
      }
  }

  void set_pose(const Eigen::Affine3d& T_cam_obj) const {
    const Eigen::Matrix4f clip_from_obj = (P * T_cam_obj.matrix()).cast<float>();
    const Eigen::Matrix4f cam_from_obj = T_cam_obj.matrix().cast<float>();
    glUniformMatrix4fv(u.clip_from_obj, 1, GL_FALSE, clip_from_obj.data());
    glUniformMatrix4fv(u.cam_from_obj, 1, GL_FALSE, cam_from_obj.data());
  }
  void draw_mesh(const scene::GpuMesh& m, const Eigen::Affine3d& T_cam_obj) const {
    if (m.count == 0) return;
    set_pose(T_cam_obj);
    glBindVertexArray(m.vao.id());
    glDrawElements(GL_TRIANGLES, m.count, GL_UNSIGNED_INT, nullptr);
  }

  // Draws the parts of a clustered phantom whose screen box overlaps `view`.
  // With cull_facing_away and phantom_facing_cull (session 23), parts whose faces all turn away from the eye are not
  // drawn either (the same pixels: back-face culling drops them); consecutive drawn parts are
  // one draw. T_cam_obj may hold a reflection (the eye is then the camera's mirror image).
  // max_z (session 23, the reflected pass): parts wholly farther from the eye than this
  // (camera z, m) are not drawn: a depth-only phantom there can hide nothing drawn nearer.
  void draw_clustered(const ClusteredMesh& m, const Eigen::Affine3d& T_cam_obj,
                      const PxRect& view, double max_z = std::numeric_limits<double>::infinity()) const {
    set_pose(T_cam_obj);
    glBindVertexArray(m.gpu.vao.id());
    const bool facing = opt.cull_facing_away && opt.phantom_facing_cull;
    const Eigen::Vector3d eye = T_cam_obj.inverse() * Eigen::Vector3d::Zero();
    GLsizei run_first = 0, run_count = 0;
    const auto flush = [&] {
      if (run_count == 0) return;
      glDrawElements(GL_TRIANGLES, run_count, GL_UNSIGNED_INT,
                     reinterpret_cast<const void*>(static_cast<std::size_t>(run_first) * sizeof(std::uint32_t)));
      run_count = 0;
    };
    for (const auto& p : m.parts) {
      bool skip = !project_box(p.box, T_cam_obj, this->view.pinhole, opt.near_m).overlaps(view);
      if (!skip && facing) {
        const Eigen::Vector3d lo = p.box.lo.cast<double>(), hi = p.box.hi.cast<double>();
        skip = faces_away(p.cone, 0.5 * (lo + hi), 0.5 * (hi - lo).norm(), eye);
      }
      if (!skip && max_z < std::numeric_limits<double>::infinity()) {
        double z_min = std::numeric_limits<double>::infinity();
        for (int c = 0; c < 8; ++c) z_min = std::min(z_min, (T_cam_obj * p.box.corner(c).cast<double>()).z());
        skip = z_min > max_z;
      }
      if (skip) {
        flush();
        continue;
      }
      if (run_count > 0 && run_first + run_count != p.first) flush();
      if (run_count == 0) run_first = p.first;
      run_count += p.count;
    }
    flush();
  }

  // Draws the tooth's chunks at `level` whose screen box overlaps `view`
  // (and, with a plane, that are not wholly on its negative side); of each, the
  // groups of triangles that may face the eye (the normal cone test: a group whose
  // faces all turn away would be dropped whole by back-face culling, after its
  // vertex work). T_cam_tooth may hold a reflection (the mirror pass): the eye is
  // then the camera's mirror image, as the winding is flipped.
  void draw_tooth(const Eigen::Affine3d& T_cam_tooth, int level, const PxRect& view,
                  const Eigen::Vector4d* plane, CompositeResult& out) const {
    set_pose(T_cam_tooth);
    const auto& k = this->view.pinhole;
    const Eigen::Vector3d eye = T_cam_tooth.inverse() * Eigen::Vector3d::Zero();
    const bool facing = opt.cull_chunks && opt.cull_facing_away;
    for (const GpuChunk& g : chunks) {
      if (g.levels.empty()) continue;
      if (opt.cull_chunks) {
        bool culled = !project_box(g.box, T_cam_tooth, k, opt.near_m).overlaps(view);
        if (!culled && plane != nullptr) {
          bool any = false;
          for (int c = 0; c < 8 && !any; ++c)
            any = plane->head<3>().dot(T_cam_tooth * g.box.corner(c)) + plane->w() >= 0;
          culled = !any;
        }
        if (culled) {
          ++out.chunks_culled;
          continue;
        }
      }
      const scene::GpuMesh& m = g.levels[static_cast<std::size_t>(level)];
      if (m.count == 0) continue;
      glBindVertexArray(m.vao.id());
      if (!facing) {
        glDrawElements(GL_TRIANGLES, m.count, GL_UNSIGNED_INT, nullptr);
        out.triangles_drawn += static_cast<std::size_t>(m.count) / 3;
        continue;
      }
      // Runs of consecutive groups that may face the eye, one draw each.
      const Eigen::Vector3d lo = g.box.lo.cast<double>(), hi = g.box.hi.cast<double>();
      const Eigen::Vector3d centre = 0.5 * (lo + hi);
      const double radius = 0.5 * (hi - lo).norm();
      GLsizei run_first = 0, run_count = 0;
      const auto flush = [&] {
        if (run_count == 0) return;
        glDrawElements(GL_TRIANGLES, run_count, GL_UNSIGNED_INT,
                       reinterpret_cast<const void*>(static_cast<std::size_t>(run_first) * sizeof(std::uint32_t)));
        out.triangles_drawn += static_cast<std::size_t>(run_count) / 3;
        run_count = 0;
      };
      for (const FacingGroup& fg : g.groups[static_cast<std::size_t>(level)]) {
        if (fg.count == 0) continue;
        if (faces_away(fg.cone, centre, radius, eye)) {
          flush();
          continue;
        }
        if (run_count == 0) run_first = fg.first;
        run_count += fg.count;
      }
      flush();
    }
  }

  // Reads attachment `att` in canvas rectangle r into dst (canvas-size Mat), top-down.
  void read_attachment(int att, const cv::Rect& r, cv::Mat& dst) {
    glReadBuffer(kAtt[att]);
    flip_scratch.create(r.height, r.width, CV_8UC4);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glReadPixels(r.x, ch - (r.y + r.height), r.width, r.height, GL_RGBA, GL_UNSIGNED_BYTE,
                 flip_scratch.data);
    cv::flip(flip_scratch, dst(r), 0);
  }

  // Output rectangle covering the distorted image of canvas rectangle r.
  cv::Rect output_rect(const cv::Rect& r) const {
    if (r.empty()) return {};
    if (view.identity()) return r & cv::Rect(0, 0, camera.width, camera.height);
    const auto& pk = view.pinhole;
    const auto& k = camera;
    PxRect o;
    const int n = 16;
    for (int e = 0; e < 4; ++e) {
      for (int i = 0; i <= n; ++i) {
        const double s = static_cast<double>(i) / n;
        double x = r.x - 0.5, y = r.y - 0.5;
        const double w = r.width, h = r.height;
        if (e == 0) x += s * w;
        if (e == 1) x += s * w, y += h;
        if (e == 2) y += s * h;
        if (e == 3) x += w, y += s * h;
        const double xn = (x - pk.cx) / pk.fx, yn = (y - pk.cy) / pk.fy;
        const double r2 = xn * xn + yn * yn;
        const auto& d = k.dist;
        const double radial = 1 + d[0] * r2 + d[1] * r2 * r2 + d[4] * r2 * r2 * r2;
        const double xd = xn * radial + 2 * d[2] * xn * yn + d[3] * (r2 + 2 * xn * xn);
        const double yd = yn * radial + d[2] * (r2 + 2 * yn * yn) + 2 * d[3] * xn * yn;
        o.add(Eigen::Vector2d(k.fx * xd + k.cx, k.fy * yd + k.cy));
      }
    }
    return o.clip(k.width, k.height, 2);
  }
};

std::string ExpertTool::validate() const {
  std::ostringstream os;
  if (!valid) return {};
  if (!(std::isfinite(opacity) && opacity > 0 && opacity <= 1)) {
    os << "opacity = " << opacity << " must be in (0, 1]";
  } else if (!T_tooth_exp.matrix().allFinite()) {
    os << "T_tooth_exp is not finite";
  } else {
    for (int i = 0; i < 3; ++i)
      if (!(tint[i] >= 0 && tint[i] <= 2)) {
        os << "tint[" << i << "] = " << tint[i] << " must be in [0, 2]";
        break;
      }
  }
  return os.str();
}

Compositor::Compositor(Compositor&&) noexcept = default;
Compositor& Compositor::operator=(Compositor&&) noexcept = default;
Compositor::~Compositor() = default;

const CompositorOptions& Compositor::options() const { return impl_->opt; }
const ForegroundSegmenter& Compositor::segmenter() const { return impl_->segmenter; }
std::vector<std::size_t> Compositor::lod_triangle_counts() const { return impl_->level_tris; }
std::vector<double> Compositor::lod_errors_m() const { return impl_->level_error_m; }

Status Compositor::set_options(const CompositorOptions& o) {
  if (std::string e = o.validate(); !e.empty()) return Error{"CompositorOptions." + e};
  CompositorOptions keep = o;
  keep.bur = impl_->opt.bur;
  keep.handpiece = impl_->opt.handpiece;
  keep.lod_cell_voxels = impl_->opt.lod_cell_voxels;
  keep.phantom_cell_m = impl_->opt.phantom_cell_m;
  keep.near_m = impl_->opt.near_m;
  keep.far_m = impl_->opt.far_m;
  impl_->opt = keep;
  impl_->segmenter = ForegroundSegmenter(o.segmenter);  // starts adapting afresh
  if (impl_->gpu) impl_->gpu->model_reset = true;          // the GPU path's model too
  return {};
}

Result<Compositor> Compositor::create(const StationScene& station, const CompositorOptions& o) {
  if (std::string e = o.validate(); !e.empty()) return Error{"CompositorOptions." + e};
  if (std::string e = station.validate(); !e.empty()) return Error{"station: " + e};
  Compositor c;
  c.impl_ = std::make_unique<Impl>();
  Impl& im = *c.impl_;
  im.station = station;
  im.opt = o;
  im.camera = station.calibration.camera;
  im.segmenter = ForegroundSegmenter(o.segmenter);
  auto view = plan_undistorted_view(im.camera);
  if (!view) return Error{"station camera: " + view.error()};
  im.view = std::move(view).value();
  im.cw = im.view.pinhole.width;
  im.ch = im.view.pinhole.height;
  im.P = clip_from_cam(im.view.pinhole, o.near_m, o.far_m);
  if (!im.view.identity()) {
    // The same per-pixel map the Renderer's CPU warp uses (pixels that
    // cannot be inverted point far outside and take the clear value).
    const int W = im.camera.width, H = im.camera.height;
    cv::Mat map(H, W, CV_32FC2);
    for (int v = 0; v < H; ++v)
      for (int x = 0; x < W; ++x) {
        const Eigen::Vector2f p = im.view.map_px[static_cast<std::size_t>(v) * W + x];
        map.at<cv::Vec2f>(v, x) =
            std::isnan(p.x()) ? cv::Vec2f(-100.f, -100.f) : cv::Vec2f(p.x(), p.y());
      }
    cv::convertMaps(map, cv::noArray(), im.map1, im.map2, CV_16SC2);
  }

  // Framebuffer: colour, tooth coverage, albedo (RGBA8 each) + depth/stencil.
  im.fbo = make_framebuffer();
  glBindFramebuffer(GL_FRAMEBUFFER, im.fbo.id());
  Texture* ts[3] = {&im.t_color, &im.t_tooth, &im.t_albedo};
  for (int i = 0; i < 3; ++i) {
    *ts[i] = make_texture();
    glBindTexture(GL_TEXTURE_2D, ts[i]->id());
    glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA8, im.cw, im.ch);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glFramebufferTexture2D(GL_FRAMEBUFFER, kAtt[i], GL_TEXTURE_2D, ts[i]->id(), 0);
  }
  glBindTexture(GL_TEXTURE_2D, 0);
  im.rb_depth = make_renderbuffer();
  glBindRenderbuffer(GL_RENDERBUFFER, im.rb_depth.id());
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH24_STENCIL8, im.cw, im.ch);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_STENCIL_ATTACHMENT, GL_RENDERBUFFER,
                            im.rb_depth.id());
  const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
  glBindRenderbuffer(GL_RENDERBUFFER, 0);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  if (status != GL_FRAMEBUFFER_COMPLETE) {
    std::ostringstream os;
    os << "compositor framebuffer " << im.cw << "x" << im.ch
       << " (3 x RGBA8 + DEPTH24_STENCIL8) is incomplete: status 0x" << std::hex << status;
    return Error{os.str()};
  }

  auto lit = link_program(kVertex, kFragment, "compositor (lit)");
  if (!lit) return Error{lit.error()};
  im.lit = std::move(lit).value();
  const GLuint id = im.lit.id();
  im.u.clip_from_obj = glGetUniformLocation(id, "u_clip_from_obj");
  im.u.cam_from_obj = glGetUniformLocation(id, "u_cam_from_obj");
  im.u.plane = glGetUniformLocation(id, "u_plane");
  im.u.to_light = glGetUniformLocation(id, "u_to_light_cam");
  im.u.ambient = glGetUniformLocation(id, "u_ambient");
  im.u.diffuse = glGetUniformLocation(id, "u_diffuse");
  im.u.alpha = glGetUniformLocation(id, "u_alpha");
  im.u.tooth = glGetUniformLocation(id, "u_tooth");
  im.u.tint = glGetUniformLocation(id, "u_tint");
  auto far = link_program(full_screen_triangle_vertex_shader(true), kFarFragment, "compositor (depth reset)");
  if (!far) return Error{far.error()};
  im.far = std::move(far).value();
  im.empty_vao = make_vertex_array();

  // Phantom and instrument meshes (the generator's builders: same shapes).
  {
    const scene::Mesh man = scene::mannequin_mesh(station.mannequin);
    im.mannequin = cluster_phantom(man, static_cast<float>(o.phantom_cell_m));
    scene::Mesh hp, b;
    hp.add(make_handpiece_mesh(o.bur, o.handpiece), Eigen::Isometry3f::Identity(),
           {0.62f, 0.64f, 0.68f});
    b.add(make_bur_mesh(o.bur), Eigen::Isometry3f::Identity(), {0.80f, 0.80f, 0.78f});
    im.handpiece_box = box_of(hp);
    im.bur_box = box_of(b);
    im.tool_box = im.handpiece_box;
    im.tool_box.add(im.bur_box);
    im.handpiece = scene::upload(hp);
    im.bur = scene::upload(b);
    MirrorMeshParams mp;
    const auto& ms = station.mirror;
    mp.radius_m = station.calibration.mirror_radius_m;
    mp.thickness_m = ms.thickness_m;
    mp.neck_length_m = ms.neck_length_m;
    mp.neck_radius_m = ms.neck_radius_m;
    mp.handle_length_m = ms.handle_length_m;
    mp.handle_radius_m = ms.handle_radius_m;
    mp.stem_tilt_rad = ms.stem_tilt_rad;
    const MirrorMeshes mm = make_mirror_meshes(mp);
    scene::Mesh face, body;
    face.add(mm.face, Eigen::Isometry3f::Identity(), Eigen::Vector3f::Ones());
    body.add(mm.body, Eigen::Isometry3f::Identity(), Eigen::Vector3f::Ones());
    im.mirror_box = box_of(face);
    im.mirror_face = scene::upload(face);
    im.mirror_body = scene::upload(body);
    im.paddle = scene::upload(scene::paddle_mesh(ms, Eigen::Vector3f::Ones()));
  }
  glBindVertexArray(0);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
  if (auto e = gl_error_message("Compositor::create"); !e.empty()) return Error{e};
  return c;
}

// Empty, or why the frame cannot be composited.
static std::string check_video(const Compositor::Impl& im, const CompositeInput& in) {
  const int W = im.camera.width, H = im.camera.height;
  if (in.video_bgr == nullptr || in.video_bgr->empty())
    return std::string("compose: the video frame is empty (a decoding error or the end of the footage)");
  if (in.video_bgr->type() != CV_8UC3 && in.video_bgr->type() != CV_8UC2)
    return std::string("compose: the video frame must be 8-bit BGR (CV_8UC3) or the camera's YUYV (CV_8UC2); got " +
                       cv::typeToString(in.video_bgr->type()));
  if (in.video_bgr->type() == CV_8UC2 && in.video_bgr->cols % 2 != 0)
    return std::string("compose: a YUYV frame must have an even width; got " + std::to_string(in.video_bgr->cols));
  if (in.video_bgr->cols != W || in.video_bgr->rows != H)
    return std::string("compose: the video frame is " + std::to_string(in.video_bgr->cols) + "x" +
                 std::to_string(in.video_bgr->rows) + " but the station camera is " +
                 std::to_string(W) + "x" + std::to_string(H) +
                 " (use the station file calibrated for this camera)");
  if (std::string e = in.expert.validate(); !e.empty()) return "compose: expert." + e;
  for (int i = 0; i < 3; ++i)
    if (!(in.tooth_tint[i] >= 0 && in.tooth_tint[i] <= 2))
      return "compose: tooth_tint[" + std::to_string(i) + "] = " + std::to_string(in.tooth_tint[i]) +
             " must be in [0, 2]";
  return {};
}

// The canvas passes of one frame (phantoms, reflection, tooth, bur) into the
// canvas framebuffer, limited to the overlay's canvas rectangle (returned;
// empty = nothing to draw). finish: wait for the GL work (the CPU path reads
// back next); the GPU path leaves it queued.
static cv::Rect draw_canvas(Compositor::Impl& im, const CompositeInput& in, CompositeResult& out,
                     bool finish) {
  const CompositorOptions& o = im.opt;
  // Which attachments the next draws write. Session 23 (attachment_masks): all three stay
  // draw buffers and the others' writes are masked (glColorMaski): a change of draw buffers
  // is a change of framebuffer state, which makes llvmpipe flush the queued scene (bin,
  // rasterise, wait for its threads) ~10 times a frame; a write mask is not.
  const auto db = [&](bool color, bool tooth, bool albedo) {
    if (!o.attachment_masks) {
      draw_buffers(color, tooth, albedo);
      return;
    }
    const bool on[3] = {color, tooth, albedo};
    for (GLuint i = 0; i < 3; ++i) glColorMaski(i, on[i], on[i], on[i], on[i]);
  };
  const calibration::StationCalibration& cal = im.station.calibration;
  // Poses (cam frame, metres).
  const Eigen::Isometry3d T_cam_tooth = in.T_cam_man * cal.T_man_tooth;
  const bool stylus = in.stylus_valid;
  const Eigen::Isometry3d T_cam_tip =
      in.T_cam_man * cal.T_man_dev * in.T_dev_sty * cal.T_sty_tip;
  const bool mirror_known = in.mirror_valid;
  const Eigen::Isometry3d T_cam_mir = in.T_cam_mtag * cal.T_mtag_mir;
  const Eigen::Vector3d n_mir = T_cam_mir.linear().col(2);
  const Eigen::Vector3d p_mir = T_cam_mir.translation();
  // The face is seen from its reflecting side when the camera (origin) is on +z of `mir`.
  const bool reflect = o.mirror && mirror_known && n_mir.dot(-p_mir) > 0 && p_mir.z() > o.near_m;

  // Level of detail: footprint first, then the budget. level_at(T): the level for the tooth
  // seen through T (cam from tooth; the reflected view's T holds the mirror's reflection, so
  // its centre lies at the virtual image's distance, the camera-mirror-tooth path).
  Box tooth_box;
  for (const auto& g : im.chunks) tooth_box.add(g.box);
  const int L = im.levels();
  const auto level_at = [&](const Eigen::Affine3d& T) {
    int level = 0;
    if (tooth_box.empty()) return level;
    const Eigen::Vector3d c = T * (0.5 * (tooth_box.lo + tooth_box.hi).cast<double>());
    const double m_per_px = std::max(c.z(), o.near_m) / im.view.pinhole.fx;
    // The budget in px of this frame: the same angle at every width above the reference.
    const double budget_px =
        o.lod_max_error_px * (o.lod_reference_width_px > 0
                                  ? std::max(1.0, im.camera.width / o.lod_reference_width_px)
                                  : 1.0);
    if (o.lod_max_error_px > 0)
      for (int l = 1; l < L; ++l)
        if (im.level_error_m[static_cast<std::size_t>(l)] / m_per_px <= budget_px)
          level = l;
    // Session 23: triangles per pixel. A closed surface of area A shows A/4 of it projected
    // on average (Cauchy) through about half its triangles, so a level's mean triangle covers
    // ~ A / (2 n m_per_px^2) px. Coarser while that is under lod_min_triangle_px and the
    // next level's error is within lod_triangle_max_error_px (px of this frame).
    if (o.lod_min_triangle_px > 0)
      while (level + 1 < L) {
        const auto li = static_cast<std::size_t>(level);
        const double n = static_cast<double>(im.level_tris[li]);
        const double px_per_tri = n > 0 ? im.level_area_m2[li] / (2.0 * n * m_per_px * m_per_px) : 1e30;
        if (!(px_per_tri < o.lod_min_triangle_px)) break;
        if (im.level_error_m[li + 1] / m_per_px > o.lod_triangle_max_error_px) break;
        ++level;
      }
    if (o.triangle_budget > 0)
      while (level + 1 < L && im.level_tris[static_cast<std::size_t>(level)] > o.triangle_budget)
        ++level;
    return level;
  };
  const int level = level_at(Eigen::Affine3d(T_cam_tooth.matrix()));
  out.lod_level = level;

  // Canvas region of everything drawn in colour.
  const auto& pk = im.view.pinhole;
  const PxRect canvas_all = [&] {
    PxRect r;
    r.add(Eigen::Vector2d(0, 0));
    r.add(Eigen::Vector2d(im.cw - 1, im.ch - 1));
    return r;
  }();
  PxRect tooth_rect = project_box(tooth_box, T_cam_tooth, pk, o.near_m);
  PxRect mirror_rect;
  if (reflect) mirror_rect = project_box(im.mirror_box, T_cam_mir, pk, o.near_m);
  PxRect overlay = tooth_rect;
  if (reflect) overlay.add(mirror_rect);
  const bool bur = stylus && o.draw_bur;
  if (bur) overlay.add(project_box(im.bur_box, T_cam_tip, pk, o.near_m));
  const bool expert = in.expert.valid;
  const Eigen::Isometry3d T_cam_exp = T_cam_tooth * in.expert.T_tooth_exp;
  if (expert) overlay.add(project_box(im.tool_box, T_cam_exp, pk, o.near_m));
  const bool tinted = !in.tooth_tint.isOnes();
  const auto tooth_tint = [&](bool on) {
    if (!tinted) return;
    if (on)
      glUniform3f(im.u.tint, in.tooth_tint.x(), in.tooth_tint.y(), in.tooth_tint.z());
    else
      glUniform3f(im.u.tint, 1, 1, 1);
  };
  // The expert's tool, translucent: its nearest surface into depth (colour off), then that
  // surface alone (LEQUAL) blended over what is there (premultiplied "over"). Leaves depth
  // writes on, blending off, the tint white, alpha 1 and the colour attachment only.
  const auto draw_expert = [&](const Eigen::Affine3d& A_exp, float alpha, GLenum depth_func) {
    db(false, false, false);
    if (!in.expert.depth_tested) {
      // Overlaid: depth to far first (in the scissor, and in the mirror's stencil there), so
      // only the ghost's own surfaces compete. Nothing drawn after it needs the old depth:
      // the direct pass ends with the ghost, and the reflection pass puts the mirror face's
      // depth back after it.
      glDepthFunc(GL_ALWAYS);
      glDisable(GL_CULL_FACE);
      glUseProgram(im.far.id());
      glBindVertexArray(im.empty_vao.id());
      glDrawArrays(GL_TRIANGLES, 0, 3);
      glUseProgram(im.lit.id());
      glEnable(GL_CULL_FACE);
      glDepthFunc(GL_LESS);
    } else {
      glDepthFunc(depth_func);
    }
    im.draw_mesh(im.handpiece, A_exp);
    im.draw_mesh(im.bur, A_exp);
    db(true, false, false);
    glDepthFunc(GL_LEQUAL);
    glDepthMask(GL_FALSE);
    glEnable(GL_BLEND);
    glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
    glUniform1f(im.u.alpha, alpha);
    glUniform3f(im.u.tint, in.expert.tint.x(), in.expert.tint.y(), in.expert.tint.z());
    im.draw_mesh(im.handpiece, A_exp);
    im.draw_mesh(im.bur, A_exp);
    glUniform3f(im.u.tint, 1, 1, 1);
    glUniform1f(im.u.alpha, 1.0f);
    glDisable(GL_BLEND);
    glDepthMask(GL_TRUE);
    glDepthFunc(depth_func);
  };
  // The region path draws, reads back, resamples, segments and blends inside the
  // overlay's rectangle only; the whole-frame path (the rival, region_path = false) does the
  // same over the whole canvas.
  const cv::Rect croi = o.region_path ? overlay.clip(im.cw, im.ch, 3) & cv::Rect(0, 0, im.cw, im.ch)
                                      : cv::Rect(0, 0, im.cw, im.ch);
  PxRect croi_px;  // the same as a PxRect, for culling
  croi_px.add(Eigen::Vector2d(croi.x, croi.y));
  croi_px.add(Eigen::Vector2d(croi.x + croi.width, croi.y + croi.height));

  // ---- GL passes ----
  auto t0 = Clock::now();
  glBindFramebuffer(GL_FRAMEBUFFER, im.fbo.id());
  glViewport(0, 0, im.cw, im.ch);
  if (!croi.empty()) {
    glEnable(GL_SCISSOR_TEST);
    glScissor(croi.x, im.ch - (croi.y + croi.height), croi.width, croi.height);
    draw_buffers(true, true, true);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    glDepthMask(GL_TRUE);
    glStencilMask(0xFF);
    glClearColor(0, 0, 0, 0);
    glClearDepthf(1.0f);
    glClearStencil(0);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT | GL_STENCIL_BUFFER_BIT);
    glDisable(GL_BLEND);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LEQUAL);
    glEnable(GL_CULL_FACE);
    glCullFace(GL_BACK);
    glFrontFace(GL_CCW);
    glDisable(GL_STENCIL_TEST);
    glUseProgram(im.lit.id());
    const Eigen::Vector3f L0 = Eigen::Vector3f(0.0f, -0.35f, -1.0f).normalized();
    glUniform3f(im.u.to_light, L0.x(), L0.y(), L0.z());
    glUniform1f(im.u.ambient, 0.3f);
    glUniform1f(im.u.diffuse, 0.8f);
    glUniform3f(im.u.tint, 1, 1, 1);
    glUniform4f(im.u.plane, 0, 0, 0, 1);  // keep everything
    glUniform1f(im.u.alpha, 1.0f);
    glUniform1f(im.u.tooth, 0.0f);

    const Eigen::Affine3d A_man(in.T_cam_man.matrix());
    const Eigen::Affine3d A_tip(T_cam_tip.matrix());
    const Eigen::Affine3d A_mir(T_cam_mir.matrix());
    const Eigen::Affine3d A_mtag(in.T_cam_mtag.matrix());
    // 1. Phantoms: depth; the mannequin also leaves its albedo for the segmenter.
    if (o.phantoms) {
      db(false, false, true);
      im.draw_clustered(im.mannequin, A_man, croi_px);
      db(false, false, false);
      if (stylus) im.draw_mesh(im.handpiece, A_tip);
      if (mirror_known) {
        im.draw_mesh(im.mirror_body, A_mir);
        im.draw_mesh(im.paddle, A_mtag);
        if (!reflect) im.draw_mesh(im.mirror_face, A_mir);
      }
    }
    // 2. Mirror reflection inside the visible part of the face.
    if (reflect) {
      db(false, false, false);
      glEnable(GL_STENCIL_TEST);
      glStencilFunc(GL_ALWAYS, 1, 0xFF);
      glStencilOp(GL_KEEP, GL_KEEP, GL_REPLACE);
      glDepthMask(GL_FALSE);
      im.draw_mesh(im.mirror_face, A_mir);
      // Depth to far inside the stencil so the reflected world starts empty.
      glStencilFunc(GL_EQUAL, 1, 0xFF);
      glStencilOp(GL_KEEP, GL_KEEP, GL_KEEP);
      glDepthMask(GL_TRUE);
      glDepthFunc(GL_ALWAYS);
      glUseProgram(im.far.id());
      glBindVertexArray(im.empty_vao.id());
      glDrawArrays(GL_TRIANGLES, 0, 3);
      glUseProgram(im.lit.id());
      glDepthFunc(GL_LEQUAL);
      // Reflection about the plane n.x = d (cam frame): x' = x - 2 n (n.x - d).
      const double d = n_mir.dot(p_mir);
      Eigen::Affine3d M = Eigen::Affine3d::Identity();
      M.linear() = Eigen::Matrix3d::Identity() - 2.0 * n_mir * n_mir.transpose();
      M.translation() = 2.0 * d * n_mir;
      // Keep what lies behind the mirror plane after reflection.
      const Eigen::Vector4d plane(-n_mir.x(), -n_mir.y(), -n_mir.z(), d);
      glUniform4f(im.u.plane, static_cast<float>(plane.x()), static_cast<float>(plane.y()),
                  static_cast<float>(plane.z()), static_cast<float>(plane.w()));
      glFrontFace(GL_CW);  // the reflection reverses the winding
      // Session 23: the reflected mannequin is depth only (no albedo: the segmenter reads the
      // direct view's); a part wholly behind everything the reflection draws in colour hides
      // nothing, so it is not drawn (phantom_depth_cull; the same pixels).
      double refl_far = std::numeric_limits<double>::infinity();
      if (o.phantom_depth_cull && !(expert && in.expert.depth_tested)) {
        refl_far = -std::numeric_limits<double>::infinity();
        const auto far_of = [&](const Box& b, const Eigen::Affine3d& T) {
          for (int c = 0; c < 8; ++c) refl_far = std::max(refl_far, (T * b.corner(c).cast<double>()).z());
        };
        far_of(tooth_box, M * Eigen::Affine3d(T_cam_tooth.matrix()));
        if (bur) far_of(im.bur_box, M * A_tip);
      }
      if (o.phantoms) im.draw_clustered(im.mannequin, M * A_man, mirror_rect, refl_far);
      db(true, false, false);
      const float a = static_cast<float>(o.mirror_reflectance);
      glUniform1f(im.u.alpha, a);
      tooth_tint(true);
      const Eigen::Affine3d A_refl = M * Eigen::Affine3d(T_cam_tooth.matrix());
      // Session 23: the reflection's own level (its virtual image lies farther than the
      // tooth: the same error in px allows a coarser mesh); reflection_lod = false: the
      // direct view's level (before session 23).
      im.draw_tooth(A_refl, o.reflection_lod ? std::max(level, level_at(A_refl)) : level, mirror_rect,
                    &plane, out);
      tooth_tint(false);
      if (bur) im.draw_mesh(im.bur, M * A_tip);
      glUniform1f(im.u.alpha, 1.0f);
      if (expert) {
        draw_expert(M * Eigen::Affine3d(T_cam_exp.matrix()), a * static_cast<float>(in.expert.opacity), GL_LEQUAL);
        db(true, false, false);
      }
      glFrontFace(GL_CCW);
      glUniform4f(im.u.plane, 0, 0, 0, 1);
      // The face's own depth back inside the stencil: it hides what is behind it.
      db(false, false, false);
      glDepthFunc(GL_ALWAYS);
      im.draw_mesh(im.mirror_face, A_mir);
      glDepthFunc(GL_LEQUAL);
      glDisable(GL_STENCIL_TEST);
      out.mirror_drawn = true;
    }
    // 3. The tooth (coverage 1) and the bur (coverage 0: it hides the tooth).
    glDepthFunc(GL_LESS);
    db(true, true, false);
    glUniform1f(im.u.tooth, 1.0f);
    tooth_tint(true);
    im.draw_tooth(Eigen::Affine3d(T_cam_tooth.matrix()), level, canvas_all, nullptr, out);
    tooth_tint(false);
    glUniform1f(im.u.tooth, 0.0f);
    if (bur) im.draw_mesh(im.bur, A_tip);
    if (expert) {
      draw_expert(Eigen::Affine3d(T_cam_exp.matrix()), static_cast<float>(in.expert.opacity), GL_LESS);
      out.expert_drawn = true;
    }
    glBindVertexArray(0);
    glUseProgram(0);
    glDisable(GL_SCISSOR_TEST);
    if (o.attachment_masks) glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);  // every buffer writable again
    if (finish) glFinish();
  }
  out.timing.render_ms = ms_since(t0);
  return croi;
}

Status Compositor::compose(const volume::Surface& surface, const CompositeInput& in,
                           CompositeResult& result) {
  const auto t_start = Clock::now();
  Impl& im = *impl_;
  const int W = im.camera.width, H = im.camera.height;
  if (std::string e = check_video(im, in); !e.empty()) return Error{e};
  const CompositorOptions& o = im.opt;
  CompositeResult out;
  // Issue 28 session 20: the previous result's frame-size buffers are drawn into again when
  // the caller holds them alone (the live loop hands them round: frame thread, window), not
  // allocated anew: 2.7 + 0.9 MB a 720p frame and eye were fresh pages every frame (the
  // frame thread's page faults in session 19's profile). Shared buffers are never written.
  const auto sole = [](const cv::Mat& m, int rows, int cols, int type) {
    return m.u != nullptr && m.u->refcount == 1 && m.rows == rows && m.cols == cols && m.type() == type &&
           m.data == m.datastart && m.isContinuous();
  };
  const bool keep = in.keep_yuyv && in.video_bgr->type() == CV_8UC2;
  if (!keep && sole(result.image, H, W, CV_8UC3)) out.image = std::move(result.image);
  if (sole(result.tooth_visible, H, W, CV_8UC1)) out.tooth_visible = std::move(result.tooth_visible);
  if (keep && result.patch.u != nullptr && result.patch.u->refcount == 1) out.patch = std::move(result.patch);

  auto t0 = Clock::now();
  im.sync(surface);
  out.timing.sync_ms = ms_since(t0);

  // The output starts as the video: the camera's own YUYV is converted here, once
  // (the copy the CPU path makes anyway), never before; keep_yuyv: not at all outside
  // the overlay (the frame itself is the output there, its buffer shared).
  if (keep)
    out.image = *in.video_bgr;
  else if (in.video_bgr->type() == CV_8UC2)
    cv::cvtColor(*in.video_bgr, out.image, cv::COLOR_YUV2BGR_YUYV);
  else
    in.video_bgr->copyTo(out.image);
  if (out.tooth_visible.empty())
    out.tooth_visible = cv::Mat::zeros(H, W, CV_8UC1);
  else
    out.tooth_visible.setTo(0);
  if (!in.man_valid) {
    out.patch.release();
    out.timing.total_ms = ms_since(t_start);
    result = std::move(out);
    return {};
  }

  const cv::Rect croi = draw_canvas(im, in, out, true);

  // ---- readback of the region ----
  t0 = Clock::now();
  if (im.c_color.rows != im.ch || im.c_color.cols != im.cw) {
    for (cv::Mat* m : {&im.c_color, &im.c_tooth, &im.c_albedo})
      *m = cv::Mat::zeros(im.ch, im.cw, CV_8UC4);
    im.last_canvas = {};
  }
  if (!im.last_canvas.empty())
    for (cv::Mat* m : {&im.c_color, &im.c_tooth, &im.c_albedo}) (*m)(im.last_canvas).setTo(0);
  im.last_canvas = croi;
  if (!croi.empty()) {
    im.read_attachment(0, croi, im.c_color);
    im.read_attachment(1, croi, im.c_tooth);
    im.read_attachment(2, croi, im.c_albedo);
  }
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  out.readback_px = 3 * static_cast<std::int64_t>(croi.area());
  out.timing.readback_ms = ms_since(t0);
  if (auto e = gl_error_message("Compositor::compose"); !e.empty()) return Error{e};

  // ---- resample the region into the distorted image ----
  t0 = Clock::now();
  const cv::Rect roi = im.output_rect(croi);
  out.region = roi;
  double blend_ms = 0;
  // The video under the overlay, BGR: the output's own pixels, or (keep_yuyv) the patch:
  // the region's YUYV converted from an even column (a pixel pair shares its chroma), as
  // the whole frame's conversion gives them.
  cv::Mat base;
  if (keep && !roi.empty()) {
    const int x0 = roi.x & ~1, x1 = std::min(W, (roi.x + roi.width + 1) & ~1);
    out.patch_rect = cv::Rect(x0, roi.y, x1 - x0, roi.height);
    cv::cvtColor((*in.video_bgr)(out.patch_rect), out.patch, cv::COLOR_YUV2BGR_YUYV);
    base = out.patch(cv::Rect(roi.x - x0, 0, roi.width, roi.height));
  } else if (keep) {
    out.patch.release();
  } else if (!roi.empty()) {
    base = out.image(roi);
  }
  if (!roi.empty()) {
    for (cv::Mat* m : {&im.o_color, &im.o_tooth, &im.o_albedo})
      if (m->rows != H || m->cols != W) m->create(H, W, CV_8UC4);
    cv::Mat oc = im.o_color(roi), ot = im.o_tooth(roi), oa = im.o_albedo(roi);
    if (im.view.identity()) {
      im.c_color(roi).copyTo(oc);
      im.c_tooth(roi).copyTo(ot);
      im.c_albedo(roi).copyTo(oa);
    } else {
      const cv::Mat m1 = im.map1(roi), m2 = im.map2(roi);
      cv::remap(im.c_color, oc, m1, m2, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
      cv::remap(im.c_tooth, ot, m1, m2, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
      // Nearest for the albedo: a blend of two surfaces' colours is neither.
      cv::remap(im.c_albedo, oa, m1, m2, cv::INTER_NEAREST, cv::BORDER_CONSTANT,
                cv::Scalar::all(0));
    }
    blend_ms += ms_since(t0);

    // ---- unknown foreground in the tooth's region ----
    t0 = Clock::now();
    const cv::Mat video = base;  // the video (BGR): the blend below writes into it after this
    cv::Mat tooth_cov;
    cv::extractChannel(ot, tooth_cov, 0);
    bool have_fg = false;
    if (o.segmentation && cv::countNonZero(tooth_cov) > 0) {
      // Classify the tooth's pixels and a ring of feather width around them.
      const int grow = static_cast<int>(std::ceil(2.0 * o.feather_px)) + 1;
      cv::dilate(tooth_cov, im.region, cv::getStructuringElement(
                                           cv::MORPH_RECT, cv::Size(2 * grow + 1, 2 * grow + 1)));
      im.segmenter.segment(video, oa, im.region, im.fg);
      if (o.feather_px > 0)
        cv::GaussianBlur(im.fg, im.fgf, cv::Size(0, 0), o.feather_px);
      else
        im.fg.copyTo(im.fgf);
      have_fg = true;
    }
    out.timing.segment_ms = ms_since(t0);

    // ---- blend: out = video (1 - a (1 - f)) + rgb (1 - f), rgb premultiplied ----
    t0 = Clock::now();
    cv::Mat dst = base, vis = out.tooth_visible(roi);
    for (int v = 0; v < roi.height; ++v) {
      const auto* c = oc.ptr<cv::Vec4b>(v);
      const auto* tc = tooth_cov.ptr<std::uint8_t>(v);
      const std::uint8_t* f = have_fg ? im.fgf.ptr<std::uint8_t>(v) : nullptr;
      auto* p = dst.ptr<cv::Vec3b>(v);
      auto* tv = vis.ptr<std::uint8_t>(v);
      for (int x = 0; x < roi.width; ++x) {
        const int a = c[x][3];
        if (a == 0) continue;
        const int keep = f != nullptr ? 255 - f[x] : 255;  // 1 - foreground, 0..255
        const int ae = a * keep;                           // 0..255^2
        for (int ch = 0; ch < 3; ++ch) {
          const int val = (p[x][ch] * (65025 - ae) + c[x][2 - ch] * keep * 255 + 32512) / 65025;
          p[x][ch] = static_cast<std::uint8_t>(std::min(val, 255));
        }
        tv[x] = static_cast<std::uint8_t>((tc[x] * keep + 127) / 255);
      }
    }
    blend_ms += ms_since(t0);
    out.tooth_px = cv::countNonZero(vis > 127);
    out.cpu_blend_px = static_cast<std::int64_t>(roi.area());
    out.overlay_drawn = true;
  }
  out.timing.blend_ms = blend_ms;
  out.timing.total_ms = ms_since(t_start);
  result = std::move(out);
  return {};
}

void composite_bgr(const CompositeResult& r, cv::Mat& bgr) {
  if (r.image.empty()) {
    bgr.release();
    return;
  }
  if (r.image.type() != CV_8UC2) {
    r.image.copyTo(bgr);
    return;
  }
  cv::cvtColor(r.image, bgr, cv::COLOR_YUV2BGR_YUYV);
  if (!r.patch.empty()) r.patch.copyTo(bgr(r.patch_rect));
}

// ---- the GPU path ------------------------------------------------------------------

std::string Compositor::gpu_path_error() {
  Impl& im = *impl_;
  if (im.gpu) return im.gpu->error;
  im.gpu = std::make_unique<GpuPath>();
  GpuPath& g = *im.gpu;
  const int W = im.camera.width, H = im.camera.height;
  g.W = W;
  g.H = H;
  GLint max_tex = 0;
  glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_tex);
  if (W > max_tex || H > max_tex) {
    g.error = "the video (" + std::to_string(W) + "x" + std::to_string(H) + ") exceeds GL_MAX_TEXTURE_SIZE " +
              std::to_string(max_tex);
    return g.error;
  }
  if (!has_gl_extension("GL_EXT_color_buffer_float")) {
    g.error =
        "the GL driver lacks GL_EXT_color_buffer_float (float render targets for the segmenter's "
        "reduction on the GPU)";
    return g.error;
  }
  struct {
    Program* p;
    const char* fs;
    const char* name;
  } progs[] = {{&g.resample, kResampleFragment, "GPU compositing (resample)"},
               {&g.classify, kClassifyFragment, "GPU compositing (segmentation)"},
               {&g.feather, kFeatherFragment, "GPU compositing (feather)"},
               {&g.colsum_p, kColumnSumFragment, "GPU compositing (column sums)"},
               {&g.model_p, kModelFragment, "GPU compositing (model update)"},
               {&g.blend, kBlendFragment, "GPU compositing (blend)"},
               {&g.yuyv_p, kYuyvFragment, "GPU compositing (YUYV video)"}};
  const std::string post_vertex = full_screen_triangle_vertex_shader();
  for (auto& pr : progs) {
    auto r = link_program(post_vertex, pr.fs, pr.name);
    if (!r) {
      g.error = r.error();
      return g.error;
    }
    *pr.p = std::move(r).value();
  }
  {
    const auto* r = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
    const std::string renderer = r != nullptr ? r : "";
    g.yuyv_shader = renderer.find("llvmpipe") == std::string::npos && renderer.find("softpipe") == std::string::npos &&
                    renderer.find("SWR") == std::string::npos;
    if (const char* e = std::getenv("DENTAR_YUYV_GL"); e != nullptr && *e != '\0') g.yuyv_shader = std::string(e) == "shader";
  }
  // Output -> canvas positions (the CPU path's map before fixed-point conversion).
  std::vector<float> map(static_cast<std::size_t>(W) * H * 2);
  for (int v = 0; v < H; ++v)
    for (int x = 0; x < W; ++x) {
      float* m = &map[(static_cast<std::size_t>(v) * W + x) * 2];
      if (im.view.identity()) {
        m[0] = static_cast<float>(x);
        m[1] = static_cast<float>(v);
      } else {
        const Eigen::Vector2f p = im.view.map_px[static_cast<std::size_t>(v) * W + x];
        m[0] = std::isnan(p.x()) ? -100.f : p.x();
        m[1] = std::isnan(p.x()) ? -100.f : p.y();
      }
    }
  g.map = make_texture_2d(GL_RG32F, W, H);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, W, H, GL_RG, GL_FLOAT, map.data());
  g.r_color = make_texture_2d(GL_RGBA8, W, H);
  g.r_tooth = make_texture_2d(GL_RGBA8, W, H);
  g.r_albedo = make_texture_2d(GL_RGBA8, W, H);
  g.fg = make_texture_2d(GL_RGBA32F, W, H);
  g.fgh = make_texture_2d(GL_R32F, W, H);
  g.colsum = make_texture_2d(GL_RGBA32F, W, 1);
  g.model[0] = make_texture_2d(GL_RGBA32F, 1, 1);
  g.model[1] = make_texture_2d(GL_RGBA32F, 1, 1);
  glBindTexture(GL_TEXTURE_2D, 0);
  for (std::string e :
       {make_fb(g.fb_resample, {g.r_color.id(), g.r_tooth.id(), g.r_albedo.id()}, "resample"),
        make_fb(g.fb_fg, {g.fg.id()}, "segmentation"), make_fb(g.fb_fgh, {g.fgh.id()}, "feather"),
        make_fb(g.fb_colsum, {g.colsum.id()}, "column sums"),
        make_fb(g.fb_model[0], {g.model[0].id()}, "model 0"),
        make_fb(g.fb_model[1], {g.model[1].id()}, "model 1")})
    if (!e.empty()) {
      g.error = e;
      return g.error;
    }
  if (auto e = gl_error_message("Compositor GPU path set-up"); !e.empty()) g.error = e;
  return g.error;
}

Status Compositor::compose_gl(const volume::Surface& surface, const CompositeInput& in,
                              const GlFrameTarget& target, CompositeResult& result) {
  const auto t_start = Clock::now();
  Impl& im = *impl_;
  if (std::string e = check_video(im, in); !e.empty()) return Error{e};
  if (std::string e = gpu_path_error(); !e.empty()) return Error{"compose_gl: " + e};
  if (target.video_texture == 0 || target.overlay_texture == 0)
    return Error{"compose_gl: no target texture (video " + std::to_string(target.video_texture) + ", overlay " +
                 std::to_string(target.overlay_texture) + ")"};
  GpuPath& g = *im.gpu;
  const int W = g.W, H = g.H;
  const CompositorOptions& o = im.opt;
  CompositeResult out;
  out.gpu_output = true;
  out.tooth_px = -1;

  auto t0 = Clock::now();
  im.sync(surface);
  out.timing.sync_ms = ms_since(t0);

  // The frame as RGBA8: one SIMD conversion on the CPU (no blend), then the
  // driver's upload is a plain copy and the window can show it with a blit
  // (llvmpipe's fast path; a shader unpacking BGR bytes for every pixel of
  // the frame was measured slower than the whole CPU path).
  t0 = Clock::now();
  const GLuint video_tex = target.video_texture;
  const bool yuyv = in.video_bgr->type() == CV_8UC2;
  if (yuyv && !g.yuyv_shader) {
    // One conversion, straight into the upload's layout (the BGR path's decode and
    // its BGR-to-RGBA pass in one).
    cv::cvtColor(*in.video_bgr, g.rgba, cv::COLOR_YUV2RGBA_YUYV);
    glBindTexture(GL_TEXTURE_2D, video_tex);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, W, H, GL_RGBA, GL_UNSIGNED_BYTE, g.rgba.data);
  } else if (yuyv) {
    // The camera's own YUYV as it came (half the bytes, no CPU conversion); the
    // shader pass below converts it into the video texture.
    if (g.yuyv.id() == 0) g.yuyv = make_texture_2d(GL_RGBA8, W / 2, H);
    const cv::Mat src = in.video_bgr->isContinuous() ? *in.video_bgr : in.video_bgr->clone();
    glBindTexture(GL_TEXTURE_2D, g.yuyv.id());
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, W / 2, H, GL_RGBA, GL_UNSIGNED_BYTE, src.data);
  } else {
    cv::cvtColor(*in.video_bgr, g.rgba, cv::COLOR_BGR2RGBA);
    glBindTexture(GL_TEXTURE_2D, video_tex);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, W, H, GL_RGBA, GL_UNSIGNED_BYTE, g.rgba.data);
  }
  glBindTexture(GL_TEXTURE_2D, 0);
  out.timing.upload_ms = ms_since(t0);

  cv::Rect roi, croi;
  if (in.man_valid) {
    croi = draw_canvas(im, in, out, false);
    roi = im.output_rect(croi);
  }
  out.region = roi;
  out.overlay_drawn = !roi.empty();

  t0 = Clock::now();
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  glDisable(GL_STENCIL_TEST);
  glDisable(GL_SCISSOR_TEST);
  glDisable(GL_BLEND);
  glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  glBindVertexArray(im.empty_vao.id());
  if (yuyv && g.yuyv_shader) {
    // 0. The YUYV frame into the video texture (every pixel: the window shows it).
    auto fb = g.video_fbs.find(video_tex);
    if (fb == g.video_fbs.end()) {
      Framebuffer f;
      if (std::string e = make_fb(f, {video_tex}, "video (YUYV)"); !e.empty()) return Error{"compose_gl: " + e};
      fb = g.video_fbs.emplace(video_tex, std::move(f)).first;
    }
    glBindFramebuffer(GL_FRAMEBUFFER, fb->second.id());
    glDrawBuffers(1, kAtt);
    glViewport(0, 0, W, H);
    glUseProgram(g.yuyv_p.id());
    bind_tex(0, g.yuyv.id(), uloc(g.yuyv_p, "u_yuyv"));
    glDrawArrays(GL_TRIANGLES, 0, 3);
  }
  const GLint r4[4] = {roi.x, roi.y, roi.x + roi.width, roi.y + roi.height};
  // Feathering: cv::GaussianBlur's kernel for 8-bit images (size
  // round(6 sigma + 1) | 1), applied as two 1-D passes.
  if (g.weights_sigma != o.feather_px) {
    g.weights_sigma = o.feather_px;
    const int k = o.feather_px > 0
                      ? std::min(63, (static_cast<int>(std::lround(o.feather_px * 6 + 1)) | 1) / 2)
                      : 0;
    g.weights.assign(static_cast<std::size_t>(2 * k + 1), 1.0f);
    if (k > 0) {
      double sum = 0;
      std::vector<double> w(static_cast<std::size_t>(2 * k + 1));
      for (int i = -k; i <= k; ++i)
        sum += w[static_cast<std::size_t>(i + k)] =
            std::exp(-0.5 * i * i / (o.feather_px * o.feather_px));
      for (std::size_t i = 0; i < w.size(); ++i) g.weights[i] = static_cast<float>(w[i] / sum);
    }
  }
  const GLint k = static_cast<GLint>(g.weights.size() / 2);
  const bool seg = o.segmentation && !roi.empty();
  if (!roi.empty()) {
    // 1. Resample the canvas region into the distorted output.
    glBindFramebuffer(GL_FRAMEBUFFER, g.fb_resample.id());
    glDrawBuffers(3, kAtt);
    glViewport(roi.x, roi.y, roi.width, roi.height);
    glUseProgram(g.resample.id());
    bind_tex(0, g.map.id(), uloc(g.resample, "u_map"));
    bind_tex(1, im.t_color.id(), uloc(g.resample, "u_color"));
    bind_tex(2, im.t_tooth.id(), uloc(g.resample, "u_tooth"));
    bind_tex(3, im.t_albedo.id(), uloc(g.resample, "u_albedo"));
    glUniform2i(uloc(g.resample, "u_canvas"), im.cw, im.ch);
    const GLint c4[4] = {croi.x, croi.y, croi.x + croi.width, croi.y + croi.height};
    glUniform4iv(uloc(g.resample, "u_croi"), 1, c4);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    if (seg) {
      const SegmenterOptions& so = im.segmenter.options();
      const double sr = std::max(so.seed_rgb.x(), 1e-6);
      const float seed[2] = {static_cast<float>(so.seed_rgb.y() / sr),
                             static_cast<float>(so.seed_rgb.z() / sr)};
      if (g.model_reset) {
        const float px[4] = {seed[0], seed[1], 0.f, 1.f};
        glBindTexture(GL_TEXTURE_2D, g.model[g.cur_model].id());
        glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, 1, 1, GL_RGBA, GL_FLOAT, px);
        g.model_reset = false;
      }
      // 2. Classify.
      glBindFramebuffer(GL_FRAMEBUFFER, g.fb_fg.id());
      glDrawBuffers(1, kAtt);
      glUseProgram(g.classify.id());
      const Program& c = g.classify;
      bind_tex(0, video_tex, uloc(c, "u_video"));
      bind_tex(1, g.r_tooth.id(), uloc(c, "u_tooth"));
      bind_tex(2, g.r_albedo.id(), uloc(c, "u_albedo"));
      bind_tex(3, g.model[g.cur_model].id(), uloc(c, "u_model"));
      glUniform4iv(uloc(c, "u_roi"), 1, r4);
      glUniform1i(uloc(c, "u_grow"), static_cast<int>(std::ceil(2.0 * o.feather_px)) + 1);
      glUniform1i(uloc(c, "u_r"), so.mix_radius_px);
      glUniform1i(uloc(c, "u_h"), so.mix_radius_px / 2);
      const float reach = static_cast<float>(so.max_distance) + 0.5f * static_cast<float>(so.softness);
      glUniform1f(uloc(c, "u_dmax"), static_cast<float>(so.max_distance));
      glUniform1f(uloc(c, "u_inv_soft"), 1.0f / static_cast<float>(so.softness));
      glUniform1f(uloc(c, "u_reach2"), reach * reach);
      glUniform1i(uloc(c, "u_min_red"), so.min_red);
      glDrawArrays(GL_TRIANGLES, 0, 3);
      // 3. Feather, horizontal half.
      glBindFramebuffer(GL_FRAMEBUFFER, g.fb_fgh.id());
      glUseProgram(g.feather.id());
      bind_tex(0, g.fg.id(), uloc(g.feather, "u_fg"));
      glUniform4iv(uloc(g.feather, "u_roi"), 1, r4);
      glUniform1i(uloc(g.feather, "u_k"), k);
      glUniform1fv(uloc(g.feather, "u_w"), static_cast<GLsizei>(g.weights.size()), g.weights.data());
      glDrawArrays(GL_TRIANGLES, 0, 3);
      // 4-5. Adapt the model (it stays on the GPU).
      glBindFramebuffer(GL_FRAMEBUFFER, g.fb_colsum.id());
      glViewport(roi.x, 0, roi.width, 1);
      glUseProgram(g.colsum_p.id());
      bind_tex(0, g.fg.id(), uloc(g.colsum_p, "u_fg"));
      glUniform4iv(uloc(g.colsum_p, "u_roi"), 1, r4);
      glDrawArrays(GL_TRIANGLES, 0, 3);
      const int next = 1 - g.cur_model;
      glBindFramebuffer(GL_FRAMEBUFFER, g.fb_model[next].id());
      glViewport(0, 0, 1, 1);
      glUseProgram(g.model_p.id());
      bind_tex(0, g.colsum.id(), uloc(g.model_p, "u_colsum"));
      bind_tex(1, g.model[g.cur_model].id(), uloc(g.model_p, "u_model"));
      glUniform4iv(uloc(g.model_p, "u_roi"), 1, r4);
      glUniform2f(uloc(g.model_p, "u_seed"), seed[0], seed[1]);
      glUniform1f(uloc(g.model_p, "u_rate"), static_cast<float>(so.adapt_rate));
      glUniform1f(uloc(g.model_p, "u_max_adapt"), static_cast<float>(so.max_adapt));
      glDrawArrays(GL_TRIANGLES, 0, 3);
      g.cur_model = next;
    }
  }
  // 6. The composite inside the region into the caller's overlay texture.
  if (!roi.empty()) {
    Framebuffer& tfb = g.targets[target.overlay_texture];
    if (!tfb) {
      if (std::string e = make_fb(tfb, {target.overlay_texture}, "overlay target"); !e.empty()) {
        g.targets.erase(target.overlay_texture);
        return Error{"compose_gl: the overlay texture " + std::to_string(target.overlay_texture) +
                     " cannot be drawn into (" + e + "); it must be RGBA8 of the camera's size"};
      }
    }
    glBindFramebuffer(GL_FRAMEBUFFER, tfb.id());
    glDrawBuffers(1, kAtt);
    glViewport(roi.x, roi.y, roi.width, roi.height);
    glUseProgram(g.blend.id());
    bind_tex(0, video_tex, uloc(g.blend, "u_video"));
    bind_tex(1, g.r_color.id(), uloc(g.blend, "u_color"));
    bind_tex(2, g.fgh.id(), uloc(g.blend, "u_fgh"));
    glUniform4iv(uloc(g.blend, "u_roi"), 1, r4);
    glUniform1i(uloc(g.blend, "u_seg"), seg ? 1 : 0);
    glUniform1i(uloc(g.blend, "u_k"), k);
    glUniform1fv(uloc(g.blend, "u_w"), static_cast<GLsizei>(g.weights.size()), g.weights.data());
    glDrawArrays(GL_TRIANGLES, 0, 3);
  }
  for (int u = 3; u >= 0; --u) {
    glActiveTexture(GL_TEXTURE0 + static_cast<GLenum>(u));
    glBindTexture(GL_TEXTURE_2D, 0);
  }
  glBindVertexArray(0);
  glUseProgram(0);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  out.timing.blend_ms = ms_since(t0);
  if (auto e = gl_error_message("Compositor::compose_gl"); !e.empty()) return Error{e};
  out.timing.total_ms = ms_since(t_start);
  result = std::move(out);
  return {};
}

Eigen::Vector2d Compositor::gpu_model_chroma_for_test() {
  Impl& im = *impl_;
  if (!im.gpu || !im.gpu->error.empty()) return Eigen::Vector2d::Constant(std::nan(""));
  GpuPath& g = *im.gpu;
  if (g.model_reset) return im.segmenter.model_chroma();  // the seed, not uploaded yet
  float px[4] = {0, 0, 0, 0};
  glBindFramebuffer(GL_FRAMEBUFFER, g.fb_model[g.cur_model].id());
  glReadPixels(0, 0, 1, 1, GL_RGBA, GL_FLOAT, px);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  return {px[0], px[1]};
}

}  // namespace dentar::ar
