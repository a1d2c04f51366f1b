// The comparator node with an assembly: model_state4_t on RL_MODEL_<name>
// paired with block_state2_t on RL_BODIES (RL_COMPAREBODIES_<name>,
// comparison3_t, the summary's "bodies"), and a single block's output
// unchanged whichever model-state type carries it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/direct_bus.h"
#include "compare/compare_node.h"
#include "rocklab/block_state2_t.hpp"
#include "rocklab/comparison2_t.hpp"
#include "tests/compare/printed_summary.h"
#include "rocklab/comparison3_t.hpp"
#include "rocklab/model_state4_t.hpp"
#include "tests/tools/lcm_messages.h"

namespace rocklab::compare {
namespace {

// RL_BODIES as the DAQ publishes it: per-body angles, flags 0.
rocklab::block_state2_t Bodies(std::int64_t utime, const std::vector<double>& theta) {
  rocklab::block_state2_t m{};
  m.utime = utime;
  m.seq = utime / 1000;
  m.nbodies = static_cast<std::int32_t>(theta.size());
  const std::vector<double> zero(theta.size(), 0.0);
  m.theta = theta;
  m.theta_dot = m.theta_mirror = m.theta_camera = m.sliding = m.jump = m.twist = m.out_of_plane = zero;
  m.leds_used.assign(theta.size(), 4);
  m.flags.assign(theta.size(), 0);
  return m;
}

// An assembly variant's state: per-body angles and its mode.
rocklab::model_state4_t Assembly(const std::string& name, std::int64_t utime,
                                 const std::vector<double>& theta, const std::string& mode) {
  rocklab::model_state4_t m{};
  m.utime = utime;
  m.seq = utime / 1000;
  m.name = name;
  m.model = "housner";
  m.nbodies = static_cast<std::int32_t>(theta.size());
  const std::vector<double> zero(theta.size(), 0.0);
  m.theta = theta;
  m.theta_dot = m.chi = m.psi = zero;
  const std::int8_t rocking = rocklab::model_state4_t::REGIME_ROCKING;  // by value: no definition to bind to
  m.regime.assign(theta.size(), rocking);
  m.alpha.assign(theta.size(), 0.235);
  m.p.assign(theta.size(), 3.884);
  m.mu.assign(theta.size(), 0.937);
  m.equations = rocklab::model_state4_t::EQUATIONS_HOUSNER;
  m.mode = mode;
  return m;
}

// Oracle: a two-body model offset from the measurement by 1e-3 rad on the
// lower body and -2e-3 rad on the upper has those RMS errors per body (the
// lower one also on RL_COMPARE_<name>, paired with RL_THETA); the model
// says "RC" (rocking as one) for 1 s while the measured upper block rocks
// as one for 0.6 s and then 0.01 rad beyond the lower one ("RR"): the modes
// agree 0.6 of the time. At 20 Hz of the sample clock over 1000 samples of
// 1 kHz: 20 RL_COMPAREBODIES messages, and Finish's last. Either side may
// come first.
TEST(CompareNodeBodies, ComparesEveryBodyAndTheMode) {
  common::DirectBus bus;
  std::vector<rocklab::comparison3_t> bodies_out;
  std::vector<std::string> bodies_channels;
  std::vector<rocklab::comparison2_t> single_out;
  auto s1 = bus.Subscribe<rocklab::comparison3_t>(
      "RL_COMPAREBODIES_.*", [&](const std::string& channel, const rocklab::comparison3_t& m) {
        bodies_channels.push_back(channel);
        bodies_out.push_back(m);
      });
  auto s2 = bus.Subscribe<rocklab::comparison2_t>(
      "RL_COMPARE_.*", [&](const std::string&, const rocklab::comparison2_t& m) { single_out.push_back(m); });
  CompareNodeConfig cfg;
  cfg.publish_rate_hz = 20.0;
  CompareNode node(cfg, bus);
  for (int i = 0; i < 1000; ++i) {
    const std::int64_t utime = 1000 * i;
    const double lower = 0.01 + 0.005 * std::sin(1e-2 * i);
    const double upper = i < 600 ? lower : lower + 0.01;
    const auto model = Assembly("statue", utime, {lower + 1e-3, upper - 2e-3}, "RC");
    if (i % 2 == 1) bus.Publish("RL_MODEL_statue", model);
    bus.Publish("RL_THETA", test::Theta(utime, lower));
    bus.Publish("RL_BODIES", Bodies(utime, {lower, upper}));
    if (i % 2 == 0) bus.Publish("RL_MODEL_statue", model);
  }
  node.Finish();
  EXPECT_EQ(bus.decode_error_count(), 0);
  const auto summary = node.Summary();
  ASSERT_EQ(summary.size(), 1u);
  const VariantSummary& s = summary[0];
  // The bottom body as a single block (RL_THETA).
  EXPECT_EQ(s.metrics.samples, 1000);
  EXPECT_NEAR(s.metrics.rms_total, 1e-3, 1e-15);
  ASSERT_EQ(s.bodies.size(), 2u);
  EXPECT_NEAR(s.bodies[0].rms_total, 1e-3, 1e-15);
  EXPECT_NEAR(s.bodies[1].rms_total, 2e-3, 1e-15);
  EXPECT_EQ(s.bodies[1].samples, 1000);
  EXPECT_EQ(s.mode.samples, 1000);
  EXPECT_EQ(s.mode.fraction(), 0.6);
  EXPECT_EQ(s.bodies_unmatched_model, 0);
  EXPECT_EQ(s.bodies_unmatched_measured, 0);

  ASSERT_EQ(bodies_out.size(), 21u);
  EXPECT_EQ(bodies_channels[0], "RL_COMPAREBODIES_statue");
  const rocklab::comparison3_t& last = bodies_out.back();
  EXPECT_EQ(last.utime, 999000);
  EXPECT_EQ(last.seq, 20);
  ASSERT_EQ(last.nbodies, 2);
  EXPECT_NEAR(last.rms_total[1], 2e-3, 1e-15);
  EXPECT_NEAR(last.error[1], -2e-3, 1e-15);
  EXPECT_TRUE(last.valid[0] && last.valid[1]);
  EXPECT_EQ(last.mode_model, "RC");
  EXPECT_EQ(last.mode_measured, "RR");
  EXPECT_EQ(last.mode_agreement, 0.6);
  EXPECT_EQ(last.mode_samples, 1000);
  EXPECT_EQ(last.mode_rest_rad, cfg.mode_rest_rad);
  EXPECT_EQ(single_out.size(), 21u);  // RL_COMPARE_statue: the bottom body

  const auto v = nlohmann::json::parse(CompareNode::SummaryJsonText(summary, {})).at("variants").at(0);
  EXPECT_EQ(v.at("mode_agreement").get<double>(), 0.6);
  EXPECT_EQ(v.at("mode_samples").get<int>(), 1000);
  ASSERT_EQ(v.at("bodies").size(), 2u);
  EXPECT_EQ(v.at("bodies").at(1).at("body").get<int>(), 1);
  EXPECT_EQ(v.at("bodies").at(1).at("number").get<int>(), 2);  // theta_2 in the CSVs (docs/compare.md)
  EXPECT_NEAR(v.at("bodies").at(1).at("rms").get<double>(), 2e-3, 1e-15);

  const std::string table = test::PrintedSummary(summary);
  ASSERT_FALSE(table.empty());
  EXPECT_NE(table.find("statue               body 1"), std::string::npos) << table;
  EXPECT_NE(table.find("statue: modes agree 60.00000 % of 1000 samples"), std::string::npos) << table;
}

// Oracle: the contract. A single block sent as model_state4_t (nbodies 1)
// is the model_state3_t it carries: the same RL_COMPARE messages, the same
// summary document, no "bodies" key, nothing on RL_COMPAREBODIES_*.
TEST(CompareNodeBodies, ASingleBlockIsUnchangedWhicheverTypeCarriesIt) {
  std::vector<std::string> documents;
  std::vector<std::vector<rocklab::comparison2_t>> published(2);
  for (int as_bodies = 0; as_bodies < 2; ++as_bodies) {
    common::DirectBus bus;
    int bodies_messages = 0;
    auto s1 = bus.Subscribe<rocklab::comparison2_t>(
        "RL_COMPARE_.*", [&](const std::string&, const rocklab::comparison2_t& m) { published[as_bodies].push_back(m); });
    auto s2 = bus.Subscribe<rocklab::comparison3_t>(
        "RL_COMPAREBODIES_.*", [&](const std::string&, const rocklab::comparison3_t&) { ++bodies_messages; });
    CompareNode node(CompareNodeConfig{}, bus);
    for (int i = 0; i < 300; ++i) {
      const double th = 0.02 * std::sin(2 * M_PI * 3.0 * i * 1e-3);
      bus.Publish("RL_THETA", test::Theta(1000 * i, th));
      const double model = 0.021 * std::sin(2 * M_PI * 3.0 * (i - 4) * 1e-3);
      if (as_bodies) {
        auto m = Assembly("a", 1000 * i, {model}, "");
        bus.Publish("RL_MODEL_a", m);
      } else {
        bus.Publish("RL_MODEL_a", test::Model("a", 1000 * i, model));
      }
    }
    node.Finish();
    EXPECT_EQ(bodies_messages, 0);
    EXPECT_EQ(bus.decode_error_count(), 0);
    documents.push_back(CompareNode::SummaryJsonText(node.Summary(), {}));
  }
  EXPECT_EQ(documents[0], documents[1]);
  EXPECT_EQ(documents[0].find("bodies"), std::string::npos);
  EXPECT_EQ(documents[0].find("mode_"), std::string::npos);
  ASSERT_EQ(published[0].size(), published[1].size());
  for (std::size_t i = 0; i < published[0].size(); ++i) {
    rocklab::comparison2_t a = published[0][i], b = published[1][i];
    std::vector<std::uint8_t> ea(static_cast<std::size_t>(a.getEncodedSize())), eb(static_cast<std::size_t>(b.getEncodedSize()));
    a.encode(ea.data(), 0, static_cast<int>(ea.size()));
    b.encode(eb.data(), 0, static_cast<int>(eb.size()));
    EXPECT_EQ(ea, eb) << i;
  }
}

// A model state of another number of bodies than the measurement is not
// paired: counted, never compared body against the wrong body.
TEST(CompareNodeBodies, AnotherNumberOfBodiesIsCountedNotPaired) {
  common::DirectBus bus;
  CompareNode node(CompareNodeConfig{}, bus);
  for (int i = 0; i < 10; ++i) {
    bus.Publish("RL_THETA", test::Theta(1000 * i, 0.0));
    bus.Publish("RL_BODIES", Bodies(1000 * i, {0.0, 0.0, 0.0}));
    bus.Publish("RL_MODEL_b", Assembly("b", 1000 * i, {0.0, 0.0}, "CC"));
  }
  const auto s = node.Summary().at(0);
  ASSERT_EQ(s.bodies.size(), 2u);
  EXPECT_EQ(s.bodies[0].samples, 0);
  EXPECT_EQ(s.bodies_unmatched_model, 10);
  EXPECT_EQ(s.bodies_unmatched_measured, 10);
  EXPECT_TRUE(std::isnan(s.mode.fraction()));
  // Arrays of another length than nbodies (a caller's message, not a
  // decoded one): dropped whole, nothing read past them.
  auto short_model = Assembly("b", 20000, {0.0, 0.0}, "CC");
  short_model.theta.resize(1);
  node.HandleModelBodies(short_model);
  auto short_bodies = Bodies(20000, {0.0, 0.0});
  short_bodies.nbodies = 5;
  node.HandleBodies(short_bodies);
  EXPECT_EQ(node.Summary().at(0).metrics.samples, 10);
}

}  // namespace
}  // namespace rocklab::compare
