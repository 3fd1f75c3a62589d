#include "dentar/ar/mirror_rim.h"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>

#include "dentar/ar/srgb.h"

namespace dentar::ar {

std::string MirrorRimOptions::validate() const {
  std::ostringstream os;
  if (samples < 8 || samples > 4096) os << "samples = " << samples << " must be in 8..4096";
  else if (!(std::isfinite(search_px) && search_px >= 1 && search_px <= 50))
    os << "search_px = " << search_px << " must be in [1, 50]";
  else if (!(std::isfinite(min_step) && min_step >= 0 && min_step < 1))
    os << "min_step = " << min_step << " must be in [0, 1)";
  else if (!(std::isfinite(ambiguity) && ambiguity > 0 && ambiguity <= 1))
    os << "ambiguity = " << ambiguity << " must be in (0, 1]";
  else if (!(std::isfinite(stem_exclude_rad) && stem_exclude_rad >= 0 && stem_exclude_rad < M_PI))
    os << "stem_exclude_rad = " << stem_exclude_rad << " must be in [0, pi)";
  else if (min_points < 6) os << "min_points = " << min_points << " must be >= 6";
  else if (!(std::isfinite(huber_px) && huber_px > 0)) os << "huber_px = " << huber_px << " must be > 0";
  else if (!(std::isfinite(max_correction_sigma) && max_correction_sigma > 0))
    os << "max_correction_sigma = " << max_correction_sigma << " must be > 0";
  else if (iterations < 1 || iterations > 100) os << "iterations = " << iterations << " must be in 1..100";
  else if (rounds < 1 || rounds > 10) os << "rounds = " << rounds << " must be in 1..10";
  else if (!(std::isfinite(research_px) && research_px >= 0.5 && research_px <= 50))
    os << "research_px = " << research_px << " must be in [0.5, 50]";
  else if (!(std::isfinite(rim_effective_points) && rim_effective_points >= 1))
    os << "rim_effective_points = " << rim_effective_points << " must be >= 1";
  else if (!(std::isfinite(blur_px) && blur_px >= 0.1 && blur_px <= 10))
    os << "blur_px = " << blur_px << " must be in [0.1, 10]";
  else if (!(std::isfinite(max_width_ratio) && max_width_ratio >= 1))
    os << "max_width_ratio = " << max_width_ratio << " must be >= 1";
  else if (!(std::isfinite(max_fit_rms) && max_fit_rms > 0))
    os << "max_fit_rms = " << max_fit_rms << " must be > 0";
  else if (!(std::isfinite(saturation) && saturation > 0 && saturation <= 1.5))
    os << "saturation = " << saturation << " must be in (0, 1.5]";
  else if (parallel_lines < 1 || parallel_lines > 15)
    os << "parallel_lines = " << parallel_lines << " must be in 1..15";
  else if (!(std::isfinite(parallel_px) && parallel_px >= 0 && parallel_px <= 5))
    os << "parallel_px = " << parallel_px << " must be in [0, 5]";
  else if (max_candidates < 1 || max_candidates > 64)
    os << "max_candidates = " << max_candidates << " must be in 1..64";
  else if (!(std::isfinite(max_rim_rms_px) && max_rim_rms_px >= 0))
    os << "max_rim_rms_px = " << max_rim_rms_px << " must be >= 0";
  else if (!(std::isfinite(face_level_tol) && face_level_tol >= 0))
    os << "face_level_tol = " << face_level_tol << " must be >= 0";
  return os.str();
}

namespace {

using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;

// Linear-light sample (0..1) of an 8-bit image, bilinear; nullopt off the image.
struct Sampler {
  const cv::Mat& g;
  const float* lut;  // 256 entries, or null: levels / 255
  std::optional<double> operator()(const Eigen::Vector2d& p) const {
    const int x = static_cast<int>(std::floor(p.x())), y = static_cast<int>(std::floor(p.y()));
    if (x < 0 || y < 0 || x + 1 >= g.cols || y + 1 >= g.rows) return std::nullopt;
    const double a = p.x() - x, b = p.y() - y;
    const std::uint8_t* r0 = g.ptr<std::uint8_t>(y);
    const std::uint8_t* r1 = g.ptr<std::uint8_t>(y + 1);
    auto v = [&](std::uint8_t c) { return lut ? double(lut[c]) : c / 255.0; };
    return (1 - b) * ((1 - a) * v(r0[x]) + a * v(r0[x + 1])) + b * ((1 - a) * v(r1[x]) + a * v(r1[x + 1]));
  }
};

// The pose with a delta (w, v) applied as BundlePose defines it.
Eigen::Isometry3d apply(const Eigen::Isometry3d& T, const Vec6& d) {
  Eigen::Isometry3d out = T;
  const Eigen::Vector3d w = d.head<3>();
  const double a = w.norm();
  if (a > 0) out.linear() = Eigen::AngleAxisd(a, w / a).toRotationMatrix() * T.linear();
  out.translation() = T.translation() + d.tail<3>();
  return out;
}

}  // namespace

namespace {

// The mean of o.parallel_lines profiles along `normal` around `origin`:
// sample k at x = (k - ns - pad) * step. False off the image.
struct Profile {
  std::vector<double> v;
  double step = 0.25, reach = 0;
  int ns = 0, nf = 0, pad = 0;
  double x(int k) const { return (k - ns - pad) * step; }
  double grad(int k) const { return (v[k + 2] - v[k - 2]) / (4 * step); }
};

bool sample_profile(const Sampler& S, const Eigen::Vector2d& origin, const Eigen::Vector2d& normal, double window,
                    const MirrorRimOptions& o, Profile& p) {
  p.reach = 1.5 + 2 * o.blur_px;  // the fit's half-width around the gradient peak
  p.ns = std::max(2, static_cast<int>(std::round(window / p.step)));
  p.nf = static_cast<int>(std::ceil(p.reach / p.step));
  p.pad = p.nf + 2;
  const int n = 2 * p.ns + 1 + 2 * p.pad;
  p.v.assign(n, 0.0);
  const Eigen::Vector2d tan(-normal.y(), normal.x());
  const int L = o.parallel_lines;
  for (int l = 0; l < L; ++l) {
    const Eigen::Vector2d p0 = origin + tan * ((l - 0.5 * (L - 1)) * o.parallel_px);
    for (int k = 0; k < n; ++k) {
      const auto v = S(p0 + normal * p.x(k));
      if (!v) return false;
      p.v[k] += *v / L;
    }
  }
  return true;
}

// The blurred-step fit seeded at sample `best`, and its tests.
RimEdgeFit fit_step(const Profile& P, int best, double window, const MirrorRimOptions& o) {
  RimEdgeFit res;
  const int nf = P.nf;
  const double reach = P.reach;
  const int k0 = best - nf, k1 = best + nf;
  for (int k = k0; k <= k1; ++k)
    if (P.v[k] >= o.saturation) {
      res.why = "saturated";
      return res;
    }
  // Least squares  a + b Phi((x - x0) / w)  over [k0, k1] (Gauss-Newton, a
  // little damping, x0 kept within the fit window, w within [0.15, 5] px).
  double a = P.v[k0], b = P.v[k1] - P.v[k0], x0 = P.x(best), w = o.blur_px;
  const double xlo = P.x(best) - reach, xhi = P.x(best) + reach;
  auto Phi = [](double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); };
  auto cost = [&](double aa, double bb, double xx, double ww) {
    double c = 0;
    for (int k = k0; k <= k1; ++k) {
      const double r = aa + bb * Phi((P.x(k) - xx) / ww) - P.v[k];
      c += r * r;
    }
    return c;
  };
  double c = cost(a, b, x0, w), mu = 1e-4;
  for (int it = 0; it < 15; ++it) {
    Eigen::Matrix4d H = Eigen::Matrix4d::Zero();
    Eigen::Vector4d g = Eigen::Vector4d::Zero();
    for (int k = k0; k <= k1; ++k) {
      const double z = (P.x(k) - x0) / w, phi = std::exp(-0.5 * z * z) / std::sqrt(2 * M_PI), F = Phi(z);
      const double r = a + b * F - P.v[k];
      const Eigen::Vector4d J(1.0, F, -b * phi / w, -b * phi * z / w);
      H += J * J.transpose();
      g += J * r;
    }
    Eigen::Matrix4d Hd = H;
    Hd.diagonal() *= 1 + mu;
    Hd.diagonal().array() += 1e-12;
    const Eigen::Vector4d d = Hd.ldlt().solve(-g);
    const double na = a + d[0], nb = b + d[1], nx = std::clamp(x0 + d[2], xlo, xhi),
                 nw = std::clamp(w + d[3], 0.15, 5.0);
    const double nc = cost(na, nb, nx, nw);
    if (nc < c) {
      const bool done = std::abs(nx - x0) < 1e-3 && std::abs(nw - w) < 1e-3;
      a = na, b = nb, x0 = nx, w = nw, c = nc;
      mu = std::max(1e-6, mu * 0.3);
      if (done) break;
    } else {
      mu *= 10;
      if (mu > 1e4) break;
    }
  }
  res.offset_px = x0;
  res.width_px = w;
  res.step = b;
  res.rms = std::sqrt(c / (k1 - k0 + 1));
  res.inside = a;
  if (std::abs(b) < o.min_step) res.why = "weak step";
  else if (x0 <= xlo + 1e-9 || x0 >= xhi - 1e-9 || std::abs(x0) > window) res.why = "step outside the window";
  else if (w > o.max_width_ratio * o.blur_px) res.why = "too wide (blur)";
  else if (res.rms > o.max_fit_rms * std::abs(b)) res.why = "not one step";
  else res.ok = true;
  return res;
}

bool edge_input_ok(const cv::Mat& gray, double window, const Eigen::Vector2d& normal, const MirrorRimOptions& o) {
  return !gray.empty() && gray.type() == CV_8UC1 && window > 0 && o.validate().empty() &&
         std::abs(normal.norm() - 1) < 1e-6;
}

// Every step along the line (local gradient maxima >= 0.25 x the largest,
// at least 0.75 px apart) that passes the fit's tests (joint_select).
std::vector<RimEdgeFit> edge_candidates(const Sampler& S, const Eigen::Vector2d& origin, const Eigen::Vector2d& normal,
                                        double window, const MirrorRimOptions& o, bool& off_image) {
  std::vector<RimEdgeFit> out;
  Profile P;
  off_image = !sample_profile(S, origin, normal, window, o, P);
  if (off_image) return out;
  double gmax = 0;
  for (int k = P.pad; k <= P.pad + 2 * P.ns; ++k) gmax = std::max(gmax, std::abs(P.grad(k)));
  if (!(gmax > 0)) return out;
  std::vector<int> peaks;
  for (int k = P.pad + 1; k < P.pad + 2 * P.ns; ++k) {
    const double g = std::abs(P.grad(k));
    if (g < 0.25 * gmax || g < std::abs(P.grad(k - 1)) || g < std::abs(P.grad(k + 1))) continue;
    if (!peaks.empty() && (k - peaks.back()) * P.step < 0.75) {
      if (g > std::abs(P.grad(peaks.back()))) peaks.back() = k;
      continue;
    }
    peaks.push_back(k);
  }
  // Only the strongest max_candidates are fitted (the fit is the cost).
  if (static_cast<int>(peaks.size()) > o.max_candidates) {
    std::partial_sort(peaks.begin(), peaks.begin() + o.max_candidates, peaks.end(),
                      [&](int x, int y) { return std::abs(P.grad(x)) > std::abs(P.grad(y)); });
    peaks.resize(o.max_candidates);
  }
  for (int k : peaks) {
    RimEdgeFit f = fit_step(P, k, window, o);
    if (f.ok) out.push_back(f);
  }
  return out;
}

}  // namespace

