// Procedural meshes of the station's real things (room, phantom head,
// hand, instruments, tag plates) with per-vertex colours, on the CPU. Used by
// the footage generator to draw the scene and by the compositor for its
// depth phantoms, so both see the same geometry. Frames in the comments;
// metres. No GL here (gpu_mesh.h uploads a Mesh).
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <vector>

#include "dentar/ar/meshes.h"
#include "dentar/ar/station_scene.h"

namespace dentar::ar::scene {

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
// The mirror's tag paddle in the mtag frame (station_scene.h
// MirrorSceneParams: flat front or roof), every face moved `inset_m` inward
// (the generator draws it 0.2 mm inside the tag planes so the tags are not
// z-fought).
Mesh paddle_mesh(const MirrorSceneParams& mp, const Eigen::Vector3f& rgb, float inset_m = 0);
// Hand holding the handpiece, in the tip frame of the bur (handle leaving
// toward -x of tip at HandpieceParams::handle_angle_rad).
Mesh hand_mesh(const HandpieceParams& hp, double head_centre_z_m);
// Tag plate quad in the tag frame (z = 0), uv over the printed image.
Mesh tag_quad(double half_size_m);

}  // namespace dentar::ar::scene
