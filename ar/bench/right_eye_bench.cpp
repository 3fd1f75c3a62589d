// Issue 28 (session 16): what the right eye's own composite costs, and where it lands
// (docs/BENCHMARKS.md, "Issue 28 session 16 — the right eye's composite").
//
//   ./build/ar/ar_right_eye_bench [--frames N] [--sizes 640x480,1280x720] [--preset standard|hard|mirror]
//                                 [--seed S] [--baseline-mm B]
//
// For each size: N frames of generated stereo footage (StereoSynthGenerator: both eyes of a
// rig of B mm, truth per eye), then three frame pipelines over the same frames, alternating
// frame by frame (same input, same load), each with its own tracker, compositors and meshes:
//   mono         one camera (the left eye's images), the mono composite
//   stereo-left  both eyes tracked (StereoTracker), the left eye composited (session 15)
//   stereo-both  both eyes tracked, each eye composited (FramePipeline::process's right output)
// FramePipeline::process is timed with the process's CPU clock (CLOCK_PROCESS_CPUTIME_ID:
// llvmpipe's rasteriser threads count; other processes on the machine do not). A bogus
// stylus pose from the truth draws the bur and handpiece; no cutting.
//
// Per-eye agreement (stereo-both): in each eye, the tooth frame's origin projected with the
// pipeline's pose against the same point with that eye's true pose (px), and the drawn
// silhouette (CompositeResult::tooth_visible > 127) against the eye's visible-tooth mask (IoU).
// Frames 0-1 (the filter starting) and frames with the mannequin lost are left out.
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <opencv2/core.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "dentar/ar/camera_model.h"
#include "dentar/ar/egl_context.h"
#include "dentar/ar/frame_pipeline.h"
#include "dentar/ar/synth.h"
#include "dentar/volume/procedural_tooth.h"

namespace dentar::ar {
namespace {

double cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

struct Args {
  int frames = 40;
  std::vector<std::pair<int, int>> sizes = {{640, 480}, {1280, 720}};
  std::string preset = "standard";
  std::uint64_t seed = 5;
  double baseline_mm = 63;
};

[[noreturn]] void usage(const std::string& why) {
  std::fprintf(stderr,
               "ar_right_eye_bench: %s\nusage: ar_right_eye_bench [--frames N] [--sizes WxH,...] "
               "[--preset standard|hard|mirror] [--seed S] [--baseline-mm B]\n",
               why.c_str());
  std::exit(2);
}

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    auto val = [&]() -> std::string {
      if (i + 1 >= argc) usage(k + " needs a value");
      return argv[++i];
    };
    if (k == "--frames") {
      a.frames = std::atoi(val().c_str());
      if (a.frames < 4 || a.frames > 10000) usage("--frames must be in 4..10000");
    } else if (k == "--sizes") {
      a.sizes.clear();
      std::stringstream ss(val());
      for (std::string s; std::getline(ss, s, ',');) {
        int w = 0, h = 0;
        if (std::sscanf(s.c_str(), "%dx%d", &w, &h) != 2 || w < 64 || h < 48 || w > 4096 || h > 4096)
          usage("--sizes: '" + s + "' is not WxH (64x48 .. 4096x4096)");
        a.sizes.emplace_back(w, h);
      }
      if (a.sizes.empty()) usage("--sizes is empty");
    } else if (k == "--preset") {
      a.preset = val();
    } else if (k == "--seed") {
      a.seed = std::strtoull(val().c_str(), nullptr, 10);
    } else if (k == "--baseline-mm") {
      a.baseline_mm = std::atof(val().c_str());
      if (!(a.baseline_mm >= 10 && a.baseline_mm <= 200)) usage("--baseline-mm must be in 10..200");
    } else {
      usage("unknown argument '" + k + "'");
    }
  }
  return a;
}

double pct(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::min<double>(v.size() - 1, std::ceil(q * (v.size() - 1))))];
}

double iou(const cv::Mat& a, const cv::Mat& b) {
  const int i = cv::countNonZero(a & b), u = cv::countNonZero(a | b);
  return u > 0 ? static_cast<double>(i) / u : std::nan("");
}

