#include "common/direct_bus.h"

#include <chrono>
#include <regex>
#include <stdexcept>
#include <thread>
#include <unordered_map>
#include <vector>

namespace rocklab::common {

struct DirectBus::Impl {
  struct Entry {
    int id{};
    std::regex pattern;
    std::unordered_map<std::string, bool> matches;  // channel -> matches (regex once per channel)
    RawHandler handler;
    bool removed{};
  };
  std::vector<std::unique_ptr<Entry>> entries;
  int next_id{1};
  int depth{};  // nested Publish calls under way
  bool any_removed{};

  void Compact() {
    if (depth > 0 || !any_removed) return;
    std::vector<std::unique_ptr<Entry>> kept;
    for (auto& e : entries) {
      if (!e->removed) kept.push_back(std::move(e));
    }
    entries = std::move(kept);
    any_removed = false;
  }
};

DirectBus::DirectBus() : impl_(std::make_unique<Impl>()) {}
DirectBus::~DirectBus() = default;

bool DirectBus::Publish(const std::string& channel, const void* data, int size) {
  if (size < 0) return false;
  Impl& m = *impl_;
  ++m.depth;
  // Entries subscribed by a handler during this dispatch wait for the next
  // message: iterate over the count at the start.
  const std::size_t n = m.entries.size();
  for (std::size_t i = 0; i < n; ++i) {
    Impl::Entry& e = *m.entries[i];
    if (e.removed) continue;
    auto it = e.matches.find(channel);
    if (it == e.matches.end()) it = e.matches.emplace(channel, std::regex_match(channel, e.pattern)).first;
    if (it->second) Dispatch(e.handler, channel, data, size);
  }
  --m.depth;
  m.Compact();
  return true;
}

Subscription DirectBus::SubscribeRaw(const std::string& channel_regex, RawHandler handler,
                                     int /*queue_capacity: nothing is queued*/) {
  auto e = std::make_unique<Impl::Entry>();
  try {
    e->pattern = std::regex(channel_regex);
  } catch (const std::regex_error& err) {
    throw std::invalid_argument("bad channel regex '" + channel_regex + "': " + err.what());
  }
  e->handler = std::move(handler);
  e->id = impl_->next_id++;
  const int id = e->id;
  impl_->entries.push_back(std::move(e));
  return MakeSubscription(id);
}

void DirectBus::Unsubscribe(int id) {
  for (auto& e : impl_->entries) {
    if (e->id == id) {
      e->removed = true;
      impl_->any_removed = true;
    }
  }
  impl_->Compact();
}

int DirectBus::HandleTimeout(int timeout_ms) {
  if (timeout_ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(timeout_ms));
  return 0;
}

}  // namespace rocklab::common
