// Parameter identification (model/fit.h) and record reading (model/test_record.h).
// Oracle throughout: records synthesised with known (alpha, p, mu) by the
// tests' RK4 reference integrator of Housner's equation (fit_synthetic.h,
// rk4_reference.h: not rocklab's model code, which the fits use), sampled
// like a test, with seeded Gaussian noise of 0.02 degrees (a lab's figure).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "model/fit.h"
#include "model/fit_impl.h"
#include "model/test_record.h"
#include "rocklab/block_state_t.hpp"
#include "rocklab/table_state_t.hpp"
#include "tests/model/fit_synthetic.h"
#include "tests/scratch.h"
#include "tests/paper_blocks.h"

namespace rocklab::test {
namespace {

using model::BlockParams;
using model::FitError;
using model::FitOptions;
using model::RecordError;

// Table 2 block 1 (docs/errata.md item 10: p = 3.884 rad/s), geometry of Table 1 row 1.
using ::rocklab::test::kBlock1;  // tests/paper_blocks.h
const model::FitGeometry kBlock1Geometry{0.247, 1.0, 0.0};

std::string TempPath(const std::string& name) {
  const std::filesystem::path dir = test::ScratchDir("fit_test");
  return (dir / name).string();
}

// Oracle: the model's own impact events (CVODE root finding, ~1e-10 s). On
// a noise-free 500 Hz record the two-sided crossing fit must find them to a
// thousandth of the 2 ms sample period (measured: 3.5e-7 s).
// The impact times of `f` against the model's own events (block 1 released
// from 0.6 alpha at 0.3 s, run to end_s), to 2e-6 s each.
void ExpectModelImpactTimes(const model::FreeRockingFeatures& f, double end_s) {
  model::ModelOptions mo;
  mo.rtol = 1e-10;
  auto m = model::RockingModel::Create(model::ModelKind::kHousner, kBlock1, mo);
  const model::NoTableMotion zero;
  m->Reset(0.3, 0.6 * kBlock1.alpha, 0.0);
  m->AdvanceTo(end_s, zero);
  std::size_t i = 0;
  for (const auto& e : m->events()) {
    if (e.kind != model::EventKind::kImpact || i >= f.impact_time_s.size()) continue;
    EXPECT_NEAR(f.impact_time_s[i], e.time_s, 2e-6) << "impact " << i + 1;
    ++i;
  }
}

TEST(FitFeatures, ImpactTimesMatchTheModelEventsWithoutNoise) {
  const auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 8.0, 500, 0.0, 1);
  const auto f = model::ExtractFreeRocking(rec, {});
  ASSERT_GE(f.impact_time_s.size(), 20u);
  ExpectModelImpactTimes(f, 8.3);
  // The hold makes the release identifiable; r0 is the hold level (1e-6 rad:
  // the onset fit averages 150 noise-free samples).
  ASSERT_TRUE(f.release_time_s && f.r0_rad);
  EXPECT_NEAR(*f.r0_rad, 0.6 * kBlock1.alpha, 1e-6);
}

// Oracle: golden section's own contract on a parabola (minimum at 0.3).
// The search of a crossing time over a window of a million samples calls
// its cost function at most kMaxCrossingGridPoints + 2 + 60 times (grid,
// golden section): each call costs O(window), so the fit's cost is linear
// in the samples; 8 calls a sample (8e6 here) made it quadratic.
TEST(FitFeatures, GridSearchCostIsBoundedWhateverTheSampleRate) {
  int calls = 0;
  const auto f = [&calls](double x) {
    ++calls;
    return (x - 0.3) * (x - 0.3);
  };
  const double x = model::fit_detail::GridThenGolden(f, 0.0, 1.0, 1e-6, 8, model::fit_detail::kMaxCrossingGridPoints);
  EXPECT_NEAR(x, 0.3, 1e-9);
  EXPECT_LE(calls, model::fit_detail::kMaxCrossingGridPoints + 62);
}

// Oracle: the model's own impact events, as above, on a 50 kHz record
// (315 000 samples), where the capped grid is coarser than a sample: the
// crossings are still found to 2e-6 s and the hold level to 1e-6 rad.
TEST(FitFeatures, AHighRateRecordKeepsItsImpactTimes) {
  const auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 6.0, 50000, 0.0, 1);
  int polls = 0;
  const auto f = model::ExtractFreeRocking(rec, {}, [&polls] { return ++polls < 0; });
  ASSERT_GE(f.impact_time_s.size(), 8u);
  EXPECT_GE(polls, static_cast<int>(f.impact_time_s.size()));  // the cancel hook is polled along the scan
  ExpectModelImpactTimes(f, 6.3);
  ASSERT_TRUE(f.release_time_s && f.r0_rad);
  EXPECT_NEAR(*f.r0_rad, 0.6 * kBlock1.alpha, 1e-6);
}

// Oracle: the contract of FitOptions::cancelled: a hook that says stop
// ends the fit with model::Cancelled (not a FitError), after the poll that
// said so.
TEST(FitImpacts, ACancelHookStopsTheFit) {
  const auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 8.0, 500, 0.02, 1);
  FitOptions o;
  int polls = 0;
  o.cancelled = [&polls] { return ++polls >= 3; };
  EXPECT_THROW((void)model::FitImpacts(rec, o), model::Cancelled);
  EXPECT_EQ(polls, 3);
  o.cancelled = [] { return false; };
  EXPECT_NO_THROW((void)model::FitImpacts(rec, o));
}

