// The posterior's likelihoods and priors on synthetic records whose truth is
// known (fit_synthetic.h: the tests' own RK4, not the model code the
// likelihood runs).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <vector>
#include <limits>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "model/excitation.h"
#include "model/free_rocking.h"
#include "model/posterior.h"
#include "tests/model/fit_synthetic.h"
#include "tests/paper_blocks.h"

namespace rocklab {
namespace {

using model::BlockParams;
using test::SyntheticFree;

using ::rocklab::test::kBlock1;  // tests/paper_blocks.h

// The log posterior of the trajectory likelihood at noise sigma (rad),
// written here from `m` run from rest at the record's first sample and
// output at every sample: -ss / (2 sigma^2) - (n + 1) log sigma (the prior
// on sigma is 1 / sigma). The oracle of the likelihood's rest skip.
double LogPosteriorFromRest(model::RockingModel& m, const model::Forcing& table, const model::RockingRecord& rec,
                            double sigma) {
  m.Reset(rec.time_s.front(), 0.0, 0.0);
  double ss = 0.0;
  for (std::size_t k = 0; k < rec.time_s.size(); ++k) {
    m.AdvanceAhead(rec.time_s[k], table, std::numeric_limits<double>::infinity());
    ss += (m.state().theta - rec.theta[k]) * (m.state().theta - rec.theta[k]);
  }
  const double n = static_cast<double>(rec.time_s.size());
  return -0.5 * ss / (sigma * sigma) - (n + 1.0) * std::log(sigma);
}

model::PosteriorOptions Options(model::FitMethod method) {
  model::PosteriorOptions o;
  o.method = method;
  o.fit.geometry = model::FitGeometry{0.247, 1.0, 0.0};  // Table 1, block 1
  o.sampler.walkers = 32;
  o.sampler.steps = 4000;
  o.sampler.seed = 3;
  return o;
}

// Oracle: at the true parameters the trajectory residuals are the record's
// own noise, N(0, s^2) with s = 0.02 deg: sum r^2 / s^2 is chi-square with n
// degrees of freedom, n ~ 4500, so within 4 sqrt(2 n) of n (6 %). The
// likelihood's release level is the hold's mean (its noise over 150 samples,
// 3e-5 rad, moves theta by less than a tenth of the noise) and its release
// time is the features' plus t_offset, set here to the true release.
TEST(Posterior, TrajectoryChiSquareAtTheTruthIsTheNoise) {
  const double noise_rad = 0.02 * test::kDeg;
  const auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 9.0, 500, 0.02, 11);
  model::PosteriorOptions o = Options(model::FitMethod::kTrajectory);
  o.rtol = 1e-9;
  const model::PosteriorProblem problem(rec, o);
  ASSERT_EQ(problem.names(), (std::vector<std::string>{"alpha", "p", "mu", "sigma", "t_offset"}));
  const model::FreeRockingFeatures f = model::ExtractFreeRocking(rec, o.fit.features);
  ASSERT_TRUE(f.release_time_s.has_value());
  Eigen::VectorXd x(5);
  x << kBlock1.alpha, kBlock1.p, kBlock1.mu, noise_rad, 0.3 - *f.release_time_s;
  // log posterior = -log s (prior) - ss / (2 s^2) - n log s.
  const double n = problem.data_points();
  const double lp = problem.LogPosterior(x);
  const double ss = -2.0 * noise_rad * noise_rad * (lp + (n + 1.0) * std::log(noise_rad));
  EXPECT_NEAR(ss / (noise_rad * noise_rad) / n, 1.0, 4.0 * std::sqrt(2.0 / n));
  // Oracle: the CVODE model (rtol 1e-9) output at every sample. The
  // likelihood's RK4 (SampleFreeHousner) is within 1e-8 rad of it
  // (free_rocking_test), and the CVODE run output at every 10th sample
  // (20 ms) with Hermite interpolation between errs by at most h^4/384
  // max|d4 theta/dt4| (p^4 alpha = 53 rad/s^4: 2e-8 rad); either moves the
  // log posterior by at most sum |r_i| delta / s^2 (~0.2) in the worst case.
  model::PosteriorOptions every = o;
  every.free_rk4 = false;
  every.output_stride = 1;
  const model::PosteriorProblem per_sample(rec, every, &problem.point());
  EXPECT_NEAR(per_sample.LogPosterior(x), lp, 0.2);
  model::PosteriorOptions strided = every;
  strided.output_stride = 10;
  const model::PosteriorProblem cvode_strided(rec, strided, &problem.point());
  EXPECT_NEAR(per_sample.LogPosterior(x), cvode_strided.LogPosterior(x), 0.2);
  // A wrong alpha (by 2 %) leaves the record far from the model.
  x(0) *= 1.02;
  EXPECT_LT(problem.LogPosterior(x), lp - 100.0);
}

// Oracle: the order of the sampler's steps (on_step) against the cancel.
// A trajectory posterior of a 600 001-sample record: each step is 10 model
// runs over the record (tens of ms each). The cancel is asked 5 ms into the
// second step, from the cancel hook's own clock; the hook once was polled
// only after a whole step, so step 2 then ended (on_step(2)) before
// Cancelled. Now the model runs poll it every 256 samples (this thread) or
// see its flag (the other thread), and the thread that waits for the other
// polls it every 10 ms: step 2 never ends. The latency is printed (the
// figure: docs/reliability.md).
TEST(Posterior, ACancelStopsTheSamplerInsideAStep) {
  const auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 29.7, 20000, 0.02, 11);
  model::PosteriorOptions o = Options(model::FitMethod::kTrajectory);
  o.start_scan = 0;
  o.free_rk4 = false;  // the CVODE run, whose cancel checks are inside it
  o.sampler.walkers = 10;
  o.sampler.steps = 20;
  o.sampler.threads = 2;
  model::FitResult point;
  point.params = kBlock1;
  const model::PosteriorProblem problem(rec, o, &point);
  using Clock = std::chrono::steady_clock;
  std::vector<int> steps_done;
  Clock::time_point cancel_at = Clock::time_point::max();
  o.sampler.on_step = [&](int step, int) {
    steps_done.push_back(step);
    if (step == 1) cancel_at = Clock::now() + std::chrono::milliseconds(5);
  };
  o.sampler.cancelled = [&] { return Clock::now() >= cancel_at; };
  EXPECT_THROW((void)model::SamplePosterior(problem, o), model::Cancelled);
  const double latency_s = std::chrono::duration<double>(Clock::now() - cancel_at).count();
  std::printf("Cancelled %.1f ms after the cancel was asked\n", latency_s * 1e3);
  EXPECT_EQ(steps_done, std::vector<int>{1});
}

