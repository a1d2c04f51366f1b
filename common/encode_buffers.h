#pragma once
/// @file
/// The buffers a bus encodes typed messages into, reused from message to
/// message (no allocation once a size was seen), one per nesting depth: a
/// DirectBus handler that publishes while its own message is still being
/// dispatched must not overwrite that message's bytes.

#include <cstdint>
#include <vector>

namespace rocklab::common {

class EncodeBuffers {
 public:
  /// Encodes `msg` (an lcm-gen type) into the buffer of the current depth
  /// and calls `then(const void* data, int size)` with it (a nested call
  /// gets the next buffer). False when `msg` does not encode; else what
  /// `then` returned.
  template <class Msg, class Then>
  bool EncodeThen(const Msg& msg, Then&& then) {
    if (buffers_.size() <= depth_) buffers_.emplace_back();
    std::vector<std::uint8_t>& buf = buffers_[depth_];
    const int size = msg.getEncodedSize();
    if (size < 0) return false;
    if (buf.size() < static_cast<std::size_t>(size)) buf.resize(size);
    ++encoded_;
    if (msg.encode(buf.data(), 0, size) != size) return false;
    ++depth_;
    struct Leave {  // also when `then` throws
      std::size_t& depth;
      ~Leave() { --depth; }
    } leave{depth_};
    return then(static_cast<const void*>(buf.data()), size);
  }

  /// Messages encoded so far (those that failed to encode too).
  std::int64_t encoded() const { return encoded_; }

 private:
  std::vector<std::vector<std::uint8_t>> buffers_;
  std::int64_t encoded_{};
  std::size_t depth_{};
};

}  // namespace rocklab::common
