// The band comparison (coverage of the posterior predictive band, impact
// times in units of the ensemble's spread) on cases whose answer is known by
// construction, and through the compare node (RL_COVERAGE, summary JSON).
#include "compare/band_comparator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/direct_bus.h"
#include "compare/compare_node.h"
#include "rocklab/band_comparison_t.hpp"
#include "rocklab/model_band_t.hpp"
#include "tests/scratch.h"
#include "tests/tools/lcm_messages.h"
#include "common/units.h"

namespace rocklab::compare {
namespace {

using ::rocklab::common::kPi;  // one pi for the tests a unity batch shares
std::int64_t BandUtime(int k) { return 1000 * static_cast<std::int64_t>(k); }  // 1 kHz

// A band constant in time: [-w95, w95] and [-w68, w68] around `centre`, no impacts.
BandSample Flat(double centre, double w95, double w68) {
  BandSample b;
  b.lo95 = centre - w95;
  b.hi95 = centre + w95;
  b.lo68 = centre - w68;
  b.hi68 = centre + w68;
  b.median = centre;
  return b;
}

// Oracle: by construction. The measurement cycles through 10 values of
// which 9 lie inside [-1, 1] and 3 inside [-0.5, 0.5]: coverage 0.9 and 0.3
// exactly over whole cycles since the start; the window's fraction counted
// in the test over the samples it holds.
TEST(BandComparator, CoverageIsTheFractionOfSamplesInside) {
  const double cycle[10] = {0.0, 0.2, -0.4, 0.7, -0.9, 0.95, -0.6, 0.8, 1.5, -0.99};
  ComparatorOptions options;
  options.window_s = 2.0005;  // half a sample over 2 s: which samples it holds is not a rounding question
  BandComparator c(options);
  for (int k = 0; k < 5000; ++k) c.Add(BandUtime(k), cycle[k % 10], true, Flat(0.0, 1.0, 0.5));
  const BandMetrics& m = c.metrics();
  EXPECT_DOUBLE_EQ(m.coverage95_total, 0.9);
  EXPECT_DOUBLE_EQ(m.coverage68_total, 0.3);
  // The window holds the samples within 2.0005 s of the latest: 2001
  // samples, k = 2999 .. 4999.
  int in95 = 0, in68 = 0;
  for (int k = 2999; k < 5000; ++k) {
    in95 += std::abs(cycle[k % 10]) <= 1.0;
    in68 += std::abs(cycle[k % 10]) <= 0.5;
  }
  EXPECT_DOUBLE_EQ(m.coverage95_window, in95 / 2001.0);
  EXPECT_DOUBLE_EQ(m.coverage68_window, in68 / 2001.0);
  EXPECT_EQ(m.valid_samples, 5000);
  EXPECT_DOUBLE_EQ(m.width95, 2.0);
}

// Oracle: a measurement shifted outside the band (band +-0.01 rad around a
// curve, the measurement that curve + 0.05 rad) is never inside: coverage 0;
// the same curve itself is always inside: coverage 1.
TEST(BandComparator, MeasurementOutsideTheBandHasCoverageZero) {
  BandComparator outside, inside;
  for (int k = 0; k < 3000; ++k) {
    const double th = 0.05 * std::sin(2 * kPi * 1.1 * k * 1e-3);
    outside.Add(BandUtime(k), th + 0.05, true, Flat(th, 0.01, 0.005));
    inside.Add(BandUtime(k), th, true, Flat(th, 0.01, 0.005));
  }
  EXPECT_EQ(outside.metrics().coverage95_total, 0.0);
  EXPECT_EQ(outside.metrics().coverage95_window, 0.0);
  EXPECT_EQ(inside.metrics().coverage95_total, 1.0);
  EXPECT_EQ(inside.metrics().coverage68_total, 1.0);
  EXPECT_NEAR(outside.metrics().median_error, -0.05, 1e-12);
}

// Oracle: a measurement that is a draw of the ensemble's distribution: the
// band is the exact 2.5/97.5 % and 16/84 % quantiles of N(0, s^2) (s z with
// z = 1.959964, 0.994458), the measurement N(0, s^2) noise (seeded). Over
// n = 200000 samples the coverage is binomial: 0.95 +- 4 sd (4 * 0.00049)
// and 0.68 +- 4 sd (4 * 0.00104).
TEST(BandComparator, GaussianDrawsCoverAtTheNominalRate) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 0.01);
  BandComparator c;
  const int n = 200000;
  for (int k = 0; k < n; ++k) {
    c.Add(BandUtime(k), noise(rng), true, Flat(0.0, 0.01 * 1.959964, 0.01 * 0.994458));
  }
  EXPECT_NEAR(c.metrics().coverage95_total, 0.95, 4 * std::sqrt(0.95 * 0.05 / n));
  EXPECT_NEAR(c.metrics().coverage68_total, 0.68, 4 * std::sqrt(0.68 * 0.32 / n));
}

