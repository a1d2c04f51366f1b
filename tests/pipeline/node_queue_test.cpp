// The model and compare nodes over udpm:// keep what arrives while they are
// busy. LCM 1.3.1 queues 30 messages per subscription by default and drops
// the rest silently (its receive thread discards what no subscription has
// room for): 30 ms of a 1 kHz stream, one scheduling hiccup of a loaded
// machine. Each test holds the node's thread inside a handler while a burst
// of 1000 messages arrives, then lets it run. Oracle: the node's own input
// counter equals the burst. Private network namespace per test
// (tests/tools/udpm_netns.h).
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include "common/bus.h"
#include "common/lcm_bus.h"
#include "compare/compare_node.h"
#include "model/model_node.h"
#include "rocklab/block_state_t.hpp"
#include "rocklab/health2_t.hpp"
#include "rocklab/table_state_t.hpp"
#include "tests/pipeline/node_inputs.h"
#include "tests/skip.h"
#include "tests/tools/udpm_netns.h"

namespace rocklab::pipeline {
namespace {

constexpr int kQueueBurst = 1000;

// Subscribed on the node's own LCM instance, so its handlers run on the
// node's thread. On the node's first RL_HEALTH (sent right after it
// subscribed) it publishes the burst from another instance and holds the
// node's thread until a third instance has received the whole burst (by
// then the node's socket has it too, and LCM's receive thread queues it);
// then either a TEST_DONE marker, which the node dispatches after everything
// queued before it, stops the node, or (kStopWhileQueued) the stop flag is
// raised at once, as a SIGTERM would, with the whole burst still queued.
enum class QueueStopBy { kMarker, kStopWhileQueued };

class Burst {
 public:
  Burst(common::Bus& node_bus, std::string channel,
        std::function<void(lcm::LCM&, int)> publish_one, QueueStopBy stop_by = QueueStopBy::kMarker)
      : channel_(std::move(channel)), publish_one_(std::move(publish_one)), stop_by_(stop_by) {
    subscriptions_.push_back(
        node_bus.SubscribeRaw("RL_HEALTH", [this](const std::string&, const void*, int) { OnHealth(); }));
    subscriptions_.push_back(
        node_bus.SubscribeRaw("TEST_DONE", [this](const std::string&, const void*, int) { stop_ = true; }));
    lcm::Subscription* s = probe_.subscribe(channel_, &Burst::OnProbe, this);
    s->setQueueCapacity(kQueueBurst + 100);
  }
  const std::atomic<bool>& stop() const { return stop_; }
  int probed() const { return probed_; }

 private:
  void OnHealth() {
    if (sent_) return;
    sent_ = true;
    for (int k = 0; k < kQueueBurst; ++k) {
      publish_one_(publisher_, k);
      // 16 messages a millisecond, as the DAQ spreads its bursts: the test
      // is about LCM's queue, not about the kernel's socket buffers.
      if (k % 16 == 15) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (probed_ < kQueueBurst && std::chrono::steady_clock::now() < deadline) probe_.handleTimeout(50);
    if (stop_by_ == QueueStopBy::kStopWhileQueued) {
      stop_ = true;
      return;
    }
    publisher_.publish("TEST_DONE", "done", 4);
  }
  void OnProbe(const lcm::ReceiveBuffer*, const std::string&) { ++probed_; }

  std::string channel_;
  std::function<void(lcm::LCM&, int)> publish_one_;
  QueueStopBy stop_by_;
  lcm::LCM publisher_{test::kUdpmUrl};
  lcm::LCM probe_{std::string(test::kUdpmUrl) + "&recv_buf_size=4194304"};
  bool sent_{};
  int probed_{};
  std::atomic<bool> stop_{false};
  std::vector<common::Subscription> subscriptions_;  // last: end before the fields their handlers use
};

using test::OneHousnerVariant;

// Sample k of a 1 kHz stream on `channel` (tests/pipeline/node_inputs.h).
template <class Msg>
void PublishSample(lcm::LCM& out, const std::string& channel, int k) {
  const Msg msg = test::Sample<Msg>(k);
  out.publish(channel, &msg);
}

// The model node's burst: one RL_THETA at rest, then 1 kHz table samples of
// zero acceleration.
void PublishRestThenTableOverLcm(lcm::LCM& out, int k) {
  if (k == 0) PublishSample<rocklab::block_state_t>(out, "RL_THETA", 0);
  PublishSample<rocklab::table_state_t>(out, "RL_TABLE", k);
}

// A private network namespace and the node's LCM, with a socket buffer for
// the whole burst (the host's rmem_max).
class NodeQueue : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string why = test::EnterPrivateNetwork();
    if (!why.empty()) ROCKLAB_SKIP(why);
    bus_ = std::make_unique<common::LcmBus>(std::string(test::kUdpmUrl) + "&recv_buf_size=4194304");
  }
  std::unique_ptr<common::LcmBus> bus_;
};

TEST_F(NodeQueue, ModelNodeHandlesABurstOfTableSamplesThatArrivedWhileItWasBusy) {
  model::ModelNode node(OneHousnerVariant(), *bus_);
  Burst burst(*bus_, "RL_TABLE", &PublishRestThenTableOverLcm);
  node.Run(burst.stop());
  EXPECT_EQ(burst.probed(), kQueueBurst);
  EXPECT_EQ(node.table_count(), kQueueBurst);
  EXPECT_EQ(node.failures(), 0);
}

TEST_F(NodeQueue, CompareNodeHandlesABurstOfThetaSamplesThatArrivedWhileItWasBusy) {
  compare::CompareNode node(compare::CompareNodeConfig{}, *bus_);
  Burst burst(*bus_, "RL_THETA", [](lcm::LCM& out, int k) {
    PublishSample<rocklab::block_state_t>(out, "RL_THETA", k);
  });
  node.Run(burst.stop());
  EXPECT_EQ(burst.probed(), kQueueBurst);
  EXPECT_EQ(node.theta_count(), kQueueBurst);
}

// A stop (SIGINT/SIGTERM) while input is queued: what arrived before it is
// still handled, so the final health and summary cover it. Oracle: the
// node's input counter equals the burst.
TEST_F(NodeQueue, ModelNodeStoppedWithABurstQueuedHandlesItBeforeFinishing) {
  model::ModelNode node(OneHousnerVariant(), *bus_);
  Burst burst(
      *bus_, "RL_TABLE",
      &PublishRestThenTableOverLcm, QueueStopBy::kStopWhileQueued);
  node.Run(burst.stop());
  EXPECT_EQ(burst.probed(), kQueueBurst);
  EXPECT_EQ(node.table_count(), kQueueBurst);
}

TEST_F(NodeQueue, CompareNodeStoppedWithABurstQueuedComparesItBeforeFinishing) {
  compare::CompareNode node(compare::CompareNodeConfig{}, *bus_);
  Burst burst(
      *bus_, "RL_THETA",
      [](lcm::LCM& out, int k) { PublishSample<rocklab::block_state_t>(out, "RL_THETA", k); },
      QueueStopBy::kStopWhileQueued);
  node.Run(burst.stop());
  EXPECT_EQ(burst.probed(), kQueueBurst);
  EXPECT_EQ(node.theta_count(), kQueueBurst);
}

}  // namespace
}  // namespace rocklab::pipeline
