#include "common/seq_gaps.h"

namespace rocklab::common {

void SeqGaps::AddChange(Counts& sum, const Counts& before, const Counts& now) {
  // Differences of saturated counts stay in range: both lie in [0, INT64_MAX].
  sum.gaps = SaturatingAdd(sum.gaps, now.gaps - before.gaps);
  sum.missing = SaturatingAdd(sum.missing, now.missing - before.missing);
  sum.back = SaturatingAdd(sum.back, now.back - before.back);
  sum.late = SaturatingAdd(sum.late, now.late - before.late);
  sum.duplicates = SaturatingAdd(sum.duplicates, now.duplicates - before.duplicates);
  sum.restarts = SaturatingAdd(sum.restarts, now.restarts - before.restarts);
  sum.wild = SaturatingAdd(sum.wild, now.wild - before.wild);
}

bool SeqGaps::Seen(std::int64_t n) const {
  const auto bit = static_cast<std::uint64_t>(n) % static_cast<std::uint64_t>(kWindow);
  return (seen_[bit / 64] >> (bit % 64)) & 1U;
}

void SeqGaps::Mark(std::int64_t n, bool seen) {
  const auto bit = static_cast<std::uint64_t>(n) % static_cast<std::uint64_t>(kWindow);
  const std::uint64_t mask = std::uint64_t{1} << (bit % 64);
  if (seen) {
    seen_[bit / 64] |= mask;
  } else {
    seen_[bit / 64] &= ~mask;
  }
}

void SeqGaps::Begin(std::int64_t seq) {
  first_ = highest_ = seq;
  seen_.fill(0);  // numbers below the first are not known to be missing
  Mark(seq, true);
}

void SeqGaps::Advance(std::int64_t seq) {
  // The numbers passed over leave the window's low end as they enter at the top.
  for (std::int64_t n = highest_ + 1; n != seq; ++n) Mark(n, false);
  Mark(seq, true);
  if (seq - highest_ > 1) {
    ++c_.gaps;
    c_.missing = SaturatingAdd(c_.missing, seq - highest_ - 1);
  }
  highest_ = seq;
}

void SeqGaps::InRun(std::int64_t seq) {
  if (seq > highest_) {
    if (Distance(highest_, seq) > static_cast<std::uint64_t>(kWindow)) {
      held_ = true;
      held_seq_ = seq;
      ++c_.wild;  // until the next number says otherwise
      return;
    }
    Advance(seq);
    return;
  }
  ++c_.back;
  if (Distance(seq, highest_) > static_cast<std::uint64_t>(kWindow - 2)) {
    held_ = true;
    held_seq_ = seq;
    ++c_.wild;
    return;
  }
  if (Seen(seq)) {
    ++c_.duplicates;
    return;
  }
  Mark(seq, true);
  ++c_.late;
  if (seq < first_) return;  // before the run's first number: never counted missing
  if (c_.missing != kMax) --c_.missing;
  // Filling one number of a run of missing ones: the run ends (it was that
  // number alone), shrinks (a neighbour arrived) or splits in two.
  const bool below_missing = seq > first_ && !Seen(seq - 1);
  const bool above_missing = !Seen(seq + 1);  // seq < highest_, and highest_ arrived
  if (below_missing && above_missing) {
    ++c_.gaps;
  } else if (!below_missing && !above_missing) {
    --c_.gaps;
  }
}

void SeqGaps::Add(std::int64_t seq) {
  if (!any_) {
    any_ = true;
    Begin(seq);
    return;
  }
  if (held_) {
    held_ = false;
    const auto window = static_cast<std::uint64_t>(kWindow);
    if (Distance(seq, highest_) > window && Distance(seq, held_seq_) <= window) {
      // The stream went on from the held number: the sender moved there.
      --c_.wild;
      if (held_seq_ > highest_) {
        seen_.fill(0);  // every number of the new window lies above the old highest: missing
        ++c_.gaps;
        c_.missing = SaturatingAdd(c_.missing, Skipped(highest_, held_seq_));
        highest_ = held_seq_;
        Mark(held_seq_, true);
      } else {
        ++c_.restarts;
        Begin(held_seq_);
      }
    } else if (Distance(seq, highest_) > window) {
      // Far from both: the held one was wild; this one is held in turn.
      held_ = true;
      held_seq_ = seq;
      ++c_.wild;
      if (seq <= highest_) ++c_.back;
      return;
    }
  }
  InRun(seq);
}

}  // namespace rocklab::common
