#pragma once
// Private to rocklab::model: what the parts of the fit share. The public API
// is model/fit.h; the parts are
//   fit.cpp            options, names, the opening and the verdict both
//                      methods share (StartFit, SetNoiseVerdict, ...)
//   fit_numerics.cpp   number helpers, the Levenberg-Marquardt covariance
//                      (the 1-D search and the LM driver are templates, here)
//   fit_features.cpp   a record's noise, crossings, peaks and release
//   fit_impacts.cpp    FitImpacts (the paper's method)
//   fit_trajectory.cpp FitTrajectory

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Dense>
#include <unsupported/Eigen/LevenbergMarquardt>
#include <unsupported/Eigen/NumericalDiff>

#include "model/fit.h"
#include "model/numbers.h"

namespace rocklab::model::fit_detail {

using detail::kPi;
using common::kNaN;

// --- numerics (fit_numerics.cpp) ---------------------------------------------

// `v` with `digits` significant digits, for messages.
std::string Num(double v, int digits = 6);

// Median of `v` (NaN when empty).
double Median(std::vector<double> v);

// Sample standard deviation (NaN below two values).
double StdDev(const std::vector<double>& v);

// The noise scale of a local least-squares fit (a crossing, a peak, an
// onset): `noise` unless the fit's own residual, rss / dof, exceeds it beyond
// what the noise allows (its chi-square above the 1 % upper quantile of
// chi2(dof)); then sqrt(rss / dof). On a quiet record this is the local
// polynomial's own model error, so a noise-free record never claims a
// precision its features do not have.
double LocalNoiseScale(double rss, int dof, double noise);

// Index range [lo, hi) of the samples with time in [t0, t1].
std::pair<std::size_t, std::size_t> Range(const std::vector<double>& t, double t0, double t1);

// Golden-section minimisation of f on [a, b].
template <typename F>
double GoldenMin(const F& f, double a, double b, int iterations = 60) {
  const double g = (std::sqrt(5.0) - 1.0) / 2.0;
  double c = b - g * (b - a);
  double d = a + g * (b - a);
  double fc = f(c);
  double fd = f(d);
  for (int i = 0; i < iterations && (b - a) > 1e-12 * (1.0 + std::abs(a)); ++i) {
    if (fc < fd) {
      b = d;
      d = c;
      fd = fc;
      c = b - g * (b - a);
      fc = f(c);
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + g * (b - a);
      fd = f(d);
    }
  }
  return (a + b) / 2;
}

// Grid points of GridThenGolden at most, for a crossing's bracket and for a
// release's window. Their f costs O(samples in a window), and their grids
// had a point per fraction of a sample: O(rate^2) per crossing or release,
// a fit growing as N^1.8 (docs/commands.md, the impacts method's "Cost").
// Capped, a search costs at most (max_points + ~60) f's. A grid under the
// cap is as before: a bracket of up to 32 samples (8 points a sample; at
// 1 kHz a crossing's bracket is a few samples), a 0.3 s release window at
// up to 1.7 kHz (2 a sample).
inline constexpr int kMaxCrossingGridPoints = 257;
inline constexpr int kMaxOnsetGridPoints = 1025;

// Minimises a piecewise-smooth 1-D function: a grid of `per_step` points per
// `step` over [a, b] (at most max_points, evenly spread), then golden
// section around the best grid point.
template <typename F>
double GridThenGolden(const F& f, double a, double b, double step, int per_step, int max_points) {
  const double wanted = std::ceil((b - a) / step * per_step) + 1;
  const int n = std::max(2, static_cast<int>(std::min(wanted, static_cast<double>(max_points))));
  double best_x = a;
  double best_f = std::numeric_limits<double>::infinity();
  for (int i = 0; i < n; ++i) {
    const double x = a + (b - a) * i / (n - 1);
    const double v = f(x);
    if (v < best_f) {
      best_f = v;
      best_x = x;
    }
  }
  const double h = (b - a) / (n - 1);
  return GoldenMin(f, std::max(a, best_x - h), std::min(b, best_x + h));
}

// Least squares of theta = s u + c u^2 (through the origin) on one side of

// --- Levenberg-Marquardt driver ---------------------------------------------

struct LmOutcome {
  Eigen::VectorXd x;
  Eigen::VectorXd residuals;
  Eigen::MatrixXd jacobian;
  int iterations{};
  int evaluations{};
  Eigen::LevenbergMarquardtSpace::Status status{};
};

// Runs Eigen's LM on `functor` (an Eigen::DenseFunctor with a const
// operator()(x, fvec) and an `evaluations()` counter) with central
// differences of relative step sqrt(epsfcn), reporting every iteration.
template <typename Functor>
LmOutcome RunLm(const Functor& functor, Eigen::VectorXd x, double epsfcn, double xtol,
                double ftol, int max_evaluations, const FitOptions& options,
                std::chrono::steady_clock::time_point start) {
  Eigen::NumericalDiff<Functor, Eigen::Central> numdiff(functor, epsfcn);
  Eigen::LevenbergMarquardt<Eigen::NumericalDiff<Functor, Eigen::Central>> lm(numdiff);
  lm.setXtol(xtol);
  lm.setFtol(ftol);
  lm.setMaxfev(max_evaluations);
  LmOutcome out;
  out.status = lm.minimizeInit(x);
  int iteration = 0;
  if (out.status != Eigen::LevenbergMarquardtSpace::ImproperInputParameters) {
    do {
      ThrowIfCancelled(options.cancelled);
      out.status = lm.minimizeOneStep(x);
      ++iteration;
      if (options.on_progress) {
        FitProgress p;
        p.iteration = iteration;
        p.evaluations = numdiff.evaluations();
        p.rms = lm.fnorm() / std::sqrt(static_cast<double>(functor.values()));
        p.x = x;
        p.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        options.on_progress(p);
      }
    } while (out.status == Eigen::LevenbergMarquardtSpace::Running);
  }
  out.x = x;
  out.residuals.resize(functor.values());
  functor(x, out.residuals);
  out.jacobian.resize(functor.values(), x.size());
  numdiff.df(x, out.jacobian);
  out.iterations = iteration;
  out.evaluations = numdiff.evaluations();
  return out;
}

// s^2 (J^T J)^-1 with s^2 = RSS / (m - n); NaN where J^T J is singular.
Eigen::MatrixXd Covariance(const LmOutcome& o);

bool LmConverged(Eigen::LevenbergMarquardtSpace::Status s);

// --- what both methods share (fit.cpp) ---------------------------------------

// Largest |table acceleration| of the record, m/s^2 (0 without a table).
double MaxAbsTable(const RockingRecord& r);

// The opening both methods share: validates the options; sets the method,
// the quarter time, the theory and band from the geometry, the features and
// the gap counts; checks that the block rocks without overturning.
// @throws std::invalid_argument on bad options, FitError on a record that
// does not rock or overturns.
FitResult StartFit(FitMethod method, const RockingRecord& record, const FitOptions& options);

// sum (r_i / sigma_i)^2 (NaN when a sigma is not positive); sets
// *noise_residual to the rms of sigma (what the noise alone leaves).
double DiagonalChi2(const Eigen::VectorXd& residuals, const std::vector<double>& sigma, double* noise_residual);

// The verdict on the residual: standard errors withheld below
// kMinDofForStderr degrees of freedom; chi2, chi2 / dof, residual_to_noise
// (its root), the p-value of F(dof, noise dof) and converged (the LM's test
// and p_value >= ChiSquareLevel). Needs out.dof and out.features.noise_dof.
void SetNoiseVerdict(double chi2, double noise_residual, bool lm_converged, FitResult& out);

// The chi-square test's level: the significance; half of it for the
// trajectory method, whose band test takes the other half (Bonferroni).
double ChiSquareLevel(const FitResult& out);

// The band test of a trajectory fit (docs/fit_coverage.md, "The band
// test"): the residuals r (n) split by the orthonormal DCT-II into their
// first m coefficients (the low band, where a model error lies) and the
// rest. For white Gaussian noise every coefficient is N(0, sigma^2),
// independent, so (S_low / d_low) / (S_high / d_high) is F(d_low, d_high),
// the noise level taken from the record's own high band: no estimate of the
// noise enters. d_low = m - tr(P_low H), d_high = n - m - tr(P_high H),
// H = J (J^T J)^-1 J^T the fit's hat matrix (its q = columns of J
// parameters take their degrees of freedom from both bands).
struct BandTest {
  int low{};  // m, the low band's coefficients
  double dof_low{std::numeric_limits<double>::quiet_NaN()};
  double dof_high{std::numeric_limits<double>::quiet_NaN()};
  double ratio{std::numeric_limits<double>::quiet_NaN()};    // the F statistic
  double p_value{std::numeric_limits<double>::quiet_NaN()};  // P(F >= ratio)
};
BandTest LowBandTest(const Eigen::VectorXd& r, const Eigen::MatrixXd& jacobian, Eigen::Index m);

// The low band of LowBandTest for a record: the DCT coefficients that hold
// kBandEnergy of the fitted model's first-difference energy (its velocity:
// a parameter error moves the impacts, theta_model' times the shift),
// `fraction` of it,
// bounded to [4 q, n / 2]. `model` is theta_model at the samples.
Eigen::Index LowBandSize(const Eigen::VectorXd& model, Eigen::Index q, double fraction);

// Notes on what the fit knows: missing samples, withheld standard errors, a
// residual above the noise. `handled`: what the method did with the gaps.
void AddVerdictWarnings(FitResult& out, const std::string& handled);

}  // namespace rocklab::model::fit_detail
