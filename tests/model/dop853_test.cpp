// model/dop853.h: Dormand-Prince 8(5,3) and 5(4) with their dense outputs and roots.
#include <gtest/gtest.h>

#include <array>
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

// Both pairs on the oscillator at rtol 1e-10, atol 1e-12 (kOscillatorAtol),
// started from y(0) = (1, 0) with the roots y0 (either direction), y1
// (rising), a constant.
constexpr double kOscillatorAtol[2] = {1e-12, 1e-12};
void StartOscillator(EmbeddedRungeKutta& dp) {
  const double y0[2] = {1.0, 0.0};
  dp.ReInit(0.0, y0);
  const int dir[3] = {0, +1, 0};
  dp.SetRootDirection(dir);
}

// 2000 outputs over 20 periods: the largest error against the closed form
// (y1 over w) and the roots met on the way.
struct OscillatorOutputs {
  double worst{};
  int roots{};
};
OscillatorOutputs RunOscillatorOutputs(EmbeddedRungeKutta& dp, const DopOscillator& sys) {
  OscillatorOutputs out;
  const double period = 2 * M_PI / sys.w;
  for (int k = 1; k <= 2000; ++k) {
    const double t = k * 20 * period / 2000;
    while (dp.Advance(t, 1e300) == EmbeddedRungeKutta::Result::kRoot) ++out.roots;
    EXPECT_EQ(dp.t_s(), t);
    out.worst = std::max({out.worst, std::abs(dp.y()[0] - std::cos(sys.w * t)),
                          std::abs(dp.y()[1] + sys.w * std::sin(sys.w * t)) / sys.w});
  }
  return out;
}

// Oracle: the zeros of cos(w t) at (k + 1/2) pi / w (y0, either direction)
// and of -w sin(w t) rising at (2k + 1) pi / w. Tolerance: 1e-9 s, the
// solution's error over |y'| = w; the root finder's own resolution is 100
// ulp of t.
void ExpectClosedFormRoots(EmbeddedRungeKutta& dp, const DopOscillator& sys) {
  int zeros = 0, rises = 0;
  while (dp.Advance(10.0, 1e300) == EmbeddedRungeKutta::Result::kRoot) {
    int found[3] = {};
    dp.RootsFound(found);
    EXPECT_EQ(found[2], 0);
    if (found[0] != 0) {
      EXPECT_NEAR(dp.t_s(), (zeros + 0.5) * M_PI / sys.w, 1e-9) << zeros;
      EXPECT_EQ(found[0], zeros % 2 == 0 ? -1 : +1) << zeros;  // cos falls first
      ++zeros;
    }
    if (found[1] != 0) {
      EXPECT_NEAR(dp.t_s(), (2 * rises + 1) * M_PI / sys.w, 1e-9) << rises;
      EXPECT_EQ(found[1], +1);
      ++rises;
    }
  }
  // In [0, 10] s at w = 3: cos(3t) has zeros while 3t < 30, i.e. k + 1/2 < 30 / pi.
  EXPECT_EQ(zeros, static_cast<int>(std::floor(30.0 / M_PI + 0.5)));
  EXPECT_EQ(rises, static_cast<int>(std::floor((30.0 / M_PI + 1) / 2)));
  EXPECT_EQ(dp.t_s(), 10.0);
}

// Oracle: the closed form y0 = cos(w t), y1 = -w sin(w t) from y(0) = (1, 0).
// Tolerance: rtol 1e-10, atol 1e-12 over 20 periods, at the outputs (the
// dense output between steps as at the steps' ends): measured 9.2e-10 with
// 395 steps; 1e-8 leaves 10x for other compilers and libm. A dense output
// of lower order (a cubic between ~1 rad steps) is off by ~1e-3.
TEST(Dop853Test, OscillatorMatchesTheClosedFormAtEveryOutput) {
  DopOscillator sys;
  Dop853 dp(2, sys, 1e-10, kOscillatorAtol, 0.0, 3);
  StartOscillator(dp);
  const OscillatorOutputs out = RunOscillatorOutputs(dp, sys);
  std::printf("oscillator: %ld steps (%ld rhs), max error %.3e\n", dp.steps(), dp.rhs_evals(), out.worst);
  EXPECT_LT(out.worst, 1e-8);
  // 20 periods: y0 crosses zero 40 times, y1 rises through zero 20 times.
  EXPECT_EQ(out.roots, 60);
  // Order 8: far fewer steps than 2000 outputs (each step serves several).
  EXPECT_LT(dp.steps(), 600);
}

