// Text helpers: Trim and whole-field number parsing (record and variant
// readers). Oracle: the documented contract on hand-picked fields.
#include "common/text.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/ring.h"
#include "common/units.h"

namespace rocklab::common {
namespace {

TEST(Text, TrimRemovesSurroundingBlanksOnly) {
  EXPECT_EQ(Trim("  a b\t\r\n"), "a b");
  EXPECT_EQ(Trim(" \t "), "");
  EXPECT_EQ(Trim("x"), "x");
}

TEST(Text, ParseDoubleTakesWholeFieldsOnly) {
  double v = 0;
  EXPECT_TRUE(ParseDouble("1e3", v));
  EXPECT_EQ(v, 1000.0);
  EXPECT_TRUE(ParseDouble("-0.25", v));
  EXPECT_EQ(v, -0.25);
  EXPECT_TRUE(ParseDouble("nan", v));
  EXPECT_TRUE(std::isnan(v));
  EXPECT_FALSE(ParseDouble("", v));
  EXPECT_FALSE(ParseDouble("2x", v));
  EXPECT_FALSE(ParseDouble("1,5", v));
}

// Oracle: a ring of capacity 3 keeps the newest 3, oldest first, and says
// when it overwrote.
TEST(Ring, KeepsTheNewestOldestFirst) {
  Ring<int> r(3);
  EXPECT_TRUE(r.push_back(1));
  EXPECT_TRUE(r.push_back(2));
  EXPECT_TRUE(r.push_back(3));
  EXPECT_FALSE(r.push_back(4));
  ASSERT_EQ(r.size(), 3u);
  EXPECT_EQ(r.front(), 2);
  EXPECT_EQ(r.back(), 4);
  r.pop_front();
  EXPECT_EQ(r[0], 3);
  r.clear();
  EXPECT_TRUE(r.empty());
}

// Oracle: 180 degrees is pi radians.
TEST(Units, DegreesPerRadian) { EXPECT_DOUBLE_EQ(kPi * kDegPerRad, 180.0); }

}  // namespace
}  // namespace rocklab::common
