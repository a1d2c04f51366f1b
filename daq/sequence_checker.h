#pragma once
/// @file
/// Sequence accounting of a frame stream: gaps, duplicates and frames out of
/// order (by sequence number or by time) are classified and counted; nothing
/// is dropped or reordered here, the caller decides and reports.
///
/// One bad timestamp must not cost the rest of a record. Two patterns are
/// recognised and the reference re-anchored (kReanchored):
/// - an isolated jump: frame J jumps ahead (a gap) and the very next frame is
///   back in step with the frame before J. J was a bad timestamp: its gap is
///   withdrawn from the counts (gaps, missing) and counted in bad_timestamps;
///   last_was_bad() tells the caller to drop what it made of J.
/// - a run: kReanchorRun consecutive frames behind the reference, each in
///   order after the one before (the reference itself was bad, e.g. the
///   first frame, or the clock was set back). The run's earlier frames stay
///   counted out of order; the reference moves to the last one; counted in
///   reanchors.

#include <cstdint>

namespace rocklab::daq {

enum class SequenceStatus {
  kFirst,       ///< first frame of the stream
  kInOrder,     ///< seq = previous + 1 and time increases
  kGap,         ///< seq jumped forward: missing() samples lost before this one
  kDuplicate,   ///< same seq or same time as the previous frame
  kOutOfOrder,  ///< seq or time went backwards
  kReanchored,  ///< the reference was bad and now is this frame (see the top of the file)
};
const char* ToString(SequenceStatus status);

struct SequenceCounts {
  int64_t frames{};          ///< frames seen
  int64_t gaps{};            ///< gap occurrences
  int64_t missing{};         ///< samples lost in gaps
  int64_t duplicates{};      ///< duplicate seq or time
  int64_t out_of_order{};    ///< seq or time backwards
  int64_t bad_timestamps{};  ///< isolated jumps found and withdrawn
  int64_t reanchors{};       ///< re-anchorings on a run of frames (not isolated jumps)
};

class SequenceChecker {
 public:
  /// Frames behind the reference, in order among themselves, that move it.
  static constexpr int kReanchorRun = 3;

  /// Classifies a frame. Duplicate and out-of-order frames do not move the
  /// reference: the next frame is compared with the last in-order one.
  SequenceStatus Check(int64_t seq, int64_t utime);
  /// Samples missing before the last frame classified kGap (or, for
  /// kReanchored after an isolated jump, between the frame before the jump
  /// and this one).
  int64_t missing() const { return last_missing_; }
  /// After kReanchored: whether the frame before this one was the bad one
  /// (an isolated jump), rather than a run having moved the reference.
  bool last_was_bad() const { return last_was_bad_; }
  const SequenceCounts& counts() const { return counts_; }

 private:
  bool started_{false};
  int64_t seq_{};
  int64_t utime_{};
  int64_t last_missing_{};
  bool last_was_bad_{false};
  // The reference before the last frame, when the last frame was a gap.
  bool after_gap_{false};
  int64_t before_gap_seq_{};
  int64_t before_gap_utime_{};
  int64_t gap_missing_{};
  // Frames behind the reference in a row, in order among themselves.
  int run_{0};
  int64_t run_seq_{};
  int64_t run_utime_{};
  SequenceCounts counts_;
};

}  // namespace rocklab::daq
