// The ensemble sampler and its diagnostics against exact answers: a
// linear-Gaussian posterior in closed form, an AR(1) series's
// autocorrelation time, R-hat of chains with known means.
#include <cmath>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "model/ensemble_sampler.h"

namespace rocklab::model {
namespace {

// y = A x + e, e ~ N(0, s^2 I), prior x ~ N(m0, P0): the posterior is
// Gaussian with C = (A^T A / s^2 + P0^-1)^-1, m = C (A^T y / s^2 + P0^-1 m0).
struct LinearGaussian {
  Eigen::MatrixXd a;
  Eigen::VectorXd y;
  double s{};
  Eigen::VectorXd m0;
  Eigen::MatrixXd p0_inv;
  double operator()(const Eigen::VectorXd& x) const {
    const Eigen::VectorXd r = y - a * x;
    const Eigen::VectorXd d = x - m0;
    return -0.5 * r.squaredNorm() / (s * s) - 0.5 * d.dot(p0_inv * d);
  }
  Eigen::MatrixXd Cov() const { return (a.transpose() * a / (s * s) + p0_inv).inverse(); }
  Eigen::VectorXd Mean() const { return Cov() * (a.transpose() * y / (s * s) + p0_inv * m0); }
};

LinearGaussian Toy() {
  LinearGaussian g;
  // A line with a quadratic term sampled at 6 points: strongly correlated
  // coefficients (|rho| up to ~0.9), as alpha and p are.
  const int n = 6;
  g.a.resize(n, 3);
  g.y.resize(n);
  const double yv[n] = {1.1, 1.9, 3.2, 3.9, 5.3, 5.8};
  for (int i = 0; i < n; ++i) {
    const double t = 0.2 * i;
    g.a.row(i) << 1.0, t, t * t;
    g.y(i) = yv[i];
  }
  g.s = 0.2;
  g.m0 = Eigen::Vector3d(0.0, 0.0, 0.0);
  g.p0_inv = Eigen::Matrix3d::Identity() / 100.0;
  return g;
}

Eigen::MatrixXd Ball(const Eigen::VectorXd& c, int walkers, double scale, std::uint64_t seed) {
  RandomStream rng(seed, 1000);
  Eigen::MatrixXd m(walkers, c.size());
  for (int k = 0; k < walkers; ++k) {
    for (Eigen::Index i = 0; i < c.size(); ++i) m(k, i) = c(i) + scale * rng.Normal();
  }
  return m;
}

// Oracle: the closed-form posterior of a linear-Gaussian model. The sample
// mean's Monte Carlo standard error is sd / sqrt(ESS), a variance's about
// var sqrt(2 / ESS), a correlation's (1 - rho^2) / sqrt(ESS); each is asked
// to within 4 of them (a fixed seed: the figure is deterministic, and 4
// standard errors keep it clear of the tail).
TEST(EnsembleSampler, LinearGaussianPosteriorWithinMonteCarloError) {
  const LinearGaussian g = Toy();
  EnsembleOptions o;
  o.walkers = 32;
  o.steps = 4000;
  o.seed = 7;
  o.threads = 2;
  const EnsembleRun run = RunEnsemble(g, Ball(Eigen::Vector3d(1, 1, 1), o.walkers, 0.1, 3), o);
  const int burn = o.steps / 2;
  const EnsembleDiagnostics d = Diagnose(run, burn);
  const Eigen::MatrixXd kept = run.chain.bottomRows(static_cast<Eigen::Index>(o.steps - burn) * o.walkers);
  const Eigen::RowVectorXd mean = kept.colwise().mean();
  const Eigen::MatrixXd c = kept.rowwise() - mean;
  const Eigen::MatrixXd cov = c.transpose() * c / static_cast<double>(kept.rows() - 1);
  const Eigen::VectorXd m_true = g.Mean();
  const Eigen::MatrixXd c_true = g.Cov();
  for (int i = 0; i < 3; ++i) {
    const double ess = d.ess[static_cast<std::size_t>(i)];
    ASSERT_GT(ess, 1000.0) << i;
    const double sd = std::sqrt(c_true(i, i));
    EXPECT_NEAR(mean(i), m_true(i), 4.0 * sd / std::sqrt(ess)) << "mean " << i;
    EXPECT_NEAR(cov(i, i) / c_true(i, i), 1.0, 4.0 * std::sqrt(2.0 / ess)) << "variance " << i;
    for (int j = 0; j < i; ++j) {
      const double rho_true = c_true(i, j) / std::sqrt(c_true(i, i) * c_true(j, j));
      const double rho = cov(i, j) / std::sqrt(cov(i, i) * cov(j, j));
      EXPECT_NEAR(rho, rho_true, 4.0 * (1.0 - rho_true * rho_true) / std::sqrt(std::min(ess, d.ess[j])))
          << "correlation " << i << "," << j;
    }
    // Split R-hat of walkers that mix: the split chains' means scatter by
    // their own Monte Carlo error, so R-hat^2 - 1 ~ 2 tau / kept, R-hat ~
    // 1 + tau / kept (1.015 here); three times that excess bounds it.
    const double tau = d.tau[static_cast<std::size_t>(i)];
    EXPECT_LT(d.rhat[static_cast<std::size_t>(i)], 1.0 + 3.0 * tau / d.kept_steps) << i;
  }
  // Goodman and Weare report acceptance fractions of 0.2-0.5 for a = 2 on
  // Gaussians of a few dimensions.
  EXPECT_GT(d.acceptance, 0.2);
  EXPECT_LT(d.acceptance, 0.8);
  EXPECT_TRUE(ConvergenceProblems(d, ConvergenceRule{}, {"a", "b", "c"}).empty());
}

// Oracle: the stretch move reads only its own walker's stream and the other
// half's positions, so the chain cannot depend on the threads.
TEST(EnsembleSampler, SameSeedSameDrawsForOneAndTwoThreads) {
  const LinearGaussian g = Toy();
  EnsembleOptions o;
  o.walkers = 16;
  o.steps = 300;
  o.seed = 42;
  const Eigen::MatrixXd start = Ball(Eigen::Vector3d(1, 1, 1), o.walkers, 0.1, 5);
  o.threads = 1;
  const EnsembleRun one = RunEnsemble(g, start, o);
  o.threads = 2;
  const EnsembleRun two = RunEnsemble(g, start, o);
  o.threads = 5;
  const EnsembleRun five = RunEnsemble(g, start, o);
  EXPECT_EQ(one.threads, 1);
  EXPECT_EQ(two.threads, 2);
  EXPECT_TRUE(one.chain == two.chain);
  EXPECT_TRUE(one.chain == five.chain);
  EXPECT_TRUE(one.log_density == two.log_density);
  EXPECT_EQ(one.accepted, two.accepted);
  o.seed = 43;
  const EnsembleRun other = RunEnsemble(g, start, o);
  EXPECT_FALSE(one.chain == other.chain);
}

// Oracle: an AR(1) series x_t = phi x_{t-1} + e_t has rho(t) = phi^t and
// tau = (1 + phi) / (1 - phi) (19 for phi = 0.9). With 32 x 20000 steps and
// Sokal's window (M ~ 5 tau) the estimate's relative standard error is
// about sqrt(2 (2M + 1) / N) = 2.4 %: 10 % is four of them.
TEST(EnsembleDiagnostics, AutocorrelationTimeOfAr1) {
  const double phi = 0.9;
  std::vector<std::vector<double>> walkers;
  for (int w = 0; w < 32; ++w) {
    RandomStream rng(11, static_cast<std::uint64_t>(w));
    std::vector<double> x(20000);
    double v = rng.Normal() / std::sqrt(1.0 - phi * phi);  // stationary start
    for (double& xi : x) {
      v = phi * v + rng.Normal();
      xi = v;
    }
    walkers.push_back(std::move(x));
  }
  EXPECT_NEAR(IntegratedAutocorrTime(walkers), (1 + phi) / (1 - phi), 0.1 * 19.0);
  // White noise: tau = 1 (same error budget, M ~ 5).
  for (auto& x : walkers) {
    for (std::size_t i = x.size() - 1; i > 0; --i) x[i] = x[i] - phi * x[i - 1];
  }
  EXPECT_NEAR(IntegratedAutocorrTime(walkers), 1.0, 0.05);
}

// Oracle: BDA3's R-hat by hand. Half the walkers N(0, 1), half N(3, 1):
// split into 2W chains of n steps, W -> 1 and B / n -> var of the chain
// means = 2.25 x 2W / (2W - 1), so R-hat -> sqrt((n-1)/n + 2.25 x 64/63).
// Same distribution everywhere: R-hat -> 1 (its excess ~ 1/N_eff).
TEST(EnsembleDiagnostics, SplitRhatOfShiftedChains) {
  std::vector<std::vector<double>> same, shifted;
  for (int w = 0; w < 32; ++w) {
    RandomStream rng(5, static_cast<std::uint64_t>(w));
    std::vector<double> x(4000);
    for (double& xi : x) xi = rng.Normal();
    same.push_back(x);
    if (w % 2 == 1) {
      for (double& xi : x) xi += 3.0;
    }
    shifted.push_back(x);
  }
  EXPECT_NEAR(SplitRhat(same), 1.0, 2e-3);
  const double n = 2000.0;
  // Relative error of the sample mean of the B term: the chain means
  // scatter by 1/sqrt(n) around 0 and 3, a ~1 % effect on B.
  EXPECT_NEAR(SplitRhat(shifted), std::sqrt((n - 1) / n + 2.25 * 64.0 / 63.0), 0.02);
  // A trend within every walker is what the split catches.
  std::vector<std::vector<double>> trend = same;
  for (auto& x : trend) {
    for (std::size_t i = 0; i < x.size(); ++i) x[i] += 2.0 * static_cast<double>(i) / static_cast<double>(x.size());
  }
  EXPECT_GT(SplitRhat(trend), 1.1);
}

// A run far too short for its autocorrelation time fails the rule, naming
// the parameter.
TEST(EnsembleDiagnostics, ShortRunIsNotConverged) {
  const LinearGaussian g = Toy();
  EnsembleOptions o;
  o.walkers = 8;
  o.steps = 40;
  o.seed = 1;
  const EnsembleRun run = RunEnsemble(g, Ball(Eigen::Vector3d(5, -5, 5), o.walkers, 0.01, 2), o);
  const EnsembleDiagnostics d = Diagnose(run, 20);
  const std::vector<std::string> problems = ConvergenceProblems(d, ConvergenceRule{}, {"a", "b", "c"});
  ASSERT_FALSE(problems.empty());
  bool named = false;
  for (const std::string& p : problems) named = named || p.find("effective sample size of a") != std::string::npos;
  EXPECT_TRUE(named);
}

TEST(EnsembleSampler, RejectsBadOptionsAndStarts) {
  const LinearGaussian g = Toy();
  EnsembleOptions o;
  o.walkers = 4;  // < 2 x 3
  EXPECT_THROW(RunEnsemble(g, Eigen::MatrixXd::Zero(4, 3), o), std::invalid_argument);
  o.walkers = 8;
  EXPECT_THROW(RunEnsemble(g, Eigen::MatrixXd::Zero(6, 3), o), std::invalid_argument);
  const auto outside = [](const Eigen::VectorXd& x) { return x(0) > 0 ? 0.0 : -INFINITY; };
  EXPECT_THROW(RunEnsemble(outside, Eigen::MatrixXd::Zero(8, 3), o), std::invalid_argument);
}

}  // namespace
}  // namespace rocklab::model
