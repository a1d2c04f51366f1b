#include "sweep/fragility.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace rocklab::sweep {
namespace {

constexpr double kInvSqrt2 = 0.70710678118654752440;
constexpr double kInvSqrt2Pi = 0.39894228040143267794;

double NormalPdf(double z) { return kInvSqrt2Pi * std::exp(-0.5 * z * z); }

// ln Phi(z), accurate far in the lower tail (erfc does not underflow there
// before z ~ -38; beyond, the asymptote ln phi(z) - ln(-z)).
double LogCdf(double z) {
  if (z > -37.0) return std::log(0.5 * std::erfc(-z * kInvSqrt2));
  return -0.5 * z * z - std::log(-z) - 0.5 * std::log(2 * 3.14159265358979323846);
}

// phi(z) / Phi(z) (the inverse Mills ratio), stable for z -> -infinity.
double MillsRatio(double z) {
  if (z > -37.0) return NormalPdf(z) / (0.5 * std::erfc(-z * kInvSqrt2));
  return -z;  // leading term of the asymptotic series
}

double LogLikelihoodAB(const std::vector<FragilityPoint>& points, double a, double b) {
  double sum = 0.0;
  for (const FragilityPoint& p : points) {
    if (p.trials <= 0) continue;
    const double eta = a + b * std::log(p.x);
    if (p.overturned > 0) sum += p.overturned * LogCdf(eta);
    if (p.trials - p.overturned > 0) sum += (p.trials - p.overturned) * LogCdf(-eta);
  }
  return sum;
}

}  // namespace

double NormalCdf(double z) { return 0.5 * std::erfc(-z * kInvSqrt2); }

double FragilityFit::Probability(double x) const { return NormalCdf(std::log(x / median) / beta); }

const char* ToString(FragilityFit::Status status) {
  switch (status) {
    case FragilityFit::Status::kFitted: return "fitted";
    case FragilityFit::Status::kNone: return "none_overturned";
    case FragilityFit::Status::kAll: return "all_overturned";
    case FragilityFit::Status::kSeparated: return "separated";
  }
  return "?";
}

double FragilityLogLikelihood(const std::vector<FragilityPoint>& points, double median, double beta) {
  return LogLikelihoodAB(points, -std::log(median) / beta, 1.0 / beta);
}

FragilityFit FitLognormalFragility(const std::vector<FragilityPoint>& points) {
  double safe_max = -std::numeric_limits<double>::infinity();
  double over_min = std::numeric_limits<double>::infinity();
  double trials = 0.0, overturned = 0.0, sum_log = 0.0;
  for (const FragilityPoint& p : points) {
    if (!std::isfinite(p.x) || p.x <= 0) throw std::invalid_argument("fragility: intensity must be finite and > 0");
    if (!(p.trials >= 0) || !(p.overturned >= 0) || !(p.overturned <= p.trials)) {
      throw std::invalid_argument("fragility: counts must satisfy 0 <= overturned <= trials");
    }
    if (p.trials == 0) continue;
    trials += p.trials;
    overturned += p.overturned;
    sum_log += p.trials * std::log(p.x);
    if (p.overturned > 0) over_min = std::min(over_min, p.x);
    if (p.trials - p.overturned > 0) safe_max = std::max(safe_max, p.x);
  }
  FragilityFit fit;
  if (overturned == 0) {
    fit.status = FragilityFit::Status::kNone;
    return fit;
  }
  if (overturned == trials) {
    fit.status = FragilityFit::Status::kAll;
    return fit;
  }
  if (safe_max <= over_min) {  // complete or quasi-complete separation
    fit.status = FragilityFit::Status::kSeparated;
    fit.safe_below = safe_max;
    fit.overturned_above = over_min;
    return fit;
  }

  // Newton on (a, b) from beta = 0.5 around the mean log intensity.
  double b = 2.0, a = -b * sum_log / trials;
  double ll = LogLikelihoodAB(points, a, b);
  for (fit.iterations = 1; fit.iterations <= 200; ++fit.iterations) {
    double ga = 0, gb = 0, haa = 0, hab = 0, hbb = 0;  // gradient and -Hessian
    for (const FragilityPoint& p : points) {
      if (p.trials <= 0) continue;
      const double u = std::log(p.x), eta = a + b * u;
      const double m = p.overturned, s = p.trials - p.overturned;
      const double l1 = MillsRatio(eta), l2 = MillsRatio(-eta);
      const double d = m * l1 - s * l2;                              // dL/deta
      const double w = m * l1 * (eta + l1) + s * l2 * (l2 - eta);    // -d2L/deta2 >= 0
      ga += d;
      gb += d * u;
      haa += w;
      hab += w * u;
      hbb += w * u * u;
    }
    const double det = haa * hbb - hab * hab;
    if (!(det > 0)) break;
    double da = (hbb * ga - hab * gb) / det, db = (haa * gb - hab * ga) / det;
    double step = 1.0, next = ll;
    for (int halvings = 0; halvings < 60; ++halvings) {
      next = LogLikelihoodAB(points, a + step * da, b + step * db);
      if (next >= ll && b + step * db > 0) break;
      step *= 0.5;
    }
    a += step * da;
    b += step * db;
    const bool converged = std::abs(step * da) < 1e-13 * (1 + std::abs(a)) &&
                           std::abs(step * db) < 1e-13 * (1 + std::abs(b));
    ll = next;
    if (converged) break;
  }
  fit.status = FragilityFit::Status::kFitted;
  fit.beta = 1.0 / b;
  fit.median = std::exp(-a / b);
  fit.log_likelihood = ll;
  return fit;
}

