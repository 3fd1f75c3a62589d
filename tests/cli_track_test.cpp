// End-to-end: `dentar track` on `dentar synth` footage, its poses.jsonl
// checked against truth.jsonl; the live-camera path with the video standing
// in for the camera; --tags; bad inputs (missing file, corrupt video,
// calibration for another image size, bad arguments).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <vector>

#include "testutil.h"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using dentar::test::CommandResult;

using dentar::test::run_dentar;

std::vector<json> read_jsonl(const fs::path& p) {
  std::vector<json> out;
  std::ifstream in(p);
  std::string line;
  while (std::getline(in, line))
    if (!line.empty()) out.push_back(json::parse(line));
  return out;
}

Eigen::Isometry3d to_iso(const json& a) {
  Eigen::Matrix4d m;
  for (int i = 0; i < 16; ++i) m(i / 4, i % 4) = a.at(static_cast<std::size_t>(i)).get<double>();
  Eigen::Isometry3d T;
  T.matrix() = m;
  return T;
}

double rot_deg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear() * b.linear().transpose()).angle() * 180 / M_PI;
}
double trans_mm(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm() * 1e3;
}

constexpr int kFrames = 40;

// `dentar synth` output shared by the tests; empty path (and a reason) when
// the generator cannot run here (no EGL).
struct Synth {
  fs::path dir;
  std::string why;
};
const Synth& synth() {
  static const Synth s = [] {
    Synth r;
    const fs::path d = dentar::test::temp_dir("cli_track_synth");
    const CommandResult c = run_dentar("synth --preset standard --frames " + std::to_string(kFrames) +
                                " --seed 3 --out " + d.string());
    if (c.code != 0)
      r.why = "dentar synth failed (no headless EGL here?): " + c.out;
    else
      r.dir = d;
    return r;
  }();
  return s;
}

#define NEED_SYNTH()                                         \
  const Synth& S = synth();                                  \
  if (S.dir.empty()) {                                       \
    if (std::getenv("DENTAR_REQUIRE_GL")) FAIL() << S.why;   \
    GTEST_SKIP() << S.why;                                   \
  }