// The acceptance test: theta0 = 0.6 alpha, 500 Hz, 0.02 deg noise,
// three seeds, records from the RK4 reference (fit_synthetic.h). Measured
// (the printed lines): alpha -0.099, -0.311, -0.001 %; p +0.071,
// +0.172, -0.053 %; mu -3.3e-5, +5.1e-5, -4.2e-5. Tolerances 3x the worst:
// alpha 0.9 %, p 0.5 %, mu 1.5e-4 (the earlier 1 % and 0.005 were 3x
// and 100x). The release time is only known to ~4 ms at this noise, so the
// release pair is not used (a warning says so) and the fit rests on 20
// inter-impact half intervals.
TEST(FitImpacts, RecoversBlock1FromNoisyFreeRocking) {
  for (std::uint32_t seed : {1u, 2u, 3u}) {
    const auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 8.0, 500, 0.02, seed);
    FitOptions o;
    o.geometry = kBlock1Geometry;
    const auto r = model::FitImpacts(rec, o);
    std::printf("seed %u: alpha %+.4f %%, p %+.4f %%, mu %+.6f\n", seed, 100 * (r.params.alpha / kBlock1.alpha - 1),
                100 * (r.params.p / kBlock1.p - 1), r.params.mu - kBlock1.mu);
    EXPECT_NEAR(r.params.alpha / kBlock1.alpha, 1.0, 0.009) << "seed " << seed;
    EXPECT_NEAR(r.params.p / kBlock1.p, 1.0, 0.005) << "seed " << seed;
    EXPECT_NEAR(r.params.mu, kBlock1.mu, 1.5e-4) << "seed " << seed;
    EXPECT_GE(r.impacts.size(), 15u);
    // The standard errors must cover the actual error (3 sigma).
    EXPECT_LT(std::abs(r.params.alpha - kBlock1.alpha), 3 * r.alpha_stderr) << "seed " << seed;
    EXPECT_LT(std::abs(r.params.p - kBlock1.p), 3 * r.p_stderr) << "seed " << seed;
    // The paper's conclusion (different sets give the same response): for
    // r << alpha, T ~ sqrt(2 r / alpha) / p depends on alpha p^2 only, so the
    // estimates are strongly anti-correlated (measured -0.986).
    EXPECT_LT(r.alpha_p_correlation, -0.95) << "seed " << seed;
    EXPECT_GT(r.alpha_p_correlation, -1.0);
  }
}

// Eq. (13) against the exact quarter time on a stocky block: block 4
// (docs/errata.md item 9: alpha = 0.31, p = 5.21 rad/s), released from 0.6 alpha,
// noise-free, inter-impact pairs only. The exact form recovers the truth
// (to 0.01 %, measured 0.009 %); the slender form over-estimates alpha by
// +1.36 % and under-estimates p by -1.39 %: that is its bias, asserted to
// +-0.1 % (the exact fit's own residual error is 0.01 %).
TEST(FitImpacts, SlenderQuarterTimeBiasesAStockyBlock) {
  const BlockParams block4{0.31, 5.21, 0.926};
  const auto rec = SyntheticFree(block4, 0.6 * block4.alpha, 0.3, 6.0, 500, 0.0, 1);
  FitOptions o;
  o.use_release = false;
  const auto exact = model::FitImpacts(rec, o);
  o.quarter_time = model::QuarterTime::kSlender;
  const auto slender = model::FitImpacts(rec, o);
  EXPECT_NEAR(exact.params.alpha / block4.alpha, 1.0, 1e-3);
  EXPECT_NEAR(exact.params.p / block4.p, 1.0, 1e-3);
  EXPECT_NEAR(slender.params.alpha / block4.alpha - 1.0, +0.0136, 1e-3);
  EXPECT_NEAR(slender.params.p / block4.p - 1.0, -0.0139, 1e-3);
  EXPECT_GT(slender.rms_residual, 2 * exact.rms_residual);
}

