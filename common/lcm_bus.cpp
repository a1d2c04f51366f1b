#include "common/lcm_bus.h"

#include <map>
#include <stdexcept>
#include <vector>

#include <lcm/lcm-cpp.hpp>

namespace rocklab::common {

struct LcmBus::Impl {
  struct Entry {
    LcmBus* bus{};
    RawHandler handler;
    lcm::Subscription* subscription{};
    bool ended{};  // unsubscribed during a dispatch: removed once it returns
    void OnMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
      if (ended) return;
      Impl& impl = *bus->impl_;
      ++impl.dispatching;
      struct Leave {
        int& depth;
        ~Leave() { --depth; }
      } leave{impl.dispatching};
      bus->Dispatch(handler, channel, rbuf->data, static_cast<int>(rbuf->data_size));
    }
  };
  explicit Impl(const std::string& url) : lcm(url) {}
  void Remove(std::map<int, std::unique_ptr<Entry>>::iterator it) {
    lcm.unsubscribe(it->second->subscription);
    entries.erase(it);
  }
  lcm::LCM lcm;
  std::map<int, std::unique_ptr<Entry>> entries;
  int next_id{1};
  int dispatching{};           // handlers running (nested through HandleTimeout)
  std::vector<int> to_remove;  // ended inside a handler
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
  if (it == impl_->entries.end() || it->second->ended) return;
  if (impl_->dispatching > 0) {
    // A handler (maybe this one) is running: its Entry must outlive it.
    it->second->ended = true;
    impl_->to_remove.push_back(id);
    return;
  }
  impl_->Remove(it);
}

int LcmBus::HandleTimeout(int timeout_ms) {
  const int handled = impl_->lcm.handleTimeout(timeout_ms);
  if (impl_->dispatching == 0 && !impl_->to_remove.empty()) {
    for (int id : impl_->to_remove) {
      if (auto it = impl_->entries.find(id); it != impl_->entries.end()) impl_->Remove(it);
    }
    impl_->to_remove.clear();
  }
  return handled;
}

}  // namespace rocklab::common
