// Reconstruction through the inverse measurement models (daq/rig_simulator.h)
// driven by an analytic motion. Oracles: the analytic motion itself; the
// noise each estimate must carry, derived from the injected noise; Eigen's
// umeyama() for the rigid fit.
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "daq/processor.h"
#include "daq/reconstruction.h"
#include "daq/rig_simulator.h"
#include "rocklab/event2_t.hpp"
#include "rocklab/table_state_t.hpp"
#include "tests/daq/daq_test_util.h"
#include "common/units.h"

namespace rocklab::daq {
namespace {

using common::kPi;

// Rocking-like test motion: theta crosses zero (both pivots are used), the
// table moves 6 mm at 5 Hz (docs/errata.md item 11's figure 8 amplitude).
TrueMotion Motion(double t) {
  TrueMotion m;
  m.time_s = t;
  m.theta = 0.05 * std::sin(2 * kPi * 1.0 * t);
  const double w = 2 * kPi * 5.0;
  m.table_displacement = 0.006 * std::sin(w * t);
  m.table_acceleration = -0.006 * w * w * std::sin(w * t);
  return m;
}
double ThetaDot(double t) { return 0.05 * 2 * kPi * std::cos(2 * kPi * t); }

struct Run {
  test::CollectSink sink;
  ProcessorCounts counts;
  SequenceCounts sequence;
  ReconstructionCounts recon;
};

std::unique_ptr<Run> Process(const RigConfig& rig, const std::vector<Frame>& frames) {
  auto run = std::make_unique<Run>();
  Processor proc(rig, RigSimulator(rig, {}, 0).channel_names(), "sim", run->sink);
  for (const Frame& f : frames) proc.Process(f);
  proc.Finish();
  run->counts = proc.counts();
  run->sequence = proc.sequence();
  run->recon = proc.reconstruction();
  return run;
}

RigConfig LabRig() { return LoadRigConfig(test::LabRigPath()); }

// The lab rig without its accelerometer channel (the last [[channel]]).
RigConfig LabRigWithoutAccelerometer() {
  std::ifstream in(test::LabRigPath());
  std::stringstream text;
  text << in.rdbuf();
  std::string s = text.str();
  s = s.substr(0, s.rfind("[[channel]]"));
  return ParseRigConfig(s, "lab_rig_noacc.toml");
}

TEST(FitRigid2d, AgreesWithEigenUmeyama) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 20; ++trial) {
    const int n = 2 + trial % 5;
    Eigen::MatrixXd model(2, n), world(2, n);
    const double phi = 3 * u(rng);
    const Eigen::Rotation2Dd rot(phi);
    const Eigen::Vector2d t(u(rng), u(rng));
    for (int i = 0; i < n; ++i) {
      model.col(i) = Eigen::Vector2d(u(rng), u(rng));
      world.col(i) = rot * model.col(i) + t + 0.01 * Eigen::Vector2d(u(rng), u(rng));
    }
    const Rigid2d fit = FitRigid2d(model.data(), world.data(), n);
    const Eigen::MatrixXd ref = Eigen::umeyama(model, world, false);
    // Both are the exact least-squares solution: equal to rounding.
    EXPECT_NEAR(fit.phi, std::atan2(ref(1, 0), ref(0, 0)), 1e-12) << trial;
    EXPECT_NEAR(fit.tx, ref(0, 2), 1e-12);
    EXPECT_NEAR(fit.tz, ref(1, 2), 1e-12);
  }
}