// The trajectory method on a synthetic forced test: block 1 from rest on a
// Hanning sine (10 mm, 3.3 Hz, 4 s from 0.5 s), 7 s of theta at 250 Hz with
// 0.02 deg noise, table acceleration at 500 Hz. Start from the geometry of
// Table 1 row 1 (alpha 0.242, p 3.780, mu 0.914: 3 %, 3 %, 2.5 % off).
// Measured (printed; record from the RK4 reference): alpha -0.0175 %,
// p +0.0042 %, mu -0.0038 %. Tolerances 3x: 0.05 %, 0.012 %, 0.011 %.
TEST(FitTrajectory, RecoversBlock1FromAForcedTest) {
  const auto ex = model::ParseExcitation("hanning:amp=0.010,freq=3.3,duration=4,start=0.5");
  const auto rec = SyntheticForced(kBlock1, *ex, 7.0, 250, 500, 0.02, 7);
  FitOptions o;
  o.geometry = kBlock1Geometry;
  int progress_lines = 0;
  o.on_progress = [&](const model::FitProgress&) { ++progress_lines; };
  const auto r = model::FitTrajectory(rec, o);
  std::printf("trajectory: alpha %+.4f %%, p %+.4f %%, mu %+.4f %%, rms %.4e rad\n",
              100 * (r.params.alpha / kBlock1.alpha - 1), 100 * (r.params.p / kBlock1.p - 1),
              100 * (r.params.mu / kBlock1.mu - 1), r.rms_residual);
  EXPECT_TRUE(r.forced);
  EXPECT_NEAR(r.params.alpha / kBlock1.alpha, 1.0, 5e-4);
  EXPECT_NEAR(r.params.p / kBlock1.p, 1.0, 1.2e-4);
  EXPECT_NEAR(r.params.mu / kBlock1.mu, 1.0, 1.1e-4);
  // The residual is the noise (0.02 deg = 3.49e-4 rad) when the model fits.
  EXPECT_NEAR(r.rms_residual, 0.02 * kDeg, 0.1 * 0.02 * kDeg);
  EXPECT_NEAR(r.residual_to_noise, 1.0, 0.1);
  EXPECT_TRUE(r.converged);
  EXPECT_GT(progress_lines, 0);
}

// Oracle: the record's truth (block 1, driven by the exact excitation) and
// the same fit on the table sampled at 20 kHz, whose spline is the exact
// motion to 5/384 h^4 max|a''''| (1e-12 of it). The same forced test
// (8 mm, 3.3 Hz Hanning, 0.02 deg noise at 250 Hz), fitted from the truth
// (the reading is tested, not the search), with the table record at
// 500 Hz: the fit reads its spline, not its chord, so it lands where the
// 20 kHz fit does, within 0.1 of alpha's and mu's standard errors (the
// chord put alpha 0.95 of them low; measured with the spline 0.02 and
// 0.1), and does not warn. At 50 Hz the two cubics through the samples
// differ by more than the noise moves the fit, which it says and puts in
// its standard errors: alpha within 3 of them of the truth. Measured
// values printed.
TEST(FitTrajectory, ReadsTheTableRecordAsASplineAndSaysWhenItsSamplingMovesTheFit) {
  const auto ex = model::ParseExcitation("hanning:amp=0.008,freq=3.3,duration=4,start=0.5");
  std::vector<model::FitResult> fits;
  for (double table_hz : {20000.0, 500.0, 50.0}) {
    const auto rec = SyntheticForced(kBlock1, *ex, 7.0, 250, table_hz, 0.02, 7);
    FitOptions o;
    o.geometry = kBlock1Geometry;
    o.start = kBlock1;
    o.starts = 0;
    o.table_interpolation = model::Interpolation::kSpline;
    const auto r = model::FitTrajectory(rec, o);
    bool said = false;
    for (const auto& w : r.warnings) said = said || w.find("table record's sampling") != std::string::npos;
    std::printf("table at %g Hz: alpha %.7f (truth %.6f, off by %.2f stderr of %.2e), mu %.6f, shift %.2e rad, "
                "theta %.2e rad rms, warned %d\n",
                table_hz, r.params.alpha, kBlock1.alpha, (r.params.alpha - kBlock1.alpha) / r.alpha_stderr,
                r.alpha_stderr, r.params.mu, r.table_interpolation_shift.alpha, r.table_interpolation_rad, said);
    ASSERT_TRUE(r.converged) << table_hz;
    EXPECT_LT(std::abs(r.params.alpha - kBlock1.alpha), 3 * r.alpha_stderr) << table_hz;
    EXPECT_EQ(said, table_hz < 100) << table_hz;
    fits.push_back(r);
  }
  EXPECT_LT(std::abs(fits[1].params.alpha - fits[0].params.alpha), 0.1 * fits[0].alpha_stderr);
  EXPECT_LT(std::abs(fits[1].params.mu - fits[0].params.mu), 0.2 * fits[0].mu_stderr);
}

