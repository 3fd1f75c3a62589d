// The built-in procedural molar: the default tooth of every demo and test.
// Deterministic from its parameters (no random numbers, no files).
#pragma once

#include "dentar/volume/result.h"
#include "dentar/volume/voxel_volume.h"

namespace dentar::volume {

// A maxillary first molar, sizes in millimetres (user boundary).
struct MolarParams {
  double voxel_mm = 0.08;          // isotropic voxel size, 0.02..0.5
  double crown_mesiodistal_mm = 10.0;
  double crown_buccolingual_mm = 11.0;
  double crown_height_mm = 7.0;    // cervical line to cusp tips
  double enamel_mm = 1.5;          // occlusal enamel thickness (thinner at the cervix)
  double root_length_mm = 12.5;    // cervical line to apex
  double cusp_height_mm = 1.6;     // cusp tips above the central fossa
  double pulp_horn_mm = 1.5;       // height of the pulp horns above the chamber roof
  // Height of the pulp chamber's roof above the cervical line; < 0: 0.45 x the crown height
  // (3.15 mm, the model's shape since it was made). Adult maxillary molars: the roof at the
  // cervical line's level, about 6 mm below the cusp tips (Deutsch & Musikant, J Endod 2004).
  double pulp_roof_mm = -1;
  double canal_radius_mm = 0.25;
  double margin_mm = 0.5;          // air around the tooth inside the volume

  std::string validate() const;
};

// Tooth frame: origin at the volume's voxel (0,0,0); +z from the root apices
// toward the occlusal surface; x mesio-distal, y bucco-lingual. The crown
// centre sits at the centre of the x/y extent.
Result<VoxelVolume> make_molar(const MolarParams& p = {});

}  // namespace dentar::volume
