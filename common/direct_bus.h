#pragma once
/// @file
/// The in-process bus of `rocklab run` (common/bus.h): synchronous, no
/// queue, no copy through memq.

#include <memory>
#include <string>

#include "common/bus.h"

namespace rocklab::common {

/// Publish runs every matching handler before it returns, in subscription
/// order. A handler may publish (nested dispatch) and may end
/// subscriptions (its own too).
class DirectBus final : public Bus {
 public:
  DirectBus();
  ~DirectBus() override;

  using Bus::Publish;
  bool Publish(const std::string& channel, const void* data, int size) override;
  Subscription SubscribeRaw(const std::string& channel_regex, RawHandler handler,
                            int queue_capacity = kDefaultQueue) override;
  /// Nothing is ever queued: sleeps `timeout_ms` (a node's idle loop) and returns 0.
  int HandleTimeout(int timeout_ms) override;

 private:
  void Unsubscribe(int id) override;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rocklab::common
