#pragma once
/// @file
/// A bus decorator (common/bus.h) that writes every published message to an
/// LCM log before publishing it: `rocklab run --log`.

#include <string>

#include "common/bus.h"

namespace rocklab::common {

class LogWriter;

/// Writes each published message to `log` (stamp: the message's utime, the
/// int64 after the 8-byte fingerprint every rocklab type starts with; the
/// writer keeps stamps non-decreasing), then publishes it on `inner`.
/// Subscriptions, HandleTimeout and the counters are `inner`'s. Both are
/// not owned and must outlive the decorator.
class LogWritingBus final : public Bus {
 public:
  LogWritingBus(Bus& inner, LogWriter& log);

  using Bus::Publish;
  bool Publish(const std::string& channel, const void* data, int size) override;
  Subscription SubscribeRaw(const std::string& channel_regex, RawHandler handler,
                            int queue_capacity = kDefaultQueue) override;
  int HandleTimeout(int timeout_ms) override;

 private:
  Bus& inner_;      // not owned
  LogWriter& log_;  // not owned
};

}  // namespace rocklab::common
