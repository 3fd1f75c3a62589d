// ReplayDevice: plays the device states of a session log back, one record
// per step, in simulated time. The forces it receives are kept so a replay
// can be compared with what was sent live.
#pragma once

#include <vector>

#include "dentar/haptics/device.h"
#include "dentar/haptics/session_log.h"

namespace dentar::haptics {

class ReplayDevice final : public HapticDevice {
 public:
  // Takes the records (moved in). Limits come from the log header.
  ReplayDevice(std::vector<StepRecord> records, const DeviceLimits& limits);

  std::string name() const override { return "replay"; }
  const DeviceLimits& limits() const override { return limits_; }
  // Next record's state; false with fault == false at the end of the log.
  // A record flagged with a device fault replays as a fault.
  bool read(DeviceState& out) noexcept override;
  void write_force(const Eigen::Vector3d& f) noexcept override;
  bool recorded_watchdog() const noexcept override {
    return next_ < records_.size() && (records_[next_].flags & kFlagWatchdog) != 0;
  }

  std::size_t position() const { return next_; }
  std::size_t size() const { return records_.size(); }
  // Largest |replayed force - recorded force| seen so far (N).
  double max_force_difference_N() const { return max_diff_N_; }

 private:
  std::vector<StepRecord> records_;
  DeviceLimits limits_;
  std::size_t next_ = 0;
  double max_diff_N_ = 0;
};

}  // namespace dentar::haptics
