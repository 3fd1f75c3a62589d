#include "dentar/training/models.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>

namespace dentar::training {
namespace {

constexpr double kLog2Pi = 1.8378770664093453;

std::string feature_name(const std::vector<std::string>& names, Eigen::Index c) {
  if (c < static_cast<Eigen::Index>(names.size())) return "'" + names[static_cast<std::size_t>(c)] + "'";
  return "#" + std::to_string(c);
}

// Mixes a row-stochastic matrix with the uniform floor: every entry >= floor.
void apply_floor(Eigen::MatrixXd& B, double floor) {
  const double M = static_cast<double>(B.cols());
  for (Eigen::Index i = 0; i < B.rows(); ++i) {
    const double s = B.row(i).sum();
    if (s > 0) B.row(i) /= s;
    else B.row(i).setConstant(1.0 / M);
    B.row(i) = (B.row(i).array() * (1.0 - M * floor) + floor).matrix();
  }
}

std::string check_stochastic(const Eigen::VectorXd& pi, const Eigen::MatrixXd& A) {
  const Eigen::Index n = pi.size();
  if (n < 1) return "the model has no state";
  if (A.rows() != n || A.cols() != n) return "A must be N x N";
  if (!pi.allFinite() || !A.allFinite()) return "pi or A holds a non-finite value";
  if ((pi.array() < 0).any() || std::abs(pi.sum() - 1) > 1e-6) return "pi must be a probability vector";
  for (Eigen::Index i = 0; i < n; ++i)
    if ((A.row(i).array() < 0).any() || std::abs(A.row(i).sum() - 1) > 1e-6)
      return "row " + std::to_string(i) + " of A must be a probability vector";
  return {};
}

}  // namespace

Status check_finite(const Sequence& x, const std::string& what, const std::vector<std::string>& names) {
  for (Eigen::Index t = 0; t < x.rows(); ++t)
    for (Eigen::Index c = 0; c < x.cols(); ++c)
      if (!std::isfinite(x(t, c))) {
        std::ostringstream os;
        os << what << ": row " << t << ", feature " << feature_name(names, c) << " is " << x(t, c)
           << " (NaN or infinite); remove or interpolate such rows before assessment";
        return Error{os.str()};
      }
  return {};
}

Result<ZScaler> ZScaler::fit(std::span<const Sequence> data, const std::vector<std::string>& names) {
  if (data.empty()) return Error{"z-scaling: no training sequence"};
  const Eigen::Index D = data[0].cols();
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(D), sq = Eigen::VectorXd::Zero(D);
  double n = 0;
  for (std::size_t s = 0; s < data.size(); ++s) {
    if (data[s].cols() != D)
      return Error{"z-scaling: sequence " + std::to_string(s) + " has " + std::to_string(data[s].cols()) +
                   " features, the first has " + std::to_string(D)};
    if (Status st = check_finite(data[s], "sequence " + std::to_string(s), names); !st) return Error{st.error()};
    sum += data[s].colwise().sum().transpose();
    n += static_cast<double>(data[s].rows());
  }
  if (n < 2) return Error{"z-scaling: fewer than 2 time steps in the training data"};
  ZScaler z;
  z.mean = sum / n;
  for (const auto& s : data) sq += (s.rowwise() - z.mean.transpose()).array().square().colwise().sum().matrix().transpose();
  z.std = (sq / n).cwiseSqrt();
  for (Eigen::Index c = 0; c < D; ++c)
    if (!(z.std(c) > 1e-12 * std::max(1.0, std::abs(z.mean(c)))))
      return Error{"z-scaling: feature " + feature_name(names, c) +
                   " is constant in the training data (value " + std::to_string(z.mean(c)) +
                   "); it carries no information: drop it from the column map or the feature set"};
  return z;
}

Sequence ZScaler::apply(const Sequence& x) const {
  Sequence y = (x.rowwise() - mean.transpose());
  y.array().rowwise() /= std.transpose().array();
  return y;
}

Result<KMeans> KMeans::fit(const Sequence& all, int k, std::uint64_t seed, int max_iter) {
  if (k < 1) return Error{"k-means: k must be >= 1"};
  if (all.rows() < k) return Error{"k-means: " + std::to_string(all.rows()) + " points, fewer than k = " + std::to_string(k)};
  // Large inputs: fit on an even subsample of at most 200,000 points.
  const Eigen::Index stride = std::max<Eigen::Index>(1, all.rows() / 200000);
  Sequence pts(all.rows() / stride, all.cols());
  for (Eigen::Index i = 0; i < pts.rows(); ++i) pts.row(i) = all.row(i * stride);
  const Eigen::Index n = pts.rows();
  std::mt19937_64 rng(seed);
  KMeans km;
  km.centroids.resize(k, pts.cols());
  km.centroids.row(0) = pts.row(static_cast<Eigen::Index>(rng() % static_cast<std::uint64_t>(n)));
  Eigen::VectorXd d2(n);
  for (Eigen::Index i = 0; i < n; ++i) d2(i) = (pts.row(i) - km.centroids.row(0)).squaredNorm();
  for (int c = 1; c < k; ++c) {
    const double total = d2.sum();
    if (!(total > 0))
      return Error{"k-means: only " + std::to_string(c) + " distinct feature vectors, fewer than k = " +
                   std::to_string(k) + " (the data are (nearly) constant)"};
    double r = std::uniform_real_distribution<double>(0, total)(rng);
    Eigen::Index pick = n - 1;
    for (Eigen::Index i = 0; i < n; ++i) {
      r -= d2(i);
      if (r <= 0 && d2(i) > 0) { pick = i; break; }
    }
    km.centroids.row(c) = pts.row(pick);
    for (Eigen::Index i = 0; i < n; ++i) d2(i) = std::min(d2(i), (pts.row(i) - km.centroids.row(c)).squaredNorm());
  }
  std::vector<int> assign(static_cast<std::size_t>(n), -1);
  for (int it = 0; it < max_iter; ++it) {
    bool changed = false;
    for (Eigen::Index i = 0; i < n; ++i) {
      const int a = km.nearest(pts.row(i));
      if (a != assign[static_cast<std::size_t>(i)]) { assign[static_cast<std::size_t>(i)] = a; changed = true; }
    }
    if (!changed) break;
    Sequence sum = Sequence::Zero(k, pts.cols());
    Eigen::VectorXd cnt = Eigen::VectorXd::Zero(k);
    for (Eigen::Index i = 0; i < n; ++i) {
      sum.row(assign[static_cast<std::size_t>(i)]) += pts.row(i);
      cnt(assign[static_cast<std::size_t>(i)]) += 1;
    }
    for (int c = 0; c < k; ++c)
      if (cnt(c) > 0) km.centroids.row(c) = sum.row(c) / cnt(c);  // an empty cluster keeps its centroid
  }
  return km;
}

int KMeans::nearest(const Eigen::Ref<const Eigen::RowVectorXd>& x) const {
  int best = 0;
  double bd = std::numeric_limits<double>::infinity();
  for (Eigen::Index c = 0; c < centroids.rows(); ++c) {
    const double d = (centroids.row(c) - x).squaredNorm();
    if (d < bd) { bd = d; best = static_cast<int>(c); }
  }
  return best;
}

std::vector<int> KMeans::quantise(const Sequence& x) const {
  std::vector<int> o(static_cast<std::size_t>(x.rows()));
  for (Eigen::Index t = 0; t < x.rows(); ++t) o[static_cast<std::size_t>(t)] = nearest(x.row(t));
  return o;
}

// ---------------------------------------------------------------- discrete HMM

DiscreteHmm DiscreteHmm::random(int n, int m, std::uint64_t seed, double floor) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.5, 1.5);
  DiscreteHmm h;
  h.floor = floor;
  h.pi = Eigen::VectorXd::Constant(n, 1.0 / n);
  h.A.resize(n, n);
  h.B.resize(n, m);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) h.A(i, j) = u(rng) + (i == j ? 2.0 : 0.0);  // favour staying
    for (int j = 0; j < m; ++j) h.B(i, j) = u(rng);
    h.A.row(i) /= h.A.row(i).sum();
  }
  apply_floor(h.B, floor);
  return h;
}

