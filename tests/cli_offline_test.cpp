// `dentar offline` end to end, run as a tester would: on a short generated
// clip with ground truth, and on the built-in default. Checks the outputs'
// contents (video frames, CSV rows, summary figures, report plots), and that
// bad input gives a clear message and no complete-looking report.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <sstream>

#include "testutil.h"

namespace fs = std::filesystem;
using dentar::test::read_file;
using dentar::test::run_command;
using dentar::test::temp_dir;

namespace {

const std::string kDentar = DENTAR_BINARY;

// One short clip shared by the tests (generated once per process).
const fs::path& clip() {
  static const fs::path dir = [] {
    fs::path d = temp_dir("offline_clip");
    const auto r = run_command(kDentar + " synth --frames 30 --resolution 640x480 --out " + d.string());
    EXPECT_EQ(r.code, 0) << r.out;
    return d;
  }();
  return dir;
}

std::string offline_on(const fs::path& footage_dir, const fs::path& out, const std::string& extra = "") {
  return kDentar + " offline --quiet --footage " + (footage_dir / "video.mkv").string() + " --station " +
         (footage_dir / "station.json").string() + " --session " + (footage_dir / "session.dlog").string() +
         " --out " + out.string() + " " + extra;
}

std::vector<std::vector<std::string>> read_csv(const fs::path& p) {
  std::vector<std::vector<std::string>> rows;
  std::ifstream in(p);
  std::string line;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string c;
    while (std::getline(ss, c, ',')) cells.push_back(c);
    if (!line.empty() && line.back() == ',') cells.emplace_back();
    rows.push_back(cells);
  }
  return rows;
}

void expect_no_complete_report(const fs::path& out) {
  EXPECT_FALSE(fs::exists(out / "summary.json")) << "a failed run left summary.json";
  EXPECT_FALSE(fs::exists(out / "report.html")) << "a failed run left report.html";
  EXPECT_TRUE(fs::exists(out / "FAILED.txt"));
}

