// The live tests' shared footage (live_xvfb_test.cpp, headset_xvfb_test.cpp, ...).
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <string>

#include "testutil.h"

namespace dentar::test {

// Footage shared by the tests: 640x480, 60 frames at 30 fps, as FFV1
// (video.mkv) and as a webcam's Motion JPEG (camera.avi, synth --webcam). Generated once
// per build of dentar (keyed by the binary's time stamp) and shared by the
// test processes ctest runs in parallel: made in a private folder, then
// renamed into place (the loser of a race uses the winner's).
inline const std::filesystem::path& live_clip(const std::string& kBin) {
  namespace fs = std::filesystem;
  static fs::path dir = [&] {
    const auto stamp = fs::last_write_time(kBin).time_since_epoch().count();
    const fs::path d = fs::temp_directory_path() / ("dentar_live_clip_" + std::to_string(stamp));
    if (fs::exists(d / "session.dlog")) return d;
    // Clips of earlier builds (33 MB each) are removed after a day; a day-old one is no longer
    // in use by a parallel run of the same build.
    std::error_code e1;
    for (fs::directory_iterator it(fs::temp_directory_path(), e1), end; !e1 && it != end; it.increment(e1)) {
      if (it->path().filename().string().rfind("dentar_live_clip_", 0) != 0 || it->path() == d) continue;
      std::error_code e2;
      const auto age = fs::file_time_type::clock::now() - fs::last_write_time(it->path(), e2);
      if (!e2 && age > std::chrono::hours(24)) fs::remove_all(it->path(), e2);
    }
    const fs::path tmp = fs::temp_directory_path() / ("dentar_live_clip_tmp_" + std::to_string(getpid()));
    fs::remove_all(tmp);
    auto r = run_command(kBin + " synth --preset standard --frames 60 --resolution 640x480 --seed 3 --webcam --out " +
                         tmp.string() + " 2>&1");
    EXPECT_EQ(r.code, 0) << r.out;
    std::error_code ec;
    fs::rename(tmp, d, ec);
    if (ec) fs::remove_all(tmp);
    return d;
  }();
  return dir;
}

}  // namespace dentar::test
