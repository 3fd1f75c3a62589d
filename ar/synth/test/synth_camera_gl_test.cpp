// The generator's physical camera model (issue 24, synth.h CameraSensorModel): each effect is
// switched on alone against the same footage without it (same seed, same scene), and must be
// there, of the size the model says, and nowhere else.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "dentar/ar/srgb.h"
#include "dentar/ar/synth.h"
#include "gl_test_context.h"

namespace dentar::ar {
namespace {

// The camera model on with every effect off: no noise to speak of (a huge full well), no
// defocus, no vignetting, no JPEG, no auto-exposure, global shutter, no motion blur.
SynthOptions plain(int frames = 1) {
  SynthOptions o = synth_preset(SynthPreset::kStandard);
  o.frames = frames;
  o.width = 320;
  o.height = 240;
  o.seed = 31;
  o.bur_samples = 1000;
  o.motion_blur = false;
  o.camera.enabled = true;
  o.camera.full_well_e = 1e6;
  o.camera.read_noise_e = 0;
  o.camera.aperture_m = 0;
  o.camera.cos_power = 0;
  o.camera.jpeg_quality = 0;
  o.camera.ae_step_ev = 0;
  o.camera.rolling_readout_s = 0;
  return o;
}

std::vector<SynthFrame> render(const SynthOptions& o) {
  auto g = SynthGenerator::create(default_station_scene(), o);
  EXPECT_TRUE(g.ok()) << (g.ok() ? "" : g.error());
  std::vector<SynthFrame> out;
  if (!g.ok()) return out;
  for (int i = 0; i < o.frames; ++i) {
    SynthFrame f;
    Status s = (*g)->next(f);
    EXPECT_TRUE(s.ok()) << s.error();
    if (!s.ok()) break;
    f.image = f.image.clone();
    out.push_back(std::move(f));
  }
  return out;
}

cv::Mat linear(const cv::Mat& bgr) {
  cv::Mat lin;
  cv::LUT(bgr, srgb_decode_table(), lin);
  return lin;
}

double mean_abs_diff(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat d;
  cv::absdiff(a, b, d);
  return cv::mean(d.reshape(1))[0];
}

TEST(SynthCameraModel, PresetsAreListedAndValid) {
  EXPECT_EQ(*parse_synth_preset("webcam"), SynthPreset::kWebcam);
  EXPECT_EQ(*parse_synth_preset("headset"), SynthPreset::kHeadset);
  for (SynthPreset p : {SynthPreset::kWebcam, SynthPreset::kHeadset}) {
    const SynthOptions o = synth_preset(p);
    EXPECT_TRUE(o.camera.enabled);
    EXPECT_TRUE(o.validate().empty()) << o.validate();
  }
  EXPECT_GT(synth_preset(SynthPreset::kWebcam).camera.jpeg_quality, 0);
  EXPECT_GT(synth_preset(SynthPreset::kWebcam).camera.rolling_readout_s, 0);
  EXPECT_EQ(synth_preset(SynthPreset::kHeadset).camera.rolling_readout_s, 0);  // global shutter
  // The classic presets keep the classic sensor model.
  for (SynthPreset p : {SynthPreset::kStandard, SynthPreset::kHard, SynthPreset::kLowLight})
    EXPECT_FALSE(synth_preset(p).camera.enabled) << synth_preset_name(p);
  SynthOptions bad = plain();
  bad.camera.jpeg_quality = 101;
  EXPECT_NE(bad.validate().find("camera.jpeg_quality"), std::string::npos) << bad.validate();
  bad = plain();
  bad.camera.rolling_readout_s = 0.05;  // longer than a frame at 30 fps
  EXPECT_NE(bad.validate().find("camera.rolling_readout_s"), std::string::npos) << bad.validate();
  bad = plain();
  bad.camera.rolling_bands = 4;
  EXPECT_NE(bad.validate().find("camera.rolling_bands"), std::string::npos) << bad.validate();
}

// Shot noise follows the signal: in linear light the variance of (noisy - clean) grows with the
// clean signal y as y / full_well + (read / full_well)^2.
TEST(SynthCameraModel, NoiseVarianceFollowsTheSignal) {
  DENTAR_GL_TEST_CONTEXT();
  const SynthOptions clean = plain();
  SynthOptions noisy = clean;
  noisy.camera.full_well_e = 2000;
  noisy.camera.read_noise_e = 5;
  const auto a = render(clean), b = render(noisy);
  ASSERT_EQ(a.size(), 1u);
  ASSERT_EQ(b.size(), 1u);
  const cv::Mat la = linear(a[0].image), lb = linear(b[0].image);
  // Bins of the clean signal: sum of squared residuals and count.
  constexpr int kBins = 8;
  double s2[kBins] = {}, n[kBins] = {};
  for (int v = 0; v < la.rows; ++v)
    for (int u = 0; u < la.cols * 3; ++u) {
      const float y = la.ptr<float>(v)[u], z = lb.ptr<float>(v)[u];
      if (y < 0.02f || y > 0.9f) continue;  // away from black and the full well
      const int k = std::min(kBins - 1, static_cast<int>(y * kBins));
      s2[k] += (z - y) * (z - y);
      n[k] += 1;
    }
  // Slope of variance against signal over the populated bins (least squares).
  double sx = 0, sy = 0, sxx = 0, sxy = 0, m = 0;
  for (int k = 0; k < kBins; ++k) {
    if (n[k] < 500) continue;
    const double x = (k + 0.5) / kBins, var = s2[k] / n[k];
    sx += x;
    sy += var;
    sxx += x * x;
    sxy += x * var;
    m += 1;
  }
  ASSERT_GE(m, 3) << "too few populated signal bins";
  const double slope = (m * sxy - sx * sy) / (m * sxx - sx * sx);
  EXPECT_NEAR(slope, 1.0 / 2000, 0.3 / 2000) << "variance per unit signal";
}

TEST(SynthCameraModel, JpegCompressesLikeAWebcam) {
  DENTAR_GL_TEST_CONTEXT();
  const SynthOptions raw = plain();
  SynthOptions mjpg = raw;
  mjpg.camera.jpeg_quality = 80;
  const auto a = render(raw), b = render(mjpg), c = render(raw);
  ASSERT_EQ(a.size(), 1u);
  ASSERT_EQ(b.size(), 1u);
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(mean_abs_diff(a[0].image, c[0].image), 0.0);  // deterministic
  const double psnr = cv::PSNR(a[0].image, b[0].image);
  EXPECT_GT(psnr, 30.0);  // quality 80: visible only up close
  EXPECT_LT(psnr, 50.0);  // but there
}

// Rolling shutter: the middle band is exposed at the frame's time as with a global shutter; the
// first and last bands, 2/5 of the readout earlier and later, see the moving camera elsewhere.
TEST(SynthCameraModel, RollingShutterShiftsTheOuterBandsOnly) {
  DENTAR_GL_TEST_CONTEXT();
  SynthOptions global = plain(3);
  global.motion_speed = 8.0;  // a moving head
  SynthOptions rolling = global;
  rolling.camera.rolling_readout_s = 0.03;
  rolling.camera.rolling_bands = 5;
  const auto a = render(global), b = render(rolling);
  ASSERT_EQ(a.size(), 3u);
  ASSERT_EQ(b.size(), 3u);
  const int H = a[2].image.rows;
  // (3 rows in from the band's edges: the lens blur, after the readout, mixes neighbouring rows.)
  const cv::Rect middle(0, 2 * H / 5 + 3, a[2].image.cols, H / 5 - 6), top(0, 0, a[2].image.cols, H / 5);
  EXPECT_EQ(mean_abs_diff(a[2].image(middle), b[2].image(middle)), 0.0);
  EXPECT_GT(mean_abs_diff(a[2].image(top), b[2].image(top)), 0.3);
  // The truth is the middle row's: the same poses.
  EXPECT_TRUE(a[2].truth.T_cam_man.isApprox(b[2].truth.T_cam_man, 1e-12));
}

// Defocus: the thin lens's blur circle at the tooth's depth, and an image that is softer.
TEST(SynthCameraModel, DefocusBlursByTheCircleOfConfusion) {
  DENTAR_GL_TEST_CONTEXT();
  const SynthOptions sharp = plain();
  SynthOptions soft = sharp;
  soft.camera.aperture_m = 4e-3;
  soft.camera.focus_distance_m = 2.0;
  const auto a = render(sharp), b = render(soft);
  ASSERT_EQ(a.size(), 1u);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_EQ(a[0].truth.defocus_px, 0.0);
  const double depth = a[0].truth.T_cam_tooth.translation().z();
  const double fx = 0.9375 * 320;  // default_camera's at 320 px wide
  EXPECT_NEAR(b[0].truth.defocus_px, fx * 4e-3 * std::abs(1 / depth - 0.5), 1e-6);
  EXPECT_GT(b[0].truth.defocus_px, 2.0);
  auto sharpness = [](const cv::Mat& bgr) {
    cv::Mat g, lap;
    cv::cvtColor(bgr, g, cv::COLOR_BGR2GRAY);
    cv::Laplacian(g, lap, CV_32F);
    cv::Scalar mu, sd;
    cv::meanStdDev(lap, mu, sd);
    return sd[0];
  };
  EXPECT_LT(sharpness(b[0].image), 0.7 * sharpness(a[0].image));
}

// Vignetting cos^4: the corners lose what the field angle says, the centre nothing.
TEST(SynthCameraModel, VignettingFollowsTheFieldAngle) {
  DENTAR_GL_TEST_CONTEXT();
  const SynthOptions flat = plain();
  SynthOptions vig = flat;
  vig.camera.cos_power = 4;
  const auto a = render(flat), b = render(vig);
  ASSERT_EQ(a.size(), 1u);
  ASSERT_EQ(b.size(), 1u);
  const cv::Mat la = linear(a[0].image), lb = linear(b[0].image);
  auto ratio = [&](const cv::Rect& r) { return cv::mean(lb(r))[1] / cv::mean(la(r))[1]; };
  const double fx = 0.9375 * 320;
  // A 10 px patch at the top-left corner: its centre (5, 5) against the principal point.
  const double x = (5 - (0.5 * 319 + 0.004 * 320)) / fx, y = (5 - (0.5 * 239 - 0.003 * 240)) / fx;
  const double expect = std::pow(1.0 / std::sqrt(1 + x * x + y * y), 4);
  EXPECT_NEAR(ratio(cv::Rect(0, 0, 10, 10)), expect, 0.03);
  EXPECT_NEAR(ratio(cv::Rect(155, 115, 10, 10)), 1.0, 0.01);
}

// Auto-exposure: a jump in the scene light is answered by 1/3 EV steps, so the frame's gain is
// the light times 2^(k/3), and changes only by light jumps and whole steps.
TEST(SynthCameraModel, AutoExposureAnswersLightJumpsInSteps) {
  DENTAR_GL_TEST_CONTEXT();
  SynthOptions o = plain(90);
  o.width = 160;
  o.height = 120;
  o.exposure_variation = 0;
  o.exposure_jumps = true;
  o.camera.ae_step_ev = 1.0 / 3.0;
  o.camera.ae_deadband_ev = 0.2;
  o.camera.ae_delay_frames = 2;
  const auto f = render(o);
  ASSERT_EQ(f.size(), 90u);
  int steps = 0, jumps = 0;
  for (std::size_t i = 1; i < f.size(); ++i) {
    const double r = f[i].truth.exposure_gain / f[i - 1].truth.exposure_gain;
    bool explained = false;
    for (double light : {1.0, 1.25, 0.75})
      for (int k : {0, 1, -1})
        if (!explained && std::abs(r - light * std::exp2(k / 3.0)) < 1e-9) {
          explained = true;
          jumps += light != 1.0;
          steps += k != 0;
        }
    EXPECT_TRUE(explained) << "frame " << i << " gain ratio " << r;
  }
  ASSERT_GE(jumps, 1) << "seed 31 draws no light jump in 3 s: pick another seed";
  EXPECT_GE(steps, 1) << "no AE step after a 25 % light jump";
  EXPECT_EQ(f.back().truth.ae_steps, steps);
}

}  // namespace
}  // namespace dentar::ar