TEST(CliOffline, RunsTheWholePipelineOnAClipWithTruth) {
  const fs::path out = temp_dir("offline_run");
  // --mirror-sigma-mm 0: the mirror is drawn (and its error measured) in
  // every frame it is tracked, however uncertain.
  const auto r = run_command(offline_on(clip(), out, "--mirror-sigma-mm 0"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("wrote"), std::string::npos) << r.out;

  // Summary: complete, every frame, errors within the trainer's bounds.
  const auto js = nlohmann::json::parse(read_file(out / "summary.json"));
  EXPECT_TRUE(js["complete"].get<bool>());
  EXPECT_EQ(js["frames"].get<int>(), 30);
  EXPECT_TRUE(js["has_truth"].get<bool>());
  EXPECT_GE(js["states"]["tracking"].get<int>(), 28) << js.dump(1);
  EXPECT_LT(js["errors"]["man_mm"]["p95"].get<double>(), 1.0);
  EXPECT_LT(js["errors"]["man_deg"]["p95"].get<double>(), 0.3);
  EXPECT_LT(js["errors"]["tooth_px"]["median"].get<double>(), 1.0);
  EXPECT_LT(js["errors"]["tip_mm"]["median"].get<double>(), 1.0);
  EXPECT_GT(js["errors"]["silhouette_iou"]["median"].get<double>(), 0.85);
  // The mirror is in the mouth for the whole clip (standard: the first
  // 4.8 s of every 8 s): its pose error is measured where testers look.
  ASSERT_TRUE(js["errors"]["mir_mm"]["p95"].is_number()) << js["errors"].dump(1);
  EXPECT_GE(js["errors"]["mir_mm"]["n"].get<int>(), 20);
  EXPECT_EQ(js["errors"]["mir_mm"]["n"].get<int>(), js["errors"]["mir_deg"]["n"].get<int>());
  EXPECT_GT(js["errors"]["mir_mm"]["median"].get<double>(), 0.0);
  EXPECT_LT(js["errors"]["mir_mm"]["p95"].get<double>(), 8.0);
  EXPECT_LT(js["errors"]["mir_deg"]["p95"].get<double>(), 3.0);
  // The haptic replay ran every step not after the last frame's time
  // (29/30 s = 966.7 ms: steps 0..966), the whole session log.
  EXPECT_EQ(js["haptic_steps"].get<int>(), 966 + 1);
  EXPECT_TRUE(js["warnings"].empty()) << js["warnings"].dump();
  EXPECT_GT(js["stage_ms"]["composite"]["median"].get<double>(), 0.0);
  EXPECT_GE(js["latency_ms"]["p99"].get<double>(), js["latency_ms"]["median"].get<double>());

  // CSV: a header and one row per frame, frame numbers in order, same width.
  const auto rows = read_csv(out / "frames.csv");
  ASSERT_EQ(rows.size(), 31u);
  const auto& head = rows[0];
  EXPECT_EQ(head[0], "frame");
  const auto col = [&](const std::string& name) {
    const auto it = std::find(head.begin(), head.end(), name);
    EXPECT_NE(it, head.end()) << name;
    return static_cast<std::size_t>(it - head.begin());
  };
  const std::size_t c_state = col("man_state"), c_err = col("man_err_mm"), c_lat = col("latency_ms"),
                    c_tz = col("man_tz_mm"), c_mstate = col("mirror_state"), c_merr = col("mir_err_mm"),
                    c_mdeg = col("mir_err_deg");
  for (std::size_t i = 1; i < rows.size(); ++i) {
    ASSERT_EQ(rows[i].size(), head.size()) << "row " << i;
    EXPECT_EQ(std::stoi(rows[i][0]), static_cast<int>(i - 1));
    if (rows[i][c_state] == "tracking") {
      const double tz = std::stod(rows[i][c_tz]);
      EXPECT_GT(tz, 250.0);  // the camera is 28-42 cm from the mouth
      EXPECT_LT(tz, 450.0);
      EXPECT_LT(std::stod(rows[i][c_err]), 2.0);
    }
    // Mirror error cells are filled exactly when the mirror has a pose.
    EXPECT_EQ(rows[i][c_mstate] != "lost", !rows[i][c_merr].empty()) << "row " << i;
    EXPECT_EQ(rows[i][c_merr].empty(), rows[i][c_mdeg].empty()) << "row " << i;
    EXPECT_GT(std::stod(rows[i][c_lat]), 0.0);
  }

  // Video: every frame, the camera's size; the overlay changes the image
  // where the tooth is and (almost) nowhere else.
  cv::VideoCapture comp((out / "composite.mkv").string()), orig((clip() / "video.mkv").string());
  ASSERT_TRUE(comp.isOpened());
  int frames = 0;
  cv::Mat a, b;
  while (comp.read(a) && orig.read(b)) {
    ASSERT_EQ(a.size(), cv::Size(640, 480));
    char name[40];
    std::snprintf(name, sizeof name, "masks/mask_%06d.png", frames);
    const cv::Mat mask = cv::imread((clip() / name).string(), cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(mask.empty());
    cv::Mat diff;
    cv::absdiff(a, b, diff);
    cv::cvtColor(diff, diff, cv::COLOR_BGR2GRAY);
    const cv::Mat changed = diff > 20;
    const int visible = cv::countNonZero(mask == 64);
    if (visible > 200) {
      EXPECT_GT(cv::countNonZero(changed & (mask == 64)), visible / 2) << "frame " << frames;
    }
    ++frames;
  }
  EXPECT_EQ(frames, 30);

  // Report: the plots a tester reads, and the stills it links.
  const std::string html = read_file(out / "report.html");
  for (const char* s : {"Mannequin pose error against time", "Mirror pose error against time",
                        "mirror plane pose, translation", "Removed volume per material",
                        "capture-to-composite latency", "compositing", "<svg"})
    EXPECT_NE(html.find(s), std::string::npos) << s;
  int svgs = 0;
  for (std::size_t p = html.find("<svg"); p != std::string::npos; p = html.find("<svg", p + 1)) ++svgs;
  EXPECT_GE(svgs, 10);
  EXPECT_GE(std::distance(fs::directory_iterator(out / "stills"), fs::directory_iterator{}), 1);
}

TEST(CliOffline, BuiltInDefaultNeedsNoInput) {
  const fs::path out = temp_dir("offline_builtin");
  const auto r = run_command(kDentar + " offline --quiet --frames 12 --resolution 640x480 --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::exists(out / "footage" / "video.mkv"));
  const auto js = nlohmann::json::parse(read_file(out / "summary.json"));
  EXPECT_EQ(js["frames"].get<int>(), 12);
  EXPECT_TRUE(js["has_truth"].get<bool>());
  EXPECT_GT(js["overlays"].get<int>(), 6);
  EXPECT_TRUE(fs::exists(out / "report.html"));
}

TEST(CliOffline, FootageShorterThanTheSessionIsRefused) {
  const fs::path shortclip = temp_dir("offline_short_clip");
  ASSERT_EQ(run_command(kDentar + " synth --frames 8 --resolution 640x480 --out " + shortclip.string()).code, 0);
  const fs::path out = temp_dir("offline_short");
  const auto r = run_command(kDentar + " offline --quiet --footage " + (shortclip / "video.mkv").string() +
                             " --station " + (shortclip / "station.json").string() + " --session " +
                             (clip() / "session.dlog").string() + " --out " + out.string());
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("shorter than the session log"), std::string::npos) << r.out;
  expect_no_complete_report(out);
}

TEST(CliOffline, StationForAnotherCameraIsRefusedAndAnOldReportRemoved) {
  const fs::path big = temp_dir("offline_720p_station");
  ASSERT_EQ(run_command(kDentar + " synth --frames 2 --resolution 1280x720 --out " + big.string()).code, 0);
  const fs::path out = temp_dir("offline_wrong_station");
  // A good run first: its report must not survive a failed run into the same folder.
  ASSERT_EQ(run_command(offline_on(clip(), out, "--max-frames 3 --no-video")).code, 0);
  ASSERT_TRUE(fs::exists(out / "report.html"));
  const auto r = run_command(kDentar + " offline --quiet --footage " + (clip() / "video.mkv").string() +
                             " --station " + (big / "station.json").string() + " --out " + out.string());
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("640x480"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("1280x720"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("--scale-calib"), std::string::npos) << r.out;
  expect_no_complete_report(out);
}

TEST(CliOffline, EmptyOrMissingFootageGivesAClearError) {
  const fs::path dir = temp_dir("offline_empty");
  dentar::test::write_file(dir / "empty.mkv", "");
  const fs::path out = dir / "out";
  auto r = run_command(kDentar + " offline --quiet --footage " + (dir / "empty.mkv").string() + " --station " +
                       (clip() / "station.json").string() + " --out " + out.string());
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("empty.mkv"), std::string::npos) << r.out;
  expect_no_complete_report(out);

  fs::create_directories(dir / "no_frames");
  r = run_command(kDentar + " offline --quiet --footage " + (dir / "no_frames").string() + " --station " +
                  (clip() / "station.json").string() + " --out " + out.string());
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("no_frames"), std::string::npos) << r.out;

  r = run_command(kDentar + " offline --footage " + (dir / "nothing.mkv").string() + " --station x.json --out " +
                  out.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("nothing.mkv"), std::string::npos) << r.out;
  r = run_command(kDentar + " offline --footage " + (clip() / "video.mkv").string() + " --out " + out.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("--station"), std::string::npos) << r.out;
  r = run_command(offline_on(clip(), out, "--camera-response gamma22"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("--camera-response"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("gamma22"), std::string::npos) << r.out;
  r = run_command(offline_on(clip(), out, "--stereo-mirror-rim maybe"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("--stereo-mirror-rim"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("maybe"), std::string::npos) << r.out;
}

// A live recording's recording.json says how the live run tracked
// (camera_response, mirror_rim); bad values are refused naming the file, the
// field and the value, before any frame is read.
TEST(CliOffline, RecordingWithBadTrackingFieldsIsRefused) {
  const fs::path dir = temp_dir("offline_bad_recording");
  const fs::path out = dir / "out";
  fs::create_directories(dir / "rec");
  auto run_with = [&](const std::string& fields) {
    dentar::test::write_file(dir / "rec" / "recording.json",
                             R"({"format": "dentar-recording", "version": 1, "discovery": "inline", )" + fields + "}");
    return run_command(kDentar + " offline --quiet --footage " + (dir / "rec").string() + " --out " + out.string());
  };
  auto r = run_with(R"("camera_response": "gamma22")");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("recording.json"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("camera_response"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("gamma22"), std::string::npos) << r.out;
  r = run_with(R"("camera_response": 1)");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("camera_response must be"), std::string::npos) << r.out;
  r = run_with(R"("camera_response": "linear", "mirror_rim": "yes")");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("mirror_rim must be true or false"), std::string::npos) << r.out;
  r = run_with(R"("stereo_mirror_rim": "on")");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("stereo_mirror_rim must be true or false"), std::string::npos) << r.out;
  expect_no_complete_report(out);
}

}  // namespace
