// Issue 28, benchmark 3: the frame's CPU cost against the camera's resolution
// and the overlay's pixel area (docs/BENCHMARKS.md, "Issue 28 (session 15):
// frame cost against overlay").
//
//   ./build/ar/ar_frame_cost_bench [--frames N] [--sizes 640x480,1280x720,1920x1080]
//                                  [--preset standard|hard|mirror] [--seed S] [--csv FILE]
//                                  [--paths region,main,angular,pixel,roidec,whole,native] [--gl] [--repeat R] [--truth-poses]
//                                  [--yuyv] [--stereo] [--outline] [--rounds R]
//
// For each size: N frames of generated footage (the same scene and motion at every
// size: the generator rescales the station camera), then the frame pipeline's own
// tracker and compositor run over them once per path (region: the defaults; main: the
// defaults without CompositorOptions::cull_facing_away, i.e. main before issue 28's
// session 15; whole: CompositorOptions::region_path = false and
// TrackerOptions::predicted_regions = false; angular: region with lod_reference_width_px = 640,
// the same error in angle at every size as 1 px at 640x480; the default since session 16;
// pixel: the budget in px of the frame itself, session 15's default; roidec: region with
// TrackerOptions::roi_decimation_max = 4), the paths
// alternating frame by frame (same input, same load), each path with its own
// pipeline. Every stage is timed with the process's CPU clock
// (CLOCK_PROCESS_CPUTIME_ID: llvmpipe's rasteriser threads work for the frame thread
// and are counted; the other engineers' processes on the machine are not). The
// CPU path waits for its GL work (glFinish inside compose); with --gl the GPU path
// (compose_gl, the live display's) is followed by glFinish so its shader passes count.
//
// What is counted as what (per frame):
//   passthrough  what a bare viewer does with the frame: the CPU path's copy of the
//                frame into the output image; with --gl the conversion to RGBA and the
//                texture upload. Measured by doing exactly that once more on the same
//                frame, outside the pipeline (the pipeline does it inside compose).
//   track        Tracker::track (colour to grey, tag search, poses, filter)
//   composite    Compositor::compose / compose_gl, passthrough included
//   ar           track + composite - passthrough: everything the trainer adds
// Decode and swap are not part of this bench (no decoder, no window): they are the
// same for a bare viewer and for DentAR.
//
// --truth-poses: the tracker runs (and is timed) as always, but the compositor is given the
// generator's true poses, so every size draws the same things (tracking at 640x480 loses
// the mirror's small tag more often, which shrinks the overlay there).
//
// --yuyv (session 16): the camera's own format. Each generated frame is turned into YUYV
// 4:2:2 beforehand (frame_gray.h, bgr_to_yuyv: what a UVC camera sends); the tracker
// is given the YUYV frame (grey from the Y plane, only where it searches), and the
// compositor the BGR that a bare viewer's YUYV-to-BGR conversion makes once per frame
// (timed as 'decode', outside the AR part: a bare viewer does it too).
// --paths ...,native (session 17, with --yuyv): the camera's own format carried through:
// the region path's pipeline given the YUYV frame itself (the compositor converts it once
// into its output, in place of its copy; with --gl it uploads YUYV and converts in a
// shader), so there is no separate decode. Its AR part subtracts what a bare viewer does
// with a YUYV frame (decode + passthrough), the others' only passthrough (decode is
// outside them). 'frame CPU' = decode + track + composite: everything from the camera's
// bytes to the composite, the figure to compare between region and native.
// --stereo: both eyes of a 63 mm rig (StereoSynthGenerator); the tracker is the
// StereoTracker over both eyes and each eye is composited at its own pose (the left
// at the rig's, the right at T_camr_caml times it; --truth-poses: each eye's truth),
// so every per-frame figure is the pair's (passthrough: both eyes' copies).
// --outline: per frame, the drawn tooth's outline against the truth: the visible-tooth
// mask (CompositeResult::tooth_visible >= 128) against the same mask composited at the
// true pose with the full mesh (lod_max_error_px = 0), as the mean distance between the
// two outlines in px (differing pixels / the truth outline's length), in px of the frame
// and in px of a 640-px-wide frame (the same angle at every size). Left eye only.
//
// --rounds R: R sweeps over the sizes, the order reversed every other sweep, each size's
// samples pooled over the sweeps: on a shared machine the load drifts during a run,
// and a size measured only at its end of the run would carry the drift into the ratio.
//
// Output: one table row per (size, path) with medians and p99s, and per size a table of
// the AR part against the overlay's area (CompositeResult::region, output pixels), in
// quartiles of that area. --csv writes every frame.
// Profiling only the timed loops (not the footage generator): DENTAR_PERF_CTL=<fifo> writes
// perf's "enable"/"disable" commands there around them, e.g.
//   mkfifo ctl; perf record -D -1 --control=fifo:ctl -g -o perf.data -- ./ar_frame_cost_bench ...
#include <time.h>