// Oracle: the sensitivities of the tests' RK4 reference (fixed step, so
// theta is a smooth function of the parameters, with no adaptive error that
// changes unevenly with them), driven by the same spline of the table
// samples, by central differences of relative step 1e-4: s^2 (J^T J)^-1
// with the fit's s^2 must be the fit's covariance. The record is the
// coverage bench's forced seed 3053 (docs/fit_coverage.md), where the
// search's Jacobian (CVODE rtol 1e-8, step 1e-5) made p's column 3.4
// times its size and p's stated error 3.2 times too small. Tolerance 3 %:
// RK4 at h = 1e-4 s against CVODE at 1e-10 (measured on block 1's record:
// 0.05 %), steps 1e-6 to 1e-3 agree within 2 %.
TEST(FitTrajectory, CovarianceIsTheModelsSensitivityNotTheIntegratorsError) {
  const BlockParams truth{0.2360142342, 3.7785824603, 0.9045964042};
  const auto ex = model::ParseExcitation("hanning:amp=0.009862,freq=3.3,duration=4,start=0.5");
  const auto rec = SyntheticForced(truth, *ex, 6.0, 250, 1000, 0.02, 3053);
  FitOptions o;
  o.start = truth;
  o.starts = 0;  // the covariance is tested, not the search
  o.table_interpolation = model::Interpolation::kSpline;
  const auto r = model::FitTrajectory(rec, o);
  ASSERT_TRUE(r.converged);
  const model::SampledAcceleration spline(rec.table_time_s, rec.table_accel_mps2, model::Interpolation::kSpline);
  const Eigen::Vector3d x(r.params.alpha, r.params.p, r.params.mu);
  auto theta = [&](const Eigen::Vector3d& y) {
    rk4::RefOptions ro;
    ro.h_s = 1e-4;
    ro.sample_rate_hz = 250;
    const auto run = rk4::Reference({y(0), y(1), y(2)}, [&spline](double t, bool) { return spline.TableAcceleration(t); },
                                    ro).Run(rec.time_s.back());
    Eigen::VectorXd v(static_cast<Eigen::Index>(rec.size()));
    for (std::size_t k = 0; k < rec.size(); ++k) v(static_cast<Eigen::Index>(k)) = run.sample_theta.at(k);
    return v;
  };
  Eigen::MatrixXd jac(static_cast<Eigen::Index>(rec.size()), 3);
  for (int i = 0; i < 3; ++i) {
    Eigen::Vector3d h = Eigen::Vector3d::Zero();
    h(i) = 1e-4 * x(i);
    jac.col(i) = (theta(x + h) - theta(x - h)) / (2 * h(i));
  }
  const double n = static_cast<double>(r.residuals);
  const double s2 = r.rms_residual * r.rms_residual * n / (n - 3);
  const Eigen::Matrix3d oracle = s2 * (jac.transpose() * jac).inverse();
  const char* names[3] = {"alpha", "p", "mu"};
  for (int i = 0; i < 3; ++i) {
    const double stated = std::sqrt(r.covariance(i, i)), expected = std::sqrt(oracle(i, i));
    std::printf("%s: stated %.4e, reference %.4e, error %.2f stated\n", names[i], stated, expected,
                (x(i) - (i == 0 ? truth.alpha : i == 1 ? truth.p : truth.mu)) / stated);
    EXPECT_NEAR(stated / expected, 1.0, 0.03) << names[i];
  }
}

// --- what a fit knows: noise, gaps, convergence, standard errors ----------

// Oracle: the seeded noise itself (0.02 deg = 3.49e-4 rad). The estimate
// uses only the record's second differences, so it must find the noise
// whatever the motion (free, forced) and with samples missing (0.1 % at
// random and a block of 20, whose unequal steps are left out). Tolerance
// 8 %: the median of |d2| over ~4000 correlated differences has a relative
// standard error of about 2.5 % (measured spread over seeds 1-3: see the
// printed values), 3 of them.
TEST(FitNoise, EstimateIsTheSeededNoiseWithAndWithoutGaps) {
  const double sigma = 0.02 * kDeg;
  for (std::uint32_t seed : {1u, 2u, 3u}) {
    auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 8.0, 500, 0.02, seed);
    const double full = model::EstimateThetaNoise(rec);
    DropSamples(rec, 0.001, seed, 1000, 20);
    const double gapped = model::EstimateThetaNoise(rec);
    std::printf("seed %u: noise %.4e (full) %.4e (gaps) rad, truth %.4e\n", seed, full, gapped, sigma);
    EXPECT_NEAR(full / sigma, 1.0, 0.08) << "seed " << seed;
    EXPECT_NEAR(gapped / sigma, 1.0, 0.08) << "seed " << seed;
  }
  // Noise-free: the motion alone (theta'' dt^2, about 1e-5 rad) is far below
  // the noise levels of interest.
  const auto clean = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 8.0, 500, 0.0, 1);
  EXPECT_LT(model::EstimateThetaNoise(clean), 1e-5);
}

// A record with dropped samples (the rig simulator's
// default 0.1 %) must be fitted. Oracle: the synthetic truth, to the same
// 1 % / 0.005 as the gap-free acceptance test; the missing count is the
// number removed; the residual reaches the noise (the model is right).
TEST(FitImpacts, BridgesMissingSamplesAndCountsThem) {
  for (std::uint32_t seed : {1u, 2u, 3u}) {
    auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 8.0, 500, 0.02, seed);
    const long removed = DropSamples(rec, 0.001, seed + 10, 600, 12);  // 12 around the first crossing
    FitOptions o;
    o.geometry = kBlock1Geometry;
    const auto r = model::FitImpacts(rec, o);
    std::printf("seed %u: removed %ld, alpha %.5f p %.5f mu %.5f, ratio %.3f\n", seed, removed, r.params.alpha,
                r.params.p, r.params.mu, r.residual_to_noise);
    EXPECT_EQ(r.theta_gaps.missing_samples, removed);
    EXPECT_NEAR(r.params.alpha / kBlock1.alpha, 1.0, 0.01) << "seed " << seed;
    EXPECT_NEAR(r.params.p / kBlock1.p, 1.0, 0.01) << "seed " << seed;
    EXPECT_NEAR(r.params.mu, kBlock1.mu, 0.005) << "seed " << seed;
    EXPECT_TRUE(r.converged);
    bool noted = false;
    for (const auto& w : r.warnings) noted = noted || w.find("missing") != std::string::npos;
    EXPECT_TRUE(noted);
  }
}

