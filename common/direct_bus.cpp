#include "common/direct_bus.h"

#include <chrono>
#include <cstring>
#include <regex>
#include <stdexcept>
#include <thread>
#include <unordered_map>
#include <vector>

#include "rocklab/block_state_t.hpp"
#include "rocklab/model_band_t.hpp"
#include "rocklab/model_state3_t.hpp"
#include "rocklab/raw_frame_t.hpp"
#include "rocklab/table_state_t.hpp"

namespace rocklab::common {
namespace {

// lcm-gen encodes a string up to its first NUL but sizes it by size().
bool EncodesWhole(const std::string& s) { return std::strlen(s.c_str()) == s.size(); }

}  // namespace

// Fixed fields only: their encoding is their value.
template <>
bool PassesAsValue(const rocklab::block_state_t& /*msg*/) {
  return true;
}
template <>
bool PassesAsValue(const rocklab::table_state_t& /*msg*/) {
  return true;
}
template <>
bool PassesAsValue(const rocklab::model_state3_t& msg) {
  return EncodesWhole(msg.name) && EncodesWhole(msg.model);
}
template <>
bool PassesAsValue(const rocklab::model_band_t& msg) {
  return EncodesWhole(msg.name) && EncodesWhole(msg.model);
}
template <>
bool PassesAsValue(const rocklab::raw_frame_t& msg) {
  return msg.num_channels >= 0 && static_cast<std::size_t>(msg.num_channels) == msg.values.size();
}

struct DirectBus::Impl {
  struct Entry {
    int id{};
    std::regex pattern;
    std::unordered_map<std::string, bool> matches;  // channel -> matches (regex once per channel)
    RawHandler handler;
    std::vector<TypedValueHandler> values;  // the objects it takes, by type (bus.h)
    bool removed{};
    // The handler of `values` that takes objects of `type`, or nullptr.
    const ValueHandler* ValueFor(const std::type_info& type) const {
      for (const TypedValueHandler& v : values) {
        if (*v.type == type) return &v.handler;
      }
      return nullptr;
    }
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

bool DirectBus::PublishValue(const std::string& channel, const MessageRef& msg) {
  Impl& m = *impl_;
  // While the routes are stale (a subscription changed during a dispatch)
  // the raw Publish matches entry by entry.
  if (!msg.by_value || m.routes_stale) return Bus::PublishValue(channel, msg);
  const std::vector<Impl::Entry*>& route = m.Route(channel);
  bool bytes_wanted = false;
  for (const Impl::Entry* e : route) bytes_wanted = bytes_wanted || e->ValueFor(*msg.type) == nullptr;
  ++m.depth;
  struct Leave {  // also when the encoding throws
    Impl& m;
    ~Leave() {
      --m.depth;
      m.Compact();
    }
  } leave{m};
  // An entry removed by a handler is skipped; none is added meanwhile (as
  // in Publish). `route` stays valid: the routes are only cleared by Compact
  // at depth 0.
  const auto dispatch = [&](const void* data, int size) {
    for (Impl::Entry* e : route) {
      if (e->removed) continue;
      if (const ValueHandler* value = e->ValueFor(*msg.type)) {
        DispatchValue(*value, channel, msg.msg);
      } else {
        Dispatch(e->handler, channel, data, size);
      }
    }
    return true;
  };
  if (!bytes_wanted) return dispatch(nullptr, 0);
  return EncodeThen(msg, dispatch);
}

Subscription DirectBus::SubscribeRawOrValue(const std::string& channel_regex, RawHandler raw,
                                            std::vector<TypedValueHandler> values, int queue_capacity) {
  Subscription s = SubscribeRaw(channel_regex, std::move(raw), queue_capacity);
  impl_->entries.back()->values = std::move(values);
  return s;
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
