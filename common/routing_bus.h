#pragma once
/// @file
/// A bus decorator (common/bus.h) that sends the channels matching a regex
/// to a second bus: RL_RAW on its own udpm group (common/bus_urls.h).

#include <memory>
#include <string>

#include "common/bus.h"

namespace rocklab::common {

/// Publishes each message whose channel matches `channel_regex` (whole name)
/// on `routed`, every other on `main`: the raw frames' publishers (the DAQ
/// stage, replay) send RL_RAW to its own group this way. A publisher's bus:
/// subscriptions, HandleTimeout and the counters are `main`'s. Whether a
/// channel matches is decided once per channel name (a lookup per message,
/// no allocation after a channel's first message). Both buses are not
/// owned and must outlive it.
class RoutingBus final : public Bus {
 public:
  /// @throws std::invalid_argument for a bad regex.
  RoutingBus(Bus& main, Bus& routed, const std::string& channel_regex);
  ~RoutingBus() override;

  using Bus::Publish;
  bool Publish(const std::string& channel, const void* data, int size) override;
  Subscription SubscribeRaw(const std::string& channel_regex, RawHandler handler,
                            int queue_capacity = kDefaultQueue) override;
  int HandleTimeout(int timeout_ms) override;

 private:
  struct Impl;
  Bus& main_;    // not owned
  Bus& routed_;  // not owned
  std::unique_ptr<Impl> impl_;
};

}  // namespace rocklab::common
