#include "model/free_rocking.h"

#include "model/numbers.h"

#include <array>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

namespace rocklab::model {
namespace {

using detail::ExactText;
using detail::kPi;

[[noreturn]] void Bad(const char* function, const char* what, const char* rule, double value) {
  throw std::invalid_argument(std::string(function) + ": " + what + " must be " + rule + " (got " +
                              ExactText(value) + ")");
}

// 20-point Gauss-Legendre nodes and weights on [-1, 1], computed once by
// Newton iteration on P_20.
constexpr int kGaussN = 20;
struct GaussRule {
  std::array<double, kGaussN> x{};
  std::array<double, kGaussN> w{};
};

GaussRule MakeGaussRule() {
  GaussRule rule;
  for (int i = 0; i < kGaussN; ++i) {
    double x = std::cos(kPi * (i + 0.75) / (kGaussN + 0.5));
    double dp = 0.0;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1.0;
      double p1 = x;
      for (int k = 2; k <= kGaussN; ++k) {
        const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      dp = kGaussN * (x * p1 - p0) / (x * x - 1.0);
      const double dx = p1 / dp;
      x -= dx;
      if (std::abs(dx) < 1e-16) break;
    }
    rule.x[i] = x;
    rule.w[i] = 2.0 / ((1.0 - x * x) * dp * dp);
  }
  return rule;
}

const GaussRule& Gauss() {
  static const GaussRule rule = MakeGaussRule();
  return rule;
}

template <typename F>
double GaussPanel(const F& f, double a, double b) {
  const GaussRule& g = Gauss();
  const double c = (a + b) / 2;
  const double h = (b - a) / 2;
  double sum = 0.0;
  for (int i = 0; i < kGaussN; ++i) sum += g.w[i] * f(c + h * g.x[i]);
  return sum * h;
}

// Adaptive bisection: accept a panel when its two halves agree with it.
template <typename F>
double Adaptive(const F& f, double a, double b, double whole, double tol, int depth) {
  const double m = (a + b) / 2;
  const double left = GaussPanel(f, a, m);
  const double right = GaussPanel(f, m, b);
  if (std::abs(left + right - whole) <= tol || depth >= 40) return left + right;
  return Adaptive(f, a, m, left, tol / 2, depth + 1) + Adaptive(f, m, b, right, tol / 2, depth + 1);
}

// cos(a - r) - cos(a) without cancellation, the energy (over M g R) at a peak r.
double PeakEnergy(double alpha, double r) { return 2.0 * std::sin(alpha - r / 2) * std::sin(r / 2); }

}  // namespace

double QuarterTimeExact(double alpha, double p, double r) {
  if (!(alpha > 0.0 && alpha < kPi / 2)) Bad("QuarterTimeExact", "alpha", "in (0, pi/2) rad", alpha);
  if (!(p > 0.0) || !std::isfinite(p)) Bad("QuarterTimeExact", "p", "finite and > 0 rad/s", p);
  if (!(r > 0.0 && r < alpha)) Bad("QuarterTimeExact", "r", "in (0, alpha) rad", r);
  // x = r (1 - u^2), u in [0, 1]: dx = -2 r u du and, with c = alpha - r and
  // d = r u^2, cos(c) - cos(c + d) = 2 sin(c + d/2) sin(d/2) ~ r u^2 sin(c):
  // the u cancels the inverse square root, leaving an analytic integrand
  //   2 r u / sqrt(2 sin(c + d/2) sin(d/2)),  finite (2 sqrt(r / sin c)) at u = 0.
  const double c = alpha - r;
  auto integrand = [c, r](double u) {
    const double d = r * u * u;
    if (d == 0.0) return 2.0 * std::sqrt(r / std::sin(c));
    return 2.0 * r * u / std::sqrt(2.0 * std::sin(c + d / 2) * std::sin(d / 2));
  };
  const double whole = GaussPanel(integrand, 0.0, 1.0);
  const double integral = Adaptive(integrand, 0.0, 1.0, whole, 1e-14 * std::abs(whole), 0);
  return integral / (p * std::sqrt(2.0));
}

double QuarterTimeSlender(double alpha, double p, double r) {
  if (!(alpha > 0.0) || !std::isfinite(alpha)) Bad("QuarterTimeSlender", "alpha", "finite and > 0 rad", alpha);
  if (!(p > 0.0) || !std::isfinite(p)) Bad("QuarterTimeSlender", "p", "finite and > 0 rad/s", p);
  if (!(r > 0.0 && r < alpha)) Bad("QuarterTimeSlender", "r", "in (0, alpha) rad", r);
  return std::acosh(1.0 / (1.0 - r / alpha)) / p;
}

double NextPeak(double alpha, double mu, double r) {
  if (!(alpha > 0.0 && alpha < kPi / 2)) Bad("NextPeak", "alpha", "in (0, pi/2) rad", alpha);
  if (!(mu > 0.0 && mu <= 1.0)) Bad("NextPeak", "mu", "in (0, 1]", mu);
  if (!(r > 0.0 && r < alpha)) Bad("NextPeak", "r", "in (0, alpha) rad", r);
  // cos(alpha - r') - cos(alpha) = mu^2 (cos(alpha - r) - cos(alpha)).
  return alpha - std::acos(std::cos(alpha) + mu * mu * PeakEnergy(alpha, r));
}

double MuFromPeaks(double alpha, double r0, double rn, int n) {
  if (!(alpha > 0.0 && alpha < kPi / 2)) Bad("MuFromPeaks", "alpha", "in (0, pi/2) rad", alpha);
  if (n < 1) Bad("MuFromPeaks", "n", ">= 1", n);
  if (!(r0 > 0.0 && r0 < alpha)) Bad("MuFromPeaks", "r0", "in (0, alpha) rad", r0);
  if (!(rn > 0.0 && rn < alpha)) Bad("MuFromPeaks", "rn", "in (0, alpha) rad", rn);
  return std::pow(PeakEnergy(alpha, rn) / PeakEnergy(alpha, r0), 1.0 / (2.0 * n));
}

}  // namespace rocklab::model
