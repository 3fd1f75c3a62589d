// HMM, GHMM, k-means, z-scaling and DTW: hand-computed cases, brute-force
// enumeration for tiny models, and numerical stability on hard inputs.
#include "dentar/training/models.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

namespace dentar::training {
namespace {

DiscreteHmm two_state() {
  DiscreteHmm h;
  h.floor = 0;
  h.pi = Eigen::Vector2d(0.6, 0.4);
  h.A.resize(2, 2);
  h.A << 0.7, 0.3, 0.4, 0.6;
  h.B.resize(2, 2);
  h.B << 0.9, 0.1, 0.2, 0.8;
  return h;
}

// Sum over all N^T state paths.
double brute_force(const DiscreteHmm& h, const std::vector<int>& o) {
  const int N = h.states();
  const int T = static_cast<int>(o.size());
  double total = 0;
  std::vector<int> s(static_cast<std::size_t>(T), 0);
  std::function<void(int, double)> rec = [&](int t, double p) {
    for (int i = 0; i < N; ++i) {
      const double q = (t == 0 ? h.pi(i) : p * h.A(s[static_cast<std::size_t>(t - 1)], i)) * h.B(i, o[static_cast<std::size_t>(t)]);
      s[static_cast<std::size_t>(t)] = i;
      if (t + 1 == T) total += q;
      else rec(t + 1, q);
    }
  };
  rec(0, 1.0);
  return total;
}

TEST(DiscreteHmm, HandComputedTwoSteps) {
  // P(o = [0, 1]) = sum_ij pi_i b_i(0) a_ij b_j(1)
  // = 0.6*0.9*(0.7*0.1 + 0.3*0.8) + 0.4*0.2*(0.4*0.1 + 0.6*0.8) = 0.54*0.31 + 0.08*0.52 = 0.209
  const DiscreteHmm h = two_state();
  auto ll = h.log_likelihood(std::vector<int>{0, 1});
  ASSERT_TRUE(ll.ok());
  EXPECT_NEAR(std::exp(*ll), 0.209, 1e-12);
}

TEST(DiscreteHmm, ForwardMatchesBruteForceEnumeration) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 20; ++trial) {
    DiscreteHmm h = DiscreteHmm::random(3, 4, 100 + trial, 0.0);
    h.pi = Eigen::Vector3d(0.2, 0.5, 0.3);
    std::vector<int> o(6);
    for (auto& x : o) x = static_cast<int>(rng() % 4);
    auto ll = h.log_likelihood(o);
    ASSERT_TRUE(ll.ok());
    EXPECT_NEAR(*ll, std::log(brute_force(h, o)), 1e-10);
  }
}

TEST(DiscreteHmm, SingleStateIsSumOfLogEmissions) {
  DiscreteHmm h;
  h.floor = 0;
  h.pi = Eigen::VectorXd::Ones(1);
  h.A = Eigen::MatrixXd::Ones(1, 1);
  h.B.resize(1, 3);
  h.B << 0.5, 0.3, 0.2;
  auto ll = h.log_likelihood(std::vector<int>{0, 1, 2, 2});
  ASSERT_TRUE(ll.ok());
  EXPECT_NEAR(*ll, std::log(0.5) + std::log(0.3) + 2 * std::log(0.2), 1e-12);
  // Training a single state recovers the symbol frequencies exactly.
  ASSERT_TRUE(h.train({{0, 0, 1, 2}, {0, 2}}).ok());
  EXPECT_NEAR(h.B(0, 0), 0.5, 1e-12);
  EXPECT_NEAR(h.B(0, 1), 1.0 / 6, 1e-12);
  EXPECT_NEAR(h.A(0, 0), 1.0, 1e-12);
}

TEST(DiscreteHmm, BaumWelchNeverDecreasesAndLearnsStructure) {
  // Data from a known 2-state model; training from a random start must
  // raise the likelihood monotonically (EM, floor 0) above the start.
  const DiscreteHmm truth = two_state();
  std::mt19937_64 rng(7);
  std::vector<std::vector<int>> seqs;
  for (int s = 0; s < 20; ++s) {
    std::vector<int> o;
    int st = std::bernoulli_distribution(truth.pi(1))(rng);
    for (int t = 0; t < 200; ++t) {
      o.push_back(std::bernoulli_distribution(truth.B(st, 1))(rng));
      st = std::bernoulli_distribution(truth.A(st, 1))(rng);
    }
    seqs.push_back(o);
  }
  DiscreteHmm h = DiscreteHmm::random(2, 2, 11, 0.0);
  auto rep = h.train(seqs, 200, 1e-10);
  ASSERT_TRUE(rep.ok()) << rep.error();
  for (std::size_t i = 1; i < rep->log_likelihood.size(); ++i)
    EXPECT_GE(rep->log_likelihood[i], rep->log_likelihood[i - 1] - 1e-7);
  double ll_truth = 0;
  for (const auto& o : seqs) ll_truth += *truth.log_likelihood(o);
  EXPECT_GE(rep->log_likelihood.back(), ll_truth - 1.0);  // as good as the generating model
  EXPECT_TRUE(h.validate().empty());
}

