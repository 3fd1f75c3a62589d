// Corner bias of the detector on ideally sampled tags (issue 16, "corner
// bias"): on the generator's footage libapriltag's corners lie ~0.09 px
// inside the true border square on every preset (docs/BENCHMARKS.md). Is
// that the detector or the renderer? Here the tag is drawn without GL: a
// high-resolution tag image warped by a homography at 8x the output size
// and box-filtered down (exact pixel integration), then the generator's
// optical blur (Gaussian, sigma 0.5 px). The mean outward error of the
// detected corners says what the detector itself does.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "dentar/ar/apriltags.h"
#include "dentar/ar/tag_detector.h"
#include "dentar/ar/tag_edge_fit.h"
#include "dentar/ar/tag_pattern_fit.h"
#include "dentar/ar/tracker.h"

namespace dentar::ar {
namespace {

struct BiasResult {
  double mean_outward_px = 0, median_err_px = 0;
  int tags = 0;
};

double srgb_encode(double c) { return c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1 / 2.4) - 0.055; }

// side_px: border-square side in the output image; blur_px: Gaussian sigma.
// srgb: the image is a camera's: the tag's light (ink 5 %, paper 100 %) is
// integrated and blurred in linear light, then sRGB-encoded; `response` is
// what the detector is told.
// linear_search: TagDetector::detect_in_linear_light instead of detect.
BiasResult measure(double side_px, double blur_px, int n, unsigned seed, bool srgb = false,
                   CameraResponse response = CameraResponse::kLinear, bool linear_search = false) {
  const TagFamily fam = TagFamily::create(TagFamilyId::kStandard41h12);
  const int ppc = 32, margin = 2 * ppc;
  const cv::Mat tex = render_tag_image(fam, 7, ppc, margin);
  // Border square corners in the texture (OpenCV px), libapriltag's order.
  const double lo = margin + fam.border_start() * ppc - 0.5;
  const double hi = margin + (fam.border_start() + fam.width_at_border()) * ppc - 0.5;
  const std::vector<cv::Point2f> src = {{float(lo), float(hi)}, {float(hi), float(hi)},
                                        {float(hi), float(lo)}, {float(lo), float(lo)}};
  TagDetectorOptions o;
  o.decimation = 1;
  o.response = response;
  auto det = TagDetector::create(o);
  EXPECT_TRUE(det.ok());
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  const int W = 160, S = 8;
  double outward = 0;
  std::vector<double> errs;
  BiasResult r;
  for (int i = 0; i < n; ++i) {
    // A square of the given side, turned and slightly foreshortened, at a
    // random sub-pixel position.
    const double a = M_PI * u(rng), sq = 1.0 + 0.15 * u(rng);
    const Eigen::Vector2d c(W / 2.0 + 3 * u(rng), W / 2.0 + 3 * u(rng));
    std::vector<Eigen::Vector2d> dst(4);
    const double h = side_px / 2;
    const double kx[4] = {-1, 1, 1, -1}, ky[4] = {1, 1, -1, -1};
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector2d p(kx[k] * h * sq, ky[k] * h / sq);
      dst[k] = c + Eigen::Rotation2Dd(a) * p;
    }
    std::vector<cv::Point2f> dst_hi;
    for (const auto& p : dst)
      dst_hi.emplace_back(float((p.x() + 0.5) * S - 0.5), float((p.y() + 0.5) * S - 0.5));
    const cv::Mat H = cv::getPerspectiveTransform(src, dst_hi);
    cv::Mat big, img;
    cv::warpPerspective(tex, big, H, cv::Size(W * S, W * S), cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                        cv::Scalar(255));
    cv::resize(big, img, cv::Size(W, W), 0, 0, cv::INTER_AREA);
    if (srgb) {
      cv::Mat lin;
      img.convertTo(lin, CV_32F, 0.95 / 255, 0.05);
      if (blur_px > 0) cv::GaussianBlur(lin, lin, cv::Size(0, 0), blur_px);
      for (int v = 0; v < W; ++v)
        for (int x = 0; x < W; ++x)
          img.at<std::uint8_t>(v, x) = static_cast<std::uint8_t>(
              std::lround(255 * srgb_encode(std::clamp<double>(0.8 * lin.at<float>(v, x), 0, 1))));
    } else if (blur_px > 0) {
      cv::GaussianBlur(img, img, cv::Size(0, 0), blur_px);
    }
    auto found = linear_search ? det->detect_in_linear_light(img) : det->detect(img);
    if (!found || found->size() != 1) continue;
    const DetectedTag& t = found->front();
    ++r.tags;
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector2d e = t.corners_px[k] - dst[k];
      outward += e.dot((dst[k] - c).normalized());
      errs.push_back(e.norm());
    }
  }
  if (r.tags == 0) return r;
  r.mean_outward_px = outward / (4.0 * r.tags);
  std::sort(errs.begin(), errs.end());
  r.median_err_px = errs[errs.size() / 2];
  return r;
}

