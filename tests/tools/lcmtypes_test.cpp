// The generated LCM types: every rocklab type survives a publish/subscribe
// round trip over memq:// unchanged (oracle: the values published).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "rocklab/block_state_t.hpp"
#include "rocklab/comparison_t.hpp"
#include "rocklab/daq_config_t.hpp"
#include "rocklab/event_t.hpp"
#include "rocklab/health_t.hpp"
#include "common/model_state.h"
#include "rocklab/model_state2_t.hpp"
#include "rocklab/model_state3_t.hpp"
#include "rocklab/model_state_t.hpp"
#include "rocklab/raw_frame_t.hpp"
#include "rocklab/table_state_t.hpp"

namespace rocklab::test {
namespace {

template <typename T>
class Catcher {
 public:
  void Handle(const lcm::ReceiveBuffer*, const std::string& channel, const T* msg) {
    channel_ = channel;
    last_ = *msg;
    ++count_;
  }
  std::string channel_;
  T last_{};
  int count_{};
};

template <typename T>
T RoundTrip(lcm::LCM& lcm, const std::string& channel, const T& msg) {
  Catcher<T> catcher;
  lcm::Subscription* sub = lcm.subscribe(channel, &Catcher<T>::Handle, &catcher);
  EXPECT_EQ(lcm.publish(channel, &msg), 0);
  EXPECT_GT(lcm.handleTimeout(1000), 0);
  lcm.unsubscribe(sub);
  EXPECT_EQ(catcher.count_, 1);
  EXPECT_EQ(catcher.channel_, channel);
  return catcher.last_;
}

TEST(LcmTypes, RawFrameAndConfigRoundTripOverMemq) {
  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());

  rocklab::raw_frame_t raw;
  raw.utime = 1234567;
  raw.seq = 42;
  raw.values = {0.1, -2.5, std::numeric_limits<double>::quiet_NaN()};
  raw.num_channels = static_cast<int32_t>(raw.values.size());
  const auto raw_back = RoundTrip(lcm, "RL_RAW", raw);
  EXPECT_EQ(raw_back.utime, raw.utime);
  EXPECT_EQ(raw_back.seq, raw.seq);
  ASSERT_EQ(raw_back.num_channels, 3);
  EXPECT_EQ(raw_back.values[1], -2.5);
  EXPECT_TRUE(std::isnan(raw_back.values[2]));

  rocklab::daq_config_t cfg;
  cfg.utime = 1;
  cfg.rig_name = "rig";
  cfg.sample_rate_hz = 500;
  cfg.channel_names = {"mirror_x", "led1_x"};
  cfg.channel_units = {"m", "m"};
  cfg.channel_sensors = {"mirror_x", "led1_x"};
  cfg.gain = {1.0, 0.001};
  cfg.offset = {0.0, -0.5};
  cfg.num_channels = 2;
  cfg.alpha = 0.235;
  const auto cfg_back = RoundTrip(lcm, "RL_DAQ_CONFIG", cfg);
  EXPECT_EQ(cfg_back.channel_names, cfg.channel_names);
  EXPECT_EQ(cfg_back.gain, cfg.gain);
  EXPECT_EQ(cfg_back.alpha, 0.235);
}

TEST(LcmTypes, StateEventAndHealthRoundTripOverMemq) {
  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());

  rocklab::block_state_t theta{};
  theta.utime = 10;
  theta.theta = 0.01;
  theta.flags = rocklab::block_state_t::FLAG_SLIDING | rocklab::block_state_t::FLAG_TWIST;
  EXPECT_EQ(RoundTrip(lcm, "RL_THETA", theta).flags, 5);

  rocklab::model_state_t model{};
  model.name = "housner_fit";
  model.model = "housner";
  model.regime = rocklab::model_state_t::REGIME_ROCKING;
  model.impact_count = 3;
  const auto model_back = RoundTrip(lcm, "RL_MODEL_housner_fit", model);
  EXPECT_EQ(model_back.name, "housner_fit");
  EXPECT_EQ(model_back.impact_count, 3);

  rocklab::model_state2_t model2{};
  model2.name = "complex_fit";
  model2.model = "complex";
  model2.regime = rocklab::model_state2_t::REGIME_ROCKING;
  model2.equations = rocklab::model_state2_t::EQUATIONS_EQ10;
  model2.l = 0.5;
  const auto model2_back = RoundTrip(lcm, "RL_MODEL_complex_fit", model2);
  EXPECT_EQ(model2_back.equations, +rocklab::model_state2_t::EQUATIONS_EQ10);
  EXPECT_EQ(model2_back.l, 0.5);

  rocklab::table_state_t table{};
  table.acceleration = -3.25;
  table.accel_source = rocklab::table_state_t::ACCEL_DIFFERENTIATED;
  EXPECT_EQ(RoundTrip(lcm, "RL_TABLE", table).acceleration, -3.25);

  rocklab::comparison_t cmp{};
  cmp.valid = true;
  cmp.nrms = 0.05;
  EXPECT_TRUE(RoundTrip(lcm, "RL_COMPARE_housner_fit", cmp).valid);

  rocklab::event_t ev{};
  ev.kind = rocklab::event_t::IMPACT;
  ev.source = "model";
  ev.detail = "impact 1";
  EXPECT_EQ(RoundTrip(lcm, "RL_EVENT", ev).kind, +rocklab::event_t::IMPACT);  // + : no ODR-use of the constant

  rocklab::health_t health{};
  health.node = "daq";
  health.state = "running";
  health.gaps = 2;
  EXPECT_EQ(RoundTrip(lcm, "RL_HEALTH", health).gaps, 2);
}

