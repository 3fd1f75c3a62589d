// The footage generator on llvmpipe: determinism, ground truth against
// libapriltag detections, the occlusion mask against the tooth renderer,
// the presets' properties, and `dentar synth` end to end.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "dentar/ar/apriltags.h"
#include "dentar/ar/tag_detector.h"
#include "dentar/ar/synth.h"
#include "dentar/haptics/session_log.h"
#include "gl_test_context.h"
#include "testutil.h"

#include "tag_test_util.h"

namespace dentar::ar {
namespace {

using test::detect_full_resolution;

std::unique_ptr<SynthGenerator> make(const SynthOptions& o, const std::string& log = {}) {
  auto g = SynthGenerator::create(default_station_scene(), o, log);
  EXPECT_TRUE(g.ok()) << (g.ok() ? "" : g.error());
  return g.ok() ? std::move(g).value() : nullptr;
}

SynthOptions small(SynthPreset p, int frames, double fps) {
  SynthOptions o = synth_preset(p);
  o.frames = frames;
  o.fps = fps;
  o.seed = 11;
  o.bur_samples = 1000;
  return o;
}

TEST(Synth, SameSeedGivesIdenticalFrames) {
  DENTAR_GL_TEST_CONTEXT();
  // 1 fps: 1000 engine steps between frames, so a writer that cuts blocks by
  // wall time cuts them mid-batch at different places in the two runs.
  SynthOptions o = small(SynthPreset::kStandard, 3, 1);
  std::vector<SynthFrame> a(3), b(3);
  const auto dir = dentar::test::temp_dir("same_seed");
  {
    auto g = make(o, (dir / "a.dlog").string());
    ASSERT_TRUE(g);
    for (auto& f : a) ASSERT_TRUE(g->next(f).ok());
  }
  {
    auto g = make(o, (dir / "b.dlog").string());
    ASSERT_TRUE(g);
    for (auto& f : b) ASSERT_TRUE(g->next(f).ok());
  }
  // The session logs too, byte for byte (blocks were once cut by wall time).
  const std::string la = dentar::test::read_file(dir / "a.dlog"), lb = dentar::test::read_file(dir / "b.dlog");
  EXPECT_GT(la.size(), 1000u);
  EXPECT_TRUE(la == lb) << "session logs differ: " << la.size() << " vs " << lb.size() << " bytes";
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(cv::norm(a[i].image, b[i].image, cv::NORM_INF), 0.0) << "frame " << i;
    EXPECT_EQ(cv::norm(a[i].mask, b[i].mask, cv::NORM_INF), 0.0) << "frame " << i;
    EXPECT_EQ(frame_truth_json(a[i].truth), frame_truth_json(b[i].truth)) << "frame " << i;
  }
  o.seed = 12;
  auto g = make(o);
  ASSERT_TRUE(g);
  SynthFrame c;
  ASSERT_TRUE(g->next(c).ok());
  EXPECT_GT(cv::norm(a[0].image, c.image, cv::NORM_L1), 0.0) << "another seed, another path";
}

// Standard footage: every tag libapriltag finds is a ground-truth tag, and
// its corners (shifted to OpenCV's convention) are within 1 px of the truth.
TEST(Synth, TagCornersMatchLibapriltagWithinOnePixel) {
  DENTAR_GL_TEST_CONTEXT();
  auto g = make(small(SynthPreset::kStandard, 4, 1.5));  // frames 0.67 s apart
  ASSERT_TRUE(g);
  int matched = 0;
  double worst = 0;
  for (int i = 0; i < 4; ++i) {
    SynthFrame f;
    ASSERT_TRUE(g->next(f).ok());
    cv::Mat gray;
    cv::cvtColor(f.image, gray, cv::COLOR_BGR2GRAY);
    std::map<int, const TagTruth*> truth;
    for (const auto& t : f.truth.tags) truth[t.id] = &t;
    int in_frame = 0;
    for (const auto& d : detect_full_resolution(gray, TagFamilyId::kStandard41h12)) {
      auto it = truth.find(d.id);
      ASSERT_NE(it, truth.end()) << "frame " << i << ": detected tag " << d.id
                                 << " is not in the truth";
      for (int k = 0; k < 4; ++k) {
        const double e = (d.corners_px[k] - it->second->corners_px[k]).norm();
        worst = std::max(worst, e);
        EXPECT_LT(e, 1.0) << "frame " << i << " tag " << d.id << " corner " << k;
      }
      ++in_frame;
    }
    // Most of the 8-12 visible head tags are found.
    EXPECT_GE(in_frame, 6) << "frame " << i;
    matched += in_frame;
  }
  std::printf("[ synth ] %d tag detections, worst corner error %.3f px\n", matched, worst);
}

// The mask's tooth silhouette is exactly what the tooth renderer draws at
// T_cam_tooth; the mask holds only the documented values.
TEST(Synth, MaskIsTheToothSilhouetteSplitByOccluders) {
  DENTAR_GL_TEST_CONTEXT();
  auto g = make(small(SynthPreset::kStandard, 2, 10));
  ASSERT_TRUE(g);
  for (int i = 0; i < 2; ++i) {
    SynthFrame f;
    ASSERT_TRUE(g->next(f).ok());
    auto sil = g->render_tooth_silhouette(f.truth.T_cam_tooth);
    ASSERT_TRUE(sil.ok()) << sil.error();
    cv::Mat in_mask = f.mask > 0;
    EXPECT_EQ(cv::countNonZero(in_mask != *sil), 0) << "frame " << i;
    EXPECT_EQ(cv::countNonZero(in_mask), f.truth.tooth_px);
    EXPECT_GT(f.truth.tooth_px, 100);
    int counts[256] = {};
    for (int v = 0; v < f.mask.rows; ++v)
      for (int u = 0; u < f.mask.cols; ++u) ++counts[f.mask.at<std::uint8_t>(v, u)];
    for (int k = 0; k < 256; ++k) {
      if (k != kMaskOutside && k != kMaskToothVisible && k != kMaskMannequin &&
          k != kMaskForeground) {
        EXPECT_EQ(counts[k], 0) << "value " << k;
      }
    }
    EXPECT_EQ(counts[kMaskMannequin] + counts[kMaskForeground], f.truth.tooth_hidden_px);
    // Roots are under the gum and the crown shows through the open mouth.
    EXPECT_GT(counts[kMaskToothVisible], 0) << "frame " << i;
    EXPECT_GT(counts[kMaskMannequin], 0) << "frame " << i;
  }
}

TEST(Synth, HardPresetHasSmallAndGrazingTags) {
  DENTAR_GL_TEST_CONTEXT();
  SynthOptions o = small(SynthPreset::kHard, 12, 4);
  o.blur_subframes = 3;  // keep CI quick; the default is 5
  EXPECT_TRUE(o.motion_blur);
  EXPECT_GT(o.tag_occluders, 0);
  auto g = make(o);
  ASSERT_TRUE(g);
  int small_tags = 0, grazing = 0, occluded = 0, most_subframes = 0;
  for (int i = 0; i < o.frames; ++i) {
    SynthFrame f;
    ASSERT_TRUE(g->next(f).ok());
    // Sub-frames follow the motion (issue 28 session 20): odd, within [blur_subframes, max].
    EXPECT_EQ(f.truth.blur_subframes % 2, 1);
    EXPECT_GE(f.truth.blur_subframes, o.blur_subframes);
    EXPECT_LE(f.truth.blur_subframes, o.blur_subframes_max);
    most_subframes = std::max(most_subframes, f.truth.blur_subframes);
    for (const auto& t : f.truth.tags) {
      if (t.on_mirror) continue;
      small_tags += t.side_px < 20 ? 1 : 0;
      grazing += t.view_angle_rad >= 70 * M_PI / 180 && t.visible_fraction > 0.5 ? 1 : 0;
      occluded += t.visible_fraction < 0.8 && t.view_angle_rad < 60 * M_PI / 180 ? 1 : 0;
    }
  }
  std::printf("[ synth ] hard: %d tags < 20 px, %d at >= 70 deg, %d occluded; most sub-frames %d\n", small_tags,
              grazing, occluded, most_subframes);
  EXPECT_GT(small_tags, 0);
  EXPECT_GT(grazing, 0);
  EXPECT_GT(occluded, 0);
}

TEST(Synth, MirrorPresetKeepsTheMirrorInView) {
  DENTAR_GL_TEST_CONTEXT();
  auto g = make(small(SynthPreset::kMirror, 10, 3));
  ASSERT_TRUE(g);
  int in_view = 0, tag_seen = 0;
  for (int i = 0; i < 10; ++i) {
    SynthFrame f;
    ASSERT_TRUE(g->next(f).ok());
    in_view += f.truth.mirror_in_view ? 1 : 0;
    for (const auto& t : f.truth.tags) tag_seen += t.on_mirror && t.visible_fraction > 0.5 ? 1 : 0;
  }
  EXPECT_GE(in_view, 8);
  EXPECT_GE(tag_seen, 5);
}

TEST(Synth, OptionErrorsNameTheOption) {
  DENTAR_GL_TEST_CONTEXT();
  SynthOptions o;
  o.frames = 0;
  auto g = SynthGenerator::create(default_station_scene(), o);
  ASSERT_FALSE(g.ok());
  EXPECT_NE(g.error().find("frames"), std::string::npos) << g.error();
  o = SynthOptions{};
  o.blur_subframes = 4;
  g = SynthGenerator::create(default_station_scene(), o);
  ASSERT_FALSE(g.ok());
  EXPECT_NE(g.error().find("subframes"), std::string::npos) << g.error();
  o = SynthOptions{};
  o.blur_step_px = 0.1;
  g = SynthGenerator::create(default_station_scene(), o);
  ASSERT_FALSE(g.ok());
  EXPECT_NE(g.error().find("blur step"), std::string::npos) << g.error();
  o = SynthOptions{};
  o.blur_subframes_max = 3;  // below blur_subframes (5)
  g = SynthGenerator::create(default_station_scene(), o);
  ASSERT_FALSE(g.ok());
  EXPECT_NE(g.error().find("subframes max"), std::string::npos) << g.error();
}

// ---- the command line ------------------------------------------------------------

using CmdResult = dentar::test::CommandResult;

CmdResult run(const std::string& args) {
  return dentar::test::run_command(std::string(DENTAR_BINARY) + " " + args);
}

TEST(SynthCli, WritesEveryOutput) {
  DENTAR_GL_TEST_CONTEXT();
  namespace fs = std::filesystem;
  const fs::path dir = dentar::test::temp_dir("synth_cli");
  const CmdResult r =
      run("synth --preset standard --frames 3 --fps 30 --seed 5 --out " + dir.string());
  ASSERT_EQ(r.code, 0) << r.out;
  cv::VideoCapture cap((dir / "video.mkv").string());
  ASSERT_TRUE(cap.isOpened());
  cv::Mat frame;
  int frames = 0;
  while (cap.read(frame)) {
    EXPECT_EQ(frame.cols, 640);
    EXPECT_EQ(frame.rows, 480);
    ++frames;
  }
  EXPECT_EQ(frames, 3);
  std::ifstream truth(dir / "truth.jsonl");
  std::string line;
  int lines = 0;
  while (std::getline(truth, line)) {
    const auto j = nlohmann::json::parse(line);
    EXPECT_EQ(j.at("frame").get<int>(), lines);
    EXPECT_EQ(j.at("T_cam_man").size(), 16u);
    EXPECT_EQ(j.at("T_cam_mtag").size(), 16u);
    EXPECT_EQ(j.at("T_cam_tip").size(), 16u);
    EXPECT_GE(j.at("tags").size(), 8u);
    ++lines;
  }
  EXPECT_EQ(lines, 3);
  for (int i = 0; i < 3; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "mask_%06d.png", i);
    const cv::Mat m = cv::imread((dir / "masks" / name).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(m.empty()) << name;
    EXPECT_EQ(m.type(), CV_8UC1);
  }
  auto st = read_station_scene((dir / "station.json").string());
  ASSERT_TRUE(st.ok()) << st.error();
  auto log = haptics::read_session_log((dir / "session.dlog").string());
  ASSERT_TRUE(log.ok()) << log.error();
  EXPECT_EQ(log->warning, "");
  EXPECT_GE(log->records.size(), 67u);  // frame 2 at 66.7 ms: steps 0..66
  EXPECT_NE(log->header_json.find("dentar synth"), std::string::npos);
  EXPECT_TRUE(fs::exists(dir / "synth.json"));

  const CmdResult p = run("synth --frames 2 --png --no-distortion --out " + (dir / "png").string());
  ASSERT_EQ(p.code, 0) << p.out;
  EXPECT_TRUE(fs::exists(dir / "png" / "frames" / "frame_000001.png"));
  auto st2 = read_station_scene((dir / "png" / "station.json").string());
  ASSERT_TRUE(st2.ok());
  EXPECT_EQ(st2->calibration.camera.dist[0], 0.0);
  fs::remove_all(dir);
}

TEST(SynthCli, HelpAndBadArguments) {
  CmdResult r = run("synth --help");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("Synopsis"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("Example"), std::string::npos) << r.out;
  r = run("synth --resolution 800x600");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("--resolution"), std::string::npos) << r.out;
  r = run("synth --preset easy");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("--preset"), std::string::npos) << r.out;
  r = run("synth --frames 0");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("--frames"), std::string::npos) << r.out;
  r = run("synth --station /nonexistent/station.json");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("/nonexistent/station.json"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace dentar::ar
