// The model node: variants stepped with the table samples, started from the
// measured state, reset when the table time goes back, published over memq.
#include "model/model_node.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>

#include "common/bus.h"
#include "common/direct_bus.h"
#include "common/lcm_bus.h"
#include "model/excitation.h"
#include "rocklab/event2_t.hpp"
#include "rocklab/health2_t.hpp"
#include "tests/model/node_messages.h"
#include "tests/scratch.h"
#include "tests/paper_blocks.h"

namespace rocklab::model {
namespace {

using ::rocklab::test::kBlock1;  // tests/paper_blocks.h

using node_messages::Table;
using node_messages::Theta;

using common::DirectBus;

ModelNodeConfig Config(const std::string& variant) {
  ModelNodeConfig c;
  c.variants.push_back(ParseVariant(variant, kBlock1));
  return c;
}

// The library options the node steps its variants with (its integrator):
// "the same calls" include it.
ModelOptions NodeModelOptions() {
  ModelOptions o;
  o.integrator = ModelNodeConfig{}.integrator;
  return o;
}

// Oracle: the same library run directly. Free rocking from the measured
// theta0 = 0.1 rad at the first RL_THETA: the node's theta at every table
// sample equals a model reset to 0.1 rad and advanced to the same times
// (same calls, same arithmetic: equal to 1e-12 rad).
TEST(ModelNode, FreeRockingFromTheMeasuredStartMatchesTheLibrary) {
  DirectBus bus;
  ModelNode node(Config("h:housner:theoretical"), bus);
  const std::int64_t t0 = 1'700'000'000'000'000;  // an epoch utime: model time counts from it
  node.HandleTheta(Theta(t0, 0.1));
  auto direct = RockingModel::Create(ModelKind::kHousner, kBlock1, NodeModelOptions());
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

// Oracle: docs/errata.md item 6 through the node. A measured |theta| below the rest
// threshold (sensor noise) starts the block at rest; a table acceleration
// above g tan(alpha) = 2.35 m/s^2 lifts it towards theta < 0 (docs/errata.md item 5);
// table samples before the first RL_THETA are skipped and counted.
TEST(ModelNode, StartsAtRestBelowTheThresholdAndLiftsWithTheTable) {
  DirectBus bus;
  ModelNode node(Config("c:complex:theoretical"), bus);
  node.HandleTable(Table(0, 0.0));  // before any RL_THETA
  node.HandleTheta(Theta(1000, 5e-4));
  for (int k = 1; k <= 500; ++k) node.HandleTable(Table(1000 * k, k < 100 ? 0.0 : 3.0));
  EXPECT_EQ(node.skipped_before_start(), 1);
  EXPECT_LT(node.latest(0).theta, -1e-3);
  EXPECT_EQ(node.latest(0).regime, +rocklab::model_state3_t::REGIME_ROCKING);
}

// Oracle: the DAQ publishes the RL_THETA and RL_TABLE of a sample together,
// RL_THETA first: the node starts at the first table sample from the theta
// of that sample (0.1 rad), not from a later one, and matches the library
// reset to it.
TEST(ModelNode, StartsFromTheThetaPublishedWithTheTableSample) {
  DirectBus bus;
  ModelNode node(Config("h:housner:theoretical"), bus);
  auto direct = RockingModel::Create(ModelKind::kHousner, kBlock1, NodeModelOptions());
  direct->Reset(0.0, 0.1, 0.0);
  SampledAcceleration none({0.0, 10.0}, {0.0, 0.0});
  for (int k = 0; k < 1000; ++k) {
    node.HandleTheta(Theta(1000 * k, k == 0 ? 0.1 : 0.5));
    node.HandleTable(Table(1000 * k, 0.0));
    direct->AdvanceTo(static_cast<double>(1000 * k) * 1e-6, none);  // the node's arithmetic
    ASSERT_NEAR(node.latest(0).theta, direct->state().theta, 1e-12) << "sample " << k;
  }
  EXPECT_EQ(node.skipped_before_start(), 0);
}

// Oracle: a saturated table channel gives NaN accelerations: the node holds
// the last finite value, so its theta equals a library model fed that held
// value (same calls, 1e-12 rad); the variant goes on (no failure), the bad
// samples are counted, and one RL_EVENT BAD_SAMPLE opens the stretch and
// one RECOVERED closes it.
TEST(ModelNode, NonFiniteTableSampleHoldsTheLastValueAndTheVariantGoesOn) {
  DirectBus bus;
  std::vector<rocklab::event2_t> events;
  const common::Subscription sub1 = bus.Subscribe<rocklab::event2_t>("RL_EVENT", [&](const std::string&, const rocklab::event2_t& e) {
    if (e.source == "model") events.push_back(e);
  });
  ModelNode node(Config("h:housner:theoretical"), bus);
  auto direct = RockingModel::Create(ModelKind::kHousner, kBlock1, NodeModelOptions());
  direct->Reset(0.0, 0.0, 0.0);
  node.HandleTheta(Theta(0, 0.0));
  const double nan = std::nan("");
  for (int k = 0; k < 600; ++k) {
    // 3 m/s^2 (above g tan(alpha)) until sample 200, NaN from 200 to 299.
    const double sent = k < 200 ? 3.0 : (k < 300 ? nan : 0.0);
    const double used = k < 300 ? 3.0 : 0.0;
    node.HandleTable(Table(1000 * k, sent));
    direct->Step(static_cast<double>(1000 * k) * 1e-6, used);
    ASSERT_NEAR(node.latest(0).theta, direct->state().theta, 1e-12) << "sample " << k;
  }
  EXPECT_EQ(node.failures(), 0);
  EXPECT_EQ(node.bad_table_samples(), 100);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].kind, +rocklab::event2_t::BAD_SAMPLE);
  EXPECT_EQ(events[0].utime, 200'000);
  EXPECT_EQ(events[1].kind, +rocklab::event2_t::RECOVERED);
  EXPECT_EQ(events[1].utime, 300'000);
  EXPECT_NE(events[1].detail.find("100 bad samples"), std::string::npos) << events[1].detail;
}

// Oracle: the node's reset rule: table time going back restarts the
// variants from the next RL_THETA, so a replayed record gives the same
// states the second time.
TEST(ModelNode, TimeGoingBackResetsAndReplaysIdentically) {
  DirectBus bus;
  ModelNode node(Config("h:housner:alpha=0.235,p=3.884,mu=0.937"), bus);
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

// Oracle: the channel contract RL_MODEL_<name>, one message per table
// sample per variant, and an RL_EVENT per impact the model counts.
TEST(ModelNode, PublishesEveryVariantAndItsImpacts) {
  common::LcmBus bus("memq://");
  std::vector<std::string> channels;
  int impacts = 0;
  const common::Subscription sub2 = bus.Subscribe<rocklab::model_state3_t>(
      "RL_MODEL_.*", [&](const std::string& channel, const rocklab::model_state3_t&) {
        channels.push_back(channel);
      });
  const common::Subscription sub3 = bus.Subscribe<rocklab::event2_t>("RL_EVENT", [&](const std::string&, const rocklab::event2_t& m) {
    if (m.kind == rocklab::event2_t::IMPACT) ++impacts;
  });
  ModelNodeConfig cfg = Config("fit:housner:alpha=0.235,p=3.884,mu=0.937");
  cfg.variants.push_back(ParseVariant("theory:complex:theoretical", BlockParams{0.242, 3.780, 0.914}));
  ModelNode node(cfg, bus);
  node.HandleTheta(Theta(0, 0.1));
  for (int k = 0; k < 1000; ++k) {
    node.HandleTable(Table(2000 * k, 0.0));
    while (bus.HandleTimeout(0) > 0) {
    }
  }
  ASSERT_EQ(channels.size(), 2000u);
  EXPECT_EQ(channels[0], "RL_MODEL_fit");
  EXPECT_EQ(channels[1], "RL_MODEL_theory");
  EXPECT_EQ(impacts, node.latest(0).impact_count + node.latest(1).impact_count);
  EXPECT_GT(impacts, 0);
}

// Oracle: the documented syntax NAME:MODEL:PARAMS and its errors.
TEST(ModelNode, VariantSyntax) {
  const VariantSpec a = ParseVariant("a:complex:alpha=0.2,p=4,mu=0.9,l=1e-4", std::nullopt);
  EXPECT_EQ(a.kind, ModelKind::kComplex);
  EXPECT_EQ(a.params.alpha, 0.2);
  EXPECT_EQ(a.options.l, 1e-4);
  const std::string json = test::ScratchDir("model_node_test") + "/params.json";
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
  DirectBus bus;
  EXPECT_THROW(ModelNode(twice, bus), std::invalid_argument);
}

}  // namespace
}  // namespace rocklab::model

namespace rocklab::model {
namespace {

// Oracle: the channel contract (docs/channels.md). RL_MODEL_<name> carries
// model_state3_t and its `equations` says what produced the sample: the
// complex variant integrates eq. (10) while it rocks (EQUATIONS_EQ10), the
// Housner variant Housner's equations (EQUATIONS_HOUSNER), at every sample;
// the decoded message equals what latest() holds.
TEST(ModelNode, PublishesModelState2WithTheEquationsOfEachSample) {
  common::LcmBus bus("memq://");
  std::map<std::string, std::vector<rocklab::model_state3_t>> got;
  const common::Subscription sub4 = bus.Subscribe<rocklab::model_state3_t>(
      "RL_MODEL_.*", [&](const std::string& channel, const rocklab::model_state3_t& m) {
        got[channel].push_back(m);
      });
  ModelNodeConfig cfg = Config("h:housner:theoretical");
  cfg.variants.push_back(ParseVariant("c:complex:theoretical", kBlock1));
  ModelNode node(cfg, bus);
  node.HandleTheta(Theta(0, 0.1));
  for (int k = 0; k < 500; ++k) {  // 1 s of free rocking from 0.1 rad at 500 Hz
    node.HandleTable(Table(2000 * k, 0.0));
    while (bus.HandleTimeout(0) > 0) {
    }
  }
  ASSERT_EQ(got["RL_MODEL_h"].size(), 500u);
  ASSERT_EQ(got["RL_MODEL_c"].size(), 500u);
  int complex_rocking = 0;
  for (const rocklab::model_state3_t& m : got["RL_MODEL_h"]) {
    EXPECT_EQ(m.equations, +rocklab::model_state3_t::EQUATIONS_HOUSNER) << m.utime;
  }
  for (const rocklab::model_state3_t& m : got["RL_MODEL_c"]) {
    if (m.regime != rocklab::model_state3_t::REGIME_ROCKING) continue;
    ++complex_rocking;
    EXPECT_EQ(m.equations, +rocklab::model_state3_t::EQUATIONS_EQ10) << m.utime;
  }
  EXPECT_GT(complex_rocking, 400);  // 0.1 rad of a 0.235 rad block rocks for the whole second
  EXPECT_EQ(got["RL_MODEL_c"].back().equations, node.latest(1).equations);
  EXPECT_EQ(got["RL_MODEL_c"].back().model, "complex");
}

}  // namespace
}  // namespace rocklab::model

namespace rocklab::model {
namespace {

// Oracle: counting by hand. RL_TABLE over memq at 500 Hz
// with seq 100..104 and 300 dropped (6 samples missing by seq). RL_HEALTH "stopped" carries gaps = 6.
TEST(ModelNode, CountsRlTableSequenceGapsInHealth) {
  common::LcmBus bus("memq://");
  rocklab::health2_t last{};
  const common::Subscription sub5 = bus.Subscribe<rocklab::health2_t>("RL_HEALTH",
                                   [&](const std::string&, const rocklab::health2_t& m) { last = m; });
  ModelNode node(Config("h:housner:theoretical"), bus);
  bus.Publish("RL_THETA", Theta(0, 0.0));
  for (int k = 0; k < 500; ++k) {
    rocklab::table_state_t t = Table(2000 * k, 0.0);
    t.seq = k;
    if ((k < 100 || k > 104) && k != 300) bus.Publish("RL_TABLE", t);
    while (bus.HandleTimeout(0) > 0) {
    }
  }
  node.Finish();
  while (bus.HandleTimeout(0) > 0) {
  }
  EXPECT_EQ(node.table_gaps(), 6);
  EXPECT_EQ(last.state, "stopped");
  EXPECT_EQ(last.gaps, 6);
  EXPECT_EQ(last.count_in, 494);
}

}  // namespace
}  // namespace rocklab::model
