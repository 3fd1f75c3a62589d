// The built-in procedural upper left central incisor (FDI 21): the tooth of
// the seed's partial crown preparation exercise. Enamel over dentin, a pulp
// chamber and one root canal. Deterministic from its parameters.
#pragma once

#include "dentar/volume/result.h"
#include "dentar/volume/voxel_volume.h"

namespace dentar::volume {

// Sizes in millimetres (user boundary); typical values of a maxillary
// central incisor (crown 10.5 mm long, 8.5 mm wide, root 13 mm).
struct IncisorParams {
  double voxel_mm = 0.1;                 // isotropic voxel size, 0.02..0.5
  double crown_length_mm = 10.5;         // cervical line to incisal edge
  double crown_mesiodistal_mm = 8.5;     // widest, incisal third
  double cervical_mesiodistal_mm = 7.0;  // at the cervical line
  double cervical_labiolingual_mm = 7.0; // at the cervical line (cingulum)
  double incisal_thickness_mm = 1.2;     // labio-lingual at the incisal edge
  double root_length_mm = 13.0;
  double enamel_labial_mm = 1.0;         // thinning to 0 at the cervical line
  double enamel_lingual_mm = 0.7;
  double pulp_top_fraction = 0.55;       // pulp chamber top as a fraction of the crown length
  double margin_mm = 0.5;                // air around the tooth inside the volume

  std::string validate() const;
};

// Tooth frame: origin at the centre of the crown on the cervical plane; +z
// from the root apex toward the incisal edge; x mesio-distal (mesial -x),
// y labio-lingual (labial -y), as for the procedural molar.
Result<VoxelVolume> make_incisor(const IncisorParams& p = {});

// Signed distance (mm, approximate, negative inside) to the outer surface of
// the incisor described by p, at q (mm, tooth frame). For exercises and tests.
double incisor_outer_distance_mm(const IncisorParams& p, const Eigen::Vector3d& q_mm);

}  // namespace dentar::volume
