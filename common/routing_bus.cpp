#include "common/routing_bus.h"

#include <regex>
#include <stdexcept>
#include <unordered_map>

namespace rocklab::common {

struct RoutingBus::Impl {
  std::regex pattern;
  std::unordered_map<std::string, bool> matches;  // channel -> routed (regex once per channel)
};

RoutingBus::RoutingBus(Bus& main, Bus& routed, const std::string& channel_regex)
    : Bus(SharesCountersWith{main}), main_(main), routed_(routed), impl_(std::make_unique<Impl>()) {
  try {
    impl_->pattern = std::regex(channel_regex);
  } catch (const std::regex_error& err) {
    throw std::invalid_argument("bad channel regex '" + channel_regex + "': " + err.what());
  }
}

RoutingBus::~RoutingBus() = default;

bool RoutingBus::Publish(const std::string& channel, const void* data, int size) {
  auto it = impl_->matches.find(channel);
  if (it == impl_->matches.end()) {
    it = impl_->matches.emplace(channel, std::regex_match(channel, impl_->pattern)).first;
  }
  return (it->second ? routed_ : main_).Publish(channel, data, size);
}

Subscription RoutingBus::SubscribeRaw(const std::string& channel_regex, RawHandler handler,
                                      int queue_capacity) {
  return main_.SubscribeRaw(channel_regex, std::move(handler), queue_capacity);
}

int RoutingBus::HandleTimeout(int timeout_ms) { return main_.HandleTimeout(timeout_ms); }

}  // namespace rocklab::common
