// Private to the footage generator: a small GLES 3 program that draws the
// scene meshes (scene_mesh.h, gpu_mesh.h) lit, textured (tags) or in flat id
// colours, and the tag textures.
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>

#include "dentar/ar/apriltags.h"
#include "dentar/ar/gl_objects.h"
#include "dentar/ar/gpu_mesh.h"
#include "dentar/ar/scene_mesh.h"

namespace dentar::ar::synth {

using scene::arch_point;
using scene::box;
using scene::capsule;
using scene::ellipsoid;
using scene::GpuMesh;
using scene::hand_mesh;
using scene::mannequin_mesh;
using scene::Mesh;
using scene::room_mesh;
using scene::tag_quad;
using scene::upload;
using scene::Vertex;

// Lit (two lights: head lamp + overhead), textured or flat drawing.
class SceneProgram {
 public:
  static Result<SceneProgram> create();
  enum class Mode { kLit = 0, kTextured = 1, kFlat = 2, kMirror = 3 };
  // Binds the program and sets per-frame uniforms (light directions in cam).
  void begin(const Eigen::Vector3f& head_lamp_cam, const Eigen::Vector3f& overhead_cam) const;
  void draw(const GpuMesh& mesh, const Eigen::Matrix4d& clip_from_cam,
            const Eigen::Isometry3d& T_cam_obj, Mode mode, const Eigen::Vector4f& flat = {},
            GLuint texture = 0, bool cull = true) const;

 private:
  Program program_;
  GLint u_clip_from_obj_ = -1, u_cam_from_obj_ = -1, u_mode_ = -1, u_flat_ = -1, u_tex_ = -1,
        u_light0_ = -1, u_light1_ = -1;
};

// The sensor model works in linear light (generator v2): sRGB codes are
// decoded with srgb_decode_table() (dentar/ar/srgb.h); linear [0, 1] ->
// sRGB code as a float 0..255 (not rounded; 16-bit table).
float srgb_encode_dn(float linear);

// RGBA8 texture with mipmaps from a CV_8UC1 image (trilinear minification,
// bilinear magnification: edges stay at their true positions).
Texture make_tag_texture(const cv::Mat& gray);

}  // namespace dentar::ar::synth