TEST(CornerBias, LibapriltagOnIdeallySampledTags) {
  std::printf("[ bias ] side px | blur sigma px | tags | median corner error px | mean outward px\n");
  double worst = 0;
  for (double side : {18.0, 25.0, 40.0})
    for (double blur : {0.0, 0.5, 1.0}) {
      const BiasResult r = measure(side, blur, 40, 3);
      std::printf("[ bias ] %5.0f | %.1f | %d | %.3f | %+.3f\n", side, blur, r.tags, r.median_err_px,
                  r.mean_outward_px);
      EXPECT_GE(r.tags, 30) << side << " " << blur;
      // Measured 2026-11-25: |bias| <= 0.007 px up to the generator's 0.5 px
      // blur (0.08 px only with 1 px blur on 18 px tags); a change of corner
      // convention (the 0.5 px shift) or of libapriltag would show here.
      if (blur <= 0.5) {
        EXPECT_LT(std::abs(r.mean_outward_px), 0.03) << side << " " << blur;
        EXPECT_LT(r.median_err_px, 0.12) << side << " " << blur;
      }
      worst = std::max(worst, std::abs(r.mean_outward_px));
    }
  std::printf("[ bias ] largest |mean outward| %.3f px\n", worst);
}

// A camera's image (light blurred, then sRGB-encoded, as `dentar synth`
// renders since generator v2): libapriltag on the encoded grey levels puts
// the edges into the bright side (the white border ring grows: outline too
// large); told the response (kSrgb: the tracker's default) it fits them in
// linear light and the bias is gone.
TEST(CornerBias, SrgbEncodedTagsNeedTheSrgbResponse) {
  std::printf("[ bias srgb ] side px | blur sigma px | mean outward px: encoded image, response linear / srgb; "
              "ideal linear image\n");
  for (double side : {18.0, 25.0})
    for (double blur : {0.5, 1.0}) {
      const BiasResult lin = measure(side, blur, 30, 5, true, CameraResponse::kLinear);
      const BiasResult srgb = measure(side, blur, 30, 5, true, CameraResponse::kSrgb);
      const BiasResult ideal = measure(side, blur, 30, 5);
      std::printf("[ bias srgb ] %5.0f | %.1f | %+.3f / %+.3f | %+.3f\n", side, blur, lin.mean_outward_px,
                  srgb.mean_outward_px, ideal.mean_outward_px);
      ASSERT_GE(lin.tags, 25);
      ASSERT_GE(srgb.tags, 25);
      // Measured 2026-11-25: +0.29..+0.63 px taken as linear; with the sRGB
      // response within 0.02 px of the ideal linear image's own bias (which
      // is libapriltag's: -0.08 px for 18 px tags under a 1 px blur).
      EXPECT_GT(lin.mean_outward_px, 0.15) << side << " " << blur;
      EXPECT_LT(std::abs(srgb.mean_outward_px - ideal.mean_outward_px), 0.03) << side << " " << blur;
    }
}

// Edges of 32 px and longer take the refit's cheaper second window (centred
// on the first estimate rounded to 0.25 px, reusing the first window's
// levels: issue 24 session 14). On sRGB-encoded tags, where libapriltag's
// start is 0.3-0.6 px off and the second window does shift, their corners
// must be as unbiased as the small tags' exact second window makes them.
TEST(CornerBias, SrgbEncodedLargeTagsTakeTheSnappedSecondWindow) {
  std::printf("[ bias srgb large ] side px | blur sigma px | tags | mean outward px: response linear / srgb; "
              "ideal linear image | median corner error px (srgb)\n");
  for (double side : {40.0, 64.0}) {
    const double blur = 1.0;
    const BiasResult lin = measure(side, blur, 12, 9, true, CameraResponse::kLinear);
    const BiasResult srgb = measure(side, blur, 12, 9, true, CameraResponse::kSrgb);
    const BiasResult ideal = measure(side, blur, 12, 9);
    std::printf("[ bias srgb large ] %5.0f | %.1f | %d | %+.3f / %+.3f | %+.3f | %.3f\n", side, blur, srgb.tags,
                lin.mean_outward_px, srgb.mean_outward_px, ideal.mean_outward_px, srgb.median_err_px);
    ASSERT_GE(srgb.tags, 10);
    ASSERT_GE(ideal.tags, 10);
    // The encoding's bias is there to remove, and the refit removes it.
    EXPECT_GT(lin.mean_outward_px, 0.15) << side;
    EXPECT_LT(std::abs(srgb.mean_outward_px - ideal.mean_outward_px), 0.03) << side;
    EXPECT_LT(srgb.median_err_px, 0.12) << side;
  }
}

