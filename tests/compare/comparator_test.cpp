// Comparator metrics against closed-form results on synthetic signals.
#include "compare/comparator.h"
#include "common/units.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace rocklab::compare {
namespace {

using ::rocklab::common::kPi;  // one pi for the tests a unity batch shares
constexpr double kRateHz = 1000.0;

std::int64_t Utime(int k) { return static_cast<std::int64_t>(std::llround(k * 1e6 / kRateHz)); }
double Time(int k) { return k / kRateHz; }

// Oracle: signals that never cross zero have no crossing
// to match: the timing and peak errors are NaN (no value), not 0 (a
// perfect match); once a crossing is matched they are numbers.
TEST(Comparator, NoMatchedCrossingGivesNoTimingOrPeakError) {
  Comparator c;
  for (int k = 0; k < 2000; ++k) c.Add(Utime(k), 0.05 + 0.01 * std::sin(Time(k)), 0.06, true);
  const ComparisonMetrics& m = c.metrics();
  EXPECT_EQ(m.matched_crossings, 0);
  EXPECT_TRUE(std::isnan(m.impact_timing_error));
  EXPECT_TRUE(std::isnan(m.peak_error));
  EXPECT_TRUE(std::isnan(m.mean_abs_timing_error));
  EXPECT_TRUE(std::isnan(m.mean_abs_peak_error));
  EXPECT_GT(m.rms_total, 0.0);  // the other metrics are there
  for (int k = 2000; k < 6000; ++k) {
    const double th = 0.1 * std::sin(2 * kPi * 1.3 * Time(k));
    c.Add(Utime(k), th, th, true);
  }
  EXPECT_GT(c.metrics().matched_crossings, 0);
  EXPECT_TRUE(std::isfinite(c.metrics().mean_abs_timing_error));
  EXPECT_TRUE(std::isfinite(c.metrics().mean_abs_peak_error));
  EXPECT_TRUE(std::isfinite(c.metrics().impact_timing_error));
}

// Oracle: identity. Identical signals have zero error, correlation 1 and
// every zero crossing matched at zero timing and peak error.
TEST(Comparator, IdenticalSignalsAgreeExactly) {
  Comparator c;
  for (int k = 0; k < 5000; ++k) {
    const double th = 0.1 * std::sin(2 * kPi * 1.3 * Time(k) + 0.3);
    c.Add(Utime(k), th, th, true);
  }
  const ComparisonMetrics& m = c.metrics();
  EXPECT_EQ(m.rms_total, 0.0);
  EXPECT_EQ(m.rms_window, 0.0);
  EXPECT_NEAR(m.correlation, 1.0, 1e-12);
  EXPECT_EQ(m.samples, 5000);
  // 5 s at 1.3 Hz: 13 crossings, the first one is never complete (no prior
  // half cycle seen beyond the hysteresis) but all others are.
  EXPECT_GE(m.matched_crossings, 12);
  EXPECT_EQ(m.unmatched_crossings, 0);
  EXPECT_EQ(m.impact_timing_error, 0.0);
  EXPECT_EQ(m.peak_error, 0.0);
}

// Oracle: for a constant offset c, the error is c everywhere, so every RMS
// is |c| (to rounding, 1e-15 relative per sample).
TEST(Comparator, ConstantOffsetGivesThatRms) {
  Comparator c;
  for (int k = 0; k < 3000; ++k) {
    const double th = 0.05 * std::sin(2 * kPi * Time(k));
    c.Add(Utime(k), th, th + 0.004, true);
  }
  EXPECT_NEAR(c.metrics().rms_total, 0.004, 1e-12);
  EXPECT_NEAR(c.metrics().rms_window, 0.004, 1e-12);
  EXPECT_NEAR(c.metrics().nrms, 0.004 / 0.05, 1e-6);  // sampled peak within 1e-6 of 0.05
  EXPECT_NEAR(c.metrics().max_abs_error, 0.004, 1e-12);
}

// Oracle: a delay d between two sines of amplitude A and angular frequency w
// gives the error 2 A sin(w d / 2) cos(w t - w d / 2): RMS over whole periods
// sqrt(2) A sin(w d / 2); every zero crossing of the model comes d late.
// Linear interpolation of a sine through zero is exact to O(w^3 dt^3), far
// below 1e-6 s here.
TEST(Comparator, DelayGivesTimingErrorAndClosedFormRms) {
  const double a = 0.08, f = 2.0, d = 0.012, w = 2 * kPi * f;
  Comparator c;
  const int n = static_cast<int>(4.0 * kRateHz);  // 8 whole periods
  for (int k = 0; k < n; ++k) {
    const double t = Time(k);
    c.Add(Utime(k), a * std::sin(w * t), a * std::sin(w * (t - d)), true);
  }
  const ComparisonMetrics& m = c.metrics();
  EXPECT_NEAR(m.rms_total, std::sqrt(2.0) * a * std::sin(w * d / 2), 1e-3 * m.rms_total);
  EXPECT_NEAR(m.impact_timing_error, d, 1e-6);
  EXPECT_NEAR(m.mean_abs_timing_error, d, 1e-6);
  EXPECT_GE(m.matched_crossings, 14);
  EXPECT_NEAR(m.correlation, std::cos(w * d), 1e-3);
}

// Oracle: a model that is 1.1 times the measurement overshoots every half
// cycle's peak by 0.1 A (peaks sampled exactly: f divides the rate).
TEST(Comparator, ScaledModelGivesPeakError) {
  const double a = 0.06;
  Comparator c;
  for (int k = 0; k < 4000; ++k) {
    const double th = a * std::sin(2 * kPi * 1.25 * Time(k));
    c.Add(Utime(k), th, 1.1 * th, true);
  }
  EXPECT_NEAR(c.metrics().peak_error, 0.1 * a, 1e-12);
  EXPECT_NEAR(c.metrics().mean_abs_peak_error, 0.1 * a, 1e-12);
}

// Oracle: the window holds only the last window_s of errors: after an error
// step from 0 to e, the windowed RMS is e once the window has passed, while
// the total RMS is e sqrt(fraction of time with the error).
TEST(Comparator, WindowForgetsAndTotalRemembers) {
  ComparatorOptions o;
  o.window_s = 0.5;
  Comparator c(o);
  for (int k = 0; k < 2000; ++k) c.Add(Utime(k), 0.0, k < 1000 ? 0.0 : 0.01, true);
  EXPECT_NEAR(c.metrics().rms_window, 0.01, 1e-12);
  EXPECT_NEAR(c.metrics().rms_total, 0.01 * std::sqrt(0.5), 1e-12);
}

// Oracle: invalid pairs (DAQ flags sliding, jump or twist) do not enter the
// metrics: a huge error while invalid leaves the RMS at zero.
TEST(Comparator, InvalidPairsAreLeftOut) {
  Comparator c;
  for (int k = 0; k < 1000; ++k) {
    const bool valid = k < 400 || k >= 600;
    const double th = 0.02 * std::sin(2 * kPi * Time(k));
    c.Add(Utime(k), th, valid ? th : th + 1.0, valid);
  }
  EXPECT_EQ(c.metrics().rms_total, 0.0);
  EXPECT_EQ(c.metrics().valid_samples, 800);
  EXPECT_EQ(c.metrics().samples, 1000);
  EXPECT_TRUE(c.metrics().valid);
}

// Oracle: y = -x has correlation -1; a model that never crosses leaves the
// measured crossings unmatched, and they are counted.
TEST(Comparator, AntiphaseAndMissingCrossingsAreReported) {
  Comparator c;
  for (int k = 0; k < 3000; ++k) {
    const double th = 0.03 * std::sin(2 * kPi * Time(k));
    c.Add(Utime(k), th, -th, true);
  }
  EXPECT_NEAR(c.metrics().correlation, -1.0, 1e-12);

  Comparator quiet;
  for (int k = 0; k < 3000; ++k) {
    quiet.Add(Utime(k), 0.03 * std::sin(2 * kPi * Time(k)), 0.0, true);
  }
  EXPECT_EQ(quiet.metrics().matched_crossings, 0);
  EXPECT_GE(quiet.metrics().unmatched_crossings, 4);
}

// Oracle: the window's capacity bounds memory: a window longer than the
// capacity keeps only the newest samples (here 100 of them), so the windowed
// RMS is that of the last 100 errors.
TEST(Comparator, WindowCapacityIsABound) {
  ComparatorOptions o;
  o.window_s = 100.0;
  o.max_window_samples = 100;
  Comparator c(o);
  for (int k = 0; k < 100000; ++k) c.Add(Utime(k), 0.0, k < 99900 ? 1.0 : 0.5, true);
  EXPECT_NEAR(c.metrics().rms_window, 0.5, 1e-12);
}

// Oracle: ComparatorOptions' documented ranges, each of its four checks on
// its own (every other option at its default), at and beyond the boundary;
// the message names the option.
TEST(Comparator, BadOptionsThrowNamingTheOption) {
  struct Case {
    const char* name;
    void (*set)(ComparatorOptions&);
  };
  const Case bad[] = {
      {"window_s", [](ComparatorOptions& o) { o.window_s = -1; }},
      {"window_s", [](ComparatorOptions& o) { o.window_s = 0; }},
      {"window_s", [](ComparatorOptions& o) { o.window_s = std::nan(""); }},
      {"max_window_samples", [](ComparatorOptions& o) { o.max_window_samples = 1; }},
      {"crossing_hysteresis_rad", [](ComparatorOptions& o) { o.crossing_hysteresis_rad = -1e-3; }},
      {"crossing_hysteresis_rad", [](ComparatorOptions& o) { o.crossing_hysteresis_rad = INFINITY; }},
      {"crossing_match_s", [](ComparatorOptions& o) { o.crossing_match_s = 0; }},
      {"crossing_match_s", [](ComparatorOptions& o) { o.crossing_match_s = std::nan(""); }},
  };
  for (const Case& c : bad) {
    ComparatorOptions o;
    c.set(o);
    try {
      Comparator comparator(o);
      ADD_FAILURE() << c.name << ": no throw";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(c.name), std::string::npos) << e.what();
    }
  }
  // The boundaries the ranges allow.
  ComparatorOptions edge;
  edge.max_window_samples = 2;
  edge.crossing_hysteresis_rad = 0;
  EXPECT_NO_THROW(edge.Validate());
}

}  // namespace
}  // namespace rocklab::compare