TEST(Reconstruction, NoiseFreeRoundTripIsExact) {
  const RigConfig rig = LabRig();
  const auto frames = test::SimulateFrames(rig, {}, 1, 2.0, Motion);
  const auto run = Process(rig, frames);
  ASSERT_EQ(run->sink.block.size(), frames.size());
  for (const BlockState& s : run->sink.block) {
    const TrueMotion m = Motion(s.time_s);
    // Forward model = exact inverse of the simulator: rounding only.
    EXPECT_NEAR(s.theta_mirror, m.theta, 1e-12);
    EXPECT_NEAR(s.theta_camera, m.theta, 1e-12);
    EXPECT_EQ(s.theta, s.theta_mirror);
    EXPECT_NEAR(s.sliding, 0, 1e-12);
    EXPECT_NEAR(s.jump, 0, 1e-12);
    EXPECT_NEAR(s.twist, 0, 1e-12);
    EXPECT_NEAR(s.out_of_plane, 0, 1e-12);
    EXPECT_EQ(s.leds_used, 4);
    EXPECT_EQ(s.flags, 0);
  }
  EXPECT_TRUE(run->sink.events.empty());
  ASSERT_EQ(run->sink.table.size(), frames.size());
  for (const TableState& t : run->sink.table) {
    EXPECT_NEAR(t.acceleration, Motion(t.time_s).table_acceleration, 1e-12);
    EXPECT_EQ(t.accel_source, int8_t{rocklab::table_state_t::ACCEL_ACCELEROMETER});
  }
}

TEST(Reconstruction, NoisyRoundTripCarriesTheInjectedNoiseOnly) {
  const RigConfig rig = LabRig();
  SimulatorNoise noise = SimulatorNoise::Typical();
  noise.occlusion = 0;
  noise.drop = 0;
  const auto frames = test::SimulateFrames(rig, noise, 2, 10.0, Motion);
  const auto run = Process(rig, frames);
  ASSERT_EQ(run->sink.block.size(), frames.size());
  // Mirror: theta = atan(s / D) / 2, so sigma_theta = sigma_s cos^2(2 theta) / (2 D),
  // within 1 % of sigma_s / (2 D) for |theta| <= 0.05.
  const double sigma_m = noise.mirror_m / (2 * rig.mirror.lever_m);
  // Cameras: the least-squares rotation of n LEDs with isotropic noise
  // sigma has sigma_phi = sigma / sqrt(sum |p_i - centroid|^2).
  double spread = 0;
  for (const auto& cam : rig.cameras) {
    for (const auto& led : cam.leds) spread += led.x_m * led.x_m + (led.z_m - 0.5) * (led.z_m - 0.5);
  }
  const double sigma_c = noise.led_m / std::sqrt(spread);
  double ss_m = 0, ss_c = 0, ss_d = 0, max_m = 0, max_c = 0;
  for (const BlockState& s : run->sink.block) {
    const double truth = Motion(s.time_s).theta;
    ss_m += std::pow(s.theta_mirror - truth, 2);
    ss_c += std::pow(s.theta_camera - truth, 2);
    ss_d += std::pow(s.theta_mirror - s.theta_camera, 2);
    max_m = std::max(max_m, std::abs(s.theta - truth));
    max_c = std::max(max_c, std::abs(s.theta_camera - truth));
    EXPECT_EQ(s.flags, 0) << s.time_s;
  }
  const double n = static_cast<double>(run->sink.block.size());
  // 10001 samples: the sample RMS is within 1/sqrt(2n) = 0.7 % (1 sigma) of
  // the true one; 5 % is 7 sigma, plus the 1 % of the cos^2 factor.
  EXPECT_NEAR(std::sqrt(ss_m / n) / sigma_m, 1.0, 0.05);
  EXPECT_NEAR(std::sqrt(ss_c / n) / sigma_c, 1.0, 0.05);
  // Mirror and cameras agree: their difference is the two noises combined.
  EXPECT_NEAR(std::sqrt(ss_d / n) / std::hypot(sigma_m, sigma_c), 1.0, 0.05);
  // No sample beyond 6 sigma (probability 2e-9 per sample).
  EXPECT_LT(max_m, 6 * sigma_m);
  EXPECT_LT(max_c, 6 * sigma_c);
  EXPECT_EQ(run->sink.CountEvents(rocklab::event2_t::DISAGREE), 0);

  // theta_dot: the centred Savitzky-Golay derivative of A sin(w t) is
  // A G cos(w t), G = sum_k w_k sin(w k dt); its noise is sigma_m * ||w||.
  SavitzkyGolay sg(rig.HalfWindow(rig.theta_dot), rig.theta_dot.order, 1e-3);
  const Eigen::VectorXd w1 = sg.CentreWeights(1);
  const int m = sg.delay_samples();
  double gain = 0;
  for (int k = -m; k <= m; ++k) gain += w1(k + m) * std::sin(2 * kPi * k * 1e-3);
  const double bias = 0.05 * std::abs(2 * kPi - gain);
  const double noise_dot = sigma_m * w1.norm();
  for (size_t i = m; i + m < run->sink.block.size(); ++i) {
    const BlockState& s = run->sink.block[i];
    EXPECT_LT(std::abs(s.theta_dot - ThetaDot(s.time_s)), bias + 6 * noise_dot) << s.time_s;
  }
}

