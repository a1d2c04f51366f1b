// The complex model against eq. (10) itself, integrated here by code that is
// not rocklab's: free rocking of block 1 from alpha/2, the planar form of
// docs/errata.md item 4 (a particle at (x, y) = chi (cos psi, sin psi) under the
// radial force -sin(alpha - alpha chi)/alpha + (2 ln mu / pi) l chi'/chi^2,
// angular momentum x y' - y x' = l; theta = alpha x), in normalised time,
// by an adaptive Dormand-Prince 5(4) pair in long double with absolute
// tolerances scaled to the crossing (1e-6 l: a crossing passes the origin at
// the distance l / v), impacts (x = 0) located by bisecting the step.
// At l = 1e-8 every crossing is resolved in double precision time (it lasts
// ~ l / v^2 / p ~ 1e-8 s), so this is eq. (10)'s solution, not its limit.
// The model is run on each path a user takes: Simulate (`rocklab
// simulate`, `sweep`), AdvanceTo (fits) and Step at 1 kHz (the model node).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

#include "model/rocking_model.h"
#include "tests/paper_blocks.h"

namespace rocklab::model {
namespace {

using Real = long double;
constexpr Real kPiL = 3.141592653589793238462643383279502884L;
using ::rocklab::test::kBlock1;  // tests/paper_blocks.h

struct ExactRun {
  std::vector<double> impact_times;  // s
  std::vector<double> apex_times;    // s, where chi is largest between impacts
  std::vector<double> apex_energies;  // regularised energy there (normalised), 1
};

class Eq10 {
 public:
  Eq10(const BlockParams& b, Real l) : a_(b.alpha), p_(b.p), l_(l), d_(2 * std::log((Real)b.mu) / kPiL) {}

  ExactRun FreeRocking(Real theta0, Real duration_s, int impacts) const {
    std::array<Real, 4> y{theta0 / a_, 0, 0, l_ / (theta0 / a_)};  // x, y, x', y' (normalised)
    const Real t_end = duration_s * p_;
    Real t = 0, h = 1e-3L;
    ExactRun run;
    run.apex_times.push_back(0.0);  // released at rest: the first apex
    run.apex_energies.push_back(static_cast<double>(Energy(y)));
    while (t < t_end && static_cast<int>(run.impact_times.size()) < impacts) {
      std::array<Real, 4> y1, err;
      h = std::min(h, t_end - t);
      Step(y, h, y1, err);
      Real e = 0;
      for (int i = 0; i < 4; ++i) {
        const Real atol = 1e-8L * l_;
        e = std::max(e, std::abs(err[i]) / (atol + 1e-15L * std::abs(y1[i])));
      }
      if (e > 1) {
        h *= std::max((Real)0.2, 0.9L * std::pow(e, -0.2L));
        continue;
      }
      if ((y[0] > 0) != (y1[0] > 0) && y1[0] != 0) {
        // x crosses 0 within the step: bisect its length.
        Real lo = 0, hi = h;
        for (int k = 0; k < 200 && hi - lo > 1e-30L; ++k) {
          const Real mid = (lo + hi) / 2;
          std::array<Real, 4> ym, em;
          Step(y, mid, ym, em);
          ((ym[0] > 0) == (y[0] > 0) ? lo : hi) = mid;
        }
        run.impact_times.push_back(static_cast<double>((t + hi) / p_));
      } else if (Radial(y) > 0 && Radial(y1) <= 0) {
        // chi at its largest within the step: bisect its length.
        Real lo = 0, hi = h;
        for (int k = 0; k < 200 && hi - lo > 1e-30L; ++k) {
          const Real mid = (lo + hi) / 2;
          std::array<Real, 4> ym, em;
          Step(y, mid, ym, em);
          (Radial(ym) > 0 ? lo : hi) = mid;
        }
        std::array<Real, 4> ya, ea;
        Step(y, hi, ya, ea);
        run.apex_times.push_back(static_cast<double>((t + hi) / p_));
        run.apex_energies.push_back(static_cast<double>(Energy(ya)));
      }
      t += h;
      y = y1;
      h *= std::min((Real)5, 0.9L * std::pow(std::max(e, (Real)1e-10), -0.2L));
    }
    return run;
  }

