// Fuzz target: read_camera_file on arbitrary bytes (OpenCV FileStorage YAML/XML, ROS
// camera_info YAML; the kind is detected from the content).
//
// read_camera_file only takes a path, so each input is written to a file in a per-process
// temporary directory first. Every file the reader accepts is written back with both writers
// and read again: what the reader accepts, the writers must be able to store, and the stored
// file must read back to the same numbers.
//
#include <unistd.h>

#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>

#include "dentar/calibration/camera_file.h"

namespace {

namespace cal = dentar::calibration;
namespace fs = std::filesystem;

// Per-process, so parallel fuzzing jobs (-jobs/-fork) do not share files. Removed at exit.
const fs::path& work_dir() {
  static const fs::path dir = [] {
    fs::path d = fs::temp_directory_path() / ("dentar-fuzz-camera-" + std::to_string(::getpid()));
    fs::create_directories(d);
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

bool same_numbers(const cal::CameraFile& a, const cal::CameraFile& b) {
  const auto& x = a.camera;
  const auto& y = b.camera;
  return x.width == y.width && x.height == y.height && x.fx == y.fx && x.fy == y.fy &&
         x.cx == y.cx && x.cy == y.cy && x.dist == y.dist && a.dist == b.dist &&
         a.model == b.model;
}

// Contracts every read must keep, whatever the input.
void check(const dentar::Result<cal::CameraFile>& r, const std::string& path) {
  if (!r) {
    if (r.error().rfind(path + ": ", 0) != 0) __builtin_trap();  // errors name the file
    return;
  }
  const cal::CameraFile& f = *r;
  if (!f.validate().empty()) __builtin_trap();  // the reader validates
  if (f.source_format != "opencv-yaml" && f.source_format != "opencv-xml" &&
      f.source_format != "ros-yaml")
    __builtin_trap();
  if (f.dist.size() != 5 && f.dist.size() != 8) __builtin_trap();
  for (int i = 0; i < 5; ++i)
    if (f.dist[static_cast<std::size_t>(i)] != f.camera.dist[static_cast<std::size_t>(i)])
      __builtin_trap();

  for (const char* name : {"rt.yaml", "rt.xml", "rt_ros.yaml"}) {
    const std::string out = (work_dir() / name).string();
    const bool ros = std::string(name) == "rt_ros.yaml";
    const dentar::Status w = ros ? cal::write_ros_camera_info(out, f) : cal::write_camera_file(out, f);
    if (!w) __builtin_trap();  // a file the reader accepted must be writable
    const auto back = cal::read_camera_file(out);
    if (!back || !same_numbers(f, *back)) __builtin_trap();  // and read back unchanged
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > (1u << 16)) return 0;  // camera files are a few KiB; keep each run cheap
  const std::string path = (work_dir() / "in.yaml").string();
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    if (!out) std::abort();  // the harness itself failed (disk full), not the parser
  }
  // read_camera_file screens XML attributes before OpenCV 4.6's XML parser
  // (which segfaulted on "<?xml v=") and catches its std::length_error: both
  // were findings of this target, now fixed, so any escape is a crash.
  check(cal::read_camera_file(path), path);
  return 0;
}
