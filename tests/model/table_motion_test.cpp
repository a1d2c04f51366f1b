// model::TableMotion: the table's displacement and acceleration for the rig
// simulator.
// Oracles: an analytic excitation's own closed-form displacement (exact);
// for a sampled record, the closed form of a constant and of a linear
// acceleration from rest, which the trapezoidal rule integrates exactly at
// the sample times for the velocity (linear) and, for a constant
// acceleration, for the displacement too; for a linear acceleration the
// rule's displacement error is known: u_n = j t^3/6 + j t dt^2/12.
#include "model/table_motion.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

namespace rocklab::model {
namespace {

TEST(TableMotion, AnExcitationGivesItsExactDisplacement) {
  const auto sine = ParseExcitation("sine:amp=0.006,freq=2,duration=3,start=0.5");
  TableMotion motion(*sine);
  for (double t : {0.0, 0.6, 1.234, 3.2, 4.0}) {
    double u = -1, a = -1;
    motion.At(t, u, a);
    EXPECT_EQ(u, sine->Displacement(t)) << t;
    EXPECT_EQ(a, sine->TableAcceleration(t)) << t;
  }
}

TEST(TableMotion, AConstantRecordIsIntegratedExactly) {
  constexpr double kAccel = 2.0;  // m/s^2
  SampledAcceleration record({0.0, 10.0}, {kAccel, kAccel});
  TableMotion motion(record);
  for (int k = 0; k <= 100; ++k) {
    const double t = 0.01 * k;
    double u = 0, a = 0;
    motion.At(t, u, a);
    EXPECT_DOUBLE_EQ(a, kAccel);
    // 1e-12 m: rounding of 100 trapezoid steps on values of ~1 m.
    EXPECT_NEAR(u, 0.5 * kAccel * t * t, 1e-12) << t;
  }
}

TEST(TableMotion, ALinearRecordHasTheTrapezoidRulesKnownError) {
  constexpr double kJerk = 3.0;  // m/s^3: a = j t
  constexpr double kDt = 0.01;   // s
  SampledAcceleration record({0.0, 10.0}, {0.0, 10.0 * kJerk});
  TableMotion motion(record);
  for (int k = 0; k <= 100; ++k) {
    const double t = kDt * k;
    double u = 0, a = 0;
    motion.At(t, u, a);
    // Velocity is exact (a linear); the trapezoid on v = j t^2 / 2 adds
    // j dt^2 / 12 per unit time of the step sum: u = j t^3/6 + j t dt^2/12.
    EXPECT_NEAR(u, kJerk * t * t * t / 6 + kJerk * t * kDt * kDt / 12, 1e-12) << t;
  }
}

}  // namespace
}  // namespace rocklab::model
