#pragma once
/// @file
/// Fragility curves: the probability of overturning against an intensity
/// measure x (here the PGA in g), P(x) = Phi(ln(x / theta) / beta), a
/// lognormal distribution function with median theta and dispersion beta,
/// fitted by maximum likelihood to binary outcomes (overturned or not).
///
/// The log-likelihood of n_k trials with m_k overturned at x_k,
///   L = sum_k m_k ln Phi(eta_k) + (n_k - m_k) ln(1 - Phi(eta_k)),
///   eta_k = a + b ln x_k,  b = 1 / beta,  a = -ln(theta) / beta,
/// is a probit regression on ln x and is concave in (a, b): Newton's method
/// with a halving line search finds its maximum. A finite maximum exists
/// only when the outcomes overlap (some x overturned is below some x that
/// was not); separated outcomes (every safe x at or below every overturned
/// x) make beta -> 0, and the fit reports the bracket instead.

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace rocklab::sweep {

/// Outcomes at one intensity. Counts may be fractional (weights).
struct FragilityPoint {
  double x{};           ///< intensity, e.g. PGA in g; > 0
  double trials{};      ///< >= 0
  double overturned{};  ///< in [0, trials]
};

struct FragilityFit {
  enum class Status {
    kFitted,     ///< median and dispersion are the maximum-likelihood estimates
    kNone,       ///< nothing overturned: no curve
    kAll,        ///< everything overturned: no curve
    kSeparated,  ///< no finite maximum: the median lies in [safe_below, overturned_above] (safe_below <= overturned_above)
  };
  Status status{Status::kNone};
  double median{};             ///< theta, in the unit of x
  double beta{};               ///< dispersion (log standard deviation), 1
  double log_likelihood{};     ///< at the estimate
  double safe_below{};         ///< kSeparated: the largest x that did not overturn
  double overturned_above{};   ///< kSeparated: the smallest x that overturned
  int iterations{};
  /// Phi(ln(x / median) / beta). Precondition: status == kFitted.
  double Probability(double x) const;
};

const char* ToString(FragilityFit::Status status);

/// Maximum-likelihood lognormal fragility of `points` (points with no trial
/// are ignored).
/// @throws std::invalid_argument for x <= 0 or not finite, or counts out of range.
FragilityFit FitLognormalFragility(const std::vector<FragilityPoint>& points);

/// The 95 % profile-likelihood intervals of a fitted curve: the points
/// (a, b) with 2 (L_max - L(a, b)) <= 3.841 (chi-square, 1 degree of
/// freedom, 0.95), projected on the median exp(-a / b) and on P(x) at each
/// x asked for (pointwise). Found on a 241 x 241 grid over (a, b), 6
/// standard errors (the observed information's) each side of the estimate
/// (b > 0); when the region reaches the grid's edge the interval is open on
/// that side (the likelihood does not bound it: few outcomes, or a median
/// far outside the data).
struct FragilityBand {
  double median_low{}, median_high{};  ///< in the unit of x
  bool median_low_open{}, median_high_open{};  ///< the region reached the grid's edge on that side
  std::vector<double> x;                      ///< where the band is given
  std::vector<double> p_low, p_high;          ///< P(overturn) bounds at each x
};

/// The band of `fit` (status kFitted) over `points`, at `xs`.
FragilityBand LikelihoodBand(const std::vector<FragilityPoint>& points, const FragilityFit& fit,
                             const std::vector<double>& xs);

/// The log-likelihood above at (median, beta), for checks.
double FragilityLogLikelihood(const std::vector<FragilityPoint>& points, double median, double beta);

/// The standard normal distribution function.
double NormalCdf(double z);

}  // namespace rocklab::sweep
