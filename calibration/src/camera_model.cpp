#include "dentar/calibration/camera_model.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <sstream>

#include "cell_place.h"
#include "intrinsics_detail.h"

namespace dentar::calibration {
namespace {

constexpr double kNoFold = 1e9;
constexpr double kMaxRadius = 10.0;  // normalised radius scanned (84 degrees off axis)

// Which of the 8 coefficients a model fits.
std::vector<int> free_coefficients(DistortionModel m) {
  switch (m) {
    case DistortionModel::kK1: return {0};
    case DistortionModel::kK1K2: return {0, 1};
    case DistortionModel::kRadTan5: return {0, 1, 2, 3, 4};
    case DistortionModel::kRational8: return {0, 1, 2, 3, 4, 5, 6, 7};
  }
  return {};
}

std::string fmt(double v, int prec) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(prec) << v;
  return os.str();
}

// g(r) = r f(r) and its derivative (central difference).
double radial_map(const Lens& l, double r) { return r * l.radial_factor(r); }
double radial_slope(const Lens& l, double r) {
  const double h = 1e-6;
  return (radial_map(l, r + h) - radial_map(l, std::max(0.0, r - h))) / (r + h - std::max(0.0, r - h));
}

// First radius where r f(r) stops increasing or f <= 0 (kNoFold when none up to kMaxRadius).
double fold_radius(const Lens& l) {
  const int n = 5000;
  for (int i = 1; i <= n; ++i) {
    const double r = kMaxRadius * i / n;
    if (radial_slope(l, r) <= 0 || l.radial_factor(r) <= 0) return r;
  }
  return kNoFold;
}

// Radial-only inverse on the monotonic branch: r with r f(r) = rd; false when the branch
// folds before reaching rd.
bool radial_inverse(const Lens& l, double rd, double& r_out) {
  if (rd <= 0) {
    r_out = 0;
    return true;
  }
  const double h = std::max(rd, 0.05) / 200;
  double r0 = 0, g0 = 0;
  for (double r = h; r <= kMaxRadius; r += h) {
    const double g = radial_map(l, r);
    if (!(g > g0) || l.radial_factor(r) <= 0) return false;  // folded before reaching rd
    if (g >= rd) {
      double a = r0, b = r;
      for (int k = 0; k < 60; ++k) {
        const double m = 0.5 * (a + b);
        (radial_map(l, m) < rd ? a : b) = m;
      }
      r_out = 0.5 * (a + b);
      return true;
    }
    r0 = r;
    g0 = g;
  }
  return false;
}

Eigen::Matrix2d distortion_jacobian(const Lens& l, const Eigen::Vector2d& xy) {
  const double h = 1e-7;
  Eigen::Matrix2d J;
  for (int k = 0; k < 2; ++k) {
    Eigen::Vector2d a = xy, b = xy;
    a[k] += h;
    b[k] -= h;
    J.col(k) = (l.project(a) - l.project(b)) / (2 * h);
  }
  return J;
}

// Projection as a function of the free parameters theta = fx fy cx cy d[free...].
Lens with_params(Lens l, const std::vector<int>& fr, const Eigen::VectorXd& th) {
  l.fx = th[0];
  l.fy = th[1];
  l.cx = th[2];
  l.cy = th[3];
  for (std::size_t i = 0; i < fr.size(); ++i) l.d[fr[i]] = th[4 + i];
  return l;
}

Eigen::VectorXd params_of(const Lens& l, const std::vector<int>& fr) {
  Eigen::VectorXd th(4 + fr.size());
  th << l.fx, l.fy, l.cx, l.cy, Eigen::VectorXd::Zero(fr.size());
  for (std::size_t i = 0; i < fr.size(); ++i) th[4 + i] = l.d[fr[i]];
  return th;
}

// d pixel / d theta at the ray xy (2 x P), central differences.
Eigen::MatrixXd projection_jacobian(const Lens& l, const std::vector<int>& fr,
                                    const Eigen::Vector2d& xy) {
  const Eigen::VectorXd th = params_of(l, fr);
  Eigen::MatrixXd J(2, th.size());
  for (int j = 0; j < th.size(); ++j) {
    const double h = 1e-6 * std::max(1.0, std::abs(th[j]));
    Eigen::VectorXd a = th, b = th;
    a[j] += h;
    b[j] -= h;
    J.col(j) = (with_params(l, fr, a).project(xy) - with_params(l, fr, b).project(xy)) / (2 * h);
  }
  return J;
}

// Covariance of theta with the board poses marginalised: sigma^2 (J^T J)^-1's intrinsic block,
// J over all points of the kept views and all parameters (theta, then 6 per view).
Eigen::MatrixXd intrinsics_covariance(const Lens& l, const std::vector<int>& fr,
                                      const std::vector<BoardView>& views,
                                      const std::vector<Eigen::Isometry3d>& T_cam_board) {
  const int ni = 4 + static_cast<int>(fr.size());
  const int P = ni + 6 * static_cast<int>(views.size());
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(P, P);
  double sse = 0;
  long n = 0;
  for (std::size_t v = 0; v < views.size(); ++v) {
    const Eigen::AngleAxisd aa(T_cam_board[v].linear());
    const Eigen::Vector3d w0 = aa.angle() * aa.axis(), t0 = T_cam_board[v].translation();
    auto project_pose = [&](const Lens& lens, const Eigen::Vector3d& w, const Eigen::Vector3d& t,
                            const Eigen::Vector3d& X) {
      Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
      if (w.norm() > 0) R = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix();
      const Eigen::Vector3d p = R * X + t;
      return lens.project(Eigen::Vector2d(p.x() / p.z(), p.y() / p.z()));
    };
    for (std::size_t j = 0; j < views[v].image_points.size(); ++j) {
      const Eigen::Vector3d& X = views[v].object_points[j];
      const Eigen::Vector2d r = project_pose(l, w0, t0, X) - views[v].image_points[j];
      sse += r.squaredNorm();
      ++n;
      Eigen::MatrixXd J(2, ni + 6);
      const Eigen::Vector3d pc = T_cam_board[v] * X;
      J.leftCols(ni) = projection_jacobian(l, fr, Eigen::Vector2d(pc.x() / pc.z(), pc.y() / pc.z()));
      for (int k = 0; k < 6; ++k) {
        const double h = 1e-7;
        Eigen::Vector3d wa = w0, wb = w0, ta = t0, tb = t0;
        if (k < 3) {
          wa[k] += h;
          wb[k] -= h;
        } else {
          ta[k - 3] += h;
          tb[k - 3] -= h;
        }
        J.col(ni + k) = (project_pose(l, wa, ta, X) - project_pose(l, wb, tb, X)) / (2 * h);
      }
      const Eigen::MatrixXd JtJ = J.transpose() * J;
      const int o = ni + 6 * static_cast<int>(v);
      H.topLeftCorner(ni, ni) += JtJ.topLeftCorner(ni, ni);
      H.block(0, o, ni, 6) += JtJ.topRightCorner(ni, 6);
      H.block(o, 0, 6, ni) += JtJ.bottomLeftCorner(6, ni);
      H.block(o, o, 6, 6) += JtJ.bottomRightCorner(6, 6);
    }
  }
  const double sigma2 = sse / std::max(1.0, 2.0 * n - P);
  Eigen::VectorXd s = H.diagonal().cwiseMax(1e-30).cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd Hs = s.asDiagonal() * H * s.asDiagonal();
  const Eigen::MatrixXd inv = Hs.ldlt().solve(Eigen::MatrixXd::Identity(P, P));
  const Eigen::MatrixXd cov = s.asDiagonal() * inv * s.asDiagonal() * sigma2;
  return cov.topLeftCorner(ni, ni);
}

// K-fold held-out reprojection RMS (px) of a model over the kept views.
bool heldout_rms(const std::vector<BoardView>& views, int width, int height, DistortionModel m,
                 int folds, double& rms, int& npts, std::vector<double>& view_mse,
                 std::string& error) {
  const int V = static_cast<int>(views.size());
  view_mse.assign(V, NAN);
  const int K = std::clamp(folds, 2, V);
  double sse = 0;
  npts = 0;
  for (int f = 0; f < K; ++f) {
    std::vector<int> train;
    for (int i = 0; i < V; ++i)
      if (i % K != f) train.push_back(i);
    const detail::CalibRun run = detail::run_calibration(views, train, width, height, m);
    if (!run.ok) {
      error = run.error;
      return false;
    }
    for (int i = f; i < V; i += K) {
      std::vector<cv::Point3d> obj;
      std::vector<cv::Point2d> img;
      for (std::size_t j = 0; j < views[i].image_points.size(); ++j) {
        const auto& q = views[i].object_points[j];
        obj.emplace_back(q.x(), q.y(), q.z());
        img.emplace_back(views[i].image_points[j].x(), views[i].image_points[j].y());
      }
      cv::Mat rvec, tvec;
      std::vector<cv::Point2d> proj;
      try {
        if (!cv::solvePnP(obj, img, run.K, run.D, rvec, tvec, false, cv::SOLVEPNP_IPPE)) continue;
        cv::solvePnP(obj, img, run.K, run.D, rvec, tvec, true, cv::SOLVEPNP_ITERATIVE);
        cv::projectPoints(obj, rvec, tvec, run.K, run.D, proj);
      } catch (const cv::Exception& e) {
        continue;  // this held-out view does not count
      }
      double view_sse = 0;
      for (std::size_t j = 0; j < proj.size(); ++j) {
        const double dx = proj[j].x - img[j].x, dy = proj[j].y - img[j].y;
        sse += dx * dx + dy * dy;
        view_sse += dx * dx + dy * dy;
        ++npts;
      }
      if (!proj.empty()) view_mse[i] = view_sse / proj.size();
    }
  }
  if (npts == 0) {
    error = "no held-out view could be solved";
    return false;
  }
  rms = std::sqrt(sse / npts);
  return true;
}

// Paired t statistic of a - b over the entries finite in both (0 with fewer than 3).
double paired_t(const std::vector<double>& a, const std::vector<double>& b) {
  std::vector<double> d;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i)
    if (std::isfinite(a[i]) && std::isfinite(b[i])) d.push_back(a[i] - b[i]);
  if (d.size() < 3) return 0;
  double mean = 0, var = 0;
  for (double x : d) mean += x / d.size();
  for (double x : d) var += (x - mean) * (x - mean) / (d.size() - 1);
  if (var <= 0) return mean > 0 ? std::numeric_limits<double>::infinity() : 0;
  return mean / std::sqrt(var / d.size());
}

}  // namespace