// Oracle: the closed-form zeros (ExpectClosedFormRoots).
TEST(Dop853Test, RootsAtTheClosedFormTimesInTheirDirection) {
  DopOscillator sys;
  Dop853 dp(2, sys, 1e-10, kOscillatorAtol, 0.0, 3);
  StartOscillator(dp);
  ExpectClosedFormRoots(dp, sys);
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

// Dormand-Prince 5(4), the model node's pair, on the same oscillator.
// Oracle: the closed form, as above. Tolerance: measured 1.5e-9 at rtol
// 1e-10 with 3985 steps (the dense output of order 4 between them); 1e-8 as
// for the 8(5,3) pair. The step bound (5000) holds the order: an order-4
// pair needs (1e-10)^(1/5 - 1/4) = 3.2 times the steps of an order-5 one
// at this tolerance.
TEST(Dopri5Test, OscillatorMatchesTheClosedFormAtEveryOutput) {
  DopOscillator sys;
  Dopri5 dp(2, sys, 1e-10, kOscillatorAtol, 0.0, 3);
  StartOscillator(dp);
  const OscillatorOutputs out = RunOscillatorOutputs(dp, sys);
  std::printf("oscillator, 5(4): %ld steps (%ld rhs), max error %.3e\n", dp.steps(), dp.rhs_evals(), out.worst);
  EXPECT_LT(out.worst, 1e-8);
  EXPECT_EQ(out.roots, 60);
  EXPECT_LT(dp.steps(), 5000);
  // Six right-hand sides a step (the seventh is the next step's first).
  EXPECT_LE(dp.rhs_evals(), 6 * (dp.steps() + dp.error_test_fails()) + 2);
}

// Oracle: the closed-form zeros (ExpectClosedFormRoots).
TEST(Dopri5Test, RootsAtTheClosedFormTimesInTheirDirection) {
  DopOscillator sys;
  Dopri5 dp(2, sys, 1e-10, kOscillatorAtol, 0.0, 3);
  StartOscillator(dp);
  ExpectClosedFormRoots(dp, sys);
}

// Oracle: the stop time bounds every right-hand side (the node's forcing is
// a chord ending there), and steps of at most 1 ms that stop at every 1 ms
// sample land on it: one step a sample, as the model node steps.
TEST(Dopri5Test, StopsAtEverySampleWithoutPassingIt) {
  struct Bounded : DopOscillator {
    double tstop{};
    bool passed{false};
    int Rhs(double t, const double* y, double* ydot) override {
      passed = passed || t > tstop;
      return DopOscillator::Rhs(t, y, ydot);
    }
  } sys;
  const double atol[2] = {1e-12, 1e-12};
  Dopri5 dp(2, sys, 1e-10, atol, 1e-3, 3);
  const double y0[2] = {1.0, 0.0};
  dp.ReInit(0.0, y0);
  const int none[3] = {0, 0, 0};
  dp.SetRootDirection(none);
  for (int k = 1; k <= 1000; ++k) {
    sys.tstop = k * 1e-3;
    while (dp.Advance(sys.tstop, sys.tstop) == Dopri5::Result::kRoot) {
    }
    ASSERT_EQ(dp.t_s(), sys.tstop);
  }
  EXPECT_FALSE(sys.passed);
  EXPECT_NEAR(dp.y()[0], std::cos(3.0), 1e-9);
  EXPECT_LE(dp.steps(), 1010);
}

// y' = 0 before t = 0.25 s and 1e8 after (a jump nobody declared), y(0) =
// 1: y = 1 + 1e8 max(0, t - 0.25). A step across the jump passes the error
// test only when it is ~1e-15 s (its estimate ~1.2e5 h against 2e-10),
// about the smallest step (4.4e-16 s at t < 1 s).
struct DopJump : OdeSystem {
  int Rhs(double t, const double*, double* ydot) override {
    ydot[0] = t < 0.25 ? 0.0 : 1e8;
    return 0;
  }
  int Roots(double, const double* y, double* g) override {
    g[0] = y[0] - 1.0 - 1e7;  // at 0.35 s
    return 0;
  }
};

// Oracle: the closed form 1 + 1e8 max(0, t - 0.25) and its root at 0.35 s.
// The 5(4) pair either steps across the jump with such a step, or gives it
// up (StepFailure) and Cvode::Advance restarts it from its last step's
// end, which fails there again, then twice its smallest step later (8.9e-16
// s), past the jump, as it restarts ARKODE and CVODE 16 ulp later: at most
// two recoveries (with the smallest step at 16 ulp, 3.6e-15 s, it was
// always the two; at 2 eps, the floor since the complex model's crossings
// needed it, the step is taken). Tolerance: either way ~1e-15 s of the
// jump is misplaced, which moves the root by as much and y by 1e8 times it
// (1e-7 against 2.5e7),
// plus the steps' own error at rtol 1e-10 (2.5e-3 in y, 2.5e-11 s in the
// root): 1e-10 s and 1e-9 relative.
TEST(Dopri5Test, CvodeRecoversWhenTheRightHandSideJumps) {
  DopJump sys;
  const double atol[1] = {1e-10};
  Cvode cv(1, sys, 1e-10, atol, 1e-2, Cvode::Method::kDormandPrince5, 1);
  const double y0[1] = {1.0};
  cv.ReInit(0.0, y0);
  const int dir[1] = {0};
  cv.SetRootDirection(dir);
  int found = 0;
  while (cv.Advance(0.5, 0.5) == Cvode::Result::kRoot) {
    ASSERT_EQ(found++, 0);
    EXPECT_NEAR(cv.t_s(), 0.35, 1e-10);
  }
  EXPECT_EQ(found, 1);
  EXPECT_EQ(cv.t_s(), 0.5);
  EXPECT_NEAR(cv.y()[0] / (1.0 + 2.5e7), 1.0, 1e-9);
  EXPECT_LE(cv.stats().recoveries, 2);
}

}  // namespace
}  // namespace rocklab::model::detail
