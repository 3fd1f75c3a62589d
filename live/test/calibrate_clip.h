// The generator's board clip shared by the `dentar calibrate live` tests under Xvfb
// (calibrate_live_xvfb_test.cpp and the long whole-station run), and a station file's
// calibration report step by name.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "testutil.h"
#include "xvfb_util.h"

namespace calibrate_clip {

namespace fs = std::filesystem;
using dentar::test::run_command;

inline const std::string kBin = DENTAR_BINARY;

inline const nlohmann::json* step(const nlohmann::json& j, const std::string& name) {
  for (const auto& r : j["calibration_report"])
    if (r["step"] == name) return &r;
  return nullptr;
}

// The generator's footage of a hand-held board (16 poses, held 3 s each, the last six pushed
// into the corners and edges); its camera.yaml is the truth.
class CalibrateLiveCameraXvfb : public ::testing::Test {
 protected:
  // The clip is deterministic: rendered once into the build folder (ctest runs each test in its
  // own process) and reused while its clip.json is there.
  static void SetUpTestSuite() {
    dir_ = new fs::path(dentar::test::temp_dir("calibrate_live_board"));
    const fs::path cache = fs::path(kBin).parent_path() / "test_cache" / "calibrate_live_board_clip_seed3";
    fs::create_directories(cache.parent_path());
    out_ = new std::string;
    if (!fs::exists(cache / "clip.json")) {
      const fs::path tmp = *dir_ / "render";
      const auto r = run_command(kBin + " synth --board aprilgrid:6x5:24:8 --holds 16 --hold 3 --seed 3 --out " +
                                 tmp.string() + " 2>&1");
      *out_ = r.out;
      if (r.code != 0) return;
      std::error_code ec;
      fs::remove_all(cache, ec);
      fs::rename(tmp, cache, ec);
      if (ec) fs::copy(tmp, cache, fs::copy_options::recursive | fs::copy_options::overwrite_existing, ec);
      if (ec) {
        *out_ += "cannot keep the clip in " + cache.string() + ": " + ec.message();
        return;
      }
    }
    clip_dir_ = new fs::path(cache);
    ok_ = true;
  }
  static void TearDownTestSuite() {
    delete dir_;
    delete out_;
    delete clip_dir_;
  }
  static std::string clip() { return "live:" + (*clip_dir_ / "video.mkv").string(); }
  static fs::path* dir_;
  static fs::path* clip_dir_;
  static std::string* out_;
  static bool ok_;
};
inline fs::path* CalibrateLiveCameraXvfb::dir_ = nullptr;
inline fs::path* CalibrateLiveCameraXvfb::clip_dir_ = nullptr;
inline std::string* CalibrateLiveCameraXvfb::out_ = nullptr;
inline bool CalibrateLiveCameraXvfb::ok_ = false;

}  // namespace calibrate_clip
