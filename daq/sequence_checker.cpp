#include "daq/sequence_checker.h"

namespace rocklab::daq {

const char* ToString(SequenceStatus status) {
  switch (status) {
    case SequenceStatus::kFirst: return "first";
    case SequenceStatus::kInOrder: return "in order";
    case SequenceStatus::kGap: return "gap";
    case SequenceStatus::kDuplicate: return "duplicate";
    case SequenceStatus::kOutOfOrder: return "out of order";
  }
  return "?";
}

SequenceStatus SequenceChecker::Check(int64_t seq, int64_t utime) {
  ++counts_.frames;
  last_missing_ = 0;
  if (!started_) {
    started_ = true;
    seq_ = seq;
    utime_ = utime;
    return SequenceStatus::kFirst;
  }
  if (seq < seq_ || utime < utime_) {
    ++counts_.out_of_order;
    return SequenceStatus::kOutOfOrder;
  }
  if (seq == seq_ || utime == utime_) {
    ++counts_.duplicates;
    return SequenceStatus::kDuplicate;
  }
  const int64_t missing = seq - seq_ - 1;
  seq_ = seq;
  utime_ = utime;
  if (missing > 0) {
    ++counts_.gaps;
    counts_.missing += missing;
    last_missing_ = missing;
    return SequenceStatus::kGap;
  }
  return SequenceStatus::kInOrder;
}

}  // namespace rocklab::daq