// Oracle: the truth of a synthetic record. The posterior's median is within
// 4 of its standard deviations of the truth for alpha, p and mu (a fixed
// seed; 4 sd keeps the check clear of the tails, and an error as large as
// the 152 standard errors would fail it), and the run converges.
TEST(Posterior, ImpactsPosteriorCoversTheTruthAndConverges) {
  const auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 9.0, 500, 0.02, 5);
  const model::PosteriorResult r = model::SamplePosterior(rec, Options(model::FitMethod::kImpacts));
  ASSERT_EQ(r.names.size(), 5u);
  const double truth[3] = {kBlock1.alpha, kBlock1.p, kBlock1.mu};
  for (int i = 0; i < 3; ++i) {
    const model::ParameterSummary& s = r.summary[static_cast<std::size_t>(i)];
    EXPECT_NEAR(s.median, truth[i], 4.0 * s.sd) << s.name;
    EXPECT_LT(s.ci95_lo, s.ci68_lo);
    EXPECT_LT(s.ci68_lo, s.median);
    EXPECT_LT(s.median, s.ci68_hi);
    EXPECT_LT(s.ci68_hi, s.ci95_hi);
  }
  // sigma: the record's noise, to 4 relative standard errors of a variance
  // from ~40 features (1 / sqrt(2 x 40) = 11 %; the features' standard
  // errors are the noise's through fits, so looser: 45 %).
  EXPECT_NEAR(r.summary[3].median / (0.02 * test::kDeg), 1.0, 0.45);
  EXPECT_TRUE(r.converged()) << (r.problems.empty() ? "" : r.problems[0]);
  EXPECT_EQ(r.draws.rows(), 32 * 2000);
  // The correlation matrix is one: symmetric, unit diagonal.
  for (int i = 0; i < 5; ++i) {
    EXPECT_NEAR(r.correlation(i, i), 1.0, 1e-12);
    for (int j = 0; j < 5; ++j) EXPECT_NEAR(r.correlation(i, j), r.correlation(j, i), 1e-12);
  }
  // Same seed, same draws (a short run, twice).
  model::PosteriorOptions shorter = Options(model::FitMethod::kImpacts);
  shorter.sampler.steps = 100;
  const model::PosteriorResult a = model::SamplePosterior(rec, shorter);
  const model::PosteriorResult b = model::SamplePosterior(rec, shorter);
  EXPECT_TRUE(a.draws == b.draws);
}

