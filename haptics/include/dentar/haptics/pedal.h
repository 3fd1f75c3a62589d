// Foot pedal: the student holds it down to run the drill.
//
// Implementations: ManualPedal (a key in the live window, tests), and the USB
// pedals (HID through libusb, keyboard-like pedals through evdev) of the
// device backends. PedalDevice puts a pedal in front of any HapticDevice, so
// the engine sees one DeviceState whatever drives the stylus and the drill.
//
// Thread: pressed() and connected() are called by the haptic thread every
// step: they read atomics only (no lock, syscall or allocation). A pedal that
// polls hardware does it on its own thread and publishes into those atomics.
// Safety: a pedal that is unplugged, faulted or stale reads as released, so
// the drill stops within one haptic step of the pedal's reader noticing.
#pragma once

#include <atomic>
#include <memory>
#include <string>

#include "dentar/haptics/device.h"

namespace dentar::haptics {

class Pedal {
 public:
  virtual ~Pedal() = default;
  virtual std::string name() const = 0;
  // Pressed now; false whenever not connected. Haptic thread safe.
  virtual bool pressed() const noexcept = 0;
  virtual bool connected() const noexcept = 0;
  // One line for the HUD and the log ("USB pedal 05f3:00ff: unplugged").
  // Not for the haptic thread (may allocate).
  virtual std::string status() const = 0;
};

// A pedal set by the program: the space bar of the live window, tests.
class ManualPedal final : public Pedal {
 public:
  explicit ManualPedal(std::string name = "keyboard (space bar)") : name_(std::move(name)) {}
  std::string name() const override { return name_; }
  bool pressed() const noexcept override {
    return connected_.load(std::memory_order_acquire) && down_.load(std::memory_order_acquire);
  }
  bool connected() const noexcept override { return connected_.load(std::memory_order_acquire); }
  std::string status() const override;
  // Any thread.
  void set_pressed(bool down) noexcept { down_.store(down, std::memory_order_release); }
  void set_connected(bool c) noexcept { connected_.store(c, std::memory_order_release); }

 private:
  std::string name_;
  std::atomic<bool> down_{false}, connected_{true};
};

// Decorator: the inner device's state, with DeviceState::pedal taken from
// `pedal` (the inner device's own pedal bit is ignored unless `or_inner`).
// Neither is owned; both must outlive this object.
class PedalDevice final : public HapticDevice {
 public:
  PedalDevice(HapticDevice& inner, const Pedal& pedal, bool or_inner = false)
      : inner_(&inner), pedal_(&pedal), or_inner_(or_inner) {}
  std::string name() const override { return inner_->name() + " + " + pedal_->name(); }
  const DeviceLimits& limits() const override { return inner_->limits(); }
  bool read(DeviceState& out) noexcept override {
    const bool ok = inner_->read(out);
    out.pedal = pedal_->pressed() || (or_inner_ && out.pedal);
    return ok;
  }
  void write_force(const Eigen::Vector3d& f) noexcept override { inner_->write_force(f); }
  bool recorded_watchdog() const noexcept override { return inner_->recorded_watchdog(); }
  std::string status() const override { return inner_->status(); }

 private:
  HapticDevice* inner_;
  const Pedal* pedal_;
  bool or_inner_;
};

}  // namespace dentar::haptics
