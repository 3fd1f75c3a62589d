// See headset.h.
#include "dentar/live/headset.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <vector>

namespace dentar::live {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::string num(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

// The camera's model and the loupe's view, the same in every mapping.
void set_camera_and_loupe(EyeMapping& m, const calibration::CameraIntrinsics& cam, const LoupeView& loupe,
                          const double loupe_c[2]) {
  m.f_cam[0] = cam.fx;
  m.f_cam[1] = cam.fy;
  m.c_cam[0] = cam.cx;
  m.c_cam[1] = cam.cy;
  m.cam_w = cam.width;
  m.cam_h = cam.height;
  m.loupe = loupe;
  m.loupe_c[0] = loupe_c[0];
  m.loupe_c[1] = loupe_c[1];
}

}  // namespace

double HeadsetProfile::max_radius(int e) const {
  const HeadsetEye& eye = eyes[static_cast<std::size_t>(e)];
  const double norm = eye.viewport[2] / 2.0;
  double r = 0;
  for (int cx = 0; cx < 2; ++cx)
    for (int cy = 0; cy < 2; ++cy) {
      const double dx = (cx ? eye.viewport[2] : 0) - eye.lens_center_px[0];
      const double dy = (cy ? eye.viewport[3] : 0) - eye.lens_center_px[1];
      r = std::max(r, std::hypot(dx, dy) / norm);
    }
  return r;
}

std::string HeadsetProfile::validate() const {
  if (panel_w < 16 || panel_h < 16 || panel_w > 16384 || panel_h > 16384)
    return "panel = " + std::to_string(panel_w) + "x" + std::to_string(panel_h) + " px must be within 16..16384 each";
  for (int e = 0; e < 2; ++e) {
    const HeadsetEye& eye = eyes[static_cast<std::size_t>(e)];
    const std::string f = "eyes[" + std::to_string(e) + "]";
    const int* v = eye.viewport;
    if (v[2] < 16 || v[3] < 16) return f + ".viewport_px size " + std::to_string(v[2]) + "x" + std::to_string(v[3]) + " must be at least 16x16 px";
    if (v[0] < 0 || v[1] < 0 || v[0] + v[2] > panel_w || v[1] + v[3] > panel_h)
      return f + ".viewport_px [" + std::to_string(v[0]) + ", " + std::to_string(v[1]) + ", " + std::to_string(v[2]) +
             ", " + std::to_string(v[3]) + "] must lie on the " + std::to_string(panel_w) + "x" +
             std::to_string(panel_h) + " panel";
    if (!(std::isfinite(eye.lens_center_px[0]) && std::isfinite(eye.lens_center_px[1]) && eye.lens_center_px[0] >= 0 &&
          eye.lens_center_px[1] >= 0 && eye.lens_center_px[0] <= v[2] && eye.lens_center_px[1] <= v[3]))
      return f + ".lens_center_px [" + num(eye.lens_center_px[0]) + ", " + num(eye.lens_center_px[1]) +
             "] must lie in the eye's viewport (0..width, 0..height)";
  }
  {
    const int* a = eyes[0].viewport;
    const int* b = eyes[1].viewport;
    if (a[0] < b[0] + b[2] && b[0] < a[0] + a[2] && a[1] < b[1] + b[3] && b[1] < a[1] + a[3])
      return "eyes[0].viewport_px and eyes[1].viewport_px overlap: each eye needs its own part of the panel";
  }
  if (!(fov_h_deg > 1 && fov_h_deg < 180)) return "fov_deg[0] = " + num(fov_h_deg) + " must be in (1, 180) degrees (a pinhole view cannot reach 180)";
  if (!(fov_v_deg > 1 && fov_v_deg < 180)) return "fov_deg[1] = " + num(fov_v_deg) + " must be in (1, 180) degrees (a pinhole view cannot reach 180)";
  if (!(ipd_m > 0)) return "ipd_mm = " + num(ipd_m * 1e3) + " must be positive";
  if (!(ipd_m >= 0.040 && ipd_m <= 0.090))
    return "ipd_mm = " + num(ipd_m * 1e3) + " must be in 40..90 mm (adults: about 52-78 mm, Dodgson 2004)";
  if (!(std::isfinite(k1) && std::isfinite(k2))) return "distortion.k1/k2 must be finite numbers";
  for (const auto& [name, s] : {std::pair{"distortion.chroma_scale_r", chroma_scale_r}, std::pair{"distortion.chroma_scale_b", chroma_scale_b}})
    if (!(s >= 0.9 && s <= 1.1)) return std::string(name) + " = " + num(s) + " must be in 0.9..1.1 (a lens's lateral colour is a few per cent)";
  if (!(mono_convergence_m >= 0.1 && mono_convergence_m <= 10))
    return "mono_convergence_mm = " + num(mono_convergence_m * 1e3) + " must be in 100..10000 mm";
  // The pre-warp must map the viewport one to one: r * (1 + k1 r^2 + k2 r^4)
  // strictly increasing from the lens axis to the farthest corner, in every
  // channel (d/dr = 1 + 3 k1 r^2 + 5 k2 r^4 > 0), and non-zero.
  for (int e = 0; e < 2; ++e) {
    const double rmax = max_radius(e) * std::max({1.0, chroma_scale_r, chroma_scale_b});
    constexpr int kSteps = 2000;
    for (int i = 1; i <= kSteps; ++i) {
      const double r = rmax * i / kSteps, r2 = r * r;
      const double d = 1 + 3 * k1 * r2 + 5 * k2 * r2 * r2;
      if (!(d > 1e-3))
        return "distortion k1 = " + num(k1) + ", k2 = " + num(k2) + " is not monotonic over eyes[" + std::to_string(e) +
               "]'s viewport: the pre-warp folds back at lens radius " + num(r) + " (the farthest corner is at " +
               num(max_radius(e)) + "; lens units = half the viewport width)";
    }
  }
  return {};
}

Result<HeadsetProfile> parse_headset_profile(const std::string& text, const std::string& path) {
  const std::string where = "headset profile " + path + ": ";
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const std::exception& e) {
    return Error{where + "not JSON (" + e.what() + ")"};
  }
  if (!j.is_object()) return Error{where + "must be a JSON object"};
  static const std::set<std::string> kKeys = {"format", "version", "name", "provenance", "panel_px", "eyes", "fov_deg",
                                              "ipd_mm", "distortion", "mono_convergence_mm"};
  for (const auto& [k, v] : j.items())
    if (!kKeys.count(k)) return Error{where + "unknown field \"" + k + "\" (docs/formats.md, Headset profile)"};
  HeadsetProfile h;
  try {
    if (j.value("format", std::string()) != "dentar-headset")
      return Error{where + "format must be \"dentar-headset\""};
    if (!j.contains("version") || !j["version"].is_number_integer() || j["version"].get<int>() != kHeadsetProfileVersion)
      return Error{where + "version must be " + std::to_string(kHeadsetProfileVersion)};
    for (const char* k : {"name", "provenance", "panel_px", "eyes", "fov_deg", "ipd_mm"})
      if (!j.contains(k)) return Error{where + "missing field \"" + std::string(k) + "\""};
    h.name = j["name"].get<std::string>();
    h.provenance = j["provenance"].get<std::string>();
    if (h.provenance.empty()) return Error{where + "provenance is empty: say where each number comes from"};
    const auto& p = j["panel_px"];
    if (!p.is_array() || p.size() != 2) return Error{where + "panel_px must be [width, height]"};
    h.panel_w = p[0].get<int>();
    h.panel_h = p[1].get<int>();
    const auto& eyes = j["eyes"];
    if (!eyes.is_array() || eyes.size() != 2) return Error{where + "eyes must be an array of 2 (left, right)"};
    for (int e = 0; e < 2; ++e) {
      const auto& je = eyes[static_cast<std::size_t>(e)];
      const std::string f = "eyes[" + std::to_string(e) + "]";
      if (!je.is_object() || !je.contains("viewport_px")) return Error{where + f + ".viewport_px is missing"};
      for (const auto& [k, v] : je.items())
        if (k != "viewport_px" && k != "lens_center_px") return Error{where + f + ": unknown field \"" + k + "\""};
      const auto& vp = je["viewport_px"];
      if (!vp.is_array() || vp.size() != 4) return Error{where + f + ".viewport_px must be [x, y, width, height]"};
      HeadsetEye& eye = h.eyes[static_cast<std::size_t>(e)];
      for (int i = 0; i < 4; ++i) eye.viewport[i] = vp[static_cast<std::size_t>(i)].get<int>();
      eye.lens_center_px[0] = eye.viewport[2] / 2.0;
      eye.lens_center_px[1] = eye.viewport[3] / 2.0;
      if (je.contains("lens_center_px")) {
        const auto& lc = je["lens_center_px"];
        if (!lc.is_array() || lc.size() != 2) return Error{where + f + ".lens_center_px must be [x, y]"};
        eye.lens_center_px[0] = lc[0].get<double>();
        eye.lens_center_px[1] = lc[1].get<double>();
      }
    }
    const auto& fov = j["fov_deg"];
    if (!fov.is_array() || fov.size() != 2) return Error{where + "fov_deg must be [horizontal, vertical]"};
    h.fov_h_deg = fov[0].get<double>();
    h.fov_v_deg = fov[1].get<double>();
    h.ipd_m = j["ipd_mm"].get<double>() * 1e-3;
    h.mono_convergence_m = j.value("mono_convergence_mm", 400.0) * 1e-3;
    if (j.contains("distortion")) {
      const auto& d = j["distortion"];
      if (!d.is_object()) return Error{where + "distortion must be an object"};
      for (const auto& [k, v] : d.items())
        if (k != "k1" && k != "k2" && k != "chroma_scale_r" && k != "chroma_scale_b")
          return Error{where + "distortion: unknown field \"" + k + "\" (k1, k2, chroma_scale_r, chroma_scale_b)"};
      h.k1 = d.value("k1", 0.0);
      h.k2 = d.value("k2", 0.0);
      h.chroma_scale_r = d.value("chroma_scale_r", 1.0);
      h.chroma_scale_b = d.value("chroma_scale_b", 1.0);
    }
  } catch (const nlohmann::json::exception& e) {
    return Error{where + "a field has the wrong type (" + e.what() + ")"};
  }
  if (std::string v = h.validate(); !v.empty()) return Error{where + v};
  return h;
}