// The priors' support: the admissible band of alpha (b +- 1 cm), p within
// 30 % of the geometry's, mu in (0, 1], sigma within a decade of the noise.
TEST(Posterior, PriorSupport) {
  const auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 9.0, 500, 0.02, 5);
  const model::PosteriorProblem problem(rec, Options(model::FitMethod::kImpacts));
  const model::AlphaBand band = model::AdmissibleAlphaBand(model::FitGeometry{0.247, 1.0, 0.0}, 0.01);
  EXPECT_DOUBLE_EQ(problem.lower()(0), band.lo);
  EXPECT_DOUBLE_EQ(problem.upper()(0), band.hi);
  const double p_geo = model::RectangleBlock(0.247, 1.0, 0.0).p;
  EXPECT_DOUBLE_EQ(problem.lower()(1), 0.7 * p_geo);
  EXPECT_DOUBLE_EQ(problem.upper()(1), 1.3 * p_geo);
  EXPECT_DOUBLE_EQ(problem.upper()(2), 1.0);
  const Eigen::VectorXd x = problem.Start();
  ASSERT_TRUE(std::isfinite(problem.LogPosterior(x)));
  const double inf = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 5; ++i) {
    Eigen::VectorXd y = x;
    y(i) = problem.upper()(i) * 1.0001 + 1e-9;
    EXPECT_EQ(problem.LogPosterior(y), -inf) << i;
    y(i) = problem.lower()(i) - 1e-9 - std::abs(problem.lower()(i)) * 1e-4;
    EXPECT_EQ(problem.LogPosterior(y), -inf) << i;
  }
}

TEST(Posterior, RefusesWhatCannotGiveAPosterior) {
  const auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 9.0, 500, 0.02, 5);
  model::PosteriorOptions o = Options(model::FitMethod::kImpacts);
  o.fit.geometry.reset();
  EXPECT_THROW(model::PosteriorProblem(rec, o), std::invalid_argument);
  o = Options(model::FitMethod::kImpacts);
  o.priors.p_range = 1.5;
  EXPECT_THROW(model::PosteriorProblem(rec, o), std::invalid_argument);
  // A block at rest never rocks.
  auto still = rec;
  for (double& th : still.theta) th = 1e-5 * std::sin(th * 1e6);
  EXPECT_THROW(model::PosteriorProblem(still, Options(model::FitMethod::kImpacts)), model::FitError);
}

}  // namespace
}  // namespace rocklab

