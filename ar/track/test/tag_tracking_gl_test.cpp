// Tag detection + bundle PnP on the generator's `standard` footage against
// its exact ground truth (T_cam_man), and the mirror's tags when in view.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "dentar/ar/bundle_pose.h"
#include "dentar/ar/synth.h"
#include "dentar/ar/tag_detector.h"
#include "gl_test_context.h"

namespace dentar::ar {
namespace {

double rot_err_deg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear() * b.linear().transpose()).angle() * 180 / M_PI;
}

double trans_err_mm(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm() * 1e3;
}

struct Errors {
  double max_t_mm = 0, max_r_deg = 0, max_tooth_mm = 0, max_rms_px = 0;
  int frames = 0, tags = 0;
  int mirror_frames = 0;
  double max_mirror_t_mm = 0, max_mirror_r_deg = 0;
  double detect_ms = 0, pose_ms = 0;
};

// Runs detect + pose on `frames` frames of a preset; checks every frame
// gives a pose and returns the worst errors.
Errors track_footage(SynthPreset preset, int frames, double fps, double decimation) {
  Errors e;
  SynthOptions o = synth_preset(preset);
  o.frames = frames;
  o.fps = fps;
  o.seed = 21;
  o.bur_samples = 1000;
  auto g = SynthGenerator::create(default_station_scene(), o);
  EXPECT_TRUE(g.ok()) << (g.ok() ? "" : g.error());
  if (!g.ok()) return e;
  const StationScene& station = (*g)->station();  // camera as rendered
  const TagBundle man = mannequin_bundle(station);
  const TagBundle mirror = mirror_bundle(station);
  TagDetectorOptions dopt;
  dopt.families = {station.family};
  dopt.decimation = decimation;
  dopt.response = CameraResponse::kSrgb;  // the generator's video is sRGB-encoded (v2)
  auto det = TagDetector::create(dopt);
  EXPECT_TRUE(det.ok()) << (det.ok() ? "" : det.error());
  if (!det.ok()) return e;
  std::optional<Eigen::Isometry3d> prev;
  using Clock = std::chrono::steady_clock;
  for (int i = 0; i < frames; ++i) {
    SynthFrame f;
    const Status s = (*g)->next(f);
    EXPECT_TRUE(s.ok()) << s.error();
    if (!s.ok()) return e;
    cv::Mat gray;
    cv::cvtColor(f.image, gray, cv::COLOR_BGR2GRAY);
    const auto t0 = Clock::now();
    auto tags = det->detect(gray);
    const auto t1 = Clock::now();
    EXPECT_TRUE(tags.ok()) << tags.error();
    if (!tags.ok()) return e;
    const BundlePose p =
        estimate_bundle_pose(man, station.calibration.camera, *tags, BundlePoseOptions{}, prev);
    const auto t2 = Clock::now();
    EXPECT_TRUE(p.ok()) << "frame " << i << ": " << p.message;
    if (!p.ok()) continue;
    prev = p.T_cam_body;
    const Eigen::Isometry3d T_cam_tooth = p.T_cam_body * station.calibration.T_man_tooth;
    const double et = trans_err_mm(p.T_cam_body, f.truth.T_cam_man);
    const double er = rot_err_deg(p.T_cam_body, f.truth.T_cam_man);
    const double etooth = trans_err_mm(T_cam_tooth, f.truth.T_cam_tooth);
    std::printf(
        "[ track ] %s frame %d: %d tags, rms %.3f px, T_cam_man error %.3f mm %.4f deg, "
        "tooth %.3f mm (1-sigma t %.3f mm), detect %.2f ms, pose %.3f ms\n",
        synth_preset_name(preset), i, p.tags_used, p.rms_px, et, er, etooth,
        std::sqrt(p.covariance.bottomRightCorner<3, 3>().trace()) * 1e3,
        std::chrono::duration<double, std::milli>(t1 - t0).count(),
        std::chrono::duration<double, std::milli>(t2 - t1).count());
    e.max_t_mm = std::max(e.max_t_mm, et);
    e.max_r_deg = std::max(e.max_r_deg, er);
    e.max_tooth_mm = std::max(e.max_tooth_mm, etooth);
    e.max_rms_px = std::max(e.max_rms_px, p.rms_px);
    e.tags += p.tags_used;
    e.detect_ms += std::chrono::duration<double, std::milli>(t1 - t0).count();
    e.pose_ms += std::chrono::duration<double, std::milli>(t2 - t1).count();
    ++e.frames;
    // The mirror: only when a mirror tag is mostly visible and facing us.
    bool mirror_seen = false;
    for (const auto& t : f.truth.tags)
      mirror_seen = mirror_seen || (t.on_mirror && t.in_image && t.visible_fraction > 0.9 &&
                                    t.side_px > 15 && t.view_angle_rad < 1.2);
    const BundlePose pm = estimate_bundle_pose(mirror, station.calibration.camera, *tags);
    if (mirror_seen && pm.ok()) {
      const double mt = trans_err_mm(pm.T_cam_body, f.truth.T_cam_mtag);
      const double mr = rot_err_deg(pm.T_cam_body, f.truth.T_cam_mtag);
      std::printf("[ track ]   mirror: %d tag(s), rms %.3f px, T_cam_mtag error %.3f mm %.3f deg\n",
                  pm.tags_used, pm.rms_px, mt, mr);
      e.max_mirror_t_mm = std::max(e.max_mirror_t_mm, mt);
      e.max_mirror_r_deg = std::max(e.max_mirror_r_deg, mr);
      ++e.mirror_frames;
    }
  }
  return e;
}