std::string DiscreteHmm::validate() const {
  if (std::string s = check_stochastic(pi, A); !s.empty()) return s;
  if (B.rows() != pi.size() || B.cols() < 1) return "B must be N x M with M >= 1";
  if (!(floor >= 0) || floor * static_cast<double>(B.cols()) >= 1) return "floor must be in [0, 1/M)";
  for (Eigen::Index i = 0; i < B.rows(); ++i)
    if (!B.row(i).allFinite() || (B.row(i).array() < 0).any() || std::abs(B.row(i).sum() - 1) > 1e-6)
      return "row " + std::to_string(i) + " of B must be a probability vector";
  return {};
}

Result<double> DiscreteHmm::log_likelihood(std::span<const int> obs) const {
  if (obs.empty()) return Error{"discrete HMM: empty sequence"};
  const int N = states(), M = symbols();
  for (std::size_t t = 0; t < obs.size(); ++t)
    if (obs[t] < 0 || obs[t] >= M)
      return Error{"discrete HMM: symbol " + std::to_string(obs[t]) + " at step " + std::to_string(t) +
                   " is outside the model's alphabet [0, " + std::to_string(M) + ")"};
  Eigen::VectorXd a = pi.cwiseProduct(B.col(obs[0])), nx(N);
  double ll = 0;
  for (std::size_t t = 0;; ++t) {
    const double c = a.sum();
    if (!(c > 0)) return -std::numeric_limits<double>::infinity();  // impossible under the model
    ll += std::log(c);
    a /= c;
    if (t + 1 == obs.size()) break;
    nx.noalias() = A.transpose() * a;
    a = nx.cwiseProduct(B.col(obs[t + 1]));
  }
  return ll;
}

