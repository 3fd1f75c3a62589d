// `dentar calibrate live` end to end, as an instructor runs it but driven by the stand-ins: a
// real window under Xvfb, the generator's footage paced as the camera behind the HUD, the
// simulated instructor's hand on a SimulatedDevice and its scripted keys (one press while the
// stylus still moves, which must be refused). The station file is checked against the hidden
// truth with the simulated workflow's figures as bounds (pivot RMSE 0.16 mm, TRE at the tooth
// 0.18 mm, co-location 0.32 mm). Skips when xvfb-run is missing, unless DENTAR_REQUIRE_GL=1.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "dentar/calibration/camera_file.h"
#include "testutil.h"
#include "xvfb_util.h"

namespace fs = std::filesystem;
using dentar::test::read_json;
using dentar::test::run_command;
using dentar::test::xvfb;

namespace {

const std::string kBin = DENTAR_BINARY;

const nlohmann::json* step(const nlohmann::json& j, const std::string& name) {
  for (const auto& r : j["calibration_report"])
    if (r["step"] == name) return &r;
  return nullptr;
}

}  // namespace

TEST(CalibrateLiveXvfb, StylusStepsWithTheSimulatedInstructor) {
  REQUIRE_XVFB();
  const fs::path t = dentar::test::temp_dir("calibrate_live");
  auto r = run_command(kBin + " synth --preset standard --frames 30 --resolution 640x480 --seed 2 --out " +
                       (t / "clip").string() + " 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  const fs::path st = t / "station.json", sum = t / "summary.json", shots = t / "shots";
  r = run_command(xvfb(kBin + " calibrate live --steps pivot,register,tooth --haptic sim --pace 4 --seed 3 --camera live:" +
                       (t / "clip" / "video.mkv").string() + " --station " + st.string() + " --summary " +
                       sum.string() + " --screenshots " + shots.string() + " --seconds 400 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  const auto s = read_json(sum);
  ASSERT_EQ(s["steps"].size(), 3u) << s.dump(2);
  EXPECT_TRUE(s["written"].get<bool>());
  // The press while the stylus was still arriving at divot 2 was refused, then retaken.
  EXPECT_GE(s["steps"][1]["refused"].get<int>(), 1) << s.dump(2);
  bool said = false;
  for (const auto& l : s["log"]) said |= l.get<std::string>().find("divot 2: touch refused: the stylus moved") != std::string::npos;
  EXPECT_TRUE(said) << s.dump(2);
  // The station file against the hidden truth.
  const auto j = read_json(st);
  EXPECT_EQ(j["version"], 4);
  for (const char* name : {"pivot", "register", "tooth"}) {
    const auto* p = step(j, name);
    ASSERT_NE(p, nullptr) << name;
    EXPECT_TRUE((*p)["pass"].get<bool>()) << name;
    EXPECT_GT((*p)["figures"]["instructor_s"].get<double>(), 0.0) << name;
  }
  EXPECT_LE((*step(j, "pivot"))["figures"]["rmse_mm"].get<double>(), 0.16);
  EXPECT_LE((*step(j, "pivot"))["figures"]["tip_sd_mm"].get<double>(), 0.2);
  EXPECT_LE((*step(j, "register"))["figures"]["tre_mm"].get<double>(), 0.18);
  EXPECT_LE(s["truth"]["tip_error_mm"].get<double>(), 0.2) << s.dump(2);
  EXPECT_LE(s["truth"]["tooth_error_mm"].get<double>(), 0.32) << s.dump(2);
  EXPECT_LE(s["truth"]["static_colocation_mean_mm"].get<double>(), 0.32) << s.dump(2);
  // The HUD was drawn: each step's window is not blank.
  for (const char* name : {"pivot", "register", "tooth"}) {
    const cv::Mat img = cv::imread((shots / (std::string(name) + ".png")).string());
    ASSERT_FALSE(img.empty()) << name;
    cv::Scalar mean, sd;
    cv::meanStdDev(img, mean, sd);
    EXPECT_GT(sd[0] + sd[1] + sd[2], 10.0) << name;
  }
}

// The generator's footage of a hand-held board (16 poses, held 3 s each, the last six pushed
// into the corners and edges), for the tests below; its camera.yaml is the truth.
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
fs::path* CalibrateLiveCameraXvfb::dir_ = nullptr;
fs::path* CalibrateLiveCameraXvfb::clip_dir_ = nullptr;
std::string* CalibrateLiveCameraXvfb::out_ = nullptr;
bool CalibrateLiveCameraXvfb::ok_ = false;

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

// A board spec that is not the printed board: every view is refused with the reason, and the
// station file is not written.
TEST_F(CalibrateLiveCameraXvfb, WrongBoardIsRefused) {
  REQUIRE_XVFB();
  ASSERT_TRUE(ok_) << *out_;
  const fs::path t = *dir_ / "wrong";
  const fs::path st = t / "station.json", sum = t / "summary.json";
  const auto r = run_command(xvfb(kBin + " calibrate live --steps camera --board aprilgrid:7x6:24:8 --haptic sim --camera " +
                                  clip() + " --station " + st.string() + " --summary " + sum.string() +
                                  " --seconds 20 2>&1"));
  EXPECT_NE(r.code, 0) << r.out;  // 1: nothing written (xvfb-run may add its own code)
  EXPECT_FALSE(fs::exists(st));
  const auto s = read_json(sum);
  bool wrong = false;
  for (const auto& l : s["log"]) wrong |= l.get<std::string>().find("view refused: wrong board") != std::string::npos;
  EXPECT_TRUE(wrong) << s.dump(2);
  EXPECT_FALSE(s["written"].get<bool>()) << s.dump(2);
  EXPECT_EQ(s["stop_reason"], "time limit") << s.dump(2);
}

// Bad options are bad input with the reason.
TEST(CalibrateLiveXvfb, BadInput) {
  auto r = run_command(kBin + " calibrate live --steps camera --station /tmp/x.json 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("the camera step needs the camera"), std::string::npos) << r.out;
  r = run_command(kBin + " calibrate live --steps hand_eye --station /tmp/x.json 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("not a live step"), std::string::npos) << r.out;
  r = run_command(kBin + " calibrate live --steps camera --camera live:/nonexistent.mkv --board aprilgrid:0x5:24:8 --station /tmp/x.json 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("board"), std::string::npos) << r.out;
  // A station file from another camera.
  const fs::path t = dentar::test::temp_dir("calibrate_live_other_camera");
  r = run_command(kBin + " synth --write-default-station " + (t / "s.json").string() + " 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  auto j = read_json(t / "s.json");
  j["camera"]["device_id"] = "footage elsewhere/video.mkv";
  std::ofstream(t / "s.json") << j.dump(2);
  r = run_command(kBin + " calibrate live --steps pivot --camera live:" + (t / "here" / "video.mkv").string() +
                  " --station " + (t / "s.json").string() + " 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("calibrated with camera \"footage elsewhere/video.mkv\""), std::string::npos) << r.out;
  r = run_command(kBin + " calibrate live --steps pivot --haptic nosuchdevice --station /tmp/x.json 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("haptic device nosuchdevice"), std::string::npos) << r.out;
}
