// The failure-mode presets (issue 16): each adds one way tracking fails to
// an otherwise unchanged scene, with ground truth. Every test renders the
// failure preset and its base preset from the same seed (the motion signals
// are the same streams) and checks that the failure is there, where the
// truth says, and that the base has none of it.
#include <gtest/gtest.h>

#include <algorithm>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "dentar/ar/synth.h"
#include "gl_test_context.h"

namespace dentar::ar {
namespace {

std::vector<SynthFrame> render(SynthPreset p, int frames, double fps = 30) {
  SynthOptions o = synth_preset(p);
  o.frames = frames;
  o.fps = fps;
  o.seed = 23;
  o.bur_samples = 1000;
  o.blur_subframes = 3;  // keep CI quick
  auto g = SynthGenerator::create(default_station_scene(), o);
  EXPECT_TRUE(g.ok()) << (g.ok() ? "" : g.error());
  std::vector<SynthFrame> out;
  if (!g.ok()) return out;
  for (int i = 0; i < frames; ++i) {
    SynthFrame f;
    Status s = (*g)->next(f);
    EXPECT_TRUE(s.ok()) << s.error();
    if (!s.ok()) break;
    f.image = f.image.clone();
    f.mask = f.mask.clone();
    out.push_back(std::move(f));
  }
  return out;
}

double hidden_by_foreground(const SynthFrame& f) {
  if (f.truth.tooth_px == 0) return 0;
  return cv::countNonZero(f.mask == kMaskForeground) / double(f.truth.tooth_px);
}

TEST(SynthFailurePresets, NamesParseAndAreListed) {
  for (SynthPreset p : all_synth_presets()) {
    auto q = parse_synth_preset(synth_preset_name(p));
    ASSERT_TRUE(q.has_value()) << synth_preset_name(p);
    EXPECT_EQ(*q, p);
    EXPECT_TRUE(synth_preset(p).validate().empty()) << synth_preset_name(p);
  }
  EXPECT_EQ(synth_preset_names(), "standard|hard|mirror|hand|glare|lowlight|fast|offframe|webcam|headset");
  EXPECT_FALSE(parse_synth_preset("easy").has_value());
  SynthOptions o = synth_preset(SynthPreset::kFastTurns);
  o.head_turn_s = 0.5;  // longer than a quarter period
  EXPECT_NE(o.validate().find("head turn"), std::string::npos) << o.validate();
  o = synth_preset(SynthPreset::kGlare);
  o.mirror_glare = 2;
  EXPECT_NE(o.validate().find("glare"), std::string::npos) << o.validate();
}

TEST(SynthFailurePresets, HandCrossesTheTooth) {
  DENTAR_GL_TEST_CONTEXT();
  const auto base = render(SynthPreset::kStandard, 30), hand = render(SynthPreset::kHand, 30);
  ASSERT_EQ(base.size(), 30u);
  ASSERT_EQ(hand.size(), 30u);
  int crossing = 0;
  double worst_base = 0, best_cross = 0;
  for (std::size_t i = 0; i < hand.size(); ++i) {
    // Same motion: the camera poses are identical.
    EXPECT_TRUE(hand[i].truth.T_cam_man.isApprox(base[i].truth.T_cam_man, 1e-12));
    worst_base = std::max(worst_base, hidden_by_foreground(base[i]));
    if (hand[i].truth.hand_crossing) {
      ++crossing;
      best_cross = std::max(best_cross, hidden_by_foreground(hand[i]));
    }
  }
  std::printf("[ synth ] hand: %d crossing frames, tooth hidden by the finger up to %.2f (standard %.2f)\n",
              crossing, best_cross, worst_base);
  EXPECT_GE(crossing, 5);
  EXPECT_GT(best_cross, 0.9);  // the finger hides (almost) all of the tooth
  EXPECT_LT(worst_base, 0.5);
}

TEST(SynthFailurePresets, GlareWashesOutTheMirror) {
  DENTAR_GL_TEST_CONTEXT();
  const auto base = render(SynthPreset::kMirror, 8), glare = render(SynthPreset::kGlare, 8);
  ASSERT_EQ(glare.size(), 8u);
  ASSERT_EQ(base.size(), 8u);
  int drawn = 0, brightened = 0, outside = 0;
  for (std::size_t i = 0; i < glare.size(); ++i) {
    EXPECT_FALSE(base[i].truth.glare);
    if (!glare[i].truth.glare) continue;
    ++drawn;
    cv::Mat g0, g1;
    cv::cvtColor(base[i].image, g0, cv::COLOR_BGR2GRAY);
    cv::cvtColor(glare[i].image, g1, cv::COLOR_BGR2GRAY);
    cv::Mat diff;
    cv::subtract(g1, g0, diff, cv::noArray(), CV_16S);
    const cv::Mat lit = diff > 40;
    brightened += cv::countNonZero(lit);
    // Everything it brightened lies around the mirror's paddle (its front
    // tag's box, grown to 4x: the paddle is 30 mm, the tag 12 mm).
    cv::Mat near = cv::Mat::zeros(lit.size(), CV_8U);
    for (const auto& t : glare[i].truth.tags) {
      if (!t.on_mirror) continue;
      cv::Rect box(int(t.corners_px[0].x()), int(t.corners_px[0].y()), 1, 1);
      for (const auto& c : t.corners_px) box |= cv::Rect(int(c.x()), int(c.y()), 1, 1);
      const int gx = 2 * std::max(box.width, box.height);
      box = cv::Rect(box.x - gx, box.y - gx, box.width + 2 * gx, box.height + 2 * gx) &
            cv::Rect(0, 0, lit.cols, lit.rows);
      near(box).setTo(255);
    }
    outside += cv::countNonZero(lit & ~near);
  }
  std::printf("[ synth ] glare: %d frames with glare, %d pixels brightened by > 40 DN, %d of them away "
              "from the mirror's tags\n",
              drawn, brightened, outside);
  EXPECT_GE(drawn, 6);
  EXPECT_GE(brightened, 20 * drawn);
  EXPECT_LE(outside, brightened / 10);
}

TEST(SynthFailurePresets, LowLightIsDarkAndNoisy) {
  DENTAR_GL_TEST_CONTEXT();
  const auto base = render(SynthPreset::kStandard, 3), low = render(SynthPreset::kLowLight, 3);
  ASSERT_EQ(low.size(), 3u);
  ASSERT_EQ(base.size(), 3u);
  for (std::size_t i = 0; i < low.size(); ++i) {
    EXPECT_NEAR(low[i].truth.exposure_gain / base[i].truth.exposure_gain, 0.3, 1e-9);
    cv::Mat a, b;
    cv::cvtColor(base[i].image, a, cv::COLOR_BGR2GRAY);
    cv::cvtColor(low[i].image, b, cv::COLOR_BGR2GRAY);
    const double ma = cv::mean(a)[0], mb = cv::mean(b)[0];
    EXPECT_LT(mb, 0.4 * ma) << "frame " << i;
    // Noise relative to the signal: high-pass energy over the mean, on the
    // pixels that are flat in the standard frame (the same scene: scene edges
    // such as the mirror's tags are not noise).
    auto high_pass = [](const cv::Mat& g) {
      cv::Mat f, s;
      g.convertTo(f, CV_32F);
      cv::GaussianBlur(f, s, cv::Size(0, 0), 2.0);
      return cv::Mat(f - s);
    };
    const cv::Mat ha = high_pass(a);
    cv::Mat flat = cv::abs(ha) < 4.0f;
    cv::erode(flat, flat, cv::Mat(), cv::Point(-1, -1), 3);
    ASSERT_GT(cv::countNonZero(flat), a.total() / 4) << "frame " << i;
    auto rel_noise = [&](const cv::Mat& g, const cv::Mat& hp) {
      cv::Scalar mean, sd;
      cv::meanStdDev(hp, mean, sd, flat);
      return sd[0] / std::max(1.0, cv::mean(g, flat)[0]);
    };
    EXPECT_GT(rel_noise(b, high_pass(b)), 1.5 * rel_noise(a, ha)) << "frame " << i;
  }
}

TEST(SynthFailurePresets, FastHeadTurnsExceed200DegPerSecond) {
  DENTAR_GL_TEST_CONTEXT();
  const auto base = render(SynthPreset::kStandard, 24), fast = render(SynthPreset::kFastTurns, 24);
  ASSERT_EQ(fast.size(), 24u);
  double top_base = 0, top_fast = 0;
  for (const auto& f : base) top_base = std::max(top_base, f.truth.camera_speed_deg_s);
  for (const auto& f : fast) top_fast = std::max(top_fast, f.truth.camera_speed_deg_s);
  // Check the truth's speed against the poses: frame to frame rotation.
  double top_step = 0;
  for (std::size_t i = 1; i < fast.size(); ++i)
    top_step = std::max(top_step, Eigen::AngleAxisd(fast[i - 1].truth.T_cam_man.linear() *
                                                    fast[i].truth.T_cam_man.linear().transpose())
                                          .angle() *
                                      180 / M_PI * 30);
  std::printf("[ synth ] fast: camera up to %.0f deg/s (frame to frame %.0f deg/s); standard %.0f deg/s\n",
              top_fast, top_step, top_base);
  EXPECT_GE(top_fast, 200.0);
  EXPECT_GE(top_step, 150.0);  // averaged over a frame, the 0.12 s turn is still fast
  EXPECT_LT(top_base, 60.0);
}

TEST(SynthFailurePresets, OffFrameCutsTagsButKeepsTheTooth) {
  DENTAR_GL_TEST_CONTEXT();
  const auto base = render(SynthPreset::kStandard, 6), off = render(SynthPreset::kOffFrame, 6);
  ASSERT_EQ(off.size(), 6u);
  // Tags cut by the left or right edge (standard cuts some at the top and
  // bottom: the forehead and chin tags).
  auto cut_tags = [](const SynthFrame& f) {
    int n = 0;
    for (const auto& t : f.truth.tags) {
      if (t.on_mirror || t.in_image || t.visible_fraction <= 0.2) continue;
      bool side = false;
      for (const auto& c : t.corners_px) side = side || c.x() < 0 || c.x() > 639;
      n += side ? 1 : 0;
    }
    return n;
  };
  int cut_off = 0, cut_base = 0;
  for (std::size_t i = 0; i < off.size(); ++i) {
    cut_off += cut_tags(off[i]);
    cut_base += cut_tags(base[i]);
    EXPECT_GT(off[i].truth.tooth_px, 0) << "frame " << i << ": the tooth left the image";
  }
  std::printf("[ synth ] offframe: %d tags cut by the side edges in 6 frames (standard %d)\n", cut_off,
              cut_base);
  EXPECT_GE(cut_off, 3);
  EXPECT_GT(cut_off, cut_base);
}

}  // namespace
}  // namespace dentar::ar
