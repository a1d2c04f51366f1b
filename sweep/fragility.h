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

/// The log-likelihood above at (median, beta), for checks.
double FragilityLogLikelihood(const std::vector<FragilityPoint>& points, double median, double beta);

/// The standard normal distribution function.
double NormalCdf(double z);

}  // namespace rocklab::sweep
