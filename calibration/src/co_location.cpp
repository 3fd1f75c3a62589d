#include "dentar/calibration/co_location.h"

#include <cmath>

namespace dentar::calibration {

Eigen::Isometry3d random_perturbation(double sigma_rad, double sigma_m, std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  const Eigen::Vector3d w(n(rng) * sigma_rad, n(rng) * sigma_rad, n(rng) * sigma_rad);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (w.norm() > 0) T.linear() = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(n(rng), n(rng), n(rng)) * sigma_m;
  return T;
}

StationCalibration simulated_truth(const StationCalibration& nominal, std::uint64_t seed) {
  std::mt19937_64 rng(seed * 7919 + 17);
  std::normal_distribution<double> n(0.0, 1.0);
  StationCalibration t = nominal;
  t.camera.fx += 4 * n(rng);
  t.camera.fy = t.camera.fx * (1 + 0.002 * n(rng));
  t.camera.cx += 3 * n(rng);
  t.camera.cy += 3 * n(rng);
  t.camera.dist[0] += 0.01 * n(rng);
  t.T_man_dev = t.T_man_dev * random_perturbation(0.035, 3e-3, rng);
  t.T_sty_tip.translation() += Eigen::Vector3d(0.3e-3 * n(rng), 0.3e-3 * n(rng), 0.5e-3 * n(rng));
  t.T_man_tooth = t.T_man_tooth * random_perturbation(0.035, 0.8e-3, rng);
  t.T_mtag_mir = t.T_mtag_mir * random_perturbation(0.05, 0.5e-3, rng);
  t.mirror_radius_m += 0.3e-3 * n(rng);
  return t;
}

Eigen::Vector3d simulated_pivot_divot_dev() { return Eigen::Vector3d(0.04, 0.03, -0.05); }

namespace {
// A stylus orientation: the stylus z axis tilted by `tilt` toward azimuth `az` from the
// device's -y... any fixed reference works; spin about its own axis.
Eigen::Matrix3d stylus_rotation(double tilt, double az, double spin) {
  const Eigen::Vector3d axis(std::cos(az), std::sin(az), 0);
  // Reference: stylus pointing down and toward the mannequin (rotation about x by 120 deg).
  const Eigen::Matrix3d ref = Eigen::AngleAxisd(2.1, Eigen::Vector3d::UnitX()).toRotationMatrix();
  return Eigen::AngleAxisd(tilt, ref * axis).toRotationMatrix() * ref *
         Eigen::AngleAxisd(spin, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}
}  // namespace

std::vector<Eigen::Isometry3d> simulate_pivot_poses(const StationCalibration& truth,
                                                    const Eigen::Vector3d& divot, int count,
                                                    double max_tilt_rad, const StylusNoise& noise,
                                                    std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<Eigen::Isometry3d> out;
  const Eigen::Vector3d p_tip = truth.T_sty_tip.translation();
  for (int i = 0; i < count; ++i) {
    // Uniform-ish over the cone: sqrt for area, azimuth spread over all directions.
    const double tilt = max_tilt_rad * std::sqrt(u(rng));
    const double az = 2 * M_PI * (i + u(rng)) / std::max(count, 1);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = stylus_rotation(tilt, az, 0.6 * (u(rng) - 0.5));
    const Eigen::Vector3d tip = divot + noise.tip_sigma_m * Eigen::Vector3d(n(rng), n(rng), n(rng));
    T.translation() = tip - T.linear() * p_tip;
    out.push_back(T);
  }
  return out;
}

std::vector<Eigen::Isometry3d> simulate_touches(const StationCalibration& truth,
                                                const std::vector<Eigen::Vector3d>& points_dev,
                                                const StylusNoise& noise, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> n(0.0, 1.0);
  const double s = noise.fle_m / std::sqrt(3.0);  // per axis, so the RMS 3-D length is fle_m
  std::vector<Eigen::Isometry3d> out;
  for (const auto& p : points_dev) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = stylus_rotation(0.5 * u(rng), 2 * M_PI * u(rng), 0.6 * (u(rng) - 0.5));
    T.translation() = p + s * Eigen::Vector3d(n(rng), n(rng), n(rng)) -
                      T.linear() * truth.T_sty_tip.translation();
    out.push_back(T);
  }
  return out;
}

Eigen::Isometry3d simulated_mirror_clamp_man() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 0.3, 0).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.06, -0.02, 0.09);
  return T;
}

Eigen::Vector3d chain_tip_cam(const Eigen::Isometry3d& T_cam_man, const StationCalibration& cal,
                              const Eigen::Isometry3d& T_dev_sty) {
  return (T_cam_man * cal.T_man_dev * T_dev_sty * cal.T_sty_tip).translation();
}

}  // namespace dentar::calibration