Result<DiscreteHmm::TrainReport> DiscreteHmm::train(const std::vector<std::vector<int>>& seqs, int max_iter, double tol) {
  if (std::string v = validate(); !v.empty()) return Error{"discrete HMM: " + v};
  if (seqs.empty()) return Error{"discrete HMM: no training sequence"};
  const int N = states(), M = symbols();
  std::size_t total = 0;
  for (std::size_t s = 0; s < seqs.size(); ++s) {
    if (seqs[s].empty()) return Error{"discrete HMM: training sequence " + std::to_string(s) + " is empty"};
    for (std::size_t t = 0; t < seqs[s].size(); ++t)
      if (seqs[s][t] < 0 || seqs[s][t] >= M)
        return Error{"discrete HMM: training sequence " + std::to_string(s) + ", step " + std::to_string(t) +
                     ": symbol " + std::to_string(seqs[s][t]) + " outside [0, " + std::to_string(M) + ")"};
    total += seqs[s].size();
  }
  TrainReport rep;
  std::vector<double> alpha, c;
  for (int it = 0; it < max_iter; ++it) {
    Eigen::VectorXd pi_acc = Eigen::VectorXd::Zero(N), a_den = Eigen::VectorXd::Zero(N), b_den = Eigen::VectorXd::Zero(N);
    Eigen::MatrixXd a_num = Eigen::MatrixXd::Zero(N, N), b_num = Eigen::MatrixXd::Zero(N, M);
    double ll = 0;
    for (const auto& o : seqs) {
      const std::size_t T = o.size();
      alpha.assign(T * static_cast<std::size_t>(N), 0.0);
      c.assign(T, 0.0);
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> al(alpha.data(), static_cast<Eigen::Index>(T), N);
      al.row(0) = pi.cwiseProduct(B.col(o[0])).transpose();
      for (std::size_t t = 0;; ++t) {
        const auto ti = static_cast<Eigen::Index>(t);
        c[t] = al.row(ti).sum();
        if (!(c[t] > 0)) c[t] = std::numeric_limits<double>::min();
        al.row(ti) /= c[t];
        ll += std::log(c[t]);
        if (t + 1 == T) break;
        al.row(ti + 1) = (al.row(ti) * A).cwiseProduct(B.col(o[t + 1]).transpose());
      }
      // Backward pass, accumulating gamma and xi on the fly (beta is one row).
      Eigen::RowVectorXd beta = Eigen::RowVectorXd::Ones(N), nb(N), w(N);
      for (std::size_t tt = T; tt-- > 0;) {
        const auto ti = static_cast<Eigen::Index>(tt);
        const Eigen::RowVectorXd gamma = al.row(ti).cwiseProduct(beta);
        b_num.col(o[tt]) += gamma.transpose();
        b_den += gamma.transpose();
        if (tt == 0) pi_acc += gamma.transpose();
        if (tt > 0) {
          w = B.col(o[tt]).transpose().cwiseProduct(beta) / c[tt];  // b_j(o_t) beta_t(j) / c_t
          a_num.noalias() += al.row(ti - 1).transpose() * w;
          nb.noalias() = (A * w.transpose()).transpose();
          a_den += (al.row(ti - 1).cwiseProduct(nb)).transpose();
          beta = nb;
        }
      }
    }
    rep.log_likelihood.push_back(ll);
    rep.iterations = it + 1;
    if (it > 0 && ll - rep.log_likelihood[rep.log_likelihood.size() - 2] < tol * static_cast<double>(total)) {
      rep.converged = true;
      break;
    }
    // M step.
    pi = pi_acc / pi_acc.sum();
    for (int i = 0; i < N; ++i) {
      if (a_den(i) > 0) {
        for (int j = 0; j < N; ++j) A(i, j) = A(i, j) * a_num(i, j) / a_den(i);
        A.row(i) /= A.row(i).sum();
      }
      if (b_den(i) > 0) B.row(i) = b_num.row(i) / b_den(i);
    }
    apply_floor(B, floor);
  }
  return rep;
}

