// Factories for the live trainer: a haptic device or a foot pedal from a
// command-line word, and what `dentar devices` reports.
//
// Kinds of haptic device:
//   "touch" | "omni" | "desktop" | "premium" | "premium3" | "hd"  -> OpenHaptics (HdDevice)
//   "omega" | "sigma" | "delta" | "falcon" | "dhd"                  -> Force Dimension (DhdDevice)
// A profile name asks for that profile; "hd"/"dhd" take the profile from the
// model the device reports. Asking for a profile that contradicts the model
// the device reports (--device touch on an Omni) is refused, so a device is
// never driven with another device's gains.
//
// Pedal specs:
//   "auto"                      the first known pedal found (USB HID, then keyboard pedals)
//   "vec" | "pcsensor"          a known pedal by name
//   "usb:VID:PID"               a HID bitmask pedal through libusb (any pedal bit runs the drill)
//   "evdev:/dev/input/eventN[:KEY_B,KEY_C]"  a keyboard-like pedal, with an optional key map
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "dentar/haptics/device.h"
#include "dentar/haptics/device_profiles.h"
#include "dentar/haptics/pedal.h"
#include "dentar/haptics/vendor_device.h"
#include "dentar/volume/result.h"

namespace dentar::haptics {

Result<std::unique_ptr<HapticDevice>> open_haptic_device(const std::string& kind,
                                                         const DeviceOpenOptions& options);

Result<std::unique_ptr<Pedal>> open_pedal(const std::string& spec);

// The words open_haptic_device accepts, for --help texts.
std::vector<std::string> haptic_device_kinds();

// Everything `dentar devices` prints, gathered without side effects on the
// devices (each is opened and closed again).
struct DeviceReport {
  std::vector<RuntimeInfo> runtimes;  // HD, DHD
  std::vector<std::string> haptic_devices;  // one line per device found
  std::vector<std::string> haptic_absent;   // why no device of a runtime was found
  struct PedalLine {
    std::string id;       // "vec", "pcsensor" or ""
    std::string vid_pid;  // "05f3:00ff"
    std::string path;     // /dev/bus/usb/... or /dev/input/eventN
    bool permission_ok = false;
    std::string note;     // advice or the key map to use
  };
  std::vector<PedalLine> pedals;
  std::vector<std::string> pedal_absent;  // why no pedal was found
};
DeviceReport probe_devices(const std::string& hd_library = "", const std::string& dhd_library = "",
                           bool open_devices = true);

}  // namespace dentar::haptics