int free_coefficient_count(DistortionModel m) {
  return static_cast<int>(free_coefficients(m).size());
}

Lens Lens::from(const CameraIntrinsics& k) {
  Lens l;
  l.width = k.width;
  l.height = k.height;
  l.fx = k.fx;
  l.fy = k.fy;
  l.cx = k.cx;
  l.cy = k.cy;
  for (int i = 0; i < 5; ++i) l.d[i] = k.dist[i];
  return l;
}

Lens Lens::from(const IntrinsicsSummary& s) {
  Lens l = from(s.camera);
  for (std::size_t i = 0; i < s.dist.size() && i < 8; ++i) l.d[i] = s.dist[i];
  return l;
}

double Lens::radial_factor(double r) const {
  const double r2 = r * r;
  const double num = 1 + r2 * (d[0] + r2 * (d[1] + r2 * d[4]));
  const double den = 1 + r2 * (d[5] + r2 * (d[6] + r2 * d[7]));
  return num / den;
}

Eigen::Vector2d Lens::project(const Eigen::Vector2d& xy) const {
  const double x = xy.x(), y = xy.y(), r2 = x * x + y * y;
  const double f = radial_factor(std::sqrt(r2));
  const double xd = x * f + 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x);
  const double yd = y * f + d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y;
  return {fx * xd + cx, fy * yd + cy};
}

