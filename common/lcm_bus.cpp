#include "common/lcm_bus.h"

#include <map>
#include <stdexcept>

#include <lcm/lcm-cpp.hpp>

namespace rocklab::common {

struct LcmBus::Impl {
  struct Entry {
    LcmBus* bus{};
    RawHandler handler;
    lcm::Subscription* subscription{};
    void OnMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
      bus->Dispatch(handler, channel, rbuf->data, static_cast<int>(rbuf->data_size));
    }
  };
  explicit Impl(const std::string& url) : lcm(url) {}
  lcm::LCM lcm;
  std::map<int, std::unique_ptr<Entry>> entries;
  int next_id{1};
};

LcmBus::LcmBus(const std::string& url) : impl_(std::make_unique<Impl>(url)) {
  if (!impl_->lcm.good()) {
    throw std::runtime_error("cannot open LCM at '" + (url.empty() ? std::string("(default)") : url) + "'");
  }
}

LcmBus::~LcmBus() {
  for (auto& [id, entry] : impl_->entries) impl_->lcm.unsubscribe(entry->subscription);
}

bool LcmBus::Publish(const std::string& channel, const void* data, int size) {
  return size >= 0 && impl_->lcm.publish(channel, data, static_cast<unsigned>(size)) == 0;
}

Subscription LcmBus::SubscribeRaw(const std::string& channel_regex, RawHandler handler,
                                  int queue_capacity) {
  auto entry = std::make_unique<Impl::Entry>();
  entry->bus = this;
  entry->handler = std::move(handler);
  entry->subscription = impl_->lcm.subscribe(channel_regex, &Impl::Entry::OnMessage, entry.get());
  if (entry->subscription == nullptr) {
    throw std::invalid_argument("cannot subscribe to '" + channel_regex + "'");
  }
  entry->subscription->setQueueCapacity(queue_capacity);
  const int id = impl_->next_id++;
  impl_->entries.emplace(id, std::move(entry));
  return MakeSubscription(id);
}

void LcmBus::Unsubscribe(int id) {
  auto it = impl_->entries.find(id);
  if (it == impl_->entries.end()) return;
  impl_->lcm.unsubscribe(it->second->subscription);
  impl_->entries.erase(it);
}

int LcmBus::HandleTimeout(int timeout_ms) { return impl_->lcm.handleTimeout(timeout_ms); }

}  // namespace rocklab::common