// Oracle for the residual-to-noise ratio with a right model: it is the
// root of a reduced chi-square with the noise-propagated sigmas, so over
// seeds it scatters about 1 (with 18 degrees of freedom its relative
// standard error is 1/sqrt(2 dof) = 17 %): each seed within [0.6, 1.5]
// (measured 0.81 .. 1.37), their mean within [0.75, 1.25] (measured 1.03).
// With a wrong model (the slender eq. (13) on the stocky block 4, whose
// bias is 1.4 % on alpha, docs/errata.md item 2) on a record quiet enough
// (0.001 deg) for the bias to show, the chi-square test must reject it
// (p-value below the 1 % significance; residual / noise measured 2.7
// against 0.7 for the exact form) and the fit say it has not converged.
TEST(FitImpacts, ResidualToNoiseIsAboutOneForTheRightModelOnly) {
  double sum = 0.0;
  const std::uint32_t seeds[] = {1u, 2u, 3u, 4u, 5u, 6u};
  for (std::uint32_t seed : seeds) {
    const auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 8.0, 500, 0.02, seed);
    const auto r = model::FitImpacts(rec, {});
    std::printf("seed %u: rms %.4e s, noise residual %.4e s, ratio %.3f, mu %.5f +- %.5f\n", seed,
                r.rms_residual, r.noise_residual, r.residual_to_noise, r.params.mu, r.mu_stderr);
    EXPECT_GT(r.residual_to_noise, 0.6) << "seed " << seed;
    EXPECT_LT(r.residual_to_noise, 1.5) << "seed " << seed;
    EXPECT_TRUE(r.converged);
    sum += r.residual_to_noise;
  }
  const double mean = sum / std::size(seeds);
  EXPECT_GT(mean, 0.75);
  EXPECT_LT(mean, 1.25);

  const BlockParams block4{0.31, 5.21, 0.926};
  const auto rec = SyntheticFree(block4, 0.6 * block4.alpha, 0.3, 6.0, 500, 0.001, 1);
  FitOptions o;
  o.use_release = false;
  const auto exact = model::FitImpacts(rec, o);
  o.quarter_time = model::QuarterTime::kSlender;
  const auto slender = model::FitImpacts(rec, o);
  std::printf("block 4: exact ratio %.3f, slender ratio %.3f\n", exact.residual_to_noise, slender.residual_to_noise);
  std::printf("block 4: exact p-value %.3g, slender p-value %.3g\n", exact.p_value, slender.p_value);
  EXPECT_GE(exact.p_value, model::kDefaultSignificance);
  EXPECT_TRUE(exact.converged);
  EXPECT_LT(slender.p_value, model::kDefaultSignificance);
  EXPECT_FALSE(slender.converged);
  bool warned = false;
  for (const auto& w : slender.warnings) warned = warned || w.find("not converged to the noise") != std::string::npos;
  EXPECT_TRUE(warned);
}

// Oracle for mu's standard error: Monte Carlo over 12 seeds. The scatter
// of the fitted mu about the truth must match the mean reported standard
// error within a factor 2 (12 samples give the scatter to about 20 %;
// measured: stderr 7.9e-5 against a scatter of 6.0e-5), and no seed may
// miss by more than 4 standard errors.
TEST(FitImpacts, MuStandardErrorMatchesTheScatterOverSeeds) {
  double ss = 0.0;
  double se_sum = 0.0;
  const int n = 12;
  for (int seed = 1; seed <= n; ++seed) {
    const auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 8.0, 500, 0.02, 100 + seed);
    const auto r = model::FitImpacts(rec, {});
    ASSERT_TRUE(std::isfinite(r.mu_stderr));
    ss += (r.params.mu - kBlock1.mu) * (r.params.mu - kBlock1.mu);
    se_sum += r.mu_stderr;
    EXPECT_LT(std::abs(r.params.mu - kBlock1.mu), 4 * r.mu_stderr) << "seed " << seed;
  }
  const double scatter = std::sqrt(ss / n);
  const double se = se_sum / n;
  std::printf("mu: scatter %.3e, mean stderr %.3e\n", scatter, se);
  EXPECT_GT(se / scatter, 0.5);
  EXPECT_LT(se / scatter, 2.0);
}

// The issue: "with 3 residuals the impacts method reports an error of -15
// standard errors". Oracle: the contract, dof = residuals - 2 < 3 withholds
// the standard errors (NaN) and says so; 5 residuals (dof 3) keep them.
TEST(FitImpacts, StandardErrorsWithheldBelowThreeDegreesOfFreedom) {
  // 2.6 s after the release: 4 impacts of block 1 (0.70, 1.37, 1.97, 2.53 s).
  const auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 2.6, 500, 0.02, 4, "few.csv");
  FitOptions o;
  o.min_impacts = 3;
  o.use_release = false;
  const auto r = model::FitImpacts(rec, o);
  ASSERT_EQ(r.residuals, 3);
  EXPECT_EQ(r.dof, 1);
  EXPECT_TRUE(r.stderr_withheld);
  EXPECT_TRUE(std::isnan(r.alpha_stderr));
  EXPECT_TRUE(std::isnan(r.p_stderr));
  EXPECT_TRUE(std::isnan(r.mu_stderr));
  bool noted = false;
  for (const auto& w : r.warnings) noted = noted || w.find("standard errors withheld") != std::string::npos;
  EXPECT_TRUE(noted);
  const auto longer = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 3.6, 500, 0.02, 4, "more.csv");
  const auto r5 = model::FitImpacts(longer, o);
  EXPECT_GE(r5.dof, 3);
  EXPECT_FALSE(r5.stderr_withheld);
  EXPECT_TRUE(std::isfinite(r5.alpha_stderr));
}

