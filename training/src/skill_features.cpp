#include "dentar/training/skill_features.h"

#include <algorithm>
#include <cmath>
#include <map>

namespace dentar::training {
namespace {

struct Tool {
  std::string name;
  int pos = -1, axis = -1, force = -1;
};

// Groups columns by tool: "<tool>.pos_x_mm" or the unnamed tool's
// "pos_x_mm" / "tip_x_mm" (position), "axis_x", "force_x_N".
std::vector<Tool> tools_of(const std::vector<std::string>& cols, int& pedal, int& speed) {
  std::vector<Tool> tools;
  pedal = speed = -1;
  auto tool = [&](const std::string& n) -> Tool& {
    for (auto& t : tools)
      if (t.name == n) return t;
    tools.push_back({n});
    return tools.back();
  };
  for (std::size_t i = 0; i < cols.size(); ++i) {
    const std::string& c = cols[i];
    const auto dot = c.rfind('.');
    const std::string pre = dot == std::string::npos ? "" : c.substr(0, dot);
    const std::string base = dot == std::string::npos ? c : c.substr(dot + 1);
    const int k = static_cast<int>(i);
    if (base == "pedal") pedal = k;
    else if (base == "speed_mm_per_s") speed = k;
    else if ((base == "pos_x_mm" || base == "tip_x_mm") && i + 2 < cols.size()) tool(pre).pos = k;
    else if (base == "axis_x" && i + 2 < cols.size()) tool(pre).axis = k;
    else if (base == "force_x_N" && i + 2 < cols.size()) tool(pre).force = k;
  }
  tools.erase(std::remove_if(tools.begin(), tools.end(), [](const Tool& t) { return t.pos < 0; }), tools.end());
  // The primary tool first: the one with force, else the first.
  std::stable_partition(tools.begin(), tools.end(), [](const Tool& t) { return t.force >= 0; });
  return tools;
}

// Centred moving average over w rows (w odd), per column of a T x 3 block.
Eigen::MatrixX3d smooth(const Eigen::MatrixX3d& p, int w) {
  const Eigen::Index T = p.rows();
  Eigen::MatrixX3d out(T, 3);
  Eigen::MatrixX3d cs(T + 1, 3);
  cs.row(0).setZero();
  for (Eigen::Index i = 0; i < T; ++i) cs.row(i + 1) = cs.row(i) + p.row(i);
  const Eigen::Index h = w / 2;
  for (Eigen::Index i = 0; i < T; ++i) {
    const Eigen::Index a = std::max<Eigen::Index>(0, i - h), b = std::min<Eigen::Index>(T, i + h + 1);
    out.row(i) = (cs.row(b) - cs.row(a)) / static_cast<double>(b - a);
  }
  return out;
}

// Runs of true of at least `min_len` rows: [begin, end).
std::vector<std::pair<Eigen::Index, Eigen::Index>> runs(const std::vector<bool>& m, Eigen::Index min_len) {
  std::vector<std::pair<Eigen::Index, Eigen::Index>> r;
  const auto T = static_cast<Eigen::Index>(m.size());
  for (Eigen::Index i = 0; i < T;) {
    if (!m[static_cast<std::size_t>(i)]) {
      ++i;
      continue;
    }
    Eigen::Index j = i;
    while (j < T && m[static_cast<std::size_t>(j)]) ++j;
    if (j - i >= min_len) r.emplace_back(i, j);
    i = j;
  }
  return r;
}

double path_length(const Eigen::MatrixX3d& p, Eigen::Index a, Eigen::Index b) {
  double s = 0;
  for (Eigen::Index i = a + 1; i < b; ++i) s += (p.row(i) - p.row(i - 1)).norm();
  return s;
}

const char* kSkillNames[] = {"tremor_mm",        "force_cv",      "axis_spread_deg", "pauses_per_episode",
                             "transit_efficiency", "log_work_path_mm", "log_jerk"};

}  // namespace

std::vector<std::string> summary_feature_names(SummarySet set, const std::vector<std::string>& columns) {
  if (set == SummarySet::kTime) return {"duration_s"};
  if (set == SummarySet::kTimePath) return {"duration_s", "path_mm"};
  int pedal, speed;
  const auto tools = tools_of(columns, pedal, speed);
  std::vector<std::string> n(std::begin(kSkillNames), std::end(kSkillNames));
  for (std::size_t i = 1; i < tools.size(); ++i) {
    const std::string p = tools[i].name.empty() ? "tool" + std::to_string(i) : tools[i].name;
    n.push_back(p + ".tremor_mm");
    n.push_back(p + ".drift_mm");
  }
  return n;
}

Result<Eigen::VectorXd> summary_features(SummarySet set, const Sequence& x, const std::vector<std::string>& columns,
                                         double rate_hz) {
  if (!(rate_hz > 0)) return Error{"summary features: the sampling rate must be > 0"};
  if (static_cast<std::size_t>(x.cols()) != columns.size())
    return Error{"summary features: " + std::to_string(x.cols()) + " columns against " + std::to_string(columns.size()) + " names"};
  int pedal, speed;
  const auto tools = tools_of(columns, pedal, speed);
  if (tools.empty()) return Error{"summary features: no position columns (pos_x_mm, tip_x_mm or <tool>.pos_x_mm)"};
  const Eigen::Index T = x.rows();
  if (T < 4) return Error{"summary features: fewer than 4 frames"};
  const double dt = 1.0 / rate_hz;
  const Tool& p = tools[0];
  const Eigen::MatrixX3d pos = x.middleCols(p.pos, 3);
  const double duration = static_cast<double>(T) * dt;
  if (set == SummarySet::kTime) return Eigen::VectorXd(Eigen::VectorXd::Constant(1, duration));
  const double raw_path = path_length(pos, 0, T);
  if (set == SummarySet::kTimePath) return Eigen::VectorXd(Eigen::Vector2d(duration, raw_path));

  const int w = std::max(3, static_cast<int>(std::lround(0.25 * rate_hz)) | 1);  // 0.25 s, odd
  const Eigen::MatrixX3d sm = smooth(pos, w);
  // Working frames: pressing (force > 0.1 N), else the pedal down, else all.
  std::vector<bool> work(static_cast<std::size_t>(T), true);
  for (Eigen::Index i = 0; i < T; ++i) {
    if (p.force >= 0) work[static_cast<std::size_t>(i)] = x.row(i).segment(p.force, 3).norm() > 0.1;
    else if (pedal >= 0) work[static_cast<std::size_t>(i)] = x(i, pedal) > 0.5;
  }
  const Eigen::Index min_ep = std::max<Eigen::Index>(2, static_cast<Eigen::Index>(0.2 * rate_hz));
  const auto episodes = runs(work, min_ep);
  std::vector<bool> idle(static_cast<std::size_t>(T), false), moving(static_cast<std::size_t>(T), false);
  for (Eigen::Index i = 1; i < T; ++i) {
    const double v = (sm.row(i) - sm.row(i - 1)).norm() / dt;
    idle[static_cast<std::size_t>(i)] = !work[static_cast<std::size_t>(i)] && v < 2.0;
    moving[static_cast<std::size_t>(i)] = !work[static_cast<std::size_t>(i)];
  }
  const auto pauses = runs(idle, static_cast<Eigen::Index>(0.25 * rate_hz));
  const auto transits = runs(moving, min_ep);

  Eigen::VectorXd f(static_cast<Eigen::Index>(summary_feature_names(set, columns).size()));
  // 1. Tremor: RMS distance of the position from its 0.25 s moving average.
  f(0) = std::sqrt((pos - sm).rowwise().squaredNorm().mean());
  // 2. Force variability: coefficient of variation of the episodes' median force.
  {
    std::vector<double> med;
    if (p.force >= 0)
      for (const auto& [a, b] : episodes) {
        std::vector<double> v;
        for (Eigen::Index i = a; i < b; ++i) v.push_back(x.row(i).segment(p.force, 3).norm());
        std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
        med.push_back(v[v.size() / 2]);
      }
    double m = 0, s = 0;
    for (double v : med) m += v;
    if (med.size() >= 2) {
      m /= static_cast<double>(med.size());
      for (double v : med) s += (v - m) * (v - m);
      s = std::sqrt(s / static_cast<double>(med.size() - 1));
    }
    f(1) = med.size() >= 2 && m > 0 ? s / m : 0.0;
  }
  // 3. Axis spread: RMS angle of the episodes' mean axis from their common mean (a constant habit cancels).
  {
    std::vector<Eigen::Vector3d> ax;
    if (p.axis >= 0)
      for (const auto& [a, b] : episodes) {
        Eigen::Vector3d m = x.block(a, p.axis, b - a, 3).colwise().mean().transpose();
        if (m.norm() > 1e-9) ax.push_back(m.normalized());
      }
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (const auto& a : ax) c += a;
    double s = 0;
    if (ax.size() >= 2 && c.norm() > 1e-9) {
      c.normalize();
      for (const auto& a : ax) {
        const double ang = std::acos(std::clamp(a.dot(c), -1.0, 1.0)) * 180.0 / M_PI;
        s += ang * ang;
      }
      s = std::sqrt(s / static_cast<double>(ax.size()));
    }
    f(2) = s;
  }
  // 4. Pauses (still, not working, >= 0.25 s) per work episode: how often, not how long.
  f(3) = static_cast<double>(pauses.size()) / static_cast<double>(std::max<std::size_t>(1, episodes.size()));
  // 5. Transit efficiency: straight distance over smoothed path, between work episodes (economy of motion).
  {
    double straight = 0, path = 0;
    for (const auto& [a, b] : transits) {
      const double l = path_length(sm, a, b);
      if (l < 1.0) continue;
      straight += (sm.row(b - 1) - sm.row(a)).norm();
      path += l;
    }
    f(4) = path > 0 ? straight / path : 1.0;
  }
  // 6. Smoothed path while working (how much of the work was done), log mm.
  {
    double l = 0;
    for (const auto& [a, b] : episodes) l += path_length(sm, a, b);
    f(5) = std::log(1.0 + l);
  }
  // 7. Smoothness: median over work episodes of log dimensionless jerk,
  //    log(integral |jerk|^2 dt * D^5 / L^2), on the smoothed path (speed-invariant).
  {
    std::vector<double> lj;
    for (const auto& [a, b] : episodes) {
      if (b - a < 8) continue;
      double J = 0;
      for (Eigen::Index i = a + 3; i < b; ++i) {
        const Eigen::RowVector3d j3 = (sm.row(i) - 3 * sm.row(i - 1) + 3 * sm.row(i - 2) - sm.row(i - 3)) / (dt * dt * dt);
        J += j3.squaredNorm() * dt;
      }
      const double D = static_cast<double>(b - a) * dt, L = path_length(sm, a, b);
      if (L > 0.1 && J > 0) lj.push_back(std::log(J * std::pow(D, 5) / (L * L)));
    }
    if (!lj.empty()) {
      std::nth_element(lj.begin(), lj.begin() + static_cast<std::ptrdiff_t>(lj.size() / 2), lj.end());
      f(6) = lj[lj.size() / 2];
    } else {
      f(6) = 0;
    }
  }
  // Other tools: tremor (as 1) and drift (SD of the smoothed position about its mean; a posture offset cancels).
  Eigen::Index k = 7;
  for (std::size_t t = 1; t < tools.size(); ++t) {
    const Eigen::MatrixX3d q = x.middleCols(tools[t].pos, 3);
    const Eigen::MatrixX3d qs = smooth(q, w);
    f(k++) = std::sqrt((q - qs).rowwise().squaredNorm().mean());
    const Eigen::RowVector3d mu = qs.colwise().mean();
    f(k++) = std::sqrt((qs.rowwise() - mu).rowwise().squaredNorm().mean());
  }
  return f;
}

Sequence normalise_trial(const Sequence& x, const std::vector<std::string>& columns) {
  Sequence y = x;
  int pedal, speed;
  const auto tools = tools_of(columns, pedal, speed);
  for (const Tool& t : tools) {
    if (t.pos >= 0) y.middleCols(t.pos, 3).rowwise() -= x.middleCols(t.pos, 3).colwise().mean();
    if (t.axis >= 0) y.middleCols(t.axis, 3).rowwise() -= x.middleCols(t.axis, 3).colwise().mean();
    if (t.force >= 0) {
      double s = 0, n = 0;
      for (Eigen::Index i = 0; i < x.rows(); ++i) {
        const double m = x.row(i).segment(t.force, 3).norm();
        if (m > 0.05) {
          s += m;
          n += 1;
        }
      }
      if (n > 0 && s > 0) y.middleCols(t.force, 3) /= s / n;
    }
  }
  if (speed >= 0) {
    std::vector<double> v;
    for (Eigen::Index i = 0; i < x.rows(); ++i)
      if (x(i, speed) > 0) v.push_back(x(i, speed));
    if (!v.empty()) {
      std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
      if (v[v.size() / 2] > 0) y.col(speed) /= v[v.size() / 2];
    }
  }
  return y;
}

}  // namespace dentar::training
