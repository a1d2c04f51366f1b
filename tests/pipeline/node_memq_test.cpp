// ModelNode::Run and CompareNode::Run over memq://, so that a run without a
// network namespace (no root) still tests the node loops: the loop handles
// what arrives, stops on a marker it dispatches after everything queued
// before it, and after a stop raised with input still queued dispatches that
// input before Finish (common::RunNodeLoop's drain). The udpm versions of
// these tests (node_queue_test.cpp) add LCM's receive thread and socket.
// Oracle: the node's own input counter and its final RL_HEALTH count_in
// equal the burst published; the final RL_HEALTH says "stopped".
#include <atomic>
#include <cstdint>
#include <functional>
#include <string>

#include <gtest/gtest.h>

#include "common/bus.h"
#include "common/lcm_bus.h"
#include "compare/compare_node.h"
#include "model/model_node.h"
#include "rocklab/block_state_t.hpp"
#include "rocklab/health2_t.hpp"
#include "rocklab/table_state_t.hpp"
#include "tests/pipeline/node_inputs.h"

namespace rocklab::pipeline {
namespace {

constexpr int kBurst = 1000;

enum class StopBy { kMarker, kStopWhileQueued };

// On the node's first RL_HEALTH (Run sends it before its loop) publishes
// the burst on the node's own memq bus, where it queues behind that health
// message; then a TEST_DONE marker (handled after the burst) raises the stop,
// or (kStopWhileQueued) the stop is raised at once, as a SIGTERM would.
class MemqBurst {
 public:
  MemqBurst(common::Bus& bus, std::function<void(common::Bus&, int)> publish_one, StopBy stop_by)
      : bus_(bus), publish_one_(std::move(publish_one)), stop_by_(stop_by) {
    subscriptions_.push_back(
        bus.Subscribe<rocklab::health2_t>("RL_HEALTH", [this](const std::string&, const rocklab::health2_t& h) {
          last_health_ = h;
          OnHealth();
        }));
    subscriptions_.push_back(
        bus.SubscribeRaw("TEST_DONE", [this](const std::string&, const void*, int) { stop_ = true; }));
  }
  const std::atomic<bool>& stop() const { return stop_; }
  const rocklab::health2_t& last_health() const { return last_health_; }

 private:
  void OnHealth() {
    if (sent_) return;
    sent_ = true;
    for (int k = 0; k < kBurst; ++k) publish_one_(bus_, k);
    if (stop_by_ == StopBy::kStopWhileQueued) {
      stop_ = true;
      return;
    }
    bus_.Publish("TEST_DONE", "done", 4);
  }

  common::Bus& bus_;  // not owned
  std::function<void(common::Bus&, int)> publish_one_;
  StopBy stop_by_;
  bool sent_{};
  rocklab::health2_t last_health_{};
  std::atomic<bool> stop_{false};
  std::vector<common::Subscription> subscriptions_;  // last: end before the fields their handlers use
};

using test::OneHousnerVariant;
using test::Sample;

// One RL_THETA at rest, then table samples of zero acceleration.
void PublishRestThenTable(common::Bus& out, int k) {
  if (k == 0) out.Publish("RL_THETA", Sample<rocklab::block_state_t>(0));
  out.Publish("RL_TABLE", Sample<rocklab::table_state_t>(k));
}

void PublishTheta(common::Bus& out, int k) { out.Publish("RL_THETA", Sample<rocklab::block_state_t>(k)); }

// What the node published last (its "stopped" RL_HEALTH is queued by Finish).
void DispatchTheRest(common::LcmBus& bus) {
  while (bus.HandleTimeout(0) > 0) {
  }
}

class NodeMemq : public ::testing::TestWithParam<StopBy> {};

TEST_P(NodeMemq, ModelNodeRunHandlesEveryTableSample) {
  common::LcmBus bus("memq://");
  model::ModelNode node(OneHousnerVariant(), bus);
  MemqBurst burst(bus, &PublishRestThenTable, GetParam());
  node.Run(burst.stop());
  DispatchTheRest(bus);
  EXPECT_EQ(node.table_count(), kBurst);
  EXPECT_EQ(node.failures(), 0);
  EXPECT_EQ(burst.last_health().node, "model");
  EXPECT_EQ(burst.last_health().state, "stopped");
  EXPECT_EQ(burst.last_health().count_in, kBurst);
  EXPECT_EQ(burst.last_health().gaps, 0);
}

TEST_P(NodeMemq, CompareNodeRunHandlesEveryThetaSample) {
  common::LcmBus bus("memq://");
  compare::CompareNode node(compare::CompareNodeConfig{}, bus);
  MemqBurst burst(bus, &PublishTheta, GetParam());
  node.Run(burst.stop());
  DispatchTheRest(bus);
  EXPECT_EQ(node.theta_count(), kBurst);
  EXPECT_EQ(burst.last_health().node, "compare");
  EXPECT_EQ(burst.last_health().state, "stopped");
  EXPECT_EQ(burst.last_health().count_in, kBurst);
  EXPECT_EQ(node.theta_gaps(), 0);
}

INSTANTIATE_TEST_SUITE_P(StopBy, NodeMemq, ::testing::Values(StopBy::kMarker, StopBy::kStopWhileQueued),
                         [](const ::testing::TestParamInfo<StopBy>& p) {
                           return p.param == StopBy::kMarker ? std::string("MarkerAfterTheBurst")
                                                             : std::string("StopWithTheBurstQueued");
                         });

}  // namespace
}  // namespace rocklab::pipeline
