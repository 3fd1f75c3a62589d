// The whole station through `dentar calibrate live` under Xvfb, against the hidden truth
// (about 150 s: label live_long, `ctest -L long`). The default suite runs the same command
// in the README's contract (ReadmeContract.RunsEveryCommandInOrder: the station is written)
// and each step's bounds in calibrate_live_xvfb_test.cpp and the calibration tests.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calibrate_clip.h"
#include "dentar/calibration/camera_file.h"
#include "testutil.h"
#include "xvfb_util.h"

namespace fs = std::filesystem;
using calibrate_clip::CalibrateLiveCameraXvfb;
using calibrate_clip::kBin;
using calibrate_clip::step;
using dentar::test::read_json;
using dentar::test::run_command;
using dentar::test::xvfb;

// The whole station through the live code: camera (the board clip), pivot, register, tooth,
// mirror and check, driven by the simulated instructor (keys on what the HUD shows; travel at
// pace 4, holds real). The station file against the hidden truth, with the simulated
// workflow's figures as bounds.
TEST_F(CalibrateLiveCameraXvfb, WholeStationWithTheSimulatedInstructor) {
  REQUIRE_XVFB();
  ASSERT_TRUE(ok_) << *out_;
  const fs::path t = *dir_ / "station";
  const fs::path st = t / "station.json", sum = t / "summary.json", shots = t / "shots";
  const auto r = run_command(xvfb(kBin + " calibrate live --haptic sim --pace 4 --seed 3 --camera " + clip() +
                                  " --station " + st.string() + " --summary " + sum.string() + " --screenshots " +
                                  shots.string() + " --seconds 500 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  const auto s = read_json(sum);
  ASSERT_EQ(s["steps"].size(), 6u) << s.dump(2);
  EXPECT_TRUE(s["written"].get<bool>());
  // Refusals with their reason: a view taken while the board moved, a touch while the stylus moved.
  bool moved_view = false, moved_touch = false;
  for (const auto& l : s["log"]) {
    const std::string x = l.get<std::string>();
    moved_view |= x.find("view refused: the board moved") != std::string::npos;
    moved_touch |= x.find("touch refused: the stylus moved") != std::string::npos;
  }
  EXPECT_TRUE(moved_view) << s.dump(2);
  EXPECT_TRUE(moved_touch) << s.dump(2);
  // Camera: the chosen model against the clip's true camera (part 0's bound: 1 px over the image).
  EXPECT_GE(s["steps"][0]["items"].get<int>(), 6) << s.dump(2);
  EXPECT_LE(s["truth"]["camera_fx_error_px"].get<double>(), 1.0) << s.dump(2);
  EXPECT_GE(s["truth"]["camera_max_error_px"].get<double>(), 0.0) << s.dump(2);
  EXPECT_LE(s["truth"]["camera_max_error_px"].get<double>(), 1.0) << s.dump(2);
  EXPECT_LE(s["truth"]["camera_tooth_max_error_px"].get<double>(), 0.3) << s.dump(2);
  // The station file: every step passed and dated, the camera recorded.
  const auto j = read_json(st);
  EXPECT_EQ(j["version"], 4);
  for (const char* name : {"camera", "pivot", "register", "tooth", "mirror", "check"}) {
    const auto* p = step(j, name);
    ASSERT_NE(p, nullptr) << name;
    EXPECT_TRUE((*p)["pass"].get<bool>()) << name;
    EXPECT_FALSE((*p)["date"].get<std::string>().empty()) << name;
    EXPECT_GT((*p)["figures"]["instructor_s"].get<double>(), 0.0) << name;
  }
  const auto truth_cam = dentar::calibration::read_camera_file((*clip_dir_ / "camera.yaml").string());
  ASSERT_TRUE(truth_cam) << truth_cam.error();
  EXPECT_NEAR(j["camera"]["fx"].get<double>(), truth_cam->camera.fx, 1.0) << j["camera"].dump();
  EXPECT_NEAR(j["camera"]["cx"].get<double>(), truth_cam->camera.cx, 2.0) << j["camera"].dump();
  EXPECT_TRUE(fs::exists(t / "station.camera.yaml"));
  EXPECT_LE((*step(j, "camera"))["figures"]["rms_px"].get<double>(), 0.3);
  EXPECT_LE((*step(j, "pivot"))["figures"]["rmse_mm"].get<double>(), 0.16);
  EXPECT_LE((*step(j, "register"))["figures"]["tre_mm"].get<double>(), 0.18);
  EXPECT_LE((*step(j, "check"))["figures"]["error_mean_mm"].get<double>(),
            (*step(j, "check"))["figures"]["threshold_mm"].get<double>());
  EXPECT_LE(s["truth"]["tip_error_mm"].get<double>(), 0.2) << s.dump(2);
  EXPECT_LE(s["truth"]["tooth_error_mm"].get<double>(), 0.32) << s.dump(2);
  EXPECT_LE(s["truth"]["static_colocation_mean_mm"].get<double>(), 0.32) << s.dump(2);
  // The camera step's window shows the overlay (not blank).
  const cv::Mat img = cv::imread((shots / "camera.png").string());
  ASSERT_FALSE(img.empty());
  cv::Scalar mean, sd;
  cv::meanStdDev(img, mean, sd);
  EXPECT_GT(sd[0] + sd[1] + sd[2], 10.0);
}

