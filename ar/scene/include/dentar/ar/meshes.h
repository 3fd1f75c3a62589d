// Procedural meshes of the instruments, built from their parameters (no mesh
// files): the bur with its neck and shank, a contra-angle handpiece, and the
// dental mouth mirror. All sizes in metres; every mesh is closed or, for the
// mirror face, a single-sided disc, with triangles counter-clockwise seen
// from outside and smooth normals where the surface is smooth.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "dentar/volume/bur.h"

namespace dentar::ar {

// Indexed triangle mesh in its part's frame.
struct PartMesh {
  std::vector<Eigen::Vector3f> positions_m;
  std::vector<Eigen::Vector3f> normals;  // unit, same size as positions_m
  std::vector<std::uint32_t> indices;    // triangles, counter-clockwise seen from outside
  std::size_t triangle_count() const { return indices.size() / 3; }
  // Appends `other` placed at T_this_other (rigid).
  void append(const PartMesh& other, const Eigen::Isometry3f& T_this_other);
};

// Surface of revolution about +z: a profile (r, z) polyline walked from the
// back (smaller z) to the front, each point with its outward (n_r, n_z)
// normal. A crease is two points at the same (r, z) with different normals;
// a pole is a point with r = 0. `segments` >= 3 around the axis.
struct ProfilePoint {
  double r_m, z_m, n_r, n_z;
};
PartMesh revolve(const std::vector<ProfilePoint>& profile, int segments);

struct BurMeshOptions {
  int segments = 32;               // around the axis
  int arc_steps = 8;               // per quarter circle (sphere / capsule end)
  double neck_length_m = 1.5e-3;   // thin neck between the cutting part and the shank
  double neck_radius_m = 0.35e-3;  // clamped to 0.8 x the cutting part's back radius
  double shank_length_m = 8.0e-3;  // visible shank out of the handpiece head
  double shank_radius_m = 0.8e-3;  // FG shank, 1.6 mm diameter
  std::string validate() const;
};
// Bur in the tip frame (docs/conventions.md): the cutting part occupies
// z in [-length, 0] (sphere: [-2 radius, 0]) exactly as volume::BurParams
// describes it for cutting, then the neck and shank continue toward -z.
// bur must validate (asserted).
PartMesh make_bur_mesh(const volume::BurParams& bur, const BurMeshOptions& options = {});
// Where the shank enters the handpiece head, z in the tip frame (negative).
double bur_shank_end_z_m(const volume::BurParams& bur, const BurMeshOptions& options = {});

struct HandpieceParams {
  double head_radius_m = 5.0e-3;  // head cylinder, coaxial with the bur
  double head_height_m = 9.0e-3;
  double neck_radius_m = 3.5e-3;  // tapering from the head to the body
  double neck_length_m = 20e-3;
  double body_radius_m = 6.0e-3;
  double body_length_m = 80e-3;
  // Angle between the bur axis (+z of tip, pointing out) and the handle
  // direction (from the head toward the back end); contra-angle ~100 deg.
  // The handle leaves the head toward -x of the tip frame.
  double handle_angle_rad = 1.75;
  int segments = 32;
  std::string validate() const;
};
// Contra-angle handpiece in the tip frame of `bur` (its head starts where the
// bur's shank ends). Both must validate (asserted).
PartMesh make_handpiece_mesh(const volume::BurParams& bur, const HandpieceParams& params = {},
                             const BurMeshOptions& bur_options = {});

struct MirrorMeshParams {
  double radius_m = 0.011;      // reflecting disc (StationCalibration::mirror_radius_m)
  double thickness_m = 1.5e-3;  // disc body behind the face
  double neck_length_m = 20e-3;
  double neck_radius_m = 1.0e-3;
  double handle_length_m = 100e-3;
  double handle_radius_m = 3.0e-3;
  // The stem leaves the rim along -y of the mirror frame, tilted by this
  // angle toward the back (-z): a mirror head is angled to its handle.
  double stem_tilt_rad = 0.35;
  int segments = 48;
  std::string validate() const;
};
// Mirror in the `mir` frame: z = normal out of the reflecting face, the face
// is the disc z = 0, r <= radius. `face` is only that disc (for the
// compositor's reflection/stencil pass); `body` is the back, rim, stem and
// handle.
struct MirrorMeshes {
  PartMesh face;
  PartMesh body;
};
MirrorMeshes make_mirror_meshes(const MirrorMeshParams& params = {});

}  // namespace dentar::ar
