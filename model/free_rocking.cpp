#include "model/free_rocking.h"

#include "model/numbers.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
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

namespace {

// Housner's free equation theta'' = -p^2 sin(alpha s - theta) on pivot s,
// one classical RK4 step of length h (autonomous: no time needed).
struct FreeHousnerPivot {
  double a_side;  // alpha_s s, rad
  double p2;      // p_s^2, 1/s^2
  void Step(double h, double th, double thd, double& th1, double& thd1) const {
    const double k1 = thd, l1 = -p2 * std::sin(a_side - th);
    const double k2 = thd + 0.5 * h * l1, l2 = -p2 * std::sin(a_side - (th + 0.5 * h * k1));
    const double k3 = thd + 0.5 * h * l2, l3 = -p2 * std::sin(a_side - (th + 0.5 * h * k2));
    const double k4 = thd + h * l3, l4 = -p2 * std::sin(a_side - (th + h * k3));
    th1 = th + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    thd1 = thd + h / 6.0 * (l1 + 2.0 * l2 + 2.0 * l3 + l4);
  }
};

}  // namespace

FreeHousnerRun SampleFreeHousner(const BlockParams& params, double t0_s, double theta0, double theta_dot0,
                                 const double* t_s, std::size_t n, double* theta, double rest_impact_interval_s,
                                 std::vector<double>* impact_times_s) {
  params.Validate();
  if (!std::isfinite(t0_s)) Bad("SampleFreeHousner", "t0_s", "finite", t0_s);
  if (!(std::abs(theta0) < kPi / 2)) Bad("SampleFreeHousner", "theta0", "finite with |theta0| < pi/2 rad", theta0);
  if (!std::isfinite(theta_dot0)) Bad("SampleFreeHousner", "theta_dot0", "finite", theta_dot0);
  if (!(rest_impact_interval_s >= 0.0)) {
    Bad("SampleFreeHousner", "rest_impact_interval_s", ">= 0 s", rest_impact_interval_s);
  }
  FreeHousnerRun run;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  int side = theta0 > 0.0 || (theta0 == 0.0 && theta_dot0 > 0.0) ? +1 : -1;
  auto pivot = [&params](int s) {
    const SideParams sp = params.Side(s);
    return FreeHousnerPivot{sp.alpha * s, sp.p * sp.p};
  };
  FreeHousnerPivot piv = pivot(side);
  const double h_max = kFreeHousnerMaxPh / std::max(params.Side(+1).p, params.Side(-1).p);
  double tc = t0_s, th = theta0, thd = theta_dot0;
  double last_impact = -std::numeric_limits<double>::infinity();
  bool rest = theta0 == 0.0 && theta_dot0 == 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double ti = t_s[i];
    if (!(ti >= tc || run.overturned)) {
      Bad("SampleFreeHousner", "t_s", "non-decreasing and >= t0_s", ti);
    }
    if (run.overturned) {
      theta[i] = nan;
      continue;
    }
    while (!rest && tc < ti) {
      // Equal steps to the sample, none longer than h_max.
      const double span = ti - tc;
      const double m = std::ceil(span / h_max);
      const bool last = m <= 1.0;
      const double h = last ? span : span / m;
      double th1 = 0.0, thd1 = 0.0;
      piv.Step(h, th, thd, th1, thd1);
      const double g0 = th + side * kHousnerImpactSlackRad;
      const double g1 = th1 + side * kHousnerImpactSlackRad;
      const bool impact = side > 0 ? (g0 > 0.0 && g1 <= 0.0) : (g0 < 0.0 && g1 >= 0.0);
      if (!impact) {
        if (side * th1 >= kPi / 2) {
          run.overturned = true;
          break;
        }
        tc = last ? ti : tc + h;
        th = th1;
        thd = thd1;
        continue;
      }
      // The impact on this step: Newton on tau -> theta of an RK4 step of
      // length tau (its derivative there is the step's theta_dot to
      // O(tau^4)), from the chord's root, kept inside (0, h].
      double tau = h * g0 / (g0 - g1);
      double thi = 0.0, thdi = 0.0;
      piv.Step(tau, th, thd, thi, thdi);
      for (int it = 0; it < 20; ++it) {
        const double f = thi + side * kHousnerImpactSlackRad;
        if (f == 0.0 || thdi == 0.0) break;
        double next = tau - f / thdi;
        if (!(next > 0.0)) next = tau / 2;
        if (next > h) next = h;
        const bool done = std::abs(next - tau) <= 1e-15 * (1.0 + std::abs(tc));
        tau = next;
        piv.Step(tau, th, thd, thi, thdi);  // thi, thdi always of this tau
        if (done) break;
      }
      const double t_imp = last && tau >= h ? ti : tc + tau;
      ++run.impacts;
      if (impact_times_s != nullptr) impact_times_s->push_back(t_imp);
      tc = t_imp;
      if (t_imp - last_impact < rest_impact_interval_s) {
        rest = true;
        run.rested = true;
        th = thd = 0.0;
        break;
      }
      last_impact = t_imp;
      side = -side;
      piv = pivot(side);
      th = 0.0;
      thd = thdi * params.Side(side).mu;
    }
    if (run.overturned) {
      theta[i] = nan;
      continue;
    }
    theta[i] = rest ? 0.0 : th;
  }
  return run;
}

}  // namespace rocklab::model
