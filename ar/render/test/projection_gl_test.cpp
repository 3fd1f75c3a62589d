// Rendered points land where OpenCV's projectPoints puts them, within 0.1 px,
// with and without lens distortion.
//
// Method: each 3D point is drawn as a small camera-facing (z = const) quad
// whose fragment shader writes a Gaussian of the quad's own coordinates
// (sigma ~2.5 px). A plane z = const maps to the image by a pure scale +
// shift, so the Gaussian's image is a Gaussian centred on the projected
// point; sampled at pixel centres with sigma >= 2 px its intensity-weighted
// centroid equals the true centre to ~1e-3 px (aliasing of a Gaussian at that
// width is negligible, and 8-bit rounding averages out over ~200 pixels). A
// binary disc would not do: its centroid jumps with which pixel centres it
// covers (errors of 0.05-0.2 px for small radii). With distortion the spot is
// warped by the bilinear remap, which preserves the centroid of a locally
// translated image; but a real lens's magnification varies across the blob,
// which moves the centroid of the blob's image by about sigma^2 * grad(ln det J)
// plus a curvature term: 0.01-0.03 px near the corners for sigma = 2.5 px. That
// is a property of imaging a finite blob, not a renderer error, and it stays
// well below the 0.1 px budget.
#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>

#include "dentar/ar/renderer.h"
#include "gl_test_context.h"

namespace dentar::ar {
namespace {

constexpr const char* kSpotVertex = R"(#version 300 es
uniform highp mat4 u_clip_from_cam;
layout(location = 0) in highp vec3 a_position_cam;
layout(location = 1) in highp vec2 a_local_m;
out highp vec2 v_local_m;
void main() {
  gl_Position = u_clip_from_cam * vec4(a_position_cam, 1.0);
  v_local_m = a_local_m;
}
)";
constexpr const char* kSpotFragment = R"(#version 300 es
precision highp float;
in vec2 v_local_m;
out vec4 o_color;
// v_local_m is in units of the spot's sigma (scaled per vertex on the CPU).
void main() {
  float i = exp(-0.5 * dot(v_local_m, v_local_m));
  o_color = vec4(i, i, i, 1.0);
}
)";

struct Spot {
  Eigen::Vector3d p_cam;
  double sigma_px;
};

calibration::CameraIntrinsics camera(bool distorted) {
  calibration::CameraIntrinsics k;
  k.width = 640;
  k.height = 480;
  k.fx = 600.0;
  k.fy = 610.0;
  k.cx = 319.3;
  k.cy = 241.7;
  if (distorted) k.dist = {-0.30, 0.12, 0.001, -0.0008, -0.02};
  return k;
}

std::vector<Spot> grid_spots(const calibration::CameraIntrinsics& k) {
  std::vector<Spot> spots;
  int i = 0;
  for (double v = 45; v < k.height - 40; v += 97.3) {
    for (double u = 45; u < k.width - 40; u += 91.7) {
      const double z = 0.2 + 0.05 * (i++ % 7);  // 0.2 .. 0.5 m
      spots.push_back({Eigen::Vector3d((u - k.cx) / k.fx * z, (v - k.cy) / k.fy * z, z), 2.5});
    }
  }
  return spots;
}

