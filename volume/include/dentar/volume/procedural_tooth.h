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
  // Height of the pulp chamber's roof above the cervical line (the chamber is 2.0 mm high; the
  // horns rise pulp_horn_mm above the roof). Default 0.8 mm: an adult molar's, from Deutsch &
  // Musikant (J Endod 2004;30:388-390, 100 maxillary molars): buccal cusp tip to the chamber's
  // ceiling 6.24 +- 0.88 mm (this model's cusp tips are at 7.0 mm: 7.0 - 6.24 = 0.76), the
  // ceiling at the cementoenamel junction's level in 98 %, chamber height 1.88 +- 0.69 mm
  // (docs/conventions.md, "The procedural molar's pulp"). Before session 18 the roof was at
  // 0.45 x the crown height (3.15 mm, kLegacyMolarPulpRoofFraction), its horns 2.4 mm under the cusp tips:
  // 2.4 mm higher than the published adult roof. Range 0..crown_height_mm - 1.
  double pulp_roof_mm = 0.8;
  double canal_radius_mm = 0.25;
  double margin_mm = 0.5;          // air around the tooth inside the volume

  std::string validate() const;
};

// The pulp roof of the molar before session 18, as a fraction of the crown height: session
// logs recorded then describe their molar without "pulp_roof_mm" and were cut on this tooth
// (training::make_start_tooth rebuilds it when the log's starting hash says so).
inline constexpr double kLegacyMolarPulpRoofFraction = 0.45;

// Tooth frame: origin at the volume's voxel (0,0,0); +z from the root apices
// toward the occlusal surface; x mesio-distal, y bucco-lingual. The crown
// centre sits at the centre of the x/y extent.
Result<VoxelVolume> make_molar(const MolarParams& p = {});

}  // namespace dentar::volume