// The tracker's second look (TrackerOptions::linear_second_look): on small
// tags blurred in linear light and sRGB-encoded, libapriltag's search on the
// linear copy finds tags the search on the delivered image misses (the
// encoding lifts the blurred black border above libapriltag's tile
// threshold), and their corners, refit the same way, are as good.
TEST(CornerBias, LinearSearchFindsSmallBlurredSrgbTags) {
  std::printf("[ second look ] side px | blur sigma px | tags found of 30: delivered / linear copy | mean outward px\n");
  int delivered = 0, linear = 0;
  for (double side : {11.0, 12.0, 13.0})
    for (double blur : {1.0}) {
      const BiasResult d = measure(side, blur, 30, 7, true, CameraResponse::kSrgb);
      const BiasResult l = measure(side, blur, 30, 7, true, CameraResponse::kSrgb, true);
      std::printf("[ second look ] %5.0f | %.1f | %d / %d | %+.3f / %+.3f\n", side, blur, d.tags, l.tags,
                  d.mean_outward_px, l.mean_outward_px);
      delivered += d.tags;
      linear += l.tags;
      // Both sets of corners come from the same linear-light refit: the same
      // bias (libapriltag's own on tags this small, -0.17..-0.23 px, as on an
      // ideal linear image; measured within 0.01 px of each other).
      if (l.tags >= 10 && d.tags >= 10) {
        EXPECT_LT(std::abs(l.mean_outward_px - d.mean_outward_px), 0.03) << side << " " << blur;
      }
    }
  // Measured 2026-11-27 (11..13 px, sigma 1 px, 90 tags): 70 delivered,
  // 74 on the linear copy (on the GL footage the gap is larger: BENCHMARKS
  // issue 24 session 11).
  EXPECT_GT(linear, delivered);
  // Nothing to linearise with a linear response: refused, saying so.
  auto det = TagDetector::create({});
  ASSERT_TRUE(det.ok());
  const auto r = det->detect_in_linear_light(cv::Mat(32, 32, CV_8UC1, cv::Scalar(128)));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("linear"), std::string::npos);
}

TEST(CornerBias, CameraResponseNames) {
  EXPECT_EQ(*parse_camera_response("srgb"), CameraResponse::kSrgb);
  EXPECT_EQ(*parse_camera_response("linear"), CameraResponse::kLinear);
  EXPECT_STREQ(camera_response_name(CameraResponse::kSrgb), "srgb");
  const auto bad = parse_camera_response("gamma");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("gamma"), std::string::npos);
  EXPECT_NE(bad.error().find("auto, srgb, linear"), std::string::npos);
  TagDetectorOptions o;
  o.response = static_cast<CameraResponse>(7);
  EXPECT_NE(o.validate().find("response"), std::string::npos);
  // The tracker takes the station's measured response (issue 24); a bare
  // TagDetector refuses "auto" unresolved, and a station without a response
  // resolves to linear with a note.
  EXPECT_EQ(TrackerOptions{}.detector.response, CameraResponse::kAuto);
  EXPECT_EQ(*parse_camera_response("auto"), CameraResponse::kAuto);
  EXPECT_NE(parse_camera_response("curve").error().find("station"), std::string::npos);
  o.response = CameraResponse::kAuto;
  EXPECT_NE(o.validate().find("auto"), std::string::npos);
  StationScene st = default_station_scene();
  TagDetectorOptions d = TrackerOptions{}.detector;
  EXPECT_EQ(resolve_camera_response(d, st), "");
  EXPECT_EQ(d.response, CameraResponse::kSrgb);  // the built-in (generator's) camera is sRGB
  st.camera_provenance.response = {};
  d = TrackerOptions{}.detector;
  EXPECT_NE(resolve_camera_response(d, st).find("unknown"), std::string::npos);
  EXPECT_EQ(d.response, CameraResponse::kLinear);
  st.camera_provenance.response.kind = "curve";
  for (int i = 0; i < 256; ++i) st.camera_provenance.response.table.push_back(std::pow(i / 255.0, 2.0));
  d = TrackerOptions{}.detector;
  EXPECT_EQ(resolve_camera_response(d, st), "");
  EXPECT_EQ(d.response, CameraResponse::kCurve);
  EXPECT_EQ(d.response_curve.size(), 256u);
  EXPECT_TRUE(TagDetector::create(d).ok());
  d.response_curve[3] = 0.9;  // decreasing after it
  EXPECT_NE(d.validate().find("response_curve"), std::string::npos);
  EXPECT_EQ(TagDetectorOptions{}.response, CameraResponse::kLinear);
}

