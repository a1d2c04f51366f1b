#include "common/bus.h"

namespace rocklab::common {

Subscription& Subscription::operator=(Subscription&& other) noexcept {
  if (this != &other) {
    Reset();
    bus_ = std::move(other.bus_);
    id_ = std::exchange(other.id_, 0);
  }
  return *this;
}

void Subscription::Reset() noexcept {
  const int id = std::exchange(id_, 0);
  if (id == 0) return;
  if (const std::shared_ptr<Bus*> bus = bus_.lock()) (*bus)->Unsubscribe(id);
  bus_.reset();
}

Bus::Bus() : counters_(std::make_shared<BusCounters>()), self_(std::make_shared<Bus*>(this)) {}

Bus::Bus(SharesCountersWith shared)
    : counters_(shared.wrapped.counters_), self_(std::make_shared<Bus*>(this)) {}

Bus::~Bus() = default;

std::int64_t PayloadUtime(const void* data, int size, std::int64_t fallback) {
  if (size < 16) return fallback;
  const auto* b = static_cast<const std::uint8_t*>(data) + 8;
  std::uint64_t u = 0;
  for (int i = 0; i < 8; ++i) u = (u << 8) | b[i];
  return static_cast<std::int64_t>(u);
}

}  // namespace rocklab::common
