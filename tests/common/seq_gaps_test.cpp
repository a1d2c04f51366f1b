// common::SeqGaps: the loss-and-disorder accounting of every reader (the
// model and compare nodes, the recorder, info, the monitor). Oracle: counts
// made by hand for the short sequences; for the random streams, a count made
// here from the sets of numbers sent and received (missing: the numbers
// between the first received and the highest that never arrived).
#include "common/seq_gaps.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <random>
#include <set>
#include <vector>

namespace rocklab::common {
namespace {

SeqGaps Count(std::initializer_list<std::int64_t> seqs) {
  SeqGaps g;
  for (std::int64_t s : seqs) g.Add(s);
  return g;
}

SeqGaps Count(const std::vector<std::int64_t>& seqs) {
  SeqGaps g;
  for (std::int64_t s : seqs) g.Add(s);
  return g;
}

std::vector<std::int64_t> Range(std::int64_t from, std::int64_t to) {  // [from, to)
  std::vector<std::int64_t> v;
  for (std::int64_t k = from; k < to; ++k) v.push_back(k);
  return v;
}

TEST(SeqGaps, AnUnbrokenStreamHasNoGap) {
  const SeqGaps g = Count({7, 8, 9, 10});
  EXPECT_TRUE(g.any());
  EXPECT_EQ(g.first(), 7);
  EXPECT_EQ(g.highest(), 10);
  EXPECT_EQ(g.gaps(), 0);
  EXPECT_EQ(g.missing(), 0);
  EXPECT_EQ(g.back(), 0);
}

TEST(SeqGaps, ForwardJumpsCountGapsAndTheNumbersSkipped) {
  // 0 -> 3 skips 1, 2; 4 -> 9 skips 5..8: two gaps, six missing.
  const SeqGaps g = Count({0, 3, 4, 9});
  EXPECT_EQ(g.gaps(), 2);
  EXPECT_EQ(g.missing(), 6);
  EXPECT_EQ(g.back(), 0);
}

// Issue 34 changed this case: a repeat is a duplicate and numbers below the
// first one that arrive late are late, not a restart whose next jump opens
// a gap (the old rule counted 2 missing here, none of them lost).
TEST(SeqGaps, RepeatsAndLateNumbersAreNotLoss) {
  // 5 again (a duplicate), then 2 and 3 (sent before 4, late), then 6.
  const SeqGaps g = Count({4, 5, 5, 2, 3, 6});
  EXPECT_EQ(g.back(), 3);
  EXPECT_EQ(g.duplicates(), 1);
  EXPECT_EQ(g.late(), 2);
  EXPECT_EQ(g.gaps(), 0);
  EXPECT_EQ(g.missing(), 0);
  EXPECT_EQ(g.highest(), 6);
  // 3 arriving once more is a duplicate too.
  SeqGaps h = g;
  h.Add(3);
  EXPECT_EQ(h.duplicates(), 2);
}

TEST(SeqGaps, ALateMessageFillsItsGapAndTheRunsFollow) {
  // 0, then 5: 1..4 missing, one gap. 3 arrives: 1, 2 and 4 missing, two
  // runs. 4: one run (1, 2). 1: one run (2). 2: none.
  SeqGaps g = Count({0, 5});
  EXPECT_EQ(g.missing(), 4);
  EXPECT_EQ(g.gaps(), 1);
  g.Add(3);
  EXPECT_EQ(g.missing(), 3);
  EXPECT_EQ(g.gaps(), 2);
  g.Add(4);
  EXPECT_EQ(g.missing(), 2);
  EXPECT_EQ(g.gaps(), 1);
  g.Add(1);
  EXPECT_EQ(g.missing(), 1);
  EXPECT_EQ(g.gaps(), 1);
  g.Add(2);
  EXPECT_EQ(g.missing(), 0);
  EXPECT_EQ(g.gaps(), 0);
  EXPECT_EQ(g.late(), 4);
  EXPECT_EQ(g.duplicates(), 0);
}

TEST(SeqGaps, AMessageOneHundredLateIsLateNotLost) {
  std::vector<std::int64_t> s = Range(0, 200);
  s.erase(s.begin() + 50);
  s.push_back(50);  // after 199: 149 numbers late
  const SeqGaps g = Count(s);
  EXPECT_EQ(g.missing(), 0);
  EXPECT_EQ(g.gaps(), 0);
  EXPECT_EQ(g.late(), 1);
}

TEST(SeqGaps, ALoneWildNumberIsNotAMillionLosses) {
  // An extra message numbered a million ahead in the middle of the stream.
  std::vector<std::int64_t> s = Range(0, 1000);
  s.insert(s.begin() + 500, 500 + 1'000'000);
  SeqGaps g = Count(s);
  EXPECT_EQ(g.missing(), 0);
  EXPECT_EQ(g.gaps(), 0);
  EXPECT_EQ(g.wild(), 1);
  EXPECT_EQ(g.restarts(), 0);
  EXPECT_EQ(g.highest(), 999);
  // A message whose own number was damaged: it counts wild, and its own
  // number, which never arrives, is missing.
  std::vector<std::int64_t> d = Range(0, 1000);
  d[500] += 1'000'000;
  g = Count(d);
  EXPECT_EQ(g.wild(), 1);
  EXPECT_EQ(g.missing(), 1);
  EXPECT_EQ(g.gaps(), 1);
  // Far below, alone (a foreign stream's message): wild too.
  std::vector<std::int64_t> b = Range(100'000, 101'000);
  b.insert(b.begin() + 300, 3);
  g = Count(b);
  EXPECT_EQ(g.wild(), 1);
  EXPECT_EQ(g.missing(), 0);
  EXPECT_EQ(g.back(), 1);
}

TEST(SeqGaps, ASenderThatRestartsIsCountedOnceAndCountingGoesOn) {
  // 10 000 messages, then the sender starts again from 0 and loses 7 there.
  std::vector<std::int64_t> s = Range(0, 10'000);
  for (std::int64_t k = 0; k < 500; ++k) {
    if (k != 7) s.push_back(k);
  }
  const SeqGaps g = Count(s);
  EXPECT_EQ(g.restarts(), 1);
  EXPECT_EQ(g.wild(), 0);
  EXPECT_EQ(g.missing(), 1);
  EXPECT_EQ(g.gaps(), 1);
  EXPECT_EQ(g.duplicates(), 0);
  EXPECT_EQ(g.first(), 0);
  EXPECT_EQ(g.highest(), 499);
}

TEST(SeqGaps, AnOutageLongerThanTheWindowIsLoss) {
  // 9 000 numbers skipped (9 s at 1 kHz), the stream going on after them.
  std::vector<std::int64_t> s = Range(0, 1000);
  const std::vector<std::int64_t> after = Range(10'000, 11'000);
  s.insert(s.end(), after.begin(), after.end());
  SeqGaps g = Count(s);
  EXPECT_EQ(g.missing(), 9000);
  EXPECT_EQ(g.gaps(), 1);
  EXPECT_EQ(g.wild(), 0);
  // One of them arriving later, inside the new window, fills its place.
  g.Add(9990);
  EXPECT_EQ(g.missing(), 8999);
  EXPECT_EQ(g.gaps(), 2);
  EXPECT_EQ(g.late(), 1);
  // A far number that nothing follows yet counts wild until the next one.
  SeqGaps h = Count(Range(0, 10));
  h.Add(100'000);
  EXPECT_EQ(h.wild(), 1);
  EXPECT_EQ(h.missing(), 0);
}

TEST(SeqGaps, NumbersAtTheEndsOfTheRangeNeitherOverflowNorWrap) {
  // Numbers come off the wire: the fuzzer sent INT64_MIN then INT64_MAX.
  constexpr std::int64_t kMin = std::numeric_limits<std::int64_t>::min();
  constexpr std::int64_t kMax = std::numeric_limits<std::int64_t>::max();
  SeqGaps g = Count({kMin, kMax, kMin});  // a lone far number, then a repeat
  EXPECT_EQ(g.wild(), 1);
  EXPECT_EQ(g.duplicates(), 1);
  EXPECT_EQ(g.missing(), 0);
  g.Add(kMin + 3);  // skips two
  EXPECT_EQ(g.gaps(), 1);
  EXPECT_EQ(g.missing(), 2);
  // INT64_MIN, then the stream goes on from INT64_MAX - 1: 2^64 - 3 numbers
  // skipped, more than an int64 holds, so `missing` saturates; a late one
  // then leaves it saturated.
  SeqGaps m = Count({kMin, kMax - 1, kMax});
  EXPECT_EQ(m.missing(), kMax);
  EXPECT_EQ(m.gaps(), 1);
  m.Add(kMax - 2);
  EXPECT_EQ(m.missing(), kMax);
  EXPECT_EQ(m.late(), 1);
  // -2 -> 2 crosses zero: skips -1, 0, 1.
  EXPECT_EQ(Count({-2, 2}).missing(), 3);
  EXPECT_EQ(SeqGaps::SaturatingAdd(kMax, -1), kMax);
  EXPECT_EQ(SeqGaps::SaturatingAdd(5, -2), 3);
}

TEST(SeqGaps, NothingSeenIsNotAGap) {
  const SeqGaps g;
  EXPECT_FALSE(g.any());
  EXPECT_EQ(g.gaps() + g.missing() + g.back(), 0);
}

// Random streams: numbers 0..N-1, some lost, neighbours swapped, some sent
// twice, some delayed by up to 2 000 places (inside the window). The count
// must equal the one made from the sets.
TEST(SeqGaps, MissingIsExactOnReorderedAndDuplicatedStreams) {
  for (unsigned seed = 1; seed <= 40; ++seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const std::int64_t n = 20'000;
    std::vector<std::int64_t> sent;
    std::set<std::int64_t> received;
    for (std::int64_t k = 0; k < n; ++k) {
      if (u(rng) < 0.01) continue;  // lost
      sent.push_back(k);
      received.insert(k);
      if (u(rng) < 0.005) sent.push_back(k);  // duplicated
    }
    for (std::size_t i = 0; i + 1 < sent.size(); ++i) {
      if (u(rng) < 0.02) std::swap(sent[i], sent[i + 1]);  // reordered
    }
    for (int d = 0; d < 20; ++d) {  // delayed
      const auto from = static_cast<std::size_t>(u(rng) * static_cast<double>(sent.size() - 2001));
      const std::size_t by = 1 + static_cast<std::size_t>(u(rng) * 1999);
      const std::int64_t v = sent[from];
      sent.erase(sent.begin() + static_cast<std::ptrdiff_t>(from));
      sent.insert(sent.begin() + static_cast<std::ptrdiff_t>(from + by), v);
    }
    const SeqGaps g = Count(sent);
    const std::int64_t first = sent.front();
    const std::int64_t highest = *received.rbegin();
    std::int64_t missing = 0, runs = 0;
    bool in_run = false;
    for (std::int64_t k = first; k <= highest; ++k) {
      const bool lost = received.count(k) == 0;
      missing += lost;
      runs += lost && !in_run;
      in_run = lost;
    }
    const auto duplicates = static_cast<std::int64_t>(sent.size() - received.size());
    ASSERT_EQ(g.missing(), missing) << "seed " << seed;
    ASSERT_EQ(g.gaps(), runs) << "seed " << seed;
    ASSERT_EQ(g.duplicates(), duplicates) << "seed " << seed;
    ASSERT_EQ(g.wild() + g.restarts(), 0) << "seed " << seed;
  }
}

}  // namespace
}  // namespace rocklab::common
