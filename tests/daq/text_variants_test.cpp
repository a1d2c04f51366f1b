// LVM as LabVIEW writes it (NI's "LabVIEW Measurement File (.lvm) Format":
// X_Columns No/One/Multi, a Comment column, empty fields, no
// Decimal_Separator line, Windows-1252 header text, several segments with
// their own X0, rows past Samples, CRLF) and CSV dialects (',', ';', tab,
// decimal comma). Every file is written here, small.
// Oracle: the fixture text: the times are X0 + k Delta_X or the X column as
// written, the values the numbers written (exact in binary where compared
// with ==).
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "daq/source.h"
#include "tests/daq/daq_test_util.h"

namespace rocklab::daq {
namespace {

using Read = test::SourceRead;

Read ReadText(const std::string& name, const std::string& text, char delimiter = 0) {
  SourceOptions opt;
  // An LVM's rate is its Delta_X (a rate given is checked against it);
  // the CSV fixtures without a time column are read at 100 Hz.
  const bool lvm = name.size() > 4 && name.compare(name.size() - 4, 4, ".lvm") == 0;
  opt.sample_rate_hz = lvm ? 0.0 : 100.0;
  opt.delimiter = delimiter;
  Read r = test::ReadSource(test::WriteFile(name, text), opt);
  EXPECT_EQ(r.status, ReadStatus::kEnd) << r.error;
  return r;
}

std::string Joined(const std::vector<std::string>& lines) {
  std::string out;
  for (const auto& l : lines) out += l + "\n";
  return out;
}

const char* kFileHeaderNoX =
    "LabVIEW Measurement\t\nWriter_Version\t2\nReader_Version\t2\nSeparator\tTab\nDecimal_Separator\t.\n"
    "Multi_Headings\tNo\nX_Columns\tNo\nTime_Pref\tRelative\nOperator\tlab\n***End_of_Header***\t\n\n";

// X_Columns No as Write To Measurement File writes it: the X_Value column is
// in the column row but empty in every row (once read as 0 frames of 16 384).
TEST(LvmVariants, XColumnsNoTakesTimeFromX0AndDeltaX) {
  const std::string text = std::string(kFileHeaderNoX) +
                           "Channels\t2\t\nSamples\t3\t3\t\nX0\t1.5000000000000000E+0\t1.5\t\n"
                           "Delta_X\t0.25\t0.25\t\n***End_of_Header***\t\t\n"
                           "X_Value\ta\tb\tComment\n\t1\t2\n\t3\t4\n\t5\t6\n";
  const Read r = ReadText("xno.lvm", text);
  ASSERT_EQ(r.frames.size(), 3u) << (r.problems.empty() ? "" : r.problems[0]);
  EXPECT_EQ(r.names, (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(r.rate_hz, 4.0);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(r.frames[k].time_s, 1.5 + 0.25 * k);
    EXPECT_EQ(r.frames[k].seq, k);
    EXPECT_EQ(r.frames[k].values[0], 1.0 + 2 * k);
  }
  EXPECT_TRUE(r.problems.empty());
  // Without the X_Value column at all: the same.
  const std::string bare = std::string(kFileHeaderNoX) +
                           "Channels\t1\nSamples\t2\nX0\t0\nDelta_X\t0.5\n***End_of_Header***\n"
                           "a\n7\n8\n";
  const Read b = ReadText("xno_bare.lvm", bare);
  ASSERT_EQ(b.frames.size(), 2u);
  EXPECT_EQ(b.frames[1].time_s, 0.5);
  EXPECT_EQ(b.frames[1].values[0], 8.0);
}

// X_Columns Multi: an X column before every channel; the first is the time,
// a row where another disagrees is counted and the first reported.
TEST(LvmVariants, XColumnsMultiUsesTheFirstAndWarnsOnDisagreement) {
  const std::string text = Joined({"LabVIEW Measurement\t", "Separator\tTab", "Decimal_Separator\t.",
                                   "X_Columns\tMulti", "***End_of_Header***", "", "Channels\t2",
                                   "Samples\t3\t3", "X0\t0\t0", "Delta_X\t0.01\t0.01", "***End_of_Header***",
                                   "X_Value\ta\tX_Value\tb\tComment", "0\t1\t0\t10", "0.01\t2\t0.01\t20",
                                   "0.02\t3\t0.05\t30"});
  const Read r = ReadText("multi.lvm", text);
  ASSERT_EQ(r.frames.size(), 3u);
  EXPECT_EQ(r.names, (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(r.frames[2].time_s, 0.02);
  EXPECT_EQ(r.frames[2].values[1], 30.0);
  EXPECT_EQ(r.stats.x_disagreements, 1);
  ASSERT_EQ(r.problems.size(), 1u);
  EXPECT_NE(r.problems[0].find("multi.lvm:15: X column 3 says 0.05 s"), std::string::npos) << r.problems[0];
}

// The Comment column: text in some rows is kept (Frame::comment, counted),
// never a rejected row; a comment with a tab in it stays one comment.
TEST(LvmVariants, CommentTextIsKeptNotRejected) {
  const std::string text = Joined({"LabVIEW Measurement\t", "Separator\tTab", "Decimal_Separator\t.",
                                   "X_Columns\tOne", "***End_of_Header***", "Channels\t2", "Samples\t4\t4",
                                   "Delta_X\t0.01\t0.01", "***End_of_Header***", "X_Value\ta\tb\tComment",
                                   "0\t1\t2\tdrop started", "0.01\t1\t2\t", "0.02\t1\t2", "0.03\t1\t2\tsee\tlog"});
  const Read r = ReadText("comment.lvm", text);
  ASSERT_EQ(r.frames.size(), 4u);
  EXPECT_EQ(r.frames[0].comment, "drop started");
  EXPECT_EQ(r.frames[1].comment, "");
  EXPECT_EQ(r.frames[2].comment, "");
  EXPECT_EQ(r.frames[3].comment, "see\tlog");
  EXPECT_EQ(r.stats.comments, 2);
  EXPECT_EQ(r.stats.bad_rows, 0);
}

// Empty fields (a channel with no data): NaN, counted; one report per column.
TEST(LvmVariants, EmptyFieldsAreNaNAndCounted) {
  const std::string text = Joined({"LabVIEW Measurement\t", "Separator\tTab", "Decimal_Separator\t.",
                                   "***End_of_Header***", "Channels\t2", "Samples\t3\t3", "Delta_X\t1\t1",
                                   "***End_of_Header***", "X_Value\ta\tb", "0\t1\t", "1\t\t", "2\t3\t4"});
  const Read r = ReadText("empty.lvm", text);
  ASSERT_EQ(r.frames.size(), 3u);
  EXPECT_TRUE(std::isnan(r.frames[0].values[1]));
  EXPECT_TRUE(std::isnan(r.frames[1].values[0]));
  EXPECT_EQ(r.frames[2].values[1], 4.0);
  EXPECT_EQ(r.stats.empty_values, 3);
  EXPECT_EQ(r.stats.bad_values, 0);
  EXPECT_EQ(r.problems.size(), 2u);  // the first empty field of a and of b
}

// Writer_Version 0.92: no Decimal_Separator line; the numbers decide (here
// a decimal comma), each field read with '.' first, then ','. Windows-1252
// channel names come out as UTF-8.
TEST(LvmVariants, NoDecimalSeparatorLineAndLatin1Names) {
  const std::string text = Joined({"LabVIEW Measurement\t", "Writer_Version\t0,92", "Separator\tTab",
                                   "***End_of_Header***", "Channels\t2", "Samples\t2\t2", "X0\t0,5\t0,5",
                                   "Delta_X\t0,125\t0,125", "***End_of_Header***",
                                   "X_Value\tPress\xE3o\tTemp \xB0" "C", "0,5\t1,25\t20", "0,625\t-2,5\t21.5"});
  const Read r = ReadText("v092.lvm", text);
  ASSERT_EQ(r.frames.size(), 2u) << (r.problems.empty() ? "" : r.problems[0]);
  EXPECT_EQ(r.names, (std::vector<std::string>{"Press\xC3\xA3o", "Temp \xC2\xB0" "C"}));
  EXPECT_EQ(r.rate_hz, 8.0);
  EXPECT_EQ(r.frames[1].time_s, 0.625);
  EXPECT_EQ(r.frames[0].values[0], 1.25);
  EXPECT_EQ(r.frames[1].values[0], -2.5);
  EXPECT_EQ(r.frames[1].values[1], 21.5);  // a '.' still reads
}

// Several segments with their own X0 (and Samples), CRLF line ends, and a
// segment whose rows run past its Samples (warned, kept).
TEST(LvmVariants, SegmentsWithTheirOwnX0CrlfAndRowsPastSamples) {
  std::string text = std::string(kFileHeaderNoX) +
                     "Channels\t1\nSamples\t2\nX0\t0\nDelta_X\t0.5\n***End_of_Header***\nX_Value\ta\tComment\n"
                     "\t1\n\t2\n\t3\n"
                     "Channels\t1\nSamples\t2\nX0\t10\nDelta_X\t0.5\n***End_of_Header***\nX_Value\ta\tComment\n"
                     "\t4\n\t5\n";
  std::string crlf;
  for (char c : text) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
  const Read r = ReadText("segments.lvm", crlf);
  ASSERT_EQ(r.frames.size(), 5u) << (r.problems.empty() ? "" : r.problems[0]);
  const double times[5] = {0, 0.5, 1.0, 10.0, 10.5};
  for (int k = 0; k < 5; ++k) {
    EXPECT_EQ(r.frames[k].time_s, times[k]);
    EXPECT_EQ(r.frames[k].values[0], k + 1.0);
  }
  EXPECT_EQ(r.frames[3].seq, 20);  // the sample clock jumped with X0: a gap of 18 samples
  EXPECT_EQ(r.stats.warnings, 1);
  ASSERT_EQ(r.problems.size(), 1u);
  EXPECT_NE(r.problems[0].find("Samples 2 but it has 3 rows (the rows are used)"), std::string::npos);
}

// CSV dialects: the separator sniffed from the header line (or given), a
// decimal comma with ';' or tab.
TEST(CsvDialects, SemicolonAndTabWithDecimalCommaAndAGivenDelimiter) {
  const Read semi = ReadText("semi.csv", "time;a;b\n0;1,5;2\n0,01;-3,25;4.5\n");
  ASSERT_EQ(semi.frames.size(), 2u);
  EXPECT_EQ(semi.names, (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(semi.frames[1].time_s, 0.01);
  EXPECT_EQ(semi.frames[0].values[0], 1.5);
  EXPECT_EQ(semi.frames[1].values[0], -3.25);
  EXPECT_EQ(semi.frames[1].values[1], 4.5);

  const Read tab = ReadText("tab.csv", "time\ta\n0\t0,25\n0,01\t0,5\n");
  ASSERT_EQ(tab.frames.size(), 2u);
  EXPECT_EQ(tab.frames[1].values[0], 0.5);
  EXPECT_EQ(tab.frames[1].seq, 1);

  const Read comma = ReadText("comma.csv", "time,a,b\n0,1.5,2\n");
  ASSERT_EQ(comma.frames.size(), 1u);
  EXPECT_EQ(comma.frames[0].values[0], 1.5);

  // Given: a header "a;b" read with ',' is one column named "a;b".
  const Read given = ReadText("given.csv", "time,a;b\n0,1\n", ',');
  ASSERT_EQ(given.names, (std::vector<std::string>{"a;b"}));
  EXPECT_EQ(given.frames.size(), 1u);
}

}  // namespace
}  // namespace rocklab::daq