Result<HeadsetProfile> read_headset_profile(const std::string& path) {
  std::ifstream f(path);
  if (!f) return Error{"headset profile " + path + ": cannot read the file"};
  std::stringstream ss;
  ss << f.rdbuf();
  return parse_headset_profile(ss.str(), path);
}

void EyeMapping::eye_to_camera(double qx, double qy, double& u, double& v) const {
  // Eye image point (viewport px) to tan angles about the lens axis.
  double tx = (qx - lens_c[0]) / f_eye[0], ty = (qy - lens_c[1]) / f_eye[1];
  if (loupe.mag > 0) {
    if (!loupe.inset) {
      u = loupe_c[0] + f_cam[0] * (tx - shift_tan) / loupe.mag;
      v = loupe_c[1] + f_cam[1] * ty / loupe.mag;
      return;
    }
    const double ix = loupe.inset_cx * vp[2], iy = loupe.inset_cy * vp[3];
    const double hw = loupe.inset_w * vp[2] / 2, hh = loupe.inset_h * vp[3] / 2;
    if (std::abs(qx - ix) <= hw && std::abs(qy - iy) <= hh) {
      u = loupe_c[0] + f_cam[0] * ((qx - ix) / f_eye[0]) / loupe.mag;
      v = loupe_c[1] + f_cam[1] * ((qy - iy) / f_eye[1]) / loupe.mag;
      return;
    }
  }
  u = c_cam[0] + f_cam[0] * (tx - shift_tan);
  v = c_cam[1] + f_cam[1] * ty;
}

