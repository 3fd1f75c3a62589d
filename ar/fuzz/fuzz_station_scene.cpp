// Fuzz target: parse_station_scene on arbitrary bytes (the station JSON, with its
// calibration_fixtures, calibration_report and version rules, and camera blocks that are
// embedded or reference a camera file).
//
// The "source" is a file name in a per-process temporary directory that holds an OpenCV
// camera YAML (cam.yaml), an XML (cam.xml) and a ROS camera_info (ros.yaml), so relative
// {"camera": {"file": ...}} references reach the camera-file reader. Every accepted scene is
// written with station_scene_to_json and parsed again: the writer's output must be accepted
// and write the same document again (the writer and the reader agree on every field). Numbers
// are compared to 1e-9 relative: poses pass through rotation matrices (rvec in degrees ->
// Isometry3d -> rvec), which moves their last bits on every cycle.
//
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "dentar/ar/station_scene.h"
#include "dentar/calibration/camera_file.h"

namespace {

namespace fs = std::filesystem;

// Per-process, so parallel fuzzing jobs do not share files. Removed at exit.
const fs::path& work_dir() {
  static const fs::path dir = [] {
    fs::path d = fs::temp_directory_path() / ("dentar-fuzz-station-" + std::to_string(::getpid()));
    fs::create_directories(d);
    dentar::calibration::CameraFile cam;
    cam.camera = dentar::ar::default_station_scene().calibration.camera;
    cam.dist.assign(cam.camera.dist.begin(), cam.camera.dist.end());
    cam.rms_px = 0.31;
    cam.std_devs = {0.8, 0.8, 0.5, 0.5, 0.002, 0.01, 0.0001, 0.0001, 0.02};
    cam.date = "2026-11-22T01:30:00Z";
    cam.device = "fuzz camera";
    if (!dentar::calibration::write_camera_file((d / "cam.yaml").string(), cam) ||
        !dentar::calibration::write_camera_file((d / "cam.xml").string(), cam) ||
        !dentar::calibration::write_ros_camera_info((d / "ros.yaml").string(), cam))
      std::abort();  // the harness itself failed, not the parser
    // The exit handler runs after `dir` below is destroyed (it was registered before `dir` was
    // made), so it removes a copy that is never freed (valgrind: a read of freed memory, session 23).
    static const fs::path* const keep = new fs::path(d);
    std::atexit([] {
      std::error_code ec;
      fs::remove_all(*keep, ec);
    });
    return d;
  }();
  return dir;
}

// Same document: same keys, arrays and strings; numbers equal to 1e-9 relative (1e-12 absolute).
bool same_document(const nlohmann::json& a, const nlohmann::json& b) {
  if (a.is_number() && b.is_number()) {
    const double x = a.get<double>(), y = b.get<double>();
    return std::abs(x - y) <= 1e-12 + 1e-9 * std::max(std::abs(x), std::abs(y));
  }
  if (a.type() != b.type() || a.size() != b.size()) return false;
  if (a.is_object()) {
    for (auto it = a.begin(); it != a.end(); ++it)
      if (!b.contains(it.key()) || !same_document(it.value(), b.at(it.key()))) return false;
    return true;
  }
  if (a.is_array()) {
    for (std::size_t i = 0; i < a.size(); ++i)
      if (!same_document(a[i], b[i])) return false;
    return true;
  }
  return a == b;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dentar::ar;
  if (size > (1u << 20)) return 0;  // read_station_scene refuses files over 4 MiB anyway
  static const std::string source = (work_dir() / "station.json").string();
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  // Any exception escaping is a crash (json::out_of_range for "1e309" was one, fixed).
  const dentar::Result<StationScene> r = parse_station_scene(text, source);
  if (!r) {
    if (r.error().rfind(source + ": ", 0) != 0) __builtin_trap();  // errors name the file
    return 0;
  }
  if (!r->validate().empty()) __builtin_trap();  // the parser validates
  if (r->version < 1 || r->version > kStationFileVersion) __builtin_trap();
  if (r->version < 2 && (!r->calibration_report.empty() || !r->fixtures.divots_man.empty() ||
                         !r->fixtures.landmarks_tooth.empty()))
    __builtin_trap();  // version 1 files carry neither
  const std::string once = station_scene_to_json(*r);
  const auto again = parse_station_scene(once, source);
  if (!again) __builtin_trap();  // the writer's output must be readable
  if (!same_document(nlohmann::json::parse(once),
                     nlohmann::json::parse(station_scene_to_json(*again))))
    __builtin_trap();  // and write the same document
  return 0;
}
