#pragma once
/// @file
/// Sequence-number accounting of a received stream, written once for every
/// node that counts gaps (node support, beside node_support.h).

#include <cstdint>
#include <limits>

namespace rocklab::common {

/// Accounting of a received stream that its sender numbers one by one
/// (`seq`: RL_RAW, RL_THETA, RL_TABLE): a forward jump of k is one gap of
/// k - 1 missing messages; a repeat or a step back (a duplicate, or a sender
/// that restarted) is counted in `back`, and the count goes on from it.
/// Used by the model and compare nodes (RL_HEALTH gaps) and the recorder.
struct SeqGaps {
  std::int64_t gaps{};     ///< forward jumps
  std::int64_t missing{};  ///< numbers skipped by those jumps
  std::int64_t back{};     ///< numbers that repeated or went back
  bool any{};              ///< a number has been seen
  std::int64_t first{};    ///< the first number seen
  std::int64_t last{};     ///< the last number seen
  /// Any int64 is accepted (numbers come off the wire); see Skipped.
  void Add(std::int64_t seq) {
    if (!any) {
      any = true;
      first = seq;
    } else if (seq > last) {
      if (seq - 1 != last) {
        ++gaps;
        missing = SaturatingAdd(missing, Skipped(last, seq));
      }
    } else {
      ++back;
    }
    last = seq;
  }

  /// The numbers strictly between `last` and a later `seq` (seq > last),
  /// taken in unsigned arithmetic and capped at INT64_MAX.
  static std::int64_t Skipped(std::int64_t last, std::int64_t seq) {
    const std::uint64_t jump = static_cast<std::uint64_t>(seq) - static_cast<std::uint64_t>(last);
    return jump - 1 >= kMaxU ? kMax : static_cast<std::int64_t>(jump - 1);
  }
  /// a + b for non-negative counts, capped at INT64_MAX.
  static std::int64_t SaturatingAdd(std::int64_t a, std::int64_t b) {
    return b >= kMax - a ? kMax : a + b;
  }

 private:
  static constexpr std::int64_t kMax = std::numeric_limits<std::int64_t>::max();
  static constexpr auto kMaxU = static_cast<std::uint64_t>(kMax);
};

}  // namespace rocklab::common