bool EyeMapping::map(double px, double py, int ch, double& u, double& v) const {
  const double x = px - vp[0], y = py - vp[1];
  if (x < 0 || y < 0 || x > vp[2] || y > vp[3]) return false;
  const double dx = (x - lens_c[0]) / norm, dy = (y - lens_c[1]) / norm;
  const double r2 = dx * dx + dy * dy;
  const double s = (1 + k1 * r2 + k2 * r2 * r2) * chroma[ch];
  eye_to_camera(lens_c[0] + dx * s * norm, lens_c[1] + dy * s * norm, u, v);
  return true;
}

EyeMapping make_eye_mapping(const HeadsetProfile& h, int eye, const calibration::CameraIntrinsics& cam, bool stereo,
                            const LoupeView& loupe, const double loupe_c[2], bool prewarp) {
  EyeMapping m;
  const HeadsetEye& e = h.eyes[static_cast<std::size_t>(eye)];
  for (int i = 0; i < 4; ++i) m.vp[i] = e.viewport[i];
  m.lens_c[0] = e.lens_center_px[0];
  m.lens_c[1] = e.lens_center_px[1];
  m.norm = e.viewport[2] / 2.0;
  if (prewarp) {
    m.k1 = h.k1;
    m.k2 = h.k2;
    m.chroma[0] = h.chroma_scale_r;
    m.chroma[2] = h.chroma_scale_b;
  }
  m.f_eye[0] = (e.viewport[2] / 2.0) / std::tan(h.fov_h_deg * kPi / 360.0);
  m.f_eye[1] = (e.viewport[3] / 2.0) / std::tan(h.fov_v_deg * kPi / 360.0);
  m.shift_tan = stereo ? 0.0 : (eye == 0 ? 1.0 : -1.0) * (h.ipd_m / 2) / h.mono_convergence_m;
  set_camera_and_loupe(m, cam, loupe, loupe_c);
  return m;
}

