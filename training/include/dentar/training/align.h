// Aligning two recordings in time by dynamic time warping (issue 27: the student against
// the expert, side by side, per step). A path of index pairs, monotone in both, from (0, 0)
// to (n-1, m-1).
//
// Exact DTW costs n*m; two 10-minute sessions at 50 Hz would be 9e8 cells. So the aligner is
// multi-resolution: both series are halved (pairwise means) until short, aligned exactly
// there, and each finer level is aligned only within `radius` cells of the coarser path
// projected down (the FastDTW idea). Cost O((n + m) * radius) per level. Where the warp is
// smooth at the coarse scale (recordings of the same procedure) this finds the exact path;
// it is checked against exact DTW in the tests.
#pragma once

#include <Eigen/Core>
#include <utility>
#include <vector>

#include "dentar/volume/result.h"

namespace dentar::training {

using Series = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;  // rows: samples

struct Alignment {
  std::vector<std::pair<int, int>> path;  // (row of a, row of b), monotone, both ends included
  double cost = 0;                        // sum of Euclidean distances along the path
  std::size_t cells = 0;                  // cells evaluated (all levels): the work done
};

// radius <= 0: exact DTW (all n*m cells; refused above 2e8 cells). Errors: empty series,
// different widths, non-finite values (naming which series and row).
Result<Alignment> dtw_align(const Series& a, const Series& b, int radius = 8);

// Where each row of `a` falls in `b` along the path (the mean of the b rows matched to it):
// to play b beside a, show b at map[i] while a is at i.
std::vector<double> warp_map(const Alignment& al, int rows_a);

}  // namespace dentar::training
