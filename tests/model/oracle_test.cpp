// Independent oracles for the forced response of rocklab's Housner model
// (docs/testing.md). Nothing here calls rocklab's model code except the
// model under test through its public API (model/rocking_model.h); the table
// motions, the reference integrator and the closed forms are written here from
// docs/errata.md items 5, 6 and 11 and docs/commands.md's definition of the excitations (`simulate --excitation`).
// The golden files of scenario_test.cpp stay as a regression check only.
//
// 1. Closed form: the linearised slender block under a rectangular pulse of
//    table acceleration. Housner's equation (docs/errata.md item 5) on the +x corner,
//      theta'' = -p^2 [ sin(alpha - theta) + (u_g''/g) cos(alpha - theta) ],
//    linearised for alpha, theta << 1 (sin x ~ x, cos x ~ 1):
//      theta'' = p^2 (theta - alpha - u_g''/g).
//    A block at rest under u_g'' = -A (A > g tan alpha) from t = 0 lifts off
//    at once on its +x corner (docs/errata.md item 6: u_g'' < -g tan alpha gives theta > 0).
//    With e = A/g - alpha, theta(0) = theta'(0) = 0:
//      theta(t) = e (cosh(p t) - 1),   theta'(t) = e p sinh(p t),  t <= td.
//    After the pulse (s = t - td), theta'' = p^2 (theta - alpha):
//      theta - alpha = -c cosh(p s) + d sinh(p s),
//      c = alpha - theta(td) > 0,  d = theta'(td) / p.
//    For d < c this is -sqrt(c^2 - d^2) cosh(p (s - s*)) with
//    tanh(p s*) = d / c: the peak is alpha - sqrt(c^2 - d^2) at s = s*, and
//    the first impact (theta = 0) at cosh(p (s - s*)) = alpha / sqrt(c^2 - d^2),
//      t_impact = td + s* + acosh(alpha / sqrt(c^2 - d^2)) / p,
//    which is eq. (13) of the paper, T(r) = acosh(1 / (1 - r/alpha)) / p,
//    for the peak r (docs/errata.md item 2). For the constant pulse (td -> infinity) the
//    block leaves as theta = e (cosh(p t) - 1) and never comes back.
//    The nonlinear model departs from these by O(alpha^2) relative: on
//    [0, 2 alpha], sin x = x (1 - x^2/6 + ...) and cos x = 1 - x^2/2 + ...
//
// 2. A reference integrator: Housner's equation above (both corners), the
//    rest/uplift rule of docs/errata.md item 6 (rest until |u_g''| > g tan alpha, uplift
//    towards -sgn(u_g'')), impacts at theta = 0 with theta' <- mu theta', the
//    corner switching, and back to rest when two impacts come closer than
//    2 ms (the rule in docs/models.md), integrated by classical fixed-step RK4 at
//    h = 1e-5 s (2 M steps for figure 8's 20 s: 0.6 s at -O2), events
//    located by bisection of the step length (to 1e-14 s).
//    Its error is measured in ReferenceIntegratorConvergesAtFourthOrder: the
//    same run at 2h differs by D, so the h run is within D/15 (RK4's error
//    scales as h^4). It reproduces the figure 8 and figure 7 figures the issue
//    quotes from a third, independent RK4 (peak 0.024721 rad and 199 impacts;
//    peak 0.038490 rad) and the closed forms of (1) in its linearised mode.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <vector>

#include "common/bus.h"
#include "common/direct_bus.h"
#include "model/model_node.h"
#include "model/rocking_model.h"
#include "tests/model/rk4_reference.h"
#include "rocklab/event2_t.hpp"
#include "common/units.h"

