// Simulated station sessions for `dentar calibrate --simulate` and the tests: a hidden "true"
// station (the nominal one perturbed the way a real installation differs from its drawing) and
// the stylus data an instructor would record on it (pivoting in a divot, touching divots,
// tooth landmarks and the mirror rim), with noise. Plus the co-location error of a calibrated
// chain against the truth.
// Frames as in docs/conventions.md; metres and radians.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <random>
#include <vector>

#include "dentar/calibration/station.h"

namespace dentar::calibration {

struct StylusNoise {
  double tip_sigma_m = 0.1e-3;  // per-axis noise of the tip while pivoting (device + hand)
  double fle_m = 0.2e-3;        // fiducial localisation error when touching (RMS 3-D length)
  double tracking_sigma_m = 0.1e-3;     // per-axis error of a tracked tag pose's translation
  double tracking_sigma_rad = 0.5e-3;   // per-axis error of its rotation
};

// The nominal calibration perturbed deterministically from `seed`: camera focal lengths and
// principal point by a few px, T_man_dev by ~3 mm / 2 deg, T_sty_tip by ~0.5 mm, the tooth by
// ~0.8 mm / 2 deg, the mirror by ~0.5 mm / 3 deg and 0.3 mm of radius.
StationCalibration simulated_truth(const StationCalibration& nominal, std::uint64_t seed);

// Where the pivot divot is in the device frame for the simulation (in the workspace).
Eigen::Vector3d simulated_pivot_divot_dev();

// `count` stylus poses pivoting about the divot (tilts up to max_tilt_rad in all directions,
// spin about the stylus axis), the tip at the divot plus per-axis noise tip_sigma_m.
std::vector<Eigen::Isometry3d> simulate_pivot_poses(const StationCalibration& truth,
                                                    const Eigen::Vector3d& divot_dev, int count,
                                                    double max_tilt_rad, const StylusNoise& noise,
                                                    std::mt19937_64& rng);

// One stylus pose per point (device frame) with the tip on the point plus FLE noise
// (isotropic, RMS 3-D length fle_m); orientations vary by up to 30 deg.
std::vector<Eigen::Isometry3d> simulate_touches(const StationCalibration& truth,
                                                const std::vector<Eigen::Vector3d>& points_dev,
                                                const StylusNoise& noise, std::mt19937_64& rng);

// A rigid perturbation with per-axis sigmas (rotation vector rad, translation m).
Eigen::Isometry3d random_perturbation(double sigma_rad, double sigma_m, std::mt19937_64& rng);

// Where the mirror is clamped for its calibration in the simulation: T_man_mtag.
Eigen::Isometry3d simulated_mirror_clamp_man();

// Bur-tip position the calibrated chain predicts in the camera frame:
// T_cam_man * T_man_dev * T_dev_sty * T_sty_tip (translation), m.
Eigen::Vector3d chain_tip_cam(const Eigen::Isometry3d& T_cam_man, const StationCalibration& cal,
                              const Eigen::Isometry3d& T_dev_sty);

}  // namespace dentar::calibration
