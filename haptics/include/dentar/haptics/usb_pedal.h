// USB foot pedals read directly with libusb (HID reports on the interrupt IN
// endpoint), for example the VEC Infinity pedal (05f3:00ff: a 2-byte report,
// a little-endian bitmask: left 1, middle 2, right 4).
//
// Thread: a reader thread per pedal does all libusb calls and publishes the
// state into atomics; pressed()/connected() (the haptic thread) only load
// them. Unplug: the pending interrupt transfer fails with NO_DEVICE at once,
// the pedal reads as released and disconnected (the drill stops on the next
// engine step); libusb hot-plug callbacks (or a 250 ms poll where the
// platform has none) reopen it when it comes back.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "dentar/haptics/pedal.h"
#include "dentar/volume/result.h"

namespace dentar::haptics {

// Known pedals. kHidBitmask pedals are read here (libusb); kKeyboard pedals
// (they type keys) through evdev (evdev_pedal.h).
struct PedalModel {
  std::string id;    // "vec", "pcsensor"
  std::string name;  // "VEC Infinity IN-USB-2"
  std::uint16_t vid = 0, pid = 0;
  enum class Kind { kHidBitmask, kKeyboard } kind = Kind::kHidBitmask;
  std::uint32_t drill_mask = 0x7;  // HID: which pedal bits run the drill (any of them by default)
};
const std::vector<PedalModel>& known_pedals();
const PedalModel* find_pedal_model(std::uint16_t vid, std::uint16_t pid);
const PedalModel* find_pedal_model(const std::string& id);

// The pedal bits of one VEC-style HID report: bytes[0] | bytes[1] << 8.
// A report of another length is malformed: nullopt.
std::optional<std::uint32_t> parse_bitmask_report(const std::uint8_t* bytes, std::size_t n);

// "05f3:00ff" -> vid, pid; false (and `error` naming the text) when malformed.
bool parse_vid_pid(const std::string& s, std::uint16_t& vid, std::uint16_t& pid, std::string& error);

// The state a pedal reader thread publishes: atomics for the haptic thread,
// a status line (under a mutex) for the HUD. Shared by the USB and evdev pedals.
class PedalPublisher {
 public:
  bool pressed() const noexcept {
    return connected_.load(std::memory_order_acquire) && down_.load(std::memory_order_acquire);
  }
  bool connected() const noexcept { return connected_.load(std::memory_order_acquire); }
  // Reader thread.
  void set_down(bool d) noexcept { down_.store(d, std::memory_order_release); }
  // Unplug, permission error, reader stopped: released first, then disconnected.
  void set_disconnected(const std::string& why);
  void set_connected(const std::string& what);
  std::string status() const;
  std::uint64_t changes() const noexcept { return changes_.load(std::memory_order_acquire); }
  void count_change() noexcept { changes_.fetch_add(1, std::memory_order_acq_rel); }

 private:
  std::atomic<bool> down_{false}, connected_{false};
  std::atomic<std::uint64_t> changes_{0};
  mutable std::mutex mu_;
  std::string status_ = "not connected";
};

class UsbPedal final : public Pedal {
 public:
  // Starts the reader; succeeds even when the pedal is absent or not
  // accessible yet (status() says why; hot-plug connects it later), unless
  // libusb itself cannot start.
  static Result<std::unique_ptr<UsbPedal>> open(std::uint16_t vid, std::uint16_t pid,
                                                std::uint32_t drill_mask = 0x7,
                                                std::string name = "");
  ~UsbPedal() override;  // stops and joins the reader

  std::string name() const override { return name_; }
  bool pressed() const noexcept override { return pub_.pressed(); }
  bool connected() const noexcept override { return pub_.connected(); }
  std::string status() const override { return name_ + ": " + pub_.status(); }
  bool hotplug() const { return hotplug_; }

  struct Impl;

 private:
  UsbPedal() = default;
  void run();
  std::string name_;
  std::uint16_t vid_ = 0, pid_ = 0;
  std::uint32_t mask_ = 0x7;
  bool hotplug_ = false;
  PedalPublisher pub_;
  std::unique_ptr<Impl> impl_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// A USB device as `dentar devices` lists it.
struct UsbDeviceEntry {
  std::uint16_t vid = 0, pid = 0;
  int bus = 0, address = 0;
  std::string path;         // /dev/bus/usb/BBB/AAA
  bool accessible = false;  // can be opened read-write
  std::string known_as;     // pedal id when known, else ""
  std::string message;      // permission advice when not accessible
};
// Every USB device that is a known pedal (all devices when `all`); `error`
// set when libusb cannot run.
std::vector<UsbDeviceEntry> list_usb_devices(bool all, std::string& error);

// The advice for a permission error: install the udev rule.
std::string udev_rule_advice();

}  // namespace dentar::haptics