TEST(Reconstruction, InvalidLedSamplesAreLeftOutAndCounted) {
  const RigConfig rig = LabRig();
  SimulatorNoise noise;
  noise.occlusion = 0.2;
  auto frames = test::SimulateFrames(rig, noise, 3, 2.0, Motion);
  // Saturate one LED coordinate (its rail, 4096 px) and put text-NaN in another.
  frames[100].values[2] = 4096.0;    // low_L1_x
  frames[200].values[9] = -1.0;      // high_H2_z, below its range
  int64_t invalid = 0;
  for (const Frame& f : frames) {
    for (int led = 0; led < 4; ++led) {
      const double x = f.values[2 + 2 * led], z = f.values[3 + 2 * led];
      invalid += !(x > 0 && x < 4096 && z > 0 && z < 4096);
    }
  }
  ASSERT_GT(invalid, 1000);  // 20 % of 4 x 2001
  const auto run = Process(rig, frames);
  EXPECT_EQ(run->recon.invalid_led_samples, invalid);
  int64_t no_camera = 0;
  for (const BlockState& s : run->sink.block) {
    if (s.leds_used >= 2) {
      // Noise-free: the remaining LEDs still give the exact angle.
      EXPECT_NEAR(s.theta_camera, Motion(s.time_s).theta, 1e-12);
    } else {
      ++no_camera;
      EXPECT_TRUE(std::isnan(s.theta_camera));
      EXPECT_TRUE(s.flags & kFlagNoCamera);
      EXPECT_TRUE(std::isfinite(s.theta));  // the mirror still gives theta
    }
  }
  EXPECT_EQ(run->recon.no_camera_frames, no_camera);
  EXPECT_EQ(run->sink.block[100].leds_used, 4 - run->sink.block[100].leds_invalid);
}

// A fault injected at t_fault: the flag must rise at the first sample at or
// after t_fault (within 10 ms), never before, and its event be sent.
void ExpectFlaggedWithin10ms(const std::function<void(TrueMotion&)>& fault, double t_fault,
                             int32_t flag, int8_t event_kind) {
  const RigConfig rig = LabRig();
  const SimulatorNoise noise = SimulatorNoise::Typical();
  auto motion = [&](double t) {
    TrueMotion m = Motion(t);
    if (t >= t_fault) fault(m);
    return m;
  };
  const auto frames = test::SimulateFrames(rig, noise, 11, 4.0, motion);
  const auto run = Process(rig, frames);
  double first = -1;
  for (const BlockState& s : run->sink.block) {
    if ((s.flags & flag) && first < 0) first = s.time_s;
  }
  ASSERT_GE(first, t_fault);
  EXPECT_LE(first - t_fault, 0.010);
  ASSERT_EQ(run->sink.CountEvents(event_kind), 1);
  for (const auto& e : run->sink.events) {
    if (e.kind == event_kind) {
      EXPECT_NEAR(e.utime * 1e-6, first, 1e-9);
    }
  }

  // The same run without the fault (same seed): no flag, no check event.
  const auto clean = Process(rig, test::SimulateFrames(rig, noise, 11, 4.0, Motion));
  for (const BlockState& s : clean->sink.block) {
    ASSERT_EQ(s.flags & ~(kFlagNoCamera | kFlagNoMirror), 0) << s.time_s;
  }
  for (const auto& e : clean->sink.events) EXPECT_EQ(e.kind, int8_t{rocklab::event2_t::GAP});
}

TEST(Checks, SlipOf3mmIsFlaggedWithin10ms) {
  ExpectFlaggedWithin10ms([](TrueMotion& m) { m.slip_m = 0.003; }, 2.0037, kFlagSliding,
                          rocklab::event2_t::SLIDING);
}

