#include "common/log_writing_bus.h"

#include <cstdint>

#include "common/lcm_log.h"

namespace rocklab::common {

LogWritingBus::LogWritingBus(Bus& inner, LogWriter& log)
    : Bus(SharesCountersWith{inner}), inner_(inner), log_(log) {}

bool LogWritingBus::Publish(const std::string& channel, const void* data, int size) {
  const bool logged =
      size >= 0 && log_.Write(channel, data, static_cast<std::size_t>(size), PayloadUtime(data, size, INT64_MIN));
  const bool published = inner_.Publish(channel, data, size);
  return logged && published;
}

Subscription LogWritingBus::SubscribeRaw(const std::string& channel_regex, RawHandler handler,
                                         int queue_capacity) {
  return inner_.SubscribeRaw(channel_regex, std::move(handler), queue_capacity);
}

int LogWritingBus::HandleTimeout(int timeout_ms) { return inner_.HandleTimeout(timeout_ms); }

}  // namespace rocklab::common