#include <GLES3/gl3.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "dentar/ar/egl_context.h"
#include "dentar/ar/frame_gray.h"
#include "dentar/ar/frame_pipeline.h"
#include "dentar/ar/stereo_tracker.h"
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
  int frames = 60;
  std::vector<std::pair<int, int>> sizes = {{640, 480}, {1280, 720}, {1920, 1080}};
  std::string preset = "standard";
  std::uint64_t seed = 5;
  std::string csv;
  std::vector<std::string> paths = {"region", "main", "whole"};
  bool gl = false;
  int repeat = 1;  // passes over the frames (more samples for a profile)
  bool truth_poses = false;
  bool yuyv = false, stereo = false, outline = false;
  int rounds = 1;  // sweeps over the sizes, alternating their order (load drift averages out)
};

[[noreturn]] void usage(const std::string& why) {
  std::fprintf(stderr,
               "ar_frame_cost_bench: %s\nusage: ar_frame_cost_bench [--frames N] [--sizes WxH,...] "
               "[--preset standard|hard|mirror] [--seed S] [--csv FILE] [--paths region,main,angular,pixel,roidec,whole,native,nomirror,nophantoms,noseg,coarse,full,before23,tripx,tripx2,cell5,drawbuf,refl] [--gl] [--repeat R] [--truth-poses] "
               "[--yuyv] [--stereo] [--outline] [--rounds R]\n",
               why.c_str());
  std::exit(2);
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string t; std::getline(ss, t, ',');)
    if (!t.empty()) out.push_back(t);
  return out;
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
      if (a.frames < 2 || a.frames > 10000) usage("--frames must be in 2..10000");
    } else if (k == "--sizes") {
      a.sizes.clear();
      for (const auto& s : split(val())) {
        int w = 0, h = 0;
        if (std::sscanf(s.c_str(), "%dx%d", &w, &h) != 2 || w < 64 || h < 48 || w > 4096 || h > 4096)
          usage("--sizes: '" + s + "' is not WxH (64x48 .. 4096x4096)");
        a.sizes.emplace_back(w, h);
      }
    } else if (k == "--preset") {
      a.preset = val();
    } else if (k == "--seed") {
      a.seed = std::strtoull(val().c_str(), nullptr, 10);
    } else if (k == "--csv") {
      a.csv = val();
    } else if (k == "--paths") {
      a.paths = split(val());
      for (const auto& p : a.paths)
        if (p != "region" && p != "whole" && p != "main" && p != "angular" && p != "pixel" && p != "roidec" &&
            p != "native" && p != "nomirror" && p != "nophantoms" && p != "coarse" && p != "full" && p != "noseg" &&
            p != "before23" && p != "tripx" && p != "tripx2" && p != "cell5" && p != "drawbuf" && p != "refl")
          usage("--paths: '" + p + "' is not region, main, angular, pixel, roidec, whole or native");
      if (a.paths.empty()) usage("--paths is empty");
    } else if (k == "--repeat") {
      a.repeat = std::atoi(val().c_str());
      if (a.repeat < 1 || a.repeat > 1000) usage("--repeat must be in 1..1000");
    } else if (k == "--truth-poses") {
      a.truth_poses = true;
    } else if (k == "--rounds") {
      a.rounds = std::atoi(val().c_str());
      if (a.rounds < 1 || a.rounds > 100) usage("--rounds must be in 1..100");
    } else if (k == "--yuyv") {
      a.yuyv = true;
    } else if (k == "--stereo") {
      a.stereo = true;
    } else if (k == "--outline") {
      a.outline = true;
    } else if (k == "--gl") {
      a.gl = true;
    } else {
      usage("unknown argument '" + k + "'");
    }
  }
  for (const auto& p : a.paths)
    if (p == "native" && !a.yuyv) usage("--paths native needs --yuyv (the camera's own format to carry)");
  return a;
}

// perf's control fifo (DENTAR_PERF_CTL), or nothing.
void perf_control(const char* cmd) {
  const char* p = std::getenv("DENTAR_PERF_CTL");
  if (p == nullptr || *p == 0) return;
  if (std::FILE* f = std::fopen(p, "w")) {
    std::fprintf(f, "%s\n", cmd);
    std::fclose(f);
  }
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const double pos = q * (v.size() - 1);
  const auto i = static_cast<std::size_t>(pos);
  const double f = pos - i;
  return i + 1 < v.size() ? v[i] * (1 - f) + v[i + 1] * f : v[i];
}

