// See view.h.
#include "dentar/replay/view.h"

#include <GLES3/gl3.h>

#include <algorithm>
#include <cmath>
#include <optional>

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
};

SceneView::SceneView() = default;
SceneView::~SceneView() = default;

Result<std::unique_ptr<SceneView>> SceneView::create(const calibration::CameraIntrinsics& k, const volume::BurParams& bur,
                                                     double reduced_scale) {
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
                                         std::move(g).value(), std::move(p).value(), {}, 0});
  v->impl_->bur = v->impl_->parts.upload(ar::make_bur_mesh(bur));
  return v;
}

void SceneView::render(const OrbitCamera& cam, const Tooth& main, const MaterialAlphas& a, const Tooth* ghost,
                       float ghost_alpha, bool reduced) {
  Impl& s = *impl_;
  s.last_small = reduced && s.small;
  ar::Renderer& target = s.used();
  for (int m = 1; m < volume::kMaxMaterials; ++m) {
    const auto mat = static_cast<volume::Material>(m);
    const auto& rgb = volume::material_info(m).rgb;
    const Eigen::Vector3f c = Eigen::Vector3f(rgb[0], rgb[1], rgb[2]) / 255.0f;
    const float alpha = mat == volume::Material::kEnamel ? a.enamel : mat == volume::Material::kPulp ? a.pulp : a.dentin;
    s.tooth.set_style(mat, {c, std::clamp(alpha, 0.0f, 1.0f)});
    // The other recording: the same materials, tinted blue, translucent.
    s.ghost.set_style(mat, {0.45f * c + Eigen::Vector3f(0.1f, 0.25f, 0.55f), std::clamp(ghost_alpha, 0.0f, 0.99f)});
  }
  if (main.surface) s.tooth.sync(*main.surface);
  if (ghost && ghost->surface) s.ghost.sync(*ghost->surface);
  target.begin_frame(background);
  glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &s.fbo);
  const Eigen::Isometry3d T_cam_tooth = cam.T_cam_tooth();
  const Eigen::Matrix4d& P = target.clip_from_cam();
  // Opaque things first (the bur, the tooth's opaque materials), translucent after.
  const ar::MaterialStyle bur_style{main.bur_cutting ? Eigen::Vector3f(0.95f, 0.75f, 0.3f) : Eigen::Vector3f(0.75f, 0.76f, 0.8f), 1.0f};
  if (main.draw_bur) s.parts.draw(s.bur, P, T_cam_tooth * main.T_tooth_tip, bur_style);
  if (main.surface) s.tooth.draw(P, T_cam_tooth);
  if (ghost) {
    if (ghost->draw_bur)
      s.parts.draw(s.bur, P, T_cam_tooth * ghost->T_tooth_tip,
                   {Eigen::Vector3f(0.3f, 0.55f, 0.95f), std::clamp(ghost_alpha + 0.3f, 0.0f, 0.95f)});
    if (ghost->surface) s.ghost.draw(P, T_cam_tooth);
  }
  target.end_frame();
}

void SceneView::read_bgr(cv::Mat& out) const { impl_->used().read_bgr(out); }

int SceneView::rendered_width() const { return impl_->used().camera().width; }
int SceneView::rendered_height() const { return impl_->used().camera().height; }

unsigned SceneView::framebuffer() const { return static_cast<unsigned>(impl_->fbo); }

const calibration::CameraIntrinsics& SceneView::intrinsics() const { return impl_->renderer.camera(); }

}  // namespace dentar::replay