namespace rocklab {
namespace {

// The complex formulation's posterior samples l (as log10 l, reported as l).
// Oracle: eq. (10) tends to Housner's model as l -> 0 (docs/models.md), so
// at the truth of an RK4 (Housner) forced record and l = 1e-14 the
// residuals are the record's noise: chi-square ~ n within 4 sqrt(2/n).
TEST(Posterior, ComplexModelSamplesL) {
  const double noise_rad = 0.02 * test::kDeg;
  model::SineSpec spec;
  spec.amplitude_m = 0.010;
  spec.frequency_hz = 3.3;
  spec.duration_s = 2.0;
  spec.start_s = 0.2;
  const auto hanning = model::MakeHanningSine(spec);
  const auto rec = test::SyntheticForced(kBlock1, *hanning, 3.0, 250, 1000, 0.02, 7);
  model::PosteriorOptions o = Options(model::FitMethod::kTrajectory);
  o.model = model::ModelKind::kComplex;
  o.rtol = 1e-9;
  o.start_scan = 0;  // the complex model's runs are slow; the start is not under test
  const model::PosteriorProblem problem(rec, o);
  ASSERT_EQ(problem.names(), (std::vector<std::string>{"alpha", "p", "mu", "l", "sigma", "t_offset"}));
  EXPECT_DOUBLE_EQ(problem.lower()(3), -14.0);
  EXPECT_DOUBLE_EQ(problem.upper()(3), -8.0);
  Eigen::VectorXd x(6);
  x << kBlock1.alpha, kBlock1.p, kBlock1.mu, -14.0 + 1e-9, noise_rad, 0.0;
  EXPECT_NEAR(problem.ToReported(x)(3), 1e-14, 1e-22);
  const double n = problem.data_points();
  const double lp = problem.LogPosterior(x);
  ASSERT_TRUE(std::isfinite(lp));
  const double ss = -2.0 * noise_rad * noise_rad * (lp + (n + 1.0) * std::log(noise_rad));
  std::printf("complex at l = 1e-14: chi-square / n = %.4f (n = %.0f)\n", ss / (noise_rad * noise_rad) / n, n);
  EXPECT_NEAR(ss / (noise_rad * noise_rad) / n, 1.0, 4.0 * std::sqrt(2.0 / n));

  // Oracle: the block is at rest (theta = 0) until the table first leaves
  // the uplift band, so the likelihood's run started at rest where that
  // interval begins (PosteriorProblem's rest skip) is the run from the first
  // sample: the same log posterior, computed here from a model run from
  // t = 0 output at every sample. They differ only by CVODE's steps (the
  // rest steps before the uplift root, so where it places the root and the
  // step sequence after it, each at rtol 1e-9): within 1e-3 (measured
  // 8.5e-5); a run started after the uplift, or at rest too late, misses
  // the start of the motion and the log posterior by far more.
  model::ModelOptions mo;
  mo.rtol = o.rtol;
  mo.atol = 1e-10;
  mo.l = 1e-14 * std::pow(10.0, 1e-9);
  auto m = model::RockingModel::Create(model::ModelKind::kComplex, kBlock1, mo);
  // The table read as the likelihood reads it (FitOptions::table_interpolation).
  const model::SampledAcceleration table(rec.table_time_s, rec.table_accel_mps2, o.fit.table_interpolation);
  ASSERT_EQ(n, static_cast<double>(rec.time_s.size()));
  const double lp_all = LogPosteriorFromRest(*m, table, rec, noise_rad);
  std::printf("rest skip: log posterior %.9f against the run from t = 0 %.9f\n", lp, lp_all);
  EXPECT_NEAR(lp, lp_all, 1e-3);
}

// The rest skip where the table's samples stay inside the uplift band but
// its spline leaves it between two of them: a sine at 50 Hz sampling whose
// peaks, all at the middle of an interval, stand 0.5 % above g tan alpha
// while the samples either side stand 0.5 % below. Oracle: the same model
// run from t = 0 on the same reading, every sample: the likelihood, which
// starts its run at rest where the reading first leaves the band, must
// give the same log posterior (within 1e-3, as above). A skip that read the
// samples only (the chord's rule) starts after the first uplift and misses
// the motion (theta peaks at 1.7e-6 rad, 1700 of the 1e-9 rad sigma): its
// log posterior came out 2e7 below.
TEST(Posterior, RestSkipFollowsTheSplineBetweenSamples) {
  const double thr = 9.80665 * std::tan(kBlock1.alpha);
  const double h = 0.02, f = 1.0 / (4.0 * 5.5 * h);  // a peak at every 5.5 + 11 k steps
  const double amp = thr * 1.005;
  model::RockingRecord rec;
  rec.source = "spline-overshoot";
  for (int k = 0; k * h <= 0.8 + 1e-12; ++k) {
    rec.table_time_s.push_back(k * h);
    rec.table_accel_mps2.push_back(amp * std::sin(2.0 * M_PI * f * k * h));
  }
  double sample_max = 0.0;
  for (double a : rec.table_accel_mps2) sample_max = std::max(sample_max, std::abs(a));
  ASSERT_LT(sample_max, thr);
  const model::SampledAcceleration table(rec.table_time_s, rec.table_accel_mps2, model::Interpolation::kSpline);
  ASSERT_GT(table.TableAcceleration(5.5 * h), thr);

  model::ModelOptions mo;
  mo.rtol = 1e-10;
  mo.atol = 1e-12;
  auto m = model::RockingModel::Create(model::ModelKind::kHousner, kBlock1, mo);
  m->Reset(0.0, 0.0, 0.0);
  std::mt19937 rng(4);
  std::normal_distribution<double> noise(0.0, 1e-9);
  double peak = 0.0;
  for (int k = 0; k <= 350; ++k) {  // 0.7 s: the peaks at 0.11, 0.33 and 0.55 s
    const double t = k / 500.0;
    m->AdvanceAhead(t, table, std::numeric_limits<double>::infinity());
    peak = std::max(peak, std::abs(m->state().theta));
    rec.time_s.push_back(t);
    rec.theta.push_back(m->state().theta + noise(rng));
    rec.line.push_back(k + 2);
  }
  ASSERT_GT(peak, 1e-8) << "the spline's excursions must rock the block";

  model::PosteriorOptions o = Options(model::FitMethod::kTrajectory);
  o.rtol = 1e-10;
  o.output_stride = 1;
  o.start_scan = 0;
  ASSERT_EQ(o.fit.table_interpolation, model::Interpolation::kSpline);
  const model::PosteriorProblem problem(rec, o);
  Eigen::VectorXd x(5);
  const double sigma = 1e-9;
  x << kBlock1.alpha, kBlock1.p, kBlock1.mu, sigma, 0.0;
  ASSERT_EQ(problem.data_points(), static_cast<int>(rec.time_s.size()));
  const double lp = problem.LogPosterior(x);
  model::ModelOptions ao;
  ao.rtol = o.rtol;
  ao.atol = 1e-10;
  auto all = model::RockingModel::Create(model::ModelKind::kHousner, kBlock1, ao);
  const double lp_all = LogPosteriorFromRest(*all, table, rec, sigma);
  std::printf("spline overshoot: theta peak %.3g rad; log posterior %.6f against the run from t = 0 %.6f\n", peak,
              lp, lp_all);
  EXPECT_NEAR(lp, lp_all, 1e-3);
}

}  // namespace
}  // namespace rocklab