PanelRect letterbox(int win_w, int win_h, int w, int h) {
  PanelRect r;
  if (win_w <= 0 || win_h <= 0 || w <= 0 || h <= 0) return r;
  const double s = std::min(double(win_w) / w, double(win_h) / h);
  r.w = static_cast<int>(std::lround(w * s));
  r.h = static_cast<int>(std::lround(h * s));
  r.x = (win_w - r.w) / 2;
  r.y = (win_h - r.h) / 2;
  return r;
}

EyeMapping make_window_mapping(int win_w, int win_h, const calibration::CameraIntrinsics& cam, const LoupeView& loupe,
                               const double loupe_c[2]) {
  EyeMapping m;
  const double s = std::min(double(win_w) / cam.width, double(win_h) / cam.height);
  const PanelRect lb = letterbox(win_w, win_h, cam.width, cam.height);
  const int dw = lb.w;
  m.vp[0] = lb.x;
  m.vp[1] = lb.y;
  m.vp[2] = lb.w;
  m.vp[3] = lb.h;
  // The eye image is the video scaled by s: its "lens axis" at the principal point.
  m.lens_c[0] = (cam.cx + 0.5) * s;
  m.lens_c[1] = (cam.cy + 0.5) * s;
  m.norm = dw / 2.0;
  m.f_eye[0] = cam.fx * s;
  m.f_eye[1] = cam.fy * s;
  set_camera_and_loupe(m, cam, loupe, loupe_c);
  return m;
}