FragilityBand LikelihoodBand(const std::vector<FragilityPoint>& points, const FragilityFit& fit,
                             const std::vector<double>& xs) {
  FragilityBand band;
  band.x = xs;
  const double b0 = 1.0 / fit.beta, a0 = -std::log(fit.median) * b0;
  // Observed information at the estimate (the Newton iteration's -Hessian).
  double haa = 0, hab = 0, hbb = 0;
  for (const FragilityPoint& p : points) {
    if (p.trials <= 0) continue;
    const double u = std::log(p.x), eta = a0 + b0 * u;
    const double m = p.overturned, s = p.trials - p.overturned;
    const double l1 = MillsRatio(eta), l2 = MillsRatio(-eta);
    const double w = m * l1 * (eta + l1) + s * l2 * (l2 - eta);
    haa += w;
    hab += w * u;
    hbb += w * u * u;
  }
  const double det = haa * hbb - hab * hab;
  const double se_a = det > 0 ? std::sqrt(hbb / det) : 1.0, se_b = det > 0 ? std::sqrt(haa / det) : b0;
  constexpr int kGrid = 241;
  constexpr double kSpan = 6.0;            // standard errors each side
  constexpr double kHalfChi2 = 3.841458820694124 / 2;  // chi-square(1) 0.95 quantile / 2
  const double a_lo = a0 - kSpan * se_a, a_step = 2 * kSpan * se_a / (kGrid - 1);
  const double b_lo = std::max(b0 - kSpan * se_b, 1e-3 * b0), b_hi = b0 + kSpan * se_b;
  const double b_step = (b_hi - b_lo) / (kGrid - 1);
  const bool b_floored = b_lo > b0 - kSpan * se_b;  // the grid starts at b ~ 0, not 6 se below
  std::vector<double> eta_lo(xs.size(), INFINITY), eta_hi(xs.size(), -INFINITY);
  double log_median_lo = INFINITY, log_median_hi = -INFINITY;
  bool low_at_edge = false, high_at_edge = false;
  for (int i = 0; i < kGrid; ++i) {
    const double a = a_lo + i * a_step;
    for (int j = 0; j < kGrid; ++j) {
      const double b = b_lo + j * b_step;
      if (fit.log_likelihood - LogLikelihoodAB(points, a, b) > kHalfChi2) continue;
      const bool edge = i == 0 || i == kGrid - 1 || j == 0 || j == kGrid - 1;
      const double log_median = -a / b;
      if (log_median < log_median_lo) {
        log_median_lo = log_median;
        low_at_edge = edge;
      }
      if (log_median > log_median_hi) {
        log_median_hi = log_median;
        high_at_edge = edge;
      }
      // b -> 0 (beta -> infinity, a curve flat in x) inside the region: the
      // median exp(-a / b) is unbounded on the side of -a's sign.
      if (j == 0 && b_floored) {
        (a < 0 ? band.median_high_open : band.median_low_open) = true;
      }
      for (std::size_t k = 0; k < xs.size(); ++k) {
        const double eta = a + b * std::log(xs[k]);
        eta_lo[k] = std::min(eta_lo[k], eta);
        eta_hi[k] = std::max(eta_hi[k], eta);
      }
    }
  }
  band.median_low_open = band.median_low_open || low_at_edge;
  band.median_high_open = band.median_high_open || high_at_edge;
  // The estimate itself is always inside; the grid holds it (i = j = 120
  // when b0 - 6 se_b > 1e-3 b0, else near it).
  band.median_low = std::exp(std::min(log_median_lo, std::log(fit.median)));
  band.median_high = std::exp(std::max(log_median_hi, std::log(fit.median)));
  for (std::size_t k = 0; k < xs.size(); ++k) {
    const double eta = a0 + b0 * std::log(xs[k]);
    band.p_low.push_back(NormalCdf(std::min(eta_lo[k], eta)));
    band.p_high.push_back(NormalCdf(std::max(eta_hi[k], eta)));
  }
  return band;
}

}  // namespace rocklab::sweep