namespace rocklab {
namespace {

// The impacts features predicted by the closed-form chain with a
// restitution per impact (mu[j] at the j-th impact whose next peak is
// measured), in the likelihood's order t_0, r_0, t_1, ..., t_last; written
// here from QuarterTimeExact and NextPeak, independently of the
// likelihood's derivatives.
Eigen::VectorXd ChainPerImpact(const model::FreeRockingFeatures& f, double alpha, double p,
                               const Eigen::VectorXd& mu, double offset) {
  const std::size_t n = f.impact_time_s.size();
  Eigen::VectorXd y(2 * static_cast<Eigen::Index>(n) - 1);
  double r = *f.r0_rad;
  double t = *f.release_time_s + offset + model::QuarterTimeExact(alpha, p, r);
  for (std::size_t i = 0; i < n; ++i) {
    y(static_cast<Eigen::Index>(2 * i)) = t;
    if (i + 1 == n) break;
    r = model::NextPeak(alpha, mu(static_cast<Eigen::Index>(i)), r);
    y(static_cast<Eigen::Index>(2 * i + 1)) = r;
    t += 2.0 * model::QuarterTimeExact(alpha, p, r);
  }
  return y;
}

// Per-impact restitution mu_n ~ N(mu, sigma_mu^2), marginalised to first
// order. Oracle: the same marginal written densely here, the Gaussian of the
// features with covariance D + sigma_mu^2 G G^T, G the chain's derivatives
// by each impact's mu from central differences of ChainPerImpact (step
// 1e-6: relative error ~1e-10) and D the features' variances (their
// standard errors scaled by sigma / noise); log posterior = its log density
// - log sigma (the prior). Agreement within 1e-6 (the differences' error on
// a log density of order 1e3). And as sigma_mu -> 0 (1e-12) the log
// posterior is the one-mu likelihood's at the same point, within 1e-9.
TEST(Posterior, PerImpactRestitutionIsTheLinearisedMarginal) {
  const auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 9.0, 500, 0.02, 5);
  model::PosteriorOptions one = Options(model::FitMethod::kImpacts);
  one.start_scan = 0;
  const model::PosteriorProblem single(rec, one);
  model::PosteriorOptions o = one;
  o.priors.per_impact_mu = true;
  const model::PosteriorProblem scatter(rec, o, &single.point());
  ASSERT_EQ(scatter.names(), (std::vector<std::string>{"alpha", "p", "mu", "sigma_mu", "sigma", "t_offset"}));
  EXPECT_DOUBLE_EQ(scatter.upper()(3), 0.1);
  const model::FreeRockingFeatures f = model::ExtractFreeRocking(rec, o.fit.features);
  ASSERT_TRUE(f.release_time_s && f.r0_rad);
  const Eigen::VectorXd x5 = single.Start();
  Eigen::VectorXd x6(6);
  x6 << x5(0), x5(1), x5(2), 1e-12, x5(3), x5(4);
  EXPECT_NEAR(scatter.LogPosterior(x6), single.LogPosterior(x5), 1e-9);