// Issue 28 session 21: a tag blurred along a straight motion (a continuous exposure: the
// motion integrated at 1/4 px in a 4x image, in linear light, then sRGB with read noise),
// searched by libapriltag as delivered, and its border square fitted to the edges where a
// prediction `pred_off_px` off (a shift along a random direction, plus up to 0.5 px per corner)
// puts it (fit_tag_border, reach = the offset + 4 px). The edge fit must find tags the detector
// misses, with the corners' largest error bounded.
//
// Session 22: with pattern_code >= 0 the cell-pattern fit (fit_tag_pattern) of code
// `pattern_code` (7 is the drawn tag's; another code is a wrong id) runs on the same image,
// given the blur vector 10 % longer than the drawn one and 10 deg off its direction.
// DENTAR_PATFIT_DIAG=1 prints each pattern fit's cell counts and correlation.
struct BlurRun {
  int plain = 0, fitted = 0, n = 0;
  std::vector<double> err_px;  // fitted: largest corner error per tag
  std::array<int, 5> status{};
  int pattern_fitted = 0;
  std::vector<double> pattern_err_px;
  // Per fitted tag: the RMS corner coordinate error (px) and the fit's stated sigma (corner_sigma_px).
  std::vector<double> pattern_coord_rms_px, pattern_sigma_px;
  // Per fitted tag: the largest corner difference between the analytic and the numeric
  // Jacobian's fits (TagPatternFitOptions::numeric_jacobian); -1 = the numeric one refused it.
  std::vector<double> pattern_numeric_diff_px;
  std::vector<double> pattern_numeric_coord_rms_px;  // the numeric fit's RMS corner coordinate error
  std::array<int, 6> pattern_status{};
};
BlurRun blurred_tags(double side_px, double blur_len_px, double pred_off_px, int n, unsigned seed,
                     int pattern_code = -1) {
  const TagFamily fam = TagFamily::create(TagFamilyId::kStandard41h12);
  const int ppc = 32, margin = 2 * ppc, code = 7;
  const cv::Mat tex = render_tag_image(fam, code, ppc, margin);
  const double lo = margin + fam.border_start() * ppc - 0.5;
  const double hi = margin + (fam.border_start() + fam.width_at_border()) * ppc - 0.5;
  const std::vector<cv::Point2f> src = {{float(lo), float(hi)}, {float(hi), float(hi)},
                                        {float(hi), float(lo)}, {float(lo), float(lo)}};
  const double outer_extent = 0.5 * (fam.total_width() - fam.width_at_border()) / double(fam.width_at_border());
  TagDetectorOptions o;
  o.decimation = 1;
  o.response = CameraResponse::kSrgb;
  auto det = TagDetector::create(o);
  EXPECT_TRUE(det.ok());
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> noise(0, 1.5);
  const int W = 128, S = 4;
  BlurRun r;
  for (int i = 0; i < n; ++i, ++r.n) {
    const double a = M_PI * u(rng), sq = 1.0 + 0.15 * u(rng), dir = M_PI * u(rng);
    const Eigen::Vector2d c(W / 2.0 + 3 * u(rng), W / 2.0 + 3 * u(rng));
    const Eigen::Vector2d blur = blur_len_px * Eigen::Vector2d(std::cos(dir), std::sin(dir));
    std::array<Eigen::Vector2d, 4> dst;
    const double h = side_px / 2;
    const double kx[4] = {-1, 1, 1, -1}, ky[4] = {1, 1, -1, -1};
    for (int k = 0; k < 4; ++k) dst[k] = c + Eigen::Rotation2Dd(a) * Eigen::Vector2d(kx[k] * h * sq, ky[k] * h / sq);
    // The exposure: the square swept from c - blur/2 to c + blur/2, every 1/4 px (whole pixels of
    // the 4x image: the tag warped once, then shifted copies summed).
    const int steps = static_cast<int>(std::ceil(S * blur_len_px)) + 1;
    std::vector<cv::Point2f> dst_hi;
    for (const auto& p : dst) dst_hi.emplace_back(float((p.x() + 0.5) * S - 0.5), float((p.y() + 0.5) * S - 0.5));
    cv::Mat big, lin, padded;
    cv::warpPerspective(tex, big, cv::getPerspectiveTransform(src, dst_hi), cv::Size(W * S, W * S), cv::INTER_LINEAR,
                        cv::BORDER_CONSTANT, cv::Scalar(255));
    big.convertTo(lin, CV_32F, 0.95 / 255, 0.05);
    const int pad = static_cast<int>(std::ceil(0.5 * S * blur_len_px)) + 2;
    cv::copyMakeBorder(lin, padded, pad, pad, pad, pad, cv::BORDER_CONSTANT, cv::Scalar(1.0));
    cv::Mat acc(W * S, W * S, CV_32F, cv::Scalar(0));
    for (int j = 0; j < steps; ++j) {
      const Eigen::Vector2d off = (static_cast<double>(j) / (steps - 1) - 0.5) * blur * S;
      const int dx = static_cast<int>(std::lround(off.x())), dy = static_cast<int>(std::lround(off.y()));
      acc += padded(cv::Rect(pad - dx, pad - dy, W * S, W * S));
    }
    acc *= 1.0 / steps;
    cv::resize(acc, lin, cv::Size(W, W), 0, 0, cv::INTER_AREA);
    cv::GaussianBlur(lin, lin, cv::Size(0, 0), 0.5);
    cv::Mat img(W, W, CV_8U);
    for (int v = 0; v < W; ++v)
      for (int x = 0; x < W; ++x)
        img.at<std::uint8_t>(v, x) = static_cast<std::uint8_t>(std::clamp<long>(
            std::lround(255 * srgb_encode(std::clamp<double>(0.8 * lin.at<float>(v, x), 0, 1)) + noise(rng)), 0, 255));
    auto plain = det->detect(img);
    EXPECT_TRUE(plain.ok());
    if (!plain) continue;
    for (const DetectedTag& t : *plain) r.plain += t.id == code;
    // The prediction: off by pred_off_px along a random direction, each corner by up to 0.5 px more.
    const double pd = M_PI * u(rng);
    std::array<Eigen::Vector2d, 4> pred;
    for (int k = 0; k < 4; ++k)
      pred[k] = dst[k] + pred_off_px * Eigen::Vector2d(std::cos(pd), std::sin(pd)) + 0.35 * Eigen::Vector2d(u(rng), u(rng));
    if (pattern_code >= 0) {
      std::array<Eigen::Vector2d, 4> bv;
      const Eigen::Vector2d pb = 1.1 * (Eigen::Rotation2Dd(10 * M_PI / 180) * blur);
      for (auto& v : bv) v = pb;
      const TagPatternFit pf = fit_tag_pattern(img, fam.cells(pattern_code), fam.border_start(), fam.width_at_border(), pred,
                                               bv, pred_off_px + 4, outer_extent, {}, {}, &det->to_linear());
      ++r.pattern_status[static_cast<std::size_t>(pf.status)];
      if (std::getenv("DENTAR_PATFIT_DIAG"))
        std::printf("diag code %d status %d right %d wrong %d corr %.3f px %d it %d\n", pattern_code, int(pf.status),
                    pf.right_cells, pf.wrong_cells, pf.correlation, pf.pixels, pf.iterations);
      if (pf.status == TagPatternFitStatus::kFitted) {
        ++r.pattern_fitted;
        double e = 0;
        for (int k = 0; k < 4; ++k) e = std::max(e, (pf.corners_px[k] - dst[k]).norm());
        r.pattern_err_px.push_back(e);
        double e2 = 0;
        for (int k = 0; k < 4; ++k) e2 += (pf.corners_px[k] - dst[k]).squaredNorm();
        r.pattern_coord_rms_px.push_back(std::sqrt(e2 / 8));
        r.pattern_sigma_px.push_back(pf.corner_sigma_px);
        TagPatternFitOptions numeric;
        numeric.numeric_jacobian = true;
        const TagPatternFit pn = fit_tag_pattern(img, fam.cells(pattern_code), fam.border_start(), fam.width_at_border(),
                                                 pred, bv, pred_off_px + 4, outer_extent, {}, numeric, &det->to_linear());
        double dn = pn.status == TagPatternFitStatus::kFitted ? 0.0 : -1.0;
        for (int k = 0; k < 4 && dn >= 0; ++k) dn = std::max(dn, (pf.corners_px[k] - pn.corners_px[k]).norm());
        r.pattern_numeric_diff_px.push_back(dn);
        double en = 0;
        for (int k = 0; k < 4; ++k) en += (pn.corners_px[k] - dst[k]).squaredNorm();
        r.pattern_numeric_coord_rms_px.push_back(std::sqrt(en / 8));
      }
    }
    const TagEdgeFit fit =
        fit_tag_border(img, pred, /*inside_bright=*/true, fam.width_at_border(), pred_off_px + 4, outer_extent, {}, {}, &det->to_linear());
    ++r.status[static_cast<std::size_t>(fit.status)];
    if (fit.status != TagEdgeFitStatus::kFitted) continue;
    ++r.fitted;
    double e = 0;
    for (int k = 0; k < 4; ++k) e = std::max(e, (fit.corners_px[k] - dst[k]).norm());
    r.err_px.push_back(e);
  }
  return r;
}

