// Foot pedals that act as keyboards (for example the PCsensor FootSwitch,
// 0c45:7403), read through evdev (/dev/input/eventN) with a key map: the
// drill runs while any mapped key is held.
//
// Thread: a reader thread poll()s the event device and publishes into
// atomics (PedalPublisher); the haptic thread only loads them. The device is
// grabbed (EVIOCGRAB) so the pedal's keys do not also type into the window.
// Unplug: read() fails with ENODEV (or EOF): released and disconnected at
// once; the reader then looks for the device again every 250 ms (by its
// USB vendor:product in sysfs when known, else the same path) and reopens it.
#pragma once

#include <atomic>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "dentar/haptics/pedal.h"
#include "dentar/haptics/usb_pedal.h"
#include "dentar/volume/result.h"

namespace dentar::haptics {

// Key names ("KEY_B", "BTN_LEFT", or a decimal code) -> evdev codes. An
// empty map means every key runs the drill. Errors name the unknown key.
Result<std::vector<int>> parse_key_map(const std::string& comma_separated);

// The event node of an input device with this USB vendor:product, from
// /sys/class/input (sysfs root replaceable for tests); "" when none.
std::string find_event_node(std::uint16_t vid, std::uint16_t pid,
                            const std::string& sysfs_input = "/sys/class/input");

class EvdevPedal final : public Pedal {
 public:
  // Opens `path` (/dev/input/eventN) and starts the reader. vid/pid (0 =
  // unknown) let it find the device again after an unplug, when the event
  // number may change. A permission error names the udev rule.
  static Result<std::unique_ptr<EvdevPedal>> open(const std::string& path, std::vector<int> keys,
                                                  std::uint16_t vid = 0, std::uint16_t pid = 0,
                                                  std::string name = "");
  // Reads input_event records from an already open fd (tests: a pipe).
  // Takes ownership of fd. EOF counts as an unplug; no reopening.
  static std::unique_ptr<EvdevPedal> from_fd(int fd, std::vector<int> keys, std::string name);
  ~EvdevPedal() override;

  std::string name() const override { return name_; }
  bool pressed() const noexcept override { return pub_.pressed(); }
  bool connected() const noexcept override { return pub_.connected(); }
  std::string status() const override { return name_ + ": " + pub_.status(); }
  std::uint64_t changes() const noexcept { return pub_.changes(); }

 private:
  EvdevPedal() = default;
  void run();
  bool reopen();
  std::string name_, path_;
  std::vector<int> keys_;
  std::uint16_t vid_ = 0, pid_ = 0;
  bool can_reopen_ = false;
  int fd_ = -1;
  int held_ = 0;
  std::vector<unsigned char> down_;  // per key code: held
  PedalPublisher pub_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace dentar::haptics