TEST(Checks, TwistIsFlaggedWithin10ms) {
  ExpectFlaggedWithin10ms([](TrueMotion& m) { m.twist_rad = 0.03; }, 1.5021, kFlagTwist,
                          rocklab::event2_t::TWIST);
}

TEST(Checks, JumpIsFlaggedWithin10ms) {
  ExpectFlaggedWithin10ms([](TrueMotion& m) { m.lift_m = 0.003; }, 2.5, kFlagJump,
                          rocklab::event2_t::JUMP);
}

TEST(Checks, OutOfPlaneIsFlaggedWithin10ms) {
  ExpectFlaggedWithin10ms([](TrueMotion& m) { m.out_of_plane_m = 0.005; }, 3.25, kFlagOutOfPlane,
                          rocklab::event2_t::OUT_OF_PLANE);
}

TEST(Checks, MirrorCameraDisagreementIsFlaggedAndRecovers) {
  // The processing rig believes a 2.5 m lever while the rig has 2.0 m: the
  // mirror then reads theta_m = atan(0.8 tan 2 theta) / 2 ~ 0.8 theta, which
  // differs from the camera by more than 5 mrad when |theta| > ~25 mrad.
  RigConfig truth = LabRig();
  RigConfig wrong = truth;
  wrong.mirror.lever_m = 2.5;
  const auto frames = test::SimulateFrames(truth, {}, 5, 1.0, Motion);
  const auto run = Process(wrong, frames);
  int flagged = 0;
  for (const BlockState& s : run->sink.block) {
    const double expected = std::abs(0.5 * std::atan(0.8 * std::tan(2 * Motion(s.time_s).theta)) -
                                     Motion(s.time_s).theta) > 0.005;
    EXPECT_EQ((s.flags & kFlagDisagree) != 0, expected) << s.time_s;
    flagged += expected;
  }
  EXPECT_GT(flagged, 0);
  // Two excursions in one period (theta > 0 and < 0): two events, two recoveries.
  EXPECT_EQ(run->sink.CountEvents(rocklab::event2_t::DISAGREE), 2);
  EXPECT_EQ(run->sink.CountEvents(rocklab::event2_t::RECOVERED), 2);
}

TEST(TableMotion, DifferentiatedDisplacementMatchesTheExactAcceleration) {
  const RigConfig rig = LabRigWithoutAccelerometer();
  SimulatorNoise noise;
  noise.table_m = 2e-5;
  const auto frames = test::SimulateFrames(rig, noise, 9, 4.0, Motion);
  const auto run = Process(rig, frames);
  ASSERT_EQ(run->sink.table.size(), frames.size());
  // Bound: the centred filter turns U sin(w t) into U G sin(w t) with
  // G = sum_k w2_k cos(w k dt) (symmetric weights), while the truth is
  // -U w^2 sin(w t): the bias is at most U |G + w^2|. The noise is
  // sigma_u ||w2||; allow 6 sigma.
  SavitzkyGolay sg(rig.HalfWindow(rig.table), rig.table.order, 1e-3);
  const Eigen::VectorXd w2 = sg.CentreWeights(2);
  const int m = sg.delay_samples();
  const double w = 2 * kPi * 5.0;
  double g = 0;
  for (int k = -m; k <= m; ++k) g += w2(k + m) * std::cos(w * k * 1e-3);
  const double bound = 0.006 * std::abs(g + w * w) + 6 * noise.table_m * w2.norm();
  EXPECT_LT(bound, 0.05 * 0.006 * w * w);  // the bound itself is useful: < 5 % of the peak
  for (size_t i = m; i + m < run->sink.table.size(); ++i) {
    const TableState& t = run->sink.table[i];
    EXPECT_EQ(t.accel_source, int8_t{rocklab::table_state_t::ACCEL_DIFFERENTIATED});
    EXPECT_LT(std::abs(t.acceleration - Motion(t.time_s).table_acceleration), bound) << t.time_s;
  }
}

