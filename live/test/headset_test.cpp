// The headset profile (read, validated), the per-eye mapping (pre-warp,
// chromatic scale, field of view, IPD shift, loupe) and the loupe's centre
// filter, on the CPU (headset.h).
#include "dentar/live/headset.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <random>

#include "testutil.h"

namespace fs = std::filesystem;
using namespace dentar::live;

namespace {

nlohmann::json good_json() {
  return nlohmann::json::parse(R"({
    "format": "dentar-headset", "version": 1, "name": "test", "provenance": "a test's numbers",
    "panel_px": [1280, 480],
    "eyes": [{"viewport_px": [0, 0, 640, 480]}, {"viewport_px": [640, 0, 640, 480], "lens_center_px": [300, 240]}],
    "fov_deg": [90, 70], "ipd_mm": 63,
    "distortion": {"k1": 0.2, "k2": 0.1, "chroma_scale_r": 0.99, "chroma_scale_b": 1.01}
  })");
}

dentar::calibration::CameraIntrinsics cam640() {
  dentar::calibration::CameraIntrinsics c;
  c.width = 640, c.height = 480, c.fx = 500, c.fy = 500, c.cx = 319.5, c.cy = 239.5;
  return c;
}

}  // namespace

TEST(Headset, ExampleProfilesRead) {
  for (const char* f : {"assets/headsets/oculus_rift_dk1.json", "assets/headsets/generic_2x1440x1600.json"}) {
    auto h = read_headset_profile(f);
    ASSERT_TRUE(h.ok()) << h.error();
    EXPECT_FALSE(h->provenance.empty());
    EXPECT_TRUE(h->has_warp()) << f;
  }
  auto dk1 = read_headset_profile("assets/headsets/oculus_rift_dk1.json");
  ASSERT_TRUE(dk1.ok());
  EXPECT_EQ(dk1->panel_w, 1280);
  EXPECT_DOUBLE_EQ(dk1->k1, 0.22);
  EXPECT_DOUBLE_EQ(dk1->ipd_m, 0.064);
  EXPECT_NEAR(dk1->eyes[0].lens_center_px[0] + dk1->eyes[1].lens_center_px[0], 640, 1e-9);  // mirror images
  auto g = parse_headset_profile(good_json().dump(), "g.json");
  ASSERT_TRUE(g.ok()) << g.error();
  EXPECT_DOUBLE_EQ(g->eyes[0].lens_center_px[0], 320);  // default: the viewport's centre
  EXPECT_DOUBLE_EQ(g->mono_convergence_m, 0.4);
}

// Each impossible value is refused with the file and the field named.
TEST(Headset, BadProfilesNameFileAndField) {
  struct Case {
    std::function<void(nlohmann::json&)> edit;
    std::string field;
  };
  const std::vector<Case> cases = {
      {[](auto& j) { j["ipd_mm"] = -63; }, "ipd_mm = -63 must be positive"},
      {[](auto& j) { j["ipd_mm"] = 150; }, "ipd_mm = 150"},
      {[](auto& j) { j["fov_deg"][0] = 180; }, "fov_deg[0] = 180"},
      {[](auto& j) { j["fov_deg"][1] = 200; }, "fov_deg[1] = 200"},
      {[](auto& j) { j["distortion"]["k1"] = -0.5; }, "not monotonic over eyes[0]'s viewport"},
      {[](auto& j) { j["distortion"]["k2"] = -0.3; }, "not monotonic"},
      {[](auto& j) { j["distortion"]["chroma_scale_b"] = 1.5; }, "distortion.chroma_scale_b = 1.5"},
      {[](auto& j) { j["eyes"][1]["viewport_px"][2] = 700; }, "eyes[1].viewport_px [640, 0, 700, 480] must lie on"},
      {[](auto& j) { j["eyes"][1]["viewport_px"][0] = 600; }, "overlap"},
      {[](auto& j) { j["eyes"][0]["lens_center_px"] = {700, 240}; }, "eyes[0].lens_center_px"},
      {[](auto& j) { j["panel_px"] = {0, 480}; }, "panel = 0x480"},
      {[](auto& j) { j["mono_convergence_mm"] = 10; }, "mono_convergence_mm = 10"},
      {[](auto& j) { j["fov"] = 90; }, "unknown field \"fov\""},
      {[](auto& j) { j.erase("ipd_mm"); }, "missing field \"ipd_mm\""},
      {[](auto& j) { j["ipd_mm"] = "63"; }, "wrong type"},
      {[](auto& j) { j["provenance"] = ""; }, "provenance is empty"},
      {[](auto& j) { j["eyes"].erase(1); }, "eyes must be an array of 2"},
      {[](auto& j) { j["version"] = 2; }, "version must be 1"},
  };
  for (const Case& c : cases) {
    nlohmann::json j = good_json();
    c.edit(j);
    auto h = parse_headset_profile(j.dump(), "bad.json");
    ASSERT_FALSE(h.ok()) << c.field;
    EXPECT_EQ(h.error().rfind("headset profile bad.json: ", 0), 0u) << h.error();
    EXPECT_NE(h.error().find(c.field), std::string::npos) << h.error();
  }
  EXPECT_NE(parse_headset_profile("{", "x.json").error().find("headset profile x.json: not JSON"), std::string::npos);
  EXPECT_NE(read_headset_profile("no/such/file.json").error().find("no/such/file.json: cannot read"), std::string::npos);
}