TEST(CornerBias, EdgeFitFindsMotionBlurredTags) {
  std::printf("[ edgefit ] side px | blur px | prediction off px | found: libapriltag / edge fit of n | edge fit "
              "largest corner error p50 / max px | refused: ambiguous / no edges / off prediction\n");
  // Measured (session 21, seed 11, 24 draws, prediction 6 px off): side 20 px blur 0 / 3 / 6 px:
  // libapriltag 24 / 23 / 4, edge fit 24 / 24 / 14, largest corner error p50 0.15 / 0.41 / 1.47 px,
  // max 0.46 / 0.70 / 1.77; side 30 px blur 6 px: 13 -> 24, 0.43 / 1.25 px; 10 px: 0 -> 2, 1.79 px.
  // Two cases run here: the one where libapriltag misses half and the edge fit finds them, and a
  // light blur (bound tighter).
  struct Case {
    double side, len, max_err;
    int more;
  };
  for (const Case& c : {Case{30.0, 6.0, 1.5, 6}, Case{20.0, 3.0, 1.0, 0}}) {
    const BlurRun r = blurred_tags(c.side, c.len, 6.0, 24, 11);
    std::vector<double> e = r.err_px;
    std::sort(e.begin(), e.end());
    std::printf("[ edgefit ] %4.0f | %4.0f | 6 | %d / %d of %d | %.2f / %.2f | %d / %d / %d\n", c.side, c.len, r.plain,
                r.fitted, r.n, e.empty() ? NAN : e[e.size() / 2], e.empty() ? NAN : e.back(), r.status[1], r.status[2],
                r.status[3]);
    EXPECT_EQ(r.status[4], 0);
    EXPECT_GE(r.fitted, r.plain + c.more) << c.side << " " << c.len;
    ASSERT_FALSE(e.empty());
    EXPECT_LT(e.back(), c.max_err) << c.side << " " << c.len;
  }
}