// The issue: "--method impacts on a forced record fits alpha = 1.571 and
// then tells the user to widen the band". Oracle: the records are forced by
// construction. With its table record the impacts method refuses one in a
// line naming the cause. Without it (theta alone, as a CSV without
// --accel), a steady response to a constant 5 Hz sine (figure 8) has many
// crossings of equal amplitude whose half intervals follow no quarter time:
// it must say the record is not free rocking, never report a band-edge
// alpha.
TEST(FitImpacts, AForcedRecordIsNotFreeRocking) {
  const auto hanning = model::ParseExcitation("hanning:amp=0.010,freq=3.3,duration=4,start=0.5");
  const auto steady = model::ParseExcitation("sine:amp=0.010,freq=5,duration=10");
  auto with_table = SyntheticForced(kBlock1, *hanning, 7.0, 250, 500, 0.02, 7);
  auto theta_only = SyntheticForced(kBlock1, *steady, 10.0, 250, 500, 0.02, 7);
  theta_only.table_time_s.clear();
  theta_only.table_accel_mps2.clear();
  FitOptions o;
  o.geometry = kBlock1Geometry;
  for (const auto* rec : {&with_table, &theta_only}) {
    try {
      const auto r = model::FitImpacts(*rec, o);
      FAIL() << "no error; alpha " << r.params.alpha;
    } catch (const FitError& e) {
      const std::string what = e.what();
      std::printf("%s\n", what.c_str());
      EXPECT_NE(what.find("not free rocking"), std::string::npos) << what;
      EXPECT_EQ(what.find("admissible band"), std::string::npos) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    }
  }
}

// Oracle for the trajectory method's ratio: theta plus a 7 Hz vibration of
// amplitude A = 0.1 deg that no rocking model has (a deliberately wrong
// model). The fit started at the truth stays there, so its residual is the
// noise and the vibration together: ratio = sqrt(sigma^2 + A^2/2) / sigma
// = sqrt(1 + 12.5) = 3.67 for sigma = 0.02 deg; the noise estimate hardly
// sees the vibration (its second difference, A (2 pi 7)^2 dt^2 = 1.4e-4
// rad at 250 Hz, is a sixth of the noise's 8.5e-4 and moves the median a
// few %). The fit can only lower its residual below the one at the truth
// (bound: 3 % over the oracle for the noise estimate); it absorbs part of
// the vibration into (alpha, p, mu), measured 10 %: bound 15 % under.
// Without the vibration the ratio is 1 within 10 %, as the acceptance
// test's rms is the noise. Both records miss samples, which the method
// skips (the residuals are at the samples present).
TEST(FitTrajectory, ResidualToNoiseSeesAWrongModel) {
  const auto ex = model::ParseExcitation("hanning:amp=0.010,freq=3.3,duration=4,start=0.5");
  auto rec = SyntheticForced(kBlock1, *ex, 5.0, 250, 500, 0.02, 7);
  // Missing samples (0.1 % and 10 in a row during the rocking) are skipped.
  const long removed = DropSamples(rec, 0.001, 3, 500, 10);
  FitOptions o;
  o.start = kBlock1;
  // The verdict is tested, not the search: LM from the truth alone, as the
  // test was written before the global start (whose 24 starts, and 48 more
  // for the wrong model's record, took the two fits from 3.6 to 9.4 s CPU).
  o.starts = 0;
  const auto right = model::FitTrajectory(rec, o);
  EXPECT_EQ(right.theta_gaps.missing_samples, removed);
  EXPECT_EQ(right.residuals, static_cast<int>(rec.size()));
  EXPECT_NEAR(right.params.alpha / kBlock1.alpha, 1.0, 0.01);
  const double a = 0.1 * kDeg;
  // From 0.5 s (the excitation's start; sin(7 pi) = 0 there): the record
  // still starts at rest.
  for (std::size_t k = 0; k < rec.size(); ++k) {
    if (rec.time_s[k] >= 0.5) rec.theta[k] += a * std::sin(2 * 3.14159265358979 * 7.0 * rec.time_s[k]);
  }
  const auto wrong = model::FitTrajectory(rec, o);
  std::printf("trajectory: right ratio %.3f, wrong ratio %.3f (oracle 3.67)\n", right.residual_to_noise,
              wrong.residual_to_noise);
  EXPECT_NEAR(right.residual_to_noise, 1.0, 0.1);
  EXPECT_TRUE(right.converged);
  const double oracle = std::sqrt(1.0 + 0.5 * (0.1 / 0.02) * (0.1 / 0.02));
  EXPECT_LT(wrong.residual_to_noise, 1.03 * oracle);
  EXPECT_GT(wrong.residual_to_noise, 0.85 * oracle);
  EXPECT_FALSE(wrong.converged);
}

// --- error cases: each a FitError / RecordError with a clear message -------

