#pragma once
/// @file
/// A bounded queue of LCM events between one producer (LCM's dispatch
/// thread) and one consumer (the recorder's writer thread), in a single byte
/// ring allocated at construction: Push copies an event in, PopBatch hands the
/// consumer views of every queued event and then frees them. No allocation
/// after construction. A full queue refuses the event (the caller counts the
/// drop) instead of blocking LCM's thread.

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string_view>

namespace rocklab::record {

/// One queued event, valid only during the PopBatch callback.
struct EventView {
  int32_t channel_id{};      ///< the producer's dense id of the channel
  int64_t utime{};           ///< receipt time, us since the epoch
  std::string_view channel;  ///< channel name
  const uint8_t* data{};     ///< payload
  uint32_t size{};           ///< payload bytes
};

class EventQueue {
 public:
  /// @param capacity_bytes ring size, bytes, rounded up to a multiple of 8;
  ///        >= 64. Each event takes 24 bytes + channel + payload, 8-aligned.
  /// @throws std::invalid_argument for a capacity below 64 bytes.
  explicit EventQueue(std::size_t capacity_bytes);
  EventQueue(const EventQueue&) = delete;
  EventQueue& operator=(const EventQueue&) = delete;

  /// Producer: copies the event in. False when it does not fit in the free
  /// space (or never could) or the queue is closed: nothing is queued.
  [[nodiscard]] bool Push(int32_t channel_id, int64_t utime, std::string_view channel, const void* data,
                          uint32_t size);

  /// Consumer: waits up to `wait` for events, calls `fn` on every event queued
  /// at that moment, in order, then frees their space. Returns the number of
  /// events handed out; 0 when none came within `wait`; -1 once the queue is
  /// closed and empty.
  int PopBatch(const std::function<void(const EventView&)>& fn, std::chrono::milliseconds wait);

  /// No more pushes; PopBatch drains what is queued, then returns -1.
  void Close();

  std::size_t capacity_bytes() const { return capacity_; }
  /// Largest number of bytes in use at once since construction.
  std::size_t high_water_bytes() const;
  /// Bytes an event of this channel and payload takes in the ring.
  static std::size_t RecordBytes(std::size_t channel_size, std::size_t data_size);

 private:
  // Not value-initialised: the kernel maps its pages as they are first used.
  std::unique_ptr<uint8_t[]> ring_;
  std::size_t capacity_{};
  mutable std::mutex mutex_;
  std::condition_variable ready_;
  // Positions grow without bound (offset = position % capacity); only the
  // producer moves head_, only the consumer tail_. The bytes in
  // [tail_, head_) belong to the consumer, the rest to the producer.
  uint64_t head_{0};
  uint64_t tail_{0};
  std::size_t high_water_{0};
  bool closed_{false};
};

}  // namespace rocklab::record
