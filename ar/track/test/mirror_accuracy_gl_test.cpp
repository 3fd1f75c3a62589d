// The mirror's pose accuracy and where its error comes from (issue 16, third
// part): is the generator's tag edge where its truth says (measured in linear
// light on large, clean tags), and how the detected corners of the mirror's
// roof-paddle tags differ from the true ones -- per tag, per view angle, per
// edge (a uniform outline growth/shrink is a bias, the rest is noise) -- and
// what that makes of the mirror centre's pose.
//
// Default: 640x480, 60 frames of `standard`, seed 5 (the figures of
// docs/BENCHMARKS.md, asserted as regression bounds). DENTAR_PRESET_SIZE /
// DENTAR_PRESET_FRAMES / DENTAR_PRESETS print the same tables for other
// sizes and presets without asserting.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <optional>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>
#include <ctime>

#include "dentar/ar/apriltags.h"
#include "dentar/ar/bundle_pose.h"
#include "dentar/ar/camera_model.h"
#include "dentar/ar/mirror_rim.h"
#include "dentar/ar/pose_filter.h"
#include "dentar/ar/pose_uncertainty.h"
#include "dentar/ar/srgb.h"
#include "dentar/ar/synth.h"
#include "dentar/ar/tracker.h"
#include "accuracy_test_util.h"
#include "gl_test_context.h"

