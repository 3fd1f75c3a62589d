#include "dentar/haptics/replay_device.h"

#include <cmath>

namespace dentar::haptics {

ReplayDevice::ReplayDevice(std::vector<StepRecord> records, const DeviceLimits& limits)
    : records_(std::move(records)), limits_(limits) {}

bool ReplayDevice::read(DeviceState& out) noexcept {
  if (next_ >= records_.size()) {
    out.fault = false;
    return false;
  }
  const StepRecord& r = records_[next_];
  out.time_s = r.time_s;
  out.T_dev_sty = Eigen::Isometry3d::Identity();
  for (int row = 0; row < 3; ++row) {
    out.T_dev_sty.translation()[row] = r.position_m[row];
    out.velocity_m_per_s[row] = r.velocity_m_per_s[row];
    for (int c = 0; c < 3; ++c) out.T_dev_sty.linear()(row, c) = r.rotation[row * 3 + c];
  }
  out.buttons = r.buttons;
  out.pedal = r.pedal != 0;
  out.fault = (r.flags & kFlagDeviceFault) != 0;
  return !out.fault;
}

void ReplayDevice::write_force(const Eigen::Vector3d& f) noexcept {
  if (next_ >= records_.size()) return;
  const StepRecord& r = records_[next_];
  const Eigen::Vector3d rec(r.force_dev_N[0], r.force_dev_N[1], r.force_dev_N[2]);
  const double d = (f - rec).norm();
  if (std::isfinite(d) && d > max_diff_N_) max_diff_N_ = d;
  ++next_;
}

}  // namespace dentar::haptics
