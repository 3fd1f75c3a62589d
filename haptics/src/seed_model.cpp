// The "seed" force model: the 2012 dissertation's voxel-sample model,
// reproduced as written, with its open cases closed as documented below.
//
//   immersed sample: its nearest voxel (centre rounding, as volume::Cutter)
//                    has a non-air material and density > 0
//   f_i            = target_i - p_i   (raw vector, see below)
//   f_coll         = (density_scale * mean density + c1 * N) * sum f_i / |sum f_i|
//   f_raw          = f_coll - c2 v   (only while N > 0)
//   f_smooth       = H(f_raw, f_hist), f_hist = weighted mean of the last K
//                    rendered forces (weights 1.3 newest .. 1.0 oldest)
//
// Targets: sphere -> its centre; cylinder, capsule, cone -> body samples
// toward their projection on the axis, tip samples toward the tip/body point.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <vector>

#include "contact.h"

namespace dentar::haptics {

std::string SeedParams::validate() const {
  std::ostringstream os;
  if (!std::isfinite(density_scale_N) || density_scale_N < 0)
    os << "seed.density_scale_N = " << density_scale_N << " must be finite and >= 0";
  else if (!std::isfinite(c1_N) || c1_N < 0)
    os << "seed.c1_N = " << c1_N << " must be finite and >= 0";
  else if (!std::isfinite(c2_N_s_per_m) || c2_N_s_per_m < 0)
    os << "seed.c2_N_s_per_m = " << c2_N_s_per_m << " must be finite and >= 0";
  else if (history < 1 || history > 10000)
    os << "seed.history = " << history << " must be in [1, 10000]";
  return os.str();
}

namespace seed {

double history_weight(int age, int K) noexcept {
  if (K <= 1) return 1.3;
  return 1.3 - 0.3 * static_cast<double>(age) / static_cast<double>(K - 1);
}

Eigen::Vector3d blend(const Eigen::Vector3d& f_raw, const Eigen::Vector3d& f_hist) noexcept {
  // Below this a magnitude has no usable direction; the harmonic mean tends
  // to 0 as either magnitude does, so returning zero keeps H continuous.
  constexpr double kTinyN = 1e-12;
  const double a = f_raw.norm(), b = f_hist.norm();
  if (!(a > kTinyN) || !(b > kTinyN)) return Eigen::Vector3d::Zero();
  const double hm = 2.0 * a * b / (a + b);
  const Eigen::Vector3d mean_dir = 0.5 * (f_raw / a + f_hist / b);
  const double m = mean_dir.norm();
  // Opposite directions: the average direction is undefined; the current
  // measurement wins (it is what the bur feels now).
  if (m < 1e-9) return hm * (f_raw / a);
  return hm * (mean_dir / m);
}

}  // namespace seed

namespace detail {
namespace {

class SeedModel final : public ForceModel {
 public:
  SeedModel(const SeedParams& p, std::size_t max_samples)
      : p_(p), max_samples_(max_samples), ring_(static_cast<std::size_t>(p.history)) {}

  std::string_view name() const override { return "seed"; }

  void reset() noexcept override { clear_history(); }

  void set_rendered_force(const Eigen::Vector3d& f) noexcept override {
    if (count_ > 0 && f.allFinite()) ring_[newest()] = f;
  }