TEST(DiscreteHmm, UnseenSymbolGetsFloorNotMinusInfinity) {
  DiscreteHmm h = DiscreteHmm::random(2, 3, 5, 1e-4);
  ASSERT_TRUE(h.train({{0, 1, 0, 1, 0, 1}, {1, 0, 1}}).ok());
  for (int i = 0; i < 2; ++i) EXPECT_GE(h.B(i, 2), 1e-4 - 1e-15);
  auto ll = h.log_likelihood(std::vector<int>{0, 2, 1});
  ASSERT_TRUE(ll.ok());
  EXPECT_TRUE(std::isfinite(*ll));
  EXPECT_LT(*ll, *h.log_likelihood(std::vector<int>{0, 1, 1}));
  // Out of the alphabet: an error naming the symbol and step.
  auto bad = h.log_likelihood(std::vector<int>{0, 3});
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("symbol 3 at step 1"), std::string::npos) << bad.error();
}

TEST(DiscreteHmm, MillionStepSequenceStaysFinite) {
  DiscreteHmm h = DiscreteHmm::random(13, 13, 1, 1e-4);
  std::vector<int> o(1'000'000);
  std::mt19937 rng(1);
  for (auto& x : o) x = static_cast<int>(rng() % 13);
  auto ll = h.log_likelihood(o);
  ASSERT_TRUE(ll.ok());
  EXPECT_TRUE(std::isfinite(*ll));
  // Per-step log-likelihood of near-uniform emissions is about log(1/13).
  EXPECT_NEAR(*ll / 1e6, std::log(1.0 / 13), 0.1);
  auto rep = h.train({o}, 2);
  ASSERT_TRUE(rep.ok());
  EXPECT_TRUE(std::isfinite(rep->log_likelihood.back()));
  EXPECT_TRUE(h.validate().empty()) << h.validate();
}

TEST(GaussianHmm, ForwardMatchesBruteForce) {
  GaussianHmm g;
  g.pi = Eigen::Vector2d(0.3, 0.7);
  g.A.resize(2, 2);
  g.A << 0.8, 0.2, 0.1, 0.9;
  g.mean.resize(2, 1);
  g.mean << -1, 2;
  g.var.resize(2, 1);
  g.var << 0.5, 2.0;
  Sequence x(4, 1);
  x << -0.5, 1.0, 2.5, -1.2;
  double total = 0;
  auto pdf = [&](int i, double v) {
    return std::exp(-0.5 * (v - g.mean(i, 0)) * (v - g.mean(i, 0)) / g.var(i, 0)) / std::sqrt(2 * M_PI * g.var(i, 0));
  };
  for (int s = 0; s < 16; ++s) {
    int st[4];
    for (int t = 0; t < 4; ++t) st[t] = (s >> t) & 1;
    double p = g.pi(st[0]) * pdf(st[0], x(0, 0));
    for (int t = 1; t < 4; ++t) p *= g.A(st[t - 1], st[t]) * pdf(st[t], x(t, 0));
    total += p;
  }
  auto ll = g.log_likelihood(x);
  ASSERT_TRUE(ll.ok());
  EXPECT_NEAR(*ll, std::log(total), 1e-10);
}

TEST(GaussianHmm, TrainsOnTwoRegimesAndStaysStableOnLongFarData) {
  std::mt19937_64 rng(2);
  std::normal_distribution<double> n01(0, 1);
  std::vector<Sequence> seqs;
  for (int s = 0; s < 5; ++s) {
    Sequence x(400, 2);
    for (int t = 0; t < 400; ++t) {
      const double c = (t / 100) % 2 ? 5.0 : -5.0;
      x(t, 0) = c + n01(rng);
      x(t, 1) = -c + n01(rng);
    }
    seqs.push_back(x);
  }
  auto g = GaussianHmm::init(seqs, 2, 1);
  ASSERT_TRUE(g.ok()) << g.error();
  auto rep = g->train(seqs, 50);
  ASSERT_TRUE(rep.ok()) << rep.error();
  for (std::size_t i = 1; i < rep->log_likelihood.size(); ++i)
    EXPECT_GE(rep->log_likelihood[i], rep->log_likelihood[i - 1] - 1e-6);
  EXPECT_NEAR(std::abs(g->mean(0, 0)), 5.0, 0.3);
  // Points 1000 standard deviations away: emissions underflow in linear
  // space, the log-space forward stays finite.
  Sequence far = Sequence::Constant(1'000'000, 2, 1000.0);
  auto ll = g->log_likelihood(far);
  ASSERT_TRUE(ll.ok());
  EXPECT_TRUE(std::isfinite(*ll));
  EXPECT_LT(*ll, -1e9);
}