// Oracle: invalid pairs (DAQ flags) and a band that is not finite (every
// member failed) are left out of the coverage: 1000 valid samples inside,
// 500 invalid ones outside: coverage 1.
TEST(BandComparator, InvalidPairsAreLeftOut) {
  BandComparator c;
  for (int k = 0; k < 1000; ++k) c.Add(BandUtime(k), 0.0, true, Flat(0.0, 1.0, 0.5));
  for (int k = 1000; k < 1250; ++k) c.Add(BandUtime(k), 5.0, false, Flat(0.0, 1.0, 0.5));
  for (int k = 1250; k < 1500; ++k) c.Add(BandUtime(k), 5.0, true, Flat(std::nan(""), 1.0, 0.5));
  EXPECT_EQ(c.metrics().coverage95_total, 1.0);
  EXPECT_EQ(c.metrics().valid_samples, 1000);
  EXPECT_EQ(c.metrics().samples, 1500);
  EXPECT_FALSE(c.metrics().valid);
}

// The measurement: sin(2 pi t), crossing zero - to + at t = 1, 2, ... s and
// + to - at 0.5, 1.5, ... s; the band's members impact (up) at the up-crossings
// plus the offsets given, each in the sample whose interval holds it.
struct ImpactCase {
  std::vector<double> offsets_s;  // member impact time - measured crossing time, s
};

BandMetrics RunImpacts(const ImpactCase& ic, int seconds) {
  BandComparator c;
  const int n = seconds * 1000 + 1;
  std::vector<BandSample> band(static_cast<std::size_t>(n), Flat(0.0, 1.0, 0.5));
  for (int s = 1; s < seconds; ++s) {
    for (double off : ic.offsets_s) {
      const double t = s + off;
      const int k = static_cast<int>(std::ceil(t * 1000 - 1e-9));  // the sample whose interval holds t
      BandSample& b = band[static_cast<std::size_t>(k)];
      const double o = t - k * 1e-3;
      ++b.impacts_up;
      b.up_offset_sum += o;
      b.up_offset_sq_sum += o * o;
    }
  }
  for (int k = 0; k < n; ++k) {
    c.Add(BandUtime(k), 0.1 * std::sin(2 * kPi * k * 1e-3), true, band[static_cast<std::size_t>(k)]);
  }
  return c.Finish();
}

// Oracle: hand arithmetic. Member impacts at t_m + {-0.01, 0, 0.01, 0.02,
// 0.03} s: mean offset 0.01 s, sample sd sqrt(0.001 / 4) = 0.0158114 s, so
// z = 0.01 / 0.0158114 = 0.632456 at every up-crossing (the down-crossings
// have no member impact: unmatched). The measured crossing time comes from
// linear interpolation between samples of a sine: its error (< 1e-7 s) is
// far below the tolerance (1e-5 in z).
TEST(BandComparator, ImpactTimingInUnitsOfTheEnsembleSpread) {
  const BandMetrics m = RunImpacts({{-0.01, 0.0, 0.01, 0.02, 0.03}}, 6);
  const double sd = std::sqrt(0.001 / 4);
  EXPECT_EQ(m.matched_crossings, 5);  // the up-crossings at 1 .. 5 s
  EXPECT_NEAR(m.impact_time_sd, sd, 1e-7);
  EXPECT_NEAR(m.impact_timing_z, 0.01 / sd, 1e-5);
  EXPECT_NEAR(m.impact_timing_z_rms, 0.01 / sd, 1e-5);
  EXPECT_NEAR(m.impact_timing_z_max_abs, 0.01 / sd, 1e-5);
  EXPECT_EQ(m.unmatched_crossings, 6);  // the down-crossings at 0.5 .. 5.5 s: no member impact
}

