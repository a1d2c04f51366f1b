// An assembly against its measurement: per-body figures and the mode
// agreement (compare/bodies_comparator.h).
#include "compare/bodies_comparator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace rocklab::compare {
namespace {

// Oracle: docs/models.md's mode names by hand. Interface k carries the
// relative angle theta_k - theta_{k-1} (the table under body 0): > rest is
// R (the single block's theta > 0), < -rest is L, else C; the threshold
// itself is still closed.
TEST(MeasuredMode, NamesEachInterfaceByItsRelativeAngle) {
  std::string mode;
  const double rest = 2e-3;
  const double one_body[] = {0.01, 0.01};  // rocking as one on the +x corner
  MeasuredMode(one_body, 2, rest, mode);
  EXPECT_EQ(mode, "RC");
  const double upper_alone[] = {0.0, -0.02};
  MeasuredMode(upper_alone, 2, rest, mode);
  EXPECT_EQ(mode, "CL");
  const double both[] = {-0.01, 0.005};  // upper turned +0.015 relative to the lower
  MeasuredMode(both, 2, rest, mode);
  EXPECT_EQ(mode, "LR");
  const double at_rest[] = {rest, 2 * rest, 2 * rest};  // every relative angle exactly rest
  MeasuredMode(at_rest, 3, rest, mode);
  EXPECT_EQ(mode, "CCC");
  const double lost[] = {0.01, std::nan("")};
  MeasuredMode(lost, 2, rest, mode);
  EXPECT_EQ(mode, "R?");
}

// A two-body response at 1 kHz for 1 s: the lower body rocks alone-sized,
// the upper one with twice its amplitude (every interface open or closed
// by the angles alone).
constexpr int kSamples = 1000;
double Lower(int i) { return 0.02 * std::sin(2 * M_PI * 2.0 * i * 1e-3); }
double Upper(int i) { return 0.04 * std::sin(2 * M_PI * 2.0 * i * 1e-3); }

// Oracle: a model equal to the measurement has zero error on every body,
// correlation 1 and the mode it names from the same angles: agreement 1.
TEST(BodiesComparator, AModelEqualToTheMeasurementHasNoErrorAndAgreesAlways) {
  BodiesComparator c(2);
  std::string mode;
  for (int i = 0; i < kSamples; ++i) {
    const double th[] = {Lower(i), Upper(i)};
    const bool valid[] = {true, true};
    MeasuredMode(th, 2, 2e-3, mode);
    c.Add(1000 * i, th, valid, th, mode);
  }
  for (int k = 0; k < 2; ++k) {
    EXPECT_EQ(c.body(k).rms_total, 0.0) << k;
    EXPECT_EQ(c.body(k).max_abs_error, 0.0) << k;
    EXPECT_NEAR(c.body(k).correlation, 1.0, 1e-12) << k;
    EXPECT_EQ(c.body(k).samples, kSamples) << k;
    EXPECT_EQ(c.body(k).unmatched_crossings, 0) << k;
  }
  EXPECT_EQ(c.mode().samples, kSamples);
  EXPECT_EQ(c.mode().fraction(), 1.0);
}

// Oracle: a constant offset d_k on body k is an error of d_k at every
// sample: RMS d_k, max |error| d_k, nRMS d_k / peak |theta_k| (the sampled
// peak, computed here); the crossings move by nothing measurable at a
// 1e-4 rad offset against a 2 Hz swing of 0.02 rad (|dtheta/dt| >= 0.25 rad/s
// at the crossing: < 0.4 ms, under one sample).
TEST(BodiesComparator, AKnownOffsetPerBodyIsItsRms) {
  BodiesComparator c(3);
  const double offset[] = {1e-4, -3e-4, 5e-4};
  double peak[3] = {};
  for (int i = 0; i < kSamples; ++i) {
    const double th[] = {Lower(i), Upper(i), 1.5 * Upper(i)};
    const double model[] = {th[0] + offset[0], th[1] + offset[1], th[2] + offset[2]};
    const bool valid[] = {true, true, true};
    for (int k = 0; k < 3; ++k) peak[k] = std::max(peak[k], std::abs(th[k]));
    c.Add(1000 * i, th, valid, model, "");
  }
  for (int k = 0; k < 3; ++k) {
    // Rounding of theta + offset - theta: a few ulp of 0.06 rad.
    EXPECT_NEAR(c.body(k).rms_total, std::abs(offset[k]), 1e-15) << k;
    EXPECT_NEAR(c.body(k).max_abs_error, std::abs(offset[k]), 1e-15) << k;
    EXPECT_NEAR(c.body(k).nrms, std::abs(offset[k]) / peak[k], 1e-12) << k;
  }
  // The model's mode "" is unknown: no sample enters the agreement.
  EXPECT_EQ(c.mode().samples, 0);
  EXPECT_TRUE(std::isnan(c.mode().fraction()));
}

// Oracle: the model says "RC" (rocking as one body) for the whole second;
// the measurement rocks as one for 0.6 s, then its upper block turns
// 0.01 rad further than the lower one ("RR") for 0.4 s: the modes agree
// 600 of 1000 samples, 0.6 exactly. While the DAQ flags one body (200
// samples in the agreeing part) those samples leave the fraction: 400 of 800.
TEST(BodiesComparator, AModeFlipForAKnownDurationGivesItsShare) {
  for (const bool flagged : {false, true}) {
    BodiesComparator c(2);
    for (int i = 0; i < kSamples; ++i) {
      const double lower = 0.01 + 0.005 * std::sin(1e-2 * i);
      const double th[] = {lower, i < 600 ? lower : lower + 0.01};
      const bool upper_valid = !(flagged && i >= 100 && i < 300);
      const bool valid[] = {true, upper_valid};
      c.Add(1000 * i, th, valid, th, "RC");
    }
    if (!flagged) {
      EXPECT_EQ(c.mode().samples, 1000);
      EXPECT_EQ(c.mode().fraction(), 0.6);
    } else {
      EXPECT_EQ(c.mode().samples, 800);
      EXPECT_EQ(c.mode().fraction(), 0.5);
    }
    EXPECT_EQ(c.mode().model, "RC");
    EXPECT_EQ(c.mode().measured, "RR");
  }
}

// A mode string that does not name every interface is not compared.
TEST(BodiesComparator, AModeOfAnotherLengthIsNotCompared) {
  BodiesComparator c(2);
  const double th[] = {0.0, 0.0};
  const bool valid[] = {true, true};
  c.Add(0, th, valid, th, "C");
  c.Add(1000, th, valid, th, "CCC");
  EXPECT_EQ(c.mode().samples, 0);
  c.Add(2000, th, valid, th, "CC");
  EXPECT_EQ(c.mode().samples, 1);
  EXPECT_EQ(c.mode().fraction(), 1.0);
  EXPECT_THROW(BodiesComparator(0), std::invalid_argument);
  BodiesComparatorOptions bad;
  bad.mode_rest_rad = -1;
  EXPECT_THROW(BodiesComparator(2, bad), std::invalid_argument);
}

}  // namespace
}  // namespace rocklab::compare