// The pre-warp's monotonicity is checked to the farthest corner: a k1 that
// folds back only beyond the viewport passes, the same k1 on a lens centre
// pushed to the edge (a longer reach) does not.
TEST(Headset, MonotonicCheckReachesTheFarthestCorner) {
  nlohmann::json j = good_json();
  j["distortion"] = {{"k1", -0.19}, {"k2", 0.0}};  // folds at r = sqrt(1 / 0.57) = 1.32
  ASSERT_TRUE(parse_headset_profile(j.dump(), "a.json").ok());  // farthest corners at r = 1.25 and 1.30
  j["eyes"][1]["lens_center_px"] = {10, 240};
  auto h = parse_headset_profile(j.dump(), "a.json");
  ASSERT_FALSE(h.ok());
  EXPECT_NE(h.error().find("eyes[1]"), std::string::npos) << h.error();
}

// The mapping: the lens axis shows the camera's principal point shifted by the
// mono IPD shift; a radius r samples the undistorted image at r (1 + k1 r^2 +
// k2 r^4) times the channel's scale; orthoscopic scale; the loupe.
TEST(Headset, EyeMappingGeometry) {
  auto h = parse_headset_profile(good_json().dump(), "g.json");
  ASSERT_TRUE(h.ok());
  const auto cam = cam640();
  const double c0[2] = {100, 200};
  LoupeView off;
  const EyeMapping L = make_eye_mapping(*h, 0, cam, false, off, c0);
  const EyeMapping R = make_eye_mapping(*h, 1, cam, false, off, c0);
  const double shift = 0.0315 / 0.4;  // (ipd / 2) / convergence, tan units
  double u = 0, v = 0;
  ASSERT_TRUE(L.map(320, 240, 1, u, v));  // the left lens axis
  EXPECT_NEAR(u, cam.cx - cam.fx * shift, 1e-9);
  EXPECT_NEAR(v, cam.cy, 1e-9);
  ASSERT_TRUE(R.map(640 + 300, 240, 1, u, v));  // the right lens axis
  EXPECT_NEAR(u, cam.cx + cam.fx * shift, 1e-9);
  EXPECT_FALSE(L.map(700, 240, 1, u, v));  // not the left eye's pixel
  // A stereo pair: no shift.
  const EyeMapping Ls = make_eye_mapping(*h, 0, cam, true, off, c0);
  ASSERT_TRUE(Ls.map(320, 240, 1, u, v));
  EXPECT_NEAR(u, cam.cx, 1e-9);
  // Radial pre-warp per channel: 100 px right of the lens axis (r = 100 / 320).
  const double r = 100.0 / 320, g = 1 + 0.2 * r * r + 0.1 * r * r * r * r;
  const double fe = 320 / std::tan(45 * M_PI / 180);  // fov 90: f_eye = 320
  for (int ch = 0; ch < 3; ++ch) {
    const double s = ch == 0 ? 0.99 : ch == 2 ? 1.01 : 1.0;
    ASSERT_TRUE(Ls.map(420, 240, ch, u, v));
    EXPECT_NEAR(u, cam.cx + cam.fx * (100 * g * s) / fe, 1e-9) << ch;
    EXPECT_NEAR(v, cam.cy, 1e-9);
  }
  // Without the pre-warp the channels agree.
  const EyeMapping Ln = make_eye_mapping(*h, 0, cam, true, off, c0, false);
  ASSERT_TRUE(Ln.map(420, 240, 0, u, v));
  EXPECT_NEAR(u, cam.cx + cam.fx * 100 / fe, 1e-9);
  // The loupe, full view: the lens axis shows the loupe's centre, and m times the angle.
  LoupeView full;
  full.mag = 3, full.inset = false;
  const EyeMapping Lf = make_eye_mapping(*h, 0, cam, true, full, c0, false);
  ASSERT_TRUE(Lf.map(320, 240, 1, u, v));
  EXPECT_NEAR(u, 100, 1e-9);
  EXPECT_NEAR(v, 200, 1e-9);
  ASSERT_TRUE(Lf.map(320 + 30, 240, 1, u, v));
  EXPECT_NEAR(u, 100 + cam.fx * (30 / fe) / 3, 1e-9);
  // Inset: inside, centred on the loupe's centre; outside, the plain view.
  LoupeView in;
  in.mag = 2.5;
  const EyeMapping Li = make_eye_mapping(*h, 0, cam, true, in, c0, false);
  ASSERT_TRUE(Li.map(in.inset_cx * 640, in.inset_cy * 480, 1, u, v));
  EXPECT_NEAR(u, 100, 1e-9);
  EXPECT_NEAR(v, 200, 1e-9);
  ASSERT_TRUE(Li.map(320, 100, 1, u, v));
  EXPECT_NEAR(u, cam.cx, 1e-9);
}