TEST(FitErrors, TooFewImpacts) {
  // 1.5 s after the release: two impacts of block 1 (0.70 s and 1.37 s).
  const auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 1.5, 500, 0.02, 4, "short.csv");
  try {
    model::FitImpacts(rec, {});
    FAIL() << "no error";
  } catch (const FitError& e) {
    EXPECT_NE(std::string(e.what()).find("short.csv: only 2 usable impacts"), std::string::npos) << e.what();
  }
}

TEST(FitErrors, NeverRocks) {
  // Held at 0.6 alpha for the whole record: never released.
  auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 5.0, 0.0, 500, 0.02, 5, "held.csv");
  try {
    model::FitImpacts(rec, {});
    FAIL() << "no error";
  } catch (const FitError& e) {
    EXPECT_NE(std::string(e.what()).find("never rocks"), std::string::npos) << e.what();
  }
  // At rest with a table that does not move it (0.5 m/s^2 < g tan alpha).
  const auto ex = model::ParseExcitation("sine:amp=0.001,freq=3.5,duration=3");
  const auto rest = SyntheticForced(kBlock1, *ex, 4.0, 250, 500, 0.02, 6);
  FitOptions o;
  o.geometry = kBlock1Geometry;
  EXPECT_THROW(model::FitTrajectory(rest, o), FitError);
}

TEST(FitErrors, Overturns) {
  // Released beyond alpha: it falls over (the model stops at pi/2).
  const auto rec = SyntheticFree(kBlock1, 1.05 * kBlock1.alpha, 0.3, 3.0, 500, 0.02, 8, "fell.csv");
  for (bool geometry : {false, true}) {
    FitOptions o;
    if (geometry) o.geometry = kBlock1Geometry;
    try {
      model::FitImpacts(rec, o);
      FAIL() << "no error";
    } catch (const FitError& e) {
      EXPECT_NE(std::string(e.what()).find("overturns"), std::string::npos) << e.what();
    }
  }
}

TEST(FitErrors, AlphaOutsideTheAdmissibleBandIsRejected) {
  const auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 8.0, 500, 0.02, 1);
  FitOptions o;
  o.geometry = model::FitGeometry{0.40, 1.0, 0.0};  // alpha 0.38: block 1 is not this block
  try {
    model::FitImpacts(rec, o);
    FAIL() << "no error";
  } catch (const FitError& e) {
    EXPECT_NE(std::string(e.what()).find("outside the admissible band"), std::string::npos) << e.what();
  }
  // A configurable band: +-10 cm on b admits it.
  o.alpha_band_m = 0.10;
  EXPECT_NO_THROW(model::FitImpacts(rec, o));
}

// Gaps are counted, not errors (a record with one dropped sample,
// as the rig simulator's 0.1 % and the demo make, must be fitted).
// Oracle: the samples removed here.
TEST(RecordErrors, GapsAreCountedAndNonMonotonicTimeIsAnError) {
  auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 2.0, 500, 0.02, 9, "gap.csv");
  auto gap = rec;
  gap.time_s.erase(gap.time_s.begin() + 500, gap.time_s.begin() + 510);
  gap.theta.erase(gap.theta.begin() + 500, gap.theta.begin() + 510);
  gap.line.erase(gap.line.begin() + 500, gap.line.begin() + 510);
  gap.time_s.erase(gap.time_s.begin() + 700);
  gap.theta.erase(gap.theta.begin() + 700);
  gap.line.erase(gap.line.begin() + 700);
  EXPECT_NO_THROW(model::CheckRecord(gap));
  const model::GapCount g = model::CountGaps(gap.time_s, gap.line);
  EXPECT_EQ(g.missing_samples, 11);
  EXPECT_EQ(g.gaps, 2);
  EXPECT_EQ(g.first_line, 512);  // the first sample after the 10 removed (line = index + 2)
  EXPECT_NEAR(g.longest_s, 11 * 0.002, 1e-12);
  EXPECT_EQ(model::CountGaps(rec.time_s, rec.line).missing_samples, 0);
  auto back = rec;
  std::swap(back.time_s[300], back.time_s[301]);
  try {
    model::CheckRecord(back);
    FAIL() << "no error";
  } catch (const RecordError& e) {
    EXPECT_NE(std::string(e.what()).find("gap.csv:303: theta time does not increase"), std::string::npos)
        << e.what();
  }
}

// --- readers ----------------------------------------------------------------

