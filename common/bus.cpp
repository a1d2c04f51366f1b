#include "common/bus.h"

#include <chrono>
#include <regex>
#include <stdexcept>
#include <thread>
#include <unordered_map>

#include <lcm/lcm-cpp.hpp>
#include <spdlog/spdlog.h>

#include "common/lcm_log.h"
#include "common/logger_clock.h"

namespace rocklab::common {
namespace {

std::shared_ptr<spdlog::logger> Log() {
  static const std::shared_ptr<spdlog::logger> log = NamedLogger("bus");
  return log;
}

std::int64_t Sum(const std::map<std::string, std::int64_t>& counts) {
  std::int64_t n = 0;
  for (const auto& [channel, count] : counts) n += count;
  return n;
}

}  // namespace

std::int64_t PayloadUtime(const void* data, int size, std::int64_t fallback) {
  if (size < 16) return fallback;
  const auto* b = static_cast<const std::uint8_t*>(data) + 8;
  std::uint64_t u = 0;
  for (int i = 0; i < 8; ++i) u = (u << 8) | b[i];
  return static_cast<std::int64_t>(u);
}

std::int64_t Bus::decode_error_count() const { return Sum(decode_errors()); }
std::int64_t Bus::handler_error_count() const { return Sum(handler_errors()); }

void Bus::Warn(std::map<std::string, double>& last, const std::string& channel,
               const std::string& what) {
  // At most one line a second per channel; the counters hold the rest.
  const double now = HostNowS();
  auto it = last.find(channel);
  if (it != last.end() && now - it->second < 1.0) return;
  last[channel] = now;
  Log()->warn("{}", what);
}

void Bus::CountDecodeError(const std::string& channel, const char* why) {
  Bus& r = root();
  const std::int64_t n = ++r.decode_errors_[channel];
  Warn(r.last_decode_warning_s_, channel,
       "channel " + channel + ": a message does not decode (" + why + "): dropped (" +
           std::to_string(n) + " so far)");
}

void Bus::Dispatch(const RawHandler& handler, const std::string& channel, const void* data,
                   int size) {
  try {
    handler(channel, data, size);
  } catch (const std::exception& e) {
    const std::int64_t n = ++handler_errors_[channel];
    Warn(last_handler_warning_s_, channel,
         "channel " + channel + ": handler failed: " + e.what() + " (" + std::to_string(n) +
             " so far)");
  } catch (...) {
    const std::int64_t n = ++handler_errors_[channel];
    Warn(last_handler_warning_s_, channel,
         "channel " + channel + ": handler failed (" + std::to_string(n) + " so far)");
  }
}

// ---- LcmBus ----

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
  std::map<SubscriptionId, std::unique_ptr<Entry>> entries;
  SubscriptionId next_id{1};
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

Bus::SubscriptionId LcmBus::SubscribeRaw(const std::string& channel_regex, RawHandler handler,
                                         int queue_capacity) {
  auto entry = std::make_unique<Impl::Entry>();
  entry->bus = this;
  entry->handler = std::move(handler);
  entry->subscription = impl_->lcm.subscribe(channel_regex, &Impl::Entry::OnMessage, entry.get());
  if (entry->subscription == nullptr) {
    throw std::invalid_argument("cannot subscribe to '" + channel_regex + "'");
  }
  entry->subscription->setQueueCapacity(queue_capacity);
  const SubscriptionId id = impl_->next_id++;
  impl_->entries.emplace(id, std::move(entry));
  return id;
}

void LcmBus::Unsubscribe(SubscriptionId id) {
  auto it = impl_->entries.find(id);
  if (it == impl_->entries.end()) return;
  impl_->lcm.unsubscribe(it->second->subscription);
  impl_->entries.erase(it);
}

int LcmBus::HandleTimeout(int timeout_ms) { return impl_->lcm.handleTimeout(timeout_ms); }

// ---- DirectBus ----

struct DirectBus::Impl {
  struct Entry {
    SubscriptionId id{};
    std::regex pattern;
    std::unordered_map<std::string, bool> matches;  // channel -> matches (regex once per channel)
    RawHandler handler;
    bool removed{};
  };
  std::vector<std::unique_ptr<Entry>> entries;
  SubscriptionId next_id{1};
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

Bus::SubscriptionId DirectBus::SubscribeRaw(const std::string& channel_regex, RawHandler handler,
                                            int /*queue_capacity: nothing is queued*/) {
  auto e = std::make_unique<Impl::Entry>();
  try {
    e->pattern = std::regex(channel_regex);
  } catch (const std::regex_error& err) {
    throw std::invalid_argument("bad channel regex '" + channel_regex + "': " + err.what());
  }
  e->handler = std::move(handler);
  e->id = impl_->next_id++;
  const SubscriptionId id = e->id;
  impl_->entries.push_back(std::move(e));
  return id;
}

void DirectBus::Unsubscribe(SubscriptionId id) {
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

// ---- LogWritingBus ----

LogWritingBus::LogWritingBus(Bus& inner, LogWriter& log) : inner_(inner), log_(log) {}

bool LogWritingBus::Publish(const std::string& channel, const void* data, int size) {
  const bool logged =
      size >= 0 && log_.Write(channel, data, static_cast<std::size_t>(size), PayloadUtime(data, size, INT64_MIN));
  const bool published = inner_.Publish(channel, data, size);
  return logged && published;
}

Bus::SubscriptionId LogWritingBus::SubscribeRaw(const std::string& channel_regex, RawHandler handler,
                                                int queue_capacity) {
  return inner_.SubscribeRaw(channel_regex, std::move(handler), queue_capacity);
}

void LogWritingBus::Unsubscribe(SubscriptionId id) { inner_.Unsubscribe(id); }

int LogWritingBus::HandleTimeout(int timeout_ms) { return inner_.HandleTimeout(timeout_ms); }

// ---- RoutingBus ----

struct RoutingBus::Impl {
  std::regex pattern;
  std::unordered_map<std::string, bool> matches;  // channel -> routed (regex once per channel)
};

RoutingBus::RoutingBus(Bus& main, Bus& routed, const std::string& channel_regex)
    : main_(main), routed_(routed), impl_(std::make_unique<Impl>()) {
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

Bus::SubscriptionId RoutingBus::SubscribeRaw(const std::string& channel_regex, RawHandler handler,
                                             int queue_capacity) {
  return main_.SubscribeRaw(channel_regex, std::move(handler), queue_capacity);
}

void RoutingBus::Unsubscribe(SubscriptionId id) { main_.Unsubscribe(id); }

int RoutingBus::HandleTimeout(int timeout_ms) { return main_.HandleTimeout(timeout_ms); }

}  // namespace rocklab::common