namespace dentar::ar {
namespace {

using Iso = Eigen::Isometry3d;
using V2 = Eigen::Vector2d;

using namespace test;  // accuracy_test_util.h: footage, run size, error figures

double stdev(const std::vector<double>& v) {
  const double m = mean(v);
  double s = 0;
  for (double x : v) s += (x - m) * (x - m);
  return v.size() < 2 ? NAN : std::sqrt(s / (v.size() - 1));
}

bool preset_wanted(SynthPreset p, bool by_default) {
  const char* only = std::getenv("DENTAR_PRESETS");
  if (!only) return by_default;
  return std::string(only).find(synth_preset_name(p)) != std::string::npos;
}

// The preset test's footage (accuracy_options, the same station): comparable figures.
const Footage& footage(SynthPreset preset) {
  static std::map<int, Footage> cache;
  auto it = cache.find(static_cast<int>(preset));
  if (it != cache.end()) return it->second;
  SynthOptions o = accuracy_options(preset);
  if (std::getenv("DENTAR_NO_DISTORTION")) o.distortion = false;  // diagnosis: a pinhole camera
  if (std::getenv("DENTAR_NO_NOISE")) o.read_noise_dn = o.shot_noise_gain = 0;  // diagnosis
  return cache[static_cast<int>(preset)] = make_footage(default_station_scene(), o);
}

// ---- 1. the generator's edges in linear light ---------------------------------

// Bilinear sample of a CV_32F image (OpenCV pixel centres).
double sample(const cv::Mat& im, V2 p) {
  const int x = static_cast<int>(std::floor(p.x())), y = static_cast<int>(std::floor(p.y()));
  if (x < 0 || y < 0 || x + 1 >= im.cols || y + 1 >= im.rows) return NAN;
  const double a = p.x() - x, b = p.y() - y;
  return (1 - b) * ((1 - a) * im.at<float>(y, x) + a * im.at<float>(y, x + 1)) +
         b * ((1 - a) * im.at<float>(y + 1, x) + a * im.at<float>(y + 1, x + 1));
}

// Where the border square's edge lies across one profile, in linear light:
// tagStandard41h12's square has a white ring inside and a black ring outside,
// one cell each. Over a window of +-w around the true edge, the white
// fraction (I - black) / (white - black) integrates to w + shift for an edge
// shifted outward by `shift`, whatever the (energy-preserving) blur. Levels
// from the ring centres.
double edge_shift(const cv::Mat& lin, V2 p, V2 n_out, double cell_px) {
  const double w = 0.5 * cell_px;
  const double white = sample(lin, p - n_out * w), black = sample(lin, p + n_out * w);
  if (!(white - black > 0.05)) return NAN;
  double s = 0;
  const double step = 0.05;
  for (double x = -w + step / 2; x < w; x += step) {
    const double v = sample(lin, p + n_out * x);
    if (std::isnan(v)) return NAN;
    s += (v - black) / (white - black) * step;
  }
  return s - w;
}

struct EdgeStats {
  std::vector<double> lin, enc;  // outward shift px: linear light / the encoded image taken as linear
};

EdgeStats generator_edges(const Footage& fo, double min_side_px) {
  EdgeStats r;
  const TagFamily fam = TagFamily::create(fo.station.family);
  cv::Mat gray, lin, enc;
  for (const SynthFrame& f : fo.frames) {
    cv::cvtColor(f.image, gray, cv::COLOR_BGR2GRAY);
    gray.convertTo(enc, CV_32F, 1.0 / 255);
    lin.create(enc.size(), CV_32F);
    for (int v = 0; v < enc.rows; ++v)
      for (int u = 0; u < enc.cols; ++u) lin.at<float>(v, u) = static_cast<float>(srgb_decode(enc.at<float>(v, u)));
    for (const TagTruth& t : f.truth.tags) {
      if (!t.in_image || t.visible_fraction < 0.999 || t.side_px < min_side_px) continue;
      if (t.view_angle_rad > 50 * M_PI / 180) continue;
      V2 c = V2::Zero();
      for (const V2& q : t.corners_px) c += q / 4;
      for (int k = 0; k < 4; ++k) {
        const V2 a = t.corners_px[k], b = t.corners_px[(k + 1) % 4];
        V2 n(-(b - a).y(), (b - a).x());
        n.normalize();
        if (n.dot((a + b) / 2 - c) < 0) n = -n;
        const double cell = (b - a).norm() / fam.width_at_border();
        if (cell < 6) continue;
        for (double s = 0.3; s <= 0.7; s += 0.05) {
          const V2 p = a + s * (b - a);
          const double dl = edge_shift(lin, p, n, cell), de = edge_shift(enc, p, n, cell);
          if (!std::isnan(dl)) r.lin.push_back(dl);
          if (!std::isnan(de)) r.enc.push_back(de);
        }
      }
    }
  }
  return r;
}

// Large tags (1280x720, the mirror in the mouth), no noise, no vignetting, no
// lens distortion (straight edges), the generator's own 0.5 px optical blur:
// in linear light the border square's edge must sit on the true edge. A
// camera integrates light linearly and then encodes it (sRGB here), so this
// is where a physically rendered edge lies.
TEST(MirrorAccuracy, GeneratorEdgesSitOnTheTruthInLinearLight) {
  DENTAR_GL_TEST_CONTEXT();
  SynthOptions o = synth_preset(SynthPreset::kMirror);
  o.frames = 4;
  o.fps = 2;
  o.width = 1280;
  o.height = 720;
  o.seed = 5;
  o.bur_samples = 1000;
  o.read_noise_dn = 0;
  o.shot_noise_gain = 0;
  o.vignetting = 0;
  o.exposure_variation = 0;
  o.distortion = false;
  const Footage fo = make_footage(default_station_scene(), o);
  ASSERT_TRUE(fo.error.empty()) << fo.error;
  const EdgeStats e = generator_edges(fo, 40);
  std::printf("[ edges ] generator v%d, 1280x720 clean: %zu profiles; outward shift of the border square's edge: "
              "linear light mean %+.3f px (sd %.3f), the encoded image taken as linear %+.3f px (sd %.3f)\n",
              kSynthGeneratorVersion, e.lin.size(), mean(e.lin), stdev(e.lin), mean(e.enc), stdev(e.enc));
  ASSERT_GT(e.lin.size(), 200u);
  // Generator v1 (tag texture taken as sRGB after filtering, blur on the
  // encoded image): -0.2x px in linear light (the black ring too wide).
  EXPECT_LT(std::abs(mean(e.lin)), 0.03);
}

// ---- 2. the mirror's corners and pose ------------------------------------------

// The detector variants compared: libapriltag on the encoded image (before
// issue 16's third part), on the sRGB-decoded image, and on the decoded image
// with the edges re-fitted in linear light (TagDetectorOptions).
struct DetVariant {
  const char* name;
  CameraResponse response;
  bool refit;
};
const DetVariant kVariants[] = {{"linear", CameraResponse::kLinear, false},
                                {"srgb", CameraResponse::kSrgb, false},
                                {"srgb+refit", CameraResponse::kSrgb, true}};

struct EdgeSample {
  int tag = 0;
  double angle_deg = 0, side_px = 0;
  double foreshortening = 1;  // image length of the neighbouring edges / this edge's
  double outward_px = 0;      // the detected edge's offset along its outward normal
  double tag_mean_px = 0;     // the same tag's mean over its four edges (outline growth)
};

struct MirrorCorners {
  std::vector<EdgeSample> edges;
  std::vector<double> corner_err_px;
  std::vector<double> dx_px, dy_px, radial_px;  // corner error components; radial: from the image centre
  std::vector<double> det_mm, det_deg, true_mm;  // mirror centre from detected / true corners
  // The same from the detected corners with each tag's outline growth
  // removed (flat) and with a uniform -0.09 px outline added (shrunk).
  std::vector<double> flat_mm, shrunk_mm;
  std::vector<double> sigma1_mm;                 // centre's sigma for 1 px corner noise
};

MirrorCorners mirror_corners(const Footage& fo, const DetVariant& var, bool on_mirror = true) {
  MirrorCorners r;
  TagDetectorOptions d;
  d.families = {fo.station.family};
  d.decimation = 1;
  d.response = var.response;
  d.refit_edges_linear = var.refit;
  auto det = TagDetector::create(d);
  EXPECT_TRUE(det.ok());
  if (!det) return r;
  const TagBundle bundle = on_mirror ? mirror_bundle(fo.station) : mannequin_bundle(fo.station);
  const Iso T_mtag_mir = fo.station.calibration.T_mtag_mir;
  cv::Mat gray;
  for (const SynthFrame& f : fo.frames) {
    cv::cvtColor(f.image, gray, cv::COLOR_BGR2GRAY);
    auto tags = det->detect(gray);
    if (!tags) continue;
    std::vector<DetectedTag> mine, truth_tags, flat, shrunk;
    for (const DetectedTag& dt : *tags) {
      const TagTruth* tt = nullptr;
      for (const TagTruth& g : f.truth.tags)
        if (g.on_mirror == on_mirror && g.id == dt.id && g.in_image) tt = &g;
      if (!tt) continue;
      mine.push_back(dt);
      DetectedTag tr = dt;
      tr.corners_px = tt->corners_px;
      truth_tags.push_back(tr);
      V2 c = V2::Zero();
      for (const V2& q : tt->corners_px) c += q / 4;
      EdgeSample e[4];
      double tag_mean = 0;
      for (int k = 0; k < 4; ++k) {
        r.corner_err_px.push_back((dt.corners_px[k] - tt->corners_px[k]).norm());
        const V2 ce = dt.corners_px[k] - tt->corners_px[k];
        const V2 ctr(0.5 * (fo.station.calibration.camera.width - 1), 0.5 * (fo.station.calibration.camera.height - 1));
        r.dx_px.push_back(ce.x());
        r.dy_px.push_back(ce.y());
        r.radial_px.push_back(ce.dot((tt->corners_px[k] - ctr).normalized()));
        const int k1 = (k + 1) % 4;
        const V2 a = tt->corners_px[k], b = tt->corners_px[k1];
        V2 n(-(b - a).y(), (b - a).x());
        n.normalize();
        if (n.dot((a + b) / 2 - c) < 0) n = -n;
        e[k].tag = dt.id;
        e[k].angle_deg = tt->view_angle_rad * 180 / M_PI;
        e[k].side_px = tt->side_px;
        const double perp = 0.5 * ((tt->corners_px[(k + 3) % 4] - a).norm() + (tt->corners_px[(k + 2) % 4] - b).norm());
        e[k].foreshortening = perp / std::max(1e-9, (b - a).norm());
        e[k].outward_px = 0.5 * ((dt.corners_px[k] - a).dot(n) + (dt.corners_px[k1] - b).dot(n));
        tag_mean += e[k].outward_px / 4;
      }
      for (auto& x : e) {
        x.tag_mean_px = tag_mean;
        r.edges.push_back(x);
      }
      DetectedTag fl = dt, sh = dt;
      for (int k = 0; k < 4; ++k) {
        V2 nsum = V2::Zero();
        for (int j : {(k + 3) % 4, k}) {
          const V2 a = tt->corners_px[j], b = tt->corners_px[(j + 1) % 4];
          V2 n(-(b - a).y(), (b - a).x());
          n.normalize();
          if (n.dot((a + b) / 2 - c) < 0) n = -n;
          nsum += n;
        }
        fl.corners_px[k] -= tag_mean * nsum;
        sh.corners_px[k] -= 0.09 * nsum;
      }
      flat.push_back(fl);
      shrunk.push_back(sh);
    }
    if (mine.empty()) continue;
    // The mirror: its centre (what the reflection is drawn from); the
    // mannequin: its origin.
    const Iso T_cam_body = on_mirror ? f.truth.T_cam_mtag : f.truth.T_cam_man;
    const Iso T_body_pt = on_mirror ? T_mtag_mir : Iso::Identity();
    const Iso T_cam_pt = T_cam_body * T_body_pt;
    const BundlePose a = estimate_bundle_pose(bundle, fo.station.calibration.camera, mine, {}, T_cam_body);
    const BundlePose b = estimate_bundle_pose(bundle, fo.station.calibration.camera, truth_tags, {}, T_cam_body);
    if (!a.ok() || !b.ok()) continue;
    r.det_mm.push_back(trans_mm(a.T_cam_body * T_body_pt, T_cam_pt));
    r.det_deg.push_back(rot_deg(a.T_cam_body * T_body_pt, T_cam_pt));
    r.true_mm.push_back(trans_mm(b.T_cam_body * T_body_pt, T_cam_pt));
    r.sigma1_mm.push_back(point_sigma_m(a.covariance_per_px2, a.T_cam_body, T_body_pt.translation()) * 1e3);
    const BundlePose fp = estimate_bundle_pose(bundle, fo.station.calibration.camera, flat, {}, T_cam_body);
    const BundlePose sp = estimate_bundle_pose(bundle, fo.station.calibration.camera, shrunk, {}, T_cam_body);
    if (fp.ok()) r.flat_mm.push_back(trans_mm(fp.T_cam_body * T_body_pt, T_cam_pt));
    if (sp.ok()) r.shrunk_mm.push_back(trans_mm(sp.T_cam_body * T_body_pt, T_cam_pt));
  }
  return r;
}

template <class Key>
void print_edge_bins(const char* what, const std::vector<EdgeSample>& s, Key key, std::vector<double> edges) {
  std::printf("| %s | edges | mean outward px (bias) | sd px | sd within tag px (noise) |\n|---|---|---|---|---|\n", what);
  for_each_bin(s, key, std::move(edges), [](double lo, double hi, const std::vector<const EdgeSample*>& in) {
    std::vector<double> o, w;
    for (const EdgeSample* e : in) {
      o.push_back(e->outward_px);
      w.push_back(e->outward_px - e->tag_mean_px);
    }
    std::printf("| [%g, %g) | %zu | %+.3f | %.3f | %.3f |\n", lo, hi, o.size(), mean(o), stdev(o),
                stdev(w) * std::sqrt(4.0 / 3.0));
  });
}

struct MirrorRun {
  int frames = 0, seen = 0, measured = 0, drawn_gated = 0;
  std::vector<double> mm, deg;              // ungated: every frame the mirror was measured or predicted
  std::vector<double> gated_mm, gated_deg;  // with the default 1 mm gate
  std::vector<double> man_mm, man_deg;      // mannequin, default tracker
  int man_drawn = 0;
  int rim_refined = 0;          // ungated frames measured with the rim (rim_points > 0)
  std::vector<double> cpu_ms;   // thread CPU per track() of the gated tracker
  std::vector<double> rim_edge_px;  // rim edges found vs the true silhouette (outward px)
  // Per edge (same order as rim_edge_px), for DENTAR_RIM_DIAG: |step| in
  // linear light, back silhouette, the normal's angle to the nearest image
  // axis (deg), the step's sign (outside - inside).
  std::vector<double> rim_edge_step, rim_edge_back, rim_edge_axis_deg, rim_edge_sign;
  std::vector<double> face_visible;  // visible face px / projected face area (DENTAR_RIM_DIAG)
  std::vector<double> lat_mm, ray_mm;  // ungated centre error across / along the line of sight
};

// Where the line origin + s n crosses the projected circle of radius rad at
// height z of `mir` (the crossing nearest the angle th0): s, or nullopt.
std::optional<double> rim_crossing(const CameraModel& cm, const Iso& T_cam_mir, double rad, double z, double th0,
                                   const V2& origin, const V2& n) {
  const V2 t(-n.y(), n.x());
  double th = th0;
  auto P = [&](double a) { return cm.project(T_cam_mir * Eigen::Vector3d(rad * std::cos(a), rad * std::sin(a), z)); };
  for (int it = 0; it < 20; ++it) {
    const auto p = P(th), q = P(th + 1e-6);
    if (!p || !q) return std::nullopt;
    const double f = t.dot(*p - origin), df = t.dot(*q - *p) / 1e-6;
    if (std::abs(df) < 1e-9) return std::nullopt;
    const double d = std::clamp(-f / df, -0.2, 0.2);
    th += d;
    if (std::abs(d) < 1e-10) break;
  }
  const auto p = P(th);
  if (!p || std::abs(t.dot(*p - origin)) > 1e-3) return std::nullopt;
  return n.dot(*p - origin);
}

double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

MirrorRun run_tracker(const Footage& fo, TrackerOptions base) {
  MirrorRun r;
  TrackerOptions ungated = base;
  ungated.mirror_max_sigma_m = 0;
  auto a = Tracker::create(fo.station, ungated);
  auto b = Tracker::create(fo.station, base);
  EXPECT_TRUE(a.ok() && b.ok());
  if (!a || !b) return r;
  const Iso T_mtag_mir = fo.station.calibration.T_mtag_mir;
  for (const SynthFrame& s : fo.frames) {
    auto fa = a->track(s.image, s.truth.time_s, s.truth.time_s);
    const double c0 = thread_cpu_ms();
    auto fb = b->track(s.image, s.truth.time_s, s.truth.time_s);
    r.cpu_ms.push_back(thread_cpu_ms() - c0);
    EXPECT_TRUE(fa.ok() && fb.ok());
    if (!fa || !fb) return r;
    ++r.frames;
    r.rim_refined += fa->mirror.rim_points > 0 ? 1 : 0;
    if (base.mirror_rim_refine && s.truth.mirror_in_view) {
      // Where the accepted rim edges lie against the true disc silhouette.
      BundlePose bp = estimate_bundle_pose(mirror_bundle(fo.station), fo.station.calibration.camera,
                                           fa->tags, {}, s.truth.T_cam_mtag);
      if (std::getenv("DENTAR_RIM_SEED_TRUTH")) bp.T_cam_body = s.truth.T_cam_mtag;  // diagnosis: search at the truth
      if (bp.ok()) {
        cv::Mat g;
        if (s.image.channels() == 3) cv::cvtColor(s.image, g, cv::COLOR_BGR2GRAY); else g = s.image;
        const CameraModel cm(fo.station.calibration.camera);
        const MirrorRimResult rr = refine_mirror_rim(g, true, cm, bp, 0.01, T_mtag_mir,
                                                     fo.station.calibration.mirror_radius_m,
                                                     fo.station.mirror.thickness_m, base.mirror_rim);
        const double rad = fo.station.calibration.mirror_radius_m, th = fo.station.mirror.thickness_m;
        const char* dbg = std::getenv("DENTAR_RIM_DEBUG");
        cv::Mat vis;
        if (dbg && r.frames % 10 == 1) cv::cvtColor(g, vis, cv::COLOR_GRAY2BGR);
        for (const MirrorRimEdge& e : rr.edges) {
          const Eigen::Vector3d q(rad * std::cos(e.angle_rad), rad * std::sin(e.angle_rad), e.back ? -th : 0.0);
          const auto u = cm.project(s.truth.T_cam_mir * q);
          if (u) {
            if (std::getenv("DENTAR_RIM_EXACT_TRUTH")) {
              // The true silhouette on the edge's own line: the outer of the
              // face's and the back's crossings.
              const auto sf = rim_crossing(cm, s.truth.T_cam_mir, rad, 0.0, e.angle_rad, e.model_px, e.normal);
              const auto sb = rim_crossing(cm, s.truth.T_cam_mir, rad, -th, e.angle_rad, e.model_px, e.normal);
              if (!sf && !sb) continue;
              const double st = std::max(sf ? *sf : -1e9, sb ? *sb : -1e9);
              r.rim_edge_px.push_back(e.offset_px - st);
            } else {
              r.rim_edge_px.push_back(e.normal.dot(e.model_px + e.normal * e.offset_px - *u));
            }
            r.rim_edge_step.push_back(std::abs(e.step));
            r.rim_edge_back.push_back(e.back ? 1 : 0);
            const double a = std::fmod(std::abs(std::atan2(e.normal.y(), e.normal.x())) * 180 / M_PI, 90.0);
            r.rim_edge_axis_deg.push_back(std::min(a, 90 - a));
            r.rim_edge_sign.push_back(e.step > 0 ? 1 : -1);
            if (const char* csv = std::getenv("DENTAR_RIM_CSV")) {
              static FILE* f = std::fopen(csv, "w");
              // The face point at the truth pose too (the side band's inner edge).
              const Eigen::Vector3d qf(rad * std::cos(e.angle_rad), rad * std::sin(e.angle_rad), 0.0);
              const auto uf = cm.project(s.truth.T_cam_mir * qf);
              const auto uc = cm.project(s.truth.T_cam_mir * Eigen::Vector3d(qf.x(), qf.y(), -th));
              std::fprintf(f, "%d,%.4f,%d,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f", r.frames, e.angle_rad, e.back ? 1 : 0,
                           e.normal.x(), e.normal.y(), e.normal.dot(e.model_px + e.normal * e.offset_px - *u),
                           e.step, uf ? e.normal.dot(*uf - *u) : NAN, uc ? e.normal.dot(*uc - *u) : NAN,
                           e.offset_px);
              for (double t = -4; t <= 4.001; t += 0.25) {
                const V2 q = *u + e.normal * t;
                const int x = static_cast<int>(std::floor(q.x())), y = static_cast<int>(std::floor(q.y()));
                double v = NAN;
                if (x >= 0 && y >= 0 && x + 1 < g.cols && y + 1 < g.rows) {
                  const double a = q.x() - x, b = q.y() - y;
                  auto L = [&](int yy, int xx) { return srgb_decode(g.at<std::uint8_t>(yy, xx) / 255.0); };
                  v = (1 - b) * ((1 - a) * L(y, x) + a * L(y, x + 1)) + b * ((1 - a) * L(y + 1, x) + a * L(y + 1, x + 1));
                }
                std::fprintf(f, ",%.4f", v);
              }
              {
                // The image directions of mir's -z (thickness), +y and +x at the centre, px per mm.
                const auto c0 = cm.project(s.truth.T_cam_mir * Eigen::Vector3d(0, 0, 0));
                const auto cz = cm.project(s.truth.T_cam_mir * Eigen::Vector3d(0, 0, -1e-3));
                const auto cy = cm.project(s.truth.T_cam_mir * Eigen::Vector3d(0, 1e-3, 0));
                const auto cx = cm.project(s.truth.T_cam_mir * Eigen::Vector3d(1e-3, 0, 0));
                if (c0 && cz && cy && cx)
                  std::fprintf(f, ",%.4f,%.4f,%.4f,%.4f,%.4f,%.4f", cz->x() - c0->x(), cz->y() - c0->y(),
                               cy->x() - c0->x(), cy->y() - c0->y(), cx->x() - c0->x(), cx->y() - c0->y());
              }
              std::fprintf(f, "\n");
              std::fflush(f);
            }
          }
          if (!vis.empty() && u) {
            const V2 f = e.model_px + e.normal * e.offset_px;
            vis.at<cv::Vec3b>(static_cast<int>(std::lround(u->y())), static_cast<int>(std::lround(u->x()))) = {0, 255, 0};
            vis.at<cv::Vec3b>(static_cast<int>(std::lround(f.y())), static_cast<int>(std::lround(f.x()))) = {0, 0, 255};
          }
        }
        if (!vis.empty()) {
          const auto c = cm.project(s.truth.T_cam_mir.translation());
          if (c) {
            const int h = 40;
            cv::Rect roi(std::clamp(static_cast<int>(c->x()) - h, 0, g.cols - 2 * h), std::clamp(static_cast<int>(c->y()) - h, 0, g.rows - 2 * h), 2 * h, 2 * h);
            cv::Mat big;
            cv::resize(vis(roi), big, {}, 6, 6, cv::INTER_NEAREST);
            for (int i = 0; i < 720; ++i) {
              const double a = 2 * M_PI * i / 720;
              for (int b = 0; b < 2; ++b) {
                const auto q = cm.project(s.truth.T_cam_mir * Eigen::Vector3d(rad * std::cos(a), rad * std::sin(a), b ? -th : 0.0));
                if (!q) continue;
                const int x = static_cast<int>(std::lround((q->x() - roi.x + 0.5) * 6 - 0.5)), y = static_cast<int>(std::lround((q->y() - roi.y + 0.5) * 6 - 0.5));
                if (x >= 0 && y >= 0 && x < big.cols && y < big.rows) big.at<cv::Vec3b>(y, x) = b ? cv::Vec3b(0, 255, 255) : cv::Vec3b(255, 0, 0);
              }
            }
            cv::imwrite(std::string(dbg) + "/rim_" + std::to_string(r.frames) + ".png", big);
          }
        }
      }
    }
    if (std::getenv("DENTAR_RIM_DIAG") && base.mirror_rim_refine && s.truth.mirror_in_view) {
      // Visible face pixels (the generator's id pass) against the projected face's area.
      const CameraModel cm(fo.station.calibration.camera);
      const double rad = fo.station.calibration.mirror_radius_m;
      double area = 0;
      std::optional<V2> prev, first;
      for (int i = 0; i <= 720; ++i) {
        const double a = 2 * M_PI * i / 720;
        const auto q = cm.project(s.truth.T_cam_mir * Eigen::Vector3d(rad * std::cos(a), rad * std::sin(a), 0));
        if (!q) { area = NAN; break; }
        if (prev) area += 0.5 * (prev->x() * q->y() - q->x() * prev->y());
        prev = q;
      }
      r.face_visible.push_back(s.truth.mirror_face_px / std::abs(area));
    }
    r.seen += s.truth.mirror_in_view ? 1 : 0;
    if (fa->mirror.state != TrackState::kLost) {
      const Iso T = fa->mirror.T_cam_body * T_mtag_mir;
      r.mm.push_back(trans_mm(T, s.truth.T_cam_mir));
      r.deg.push_back(rot_deg(T, s.truth.T_cam_mir));
      const Eigen::Vector3d e = T.translation() - s.truth.T_cam_mir.translation();
      const Eigen::Vector3d ray = s.truth.T_cam_mir.translation().normalized();
      r.ray_mm.push_back(std::abs(e.dot(ray)) * 1e3);
      r.lat_mm.push_back((e - e.dot(ray) * ray).norm() * 1e3);
    }
    r.measured += fa->mirror.measured ? 1 : 0;
    if (fb->mirror.state != TrackState::kLost) {
      ++r.drawn_gated;
      const Iso T = fb->mirror.T_cam_body * T_mtag_mir;
      r.gated_mm.push_back(trans_mm(T, s.truth.T_cam_mir));
      r.gated_deg.push_back(rot_deg(T, s.truth.T_cam_mir));
    }
    if (fb->mannequin.state != TrackState::kLost) {
      ++r.man_drawn;
      r.man_mm.push_back(trans_mm(fb->mannequin.T_cam_body, s.truth.T_cam_man));
      r.man_deg.push_back(rot_deg(fb->mannequin.T_cam_body, s.truth.T_cam_man));
    }
  }
  return r;
}

void print_run(const char* preset, const char* variant, const MirrorRun& r) {
  std::printf("| %s | %s | %d / %d | %.2f / %.2f / %.2f | %.2f / %.2f / %.2f | %d | %.2f / %.2f | %.3f / %.3f (%d) |\n",
              preset, variant, static_cast<int>(r.mm.size()), r.seen, pct(r.mm, 0.5), pct(r.mm, 0.95),
              pct(r.mm, 0.99), pct(r.deg, 0.5), pct(r.deg, 0.95), pct(r.deg, 0.99), r.drawn_gated,
              pct(r.gated_mm, 0.95), pct(r.gated_deg, 0.95), pct(r.man_mm, 0.95), pct(r.man_deg, 0.95),
              r.man_drawn);
}

TEST(MirrorAccuracy, WhereTheMirrorErrorComesFrom) {
  DENTAR_GL_TEST_CONTEXT();
  const RunSize z = run_size();
  for (SynthPreset p : {SynthPreset::kStandard, SynthPreset::kMirror, SynthPreset::kHard}) {
    if (!preset_wanted(p, p == SynthPreset::kStandard)) continue;
    const Footage& fo = footage(p);
    ASSERT_TRUE(fo.error.empty()) << fo.error;
    for (const DetVariant& var : kVariants) {
      const MirrorCorners m = mirror_corners(fo, var);
      std::printf("\n[ mirror ] %s %dx%d, %d frames, generator v%d, detector %s: %zu mirror tag edges, "
                  "corner error p50 %.3f p95 %.3f px\n",
                  synth_preset_name(p), z.w, z.h, z.frames, kSynthGeneratorVersion, var.name,
                  m.edges.size(), pct(m.corner_err_px, 0.5), pct(m.corner_err_px, 0.95));
      ASSERT_GT(m.edges.size(), 40u);
      print_edge_bins("tag id", m.edges, [](const EdgeSample& e) { return e.tag; }, {20.5, 21.5});
      print_edge_bins("view angle deg", m.edges, [](const EdgeSample& e) { return e.angle_deg; }, {40, 55, 65, 75});
      print_edge_bins("tag side px", m.edges, [](const EdgeSample& e) { return e.side_px; }, {15, 20, 25, 35});
      print_edge_bins("foreshortening of the edge normal", m.edges,
                      [](const EdgeSample& e) { return e.foreshortening; }, {0.4, 0.6, 0.8});
      std::vector<double> outline;
      for (std::size_t i = 0; i < m.edges.size(); i += 4) outline.push_back(m.edges[i].tag_mean_px);
      std::printf("[ mirror ] per-tag outline growth: mean %+.3f px, sd across tags %.3f px\n", mean(outline),
                  stdev(outline));
      std::printf("[ mirror ] centre from the detected corners (full resolution): p50 %.2f p95 %.2f p99 %.2f mm, "
                  "p50 %.2f p95 %.2f deg; from the true corners of the same tags p95 %.4f mm; "
                  "centre sigma per 1 px corner noise p50 %.1f p95 %.1f mm\n",
                  pct(m.det_mm, 0.5), pct(m.det_mm, 0.95), pct(m.det_mm, 0.99), pct(m.det_deg, 0.5),
                  pct(m.det_deg, 0.95), pct(m.true_mm, 0.95), pct(m.sigma1_mm, 0.5), pct(m.sigma1_mm, 0.95));
      // p95 of a 3-D Gaussian error is ~1.62 x its sqrt(trace) sigma: the
      // corner noise at which the p95 frame's sigma gives 0.5 mm.
      std::printf("[ mirror ] corner noise for 0.5 mm p95 at the centre: %.3f px (at the median frame's "
                  "geometry %.3f px)\n",
                  0.5 / (1.62 * pct(m.sigma1_mm, 0.95)), 0.5 / (1.62 * pct(m.sigma1_mm, 0.5)));
      ASSERT_FALSE(m.true_mm.empty());
      EXPECT_LT(pct(m.true_mm, 0.95), 0.01);  // the solver and the truth agree
      if (var.response == CameraResponse::kSrgb && p == SynthPreset::kStandard && z.is_default()) {
        // Measured 2026-11-25: outline -0.025 px (generator v2, sRGB); it was
        // -0.097 px with generator v1 and the encoded image.
        EXPECT_LT(std::abs(mean(outline)), 0.05);
        EXPECT_LT(pct(m.det_mm, 0.5), 1.2);
      }
    }
  }
}

// Which stage of the footage moves the mirror tags' outline: the standard
// preset's mirror footage with the sensor's stages switched off in turn.
TEST(MirrorAccuracy, OutlineBiasByFootageStage) {
  DENTAR_GL_TEST_CONTEXT();
  struct Variant {
    const char* name;
    void (*apply)(SynthOptions&);
  };
  const Variant variants[] = {
      {"standard", [](SynthOptions&) {}},
      {"no noise", [](SynthOptions& o) { o.read_noise_dn = o.shot_noise_gain = 0; }},
      {"no lens distortion", [](SynthOptions& o) { o.distortion = false; }},
      {"no optical blur", [](SynthOptions& o) { o.optical_blur_px = 0; }},
      {"optical blur 1 px", [](SynthOptions& o) { o.optical_blur_px = 1.0; }},
      {"none of the three", [](SynthOptions& o) {
         o.read_noise_dn = o.shot_noise_gain = 0;
         o.distortion = false;
         o.optical_blur_px = 0;
       }},
  };
  std::printf("\n[ stages ] mirror preset 640x480, 20 frames, seed 5, generator v%d: mirror tags' outline growth px "
              "(mean / sd across tags) per detector\n| variant | tags | srgb | linear | srgb+refit |\n"
              "|---|---|---|---|---|\n", kSynthGeneratorVersion);
  for (const Variant& v : variants) {
    SynthOptions o = synth_preset(SynthPreset::kMirror);
    o.frames = 20;
    o.seed = 5;
    o.bur_samples = 1000;
    v.apply(o);
    const Footage fo = make_footage(default_station_scene(), o);
    ASSERT_TRUE(fo.error.empty()) << fo.error;
    double m[3], sd[3];
    std::size_t n = 0;
    int k = 0;
    for (const DetVariant* var : {&kVariants[1], &kVariants[0], &kVariants[2]}) {
      const MirrorCorners c = mirror_corners(fo, *var);
      std::vector<double> outline;
      for (std::size_t i = 0; i < c.edges.size(); i += 4) outline.push_back(c.edges[i].tag_mean_px);
      m[k] = mean(outline);
      sd[k] = stdev(outline);
      if (k == 0) n = outline.size();
      ++k;
    }
    std::printf("| %s | %zu | %+.3f / %.3f | %+.3f / %.3f | %+.3f / %.3f |\n", v.name, n, m[0], sd[0], m[1], sd[1],
                m[2], sd[2]);
    // Measured 2026-11-25, generator v2: standard -0.015 px, pinhole +0.002
    // (v2 before the distortion resampling moved to linear light: -0.10).
    if (std::string(v.name) == "standard" || std::string(v.name) == "no lens distortion") {
      EXPECT_LT(std::abs(m[0]), 0.04) << v.name;
    }
  }
}

// The mannequin's corners on the same footage: the fix must not cost them.
TEST(MirrorAccuracy, MannequinCornersByCameraResponse) {
  DENTAR_GL_TEST_CONTEXT();
  for (SynthPreset p : {SynthPreset::kStandard, SynthPreset::kHard}) {
    if (!preset_wanted(p, p == SynthPreset::kStandard)) continue;  // hard: DENTAR_PRESETS=hard
    const Footage& fo = footage(p);
    ASSERT_TRUE(fo.error.empty()) << fo.error;
    for (const DetVariant& var : kVariants) {
      const MirrorCorners m = mirror_corners(fo, var, false);
      std::printf("\n[ mannequin ] %s, generator v%d, detector %s: %zu edges, corner error p50 %.3f p95 %.3f px; "
                  "pose from the detected corners (full resolution, unfiltered) p50 %.3f p95 %.3f mm, "
                  "p50 %.3f p95 %.3f deg\n",
                  synth_preset_name(p), kSynthGeneratorVersion, var.name, m.edges.size(),
                  pct(m.corner_err_px, 0.5), pct(m.corner_err_px, 0.95), pct(m.det_mm, 0.5), pct(m.det_mm, 0.95),
                  pct(m.det_deg, 0.5), pct(m.det_deg, 0.95));
      std::printf("[ mannequin ] mean corner error dx %+.3f dy %+.3f px, radial (from the image centre) %+.3f px\n",
                  mean(m.dx_px), mean(m.dy_px), mean(m.radial_px));
      std::printf("[ mannequin ] same corners with each tag's outline growth removed: p50 %.3f p95 %.3f mm; "
                  "with -0.09 px outline added: p50 %.3f p95 %.3f mm\n",
                  pct(m.flat_mm, 0.5), pct(m.flat_mm, 0.95), pct(m.shrunk_mm, 0.5), pct(m.shrunk_mm, 0.95));
      print_edge_bins("view angle deg", m.edges, [](const EdgeSample& e) { return e.angle_deg; }, {40, 55, 65});
      print_edge_bins("tag side px", m.edges, [](const EdgeSample& e) { return e.side_px; }, {15, 20, 30});
    }
  }
}

// The mirror's pose from the tracker (ungated and with its default 1 mm
// gate), the mannequin beside it, with the detector's camera response
// linear (libapriltag as is) and sRGB (the tracker's default).
TEST(MirrorAccuracy, MirrorPoseByCameraResponse) {
  DENTAR_GL_TEST_CONTEXT();
  const RunSize z = run_size();
  std::printf("\n[ mirror ] %dx%d, %d frames, seed 5, generator v%d: mirror centre vs truth\n", z.w, z.h, z.frames,
              kSynthGeneratorVersion);
  std::printf("| preset | response | tracked / in view | mm p50 / p95 / p99 | deg p50 / p95 / p99 | gated: drawn | "
              "gated p95 mm / deg | mannequin p95 mm / deg (drawn) |\n|---|---|---|---|---|---|---|---|\n");
  for (SynthPreset p : {SynthPreset::kStandard, SynthPreset::kMirror, SynthPreset::kHard}) {
    if (!preset_wanted(p, p == SynthPreset::kStandard)) continue;  // others: DENTAR_PRESETS
    const Footage& fo = footage(p);
    ASSERT_TRUE(fo.error.empty()) << fo.error;
    MirrorRun runs[3];
    int k = 0;
    for (const DetVariant& var : kVariants) {
      TrackerOptions o;
      o.detector.response = var.response;
      o.detector.refit_edges_linear = var.refit;
      runs[k] = run_tracker(fo, o);
      print_run(synth_preset_name(p), var.name, runs[k]);
      ++k;
    }
    if (!z.is_default() || std::getenv("DENTAR_PRESETS")) continue;
    const MirrorRun& srgb = runs[1];
    ASSERT_EQ(srgb.frames, z.frames);
    if (p != SynthPreset::kStandard) continue;
    // Measured 2026-11-25 (generator v2, sRGB response): p50 0.92, p95 2.69 mm;
    // with the 1 mm gate 11 frames drawn at 0.74 mm p95. Before (generator v1,
    // libapriltag on the encoded image): 1.48 / 3.68 mm, gated 1.95 mm.
    EXPECT_LT(pct(srgb.mm, 0.5), 1.2);
    EXPECT_LT(pct(srgb.mm, 0.95), 3.2);
    EXPECT_GE(srgb.drawn_gated, 5);
    if (srgb.drawn_gated >= 5) { EXPECT_LT(pct(srgb.gated_mm, 0.95), 1.2); }
    // The mannequin keeps its preset bound (PresetAccuracy: 0.35 mm / 0.4 deg).
    EXPECT_EQ(srgb.man_drawn, z.frames);
    EXPECT_LT(pct(srgb.man_mm, 0.95), 0.35);
    EXPECT_LT(pct(srgb.man_deg, 0.95), 0.4);
  }
}


// Issue 16, Build item 3: the mirror's pose refined from its rim ellipse
// (TrackerOptions::mirror_rim_refine), off and on in the same run.
TEST(MirrorAccuracy, RimEllipseRefinement) {
  DENTAR_GL_TEST_CONTEXT();
  const RunSize z = run_size();
  std::printf("\n[ rim ] %dx%d, %d frames, seed 5, generator v%d: mirror centre vs truth, rim refinement off / on\n",
              z.w, z.h, z.frames, kSynthGeneratorVersion);
  std::printf("| preset | rim | tracked / in view | refined | mm p50 / p95 / p99 | deg p50 / p95 / p99 | gated: drawn | "
              "gated mm p50 / p95 | gated deg p95 | thread CPU ms p50 / p95 | rim edge vs truth px mean / sd / p95|abs| | "
              "across / along the ray mm p50 / p95 |\n"
              "|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (SynthPreset p : {SynthPreset::kStandard, SynthPreset::kMirror, SynthPreset::kHard, SynthPreset::kGlare,
                        SynthPreset::kFastTurns}) {
    if (!preset_wanted(p, p == SynthPreset::kStandard)) continue;
    const Footage& fo = footage(p);
    ASSERT_TRUE(fo.error.empty()) << fo.error;
    // 0: off; 1: on (the strongest-gradient edges, unless DENTAR_RIM_STEP_FIT);
    // 2: on with the blurred-step edge fit (step_fit); 3: the same with the
    // edges chosen jointly (joint_select).
    constexpr int kVariants = 4;
    MirrorRun runs[kVariants];
    const char* names[kVariants] = {"off", "on", "on+fit", "on+joint"};
    for (int on = 0; on < kVariants; ++on) {
      TrackerOptions o;
      o.mirror_rim_refine = on >= 1;
      if (on >= 2) o.mirror_rim.step_fit = true;
      if (on == 3) o.mirror_rim.joint_select = true;
      if (std::getenv("DENTAR_RIM_FACE_ONLY")) o.mirror_rim.silhouette_back = false;
      if (const char* e = std::getenv("DENTAR_RIM_SEARCH_PX")) o.mirror_rim.search_px = std::atof(e);
      if (const char* e = std::getenv("DENTAR_RIM_HUBER_PX")) o.mirror_rim.huber_px = std::atof(e);
      if (const char* e = std::getenv("DENTAR_RIM_ROUNDS")) o.mirror_rim.rounds = std::atoi(e);
      if (const char* e = std::getenv("DENTAR_RIM_RESEARCH_PX")) o.mirror_rim.research_px = std::atof(e);
      if (std::getenv("DENTAR_RIM_FREE_DEPTH")) o.mirror_rim.keep_depth = false;
      if (std::getenv("DENTAR_RIM_CENTRE_ONLY")) o.mirror_rim.centre_only = true;
      if (std::getenv("DENTAR_RIM_FIXED_SCALE")) o.mirror_rim.free_scale = false;
      if (const char* e = std::getenv("DENTAR_RIM_NEFF")) o.mirror_rim.rim_effective_points = std::atof(e);
      if (const char* e = std::getenv("DENTAR_RIM_STEP_FIT"); e && on == 1) o.mirror_rim.step_fit = std::atoi(e) != 0;
      if (const char* e = std::getenv("DENTAR_RIM_BLUR_PX")) o.mirror_rim.blur_px = std::atof(e);
      if (const char* e = std::getenv("DENTAR_RIM_WIDTH_RATIO")) o.mirror_rim.max_width_ratio = std::atof(e);
      if (const char* e = std::getenv("DENTAR_RIM_FIT_RMS")) o.mirror_rim.max_fit_rms = std::atof(e);
      if (const char* e = std::getenv("DENTAR_RIM_LINES")) o.mirror_rim.parallel_lines = std::atoi(e);
      if (const char* e = std::getenv("DENTAR_RIM_LINES_PX")) o.mirror_rim.parallel_px = std::atof(e);
      if (std::getenv("DENTAR_RIM_NO_POLARITY")) o.mirror_rim.polarity_check = false;
      if (std::getenv("DENTAR_RIM_EXACT")) o.mirror_rim.exact_silhouette = true;
      if (const char* e = std::getenv("DENTAR_RIM_FACE_TOL")) o.mirror_rim.face_level_tol = std::atof(e);
      if (const char* e = std::getenv("DENTAR_RIM_MAX_RMS")) o.mirror_rim.max_rim_rms_px = std::atof(e);
      if (std::getenv("DENTAR_RIM_JOINT") && on == 1) o.mirror_rim.joint_select = true;
      if (const char* e = std::getenv("DENTAR_RIM_MAX_CANDIDATES")) o.mirror_rim.max_candidates = std::atoi(e);
      if (const char* e = std::getenv("DENTAR_RIM_AMBIGUITY")) o.mirror_rim.ambiguity = std::atof(e);
      runs[on] = run_tracker(fo, o);
      const MirrorRun& r = runs[on];
      std::vector<double> ae;
      for (double x : r.rim_edge_px) ae.push_back(std::abs(x));
      if (std::getenv("DENTAR_RIM_DIAG") && !r.rim_edge_px.empty()) {
        auto bins = [&](const char* what, const std::vector<double>& key, std::vector<double> edges) {
          edges.insert(edges.begin(), -1e300);
          edges.push_back(1e300);
          for (std::size_t b = 0; b + 1 < edges.size(); ++b) {
            std::vector<double> in;
            for (std::size_t i = 0; i < key.size(); ++i)
              if (key[i] >= edges[b] && key[i] < edges[b + 1]) in.push_back(r.rim_edge_px[i]);
            if (in.size() < 2) continue;
            std::printf("[ rim diag ] %s %s %s [%g, %g): %zu edges, mean %+.3f sd %.3f px\n", synth_preset_name(p),
                        names[on], what, edges[b], edges[b + 1], in.size(), mean(in), stdev(in));
          }
        };
        bins("|step|", r.rim_edge_step, {0.05, 0.1, 0.2, 0.3});
        bins("back", r.rim_edge_back, {0.5});
        bins("normal vs axis deg", r.rim_edge_axis_deg, {10, 20, 30, 40});
        bins("sign", r.rim_edge_sign, {0});
        std::vector<double> fv = r.face_visible;
        std::printf("[ rim diag ] %s visible face / projected area: p5 %.2f p50 %.2f p95 %.2f (%zu frames)\n",
                    synth_preset_name(p), pct(fv, 0.05), pct(fv, 0.5), pct(fv, 0.95), fv.size());
      }
      std::printf("| %s | %s | %d / %d | %d | %.2f / %.2f / %.2f | %.2f / %.2f / %.2f | %d | %.2f / %.2f | %.2f | %.2f / %.2f | %+.2f / %.2f / %.2f (%zu) | %.2f / %.2f ; %.2f / %.2f |\n",
                  synth_preset_name(p), names[on], static_cast<int>(r.mm.size()), r.seen, r.rim_refined,
                  pct(r.mm, 0.5), pct(r.mm, 0.95), pct(r.mm, 0.99), pct(r.deg, 0.5), pct(r.deg, 0.95),
                  pct(r.deg, 0.99), r.drawn_gated, pct(r.gated_mm, 0.5), pct(r.gated_mm, 0.95),
                  pct(r.gated_deg, 0.95), pct(r.cpu_ms, 0.5), pct(r.cpu_ms, 0.95), mean(r.rim_edge_px),
                  stdev(r.rim_edge_px), pct(ae, 0.95), r.rim_edge_px.size(), pct(r.lat_mm, 0.5),
                  pct(r.lat_mm, 0.95), pct(r.ray_mm, 0.5), pct(r.ray_mm, 0.95));
    }
    if (!z.is_default() || std::getenv("DENTAR_PRESETS")) continue;
    if (p != SynthPreset::kStandard) continue;
    const MirrorRun& off = runs[0];
    EXPECT_EQ(off.rim_refined, 0);
    // Measured 2026-11-27 after issue 24 (tags searched on the image as
    // delivered, their edges refit in linear light; 640x480, standard, seed
    // 5): off p50 / p95 0.86 / 1.85 mm, 1.19 deg p95, across the line of
    // sight p95 0.96 mm (1.41 before issue 24), gated 13 frames at 0.97 mm;
    // on 0.74 / 1.80 mm, 1.03 deg, across 0.97 mm, gated 15 at 1.01 mm, every
    // frame refined; on+fit 0.84 / 1.86 mm, 1.08 deg, across 1.03 mm;
    // on+joint 0.91 / 1.82 mm, 1.61 deg, across 1.28 mm, edge bias -0.18 px.
    // Session 11 (the mannequin's tags get a second look in linear light; the
    // rim uses the mannequin's corner noise): off unchanged; on 0.78 / 1.82
    // mm, 1.09 deg, across 1.06 mm (0.10 mm worse than the tags there);
    // on+fit 0.85 / 1.86, across 1.07, 51 frames refined; on+joint 0.90 /
    // 1.82, 1.61 deg, across 1.28.
    // The refit tag edges now give the disc across the line of sight as well
    // as the rim does: the rim's issue-16 gain there (1.41 -> 1.17 mm) is
    // gone, and the two variants with their own edge pickers are worse than
    // the tags alone. All three stay off by default (README, BENCHMARKS
    // issue 24). Asserted: the plain rim is no worse than the tags; the other
    // two stay within the measured figures' margin, refine most frames, and
    // their edges sit on the silhouette.
    for (int v = 1; v < kVariants; ++v) {
      const MirrorRun& on = runs[v];
      SCOPED_TRACE(names[v]);
      ASSERT_EQ(on.frames, z.frames);
      EXPECT_GE(on.rim_refined, z.frames * 5 / 6);
      EXPECT_GE(on.drawn_gated, off.drawn_gated);
      if (v == 1) {
        EXPECT_LE(pct(on.mm, 0.5), pct(off.mm, 0.5) + 0.02);
        EXPECT_LE(pct(on.mm, 0.95), pct(off.mm, 0.95) + 0.02);
        EXPECT_LE(pct(on.deg, 0.95), pct(off.deg, 0.95) + 0.02);
        EXPECT_LE(pct(on.lat_mm, 0.95), pct(off.lat_mm, 0.95) + 0.15);
        if (on.drawn_gated >= 5 && off.drawn_gated >= 5) {
          EXPECT_LE(pct(on.gated_mm, 0.95), pct(off.gated_mm, 0.95) + 0.05);
        }
      } else {
        EXPECT_LE(pct(on.mm, 0.95), pct(off.mm, 0.95) + 0.1);
        EXPECT_LE(pct(on.deg, 0.95), 1.5 * pct(off.deg, 0.95));
        EXPECT_LE(pct(on.lat_mm, 0.95), 1.5 * pct(off.lat_mm, 0.95));
      }
      // The rim edges found sit on the true silhouette (little bias).
      EXPECT_LT(std::abs(mean(on.rim_edge_px)), v == 3 ? 0.25 : 0.15);
    }
  }
}

// With the rim hidden (the disc and its surroundings painted flat) the
// refinement finds too few edges and the tracker keeps the tag pose exactly.
TEST(MirrorAccuracy, RimHiddenFallsBackToTags) {
  DENTAR_GL_TEST_CONTEXT();
  const Footage& fo = footage(SynthPreset::kStandard);
  ASSERT_TRUE(fo.error.empty()) << fo.error;
  TrackerOptions off, on;
  off.mirror_max_sigma_m = on.mirror_max_sigma_m = 0;
  off.predicted_regions = on.predicted_regions = false;  // every frame on its own
  off.filter_enabled = on.filter_enabled = false;
  on.mirror_rim_refine = true;
  auto a = Tracker::create(fo.station, off);
  auto b = Tracker::create(fo.station, on);
  auto c = Tracker::create(fo.station, on);  // the plain frames (b sees only the hidden ones)
  TrackerOptions fit = on;  // the blurred-step edge fit, on the hidden frames
  fit.mirror_rim.step_fit = true;
  auto d = Tracker::create(fo.station, fit);
  TrackerOptions joint = fit;  // and with the edges chosen jointly
  joint.mirror_rim.joint_select = true;
  auto e = Tracker::create(fo.station, joint);
  ASSERT_TRUE(a.ok() && b.ok() && c.ok() && d.ok() && e.ok());
  const CameraModel cm(fo.station.calibration.camera);
  const double rad = fo.station.calibration.mirror_radius_m;
  int compared = 0, refined_plain = 0, refined_hidden = 0, refined_hidden_fit = 0;
  for (const SynthFrame& s : fo.frames) {
    if (!s.truth.mirror_in_view) continue;
    // The frame as it is: the rim is used.
    auto fp = c->track(s.image, s.truth.time_s, s.truth.time_s);
    ASSERT_TRUE(fp.ok());
    refined_plain += fp->mirror.rim_points > 0 ? 1 : 0;
    // The disc hidden: a flat patch 2.5 radii wide around it.
    cv::Mat hidden = s.image.clone();
    std::vector<cv::Point> poly;
    for (int i = 0; i < 64; ++i) {
      const double th = 2 * M_PI * i / 64;
      const auto u = cm.project(s.truth.T_cam_mir * Eigen::Vector3d(2.5 * rad * std::cos(th), 2.5 * rad * std::sin(th), 0));
      if (u) poly.emplace_back(static_cast<int>(std::lround(u->x())), static_cast<int>(std::lround(u->y())));
    }
    if (poly.size() < 64) continue;
    cv::fillConvexPoly(hidden, poly, cv::Scalar(128, 128, 128));
    auto fa = a->track(hidden, s.truth.time_s, s.truth.time_s);
    auto fb = b->track(hidden, s.truth.time_s, s.truth.time_s);
    auto fd = d->track(hidden, s.truth.time_s, s.truth.time_s);
    auto fe = e->track(hidden, s.truth.time_s, s.truth.time_s);
    ASSERT_TRUE(fa.ok() && fb.ok() && fd.ok() && fe.ok());
    if (!fa->mirror.measured) continue;
    ASSERT_TRUE(fb->mirror.measured);
    ++compared;
    refined_hidden += fb->mirror.rim_points > 0 ? 1 : 0;
    EXPECT_TRUE(fb->mirror.T_cam_body_measured.isApprox(fa->mirror.T_cam_body_measured, 1e-12));
    EXPECT_DOUBLE_EQ(fb->mirror.sigma_m, fa->mirror.sigma_m);
    ASSERT_TRUE(fd->mirror.measured);
    refined_hidden_fit += fd->mirror.rim_points > 0 ? 1 : 0;
    EXPECT_TRUE(fd->mirror.T_cam_body_measured.isApprox(fa->mirror.T_cam_body_measured, 1e-12));
    EXPECT_DOUBLE_EQ(fd->mirror.sigma_m, fa->mirror.sigma_m);
    ASSERT_TRUE(fe->mirror.measured);
    refined_hidden_fit += fe->mirror.rim_points > 0 ? 1 : 0;
    EXPECT_TRUE(fe->mirror.T_cam_body_measured.isApprox(fa->mirror.T_cam_body_measured, 1e-12));
    EXPECT_DOUBLE_EQ(fe->mirror.sigma_m, fa->mirror.sigma_m);
  }
  std::printf("[ rim hidden ] %d frames compared: refined %d with the rim visible, %d hidden (%d with the step fit, alone or joint)\n",
              compared, refined_plain, refined_hidden, refined_hidden_fit);
  EXPECT_GE(compared, 20);
  EXPECT_EQ(refined_hidden, 0);
  EXPECT_EQ(refined_hidden_fit, 0);
  EXPECT_GE(refined_plain, compared / 2);  // the rim is found when it is there
}

}  // namespace
}  // namespace dentar::ar
