// Skill models written on Eigen: z-scaling, k-means vector quantisation, a
// discrete HMM (scaled forward-backward, Baum-Welch over many sequences,
// emission floor for unseen symbols), a Gaussian HMM (diagonal covariances,
// log-space emissions) and dynamic time warping. Formulas: docs/formats.md
// ("Skill assessment").
//
// Sequences are T x D matrices (one row per time step). Nothing here runs in
// the haptic thread.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "dentar/volume/result.h"

namespace dentar::training {

using Sequence = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Per-column z-scaling fitted on training data. fit() rejects NaN/inf
// (naming sequence, row and feature) and constant features (naming the
// feature and what to do).
struct ZScaler {
  Eigen::VectorXd mean, std;
  static Result<ZScaler> fit(std::span<const Sequence> data, const std::vector<std::string>& names);
  Sequence apply(const Sequence& x) const;
};

// Checks every value is finite; the message names the sequence, row and feature.
Status check_finite(const Sequence& x, const std::string& what, const std::vector<std::string>& names);

struct KMeans {
  Sequence centroids;  // K x D
  // Lloyd's algorithm with k-means++ seeding (deterministic for a seed).
  // Fewer distinct points than k is an error.
  static Result<KMeans> fit(const Sequence& points, int k, std::uint64_t seed = 1, int max_iter = 100);
  int nearest(const Eigen::Ref<const Eigen::RowVectorXd>& x) const;
  std::vector<int> quantise(const Sequence& x) const;
};

class DiscreteHmm {
 public:
  Eigen::VectorXd pi;  // N
  Eigen::MatrixXd A;   // N x N, rows sum to 1
  Eigen::MatrixXd B;   // N x M, rows sum to 1, every entry >= floor
  double floor = 1e-4;  // minimum emission probability (unseen symbols)

  int states() const { return static_cast<int>(pi.size()); }
  int symbols() const { return static_cast<int>(B.cols()); }

  // Random row-stochastic start (deterministic for a seed).
  static DiscreteHmm random(int n_states, int n_symbols, std::uint64_t seed, double floor = 1e-4);
  // Empty when consistent, else names the problem.
  std::string validate() const;

  // log P(obs | model) by the scaled forward algorithm. Symbols outside
  // [0, M) and empty sequences are errors. O(T N^2), O(N) memory.
  Result<double> log_likelihood(std::span<const int> obs) const;

  struct TrainReport {
    int iterations = 0;
    std::vector<double> log_likelihood;  // total over sequences, per iteration (non-decreasing up to the floor)
    bool converged = false;
  };
  // Baum-Welch over all sequences (scaled forward-backward). Stops when the
  // total log-likelihood improves by less than tol * (total steps).
  Result<TrainReport> train(const std::vector<std::vector<int>>& seqs, int max_iter = 50, double tol = 1e-6);
};

class GaussianHmm {
 public:
  Eigen::VectorXd pi;     // N
  Eigen::MatrixXd A;      // N x N
  Eigen::MatrixXd mean;   // N x D
  Eigen::MatrixXd var;    // N x D (diagonal covariance), >= var_floor
  double var_floor = 1e-3;

  int states() const { return static_cast<int>(pi.size()); }
  int dims() const { return static_cast<int>(mean.cols()); }
  std::string validate() const;

  // Starts from k-means on all frames of the sequences.
  static Result<GaussianHmm> init(const std::vector<Sequence>& seqs, int n_states, std::uint64_t seed);
  Result<double> log_likelihood(const Sequence& x) const;
  Result<DiscreteHmm::TrainReport> train(const std::vector<Sequence>& seqs, int max_iter = 30, double tol = 1e-6);
  // log N(x | mean_i, var_i) for every state (exposed for tests).
  Eigen::VectorXd log_emission(const Eigen::Ref<const Eigen::RowVectorXd>& x) const;
};

// DTW distance with a Sakoe-Chiba band of `window` steps (<0: none) between
// two sequences of the same width, Euclidean frame distance, normalised by
// (n + m). Infinite when the band makes the ends unreachable.
double dtw_distance(const Sequence& a, const Sequence& b, int window = -1);
// Resamples a sequence to n rows (n >= 2): linear interpolation when
// lengthening, the mean of n equal spans when shortening (no aliasing).
Sequence resample(const Sequence& x, int n);

}  // namespace dentar::training