// Oracle: the values written. A reconstruct-style CSV (extra columns, theta
// not second) is read by name; a NaN theta is a lost sample, left out and
// counted once (inside the record and at its end); a ragged row names its
// line.
TEST(RecordReaders, CsvByColumnName) {
  const std::string path = TempPath("reconstruct.csv");
  {
    std::ofstream out(path);
    out << "time,theta,theta_dot,theta_mirror,theta_camera,sliding,twist,out_of_plane,flags\n";
    for (int k = 0; k < 50; ++k) {
      out << k * 0.002 << "," << 0.001 * k << ",0,0,0,0,0,0,0\n";
    }
  }
  const auto r = model::ReadRecord(path);
  ASSERT_EQ(r.size(), 50u);
  EXPECT_DOUBLE_EQ(r.theta[49], 0.049);
  EXPECT_DOUBLE_EQ(r.time_s[10], 0.02);
  EXPECT_FALSE(r.has_table());
  EXPECT_EQ(r.theta_gaps.missing_samples, 0);
  {
    std::ofstream out(path, std::ios::app);
    out << "0.1,nan,0,0,0,0,0,0,0\n";  // line 52
  }
  const auto lost_at_end = model::ReadRecord(path);
  EXPECT_EQ(lost_at_end.size(), 50u);
  EXPECT_EQ(lost_at_end.theta_gaps.missing_samples, 1);
  EXPECT_EQ(lost_at_end.theta_gaps.first_line, 52);
  {
    std::ofstream out(path, std::ios::app);
    out << "0.102,0.051,0,0,0,0,0,0,0\n0.104,0.052,0,0,0,0,0,0,0\n";
  }
  const auto lost_inside = model::ReadRecord(path);
  EXPECT_EQ(lost_inside.size(), 52u);
  EXPECT_EQ(lost_inside.theta_gaps.missing_samples, 1);
  EXPECT_EQ(lost_inside.theta_gaps.gaps, 1);
  EXPECT_EQ(lost_inside.theta_gaps.first_line, 53);  // the sample after the lost one
  {
    std::ofstream out(path, std::ios::app);
    out << "0.106,0.053,0\n";  // line 55
  }
  try {
    model::ReadRecord(path);
    FAIL() << "no error";
  } catch (const RecordError& e) {
    EXPECT_NE(std::string(e.what()).find("reconstruct.csv:55: expected 9 fields"), std::string::npos)
        << e.what();
  }
}

// Oracle: a log written here with lcm::LogFile; theta and table samples come
// back with their times; a skipped seq is a missing sample, counted per
// channel with the event after it; a seq that goes back is an error naming
// the event.
TEST(RecordReaders, LcmLogWithThetaAndTable) {
  const std::string path = TempPath("test.lcmlog");
  auto write = [&](bool with_gap) {
    lcm::LogFile log(path, "w");
    ASSERT_TRUE(log.good());
    int64_t eventnum = 0;
    for (int k = 0; k < 100; ++k) {
      if (with_gap && k == 60) continue;
      rocklab::block_state_t b{};
      b.utime = 1000000 + k * 2000;
      b.seq = k;
      b.theta = 0.01 * std::sin(0.1 * k);
      rocklab::table_state_t t{};
      t.utime = b.utime;
      t.seq = k;
      t.acceleration = 0.5 * k;
      for (int which = 0; which < 2; ++which) {
        std::vector<uint8_t> buf(which == 0 ? b.getEncodedSize() : t.getEncodedSize());
        if (which == 0) {
          b.encode(buf.data(), 0, static_cast<int>(buf.size()));
        } else {
          t.encode(buf.data(), 0, static_cast<int>(buf.size()));
        }
        lcm::LogEvent ev{};
        ev.eventnum = eventnum++;
        ev.timestamp = b.utime;
        ev.channel = which == 0 ? "RL_THETA" : "RL_TABLE";
        ev.datalen = static_cast<int32_t>(buf.size());
        ev.data = buf.data();
        ASSERT_EQ(log.writeEvent(&ev), 0);
      }
    }
  };
  write(false);
  const auto r = model::ReadRecord(path);
  ASSERT_EQ(r.size(), 100u);
  ASSERT_TRUE(r.has_table());
  EXPECT_NEAR(r.time_s[99], 1.198, 1e-12);
  EXPECT_DOUBLE_EQ(r.theta[10], 0.01 * std::sin(1.0));
  EXPECT_DOUBLE_EQ(r.table_accel_mps2[99], 49.5);
  EXPECT_EQ(r.theta_gaps.missing_samples, 0);
  write(true);
  const auto g = model::ReadRecord(path);
  EXPECT_EQ(g.size(), 99u);
  EXPECT_EQ(g.theta_gaps.missing_samples, 1);
  EXPECT_EQ(g.theta_gaps.first_line, 120);  // RL_THETA of k = 61
  EXPECT_NEAR(g.theta_gaps.longest_s, 0.004, 1e-12);
  EXPECT_EQ(g.table_gaps.missing_samples, 1);
  EXPECT_EQ(g.table_gaps.first_line, 121);
  {
    lcm::LogFile log(path, "w");
    int64_t eventnum = 0;
    for (int k : {0, 1, 2, 1}) {
      rocklab::block_state_t b{};
      b.utime = 1000000 + k * 2000;
      b.seq = k;
      std::vector<uint8_t> buf(b.getEncodedSize());
      b.encode(buf.data(), 0, static_cast<int>(buf.size()));
      lcm::LogEvent ev{};
      ev.eventnum = eventnum++;
      ev.timestamp = b.utime;
      ev.channel = "RL_THETA";
      ev.datalen = static_cast<int32_t>(buf.size());
      ev.data = buf.data();
      ASSERT_EQ(log.writeEvent(&ev), 0);
    }
  }
  try {
    model::ReadRecord(path);
    FAIL() << "no error";
  } catch (const RecordError& e) {
    EXPECT_NE(std::string(e.what()).find("RL_THETA sequence goes back from 2 to 1"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(":event 3"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace rocklab::test
