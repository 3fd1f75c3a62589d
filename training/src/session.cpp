#include "dentar/training/session.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

namespace dentar::training {

double SessionTrack::removed_total(std::size_t i) const {
  double s = 0;
  for (double v : removed_mm3[i]) s += v;
  return s;
}

Result<SessionTrack> decode_session(const haptics::SessionLog& log, const std::string& name, int decimation) {
  if (decimation < 1) return Error{"decode_session: decimation must be >= 1"};
  auto setup = haptics::parse_session_header(log.header_json);
  if (!setup) return Error{name + ": session header: " + setup.error()};
  if (log.records.empty()) return Error{name + ": the session log holds no step record"};
  double voxel_mm = 0.08;
  {
    auto tj = nlohmann::json::parse(setup->tooth_json, nullptr, false);
    if (tj.is_object() && tj.contains("voxel_mm") && tj["voxel_mm"].is_number()) voxel_mm = tj["voxel_mm"].get<double>();
  }
  const double voxel_mm3 = voxel_mm * voxel_mm * voxel_mm;
  const Eigen::Isometry3d& T_tooth_dev = setup->engine.T_tooth_dev;
  const Eigen::Isometry3d& T_sty_tip = setup->engine.T_sty_tip;
  SessionTrack s;
  s.source = name;
  s.rate_hz = setup->engine.rate_hz / decimation;
  const std::size_t n = log.records.size() / static_cast<std::size_t>(decimation);
  if (n == 0) return Error{name + ": fewer records (" + std::to_string(log.records.size()) + ") than one frame"};
  for (std::size_t f = 0; f < n; ++f) {
    Eigen::Vector3d tip = Eigen::Vector3d::Zero(), axis = Eigen::Vector3d::Zero(), force = Eigen::Vector3d::Zero();
    double pedal = 0, t = 0;
    std::array<double, volume::kMaxMaterials> rem{};
    std::uint8_t flags = 0;
    for (int k = 0; k < decimation; ++k) {
      const haptics::StepRecord& r = log.records[f * static_cast<std::size_t>(decimation) + static_cast<std::size_t>(k)];
      Eigen::Isometry3d T_dev_sty = Eigen::Isometry3d::Identity();
      T_dev_sty.linear() = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(r.rotation);
      T_dev_sty.translation() = Eigen::Vector3d(r.position_m[0], r.position_m[1], r.position_m[2]);
      const Eigen::Isometry3d T_tooth_tip = T_tooth_dev * T_dev_sty * T_sty_tip;
      tip += T_tooth_tip.translation();
      axis += T_tooth_tip.linear().col(2);
      force -= T_tooth_dev.linear() * Eigen::Vector3d(r.force_dev_N[0], r.force_dev_N[1], r.force_dev_N[2]);
      pedal += r.pedal ? 1 : 0;
      t += r.time_s;
      for (int m = 0; m < 8; ++m) {
        const double full = volume::material_info(m).full_density;
        if (full > 0) rem[static_cast<std::size_t>(m)] += r.removed[m] / full * voxel_mm3;
      }
      flags |= r.flags;
    }
    const double inv = 1.0 / decimation;
    s.t_s.push_back(t * inv);
    s.tip_m.push_back(tip * inv);
    const double an = axis.norm();
    s.axis.push_back(an > 0 ? Eigen::Vector3d(axis / an) : Eigen::Vector3d::UnitZ());
    s.force_N.push_back(force * inv);
    s.pedal.push_back(pedal * inv);
    s.removed_mm3.push_back(rem);
    s.flags.push_back(flags);
  }
  return s;
}

const std::vector<std::string>& track_feature_names() {
  static const std::vector<std::string> n = {"tip_x_mm", "tip_y_mm",  "tip_z_mm",  "axis_x",
                                             "axis_y",   "axis_z",    "force_x_N", "force_y_N",
                                             "force_z_N", "speed_mm_per_s"};
  return n;
}

Sequence track_features(const SessionTrack& s) {
  Sequence x(static_cast<Eigen::Index>(s.size()), 10);
  for (std::size_t i = 0; i < s.size(); ++i) {
    const auto r = static_cast<Eigen::Index>(i);
    x.block<1, 3>(r, 0) = (s.tip_m[i] * 1e3).transpose();
    x.block<1, 3>(r, 3) = s.axis[i].transpose();
    x.block<1, 3>(r, 6) = s.force_N[i].transpose();
    const std::size_t j = i > 0 ? i - 1 : std::min<std::size_t>(1, s.size() - 1);
    x(r, 9) = s.size() > 1 ? (s.tip_m[i] - s.tip_m[j]).norm() * 1e3 * s.rate_hz : 0.0;
  }
  return x;
}

std::vector<Eigen::Vector3d> step_focus(const Exercise& ex, const RegionMasks* masks, const volume::VoxelVolume* start) {
  std::vector<Eigen::Vector3d> f;
  for (const auto& st : ex.steps) {
    if (st.focus_m) {
      f.push_back(*st.focus_m);
      continue;
    }
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    double n = 0;
    int r = -1;
    for (std::size_t i = 0; i < ex.regions.size(); ++i)
      if (ex.regions[i].name == st.region) r = static_cast<int>(i);
    if (masks && start && r >= 0) {
      const auto d = masks->dims;
      for (int k = 0; k < d.z(); ++k)
        for (int j = 0; j < d.y(); ++j)
          for (int i = 0; i < d.x(); ++i)
            if (masks->bits[masks->index(i, j, k)] >> r & 1u) {
              c += start->voxel_center(i, j, k);
              n += 1;
            }
    }
    f.push_back(n > 0 ? Eigen::Vector3d(c / n) : Eigen::Vector3d::Zero());
  }
  return f;
}

std::vector<int> segment_steps(const SessionTrack& s, const Exercise& ex, const RegionMasks* masks,
                               const volume::VoxelVolume* start, const SegmentOptions& o) {
  const std::vector<Eigen::Vector3d> focus = step_focus(ex, masks, start);
  const int S = static_cast<int>(focus.size());
  const std::size_t T = s.size();
  std::vector<int> out(T, 0);
  if (S == 0 || T == 0) return out;
  constexpr double inf = std::numeric_limits<double>::infinity();
  std::vector<double> cost(static_cast<std::size_t>(S)), nc(static_cast<std::size_t>(S));
  std::vector<int> back(T * static_cast<std::size_t>(S), 0);
  // Start: the first step is free, others cost a jump.
  for (int k = 0; k < S; ++k) cost[static_cast<std::size_t>(k)] = k == 0 ? 0 : o.jump_cost;
  // Emission per 10 ms of track, so the switch costs mean the same at any decimation.
  const double per_frame = s.rate_hz > 0 ? 100.0 / s.rate_hz : 1.0;
  const double inv_s2 = per_frame / (o.sigma_m * o.sigma_m);
  // The bur reaches its focus along its own axis: distance off the axis line counts fully,
  // distance still ahead along it counts 0.3 times.
  auto emission = [&](std::size_t t, int k) {
    const Eigen::Vector3d d = focus[static_cast<std::size_t>(k)] - s.tip_m[t];
    const double a = d.dot(s.axis[t]);
    const double w = a > 0 ? 0.3 : 1.0;
    return ((d - a * s.axis[t]).squaredNorm() + w * w * a * a) * inv_s2;
  };
  for (std::size_t t = 0; t < T; ++t) {
    const bool cutting = s.removed_total(t) > 0;
    for (int k = 0; k < S; ++k) {
      double best = inf;
      int arg = k;
      if (t == 0) {
        best = cost[static_cast<std::size_t>(k)];
      } else {
        for (int p = 0; p < S; ++p) {
          const double tr = p == k ? 0 : (k == p + 1 ? o.next_cost : o.jump_cost);
          const double c = cost[static_cast<std::size_t>(p)] + tr;
          if (c < best) { best = c; arg = p; }
        }
      }
      const double e = cutting ? emission(t, k) : 0.0;
      nc[static_cast<std::size_t>(k)] = best + e;
      back[t * static_cast<std::size_t>(S) + static_cast<std::size_t>(k)] = arg;
    }
    std::swap(cost, nc);
  }
  int k = static_cast<int>(std::min_element(cost.begin(), cost.end()) - cost.begin());
  for (std::size_t t = T; t-- > 0;) {
    out[t] = k;
    k = back[t * static_cast<std::size_t>(S) + static_cast<std::size_t>(k)];
  }
  // Short spans with no evidence for their step (see SegmentOptions). Only spans short
  // enough to merge are looked at frame by frame.
  const double dt = s.rate_hz > 0 ? 1.0 / s.rate_hz : 0.0;
  auto nearest = [&](std::size_t t) {
    int best = 0;
    double best_e = emission(t, 0);
    for (int q = 1; q < S; ++q)
      if (const double e = emission(t, q); e < best_e) best = q, best_e = e;
    return best;
  };
  for (std::size_t b = 0; b < T;) {
    std::size_t e = b;
    while (e < T && out[e] == out[b]) ++e;
    const bool whole = b == 0 && e == T;
    if (!whole && static_cast<double>(e - b) * dt < o.min_pass_span_s) {
      bool evidence = false;
      for (std::size_t t = b; t < e && !evidence; ++t) evidence = s.removed_total(t) > 0 && nearest(t) == out[b];
      if (!evidence) {
        const int into = b > 0 ? out[b - 1] : out[e];
        std::fill(out.begin() + static_cast<std::ptrdiff_t>(b), out.begin() + static_cast<std::ptrdiff_t>(e), into);
        // Look at the merged span again from its start (one span fewer each time: this ends).
        while (b > 0 && out[b - 1] == into) --b;
        continue;
      }
    }
    b = e;
  }
  return out;
}

namespace {
void add_force(ForceStats& f, const Eigen::Vector3d& v, Eigen::Vector3d& sq) {
  f.n += 1;
  f.mean += v;
  sq += v.cwiseProduct(v);
  f.mean_magnitude += v.norm();
  f.max_magnitude = std::max(f.max_magnitude, v.norm());
}
void finish_force(ForceStats& f, const Eigen::Vector3d& sq) {
  if (f.n <= 0) return;
  f.mean /= f.n;
  f.mean_magnitude /= f.n;
  f.sd = (sq / f.n - f.mean.cwiseProduct(f.mean)).cwiseMax(0.0).cwiseSqrt();
}
}  // namespace

ProcessMetrics process_metrics(const SessionTrack& s, const Exercise& ex, const std::vector<int>& steps) {
  ProcessMetrics p;
  p.excessive_force_N = ex.excessive_force_N;
  const double dt = s.rate_hz > 0 ? 1.0 / s.rate_hz : 0;
  if (s.size() == 0) return p;
  p.duration_s = s.t_s.back() - s.t_s.front() + dt;
  std::array<Eigen::Vector3d, volume::kMaxMaterials> msq;
  for (auto& v : msq) v.setZero();
  const std::size_t S = ex.steps.size();
  p.steps.resize(S);
  std::vector<Eigen::Vector3d> ssq(S, Eigen::Vector3d::Zero()), tsum(S, Eigen::Vector3d::Zero()),
      tsq(S, Eigen::Vector3d::Zero()), asum(S, Eigen::Vector3d::Zero());
  std::vector<double> tn(S, 0);
  for (std::size_t k = 0; k < S; ++k) {
    p.steps[k].name = ex.steps[k].name;
    p.steps[k].start_s = std::numeric_limits<double>::infinity();
    p.steps[k].end_s = -std::numeric_limits<double>::infinity();
  }
  for (std::size_t i = 0; i < s.size(); ++i) {
    const bool drilling = s.pedal[i] >= 0.5;
    const bool contact = s.flags[i] & haptics::kFlagContact;
    const double step_mm = i > 0 ? (s.tip_m[i] - s.tip_m[i - 1]).norm() * 1e3 : 0.0;
    p.path_mm += step_mm;
    if (drilling) p.drilling_s += dt;
    if (drilling && s.force_N[i].norm() > ex.excessive_force_N) p.excessive_force_s += dt;
    if (s.flags[i] & haptics::kFlagWatchdog) ++p.watchdog_frames;
    if (s.flags[i] & haptics::kFlagClamped) ++p.clamped_frames;
    for (int m = 1; m < volume::kMaxMaterials; ++m)
      if (s.removed_mm3[i][static_cast<std::size_t>(m)] > 0)
        add_force(p.force_by_material[static_cast<std::size_t>(m)], s.force_N[i], msq[static_cast<std::size_t>(m)]);
    if (i < steps.size() && steps[i] >= 0 && static_cast<std::size_t>(steps[i]) < S) {
      const auto k = static_cast<std::size_t>(steps[i]);
      StepMetrics& st = p.steps[k];
      st.start_s = std::min(st.start_s, s.t_s[i]);
      st.end_s = std::max(st.end_s, s.t_s[i] + dt);
      st.path_mm += step_mm;
      st.removed_mm3 += s.removed_total(i);
      if (drilling) st.drilling_s += dt;
      if (drilling && contact) {
        add_force(st.force, s.force_N[i], ssq[k]);
        tsum[k] += s.tip_m[i] * 1e3;
        tsq[k] += (s.tip_m[i] * 1e3).cwiseProduct(s.tip_m[i] * 1e3);
        asum[k] += s.axis[i];
        tn[k] += 1;
      }
    }
  }
  for (int m = 0; m < volume::kMaxMaterials; ++m)
    finish_force(p.force_by_material[static_cast<std::size_t>(m)], msq[static_cast<std::size_t>(m)]);
  for (std::size_t k = 0; k < S; ++k) {
    StepMetrics& st = p.steps[k];
    finish_force(st.force, ssq[k]);
    if (!std::isfinite(st.start_s)) st.start_s = st.end_s = 0;
    if (tn[k] > 0) {
      st.tip_mean_mm = tsum[k] / tn[k];
      st.tip_sd_mm = (tsq[k] / tn[k] - st.tip_mean_mm.cwiseProduct(st.tip_mean_mm)).cwiseMax(0.0).cwiseSqrt();
      st.axis_mean = asum[k].normalized();
    }
  }
  return p;
}

}  // namespace dentar::training