void render_eye_cpu(const cv::Mat& src, const EyeMapping& m, cv::Mat& panel) {
  CV_Assert(src.type() == CV_8UC3 && panel.type() == CV_8UC3);
  const int W = src.cols, H = src.rows;
  for (int y = std::max(0, m.vp[1]); y < std::min(panel.rows, m.vp[1] + m.vp[3]); ++y) {
    auto* out = panel.ptr<cv::Vec3b>(y);
    for (int x = std::max(0, m.vp[0]); x < std::min(panel.cols, m.vp[0] + m.vp[2]); ++x) {
      for (int ch = 0; ch < 3; ++ch) {
        double u = 0, v = 0;
        if (!m.map(x + 0.5, y + 0.5, ch, u, v)) continue;
        // Texture coordinates as GL has them (pixel centre at +0.5), black
        // outside the image, clamped to the edge texels inside it.
        const double tu = u + 0.5, tv = v + 0.5;
        const int bgr = 2 - ch;
        if (tu < 0 || tv < 0 || tu > W || tv > H) {
          out[x][bgr] = 0;
          continue;
        }
        const double sx = tu - 0.5, sy = tv - 0.5;
        const int x0 = static_cast<int>(std::floor(sx)), y0 = static_cast<int>(std::floor(sy));
        const double fx = sx - x0, fy = sy - y0;
        auto at = [&](int xx, int yy) {
          xx = std::clamp(xx, 0, W - 1);
          yy = std::clamp(yy, 0, H - 1);
          return static_cast<double>(src.at<cv::Vec3b>(yy, xx)[bgr]);
        };
        const double val = (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) +
                           fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
        out[x][bgr] = cv::saturate_cast<uchar>(val);
      }
    }
  }
}

int WarpGrid::live_cells() const {
  int n = 0;
  for (const std::uint8_t l : live) n += l;
  return n;
}

WarpGrid make_warp_grid(const EyeMapping& m, int cols, int rows) {
  WarpGrid g;
  g.cols = std::max(1, cols);
  g.rows = std::max(1, rows);
  const int nx = g.cols + 1, ny = g.rows + 1;
  g.xy.resize(static_cast<std::size_t>(2 * nx * ny));
  g.uv.resize(static_cast<std::size_t>(6 * nx * ny));
  g.live.assign(static_cast<std::size_t>(g.cols * g.rows), 0);
  const double W = m.cam_w, H = m.cam_h;
  // A point of the viewport in cell units (i, j) to panel px.
  auto panel = [&](double i, double j, double& px, double& py) {
    px = m.vp[0] + std::min(double(m.vp[2]), i * m.vp[2] / g.cols);
    py = m.vp[1] + std::min(double(m.vp[3]), j * m.vp[3] / g.rows);
  };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const std::size_t k = static_cast<std::size_t>(j * nx + i);
      double px = 0, py = 0;
      panel(i, j, px, py);
      g.xy[2 * k] = static_cast<float>(px);
      g.xy[2 * k + 1] = static_cast<float>(py);
      for (int ch = 0; ch < 3; ++ch) {
        double u = 0, v = 0;
        m.map(px, py, ch, u, v);
        g.uv[6 * k + 2 * static_cast<std::size_t>(ch)] = static_cast<float>((u + 0.5) / W);
        g.uv[6 * k + 2 * static_cast<std::size_t>(ch) + 1] = static_cast<float>((v + 0.5) / H);
      }
    }
  if (m.loupe.mag > 0 && m.loupe.inset) {
    std::fill(g.live.begin(), g.live.end(), std::uint8_t{1});
    return g;
  }
  for (int j = 0; j < g.rows; ++j)
    for (int i = 0; i < g.cols; ++i) {
      bool seen = false;
      for (int ch = 0; ch < 3 && !seen; ++ch) {
        double u0 = 1e300, u1 = -1e300, v0 = 1e300, v1 = -1e300;
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) {
            double px = 0, py = 0, u = 0, v = 0;
            panel(i + a / 2.0, j + b / 2.0, px, py);
            m.map(px, py, ch, u, v);
            u0 = std::min(u0, u), u1 = std::max(u1, u), v0 = std::min(v0, v), v1 = std::max(v1, v);
          }
        const double gu = 0.5 * (u1 - u0) + 2, gv = 0.5 * (v1 - v0) + 2;
        seen = u1 + gu >= -0.5 && u0 - gu <= W - 0.5 && v1 + gv >= -0.5 && v0 - gv <= H - 0.5;
      }
      g.live[static_cast<std::size_t>(j * g.cols + i)] = seen ? 1 : 0;
    }
  return g;
}

