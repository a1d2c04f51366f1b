// The comparator node on an in-process bus: alignment by utime whichever side comes
// first, RL_COMPARE_<name> at the configured sample-clock rate, stale and
// recovered events, the summary.
#include "compare/compare_node.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "rocklab/comparison_t.hpp"
#include "rocklab/event_t.hpp"
#include "tests/tools/lcm_messages.h"

namespace rocklab::compare {
namespace {

using test::Model;
using test::Theta;

// What the node publishes, as received on the bus.
struct Tap {
  void Listen(common::Bus& bus) {
    bus.Subscribe<rocklab::comparison_t>(
        "RL_COMPARE_.*", [this](const std::string& channel, const rocklab::comparison_t& m) {
          channels.push_back(channel);
          compares.push_back(m);
        });
    bus.Subscribe<rocklab::event_t>(
        "RL_EVENT", [this](const std::string&, const rocklab::event_t& m) { events.push_back(m); });
  }
  std::vector<std::string> channels;
  std::vector<rocklab::comparison_t> compares;
  std::vector<rocklab::event_t> events;
};

// Oracle: a model that is the measurement plus 0.01 rad has RMS 0.01 rad
// whatever order the two arrive in; at 1 kHz samples and a 20 Hz publish
// rate, one RL_COMPARE per 50 samples (sample clock, not host time).
TEST(CompareNode, AlignsEitherOrderAndPublishesAtTheSampleClockRate) {
  common::DirectBus bus;
  Tap tap;
  tap.Listen(bus);
  CompareNodeConfig cfg;
  cfg.publish_rate_hz = 20.0;
  CompareNode node(cfg, bus);
  for (int k = 0; k < 1000; ++k) {
    const std::int64_t utime = 1000 * k;
    const double th = 0.05 * std::sin(0.01 * k);
    if (k % 2 == 0) {  // measured first
      node.HandleTheta(Theta(utime, th));
      node.HandleModel(Model("a", utime, th + 0.01));
    } else {           // model first
      node.HandleModel(Model("a", utime, th + 0.01));
      node.HandleTheta(Theta(utime, th));
    }
  }
  node.Finish();
  const auto summary = node.Summary();
  ASSERT_EQ(summary.size(), 1u);
  EXPECT_EQ(summary[0].metrics.samples, 1000);
  EXPECT_NEAR(summary[0].metrics.rms_total, 0.01, 1e-12);
  EXPECT_EQ(summary[0].unmatched_model, 0);
  EXPECT_EQ(summary[0].unmatched_measured, 0);
  // utime 0, 50 ms, ..., 950 ms: 20 messages; Finish adds the last sample's.
  ASSERT_EQ(tap.compares.size(), 21u);
  EXPECT_EQ(tap.channels[0], "RL_COMPARE_a");
  EXPECT_EQ(tap.compares[1].utime, 50000);
  EXPECT_EQ(tap.compares.back().utime, 999000);
  EXPECT_NEAR(tap.compares.back().rms_total, 0.01, 1e-12);
}

// Oracle: the DAQ's sliding flag marks pairs invalid; they leave the RMS
// untouched and RL_COMPARE says valid = false while it lasts.
TEST(CompareNode, SlidingFlagMakesPairsInvalid) {
  common::DirectBus bus;
  Tap tap;
  tap.Listen(bus);
  CompareNodeConfig cfg;
  cfg.publish_rate_hz = 1000.0;
  CompareNode node(cfg, bus);
  for (int k = 0; k < 100; ++k) {
    const bool sliding = k >= 40 && k < 60;
    node.HandleTheta(Theta(1000 * k, 0.0, sliding ? rocklab::block_state_t::FLAG_SLIDING : 0));
    node.HandleModel(Model("a", 1000 * k, sliding ? 1.0 : 0.0));
  }
  EXPECT_EQ(node.Summary()[0].metrics.rms_total, 0.0);
  EXPECT_EQ(node.Summary()[0].metrics.valid_samples, 80);
  ASSERT_EQ(tap.compares.size(), 100u);
  EXPECT_FALSE(tap.compares[50].valid);
  EXPECT_TRUE(tap.compares[70].valid);
}

// Oracle: model samples whose measured sample never comes, and measured
// samples before a model starts, are counted, never silently lost.
TEST(CompareNode, UnmatchedSamplesAreCounted) {
  common::DirectBus bus;
  CompareNode node(CompareNodeConfig{}, bus);
  for (int k = 0; k < 10; ++k) node.HandleTheta(Theta(1000 * k, 0.0));      // before the model
  for (int k = 10; k < 20; ++k) {
    if (k != 15) node.HandleTheta(Theta(1000 * k, 0.0));                     // 15 lost by the DAQ
    node.HandleModel(Model("a", 1000 * k, 0.0));
  }
  node.HandleTheta(Theta(5000, 0.0));  // out of order: dropped and counted
  const auto s = node.Summary()[0];
  EXPECT_EQ(s.metrics.samples, 9);
  EXPECT_EQ(s.unmatched_model, 1);
  EXPECT_EQ(s.unmatched_measured, 10);
}

// Oracle: the node's own rule: no input for stale_after_s of host time
// gives one STALE event; input again gives RECOVERED. Margins are wide
// (stale after 50 ms, checked after 300 ms) so a loaded machine cannot flip it.
TEST(CompareNode, StaleAndRecoveredEvents) {
  common::DirectBus bus;
  Tap tap;
  tap.Listen(bus);
  CompareNodeConfig cfg;
  cfg.stale_after_s = 0.05;
  CompareNode node(cfg, bus);
  node.HandleTheta(Theta(0, 0.0));
  node.HandleModel(Model("m", 0, 0.0));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  node.CheckStale();
  node.CheckStale();  // once only
  ASSERT_EQ(tap.events.size(), 2u);  // daq and model m
  EXPECT_EQ(tap.events[0].kind, +rocklab::event_t::STALE);  // + : LCM constants have no definition to bind a reference to
  EXPECT_EQ(tap.events[0].source, "daq");
  EXPECT_EQ(tap.events[1].source, "m");
  node.HandleTheta(Theta(1000, 0.0));
  node.HandleModel(Model("m", 1000, 0.0));
  ASSERT_EQ(tap.events.size(), 4u);
  EXPECT_EQ(tap.events[2].kind, +rocklab::event_t::RECOVERED);
  EXPECT_EQ(tap.events[3].kind, +rocklab::event_t::RECOVERED);
}

// Oracle: the documented JSON keys, with the values the comparator holds.
TEST(CompareNode, SummaryJsonNamesItsQuantities) {
  common::DirectBus bus;
  CompareNode node(CompareNodeConfig{}, bus);
  for (int k = 0; k < 10; ++k) {
    node.HandleTheta(Theta(1000 * k, 0.1));
    node.HandleModel(Model("fit", 1000 * k, 0.12));
  }
  const std::string path = "compare_summary_test.json";
  CompareNode::WriteSummaryJson(node.Summary(), path);
  std::ifstream in(path);
  const auto j = nlohmann::json::parse(in);
  const auto& v = j.at("variants").at(0);
  EXPECT_EQ(v.at("name"), "fit");
  EXPECT_NEAR(v.at("rms").get<double>(), 0.02, 1e-12);
  EXPECT_NEAR(v.at("nrms").get<double>(), 0.2, 1e-12);
  EXPECT_EQ(v.at("alpha").get<double>(), 0.235);
  EXPECT_EQ(j.at("units").at("rms"), "rad");
}

}  // namespace
}  // namespace rocklab::compare

