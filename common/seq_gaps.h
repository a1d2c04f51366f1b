#pragma once
/// @file
/// Sequence-number accounting of a received stream, written once for every
/// reader that counts gaps: the model and compare nodes, the recorder, the
/// monitor, `rocklab info` and the Python module through them. The rule and
/// its window are in docs/reliability.md ("Loss and disorder").

#include <array>
#include <cstdint>
#include <limits>

namespace rocklab::common {

/// Accounting of a stream whose sender numbers its messages one by one from
/// 0 (`seq`). It tells loss from disorder:
/// - a number above the highest seen opens a gap of the numbers it skips
///   (`missing`, in `gaps` runs);
/// - a number at most kWindow - 2 below the highest that had not arrived
///   fills its place: `late`, and it is no longer missing;
/// - a number that already arrived is a `duplicate`;
/// - a number more than kWindow above the highest, or more than kWindow - 2
///   below it, is held and judged by the next one: if the stream goes on near the old numbers it was a `wild`
///   number (one message with a damaged or foreign number; nothing lost), if
///   it goes on near the held number the sender moved there: forward, the
///   numbers between were lost (`missing`, one more gap); back, the sender
///   restarted (`restarts`, counted once, and counting begins again there).
/// Until the next number arrives a held number counts as wild.
/// `missing` is exact on reordered, duplicated and restarted streams while
/// disorder stays inside the window. Counts saturate at INT64_MAX; any int64
/// is accepted (numbers come off the wire). No allocation.
class SeqGaps {
 public:
  /// Numbers this far below the highest are still told late from duplicate.
  static constexpr std::int64_t kWindow = 4096;

  /// Counts of a stream (or a sum of streams); plain values, cheap to copy.
  struct Counts {
    std::int64_t gaps{};        ///< runs of numbers missing now
    std::int64_t missing{};     ///< numbers missing now
    std::int64_t back{};        ///< arrivals not above the highest (late, duplicate, restart, wild)
    std::int64_t late{};        ///< arrived below the highest, not seen before
    std::int64_t duplicates{};  ///< arrived again
    std::int64_t restarts{};    ///< the sender began again lower
    std::int64_t wild{};        ///< lone numbers far from the stream's
  };

  void Add(std::int64_t seq);

  const Counts& counts() const { return c_; }
  std::int64_t gaps() const { return c_.gaps; }
  std::int64_t missing() const { return c_.missing; }
  std::int64_t back() const { return c_.back; }
  std::int64_t late() const { return c_.late; }
  std::int64_t duplicates() const { return c_.duplicates; }
  std::int64_t restarts() const { return c_.restarts; }
  std::int64_t wild() const { return c_.wild; }
  bool any() const { return any_; }
  /// First number of the current run of the sender (since its last restart).
  std::int64_t first() const { return first_; }
  /// Highest number of that run.
  std::int64_t highest() const { return highest_; }

  /// The numbers strictly between `last` and a later `seq` (seq > last),
  /// taken in unsigned arithmetic and capped at INT64_MAX.
  static std::int64_t Skipped(std::int64_t last, std::int64_t seq) {
    const std::uint64_t jump = Distance(last, seq);
    return jump - 1 >= kMaxU ? kMax : static_cast<std::int64_t>(jump - 1);
  }
  /// a + b for counts, capped at INT64_MAX (b may be negative: a count that
  /// went down, e.g. missing filled by a late message).
  static std::int64_t SaturatingAdd(std::int64_t a, std::int64_t b) {
    if (b >= 0) return b >= kMax - a ? kMax : a + b;
    return a == kMax ? kMax : a + b;
  }
  /// Adds `now - before` of every count to `sum` (sums over senders).
  static void AddChange(Counts& sum, const Counts& before, const Counts& now);

 private:
  static constexpr std::int64_t kMax = std::numeric_limits<std::int64_t>::max();
  static constexpr auto kMaxU = static_cast<std::uint64_t>(kMax);
  static constexpr std::size_t kWords = static_cast<std::size_t>(kWindow) / 64;

  /// |b - a| in unsigned arithmetic (no overflow for any pair).
  static std::uint64_t Distance(std::int64_t a, std::int64_t b) {
    const auto ua = static_cast<std::uint64_t>(a), ub = static_cast<std::uint64_t>(b);
    return b >= a ? ub - ua : ua - ub;
  }
  void Begin(std::int64_t seq);      // a run of the sender starts at seq
  void InRun(std::int64_t seq);      // seq judged against the current run
  void Advance(std::int64_t seq);    // highest_ < seq <= highest_ + kWindow
  bool Seen(std::int64_t n) const;
  void Mark(std::int64_t n, bool seen);

  Counts c_;
  bool any_{};
  std::int64_t first_{};
  std::int64_t highest_{};
  bool held_{};             // a far number waits for the next one
  std::int64_t held_seq_{};
  // Bit n mod kWindow: number n in (highest_ - kWindow, highest_] arrived.
  std::array<std::uint64_t, kWords> seen_{};
};

}  // namespace rocklab::common
