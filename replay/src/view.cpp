// See view.h.
#include "dentar/replay/view.h"

#include <GLES3/gl3.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "dentar/ar/mesh_lod.h"
#include "dentar/volume/material.h"

namespace dentar::replay {

Eigen::Isometry3d OrbitCamera::T_cam_tooth() const {
  // Eye on a sphere about the target; camera x right, y down, z forward (OpenCV).
  const Eigen::Vector3d dir(std::cos(pitch_rad) * std::cos(yaw_rad), std::cos(pitch_rad) * std::sin(yaw_rad),
                            std::sin(pitch_rad));
  const Eigen::Vector3d eye = target_m + distance_m * dir;
  const Eigen::Vector3d f = -dir;
  Eigen::Vector3d r = f.cross(Eigen::Vector3d::UnitZ());
  if (r.norm() < 1e-9) r = Eigen::Vector3d::UnitX();  // straight above or below
  r.normalize();
  const Eigen::Vector3d d = f.cross(r);
  Eigen::Isometry3d T_tooth_cam = Eigen::Isometry3d::Identity();
  T_tooth_cam.linear().col(0) = r;
  T_tooth_cam.linear().col(1) = d;
  T_tooth_cam.linear().col(2) = f;
  T_tooth_cam.translation() = eye;
  return T_tooth_cam.inverse();
}

void OrbitCamera::orbit(double dyaw, double dpitch) {
  yaw_rad = std::remainder(yaw_rad + dyaw, 2 * M_PI);
  pitch_rad = std::clamp(pitch_rad + dpitch, -1.55, 1.55);  // short of the poles: "up" stays defined
}

void OrbitCamera::zoom(double factor) {
  if (!(factor > 0) || !std::isfinite(factor)) return;
  distance_m = std::clamp(distance_m / factor, 0.004, 0.5);
}

void OrbitCamera::pan(double right, double down) {
  const Eigen::Isometry3d T_tooth_cam = T_cam_tooth().inverse();
  const double h = 2 * distance_m * std::tan(0.5 * fov_y_rad);  // view height at the target, m
  target_m -= h * (right * T_tooth_cam.linear().col(0) + down * T_tooth_cam.linear().col(1));
}

void OrbitCamera::frame(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  target_m = 0.5 * (lo + hi);
  const double radius = 0.5 * (hi - lo).norm();
  distance_m = std::clamp(1.15 * radius / std::sin(0.5 * fov_y_rad), 0.004, 0.5);
}

calibration::CameraIntrinsics view_intrinsics(int w, int h, double cx, double cy, double fov_y_rad) {
  calibration::CameraIntrinsics k;
  k.width = w;
  k.height = h;
  k.fy = k.fx = 0.5 * h / std::tan(0.5 * fov_y_rad);
  k.cx = cx;
  k.cy = cy;
  return k;
}

namespace {

// A surface's coarse copy (mesh_lod.h), chunk by chunk, remade only for the chunks whose mesh
// changed since: while playing, the cut changes a few chunks a frame.
struct CoarseSurface {
  std::vector<volume::ChunkMesh> meshes;
  std::vector<std::uint64_t> from;  // the source chunk's version each was made from
  const volume::Surface* of = nullptr;
  std::size_t triangles = 0;

