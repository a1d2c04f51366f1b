#include "daq/sequence_checker.h"

#include <cstdint>

namespace rocklab::daq {
namespace {

// a - b - 1 samples between two sequence numbers from the wire, saturated
// instead of overflowing (a corrupt seq may be anything).
int64_t Between(int64_t a, int64_t b) {
  int64_t d = 0;
  if (__builtin_sub_overflow(a, b, &d) || d == INT64_MIN) return a > b ? INT64_MAX : INT64_MIN;
  return d - 1;
}

int64_t SaturatedAdd(int64_t a, int64_t b) {
  int64_t s = 0;
  if (__builtin_add_overflow(a, b, &s)) return b > 0 ? INT64_MAX : INT64_MIN;
  return s;
}

}  // namespace

const char* ToString(SequenceStatus status) {
  switch (status) {
    case SequenceStatus::kFirst: return "first";
    case SequenceStatus::kInOrder: return "in order";
    case SequenceStatus::kGap: return "gap";
    case SequenceStatus::kDuplicate: return "duplicate";
    case SequenceStatus::kOutOfOrder: return "out of order";
    case SequenceStatus::kReanchored: return "re-anchored";
  }
  return "?";
}

SequenceStatus SequenceChecker::Check(int64_t seq, int64_t utime) {
  ++counts_.frames;
  last_missing_ = 0;
  last_was_bad_ = false;
  const bool after_gap = after_gap_;
  after_gap_ = false;
  if (!started_) {
    started_ = true;
    seq_ = seq;
    utime_ = utime;
    return SequenceStatus::kFirst;
  }
  if (seq < seq_ || utime < utime_) {
    if (after_gap && seq > before_gap_seq_ && utime > before_gap_utime_) {
      // The frame before jumped ahead and this one is back in step with the
      // frame before it: that jump was a bad timestamp.
      counts_.gaps -= 1;
      counts_.missing = SaturatedAdd(counts_.missing, -gap_missing_);
      ++counts_.bad_timestamps;
      last_was_bad_ = true;
      // Samples between the last good frame and this one; the bad frame
      // stood for one of them at most, it is not counted as lost.
      const int64_t missing = Between(seq, before_gap_seq_);
      if (missing > 0) {
        ++counts_.gaps;
        counts_.missing = SaturatedAdd(counts_.missing, missing);
        last_missing_ = missing;
      }
      seq_ = seq;
      utime_ = utime;
      run_ = 0;
      return SequenceStatus::kReanchored;
    }
    ++counts_.out_of_order;
    if (run_ > 0 && seq > run_seq_ && utime > run_utime_) {
      ++run_;
    } else {
      run_ = 1;
    }
    run_seq_ = seq;
    run_utime_ = utime;
    if (run_ >= kReanchorRun) {
      --counts_.out_of_order;  // this frame is taken, as the new reference
      ++counts_.reanchors;
      seq_ = seq;
      utime_ = utime;
      run_ = 0;
      return SequenceStatus::kReanchored;
    }
    return SequenceStatus::kOutOfOrder;
  }
  run_ = 0;
  if (seq == seq_ || utime == utime_) {
    ++counts_.duplicates;
    return SequenceStatus::kDuplicate;
  }
  const int64_t missing = Between(seq, seq_);
  if (missing > 0) {
    after_gap_ = true;
    before_gap_seq_ = seq_;
    before_gap_utime_ = utime_;
    gap_missing_ = missing;
  }
  seq_ = seq;
  utime_ = utime;
  if (missing > 0) {
    ++counts_.gaps;
    counts_.missing = SaturatedAdd(counts_.missing, missing);
    last_missing_ = missing;
    return SequenceStatus::kGap;
  }
  return SequenceStatus::kInOrder;
}

}  // namespace rocklab::daq