bool Lens::unproject(const Eigen::Vector2d& px, Eigen::Vector2d& xy) const {
  const Eigen::Vector2d xd((px.x() - cx) / fx, (px.y() - cy) / fy);
  double r = 0;
  if (!radial_inverse(*this, xd.norm(), r)) return false;
  xy = xd.norm() > 0 ? Eigen::Vector2d(xd * (r / xd.norm())) : Eigen::Vector2d(0, 0);
  for (int it = 0; it < 30; ++it) {
    const Eigen::Vector2d e = project(xy) - px;
    if (!e.allFinite()) return false;
    if (e.norm() < 1e-6) return distortion_jacobian(*this, xy).determinant() > 0;
    const Eigen::Matrix2d J = distortion_jacobian(*this, xy);
    if (!(std::abs(J.determinant()) > 1e-12)) return false;
    xy -= J.inverse() * e;
  }
  return false;
}

LensCheck check_lens(const Lens& l, double max_reversal_px) {
  LensCheck c;
  c.r_fold = fold_radius(l);
  const Eigen::Vector2d corners[4] = {{-0.5, -0.5},
                                      {l.width - 0.5, -0.5},
                                      {-0.5, l.height - 0.5},
                                      {l.width - 0.5, l.height - 0.5}};
  for (const auto& p : corners) {
    Eigen::Vector2d xy;
    if (!l.unproject(p, xy)) {
      // How far the monotonic branch reaches, to say how badly it folds.
      double gmax = 0;
      for (int i = 1; i <= 2000 && kMaxRadius * i / 2000 < c.r_fold; ++i)
        gmax = std::max(gmax, radial_map(l, kMaxRadius * i / 2000));
      std::ostringstream os;
      os << std::fixed << std::setprecision(1) << "its projection cannot be inverted at the image "
         << "corner (" << p.x() << ", " << p.y() << ") px: the radial map r*f(r) stops growing at "
         << "r = " << std::setprecision(3) << c.r_fold << " (radial factor "
         << l.radial_factor(c.r_fold) << "), so no ray reaches the corner and rays beyond fold back";
      c.reason = os.str();
      c.corner_factor = c.r_fold < kNoFold ? l.radial_factor(c.r_fold) : NAN;
      return c;
    }
    c.r_image = std::max(c.r_image, xy.norm());
  }
  c.corner_factor = l.radial_factor(c.r_image);
  std::ostringstream os;
  os << std::fixed << std::setprecision(3);
  if (c.r_fold <= c.r_image) {
    os << "its radial map r*f(r) stops increasing at r = " << c.r_fold << ", inside the image "
       << "(corner at r = " << c.r_image << "): points beyond fold back";
    c.reason = os.str();
    return c;
  }
  // Monotonic radial factor: the largest move against the overall trend over [0, r_image].
  const int n = 400;
  const double trend = c.corner_factor >= 1 ? 1 : -1;
  double extreme = 1, rev = 0, r_at = 0;
  for (int i = 1; i <= n; ++i) {
    const double r = c.r_image * i / n, f = l.radial_factor(r);
    if (trend * (extreme - f) > rev) {
      rev = trend * (extreme - f);
      r_at = r;
    }
    extreme = trend > 0 ? std::max(extreme, f) : std::min(extreme, f);
  }
  c.reversal_px = rev * c.r_image * l.fx;
  if (c.reversal_px > max_reversal_px) {
    os << "its radial factor is not monotonic over the image: it turns back by " << rev
       << " near r = " << r_at << " (" << std::setprecision(1) << c.reversal_px
       << " px at the corner), a shape no real lens of this kind has; it is "
       << std::setprecision(2) << c.corner_factor << " at the corner";
    c.reason = os.str();
    return c;
  }
  // Invertible at every pixel: 16 px grid and the border every 4 px.
  auto bad_at = [&](double u, double v) {
    Eigen::Vector2d xy;
    return !l.unproject({u, v}, xy);
  };
  for (double v = -0.5; v <= l.height - 0.5; v += 16)
    for (double u = -0.5; u <= l.width - 0.5; u += 16)
      if (bad_at(u, v)) {
        os << std::setprecision(0) << "its projection cannot be inverted at pixel (" << u << ", "
           << v << ")";
        c.reason = os.str();
        return c;
      }
  for (double t = 0; t <= 1; t += 4.0 / std::max(l.width, l.height))
    for (const Eigen::Vector2d& p :
         {Eigen::Vector2d(t * l.width - 0.5, -0.5), Eigen::Vector2d(t * l.width - 0.5, l.height - 0.5),
          Eigen::Vector2d(-0.5, t * l.height - 0.5), Eigen::Vector2d(l.width - 0.5, t * l.height - 0.5)})
      if (bad_at(p.x(), p.y())) {
        os << std::setprecision(0) << "its projection cannot be inverted at the border pixel ("
           << p.x() << ", " << p.y() << ")";
        c.reason = os.str();
        return c;
      }
  c.ok = true;
  return c;
}

