#include "dentar/training/align.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace dentar::training {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The cells searched: for each row i of a, the columns [lo[i], hi[i]] of b (inclusive),
// both non-decreasing in i, lo[0] = 0, hi[n-1] = m-1.
struct Window {
  std::vector<int> lo, hi;
};

Window full_window(int n, int m) {
  Window w;
  w.lo.assign(static_cast<std::size_t>(n), 0);
  w.hi.assign(static_cast<std::size_t>(n), m - 1);
  return w;
}

// DTW restricted to the window; steps (1,0), (0,1), (1,1).
Alignment dtw_window(const Series& a, const Series& b, const Window& w) {
  const int n = static_cast<int>(a.rows());
  Alignment al;
  // Per row: cost of the cells lo..hi, and the step that reached each (0 diag, 1 up, 2 left).
  std::vector<std::vector<double>> D(static_cast<std::size_t>(n));
  std::vector<std::vector<std::uint8_t>> from(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const int lo = w.lo[static_cast<std::size_t>(i)], hi = w.hi[static_cast<std::size_t>(i)];
    auto& d = D[static_cast<std::size_t>(i)];
    auto& f = from[static_cast<std::size_t>(i)];
    d.assign(static_cast<std::size_t>(hi - lo + 1), kInf);
    f.assign(d.size(), 0);
    const int plo = i > 0 ? w.lo[static_cast<std::size_t>(i - 1)] : 0, phi = i > 0 ? w.hi[static_cast<std::size_t>(i - 1)] : -1;
    const std::vector<double>* prev = i > 0 ? &D[static_cast<std::size_t>(i - 1)] : nullptr;
    for (int j = lo; j <= hi; ++j) {
      const double c = (a.row(i) - b.row(j)).norm();
      double best = kInf;
      std::uint8_t step = 0;
      if (i == 0 && j == 0) best = 0;
      if (prev && j - 1 >= plo && j - 1 <= phi && (*prev)[static_cast<std::size_t>(j - 1 - plo)] < best) {
        best = (*prev)[static_cast<std::size_t>(j - 1 - plo)];
        step = 0;
      }
      if (prev && j >= plo && j <= phi && (*prev)[static_cast<std::size_t>(j - plo)] < best) {
        best = (*prev)[static_cast<std::size_t>(j - plo)];
        step = 1;
      }
      if (j - 1 >= lo && d[static_cast<std::size_t>(j - 1 - lo)] < best) {
        best = d[static_cast<std::size_t>(j - 1 - lo)];
        step = 2;
      }
      d[static_cast<std::size_t>(j - lo)] = best + c;
      f[static_cast<std::size_t>(j - lo)] = step;
      ++al.cells;
    }
  }
  const int m_last = w.hi[static_cast<std::size_t>(n - 1)];
  al.cost = D[static_cast<std::size_t>(n - 1)][static_cast<std::size_t>(m_last - w.lo[static_cast<std::size_t>(n - 1)])];
  int i = n - 1, j = m_last;
  while (true) {
    al.path.emplace_back(i, j);
    if (i == 0 && j == 0) break;
    const std::uint8_t s = from[static_cast<std::size_t>(i)][static_cast<std::size_t>(j - w.lo[static_cast<std::size_t>(i)])];
    if (s == 0) {
      --i;
      --j;
    } else if (s == 1) {
      --i;
    } else {
      --j;
    }
  }
  std::reverse(al.path.begin(), al.path.end());
  return al;
}

Series halve(const Series& x) {
  const Eigen::Index n = (x.rows() + 1) / 2;
  Series h(n, x.cols());
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Index k = 2 * i;
    h.row(i) = k + 1 < x.rows() ? 0.5 * (x.row(k) + x.row(k + 1)) : Eigen::RowVectorXd(x.row(k));
  }
  return h;
}