// The CPU reference draws exactly the camera's pixels when the eye image is at
// the camera's scale (f_eye = f_cam), with no pre-warp and no shift.
TEST(Headset, CpuReferenceIsTheCameraAtOneToOne) {
  nlohmann::json j = good_json();
  j["fov_deg"] = {2 * std::atan(320.0 / 500) * 180 / M_PI, 2 * std::atan(240.0 / 500) * 180 / M_PI};
  j["eyes"][1]["lens_center_px"] = {320, 240};
  auto h = parse_headset_profile(j.dump(), "g.json");
  ASSERT_TRUE(h.ok()) << h.error();
  auto cam = cam640();
  cam.cx = 319.5, cam.cy = 239.5;  // the lens axis (320, 240 px, GL) is the principal point
  cv::Mat src(480, 640, CV_8UC3);
  cv::randu(src, 0, 255);
  cv::Mat panel(480, 1280, CV_8UC3, cv::Scalar::all(7));
  const double c0[2] = {0, 0};
  for (int e = 0; e < 2; ++e) render_eye_cpu(src, make_eye_mapping(*h, e, cam, true, LoupeView{}, c0, false), panel);
  cv::Mat d;
  cv::absdiff(panel(cv::Rect(0, 0, 640, 480)), src, d);
  EXPECT_LE(cv::norm(d, cv::NORM_INF), 1);
  cv::absdiff(panel(cv::Rect(640, 0, 640, 480)), src, d);
  EXPECT_LE(cv::norm(d, cv::NORM_INF), 1);
}

