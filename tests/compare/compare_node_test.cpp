// The comparator node on an in-process bus: alignment by utime whichever side comes
// first, RL_COMPARE_<name> at the configured sample-clock rate, stale and
// recovered events, the summary.
#include "compare/compare_node.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <sstream>
#include <vector>
#include <thread>

#include <nlohmann/json.hpp>

#include "common/direct_bus.h"
#include "common/lcm_bus.h"
#include "rocklab/comparison2_t.hpp"
#include "tests/compare/printed_summary.h"
#include "rocklab/event2_t.hpp"
#include "rocklab/health2_t.hpp"
#include "tests/scratch.h"
#include "tests/tools/lcm_messages.h"

namespace rocklab::compare {
namespace {

using test::Model;
using test::Theta;

// What the node publishes, as received on the bus.
struct Tap {
  void Listen(common::Bus& bus) {
    subscriptions.push_back(bus.Subscribe<rocklab::comparison2_t>(
        "RL_COMPARE_.*", [this](const std::string& channel, const rocklab::comparison2_t& m) {
          channels.push_back(channel);
          compares.push_back(m);
        }));
    subscriptions.push_back(bus.Subscribe<rocklab::event2_t>(
        "RL_EVENT", [this](const std::string&, const rocklab::event2_t& m) { events.push_back(m); }));
  }
  std::vector<common::Subscription> subscriptions;
  std::vector<std::string> channels;
  std::vector<rocklab::comparison2_t> compares;
  std::vector<rocklab::event2_t> events;
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
  // lint: sleep-ok: a lower bound of host time past the 50 ms threshold (load only lengthens it)
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  node.CheckStale();
  node.CheckStale();  // once only
  ASSERT_EQ(tap.events.size(), 2u);  // daq and model m
  EXPECT_EQ(tap.events[0].kind, +rocklab::event2_t::STALE);  // + : LCM constants have no definition to bind a reference to
  EXPECT_EQ(tap.events[0].source, "daq");
  EXPECT_EQ(tap.events[1].source, "m");
  node.HandleTheta(Theta(1000, 0.0));
  node.HandleModel(Model("m", 1000, 0.0));
  ASSERT_EQ(tap.events.size(), 4u);
  EXPECT_EQ(tap.events[2].kind, +rocklab::event2_t::RECOVERED);
  EXPECT_EQ(tap.events[3].kind, +rocklab::event2_t::RECOVERED);
}

// Oracle: the documented JSON keys, with the values the comparator holds.
TEST(CompareNode, SummaryJsonNamesItsQuantities) {
  common::DirectBus bus;
  CompareNode node(CompareNodeConfig{}, bus);
  for (int k = 0; k < 10; ++k) {
    node.HandleTheta(Theta(1000 * k, 0.1));
    node.HandleModel(Model("fit", 1000 * k, 0.12));
  }
  const std::string path = test::ScratchDir("compare_summary") + "/summary.json";
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

// With no crossing matched, the summary printed timing
// and peak errors of 0, which reads as a perfect match. Oracle: constant
// signals have no zero crossing, so nothing is matched: the keys stay,
// their values are null; the table shows "-" and says why.
TEST(CompareNode, NoMatchedCrossingIsNullAndADashNotZero) {
  common::DirectBus bus;
  CompareNode node(CompareNodeConfig{}, bus);
  for (int k = 0; k < 10; ++k) {
    node.HandleTheta(Theta(1000 * k, 0.1));
    node.HandleModel(Model("fit", 1000 * k, 0.12));
  }
  const auto summary = node.Summary();
  ASSERT_EQ(summary.at(0).metrics.matched_crossings, 0);
  const std::string path = test::ScratchDir("compare_no_match") + "/summary.json";
  CompareNode::WriteSummaryJson(summary, path);
  std::ifstream in(path);
  const auto v = nlohmann::json::parse(in).at("variants").at(0);
  EXPECT_EQ(v.at("matched_crossings").get<int>(), 0);
  ASSERT_TRUE(v.contains("mean_abs_timing_error"));
  ASSERT_TRUE(v.contains("mean_abs_peak_error"));
  EXPECT_TRUE(v.at("mean_abs_timing_error").is_null()) << v.dump();
  EXPECT_TRUE(v.at("mean_abs_peak_error").is_null()) << v.dump();

  const std::string table = test::PrintedSummary(summary);
  ASSERT_FALSE(table.empty());
  // The row: ... corr, timing_s, peak_deg, valid%: the two as "-".
  const std::size_t row = table.find("\nfit ");
  ASSERT_NE(row, std::string::npos) << table;
  const std::string line = table.substr(row + 1, table.find('\n', row + 1) - row - 1);
  std::istringstream fields(line);
  std::vector<std::string> cells{std::istream_iterator<std::string>(fields), {}};
  ASSERT_EQ(cells.size(), 12u) << line;  // as the header's columns
  EXPECT_EQ(cells[9], "-") << line;      // timing_s
  EXPECT_EQ(cells[10], "-") << line;     // peak_deg
  EXPECT_NE(table.find("fit: no zero crossing matched"), std::string::npos) << table;
}

}  // namespace
}  // namespace rocklab::compare

namespace rocklab::compare {
namespace {

// Oracle: the channel contract (docs/channels.md). A log written before model_state3_t carries
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

namespace rocklab::compare {
namespace {

// What the node says in RL_HEALTH, as received.
struct HealthTap {
  void Listen(common::Bus& bus) {
    subscription = bus.Subscribe<rocklab::health2_t>(
        "RL_HEALTH", [this](const std::string&, const rocklab::health2_t& m) { last = m; });
  }
  common::Subscription subscription;
  rocklab::health2_t last{};
};

// Oracle: counting by hand. A 1 kHz feed over memq with RL_THETA seq 10,
// 11, 12 and 13 dropped (4 missing by seq), RL_MODEL_a's messages seq 30 and
// 31 dropped (2 missing by seq) and RL_MODEL_old's (model_state_t from an
// older log: no seq) at 40, 41 and 42 ms dropped (a 4 ms step of the sample
// clock: 3 missing samples): RL_HEALTH "stopped" says gaps = 9.
TEST(CompareNode, CountsSequenceGapsOfWhatItReadsInHealth) {
  common::LcmBus bus("memq://");
  HealthTap health;
  health.Listen(bus);
  CompareNode node(CompareNodeConfig{}, bus);
  for (int k = 0; k < 50; ++k) {
    rocklab::block_state_t theta = test::Theta(1000 * k, 0.01);
    theta.seq = k;
    if (k < 10 || k > 13) bus.Publish("RL_THETA", theta);
    rocklab::model_state3_t model = test::Model("a", 1000 * k, 0.01);
    model.seq = k;
    if (k != 30 && k != 31) bus.Publish("RL_MODEL_a", model);
    if (k < 40 || k > 42) bus.Publish("RL_MODEL_old", test::OldModel("old", 1000 * k, 0.01));
    while (bus.HandleTimeout(0) > 0) {
    }
  }
  node.Finish();
  while (bus.HandleTimeout(0) > 0) {
  }
  EXPECT_EQ(node.theta_gaps(), 4);
  EXPECT_EQ(node.model_gaps(), 2 + 3);
  EXPECT_EQ(health.last.state, "stopped");
  EXPECT_EQ(health.last.gaps, 9);
}

// Oracle: RL_THETA 0..99 with 30 and 31 lost, 10 sent after 60, 50 sent
// twice and one extra message numbered a million ahead: 2 missing (the
// rule of docs/channels.md "Loss and disorder"; the old count was 1 000 002
// and more).
TEST(CompareNode, HealthCountsLossNotDisorder) {
  common::LcmBus bus("memq://");
  HealthTap health;
  health.Listen(bus);
  CompareNode node(CompareNodeConfig{}, bus);
  std::vector<std::int64_t> order;
  for (std::int64_t k = 0; k < 100; ++k) {
    if (k == 30 || k == 31 || k == 10) continue;
    order.push_back(k);
    if (k == 50) order.push_back(50);
    if (k == 60) order.push_back(10);
    if (k == 70) order.push_back(70 + 1'000'000);
  }
  for (std::int64_t k : order) {
    rocklab::block_state_t theta = test::Theta(1000 * (k % 1000), 0.01);
    theta.seq = k;
    bus.Publish("RL_THETA", theta);
    while (bus.HandleTimeout(0) > 0) {
    }
  }
  node.Finish();
  while (bus.HandleTimeout(0) > 0) {
  }
  EXPECT_EQ(node.theta_gaps(), 2);
  EXPECT_EQ(health.last.gaps, 2);
}

// Publishes 1 kHz RL_THETA and RL_MODEL_m from `from` to `to` ms of sample
// clock on `bus` (a DirectBus: the node's handlers run as `rocklab run` runs them).
void FeedMs(common::Bus& bus, int from, int to) {
  for (int k = from; k < to; ++k) {
    rocklab::block_state_t theta = test::Theta(1000 * k, 0.0);
    theta.seq = k;
    bus.Publish("RL_THETA", theta);
    bus.Publish("RL_MODEL_m", test::Model("m", 1000 * k, 0.0));
  }
}

int StaleOrRecovered(const Tap& tap) {
  int n = 0;
  for (const rocklab::event2_t& e : tap.events) {
    n += e.kind == rocklab::event2_t::STALE || e.kind == rocklab::event2_t::RECOVERED;
  }
  return n;
}

// Oracle: offline (`run --max`) staleness follows the
// sample clock: a 300 ms host stall in the middle of a continuous 1 kHz
// feed (stale after 50 ms) makes no STALE or RECOVERED event; the same
// stall on the host clock (live) makes them (the control: the stall is
// seen). Margins as in StaleAndRecoveredEvents (6x the threshold).
TEST(CompareNode, SampleClockStalenessIgnoresAHostStall) {
  for (StaleClock clock : {StaleClock::kSample, StaleClock::kHost}) {
    common::DirectBus bus;
    Tap tap;
    tap.Listen(bus);
    CompareNodeConfig cfg;
    cfg.stale_after_s = 0.05;
    cfg.stale_clock = clock;
    CompareNode node(cfg, bus);
    FeedMs(bus, 0, 100);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the host stalls
    FeedMs(bus, 100, 200);
    if (clock == StaleClock::kSample) {
      EXPECT_EQ(StaleOrRecovered(tap), 0);
    } else {
      EXPECT_GE(StaleOrRecovered(tap), 2);
    }
  }
}

// Oracle: the sample-clock rule itself. RL_THETA stops while the model goes
// on for 200 ms of sample clock (stale after 50 ms): one STALE of "daq" once
// the model is 50 ms ahead, whatever the host clock did; RL_THETA again:
// RECOVERED.
TEST(CompareNode, SampleClockStalenessSeesASilentInputOnTheSampleClock) {
  common::DirectBus bus;
  Tap tap;
  tap.Listen(bus);
  CompareNodeConfig cfg;
  cfg.stale_after_s = 0.05;
  cfg.stale_clock = StaleClock::kSample;
  CompareNode node(cfg, bus);
  FeedMs(bus, 0, 10);
  for (int k = 10; k < 210; ++k) bus.Publish("RL_MODEL_m", test::Model("m", 1000 * k, 0.0));
  ASSERT_EQ(tap.events.size(), 1u);
  EXPECT_EQ(tap.events[0].kind, +rocklab::event2_t::STALE);
  EXPECT_EQ(tap.events[0].source, "daq");
  EXPECT_EQ(tap.events[0].utime, 60'000);  // 51 ms past the last RL_THETA at 9 ms
  FeedMs(bus, 210, 211);
  ASSERT_EQ(tap.events.size(), 2u);
  EXPECT_EQ(tap.events[1].kind, +rocklab::event2_t::RECOVERED);
}

}  // namespace
}  // namespace rocklab::compare
