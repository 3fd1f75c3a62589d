// What the replay window draws, also used headless (the offline render the window is tested
// against): the tooth being cut (volume::Surface meshes) with a colour and an opacity per
// material, and the bur at its recorded pose, seen by an orbit camera.
//
// The orbit camera looks at `target` (tooth frame, m) from `distance_m`, at azimuth `yaw`
// about the tooth's +z (long axis, occlusal up) and elevation `pitch` above its x-y plane;
// pan moves the target in the image plane. Pinhole intrinsics of the viewport, with the
// principal point where the caller wants the target (the window: the middle of the area the
// HUD leaves free).
//
// Thread/context: SceneView needs an OpenGL ES 3 context current (a headless EGL one, or
// the window's own GLES context) and must be destroyed before it.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <memory>
#include <opencv2/core/mat.hpp>

#include "dentar/ar/meshes.h"
#include "dentar/ar/renderer.h"
#include "dentar/volume/bur.h"
#include "dentar/volume/surface.h"

namespace dentar::replay {

struct OrbitCamera {
  Eigen::Vector3d target_m = Eigen::Vector3d::Zero();  // tooth frame
  double yaw_rad = -0.6, pitch_rad = 0.75, distance_m = 0.04;
  double fov_y_rad = 0.6;  // vertical field of view

  Eigen::Isometry3d T_cam_tooth() const;
  // Mouse-style moves: orbit by angles; zoom by a factor (> 1 = closer); pan by a fraction of
  // the view height (right, down).
  void orbit(double dyaw_rad, double dpitch_rad);
  void zoom(double factor);
  void pan(double right, double down);
  // Frames a box (tooth frame): target at its centre, distance to see it whole.
  void frame(const Eigen::Vector3d& lo_m, const Eigen::Vector3d& hi_m);
};

// Pinhole intrinsics for a w x h image whose principal point is (cx, cy), focal from fov_y.
calibration::CameraIntrinsics view_intrinsics(int w, int h, double cx, double cy, double fov_y_rad);

// Per-material opacity (0..1) of enamel, dentin, pulp; other materials follow dentin.
struct MaterialAlphas {
  float enamel = 1.0f, dentin = 1.0f, pulp = 1.0f;
};

class SceneView {
 public:
  // Errors: GL failures, unusable intrinsics (named).
  // reduced_scale < 1: a second, smaller target (that fraction of the pixels per axis, the
  // same field of view) that render(..., reduced = true) draws into instead: the window's
  // level of detail while playing (issue 27; llvmpipe's cost is the pixels it fills).
  // reduced_lod_voxels 2, 4 or 8: render(..., reduced = true) also draws a coarser tooth,
  // the surface's chunks clustered in cells of that many voxels (ar/mesh_lod.h), remade per
  // chunk as the cut changes them (llvmpipe's other cost is the triangles); 0 = the full mesh.
  // A full-quality render always draws the full mesh. Errors: another lod value (named).
  static Result<std::unique_ptr<SceneView>> create(const calibration::CameraIntrinsics& k, const volume::BurParams& bur,
                                                   double reduced_scale = 1.0, int reduced_lod_voxels = 0);
  ~SceneView();
  // Renders: clear to the background, the tooth (opaque materials first, then translucent
  // ones), the bur (opaque; with `ghost`, a second translucent tooth and bur are drawn after).
  // Then read_bgr gives the image (row 0 = top).
  struct Tooth {
    const volume::Surface* surface = nullptr;
    Eigen::Isometry3d T_tooth_tip = Eigen::Isometry3d::Identity();
    bool draw_bur = true;
    bool bur_cutting = false;  // the pedal down: the bur drawn in the cutting colour
  };
  void render(const OrbitCamera& cam, const Tooth& main, const MaterialAlphas& alphas, const Tooth* ghost = nullptr,
              float ghost_alpha = 0.35f, bool reduced = false);
  // The main tooth's triangles the last render() drew (the coarse level's when it drew that).
  std::size_t rendered_triangles() const;
  // The size of what the last render() drew (the reduced target's when it drew there).
  int rendered_width() const;
  int rendered_height() const;
  void read_bgr(cv::Mat& out) const;
  // The framebuffer the last render() drew into (the renderer's output: without lens
  // distortion, Renderer::begin_frame binds it as the draw target), rows bottom-up, for a
  // blit into a window of the same context.
  unsigned framebuffer() const;
  const calibration::CameraIntrinsics& intrinsics() const;
  Eigen::Vector4f background = Eigen::Vector4f(0.13f, 0.14f, 0.16f, 1.0f);

 private:
  SceneView();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dentar::replay