// The loupe's centre: the tracker's jitter does not move it; a head shake
// moves it with the tooth, within the deadband (no lag: the frame's own pose).
TEST(Headset, LoupeCentreHoldsUnderJitterAndFollowsShake) {
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0, 0.2);  // px, a tracked projection's jitter (measured ~0.1-0.3)
  LoupeCentre c;
  double travel = 0, raw_travel = 0, pu = 0, pv = 0, prev[2] = {0, 0};
  for (int i = 0; i < 300; ++i) {  // a still head, 10 s at 30 fps
    const double u = 300 + noise(rng), v = 200 + noise(rng);
    c.update(true, u, v);
    if (i > 0) {
      travel += std::hypot(c.centre()[0] - prev[0], c.centre()[1] - prev[1]);
      raw_travel += std::hypot(u - pu, v - pv);
    }
    prev[0] = c.centre()[0], prev[1] = c.centre()[1], pu = u, pv = v;
  }
  EXPECT_LT(travel, 2.0) << "raw " << raw_travel;
  EXPECT_GT(raw_travel, 50.0);
  // A head shake: 3 Hz, +-12 px in the image (about +-1.4 deg at 500 px focal), with jitter,
  // and 5 % of frames without a pose (held).
  std::uniform_real_distribution<double> drop(0, 1);
  double worst = 0;
  for (int i = 0; i < 300; ++i) {
    const double t = i / 30.0;
    const double tu = 300 + 12 * std::sin(2 * M_PI * 3 * t), tv = 200 + 5 * std::cos(2 * M_PI * 3 * t);
    const bool ok = drop(rng) > 0.05;
    c.update(ok, tu + noise(rng), tv + noise(rng));
    if (ok) worst = std::max(worst, std::hypot(tu - c.centre()[0], tv - c.centre()[1]));
  }
  EXPECT_LT(worst, 0.75 + 5 * 0.2);  // deadband + 5 sigma of jitter (a 2-D Rayleigh tail of 4e-6)
  // Never a pose: the centre stays where it was set; a jump beyond snap_px re-centres at once.
  LoupeCentre d;
  d.reset(320, 240);
  d.update(false, 0, 0);
  EXPECT_DOUBLE_EQ(d.centre()[0], 320);
  d.update(true, 500, 240);
  EXPECT_DOUBLE_EQ(d.centre()[0], 500);
}

// The one letterbox (session 16): the mono window's blit, its loupe mapping and the HUD's
// image_to_window all place the video through letterbox(); the loupe's viewport is it.
TEST(Headset, LetterboxIsTheWindowMappingsViewport) {
  using dentar::live::letterbox;
  auto lb = letterbox(1280, 1024, 640, 480);  // wider than tall: bars above and below
  EXPECT_EQ(lb.x, 0);
  EXPECT_EQ(lb.w, 1280);
  EXPECT_EQ(lb.h, 960);
  EXPECT_EQ(lb.y, 32);
  lb = letterbox(1000, 480, 640, 480);  // bars left and right
  EXPECT_EQ(lb.x, 180);
  EXPECT_EQ(lb.y, 0);
  EXPECT_EQ(lb.w, 640);
  EXPECT_EQ(lb.h, 480);
  lb = letterbox(641, 483, 640, 480);  // odd margins: the extra pixel below / right
  EXPECT_EQ(lb.w, 641);
  EXPECT_EQ(lb.h, 481);
  EXPECT_EQ(lb.y, 1);
  EXPECT_EQ(letterbox(0, 480, 640, 480).w, 0);  // no window: an empty rectangle
  const double c[2] = {320, 240};
  for (const auto& [w, h] : {std::pair{1280, 1024}, std::pair{1000, 480}, std::pair{641, 483}}) {
    const auto m = dentar::live::make_window_mapping(w, h, cam640(), {}, c);
    const auto l = letterbox(w, h, 640, 480);
    EXPECT_EQ(m.vp[0], l.x);
    EXPECT_EQ(m.vp[1], l.y);
    EXPECT_EQ(m.vp[2], l.w);
    EXPECT_EQ(m.vp[3], l.h);
  }
}

// Issue 28 session 18: the headset's pre-warp drawn over a grid (eye_output.h WarpPass).
// The mesh's warp (texture coordinates linear over each cell's two triangles) against the
// exact mapping on every pixel of the Rift DK1's eyes, the bench's 640x480 camera
// (fx = 600 px), per channel: the sampled position's error in camera px and the same as a
// displacement on the panel, within the stated tolerances (docs/headset.md) for 16 px cells
// (the default) and 8 px cells; and the cull, checked on every pixel, drops only pixels that
// show no camera in any channel.
namespace {
dentar::calibration::CameraIntrinsics bench_cam() {
  dentar::calibration::CameraIntrinsics c;
  c.width = 640, c.height = 480, c.fx = c.fy = 600, c.cx = 319.5, c.cy = 239.5;
  return c;
}
}  // namespace

