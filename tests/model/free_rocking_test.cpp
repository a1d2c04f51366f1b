// Tests of model/free_rocking.h. Oracles: docs/errata.md item 2's numbers, eq. (13)
// as the slender limit, an independent quadrature, energy conservation.
#include "model/free_rocking.h"
#include "common/units.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "model/rocking_model.h"

namespace rocklab::model {
namespace {

using ::rocklab::common::kPi;  // one pi for the tests a unity batch shares

// Composite Simpson with n (even) panels.
template <typename F>
double Simpson(const F& f, double a, double b, int n) {
  const double h = (b - a) / n;
  double s = f(a) + f(b);
  for (int i = 1; i < n; ++i) s += f(a + i * h) * (i % 2 ? 4 : 2);
  return s * h / 3;
}

// Independent T(r): x = r sin(phi) (a different substitution from the
// library's x = r (1 - u^2)); r - x = r cos^2(phi) / (1 + sin(phi)) cancels
// the singularity; Simpson with 40000 panels.
double QuarterTimeBySineSubstitution(double alpha, double p, double r) {
  auto f = [&](double phi) {
    const double x = r * std::sin(phi);
    const double d = 2 * std::sin(alpha - (r + x) / 2) * std::sin((r - x) / 2);
    if (phi >= kPi / 2) return r / std::sqrt(r * std::sin(alpha - r) / 2);  // limit (1+sin)=2
    return r * std::cos(phi) / std::sqrt(d);
  };
  return Simpson(f, 0.0, kPi / 2, 40000) / (p * std::sqrt(2.0));
}

// ORACLE: docs/errata.md item 2: T(alpha/2) = 0.3396 s for alpha 0.235, p 3.884, and
// the misprinted integrand gives 0.271 s. TOLERANCE: half a unit of the last
// printed digit (5e-5 s and 5e-4 s).
TEST(FreeRockingTest, ErrataTwoNumbers) {
  EXPECT_NEAR(QuarterTimeExact(0.235, 3.884, 0.235 / 2), 0.3396, 5e-5);
  // Misprint: integral_0^r dx / sqrt(cos(x - alpha) - cos(alpha)); x = v^2
  // removes its 1/sqrt(x) singularity at x = 0.
  const double a = 0.235, r = a / 2;
  auto f = [&](double v) {
    if (v == 0.0) return 2.0 / std::sqrt(std::sin(a));
    const double x = v * v;
    return 2 * v / std::sqrt(std::cos(x - a) - std::cos(a));
  };
  const double misprint = Simpson(f, 0.0, std::sqrt(r), 2000) / (3.884 * std::sqrt(2.0));
  EXPECT_NEAR(misprint, 0.271, 5e-4);
}

// ORACLE: an independent substitution and rule. TOLERANCE: 1e-10 relative:
// Simpson's error h^4 f''''/180 with h = 4e-5 is ~1e-20 f'''', far below
// 1e-10 unless the integrand is nearly singular (r -> alpha); the library
// claims ~1e-12.
TEST(FreeRockingTest, QuadratureMatchesIndependentSubstitution) {
  for (double alpha : {0.12, 0.235, 0.5, 1.2}) {
    for (double frac : {0.01, 0.3, 0.5, 0.9, 0.99}) {
      const double r = frac * alpha;
      const double t = QuarterTimeExact(alpha, 3.884, r);
      EXPECT_NEAR(t, QuarterTimeBySineSubstitution(alpha, 3.884, r), 1e-10 * t) << alpha << " " << frac;
    }
  }
}

// ORACLE: eq. (13) is the slender, small-angle limit of eq. (12).
// TOLERANCE: 1 % at alpha = 0.12, r = alpha/2 (the brief's bound: the
// linearisation drops O(alpha^2) ~ 1.4e-2 relative terms).
TEST(FreeRockingTest, SlenderLimit) {
  const double alpha = 0.12, r = alpha / 2, p = 3.8;
  const double exact = QuarterTimeExact(alpha, p, r);
  const double slender = QuarterTimeSlender(alpha, p, r);
  EXPECT_NEAR(slender / exact, 1.0, 0.01);
  // and the agreement improves as alpha falls
  const double rel_small = std::abs(QuarterTimeSlender(0.03, p, 0.015) / QuarterTimeExact(0.03, p, 0.015) - 1);
  EXPECT_LT(rel_small, std::abs(slender / exact - 1));
}

// ORACLE: energy conservation between impacts, E' = mu^2 E; eq. (14) then
// returns mu for any n. TOLERANCE: 1e-12 (closed forms).
TEST(FreeRockingTest, NextPeakAndMuFromPeaks) {
  const double alpha = 0.235, mu = 0.937;
  double r = alpha / 2;
  const double r0 = r;
  auto energy = [&](double x) { return std::cos(alpha - x) - std::cos(alpha); };
  for (int n = 1; n <= 10; ++n) {
    const double next = NextPeak(alpha, mu, r);
    EXPECT_NEAR(energy(next), mu * mu * energy(r), 1e-15);
    r = next;
    EXPECT_NEAR(MuFromPeaks(alpha, r0, r, n), mu, 1e-12);
  }
  EXPECT_NEAR(NextPeak(alpha, 1.0, 0.1), 0.1, 1e-15);  // elastic impact: same peak
}

// ORACLE: the contract's preconditions name the argument.
TEST(FreeRockingTest, BadArguments) {
  auto what = [](auto f) {
    try {
      f();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(what([] { QuarterTimeExact(0.2, 3, 0.2); }).find("r must"), std::string::npos);
  EXPECT_NE(what([] { QuarterTimeExact(0.2, 0, 0.1); }).find("p must"), std::string::npos);
  EXPECT_NE(what([] { QuarterTimeExact(2.0, 3, 0.1); }).find("alpha must"), std::string::npos);
  EXPECT_NE(what([] { QuarterTimeSlender(0.2, 3, -0.1); }).find("r must"), std::string::npos);
  EXPECT_NE(what([] { MuFromPeaks(0.2, 0.1, 0.05, 0); }).find("n must"), std::string::npos);
  EXPECT_NE(what([] { MuFromPeaks(0.2, 0.3, 0.05, 1); }).find("r0 must"), std::string::npos);
  EXPECT_NE(what([] { NextPeak(0.2, 1.2, 0.1); }).find("mu must"), std::string::npos);
}

// SampleFreeHousner from theta0 at t0 = 0.5 s, 1 kHz for `seconds`, and
// the same run of the CVODE model (RockingModel, rtol 1e-10, atol 1e-12,
// AdvanceAhead to every sample): the largest theta difference and the
// impact times of both.
struct FreeHousnerComparison {
  double max_theta_diff{};
  std::vector<double> rk4_impacts, cvode_impacts;
  FreeHousnerRun run;
  bool cvode_rested{};
};
FreeHousnerComparison CompareFreeHousner(const BlockParams& params, double theta0, double seconds) {
  FreeHousnerComparison c;
  std::vector<double> t;
  for (int k = 0; k <= static_cast<int>(seconds * 1000); ++k) t.push_back(0.5 + k * 1e-3);
  std::vector<double> theta(t.size());
  c.run = SampleFreeHousner(params, 0.5, theta0, 0.0, t.data(), t.size(), theta.data(), 2e-3, &c.rk4_impacts);
  ModelOptions mo;
  mo.rtol = 1e-10;
  auto model = RockingModel::Create(ModelKind::kHousner, params, mo);
  model->Reset(0.5, theta0, 0.0);
  const NoTableMotion none;
  for (std::size_t k = 0; k < t.size(); ++k) {
    model->AdvanceAhead(t[k], none, std::numeric_limits<double>::infinity());
    c.max_theta_diff = std::max(c.max_theta_diff, std::abs(model->state().theta - theta[k]));
  }
  for (const ModelEvent& e : model->events()) {
    if (e.kind == EventKind::kImpact) c.cvode_impacts.push_back(e.time_s);
    if (e.kind == EventKind::kRest) c.cvode_rested = true;
  }
  return c;
}

// ORACLE: the closed-form chain of quarter times and peaks (QuarterTimeExact,
// NextPeak; relative accuracy ~1e-12) for every impact, and the CVODE model
// at rtol 1e-10 for theta at every sample and the impacts.
// TOLERANCE: RK4 at p h = 3.9e-3 (1 ms, block 1) has a global error
// ~(p h)^4 / 120 ~ 2e-12 per unit p t: measured within 8e-11 s of the
// closed form over the impacts above 1e-4 rad, so 1e-9 s. The CVODE model
// at rtol 1e-10 drifts from the same chain by up to 2.3e-8 s there and
// 5.5e-8 s on the last, small impacts before rest (measured here; RK4 is
// the closer of the two), so 1e-7 s against it; theta within 1e-8 rad
// (4e-5 of the bench records' 0.02 deg noise).
TEST(FreeRockingTest, SampleFreeHousnerMatchesCvodeAndClosedForm) {
  const BlockParams block1{0.235, 3.884, 0.937};
  const FreeHousnerComparison c = CompareFreeHousner(block1, 0.1, 10.0);
  EXPECT_FALSE(c.run.overturned);
  ASSERT_EQ(c.rk4_impacts.size(), c.cvode_impacts.size());
  ASSERT_GT(c.rk4_impacts.size(), 20u);
  for (std::size_t i = 0; i < c.rk4_impacts.size(); ++i) EXPECT_NEAR(c.rk4_impacts[i], c.cvode_impacts[i], 1e-7) << i;
  EXPECT_LT(c.max_theta_diff, 1e-8);
  EXPECT_EQ(c.run.rested, c.cvode_rested);
  // The closed-form chain up to the impact that puts the block at rest.
  double r = 0.1, t = 0.5 + QuarterTimeExact(0.235, 3.884, r);
  for (std::size_t i = 0; i + 1 < c.rk4_impacts.size(); ++i) {
    EXPECT_NEAR(c.rk4_impacts[i], t, 1e-9) << i;
    r = NextPeak(0.235, 0.937, r);
    t += 2.0 * QuarterTimeExact(0.235, 3.884, r);
  }
}

// ORACLE: the CVODE model on an asymmetric section (each pivot its alpha, p
// and mu) from either side, and on a release beyond alpha (it overturns:
// NaN from there on). TOLERANCE: as above.
TEST(FreeRockingTest, SampleFreeHousnerAsymmetricAndOverturn) {
  BlockParams asym{0.20, 3.5, 0.92};
  asym.minus = SideParams{0.26, 4.1, 0.95};
  for (double theta0 : {0.12, -0.15}) {
    const FreeHousnerComparison c = CompareFreeHousner(asym, theta0, 6.0);
    ASSERT_EQ(c.rk4_impacts.size(), c.cvode_impacts.size()) << theta0;
    for (std::size_t i = 0; i < c.rk4_impacts.size(); ++i) {
      EXPECT_NEAR(c.rk4_impacts[i], c.cvode_impacts[i], 1e-7) << theta0 << " " << i;
    }
    EXPECT_LT(c.max_theta_diff, 1e-8) << theta0;
  }
  const double t[3] = {0.0, 1.0, 5.0};
  double theta[3] = {};
  const FreeHousnerRun run = SampleFreeHousner({0.235, 3.884, 0.937}, 0.0, 0.24, 0.0, t, 3, theta);
  EXPECT_TRUE(run.overturned);
  EXPECT_EQ(theta[0], 0.24);
  EXPECT_TRUE(std::isnan(theta[2]));
  // At rest (theta0 = theta_dot0 = 0): zero for ever, no impact.
  const FreeHousnerRun still = SampleFreeHousner({0.235, 3.884, 0.937}, 0.0, 0.0, 0.0, t, 3, theta);
  EXPECT_EQ(still.impacts, 0);
  EXPECT_EQ(theta[2], 0.0);
  EXPECT_THROW(SampleFreeHousner({0.235, 3.884, 0.937}, 2.0, 0.1, 0.0, t, 3, theta), std::invalid_argument);
}

}  // namespace
}  // namespace rocklab::model