// Oracle: members' impacts farther than crossing_match_s (0.2 s) from the
// measured crossing are not its cluster; one member's impact alone has no sd.
TEST(BandComparator, FarOrLoneImpactsGiveNoZ) {
  const BandMetrics far = RunImpacts({{0.3, 0.35}}, 4);
  EXPECT_EQ(far.matched_crossings, 0);
  EXPECT_TRUE(std::isnan(far.impact_timing_z));
  const BandMetrics lone = RunImpacts({{0.01}}, 4);
  EXPECT_EQ(lone.matched_crossings, 0);
  EXPECT_GT(lone.unmatched_crossings, 0);
}

rocklab::model_band_t BandMessage(const std::string& name, std::int64_t utime, double centre) {
  rocklab::model_band_t b{};
  b.utime = utime;
  b.name = name;
  b.model = "complex";
  b.draws = 8;
  b.members = 8;
  b.theta_median = centre;
  b.theta_lo95 = centre - 0.02;
  b.theta_hi95 = centre + 0.02;
  b.theta_lo68 = centre - 0.01;
  b.theta_hi68 = centre + 0.01;
  return b;
}

// Oracle: through the node, whichever side arrives first. The measurement
// lies inside the 68 % band for the first 1000 samples and between the 68
// and 95 % edges (0.015 rad off the median) for the next 1000: coverage95 1,
// coverage68 0.5; RL_COVERAGE_<name> at the RL_COMPARE rate (20 Hz: one per
// 50 samples, and Finish's last one for the samples after the 40th) and
// the summary JSON's plainly named keys.
TEST(CompareNodeBand, CoverageThroughTheNodeAndTheSummary) {
  common::DirectBus bus;
  std::vector<rocklab::band_comparison_t> out;
  const common::Subscription sub = bus.Subscribe<rocklab::band_comparison_t>(
      "RL_COVERAGE_post", [&](const std::string&, const rocklab::band_comparison_t& m) { out.push_back(m); });
  CompareNode node(CompareNodeConfig{}, bus);
  for (int k = 0; k < 2000; ++k) {
    const double measured = k < 1000 ? 0.0 : 0.015;
    rocklab::model_band_t b = BandMessage("post", BandUtime(k), 0.0);
    b.seq = k;
    if (k % 2 == 0) {
      node.HandleTheta(test::Theta(BandUtime(k), measured));
      node.HandleBand(b);
    } else {
      node.HandleBand(b);
      node.HandleTheta(test::Theta(BandUtime(k), measured));
    }
  }
  node.Finish();
  ASSERT_FALSE(out.empty());
  EXPECT_EQ(out.size(), 41u);
  EXPECT_EQ(out.back().seq, 40);
  EXPECT_DOUBLE_EQ(out.back().coverage95_total, 1.0);
  EXPECT_DOUBLE_EQ(out.back().coverage68_total, 0.5);
  EXPECT_EQ(out.back().samples, 2000);
  const std::vector<BandSummary> bands = node.BandSummaries();
  ASSERT_EQ(bands.size(), 1u);
  EXPECT_EQ(bands[0].unmatched_measured, 0);
  EXPECT_EQ(bands[0].unmatched_model, 0);
  EXPECT_EQ(node.model_gaps(), 0);

  const std::string path = test::ScratchDir("band_summary") + "/summary.json";
  CompareNode::WriteSummaryJson(node.Summary(), bands, path);
  std::ifstream in(path);
  const auto j = nlohmann::json::parse(in);
  const auto& b = j.at("bands").at(0);
  EXPECT_EQ(b.at("name"), "post");
  EXPECT_EQ(b.at("model"), "complex");
  EXPECT_EQ(b.at("draws"), 8);
  EXPECT_DOUBLE_EQ(b.at("band_coverage_95").get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(b.at("band_coverage_68").get<double>(), 0.5);
  EXPECT_TRUE(b.at("impact_timing_z_rms").is_null());  // constant signals: no crossing
  EXPECT_EQ(j.at("units").at("band_coverage_95"), "1");
  EXPECT_TRUE(j.at("variants").is_array());
  // The older call writes an empty band list: its readers keep working.
  CompareNode::WriteSummaryJson(node.Summary(), path);
  std::ifstream again(path);
  EXPECT_TRUE(nlohmann::json::parse(again).at("bands").empty());
}

}  // namespace
}  // namespace rocklab::compare
