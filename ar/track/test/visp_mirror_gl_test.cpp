// Model-based tracking of the mouth mirror's head with ViSP (issue 16, Build
// item 3: "model-based tracking of the mirror head"; "ViSP is used where it
// measurably helps and nowhere else"). ViSP 3.5's vpMbGenericTracker through
// the test-only bridge (visp_bridge.h), seeded every frame by the tag pose
// (the tracker's T_cam_mtag), against the tag pose alone and against our rim
// refinement (TrackerOptions::mirror_rim_refine), in the same run, on the
// generator's footage with truth (the mirror harness's: seed 5).
//
// The model, in the mtag frame, from the station (not from copied numbers):
// - the disc's rim as CAO circles: the reflecting face's (z = 0 of `mir`,
//   radius calibration.mirror_radius_m) and the back's (z = -thickness),
//   each visible from its own side, placed by calibration.T_mtag_mir;
// - the border squares of the paddle's tags (mirror_bundle), as the
//   mannequin test does;
// - the paddle's outline: the faces of scene::paddle_mesh (the generator's
//   own paddle geometry, roof or flat), merged into planar polygons.
// Variants: the rim circle alone; rim + tag outlines; rim + tags + paddle;
// the same without the rim (what the rim adds); the paddle's outline alone;
// rim + tags + paddle + KLT
// (KLT features of the tag and paddle faces carried from the previous frame,
// seeded there by its tag pose); the rim as two 36-gons instead of circles.
// ViSP's pose is dropped for the tags' when it throws or moves the mirror
// centre > 4 mm or the rotation > 3 deg from the tag pose
// (DENTAR_VISP_MAX_MM / _MAX_DEG). Moving-edge range 2 px
// (DENTAR_VISP_RANGE; _THRESHOLD, _STEP).
//
// Found (docs/BENCHMARKS.md): ViSP 3.5's circle changes nothing next to any
// line feature (the same pose to 0.01 mm with and without it: its residual
// is an algebraic distance, 4-5 orders of magnitude below the lines') and,
// alone, lets the depth run away; no variant is better than both the tags
// and the rim refinement; not adopted.
//
// Diagnosis: DENTAR_VISP_SEED_TRUTH=1 (seed with the true pose),
// DENTAR_VISP_DEBUG=1 (per frame), DENTAR_VISP_DEBUG_DIR=DIR (images of the
// model and the moving-edge sites), DENTAR_VISP_ONE_CIRCLE=face|back.
//
// Default (CI): `standard` 640x480, 20 frames, the rim and rim + tags
// variants, asserting that ViSP ran with the rim in its model and stayed near
// the tag pose. DENTAR_PRESETS (standard,mirror,hard,glare),
// DENTAR_PRESET_SIZE (e.g. 1280x720), DENTAR_PRESET_FRAMES print the full
// tables (every variant) without asserting; figures in docs/BENCHMARKS.md
// ("issue 16: model-based tracking of the mirror head with ViSP").
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "accuracy_test_util.h"
#include "dentar/ar/bundle_pose.h"
#include "dentar/ar/scene_mesh.h"
#include "dentar/ar/synth.h"
#include "dentar/ar/tracker.h"
#include "gl_test_context.h"
#include "visp_bridge.h"

