// PenDevice: a tracked pen standing in for the haptic stylus (`dentar live
// --stylus pen`). The camera tracks the pen's tag flag; the frame thread
// turns that into the stylus pose in the device frame and publishes it
// here; the 1 kHz engine reads it like any device. No force reaches the
// hand: the engine's force is shown on the HUD instead.
//
//   T_dev_sty = (T_cam_man T_man_dev)^-1 T_cam_ptag T_ptag_tip T_sty_tip^-1
//
// so the bur tip lands on the pen's tip and the engine cuts where the
// student points. A pen lost for longer than stale_s reads as a device fault
// (the engine sends zero force and stops cutting).
// Threads: publish() from the frame thread; read()/write_force() from the
// haptic thread (a seqlock: no lock, no allocation).
#pragma once

#include <Eigen/Geometry>
#include <atomic>

#include "dentar/haptics/device.h"
#include "dentar/haptics/seqlock.h"

namespace dentar::live {

class PenDevice final : public haptics::HapticDevice {
 public:
  PenDevice(const haptics::DeviceLimits& limits, double stale_s = 0.2) : limits_(limits), stale_s_(stale_s) {}
  std::string name() const override { return "tracked pen"; }
  const haptics::DeviceLimits& limits() const override { return limits_; }
  bool read(haptics::DeviceState& out) noexcept override;
  void write_force(const Eigen::Vector3d& f) noexcept override;

  // Frame thread: the pen's stylus pose (device frame) seen at steady time
  // `steady_s` (s); valid = false when the pen or the mannequin is lost.
  void publish(const Eigen::Isometry3d& T_dev_sty, bool valid, double steady_s) noexcept;
  // The last force the engine sent (N, device frame), for the HUD.
  Eigen::Vector3d last_force() const noexcept;

 private:
  struct Pose {
    double T[16];  // column-major T_dev_sty
    double steady_s;
    bool valid;
  };
  haptics::DeviceLimits limits_;
  double stale_s_;
  haptics::SeqLock<Pose> pose_;
  Eigen::Vector3d prev_pos_ = Eigen::Vector3d::Zero();
  double prev_t_ = -1;
  std::atomic<double> fx_{0}, fy_{0}, fz_{0};
};

}  // namespace dentar::live