TEST(GaussianHmm, SingleStateIsTheGaussianFit) {
  Sequence x(4, 1);
  x << 1, 2, 3, 4;
  auto g = GaussianHmm::init({x}, 1, 1);
  ASSERT_TRUE(g.ok());
  ASSERT_TRUE(g->train({x}, 5).ok());
  EXPECT_NEAR(g->mean(0, 0), 2.5, 1e-12);
  EXPECT_NEAR(g->var(0, 0), 1.25, 1e-12);
  EXPECT_NEAR(*g->log_likelihood(x), -0.5 * 4 * (std::log(2 * M_PI * 1.25) + 1.0), 1e-9);
}

TEST(ZScaler, RejectsConstantAndNanFeaturesWithNames) {
  Sequence a(3, 2);
  a << 1, 5, 2, 5, 3, 5;
  auto z = ZScaler::fit(std::vector<Sequence>{a}, {"force_x", "force_z"});
  ASSERT_FALSE(z.ok());
  EXPECT_NE(z.error().find("'force_z' is constant"), std::string::npos) << z.error();
  a(1, 1) = std::nan("");
  auto z2 = ZScaler::fit(std::vector<Sequence>{a}, {"force_x", "force_z"});
  ASSERT_FALSE(z2.ok());
  EXPECT_NE(z2.error().find("row 1, feature 'force_z'"), std::string::npos) << z2.error();
  a(1, 1) = 6;
  auto z3 = ZScaler::fit(std::vector<Sequence>{a}, {});
  ASSERT_TRUE(z3.ok());
  const Sequence y = z3->apply(a);
  EXPECT_NEAR(y.col(0).mean(), 0, 1e-12);
  EXPECT_NEAR(std::sqrt(y.col(0).squaredNorm() / 3), 1, 1e-12);
}

TEST(KMeans, SeparatesClustersAndRejectsTooFewDistinctPoints) {
  Sequence p(6, 1);
  p << 0, 0.1, 0.2, 10, 10.1, 10.2;
  auto km = KMeans::fit(p, 2, 1);
  ASSERT_TRUE(km.ok());
  EXPECT_NE(km->nearest(p.row(0)), km->nearest(p.row(5)));
  EXPECT_NEAR(km->centroids.col(0).minCoeff(), 0.1, 1e-12);
  Sequence c = Sequence::Constant(10, 2, 3.0);
  auto bad = KMeans::fit(c, 3, 1);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("distinct"), std::string::npos);
}

TEST(Dtw, HandComputedAndInvariantToTimeWarp) {
  Sequence a(3, 1), b(4, 1);
  a << 0, 1, 2;
  b << 0, 1, 1, 2;
  EXPECT_NEAR(dtw_distance(a, b), 0.0, 1e-12);  // b is a warped copy of a
  Sequence c(2, 1);
  c << 0, 3;
  // Best path (0,0)=0, (1,0)=|1-0|=1, (2,1)=|2-3|=1 (the diagonal (1,1)=2 is worse):
  // cost 2 over n+m = 5.
  EXPECT_NEAR(dtw_distance(a, c), 2.0 / 5.0, 1e-12);
  EXPECT_NEAR(dtw_distance(a, a, 0), 0.0, 1e-12);
  const Sequence r = resample(a, 5);
  EXPECT_NEAR(r(1, 0), 0.5, 1e-12);
  EXPECT_NEAR(r(4, 0), 2.0, 1e-12);
  // Shortening averages spans: 0..11 to 3 rows is the means of 0-3, 4-7, 8-11,
  // and a ripple faster than the new rate averages out instead of aliasing.
  Sequence ramp(12, 2);
  for (int i = 0; i < 12; ++i) ramp.row(i) << i, (i % 2 ? 1.0 : -1.0);
  const Sequence s = resample(ramp, 3);
  EXPECT_NEAR(s(0, 0), 1.5, 1e-12);
  EXPECT_NEAR(s(1, 0), 5.5, 1e-12);
  EXPECT_NEAR(s(2, 0), 9.5, 1e-12);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(s(i, 1), 0.0, 1e-12);
}

}  // namespace
}  // namespace dentar::training
