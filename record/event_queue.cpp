#include "record/event_queue.h"

#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

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

EventQueue::EventQueue(std::size_t capacity_bytes, std::size_t release_chunk_bytes) {
  if (capacity_bytes < 64) throw std::invalid_argument("EventQueue: capacity must be >= 64 bytes");
  if (release_chunk_bytes == 0) throw std::invalid_argument("EventQueue: release chunk must be >= 1 byte");
  capacity_ = Align8(capacity_bytes);
  const auto page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
  chunk_ = (release_chunk_bytes + page - 1) / page * page;
  mapped_ = (capacity_ + chunk_ - 1) / chunk_ * chunk_;
  void* ring = mmap(nullptr, mapped_, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
  if (ring == MAP_FAILED) {
    throw std::runtime_error("EventQueue: cannot map " + std::to_string(mapped_) + " bytes: " + std::strerror(errno));
  }
  ring_ = static_cast<uint8_t*>(ring);
  // Small pages, so that a few written bytes make one page resident, not 2 MiB.
  madvise(ring_, mapped_, MADV_NOHUGEPAGE);
}

EventQueue::~EventQueue() { munmap(ring_, mapped_); }

bool EventQueue::Push(int32_t channel_id, int64_t utime, std::string_view channel, const void* data,
                      uint32_t size) {
  const std::size_t cap = capacity_;
  const std::size_t n = RecordBytes(channel.size(), size);
  if (n > cap) return false;
  uint64_t head = 0, tail = 0;
  uint64_t restarted_from = 0;  // the position an empty queue restarted from, when > 0
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (closed_) return false;
    if (head_ == tail_ && head_ % cap != 0) {
      // Empty: start again at the ring's start, whose pages are resident.
      restarted_from = head_;
      head_ = tail_ = (head_ / cap + 1) * cap;
    }
    head = head_;
    tail = tail_;
  }
  if (restarted_from > 0) {
    // All drained, the chunk the queue ended in too.
    ReleaseDrained(restarted_from, ChunkEnd(restarted_from));
    released_ = head;
  } else {
    ReleaseDrained(head, tail);
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
    ++pushed_events_;
    high_water_ = std::max(high_water_, static_cast<std::size_t>(head_ - tail_));
  }
  ready_.notify_one();
  return true;
}

int EventQueue::PopBatch(const std::function<void(const EventView&)>& fn, std::chrono::milliseconds wait) {
  uint64_t head = 0, tail = 0;
  uint64_t events_at_head = 0;  // events pushed up to `head`
  {
    std::unique_lock<std::mutex> lock(mutex_);
    ready_.wait_for(lock, wait, [this] { return head_ != tail_ || closed_; });
    if (head_ == tail_) return closed_ ? -1 : 0;
    head = head_;
    tail = tail_;
    events_at_head = pushed_events_;
  }
  const std::size_t cap = capacity_;
  int handed = 0;
  bool corrupt = false;
  while (tail != head) {
    const std::size_t offset = static_cast<std::size_t>(tail % cap);
    const uint8_t* p = &ring_[offset];
    uint32_t total = 0;
    std::memcpy(&total, p, 4);
    if (total == kWrap && head - tail > cap - offset) {  // Push wraps only before a record it writes
      tail += cap - offset;
      continue;
    }
    EventView ev;
    uint32_t channel_size = 0;
    std::memcpy(&ev.channel_id, p + 4, 4);
    std::memcpy(&ev.utime, p + 8, 8);
    std::memcpy(&channel_size, p + 16, 4);
    std::memcpy(&ev.size, p + 20, 4);
    // Only Push writes the ring, so a record unlike Push's is memory
    // damaged by a bug elsewhere: its size cannot be trusted to find the
    // next one (a total of 0 once stopped the loop here for ever).
    if (!RecordFits(total, channel_size, ev.size, head - tail, cap - offset)) {
      corrupt = true;
      break;
    }
    ev.channel = std::string_view(reinterpret_cast<const char*>(p + kHeader), channel_size);
    ev.data = p + kHeader + channel_size;
    fn(ev);
    ++handed;
    tail += total;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    handed_events_ += static_cast<uint64_t>(handed);
    if (corrupt) {
      // Every event of this batch from the damaged one on is given up,
      // counted: the events pushed up to `head` less those handed out.
      ++corrupt_records_;
      discarded_bytes_ += head - tail;
      discarded_events_ += events_at_head - handed_events_;
      handed_events_ = events_at_head;
      tail = head;
    }
    tail_ = tail;
  }
  return handed;
}

bool EventQueue::RecordFits(uint32_t total, uint32_t channel_size, uint32_t data_size, uint64_t queued,
                            std::size_t to_end) {
  return total >= kHeader && total % 8 == 0 && total <= queued && total <= to_end &&
         RecordBytes(channel_size, data_size) == total;
}

uint64_t EventQueue::ChunkEnd(uint64_t position) const {
  const uint64_t pass_start = position / capacity_ * capacity_;
  const uint64_t offset = position - pass_start;
  return pass_start + std::min<uint64_t>((offset + chunk_ - 1) / chunk_ * chunk_, capacity_);
}

void EventQueue::ReleaseDrained(uint64_t head, uint64_t drained_to) {
  // Chunk k of a pass covers its offsets [k chunk, min((k + 1) chunk,
  // capacity)). One whose positions are below `drained_to` has been read;
  // one at or above head - capacity has not been written again since.
  const uint64_t cap = capacity_;
  uint64_t begin = ChunkEnd(std::max(released_, head >= cap ? head - cap : 0));
  for (;;) {
    const uint64_t pass_start = begin / cap * cap;
    const uint64_t end = std::min(begin + chunk_, pass_start + cap);
    if (end > drained_to) break;
    if (begin != pass_start) {
      madvise(ring_ + (begin - pass_start), static_cast<std::size_t>(end - begin), MADV_DONTNEED);
    }
    begin = end;
  }
  released_ = begin;
}

std::size_t EventQueue::resident_bytes() const {
  const auto page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
  std::vector<unsigned char> pages(mapped_ / page);
  if (mincore(ring_, mapped_, pages.data()) != 0) return 0;
  std::size_t resident = 0;
  for (const unsigned char p : pages) resident += (p & 1u) != 0 ? page : 0;
  return resident;
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

EventQueue::Damage EventQueue::damage() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return {corrupt_records_, discarded_events_, discarded_bytes_};
}

}  // namespace rocklab::record