namespace {
Eigen::Vector2d project_ray(const Lens& l, const Eigen::Vector3d& ray) {
  return l.project(Eigen::Vector2d(ray.x() / ray.z(), ray.y() / ray.z()));
}
// d pixel / d omega for the ray turned by exp(omega^) (2 x 3, central differences).
Eigen::Matrix<double, 2, 3> rotation_jacobian(const Lens& l, const Eigen::Vector3d& ray) {
  Eigen::Matrix<double, 2, 3> J;
  const double h = 1e-7;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d w = Eigen::Vector3d::Unit(k) * h;
    J.col(k) = (project_ray(l, ray + w.cross(ray)) - project_ray(l, ray - w.cross(ray))) / (2 * h);
  }
  return J;
}
}  // namespace

Eigen::Matrix3d align_rotation(const Lens& ref, const Lens& est,
                               const std::vector<Eigen::Vector2d>& fit_px) {
  std::vector<Eigen::Vector3d> rays;
  std::vector<Eigen::Vector2d> px;
  for (const auto& q : fit_px) {
    Eigen::Vector2d xy;
    if (ref.unproject(q, xy)) {
      rays.emplace_back(xy.x(), xy.y(), 1.0);
      px.push_back(q);
    }
  }
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  if (rays.size() < 3) return R;
  for (int it = 0; it < 5; ++it) {
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < rays.size(); ++i) {
      const Eigen::Vector3d r = R * rays[i];
      const Eigen::Vector2d e = project_ray(est, r) - px[i];
      if (!e.allFinite()) continue;
      const Eigen::Matrix<double, 2, 3> J = rotation_jacobian(est, r);
      H += J.transpose() * J;
      g += J.transpose() * e;
    }
    const Eigen::Vector3d w = -H.ldlt().solve(g);
    if (!w.allFinite()) break;
    if (w.norm() > 0) R = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix() * R;
    if (w.norm() < 1e-12) break;
  }
  return R;
}

double projection_error_px(const Lens& ref, const Lens& est, const Eigen::Matrix3d& R, double u,
                           double v) {
  Eigen::Vector2d xy;
  if (!ref.unproject({u, v}, xy)) return NAN;
  return (project_ray(est, R * Eigen::Vector3d(xy.x(), xy.y(), 1.0)) - Eigen::Vector2d(u, v)).norm();
}

std::string TrustMap::ascii(double max_error_px) const {
  std::ostringstream os;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const int i = r * cols + c;
      os << (extrapolated[i] ? '?' : bound_px[i] <= 0.3 ? '.' : bound_px[i] <= max_error_px ? ':' : 'x');
    }
    os << "\n";
  }
  return os.str();
}

bool TrustMap::trusted_at(double u, double v, int width, int height) const {
  if (cols <= 0 || rows <= 0) return false;
  const int c = std::clamp(static_cast<int>((u + 0.5) / width * cols), 0, cols - 1);
  const int r = std::clamp(static_cast<int>((v + 0.5) / height * rows), 0, rows - 1);
  return trusted[r * cols + c] != 0;
}

std::string ModelSelectionOptions::validate() const {
  if (std::string e = intrinsics.validate(); !e.empty()) return e;
  std::ostringstream os;
  if (folds < 2 || folds > 50) os << "folds = " << folds << " must be 2..50";
  else if (!(significance_t > 0)) os << "significance_t must be > 0";
  else if (!(as_good_ratio >= 1 && as_good_ratio < 2)) os << "as_good_ratio must be in [1, 2)";
  else if (!(as_good_px >= 0)) os << "as_good_px must be >= 0";
  else if (!(tangential_chi2 >= 0)) os << "tangential_chi2 must be >= 0 (0: off)";
  else if (!(max_error_px > 0)) os << "max_error_px must be > 0";
  else if (!(sigma_k >= 0)) os << "sigma_k must be >= 0";
  else if (!(extrapolation_margin >= 1)) os << "extrapolation_margin must be >= 1";
  return os.str();
}

