#pragma once
/// @file
/// The in-process bus of `rocklab run` (common/bus.h): synchronous, no
/// queue, no copy through memq; a typed message goes to the typed
/// subscriptions of its type as the object itself (bus.h, "Passing by
/// value"), and is encoded only when a subscription wants its bytes.

#include <memory>
#include <string>
#include <vector>

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
  /// To the matching subscriptions in order: those that take the message's
  /// type (their own, or an older one they convert: bus.h) get the object
  /// when it PassesAsValue, the others its bytes (encoded once, only when
  /// one of them matches). A message nobody subscribes to is not encoded
  /// when it PassesAsValue (its encoding cannot fail).
  bool PublishValue(const std::string& channel, const MessageRef& msg) override;
  Subscription SubscribeRaw(const std::string& channel_regex, RawHandler handler,
                            int queue_capacity = kDefaultQueue) override;
  /// Nothing is ever queued: sleeps `timeout_ms` (a node's idle loop) and returns 0.
  int HandleTimeout(int timeout_ms) override;

 private:
  Subscription SubscribeRawOrValue(const std::string& channel_regex, RawHandler raw,
                                   std::vector<TypedValueHandler> values, int queue_capacity) override;
  void Unsubscribe(int id) override;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rocklab::common