namespace rocklab::compare {
namespace {

// Oracle: issue 10 point 1. A log written before model_state2_t carries
// model_state_t on RL_MODEL_*: the node still compares it (told apart by the
// fingerprint), exactly as the new type: a model 0.02 rad above the
// measurement has RMS 0.02 rad over the 10 pairs, with nothing dropped.
TEST(CompareNode, ComparesTheOldModelStateTypeAsTheNew) {
  common::LcmBus bus("memq://");
  CompareNode node(CompareNodeConfig{}, bus);
  for (int k = 0; k < 10; ++k) {
    bus.Publish("RL_THETA", test::Theta(1000 * k, 0.1));
    bus.Publish("RL_MODEL_old", test::OldModel("old", 1000 * k, 0.12));
    bus.Publish("RL_MODEL_new", test::Model("new", 1000 * k, 0.12));
    while (bus.HandleTimeout(0) > 0) {
    }
  }
  const std::vector<VariantSummary> summary = node.Summary();
  ASSERT_EQ(summary.size(), 2u);
  for (const VariantSummary& s : summary) {
    EXPECT_EQ(s.metrics.samples, 10) << s.name;
    EXPECT_NEAR(s.metrics.rms_total, 0.02, 1e-12) << s.name;
    EXPECT_EQ(s.alpha, 0.235) << s.name;
  }
  EXPECT_EQ(bus.decode_error_count(), 0);
}

}  // namespace
}  // namespace rocklab::compare