// ---------------------------------------------------------------- Gaussian HMM

std::string GaussianHmm::validate() const {
  if (std::string s = check_stochastic(pi, A); !s.empty()) return s;
  if (mean.rows() != pi.size() || var.rows() != pi.size() || var.cols() != mean.cols() || mean.cols() < 1)
    return "mean and var must be N x D with D >= 1";
  if (!mean.allFinite() || !var.allFinite() || (var.array() <= 0).any()) return "var must be positive and finite";
  return {};
}

Eigen::VectorXd GaussianHmm::log_emission(const Eigen::Ref<const Eigen::RowVectorXd>& x) const {
  const int N = states();
  Eigen::VectorXd l(N);
  for (int i = 0; i < N; ++i)
    l(i) = -0.5 * ((x - mean.row(i)).array().square() / var.row(i).array() + var.row(i).array().log() + kLog2Pi).sum();
  return l;
}

Result<GaussianHmm> GaussianHmm::init(const std::vector<Sequence>& seqs, int n, std::uint64_t seed) {
  if (seqs.empty()) return Error{"Gaussian HMM: no training sequence"};
  Eigen::Index rows = 0;
  for (const auto& s : seqs) rows += s.rows();
  Sequence all(rows, seqs[0].cols());
  Eigen::Index r = 0;
  for (const auto& s : seqs) {
    if (s.cols() != all.cols()) return Error{"Gaussian HMM: sequences differ in width"};
    all.middleRows(r, s.rows()) = s;
    r += s.rows();
  }
  auto km = KMeans::fit(all, n, seed);
  if (!km) return Error{"Gaussian HMM: " + km.error()};
  GaussianHmm g;
  g.pi = Eigen::VectorXd::Constant(n, 1.0 / n);
  g.A = Eigen::MatrixXd::Constant(n, n, 0.1 / std::max(1, n - 1));
  if (n == 1) g.A(0, 0) = 1;
  else g.A.diagonal().setConstant(0.9);
  g.mean = km->centroids;
  g.var = Eigen::MatrixXd::Constant(n, all.cols(), 1.0);
  Eigen::MatrixXd sq = Eigen::MatrixXd::Zero(n, all.cols());
  Eigen::VectorXd cnt = Eigen::VectorXd::Zero(n);
  for (Eigen::Index t = 0; t < all.rows(); ++t) {
    const int c = km->nearest(all.row(t));
    sq.row(c) += (all.row(t) - g.mean.row(c)).array().square().matrix();
    cnt(c) += 1;
  }
  for (int i = 0; i < n; ++i)
    if (cnt(i) > 1) g.var.row(i) = (sq.row(i) / cnt(i)).array().max(g.var_floor).matrix();
  return g;
}

