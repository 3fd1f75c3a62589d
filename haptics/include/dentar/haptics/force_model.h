// Force models: given the bur pose in the tooth frame and the voxel tooth,
// the force on the stylus. Selectable by name: "seed" (the 2012
// dissertation's model, reproduced exactly) and "proxy" (our god-object
// model without discontinuities or pop-through).
//
// Frame: `tooth` for every pose, velocity and force here; bur samples are in
// the `tip` frame (volume/bur.h). Units SI.
// Thread: compute() runs in the haptic thread; it never allocates, locks or
// does I/O. Models own their history/proxy state, preallocated by the factory
// for up to max_samples bur samples; reset() clears it.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "dentar/haptics/device.h"
#include "dentar/volume/bur.h"
#include "dentar/volume/material.h"
#include "dentar/volume/result.h"
#include "dentar/volume/voxel_volume.h"

namespace dentar::haptics {

struct ForceInput {
  const volume::VoxelVolume* volume = nullptr;  // not owned; null -> zero force
  const volume::BurSamples* bur = nullptr;      // not owned; null/empty -> zero force
  Eigen::Isometry3d T_tooth_tip = Eigen::Isometry3d::Identity();  // measured bur pose
  Eigen::Vector3d velocity_m_per_s = Eigen::Vector3d::Zero();     // bur velocity, tooth frame
  double dt_s = 1e-3;
};

struct ForceOutput {
  Eigen::Vector3d force_N = Eigen::Vector3d::Zero();  // on the stylus, tooth frame, before the device guard
  std::uint32_t contacts = 0;   // seed: immersed sample points (N); proxy: samples on the constraint
  double mean_density = 0.0;    // of the voxels touched by those samples, 0..255
  bool in_contact = false;
  // Model's estimate of how deep the measured bur is in the solid (m). Seed:
  // the depth of a flat plunge that immerses the same volume
  // (N * sample volume / (pi r^2)); proxy: |device - proxy|.
  double penetration_m = 0.0;
  // Where the bur should be drawn (proxy: on the surface; seed: the measured pose)
  // and where the cutter should remove material when the pedal is down.
  Eigen::Isometry3d T_tooth_tip_display = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_tooth_tip_cut = Eigen::Isometry3d::Identity();
};

class ForceModel {
 public:
  virtual ~ForceModel() = default;
  virtual std::string_view name() const = 0;
  virtual void reset() noexcept = 0;
  // Non-finite inputs, a null volume or bur give zero force and no contact
  // (and reset the model's contact state); never NaN.
  virtual ForceOutput compute(const ForceInput& in) noexcept = 0;
  // Optional: the force actually sent after the engine's ForceGuard (tooth
  // frame) for the step whose compute() just returned. The seed model keeps
  // it as the newest "rendered force" of its smoothing history; others ignore it.
  virtual void set_rendered_force(const Eigen::Vector3d& /*force_N*/) noexcept {}
};

// Parameters of the dissertation's model. f_coll = (density_scale * mean
// density + c1 * N) * dir; damping c2 in contact; smoothing over K rendered
// forces with weights 1.3 (newest) .. 1.0 (oldest).
// Note: c1 is per sample point, as in the dissertation, so the force depends
// on the sample count; pick c1 for the count in use.
struct SeedParams {
  double density_scale_N = 1.0 / 255.0;  // N per density unit of the mean touched density
  double c1_N = 2e-4;                     // N per immersed sample point
  double c2_N_s_per_m = 2.0;              // damping, applied only in contact
  int history = 100;                      // K, in [1, 10000]
  std::string validate() const;
};

// Parameters of the proxy (god-object) model.
struct ProxyParams {
  double stiffness_N_per_m = 0.0;  // 0: 0.8 x the device's max stable stiffness; never above it
  double damping_N_s_per_m = 1.5;  // on the device-proxy relative velocity, in contact only
  double max_cut_depth_m = 1e-4;   // how far past the proxy the cutter may reach
  // Constrain with a shell sampled from the bur's shape (its signed distance,
  // up to 2048 points within half a voxel of the surface, the same whatever
  // the bur's sample count) instead of with the bur's own samples. With the
  // own samples a sparse bur's constraint has gaps the solid reaches into,
  // so the proxy sinks deeper and cuts faster the fewer samples the bur has
  // (docs/BENCHMARKS.md, "Haptics session 21/22"). Pairs with
  // volume::CutParams::overlap. Off by default here (sessions so far).
  bool shape_constraint = false;
  // Largest proxy move per substep, in voxels (< 0.5 so it cannot step over
  // a one-voxel wall), and substeps per haptic step.
  double max_substep_voxels = 0.25;
  int max_substeps = 8;
  // Felt hardness while probing: the stiffness is scaled by the material the
  // proxy rests on (filtered over ~20 ms so sliding across a boundary does
  // not jump). Indexed by volume::Material; entries in (0, 1].
  std::array<double, volume::kMaxMaterials> material_stiffness_scale = [] {
    std::array<double, volume::kMaxMaterials> s{};
    s.fill(1.0);
    s[static_cast<std::size_t>(volume::Material::kDentin)] = 0.85;
    s[static_cast<std::size_t>(volume::Material::kCaries)] = 0.6;
    return s;
  }();
  std::string validate() const;
};

struct ForceModelParams {
  SeedParams seed;
  ProxyParams proxy;
};

// Creates a model by name ("seed" or "proxy") for bur sample sets of at most
// max_samples points (in [1, volume::kMaxBurSamples]). Errors name the bad
// field. A bur with more samples than max_samples gets zero force.
Result<std::unique_ptr<ForceModel>> make_force_model(std::string_view name,
                                                     const ForceModelParams& params,
                                                     const DeviceLimits& limits,
                                                     std::size_t max_samples);

// The seed model's pieces, exposed so tests can check them against a hand
// computation.
namespace seed {
// Weight of the rendered force `age` steps old (0 = newest) in a history of
// K entries: falls linearly from 1.3 (age 0) to 1.0 (age K-1); K = 1 -> 1.3.
double history_weight(int age, int K) noexcept;
// H(f_raw, f_hist): mean of the two unit directions, renormalised, scaled by
// the harmonic mean of the two magnitudes. Either magnitude ~0 -> zero (the
// harmonic mean's limit); opposite directions (the mean direction vanishes)
// -> f_raw's direction.
Eigen::Vector3d blend(const Eigen::Vector3d& f_raw, const Eigen::Vector3d& f_hist) noexcept;
}  // namespace seed

}  // namespace dentar::haptics