RimEdgeFit locate_rim_edge(const cv::Mat& gray, bool srgb, const Eigen::Vector2d& origin,
                           const Eigen::Vector2d& normal, double window, const MirrorRimOptions& o) {
  RimEdgeFit res;
  if (!edge_input_ok(gray, window, normal, o)) {
    res.why = "bad input";
    return res;
  }
  const Sampler S{gray, srgb ? srgb_decode_table().ptr<float>() : nullptr};
  Profile P;
  if (!sample_profile(S, origin, normal, window, o, P)) {
    res.why = "off the image";
    return res;
  }
  int best = -1;
  double gbest = 0;
  for (int k = P.pad; k <= P.pad + 2 * P.ns; ++k)
    if (std::abs(P.grad(k)) > gbest) {
      gbest = std::abs(P.grad(k));
      best = k;
    }
  if (best <= P.pad || best >= P.pad + 2 * P.ns) {
    res.why = "peak at the window's end";
    return res;
  }
  double second = 0;
  for (int k = P.pad; k <= P.pad + 2 * P.ns; ++k)
    if (std::abs(k - best) * P.step > 1.5) second = std::max(second, std::abs(P.grad(k)));
  if (second >= o.ambiguity * gbest) {
    res.why = "ambiguous";
    return res;
  }
  return fit_step(P, best, window, o);
}

