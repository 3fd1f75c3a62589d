// `dentar calibrate stereo` (issue 28) as a user runs it: board photos of a stereo head with known
// extrinsics (rendered by the board ray-caster for each eye, one folder per eye, and the same as
// side-by-side photos), the rig written into the station file. Label long (~90 s on 2 cores);
// the default suite has calibration_stereo_test (generated corners) and CliCalibrateStereo.BadInputIsNamed.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "dentar/ar/calib_board.h"
#include "dentar/calibration/intrinsics.h"
#include "testutil.h"

namespace {

namespace fs = std::filesystem;
namespace cal = dentar::calibration;
constexpr double kDeg = M_PI / 180.0;

Eigen::Isometry3d rig_truth() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(-0.6 * kDeg, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.064, 0.0005, 0.0003);
  return T;
}

cal::CameraIntrinsics eye(double fx, double cx, double cy) {
  cal::CameraIntrinsics k;
  k.width = 640;
  k.height = 480;
  k.fx = fx;
  k.fy = fx;
  k.cx = cx;
  k.cy = cy;
  k.dist = {-0.08, 0.03, 0, 0, 0};
  return k;
}

// Renders 12 captures of `board` into dir/left, dir/right and dir/sbs (side by side).
fs::path render_photos(const std::string& board, const std::string& tag) {
    const fs::path d = dentar::test::temp_dir("stereo_photos_" + tag);
    fs::create_directories(d / "left");
    fs::create_directories(d / "right");
    fs::create_directories(d / "sbs");
    auto spec = dentar::ar::parse_board_spec(board);
    EXPECT_TRUE(spec.ok());
    const auto tex = dentar::ar::make_board_texture(*spec, 3000);
    const cal::CameraIntrinsics kl = eye(620, 318, 242), kr = eye(628, 323, 237);
    const auto poses = cal::plan_board_poses(kl, dentar::ar::board_width_m(*spec), dentar::ar::board_height_m(*spec), 12, 7);
    for (int i = 0; i < 12; ++i) {
      dentar::ar::BoardRenderOptions o;
      o.supersample = 2;
      o.seed = 100 + i;
      const cv::Mat l = dentar::ar::render_board_view(tex, kl, poses[i], o);
      o.seed = 200 + i;
      const cv::Mat r = dentar::ar::render_board_view(tex, kr, rig_truth().inverse() * poses[i], o);
      char name[32];
      std::snprintf(name, sizeof name, "cap%02d.png", i);
      cv::imwrite((d / "left" / name).string(), l);
      cv::imwrite((d / "right" / name).string(), r);
      cv::Mat s;
      cv::hconcat(l, r, s);
      cv::imwrite((d / "sbs" / name).string(), s);
    }
    return d;
}
const fs::path& photos() {
  static const fs::path dir = render_photos("chessboard:9x6:25", "chess");
  return dir;
}

nlohmann::json load(const fs::path& p) { return nlohmann::json::parse(dentar::test::read_file(p)); }

void expect_rig(const fs::path& station, const std::string& out) {
  ASSERT_TRUE(fs::exists(station)) << out;
  const auto j = load(station);
  ASSERT_TRUE(j.contains("stereo")) << j.dump();
  const auto& T = j["stereo"]["T_left_right"];
  std::printf("T_left_right in the file: %s\n", T.dump().c_str());
  const auto& rj = j["stereo"]["camera_right"];
  EXPECT_NEAR(rj["fx"].get<double>(), 628, 4);
  const nlohmann::json* rep = nullptr;
  for (const auto& r : j["calibration_report"])
    if (r["step"] == "stereo") rep = &r;
  ASSERT_NE(rep, nullptr);
  const auto& f = (*rep)["figures"];
  const double b = f["baseline_mm"].get<double>(), sd = f["baseline_sd_mm"].get<double>();
  EXPECT_GT(sd, 0);
  EXPECT_NEAR(b, rig_truth().translation().norm() * 1e3, std::max(3.5 * sd, 0.05)) << out;
  EXPECT_NEAR(b, rig_truth().translation().norm() * 1e3, 0.5) << out;
}