 private:
  static Real Chi(const std::array<Real, 4>& y) { return std::hypot(y[0], y[1]); }
  static Real Radial(const std::array<Real, 4>& y) { return y[0] * y[2] + y[1] * y[3]; }
  Real Energy(const std::array<Real, 4>& y) const {
    return (y[2] * y[2] + y[3] * y[3]) / 2 + (std::cos(a_ - a_ * Chi(y)) - std::cos(a_)) / (a_ * a_);
  }
  void Rhs(const std::array<Real, 4>& y, std::array<Real, 4>& f) const {
    const Real chi = Chi(y);
    const Real chi_dot = (y[0] * y[2] + y[1] * y[3]) / chi;
    const Real force = -std::sin(a_ - a_ * chi) / a_ + d_ * l_ * chi_dot / (chi * chi);
    f = {y[2], y[3], force * y[0] / chi, force * y[1] / chi};
  }
  // One Dormand-Prince 5(4) step (the coefficients of Dormand and Prince, 1980).
  void Step(const std::array<Real, 4>& y, Real h, std::array<Real, 4>& y5, std::array<Real, 4>& err) const {
    static const Real c[7][6] = {
        {0, 0, 0, 0, 0, 0},
        {1.0L / 5, 0, 0, 0, 0, 0},
        {3.0L / 40, 9.0L / 40, 0, 0, 0, 0},
        {44.0L / 45, -56.0L / 15, 32.0L / 9, 0, 0, 0},
        {19372.0L / 6561, -25360.0L / 2187, 64448.0L / 6561, -212.0L / 729, 0, 0},
        {9017.0L / 3168, -355.0L / 33, 46732.0L / 5247, 49.0L / 176, -5103.0L / 18656, 0},
        {35.0L / 384, 0, 500.0L / 1113, 125.0L / 192, -2187.0L / 6784, 11.0L / 84}};
    static const Real b5[7] = {35.0L / 384, 0, 500.0L / 1113, 125.0L / 192, -2187.0L / 6784, 11.0L / 84, 0};
    static const Real b4[7] = {5179.0L / 57600, 0, 7571.0L / 16695, 393.0L / 640, -92097.0L / 339200,
                               187.0L / 2100, 1.0L / 40};
    std::array<std::array<Real, 4>, 7> k;
    for (int s = 0; s < 7; ++s) {
      std::array<Real, 4> ys = y;
      for (int j = 0; j < s; ++j) {
        for (int i = 0; i < 4; ++i) ys[i] += h * c[s][j] * k[j][i];
      }
      Rhs(ys, k[s]);
    }
    for (int i = 0; i < 4; ++i) {
      Real s5 = 0, s4 = 0;
      for (int s = 0; s < 7; ++s) {
        s5 += b5[s] * k[s][i];
        s4 += b4[s] * k[s][i];
      }
      y5[i] = y[i] + h * s5;
      err[i] = h * (s5 - s4);
    }
  }

  Real a_, p_, l_, d_;
};

std::vector<double> ImpactTimes(const std::vector<ModelEvent>& events) {
  std::vector<double> out;
  for (const auto& e : events) {
    if (e.kind == EventKind::kImpact) out.push_back(e.time_s);
  }
  return out;
}

// Oracle: the integration above (its own error: 1e-9 s at the 10th impact,
// measured by tightening its tolerances 100 times). Tolerances: impact
// times 1.3e-6 s on every path over 10 impacts (3x the worst measured,
// 4.4e-7 s through Simulate; the bound set is 2e-6 s); the energy
// ratio between consecutive excursions (regularised energy at the apex,
// the crossing's loss) within 1e-6 of the exact one (measured below).
TEST(ComplexExactTest, FreeRockingAtL1e8MatchesEq10OnEveryPath) {
  const double l = 1e-8, theta0 = kBlock1.alpha / 2;
  const ExactRun exact = Eq10(kBlock1, l).FreeRocking(theta0, 4.0, 10);
  ASSERT_EQ(exact.impact_times.size(), 10u);
  ModelOptions o;
  o.l = l;
  const NoTableMotion none;
  auto worst = [&](const std::vector<double>& got) {
    double w = 0;
    for (std::size_t i = 0; i < 10 && i < got.size(); ++i) w = std::max(w, std::abs(got[i] - exact.impact_times[i]));
    return w;
  };
  auto m = RockingModel::Create(ModelKind::kComplex, kBlock1, o);
  const Trajectory sim = Simulate(*m, none, 0.0, theta0, 0.0, 4.0, 10000.0);
  const double w_sim = worst(ImpactTimes(sim.events));
  m->Reset(0.0, theta0, 0.0);
  for (int k = 1; k <= 4000; ++k) m->AdvanceTo(k * 1e-3, none);
  const double w_to = worst(ImpactTimes(m->events()));
  m->Reset(0.0, theta0, 0.0);
  for (int k = 0; k <= 4000; ++k) m->Step(k * 1e-3, 0.0);
  const double w_step = worst(ImpactTimes(m->events()));
  std::printf("exact eq. (10) at l = 1e-8: 10th impact %.9f s; worst of 10: Simulate %.2e s, AdvanceTo %.2e s, "
              "Step %.2e s\n",
              exact.impact_times[9], w_sim, w_to, w_step);
  EXPECT_GE(ImpactTimes(sim.events).size(), 10u);
  EXPECT_LT(w_sim, 1.3e-6);
  EXPECT_LT(w_to, 1.3e-6);
  EXPECT_LT(w_step, 1.3e-6);

  // Energy at each apex: the model's state there, regularised energy from
  // chi (theta_dot ~ 0 at the apex; its kinetic part is kept).
  ASSERT_GE(exact.apex_times.size(), 10u);
  m->Reset(0.0, theta0, 0.0);
  std::vector<double> model_energy;
  const double a = kBlock1.alpha;
  for (std::size_t n = 0; n < 10; ++n) {
    m->AdvanceTo(exact.apex_times[n], none);
    const ModelState& st = m->state();
    const double c = std::cos(st.psi);
    const double v = st.theta_dot / (a * kBlock1.p * c);
    model_energy.push_back(v * v / 2 + (std::cos(a - a * st.chi) - std::cos(a)) / (a * a));
  }
  double worst_ratio = 0;
  for (std::size_t n = 1; n < 10; ++n) {
    const double want = exact.apex_energies[n] / exact.apex_energies[n - 1];
    const double got = model_energy[n] / model_energy[n - 1];
    worst_ratio = std::max(worst_ratio, std::abs(got - want));
  }
  std::printf("energy ratio per crossing: worst |model - exact| %.2e over 9 crossings\n", worst_ratio);
  EXPECT_LT(worst_ratio, 3.5e-8);  // 3x the measured 1.1e-8; the issue asks 1e-6
}

}  // namespace
}  // namespace rocklab::model
