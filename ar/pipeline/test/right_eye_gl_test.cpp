// Issue 28 (session 16): the frame pipeline composites the right eye of a stereo rig too.
// On generated stereo footage (StereoSynthGenerator: truth per eye), the right eye's
// overlay lands where that eye's truth says (the tooth's centre and silhouette in the right
// image), not where the left eye sees it; outside the overlay the composite is the right
// camera's own pixels; the note label follows the tooth into the right eye; a frame without
// its right eye gives no right composite (the display shows mono), and one camera never
// gives one.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <opencv2/core.hpp>

#include "dentar/ar/camera_model.h"
#include "dentar/ar/frame_pipeline.h"
#include "dentar/ar/synth.h"
#include "dentar/volume/procedural_tooth.h"
#include "gl_test_context.h"

namespace dentar::ar {
namespace {

constexpr int kFrames = 6;

struct StereoClip {
  std::unique_ptr<StereoSynthGenerator> gen;
  std::vector<StereoSynthFrame> frames;
};

// 640x480 per eye, the standard preset's scene and motion, a 63 mm rig.
const StereoClip& clip() {
  static StereoClip c = [] {
    StereoClip k;
    StationScene st = default_station_scene();
    st.stereo = make_stereo_rig(st.calibration.camera, 0.063);
    SynthOptions o = synth_preset(SynthPreset::kStandard);
    o.frames = kFrames;
    o.width = 640;
    o.height = 480;
    o.stereo = true;
    auto g = StereoSynthGenerator::create(st, o);
    EXPECT_TRUE(g.ok()) << g.error();
    if (!g.ok()) return k;
    k.gen = std::move(g).value();
    for (int i = 0; i < kFrames; ++i) {
      StereoSynthFrame f;
      EXPECT_TRUE(k.gen->next(f).ok());
      k.frames.push_back(f);
    }
    return k;
  }();
  return c;
}

volume::VoxelVolume molar(double voxel_m) {
  volume::MolarParams p;
  p.voxel_mm = voxel_m * 1e3;
  auto v = volume::make_molar(p);
  EXPECT_TRUE(v.ok()) << v.error();
  return std::move(v).value();
}

// The tooth frame's origin projected through an eye's camera (OpenCV px).
Eigen::Vector2d project_origin(const calibration::CameraIntrinsics& cam, const Eigen::Isometry3d& T_cam_tooth) {
  const auto p = CameraModel(cam).project(T_cam_tooth.translation());
  EXPECT_TRUE(p.has_value());
  return p ? *p : Eigen::Vector2d(-1e9, -1e9);
}

double iou(const cv::Mat& a, const cv::Mat& b) {
  const int i = cv::countNonZero(a & b), u = cv::countNonZero(a | b);
  return u > 0 ? static_cast<double>(i) / u : 0.0;
}

TEST(RightEyeGl, OverlayLandsOnTheRightEyesTruth) {
  DENTAR_GL_TEST_CONTEXT();
  const StereoClip& c = clip();
  ASSERT_TRUE(c.gen != nullptr);
  const StationScene& st = c.gen->station();
  const auto& cam_r = st.stereo.camera_right;
  auto vol = molar(st.tooth_voxel_m);
  ToothMeshes meshes(vol);
  PipelineOptions po;
  po.stereo = true;
  auto p = FramePipeline::create(st, po);
  ASSERT_TRUE(p.ok()) << p.error();
  const std::string note = "Keep the bur parallel to the long axis";
  haptics::HapticSnapshot snap{};
  int checked = 0;
  double worst_px = 0, worst_iou = 1;
  int mirror_left = 0, mirror_right = 0;  // frames whose reflection each eye drew
  for (int i = 0; i < kFrames; ++i) {
    const StereoSynthFrame& f = c.frames[static_cast<std::size_t>(i)];
    const Eigen::Matrix4d m = f.left.truth.T_dev_sty.matrix();
    for (int k = 0; k < 16; ++k) snap.T_dev_sty[k] = m(k % 4, k / 4);
    FrameInput in;
    in.image = &f.left.image;
    in.right_image = &f.right.image;
    in.index = i;
    in.capture_time_s = i / 30.0;
    in.haptic = &snap;
    in.stylus_valid = true;
    const bool with_note = i % 2 == 1;  // the label lies outside the overlay's region
    if (with_note) in.note = &note;
    CompositeResult out, right;
    FrameRecord r;
    const Status s = (*p)->process(in, meshes, out, r, &right);
    ASSERT_TRUE(s.ok()) << s.error();
    ASSERT_EQ(r.eyes, FrameRecord::kEyesBoth);
    ASSERT_TRUE(r.right.composited) << "frame " << i;
    ASSERT_EQ(right.image.size(), f.right.image.size());
    if (r.man_state == 2 || i < 2) continue;  // the filter's first frames
    ++checked;
    SCOPED_TRACE("frame " + std::to_string(i));
    EXPECT_TRUE(r.overlay);
    EXPECT_TRUE(r.right.overlay);
    mirror_left += r.mirror_drawn ? 1 : 0;
    mirror_right += r.right.mirror_drawn ? 1 : 0;
    // The tooth's centre as the right eye draws it, against that eye's truth; and far from
    // where the left eye's truth would put it in the right image (63 mm of disparity).
    const Eigen::Isometry3d T_camr_rig = st.stereo.T_caml_camr.inverse();
    const Eigen::Vector2d drawn = project_origin(cam_r, T_camr_rig * r.T_cam_man * st.calibration.T_man_tooth);
    const Eigen::Vector2d truth_r = project_origin(cam_r, f.right.truth.T_cam_tooth);
    const Eigen::Vector2d truth_l = project_origin(st.calibration.camera, f.left.truth.T_cam_tooth);
    EXPECT_LT((drawn - truth_r).norm(), 2.0) << "right eye: drawn " << drawn.transpose() << ", truth " << truth_r.transpose();
    EXPECT_GT((truth_r - truth_l).norm(), 20.0) << "the eyes' views of the tooth must differ for this test to mean anything";
    // The note's anchor is the tooth's centre in the right eye's image.
    if (with_note) {
      EXPECT_TRUE(r.right.note_drawn);
      EXPECT_LT((r.right.note_anchor_px - truth_r).norm(), 2.0);
    }
    // The drawn silhouette (after occlusion) against the right eye's visible tooth, and
    // against the left eye's (which it must not match).
    const cv::Mat drawn_px = right.tooth_visible > 127;
    const double iou_r = iou(drawn_px, f.right.mask == kMaskToothVisible);
    const double iou_l = iou(drawn_px, f.left.mask == kMaskToothVisible);
    EXPECT_GT(iou_r, 0.7) << "right eye silhouette";
    EXPECT_LT(iou_l, 0.3) << "the right composite must not be the left eye's view";
    worst_px = std::max(worst_px, (drawn - truth_r).norm());
    worst_iou = std::min(worst_iou, iou_r);
    // Outside the overlay's region (and without a note's label) the composite is the right
    // camera's own pixels; inside it the overlay changed them.
    ASSERT_GT(right.region.area(), 0);
    if (with_note) continue;
    cv::Mat outside = cv::Mat::ones(right.image.size(), CV_8U) * 255;
    outside(right.region).setTo(0);
    EXPECT_EQ(cv::norm(right.image, f.right.image, cv::NORM_INF, outside), 0.0);
    EXPECT_GT(cv::norm(right.image(right.region), f.right.image(right.region), cv::NORM_L1), 1000.0);
  }
  EXPECT_GE(checked, kFrames - 3);
  // The mirror's reflection is drawn for the right eye too (the standard preset's mirror is in
  // both eyes' view on these frames).
  EXPECT_GT(mirror_left, 0);
  EXPECT_EQ(mirror_right, mirror_left);
  std::printf("[ note ] right eye over %d frames: tooth centre within %.2f px of its truth, silhouette IoU >= %.3f; reflection "
              "drawn left %d, right %d\n",
              checked, worst_px, worst_iou, mirror_left, mirror_right);
}

// The right eye missing this frame: the single-view path, no right composite (mono on the
// display); a pipeline of one camera never makes one.
TEST(RightEyeGl, NoRightCompositeWithoutTheRightEye) {
  DENTAR_GL_TEST_CONTEXT();
  const StereoClip& c = clip();
  ASSERT_TRUE(c.gen != nullptr);
  const StationScene& st = c.gen->station();
  auto vol = molar(st.tooth_voxel_m);
  ToothMeshes meshes(vol);
  PipelineOptions po;
  po.stereo = true;
  auto p = FramePipeline::create(st, po);
  ASSERT_TRUE(p.ok()) << p.error();
  const cv::Mat none;
  for (int i = 0; i < 4; ++i) {
    const StereoSynthFrame& f = c.frames[static_cast<std::size_t>(i)];
    FrameInput in;
    in.image = &f.left.image;
    in.right_image = i == 3 ? &none : &f.right.image;
    in.index = i;
    in.capture_time_s = i / 30.0;
    CompositeResult out, right;
    FrameRecord r;
    ASSERT_TRUE((*p)->process(in, meshes, out, r, &right).ok());
    if (i < 3) {
      EXPECT_TRUE(r.right.composited);
      EXPECT_FALSE(right.image.empty());
    } else {
      EXPECT_EQ(r.eyes, FrameRecord::kEyesLeft);
      EXPECT_FALSE(r.right.composited);
      EXPECT_TRUE(right.image.empty()) << "a right composite left over from the frame before";
      EXPECT_EQ(out.image.size(), f.left.image.size());
    }
  }
  // One camera: a right output given is left empty.
  auto mono = FramePipeline::create(st, PipelineOptions{});
  ASSERT_TRUE(mono.ok()) << mono.error();
  FrameInput in;
  in.image = &c.frames[0].left.image;
  in.right_image = &c.frames[0].right.image;
  CompositeResult out, right;
  right.image = cv::Mat(4, 4, CV_8UC3);
  FrameRecord r;
  ASSERT_TRUE((*mono)->process(in, meshes, out, r, &right).ok());
  EXPECT_FALSE(r.right.composited);
  EXPECT_TRUE(right.image.empty());
}

// Issue 28 (session 17): the right eye on its own thread (PipelineOptions::eye_threads = 2:
// its tag tracking and its composite beside the left eye's) gives the same records and the
// same pixels as both eyes on one thread, frame for frame: with a lesson's note, and through
// a frame without the right eye (the single-view path) and its return.
TEST(RightEyeGl, RightEyeThreadGivesTheSerialPixels) {
  DENTAR_GL_TEST_CONTEXT();
  const StereoClip& c = clip();
  ASSERT_TRUE(c.gen != nullptr);
  const StationScene& st = c.gen->station();
  auto vol = molar(st.tooth_voxel_m);
  ToothMeshes meshes(vol);
  PipelineOptions serial_o, threaded_o;
  serial_o.stereo = threaded_o.stereo = true;
  threaded_o.eye_threads = 2;
  auto serial = FramePipeline::create(st, serial_o);
  ASSERT_TRUE(serial.ok()) << serial.error();
  auto threaded = FramePipeline::create(st, threaded_o);
  ASSERT_TRUE(threaded.ok()) << threaded.error();
  ASSERT_TRUE((*serial)->warm_up(meshes).ok());
  ASSERT_TRUE((*threaded)->warm_up(meshes).ok());
  const std::string note = "Keep the bur parallel to the long axis";
  haptics::HapticSnapshot snap{};
  const cv::Mat none;
  int right_compared = 0, overlays = 0;
  for (int i = 0; i < kFrames; ++i) {
    SCOPED_TRACE("frame " + std::to_string(i));
    const StereoSynthFrame& f = c.frames[static_cast<std::size_t>(i)];
    const Eigen::Matrix4d m = f.left.truth.T_dev_sty.matrix();
    for (int k = 0; k < 16; ++k) snap.T_dev_sty[k] = m(k % 4, k / 4);
    FrameInput in;
    in.image = &f.left.image;
    in.right_image = i == 3 ? &none : &f.right.image;  // frame 3: the right eye lost
    in.index = i;
    in.capture_time_s = i / 30.0;
    in.haptic = &snap;
    in.stylus_valid = true;
    if (i % 2 == 1) in.note = &note;
    CompositeResult out_s, right_s, out_t, right_t;
    FrameRecord r_s, r_t;
    ASSERT_TRUE((*serial)->process(in, meshes, out_s, r_s, &right_s).ok());
    const Status st_t = (*threaded)->process(in, meshes, out_t, r_t, &right_t);
    ASSERT_TRUE(st_t.ok()) << st_t.error();
    EXPECT_EQ(r_t.eyes, r_s.eyes);
    EXPECT_EQ(r_t.man_state, r_s.man_state);
    EXPECT_EQ(r_t.mir_state, r_s.mir_state);
    EXPECT_EQ(r_t.tags_detected, r_s.tags_detected);
    EXPECT_EQ(r_t.T_cam_man.matrix(), r_s.T_cam_man.matrix());
    EXPECT_EQ(r_t.T_cam_mtag.matrix(), r_s.T_cam_mtag.matrix());
    EXPECT_EQ(r_t.right.composited, r_s.right.composited);
    EXPECT_EQ(r_t.right.overlay, r_s.right.overlay);
    EXPECT_EQ(r_t.right.mirror_drawn, r_s.right.mirror_drawn);
    EXPECT_EQ(r_t.right.note_drawn, r_s.right.note_drawn);
    EXPECT_EQ(r_t.right.region, r_s.right.region);
    ASSERT_EQ(out_t.image.size(), out_s.image.size());
    EXPECT_EQ(cv::norm(out_t.image, out_s.image, cv::NORM_INF), 0.0) << "left eye";
    ASSERT_EQ(right_t.image.empty(), right_s.image.empty());
    EXPECT_EQ(right_t.image.empty(), i == 3);
    if (right_s.image.empty()) continue;
    EXPECT_EQ(cv::norm(right_t.image, right_s.image, cv::NORM_INF), 0.0) << "right eye";
    EXPECT_EQ(cv::norm(right_t.tooth_visible, right_s.tooth_visible, cv::NORM_INF), 0.0) << "right eye's visible tooth";
    ++right_compared;
    overlays += r_t.right.overlay ? 1 : 0;
  }
  EXPECT_EQ(right_compared, kFrames - 1);
  EXPECT_GE(overlays, kFrames - 3) << "the comparison must cover drawn overlays";
  EXPECT_EQ((*threaded)->eye_threads(), 2);
  EXPECT_EQ((*threaded)->eye_thread_note(), "");
  // The option is checked.
  PipelineOptions bad = threaded_o;
  bad.eye_threads = 3;
  auto b = FramePipeline::create(st, bad);
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().find("eye_threads = 3"), std::string::npos) << b.error();
}

// Session 18: the right eye's thread needs a GL context of its own; when it cannot have one (a
// driver out of contexts; here the test hook DENTAR_TEST_FAIL_EYE_CONTEXT), the pipeline is
// made all the same with both eyes on the caller's thread, says why, and draws the right eye
// as eye_threads = 1 does (before: create() failed and `dentar live` stopped).
TEST(RightEyeGl, EyeThreadWithoutItsContextFallsBackToOne) {
  DENTAR_GL_TEST_CONTEXT();
  const StereoClip& c = clip();
  ASSERT_TRUE(c.gen != nullptr);
  const StationScene& st = c.gen->station();
  auto vol = molar(st.tooth_voxel_m);
  ToothMeshes meshes(vol);
  PipelineOptions serial_o, threaded_o;
  serial_o.stereo = threaded_o.stereo = true;
  threaded_o.eye_threads = 2;
  ASSERT_EQ(setenv("DENTAR_TEST_FAIL_EYE_CONTEXT", "1", 1), 0);
  auto fallen = FramePipeline::create(st, threaded_o);
  unsetenv("DENTAR_TEST_FAIL_EYE_CONTEXT");
  ASSERT_TRUE(fallen.ok()) << fallen.error();
  EXPECT_EQ((*fallen)->eye_threads(), 1);
  EXPECT_EQ((*fallen)->options().eye_threads, 1);
  const std::string note = (*fallen)->eye_thread_note();
  EXPECT_NE(note.find("the right eye's own thread could not start"), std::string::npos) << note;
  EXPECT_NE(note.find("DENTAR_TEST_FAIL_EYE_CONTEXT"), std::string::npos) << note;
  auto serial = FramePipeline::create(st, serial_o);
  ASSERT_TRUE(serial.ok()) << serial.error();
  EXPECT_EQ((*serial)->eye_thread_note(), "");
  ASSERT_TRUE((*serial)->warm_up(meshes).ok());
  ASSERT_TRUE((*fallen)->warm_up(meshes).ok());
  haptics::HapticSnapshot snap{};
  int overlays = 0;
  for (int i = 0; i < 1; ++i) {  // one frame: the clip and two pipelines are the test's cost
    SCOPED_TRACE("frame " + std::to_string(i));
    const StereoSynthFrame& f = c.frames[static_cast<std::size_t>(i)];
    const Eigen::Matrix4d m = f.left.truth.T_dev_sty.matrix();
    for (int k = 0; k < 16; ++k) snap.T_dev_sty[k] = m(k % 4, k / 4);
    FrameInput in;
    in.image = &f.left.image;
    in.right_image = &f.right.image;
    in.index = i;
    in.capture_time_s = i / 30.0;
    in.haptic = &snap;
    in.stylus_valid = true;
    CompositeResult out_s, right_s, out_f, right_f;
    FrameRecord r_s, r_f;
    ASSERT_TRUE((*serial)->process(in, meshes, out_s, r_s, &right_s).ok());
    const Status sf = (*fallen)->process(in, meshes, out_f, r_f, &right_f);
    ASSERT_TRUE(sf.ok()) << sf.error();
    EXPECT_TRUE(r_f.right.composited);
    ASSERT_FALSE(right_f.image.empty());
    EXPECT_EQ(cv::norm(out_f.image, out_s.image, cv::NORM_INF), 0.0) << "left eye";
    EXPECT_EQ(cv::norm(right_f.image, right_s.image, cv::NORM_INF), 0.0) << "right eye";
    overlays += r_f.right.overlay ? 1 : 0;
  }
  EXPECT_GT(overlays, 0) << "the comparison must cover a drawn overlay";
}

}  // namespace
}  // namespace dentar::ar
