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
  // Channel -> the entries it matches, in subscription order: one lookup
  // per message instead of one per subscription (run --max publishes ~7
  // messages per sample to ~6 subscriptions). Cleared when the entries
  // change; while a dispatch is under way a subscription only marks it
  // stale (the outer Publish iterates over a route), and Publish matches
  // entry by entry until the outermost dispatch ends.
  std::unordered_map<std::string, std::vector<Entry*>> routes;
  bool routes_stale{};
  int next_id{1};
  int depth{};  // nested Publish calls under way
  bool any_removed{};

  bool Matches(Entry& e, const std::string& channel) {
    auto it = e.matches.find(channel);
    if (it == e.matches.end()) it = e.matches.emplace(channel, std::regex_match(channel, e.pattern)).first;
    return it->second;
  }
  const std::vector<Entry*>& Route(const std::string& channel) {
    auto it = routes.find(channel);
    if (it != routes.end()) return it->second;
    std::vector<Entry*> route;
    for (auto& e : entries) {
      if (!e->removed && Matches(*e, channel)) route.push_back(e.get());
    }
    return routes.emplace(channel, std::move(route)).first->second;  // references survive a rehash
  }
  void EntriesChanged() {
    if (depth > 0) {
      routes_stale = true;
    } else {
      routes.clear();
    }
  }
  void Compact() {
    if (depth > 0) return;
    if (routes_stale) {
      routes.clear();
      routes_stale = false;
    }
    if (!any_removed) return;
    std::vector<std::unique_ptr<Entry>> kept;
    for (auto& e : entries) {
      if (!e->removed) kept.push_back(std::move(e));
    }
    entries = std::move(kept);
    any_removed = false;
    routes.clear();
  }
};

DirectBus::DirectBus() : impl_(std::make_unique<Impl>()) {}
DirectBus::~DirectBus() = default;

bool DirectBus::Publish(const std::string& channel, const void* data, int size) {
  if (size < 0) return false;
  Impl& m = *impl_;
  ++m.depth;
  if (!m.routes_stale) {
    // An entry removed by a handler is skipped; none is added meanwhile
    // (that makes the routes stale, and entries live until Compact).
    for (Impl::Entry* e : m.Route(channel)) {
      if (!e->removed) Dispatch(e->handler, channel, data, size);
    }
  } else {
    // Entries subscribed by a handler during this dispatch wait for the next
    // message: iterate over the count at the start.
    const std::size_t n = m.entries.size();
    for (std::size_t i = 0; i < n; ++i) {
      Impl::Entry& e = *m.entries[i];
      if (!e.removed && m.Matches(e, channel)) Dispatch(e.handler, channel, data, size);
    }
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
  impl_->EntriesChanged();
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