int run(const Args& a) {
  const auto preset = parse_synth_preset(a.preset);
  if (!preset) usage("unknown --preset '" + a.preset + "'");
  auto egl = EglContext::create();
  if (!egl || !egl->make_current()) {
    std::fprintf(stderr, "ar_right_eye_bench: no headless EGL context: %s\n", egl ? "make_current failed" : egl.error().c_str());
    return 1;
  }
  std::printf("| size per eye | path | frames | CPU ms p50 | p99 | left / right eye compose wall ms p50 |\n|---|---|---|---|---|---|\n");
  std::vector<std::string> agreement;
  for (const auto& [W, H] : a.sizes) {
    StationScene st0 = default_station_scene();
    st0.stereo = make_stereo_rig(st0.calibration.camera, a.baseline_mm * 1e-3);
    SynthOptions so = synth_preset(*preset);
    so.frames = a.frames;
    so.width = W;
    so.height = H;
    so.seed = a.seed;
    so.stereo = true;
    auto gen = StereoSynthGenerator::create(st0, so);
    if (!gen) {
      std::fprintf(stderr, "ar_right_eye_bench: %s\n", gen.error().c_str());
      return 1;
    }
    std::vector<StereoSynthFrame> frames(static_cast<std::size_t>(a.frames));
    for (auto& f : frames)
      if (Status s = (*gen)->next(f); !s) {
        std::fprintf(stderr, "ar_right_eye_bench: %s\n", s.error().c_str());
        return 1;
      }
    const StationScene& st = (*gen)->station();
    volume::MolarParams mp;
    mp.voxel_mm = st.tooth_voxel_m * 1e3;
    auto vol = volume::make_molar(mp);
    if (!vol) {
      std::fprintf(stderr, "ar_right_eye_bench: %s\n", vol.error().c_str());
      return 1;
    }
    struct Path {
      const char* name;
      bool stereo, right;
      std::unique_ptr<FramePipeline> pipe;
      std::unique_ptr<ToothMeshes> meshes;
      std::vector<double> ms, left_ms, right_ms;
    };
    Path paths[3] = {{"mono", false, false, {}, {}, {}, {}, {}},
                     {"stereo-left", true, false, {}, {}, {}, {}, {}},
                     {"stereo-both", true, true, {}, {}, {}, {}, {}}};
    for (Path& p : paths) {
      PipelineOptions po;
      po.stereo = p.stereo;
      auto made = FramePipeline::create(st, po);
      if (!made) {
        std::fprintf(stderr, "ar_right_eye_bench: %s\n", made.error().c_str());
        return 1;
      }
      p.pipe = std::move(*made);
      p.meshes = std::make_unique<ToothMeshes>(*vol);
      if (Status s = p.pipe->warm_up(*p.meshes); !s) {
        std::fprintf(stderr, "ar_right_eye_bench: %s\n", s.error().c_str());
        return 1;
      }
    }
    std::vector<double> err_l, err_r, iou_l, iou_r;
    const CameraModel cam_l(st.calibration.camera), cam_r(st.stereo.camera_right);
    const Eigen::Isometry3d T_camr_rig = st.stereo.T_caml_camr.inverse();
    haptics::HapticSnapshot snap{};
    for (int i = 0; i < a.frames; ++i) {
      const StereoSynthFrame& f = frames[static_cast<std::size_t>(i)];
      const Eigen::Matrix4d m = f.left.truth.T_dev_sty.matrix();
      for (int k = 0; k < 16; ++k) snap.T_dev_sty[k] = m(k % 4, k / 4);
      for (Path& p : paths) {
        FrameInput in;
        in.image = &f.left.image;
        in.right_image = p.stereo ? &f.right.image : nullptr;
        in.index = i;
        in.capture_time_s = i / 30.0;
        in.haptic = &snap;
        in.stylus_valid = true;
        CompositeResult out, right;
        FrameRecord r;
        const double t0 = cpu_ms();
        const Status s = p.pipe->process(in, *p.meshes, out, r, p.right ? &right : nullptr);
        p.ms.push_back(cpu_ms() - t0);
        if (!s) {
          std::fprintf(stderr, "ar_right_eye_bench: %s\n", s.error().c_str());
          return 1;
        }
        p.left_ms.push_back(r.composite_ms);
        if (p.right && r.right.composited) p.right_ms.push_back(r.right.composite_ms);
        if (!p.right || i < 2 || r.man_state == 2 || !r.right.composited) continue;
        const Eigen::Isometry3d T_caml_tooth = r.T_cam_man * st.calibration.T_man_tooth;
        const auto dl = cam_l.project(T_caml_tooth.translation()), tl = cam_l.project(f.left.truth.T_cam_tooth.translation());
        const auto dr = cam_r.project((T_camr_rig * T_caml_tooth).translation()),
                   tr = cam_r.project(f.right.truth.T_cam_tooth.translation());
        if (dl && tl) err_l.push_back((*dl - *tl).norm());
        if (dr && tr) err_r.push_back((*dr - *tr).norm());
        iou_l.push_back(iou(out.tooth_visible > 127, f.left.mask == kMaskToothVisible));
        iou_r.push_back(iou(right.tooth_visible > 127, f.right.mask == kMaskToothVisible));
      }
    }
    for (const Path& p : paths)
      std::printf("| %dx%d | %s | %zu | %.2f | %.2f | %.2f / %s |\n", W, H, p.name, p.ms.size(), pct(p.ms, 0.5),
                  pct(p.ms, 0.99), pct(p.left_ms, 0.5),
                  p.right_ms.empty() ? "-" : std::to_string(pct(p.right_ms, 0.5)).substr(0, 5).c_str());
    char b[512];
    std::snprintf(b, sizeof b,
                  "| %dx%d | %zu | %.2f / %.2f / %.2f | %.2f / %.2f / %.2f | %.3f / %.3f | %.3f / %.3f |", W, H,
                  err_r.size(), pct(err_l, 0.5), pct(err_l, 0.95), pct(err_l, 1.0), pct(err_r, 0.5), pct(err_r, 0.95),
                  pct(err_r, 1.0), pct(iou_l, 0.5), pct(iou_l, 0.0), pct(iou_r, 0.5), pct(iou_r, 0.0));
    agreement.emplace_back(b);
  }
  std::printf("\nPer-eye agreement (stereo-both), tooth centre against each eye's truth, px (median / p95 / max), "
              "silhouette IoU (median / min):\n\n");
  std::printf("| size per eye | frames | left centre px | right centre px | left IoU | right IoU |\n|---|---|---|---|---|---|\n");
  for (const auto& l : agreement) std::printf("%s\n", l.c_str());
  return 0;
}

}  // namespace
}  // namespace dentar::ar

int main(int argc, char** argv) { return dentar::ar::run(dentar::ar::parse(argc, argv)); }
