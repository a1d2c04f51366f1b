#pragma once
/// @file
/// A bounded queue of LCM events between one producer (LCM's dispatch
/// thread) and one consumer (the recorder's writer thread), in a single byte
/// ring mapped at construction: Push copies an event in, PopBatch hands the
/// consumer views of every queued event and then frees them. No allocation
/// after construction. A full queue refuses the event (the caller counts the
/// drop) instead of blocking LCM's thread.
///
/// Memory: the ring is reserved, not resident. Its pages become resident as
/// events are written into them, and the queue keeps few of them so: when
/// the producer finds the queue empty it starts again at the ring's start
/// (a writer that keeps up reuses the same first pages), and it gives back
/// to the kernel (madvise MADV_DONTNEED) every whole chunk, other than the
/// first, that the consumer has drained: only the producer writes, so a
/// chunk it gives back is never one it is writing into. So the resident
/// part is about the bytes queued plus two chunks, not the capacity
/// (docs/performance.md, Start-up: 64 MiB resident before).

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <functional>
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
  /// The default `release_chunk_bytes`.
  static constexpr std::size_t kReleaseChunkBytes = 256u << 10;

  /// @param capacity_bytes ring size, bytes, rounded up to a multiple of 8;
  ///        >= 64. Each event takes 24 bytes + channel + payload, 8-aligned.
  /// @param release_chunk_bytes what is given back to the kernel at once, bytes,
  ///        rounded up to a multiple of the page size; >= 1.
  /// @throws std::invalid_argument for a capacity below 64 bytes or a chunk
  ///         of 0; std::runtime_error when the ring cannot be mapped.
  explicit EventQueue(std::size_t capacity_bytes, std::size_t release_chunk_bytes = kReleaseChunkBytes);
  ~EventQueue();
  EventQueue(const EventQueue&) = delete;
  EventQueue& operator=(const EventQueue&) = delete;

  /// Producer: copies the event in. False when it does not fit in the free
  /// space (or never could) or the queue is closed: nothing is queued.
  [[nodiscard]] bool Push(int32_t channel_id, int64_t utime, std::string_view channel, const void* data,
                          uint32_t size);

  /// Consumer: waits up to `wait` for events, calls `fn` on every event queued
  /// at that moment, in order, then frees their space. Returns the number of
  /// events handed out; 0 when none came within `wait`; -1 once the queue is
  /// closed and empty. A record that Push cannot have written (the ring's
  /// memory damaged) is not handed out: it and the rest of the batch are
  /// freed and counted (damage()).
  int PopBatch(const std::function<void(const EventView&)>& fn, std::chrono::milliseconds wait);

  /// No more pushes; PopBatch drains what is queued, then returns -1.
  void Close();

  /// What PopBatch gave up because the ring held a record Push cannot have
  /// written (a bug elsewhere wrote over it).
  struct Damage {
    uint64_t records{};  ///< damaged records found (each ends its batch)
    uint64_t events{};   ///< events given up: the damaged one and the rest of its batch
    uint64_t bytes{};    ///< ring bytes given up
  };
  Damage damage() const;

  std::size_t capacity_bytes() const { return capacity_; }
  /// Largest number of bytes in use at once since construction.
  std::size_t high_water_bytes() const;
  /// Bytes an event of this channel and payload takes in the ring.
  static std::size_t RecordBytes(std::size_t channel_size, std::size_t data_size);

  /// The ring's bytes resident in memory now (mincore: whole pages), for
  /// the tests and the recorder's figures; 0 when mincore fails.
  std::size_t resident_bytes() const;
  std::size_t release_chunk_bytes() const { return chunk_; }

 private:
  // Producer: gives back the chunks in [released_, drained_to) that are
  // whole and not written again since they were read (head: the producer's
  // position), other than a pass's first chunk (the one an empty queue
  // restarts in); released_ then says where it stopped.
  void ReleaseDrained(uint64_t head, uint64_t drained_to);
  // A record header as Push writes it: its total is the 8-aligned size of
  // its header, channel and payload, within the queued bytes and the ring's end.
  static bool RecordFits(uint32_t total, uint32_t channel_size, uint32_t data_size, uint64_t queued,
                         std::size_t to_end);
  // The end of the chunk `position` is in (position itself at a boundary).
  uint64_t ChunkEnd(uint64_t position) const;

  // An anonymous mapping: the kernel makes its pages resident as they are
  // first written, and zero again once given back (ReleaseDrained).
  uint8_t* ring_{};
  std::size_t mapped_{};  // ring_'s mapping, bytes: capacity_ rounded up to the chunk
  std::size_t capacity_{};
  std::size_t chunk_{};
  mutable std::mutex mutex_;
  std::condition_variable ready_;
  // Positions grow without bound (offset = position % capacity); only the
  // producer moves head_, only the consumer tail_, except that the producer
  // moves both to the next multiple of the capacity when it finds them
  // equal (empty: the consumer holds nothing then). The bytes in
  // [tail_, head_) belong to the consumer, the rest to the producer.
  uint64_t head_{0};
  uint64_t tail_{0};
  uint64_t released_{0};  // the producer's: chunks below it were given back
  std::size_t high_water_{0};
  uint64_t pushed_events_{0};   // events published by Push
  uint64_t handed_events_{0};   // events handed out or given up by PopBatch
  uint64_t corrupt_records_{0};
  uint64_t discarded_events_{0};
  uint64_t discarded_bytes_{0};
  bool closed_{false};
};

}  // namespace rocklab::record
