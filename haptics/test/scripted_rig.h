// The engine set-up several haptics tests share: a procedural molar, a capsule
// bur and a simulated hand on the "access" script at the default station, with
// the engine stepping inline (no real-time request). The rig owns everything
// the engine points at, so it is built in place and never moved.
#pragma once

#include <memory>

#include "dentar/haptics/engine.h"
#include "dentar/haptics/scripts.h"
#include "dentar/haptics/simulated_device.h"
#include "dentar/volume/procedural_tooth.h"

namespace dentar::test {

struct ScriptedRig {
  // voxel_mm: tooth grid (m·1e3); bur_samples: points on the bur surface.
  explicit ScriptedRig(double voxel_mm = 0.2, int bur_samples = 500)
      : tooth(molar(voxel_mm)),
        bur(std::move(volume::sample_bur(volume::BurParams::capsule(0.5, 3.0), bur_samples)).value()) {
    haptics::HandParams hand;
    hand.stiffness_N_per_m = haptics::kFingerRestStiffness_N_per_m;
    device = std::move(haptics::SimulatedDevice::create(
                           haptics::to_hand_script(haptics::tip_script("access", 2.5, 1.0), station),
                           haptics::DeviceLimits{}, hand))
                 .value();
    cfg.T_tooth_dev = station.T_tooth_dev;
    cfg.T_sty_tip = station.T_sty_tip;
    cfg.try_realtime = false;
  }
  ScriptedRig(const ScriptedRig&) = delete;
  ScriptedRig& operator=(const ScriptedRig&) = delete;

  std::unique_ptr<haptics::Engine> engine(haptics::SessionLogWriter* log = nullptr) {
    return std::move(haptics::Engine::create(cfg, *device, tooth, bur, log)).value();
  }

  haptics::Station station = haptics::default_station();
  volume::VoxelVolume tooth;
  volume::BurSamples bur;
  std::unique_ptr<haptics::SimulatedDevice> device;
  haptics::EngineConfig cfg;

 private:
  static volume::VoxelVolume molar(double voxel_mm) {
    volume::MolarParams mp;
    mp.voxel_mm = voxel_mm;
    return std::move(volume::make_molar(mp)).value();
  }
};

}  // namespace dentar::test