// Two tags' regions overlap: the fit is refused (a wrong square is worse than none), even where
// the image shows one clean tag; the same square alone is fitted.
TEST(CornerBias, EdgeFitRefusesAnotherSquareWithinReach) {
  const TagFamily fam = TagFamily::create(TagFamilyId::kStandard41h12);
  const int ppc = 6, margin = 40;
  const cv::Mat img = render_tag_image(fam, 3, ppc, margin);  // a sharp 30 px border square
  const double lo = margin + fam.border_start() * ppc - 0.5;
  const double hi = margin + (fam.border_start() + fam.width_at_border()) * ppc - 0.5;
  const std::array<Eigen::Vector2d, 4> truth = {Eigen::Vector2d(lo, hi), Eigen::Vector2d(hi, hi),
                                                Eigen::Vector2d(hi, lo), Eigen::Vector2d(lo, lo)};
  std::array<Eigen::Vector2d, 4> pred = truth;
  for (auto& p : pred) p += Eigen::Vector2d(2.5, -1.5);
  const double outer = 0.4;
  const TagEdgeFit alone = fit_tag_border(img, pred, true, 5, 6.0, outer, {});
  ASSERT_EQ(alone.status, TagEdgeFitStatus::kFitted) << tag_edge_fit_status_name(alone.status);
  for (int k = 0; k < 4; ++k) EXPECT_LT((alone.corners_px[k] - truth[k]).norm(), 0.3) << k;
  // Another tag predicted 40 px to the right: its cells (12 px beyond its square) come within the
  // reach (6 px) of this one's cells (12 px beyond).
  std::array<Eigen::Vector2d, 4> other = pred;
  for (auto& p : other) p += Eigen::Vector2d(40, 0);
  EXPECT_EQ(fit_tag_border(img, pred, true, 5, 6.0, outer, {other}).status, TagEdgeFitStatus::kAmbiguous);
  // Far enough (70 px): fitted again.
  for (auto& p : other) p += Eigen::Vector2d(30, 0);
  EXPECT_EQ(fit_tag_border(img, pred, true, 5, 6.0, outer, {other}).status, TagEdgeFitStatus::kFitted);
  // The wrong polarity (tag36h11's: dark inside) finds no border ring here.
  EXPECT_NE(fit_tag_border(img, pred, false, 5, 6.0, outer, {}).status, TagEdgeFitStatus::kFitted);
  // Bad input is refused naming it.
  std::array<Eigen::Vector2d, 4> nan_pred = pred;
  nan_pred[2].x() = NAN;
  const TagEdgeFit b1 = fit_tag_border(img, nan_pred, true, 5, 6.0, outer, {});
  EXPECT_EQ(b1.status, TagEdgeFitStatus::kBadInput);
  EXPECT_NE(b1.message.find("corner"), std::string::npos) << b1.message;
  const TagEdgeFit b2 = fit_tag_border(img, pred, true, 5, -1.0, outer, {});
  EXPECT_NE(b2.message.find("reach_px"), std::string::npos) << b2.message;
  TagEdgeFitOptions bo;
  bo.max_rms_px = NAN;
  EXPECT_NE(fit_tag_border(img, pred, true, 5, 6.0, outer, {}, bo).message.find("max_rms_px"), std::string::npos);
  EXPECT_EQ(fit_tag_border(cv::Mat(), pred, true, 5, 6.0, outer, {}).status, TagEdgeFitStatus::kBadInput);
}