  void update(const volume::Surface& s, int cell, ar::MeshLodScratch& scratch) {
    const auto& src = s.chunks();
    if (of != &s || meshes.size() != src.size()) {
      meshes.assign(src.size(), volume::ChunkMesh{});
      from.assign(src.size(), ~std::uint64_t{0});
      of = &s;
    }
    bool changed = false;
    for (std::size_t i = 0; i < src.size(); ++i) {
      if (src[i].version == from[i]) continue;
      changed = true;
      from[i] = src[i].version;
      volume::ChunkMesh& m = meshes[i];
      if (src[i].empty()) {
        m.vertices.clear();
        m.edge_keys.clear();
        m.indices.clear();
      } else {
        ar::cluster_chunk_mesh(src[i], cell, m, scratch);
      }
      ++m.version;  // ToothRenderer uploads what changed by this
    }
    if (!changed && !merged.empty()) return;
    // All chunks in one mesh: llvmpipe's cost per draw call (a few per chunk and material)
    // outweighs the coarse level's triangles; one upload of ~0.5 MB a frame is cheaper.
    merged.resize(1);
    volume::ChunkMesh& all = merged[0];
    all.vertices.clear();
    all.edge_keys.clear();
    all.indices.clear();
    for (const auto& m : meshes) {
      const auto base = static_cast<std::uint32_t>(all.vertices.size());
      all.vertices.insert(all.vertices.end(), m.vertices.begin(), m.vertices.end());
      for (std::uint32_t i : m.indices) all.indices.push_back(base + i);
    }
    ++all.version;
    triangles = all.triangle_count();
  }
  std::vector<volume::ChunkMesh> merged;  // one mesh: every chunk's coarse copy
};

}  // namespace

struct SceneView::Impl {
  ar::Renderer renderer;
  std::optional<ar::Renderer> small;  // the reduced target (create's reduced_scale < 1)
  bool last_small = false;            // the last render() drew into `small`
  ar::Renderer& used() { return last_small && small ? *small : renderer; }
  const ar::Renderer& used() const { return last_small && small ? *small : renderer; }
  ar::ToothRenderer tooth, ghost;
  ar::PartRenderer parts;
  ar::GpuPart bur;
  GLint fbo = 0;
  // The coarse level (reduced renders with lod_cell > 0): its own renderers, so the full
  // mesh's buffers stay as they are for the next full-quality frame.
  int lod_cell = 0;
  std::optional<ar::ToothRenderer> tooth_lod, ghost_lod;
  CoarseSurface coarse, coarse_ghost;
  ar::MeshLodScratch lod_scratch;
  std::size_t last_triangles = 0;
};

SceneView::SceneView() = default;
SceneView::~SceneView() = default;

Result<std::unique_ptr<SceneView>> SceneView::create(const calibration::CameraIntrinsics& k, const volume::BurParams& bur,
                                                     double reduced_scale, int reduced_lod_voxels) {
  if (reduced_lod_voxels != 0 && reduced_lod_voxels != 2 && reduced_lod_voxels != 4 && reduced_lod_voxels != 8)
    return Error{"replay view: level of detail " + std::to_string(reduced_lod_voxels) +
                 " voxels: must be 0 (the full mesh), 2, 4 or 8"};
  ar::RendererOptions ro;
  ro.apply_distortion = false;
  ro.near_m = 0.002;
  ro.far_m = 1.0;
  auto r = ar::Renderer::create(k, ro);
  if (!r) return Error{"replay view: " + r.error()};
  auto t = ar::ToothRenderer::create();
  if (!t) return Error{"replay view: " + t.error()};
  auto g = ar::ToothRenderer::create();
  if (!g) return Error{"replay view: " + g.error()};
  auto p = ar::PartRenderer::create();
  if (!p) return Error{"replay view: " + p.error()};
  std::unique_ptr<SceneView> v(new SceneView);
  std::optional<ar::Renderer> small;
  if (reduced_scale > 0 && reduced_scale < 1) {
    calibration::CameraIntrinsics ks = k;  // the same field of view on fewer pixels
    ks.width = std::max(1, static_cast<int>(std::lround(k.width * reduced_scale)));
    ks.height = std::max(1, static_cast<int>(std::lround(k.height * reduced_scale)));
    const double sx = static_cast<double>(ks.width) / k.width, sy = static_cast<double>(ks.height) / k.height;
    ks.fx = k.fx * sx;
    ks.fy = k.fy * sy;
    ks.cx = k.cx * sx;
    ks.cy = k.cy * sy;
    auto rs = ar::Renderer::create(ks, ro);
    if (!rs) return Error{"replay view (reduced): " + rs.error()};
    small.emplace(std::move(rs).value());
  }
  v->impl_ = std::make_unique<Impl>(Impl{std::move(r).value(), std::move(small), false, std::move(t).value(),
                                         std::move(g).value(), std::move(p).value(), {}, 0, 0, std::nullopt,
                                         std::nullopt, {}, {}, {}, 0});
  v->impl_->bur = v->impl_->parts.upload(ar::make_bur_mesh(bur));
  if (reduced_lod_voxels > 0) {
    auto tl = ar::ToothRenderer::create();
    if (!tl) return Error{"replay view: " + tl.error()};
    auto gl = ar::ToothRenderer::create();
    if (!gl) return Error{"replay view: " + gl.error()};
    v->impl_->tooth_lod.emplace(std::move(tl).value());
    v->impl_->ghost_lod.emplace(std::move(gl).value());
    v->impl_->lod_cell = reduced_lod_voxels;
  }
  return v;
}

void SceneView::render(const OrbitCamera& cam, const Tooth& main, const MaterialAlphas& a, const Tooth* ghost,
                       float ghost_alpha, bool reduced) {
  Impl& s = *impl_;
  s.last_small = reduced && s.small;
  ar::Renderer& target = s.used();
  // Reduced, with a level of detail: the coarse copies of the meshes.
  const bool coarse = reduced && s.lod_cell > 0;
  ar::ToothRenderer& tooth = coarse ? *s.tooth_lod : s.tooth;
  ar::ToothRenderer& ghost_r = coarse ? *s.ghost_lod : s.ghost;
  for (int m = 1; m < volume::kMaxMaterials; ++m) {
    const auto mat = static_cast<volume::Material>(m);
    const auto& rgb = volume::material_info(m).rgb;
    const Eigen::Vector3f c = Eigen::Vector3f(rgb[0], rgb[1], rgb[2]) / 255.0f;
    const float alpha = mat == volume::Material::kEnamel ? a.enamel : mat == volume::Material::kPulp ? a.pulp : a.dentin;
    tooth.set_style(mat, {c, std::clamp(alpha, 0.0f, 1.0f)});
    // The other recording: the same materials, tinted blue, translucent.
    ghost_r.set_style(mat, {0.45f * c + Eigen::Vector3f(0.1f, 0.25f, 0.55f), std::clamp(ghost_alpha, 0.0f, 0.99f)});
  }
  if (coarse) {
    if (main.surface) {
      s.coarse.update(*main.surface, s.lod_cell, s.lod_scratch);
      tooth.sync(s.coarse.merged);
    }
    if (ghost && ghost->surface) {
      s.coarse_ghost.update(*ghost->surface, s.lod_cell, s.lod_scratch);
      ghost_r.sync(s.coarse_ghost.merged);
    }
  } else {
    if (main.surface) tooth.sync(*main.surface);
    if (ghost && ghost->surface) ghost_r.sync(*ghost->surface);
  }
  s.last_triangles = main.surface ? tooth.triangle_count() : 0;
  target.begin_frame(background);
  glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &s.fbo);
  const Eigen::Isometry3d T_cam_tooth = cam.T_cam_tooth();
  const Eigen::Matrix4d& P = target.clip_from_cam();
  // Opaque things first (the bur, the tooth's opaque materials), translucent after.
  const ar::MaterialStyle bur_style{main.bur_cutting ? Eigen::Vector3f(0.95f, 0.75f, 0.3f) : Eigen::Vector3f(0.75f, 0.76f, 0.8f), 1.0f};
  if (main.draw_bur) s.parts.draw(s.bur, P, T_cam_tooth * main.T_tooth_tip, bur_style);
  if (main.surface) tooth.draw(P, T_cam_tooth);
  if (ghost) {
    if (ghost->draw_bur)
      s.parts.draw(s.bur, P, T_cam_tooth * ghost->T_tooth_tip,
                   {Eigen::Vector3f(0.3f, 0.55f, 0.95f), std::clamp(ghost_alpha + 0.3f, 0.0f, 0.95f)});
    if (ghost->surface) ghost_r.draw(P, T_cam_tooth);
  }
  target.end_frame();
}

void SceneView::read_bgr(cv::Mat& out) const { impl_->used().read_bgr(out); }

std::size_t SceneView::rendered_triangles() const { return impl_->last_triangles; }

int SceneView::rendered_width() const { return impl_->used().camera().width; }
int SceneView::rendered_height() const { return impl_->used().camera().height; }

unsigned SceneView::framebuffer() const { return static_cast<unsigned>(impl_->fbo); }

const calibration::CameraIntrinsics& SceneView::intrinsics() const { return impl_->renderer.camera(); }

}  // namespace dentar::replay
