// model/dop853.h: Dormand-Prince 8(5,3) with its dense output and roots.
#include <gtest/gtest.h>

#include <cmath>

#include "model/cvode.h"
#include "model/dop853.h"

namespace rocklab::model::detail {
namespace {

// y'' = -w^2 y as y0' = y1, y1' = -w^2 y0; roots: y0 (both directions),
// y1 (rising only), a constant.
struct DopOscillator : OdeSystem {
  double w{3.0};
  long rhs{};
  int Rhs(double, const double* y, double* ydot) override {
    ++rhs;
    ydot[0] = y[1];
    ydot[1] = -w * w * y[0];
    return 0;
  }
  int Roots(double, const double* y, double* g) override {
    g[0] = y[0];
    g[1] = y[1];
    g[2] = 1.0;
    return 0;
  }
};

// Oracle: the closed form y0 = cos(w t), y1 = -w sin(w t) from y(0) = (1, 0).
// Tolerance: rtol 1e-10, atol 1e-12 over 20 periods, at the outputs (the
// dense output between steps as at the steps' ends): measured 9.2e-10 with
// 395 steps; 1e-8 leaves 10x for other compilers and libm. A dense output
// of lower order (a cubic between ~1 rad steps) is off by ~1e-3.
TEST(Dop853Test, OscillatorMatchesTheClosedFormAtEveryOutput) {
  DopOscillator sys;
  const double atol[2] = {1e-12, 1e-12};
  Dop853 dp(2, sys, 1e-10, atol, 0.0, 3);
  const double y0[2] = {1.0, 0.0};
  dp.ReInit(0.0, y0);
  const int dir[3] = {0, +1, 0};
  dp.SetRootDirection(dir);
  const double period = 2 * M_PI / sys.w;
  double worst = 0.0;
  int roots = 0;
  for (int k = 1; k <= 2000; ++k) {
    const double t = k * 20 * period / 2000;
    while (dp.Advance(t, 1e300) == Dop853::Result::kRoot) ++roots;
    ASSERT_EQ(dp.t_s(), t);
    worst = std::max({worst, std::abs(dp.y()[0] - std::cos(sys.w * t)),
                      std::abs(dp.y()[1] + sys.w * std::sin(sys.w * t)) / sys.w});
  }
  std::printf("oscillator: %ld steps (%ld rhs), max error %.3e\n", dp.steps(), dp.rhs_evals(), worst);
  EXPECT_LT(worst, 1e-8);
  // 20 periods: y0 crosses zero 40 times, y1 rises through zero 20 times.
  EXPECT_EQ(roots, 60);
  // Order 8: far fewer steps than 2000 outputs (each step serves several).
  EXPECT_LT(dp.steps(), 600);
}

// Oracle: the zeros of cos(w t) at (k + 1/2) pi / w (y0, either direction)
// and of -w sin(w t) rising at (2k + 1) pi / w. Tolerance: 1e-9 s, the
// solution's error (above) over |y'| = w; the root finder's own resolution
// is 100 ulp of t.
TEST(Dop853Test, RootsAtTheClosedFormTimesInTheirDirection) {
  DopOscillator sys;
  const double atol[2] = {1e-12, 1e-12};
  Dop853 dp(2, sys, 1e-10, atol, 0.0, 3);
  const double y0[2] = {1.0, 0.0};
  dp.ReInit(0.0, y0);
  const int dir[3] = {0, +1, 0};
  dp.SetRootDirection(dir);
  int zeros = 0, rises = 0;
  while (dp.Advance(10.0, 1e300) == Dop853::Result::kRoot) {
    int found[3] = {};
    dp.RootsFound(found);
    EXPECT_EQ(found[2], 0);
    if (found[0] != 0) {
      const double expected = (zeros + 0.5) * M_PI / sys.w;
      EXPECT_NEAR(dp.t_s(), expected, 1e-9) << zeros;
      EXPECT_EQ(found[0], zeros % 2 == 0 ? -1 : +1) << zeros;  // cos falls first
      ++zeros;
    }
    if (found[1] != 0) {
      const double expected = (2 * rises + 1) * M_PI / sys.w;
      EXPECT_NEAR(dp.t_s(), expected, 1e-9) << rises;
      EXPECT_EQ(found[1], +1);
      ++rises;
    }
  }
  // In [0, 10] s at w = 3: cos(3t) has zeros while 3t < 30, i.e. k + 1/2 < 30 / pi.
  EXPECT_EQ(zeros, static_cast<int>(std::floor(30.0 / M_PI + 0.5)));
  EXPECT_EQ(rises, static_cast<int>(std::floor((30.0 / M_PI + 1) / 2)));
  EXPECT_EQ(dp.t_s(), 10.0);
}

// Oracle: the stop time is a hard bound (the forcing may jump there): no
// right-hand side beyond it, and the step lands on it exactly.
TEST(Dop853Test, NeverEvaluatesBeyondTheStopTime) {
  struct Bounded : DopOscillator {
    double tstop{0.7};
    double latest{};
    int Rhs(double t, const double* y, double* ydot) override {
      latest = std::max(latest, t);
      return DopOscillator::Rhs(t, y, ydot);
    }
  } sys;
  const double atol[2] = {1e-12, 1e-12};
  Dop853 dp(2, sys, 1e-10, atol, 0.0, 3);
  const double y0[2] = {1.0, 0.0};
  dp.ReInit(0.0, y0);
  const int none[3] = {0, 0, 0};
  dp.SetRootDirection(none);
  while (dp.Advance(0.3, 0.7) == Dop853::Result::kRoot) {
  }
  while (dp.Advance(0.7, 0.7) == Dop853::Result::kRoot) {
  }
  EXPECT_EQ(dp.t_s(), 0.7);
  EXPECT_LE(sys.latest, 0.7);
  EXPECT_NEAR(dp.y()[0], std::cos(2.1), 1e-9);
}

}  // namespace
}  // namespace rocklab::model::detail