MirrorRimResult refine_mirror_rim(const cv::Mat& gray, bool srgb, const CameraModel& model,
                                  const BundlePose& tags, double corner_noise_px2,
                                  const Eigen::Isometry3d& T_mtag_mir, double radius_m,
                                  double thickness_m, const MirrorRimOptions& o) {
  MirrorRimResult res;
  res.T_cam_body = tags.T_cam_body;
  res.covariance_per_px2 = tags.covariance_per_px2;
  res.covariance_per_tag = tags.covariance_per_tag;
  if (!tags.ok()) {
    res.why = "tag fit not ok";
    return res;
  }
  if (gray.empty() || gray.type() != CV_8UC1 || !o.validate().empty() || !(radius_m > 0)) {
    res.why = "bad input";
    return res;
  }
  const Mat6 C_t = tags.covariance_per_px2;
  Eigen::FullPivLU<Mat6> lu(C_t);
  if (!lu.isInvertible()) {
    res.why = "tag covariance singular";
    return res;
  }
  const Mat6 H_t = lu.inverse();  // information per px^2 of corner noise
  const Sampler S{gray, srgb ? srgb_decode_table().ptr<float>() : nullptr};

  const double t = o.silhouette_back ? std::max(0.0, thickness_m) : 0.0;
  auto rim_pt = [&](double th, double z) {
    return Eigen::Vector3d(radius_m * std::cos(th), radius_m * std::sin(th), z);
  };

  // Points in the body (mtag) frame and their measured edge along the normal.
  struct Obs {
    double th = 0, z = 0;
    Eigen::Vector2d e_px, n;
    double thc = 0;  // exact_silhouette: the angle whose point lies on the edge's line
  };
  std::vector<Obs> obs;
  const double step = 0.25;
  // Searches the rim's edges around its projection at pose T (cam <- mtag)
  // within +-window px; fills obs and res.edges. False: centre not in front.
  auto search = [&](const Eigen::Isometry3d& T_body, double window) {
    obs.clear();
    res.edges.clear();
    res.candidates = 0;
    const Eigen::Isometry3d T0 = T_body * T_mtag_mir;  // cam <- mir
    const auto c_px = model.project(T0.translation());
    if (!c_px) return false;
    const int ns = std::max(2, static_cast<int>(std::round(window / step)));
    // joint_select: every candidate step per angle.
    struct Cands {
      double th;
      bool back;
      Eigen::Vector2d u, n;
      std::vector<RimEdgeFit> c;
    };
    std::vector<Cands> cands;
    // The face's level: the median of the image at half the radius.
    double face_level = -1;
    if (o.step_fit && o.face_level_tol > 0) {
      std::vector<double> lv;
      for (int i = 0; i < 24; ++i) {
        const double a = 2 * M_PI * (i + 0.5) / 24;
        const auto q = model.project(T0 * Eigen::Vector3d(0.5 * radius_m * std::cos(a), 0.5 * radius_m * std::sin(a), 0));
        if (!q) continue;
        if (const auto v = S(*q)) lv.push_back(*v);
      }
      if (lv.size() >= 12) {
        std::nth_element(lv.begin(), lv.begin() + lv.size() / 2, lv.end());
        face_level = lv[lv.size() / 2];
      }
    }
    // One edge found at angle th: offset_px along the normal n from the
    // model point u, its step of linear light.
    auto add_edge = [&](double th, bool back, const Eigen::Vector2d& u, const Eigen::Vector2d& n, double offset_px,
                        double step_level) {
      MirrorRimEdge e;
      e.angle_rad = th;
      e.back = back;
      e.model_px = u;
      e.normal = n;
      e.offset_px = offset_px;
      e.step = step_level;
      res.edges.push_back(e);
      obs.push_back({th, back ? -t : 0.0, u + n * offset_px, n, th});
    };
    std::vector<double> prof(2 * ns + 1 + 4);
    for (int i = 0; i < o.samples; ++i) {
      const double th = 2 * M_PI * (i + 0.5) / o.samples;
      // The stem leaves the rim along -y (th = -pi/2 = 3pi/2).
      const double dth = std::remainder(th + M_PI / 2, 2 * M_PI);
      if (std::abs(dth) < o.stem_exclude_rad) continue;
      const auto u_f = model.project(T0 * rim_pt(th, 0));
      const auto u_a = model.project(T0 * rim_pt(th - 1e-3, 0));
      const auto u_b = model.project(T0 * rim_pt(th + 1e-3, 0));
      if (!u_f || !u_a || !u_b) continue;
      const Eigen::Vector2d tan = *u_b - *u_a;
      if (tan.norm() < 1e-9) continue;
      Eigen::Vector2d n(-tan.y(), tan.x());
      n.normalize();
      if (n.dot(*u_f - *c_px) < 0) n = -n;
      // Outer silhouette: the face's circle or the back's.
      bool back = false;
      Eigen::Vector2d u = *u_f;
      if (t > 0) {
        const auto u_k = model.project(T0 * rim_pt(th, -t));
        if (u_k && (*u_k - *u_f).dot(n) > 0) {
          back = true;
          u = *u_f + n * (*u_k - *u_f).dot(n);
        }
      }
      if (o.step_fit && o.joint_select) {
        bool off = false;
        std::vector<RimEdgeFit> c = edge_candidates(S, u, n, window, o, off);
        if (!off) ++res.candidates;
        if (!c.empty()) cands.push_back({th, back, u, n, std::move(c)});
        continue;
      }
      if (o.step_fit) {
        const RimEdgeFit f = locate_rim_edge(gray, srgb, u, n, window, o);
        if (f.why != "off the image") ++res.candidates;
        if (!f.ok) continue;
        if (!back && face_level >= 0 &&
            std::abs(f.inside - face_level) > o.face_level_tol * std::max(face_level, 0.05))
          continue;
        add_edge(th, back, u, n, f.offset_px, f.step);
        continue;
      }
      // Profile of linear light along n from -window-0.5 to +window+0.5 px.
      bool inside = true;
      for (int k = 0; k < static_cast<int>(prof.size()) && inside; ++k) {
        const auto v = S(u + n * ((k - ns - 2) * step));
        inside = v.has_value();
        if (inside) prof[k] = *v;
      }
      if (!inside) continue;
      ++res.candidates;
      // Gradient by a central difference over +-0.5 px, at k in [2, size-3].
      auto grad = [&](int k) { return (prof[k + 2] - prof[k - 2]) / (4 * step); };
      int best = -1;
      double gbest = 0;
      for (int k = 2; k <= 2 * ns + 2; ++k)
        if (std::abs(grad(k)) > gbest) {
          gbest = std::abs(grad(k));
          best = k;
        }
      if (best <= 2 || best >= 2 * ns + 2) continue;  // at the window's end
      double second = 0;
      for (int k = 2; k <= 2 * ns + 2; ++k)
        if (std::abs(k - best) * step > 1.5) second = std::max(second, std::abs(grad(k)));
      if (second >= o.ambiguity * gbest) continue;
      // Step across the edge: +-1.5 px around the peak (clamped to the profile).
      const int ka = std::max(0, best - 6), kb = std::min(static_cast<int>(prof.size()) - 1, best + 6);
      const double dstep = prof[kb] - prof[ka];
      if (std::abs(dstep) < o.min_step) continue;
      // Sub-sample peak: parabola through |g| at best-1, best, best+1.
      const double g0 = std::abs(grad(best - 1)), g1 = gbest, g2 = std::abs(grad(best + 1));
      double sub = 0;
      const double den = g0 - 2 * g1 + g2;
      if (den < 0) sub = std::clamp(0.5 * (g0 - g2) / den, -0.5, 0.5);
      add_edge(th, back, u, n, (best - ns - 2 + sub) * step, dstep);
    }
    if (o.step_fit && o.joint_select && !cands.empty()) {
      // One image shift of the predicted outline that most candidates agree
      // with (within 0.5 px along their normals), from pairs of angles about
      // a quarter and a third of the rim apart; then, per angle, the candidate
      // nearest to it (within 1 px).
      const double tol = 0.5;
      auto score = [&](const Eigen::Vector2d& dl, int& n_in, double& cost) {
        n_in = 0;
        cost = 0;
        for (const Cands& a : cands) {
          double m = 1e9;
          for (const RimEdgeFit& f : a.c) m = std::min(m, std::abs(f.offset_px - a.n.dot(dl)));
          if (m < tol) ++n_in;
          cost += std::min(m, tol) * std::min(m, tol);
        }
      };
      Eigen::Vector2d best_d = Eigen::Vector2d::Zero();
      int best_n = 0;
      double best_cost = 0;
      score(best_d, best_n, best_cost);
      const int M = static_cast<int>(cands.size());
      for (int i = 0; i < M; ++i)
        for (int j : {(i + M / 4) % M, (i + M / 3) % M}) {
          if (j == i) continue;
          Eigen::Matrix2d A;
          A.row(0) = cands[i].n.transpose();
          A.row(1) = cands[j].n.transpose();
          if (std::abs(A.determinant()) < 0.3) continue;
          const Eigen::Matrix2d Ai = A.inverse();
          for (const RimEdgeFit& fi : cands[i].c)
            for (const RimEdgeFit& fj : cands[j].c) {
              const Eigen::Vector2d dl = Ai * Eigen::Vector2d(fi.offset_px, fj.offset_px);
              if (dl.norm() > window) continue;
              int n_in = 0;
              double cost = 0;
              score(dl, n_in, cost);
              if (n_in > best_n || (n_in == best_n && cost < best_cost)) {
                best_n = n_in;
                best_cost = cost;
                best_d = dl;
              }
            }
        }
      for (const Cands& a : cands) {
        const RimEdgeFit* pick = nullptr;
        double m = 2 * tol;
        for (const RimEdgeFit& f : a.c)
          if (std::abs(f.offset_px - a.n.dot(best_d)) < m) {
            m = std::abs(f.offset_px - a.n.dot(best_d));
            pick = &f;
          }
        if (pick) add_edge(a.th, a.back, a.u, a.n, pick->offset_px, pick->step);
      }
    }
    if (o.step_fit && o.polarity_check && obs.size() >= 3) {
      // An edge whose sign differs from both neighbours' is another boundary.
      const std::size_t m = obs.size();
      std::vector<char> keep(m, 1);
      for (std::size_t i = 0; i < m; ++i) {
        const double sp = res.edges[(i + m - 1) % m].step, sn = res.edges[(i + 1) % m].step;
        const double si = res.edges[i].step;
        if (si * sp < 0 && si * sn < 0) keep[i] = 0;
      }
      std::size_t j = 0;
      for (std::size_t i = 0; i < m; ++i)
        if (keep[i]) {
          obs[j] = obs[i];
          res.edges[j] = res.edges[i];
          ++j;
        }
      obs.resize(j);
      res.edges.resize(j);
    }
    return true;
  };

  const double sc2 = std::max(corner_noise_px2, 1e-6);
  double lambda = 1.0;  // rim noise / corner noise (variance ratio), >= 1
  Vec6 d = Vec6::Zero();
  double scale = 0;  // the rim's scale - 1 (free_scale)
  Mat6 H = H_t;
  const Mat6 H_p = o.centre_only ? Mat6(H_t * 1e-4) : H_t;  // the prior in the rim fit
  // d(centre . ray)/d(delta) at the tag pose (keep_depth).
  Vec6 a_ray = Vec6::Zero();
  {
    const Eigen::Vector3d pc = T_mtag_mir.translation();
    const Eigen::Vector3d c0 = tags.T_cam_body * pc, ray = c0.normalized();
    for (int j = 0; j < 6; ++j) {
      Vec6 dj = Vec6::Zero();
      dj[j] = 1e-6;
      a_ray[j] = ray.dot(apply(tags.T_cam_body, dj) * pc - c0) / 1e-6;
    }
  }
  Eigen::VectorXd w;
  const int rounds = std::max(1, o.rounds);
  for (int round = 0; round < rounds; ++round) {
    const double window = round == 0 ? o.search_px : o.research_px;
    if (!search(apply(tags.T_cam_body, d), window)) {
      res.why = "centre behind the camera";
      res.edges.clear();
      return res;
    }
    res.points = static_cast<int>(obs.size());
    if (res.points < o.min_points) {
      res.why = "too few rim edges (" + std::to_string(res.points) + ")";
      res.edges.clear();
      return res;
    }
    const int N = res.points;
    Eigen::VectorXd r(N);
    w = Eigen::VectorXd::Ones(N);
    Eigen::MatrixXd J(N, 7);
    // Parameters: the pose delta (6) and, with free_scale, the rim's scale
    // (1 + s): the ellipse's size, which ties the depth to an edge bias
    // (0.5 px on a 25 px semi-axis is 2 % of the distance), is then left to
    // the tags; the rim fixes the disc's image position and tilt.
    const int np = o.free_scale ? 7 : 6;
    // exact_silhouette: slide each point along its circle until it lies on
    // its edge's line (the residual is then the distance along that line to
    // the modelled outline, not a first-order one).
    auto correspond = [&](const Vec6& dd, double sc) {
      if (!o.exact_silhouette) return;
      const Eigen::Isometry3d T = apply(tags.T_cam_body, dd) * T_mtag_mir;
      auto P = [&](const Obs& ob, double a) {
        return model.project(T * Eigen::Vector3d((1 + sc) * radius_m * std::cos(a), (1 + sc) * radius_m * std::sin(a), ob.z));
      };
      for (Obs& ob : obs) {
        const Eigen::Vector2d tn(-ob.n.y(), ob.n.x());
        double a = ob.thc;
        for (int k = 0; k < 4; ++k) {
          const auto p = P(ob, a), q = P(ob, a + 1e-6);
          if (!p || !q) break;
          const double f = tn.dot(*p - ob.e_px), df = tn.dot(*q - *p) / 1e-6;
          if (!(std::abs(df) > 1e-9)) break;
          const double st = std::clamp(-f / df, -0.15, 0.15);
          a += st;
          if (std::abs(st) < 1e-9) break;
        }
        // Not further than 0.5 rad from the searched angle (a wrong branch).
        ob.thc = std::abs(std::remainder(a - ob.th, 2 * M_PI)) < 0.5 ? a : ob.th;
      }
    };
    auto residuals = [&](const Vec6& dd, double sc, Eigen::VectorXd& out) {
      const Eigen::Isometry3d T = apply(tags.T_cam_body, dd) * T_mtag_mir;
      for (int i = 0; i < N; ++i) {
        const Eigen::Vector3d q((1 + sc) * radius_m * std::cos(obs[i].thc),
                                (1 + sc) * radius_m * std::sin(obs[i].thc), obs[i].z);
        const auto u = model.project(T * q);
        out[i] = u ? obs[i].n.dot(*u - obs[i].e_px) : 1e3;
      }
    };
    for (int pass = 0; pass < 2; ++pass) {
      for (int it = 0; it < o.iterations; ++it) {
        correspond(d, scale);
        residuals(d, scale, r);
        for (int j = 0; j < np; ++j) {
          Vec6 dj = d;
          double sj = scale;
          const double h = j < 3 ? 1e-6 : (j < 6 ? 1e-7 : 1e-6);
          if (j < 6) dj[j] += h; else sj += h;
          Eigen::VectorXd rj(N);
          residuals(dj, sj, rj);
          J.col(j) = (rj - r) / h;
        }
        for (int i = 0; i < N; ++i) {
          const double a = std::abs(r[i]);
          // Huber, and nothing beyond 3 thresholds (a wrong edge).
          w[i] = a <= o.huber_px ? 1.0 : (a <= 3 * o.huber_px ? o.huber_px / a : 0.0);
        }
        const Eigen::MatrixXd Jp = J.leftCols(np);
        const Eigen::MatrixXd WJ = w.asDiagonal() * Jp;
        Eigen::MatrixXd Hf = Eigen::MatrixXd::Zero(np, np);
        Hf.topLeftCorner<6, 6>() = H_p;
        Hf += (Jp.transpose() * WJ) / lambda;
        Eigen::VectorXd g = Eigen::VectorXd::Zero(np);
        g.head<6>() = H_p * d;
        g += (WJ.transpose() * r) / lambda;
        Eigen::MatrixXd Hs = Hf;
        Eigen::VectorXd gs = g;
        if (o.keep_depth) {
          // Penalty on the centre's displacement along its line of sight.
          const double K = 1e6 * std::max(1.0, H_t.bottomRightCorner<3, 3>().trace());
          Hs.topLeftCorner<6, 6>() += K * a_ray * a_ray.transpose();
          gs.head<6>() += K * a_ray * a_ray.dot(d);
        }
        const Eigen::VectorXd st = Hs.ldlt().solve(-gs);
        d += st.head<6>();
        if (np == 7) scale += st[6];
        // The pose's covariance: the 6x6 marginal of the joint fit's.
        const Eigen::MatrixXd Cf = Hf.inverse();
        H = Mat6(Cf.topLeftCorner<6, 6>()).inverse();
        if (st.head<3>().norm() < 1e-8 && st.segment<3>(3).norm() < 1e-8) break;
      }
      // The rim's own noise from its weighted residuals (5 dof it constrains).
      correspond(d, scale);
      residuals(d, scale, r);
      double s = 0, sw = 0;
      for (int i = 0; i < N; ++i) {
        s += w[i] * r[i] * r[i];
        sw += w[i];
      }
      const double rim_px2 = s / std::max(1.0, sw - (o.free_scale ? 6.0 : 5.0));
      res.rms_px = std::sqrt(s / std::max(1e-9, sw));
      // The rim's points are not independent (one blur, one silhouette
      // model): their information counts as at most rim_effective_points.
      const double corr = std::max(1.0, sw / o.rim_effective_points);
      const double next = std::max(1.0, rim_px2 / sc2) * corr;
      res.noise_px2 = next * sc2;
      if (pass == 0 && std::abs(next - lambda) > 1e-3 * lambda) {
        lambda = next;
        continue;
      }
      break;
    }
  }
  for (int i = 0; i < res.points; ++i) res.edges[i].weight = w[i];
  if (o.centre_only) {
    // The rim-only fit's disc centre in the image and its covariance, as one
    // 2-D measurement joined to the tag prior.
    const Eigen::Vector3d pc = T_mtag_mir.translation();
    auto centre = [&](const Vec6& dd) { return model.project(apply(tags.T_cam_body, dd) * pc); };
    auto jac = [&](const Vec6& dd, Eigen::Matrix<double, 2, 6>& Jc) {
      const auto c0 = centre(dd);
      if (!c0) return false;
      for (int j = 0; j < 6; ++j) {
        Vec6 dj = dd;
        const double h = j < 3 ? 1e-6 : 1e-7;
        dj[j] += h;
        const auto cj = centre(dj);
        if (!cj) return false;
        Jc.col(j) = (*cj - *c0) / h;
      }
      return true;
    };
    const Mat6 C_rim = H.inverse();
    const Vec6 d_rim = d;
    const auto c_rim = centre(d_rim);
    Eigen::Matrix<double, 2, 6> Jc;
    if (!c_rim || !jac(d_rim, Jc)) {
      res.why = "rim centre not projectable";
      res.edges.clear();
      return res;
    }
    const Eigen::Matrix2d Sc = Jc * C_rim * Jc.transpose();
    const Eigen::Matrix2d Ic = Sc.inverse();
    if (!Ic.allFinite()) {
      res.why = "rim centre covariance singular";
      res.edges.clear();
      return res;
    }
    d.setZero();
    for (int it = 0; it < o.iterations; ++it) {
      const auto c = centre(d);
      if (!c || !jac(d, Jc)) break;
      const Eigen::Vector2d rc = *c - *c_rim;
      H = H_t + Jc.transpose() * Ic * Jc;
      const Vec6 g = H_t * d + Jc.transpose() * Ic * rc;
      const Vec6 st = H.ldlt().solve(-g);
      d += st;
      if (st.norm() < 1e-9) break;
    }
  }
  res.correction_sigma = std::sqrt(std::max(0.0, d.dot(H_t * d) / sc2));
  if (!(res.correction_sigma <= o.max_correction_sigma) || !d.allFinite()) {
    res.why = "correction too far from the tag pose";
    return res;
  }
  if (o.max_rim_rms_px > 0 && !(res.rms_px <= o.max_rim_rms_px)) {
    res.why = "rim residual too large";
    return res;
  }
  Mat6 C = H.inverse();
  if (o.keep_depth) {
    // The centre's depth is the tags' (pinned): give it back the tags'
    // variance along their own correlation, C + beta u u^T with u = C_t a.
    const Vec6 u = C_t * a_ray;
    const double vt = a_ray.dot(u), vj = a_ray.dot(C * a_ray);
    if (vt > vj && std::abs(vt) > 0) C += ((vt - vj) / (vt * vt)) * (u * u.transpose());
  }
  res.refined = true;
  res.T_cam_body = apply(tags.T_cam_body, d);
  res.covariance_per_px2 = 0.5 * (C + C.transpose());
  // Per-tag covariance: the tags' part carried through the joint fit (A =
  // C H_t), plus the rim's at its own noise (in corner-noise units).
  const Mat6 A = C * H_t;
  const Mat6 rimH = C.inverse() - H_t;
  res.covariance_per_tag = A * tags.covariance_per_tag * A.transpose() + C * rimH * C * sc2;
  return res;
}

}  // namespace dentar::ar