TEST(CliTrack, HelpHasSynopsisAndExample) {
  const CommandResult r = run_dentar("track --help");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("Synopsis"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("Example"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("--scale-calib"), std::string::npos) << r.out;
}

TEST(CliTrack, PosesMatchTheTruth) {
  NEED_SYNTH();
  const fs::path out = S.dir / "poses.jsonl";
  const std::string st = (S.dir / "station.json").string();
  const CommandResult r = run_dentar("track --input " + (S.dir / "video.mkv").string() + " --calib " +
                              st + " --layout " + st + " --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find(std::to_string(kFrames) + " frames"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("median"), std::string::npos) << r.out;
  const auto poses = read_jsonl(out);
  const auto truth = read_jsonl(S.dir / "truth.jsonl");
  ASSERT_EQ(poses.size(), static_cast<std::size_t>(kFrames));
  ASSERT_EQ(truth.size(), poses.size());
  double worst_t = 0, worst_r = 0, worst_f = 0;
  int tracking = 0, roi = 0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const json& p = poses[i];
    EXPECT_EQ(p.at("frame").get<int>(), static_cast<int>(i));
    EXPECT_NEAR(p.at("time_s").get<double>(), truth[i].at("time_s").get<double>(), 1e-3);
    EXPECT_EQ(p.at("dropped_before").get<int>(), 0);
    const json& m = p.at("bodies").at("mannequin");
    ASSERT_TRUE(p.at("bodies").contains("mirror"));
    const json& tm = p.at("timing_ms");
    for (const char* k : {"detect", "pose", "filter", "total"}) EXPECT_GE(tm.at(k).get<double>(), 0);
    EXPECT_GT(tm.at("total").get<double>(), 0);
    if (m.at("state") != "tracking") continue;
    ++tracking;
    roi += p.at("full_frame").get<bool>() ? 0 : 1;
    EXPECT_TRUE(m.at("measured").get<bool>());
    EXPECT_GE(m.at("tags_used").get<int>(), 3);
    EXPECT_LT(m.at("rms_px").get<double>(), 1.0);
    EXPECT_EQ(m.at("sigma_t_mm").size(), 3u);
    const Eigen::Isometry3d T_true = to_iso(truth[i].at("T_cam_man"));
    const Eigen::Isometry3d T_meas = to_iso(m.at("T_cam_body_measured"));
    const Eigen::Isometry3d T_filt = to_iso(m.at("T_cam_body"));
    worst_t = std::max(worst_t, trans_mm(T_meas, T_true));
    worst_r = std::max(worst_r, rot_deg(T_meas, T_true));
    worst_f = std::max(worst_f, trans_mm(T_filt, T_true));
  }
  std::printf("[ cli track ] %d/%d tracking (%d on regions); worst measured %.3f mm %.3f deg, "
              "worst filtered %.3f mm\n",
              tracking, kFrames, roi, worst_t, worst_r, worst_f);
  EXPECT_EQ(tracking, kFrames);
  EXPECT_GT(roi, kFrames / 2);
  EXPECT_LT(worst_t, 1.0);
  EXPECT_LT(worst_r, 0.5);
  EXPECT_LT(worst_f, 0.8);
}

// "works on a live camera path, tested with a video file standing in for the
// camera": the live reader paces the file in real time, stamps frames on the
// steady clock and counts what it had to drop.
TEST(CliTrack, LiveCameraPathWithAStandInVideo) {
  NEED_SYNTH();
  const fs::path out = S.dir / "live.jsonl";
  const std::string st = (S.dir / "station.json").string();
  const CommandResult r = run_dentar("track --input live:" + (S.dir / "video.mkv").string() +
                              " --calib " + st + " --layout " + st + " --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("live"), std::string::npos) << r.out;
  const auto poses = read_jsonl(out);
  ASSERT_FALSE(poses.empty());
  int dropped = 0, tracking = 0;
  double last = -1;
  for (const json& p : poses) {
    dropped += p.at("dropped_before").get<int>();
    EXPECT_GT(p.at("time_s").get<double>(), last);
    last = p.at("time_s").get<double>();
    tracking += p.at("bodies").at("mannequin").at("state") == "tracking" ? 1 : 0;
  }
  // Frames dropped after the last delivered one only show in the summary.
  const auto at = r.out.find(" frames, ");
  ASSERT_NE(at, std::string::npos) << r.out;
  const int total_dropped = std::stoi(r.out.substr(at + 9));
  EXPECT_GE(total_dropped, dropped);
  EXPECT_EQ(static_cast<int>(poses.size()) + total_dropped, kFrames) << r.out;
  EXPECT_GE(tracking, static_cast<int>(poses.size()) - 1);
}

TEST(CliTrack, TagsModeGivesEveryTagsPose) {
  NEED_SYNTH();
  const fs::path out = S.dir / "tags.jsonl";
  const CommandResult r =
      run_dentar("track --input " + (S.dir / "video.mkv").string() + " --calib " +
          (S.dir / "station.json").string() + " --tags --tag-size-mm 14 --decimate 1 " +
          "--max-frames 5 --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const auto lines = read_jsonl(out);
  const auto truth = read_jsonl(S.dir / "truth.jsonl");
  ASSERT_EQ(lines.size(), 5u);
  int checked = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    for (const json& t : lines[i].at("tags")) {
      // Its truth: the same id on the mannequin (mirror tags are 12 mm).
      for (const json& g : truth[i].at("tags")) {
        if (g.at("id") != t.at("id") || g.at("on") != "mannequin") continue;
        double worst_px = 0;
        for (int k = 0; k < 4; ++k)
          for (int a = 0; a < 2; ++a)
            worst_px = std::max(worst_px, std::abs(t.at("corners_px")[k][a].get<double>() -
                                                   g.at("corners_px")[k][a].get<double>()));
        EXPECT_LT(worst_px, 1.0) << "frame " << i << " tag " << t.at("id");
        ASSERT_TRUE(t.at("ok").get<bool>());
        EXPECT_LE(t.at("rms_px").get<double>(), t.at("alt_rms_px").get<double>());
        // The tag centre in the camera frame vs the truth corners' depth
        // scale: the tag's distance must be plausible (25-50 cm).
        const double z = to_iso(t.at("T_cam_tag")).translation().z();
        EXPECT_GT(z, 0.2);
        EXPECT_LT(z, 0.6);
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 10);
}

// Issue 24: --camera-response auto (the default) takes the station's measured response; a
// station without one tracks with no linear-light refit and says so in one line.
TEST(CliTrack, AutoResponseFromTheStationAndANoteWhenUnknown) {
  NEED_SYNTH();
  json st;
  std::ifstream(S.dir / "station.json") >> st;
  ASSERT_EQ(st["camera"]["response"]["kind"], "srgb");  // the generator's camera
  const fs::path known = S.dir / "station_known.json", unknown = S.dir / "station_unknown.json";
  std::ofstream(known) << st.dump(2);
  st["camera"].erase("response");
  std::ofstream(unknown) << st.dump(2);
  for (const fs::path& p : {known, unknown}) {
    const fs::path out = S.dir / ("auto_" + p.stem().string() + ".jsonl");
    const CommandResult r = run_dentar("track --input " + (S.dir / "video.mkv").string() + " --layout " +
                                p.string() + " --max-frames 3 --out " + out.string() + " 2>&1");
    ASSERT_EQ(r.code, 0) << r.out;
    const bool noted = r.out.find("camera response unknown") != std::string::npos;
    EXPECT_EQ(noted, p == unknown) << r.out;
    EXPECT_EQ(read_jsonl(out).size(), 3u);
  }
}

TEST(CliTrack, BadInputsGiveClearErrorsAndNoOutput) {
  const fs::path d = dentar::test::temp_dir("cli_track_bad");
  const fs::path out = d / "poses.jsonl";
  // Missing input.
  CommandResult r = run_dentar("track --input " + (d / "missing.mkv").string() +
                        " --out " + out.string() + " --calib " + (d / "nocal.yaml").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("nocal.yaml"), std::string::npos) << r.out;  // calibration read first
  r = run_dentar("track --input " + (d / "missing.mkv").string() + " --out " + out.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--calib"), std::string::npos) << r.out;
  // Bad arguments.
  r = run_dentar("track --input x.mkv --out o.jsonl --decimate 0");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("--decimate"), std::string::npos) << r.out;
  r = run_dentar("track --out o.jsonl");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("--input"), std::string::npos) << r.out;
  r = run_dentar("track --input x.mkv --out o.jsonl --family tag99");
  EXPECT_EQ(r.code, 2);
  EXPECT_FALSE(fs::exists(out));

  NEED_SYNTH();
  const std::string st = (S.dir / "station.json").string();
  r = run_dentar("track --input " + (d / "missing.mkv").string() + " --calib " + st + " --out " +
          out.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("missing.mkv"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("no such file"), std::string::npos) << r.out;

  // Corrupt videos: truncated, and with a garbled header.
  const std::string bytes = dentar::test::read_file(S.dir / "video.mkv");
  ASSERT_GT(bytes.size(), 10000u);
  dentar::test::write_file(d / "cut.mkv", bytes.substr(0, bytes.size() / 3));
  r = run_dentar("track --input " + (d / "cut.mkv").string() + " --calib " + st + " --out " +
          out.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("cut.mkv"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(out)) << "half-written output left behind";
  EXPECT_FALSE(fs::exists(out.string() + ".partial"));
  std::string garbled = bytes;
  for (std::size_t i = 0; i < 4096; ++i) garbled[i] = static_cast<char>((i * 131) % 256);
  dentar::test::write_file(d / "garbled.mkv", garbled);
  r = run_dentar("track --input " + (d / "garbled.mkv").string() + " --calib " + st + " --out " +
          out.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("garbled.mkv"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(out));

  // A calibration for another image size (OpenCV FileStorage YAML): refused,
  // or scaled with --scale-calib when the aspect ratio matches.
  auto write_yaml = [&](const fs::path& p, int w, int h, double s) {
    std::ostringstream y;
    y << "%YAML:1.0\n---\nimage_width: " << w << "\nimage_height: " << h
      << "\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ "
      << 600 * s << ", 0., " << (322.06 + 0.5) * s - 0.5 << ", 0., " << 600 * s << ", "
      << (238.06 + 0.5) * s - 0.5
      << ", 0., 0., 1. ]\ndistortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 5\n"
         "   dt: d\n   data: [ -0.12, 0.06, 0.0004, -0.0003, 0. ]\n";
    dentar::test::write_file(p, y.str());
  };
  write_yaml(d / "cam1280.yaml", 1280, 960, 2.0);
  const std::string video = (S.dir / "video.mkv").string();
  r = run_dentar("track --input " + video + " --calib " + (d / "cam1280.yaml").string() + " --layout " +
          st + " --out " + out.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("1280x960"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("640x480"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("--scale-calib"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(out));
  r = run_dentar("track --input " + video + " --calib " + (d / "cam1280.yaml").string() + " --layout " +
          st + " --scale-calib --max-frames 10 --out " + out.string());
  EXPECT_EQ(r.code, 0) << r.out;
  const auto scaled = read_jsonl(out);
  ASSERT_EQ(scaled.size(), 10u);
  const auto truth = read_jsonl(S.dir / "truth.jsonl");
  for (std::size_t i = 0; i < scaled.size(); ++i) {
    const json& m = scaled[i].at("bodies").at("mannequin");
    ASSERT_EQ(m.at("state"), "tracking") << i;
    EXPECT_LT(trans_mm(to_iso(m.at("T_cam_body_measured")), to_iso(truth[i].at("T_cam_man"))),
              1.0);
  }
  fs::remove(out);
  write_yaml(d / "cam_wide.yaml", 1280, 720, 2.0);
  r = run_dentar("track --input " + video + " --calib " + (d / "cam_wide.yaml").string() + " --layout " +
          st + " --scale-calib --out " + out.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("aspect"), std::string::npos) << r.out;
  r = run_dentar("track --input " + video + " --calib " + st + " --tags --out " + out.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--tag-size-mm"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(out));
}

// Issue 28: stereo footage (`dentar synth --stereo`, side by side) tracked
// from both eyes (`dentar track --stereo`): poses in the left eye's frame
// against truth.jsonl (the left eye's); bad stereo input is exit 2 with the
// reason: mono footage, a side-by-side frame of odd width, eyes of two sizes.
TEST(CliTrack, StereoSideBySideFootage) {
  const fs::path d = dentar::test::temp_dir("cli_track_stereo");
  CommandResult r = run_dentar("synth --preset mirror --stereo --baseline-mm 63 --frames 6 --seed 3 --out " +
                               (d / "st").string());
  if (r.code != 0) {
    if (std::getenv("DENTAR_REQUIRE_GL")) FAIL() << r.out;
    GTEST_SKIP() << "dentar synth failed (no headless EGL here?): " << r.out;
  }
  const json meta = json::parse(dentar::test::read_file(d / "st" / "synth.json"));
  EXPECT_EQ(meta.at("stereo").at("layout"), "side_by_side");
  EXPECT_NEAR(meta.at("stereo").at("baseline_mm").get<double>(), 63.0, 1e-9);
  const auto truth = read_jsonl(d / "st" / "truth.jsonl");
  const auto truth_r = read_jsonl(d / "st" / "truth_right.jsonl");
  ASSERT_EQ(truth.size(), 6u);
  ASSERT_EQ(truth_r.size(), 6u);
  EXPECT_TRUE(fs::exists(d / "st" / "masks_right" / "mask_000005.png"));
  const std::string st = (d / "st" / "station.json").string();
  const fs::path out = d / "poses.jsonl";
  r = run_dentar("track --input " + (d / "st" / "video.mkv").string() + " --layout " + st + " --stereo --out " +
                 out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("stereo side by side, baseline 63"), std::string::npos) << r.out;
  const auto poses = read_jsonl(out);
  ASSERT_EQ(poses.size(), 6u);
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const json& m = poses[i].at("bodies").at("mannequin");
    ASSERT_EQ(m.at("state"), "tracking") << i;
    EXPECT_EQ(m.at("views").get<int>(), 2) << i;
    EXPECT_LT(trans_mm(to_iso(m.at("T_cam_body_measured")), to_iso(truth[i].at("T_cam_man"))), 0.5) << i;
    // The right eye's truth is the left's seen from 63 mm to the right.
    const Eigen::Isometry3d Tl = to_iso(truth[i].at("T_cam_man")), Tr = to_iso(truth_r[i].at("T_cam_man"));
    EXPECT_NEAR((Tl.translation() - Tr.translation()).x(), 0.063, 1e-9);
  }
  fs::remove(out);  // the bad runs below must leave no poses file
  // dentar offline and live run one camera: stereo footage is refused naming stereo, not as a
  // size mismatch to scale away; a synth folder given as --footage names its video.
  r = run_dentar("offline --quiet --footage " + (d / "st").string() + " --station " + st + " --out " +
                 (d / "off1").string());
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("is a `dentar synth` folder: give its video"), std::string::npos) << r.out;
  r = run_dentar("offline --quiet --footage " + (d / "st" / "video.mkv").string() + " --station " + st + " --out " +
                 (d / "off2").string());
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("side-by-side stereo footage"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(d / "off2" / "composite.mkv"));
  r = run_dentar("live --camera live:" + (d / "st" / "video.mkv").string() + " --station " + st +
                 " --stylus replay:" + (d / "st" / "session.dlog").string() + " --frames 2");
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("delivers side-by-side stereo frames"), std::string::npos) << r.out;
  // Mono footage given as stereo: the station has no rig.
  r = run_dentar("synth --preset standard --frames 2 --seed 3 --png --out " + (d / "mono").string());
  ASSERT_EQ(r.code, 0) << r.out;
  r = run_dentar("track --input " + (d / "mono" / "frames").string() + " --layout " +
                 (d / "mono" / "station.json").string() + " --stereo --out " + out.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("no stereo rig"), std::string::npos) << r.out;
  // A side-by-side frame of odd width (one column cut off).
  fs::create_directories(d / "odd");
  const cv::Mat wide = cv::imread((d / "mono" / "frames" / "frame_000000.png").string());
  ASSERT_FALSE(wide.empty());
  cv::Mat sbs;
  cv::hconcat(wide, wide, sbs);
  ASSERT_TRUE(cv::imwrite((d / "odd" / "frame_000000.png").string(), sbs(cv::Rect(0, 0, sbs.cols - 1, sbs.rows))));
  r = run_dentar("track --input " + (d / "odd").string() + " --layout " + st + " --stereo --out " + out.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("even width"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("1279x480"), std::string::npos) << r.out;
  // Eyes of two sizes in the station: refused where it is read.
  json sj = json::parse(dentar::test::read_file(st));
  sj["stereo"]["camera_right"]["width"] = 320;
  sj["stereo"]["camera_right"]["height"] = 240;
  sj["stereo"]["camera_right"]["cx"] = 160;
  sj["stereo"]["camera_right"]["cy"] = 120;
  dentar::test::write_file(d / "sizes.json", sj.dump());
  r = run_dentar("track --input " + (d / "st" / "video.mkv").string() + " --layout " + (d / "sizes.json").string() +
                 " --stereo --out " + out.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("stereo.camera_right is 320x240"), std::string::npos) << r.out;
  r = run_dentar("synth --stereo --frames 2 --station " + (d / "sizes.json").string() + " --out " + (d / "x").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("stereo.camera_right is 320x240"), std::string::npos) << r.out;
  r = run_dentar("synth --stereo --baseline-mm 5 --frames 2 --out " + (d / "x").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("stereo_baseline_m"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
