// Offscreen rendering of what the (real, distorted) camera sees: a frame
// renderer (projection, distortion warp, readback), the voxel tooth with one
// vertex/index buffer per volume chunk, and the instrument meshes.
//
// A frame:
//   renderer.begin_frame(clear);                       // binds the draw target
//   tooth.sync(surface);                               // re-uploads changed chunks only
//   tooth.draw(renderer.clip_from_cam(), T_cam_tooth);
//   parts.draw(bur_gpu, renderer.clip_from_cam(), T_cam_tip, style);
//   renderer.end_frame();                              // warps to the lens (if distorted)
//   renderer.read_bgr(image);                          // row 0 = top, OpenCV pixels
//
// With lens distortion, drawing goes to an undistorted pinhole canvas slightly
// larger than the image (projection.h: plan_undistorted_view), which is then
// resampled bilinearly per output pixel through the distortion map:
//  - WarpMode::kGpu: end_frame() runs a GLES pass (map in an RG32F texture,
//    texelFetch, then one bilinear fetch of the canvas). Nearly free on a GPU;
//    the output stays on the GPU for a later windowed/compositing pass.
//  - WarpMode::kCpu: read_*() reads the canvas back and cv::remap()s it
//    (fixed-point maps). On llvmpipe this is the faster one, because the
//    software rasteriser's general texture sampler is slow; see BENCHMARKS.
// Both put rendered points within 0.03 px of cv::projectPoints (tests).
// Without distortion, drawing goes straight to the output.
//
// Colours: material and part colours are sRGB; lighting is done in linear
// light and the shader writes sRGB-encoded RGBA8. Alpha is coverage: clear
// with alpha 0 and the output's alpha says where virtual content is, ready to
// be composited over video (blending is in sRGB space, as video is).
//
// Thread/context: everything here needs the EGL context (egl_context.h)
// current on the calling thread, and must be destroyed before it. Each draw
// call sets the GL state it relies on (depth test, blending, culling) rather
// than assuming any.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <vector>

#include "dentar/ar/gl_objects.h"
#include "dentar/ar/meshes.h"
#include "dentar/ar/projection.h"
#include "dentar/calibration/station.h"
#include "dentar/volume/material.h"
#include "dentar/volume/result.h"
#include "dentar/volume/surface.h"

namespace dentar::ar {

struct RendererOptions {
  double near_m = 0.01;  // clip planes, camera z in metres; 0 < near < far
  double far_m = 2.0;
  // Apply the intrinsics' lens distortion (if any coefficient is non-zero).
  // Off: a pinhole image with the same fx, fy, cx, cy.
  bool apply_distortion = true;
  UndistortOptions undistort;
  // kAuto: kCpu on software rasterisers (llvmpipe, softpipe), else kGpu.
  enum class WarpMode { kAuto, kGpu, kCpu };
  WarpMode warp = WarpMode::kAuto;
  std::string validate() const;
};

class Renderer {
 public:
  // Needs a current context. Errors: invalid intrinsics/options (field named),
  // a distortion model that cannot be inverted, or GL failures (named).
  static Result<Renderer> create(const calibration::CameraIntrinsics& camera,
                                 const RendererOptions& options = {});

  // Binds the draw target (pinhole canvas or output), sets its viewport and
  // clears colour (RGBA in 0..1, written as is), depth and stencil.
  void begin_frame(const Eigen::Vector4f& clear_rgba = Eigen::Vector4f(0, 0, 0, 0));
  // Clip-from-camera matrix for the current draw target (projection.h); pass
  // to the draw calls. Camera frame `cam`, metres.
  const Eigen::Matrix4d& clip_from_cam() const { return clip_from_cam_; }
  // Intrinsics of the draw target (equal to the camera's without distortion;
  // the enlarged pinhole canvas with it).
  const calibration::CameraIntrinsics& draw_intrinsics() const { return view_.pinhole; }
  // Output intrinsics (the camera's, distortion included).
  const calibration::CameraIntrinsics& camera() const { return camera_; }
  // Runs the GPU distortion warp into the output target (no-op without
  // distortion or with WarpMode::kCpu, which warps in read_*()).
  void end_frame();

  // Output image after end_frame(): CV_8UC4 RGBA or CV_8UC3 BGR, camera
  // width x height, row 0 = top. `out` is (re)allocated only if needed.
  void read_rgba(cv::Mat& out) const;
  void read_bgr(cv::Mat& out) const;

  bool distorted() const { return !view_.identity(); }
  const UndistortedView& undistorted_view() const { return view_; }
  int output_width() const { return camera_.width; }
  int output_height() const { return camera_.height; }

