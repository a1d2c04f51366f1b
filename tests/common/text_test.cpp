// Text helpers: Trim and whole-field number parsing (record and variant
// readers). Oracle: the documented contract on hand-picked fields.
#include "common/text.h"

#include "common/logger_clock.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <string_view>
#include <vector>

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

// Oracle: the contract of the DAQ's allocation-free parsing: a decimal
// comma swaps the separators, a leading '+' is accepted, a value out of
// range or longer than 64 bytes is not a number.
TEST(Text, ParseNumberDecimalCommaAndBounds) {
  double v = 0;
  EXPECT_TRUE(ParseNumber(" 1,5 ", true, v));
  EXPECT_EQ(v, 1.5);
  EXPECT_FALSE(ParseNumber("1.5", true, v));
  EXPECT_TRUE(ParseNumber("+2", false, v));
  EXPECT_EQ(v, 2.0);
  EXPECT_FALSE(ParseNumber("1e999", false, v));
  EXPECT_FALSE(ParseNumber(std::string(65, '1'), false, v));
}

// Oracle: Split keeps empty fields (n separators give n + 1 fields).
TEST(Text, SplitKeepsEmptyFields) {
  std::vector<std::string_view> fields;
  Split("a,,b,", ',', fields);
  EXPECT_EQ(fields, (std::vector<std::string_view>{"a", "", "b", ""}));
  EXPECT_TRUE(HasExtension("run.LVM", ".lvm"));
  EXPECT_FALSE(HasExtension("lvm", ".lvm"));
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

// Oracle: the Unicode encodings of the characters (RFC 3629) and the
// Windows-1252 code chart (0x80 is the euro sign U+20AC, 0x81 undefined).
TEST(TextTest, Utf8CheckAndWindows1252Transcoding) {
  EXPECT_TRUE(IsUtf8("Press\xC3\xA3o \xC2\xB0" "C \xE2\x82\xAC \xF0\x9F\x98\x80"));
  EXPECT_FALSE(IsUtf8("Press\xE3o"));         // Latin-1
  EXPECT_FALSE(IsUtf8("\xC0\xAF"));           // overlong '/'
  EXPECT_FALSE(IsUtf8("\xED\xA0\x80"));       // a surrogate
  EXPECT_FALSE(IsUtf8("\xE2\x82"));           // cut short
  EXPECT_EQ(ToUtf8("Press\xE3o \xB0" "C"), "Press\xC3\xA3o \xC2\xB0" "C");
  EXPECT_EQ(ToUtf8("\x80\x81"), "\xE2\x82\xAC\xEF\xBF\xBD");
  EXPECT_EQ(ToUtf8("already \xC2\xB0"), "already \xC2\xB0");
}

// Oracle: the rule (most frequent of tab, ';', ','; ties in that order).
TEST(TextTest, SniffDelimiter) {
  EXPECT_EQ(SniffDelimiter("time,a,b"), ',');
  EXPECT_EQ(SniffDelimiter("time;a;b"), ';');
  EXPECT_EQ(SniffDelimiter("time\ta\tb"), '\t');
  EXPECT_EQ(SniffDelimiter("time;a,1;b,2"), ';');  // a tie: ';' before ','
  EXPECT_EQ(SniffDelimiter("time"), ',');
}

// Oracle: RFC 3629's well-formed sequences; the offset is that of the first
// byte of the first sequence that is not one (the rig file's
// message names it).
TEST(TextTest, Utf8ValidPrefixStopsAtTheFirstBadSequence) {
  EXPECT_EQ(Utf8ValidPrefix("abc"), 3u);
  EXPECT_EQ(Utf8ValidPrefix("\xC2\xB0" "C"), 3u);
  EXPECT_EQ(Utf8ValidPrefix("ab\x80"), 2u);             // lone continuation
  EXPECT_EQ(Utf8ValidPrefix("a\xC0\x80"), 1u);          // overlong NUL
  EXPECT_EQ(Utf8ValidPrefix("\xED\xA0\x80"), 0u);      // surrogate
  EXPECT_EQ(Utf8ValidPrefix("x\xF4\x90\x80\x80"), 1u);  // past U+10FFFF
  EXPECT_EQ(Utf8ValidPrefix("xy\xE2\x82"), 2u);         // cut by the end
}

// Oracle: Quote's escaping without its quotes or bound.
TEST(TextTest, EscapeLeavesPrintableAsciiAndEscapesTheRest) {
  EXPECT_EQ(Escape("it's a \\ \x1b[2J\x07\xC3\xA9"), "it's a \\\\ \\x1b[2J\\x07\\xc3\\xa9");
  EXPECT_EQ(Escape(std::string(100, 'a')), std::string(100, 'a'));
}

// Oracle: the escape rule of docs/reliability.md written out byte by byte:
// ESC, NUL, TAB, LF, DEL, a C1 control (U+009B, a terminal's CSI), a
// right-to-left override (U+202E) and a lone continuation byte become \xNN;
// printable ASCII, backslash and well-formed UTF-8 (U+00E9, U+00B0) stay.
TEST(TextTest, PrintableEscapesControlBytesAndKeepsUtf8) {
  const std::string hostile = std::string("a\x1b[2J\0b\t\n\x7f", 10) + "\xC2\x9B" "1m\xE2\x80\xAE" "x\x80 \\ caf\xC3\xA9 \xC2\xB0" "C";
  EXPECT_EQ(Printable(hostile), "a\\x1b[2J\\x00b\\x09\\x0a\\x7f\\xc2\\x9b1m\\xe2\\x80\\xaex\\x80 \\ caf\xC3\xA9 \xC2\xB0" "C");
  const std::string once = Printable(hostile);
  EXPECT_EQ(Printable(once), once);  // escapes are not escaped again
  EXPECT_TRUE(IsUtf8(once));
  EXPECT_EQ(Printable(std::string("\xF0\x9F\x98", 3)), "\\xf0\\x9f\\x98");  // cut sequence
}

// Oracle: 10 000 bytes cut at 100 leave 9 900 out; a 2-byte character that
// straddles the limit is left out whole (99 kept, 9 901 more).
TEST(TextTest, PrintableCutsALongLineAndCountsTheBytesLeftOut) {
  EXPECT_EQ(Printable(std::string(10000, 'a'), 100), std::string(100, 'a') + " ... [9900 bytes more]");
  const std::string straddle = std::string(99, 'a') + "\xC3\xA9" + std::string(9899, 'b');
  EXPECT_EQ(Printable(straddle, 100), std::string(99, 'a') + " ... [9901 bytes more]");
  EXPECT_EQ(Printable(std::string(kMaxLineBytes, 'a')), std::string(kMaxLineBytes, 'a'));
  EXPECT_EQ(Printable(std::string(kMaxLineBytes + 1, 'a')), std::string(kMaxLineBytes, 'a') + " ... [1 bytes more]");
  EXPECT_EQ(Quote(std::string(100, 'a'), 10), "'aaaaaaaaaa' ... [90 bytes more]");
}

// Oracle: the message's own line breaks stay; each line is escaped and cut
// on its own.
TEST(TextTest, PrintableLinesKeepsLineBreaksAndCutsEachLine) {
  EXPECT_EQ(PrintableLines("one\x1b\ntwo\r\n" + std::string(20, 'x'), 10),
            "one\\x1b\ntwo\\x0d\n" + std::string(10, 'x') + " ... [10 bytes more]");
}

// Oracle: the bytes a module's logger writes to stderr for a warning that
// quotes hostile input hold no control byte but the final newline.
TEST(TextTest, NamedLoggerEscapesTheMessage) {
  auto logger = NamedLogger("text_test_printable");
  testing::internal::CaptureStderr();
  logger->warn("channel {} went quiet", std::string("RL_\x1b]0;pwned\x07\nX"));
  logger->flush();
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("channel RL_\\x1b]0;pwned\\x07\\x0aX went quiet\n"), std::string::npos) << err;
  for (std::size_t i = 0; i + 1 < err.size(); ++i) {
    EXPECT_FALSE(static_cast<unsigned char>(err[i]) < 0x20 && err[i] != '\x1b') << "byte " << i << " of " << err;
  }
}

// Oracle: the text with the registered path replaced, every occurrence;
// text without it unchanged (the path is this test's own, unlike any other).
TEST(TextTest, ShowPathAsNamesATemporaryAsWhatWasGiven) {
  const std::string temp = "/tmp/rocklab-stdin-TextTest/stdin.csv";
  EXPECT_EQ(Printable("x " + temp + ":3"), "x " + temp + ":3");
  ShowPathAs(temp, "<stdin>");
  EXPECT_EQ(Printable("RECORD: " + temp + ":3: 'abc' is not a number"), "RECORD: <stdin>:3: 'abc' is not a number");
  EXPECT_EQ(PrintableLines(temp + "\n" + temp + " and " + temp), "<stdin>\n<stdin> and <stdin>");
  EXPECT_EQ(WithPathsShown(temp), "<stdin>");
  EXPECT_EQ(Printable("/tmp/rocklab-stdin-TextTest/stdin.cs"), "/tmp/rocklab-stdin-TextTest/stdin.cs");
  EXPECT_EQ(Printable(std::string("\x1b") + temp), "\\x1b<stdin>");  // still escaped
}

}  // namespace
}  // namespace rocklab::common