ModelSelection select_camera_model(const std::vector<BoardView>& views, int width, int height,
                                   const ModelSelectionOptions& o) {
  ModelSelection sel;
  if (std::string e = o.validate(); !e.empty()) {
    sel.message = "invalid options: " + e;
    return sel;
  }
  // 1. Outlier rejection and the geometry gates with the usual 5-coefficient model.
  IntrinsicsOptions io = o.intrinsics;
  io.model = DistortionModel::kRadTan5;
  const IntrinsicsSummary base = calibrate_intrinsics(views, width, height, io);
  if (!base.ok) {
    sel.chosen = base;
    sel.message = base.message;
    return sel;
  }
  std::vector<BoardView> kept;
  for (int i : base.used_views) kept.push_back(views[i]);

  // 2. Candidates: fit on the kept views, held-out RMS, lens check.
  const DistortionModel order[] = {DistortionModel::kK1, DistortionModel::kK1K2,
                                   DistortionModel::kRadTan5, DistortionModel::kRational8};
  IntrinsicsOptions fo = o.intrinsics;
  fo.reject_outliers = false;
  fo.min_views = std::min(fo.min_views, static_cast<int>(kept.size()));
  for (DistortionModel m : order) {
    CandidateModel c;
    c.model = m;
    if (m == DistortionModel::kRational8 && o.force != m) {
      const CandidateModel& k1k2 = sel.candidates[1];
      const CandidateModel& rt5 = sel.candidates[2];
      const bool gain = k1k2.heldout_rms_px > 0 && rt5.heldout_rms_px > 0 && rt5.check.ok &&
                        paired_t(k1k2.heldout_view_mse, rt5.heldout_view_mse) >= o.significance_t;
      if (!gain || base.coverage.image_fraction < o.rational_min_coverage) {
        c.verdict = !gain ? "not fitted: radtan5 is not valid or not significantly better than k1k2 "
                            "on held-out views, so nothing asks for more terms"
                          : "not fitted: the boards cover too little of the image for 8 coefficients";
        sel.candidates.push_back(c);
        continue;
      }
    }
    fo.model = m;
    c.fit = calibrate_intrinsics(kept, width, height, fo);
    // Row indices of fit refer to `kept`; map them back to the caller's views.
    for (int& u : c.fit.used_views) u = base.used_views[u];
    c.fit.rejected = base.rejected;
    {
      std::vector<double> pv(views.size(), 0.0);
      for (std::size_t j = 0; j < base.used_views.size(); ++j)
        pv[base.used_views[j]] = c.fit.per_view_rms_px[j];
      c.fit.per_view_rms_px = pv;
    }
    if (c.fit.calibrations_run == 0 || c.fit.T_cam_board.empty()) {
      c.verdict = "not fitted: " + c.fit.message;
      sel.candidates.push_back(c);
      continue;
    }
    c.fitted = true;
    std::string err;
    if (!heldout_rms(kept, width, height, m, o.folds, c.heldout_rms_px, c.heldout_points,
                     c.heldout_view_mse, err)) {
      c.heldout_rms_px = -1;
      c.verdict = "no held-out figure: " + err;
    }
    c.check = check_lens(Lens::from(c.fit), o.max_reversal_px);
    if (!c.check.ok) c.verdict = "refused: " + c.check.reason;
    sel.candidates.push_back(c);
  }

  // 3. Choose: the simplest valid model not significantly worse than the best valid one on
  // held-out views. The tracker reads 5 coefficients, so rational8 is reported but not chosen
  // automatically: among the others, the comparison is with the best of them.
  int best_i = -1, best_usable_i = -1;
  for (std::size_t i = 0; i < sel.candidates.size(); ++i) {
    const auto& c = sel.candidates[i];
    if (!(c.fitted && c.check.ok && c.heldout_rms_px > 0)) continue;
    if (best_i < 0 || c.heldout_rms_px < sel.candidates[best_i].heldout_rms_px) best_i = static_cast<int>(i);
    if (c.model != DistortionModel::kRational8 &&
        (best_usable_i < 0 || c.heldout_rms_px < sel.candidates[best_usable_i].heldout_rms_px))
      best_usable_i = static_cast<int>(i);
  }
  const double best = best_i >= 0 ? sel.candidates[best_i].heldout_rms_px : INFINITY;
  for (auto& c : sel.candidates) {
    if (!(c.fitted && c.check.ok && c.heldout_rms_px > 0) || best_usable_i < 0) continue;
    const auto& ref = sel.candidates[c.model == DistortionModel::kRational8 ? best_i : best_usable_i];
    c.t_vs_best = paired_t(c.heldout_view_mse, ref.heldout_view_mse);
    c.as_good = &c == &ref || (c.t_vs_best < o.significance_t &&
                               c.heldout_rms_px <= ref.heldout_rms_px * o.as_good_ratio + o.as_good_px);
  }
  // Tangential terms the data determine: a model without them is not "as good" (the principal
  // point would absorb them; held-out reprojection cannot see it, ModelSelectionOptions).
  std::string tangential_note;
  {
    CandidateModel& rt5 = sel.candidates[2];
    if (rt5.fitted && rt5.check.ok && rt5.heldout_rms_px > 0 && rt5.fit.std_devs.size() >= 8 &&
        rt5.fit.dist.size() >= 4 && rt5.fit.std_devs[6] > 0 && rt5.fit.std_devs[7] > 0) {
      const double z1 = rt5.fit.dist[2] / rt5.fit.std_devs[6], z2 = rt5.fit.dist[3] / rt5.fit.std_devs[7];
      rt5.tangential_chi2 = z1 * z1 + z2 * z2;
      if (o.tangential_chi2 > 0 && rt5.tangential_chi2 > o.tangential_chi2 && rt5.as_good) {
        std::ostringstream os;
        os << std::fixed << std::setprecision(1) << "radtan5's tangential terms are significant (p1 p2 at "
           << rt5.tangential_chi2 << " chi-square, above " << o.tangential_chi2
           << "): without them the principal point shifts to absorb them and the camera frame turns, "
              "which held-out reprojection cannot see";
        for (std::size_t i = 0; i < 2; ++i) {
          CandidateModel& c = sel.candidates[i];
          if (c.fitted && c.check.ok && c.as_good) {
            c.as_good = false;
            c.verdict = "set aside: " + os.str();
            tangential_note = os.str();  // said in `why` only when it changed the choice
          }
        }
      }
    }
  }
  int chosen = -1;
  std::string forced_note;
  if (o.force) {
    for (std::size_t i = 0; i < sel.candidates.size(); ++i)
      if (sel.candidates[i].model == *o.force) {
        if (sel.candidates[i].fitted && sel.candidates[i].check.ok)
          chosen = static_cast<int>(i);
        else
          forced_note = std::string("the requested model ") + distortion_model_name(*o.force) +
                        " was refused (" + sel.candidates[i].verdict + "); falling back to the "
                        "automatic choice. ";
      }
  }
  if (chosen < 0)
    for (std::size_t i = 0; i < sel.candidates.size(); ++i) {
      const auto& c = sel.candidates[i];
      if (c.model != DistortionModel::kRational8 && c.as_good) {
        chosen = static_cast<int>(i);
        break;
      }
    }
  if (chosen < 0) {
    std::ostringstream os;
    os << "no distortion model holds over the whole image:";
    for (const auto& c : sel.candidates)
      os << " " << distortion_model_name(c.model) << " " << c.verdict << ";";
    os << " take photos with the board near the edges and corners of the image as well as in the "
          "middle, then calibrate again";
    sel.chosen = base;
    sel.message = os.str();
    return sel;
  }
  CandidateModel& ch = sel.candidates[chosen];
  sel.model = ch.model;
  sel.chosen = ch.fit;
  {
    std::ostringstream os;
    os << std::fixed << std::setprecision(3) << forced_note;
    if (o.force && *o.force == ch.model)
      os << "requested with --model; held-out RMS " << ch.heldout_rms_px << " px (best valid "
         << best << " px)";
    else if (chosen == best_usable_i)
      os << "the best valid model on held-out views (held-out RMS " << ch.heldout_rms_px
         << " px); every simpler model is worse there (significantly, or by more than "
         << std::setprecision(0) << (o.as_good_ratio - 1) * 100 << "%) or was refused";
    else
      os << "the simplest model not significantly worse on held-out views than the best valid "
         << "one (held-out RMS " << ch.heldout_rms_px << " px vs "
         << sel.candidates[best_usable_i].heldout_rms_px << " px for "
         << distortion_model_name(sel.candidates[best_usable_i].model) << "; paired t over the "
         << "views " << std::setprecision(1) << ch.t_vs_best << " < " << o.significance_t
         << " and within " << std::setprecision(0) << (o.as_good_ratio - 1) * 100 << "%)";
    if (!tangential_note.empty() && ch.model == DistortionModel::kRadTan5 && !(o.force && *o.force == ch.model))
      os << "; k1 and k1k2 set aside: " << tangential_note;
    std::vector<std::string> refused;
    for (const auto& c : sel.candidates)
      if (c.fitted && !c.check.ok) refused.push_back(distortion_model_name(c.model));
    if (!refused.empty()) {
      os << "; refused because they fold over or are not monotonic inside the image:";
      for (const auto& r : refused) os << " " << r;
    }
    sel.why = os.str();
  }
  for (auto& c : sel.candidates) {
    if (&c == &ch) {
      c.verdict = "chosen";
    } else if (c.fitted && c.check.ok && c.verdict.empty()) {
      std::ostringstream os;
      os << std::fixed << std::setprecision(3);
      if (c.model == DistortionModel::kRational8 && c.heldout_rms_px <= best)
        os << "best held-out RMS, but the tracker reads only k1 k2 p1 p2 k3";
      else if (c.as_good)
        os << "as good on held-out views, but more coefficients";
      else if (&c < &ch)
        os << "worse on held-out views (held-out RMS " << c.heldout_rms_px << " px, paired t "
           << std::setprecision(1) << c.t_vs_best << ")";
      else
        os << "not better than the chosen model on held-out views";
      c.verdict = os.str();
    }
  }
  if (ch.model != DistortionModel::kRational8 && sel.candidates[3].fitted &&
      sel.candidates[3].check.ok && sel.candidates[3].heldout_rms_px > 0 &&
      paired_t(ch.heldout_view_mse, sel.candidates[3].heldout_view_mse) >= o.significance_t)
    sel.warnings.push_back(
        "the rational model fits held-out views clearly better (" +
        fmt(sel.candidates[3].heldout_rms_px, 3) + " px vs " + fmt(ch.heldout_rms_px, 3) +
        " px) but the tracker reads only k1 k2 p1 p2 k3; this lens has strong distortion");

  // 4. Trust map on the coverage grid.
  const Lens lens = Lens::from(ch.fit);
  const std::vector<int> fr = free_coefficients(ch.model);
  const Eigen::MatrixXd cov = intrinsics_covariance(lens, fr, kept, ch.fit.T_cam_board);
  TrustMap& tm = sel.trust;
  // The boards' pixels (at most ~400, evenly taken): the region the alignment is fitted over.
  std::vector<Eigen::Vector2d> data_px;
  {
    std::size_t total = 0;
    for (const auto& v : kept) total += v.image_points.size();
    const std::size_t step = std::max<std::size_t>(1, total / 400);
    std::size_t k = 0;
    for (const auto& v : kept)
      for (const auto& p : v.image_points) {
        Eigen::Vector2d xy;
        if (lens.unproject(p, xy)) tm.r_data = std::max(tm.r_data, xy.norm());
        if (k++ % step == 0) data_px.push_back(p);
      }
  }
  std::vector<std::pair<Lens, Eigen::Matrix3d>> others;  // as-good candidates, aligned
  for (const auto& c : sel.candidates)
    if (&c != &ch && c.as_good) {
      const Lens ol = Lens::from(c.fit);
      others.emplace_back(ol, align_rotation(lens, ol, data_px));
    }
  // Rotation compensation of the uncertainty: a change d theta of the intrinsics moves the
  // boards' pixels by J d theta; the rotation w that best undoes it over them is
  // w = -A^-1 B d theta (A = sum Jw^T Jw, B = sum Jw^T J), so a pixel moves by
  // (J - Jw A^-1 B) d theta.
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::MatrixXd B = Eigen::MatrixXd::Zero(3, 4 + fr.size());
  for (const auto& q : data_px) {
    Eigen::Vector2d xy;
    if (!lens.unproject(q, xy)) continue;
    const Eigen::Matrix<double, 2, 3> Jw = rotation_jacobian(lens, Eigen::Vector3d(xy.x(), xy.y(), 1));
    A += Jw.transpose() * Jw;
    B += Jw.transpose() * projection_jacobian(lens, fr, xy);
  }
  const Eigen::MatrixXd AinvB = A.ldlt().solve(B);
  tm.max_error_px = o.max_error_px;
  tm.cols = o.intrinsics.coverage_cols;
  tm.rows = o.intrinsics.coverage_rows;
  const int nc = tm.cols * tm.rows;
  tm.sigma_px.assign(nc, 0);
  tm.spread_px.assign(nc, 0);
  tm.bound_px.assign(nc, 0);
  tm.extrapolated.assign(nc, 0);
  tm.trusted.assign(nc, 0);
  int trusted = 0, tooth = 0, tooth_trusted = 0;
  const auto& tr = o.intrinsics.tooth_region;
  for (int r = 0; r < tm.rows; ++r)
    for (int c = 0; c < tm.cols; ++c) {
      const int i = r * tm.cols + c;
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
          const double u = (c + 0.5 * a) * width / tm.cols - 0.5;
          const double v = (r + 0.5 * b) * height / tm.rows - 0.5;
          Eigen::Vector2d xy;
          if (!lens.unproject({u, v}, xy)) {
            tm.bound_px[i] = std::numeric_limits<double>::infinity();
            continue;
          }
          if (xy.norm() > o.extrapolation_margin * tm.r_data) tm.extrapolated[i] = 1;
          const Eigen::Vector3d ray(xy.x(), xy.y(), 1);
          const Eigen::MatrixXd J = projection_jacobian(lens, fr, xy) - rotation_jacobian(lens, ray) * AinvB;
          const Eigen::Matrix2d S = J * cov * J.transpose();
          const double sigma = std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(S).eigenvalues()[1]));
          double spread = 0;
          for (const auto& [ol, R] : others)
            spread = std::max(spread, (project_ray(ol, R * ray) - Eigen::Vector2d(u, v)).norm());
          tm.sigma_px[i] = std::max(tm.sigma_px[i], sigma);
          tm.spread_px[i] = std::max(tm.spread_px[i], spread);
          tm.bound_px[i] = std::max(tm.bound_px[i], o.sigma_k * sigma + spread);
        }
      tm.trusted[i] = !tm.extrapolated[i] && tm.bound_px[i] <= o.max_error_px;
      trusted += tm.trusted[i];
      const double x = (c + 0.5) / tm.cols, y = (r + 0.5) / tm.rows;
      if (x >= tr[0] && x <= tr[2] && y >= tr[1] && y <= tr[3]) {
        ++tooth;
        tooth_trusted += tm.trusted[i];
      }
    }
  tm.trusted_fraction = static_cast<double>(trusted) / nc;
  tm.tooth_trusted_fraction = tooth ? static_cast<double>(tooth_trusted) / tooth : 0;

  // 5. Warnings and the photos to add.
  std::vector<std::string> places;
  for (int r = 0; r < tm.rows; ++r)
    for (int c = 0; c < tm.cols; ++c)
      if (!tm.trusted[r * tm.cols + c]) {
        const std::string p = detail::cell_place(r, c, tm.rows, tm.cols);
        if (std::find(places.begin(), places.end(), p) == places.end()) places.push_back(p);
      }
  if (tooth_trusted < tooth) {
    sel.warnings.push_back("the region where the tooth is drawn is not trustworthy to " +
                           fmt(o.max_error_px, 1) + " px in " + std::to_string(tooth - tooth_trusted) +
                           " of its " + std::to_string(tooth) + " cells: add views with the "
                           "board in the middle of the image, at the tooth's working distance");
  }
  if (!places.empty()) {
    std::ostringstream os;
    os << "the model is trustworthy to " << fmt(o.max_error_px, 1) << " px over only "
       << fmt(tm.trusted_fraction * 100, 0) << "% of the image; not at:";
    for (std::size_t k = 0; k < places.size(); ++k) os << (k ? ", " : " ") << places[k];
    os << ". Tags seen there will be mis-measured. Add photos with the board reaching into ";
    os << (places.size() > 4 ? "the corners and edges of the image" : "those parts of the image")
       << " (fill the frame, tilted 15-45 degrees), then calibrate again";
    sel.warnings.push_back(os.str());
  }
  for (const auto& w : ch.fit.warnings)
    if (w.find("k1 k2 p1 p2 k3") == std::string::npos || ch.model == DistortionModel::kRational8)
      sel.warnings.push_back(w);
  sel.ok = true;
  sel.message = std::string("model ") + distortion_model_name(ch.model) + ", RMS " +
                fmt(ch.fit.rms_px, 3) + " px (held-out " + fmt(ch.heldout_rms_px, 3) + " px), " +
                std::to_string(base.used_views.size()) + " views used, " +
                std::to_string(base.rejected.size()) + " rejected; trustworthy to " +
                fmt(o.max_error_px, 1) + " px over " + fmt(tm.trusted_fraction * 100, 0) +
                "% of the image";
  return sel;
}

