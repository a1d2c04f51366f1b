#pragma once
// Private to rocklab::model: what the parts of the fit share (model/fit.cpp:
// options and the checks both methods make; fit_numerics.cpp: the
// Levenberg-Marquardt driver and number helpers; fit_features.cpp: the
// features of a record; fit_impacts.cpp and fit_trajectory.cpp: the two
// methods). The public API is model/fit.h.

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
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// `v` with `digits` significant digits, for messages.
std::string Num(double v, int digits = 6);

/// Index range [lo, hi) of the samples with time in [t0, t1].
std::pair<std::size_t, std::size_t> Range(const std::vector<double>& t, double t0, double t1);

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

/// Largest |table acceleration| of the record, m/s^2 (0 without a table).
double MaxAbsTable(const RockingRecord& r);

/// The opening both methods share: validates the options, sets the method,
/// the theory and band from the geometry, extracts the features and checks
/// that the block rocks without overturning (throws FitError otherwise).
FitResult StartFit(FitMethod method, const RockingRecord& record, const FitOptions& options);

}  // namespace rocklab::model::fit_detail
