#pragma once
/// @file
/// An LCM instance behind the Bus interface (common/bus.h): udpm:// between
/// processes, memq:// inside one. PIMPL: no LCM header here.

#include <memory>
#include <string>

#include "common/bus.h"

namespace rocklab::common {

class LcmBus final : public Bus {
 public:
  /// @param url LCM URL; empty: LCM_DEFAULT_URL or LCM's own default.
  /// @throws std::runtime_error naming the URL when LCM does not open it.
  explicit LcmBus(const std::string& url);
  ~LcmBus() override;

  using Bus::Publish;
  bool Publish(const std::string& channel, const void* data, int size) override;
  Subscription SubscribeRaw(const std::string& channel_regex, RawHandler handler,
                            int queue_capacity = kDefaultQueue) override;
  int HandleTimeout(int timeout_ms) override;

 private:
  void Unsubscribe(int id) override;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rocklab::common