struct Sample {
  double track = 0, composite = 0, passthrough = 0, ar = 0;
  double render_wall = 0, blend_wall = 0, segment_wall = 0, readback_wall = 0, sync_wall = 0, upload_wall = 0;
  double grey_wall = 0, detect_wall = 0, pose_wall = 0, filter_wall = 0;
  double decode = 0;         // --yuyv: the bare viewer's YUYV-to-BGR conversion (not in ar; 0 for native)
  double gray_fraction = 0;  // of the frame converted to grey by the tracker (left eye)
  double outline_px = -1;    // --outline: mean outline distance to the truth, px (-1: no tooth)
  double man_err_mm = -1;    // the mannequin's tracked pose (drawn) against the truth, mm (-1: lost)
  int area = 0;  // overlay region, output px
  std::size_t tris = 0;
  int lod = 0;
  bool full_frame = false;
};

struct Run {
  std::string path;
  std::unique_ptr<FramePipeline> pipe;
  std::unique_ptr<FramePipeline> pipe_r;  // --stereo: the right eye's compositor
  std::optional<StereoTracker> stereo;    // --stereo: the tracker over both eyes
  std::unique_ptr<ToothMeshes> meshes;
  CompositeResult out, out_r;
  std::vector<Sample> samples;
};

int run(const Args& a) {
  auto ctx = EglContext::create();
  if (!ctx) {
    std::fprintf(stderr, "ar_frame_cost_bench: %s\n", ctx.error().c_str());
    return 1;
  }
  std::fprintf(stderr, "ar_frame_cost_bench: %s\n", ctx->description().c_str());
  const auto preset = parse_synth_preset(a.preset);
  if (!preset) usage("unknown --preset '" + a.preset + "'");
  std::ofstream csv;
  if (!a.csv.empty()) {
    csv.open(a.csv);
    if (!csv) {
      std::fprintf(stderr, "ar_frame_cost_bench: cannot write --csv %s\n", a.csv.c_str());
      return 2;
    }
    csv << "size,path,frame,area_px,tris,lod,full_frame,track_ms,composite_ms,passthrough_ms,ar_ms,decode_ms,gray_fraction,outline_px\n";
  }

  std::printf("| size | path | overlay area p50 px (%% of frame) | track p50 / p99 ms | composite p50 / p99 ms | "
              "passthrough p50 ms | **AR part p50 / p99 ms** | tooth triangles p50 (level of detail) |\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  std::map<std::string, std::vector<std::pair<std::string, double>>> ar_by_path;  // path -> (size, p50)
  std::vector<std::string> area_tables, stage_rows, extra_rows, frame_rows;

  std::map<std::pair<int, int>, std::vector<std::pair<std::string, std::vector<Sample>>>> pooled;
  for (int round = 0; round < a.rounds; ++round)
  for (std::size_t si = 0; si < a.sizes.size(); ++si) {
    const auto [W, H] = a.sizes[round % 2 == 0 ? si : a.sizes.size() - 1 - si];
    SynthOptions so = synth_preset(*preset);
    so.frames = a.frames;
    so.width = W;
    so.height = H;
    so.seed = a.seed;
    std::vector<SynthFrame> frames(static_cast<std::size_t>(a.frames)), rights;
    StationScene station;
    if (a.stereo) {
      StationScene st = default_station_scene();
      st.stereo = make_stereo_rig(st.calibration.camera, 0.063);
      auto gen = StereoSynthGenerator::create(st, so);
      if (!gen) {
        std::fprintf(stderr, "ar_frame_cost_bench: generator: %s\n", gen.error().c_str());
        return 1;
      }
      rights.resize(frames.size());
      for (std::size_t i = 0; i < frames.size(); ++i) {
        StereoSynthFrame sf;
        if (auto s = (*gen)->next(sf); !s) {
          std::fprintf(stderr, "ar_frame_cost_bench: generator: %s\n", s.error().c_str());
          return 1;
        }
        frames[i] = std::move(sf.left);
        rights[i] = std::move(sf.right);
      }
      station = (*gen)->station();
    } else {
      auto gen = SynthGenerator::create(default_station_scene(), so);
      if (!gen) {
        std::fprintf(stderr, "ar_frame_cost_bench: generator: %s\n", gen.error().c_str());
        return 1;
      }
      for (auto& f : frames)
        if (auto s = (*gen)->next(f); !s) {
          std::fprintf(stderr, "ar_frame_cost_bench: generator: %s\n", s.error().c_str());
          return 1;
        }
      station = (*gen)->station();
    }
    StationScene station_r = station;  // the right eye's camera for its compositor
    if (a.stereo) station_r.calibration.camera = station.stereo.camera_right;
    // The camera's own format (--yuyv): converted before anything is timed.
    std::vector<cv::Mat> yuyv_l, yuyv_r;
    if (a.yuyv) {
      for (const auto& f : frames) bgr_to_yuyv(f.image, yuyv_l.emplace_back());
      for (const auto& f : rights) bgr_to_yuyv(f.image, yuyv_r.emplace_back());
    }
    volume::MolarParams mp;
    mp.voxel_mm = station.tooth_voxel_m * 1e3;
    auto vol = volume::make_molar(mp);
    if (!vol) {
      std::fprintf(stderr, "ar_frame_cost_bench: molar: %s\n", vol.error().c_str());
      return 1;
    }

    // GL targets for --gl (camera size, RGBA8), one pair per path.
    std::vector<GLuint> textures;
    auto make_tex = [&] {
      GLuint t = 0;
      glGenTextures(1, &t);
      glBindTexture(GL_TEXTURE_2D, t);
      glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA8, W, H);
      glBindTexture(GL_TEXTURE_2D, 0);
      textures.push_back(t);
      return t;
    };
    std::vector<Run> runs;
    std::vector<GlFrameTarget> targets;
    for (const auto& p : a.paths) {
      PipelineOptions po;
      po.compositor.region_path = p != "whole";
      // The whole-frame rival also searches the whole frame for tags every frame.
      po.tracker.predicted_regions = p != "whole";
      // main before session 15: the region path without the facing test.
      po.compositor.cull_facing_away = p != "main";
      // angular: the region path with the level of detail's error budget kept constant in
      // angle (1 px at 640 px wide): what meeting the goal by coarser meshes would mean.
      if (p == "angular") po.compositor.lod_reference_width_px = 640;
      // pixel: the region path with the level of detail's budget in px of the frame itself.
      if (p == "pixel") po.compositor.lod_reference_width_px = 0;
      // roidec: the region path with the tag search's decimation following the tags' size.
      if (p == "roidec") po.tracker.roi_decimation_max = 4;
      // Session 23, the composite's passes by ablation (the region path without one of them):
      // nomirror (no reflection), nophantoms (no depth phantoms), noseg (no segmentation),
      // coarse (the coarsest level of detail always), full (the full mesh always).
      if (p == "nomirror") po.compositor.mirror = false;
      if (p == "nophantoms") po.compositor.phantoms = false;
      if (p == "noseg") po.compositor.segmentation = false;
      if (p == "coarse") po.compositor.lod_max_error_px = 100;
      if (p == "full") po.compositor.lod_max_error_px = 0;
      // before23: the region path as before session 23 (every mannequin part in the region
      // drawn in both views, attachments switched by glDrawBuffers); tripx / tripx2: the level also coarsened while a triangle covers
      // < 1 / < 2 px (CompositorOptions::lod_min_triangle_px).
      if (p == "before23") {
        po.compositor.phantom_depth_cull = false;
        po.compositor.phantom_facing_cull = false;
        po.compositor.attachment_masks = false;
      }
      if (p == "tripx") po.compositor.lod_min_triangle_px = 1;
      if (p == "tripx2") po.compositor.lod_min_triangle_px = 2;
      // cell5: the mannequin's culling parts 5 mm (default 10 mm).
      if (p == "cell5") po.compositor.phantom_cell_m = 0.005;
      // drawbuf: the attachments switched by glDrawBuffers (before session 23).
      if (p == "drawbuf") po.compositor.attachment_masks = false;
      // refl: the reflection at its own level of detail (CompositorOptions::reflection_lod).
      if (p == "refl") po.compositor.reflection_lod = true;
      auto pipe = FramePipeline::create(station, po);
      if (!pipe) {
        std::fprintf(stderr, "ar_frame_cost_bench: %s\n", pipe.error().c_str());
        return 1;
      }
      Run r;
      r.path = p;
      r.pipe = std::move(pipe).value();
      r.meshes = std::make_unique<ToothMeshes>(*vol);
      if (a.stereo) {
        auto st = StereoTracker::create(station, po.tracker);
        auto pr = FramePipeline::create(station_r, po);
        if (!st || !pr) {
          std::fprintf(stderr, "ar_frame_cost_bench: --stereo: %s\n", (!st ? st.error() : pr.error()).c_str());
          return 1;
        }
        r.stereo.emplace(std::move(st).value());
        r.pipe_r = std::move(pr).value();
        if (a.gl) {
          std::fprintf(stderr, "ar_frame_cost_bench: --stereo with --gl is not supported\n");
          return 2;
        }
        if (auto s2 = r.pipe_r->warm_up(*r.meshes, GlFrameTarget{}); !s2) {
          std::fprintf(stderr, "ar_frame_cost_bench: %s\n", s2.error().c_str());
          return 1;
        }
      }
      GlFrameTarget t;
      if (a.gl) {
        t.video_texture = make_tex();
        t.overlay_texture = make_tex();
        if (std::string e = r.pipe->compositor().gpu_path_error(); !e.empty()) {
          std::fprintf(stderr, "ar_frame_cost_bench: --gl: %s\n", e.c_str());
          return 1;
        }
      }
      if (auto s = r.pipe->warm_up(*r.meshes, t); !s) {
        std::fprintf(stderr, "ar_frame_cost_bench: %s\n", s.error().c_str());
        return 1;
      }
      targets.push_back(t);
      runs.push_back(std::move(r));
    }
    GLuint bare_tex = a.gl ? make_tex() : 0;
    cv::Mat bare, bare_rgba, bare_r, decoded_l, decoded_r;
    // --outline: the truth's compositor (full mesh, the defaults otherwise).
    std::unique_ptr<FramePipeline> truth_pipe;
    std::unique_ptr<ToothMeshes> truth_meshes;
    CompositeResult truth_out;
    if (a.outline) {
      PipelineOptions po;
      po.compositor.lod_max_error_px = 0;
      auto tp = FramePipeline::create(station, po);
      if (!tp) {
        std::fprintf(stderr, "ar_frame_cost_bench: %s\n", tp.error().c_str());
        return 1;
      }
      truth_pipe = std::move(tp).value();
      truth_meshes = std::make_unique<ToothMeshes>(*vol);
      if (auto s = truth_pipe->warm_up(*truth_meshes, GlFrameTarget{}); !s) {
        std::fprintf(stderr, "ar_frame_cost_bench: %s\n", s.error().c_str());
        return 1;
      }
    }
    cv::Mat truth_mask, truth_edge, path_mask, xor_mask;

    perf_control("enable");
    for (std::size_t n = 0; n < frames.size() * static_cast<std::size_t>(a.repeat); ++n) {
      const std::size_t i = n % frames.size();
      const SynthFrame& f = frames[i];
      const double t_s = static_cast<double>(n) / so.fps;
      // The bare viewer's work on this frame: with --yuyv first its conversion to BGR
      // (decode: outside the AR part, and the compositor's input).
      double c0 = cpu_ms();
      if (a.yuyv) {
        cv::cvtColor(yuyv_l[i], decoded_l, cv::COLOR_YUV2BGR_YUYV);
        if (a.stereo) cv::cvtColor(yuyv_r[i], decoded_r, cv::COLOR_YUV2BGR_YUYV);
      }
      const double decode = cpu_ms() - c0;
      const cv::Mat& img_l = a.yuyv ? decoded_l : f.image;
      const cv::Mat& img_r = a.yuyv ? decoded_r : (a.stereo ? rights[i].image : f.image);
      c0 = cpu_ms();
      if (a.gl) {
        cv::cvtColor(f.image, bare_rgba, cv::COLOR_BGR2RGBA);
        glBindTexture(GL_TEXTURE_2D, bare_tex);
        glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
        glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, W, H, GL_RGBA, GL_UNSIGNED_BYTE, bare_rgba.data);
        glBindTexture(GL_TEXTURE_2D, 0);
        glFinish();
      } else {
        img_l.copyTo(bare);
        if (a.stereo) img_r.copyTo(bare_r);
      }
      const double passthrough = cpu_ms() - c0;
      if (a.outline) {  // the truth's outline (not timed)
        CompositeInput ti;
        ti.video_bgr = &img_l;
        ti.man_valid = ti.mirror_valid = ti.stylus_valid = true;
        ti.T_cam_man = f.truth.T_cam_man;
        ti.T_cam_mtag = f.truth.T_cam_mtag;
        ti.T_dev_sty = f.truth.T_dev_sty;
        truth_meshes->sync();
        if (Status ts = truth_pipe->compositor().compose(truth_meshes->display(), ti, truth_out); !ts) {
          std::fprintf(stderr, "ar_frame_cost_bench: frame %zu (truth): %s\n", i, ts.error().c_str());
          return 1;
        }
        truth_mask = truth_out.tooth_visible >= 128;
        cv::Mat eroded;
        cv::erode(truth_mask, eroded, cv::Mat());
        truth_edge = truth_mask - eroded;
      }
      for (std::size_t ri = 0; ri < runs.size(); ++ri) {
        // Alternate which path goes first, so neither always finds the caches warm.
        Run& r = runs[(ri + i) % runs.size()];
        const GlFrameTarget& tgt = targets[(ri + i) % runs.size()];
        Sample s;
        s.passthrough = passthrough;
        s.decode = decode;
        const cv::Mat& track_l = a.yuyv ? yuyv_l[i] : f.image;
        c0 = cpu_ms();
        r.meshes->sync();
        Result<TrackFrame> tf = TrackFrame{};
        std::optional<Eigen::Isometry3d> rig_man, rig_mtag;  // --stereo, tracked poses
        if (a.stereo) {
          auto sf = r.stereo->track(track_l, a.yuyv ? yuyv_r[i] : rights[i].image, t_s, t_s);
          if (!sf) {
            std::fprintf(stderr, "ar_frame_cost_bench: frame %zu: %s\n", i, sf.error().c_str());
            return 1;
          }
          TrackFrame lf = sf->left;
          lf.mannequin = sf->mannequin.track;
          lf.mirror = sf->mirror.track;
          tf = std::move(lf);
        } else {
          tf = r.pipe->tracker().track(track_l, t_s, t_s, nullptr, static_cast<std::int64_t>(n));
        }
        const double c1 = cpu_ms();
        if (!tf) {
          std::fprintf(stderr, "ar_frame_cost_bench: frame %zu: %s\n", i, tf.error().c_str());
          return 1;
        }
        const bool native = r.path == "native";
        if (native) s.decode = 0;  // no conversion before the pipeline: the compositor's own
        CompositeInput ci;
        ci.video_bgr = native ? &yuyv_l[i] : &img_l;
        if (a.truth_poses) {
          ci.man_valid = ci.mirror_valid = true;
          ci.T_cam_man = f.truth.T_cam_man;
          ci.T_cam_mtag = f.truth.T_cam_mtag;
        } else {
          ci.man_valid = tf->mannequin.state != TrackState::kLost;
          ci.T_cam_man = tf->mannequin.T_cam_body;
          ci.mirror_valid = tf->mirror.state != TrackState::kLost;
          ci.T_cam_mtag = tf->mirror.T_cam_body;
        }
        ci.stylus_valid = true;
        ci.T_dev_sty = f.truth.T_dev_sty;
        Status cs = a.gl ? r.pipe->compositor().compose_gl(r.meshes->display(), ci, tgt, r.out)
                         : r.pipe->compositor().compose(r.meshes->display(), ci, r.out);
        if (a.gl) glFinish();
        if (cs && a.stereo) {  // the right eye at its own pose
          CompositeInput cr = ci;
          cr.video_bgr = native ? &yuyv_r[i] : &img_r;
          if (a.truth_poses) {
            cr.T_cam_man = rights[i].truth.T_cam_man;
            cr.T_cam_mtag = rights[i].truth.T_cam_mtag;
          } else {
            const Eigen::Isometry3d T_camr_caml = station.stereo.T_caml_camr.inverse();
            cr.T_cam_man = T_camr_caml * ci.T_cam_man;
            cr.T_cam_mtag = T_camr_caml * ci.T_cam_mtag;
          }
          cs = r.pipe_r->compositor().compose(r.meshes->display(), cr, r.out_r);
        }
        const double c2 = cpu_ms();
        if (!cs) {
          std::fprintf(stderr, "ar_frame_cost_bench: frame %zu: %s\n", i, cs.error().c_str());
          return 1;
        }
        s.track = c1 - c0;
        s.composite = c2 - c1;
        s.ar = s.track + s.composite - s.passthrough - (native ? decode : 0.0);
        s.area = r.out.region.area() + (a.stereo ? r.out_r.region.area() : 0);
        s.tris = r.out.triangles_drawn + (a.stereo ? r.out_r.triangles_drawn : 0);
        s.lod = r.out.lod_level;
        s.full_frame = tf->full_frame;
        s.gray_fraction = tf->gray_fraction;
        if (tf->mannequin.state != TrackState::kLost)
          s.man_err_mm = 1e3 * (tf->mannequin.T_cam_body.translation() - f.truth.T_cam_man.translation()).norm();
        if (a.outline) {
          const int edge = cv::countNonZero(truth_edge);
          if (edge >= 10) {
            path_mask = r.out.tooth_visible >= 128;
            cv::bitwise_xor(path_mask, truth_mask, xor_mask);
            s.outline_px = double(cv::countNonZero(xor_mask)) / edge;
          }
        }
        s.render_wall = r.out.timing.render_ms;
        s.blend_wall = r.out.timing.blend_ms;
        s.segment_wall = r.out.timing.segment_ms;
        s.readback_wall = r.out.timing.readback_ms;
        s.sync_wall = r.out.timing.sync_ms;
        s.upload_wall = r.out.timing.upload_ms;
        s.detect_wall = tf->timing.detect_ms;
        s.pose_wall = tf->timing.pose_ms;
        s.filter_wall = tf->timing.filter_ms;
        s.grey_wall = tf->timing.total_ms - s.detect_wall - s.pose_wall - s.filter_wall;
        r.samples.push_back(s);
        if (csv)
          csv << W << 'x' << H << ',' << r.path << ',' << i << ',' << s.area << ',' << s.tris << ',' << s.lod << ','
              << (s.full_frame ? 1 : 0) << ',' << s.track << ',' << s.composite << ',' << s.passthrough << ','
              << s.ar << ',' << s.decode << ',' << s.gray_fraction << ',' << s.outline_px << '\n';
      }
    }
    perf_control("disable");
    auto& pool = pooled[{W, H}];
    for (std::size_t ri = 0; ri < runs.size(); ++ri) {
      if (pool.size() <= ri) pool.emplace_back(runs[ri].path, std::vector<Sample>{});
      pool[ri].second.insert(pool[ri].second.end(), runs[ri].samples.begin(), runs[ri].samples.end());
    }
    for (GLuint t : textures) glDeleteTextures(1, &t);
  }
  for (const auto& [W, H] : a.sizes)
    for (auto& [path, samples] : pooled[{W, H}]) {
      struct {
        const std::string& path;
        std::vector<Sample>& samples;
      } r{path, samples};
      auto col = [&](auto get) {
        std::vector<double> v;
        for (const Sample& s : r.samples) v.push_back(static_cast<double>(get(s)));
        return v;
      };
      const auto ar = col([](const Sample& s) { return s.ar; });
      const auto tr = col([](const Sample& s) { return s.track; });
      const auto co = col([](const Sample& s) { return s.composite; });
      const auto pt = col([](const Sample& s) { return s.passthrough; });
      const auto fr = col([](const Sample& s) { return s.decode + s.track + s.composite; });
      frame_rows.push_back("  " + std::to_string(W) + "x" + std::to_string(H) + " " + r.path + ": " +
                           std::to_string(quantile(fr, 0.5)).substr(0, 5) + " / " +
                           std::to_string(quantile(fr, 0.99)).substr(0, 5) + " ms");
      const auto area = col([](const Sample& s) { return s.area; });
      const auto tris = col([](const Sample& s) { return s.tris; });
      const auto lod = col([](const Sample& s) { return s.lod; });
      const double a50 = quantile(area, 0.5);
      std::printf("| %dx%d | %s%s | %.0f (%.2f %%) | %.2f / %.2f | %.2f / %.2f | %.2f | **%.2f / %.2f** | %.0f (%.0f) |\n", W, H,
                  r.path.c_str(), a.gl ? " (GL)" : "", a50, 100.0 * a50 / (double(W) * H), quantile(tr, 0.5),
                  quantile(tr, 0.99), quantile(co, 0.5), quantile(co, 0.99), quantile(pt, 0.5), quantile(ar, 0.5),
                  quantile(ar, 0.99), quantile(tris, 0.5), quantile(lod, 0.5));
      ar_by_path[r.path].emplace_back(std::to_string(W) + "x" + std::to_string(H), quantile(ar, 0.5));
      // The AR part against the overlay's area: quartiles of the area (frames with an overlay).
      std::vector<const Sample*> with;
      for (const Sample& s : r.samples)
        if (s.area > 0) with.push_back(&s);
      std::sort(with.begin(), with.end(), [](const Sample* x, const Sample* y) { return x->area < y->area; });
      std::ostringstream t;
      for (int q = 0; q < 4 && !with.empty(); ++q) {
        const std::size_t b = with.size() * q / 4, e = with.size() * (q + 1) / 4;
        if (e <= b) continue;
        std::vector<double> ars, areas, trs, cos;
        for (std::size_t j = b; j < e; ++j) {
          ars.push_back(with[j]->ar);
          areas.push_back(with[j]->area);
          trs.push_back(with[j]->track);
          cos.push_back(with[j]->composite - with[j]->passthrough);
        }
        char line[320];
        std::snprintf(line, sizeof line, "| %dx%d | %s | %zu | %.0f–%.0f | %.2f | %.2f | %.2f | %.2f |\n", W, H,
                      r.path.c_str(), e - b, areas.front(), areas.back(), quantile(trs, 0.5), quantile(cos, 0.5),
                      quantile(ars, 0.5), quantile(ars, 0.99));
        t << line;
      }
      area_tables.push_back(t.str());
      char st[400];
      std::snprintf(st, sizeof st, "| %dx%d | %s | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f |\n", W, H,
                    r.path.c_str(), quantile(col([](const Sample& x) { return x.grey_wall; }), 0.5),
                    quantile(col([](const Sample& x) { return x.detect_wall; }), 0.5),
                    quantile(col([](const Sample& x) { return x.pose_wall; }), 0.5),
                    quantile(col([](const Sample& x) { return x.filter_wall; }), 0.5),
                    quantile(col([](const Sample& x) { return x.sync_wall; }), 0.5),
                    quantile(col([](const Sample& x) { return x.upload_wall; }), 0.5),
                    quantile(col([](const Sample& x) { return x.render_wall; }), 0.5),
                    quantile(col([](const Sample& x) { return x.readback_wall; }), 0.5),
                    quantile(col([](const Sample& x) { return x.segment_wall; }), 0.5),
                    quantile(col([](const Sample& x) { return x.blend_wall; }), 0.5));
      stage_rows.push_back(st);
      std::vector<double> outl, merr;
      for (const Sample& x : r.samples) {
        if (x.outline_px >= 0) outl.push_back(x.outline_px);
        if (x.man_err_mm >= 0) merr.push_back(x.man_err_mm);
      }
      const double o50 = quantile(outl, 0.5), o95 = quantile(outl, 0.95), to640 = 640.0 / W;
      char ex[400];
      std::snprintf(ex, sizeof ex, "| %dx%d | %s | %.1f | %.2f | %zu | %.3f / %.3f | %.3f / %.3f | %zu | %.3f / %.3f |\n", W, H,
                    r.path.c_str(), 100 * quantile(col([](const Sample& x) { return x.gray_fraction; }), 0.5),
                    quantile(col([](const Sample& x) { return x.decode; }), 0.5), outl.size(), o50, o95, o50 * to640,
                    o95 * to640, merr.size(), quantile(merr, 0.5), quantile(merr, 0.95));
      extra_rows.push_back(ex);
    }

  std::printf("\nAR part against the overlay's area (frames with an overlay, in quartiles of its area):\n\n");
  std::printf("| size | path | frames | overlay area px | track p50 ms | composite minus passthrough p50 ms | AR p50 ms | AR p99 ms |\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  for (const auto& t : area_tables) std::printf("%s", t.c_str());
  std::printf("\nStages, wall-clock medians, ms (the stages' own timers: TrackFrame::timing, CompositeTimings; "
              "'grey + motion' = the tracker's total minus its detect, pose and filter stages):\n\n");
  std::printf("| size | path | grey + motion | detect | pose | filter | mesh sync | upload (GL) | render | readback | "
              "segment | resample + blend |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& t : stage_rows) std::printf("%s", t.c_str());
  std::printf("\nGrey converted by the tracker (%% of the frame, p50; 100 on full-frame searches), the bare viewer's "
              "YUYV decode (--yuyv, CPU ms p50, not in the AR part), and the drawn tooth's outline against the truth "
              "(--outline: full mesh at the true pose; mean distance between the outlines, p50 / p95, px of the frame "
              "and px of a 640-px-wide frame), and the mannequin's tracked position against the truth (left eye / rig):\n\n");
  std::printf("| size | path | grey converted %% | decode ms | frames with a tooth | outline px | outline px at 640 | "
              "frames tracked | mannequin error p50 / p95 mm |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& t : extra_rows) std::printf("%s", t.c_str());
  std::printf("\nFrame CPU p50 / p99 (decode + track + composite: from the camera's bytes to the composite):\n");
  for (const auto& t : frame_rows) std::printf("%s\n", t.c_str());
  std::printf("\nAR part p50, largest size / smallest size (goal for 1920x1080 / 640x480: <= 1.5):\n");
  for (const auto& [path, v] : ar_by_path)
    if (v.size() >= 2)
      std::printf("  %s: %s / %s = %.2f\n", path.c_str(), v.back().first.c_str(), v.front().first.c_str(),
                  v.back().second / v.front().second);
  return 0;
}

}  // namespace
}  // namespace dentar::ar

int main(int argc, char** argv) { return dentar::ar::run(dentar::ar::parse(argc, argv)); }