namespace rocklab::model {
namespace {

using ::rocklab::common::kPi;  // one pi for the tests a unity batch shares
constexpr double kG = 9.81;  // m/s^2, the g of the model library (model/block.h)

// ---------------------------------------------------------------------------
// Table motions, from docs/commands.md (`--excitation`) and docs/errata.md item 11, written here.
// u(t) = U W(t) sin(w (t - start)) on [start, start + duration], zero outside,
// W = 1 (sine) or the Hanning window (1 + cos(pi x / a)) / 2, x = t - tc,
// a = duration / 2, tc = start + a. Returns u''(t), m/s^2:
//   u'' = U [ W'' sin + 2 W' w cos - W w^2 sin ],
//   W' = -(pi / 2a) sin(pi x / a),  W'' = -(pi^2 / 2a^2) cos(pi x / a).
struct OracleTableMotion {
  double amp_m{};
  double freq_hz{};
  double duration_s{};
  double start_s{};
  bool hanning{};
  // At the ends u'' can jump (the window's W'' is not zero there): `left`
  // picks the limit from the left, else from the right.
  double Accel(double t, bool left = false) const {
    const double end = start_s + duration_s;
    if (left ? (t <= start_s || t > end) : (t < start_s || t >= end)) return 0.0;
    const double w = 2 * kPi * freq_hz;
    const double ph = w * (t - start_s);
    double win = 1, d1 = 0, d2 = 0;
    if (hanning) {
      const double a = duration_s / 2, x = t - (start_s + a), k = kPi / a;
      win = 0.5 * (1 + std::cos(k * x));
      d1 = -0.5 * k * std::sin(k * x);
      d2 = -0.5 * k * k * std::cos(k * x);
    }
    return amp_m * (d2 * std::sin(ph) + 2 * d1 * w * std::cos(ph) - win * w * w * std::sin(ph));
  }
};

// Figure 7: block 1 (Table 2, p of Table 2: docs/errata.md item 10) under
// hanning:amp=0.006,freq=3.3,duration=4,start=0.5 over 8 s; figure 8: block 2
// under sine:amp=0.006,freq=5,duration=20,start=0 over 20 s (pipeline/scenario.*,
// tests/model/scenario_test.cpp, docs/models.md).
struct Case {
  const char* name;
  BlockParams params;
  OracleTableMotion motion;
  const char* spec;
  double duration_s;
};
const Case kFig7{"fig7", {0.235, 3.884, 0.937}, {0.006, 3.3, 4.0, 0.5, true},
                 "hanning:amp=0.006,freq=3.3,duration=4,start=0.5", 8.0};
const Case kFig8{"fig8", {0.168, 3.767, 0.942}, {0.006, 5.0, 20.0, 0.0, false},
                 "sine:amp=0.006,freq=5,duration=20,start=0", 20.0};

// ---------------------------------------------------------------------------
// The reference integrator: tests/model/rk4_reference.h.
using test::rk4::Accel;
using test::rk4::RefOptions;
using test::rk4::RefResult;
using test::rk4::Reference;

RefResult RunReference(const Case& c, RefOptions o = {}) {
  const OracleTableMotion m = c.motion;
  o.breaks_s = {m.start_s, m.start_s + m.duration_s};
  return Reference(c.params, [m](double t, bool left) { return m.Accel(t, left); }, o).Run(c.duration_s);
}

// rocklab's Housner model (or another) on the same case, sampled at 100 Hz.
Trajectory RunRocklab(const Case& c, ModelKind kind = ModelKind::kHousner, const ModelOptions& options = {}) {
  auto model = RockingModel::Create(kind, c.params, options);
  const auto excitation = ParseExcitation(c.spec);
  return Simulate(*model, *excitation, 0.0, 0.0, 0.0, c.duration_s, 100.0);
}

std::vector<double> Times(const Trajectory& t, EventKind kind) {
  std::vector<double> out;
  for (const auto& e : t.events) {
    if (e.kind == kind) out.push_back(e.time_s);
  }
  return out;
}

double MaxAbsDiff(const std::vector<double>& a, const std::vector<double>& b) {
  double worst = 0;
  for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i) worst = std::max(worst, std::abs(a[i] - b[i]));
  return worst;
}

double MaxAbs(const std::vector<double>& v) {
  double m = 0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

// Oracle: the test's own table motion against the library's (both from the
// docs/commands.md's definition; docs/errata.md item 11: the exact second derivative).
// Tolerance: 1e-9 m/s^2 on peaks of 2.6 and 5.9 m/s^2 (round-off of two
// different but exact formulas).
TEST(OracleTest, TableMotionsAgreeWithTheLibrarys) {
  for (const Case* c : {&kFig7, &kFig8}) {
    const auto e = ParseExcitation(c->spec);
    for (double t = 0; t <= c->duration_s; t += 1e-3) {
      ASSERT_NEAR(e->TableAcceleration(t), c->motion.Accel(t), 1e-9) << c->name << " t " << t;
    }
  }
}

// Oracle: RK4's global error scales as h^4, so |x(h) - x(2h)| = 15 |x(h) -
// x_exact| to leading order: the h = 1e-5 s run's error is the difference
// to the 2e-5 s run over 15. Measured: figure 8 (20 s, 199 impacts, 2 M
// steps) impact times differ by 3.8e-12 s and theta samples by 2.3e-12 rad;
// figure 7 (8 s, 92 impacts) by 1.2e-10 s and 1.0e-11 rad. The reference is
// thus good to ~1e-11 s and ~1e-12 rad, far below the tolerances of the
// comparisons below. (Steps land on the forcing's discontinuities, e.g. the
// end of the Hanning window, and a stage there takes the one-sided value of
// its step: without that the error was 1.4e-7 s, first order.) Asserted
// with a margin of ~10 for other compilers and libm: 1e-9 s, 1e-9 rad.
TEST(OracleTest, ReferenceIntegratorConvergesAtFourthOrder) {
  for (const Case* c : {&kFig8, &kFig7}) {
    const RefResult fine = RunReference(*c);
    RefOptions coarse_options;
    coarse_options.h_s = 2e-5;
    const RefResult coarse = RunReference(*c, coarse_options);
    ASSERT_EQ(fine.impact_times.size(), coarse.impact_times.size()) << c->name;
    const double dt = MaxAbsDiff(fine.impact_times, coarse.impact_times);
    const double dth = MaxAbsDiff(fine.sample_theta, coarse.sample_theta);
    std::printf("%s: reference h vs 2h: impact times %.3e s, theta %.3e rad\n", c->name, dt, dth);
    EXPECT_LT(dt, 1e-9) << c->name;
    EXPECT_LT(dth, 1e-9) << c->name;
  }
}

// Oracle: the figures of a third, independent RK4 quoted in scenario_test.cpp: figure
// 8 peaks at 0.024721 rad (first excursion) with 199 impacts in 20 s, figure
// 7 at 0.038490 rad. The quoted figures are cut, not rounded, to six decimals
// (this reference gives 0.0247214 and 0.0384908 rad): each peak must lie in
// [quoted, quoted + 1e-6) rad.
TEST(OracleTest, ReferenceReproducesTheQuotedFigures) {
  const RefResult f8 = RunReference(kFig8);
  std::printf("reference fig8: peak %.7f rad at %.4f s, %zu impacts, uplift %.6f s\n", f8.peak, f8.peak_time,
              f8.impact_times.size(), f8.uplift_times.empty() ? -1.0 : f8.uplift_times[0]);
  EXPECT_GE(f8.peak, 0.024721);
  EXPECT_LT(f8.peak, 0.024722);
  EXPECT_EQ(f8.impact_times.size(), 199u);
  const RefResult f7 = RunReference(kFig7);
  std::printf("reference fig7: peak %.7f rad at %.4f s, %zu impacts\n", f7.peak, f7.peak_time,
              f7.impact_times.size());
  EXPECT_GE(f7.peak, 0.038490);
  EXPECT_LT(f7.peak, 0.038491);
  // Figure 7's impacts: the paper prints none (its figure 7 is a plot; the
  // text gives only the parameters), so the count is this reference's: 92
  // in 8 s, the same at h and 2h (ReferenceIntegratorConvergesAtFourthOrder),
  // and rocklab's Housner must match it (HousnerFigure7MatchesTheReference,
  // ScenarioTest.ComplexAgreesWithHousnerFigure7).
  EXPECT_EQ(f7.impact_times.size(), 92u);
}

// Oracle: the reference integrator. rocklab's Housner model (CVODE, rtol
// 1e-10, root finding) must give the same uplift, the same impacts at the
// same times, and the same theta at every 100 Hz sample.
// Measured (this machine): figure 8 impact times within 1.1e-10 s, theta
// within 3.9e-11 rad. Figure 7 within 2.4e-7 s and 2.1e-8 rad: its table
// acceleration jumps by 7e-3 m/s^2 where the Hanning window ends (4.5 s; the
// window's second derivative is not zero there), which CVODE steps across
// (max step 1e-3 s); up to 4.5 s the two agree to ~1e-10 s.
// Tolerances: figure 8 1e-8 s and 1e-9 rad, figure 7 1e-6 s and 1e-7 rad:
// ~100x and ~4x the measured, for CVODE's step choices on other platforms.
// A wrong term is far outside them: replacing cos(alpha sgn(theta) - theta)
// by cos(alpha sgn(theta)) in Housner's forcing term (applied to
// model/housner.cpp, run, reverted) moves figure 8's impacts by up to
// 1.5e-3 s and theta by 6.1e-4 rad, figure 7's by 1.5e-3 s and 1.8e-4 rad.
// (The closed-form tests below do not see it: at alpha = 0.01 the term is
// within their O(alpha^2) allowance.)
struct Tolerance {
  double time_s, theta_rad;
};

void CompareWithReference(const Case& c, Tolerance tol, const ModelOptions& options = {},
                          const RefResult* reference = nullptr) {
  const RefResult ref = reference != nullptr ? *reference : RunReference(c);
  const Trajectory got = RunRocklab(c, ModelKind::kHousner, options);
  const auto impacts = Times(got, EventKind::kImpact);
  const auto uplifts = Times(got, EventKind::kUplift);
  ASSERT_EQ(got.theta.size(), ref.sample_theta.size()) << c.name;
  const double dth = MaxAbsDiff(got.theta, ref.sample_theta);
  const double dt = MaxAbsDiff(impacts, ref.impact_times);
  const double du = MaxAbsDiff(uplifts, ref.uplift_times);
  std::printf("%s (%s): rocklab vs reference: %zu/%zu impacts, max |dt| %.3e s, uplift |dt| %.3e s, "
              "max |dtheta| %.3e rad, peaks %.7f/%.7f rad\n",
              c.name, ToString(options.integrator), impacts.size(), ref.impact_times.size(), dt, du, dth,
              MaxAbs(got.theta),
              MaxAbs(ref.sample_theta));
  EXPECT_EQ(impacts.size(), ref.impact_times.size()) << c.name;
  EXPECT_EQ(uplifts.size(), ref.uplift_times.size()) << c.name;
  EXPECT_LT(dt, tol.time_s) << c.name;
  EXPECT_LT(du, tol.time_s) << c.name;
  EXPECT_LT(dth, tol.theta_rad) << c.name;
  EXPECT_NEAR(MaxAbs(got.theta), MaxAbs(ref.sample_theta), tol.theta_rad) << c.name;
}

TEST(OracleTest, HousnerFigure8MatchesTheReference) { CompareWithReference(kFig8, {1e-8, 1e-9}); }
TEST(OracleTest, HousnerFigure7MatchesTheReference) { CompareWithReference(kFig7, {1e-6, 1e-7}); }

// Oracle: the same reference, for Dormand-Prince 8(5,3) (model/dop853.h,
// what `rocklab simulate` integrates Housner's model with) at the same rtol
// 1e-10: the tolerances of Adams above, not widened. Measured (this machine):
// figure 8 impacts within 1.3e-11 s, theta within 8.2e-12 rad (Adams:
// 2.6e-10 s, 1.0e-10 rad); figure 7 within 3.0e-9 s and 6.8e-10 rad
// (Adams: 4.4e-8 s, 3.9e-9 rad), the window's end stepped across by the
// error test as Adams does.
TEST(OracleTest, HousnerDormandPrinceMatchesTheReference) {
  ModelOptions dp;
  dp.integrator = Integrator::kDormandPrince853;
  CompareWithReference(kFig8, {1e-8, 1e-9}, dp);
  CompareWithReference(kFig7, {1e-6, 1e-7}, dp);
}

// Oracle: eq. (10)'s l -> 0 limit integrated by the reference (RefOptions::
// limit_w: restitution mu^(1/w) and the line turned by pi / w per
// crossing, written here from Binet's equation), against rocklab's complex
// model through Simulate, the path of `rocklab simulate`, at l = 1e-10,
// 1e-12 and 1e-14: the same impacts, their times and theta at 100 Hz.
// The finite-l part is the uplift's seed (alpha sqrt(l), ray turned by
// ~ l^(1/6)) and the crossings' O(l / v^3); figure 7 converges last
// (its block chatters at energies ~ 1e-5 M g R before the pulse pumps it).
// Tolerances ~3x the measured (printed), and the distance to the limit
// must shrink as l does (a converged model approaches its limit
// monotonically); the peak stays within 0.3 % of Housner's and within
// 0.1 % across l. Measured: figure 8 impacts 2.2e-5, 6.8e-6, 2.2e-6 s and
// theta 2.4e-5, 1.1e-5, 5.0e-6 rad; figure 7 1.0e-3, 8.1e-4, 3.3e-4 s
// and 3.9e-4, 3.4e-4, 1.4e-4 rad (l = 1e-10, 1e-12, 1e-14).
struct ComplexTolerance {
  double l, time_s, theta_rad;
};

// Also the posterior's model run (rtol 1e-6, atol 1e-10; the complex
// model's core criterion and transverse tolerance then scale with rtol,
// model/complex.cpp) at `loose.l`: held to `loose`'s tolerances, which are
// those of the rtol 1e-10 run at the same l (the looser run must stay as
// close to eq. (10)'s limit as the default one).
void CompareComplexWithLimit(const Case& c, const std::vector<ComplexTolerance>& tols, const ComplexTolerance& loose) {
  const double w = std::sqrt(1 - std::pow(std::log(c.params.mu) / kPi, 2));
  RefOptions o;
  o.limit_w = w;
  const RefResult ref = RunReference(c, o);
  const RefResult housner = RunReference(c);
  std::printf("%s: eq. (10) limit: peak %.7f rad, %zu impacts; Housner %.7f rad, %zu impacts\n", c.name, ref.peak,
              ref.impact_times.size(), housner.peak, housner.impact_times.size());
  double last_dt = 1e300, lo_peak = 1e300, hi_peak = 0;
  for (const ComplexTolerance& tol : tols) {
    ModelOptions mo;
    mo.l = tol.l;
    const Trajectory got = RunRocklab(c, ModelKind::kComplex, mo);
    const auto impacts = Times(got, EventKind::kImpact);
    const double dt = MaxAbsDiff(impacts, ref.impact_times);
    const double dth = MaxAbsDiff(got.theta, ref.sample_theta);
    std::printf("%s l=%g: complex vs limit: %zu/%zu impacts, max |dt| %.3e s, max |dtheta| %.3e rad, "
                "peak %.7f rad\n",
                c.name, tol.l, impacts.size(), ref.impact_times.size(), dt, dth, MaxAbs(got.theta));
    EXPECT_EQ(impacts.size(), ref.impact_times.size()) << c.name << " l " << tol.l;
    EXPECT_LT(dt, tol.time_s) << c.name << " l " << tol.l;
    EXPECT_LT(dth, tol.theta_rad) << c.name << " l " << tol.l;
    EXPECT_LT(dt, last_dt) << c.name << " l " << tol.l << ": not closer to the limit than at the larger l";
    last_dt = dt;
    const double peak = MaxAbs(got.theta);
    lo_peak = std::min(lo_peak, peak);
    hi_peak = std::max(hi_peak, peak);
    EXPECT_NEAR(peak / MaxAbs(housner.sample_theta), 1.0, 3e-3) << c.name << " l " << tol.l;
  }
  EXPECT_LT(hi_peak / lo_peak - 1, 1e-3) << c.name;
  ModelOptions mo;
  mo.l = loose.l;
  mo.rtol = 1e-6;
  mo.atol = 1e-10;
  const Trajectory got = RunRocklab(c, ModelKind::kComplex, mo);
  const auto impacts = Times(got, EventKind::kImpact);
  const double dt = MaxAbsDiff(impacts, ref.impact_times);
  const double dth = MaxAbsDiff(got.theta, ref.sample_theta);
  std::printf("%s l=%g rtol 1e-6: complex vs limit: %zu/%zu impacts, max |dt| %.3e s, max |dtheta| %.3e rad\n", c.name,
              loose.l, impacts.size(), ref.impact_times.size(), dt, dth);
  EXPECT_EQ(impacts.size(), ref.impact_times.size()) << c.name << " rtol 1e-6";
  EXPECT_LT(dt, loose.time_s) << c.name << " rtol 1e-6";
  EXPECT_LT(dth, loose.theta_rad) << c.name << " rtol 1e-6";
}

TEST(OracleTest, ComplexFigure8ConvergesToEq10sLimit) {
  CompareComplexWithLimit(kFig8, {{1e-10, 7e-5, 7e-5}, {1e-12, 2e-5, 3.3e-5}, {1e-14, 6.5e-6, 1.5e-5}},
                          {1e-14, 6.5e-6, 1.5e-5});
}
TEST(OracleTest, ComplexFigure7ConvergesToEq10sLimit) {
  CompareComplexWithLimit(kFig7, {{1e-10, 3e-3, 1.2e-3}, {1e-12, 2.4e-3, 1e-3}, {1e-14, 1e-3, 4.2e-4}},
                          {1e-14, 1e-3, 4.2e-4});
}

// Oracle: eq. (10)'s l -> 0 limit integrated by the reference (limit_w, as
// above). The overturning threshold of block 1 under a half-sine pulse
// a_p sin(pi t / 0.5 s) on [0, 0.5 s], by bisection to 1e-6 g of each
// (5 s runs), must agree to 4 digits at the default l: within 5e-5 g (half
// a unit of the fourth digit of 0.3866 g). Measured (docs/models.md,
// "Choosing l", rocklab_l_study): limit 0.386573 g; the complex model
// +5.0e-6 g at l = 1e-14, +1.1e-4 g at the former default 1e-10, which
// this test rejects.
TEST(OracleTest, HalfSineThresholdMatchesEq10sLimitAtTheDefaultL) {
  const BlockParams b{0.235, 3.884, 0.937};
  const double tp = 0.5, duration = 5.0;
  auto bisect = [](auto overturns, double lo, double hi) {
    while (hi - lo > 1e-6) {
      const double mid = 0.5 * (lo + hi);
      (overturns(mid) ? hi : lo) = mid;
    }
    return 0.5 * (lo + hi);
  };
  auto limit_overturns = [&](double a_g) {
    RefOptions o;
    o.limit_w = std::sqrt(1 - std::pow(std::log(b.mu) / kPi, 2));
    o.breaks_s = {tp};
    o.sample_rate_hz = 10;
    o.h_s = 2e-5;
    const double amp = a_g * kG;
    const auto accel = [amp, tp](double t, bool left) {
      const bool in = left ? (t > 0 && t <= tp) : (t >= 0 && t < tp);
      return in ? amp * std::sin(kPi * t / tp) : 0.0;
    };
    return Reference(b, accel, o).Run(duration).sample_theta.size() < 10 * duration + 1;
  };
  class HalfSine final : public Forcing {
   public:
    HalfSine(double a, double t_p) : a_(a), tp_(t_p) {}
    double TableAcceleration(double t) const override { return t >= 0 && t <= tp_ ? a_ * std::sin(kPi * t / tp_) : 0.0; }
    double NextDiscontinuity(double t) const override { return t < tp_ ? tp_ : std::numeric_limits<double>::infinity(); }

   private:
    double a_, tp_;
  };
  auto model_overturns = [&](double a_g) {
    auto m = RockingModel::Create(ModelKind::kComplex, b);
    m->Reset(0.0, 0.0, 0.0);
    m->AdvanceTo(duration, HalfSine(a_g * kG, tp));
    return m->state().regime == Regime::kOverturned;
  };
  const double limit = bisect(limit_overturns, 0.36, 0.42);
  const double model = bisect(model_overturns, 0.36, 0.42);
  std::printf("half-sine threshold: eq. (10) limit %.6f g, complex at the default l %.6f g (%+.2e g)\n", limit,
              model, model - limit);
  EXPECT_NEAR(model, limit, 5e-5);
}

// Oracle: the reference integrator with docs/errata.md item 6's rest rule read
// whole: impacts 2 ms apart put the block to rest only while the table
// cannot lift it. Block 1 on its +x corner at theta 1e-5 rad falling at
// 0.01 rad/s under a constant u_g'' = -1.5 g tan(alpha) (a push onto the
// +x corner): it lands on -x at 1.2 ms and is thrown back, landing again
// 1.8 ms later with |u_g''| above g tan(alpha). Without the table's
// condition the rule rests it there and lifts it off at the same instant
// with no velocity (the reference run so shows the rule firing); with it
// the block keeps its speed. Both models against the gated reference
// (complex: eq. (10)'s limit at l = 1e-14). Tolerances: 1e-8 s and 1e-8
// rad (Housner against the reference: 1e-10 measured; complex: its
// finite-l start, measured printed), against a difference of the gated and
// ungated runs of 1e-3 s and more.
TEST(OracleTest, NoRestWhileTheTableCouldLiftTheBlock) {
  const BlockParams b{0.235, 3.884, 0.937};
  const double ug = -1.5 * kG * std::tan(b.alpha);
  const auto push = [ug](double, bool) { return ug; };
  RefOptions o;
  o.theta0 = 1e-5;
  o.theta_dot0 = -0.01;
  o.sample_rate_hz = 1000;
  RefOptions ungated = o;
  ungated.rest_needs_quiet_table = false;
  const RefResult fired = Reference(b, push, ungated).Run(0.5);
  ASSERT_FALSE(fired.rest_times.empty()) << "the rule does not fire in this case: the test sees nothing";
  const double w = std::sqrt(1 - std::pow(std::log(b.mu) / kPi, 2));
  class Push final : public Forcing {
   public:
    explicit Push(double a) : a_(a) {}
    double TableAcceleration(double) const override { return a_; }

   private:
    double a_;
  } forcing(ug);
  for (ModelKind kind : {ModelKind::kHousner, ModelKind::kComplex}) {
    RefOptions ro = o;
    if (kind == ModelKind::kComplex) ro.limit_w = w;
    const RefResult ref = Reference(b, push, ro).Run(0.5);
    EXPECT_TRUE(ref.rest_times.empty());
    ModelOptions mo;
    mo.l = 1e-14;
    auto m = RockingModel::Create(kind, b, mo);
    const Trajectory got = Simulate(*m, forcing, 0.0, o.theta0, o.theta_dot0, 0.5, 1000.0);
    const auto impacts = Times(got, EventKind::kImpact);
    const double dt = MaxAbsDiff(impacts, ref.impact_times);
    const double dth = MaxAbsDiff(got.theta, ref.sample_theta);
    std::printf("%s: %zu/%zu impacts (ungated reference: rest at %.6f s), max |dt| %.2e s, max |dtheta| %.2e rad, "
                "theta(0.5 s) %.6f rad gated, %.6f ungated\n",
                ToString(kind), impacts.size(), ref.impact_times.size(), fired.rest_times[0], dt, dth,
                got.theta.back(), fired.sample_theta.back());
    EXPECT_EQ(Times(got, EventKind::kRest).size(), 0u) << ToString(kind);
    EXPECT_EQ(impacts.size(), ref.impact_times.size()) << ToString(kind);
    EXPECT_LT(dt, 1e-8) << ToString(kind);
    EXPECT_LT(dth, 1e-8) << ToString(kind);
    EXPECT_GT(std::abs(got.theta.back() - fired.sample_theta.back()), 100 * 1e-8) << ToString(kind);
  }
}

// ---------------------------------------------------------------------------
// Closed forms (the derivation is at the top of the file).

// u_g'' = -A on [0, td] (td < 0: for ever), zero after: the block lifts off at
// t = 0 towards +x.
class RectPulse final : public Forcing {
 public:
  RectPulse(double a_mps2, double td_s) : a_(a_mps2), td_(td_s) {}
  double TableAcceleration(double t) const override { return (td_ < 0 || t <= td_) ? -a_ : 0.0; }

 private:
  double a_, td_;
};

struct PulseClosedForm {
  double peak, peak_time, impact_time;
};

// The pulse's height A = (1 + excess) g alpha and length td = ptd / p.
PulseClosedForm ClosedForm(double alpha, double p, double excess, double ptd) {
  const double e = excess * alpha;  // A/g - alpha
  const double th1 = e * (std::cosh(ptd) - 1), d = e * std::sinh(ptd);
  const double c = alpha - th1;
  const double q = std::sqrt(c * c - d * d);
  const double s_star = std::atanh(d / c) / p;
  return {alpha - q, ptd / p + s_star, ptd / p + s_star + std::acosh(alpha / q) / p};
}

// Oracle: the closed form against the reference integrator in its linearised
// mode (same equation: exact up to RK4's error, ~1e-12 at h = 1e-5 s; the
// pulse's end is a step boundary). Tolerance 1e-9 (rad and s).
TEST(OracleTest, ReferenceMatchesTheLinearisedClosedForm) {
  const double alpha = 0.05, p = 4.0, excess = 0.5, ptd = 1.0;
  const double a = (1 + excess) * kG * alpha;
  const double td = ptd / p;
  RefOptions o;
  o.linearised = true;
  o.sample_rate_hz = 1000;
  o.breaks_s = {td};
  const auto pulse = [=](double t, bool left) { return (left ? t <= td : t < td) ? -a : 0.0; };
  const RefResult r = Reference({alpha, p, 0.9}, pulse, o).Run(1.5);
  const PulseClosedForm cf = ClosedForm(alpha, p, excess, ptd);
  ASSERT_GE(r.impact_times.size(), 1u);
  EXPECT_NEAR(r.impact_times[0], cf.impact_time, 1e-9);
  EXPECT_NEAR(r.peak, cf.peak, 1e-9);
  EXPECT_NEAR(r.peak_time, cf.peak_time, 1e-5);  // the step grid (h = 1e-5 s) places the peak
}

struct PulseRun {
  double peak{}, impact_time{};
};

PulseRun RunPulse(double alpha, double p, double excess, double ptd) {
  const double a = (1 + excess) * kG * alpha, td = ptd / p;
  auto model = RockingModel::Create(ModelKind::kHousner, {alpha, p, 0.9});
  const RectPulse pulse(a, td);
  model->Reset(0.0, 0.0, 0.0);
  model->AdvanceTo(td, pulse);  // the discontinuity on a step boundary
  PulseRun r;
  for (int i = 1; i <= 40000; ++i) {  // 1e-4 s steps for the peak: error theta'' dt^2 / 8 < 1e-9 rad
    model->AdvanceTo(td + i * 1e-4, pulse);
    r.peak = std::max(r.peak, std::abs(model->state().theta));
    if (model->state().impacts > 0) break;
  }
  for (const auto& e : model->events()) {
    if (e.kind == EventKind::kImpact) {
      r.impact_time = e.time_s;
      break;
    }
  }
  return r;
}

// Oracle: the closed form of the linearised slender block under a
// rectangular pulse (A = 1.5 g alpha for 1 / p: peak 0.57 alpha, first
// impact 3.6 / p after lift-off).
// Tolerance, from the linearisation: while the pulse acts the push is
// p^2 [(A/g) cos(phi) - sin(phi)], phi = alpha - theta in [0.43 alpha,
// alpha], against p^2 [A/g - phi] linearised; the difference is at most
// p^2 [(A/g) alpha^2 / 2 + alpha^3 / 6] = p^2 (0.75 + 0.17) alpha^3, i.e.
// 1.83 alpha^2 of the net push e = A/g - alpha = 0.5 alpha (after the pulse,
// sin against its argument: alpha^2 / 6). The relative errors of the peak and
// of the impact time are then at most S * 1.83 alpha^2, with S their
// sensitivity to e (d ln / d ln e of the closed form, computed below: 2.2
// and 1.8). Measured: 1.0 S alpha^2 for both at alpha = 0.01 and 0.02, and
// the errors scale as alpha^2 (ratio 4.0 between the two; asserted 4 +- 0.5),
// which ties the model to the closed form rather than to a coincidence at
// one alpha.
TEST(OracleTest, SlenderBlockUnderRectangularPulseMatchesTheClosedForm) {
  const double p = 4.0, excess = 0.5, ptd = 1.0;
  double err_peak[2] = {}, err_time[2] = {};
  const double alphas[2] = {0.01, 0.02};
  for (int i = 0; i < 2; ++i) {
    const double alpha = alphas[i];
    const PulseClosedForm cf = ClosedForm(alpha, p, excess, ptd);
    const PulseClosedForm nudged = ClosedForm(alpha, p, excess * (1 + 1e-6), ptd);
    const double s_peak = std::abs(nudged.peak / cf.peak - 1) / 1e-6;
    const double s_time = std::abs(nudged.impact_time / cf.impact_time - 1) / 1e-6;
    const PulseRun run = RunPulse(alpha, p, excess, ptd);
    err_peak[i] = std::abs(run.peak / cf.peak - 1);
    err_time[i] = std::abs(run.impact_time / cf.impact_time - 1);
    std::printf("alpha %.2f: peak %.9f vs %.9f, impact %.9f vs %.9f s (relative %.2e = %.2f S alpha^2, "
                "%.2e = %.2f S alpha^2; S %.2f, %.2f)\n",
                alpha, run.peak, cf.peak, run.impact_time, cf.impact_time, err_peak[i],
                err_peak[i] / (s_peak * alpha * alpha), err_time[i], err_time[i] / (s_time * alpha * alpha), s_peak,
                s_time);
    EXPECT_LT(err_peak[i], s_peak * 1.83 * alpha * alpha) << alpha;
    EXPECT_LT(err_time[i], s_time * 1.83 * alpha * alpha) << alpha;
  }
  EXPECT_NEAR(err_peak[1] / err_peak[0], 4.0, 0.5);
  EXPECT_NEAR(err_time[1] / err_time[0], 4.0, 0.5);
}

// Oracle: the constant push's closed form theta = e (cosh(p t) - 1), while
// theta <= alpha. Tolerance: relative 1.83 alpha^2 (the push's error, as
// above; theta is proportional to e here, S = 1; measured 1.16 alpha^2); and
// the rest criterion: just below g tan(alpha) the block does not move.
TEST(OracleTest, SlenderBlockUnderConstantPushMatchesTheClosedForm) {
  const double alpha = 0.01, p = 4.0, excess = 0.5;
  auto model = RockingModel::Create(ModelKind::kHousner, {alpha, p, 0.9});
  const RectPulse push((1 + excess) * kG * alpha, -1);
  model->Reset(0.0, 0.0, 0.0);
  double worst = 0;
  for (double t = 0.05;; t += 0.05) {
    const double expected = excess * alpha * (std::cosh(p * t) - 1);
    if (expected > alpha) break;
    model->AdvanceTo(t, push);
    worst = std::max(worst, std::abs(model->state().theta / expected - 1));
  }
  std::printf("constant push: worst relative error %.2e\n", worst);
  EXPECT_LT(worst, 1.83 * alpha * alpha);

  auto still = RockingModel::Create(ModelKind::kHousner, {alpha, p, 0.9});
  const RectPulse below(kG * std::tan(alpha) * (1 - 1e-9), -1);
  still->Reset(0.0, 0.0, 0.0);
  still->AdvanceTo(5.0, below);
  EXPECT_EQ(still->state().regime, Regime::kRest);
  EXPECT_EQ(still->state().theta, 0.0);
}

// ---------------------------------------------------------------------------
// The model node's lookahead on the figures' tables
// sampled at 1 kHz, as the node sees a DAQ's RL_TABLE.
//
// Oracle: the reference integrator on the exact (analytic) table motion.
// The node's Housner variant, started at rest, with lookahead 0 (Step: the
// chord between samples) and 32 (AdvanceAhead over the window's centred
// cubic); theta at every 10th sample (100 Hz, the reference's) and the
// impacts from its RL_EVENTs.
// Tolerance (derived): the forcing's interpolation error, h = 1e-3 s. The
// chord's is at most h^2/8 max|a''|. The centred cubic's: its slopes are
// the centred difference, off by h^2/6 a''', which enter through the
// Hermite basis as h (h10 + h11), |h10 + h11| <= 0.0962: at most
// 0.016 h^3 max|a'''|, plus the Hermite remainder h^4/384 max|a''''|.
// Figure 8 (a = U w^2 sin, U = 6 mm, w = 10 pi): chord 7.3e-4 m/s^2, cubic
// 2.9e-6 m/s^2. A forcing error da moves theta'' by at most
// p^2 cos(alpha) / g da, so theta by at most half that times T^2 over T
// seconds (an impact only shrinks a perturbation, mu < 1): T = 2 s, chord
// 2.1e-3 rad, cubic 8.3e-6 rad; CVODE's own error (1e-9 rad, above) is
// below both. Figure 7 (Hanning, 6 mm at 3.3 Hz, w = 20.7 rad/s; the
// window's own rate pi / 2 s^-1 raises each derivative by at most (1 +
// 1.57 / 20.7)^n): max|a''| <= 1480 m/s^4, max|a'''| <= 3.3e4 m/s^5, so
// chord 1.9e-4 m/s^2, cubic 5.3e-7 m/s^2, and with block 1 over T = 4.4 s
// 2.7e-3 and 7.7e-6 rad. Where the Hanning window ends (4.5 s) the table
// acceleration jumps by 7e-3 m/s^2 between two samples, which no
// interpolant of the samples follows, so the bound stops there. Over the
// whole record the impact count must be the reference's. Measured: figure
// 8 chord 1.5e-5 rad, cubic 3.1e-9 rad (impacts 3.6e-5 s and 4.4e-7 s: the
// events' utimes resolve 1e-6 s); figure 7 chord 3.3e-4 rad, cubic
// 1.8e-8 rad (7.1e-4 s and 4.9e-7 s).
struct NodeRun {
  std::vector<double> theta_100hz;  // rad, at k / 100 s
  std::vector<double> impact_times;  // s
};

NodeRun RunNodeOnSamples(const Case& c, int lookahead) {
  common::DirectBus bus;
  NodeRun out;
  const common::Subscription sub1 = bus.Subscribe<rocklab::model_state3_t>("RL_MODEL_h", [&](const std::string&, const rocklab::model_state3_t& m) {
    if (m.utime % 10000 == 0) out.theta_100hz.push_back(m.theta);
  });
  const common::Subscription sub2 = bus.Subscribe<rocklab::event2_t>("RL_EVENT", [&](const std::string&, const rocklab::event2_t& e) {
    if (e.source == "h" && e.kind == rocklab::event2_t::IMPACT) out.impact_times.push_back(e.utime * 1e-6);
  });
  ModelNodeConfig cfg;
  VariantSpec h;
  h.name = "h";
  h.kind = ModelKind::kHousner;
  h.params = c.params;
  cfg.variants.push_back(h);
  cfg.lookahead_samples = lookahead;
  ModelNode node(cfg, bus);
  rocklab::block_state_t theta{};
  node.HandleTheta(theta);
  const auto excitation = ParseExcitation(c.spec);
  const int n = static_cast<int>(std::lround(c.duration_s * 1000));
  for (int k = 0; k <= n; ++k) {
    rocklab::table_state_t table{};
    table.utime = 1000 * static_cast<std::int64_t>(k);
    table.seq = k;
    table.acceleration = excitation->TableAcceleration(k * 1e-3);
    node.HandleTable(table);
  }
  node.Finish();
  return out;
}

void CompareNodeWithReference(const Case& c, double compare_s, double bound_chord, double bound_cubic) {
  const RefResult ref = RunReference(c);
  const auto window = static_cast<std::size_t>(std::lround(compare_s * 100)) + 1;
  const std::vector<double> ref_theta(ref.sample_theta.begin(), ref.sample_theta.begin() + window);
  std::vector<double> ref_impacts;
  for (double t : ref.impact_times) {
    if (t < compare_s) ref_impacts.push_back(t);
  }
  double dtheta[2], dt[2];
  for (int i = 0; i < 2; ++i) {
    const NodeRun run = RunNodeOnSamples(c, 32 * i);
    ASSERT_EQ(run.theta_100hz.size(), ref.sample_theta.size()) << c.name;
    EXPECT_EQ(run.impact_times.size(), ref.impact_times.size()) << c.name << " lookahead " << 32 * i;
    dtheta[i] = MaxAbsDiff(std::vector<double>(run.theta_100hz.begin(), run.theta_100hz.begin() + window), ref_theta);
    const std::size_t n = std::min(run.impact_times.size(), ref_impacts.size());
    dt[i] = MaxAbsDiff(std::vector<double>(run.impact_times.begin(), run.impact_times.begin() + n), ref_impacts);
  }
  std::printf("%s, first %.1f s (%zu impacts): lookahead 0 (chord): max |dtheta| %.3e rad (bound %.1e), "
              "impacts %.3e s; lookahead 32 (cubic): %.3e rad (bound %.1e), impacts %.3e s\n",
              c.name, compare_s, ref_impacts.size(), dtheta[0], bound_chord, dt[0], dtheta[1], bound_cubic, dt[1]);
  EXPECT_LT(dtheta[0], bound_chord) << c.name;
  EXPECT_LT(dtheta[1], bound_cubic) << c.name;
}

TEST(OracleTest, NodeLookaheadOnSampledFigure8) { CompareNodeWithReference(kFig8, 2.0, 2.1e-3, 8.3e-6); }
TEST(OracleTest, NodeLookaheadOnSampledFigure7) { CompareNodeWithReference(kFig7, 4.4, 2.7e-3, 7.7e-6); }

}  // namespace
}  // namespace rocklab::model
