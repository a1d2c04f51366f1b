#pragma once
/// @file
/// Sequence accounting of a frame stream: gaps, duplicates and frames out of
/// order (by sequence number or by time) are classified and counted; nothing
/// is dropped or reordered here, the caller decides and reports.

#include <cstdint>

namespace rocklab::daq {

enum class SequenceStatus {
  kFirst,       ///< first frame of the stream
  kInOrder,     ///< seq = previous + 1 and time increases
  kGap,         ///< seq jumped forward: missing() samples lost before this one
  kDuplicate,   ///< same seq or same time as the previous frame
  kOutOfOrder,  ///< seq or time went backwards
};
const char* ToString(SequenceStatus status);

struct SequenceCounts {
  int64_t frames{};        ///< frames seen
  int64_t gaps{};          ///< gap occurrences
  int64_t missing{};       ///< samples lost in gaps
  int64_t duplicates{};    ///< duplicate seq or time
  int64_t out_of_order{};  ///< seq or time backwards
};

class SequenceChecker {
 public:
  /// Classifies a frame. Duplicate and out-of-order frames do not move the
  /// reference: the next frame is compared with the last in-order one.
  SequenceStatus Check(int64_t seq, int64_t utime);
  /// Samples missing before the last frame classified kGap.
  int64_t missing() const { return last_missing_; }
  const SequenceCounts& counts() const { return counts_; }

 private:
  bool started_{false};
  int64_t seq_{};
  int64_t utime_{};
  int64_t last_missing_{};
  SequenceCounts counts_;
};

}  // namespace rocklab::daq