  ForceOutput compute(const ForceInput& in) noexcept override {
    ForceOutput out;
    out.T_tooth_tip_display = in.T_tooth_tip;
    out.T_tooth_tip_cut = in.T_tooth_tip;
    if (!in.volume || !in.bur || in.bur->size() == 0 || in.bur->size() > max_samples_ ||
        in.bur->region.size() != in.bur->size() || !in.T_tooth_tip.matrix().allFinite() ||
        !in.velocity_m_per_s.allFinite()) {
      clear_history();
      return out;
    }
    const volume::VoxelVolume& vol = *in.volume;
    const volume::BurSamples& bur = *in.bur;
    const bool sphere = bur.params.shape == volume::BurShape::kSphere;
    const VoxelMap map = VoxelMap::make(vol.geometry(), in.T_tooth_tip);
    const Eigen::Vector3f tbp = bur.tip_body_point_m;

    // Sum of f_i in the tip frame (rotated once at the end). f_i is the raw
    // vector target - p, not a unit vector: a sample on the axis or at the
    // centre then adds ~0 instead of a unit vector whose direction flips as
    // it crosses, so the sum changes continuously as samples enter the
    // solid. The sum is N * (target centroid - sample centroid): it points
    // from the immersed part back toward the bur's core.
    double sx = 0, sy = 0, sz = 0;
    std::uint64_t density_sum = 0;
    std::uint32_t n = 0;
    const std::size_t count = bur.size();
    for (std::size_t s = 0; s < count; ++s) {
      const Eigen::Vector3f& p = bur.points_m[s];
      std::uint8_t dens, mat;
      if (!nearest_voxel(vol, map(p), dens, mat) || mat == 0 || dens == 0) continue;
      ++n;
      density_sum += dens;
      if (!sphere && bur.region[s] == volume::BurRegion::kBody) {
        sx -= p.x();  // toward (0, 0, p.z): the projection on the axis
        sy -= p.y();
      } else {
        sx += tbp.x() - p.x();
        sy += tbp.y() - p.y();
        sz += tbp.z() - p.z();
      }
    }

    if (n == 0) {
      // Out of contact: zero force, no damping, and the history is cleared
      // so the next contact starts fresh (see "first step after contact").
      clear_history();
      return out;
    }
    out.contacts = n;
    out.in_contact = true;
    out.mean_density = static_cast<double>(density_sum) / n;
    const double r = bur.params.radius_m;
    out.penetration_m = n * bur.sample_volume_m3 / (std::numbers::pi * r * r);

    const Eigen::Vector3d f_hist = history_mean();
    const double hist_norm = f_hist.norm();
    const bool have_hist = count_ > 0 && hist_norm > kTinyN;

    // Direction of f_coll. When the immersed samples surround the core
    // symmetrically, sum f_i ~ 0 and its direction is noise. Below a
    // centroid offset of kSymmetric * r we blend toward the direction of the
    // force history (keeps pushing the way it pushed, continuous in time);
    // with no history the collision force fades to zero at exact symmetry.
    // Never NaN, never a spike above the normal magnitude.
    const Eigen::Vector3d sum_tip(sx, sy, sz);
    const double offset_m = sum_tip.norm() / n;  // |target centroid - sample centroid|
    Eigen::Vector3d dir = Eigen::Vector3d::Zero();
    if (offset_m >= kSymmetric * r) {
      dir = in.T_tooth_tip.linear() * (sum_tip / sum_tip.norm());
    } else {
      const double w = offset_m / (kSymmetric * r);  // in [0, 1)
      dir = in.T_tooth_tip.linear() * (sum_tip / (n * kSymmetric * r));  // length w
      if (have_hist) dir += (1.0 - w) * (f_hist / hist_norm);
      const double len = dir.norm();
      if (len > 1.0) dir /= len;
    }
    const double magnitude = p_.density_scale_N * out.mean_density + p_.c1_N * n;
    const Eigen::Vector3d f_raw = magnitude * dir - p_.c2_N_s_per_m * in.velocity_m_per_s;

    // First step after contact (empty history) or a history whose weighted
    // mean cancelled to ~0: H has nothing to average with, and the harmonic
    // mean with 0 would pin the force at 0 for the whole contact. Render
    // f_raw as is; this is the dissertation's contact-onset step.
    const Eigen::Vector3d f = have_hist ? seed::blend(f_raw, f_hist) : f_raw;
    push(f);
    out.force_N = f;
    return out;
  }

 private:
  static constexpr double kTinyN = 1e-12;
  static constexpr double kSymmetric = 0.02;  // fraction of the bur radius

  void clear_history() noexcept {
    count_ = 0;
    head_ = 0;
  }
  std::size_t newest() const { return (head_ + ring_.size() - 1) % ring_.size(); }
  void push(const Eigen::Vector3d& f) noexcept {
    ring_[head_] = f;
    head_ = (head_ + 1) % ring_.size();
    count_ = std::min(count_ + 1, ring_.size());
  }
  // Weights by age, so a force keeps its weight's meaning while the history
  // fills: age a gets history_weight(a, K) whatever the count.
  Eigen::Vector3d history_mean() const noexcept {
    if (count_ == 0) return Eigen::Vector3d::Zero();
    Eigen::Vector3d acc = Eigen::Vector3d::Zero();
    double wsum = 0;
    const int K = static_cast<int>(ring_.size());
    std::size_t idx = newest();
    for (std::size_t a = 0; a < count_; ++a) {
      const double w = seed::history_weight(static_cast<int>(a), K);
      acc += w * ring_[idx];
      wsum += w;
      idx = idx == 0 ? ring_.size() - 1 : idx - 1;
    }
    return acc / wsum;
  }

  SeedParams p_;
  std::size_t max_samples_;
  std::vector<Eigen::Vector3d> ring_;  // K rendered forces, preallocated
  std::size_t head_ = 0;               // next write position
  std::size_t count_ = 0;              // valid entries
};

}  // namespace

std::unique_ptr<ForceModel> make_seed_model(const SeedParams& p, std::size_t max_samples) {
  return std::make_unique<SeedModel>(p, max_samples);
}

}  // namespace detail
}  // namespace dentar::haptics