// lcm-gen's decoder (lcm_coretypes.h) writes doubles through int64_t
// pointers. Oracle: the encoded values. Without -fno-strict-aliasing on
// rocklab::lcmtypes, GCC -O2 returns the zeros of a message value-initialised
// just before decode() in a loop like this one (seen with the report's
// RL_TABLE peaks).
double PeakAcceleration(const std::vector<std::vector<std::uint8_t>>& payloads) {
  double peak = 0.0;
  for (const auto& b : payloads) {
    rocklab::table_state_t m{};
    if (m.decode(b.data(), 0, static_cast<int>(b.size())) < 0) return -1.0;
    peak = std::fmax(peak, std::fabs(m.acceleration));
  }
  return peak;
}

TEST(LcmTypes, DecodeIntoAFreshlyInitialisedMessageReadsItsDoubles) {
  std::vector<std::vector<std::uint8_t>> payloads;
  for (int i = 0; i < 4; ++i) {
    rocklab::table_state_t sent{};
    sent.utime = 1000 * i;
    sent.seq = i;
    sent.acceleration = 0.5 * i;  // peak 1.5
    payloads.emplace_back(static_cast<std::size_t>(sent.getEncodedSize()));
    const int size = static_cast<int>(payloads.back().size());
    ASSERT_EQ(sent.encode(payloads.back().data(), 0, size), size);
  }
  EXPECT_EQ(PeakAcceleration(payloads), 1.5);
}

}  // namespace
}  // namespace rocklab::test

namespace rocklab::test {
namespace {

template <class Msg>
std::vector<std::uint8_t> Bytes(const Msg& m) {
  std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

// Oracle: LCM's fingerprints. RL_MODEL_* carries any of three types: all are read
// by common::DecodeModelState into the same fields (model_state_t's values
// copied, equations unknown); a new type is a new fingerprint, so the two
// can never be mistaken for each other.
TEST(LcmTypes, RlModelCarriesEitherModelStateTypeByFingerprint) {
  EXPECT_NE(rocklab::model_state_t::getHash(), rocklab::model_state2_t::getHash());
  rocklab::model_state_t old{};
  old.utime = 42;
  old.name = "h";
  old.model = "housner";
  old.theta = 0.05;
  old.theta_dot = -0.2;
  old.impact_count = 2;
  old.regime = rocklab::model_state_t::REGIME_ROCKING;
  old.alpha = 0.235;
  old.p = 3.884;
  old.mu = 0.937;
  rocklab::model_state2_t out{};
  rocklab::model_state_t scratch{};
  const auto b_old = Bytes(old);
  ASSERT_EQ(common::DecodeModelState(b_old.data(), static_cast<int>(b_old.size()), out, scratch),
            nullptr);
  EXPECT_EQ(out.utime, 42);
  EXPECT_EQ(out.name, "h");
  EXPECT_EQ(out.theta, 0.05);
  EXPECT_EQ(out.theta_dot, -0.2);
  EXPECT_EQ(out.impact_count, 2);
  EXPECT_EQ(out.mu, 0.937);
  EXPECT_EQ(out.equations, +rocklab::model_state2_t::EQUATIONS_UNKNOWN);

  rocklab::model_state2_t now{};
  now.utime = 43;
  now.name = "c";
  now.equations = rocklab::model_state2_t::EQUATIONS_LIMIT;
  const auto b_new = Bytes(now);
  ASSERT_EQ(common::DecodeModelState(b_new.data(), static_cast<int>(b_new.size()), out, scratch),
            nullptr);
  EXPECT_EQ(out.utime, 43);
  EXPECT_EQ(out.name, "c");
  EXPECT_EQ(out.equations, +rocklab::model_state2_t::EQUATIONS_LIMIT);

  // What the model node publishes now: every field but seq.
  rocklab::model_state3_t v3{};
  v3.utime = 44;
  v3.seq = 7;
  v3.name = "c3";
  v3.model = "complex";
  v3.theta = -0.01;
  v3.theta_dot = 0.3;
  v3.chi = 0.25;
  v3.psi = 1.5;
  v3.energy = 0.125;
  v3.impact_count = 5;
  v3.regime = rocklab::model_state3_t::REGIME_ROCKING;
  v3.alpha = 0.25;
  v3.p = 2.5;
  v3.mu = 0.5;
  v3.l = 0.75;
  v3.equations = rocklab::model_state3_t::EQUATIONS_EQ10;
  const auto b_v3 = Bytes(v3);
  ASSERT_EQ(common::DecodeModelState(b_v3.data(), static_cast<int>(b_v3.size()), out, scratch),
            nullptr);
  EXPECT_EQ(out.utime, 44);
  EXPECT_EQ(out.name, "c3");
  EXPECT_EQ(out.model, "complex");
  EXPECT_EQ(out.theta, -0.01);
  EXPECT_EQ(out.theta_dot, 0.3);
  EXPECT_EQ(out.chi, 0.25);
  EXPECT_EQ(out.psi, 1.5);
  EXPECT_EQ(out.energy, 0.125);
  EXPECT_EQ(out.impact_count, 5);
  EXPECT_EQ(out.regime, +rocklab::model_state2_t::REGIME_ROCKING);
  EXPECT_EQ(out.alpha, 0.25);
  EXPECT_EQ(out.p, 2.5);
  EXPECT_EQ(out.mu, 0.5);
  EXPECT_EQ(out.l, 0.75);
  EXPECT_EQ(out.equations, +rocklab::model_state2_t::EQUATIONS_EQ10);

  // Another type on the channel is refused, with the reason.
  rocklab::event_t ev{};
  const auto b_ev = Bytes(ev);
  EXPECT_NE(common::DecodeModelState(b_ev.data(), static_cast<int>(b_ev.size()), out, scratch),
            nullptr);
}

}  // namespace
}  // namespace rocklab::test