Result<double> GaussianHmm::log_likelihood(const Sequence& x) const {
  if (x.rows() == 0) return Error{"Gaussian HMM: empty sequence"};
  if (x.cols() != dims())
    return Error{"Gaussian HMM: sequence has " + std::to_string(x.cols()) + " features, the model " + std::to_string(dims())};
  if (Status st = check_finite(x, "Gaussian HMM input", {}); !st) return Error{st.error()};
  Eigen::VectorXd a, le;
  double ll = 0;
  for (Eigen::Index t = 0; t < x.rows(); ++t) {
    le = log_emission(x.row(t));
    const double m = le.maxCoeff();
    const Eigen::VectorXd b = (le.array() - m).exp().matrix();
    a = t == 0 ? Eigen::VectorXd(pi.cwiseProduct(b)) : Eigen::VectorXd((A.transpose() * a).cwiseProduct(b));
    const double c = a.sum();
    if (!(c > 0)) return -std::numeric_limits<double>::infinity();
    ll += m + std::log(c);
    a /= c;
  }
  return ll;
}

Result<DiscreteHmm::TrainReport> GaussianHmm::train(const std::vector<Sequence>& seqs, int max_iter, double tol) {
  if (std::string v = validate(); !v.empty()) return Error{"Gaussian HMM: " + v};
  const int N = states();
  const Eigen::Index D = dims();
  std::size_t total = 0;
  for (std::size_t s = 0; s < seqs.size(); ++s) {
    if (seqs[s].rows() == 0 || seqs[s].cols() != D)
      return Error{"Gaussian HMM: training sequence " + std::to_string(s) + " is empty or of the wrong width"};
    if (Status st = check_finite(seqs[s], "training sequence " + std::to_string(s), {}); !st) return Error{st.error()};
    total += static_cast<std::size_t>(seqs[s].rows());
  }
  DiscreteHmm::TrainReport rep;
  std::vector<double> alpha, c, bm;
  for (int it = 0; it < max_iter; ++it) {
    Eigen::VectorXd pi_acc = Eigen::VectorXd::Zero(N), a_den = Eigen::VectorXd::Zero(N), g_sum = Eigen::VectorXd::Zero(N);
    Eigen::MatrixXd a_num = Eigen::MatrixXd::Zero(N, N), x_sum = Eigen::MatrixXd::Zero(N, D), x2_sum = Eigen::MatrixXd::Zero(N, D);
    double ll = 0;
    for (const auto& x : seqs) {
      const auto T = static_cast<std::size_t>(x.rows());
      alpha.assign(T * N, 0.0);
      bm.assign(T * N, 0.0);
      c.assign(T, 0.0);
      Eigen::Map<Sequence> al(alpha.data(), static_cast<Eigen::Index>(T), N), b(bm.data(), static_cast<Eigen::Index>(T), N);
      for (std::size_t t = 0; t < T; ++t) {
        const auto ti = static_cast<Eigen::Index>(t);
        const Eigen::VectorXd le = log_emission(x.row(ti));
        const double m = le.maxCoeff();
        b.row(ti) = (le.array() - m).exp().matrix().transpose();
        if (t == 0) al.row(0) = pi.transpose().cwiseProduct(b.row(0));
        else al.row(ti) = (al.row(ti - 1) * A).cwiseProduct(b.row(ti));
        c[t] = al.row(ti).sum();
        if (!(c[t] > 0)) c[t] = std::numeric_limits<double>::min();
        al.row(ti) /= c[t];
        ll += m + std::log(c[t]);
      }
      Eigen::RowVectorXd beta = Eigen::RowVectorXd::Ones(N), w(N), nb(N);
      for (std::size_t tt = T; tt-- > 0;) {
        const auto ti = static_cast<Eigen::Index>(tt);
        const Eigen::RowVectorXd gamma = al.row(ti).cwiseProduct(beta);
        g_sum += gamma.transpose();
        x_sum.noalias() += gamma.transpose() * x.row(ti);
        x2_sum.noalias() += gamma.transpose() * x.row(ti).array().square().matrix();
        if (tt == 0) pi_acc += gamma.transpose();
        if (tt > 0) {
          w = b.row(ti).cwiseProduct(beta) / c[tt];
          a_num.noalias() += al.row(ti - 1).transpose() * w;
          nb.noalias() = (A * w.transpose()).transpose();
          a_den += al.row(ti - 1).cwiseProduct(nb).transpose();
          beta = nb;
        }
      }
    }
    rep.log_likelihood.push_back(ll);
    rep.iterations = it + 1;
    if (it > 0 && ll - rep.log_likelihood[rep.log_likelihood.size() - 2] < tol * static_cast<double>(total)) {
      rep.converged = true;
      break;
    }
    pi = pi_acc / pi_acc.sum();
    for (int i = 0; i < N; ++i) {
      if (a_den(i) > 0) {
        for (int j = 0; j < N; ++j) A(i, j) = A(i, j) * a_num(i, j) / a_den(i);
        A.row(i) /= A.row(i).sum();
      }
      if (g_sum(i) > 1e-9) {
        mean.row(i) = x_sum.row(i) / g_sum(i);
        var.row(i) = (x2_sum.row(i) / g_sum(i) - mean.row(i).array().square().matrix()).array().max(var_floor).matrix();
      }
    }
  }
  return rep;
}

