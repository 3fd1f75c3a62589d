// See step_align.h.
#include "dentar/replay/step_align.h"

#include <algorithm>
#include <cmath>

namespace dentar::replay {
namespace {

// First row of each label 0..L-1 in the labelling's time order, made monotone: the start of
// label k is the first row whose label is >= k (so a return to an earlier label stays in the
// later step). starts[L] = n.
std::vector<int> step_starts(const std::vector<int>& labels, int L) {
  const int n = static_cast<int>(labels.size());
  std::vector<int> s(static_cast<std::size_t>(L) + 1, n);
  for (int k = L - 1; k >= 0; --k) {
    for (int i = 0; i < n; ++i)
      if (labels[static_cast<std::size_t>(i)] >= k) {
        s[static_cast<std::size_t>(k)] = i;
        break;
      }
    s[static_cast<std::size_t>(k)] = std::min(s[static_cast<std::size_t>(k)], s[static_cast<std::size_t>(k) + 1]);
  }
  s[0] = 0;  // rows before the first step belong to it
  return s;
}

}  // namespace

training::Series tip_series_mm(const training::SessionTrack& t) {
  training::Series x(static_cast<Eigen::Index>(t.size()), 3);
  for (std::size_t i = 0; i < t.size(); ++i) x.row(static_cast<Eigen::Index>(i)) = 1e3 * t.tip_m[i].transpose();
  return x;
}

Result<StepWarp> align_by_step(const training::Series& a, const std::vector<int>& steps_a, const training::Series& b,
                               const std::vector<int>& steps_b, int radius) {
  if (a.rows() < 1 || b.rows() < 1) return Error{"align_by_step: an empty series"};
  if (static_cast<std::size_t>(a.rows()) != steps_a.size() || static_cast<std::size_t>(b.rows()) != steps_b.size())
    return Error{"align_by_step: a step label is needed for every row (a: " + std::to_string(a.rows()) + " rows, " +
                 std::to_string(steps_a.size()) + " labels; b: " + std::to_string(b.rows()) + " rows, " +
                 std::to_string(steps_b.size()) + " labels)"};
  int L = 1;
  for (int s : steps_a) L = std::max(L, s + 1);
  for (int s : steps_b) L = std::max(L, s + 1);
  const std::vector<int> sa = step_starts(steps_a, L), sb = step_starts(steps_b, L);
  const int na = static_cast<int>(a.rows()), nb = static_cast<int>(b.rows());
  StepWarp w;
  w.b_row.assign(static_cast<std::size_t>(na), -1.0);
  // Anchors (row of a, row of b) the linear pieces run between: the ends, and each aligned
  // step's ends.
  for (int k = 0; k < L; ++k) {
    const int a0 = sa[static_cast<std::size_t>(k)], a1 = sa[static_cast<std::size_t>(k) + 1];
    const int b0 = sb[static_cast<std::size_t>(k)], b1 = sb[static_cast<std::size_t>(k) + 1];
    if (a1 - a0 < 2 || b1 - b0 < 2) continue;
    auto al = training::dtw_align(a.middleRows(a0, a1 - a0), b.middleRows(b0, b1 - b0), radius);
    if (!al) return Error{"step " + std::to_string(k + 1) + ": " + al.error()};
    const std::vector<double> m = training::warp_map(*al, a1 - a0);
    for (int i = 0; i < a1 - a0; ++i) w.b_row[static_cast<std::size_t>(a0 + i)] = b0 + m[static_cast<std::size_t>(i)];
    w.steps_aligned.push_back(k);
    w.cells += al->cells;
    w.cost += al->cost;
  }
  // Rows no step aligned: straight between the known rows around them (0 -> 0 and
  // na-1 -> nb-1 at the ends).
  std::vector<std::pair<int, double>> known;
  if (w.b_row.front() < 0) known.push_back({0, 0.0});
  for (int i = 0; i < na; ++i)
    if (w.b_row[static_cast<std::size_t>(i)] >= 0) known.push_back({i, w.b_row[static_cast<std::size_t>(i)]});
  if (w.b_row.back() < 0) known.push_back({na - 1, static_cast<double>(nb - 1)});
  if (na == 1) {
    w.b_row[0] = 0;
    return w;
  }
  for (std::size_t k = 0; k + 1 < known.size(); ++k) {
    const auto [i0, v0] = known[k];
    const auto [i1, v1] = known[k + 1];
    for (int i = i0 + 1; i < i1; ++i) w.b_row[static_cast<std::size_t>(i)] = v0 + (v1 - v0) * (i - i0) / double(i1 - i0);
  }
  // Monotone (DTW maps are; the joins between steps are made so too).
  for (int i = 1; i < na; ++i)
    w.b_row[static_cast<std::size_t>(i)] = std::max(w.b_row[static_cast<std::size_t>(i)], w.b_row[static_cast<std::size_t>(i) - 1]);
  return w;
}

Result<TimeWarp> align_recordings(const Recording& a, const Recording& b, int radius) {
  auto w = align_by_step(tip_series_mm(a.track), a.frame_steps, tip_series_mm(b.track), b.frame_steps, radius);
  if (!w) return Error{a.input + " against " + b.input + ": " + w.error()};
  TimeWarp t;
  const double ta0 = a.log->records.front().time_s, tb0 = b.log->records.front().time_s;
  t.a_t_s.resize(a.track.size());
  t.b_t_s.resize(a.track.size());
  for (std::size_t i = 0; i < a.track.size(); ++i) {
    t.a_t_s[i] = a.track.t_s[i] - ta0;
    const double r = w->b_row[i];
    const std::size_t j = static_cast<std::size_t>(std::floor(r));
    const double f = r - static_cast<double>(j);
    const double tb = j + 1 < b.track.size() ? (1 - f) * b.track.t_s[j] + f * b.track.t_s[j + 1] : b.track.t_s.back();
    t.b_t_s[i] = tb - tb0;
  }
  t.steps_aligned = w->steps_aligned;
  t.cells = w->cells;
  return t;
}

double TimeWarp::b_at(double a_s) const {
  if (a_t_s.empty()) return a_s;
  if (a_s <= a_t_s.front()) return b_t_s.front();
  if (a_s >= a_t_s.back()) return b_t_s.back();
  const auto it = std::upper_bound(a_t_s.begin(), a_t_s.end(), a_s);
  const std::size_t j = static_cast<std::size_t>(it - a_t_s.begin());
  const double f = (a_s - a_t_s[j - 1]) / std::max(1e-12, a_t_s[j] - a_t_s[j - 1]);
  return b_t_s[j - 1] + f * (b_t_s[j] - b_t_s[j - 1]);
}

}  // namespace dentar::replay
