// The model node: variants stepped with the table samples, started from the
// measured state, reset when the table time goes back, published over memq.
#include "model/model_node.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "model/excitation.h"
#include "rocklab/event_t.hpp"

namespace rocklab::model {
namespace {

constexpr BlockParams kBlock1{0.235, 3.884, 0.937};  // Table 2, block 1

rocklab::table_state_t Table(std::int64_t utime, double accel) {
  rocklab::table_state_t m{};
  m.utime = utime;
  m.acceleration = accel;
  return m;
}

rocklab::block_state_t Theta(std::int64_t utime, double theta) {
  rocklab::block_state_t m{};
  m.utime = utime;
  m.theta = theta;
  return m;
}

ModelNodeConfig Config(const std::string& variant) {
  ModelNodeConfig c;
  c.variants.push_back(ParseVariant(variant, kBlock1));
  return c;
}

// Oracle: the same library run directly. Free rocking from the measured
// theta0 = 0.1 rad at the first RL_THETA: the node's theta at every table
// sample equals a model reset to 0.1 rad and advanced to the same times
// (same calls, same arithmetic: equal to 1e-12 rad).
TEST(ModelNode, FreeRockingFromTheMeasuredStartMatchesTheLibrary) {
  ModelNode node(Config("h:housner:theoretical"), nullptr);
  const std::int64_t t0 = 1'700'000'000'000'000;  // an epoch utime: model time counts from it
  node.HandleTheta(Theta(t0, 0.1));
  auto direct = RockingModel::Create(ModelKind::kHousner, kBlock1);
  direct->Reset(0.0, 0.1, 0.0);
  SampledAcceleration none({0.0, 10.0}, {0.0, 0.0});
  for (int k = 0; k <= 2000; ++k) {  // 4 s at 500 Hz
    node.HandleTable(Table(t0 + 2000 * k, 0.0));
    direct->AdvanceTo(k / 500.0, none);
    ASSERT_NEAR(node.latest(0).theta, direct->state().theta, 1e-12) << "sample " << k;
  }
  EXPECT_GT(node.latest(0).impact_count, 3);
  EXPECT_EQ(node.latest(0).name, "h");
  EXPECT_EQ(node.latest(0).model, "housner");
  EXPECT_EQ(node.skipped_before_start(), 0);
}

// Oracle: ERRATA item 6 through the node. A measured |theta| below the rest
// threshold (sensor noise) starts the block at rest; a table acceleration
// above g tan(alpha) = 2.35 m/s^2 lifts it towards theta < 0 (ERRATA item 5);
// table samples before the first RL_THETA are skipped and counted.
TEST(ModelNode, StartsAtRestBelowTheThresholdAndLiftsWithTheTable) {
  ModelNode node(Config("c:complex:theoretical"), nullptr);
  node.HandleTable(Table(0, 0.0));  // before any RL_THETA
  node.HandleTheta(Theta(1000, 5e-4));
  for (int k = 1; k <= 500; ++k) node.HandleTable(Table(1000 * k, k < 100 ? 0.0 : 3.0));
  EXPECT_EQ(node.skipped_before_start(), 1);
  EXPECT_LT(node.latest(0).theta, -1e-3);
  EXPECT_EQ(node.latest(0).regime, +rocklab::model_state_t::REGIME_ROCKING);
}

// Oracle: the DAQ's own timing: it sends each RL_THETA 45 samples before the
// RL_TABLE of the same sample (its differentiators' half windows, 5 and 50
// ms at 1 kHz). The node must still start at the first table sample, from
// the RL_THETA of that sample, not skip the record.
TEST(ModelNode, StartsWhenThetaRunsAheadOfTheTable) {
  ModelNode node(Config("h:housner:theoretical"), nullptr);
  auto direct = RockingModel::Create(ModelKind::kHousner, kBlock1);
  direct->Reset(0.0, 0.1, 0.0);
  SampledAcceleration none({0.0, 10.0}, {0.0, 0.0});
  for (int k = 0; k < 45; ++k) node.HandleTheta(Theta(1000 * k, k == 0 ? 0.1 : 0.5));
  for (int k = 0; k < 1000; ++k) {
    node.HandleTheta(Theta(1000 * (k + 45), 0.5));  // ahead: must not be the start
    node.HandleTable(Table(1000 * k, 0.0));
    direct->AdvanceTo(static_cast<double>(1000 * k) * 1e-6, none);  // the node's arithmetic
    ASSERT_NEAR(node.latest(0).theta, direct->state().theta, 1e-12) << "sample " << k;
  }
  EXPECT_EQ(node.skipped_before_start(), 0);
}

// Oracle: the node's reset rule: table time going back restarts the
// variants from the next RL_THETA, so a replayed record gives the same
// states the second time.
TEST(ModelNode, TimeGoingBackResetsAndReplaysIdentically) {
  ModelNode node(Config("h:housner:alpha=0.235,p=3.884,mu=0.937"), nullptr);
  std::vector<double> first, second;
  for (int pass = 0; pass < 2; ++pass) {
    node.HandleTheta(Theta(0, 0.12));
    for (int k = 0; k < 1000; ++k) {
      node.HandleTable(Table(2000 * k, 0.0));
      (pass == 0 ? first : second).push_back(node.latest(0).theta);
    }
  }
  EXPECT_EQ(node.resets(), 1);
  EXPECT_EQ(first, second);
}

struct Tap {
  void OnModel(const lcm::ReceiveBuffer*, const std::string& channel,
               const rocklab::model_state_t*) {
    channels.push_back(channel);
  }
  void OnEvent(const lcm::ReceiveBuffer*, const std::string&, const rocklab::event_t* m) {
    if (m->kind == rocklab::event_t::IMPACT) ++impacts;
  }
  std::vector<std::string> channels;
  int impacts{};
};

// Oracle: the channel contract RL_MODEL_<name>, one message per table
// sample per variant, and an RL_EVENT per impact the model counts.
TEST(ModelNode, PublishesEveryVariantAndItsImpacts) {
  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  Tap tap;
  lcm.subscribe("RL_MODEL_.*", &Tap::OnModel, &tap);
  lcm.subscribe("RL_EVENT", &Tap::OnEvent, &tap);
  ModelNodeConfig cfg = Config("fit:housner:alpha=0.235,p=3.884,mu=0.937");
  cfg.variants.push_back(ParseVariant("theory:complex:theoretical", BlockParams{0.242, 3.780, 0.914}));
  ModelNode node(cfg, &lcm);
  node.HandleTheta(Theta(0, 0.1));
  for (int k = 0; k < 1000; ++k) {
    node.HandleTable(Table(2000 * k, 0.0));
    while (lcm.handleTimeout(0) > 0) {
    }
  }
  ASSERT_EQ(tap.channels.size(), 2000u);
  EXPECT_EQ(tap.channels[0], "RL_MODEL_fit");
  EXPECT_EQ(tap.channels[1], "RL_MODEL_theory");
  EXPECT_EQ(tap.impacts, node.latest(0).impact_count + node.latest(1).impact_count);
  EXPECT_GT(tap.impacts, 0);
}

// Oracle: the documented syntax NAME:MODEL:PARAMS and its errors.
TEST(ModelNode, VariantSyntax) {
  const VariantSpec a = ParseVariant("a:complex:alpha=0.2,p=4,mu=0.9,l=1e-4", std::nullopt);
  EXPECT_EQ(a.kind, ModelKind::kComplex);
  EXPECT_EQ(a.params.alpha, 0.2);
  EXPECT_EQ(a.options.l, 1e-4);
  const std::string json = "model_node_test_params.json";
  std::ofstream(json) << R"({"alpha": 0.311, "p": 4.633, "mu": 0.926, "alpha_stderr": 0.001})";
  const VariantSpec b = ParseVariant("b:housner:" + json, std::nullopt);
  EXPECT_EQ(b.params.p, 4.633);
  EXPECT_EQ(b.params_source, json);

  auto fails_naming = [](const std::string& text, const std::string& word) {
    try {
      ParseVariant(text, std::nullopt);
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
      return;
    }
    ADD_FAILURE() << text << " did not throw";
  };
  fails_naming("a:housner", "NAME:MODEL:PARAMS");
  fails_naming("a:newmark:alpha=0.2,p=4,mu=0.9", "MODEL");
  fails_naming("a:housner:theoretical", "rig");
  fails_naming("a:housner:alpha=0.2,p=4", "alpha, p and mu");
  fails_naming("a:housner:alpha=0.2,p=4,mu=1.5", "mu");
  fails_naming("a:housner:alpha=0.2,p=x,mu=0.9", "p");
  fails_naming("a:housner:alpha=0.2,p=4,mu=0.9,q=1", "'q'");
  fails_naming("a b:housner:alpha=0.2,p=4,mu=0.9", "NAME");
  fails_naming("a:housner:missing.json", "missing.json");
  ModelNodeConfig twice = Config("x:housner:theoretical");
  twice.variants.push_back(twice.variants[0]);
  EXPECT_THROW(ModelNode(twice, nullptr), std::invalid_argument);
}

}  // namespace
}  // namespace rocklab::model