cv::Point2d opencv_project(const calibration::CameraIntrinsics& k, const Eigen::Vector3d& p,
                           bool with_distortion) {
  const cv::Matx33d K(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
  std::vector<cv::Point3d> obj{{p.x(), p.y(), p.z()}};
  std::vector<cv::Point2d> img;
  std::vector<double> dist(5, 0.0);
  if (with_distortion) dist.assign(k.dist.begin(), k.dist.end());
  cv::projectPoints(obj, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, dist, img);
  return img[0];
}

// Renders the spots and returns the largest centroid error (px) against
// OpenCV; every individual error is checked too.
double render_and_measure(const calibration::CameraIntrinsics& k, bool apply_distortion,
                          RendererOptions::WarpMode warp = RendererOptions::WarpMode::kGpu) {
  RendererOptions ro;
  ro.apply_distortion = apply_distortion;
  ro.warp = warp;
  auto renderer = Renderer::create(k, ro);
  EXPECT_TRUE(renderer.ok()) << renderer.error();
  if (!renderer) return 1e9;
  auto program = link_program(kSpotVertex, kSpotFragment, "spot");
  EXPECT_TRUE(program.ok()) << program.error();
  if (!program) return 1e9;

  const std::vector<Spot> spots = grid_spots(k);
  // Per vertex: position in cam (3) + local coordinate in sigmas (2).
  std::vector<float> verts;
  std::vector<std::uint32_t> idx;
  for (const Spot& s : spots) {
    const double sigma_m = s.sigma_px * s.p_cam.z() / k.fx;
    constexpr double kHalfSigmas = 5.0;
    const auto base = static_cast<std::uint32_t>(verts.size() / 5);
    for (int c = 0; c < 4; ++c) {
      const double sx = (c & 1) ? kHalfSigmas : -kHalfSigmas;
      const double sy = (c & 2) ? kHalfSigmas : -kHalfSigmas;
      const Eigen::Vector3d q = s.p_cam + Eigen::Vector3d(sx * sigma_m, sy * sigma_m, 0);
      verts.insert(verts.end(),
                   {static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()),
                    static_cast<float>(sx), static_cast<float>(sy)});
    }
    idx.insert(idx.end(), {base, base + 1, base + 3, base, base + 3, base + 2});
  }
  VertexArray vao = make_vertex_array();
  Buffer vbo = make_buffer(), ibo = make_buffer();
  glBindVertexArray(vao.id());
  glBindBuffer(GL_ARRAY_BUFFER, vbo.id());
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(verts.size() * sizeof(float)), verts.data(),
               GL_STATIC_DRAW);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, ibo.id());
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(idx.size() * 4), idx.data(),
               GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 5 * sizeof(float), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 2, GL_FLOAT, GL_FALSE, 5 * sizeof(float),
                        reinterpret_cast<const void*>(3 * sizeof(float)));

  renderer->begin_frame(Eigen::Vector4f(0, 0, 0, 1));
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);  // either winding: this test is about positions only
  glDisable(GL_BLEND);
  glUseProgram(program->id());
  const Eigen::Matrix4f P = renderer->clip_from_cam().cast<float>();
  glUniformMatrix4fv(glGetUniformLocation(program->id(), "u_clip_from_cam"), 1, GL_FALSE, P.data());
  glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(idx.size()), GL_UNSIGNED_INT, nullptr);
  glBindVertexArray(0);
  renderer->end_frame();
  cv::Mat rgba;
  renderer->read_rgba(rgba);
  EXPECT_EQ(gl_error_message("spot render"), "");

  double max_err = 0.0;
  for (const Spot& s : spots) {
    const cv::Point2d ref = opencv_project(k, s.p_cam, apply_distortion);
    const int r = static_cast<int>(std::ceil(5.0 * s.sigma_px));
    const int u0 = static_cast<int>(std::lround(ref.x)), v0 = static_cast<int>(std::lround(ref.y));
    double sum = 0, su = 0, sv = 0;
    for (int v = v0 - r; v <= v0 + r; ++v) {
      for (int u = u0 - r; u <= u0 + r; ++u) {
        if (u < 0 || v < 0 || u >= k.width || v >= k.height) continue;
        const double w = rgba.at<cv::Vec4b>(v, u)[0];
        sum += w;
        su += w * u;
        sv += w * v;
      }
    }
    EXPECT_GT(sum, 1000.0) << "spot missing near (" << ref.x << ", " << ref.y << ")";
    if (sum <= 0) return 1e9;
    const double eu = su / sum - ref.x, ev = sv / sum - ref.y;
    EXPECT_LT(std::hypot(eu, ev), 0.1) << "spot at (" << ref.x << ", " << ref.y << ") rendered at ("
                                       << su / sum << ", " << sv / sum << ")";
    max_err = std::max(max_err, std::hypot(eu, ev));
  }
  return max_err;
}

TEST(ProjectionGl, PinholeSpotsLandOnProjectPoints) {
  DENTAR_GL_TEST_CONTEXT();
  const double err = render_and_measure(camera(false), true);
  std::printf("pinhole: max centroid error %.4f px over %zu spots\n", err,
              grid_spots(camera(false)).size());
  EXPECT_LT(err, 0.1);
}

TEST(ProjectionGl, DistortedSpotsLandOnProjectPoints) {
  DENTAR_GL_TEST_CONTEXT();
  const double err = render_and_measure(camera(true), true);
  std::printf("distorted: max centroid error %.4f px over %zu spots\n", err,
              grid_spots(camera(true)).size());
  EXPECT_LT(err, 0.1);
}

TEST(ProjectionGl, DistortedSpotsLandOnProjectPointsCpuWarp) {
  DENTAR_GL_TEST_CONTEXT();
  const double err = render_and_measure(camera(true), true, RendererOptions::WarpMode::kCpu);
  std::printf("distorted, cv::remap warp: max centroid error %.4f px\n", err);
  EXPECT_LT(err, 0.1);
}

TEST(ProjectionGl, DistortionOffRendersThePinholeImage) {
  DENTAR_GL_TEST_CONTEXT();
  // Distorted intrinsics with apply_distortion = false: the pinhole projection.
  const double err = render_and_measure(camera(true), false);
  EXPECT_LT(err, 0.1);
}

TEST(ProjectionGl, HdCameraWithDistortion) {
  DENTAR_GL_TEST_CONTEXT();
  calibration::CameraIntrinsics k;
  k.width = 1280;
  k.height = 720;
  k.fx = 905.5;
  k.fy = 903.2;
  k.cx = 641.8;
  k.cy = 358.4;
  k.dist = {0.08, -0.21, -0.0006, 0.0011, 0.12};  // mild pincushion/barrel mix
  const double err = render_and_measure(k, true);
  std::printf("1280x720 distorted: max centroid error %.4f px\n", err);
  EXPECT_LT(err, 0.1);
  const double err_cpu = render_and_measure(k, true, RendererOptions::WarpMode::kCpu);
  std::printf("1280x720 distorted, cv::remap warp: max centroid error %.4f px\n", err_cpu);
  EXPECT_LT(err_cpu, 0.1);
}

}  // namespace
}  // namespace dentar::ar