// Issue 28 session 22: the cell-pattern fit on tags blurred wider than the border ring, where
// libapriltag and the edge fit find (almost) none: it must find most, corners within a bound;
// the pattern of another id in the same place must be refused.
TEST(CornerBias, PatternFitFindsTagsTheDetectorMissesAndRefusesAWrongId) {
  std::printf("[ patfit ] side px | blur px | found: libapriltag / edge fit / pattern fit of n | pattern fit largest "
              "corner error p50 / max px | refused: overlap / no fit / wrong cells / off prediction\n");
  struct Case {
    double side, len, max_err;
    int min_found;
  };
  // 16 draws per case, 8 of another id (test time: the rendering dominates). Measured with 24 / 12
  // (docs/BENCHMARKS.md, issue 28 session 22): 24 / 24 found in both cases, max error 0.73 / 0.37 px.
  for (const Case& c : {Case{30.0, 10.0, 1.0, 11}, Case{20.0, 6.0, 1.0, 11}}) {
    const BlurRun r = blurred_tags(c.side, c.len, 6.0, 16, 11, 7);
    std::vector<double> e = r.pattern_err_px;
    std::sort(e.begin(), e.end());
    std::printf("[ patfit ] %4.0f | %4.0f | %d / %d / %d of %d | %.2f / %.2f | %d / %d / %d / %d\n", c.side, c.len,
                r.plain, r.fitted, r.pattern_fitted, r.n, e.empty() ? NAN : e[e.size() / 2], e.empty() ? NAN : e.back(),
                r.pattern_status[1], r.pattern_status[2], r.pattern_status[3], r.pattern_status[4]);
    {
      // The stated corner sigma against the error (Monte Carlo over the draws): RMS of each
      // tag's coordinate error over RMS of its stated sigma.
      double se = 0, ss = 0;
      for (std::size_t i = 0; i < r.pattern_sigma_px.size(); ++i) {
        se += r.pattern_coord_rms_px[i] * r.pattern_coord_rms_px[i];
        ss += r.pattern_sigma_px[i] * r.pattern_sigma_px[i];
      }
      const double n = std::max<double>(1, r.pattern_sigma_px.size());
      std::printf("[ patfit ] corner error RMS %.3f px, stated sigma RMS %.3f px (error / stated %.2f)\n",
                  std::sqrt(se / n), std::sqrt(ss / n), std::sqrt(se / std::max(ss, 1e-30)));
      // The analytic Jacobian's fit against the numeric one's (session 22's), same draws: the
      // same tags fitted, no less accurate (RMS corner error within 10 %), corners within 0.25 px
      // (measured: 0.12 / 0.03 px, RMS 0.213 against 0.208 and 0.119 against 0.119 px; the two
      // stop at different points of a flat optimum: the analytic gradient of the bilinear pattern
      // is piecewise constant, the 0.2 px forward difference smooths it).
      double worst = 0, sn = 0;
      for (std::size_t i = 0; i < r.pattern_numeric_diff_px.size(); ++i) {
        EXPECT_GE(r.pattern_numeric_diff_px[i], 0.0) << "the numeric Jacobian's fit refused a tag the analytic one fitted";
        worst = std::max(worst, r.pattern_numeric_diff_px[i]);
        sn += r.pattern_numeric_coord_rms_px[i] * r.pattern_numeric_coord_rms_px[i];
      }
      std::printf("[ patfit ] analytic against numeric Jacobian: largest corner difference %.3f px over %zu tags, "
                  "RMS corner error %.3f against %.3f px\n",
                  worst, r.pattern_numeric_diff_px.size(), std::sqrt(se / n), std::sqrt(sn / n));
      EXPECT_LT(worst, 0.25);
      EXPECT_LE(std::sqrt(se / n), 1.1 * std::sqrt(sn / n));
    }
    EXPECT_EQ(r.pattern_status[5], 0);
    EXPECT_GE(r.pattern_fitted, c.min_found) << c.side << " " << c.len;
    EXPECT_GE(r.pattern_fitted, r.plain + 8) << c.side << " " << c.len;
    ASSERT_FALSE(e.empty());
    EXPECT_LT(e.back(), c.max_err) << c.side << " " << c.len;
    // Another id's cells where the prediction puts this tag: refused every time.
    const BlurRun w = blurred_tags(c.side, c.len, 6.0, 8, 13, 8);
    std::printf("[ patfit ] wrong id: fitted %d of %d, refused: no fit / wrong cells / off prediction %d / %d / %d\n",
                w.pattern_fitted, w.n, w.pattern_status[2], w.pattern_status[3], w.pattern_status[4]);
    EXPECT_EQ(w.pattern_fitted, 0);
  }
  // Bad input is refused naming it.
  const TagFamily fam = TagFamily::create(TagFamilyId::kStandard41h12);
  const cv::Mat img(64, 64, CV_8UC1, cv::Scalar(128));
  std::array<Eigen::Vector2d, 4> pred = {Eigen::Vector2d(20, 44), Eigen::Vector2d(44, 44), Eigen::Vector2d(44, 20),
                                         Eigen::Vector2d(20, 20)};
  std::array<Eigen::Vector2d, 4> blur;
  for (auto& v : blur) v.setZero();
  blur[1].x() = NAN;
  const TagPatternFit b1 = fit_tag_pattern(img, fam.cells(7), fam.border_start(), fam.width_at_border(), pred, blur, 4, 0.4, {});
  EXPECT_EQ(b1.status, TagPatternFitStatus::kBadInput);
  EXPECT_NE(b1.message.find("blur"), std::string::npos) << b1.message;
  blur[1].x() = 0;
  EXPECT_NE(fit_tag_pattern(img, fam.cells(7), 5, 5, pred, blur, 4, 0.4, {}).message.find("border_start"), std::string::npos);
  TagPatternFitOptions po;
  po.max_subsamples = 4;
  EXPECT_NE(fit_tag_pattern(img, fam.cells(7), fam.border_start(), fam.width_at_border(), pred, blur, 4, 0.4, {}, po)
                .message.find("max_subsamples"),
            std::string::npos);
  // Another square overlapping: refused before any fit.
  std::array<Eigen::Vector2d, 4> other = pred;
  for (auto& p : other) p += Eigen::Vector2d(20, 0);
  EXPECT_EQ(fit_tag_pattern(img, fam.cells(7), fam.border_start(), fam.width_at_border(), pred, blur, 4, 0.4, {other}).status,
            TagPatternFitStatus::kOverlap);
}

}  // namespace
}  // namespace dentar::ar