TEST(Sequence, DroppedSamplesAreCountedAsGapsNeverHidden) {
  const RigConfig rig = LabRig();
  SimulatorNoise noise;
  noise.drop = 0.01;
  const auto frames = test::SimulateFrames(rig, noise, 4, 5.0, Motion);
  // Oracle: samples missing between the first and the last received frame.
  const int64_t missing =
      frames.back().seq - frames.front().seq + 1 - static_cast<int64_t>(frames.size());
  ASSERT_GT(missing, 10);
  const auto run = Process(rig, frames);
  EXPECT_EQ(run->sequence.missing, missing);
  EXPECT_EQ(run->sink.CountEvents(rocklab::event2_t::GAP), run->sequence.gaps);
  EXPECT_EQ(run->sink.block.size(), frames.size());  // every received frame is reconstructed
  // The differentiator restarts after each gap: theta_dot stays close to the truth
  // everywhere (noise-free: only the filter's bias and the short-segment fits).
  for (const BlockState& s : run->sink.block) {
    if (std::isfinite(s.theta_dot)) {
      EXPECT_NEAR(s.theta_dot, ThetaDot(s.time_s), 0.01) << s.time_s;
    }
  }
}

}  // namespace
}  // namespace rocklab::daq

namespace rocklab::daq {
namespace {

// Oracle: the predicted noise of the pivot for the LEDs used,
// sigma_led sqrt(1/n + d^2/S) (S the LEDs' spread about their centroid, d
// the pivot's distance to it). Lab rig, theta >= 0 (pivot at x = +0.125):
// all four LEDs: 2e-4 sqrt(1/4 + (0.125^2 + 0.5^2) / 0.53) = 0.173 mm, 5
// sigma = 0.87 mm <= 1 mm: checked. The high pair only: 2e-4 sqrt(1/2 +
// (0.125^2 + 0.85^2) / 0.02) = 1.22 mm: sliding and jump unmeasured.
TEST(Checks, PivotTooNoisyForTheToleranceIsReportedUnmeasured) {
  const RigConfig rig = LabRig();
  auto frames = test::SimulateFrames(rig, {}, 1, 0.01, Motion);
  for (int col = 2; col < 6; ++col) frames[5].values[col] = std::nan("");  // hide L1, L2
  const auto run = Process(rig, frames);
  const BlockState& all = run->sink.block[4];
  const BlockState& high = run->sink.block[5];
  EXPECT_NEAR(all.sigma_pivot_m, 2e-4 * std::sqrt(0.25 + (0.125 * 0.125 + 0.25) / 0.53), 1e-12);
  EXPECT_TRUE(all.checked & kFlagSliding);
  EXPECT_NEAR(high.sigma_pivot_m, 2e-4 * std::sqrt(0.5 + (0.125 * 0.125 + 0.85 * 0.85) / 0.02), 1e-12);
  EXPECT_EQ(high.leds_used, 2);
  EXPECT_TRUE(std::isnan(high.sliding));
  EXPECT_TRUE(std::isnan(high.jump));
  EXPECT_FALSE(high.checked & (kFlagSliding | kFlagJump));
  EXPECT_TRUE(std::isfinite(high.theta_camera));  // the angle is still measured
  EXPECT_EQ(run->recon.imprecise_pivot_frames, 1);
}

// A long clean run with typical noise, occlusions and drops: no check flag
// and no check event in 60 s (60 000 samples; each check spans >= 5 sigma,
// false-alarm probability < 6e-7 per sample and check).
TEST(Checks, NoFalseFlagInAMinuteOfCleanRocking) {
  const RigConfig rig = LabRig();
  const auto frames = test::SimulateFrames(rig, SimulatorNoise::Typical(), 21, 60.0, Motion);
  const auto run = Process(rig, frames);
  constexpr int32_t kChecks = kFlagSliding | kFlagJump | kFlagTwist | kFlagOutOfPlane | kFlagDisagree;
  int flagged = 0;
  for (const BlockState& s : run->sink.block) flagged += (s.flags & kChecks) != 0;
  EXPECT_EQ(flagged, 0);
  for (const auto& e : run->sink.events) EXPECT_EQ(e.kind, int8_t{rocklab::event2_t::GAP});
}

}  // namespace
}  // namespace rocklab::daq
