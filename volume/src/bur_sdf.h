// The bur's signed distance, inline: BurParams::signed_distance (bur.cpp) and
// the overlap cutter's per-voxel loop (cutter.cpp) call the same functions, so
// the cutter gets the call inlined and both give the same bits.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>

#include "dentar/volume/bur.h"

namespace dentar::volume::detail {

// Squared distance from (rho, z) to the segment a-b in the half plane.
inline double seg_dist2(double px, double pz, double ax, double az, double bx, double bz) {
  const double dx = bx - ax, dz = bz - az;
  const double len2 = dx * dx + dz * dz;
  double t = len2 > 0 ? ((px - ax) * dx + (pz - az) * dz) / len2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  const double ex = px - (ax + t * dx), ez = pz - (az + t * dz);
  return ex * ex + ez * ez;
}

// Signed distance to the solid of revolution of the trapezoid with radius
// r0 at z=0 and r1 at z=-L (rho >= 0). Exact: the profile is convex.
// One square root of the smallest square: the same bits as the smallest of
// three roots (sqrt is correctly rounded, so monotonic).
inline double frustum_sdf(double rho, double z, double r0, double r1, double L) {
  const double d = std::sqrt(std::min({seg_dist2(rho, z, 0, 0, r0, 0), seg_dist2(rho, z, r0, 0, r1, -L),
                                       seg_dist2(rho, z, r1, -L, 0, -L)}));
  const double r_at_z = r0 + (r1 - r0) * (-z / L);
  const bool inside = z <= 0 && z >= -L && rho <= r_at_z;
  return inside ? -d : d;
}

// BurParams::signed_distance. 1-Lipschitz for every shape (an exact distance,
// or for the capsule the min of two exact ones): the cutter's coarse levels
// rely on |sd(p) - sd(q)| <= |p - q|.
inline double bur_signed_distance(const BurParams& b, const Eigen::Vector3d& p) {
  const double rho = std::hypot(p.x(), p.y());
  switch (b.shape) {
    case BurShape::kSphere: return (p - Eigen::Vector3d(0, 0, -b.radius_m)).norm() - b.radius_m;
    case BurShape::kCylinder: return frustum_sdf(rho, p.z(), b.radius_m, b.radius_m, b.length_m);
    case BurShape::kCone: return frustum_sdf(rho, p.z(), b.tip_radius_m, b.radius_m, b.length_m);
    case BurShape::kCapsule: {
      // Union of the hemisphere-ended part: a sphere at z=-r and a cylinder
      // from z=-r to z=-L. min() of the two is exact outside the union.
      const double ds = (p - Eigen::Vector3d(0, 0, -b.radius_m)).norm() - b.radius_m;
      const double dc =
          frustum_sdf(rho, p.z() + b.radius_m, b.radius_m, b.radius_m, b.length_m - b.radius_m);
      return std::min(ds, dc);
    }
  }
  return 1.0;
}

}  // namespace dentar::volume::detail