TEST(TagTracking, StandardFootageMannequinPoseMatchesTruth) {
  DENTAR_GL_TEST_CONTEXT();
  const int n = 5;
  const Errors e = track_footage(SynthPreset::kStandard, n, 2.0, 1.0);
  std::printf(
      "[ track ] standard 640x480, decimation 1: %d frames, %.1f tags/frame, worst "
      "T_cam_man error %.3f mm %.4f deg, worst tooth error %.3f mm, worst rms %.3f px, "
      "mean detect %.2f ms, mean pose %.3f ms\n",
      e.frames, e.frames ? double(e.tags) / e.frames : 0.0, e.max_t_mm, e.max_r_deg, e.max_tooth_mm,
      e.max_rms_px, e.frames ? e.detect_ms / e.frames : 0.0, e.frames ? e.pose_ms / e.frames : 0.0);
  EXPECT_EQ(e.frames, n);
  EXPECT_LT(e.max_t_mm, 1.0);
  EXPECT_LT(e.max_r_deg, 0.5);
  EXPECT_LT(e.max_tooth_mm, 1.0);
  EXPECT_LT(e.max_rms_px, 1.0);
  if (e.mirror_frames > 0) {
    std::printf("[ track ] mirror in %d frames: worst T_cam_mtag error %.3f mm %.3f deg\n",
                e.mirror_frames, e.max_mirror_t_mm, e.max_mirror_r_deg);
    // One or two 12 mm tags: far weaker geometry than the head's bundle.
    EXPECT_LT(e.max_mirror_t_mm, 3.0);
    EXPECT_LT(e.max_mirror_r_deg, 3.0);
  }
}

// libapriltag's usual speed setting: quads found at half resolution, edges
// refined at full resolution. Must stay accurate.
TEST(TagTracking, StandardFootageAtDecimationTwo) {
  DENTAR_GL_TEST_CONTEXT();
  const int n = 5;
  const Errors e = track_footage(SynthPreset::kStandard, n, 2.0, 2.0);
  std::printf(
      "[ track ] standard 640x480, decimation 2: %d frames, %.1f tags/frame, worst "
      "T_cam_man error %.3f mm %.4f deg, worst tooth error %.3f mm, mean detect %.2f ms\n",
      e.frames, e.frames ? double(e.tags) / e.frames : 0.0, e.max_t_mm, e.max_r_deg, e.max_tooth_mm,
      e.frames ? e.detect_ms / e.frames : 0.0);
  EXPECT_EQ(e.frames, n);
  EXPECT_LT(e.max_t_mm, 1.0);
  EXPECT_LT(e.max_r_deg, 0.5);
}

}  // namespace
}  // namespace dentar::ar
