// Force model factory and proxy parameter validation.
#include "dentar/haptics/force_model.h"

#include <cmath>
#include <sstream>

#include "contact.h"

namespace dentar::haptics {

std::string ProxyParams::validate() const {
  std::ostringstream os;
  if (!std::isfinite(stiffness_N_per_m) || stiffness_N_per_m < 0)
    os << "proxy.stiffness_N_per_m = " << stiffness_N_per_m
       << " must be finite and >= 0 (0 = 0.8 x device max)";
  else if (!std::isfinite(damping_N_s_per_m) || damping_N_s_per_m < 0)
    os << "proxy.damping_N_s_per_m = " << damping_N_s_per_m << " must be finite and >= 0";
  else if (!std::isfinite(max_cut_depth_m) || max_cut_depth_m < 0 || max_cut_depth_m > 2e-3)
    os << "proxy.max_cut_depth_m = " << max_cut_depth_m << " must be in [0, 2e-3] m";
  else if (!std::isfinite(max_substep_voxels) || max_substep_voxels <= 0 ||
           max_substep_voxels >= 0.5)
    os << "proxy.max_substep_voxels = " << max_substep_voxels
       << " must be in (0, 0.5) so the proxy cannot step over a one-voxel wall";
  else if (max_substeps < 1 || max_substeps > 64)
    os << "proxy.max_substeps = " << max_substeps << " must be in [1, 64]";
  else
    for (std::size_t m = 0; m < material_stiffness_scale.size(); ++m)
      if (!std::isfinite(material_stiffness_scale[m]) || material_stiffness_scale[m] <= 0 ||
          material_stiffness_scale[m] > 1) {
        os << "proxy.material_stiffness_scale[" << m << "] = " << material_stiffness_scale[m]
           << " must be in (0, 1]";
        break;
      }
  return os.str();
}

Result<std::unique_ptr<ForceModel>> make_force_model(std::string_view name,
                                                     const ForceModelParams& params,
                                                     const DeviceLimits& limits,
                                                     std::size_t max_samples) {
  if (max_samples < 1 || max_samples > static_cast<std::size_t>(volume::kMaxBurSamples))
    return Error{"force model: max_samples = " + std::to_string(max_samples) + " must be in [1, " +
                 std::to_string(volume::kMaxBurSamples) + "]"};
  if (name == "seed") {
    if (std::string why = params.seed.validate(); !why.empty())
      return Error{"force model: " + why};
    if (params.seed.c2_N_s_per_m > limits.max_damping_N_s_per_m)
      return Error{"force model: seed.c2_N_s_per_m = " + std::to_string(params.seed.c2_N_s_per_m) +
                   " exceeds the device's max stable damping " +
                   std::to_string(limits.max_damping_N_s_per_m) + " N s/m"};
    return detail::make_seed_model(params.seed, max_samples);
  }
  if (name == "proxy") {
    if (std::string why = params.proxy.validate(); !why.empty())
      return Error{"force model: " + why};
    const double kmax = limits.max_stiffness_N_per_m;
    if (!std::isfinite(kmax) || kmax <= 0)
      return Error{"force model: device limits max_stiffness_N_per_m = " + std::to_string(kmax) +
                   " must be finite and > 0"};
    // Passivity: a virtual spring stiffer than the device can render stably
    // at 1 kHz would buzz; refuse rather than clamp silently.
    if (params.proxy.stiffness_N_per_m > kmax)
      return Error{"force model: proxy.stiffness_N_per_m = " +
                   std::to_string(params.proxy.stiffness_N_per_m) +
                   " exceeds the device's max stable stiffness " + std::to_string(kmax) + " N/m"};
    // Virtual damping above the device's figure is as unstable as a stiff spring.
    if (params.proxy.damping_N_s_per_m > limits.max_damping_N_s_per_m)
      return Error{"force model: proxy.damping_N_s_per_m = " +
                   std::to_string(params.proxy.damping_N_s_per_m) +
                   " exceeds the device's max stable damping " +
                   std::to_string(limits.max_damping_N_s_per_m) + " N s/m"};
    return detail::make_proxy_model(params.proxy, limits, max_samples);
  }
  return Error{"force model: unknown name '" + std::string(name) + "': use seed or proxy"};
}

}  // namespace dentar::haptics
