// dentar devices: what haptic runtimes, haptic devices and foot pedals this
// machine has, and the reason for every absence.
#include <algorithm>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "dentar/ar/station_scene.h"
#include "dentar/haptics/device_profiles.h"
#include "dentar/haptics/open_device.h"
#include "dentar/live/station_health.h"
#include "dentar/sound/audio_output.h"
#include "dentar/volume/procedural_tooth.h"

namespace dentar::tools {
namespace {

struct DevicesOptions {
  std::string hd_library, dhd_library;
  bool no_open = false;
  bool json = false;
  bool profiles = false;
  std::string station;
};

// Can each profile's stylus reach the crown of the station's tooth?
int print_reach(const std::string& path) {
  // A station file, or a built-in station by name ("default", "box").
  const auto builtin = std::filesystem::exists(path) ? std::nullopt : ar::builtin_station_scene(path);
  auto st = builtin ? Result<ar::StationScene>(*builtin) : ar::read_station_scene(path);
  if (!st.ok()) {
    print_error("devices", st.error());
    return 2;
  }
  auto box = live::crown_box_tooth(*st);
  if (!box.ok()) {
    print_error("devices", path + ": " + box.error());
    return 2;
  }
  volume::MolarParams mp;
  std::cout << "Reach from " << path << " (the crown, " << mp.crown_height_mm << " mm):\n";
  for (const auto& p : haptics::device_profiles()) {
    const auto r = live::check_station_reach(*st, haptics::limits_from_profile(p), p.display_name, *box);
    std::cout << "  " << std::left << std::setw(10) << p.id << std::right << (r.reach.reachable ? "OK  " : "NO  ")
              << r.item.message << "\n";
  }
  return 0;
}

void print_profiles() {
  std::cout << "Device profiles (force clamp, max stable stiffness and damping, workspace):\n";
  std::cout << "  " << std::left << std::setw(10) << "id" << std::setw(36) << "device" << std::right
            << std::setw(8) << "N" << std::setw(10) << "N/m" << std::setw(9) << "N s/m"
            << std::setw(8) << "mm" << "\n";
  for (const auto& p : haptics::device_profiles())
    std::cout << "  " << std::left << std::setw(10) << p.id << std::setw(36) << p.display_name
              << std::right << std::setw(8) << p.max_force_N << std::setw(10)
              << p.max_stiffness_N_per_m << std::setw(9) << p.max_damping_N_s_per_m << std::setw(8)
              << 1e3 * p.workspace_radius_m << "\n";
  std::cout << "  source: " << haptics::device_profiles().front().source << " and CDeltaDevices.cpp\n";
}

int run_devices(const DevicesOptions& o) {
  const haptics::DeviceReport r = haptics::probe_devices(o.hd_library, o.dhd_library, !o.no_open);
  if (o.json) {
    nlohmann::json j;
    for (const auto& rt : r.runtimes)
      j["runtimes"].push_back({{"runtime", rt.runtime}, {"requested", rt.requested},
                               {"present", rt.present}, {"path", rt.path},
                               {"version", rt.version}, {"message", rt.message}});
    j["haptic_devices"] = r.haptic_devices;
    j["haptic_absent"] = r.haptic_absent;
    j["pedals"] = nlohmann::json::array();
    for (const auto& p : r.pedals)
      j["pedals"].push_back({{"id", p.id}, {"vid_pid", p.vid_pid}, {"path", p.path},
                             {"permission_ok", p.permission_ok}, {"note", p.note}});
    j["pedal_absent"] = r.pedal_absent;
    j["audio_outputs"] = nlohmann::json::array();
    for (const auto& d : sound::list_audio_outputs())
      j["audio_outputs"].push_back({{"name", d.name}, {"default", d.is_default}, {"opens", d.opens}});
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  std::cout << "Haptic runtimes:\n";
  for (const auto& rt : r.runtimes) {
    std::cout << "  " << rt.runtime << ": ";
    if (rt.present)
      std::cout << "found " << rt.path << (rt.version.empty() ? "" : ", version " + rt.version)
                << "\n";
    else
      std::cout << rt.message << "\n";
  }
  std::cout << "Haptic devices:\n";
  if (o.no_open) std::cout << "  (not opened: --no-open)\n";
  for (const auto& d : r.haptic_devices) std::cout << "  " << d << "\n";
  for (const auto& a : r.haptic_absent) std::cout << "  none: " << a << "\n";
  std::cout << "Foot pedals:\n";
  for (const auto& p : r.pedals)
    std::cout << "  " << p.vid_pid << (p.id.empty() ? "" : " (" + p.id + ")") << " at " << p.path
              << ": permission " << (p.permission_ok ? "OK" : "DENIED") << "; " << p.note << "\n";
  for (const auto& a : r.pedal_absent) std::cout << "  none: " << a << "\n";
  // Audio outputs for the drill's sound (issue 29): none is a warning, never an error.
  std::cout << "Audio outputs (OpenAL Soft):\n";
  const auto outputs = sound::list_audio_outputs();
  bool any = false;
  for (const auto& d : outputs) {
    std::cout << "  " << d.name << (d.is_default ? " (default)" : "") << ": "
              << (d.opens ? "OK" : "listed but cannot be opened") << "\n";
    any = any || d.opens;
  }
  if (!any)
    std::cout << "  warning: no audio output can be opened" << (outputs.empty() ? " (none listed)" : "")
              << ": the drill's sound is off (renders to WAV still work: dentar sound render)\n";
  if (o.profiles) print_profiles();
  if (!o.station.empty()) return print_reach(o.station);
  return 0;
}

}  // namespace

void add_devices(CLI::App& app, int& exit_code) {
  auto o = std::make_shared<DevicesOptions>();
  CLI::App* c = app.add_subcommand(
      "devices",
      "List haptic runtimes (OpenHaptics libHD, Force Dimension libdhd/libdrd) with their version,\n"
      "the haptic devices they see with calibration state, and USB foot pedals with permission\n"
      "state; says why anything is absent.\n"
      "Synopsis: dentar devices [--hd-library PATH] [--dhd-library PATH] [--no-open] [--json]\n"
      "                         [--profiles] [--station FILE]");
  c->add_option("--hd-library", o->hd_library,
                "libHD.so to load (default: libHD.so through the loader path or DENTAR_HD_LIBRARY)");
  c->add_option("--dhd-library", o->dhd_library,
                "libdhd.so/libdrd.so to load (default: libdrd.so, then libdhd.so, or DENTAR_DHD_LIBRARY)");
  c->add_flag("--no-open", o->no_open, "Only look for the runtimes; do not open any device");
  c->add_flag("--json", o->json, "Print the report as JSON");
  c->add_flag("--profiles", o->profiles, "Also print the device profile table");
  c->add_option("--station", o->station,
                "Also check, for every profile, that the stylus reaches the tooth's crown from this "
                "station file's device placement (or a built-in station's: default, box), and say how "
                "far to move the device when it does not");
  c->footer(
      "Examples:\n  dentar devices\n"
      "  LD_LIBRARY_PATH=build/standin dentar devices   # against the test stand-ins\n"
      "  dentar devices --no-open --station assets/station_default.json");
  c->callback([o, &exit_code] { exit_code = run_devices(*o); });
}

}  // namespace dentar::tools