namespace {

// The exact camera px of a panel point in channel ch and whether the pass shows the
// camera there (render_eye_cpu's test: texture coordinates within [0, 1]).
bool exact_seen(const EyeMapping& m, double px, double py, int ch, double& u, double& v) {
  if (!m.map(px, py, ch, u, v)) return false;
  return u >= -0.5 && u <= m.cam_w - 0.5 && v >= -0.5 && v <= m.cam_h - 0.5;
}

// A camera-px error (du, dv) at panel point (px, py) as a panel displacement: the mapping's
// Jacobian there (central differences over +-0.25 px) inverted.
double panel_displacement(const EyeMapping& m, double px, double py, int ch, double du, double dv) {
  double ux0, vx0, ux1, vx1, uy0, vy0, uy1, vy1;
  m.map(px - 0.25, py, ch, ux0, vx0);
  m.map(px + 0.25, py, ch, ux1, vx1);
  m.map(px, py - 0.25, ch, uy0, vy0);
  m.map(px, py + 0.25, ch, uy1, vy1);
  const double a = (ux1 - ux0) * 2, b = (uy1 - uy0) * 2, c = (vx1 - vx0) * 2, d = (vy1 - vy0) * 2;
  const double det = a * d - b * c;
  if (!(std::abs(det) > 1e-12)) return std::hypot(du, dv);
  const double dx = (d * du - b * dv) / det, dy = (-c * du + a * dv) / det;
  return std::hypot(dx, dy);
}

void finish(WarpError& e, std::vector<float>& errs) {
  if (errs.empty()) return;
  const auto k = errs.begin() + static_cast<std::ptrdiff_t>((errs.size() - 1) * 99 / 100);
  std::nth_element(errs.begin(), k, errs.end());
  e.p99_cam_px = *k;
}

}  // namespace

WarpError warp_grid_error(const WarpGrid& g, const EyeMapping& m) {
  WarpError e;
  std::vector<float> errs;
  const double cw = double(m.vp[2]) / g.cols, chh = double(m.vp[3]) / g.rows;
  const int nx = g.cols + 1;
  for (int y = 0; y < m.vp[3]; ++y)
    for (int x = 0; x < m.vp[2]; ++x) {
      const double lx = x + 0.5, ly = y + 0.5, px = m.vp[0] + lx, py = m.vp[1] + ly;
      const int ci = std::min(g.cols - 1, static_cast<int>(lx / cw)), cj = std::min(g.rows - 1, static_cast<int>(ly / chh));
      const double fx = lx / cw - ci, fy = ly / chh - cj;
      const bool live = g.live[static_cast<std::size_t>(cj * g.cols + ci)] != 0;
      bool any = false;
      for (int ch = 0; ch < 3; ++ch) {
        double u = 0, v = 0;
        if (!exact_seen(m, px, py, ch, u, v)) continue;
        any = true;
        if (!live) continue;
        // Two triangles a-b-c and b-d-c (a top-left, b top-right, c bottom-left, d bottom-right).
        auto uv = [&](int i, int j, int comp) {
          return double(g.uv[6 * static_cast<std::size_t>(j * nx + i) + 2 * static_cast<std::size_t>(ch) + static_cast<std::size_t>(comp)]);
        };
        double t[2];
        for (int comp = 0; comp < 2; ++comp) {
          const double a = uv(ci, cj, comp), b = uv(ci + 1, cj, comp), c = uv(ci, cj + 1, comp), d = uv(ci + 1, cj + 1, comp);
          t[comp] = fx + fy <= 1 ? a + fx * (b - a) + fy * (c - a) : d + (1 - fx) * (c - d) + (1 - fy) * (b - d);
        }
        const double du = t[0] * m.cam_w - 0.5 - u, dv = t[1] * m.cam_h - 0.5 - v;
        const double err = std::hypot(du, dv);
        errs.push_back(static_cast<float>(err));
        e.max_cam_px[ch] = std::max(e.max_cam_px[ch], err);
        e.max_panel_px[ch] = std::max(e.max_panel_px[ch], panel_displacement(m, px, py, ch, du, dv));
      }
      e.pixels += any ? 1 : 0;
      e.culled_seen += any && !live ? 1 : 0;
    }
  finish(e, errs);
  return e;
}