std::string ModelSelection::report() const {
  std::ostringstream os;
  os << std::fixed << std::setprecision(3);
  os << (ok ? "camera calibration OK: " : "camera calibration FAILED: ") << message << "\n";
  if (!ok && chosen.calibrations_run == 0) {
    for (const auto& r : chosen.rejected)
      os << "  rejected view " << r.index << " (" << r.name << "): " << r.reason << "\n";
    return os.str();
  }
  if (ok) {
    const auto& k = chosen.camera;
    os << "  why " << distortion_model_name(model) << ": " << why << "\n";
    os << "  fx fy = " << k.fx << " " << k.fy << " px, cx cy = " << k.cx << " " << k.cy << " px\n";
    if (chosen.std_devs.size() >= 4)
      os << "  std dev fx fy cx cy = " << chosen.std_devs[0] << " " << chosen.std_devs[1] << " "
         << chosen.std_devs[2] << " " << chosen.std_devs[3] << " px\n";
    os << "  distortion k1 k2 p1 p2 k3" << (chosen.dist.size() == 8 ? " k4 k5 k6" : "") << " =";
    os << std::setprecision(5);
    for (double d : chosen.dist) os << " " << d;
    os << std::setprecision(3) << "\n  RMS " << chosen.rms_px << " px over "
       << chosen.used_views.size() << " views\n";
    for (int v : chosen.used_views)
      os << "    view " << v << ": RMS " << chosen.per_view_rms_px[v] << " px\n";
  }
  for (const auto& r : chosen.rejected)
    os << "  rejected view " << r.index << " (" << r.name << "): " << r.reason << "\n";
  os << "  candidate models (held-out: K-fold, each view's pose solved with the other views' "
        "intrinsics):\n";
  for (const auto& c : candidates) {
    os << "    " << std::left << std::setw(9) << distortion_model_name(c.model) << std::right;
    if (c.fitted)
      os << " fit RMS " << c.fit.rms_px << " px, held-out "
         << (c.heldout_rms_px > 0 ? fmt(c.heldout_rms_px, 3) + " px" : std::string("n/a"))
         << ", radial factor at the corner "
         << (std::isfinite(c.check.corner_factor) ? fmt(c.check.corner_factor, 2) : std::string("n/a"))
         << ": ";
    else
      os << " ";
    os << c.verdict << "\n";
  }
  if (ok && trust.cols > 0 && chosen.coverage.cols == trust.cols &&
      chosen.coverage.rows == trust.rows) {
    os << "  coverage (board points)   trust (error bound: '.' <= 0.3 px, ':' <= "
       << std::setprecision(1) << trust.max_error_px << " px, 'x' more, '?' beyond the boards)\n";
    std::istringstream a(chosen.coverage.ascii()), b(trust.ascii(trust.max_error_px));
    for (std::string la, lb; std::getline(a, la) && std::getline(b, lb);)
      os << "    " << la << std::string(std::max<int>(2, 26 - static_cast<int>(la.size())), ' ')
         << lb << "\n";
    os << "  (" << std::setprecision(0) << chosen.coverage.image_fraction * 100
       << "% of the cells hold board points; trustworthy: " << trust.trusted_fraction * 100
       << "% of the image, " << trust.tooth_trusted_fraction * 100 << "% of the tooth region)\n";
  }
  for (const auto& w : warnings) os << "  WARNING: " << w << "\n";
  return os.str();
}

}  // namespace dentar::calibration