// The fine-level window around a coarse path: each coarse cell (i, j) covers fine rows
// 2i, 2i+1 and columns 2j, 2j+1, widened by `radius` columns either side, then made
// monotone and clipped.
Window project(const std::vector<std::pair<int, int>>& coarse, int n, int m, int radius) {
  Window w;
  w.lo.assign(static_cast<std::size_t>(n), std::numeric_limits<int>::max());
  w.hi.assign(static_cast<std::size_t>(n), -1);
  for (const auto& [ci, cj] : coarse)
    for (int di = 0; di < 2; ++di) {
      const int i = 2 * ci + di;
      if (i >= n) continue;
      auto& lo = w.lo[static_cast<std::size_t>(i)];
      auto& hi = w.hi[static_cast<std::size_t>(i)];
      lo = std::min(lo, 2 * cj - radius);
      hi = std::max(hi, 2 * cj + 1 + radius);
    }
  // Rows widened by the radius too: the path may leave a row `radius` rows earlier/later.
  std::vector<int> lo = w.lo, hi = w.hi;
  for (int i = 0; i < n; ++i)
    for (int k = std::max(0, i - radius); k <= std::min(n - 1, i + radius); ++k) {
      lo[static_cast<std::size_t>(i)] = std::min(lo[static_cast<std::size_t>(i)], w.lo[static_cast<std::size_t>(k)]);
      hi[static_cast<std::size_t>(i)] = std::max(hi[static_cast<std::size_t>(i)], w.hi[static_cast<std::size_t>(k)]);
    }
  for (int i = 0; i < n; ++i) {
    lo[static_cast<std::size_t>(i)] = std::clamp(lo[static_cast<std::size_t>(i)], 0, m - 1);
    hi[static_cast<std::size_t>(i)] = std::clamp(hi[static_cast<std::size_t>(i)], 0, m - 1);
  }
  // Monotone: lo non-decreasing from the top, hi non-decreasing (take running max / min).
  for (int i = 1; i < n; ++i)
    hi[static_cast<std::size_t>(i)] = std::max(hi[static_cast<std::size_t>(i)], hi[static_cast<std::size_t>(i - 1)]);
  for (int i = n - 2; i >= 0; --i)
    lo[static_cast<std::size_t>(i)] = std::min(lo[static_cast<std::size_t>(i)], lo[static_cast<std::size_t>(i + 1)]);
  lo[0] = 0;
  hi[static_cast<std::size_t>(n - 1)] = m - 1;
  // Consecutive rows must overlap or touch so that a path exists.
  for (int i = 1; i < n; ++i)
    lo[static_cast<std::size_t>(i)] = std::min(lo[static_cast<std::size_t>(i)], hi[static_cast<std::size_t>(i - 1)]);
  w.lo = lo;
  w.hi = hi;
  return w;
}

Alignment align_rec(const Series& a, const Series& b, int radius) {
  const int n = static_cast<int>(a.rows()), m = static_cast<int>(b.rows());
  const int small = std::max(32, 2 * radius + 2);
  if (n <= small || m <= small) return dtw_window(a, b, full_window(n, m));
  const Alignment coarse = align_rec(halve(a), halve(b), radius);
  Alignment fine = dtw_window(a, b, project(coarse.path, n, m, radius));
  fine.cells += coarse.cells;
  return fine;
}

}  // namespace

Result<Alignment> dtw_align(const Series& a, const Series& b, int radius) {
  if (a.rows() == 0 || b.rows() == 0) return Error{"DTW: a series is empty (" + std::to_string(a.rows()) + " and " +
                                                   std::to_string(b.rows()) + " samples)"};
  if (a.cols() != b.cols())
    return Error{"DTW: the series have " + std::to_string(a.cols()) + " and " + std::to_string(b.cols()) +
                 " values per sample; align the same quantities"};
  for (const auto* s : {&a, &b})
    for (Eigen::Index i = 0; i < s->rows(); ++i)
      if (!s->row(i).allFinite())
        return Error{std::string("DTW: series ") + (s == &a ? "a" : "b") + " has a non-finite value at sample " +
                     std::to_string(i)};
  if (radius <= 0) {
    if (static_cast<double>(a.rows()) * static_cast<double>(b.rows()) > 2e8)
      return Error{"DTW: exact alignment of " + std::to_string(a.rows()) + " x " + std::to_string(b.rows()) +
                   " samples is too large; use a radius > 0 (multi-resolution)"};
    return dtw_window(a, b, full_window(static_cast<int>(a.rows()), static_cast<int>(b.rows())));
  }
  return align_rec(a, b, radius);
}

std::vector<double> warp_map(const Alignment& al, int rows_a) {
  std::vector<double> sum(static_cast<std::size_t>(std::max(rows_a, 0)), 0.0), cnt(sum.size(), 0.0);
  for (const auto& [i, j] : al.path)
    if (i >= 0 && i < rows_a) {
      sum[static_cast<std::size_t>(i)] += j;
      cnt[static_cast<std::size_t>(i)] += 1;
    }
  for (std::size_t i = 0; i < sum.size(); ++i) sum[i] = cnt[i] > 0 ? sum[i] / cnt[i] : (i > 0 ? sum[i - 1] : 0.0);
  return sum;
}

}  // namespace dentar::training