// ---------------------------------------------------------------- DTW

double dtw_distance(const Sequence& a, const Sequence& b, int window) {
  const Eigen::Index n = a.rows(), m = b.rows();
  if (n == 0 || m == 0 || a.cols() != b.cols()) return std::numeric_limits<double>::infinity();
  constexpr double inf = std::numeric_limits<double>::infinity();
  std::vector<double> prev(static_cast<std::size_t>(m + 1), inf), cur(static_cast<std::size_t>(m + 1), inf);
  prev[0] = 0;
  for (Eigen::Index i = 1; i <= n; ++i) {
    std::fill(cur.begin(), cur.end(), inf);
    Eigen::Index lo = 1, hi = m;
    if (window >= 0) {
      const double centre = static_cast<double>(i) * static_cast<double>(m) / static_cast<double>(n);
      lo = std::max<Eigen::Index>(1, static_cast<Eigen::Index>(std::floor(centre - window)));
      hi = std::min<Eigen::Index>(m, static_cast<Eigen::Index>(std::ceil(centre + window)));
    }
    for (Eigen::Index j = lo; j <= hi; ++j) {
      const double d = (a.row(i - 1) - b.row(j - 1)).norm();
      const double best = std::min({prev[static_cast<std::size_t>(j)], cur[static_cast<std::size_t>(j - 1)],
                                    prev[static_cast<std::size_t>(j - 1)]});
      cur[static_cast<std::size_t>(j)] = d + best;
    }
    std::swap(prev, cur);
  }
  return prev[static_cast<std::size_t>(m)] / static_cast<double>(n + m);
}

Sequence resample(const Sequence& x, int n) {
  Sequence y(n, x.cols());
  if (x.rows() == 1) {
    for (int i = 0; i < n; ++i) y.row(i) = x.row(0);
    return y;
  }
  if (x.rows() > n) {
    // Shortening: the mean of each of n equal spans (piecewise aggregate
    // approximation). Point samples would alias: 200 of a 30,000-row session
    // pick random phases of the tremor and the force ripple.
    const double span = static_cast<double>(x.rows()) / n;
    for (int i = 0; i < n; ++i) {
      const auto a = static_cast<Eigen::Index>(std::floor(i * span));
      const auto b = std::max(a + 1, std::min<Eigen::Index>(x.rows(), static_cast<Eigen::Index>(std::floor((i + 1) * span))));
      y.row(i) = x.middleRows(a, b - a).colwise().mean();
    }
    return y;
  }
  for (int i = 0; i < n; ++i) {
    const double s = static_cast<double>(i) * static_cast<double>(x.rows() - 1) / std::max(1, n - 1);
    const auto k = std::min<Eigen::Index>(static_cast<Eigen::Index>(s), x.rows() - 2);
    const double f = s - static_cast<double>(k);
    y.row(i) = (1 - f) * x.row(k) + f * x.row(k + 1);
  }
  return y;
}

}  // namespace dentar::training