  x6(3) = 0.02;
  const double alpha = x6(0), p = x6(1), sigma = x6(4), offset = x6(5);
  const std::size_t n = f.impact_time_s.size();
  const auto m = static_cast<Eigen::Index>(n - 1);
  ASSERT_GE(m, 10);
  Eigen::VectorXd obs(2 * m + 1), sd(2 * m + 1);
  for (std::size_t i = 0; i < n; ++i) {
    obs(static_cast<Eigen::Index>(2 * i)) = f.impact_time_s[i];
    sd(static_cast<Eigen::Index>(2 * i)) = sigma / f.noise_rad * f.impact_time_stderr_s[i];
    if (i + 1 == n) break;
    obs(static_cast<Eigen::Index>(2 * i + 1)) = f.peak_rad[i];
    sd(static_cast<Eigen::Index>(2 * i + 1)) = sigma / f.noise_rad * f.peak_stderr_rad[i];
  }
  const Eigen::VectorXd mu = Eigen::VectorXd::Constant(m, x6(2));
  const Eigen::VectorXd r = obs - ChainPerImpact(f, alpha, p, mu, offset);
  Eigen::MatrixXd g(2 * m + 1, m);
  for (Eigen::Index j = 0; j < m; ++j) {
    Eigen::VectorXd up = mu, down = mu;
    up(j) += 1e-6;
    down(j) -= 1e-6;
    g.col(j) = (ChainPerImpact(f, alpha, p, up, offset) - ChainPerImpact(f, alpha, p, down, offset)) / 2e-6;
  }
  Eigen::MatrixXd c = x6(3) * x6(3) * g * g.transpose();
  c.diagonal() += sd.array().square().matrix();
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(c);
  const double log_det = ldlt.vectorD().array().log().sum();
  const double oracle = -std::log(sigma) - 0.5 * r.dot(ldlt.solve(r)) - 0.5 * log_det;
  EXPECT_NEAR(scatter.LogPosterior(x6), oracle, 1e-6 * std::abs(oracle));
}

// Oracle: a record whose impacts keep scattered restitutions, mu_n drawn
// from N(0.937, 0.02^2) (seeded), made by the tests' RK4 with mu_n at
// impact n (7 s: ~25 impacts). The per-impact posterior holds the truth of
// sigma_mu and of the mean mu within 4 posterior sd (its sd includes the
// draw of the mu_n themselves; a short run, 16 x 1000, whose medians' Monte
// Carlo error, sd / sqrt(ESS) with ESS >= 100, is a tenth of that), and
// its sigma is the noise within 50 %. The one-mu likelihood of the same
// record, at the one-mu point fit (its walkers' start), cannot follow the
// peaks: its best sigma is over 3 times the noise. That sigma is
// noise sqrt(chi2 / n), chi2 the features' at sigma = noise, n of them:
// from the log posterior at noise and 2 noise, -log s - chi2 noise^2 /
// (2 s^2) - n log s + const, chi2 = ((n + 1) log 2 - (lp(noise) - lp(2 noise))) / 0.375.
TEST(Posterior, PerImpactRestitutionRecoversItsScatter) {
  const double sigma_mu = 0.02, noise_rad = 0.02 * test::kDeg;
  std::mt19937 rng(17);
  std::normal_distribution<double> draw(kBlock1.mu, sigma_mu);
  std::vector<double> mu_n(200);
  for (double& v : mu_n) v = std::min(draw(rng), 0.999);
  const auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 7.0, 500, 0.02, 5, "scattered", mu_n);
  model::PosteriorOptions o = Options(model::FitMethod::kImpacts);
  o.sampler.walkers = 16;
  o.sampler.steps = 1000;
  o.start_scan = 0;
  o.priors.per_impact_mu = true;
  const model::PosteriorProblem problem(rec, o);
  const model::PosteriorResult r = model::SamplePosterior(problem, o);
  ASSERT_EQ(r.names[3], "sigma_mu");
  model::PosteriorOptions one = o;
  one.priors.per_impact_mu = false;
  const model::PosteriorProblem single(rec, one, &problem.point());
  Eigen::VectorXd x = single.Start();
  const double noise = problem.point().features.noise_rad, n = single.data_points();
  x(3) = noise;
  const double lp1 = single.LogPosterior(x);
  x(3) = 2.0 * noise;
  const double chi2 = ((n + 1.0) * std::log(2.0) - (lp1 - single.LogPosterior(x))) / 0.375;
  const double one_mu_sigma = std::sqrt(chi2 / n);
  std::printf("per-impact: sigma_mu %.4f +- %.4f (ESS %.0f), mu %.5f +- %.5f, sigma / noise %.2f (sampler %.2f s); "
              "one mu: best sigma / noise %.2f\n",
              r.summary[3].median, r.summary[3].sd, r.summary[3].ess, r.summary[2].median, r.summary[2].sd,
              r.summary[4].median / noise_rad, r.runtime_s, one_mu_sigma);
  for (int i = 0; i < 6; ++i) EXPECT_GE(r.summary[static_cast<std::size_t>(i)].ess, 100.0) << r.names[static_cast<std::size_t>(i)];
  EXPECT_NEAR(r.summary[3].median, sigma_mu, 4.0 * r.summary[3].sd);
  EXPECT_NEAR(r.summary[2].median, kBlock1.mu, 4.0 * r.summary[2].sd);
  EXPECT_NEAR(r.summary[0].median, kBlock1.alpha, 4.0 * r.summary[0].sd);
  EXPECT_NEAR(r.summary[4].median / noise_rad, 1.0, 0.5);
  EXPECT_GT(one_mu_sigma, 3.0);
}

}  // namespace
}  // namespace rocklab