std::vector<float> warp_lut(const EyeMapping& m, bool half) {
  std::vector<float> lut(static_cast<std::size_t>(2 * m.vp[2] * m.vp[3]));
  for (int y = 0; y < m.vp[3]; ++y)
    for (int x = 0; x < m.vp[2]; ++x) {
      const double dx = (x + 0.5 - m.lens_c[0]) / m.norm, dy = (y + 0.5 - m.lens_c[1]) / m.norm;
      const double r2 = dx * dx + dy * dy, s = 1 + m.k1 * r2 + m.k2 * r2 * r2;
      float a = static_cast<float>(dx * s), b = static_cast<float>(dy * s);
      if (half) a = static_cast<float>(cv::float16_t(a)), b = static_cast<float>(cv::float16_t(b));
      lut[2 * static_cast<std::size_t>(y * m.vp[2] + x)] = a;
      lut[2 * static_cast<std::size_t>(y * m.vp[2] + x) + 1] = b;
    }
  return lut;
}

WarpError warp_lut_error(const EyeMapping& m, bool half) {
  WarpError e;
  std::vector<float> errs;
  const std::vector<float> lut = warp_lut(m, half);
  for (int y = 0; y < m.vp[3]; ++y)
    for (int x = 0; x < m.vp[2]; ++x) {
      const double px = m.vp[0] + x + 0.5, py = m.vp[1] + y + 0.5;
      bool any = false;
      for (int ch = 0; ch < 3; ++ch) {
        double u = 0, v = 0;
        if (!exact_seen(m, px, py, ch, u, v)) continue;
        any = true;
        const std::size_t k = 2 * static_cast<std::size_t>(y * m.vp[2] + x);
        double lu = 0, lv = 0;
        m.eye_to_camera(m.lens_c[0] + lut[k] * m.chroma[ch] * m.norm, m.lens_c[1] + lut[k + 1] * m.chroma[ch] * m.norm, lu, lv);
        const double du = lu - u, dv = lv - v, err = std::hypot(du, dv);
        errs.push_back(static_cast<float>(err));
        e.max_cam_px[ch] = std::max(e.max_cam_px[ch], err);
        e.max_panel_px[ch] = std::max(e.max_panel_px[ch], panel_displacement(m, px, py, ch, du, dv));
      }
      e.pixels += any ? 1 : 0;
    }
  finish(e, errs);
  return e;
}

void LoupeCentre::update(bool valid, double u, double v) {
  if (!valid || !std::isfinite(u) || !std::isfinite(v)) return;  // hold
  if (!init_) {
    reset(u, v);
    return;
  }
  const double ex = u - c_[0], ey = v - c_[1];
  const double e = std::hypot(ex, ey);
  if (e > snap_) {
    reset(u, v);
  } else if (e > deadband_) {
    const double k = (e - deadband_) / e;  // dragged: the projection stays on the deadband's rim
    c_[0] += ex * k;
    c_[1] += ey * k;
  }
}

bool project_point(const calibration::CameraIntrinsics& cam, const Eigen::Isometry3d& T_cam_x, const Eigen::Vector3d& p_x,
                   double& u, double& v) {
  const Eigen::Vector3d p = T_cam_x * p_x;
  if (!(p.z() > 1e-6)) return false;
  std::vector<cv::Point3d> in{{p.x(), p.y(), p.z()}};
  std::vector<cv::Point2d> out;
  const cv::Matx33d K(cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1);
  const cv::Mat dist(1, 5, CV_64F, const_cast<double*>(cam.dist.data()));
  cv::projectPoints(in, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, dist, out);
  u = out[0].x;
  v = out[0].y;
  return std::isfinite(u) && std::isfinite(v);
}

}  // namespace dentar::live
