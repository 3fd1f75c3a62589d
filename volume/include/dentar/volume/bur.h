// Dental burs: shape parameters (mm at the user boundary, m inside) and
// volumetric sample points used by cutting and by the haptic force model.
//
// Frame `tip`: origin at the bur's far end (the point that first touches the
// tooth when drilling straight down), +z along the bur axis pointing out of
// the handpiece. The bur body therefore occupies z in [-length, 0].
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "dentar/volume/result.h"

namespace dentar::volume {

enum class BurShape : std::uint8_t { kSphere = 0, kCylinder = 1, kCapsule = 2, kCone = 3 };
std::string_view bur_shape_name(BurShape s);
Result<BurShape> parse_bur_shape(std::string_view name);

struct BurParams {
  BurShape shape = BurShape::kSphere;
  // Sphere: radius only. Cylinder: flat end, constant radius. Capsule: round
  // (hemispherical) end, length includes the hemisphere. Cone: flat end of
  // radius tip_radius at z=0 widening to radius at z=-length.
  double radius_m = 0.5e-3;
  double length_m = 3.0e-3;      // ignored for the sphere
  double tip_radius_m = 0.2e-3;  // cone only; 0 <= tip_radius < radius

  static BurParams sphere(double radius_mm);
  static BurParams cylinder(double radius_mm, double length_mm);
  static BurParams capsule(double radius_mm, double length_mm);
  static BurParams cone(double tip_radius_mm, double radius_mm, double length_mm);

  // Empty when valid, else names the field and constraint.
  std::string validate() const;
  double volume_m3() const;
  // Axial extent of the tip region measured from z=0 (see BurSamples).
  double tip_region_length_m() const;
  // Signed distance (m) from a point in the tip frame to the bur surface,
  // negative inside. Exact for all four shapes.
  double signed_distance(const Eigen::Vector3d& p_tip) const;
};

enum class BurRegion : std::uint8_t { kBody = 0, kTip = 1 };

// Uniform interior samples of a bur in the tip frame. Deterministic: the same
// params and count give the same points (a Halton sequence with rejection).
//
// Regions (used by the force model):
//  - sphere: every point is body; its force centre is the sphere centre.
//  - cylinder, cone: tip = points with z > -tip_region_length (a slab of
//    depth equal to the end radius, min 0.25*length); body = the rest.
//  - capsule: tip = the hemispherical end (z > -radius); body = the rest.
// tip_body_point_m is the point on the axis where tip and body meet; the
// sphere uses its centre there.
struct BurSamples {
  BurParams params;
  std::vector<Eigen::Vector3f> points_m;  // tip frame, metres
  std::vector<BurRegion> region;          // same size as points_m
  Eigen::Vector3f tip_body_point_m{0, 0, 0};
  double sample_volume_m3 = 0.0;  // bur volume / count: volume each point stands for

  std::size_t size() const { return points_m.size(); }
};

inline constexpr int kMinBurSamples = 1;
inline constexpr int kMaxBurSamples = 100000;

// count in [kMinBurSamples, kMaxBurSamples]; the working range is 1k..30k.
Result<BurSamples> sample_bur(const BurParams& params, int count);

}  // namespace dentar::volume