 private:
  calibration::CameraIntrinsics camera_;
  RendererOptions options_;
  UndistortedView view_;
  Eigen::Matrix4d clip_from_cam_ = Eigen::Matrix4d::Identity();
  RenderTarget output_;
  RenderTarget canvas_;  // pinhole canvas with a colour texture (distortion only)
  Texture map_;          // RG32F, per output pixel: canvas texture coordinate or (-1, -1)
  Program warp_program_;
  VertexArray empty_vao_;  // the full-screen triangle comes from gl_VertexID
  GLint u_clear_ = -1;
  Eigen::Vector4f clear_rgba_ = Eigen::Vector4f::Zero();
  mutable cv::Mat rgba_scratch_;
  cv::Mat remap1_, remap2_;      // kCpu: fixed-point maps for cv::remap
  mutable cv::Mat canvas_rgba_;  // kCpu: the canvas read back
};

// Colour (sRGB, 0..1) and opacity of a material or part. alpha = 1: opaque;
// 0 < alpha < 1: drawn after every opaque surface, blended, without depth
// writes; alpha <= 0: not drawn.
struct MaterialStyle {
  Eigen::Vector3f rgb = Eigen::Vector3f(0.8f, 0.8f, 0.8f);
  float alpha = 1.0f;
};

// Lambert + ambient, in the camera frame.
struct Lighting {
  // Unit direction toward the light in `cam`; default: from just above the
  // camera (a head lamp), i.e. -z and slightly -y (up).
  Eigen::Vector3f to_light_cam = Eigen::Vector3f(0.0f, -0.35f, -1.0f).normalized();
  float ambient = 0.3f;
  float diffuse = 0.8f;
};

// The voxel tooth: one VBO/IBO/VAO per volume chunk, re-uploaded only when
// that chunk's ChunkMesh::version changed. Triangles are grouped by material
// at upload (the majority label of their three vertices) so each material can
// have its own colour and opacity.
class ToothRenderer {
 public:
  // Needs a current context. Styles start from volume::material_info colours,
  // all opaque.
  static Result<ToothRenderer> create();

  // Uploads every chunk of `surface` whose mesh version differs from the one
  // on the GPU and frees the buffers of chunks that became empty. Returns the
  // number of chunks so touched (ids, ascending, in last_uploaded()); chunks
  // empty before and after cost nothing and are not counted.
  int sync(const volume::Surface& surface);
  // The same from chunk meshes held elsewhere (one per chunk, in the surface's order: e.g. a
  // coarser level of detail of them, mesh_lod.h), compared by their `version`.
  int sync(const std::vector<volume::ChunkMesh>& meshes);
  // Draws the tooth at T_cam_tooth (rigid, metres): opaque materials first,
  // then translucent ones (depth test on, depth writes off), back faces culled.
  void draw(const Eigen::Matrix4d& clip_from_cam, const Eigen::Isometry3d& T_cam_tooth) const;

  void set_style(volume::Material m, const MaterialStyle& style);
  const MaterialStyle& style(volume::Material m) const;
  Lighting lighting;

  std::uint64_t total_uploads() const { return total_uploads_; }
  const std::vector<int>& last_uploaded() const { return last_uploaded_; }
  std::size_t triangle_count() const;  // on the GPU now

 private:
  struct GpuChunk {
    std::uint64_t version = 0;  // ChunkMesh::version uploaded (0 = nothing)
    Buffer vbo, ibo;
    VertexArray vao;
    // Per material label: [first index, index count) in the IBO.
    std::array<std::uint32_t, volume::kMaxMaterials> first{}, count{};
    std::size_t triangles = 0;
  };
  void upload(const volume::ChunkMesh& mesh, GpuChunk& gpu);

  Program program_;
  GLint u_clip_from_obj_ = -1, u_cam_from_obj_ = -1, u_color_ = -1, u_to_light_ = -1,
        u_ambient_ = -1, u_diffuse_ = -1;
  std::array<MaterialStyle, volume::kMaxMaterials> styles_;
  std::vector<GpuChunk> chunks_;
  std::uint64_t total_uploads_ = 0;
  std::vector<int> last_uploaded_;
  std::vector<std::uint32_t> sorted_indices_;  // upload scratch
};

// A PartMesh on the GPU (one VBO/IBO/VAO). Move-only.
struct GpuPart {
  Buffer vbo, ibo;
  VertexArray vao;
  GLsizei index_count = 0;
};

// Draws instrument meshes (bur, handpiece, mirror) with one style each.
class PartRenderer {
 public:
  static Result<PartRenderer> create();  // needs a current context
  GpuPart upload(const PartMesh& mesh) const;
  // Draws `part` at T_cam_part (rigid, metres). Translucent styles blend
  // without depth writes; the caller draws them after opaque geometry.
  void draw(const GpuPart& part, const Eigen::Matrix4d& clip_from_cam,
            const Eigen::Isometry3d& T_cam_part, const MaterialStyle& style) const;
  Lighting lighting;

 private:
  Program program_;
  GLint u_clip_from_obj_ = -1, u_cam_from_obj_ = -1, u_color_ = -1, u_to_light_ = -1,
        u_ambient_ = -1, u_diffuse_ = -1;
};

}  // namespace dentar::ar
