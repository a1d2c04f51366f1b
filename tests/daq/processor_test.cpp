// When the Processor's block and table states leave, and what the table
// differentiator evaluated off-centre gives. Oracles: frame counting (the
// states of sample k leave when sample k + delay arrives, the delay stated in
// docs/acquisition.md); the analytic derivatives of a sampled sine, within
// the Taylor bound of the least-squares polynomial (below) plus the noise
// gain the filter states; the centred filter run alone on the same samples
// (the default without an accelerometer is the filter it was).
#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "daq/processor.h"
#include "daq/rig_simulator.h"
#include "daq/savitzky_golay.h"
#include "rocklab/table_state_t.hpp"
#include "tests/daq/daq_test_util.h"
#include "common/units.h"

namespace rocklab::daq {
namespace {

using ::rocklab::common::kPi;  // one pi for the tests a unity batch shares
constexpr double kU = 0.006;              // table amplitude, m
constexpr double kW = 2 * kPi * 1.0;      // table angular frequency, rad/s (1 Hz)

TrueMotion ProcessorMotion(double t) {
  TrueMotion m;
  m.time_s = t;
  m.theta = 0.03 * std::sin(2 * kPi * 1.5 * t);
  m.table_displacement = kU * std::sin(kW * t);
  m.table_acceleration = -kU * kW * kW * std::sin(kW * t);
  return m;
}
double Velocity(double t) { return kU * kW * std::cos(kW * t); }
double Acceleration(double t) { return -kU * kW * kW * std::sin(kW * t); }

std::string LabRigText() {
  std::ifstream in(test::LabRigPath());
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}
RigConfig ProcessorLabRig() { return LoadRigConfig(test::LabRigPath()); }
// The lab rig without its accelerometer (the last [[channel]]), with `table`
// lines added to its [table] section.
RigConfig WithoutAccelerometer(const std::string& table = "") {
  std::string s = LabRigText();
  s = s.substr(0, s.rfind("[[channel]]"));
  const std::string section = "[table]";
  s.insert(s.find('\n', s.find(section)) + 1, table);
  return ParseRigConfig(s, "lab_rig_noacc.toml");
}
std::vector<std::string> Names(const RigConfig& rig) { return RigSimulator(rig, {}, 0).channel_names(); }

// Runs `frames` and checks after each one that exactly the received samples
// at least `delay` samples older than it have left, block and table in pairs.
void ExpectPairsLeaveAfter(const RigConfig& rig, const std::vector<Frame>& frames, int delay,
                           test::CollectSink& sink) {
  Processor proc(rig, Names(rig), "sim", sink);
  ASSERT_EQ(proc.output_delay_samples(), delay);
  std::vector<int64_t> received;
  for (const Frame& f : frames) {
    proc.Process(f);
    received.push_back(f.seq);
    const auto due = static_cast<size_t>(
        std::upper_bound(received.begin(), received.end(), f.seq - delay) - received.begin());
    ASSERT_EQ(sink.block.size(), due) << "after seq " << f.seq;
    ASSERT_EQ(sink.table.size(), due) << "after seq " << f.seq;
  }
  proc.Finish();
  ASSERT_EQ(sink.block.size(), frames.size());
  ASSERT_EQ(sink.table.size(), frames.size());
  for (size_t i = 0; i < frames.size(); ++i) {
    ASSERT_EQ(sink.block[i].seq, frames[i].seq);
    ASSERT_EQ(sink.table[i].seq, frames[i].seq);
  }
}

// Oracle: counting. The lab rig measures the acceleration: the pair of
// sample k leaves when sample k + 5 arrives (theta_dot's 5-sample half
// window), not k + 50 (the table window's); with 1 % of the samples dropped
// (gaps bridged or ending a segment) the rule holds for every received sample.
TEST(ProcessorDelay, WithAnAccelerometerEachPairLeavesAtThetasDelay) {
  const RigConfig rig = ProcessorLabRig();
  {
    test::CollectSink sink;
    Processor proc(rig, Names(rig), "sim", sink);
    EXPECT_EQ(proc.theta_delay_samples(), 5);
    EXPECT_EQ(proc.table_delay_samples(), 5);
  }
  test::CollectSink clean;
  ExpectPairsLeaveAfter(rig, test::SimulateFrames(rig, {}, 1, 1.0, ProcessorMotion), 5, clean);
  for (const TableState& t : clean.table) {
    EXPECT_EQ(t.accel_source, int8_t{rocklab::table_state_t::ACCEL_ACCELEROMETER});
    EXPECT_NEAR(t.acceleration, Acceleration(t.time_s), 1e-9);  // the accelerometer's own sample
  }
  SimulatorNoise drops;
  drops.drop = 0.01;
  const auto frames = test::SimulateFrames(rig, drops, 4, 5.0, ProcessorMotion);
  ASSERT_LT(frames.size(), 5000u);
  test::CollectSink gappy;
  ExpectPairsLeaveAfter(rig, frames, 5, gappy);
}

// Oracle: counting, as before this change: without an accelerometer the
// table differentiator stays centred and the pair leaves 50 samples late.
TEST(ProcessorDelay, WithoutAnAccelerometerThePairWaitsForTheCentredTable) {
  const RigConfig rig = WithoutAccelerometer();
  test::CollectSink sink;
  SimulatorNoise drops;
  drops.drop = 0.01;
  ExpectPairsLeaveAfter(rig, test::SimulateFrames(rig, drops, 4, 5.0, ProcessorMotion), 50, sink);
  for (const TableState& t : sink.table) {
    EXPECT_EQ(t.accel_source, int8_t{rocklab::table_state_t::ACCEL_DIFFERENTIATED});
  }
}

// Oracle: the centred filter run alone on the calibrated displacement. The
// default rig without an accelerometer gives bit for bit its velocity and
// acceleration (what the Processor always gave), and `lag_s` set to the
// half window (0.05 s) is the same filter.
TEST(ProcessorDelay, WithoutAnAccelerometerTheDefaultIsTheCentredFilterBitForBit) {
  const RigConfig rig = WithoutAccelerometer();
  SimulatorNoise noise;
  noise.table_m = 2e-5;
  const auto frames = test::SimulateFrames(rig, noise, 7, 3.0, ProcessorMotion);
  test::CollectSink sink, explicit_centre;
  {
    Processor proc(rig, Names(rig), "sim", sink);
    for (const Frame& f : frames) proc.Process(f);
    proc.Finish();
    Processor centre(WithoutAccelerometer("lag_s = 0.05\n"), Names(rig), "sim", explicit_centre);
    EXPECT_EQ(centre.table_delay_samples(), 50);
    for (const Frame& f : frames) centre.Process(f);
    centre.Finish();
  }
  SavitzkyGolay sg(50, 4, 1e-3);
  std::vector<SgOutput> want;
  SgOutput o;
  for (const TableState& t : sink.table) {
    sg.Push(t.displacement);
    while (sg.Pop(o)) want.push_back(o);
  }
  sg.Finish();
  while (sg.Pop(o)) want.push_back(o);
  ASSERT_EQ(sink.table.size(), frames.size());
  ASSERT_EQ(want.size(), frames.size());
  ASSERT_EQ(explicit_centre.table.size(), frames.size());
  for (size_t i = 0; i < frames.size(); ++i) {
    ASSERT_EQ(sink.table[i].velocity, want[i].d1) << i;
    ASSERT_EQ(sink.table[i].acceleration, want[i].d2) << i;
    ASSERT_EQ(explicit_centre.table[i].velocity, sink.table[i].velocity) << i;
    ASSERT_EQ(explicit_centre.table[i].acceleration, sink.table[i].acceleration) << i;
  }
}

// Bias of derivative `deriv` of the order-4 fit evaluated `lag` samples
// behind the newest on U sin(w t). The fit reproduces the degree-4 Taylor
// polynomial T of the sine about the output's sample, so the error is
// sum_i w_i (f(t_i) - T(t_i)), and |f - T| <= U w^5 |tau_i|^5 / 5! (tau_i the
// sample's distance to the output's): bias <= U w^5 / 120 sum |w_i| |tau_i|^5.
double TaylorBound(const SavitzkyGolay& sg, int deriv, double dt) {
  const Eigen::VectorXd w = sg.LagWeights(deriv);
  const int newest = static_cast<int>(w.size()) - 1;
  double sum = 0;
  for (int i = 0; i <= newest; ++i) sum += std::abs(w(i)) * std::pow((newest - sg.delay_samples() - i) * dt, 5);
  return kU * std::pow(kW, 5) / 120 * sum;
}

// Oracle: the analytic velocity U w cos(w t), within the Taylor bound above
// (noise-free; 1e-9 m/s for rounding) and within that plus 6 noise sigmas
// (sigma_u times the stated noise gain; probability 2e-9 per sample) on 20 um
// displacement noise. Interior samples (full windows) only.
TEST(ProcessorTable, OffCentreVelocityIsWithinItsBoundOfTheSine) {
  const RigConfig rig = ProcessorLabRig();
  const SavitzkyGolay sg(50, 4, 1e-3, 5);
  const double bias = TaylorBound(sg, 1, 1e-3);
  EXPECT_LT(bias, 0.01 * kU * kW);  // the bound itself is useful: < 1 % of the peak
  for (double sigma : {0.0, 2e-5}) {
    SimulatorNoise noise;
    noise.table_m = sigma;
    const auto frames = test::SimulateFrames(rig, noise, 3, 4.0, ProcessorMotion);
    test::CollectSink sink;
    Processor proc(rig, Names(rig), "sim", sink);
    for (const Frame& f : frames) proc.Process(f);
    proc.Finish();
    ASSERT_EQ(sink.table.size(), frames.size());
    const double tol = bias + 1e-9 + 6 * sigma * sg.NoiseGain(1);
    for (size_t i = 95; i + 5 < sink.table.size(); ++i) {
      const TableState& t = sink.table[i];
      ASSERT_LT(std::abs(t.velocity - Velocity(t.time_s)), tol) << sigma << " " << t.time_s;
    }
  }
}

// What a linear filter with weights w (sample i at tau_i from the output's
// sample) makes of U sin(w t): sum_i w_i U sin(w (t + tau_i)).
double Response(const SavitzkyGolay& sg, int deriv, double t, double dt) {
  const Eigen::VectorXd w = sg.LagWeights(deriv);
  const int at = static_cast<int>(w.size()) - 1 - sg.delay_samples();
  double sum = 0;
  for (int i = 0; i < w.size(); ++i) sum += w(i) * kU * std::sin(kW * (t + (i - at) * dt));
  return sum;
}

// Oracle: counting and the analytic acceleration. Without an accelerometer,
// [table] lag_s trades noise for latency: at 2 ms (shorter than theta_dot's
// 5 ms) and at 0 (the window's newest sample) the pair leaves at theta's
// delay, at 20 ms at 20 samples. On noise-free samples of the 1 Hz sine:
// - the acceleration is the lag filter's response to the sine (above),
//   rounding only (1e-9 m/s^2): the filter is applied to the right samples;
// - it is within the Taylor bound of the truth (+1e-9 m/s^2), a bound that
//   does not rely on the weights being right (only on the fit's exactness
//   for quartics, savitzky_golay_test), but is loose: up to 15 % of the peak;
// - the response itself is within 1 % of the truth.
// Its noise is the filter's stated gain (savitzky_golay_test).
TEST(ProcessorTable, LagOptionSetsTheDelayWithoutAnAccelerometer) {
  for (const auto& [lag_s, lag, delay] : {std::tuple<double, int, int>{0.002, 2, 5}, {0.02, 20, 20}, {0.0, 0, 5}}) {
    std::ostringstream key;
    key << "lag_s = " << lag_s << "\n";
    const RigConfig rig = WithoutAccelerometer(key.str());
    {
      test::CollectSink none;
      Processor proc(rig, Names(rig), "sim", none);
      EXPECT_EQ(proc.table_delay_samples(), lag);
    }
    test::CollectSink sink;
    ExpectPairsLeaveAfter(rig, test::SimulateFrames(rig, {}, 5, 3.0, ProcessorMotion), delay, sink);
    const SavitzkyGolay sg(50, 4, 1e-3, lag);
    const double bias = TaylorBound(sg, 2, 1e-3);
    for (size_t i = 100 - lag; i + lag < sink.table.size(); ++i) {
      const TableState& t = sink.table[i];
      ASSERT_EQ(t.accel_source, int8_t{rocklab::table_state_t::ACCEL_DIFFERENTIATED});
      const double response = Response(sg, 2, t.time_s, 1e-3);
      ASSERT_NEAR(t.acceleration, response, 1e-9) << lag_s << " " << t.time_s;
      ASSERT_LT(std::abs(t.acceleration - Acceleration(t.time_s)), bias + 1e-9) << lag_s << " " << t.time_s;
      ASSERT_LT(std::abs(response - Acceleration(t.time_s)), 0.01 * kU * kW * kW) << lag_s << " " << t.time_s;
    }
  }
}

}  // namespace
}  // namespace rocklab::daq
