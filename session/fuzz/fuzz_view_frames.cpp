// Fuzz target: frames.csv as mirror use reads it (session::read_view_frames) (offline or live layout).
// The reader takes a path, so the input goes through a scratch file.
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>

#include "dentar/session/frames_csv.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = "/tmp/dentar_fuzz_view_frames_" + std::to_string(::getpid()) + ".csv";
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) return 0;
  if (size > 0) std::fwrite(data, 1, size, f);
  std::fclose(f);
  auto r = dentar::session::read_view_frames(path, 1000.0);
  if (r) {
    for (const auto& v : *r) {
      if (!std::isfinite(v.session_s) || v.session_s < 0) __builtin_trap();
      if (v.T_cam_man && !v.T_cam_man->matrix().allFinite()) __builtin_trap();
      if (v.T_cam_mtag && !v.T_cam_mtag->matrix().allFinite()) __builtin_trap();
    }
  }
  return 0;
}
