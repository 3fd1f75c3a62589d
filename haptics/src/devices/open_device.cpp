#include "dentar/haptics/open_device.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>

#include "dentar/haptics/dhd_device.h"
#include "dentar/haptics/evdev_pedal.h"
#include "dentar/haptics/hd_device.h"
#include "dentar/haptics/usb_pedal.h"

namespace dentar::haptics {

std::vector<std::string> haptic_device_kinds() {
  std::vector<std::string> k;
  for (const auto& p : device_profiles()) k.push_back(p.id);
  k.push_back("hd");
  k.push_back("dhd");
  return k;
}

Result<std::unique_ptr<HapticDevice>> open_haptic_device(const std::string& kind,
                                                         const DeviceOpenOptions& options) {
  std::string backend;
  const DeviceProfile* wanted = nullptr;
  if (kind == "hd" || kind == "dhd") {
    backend = kind;
  } else if ((wanted = find_device_profile(kind))) {
    backend = wanted->backend;
  } else {
    std::string all;
    for (const auto& k : haptic_device_kinds()) all += (all.empty() ? "" : "|") + k;
    return Error{"unknown haptic device '" + kind + "': use " + all};
  }
  DeviceOpenOptions o = options;
  if (wanted && o.profile.empty()) o.profile = wanted->id;
  // The profile the device's own model name maps to must not contradict the request.
  auto check = [&](const std::string& model, const DeviceProfile& used) -> std::string {
    const DeviceProfile* by_model = find_device_profile(model);
    if (wanted && by_model && by_model != &used)
      return "you asked for --device " + kind + " but the device reports itself as '" + model +
             "' (profile " + by_model->id + "): use --device " + by_model->id + " or --device " +
             backend;
    return {};
  };
  if (backend == "hd") {
    auto d = HdDevice::open(o);
    if (!d.ok()) return Error{d.error()};
    if (std::string e = check((*d)->info().model, (*d)->profile()); !e.empty()) return Error{e};
    return std::unique_ptr<HapticDevice>(std::move(d).value());
  }
  auto d = DhdDevice::open(o);
  if (!d.ok()) return Error{d.error()};
  if (std::string e = check((*d)->info().model, (*d)->profile()); !e.empty()) return Error{e};
  return std::unique_ptr<HapticDevice>(std::move(d).value());
}

namespace {

std::string hex_id(std::uint16_t v, std::uint16_t p) {
  char b[16];
  std::snprintf(b, sizeof b, "%04x:%04x", v, p);
  return b;
}

Result<std::unique_ptr<Pedal>> open_model(const PedalModel& m) {
  if (m.kind == PedalModel::Kind::kHidBitmask) {
    auto p = UsbPedal::open(m.vid, m.pid, m.drill_mask, m.name + " " + hex_id(m.vid, m.pid));
    if (!p.ok()) return Error{p.error()};
    return std::unique_ptr<Pedal>(std::move(p).value());
  }
  const std::string node = find_event_node(m.vid, m.pid);
  if (node.empty())
    return Error{m.name + " (" + hex_id(m.vid, m.pid) +
                 ") has no input event node: is it plugged in? (`dentar devices` lists pedals)"};
  auto p = EvdevPedal::open(node, {}, m.vid, m.pid, m.name + " " + hex_id(m.vid, m.pid));
  if (!p.ok()) return Error{p.error()};
  return std::unique_ptr<Pedal>(std::move(p).value());
}

}  // namespace

Result<std::unique_ptr<Pedal>> open_pedal(const std::string& spec) {
  const std::string usage =
      "use auto, vec, pcsensor, usb:VID:PID (e.g. usb:05f3:00ff) or "
      "evdev:/dev/input/eventN[:KEY_B,KEY_C]";
  if (spec == "auto") {
    std::string err;
    const auto usb = list_usb_devices(false, err);
    for (const auto& e : usb)
      if (const PedalModel* m = find_pedal_model(e.vid, e.pid)) {
        if (!e.accessible) return Error{m->name + " at " + e.path + ": " + e.message};
        return open_model(*m);
      }
    // Keyboard pedals also show in sysfs where libusb cannot list devices.
    for (const auto& m : known_pedals())
      if (m.kind == PedalModel::Kind::kKeyboard && !find_event_node(m.vid, m.pid).empty())
        return open_model(m);
    std::string known;
    for (const auto& m : known_pedals()) known += (known.empty() ? "" : ", ") + m.name + " " + hex_id(m.vid, m.pid);
    return Error{"no foot pedal found" + (err.empty() ? std::string() : " (" + err + ")") +
                 "; known pedals: " + known + ". Plug one in, or use the keyboard (space bar)"};
  }
  if (const PedalModel* m = find_pedal_model(spec)) return open_model(*m);
  if (spec.rfind("usb:", 0) == 0) {
    std::uint16_t vid = 0, pid = 0;
    std::string err;
    if (!parse_vid_pid(spec.substr(4), vid, pid, err)) return Error{"--pedal " + spec + ": " + err};
    const PedalModel* m = find_pedal_model(vid, pid);
    if (m && m->kind == PedalModel::Kind::kKeyboard)
      return Error{"--pedal " + spec + ": the " + m->name +
                   " types keys; read it with --pedal " + m->id + " or evdev:/dev/input/eventN"};
    auto p = UsbPedal::open(vid, pid, m ? m->drill_mask : 0x7);
    if (!p.ok()) return Error{p.error()};
    return std::unique_ptr<Pedal>(std::move(p).value());
  }
  if (spec.rfind("evdev:", 0) == 0) {
    std::string rest = spec.substr(6), keys;
    if (const auto c = rest.find(':'); c != std::string::npos) {
      keys = rest.substr(c + 1);
      rest = rest.substr(0, c);
    }
    auto k = parse_key_map(keys);
    if (!k.ok()) return Error{"--pedal " + spec + ": " + k.error()};
    auto p = EvdevPedal::open(rest, *k);
    if (!p.ok()) return Error{p.error()};
    return std::unique_ptr<Pedal>(std::move(p).value());
  }
  return Error{"unknown pedal '" + spec + "': " + usage};
}

DeviceReport probe_devices(const std::string& hd_library, const std::string& dhd_library,
                           bool open_devices) {
  DeviceReport r;
  const RuntimeInfo hd = probe_hd_runtime(hd_library);
  const RuntimeInfo dhd = probe_dhd_runtime(dhd_library);
  r.runtimes = {hd, dhd};
  if (!hd.present) {
    r.haptic_absent.push_back("OpenHaptics devices: not looked for, no runtime (" + hd.message + ")");
  } else if (open_devices) {
    DeviceOpenOptions o;
    o.library = hd_library;
    auto d = HdDevice::open(o);
    if (d.ok()) {
      const auto& i = (*d)->info();
      r.haptic_devices.push_back("HD \"Default Device\": " + i.model + ", serial " + i.serial +
                                 ", OpenHaptics " + i.runtime_version + ", profile " + i.profile_id +
                                 ", calibration " + i.calibration);
    } else {
      r.haptic_absent.push_back("OpenHaptics default device: " + d.error());
    }
  }
  if (!dhd.present) {
    r.haptic_absent.push_back("Force Dimension devices: not looked for, no runtime (" + dhd.message + ")");
  } else if (open_devices) {
    std::string why;
    const auto lines = DhdDevice::list(dhd_library, why);
    r.haptic_devices.insert(r.haptic_devices.end(), lines.begin(), lines.end());
    if (lines.empty()) r.haptic_absent.push_back("Force Dimension: " + why);
  }
  std::string err;
  const auto usb = list_usb_devices(false, err);
  for (const auto& e : usb) {
    DeviceReport::PedalLine l;
    l.id = e.known_as;
    l.vid_pid = hex_id(e.vid, e.pid);
    l.path = e.path;
    l.permission_ok = e.accessible;
    const PedalModel* m = find_pedal_model(e.vid, e.pid);
    if (!e.accessible)
      l.note = e.message;
    else if (m && m->kind == PedalModel::Kind::kKeyboard)
      l.note = "keyboard pedal: read through evdev (--pedal " + m->id + ")";
    else
      l.note = "--pedal usb:" + l.vid_pid;
    r.pedals.push_back(l);
  }
  // Keyboard pedals through evdev (also where libusb cannot list devices).
  for (const auto& m : known_pedals()) {
    if (m.kind != PedalModel::Kind::kKeyboard) continue;
    const std::string node = find_event_node(m.vid, m.pid);
    if (node.empty()) continue;
    DeviceReport::PedalLine l;
    l.id = m.id;
    l.vid_pid = hex_id(m.vid, m.pid);
    l.path = node;
    l.permission_ok = access(node.c_str(), R_OK) == 0;
    l.note = l.permission_ok ? "--pedal " + m.id : udev_rule_advice();
    r.pedals.push_back(l);
  }
  if (r.pedals.empty()) {
    if (!err.empty()) r.pedal_absent.push_back("USB: " + err);
    if (!std::filesystem::exists("/dev/bus/usb"))
      r.pedal_absent.push_back("/dev/bus/usb does not exist (a container without USB access?)");
    std::string known;
    for (const auto& m : known_pedals()) known += (known.empty() ? "" : ", ") + m.name + " " + hex_id(m.vid, m.pid);
    r.pedal_absent.push_back("no known foot pedal is plugged in (known: " + known +
                             "); another HID pedal: --pedal usb:VID:PID");
  }
  return r;
}

}  // namespace dentar::haptics
