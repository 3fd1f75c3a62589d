// FramePipeline: the object both drivers share. Same frames, capture times
// and snapshots in -> the same records and composites out, whether or not it
// was warmed up; the threaded mesher ends with the same meshes as inline
// meshing; bad input is refused with the frame named.
#include "dentar/ar/frame_pipeline.h"

#include <gtest/gtest.h>

#include <chrono>
#include <opencv2/core.hpp>
#include <thread>

#include "dentar/ar/synth.h"
#include "dentar/volume/cutter.h"
#include "dentar/volume/procedural_tooth.h"
#include "gl_test_context.h"

namespace dentar::ar {
namespace {

struct Clip {
  std::unique_ptr<SynthGenerator> gen;
  std::vector<SynthFrame> frames;
};

const Clip& clip() {
  static Clip c = [] {
    Clip k;
    SynthOptions o = synth_preset(SynthPreset::kStandard);
    o.frames = 12;
    auto g = SynthGenerator::create(default_station_scene(), o);
    EXPECT_TRUE(g.ok()) << g.error();
    k.gen = std::move(g).value();
    for (int i = 0; i < o.frames; ++i) {
      SynthFrame f;
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

struct RunOut {
  std::vector<FrameRecord> records;
  std::vector<cv::Mat> images;
};

RunOut run(bool warm) {
  const Clip& c = clip();
  auto vol = molar(c.gen->station().tooth_voxel_m);
  ToothMeshes meshes(vol);
  const PipelineOptions opts;
  auto p = FramePipeline::create(c.gen->station(), opts);
  EXPECT_TRUE(p.ok()) << p.error();
  if (warm) {
    EXPECT_TRUE((*p)->warm_up(meshes).ok());
  }
  RunOut out;
  haptics::HapticSnapshot snap{};
  // A stylus pose from the truth, so the bur and handpiece are drawn too.
  for (std::size_t i = 0; i < c.frames.size(); ++i) {
    const SynthFrame& f = c.frames[i];
    const Eigen::Matrix4d m = f.truth.T_dev_sty.matrix();
    for (int k = 0; k < 16; ++k) snap.T_dev_sty[k] = m(k % 4, k / 4);
    snap.step = i * 33;
    FrameInput in;
    in.image = &f.image;
    in.index = static_cast<std::int64_t>(i);
    in.capture_time_s = static_cast<double>(i) / 30.0;
    in.haptic = &snap;
    in.stylus_valid = true;
    CompositeResult cr;
    FrameRecord r;
    const Status s = (*p)->process(in, meshes, cr, r);
    EXPECT_TRUE(s.ok()) << s.error();
    out.records.push_back(r);
    out.images.push_back(cr.image.clone());
  }
  return out;
}

TEST(FramePipelineGl, SameInputSameOutputWithAndWithoutWarmUp) {
  DENTAR_GL_TEST_CONTEXT();
  const RunOut a = run(false), b = run(true);
  ASSERT_EQ(a.records.size(), b.records.size());
  int overlays = 0;
  for (std::size_t i = 0; i < a.records.size(); ++i) {
    const FrameRecord &x = a.records[i], &y = b.records[i];
    EXPECT_EQ(x.man_state, y.man_state) << i;
    EXPECT_EQ(x.T_cam_man.matrix(), y.T_cam_man.matrix()) << "frame " << i << ": poses must be bit-identical";
    EXPECT_EQ(x.T_cam_mtag.matrix(), y.T_cam_mtag.matrix()) << i;
    EXPECT_EQ(x.overlay, y.overlay) << i;
    EXPECT_EQ(cv::norm(a.images[i], b.images[i], cv::NORM_INF), 0.0) << "frame " << i << ": composites differ";
    overlays += x.overlay ? 1 : 0;
    EXPECT_EQ(x.haptic_step, i * 33);
    EXPECT_TRUE(x.stylus_drawn || x.man_state == 2);
  }
  EXPECT_GE(overlays, 10) << "the tooth must be drawn on the tracked frames";
  // The overlay is really there: the composite differs from the video.
  EXPECT_GT(cv::norm(a.images[5], clip().frames[5].image, cv::NORM_L1), 1000.0);
}

TEST(FramePipelineGl, RefusesBadFrames) {
  DENTAR_GL_TEST_CONTEXT();
  const Clip& c = clip();
  auto vol = molar(c.gen->station().tooth_voxel_m);
  ToothMeshes meshes(vol);
  auto p = FramePipeline::create(c.gen->station(), PipelineOptions{});
  ASSERT_TRUE(p.ok()) << p.error();
  FrameInput in;
  in.index = 7;
  CompositeResult cr;
  FrameRecord r;
  Status s = (*p)->process(in, meshes, cr, r);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("frame 7"), std::string::npos) << s.error();
  const cv::Mat small(100, 100, CV_8UC3, cv::Scalar::all(0));
  in.image = &small;
  s = (*p)->process(in, meshes, cr, r);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("frame 7"), std::string::npos) << s.error();
  PipelineOptions bad;
  bad.predict_s = -1;
  auto q = FramePipeline::create(c.gen->station(), bad);
  ASSERT_FALSE(q.ok());
  EXPECT_NE(q.error().find("predict_s"), std::string::npos) << q.error();
}

// Issue 27: a snapshot in a training mode draws the expert's tool at its tooth-frame pose;
// mode 5 while the expert drills changes the tool's and the tooth's colours; mode 0 (no
// training) leaves the composite as it was.
TEST(FramePipelineGl, TrainingModeDrawsTheExpertsTool) {
  DENTAR_GL_TEST_CONTEXT();
  const Clip& c = clip();
  auto vol = molar(c.gen->station().tooth_voxel_m);
  ToothMeshes meshes(vol);
  auto p = FramePipeline::create(c.gen->station(), PipelineOptions{});
  ASSERT_TRUE(p.ok()) << p.error();
  const SynthFrame& f = c.frames[4];
  auto frame = [&](std::uint8_t mode, std::uint8_t drilling, FrameRecord& r) {
    haptics::HapticSnapshot snap{};
    const Eigen::Matrix4d m = f.truth.T_dev_sty.matrix();
    for (int k = 0; k < 16; ++k) snap.T_dev_sty[k] = m(k % 4, k / 4);
    // The expert's tip 3 mm above the tooth's centre, bur axis into the tooth (-z of tooth).
    Eigen::Isometry3d T_tooth_exp = Eigen::Isometry3d::Identity();
    T_tooth_exp.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
    T_tooth_exp.translation() = Eigen::Vector3d(0, 0, 0.003);
    for (int k = 0; k < 16; ++k) snap.T_tooth_expert_tip[k] = T_tooth_exp.matrix()(k % 4, k / 4);
    snap.mode = mode;
    snap.expert_drilling = drilling;
    FrameInput in;
    in.image = &f.image;
    in.index = 4;
    in.capture_time_s = 4 / 30.0;
    in.haptic = &snap;
    in.stylus_valid = true;
    CompositeResult cr;
    (*p)->tracker().reset();  // each frame tracked afresh, so the three see the same poses
    EXPECT_TRUE((*p)->process(in, meshes, cr, r).ok());
    return cr.image.clone();
  };
  FrameRecord r0, r3, r5;
  const cv::Mat plain = frame(0, 0, r0), m3 = frame(3, 1, r3), m5 = frame(5, 1, r5);
  ASSERT_TRUE(r0.overlay);
  EXPECT_FALSE(r0.expert_drawn);
  EXPECT_TRUE(r3.expert_drawn);
  EXPECT_FALSE(r3.expert_drilling_shown);  // colours change in mode 5 only
  EXPECT_TRUE(r5.expert_drawn);
  EXPECT_TRUE(r5.expert_drilling_shown);
  cv::Mat d3, d5;
  cv::absdiff(plain, m3, d3);
  cv::absdiff(m3, m5, d5);
  EXPECT_GT(cv::countNonZero(d3.reshape(1) > 10), 300) << "no expert's tool in mode 3";
  EXPECT_GT(cv::countNonZero(d5.reshape(1) > 10), 300) << "mode 5's drilling colours missing";
}

// Issue 27: a lesson's note given with the frame is drawn in the composite beside the tooth:
// a box of the label's solid background within 200 px of the tooth's centre as projected
// with the frame's mannequin pose; without a note, or with the mannequin lost, no label.
TEST(FramePipelineGl, LessonNoteIsDrawnBesideTheTooth) {
  DENTAR_GL_TEST_CONTEXT();
  const Clip& c = clip();
  auto vol = molar(c.gen->station().tooth_voxel_m);
  ToothMeshes meshes(vol);
  auto p = FramePipeline::create(c.gen->station(), PipelineOptions{});
  ASSERT_TRUE(p.ok()) << p.error();
  const std::string note = "keep the bur upright";
  const NoteLabelStyle style;
  const cv::Vec3b bg(static_cast<std::uint8_t>(style.background[0]), static_cast<std::uint8_t>(style.background[1]),
                     static_cast<std::uint8_t>(style.background[2]));
  auto frame = [&](const cv::Mat& image, const std::string* text, FrameRecord& r) {
    FrameInput in;
    in.image = &image;
    in.index = 4;
    in.capture_time_s = 4 / 30.0;
    in.note = text;
    CompositeResult cr;
    (*p)->tracker().reset();
    EXPECT_TRUE((*p)->process(in, meshes, cr, r).ok());
    return cr.image.clone();
  };
  // Pixels of exactly the label's background within `radius` px of `at`.
  auto bg_near = [&](const cv::Mat& img, const Eigen::Vector2d& at, int radius) {
    const cv::Rect win = cv::Rect(static_cast<int>(at.x()) - radius, static_cast<int>(at.y()) - radius, 2 * radius,
                                  2 * radius) &
                         cv::Rect(0, 0, img.cols, img.rows);
    int n = 0;
    for (int y = win.y; y < win.y + win.height; ++y)
      for (int x = win.x; x < win.x + win.width; ++x) n += img.at<cv::Vec3b>(y, x) == bg ? 1 : 0;
    return n;
  };
  const cv::Mat& image = c.frames[4].image;
  FrameRecord rn, rp;
  const cv::Mat with = frame(image, &note, rn), plain = frame(image, nullptr, rp);
  ASSERT_TRUE(rn.overlay);
  ASSERT_TRUE(rn.note_drawn);
  EXPECT_FALSE(rp.note_drawn);
  EXPECT_FALSE(rp.note_anchored);
  // The anchor is the tooth's centre through the station's tooth placement and camera model.
  const auto centre = tooth_centre_px(c.gen->station(), rn.T_cam_man);
  ASSERT_TRUE(centre.has_value());
  EXPECT_LT((rn.note_anchor_px - *centre).norm(), 1e-9);
  EXPECT_GT(centre->x(), 0);
  EXPECT_LT(centre->x(), image.cols);
  // The label: a solid box of at least ~ the text's size near the tooth; none without a note.
  const int n_with = bg_near(with, *centre, 200), n_plain = bg_near(plain, *centre, 200);
  EXPECT_GT(n_with, 1500) << "no label background near the tooth";
  EXPECT_LT(n_plain, 50) << "the label's colour without a note";
  // The rest of the frame is unchanged: every differing pixel lies in the label's layout
  // (box, leader line, anchor dot).
  const NoteLabelLayout lay = layout_note_label(note, *centre, image.size());
  cv::Rect keep = lay.box | cv::Rect(lay.anchor, lay.leader_end);
  keep = cv::Rect(keep.x - 8, keep.y - 8, keep.width + 16, keep.height + 16);
  cv::Mat d;
  cv::absdiff(with, plain, d);
  cv::Mat outside = d.clone();
  outside(keep & cv::Rect(0, 0, d.cols, d.rows)).setTo(cv::Scalar::all(0));
  EXPECT_GT(cv::countNonZero(d.reshape(1)), 0);
  EXPECT_EQ(cv::countNonZero(outside.reshape(1)), 0) << "the note drew outside its label";
  // The mannequin lost (no tags in a grey frame): the tooth is not drawn, nor the note.
  const cv::Mat grey(image.size(), image.type(), cv::Scalar::all(128));
  FrameRecord rl;
  const cv::Mat lost = frame(grey, &note, rl);
  EXPECT_FALSE(rl.overlay);
  EXPECT_FALSE(rl.note_drawn);
  EXPECT_EQ(bg_near(lost, *centre, 400), 0);
}

// The threaded mesher hands over the same chunk meshes inline meshing makes.
TEST(ToothMeshes, ThreadedMesherConvergesToInline) {
  auto vol_a = molar(0.1e-3), vol_b = molar(0.1e-3);
  ToothMeshes inl(vol_a), thr(vol_b);
  thr.start_mesher(0.002);
  volume::CutParams cp;
  auto bur = volume::sample_bur(volume::BurParams::sphere(1.0), 2000);
  ASSERT_TRUE(bur.ok()) << bur.error();
  volume::Cutter ca(vol_a, cp), cb(vol_b, cp);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d c = vol_a.origin() + 0.5 * vol_a.spacing().cwiseProduct(vol_a.dims().cast<double>());
  for (int i = 0; i < 40; ++i) {
    T.translation() = c + Eigen::Vector3d(0, 0, 0.004 - 1e-4 * i);
    ca.step(*bur, T, 3.0, 1e-3);
    cb.step(*bur, T, 3.0, 1e-3);
  }
  EXPECT_EQ(vol_a.content_hash(), vol_b.content_hash());
  inl.sync();
  int got = 0;
  for (int k = 0; k < 200 && got == 0; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    got += thr.sync();
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  thr.sync();
  thr.stop_mesher();
  thr.sync();
  EXPECT_GT(got, 0) << "the mesher never handed a chunk over";
  EXPECT_EQ(inl.display().triangle_count(), thr.display().triangle_count());
  const auto &A = inl.display().chunks(), &B = thr.display().chunks();
  ASSERT_EQ(A.size(), B.size());
  for (std::size_t i = 0; i < A.size(); ++i) EXPECT_EQ(A[i].indices, B[i].indices) << "chunk " << i;
  EXPECT_GT(thr.stats().passes, 0u);
}

}  // namespace
}  // namespace dentar::ar
