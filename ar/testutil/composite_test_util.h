// Helpers shared by the compositor tests (compositor_gl_test,
// compositor_gpu_gl_test) and composite_bench: generator footage with the
// generator's uncut tooth, the compositor's input from the true poses, and a
// synthetic finger across the visible tooth. No GoogleTest here (the
// benchmark includes it): failures come back as error strings.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "dentar/ar/compositor.h"
#include "dentar/ar/occlusion.h"
#include "dentar/ar/synth.h"
#include "dentar/volume/procedural_tooth.h"

namespace dentar::ar::test {

// The generator's molar before any cut (the scripted drilling starts after
// ~1.4 s, so the early frames see this mesh), meshed whole. error:
// make_molar's (then surface is null).
struct UncutMolar {
  std::optional<volume::VoxelVolume> volume;
  std::unique_ptr<volume::Surface> surface;  // refers to *volume
  std::size_t triangles = 0;
  std::string error;
  explicit UncutMolar(double voxel_m) {
    volume::MolarParams p;
    p.voxel_mm = voxel_m * 1e3;
    auto v = volume::make_molar(p);
    if (!v) {
      error = v.error();
      return;
    }
    volume.emplace(std::move(v).value());
    surface = std::make_unique<volume::Surface>(*volume);
    triangles = surface->extract_all();
  }
};

// Generator footage held in memory with its generator (the tests ask it for
// silhouettes; release it when only the frames are needed), the station as
// rendered and the uncut tooth at the station's voxel size.
struct ToothFootage {
  std::unique_ptr<SynthGenerator> gen;
  StationScene station;
  std::vector<SynthFrame> frames;  // image, mask and truth
  std::unique_ptr<UncutMolar> tooth;
  std::string error;  // the generator's or the tooth's; then the rest is partial
};

// o.frames frames of `station`, keeping frames 0, every, 2 * every, ...
inline ToothFootage tooth_footage(const StationScene& station, const SynthOptions& o, int every = 1) {
  ToothFootage fo;
  auto g = SynthGenerator::create(station, o);
  if (!g) {
    fo.error = g.error();
    return fo;
  }
  fo.gen = std::move(g).value();
  fo.station = fo.gen->station();
  for (int i = 0; i < o.frames; ++i) {
    SynthFrame f;
    if (Status s = fo.gen->next(f); !s) {
      fo.error = s.error();
      return fo;
    }
    if (i % every == 0) fo.frames.push_back(std::move(f));
  }
  fo.tooth = std::make_unique<UncutMolar>(fo.station.tooth_voxel_m);
  fo.error = fo.tooth->error;
  return fo;
}

// The compositor's input for frame f with the generator's true poses.
inline CompositeInput truth_input(const SynthFrame& f) {
  CompositeInput in;
  in.video_bgr = &f.image;
  in.man_valid = true;
  in.T_cam_man = f.truth.T_cam_man;
  in.mirror_valid = true;
  in.T_cam_mtag = f.truth.T_cam_mtag;
  in.stylus_valid = true;
  in.T_dev_sty = f.truth.T_dev_sty;
  return in;
}

// A finger across the tooth seen in `mask` (the generator's kMask* image):
// from near the visible tooth's centroid outward, three times its size long,
// at an angle that turns with the frame index i (seed i + 1). nullopt when
// the visible tooth has no more than min_area_px pixels.
inline std::optional<SyntheticFinger> finger_across_tooth(const cv::Mat& mask, int i, double min_area_px) {
  const cv::Moments mo = cv::moments(mask == kMaskToothVisible, true);
  if (!(mo.m00 > min_area_px)) return std::nullopt;
  const Eigen::Vector2d c(mo.m10 / mo.m00, mo.m01 / mo.m00);
  const double ang = 0.7 + 1.3 * i, size = std::sqrt(mo.m00);
  const Eigen::Vector2d dir(std::cos(ang), std::sin(ang));
  SyntheticFinger fi;
  fi.a_px = c + 0.1 * size * dir;
  fi.b_px = c + 3.0 * size * dir;
  fi.radius_px = 0.3 * size;
  fi.seed = static_cast<unsigned>(i + 1);
  return fi;
}

}  // namespace dentar::ar::test