TEST(Headset, WarpGridMatchesTheExactWarpWithinTolerance) {
  auto h = read_headset_profile("assets/headsets/oculus_rift_dk1.json");
  ASSERT_TRUE(h.ok()) << h.error();
  const double c[2] = {330, 250};
  struct Case {
    int eye;
    bool stereo;
    double loupe;  // full view
    int cell_px;
    double tol_cam_px, tol_panel_px;
  };
  for (const Case k : {Case{0, true, 0, 16, 1.0, 0.4}, Case{1, true, 0, 16, 1.0, 0.4}, Case{0, false, 0, 16, 1.0, 0.4},
                       Case{1, true, 3, 16, 1.2, 0.5}, Case{0, true, 0, 8, 0.2, 0.08}, Case{1, true, 3, 8, 0.3, 0.13}}) {
    SCOPED_TRACE(::testing::Message() << "eye " << k.eye << (k.stereo ? " stereo" : " mono") << " loupe " << k.loupe
                                      << " cells " << k.cell_px << " px");
    LoupeView l;
    l.mag = k.loupe, l.inset = false;
    const EyeMapping m = make_eye_mapping(*h, k.eye, bench_cam(), k.stereo, l, c);
    const int cols = 640 / k.cell_px, rows = 800 / k.cell_px;
    const WarpGrid g = make_warp_grid(m, cols, rows);
    ASSERT_EQ(g.xy.size(), 2u * (cols + 1) * (rows + 1));
    const WarpError e = warp_grid_error(g, m);
    EXPECT_EQ(e.culled_seen, 0) << "the cull dropped pixels that show the camera";
    EXPECT_GT(e.pixels, 20000);
    for (int ch = 0; ch < 3; ++ch) {
      EXPECT_LT(e.max_cam_px[ch], k.tol_cam_px) << "channel " << ch;
      EXPECT_LT(e.max_panel_px[ch], k.tol_panel_px) << "channel " << ch;
      EXPECT_GT(e.max_cam_px[ch], k.tol_cam_px / 10) << "channel " << ch;  // a warp, not an affine map
    }
    // Without the loupe most of the eye shows no camera: the cull keeps under a third of the cells.
    if (k.loupe == 0) {
      EXPECT_LT(g.live_cells(), cols * rows / 3);
      EXPECT_GT(g.live_cells(), cols * rows / 20);
    }
  }
  LoupeView off;
  const EyeMapping m = make_eye_mapping(*h, 0, bench_cam(), true, off, c);
  // The check can fail: a 5x6 grid's warp is off by far more than the tolerance.
  const WarpError coarse = warp_grid_error(make_warp_grid(m, 5, 6), m);
  EXPECT_GT(std::max({coarse.max_cam_px[0], coarse.max_cam_px[1], coarse.max_cam_px[2]}), 4 * 1.0);
  EXPECT_EQ(coarse.culled_seen, 0);
  // The loupe's inset jumps at its border: every cell live.
  LoupeView inset;
  inset.mag = 3;
  const WarpGrid gi = make_warp_grid(make_eye_mapping(*h, 0, bench_cam(), true, inset, c), 40, 50);
  EXPECT_EQ(gi.live_cells(), 40 * 50);
  // A cull that drops cells showing the camera is seen (a camera far wider than the view).
  dentar::calibration::CameraIntrinsics wide = bench_cam();
  wide.fx = wide.fy = 150;
  const EyeMapping mw = make_eye_mapping(*h, 0, wide, true, off, c);
  WarpGrid gw = make_warp_grid(mw, 40, 50);
  std::fill(gw.live.begin(), gw.live.begin() + 40 * 5, std::uint8_t{0});
  EXPECT_GT(warp_grid_error(gw, mw).culled_seen, 1000);
}

// The lookup texture's warp (WarpPass::kLut): exact at the pixel centres in float, within
// the half float's rounding in RG16F.
TEST(Headset, WarpLookupMatchesTheExactWarp) {
  auto h = read_headset_profile("assets/headsets/oculus_rift_dk1.json");
  ASSERT_TRUE(h.ok()) << h.error();
  const double c[2] = {330, 250};
  const EyeMapping m = make_eye_mapping(*h, 0, bench_cam(), true, {}, c);
  const WarpError f = warp_lut_error(m, false), hf = warp_lut_error(m, true);
  EXPECT_GT(f.pixels, 20000);
  for (int ch = 0; ch < 3; ++ch) {
    EXPECT_LT(f.max_cam_px[ch], 1e-3);
    EXPECT_LT(hf.max_cam_px[ch], 0.5);
    EXPECT_GT(hf.max_cam_px[ch], f.max_cam_px[ch]);
  }
}