TEST(CliCalibrateStereoLong, FoldersPerEyeAndSideBySidePhotosGiveTheRig) {
  const fs::path& d = photos();
  const fs::path st = dentar::test::temp_dir("stereo_cli") / "station.json";
  auto r = dentar::test::run_dentar("calibrate stereo --left " + (d / "left").string() + " --right " +
                                    (d / "right").string() + " --board chessboard:9x6:25 --station " + st.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("T_left_right"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("trusted to"), std::string::npos) << r.out;  // each eye's trust map
  expect_rig(st, r.out);

  const fs::path st2 = dentar::test::temp_dir("stereo_cli_sbs") / "station.json";
  r = dentar::test::run_dentar("calibrate stereo --images " + (d / "sbs").string() +
                               " --board chessboard:9x6:25 --station " + st2.string());
  ASSERT_EQ(r.code, 0) << r.out;
  expect_rig(st2, r.out);
}

// Kalibr's AprilGrid (our detector): folders per eye.
TEST(CliCalibrateStereoLong, KalibrAprilGridGivesTheRig) {
  const fs::path d = render_photos("kalibr:6x5:24:0.3", "kalibr");
  const fs::path st = dentar::test::temp_dir("stereo_cli_kalibr") / "station.json";
  auto r = dentar::test::run_dentar("calibrate stereo --left " + (d / "left").string() + " --right " +
                                    (d / "right").string() + " --board kalibr:6x5:24:0.3 --station " + st.string());
  ASSERT_EQ(r.code, 0) << r.out;
  expect_rig(st, r.out);
}

// ChArUco (issue 28 session 15): folders per eye.
TEST(CliCalibrateStereoLong, CharucoGivesTheRig) {
  const fs::path d = render_photos("charuco:9x7:20:15:DICT_4X4_50", "charuco");
  const fs::path st = dentar::test::temp_dir("stereo_cli_charuco") / "station.json";
  auto r = dentar::test::run_dentar("calibrate stereo --left " + (d / "left").string() + " --right " +
                                    (d / "right").string() + " --board charuco:9x7:20:15:DICT_4X4_50 --station " +
                                    st.string());
  ASSERT_EQ(r.code, 0) << r.out;
  expect_rig(st, r.out);
}

// Live stereo (`--live`): the two eyes as recorded frame folders (30 fps, read in step by
// ar::StereoSource, paired by time), a board held still at 10 places for half a second each and
// moved between them in 0.1 s; the captures are taken by themselves. ChArUco board.
TEST(CliCalibrateStereoLong, LiveEyesTakeCapturesByThemselves) {
  const std::string board = "charuco:9x7:20:15:DICT_4X4_50";
  const fs::path d = dentar::test::temp_dir("stereo_live_frames");
  fs::create_directories(d / "left");
  fs::create_directories(d / "right");
  auto spec = dentar::ar::parse_board_spec(board);
  ASSERT_TRUE(spec.ok());
  const auto tex = dentar::ar::make_board_texture(*spec, 3000);
  const cal::CameraIntrinsics kl = eye(620, 318, 242), kr = eye(628, 323, 237);
  const auto poses = cal::plan_board_poses(kl, dentar::ar::board_width_m(*spec), dentar::ar::board_height_m(*spec), 10, 7);
  int frame = 0;
  auto put = [&](const Eigen::Isometry3d& T, int copies, std::uint64_t seed) {
    dentar::ar::BoardRenderOptions o;
    o.supersample = 2;
    o.seed = seed;
    const cv::Mat l = dentar::ar::render_board_view(tex, kl, T, o);
    o.seed = seed + 7919;
    const cv::Mat r = dentar::ar::render_board_view(tex, kr, rig_truth().inverse() * T, o);
    char first[32];
    std::snprintf(first, sizeof first, "f%05d.png", frame);
    cv::imwrite((d / "left" / first).string(), l);
    cv::imwrite((d / "right" / first).string(), r);
    for (int k = 1; k < copies; ++k) {  // a still board: the same picture (linked, no disk)
      char name[32];
      std::snprintf(name, sizeof name, "f%05d.png", frame + k);
      fs::create_hard_link(d / "left" / first, d / "left" / name);
      fs::create_hard_link(d / "right" / first, d / "right" / name);
    }
    frame += copies;
  };
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (i > 0) {  // moving: 3 frames between the places
      const Eigen::Quaterniond a(poses[i - 1].linear()), b(poses[i].linear());
      for (int m = 1; m <= 3; ++m) {
        const double u = m / 4.0;
        Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
        T.linear() = a.slerp(u, b).toRotationMatrix();
        T.translation() = (1 - u) * poses[i - 1].translation() + u * poses[i].translation();
        put(T, 1, 5000 + 10 * i + static_cast<std::uint64_t>(m));
      }
    }
    put(poses[i], 15, 100 + i);
  }
  const fs::path st = d / "station.json";
  auto r = dentar::test::run_dentar("calibrate stereo --live --left " + (d / "left").string() + " --right " +
                                    (d / "right").string() + " --count 10 --board " + board + " --station " + st.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("capture 10/10"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("pairs"), std::string::npos) << r.out;  // the pairing's summary
  expect_rig(st, r.out);
}

// Live stereo with the right eye unplugged after 12 of 14 places (issue 28, session 16): the
// capture stops --stall-timeout after its last frame, naming it, and the captures taken before
// it are kept: enough here, so they give the rig, it is written (exit 0) and the output says it
// came from the captures before the stall. Motion JPEG stand-ins (live:FILE), ChArUco board.
TEST(CliCalibrateStereoLong, LiveEyeStoppedAfterEnoughCapturesStillGivesTheRig) {
  const std::string board = "charuco:9x7:20:15:DICT_4X4_50";
  const fs::path d = dentar::test::temp_dir("stereo_live_stall_rig");
  auto spec = dentar::ar::parse_board_spec(board);
  ASSERT_TRUE(spec.ok());
  const auto tex = dentar::ar::make_board_texture(*spec, 3000);
  const cal::CameraIntrinsics kl = eye(620, 318, 242), kr = eye(628, 323, 237);
  const auto poses = cal::plan_board_poses(kl, dentar::ar::board_width_m(*spec), dentar::ar::board_height_m(*spec), 14, 7);
  const int mjpg = cv::VideoWriter::fourcc('M', 'J', 'P', 'G');
  cv::VideoWriter L((d / "l.avi").string(), cv::CAP_FFMPEG, mjpg, 30, cv::Size(640, 480));
  cv::VideoWriter R((d / "r.avi").string(), cv::CAP_FFMPEG, mjpg, 30, cv::Size(640, 480));
  ASSERT_TRUE(L.isOpened() && R.isOpened());
  L.set(cv::VIDEOWRITER_PROP_QUALITY, 95);
  R.set(cv::VIDEOWRITER_PROP_QUALITY, 95);
  const cv::Mat blank(480, 640, CV_8UC3, cv::Scalar(120, 120, 120));
  for (std::size_t i = 0; i < poses.size(); ++i) {  // 1 s still, 0.1 s with the board away
    dentar::ar::BoardRenderOptions o;
    o.supersample = 2;
    o.seed = 100 + i;
    cv::Mat l, r;
    cv::cvtColor(dentar::ar::render_board_view(tex, kl, poses[i], o), l, cv::COLOR_GRAY2BGR);
    o.seed += 7919;
    cv::cvtColor(dentar::ar::render_board_view(tex, kr, rig_truth().inverse() * poses[i], o), r, cv::COLOR_GRAY2BGR);
    for (int f = 0; f < 30; ++f) L.write(l), R.write(r);
    for (int f = 0; f < 3; ++f) L.write(blank), R.write(blank);
  }
  L.release();
  R.release();
  const fs::path st = d / "station.json";
  auto r = dentar::test::run_dentar("calibrate stereo --live --left live:" + (d / "l.avi").string() + " --right live:" +
                                    (d / "r.avi").string() + " --count 20 --stall-timeout 1.5 --inject-stall-right " +
                                    std::to_string(33 * 12) + ":600 --board " + board + " --station " + st.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("the right eye (live:" + (d / "r.avi").string() + ") has delivered no frame for "),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("captures taken before it are kept and calibrated below"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("captures taken before the eye stopped"), std::string::npos) << r.out;
  expect_rig(st, r.out);
}

// --simulate: rendered captures of a seeded rig, the truth printed beside the estimate.
TEST(CliCalibrateStereoLong, SimulatedHeadPrintsItsErrorAgainstTruth) {
  const fs::path st = dentar::test::temp_dir("stereo_sim") / "station.json";
  auto r = dentar::test::run_dentar("calibrate stereo --simulate --seed 2 --station " + st.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const auto pos = r.out.find("simulation truth: baseline");
  ASSERT_NE(pos, std::string::npos) << r.out;
  double truth = 0, err = 0;
  ASSERT_EQ(std::sscanf(r.out.c_str() + pos, "simulation truth: baseline %lf mm", &truth), 1);
  const auto e = r.out.find(" mm, rotation ", pos);
  const auto b = r.out.find("baseline ", e);
  ASSERT_EQ(std::sscanf(r.out.c_str() + b, "baseline %lf mm", &err), 1) << r.out.substr(pos);
  EXPECT_NEAR(truth, 63, 1);
  EXPECT_LT(std::abs(err), 0.2) << r.out.substr(pos);
  EXPECT_TRUE(load(st).contains("stereo"));
}

// Real photographs: OpenCV's stereo sample (Debian opencv-doc; 13 pairs, 9x6 chessboard, the
// square's size not published: 10 mm assumed, so the baseline is in tenths of squares). Anchor:
// OpenCV's own stereo_calib sample on the same photographs gives |T| = 33.43 (squares x 10).
TEST(CliCalibrateStereoLong, OpenCvSampleStereoPhotographs) {
  const fs::path src = "/usr/share/doc/opencv-doc/examples/data";
  if (!fs::exists(src / "left01.jpg")) GTEST_SKIP() << "opencv-doc absent";
  const fs::path d = dentar::test::temp_dir("stereo_ocv");
  fs::create_directories(d / "left");
  fs::create_directories(d / "right");
  for (const auto& e : fs::directory_iterator(src)) {
    const std::string n = e.path().filename().string();
    if (n.size() == 10 && n.rfind("left", 0) == 0) fs::copy_file(e.path(), d / "left" / n);
    if (n.size() == 11 && n.rfind("right", 0) == 0) fs::copy_file(e.path(), d / "right" / n);
  }
  const fs::path st = d / "station.json";
  auto r = dentar::test::run_dentar("calibrate stereo --left " + (d / "left").string() + " --right " +
                                    (d / "right").string() + " --board chessboard:9x6:10 --station " + st.string());
  ASSERT_EQ(r.code, 0) << r.out;
  std::printf("%s\n", r.out.substr(r.out.find("stereo calibration:")).c_str());
  const auto j = load(st);
  double b = 0;
  for (const auto& rep : j["calibration_report"])
    if (rep["step"] == "stereo") b = rep["figures"]["baseline_mm"].get<double>();
  EXPECT_NEAR(b, 33.43, 0.5);
}

}  // namespace
