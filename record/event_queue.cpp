#include "record/event_queue.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>

namespace rocklab::record {
namespace {

// Record layout (host byte order; the ring never leaves the process):
//   uint32 total bytes (8-aligned) | int32 channel id | int64 utime |
//   uint32 channel bytes | uint32 payload bytes | channel | payload | padding
// A total of kWrap marks the unused end of the ring: the next record is at 0.
constexpr std::size_t kHeader = 24;
constexpr uint32_t kWrap = 0xFFFFFFFFu;

std::size_t Align8(std::size_t n) { return (n + 7) & ~static_cast<std::size_t>(7); }

}  // namespace

std::size_t EventQueue::RecordBytes(std::size_t channel_size, std::size_t data_size) {
  return Align8(kHeader + channel_size + data_size);
}

EventQueue::EventQueue(std::size_t capacity_bytes) {
  if (capacity_bytes < 64) throw std::invalid_argument("EventQueue: capacity must be >= 64 bytes");
  capacity_ = Align8(capacity_bytes);
  ring_.reset(new uint8_t[capacity_]);
}

bool EventQueue::Push(int32_t channel_id, int64_t utime, std::string_view channel, const void* data,
                      uint32_t size) {
  const std::size_t cap = capacity_;
  const std::size_t n = RecordBytes(channel.size(), size);
  if (n > cap) return false;
  uint64_t head = 0, tail = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (closed_) return false;
    head = head_;
    tail = tail_;
  }
  // The consumer only ever frees space, so the space seen here stays free.
  const std::size_t used = static_cast<std::size_t>(head - tail);
  const std::size_t offset = static_cast<std::size_t>(head % cap);
  const std::size_t to_end = cap - offset;
  std::size_t skip = 0;
  if (n > to_end) skip = to_end;  // does not fit before the end: wrap
  if (used + skip + n > cap) return false;
  if (skip > 0) {
    std::memcpy(&ring_[offset], &kWrap, 4);
    head += skip;
  }
  uint8_t* p = &ring_[static_cast<std::size_t>(head % cap)];
  const uint32_t total = static_cast<uint32_t>(n);
  const uint32_t channel_size = static_cast<uint32_t>(channel.size());
  std::memcpy(p, &total, 4);
  std::memcpy(p + 4, &channel_id, 4);
  std::memcpy(p + 8, &utime, 8);
  std::memcpy(p + 16, &channel_size, 4);
  std::memcpy(p + 20, &size, 4);
  std::memcpy(p + kHeader, channel.data(), channel.size());
  if (size > 0) std::memcpy(p + kHeader + channel.size(), data, size);
  head += n;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    head_ = head;
    high_water_ = std::max(high_water_, static_cast<std::size_t>(head_ - tail_));
  }
  ready_.notify_one();
  return true;
}

int EventQueue::PopBatch(const std::function<void(const EventView&)>& fn, std::chrono::milliseconds wait) {
  uint64_t head = 0, tail = 0;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    ready_.wait_for(lock, wait, [this] { return head_ != tail_ || closed_; });
    if (head_ == tail_) return closed_ ? -1 : 0;
    head = head_;
    tail = tail_;
  }
  const std::size_t cap = capacity_;
  int handed = 0;
  while (tail != head) {
    const uint8_t* p = &ring_[static_cast<std::size_t>(tail % cap)];
    uint32_t total = 0;
    std::memcpy(&total, p, 4);
    if (total == kWrap) {
      tail += cap - static_cast<std::size_t>(tail % cap);
      continue;
    }
    EventView ev;
    uint32_t channel_size = 0;
    std::memcpy(&ev.channel_id, p + 4, 4);
    std::memcpy(&ev.utime, p + 8, 8);
    std::memcpy(&channel_size, p + 16, 4);
    std::memcpy(&ev.size, p + 20, 4);
    ev.channel = std::string_view(reinterpret_cast<const char*>(p + kHeader), channel_size);
    ev.data = p + kHeader + channel_size;
    fn(ev);
    ++handed;
    tail += total;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    tail_ = tail;
  }
  return handed;
}

void EventQueue::Close() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    closed_ = true;
  }
  ready_.notify_all();
}

std::size_t EventQueue::high_water_bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return high_water_;
}

}  // namespace rocklab::record