namespace dentar::ar {
namespace {

using Iso = Eigen::Isometry3d;
using V3 = Eigen::Vector3d;
using namespace test;  // accuracy_test_util.h

double env_or(const char* name, double fallback) {
  const char* e = std::getenv(name);
  return e ? std::atof(e) : fallback;
}

// ---- the model (mtag frame) ------------------------------------------------------

// The disc's rim: the face's circle (normal +z of `mir`, toward the reflecting
// side) and the back's (z = -thickness, normal -z).
std::vector<visp::Circle> rim_circles(const StationScene& st) {
  const Iso T = st.calibration.T_mtag_mir;
  const double r = st.calibration.mirror_radius_m, t = st.mirror.thickness_m;
  visp::Circle face{T * V3(0, 0, 0), T * V3(r, 0, 0), T * V3(0, r, 0), r};
  visp::Circle back{T * V3(0, 0, -t), T * V3(0, r, -t), T * V3(r, 0, -t), r};
  if (const char* one = std::getenv("DENTAR_VISP_ONE_CIRCLE"))  // diagnosis: which one ViSP sees
    return {std::string(one) == "back" ? back : face};
  return {face, back};
}

// The same rim as two planar N-gons (face and back, outward normals +z / -z
// of `mir`): ViSP tracks polygon edges as lines, whose residuals are in the
// same units as the tags' (the circle's are not: see BENCHMARKS). Corners at
// r (pi/N) / sin(pi/N), so the sides' mean distance from the centre is r.
std::vector<visp::Face> rim_polygons(const StationScene& st, int n) {
  const Iso T = st.calibration.T_mtag_mir;
  const double r = st.calibration.mirror_radius_m * (M_PI / n) / std::sin(M_PI / n), t = st.mirror.thickness_m;
  visp::Face face, back;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    face.push_back(T * V3(r * std::cos(a), r * std::sin(a), 0));        // counter-clockwise about +z
    back.push_back(T * V3(r * std::cos(-a), r * std::sin(-a), -t));     // counter-clockwise about -z
  }
  return {face, back};
}

// The tags' border squares (tag frame: z into the tag; counter-clockwise seen
// from -z, the side the tag is read from).
std::vector<visp::Face> tag_faces(const TagBundle& b) {
  std::vector<visp::Face> out;
  for (const TagPlacement& t : b.tags) {
    const double h = 0.5 * t.size_m;
    visp::Face f;
    for (const Eigen::Vector2d& q : {Eigen::Vector2d(-h, -h), Eigen::Vector2d(-h, h), Eigen::Vector2d(h, h),
                                     Eigen::Vector2d(h, -h)})
      f.push_back(t.T_parent_tag * V3(q.x(), q.y(), 0));
    out.push_back(f);
  }
  return out;
}

// The paddle's planar faces from its mesh (triangles counter-clockwise seen
// from outside): triangles grouped by plane, each group's corners ordered
// counter-clockwise about the outward normal.
std::vector<visp::Face> paddle_faces(const StationScene& st) {
  const scene::Mesh m = scene::paddle_mesh(st.mirror, Eigen::Vector3f(1, 1, 1), 0);
  struct Plane {
    V3 n;
    double d;
    std::vector<V3> pts;
  };
  std::vector<Plane> planes;
  for (std::size_t i = 0; i + 2 < m.indices.size(); i += 3) {
    const V3 a = m.vertices[m.indices[i]].position_m.cast<double>();
    const V3 b = m.vertices[m.indices[i + 1]].position_m.cast<double>();
    const V3 c = m.vertices[m.indices[i + 2]].position_m.cast<double>();
    V3 n = (b - a).cross(c - a);
    if (n.norm() < 1e-12) continue;
    n.normalize();
    // Outward: the mesh's flat-shaded vertex normal says which side.
    if (n.dot(m.vertices[m.indices[i]].normal.cast<double>()) < 0) n = -n;
    Plane* pl = nullptr;
    for (Plane& p : planes)
      if (p.n.dot(n) > 1 - 1e-6 && std::abs(p.d - n.dot(a)) < 1e-7) pl = &p;
    if (!pl) {
      planes.push_back({n, n.dot(a), {}});
      pl = &planes.back();
    }
    for (const V3& q : {a, b, c}) {
      bool seen = false;
      for (const V3& s : pl->pts) seen = seen || (s - q).norm() < 1e-7;
      if (!seen) pl->pts.push_back(q);
    }
  }
  std::vector<visp::Face> out;
  for (Plane& p : planes) {
    V3 c = V3::Zero();
    for (const V3& q : p.pts) c += q / static_cast<double>(p.pts.size());
    const V3 u = (p.pts[0] - c).normalized(), v = p.n.cross(u);
    std::sort(p.pts.begin(), p.pts.end(), [&](const V3& a, const V3& b) {
      return std::atan2((a - c).dot(v), (a - c).dot(u)) < std::atan2((b - c).dot(v), (b - c).dot(u));
    });
    out.push_back(p.pts);
  }
  return out;
}

// ---- the run ---------------------------------------------------------------------

struct Variant {
  const char* name;
  enum Kind { kTags, kRim, kVisp } kind;
  bool circle = false, tags = false, paddle = false, klt = false;
  bool ci = false;      // run by default (the CI case)
  int rim_polygon = 0;  // > 0: the rim as two polygons of this many sides
};
const Variant kVariants[] = {
    {"tags only (tracker)", Variant::kTags, false, false, false, false, true},
    {"rim refinement (tracker)", Variant::kRim, false, false, false, false, true},
    {"ViSP rim circle", Variant::kVisp, true, false, false, false, true},
    {"ViSP rim + tag outlines", Variant::kVisp, true, true, false, false, true},
    {"ViSP rim + tags + paddle", Variant::kVisp, true, true, true, false, true},
    {"ViSP tags + paddle (no rim)", Variant::kVisp, false, true, true, false, false},
    {"ViSP tag outlines (no rim)", Variant::kVisp, false, true, false, false, false},
    {"ViSP paddle outline only", Variant::kVisp, false, false, true, false, false},
    {"ViSP rim + tags + paddle + KLT", Variant::kVisp, true, true, true, true, false},
    {"ViSP rim 36-gon", Variant::kVisp, false, false, false, false, false, 36},
    {"ViSP rim 36-gon + tag outlines", Variant::kVisp, false, true, false, false, false, 36},
    {"ViSP rim 36-gon + tags + paddle", Variant::kVisp, false, true, true, false, false, 36},
};

struct Stats {
  int measured = 0;   // frames with a tag pose of the mirror
  int refined = 0;    // frames whose pose is the variant's own (not the tags' fallback)
  int threw = 0, moved_too_far = 0;
  std::vector<double> mm, across_mm, along_mm, deg, tilt_deg, ms, circle_sites, raw_shift_mm;
};

void add_error(Stats& s, const Iso& T_cam_mir, const Iso& truth) {
  s.mm.push_back(trans_mm(T_cam_mir, truth));
  s.deg.push_back(rot_deg(T_cam_mir, truth));
  const double c = std::clamp(T_cam_mir.linear().col(2).dot(truth.linear().col(2)), -1.0, 1.0);
  s.tilt_deg.push_back(std::acos(c) * 180 / M_PI);
  const V3 e = T_cam_mir.translation() - truth.translation();
  const V3 ray = truth.translation().normalized();
  s.along_mm.push_back(std::abs(e.dot(ray)) * 1e3);
  s.across_mm.push_back((e - e.dot(ray) * ray).norm() * 1e3);
}

struct PresetRun {
  std::vector<Stats> stats;        // per variant (kVariants order; unrun ones empty)
  std::vector<bool> ran;
  std::vector<int> model_circles;  // ViSP's loaded circles per variant (-1: not ViSP)
  std::vector<double> tracker_ms;  // the tags-only tracker's track() per frame (the time anchor)
};

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

PresetRun run_preset(const Footage& fo, bool all_variants) {
  PresetRun r;
  const std::size_t nv = std::size(kVariants);
  r.stats.resize(nv);
  r.ran.assign(nv, false);
  r.model_circles.assign(nv, -1);
  const StationScene& st = fo.station;
  const auto& k = st.calibration.camera;
  const Iso T_mtag_mir = st.calibration.T_mtag_mir;
  const cv::Mat K = (cv::Mat_<double>(3, 3) << k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
  const cv::Mat dist = (cv::Mat_<double>(1, 5) << k.dist[0], k.dist[1], k.dist[2], k.dist[3], k.dist[4]);
  cv::Mat m1, m2;
  cv::initUndistortRectifyMap(K, dist, cv::Mat(), K, cv::Size(k.width, k.height), CV_16SC2, m1, m2);

  // The trackers: the tag pose (rim off) and the rim refinement, each frame's
  // own measurement (unfiltered), every measured frame (no sigma gate).
  TrackerOptions off;
  off.mirror_max_sigma_m = 0;
  TrackerOptions on = off;
  on.mirror_rim_refine = true;
  auto ta = Tracker::create(st, off);
  auto tb = Tracker::create(st, on);
  EXPECT_TRUE(ta.ok() && tb.ok());
  if (!ta || !tb) return r;

  visp::Options vo;
  vo.me_range = static_cast<int>(env_or("DENTAR_VISP_RANGE", 2));  // 4, 8: worse (BENCHMARKS)
  vo.me_threshold = env_or("DENTAR_VISP_THRESHOLD", 5000);
  vo.me_sample_step = static_cast<int>(env_or("DENTAR_VISP_STEP", 2));
  const double max_mm = env_or("DENTAR_VISP_MAX_MM", 4), max_deg = env_or("DENTAR_VISP_MAX_DEG", 3);
  const std::string scratch = std::filesystem::temp_directory_path().string();
  std::vector<std::unique_ptr<visp::Refiner>> refiners(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    const Variant& var = kVariants[v];
    if (!all_variants && !var.ci) continue;
    r.ran[v] = true;
    if (var.kind != Variant::kVisp) continue;
    visp::Model model;
    if (var.circle) model.circles = rim_circles(st);
    if (var.rim_polygon > 0) model.faces = rim_polygons(st, var.rim_polygon);
    if (var.tags)
      for (const visp::Face& f : tag_faces(mirror_bundle(st))) model.faces.push_back(f);
    if (var.paddle)
      for (const visp::Face& f : paddle_faces(st)) model.faces.push_back(f);
    visp::Options o = vo;
    o.klt = var.klt;
    o.display_features = std::getenv("DENTAR_VISP_DEBUG_DIR") != nullptr;
    std::string err;
    refiners[v] = visp::Refiner::create(model, k.fx, k.fy, k.cx, k.cy, o, scratch,
                                        "dentar_visp_mirror_" + std::to_string(v), &err);
    EXPECT_TRUE(refiners[v]) << var.name << ": " << err;
    if (!refiners[v]) return r;
    r.model_circles[v] = refiners[v]->model_circles();
  }

  cv::Mat gray, und, und_prev;
  bool have_prev = false;
  Iso prev_pose = Iso::Identity();
  const bool debug = std::getenv("DENTAR_VISP_DEBUG") != nullptr;
  int index = 0;
  for (const SynthFrame& s : fo.frames) {
    ++index;
    auto t0 = std::chrono::steady_clock::now();
    auto fa = ta->track(s.image, s.truth.time_s, s.truth.time_s);
    const double track_ms = ms_since(t0);
    auto fb = tb->track(s.image, s.truth.time_s, s.truth.time_s);
    EXPECT_TRUE(fa.ok() && fb.ok());
    if (!fa || !fb) return r;
    r.tracker_ms.push_back(track_ms);
    if (!fa->mirror.measured) {
      have_prev = false;
      continue;
    }
    // Diagnosis: DENTAR_VISP_SEED_TRUTH=1 seeds (and measures against) the true T_cam_mtag.
    const Iso tag_pose = std::getenv("DENTAR_VISP_SEED_TRUTH") ? s.truth.T_cam_mtag
                                                                : fa->mirror.T_cam_body_measured;  // T_cam_mtag
    const Iso& truth = s.truth.T_cam_mir;
    // The image ViSP sees (shared by the variants; its time counts in each).
    t0 = std::chrono::steady_clock::now();
    cv::cvtColor(s.image, gray, cv::COLOR_BGR2GRAY);
    cv::remap(gray, und, m1, m2, cv::INTER_LINEAR);
    const double undistort_ms = ms_since(t0);
    for (std::size_t v = 0; v < nv; ++v) {
      if (!r.ran[v]) continue;
      const Variant& var = kVariants[v];
      Stats& st_v = r.stats[v];
      ++st_v.measured;
      if (var.kind == Variant::kTags) {
        add_error(st_v, tag_pose * T_mtag_mir, truth);
        continue;
      }
      if (var.kind == Variant::kRim) {
        EXPECT_TRUE(fb->mirror.measured);
        st_v.refined += fb->mirror.rim_points > 0 ? 1 : 0;
        add_error(st_v, fb->mirror.T_cam_body_measured * T_mtag_mir, truth);
        continue;
      }
      Iso out = tag_pose;
      std::string err;
      t0 = std::chrono::steady_clock::now();
      const bool can = !var.klt || have_prev;
      const bool ok = can && refiners[v]->refine(und, tag_pose, have_prev ? &und_prev : nullptr,
                                                 have_prev ? &prev_pose : nullptr, out, &err);
      st_v.ms.push_back(ms_since(t0) + undistort_ms);
      if (can && !ok) ++st_v.threw;
      const double shift = ok ? trans_mm(out * T_mtag_mir, tag_pose * T_mtag_mir) : NAN;
      const double turn = ok ? rot_deg(out, tag_pose) : NAN;
      if (ok) {
        st_v.raw_shift_mm.push_back(shift);
        st_v.circle_sites.push_back(refiners[v]->circle_features());
      }
      if (const char* dir = std::getenv("DENTAR_VISP_DEBUG_DIR"); dir && ok && index % 5 == 1) {
        // The undistorted image, the model at the seed (blue) and at ViSP's
        // pose (yellow), the moving-edge sites (green kept, red rejected),
        // enlarged around the mirror head.
        cv::Mat vis;
        cv::cvtColor(und, vis, cv::COLOR_GRAY2BGR);
        const double sc = 4;
        cv::resize(vis, vis, {}, sc, sc, cv::INTER_NEAREST);
        auto draw_model = [&](const Iso& T, cv::Scalar col) {
          for (const auto& row : refiners[v]->model_for_display(und.cols, und.rows, T)) {
            if (row.size() >= 5 && row[0] == 0)
              cv::line(vis, cv::Point2d(row[2] * sc, row[1] * sc), cv::Point2d(row[4] * sc, row[3] * sc), col, 1);
            if (row.size() >= 6 && row[0] == 1) {
              // centre (i, j), second-order centred moments n20, n11, n02 (px^2)
              const double n20 = row[3], n11 = row[4], n02 = row[5];
              const double a = 0.5 * (n20 + n02), b = std::sqrt(0.25 * (n20 - n02) * (n20 - n02) + n11 * n11);
              const double l1 = std::sqrt(std::max(0.0, 4 * (a + b))), l2 = std::sqrt(std::max(0.0, 4 * (a - b)));
              const double ang = 0.5 * std::atan2(2 * n11, n20 - n02) * 180 / M_PI;
              cv::ellipse(vis, cv::Point2d(row[2] * sc, row[1] * sc), cv::Size2d(l1 * sc, l2 * sc), ang, 0, 360, col, 1);
            }
          }
        };
        draw_model(tag_pose, {255, 0, 0});
        draw_model(out, {0, 255, 255});
        for (const auto& row : refiners[v]->features_for_display())
          if (row.size() >= 4 && row[0] == 0)
            cv::circle(vis, cv::Point2d(row[2] * sc, row[1] * sc), 2, row[3] == 0 ? cv::Scalar(0, 255, 0) : cv::Scalar(0, 0, 255), -1);
        const Eigen::Vector3d c = tag_pose * (T_mtag_mir * V3::Zero());
        const double u = k.fx * c.x() / c.z() + k.cx, w = k.fy * c.y() / c.z() + k.cy;
        const int half = static_cast<int>(70 * sc);
        cv::Rect roi(std::clamp(static_cast<int>(u * sc) - half, 0, vis.cols - 2 * half),
                     std::clamp(static_cast<int>(w * sc) - half, 0, vis.rows - 2 * half), 2 * half, 2 * half);
        cv::imwrite(std::string(dir) + "/visp_" + std::to_string(index) + "_" + std::to_string(v) + ".png", vis(roi));
      }
      if (debug)
        std::printf("face toward the camera %d\n", (truth.linear().col(2).dot(truth.translation()) < 0) ? 1 : 0);
      if (debug)
        std::printf("frame %d %s ok %d features %d circle %d (weight %.2f) moved %.3f mm %.3f deg err %s\n", index,
                    var.name, ok, refiners[v]->features(), refiners[v]->circle_features(),
                    refiners[v]->circle_weight(), shift, turn, err.c_str());
      if (ok && (shift > max_mm || turn > max_deg)) {
        ++st_v.moved_too_far;
        out = tag_pose;
      } else if (ok) {
        ++st_v.refined;
      } else {
        out = tag_pose;
      }
      add_error(st_v, out * T_mtag_mir, truth);
    }
    std::swap(und, und_prev);
    prev_pose = tag_pose;
    have_prev = true;
  }
  return r;
}

TEST(VispMirror, MirrorHeadModelAgainstTagsAndRim) {
  DENTAR_GL_TEST_CONTEXT();
  RunSize z;
  z.frames = 20;
  if (const char* f = std::getenv("DENTAR_PRESET_FRAMES")) z.frames = std::max(5, std::atoi(f));
  if (const char* e = std::getenv("DENTAR_PRESET_SIZE")) std::sscanf(e, "%dx%d", &z.w, &z.h);
  const char* only = std::getenv("DENTAR_PRESETS");
  const bool full = only != nullptr;
  const bool ci_case = !full && z.frames == 20 && z.w == 640 && z.h == 480;
  std::printf("\n[ visp mirror ] %dx%d, %d frames, seed 5, generator v%d: mirror centre vs truth, each frame's "
              "own measurement (unfiltered, ungated)\n",
              z.w, z.h, z.frames, kSynthGeneratorVersion);
  std::printf("| preset | variant | measured | refined (threw / moved too far) | circle sites p50 | "
              "mm p50 / p95 / p99 | across mm p50 / p95 | along mm p50 / p95 | deg p50 / p95 | tilt deg p50 / p95 | "
              "time / tracker (p50) |\n|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (SynthPreset p : {SynthPreset::kStandard, SynthPreset::kMirror, SynthPreset::kHard, SynthPreset::kGlare}) {
    if (full ? std::string(only).find(synth_preset_name(p)) == std::string::npos : p != SynthPreset::kStandard)
      continue;
    SynthOptions o = synth_preset(p);
    o.frames = z.frames;
    o.width = z.w;
    o.height = z.h;
    o.seed = 5;
    o.bur_samples = 1000;
    const Footage fo = make_footage(default_station_scene(), o);
    ASSERT_TRUE(fo.error.empty()) << fo.error;
    ASSERT_EQ(fo.frames.size(), static_cast<std::size_t>(z.frames));
    const PresetRun r = run_preset(fo, full || std::getenv("DENTAR_VISP_ALL"));
    ASSERT_EQ(r.stats.size(), std::size(kVariants));
    const double track_p50 = pct(r.tracker_ms, 0.5);
    for (std::size_t v = 0; v < std::size(kVariants); ++v) {
      if (!r.ran[v]) continue;
      const Stats& s = r.stats[v];
      const Variant& var = kVariants[v];
      char refined[64] = "—", sites[32] = "—", ratio[32] = "1 (anchor)";
      if (var.kind == Variant::kRim) std::snprintf(refined, sizeof refined, "%d", s.refined);
      if (var.kind == Variant::kVisp) {
        std::snprintf(refined, sizeof refined, "%d (%d / %d)", s.refined, s.threw, s.moved_too_far);
        if (var.circle) std::snprintf(sites, sizeof sites, "%.0f", pct(s.circle_sites, 0.5));
        std::snprintf(ratio, sizeof ratio, "%.2f", pct(s.ms, 0.5) / track_p50);
      }
      if (var.kind == Variant::kRim) std::snprintf(ratio, sizeof ratio, "(in the tracker)");
      std::printf("| %s | %s | %d | %s | %s | %.2f / %.2f / %.2f | %.2f / %.2f | %.2f / %.2f | %.2f / %.2f | "
                  "%.2f / %.2f | %s |\n",
                  synth_preset_name(p), var.name, s.measured, refined, sites, pct(s.mm, 0.5), pct(s.mm, 0.95),
                  pct(s.mm, 0.99), pct(s.across_mm, 0.5), pct(s.across_mm, 0.95), pct(s.along_mm, 0.5),
                  pct(s.along_mm, 0.95), pct(s.deg, 0.5), pct(s.deg, 0.95), pct(s.tilt_deg, 0.5),
                  pct(s.tilt_deg, 0.95), ratio);
    }
    std::printf("(tag tracker track() p50 %.2f ms wall, the anchor of the time ratios)\n", track_p50);
    if (!ci_case) continue;
    // The CI case: ViSP ran on every frame with a tag pose, with the rim's
    // two circles in its model and its moving edges found on them; its poses
    // are finite; the full model (rim + tags + paddle) stays near the tag
    // pose (its raw shift, before the fallback); the fallback bounds the rest.
    const Stats& tags = r.stats[0];
    ASSERT_GE(tags.measured, z.frames * 3 / 4);
    for (std::size_t v = 2; v < 5; ++v) {
      const Stats& s = r.stats[v];
      SCOPED_TRACE(kVariants[v].name);
      ASSERT_TRUE(r.ran[v]);
      EXPECT_EQ(r.model_circles[v], 2);  // face and back
      EXPECT_EQ(s.measured, tags.measured);
      EXPECT_EQ(s.threw, 0);
      EXPECT_EQ(s.refined + s.moved_too_far, tags.measured);
      ASSERT_EQ(s.circle_sites.size(), static_cast<std::size_t>(tags.measured));
      EXPECT_GT(pct(s.circle_sites, 0.5), 10);  // the rim's moving edges were sampled
      for (double x : s.raw_shift_mm) EXPECT_TRUE(std::isfinite(x));
      for (double x : s.mm) EXPECT_TRUE(std::isfinite(x));
      EXPECT_LT(pct(s.mm, 0.95), pct(tags.mm, 0.95) + 4.5);  // the 4 mm fallback at the centre
    }
    // Measured 2026-11-27 (range 2): rim + tags + paddle refined 20 of 20,
    // raw shift p50 ~1 mm; the rim alone and rim + tag outlines move the
    // centre 10-600 mm and fall back on every frame (BENCHMARKS).
    const Stats& full_model = r.stats[4];
    EXPECT_GE(full_model.refined, tags.measured * 3 / 4);
    EXPECT_LT(pct(full_model.raw_shift_mm, 0.5), 2.0);
  }
}

}  // namespace
}  // namespace dentar::ar
