// common::SeqGaps: the gap accounting of the model and compare nodes and the
// recorder. Oracle: counts made by hand for each sequence below.
#include "common/seq_gaps.h"

#include <gtest/gtest.h>

#include <limits>

namespace rocklab::common {
namespace {

SeqGaps Count(std::initializer_list<std::int64_t> seqs) {
  SeqGaps g;
  for (std::int64_t s : seqs) g.Add(s);
  return g;
}

TEST(SeqGaps, AnUnbrokenStreamHasNoGap) {
  const SeqGaps g = Count({7, 8, 9, 10});
  EXPECT_TRUE(g.any);
  EXPECT_EQ(g.first, 7);
  EXPECT_EQ(g.last, 10);
  EXPECT_EQ(g.gaps, 0);
  EXPECT_EQ(g.missing, 0);
  EXPECT_EQ(g.back, 0);
}

TEST(SeqGaps, ForwardJumpsCountGapsAndTheNumbersSkipped) {
  // 0 -> 3 skips 1, 2; 4 -> 9 skips 5..8: two gaps, six missing.
  const SeqGaps g = Count({0, 3, 4, 9});
  EXPECT_EQ(g.gaps, 2);
  EXPECT_EQ(g.missing, 6);
  EXPECT_EQ(g.back, 0);
}

TEST(SeqGaps, RepeatsAndStepsBackAreCountedApartAndTheCountGoesOnFromThem) {
  // 5 again (a duplicate), then 2 (a restart), then 3, then 6 (skips 4, 5).
  const SeqGaps g = Count({4, 5, 5, 2, 3, 6});
  EXPECT_EQ(g.back, 2);
  EXPECT_EQ(g.gaps, 1);
  EXPECT_EQ(g.missing, 2);
  EXPECT_EQ(g.last, 6);
}

TEST(SeqGaps, NumbersAtTheEndsOfTheRangeNeitherOverflowNorWrap) {
  // Numbers come off the wire: the fuzzer sent INT64_MIN then INT64_MAX.
  // The jump is 2^64 - 1, so 2^64 - 2 numbers were skipped: more than an
  // int64 holds, so `missing` saturates at INT64_MAX; then a step back.
  constexpr std::int64_t kMin = std::numeric_limits<std::int64_t>::min();
  constexpr std::int64_t kMax = std::numeric_limits<std::int64_t>::max();
  SeqGaps g = Count({kMin, kMax, kMin});
  EXPECT_EQ(g.gaps, 1);
  EXPECT_EQ(g.missing, kMax);
  EXPECT_EQ(g.back, 1);
  g.Add(kMin + 3);  // skips two more: still saturated, one more gap
  EXPECT_EQ(g.gaps, 2);
  EXPECT_EQ(g.missing, kMax);
  // -2 -> 2 crosses zero: skips -1, 0, 1.
  const SeqGaps z = Count({-2, 2});
  EXPECT_EQ(z.missing, 3);
}

TEST(SeqGaps, NothingSeenIsNotAGap) {
  const SeqGaps g;
  EXPECT_FALSE(g.any);
  EXPECT_EQ(g.gaps + g.missing + g.back, 0);
}

}  // namespace
}  // namespace rocklab::common
