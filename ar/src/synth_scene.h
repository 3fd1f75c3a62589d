// Private to the footage generator: procedural scene meshes (room, phantom
// head, hand, instruments) with per-vertex colours, and a small GLES 3
// program that draws them lit, textured (tags) or in flat id colours.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <vector>

#include "dentar/ar/apriltags.h"
#include "dentar/ar/gl_objects.h"
#include "dentar/ar/meshes.h"
#include "dentar/ar/station_scene.h"

namespace dentar::ar::synth {

struct Vertex {
  Eigen::Vector3f position_m, normal, rgb;  // rgb: sRGB 0..1
  Eigen::Vector2f uv = Eigen::Vector2f::Zero();
};

struct Mesh {
  std::vector<Vertex> vertices;
  std::vector<std::uint32_t> indices;  // counter-clockwise seen from outside
  void add(const PartMesh& part, const Eigen::Isometry3f& T, const Eigen::Vector3f& rgb);
  void add(const Mesh& other);
};

// Builders (frames in the comments; metres).
Mesh room_mesh();                               // man frame
Mesh mannequin_mesh(const MannequinParams& m);  // man frame, tooth site left empty
// Arch used for the teeth and gums: x = 25 sin(phi), z = -45 + 35 cos(phi) mm.
Eigen::Vector3d arch_point(double phi_rad, double y_m);
Mesh capsule(const Eigen::Vector3f& a, const Eigen::Vector3f& b, float ra, float rb,
             const Eigen::Vector3f& rgb, int segments = 20);
Mesh ellipsoid(const Eigen::Vector3f& centre, const Eigen::Matrix3f& R_axes,
               const Eigen::Vector3f& radii, const Eigen::Vector3f& rgb, int segments = 24);
Mesh box(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, const Eigen::Vector3f& rgb);
// Hand holding the handpiece, in the tip frame of the bur (handle leaving
// toward -x of tip at HandpieceParams::handle_angle_rad).
Mesh hand_mesh(const HandpieceParams& hp, double head_centre_z_m);
// Tag plate quad in the tag frame (z = 0), uv over the printed image.
Mesh tag_quad(double half_size_m);

struct GpuMesh {
  Buffer vbo, ibo;
  VertexArray vao;
  GLsizei count = 0;
};
GpuMesh upload(const Mesh& m);

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

// RGBA8 texture with mipmaps from a CV_8UC1 image (trilinear minification,
// bilinear magnification: edges stay at their true positions).
Texture make_tag_texture(const cv::Mat& gray);

}  // namespace dentar::ar::synth
