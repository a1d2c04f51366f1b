// Sources: CSV, LabVIEW .lvm and LCM logs deliver the values written in small
// hand-made fixtures (oracle: the fixture text), and malformed input gives a
// clear start-up error or a reported, counted problem with file and line,
// never a crash.
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>
#include <string_view>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include "daq/processor.h"
#include "daq/source.h"
#include "rocklab/daq_config2_t.hpp"
#include "rocklab/raw_frame_t.hpp"
#include "tests/daq/daq_test_util.h"

namespace rocklab::daq {
namespace {

using Read = test::SourceRead;

Read ReadAll(const std::string& path, double rate_hz = 100.0) {
  SourceOptions opt;
  opt.sample_rate_hz = rate_hz;
  return test::ReadSource(path, opt);
}

std::string StartupError(const std::string& path) {
  try {
    ReadAll(path);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "no error";
}

TEST(CsvSource, TimeColumnAndValues) {
  const std::string path = test::WriteFile("a.csv", "time,a,b\n0.5,1,2\n0.51,-3.5e-1,+4\n");
  const Read r = ReadAll(path);
  EXPECT_EQ(r.names, (std::vector<std::string>{"a", "b"}));
  ASSERT_EQ(r.frames.size(), 2u);
  EXPECT_EQ(r.frames[1].seq, 1);
  EXPECT_EQ(r.frames[1].time_s, 0.51);
  EXPECT_EQ(r.frames[1].utime(), 510000);
  EXPECT_EQ(r.frames[1].values, (std::vector<double>{-0.35, 4.0}));
  EXPECT_EQ(r.frames[1].line, 3);
  EXPECT_TRUE(r.problems.empty());
}

// The reader parses the common field ("-0.002780544641", "800.5184524") on
// its own fast path and everything else through common::ParseNumber. Oracle:
// std::from_chars on the same text, bit for bit, over random fields of
// every shape the fast path takes or declines (up to 21 digits, leading
// zeros, signs, exponents, a trailing point), and rows long enough that
// many straddle the reader's 256 KiB blocks (checked by their count).
TEST(CsvSource, NumbersAreReadAsFromCharsReadsThem) {
  std::mt19937_64 rng(15);
  std::ostringstream csv;
  csv << "time,a,b,c\n";
  std::vector<std::vector<std::string>> fields;
  const char* const signs[] = {"", "-", "+"};
  for (int row = 0; row < 40000; ++row) {
    std::vector<std::string> f(3);
    for (auto& text : f) {
      text = signs[rng() % 3];
      const int before = static_cast<int>(rng() % 8);
      const int after = static_cast<int>(rng() % 14);
      for (int i = 0; i < before + 1; ++i) text += static_cast<char>('0' + rng() % 10);
      if (after > 0) text += '.';
      for (int i = 0; i < after; ++i) text += static_cast<char>('0' + rng() % 10);
      if (rng() % 16 == 0) text += "e-" + std::to_string(rng() % 30);
    }
    csv << row * 0.001 << "," << f[0] << "," << f[1] << "," << f[2] << "\n";
    fields.push_back(std::move(f));
  }
  const std::string text = csv.str();
  ASSERT_GT(text.size(), 3u * 256 * 1024);
  const Read r = ReadAll(test::WriteFile("numbers.csv", text), 1000.0);
  ASSERT_EQ(r.frames.size(), fields.size());
  EXPECT_TRUE(r.problems.empty());
  for (size_t row = 0; row < fields.size(); ++row) {
    for (size_t c = 0; c < 3; ++c) {
      std::string_view f = fields[row][c];
      if (f.front() == '+') f.remove_prefix(1);
      double expected = 0;
      const auto res = std::from_chars(f.data(), f.data() + f.size(), expected);
      ASSERT_TRUE(res.ec == std::errc() && res.ptr == f.data() + f.size()) << fields[row][c];
      const double got = r.frames[row].values[c];
      ASSERT_EQ(std::memcmp(&got, &expected, sizeof got), 0)
          << "row " << row << " column " << c << ": " << fields[row][c] << " read as " << got;
    }
  }
}

// A line that straddles two blocks, one longer than a block, and a last
// line without its newline come out whole, with their line numbers.
TEST(CsvSource, LinesAcrossBlocksComeOutWhole) {
  const std::string pad(300 * 1024, ' ');  // blanks around a number are allowed
  const std::string text = "time,a\n0," + pad + "1\n0.001,2" + pad + "\n" + std::string(200 * 1024, '\n') +
                           "0.002,3\n0.003,4";
  const Read r = ReadAll(test::WriteFile("blocks.csv", text), 1000.0);
  ASSERT_EQ(r.frames.size(), 4u);
  EXPECT_EQ(r.frames[0].values[0], 1.0);
  EXPECT_EQ(r.frames[1].values[0], 2.0);
  EXPECT_EQ(r.frames[2].values[0], 3.0);
  EXPECT_EQ(r.frames[3].values[0], 4.0);
  EXPECT_EQ(r.frames[3].line, 4 + 200 * 1024 + 1);
  EXPECT_TRUE(r.problems.empty());
}

TEST(CsvSource, NoTimeColumnUsesTheRigRate) {
  const std::string path = test::WriteFile("b.csv", "a\r\n1\r\n2\r\n3\r\n");
  const Read r = ReadAll(path, 250.0);
  ASSERT_EQ(r.frames.size(), 3u);
  EXPECT_EQ(r.frames[2].seq, 2);
  EXPECT_EQ(r.frames[2].time_s, 2 / 250.0);
  EXPECT_EQ(r.frames[2].values[0], 3.0);
}

// Without a given rate, a CSV's time column gives it. Oracle: the fixture's
// step, 4 ms = 250 Hz (exact in the text; the dropped row at 1.008 s is a
// gap of one sample, not a step of 8 ms).
TEST(CsvSource, RateFromTheTimeColumnWhenNoneIsGiven) {
  const std::string path = test::WriteFile("rate.csv", "time,a\n1,1\n1.004,2\n1.012,3\n1.016,4\n");
  const Read r = ReadAll(path, 0.0);
  EXPECT_TRUE(r.problems.empty());
  EXPECT_NEAR(r.rate_hz, 250.0, 1e-9);  // 3 steps over 1.016 - 1 in doubles: 1e-14 relative
  ASSERT_EQ(r.frames.size(), 4u);
  EXPECT_EQ(r.frames[2].seq, 3);
  EXPECT_EQ(r.frames[2].line, 4);
  EXPECT_EQ(r.frames[3].seq, 4);
  EXPECT_EQ(r.frames[3].values[0], 4.0);
}

// More rows than the read-ahead: every row is delivered once, in order,
// with its line, and the rate is the time column's. Oracle: the rows
// written (k ms, value k), 1 kHz.
TEST(CsvSource, RowsReadAheadForTheRateAreDeliveredOnceInOrder) {
  std::ostringstream csv;
  csv << "time,a\n";
  for (int k = 0; k < 1000; ++k) csv << k * 0.001 << "," << k << "\n";
  const Read r = ReadAll(test::WriteFile("ahead.csv", csv.str()), 0.0);
  EXPECT_TRUE(r.problems.empty());
  EXPECT_NEAR(r.rate_hz, 1000.0, 1e-6);  // times printed to 6 digits: steps exact to ~1e-15 s
  ASSERT_EQ(r.frames.size(), 1000u);
  for (int k = 0; k < 1000; ++k) {
    ASSERT_EQ(r.frames[k].values[0], k);
    ASSERT_EQ(r.frames[k].seq, k);
    ASSERT_EQ(r.frames[k].line, k + 2);
  }
}

// A given rate is checked against the time column: off by more than 0.1 %
// it stops the read at the start, naming both; within, it is used.
TEST(CsvSource, AGivenRateDisagreeingWithTheTimeColumnIsAnError) {
  const std::string path = test::WriteFile("rate2.csv", "time,a\n0,1\n0.001,2\n0.002,3\n");
  SourceOptions opt;
  opt.sample_rate_hz = 500;
  opt.rate_origin = "--rate";
  try {
    test::ReadSource(path, opt);
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), path + ":4: the time column gives a sample rate of 1000 Hz, but --rate is "
                                            "500 Hz (they must agree within 0.1 %)");
  }
  opt.sample_rate_hz = 1000.5;  // 0.05 %: agrees, and is the rate used
  const Read r = test::ReadSource(path, opt);
  EXPECT_EQ(r.rate_hz, 1000.5);
  EXPECT_EQ(r.frames.size(), 3u);
}

TEST(CsvSource, WithoutATimeColumnTheRateMustBeGiven) {
  const std::string path = test::WriteFile("norate.csv", "a\n1\n2\n");
  try {
    ReadAll(path, 0.0);
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              path + ":1: no time column: the sample rate must be given (--rate, or the rig's sample_rate_hz)");
  }
  const std::string one = test::WriteFile("onerow.csv", "time,a\n0,1\n");
  try {
    ReadAll(one, 0.0);
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("fewer than two increasing times"), std::string::npos) << e.what();
  }
  EXPECT_EQ(ReadAll(one, 100.0).frames.size(), 1u);  // a given rate: nothing to check it against
  // A header and no rows (found by fuzz_csv): no rate to take, so no source
  // that claims one.
  const std::string empty = test::WriteFile("headeronly.csv", "time,a\n");
  try {
    ReadAll(empty, 0.0);
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), empty + ":1: no data rows after the header: the sample rate cannot be taken "
                                             "from it; give it (--rate, or the rig's sample_rate_hz)");
  }
  EXPECT_EQ(ReadAll(empty, 100.0).frames.size(), 0u);
}

TEST(CsvSource, MalformedRowsAreReportedCountedAndSkipped) {
  const std::string path = test::WriteFile(
      "bad.csv", "time,a,b\n0.00,1,2\n0.01,1\n0.02,x7,2\n0.03,nan,2\nzzz,1,2\n0.05,1,2\n0.06,1");
  const Read r = ReadAll(path);
  // Kept: lines 2, 4 (a = NaN, reported), 5 (a = NaN, a missing-sample
  // marker, not a problem), 7. Skipped: 3 (ragged), 6 (bad time), 8 (truncated).
  ASSERT_EQ(r.frames.size(), 4u);
  EXPECT_TRUE(std::isnan(r.frames[1].values[0]));
  EXPECT_TRUE(std::isnan(r.frames[2].values[0]));
  EXPECT_EQ(r.frames[3].seq, 5);  // the skipped rows show as a gap
  EXPECT_EQ(r.stats.rows, 7);
  EXPECT_EQ(r.stats.bad_rows, 3);
  EXPECT_EQ(r.stats.bad_values, 1);
  ASSERT_EQ(r.problems.size(), 4u);
  EXPECT_EQ(r.problems[0], path + ":3: row has 2 fields, the header has 3 (row skipped)");
  EXPECT_EQ(r.problems[1], path + ":4: column 'a': 'x7' is not a number (sample set to NaN)");
  EXPECT_EQ(r.problems[2], path + ":6: time 'zzz' is not a finite number (row skipped)");
  EXPECT_EQ(r.problems[3], path + ":8: row has 2 fields, the header has 3 (row skipped)");
}

TEST(CsvSource, EmptyAndHeaderlessFilesAreStartUpErrors) {
  const std::string empty = test::WriteFile("empty.csv", "");
  EXPECT_EQ(StartupError(empty), empty + ":0: empty file: expected a header row");
  const std::string nohead = test::WriteFile("nohead.csv", "0.1,2\n");
  EXPECT_EQ(StartupError(nohead), nohead + ":1: no header row: column name '0.1' is a number");
  EXPECT_EQ(StartupError("/nonexistent/x.csv"), "/nonexistent/x.csv: cannot open the input file");
  // Header only: a valid, empty record.
  EXPECT_TRUE(ReadAll(test::WriteFile("head.csv", "time,a\n")).frames.empty());
}

TEST(CsvSource, TimeGoingBackwardsIsReportedByTheProcessorWithItsLine) {
  RigConfig rig = ParseRigConfig(
      "name = \"r\"\nsample_rate_hz = 100\n[block]\nwidth_m = 0.2\nheight_m = 0.8\n"
      "[mirror]\nlever_m = 1.0\n[[channel]]\nname = \"s\"\nsensor = \"mirror.s\"\n",
      "rig.toml");
  const std::string path = test::WriteFile("back.csv", "time,s\n0.00,0\n0.01,0\n0.02,0\n0.01,0\n0.03,0\n0.03,0\n");
  SourceOptions opt;
  opt.sample_rate_hz = 100;
  auto source = OpenSource(path, opt);
  test::CollectSink sink;
  Processor proc(rig, source->channel_names(), path, sink);
  Frame f;
  while (source->Next(f) == ReadStatus::kFrame) proc.Process(f);
  proc.Finish();
  EXPECT_EQ(proc.sequence().out_of_order, 1);
  EXPECT_EQ(proc.sequence().duplicates, 1);
  EXPECT_EQ(proc.counts().rejected, 2);
  EXPECT_EQ(sink.block.size(), 4u);  // every in-order frame, none reordered
  ASSERT_EQ(sink.problem_text.size(), 2u);
  EXPECT_EQ(sink.problem_text[0].rfind(path + ":5: frame seq 1 at t = 0.01 s is out of order", 0), 0u);
  EXPECT_EQ(sink.problem_text[1].rfind(path + ":7: frame seq 3 at t = 0.03 s is duplicate", 0), 0u);
}

const char* kLvm =
    "LabVIEW Measurement\t\n"
    "Writer_Version\t2\n"
    "Reader_Version\t2\n"
    "Separator\tTab\n"
    "Decimal_Separator\t,\n"
    "Multi_Headings\tNo\n"
    "X_Columns\tOne\n"
    "Time_Pref\tRelative\n"
    "***End_of_Header***\t\n"
    "\t\n"
    "Channels\t2\t\n"
    "Samples\t3\t3\t\n"
    "X0\t0,0000000000000000E+0\t0,0000000000000000E+0\t\n"
    "Delta_X\t0,010000\t0,010000\t\n"
    "***End_of_Header***\t\n"
    "X_Value\ta\tb\tComment\n"
    "0,000000\t1,5\t-2,25\t\n"
    "0,010000\t1,6\t-2,5\n"
    "0,020000\t1,7\t-2,75\t\n"
    "\t\n"
    "Channels\t2\t\n"
    "Samples\t5\t5\t\n"  // disagrees with the 2 rows below
    "X0\t3,0000000000000000E-2\t3,0000000000000000E-2\t\n"
    "Delta_X\t0,010000\t0,010000\t\n"
    "***End_of_Header***\t\n"
    "X_Value\ta\tb\tComment\n"
    "0,030000\t1,8\t-3\t\n"
    "0,050000\t1.9\t-3,5\t\n";

TEST(LvmSource, DecimalCommaTwoSegmentsAndSamplesMismatch) {
  const std::string path = test::WriteFile("two.lvm", kLvm);
  const Read r = ReadAll(path, 0.0);  // no rate given: the file's Delta_X
  EXPECT_EQ(r.names, (std::vector<std::string>{"a", "b"}));
  ASSERT_EQ(r.frames.size(), 5u);
  EXPECT_EQ(r.frames[0].values, (std::vector<double>{1.5, -2.25}));
  EXPECT_EQ(r.frames[3].seq, 3);
  EXPECT_DOUBLE_EQ(r.frames[3].time_s, 0.03);
  EXPECT_EQ(r.frames[3].line, 27);
  EXPECT_EQ(r.frames[4].seq, 5);  // 0.04 s is missing: a gap downstream
  EXPECT_TRUE(std::isnan(r.frames[4].values[0]));  // "1.9" is not a number with decimal comma
  EXPECT_EQ(r.frames[4].values[1], -3.5);
  EXPECT_EQ(r.stats.bad_values, 1);
  EXPECT_EQ(r.stats.warnings, 1);
  ASSERT_EQ(r.problems.size(), 2u);
  EXPECT_EQ(r.problems[0], path + ":28: column 'a': '1.9' is not a number (sample set to NaN)");
  EXPECT_EQ(r.problems[1].rfind(path + ":28: segment 2 header says Samples 5 but it has 2 rows", 0), 0u);
}

// A given rate is checked against the LVM's Delta_X (0.01 s: 100 Hz).
TEST(LvmSource, AGivenRateDisagreeingWithDeltaXIsAnError) {
  const std::string path = test::WriteFile("rate.lvm", kLvm);
  SourceOptions opt;
  opt.sample_rate_hz = 1000;
  opt.rate_origin = "the rig's sample_rate_hz";
  std::string error = "no error";
  try {
    error = test::ReadSource(path, opt).error;
  } catch (const std::runtime_error& e) {
    error = e.what();
  }
  EXPECT_NE(error.find("the file's Delta_X gives a sample rate of 100 Hz, but the rig's sample_rate_hz is 1000 Hz"),
            std::string::npos)
      << error;
  opt.sample_rate_hz = 100;
  EXPECT_EQ(test::ReadSource(path, opt).frames.size(), 5u);
}

TEST(LvmSource, NoXColumnUsesX0AndDeltaX) {
  std::string text = kLvm;
  text = text.substr(0, text.find("\t\nChannels\t2\t\nSamples\t5"));
  for (std::string from : {"X_Value\t", "0,000000\t", "0,010000\t1", "0,020000\t"}) {
    const size_t at = text.find(from);
    text.erase(at, from.back() == '1' ? from.size() - 1 : from.size());
  }
  text.replace(text.find("X_Columns\tOne"), 13, "X_Columns\tNo");
  text.replace(text.find("X0\t0,0000000000000000E+0"), 24, "X0\t2,5");
  const std::string path = test::WriteFile("nox.lvm", text);
  const Read r = ReadAll(path);
  ASSERT_EQ(r.frames.size(), 3u);
  EXPECT_DOUBLE_EQ(r.frames[2].time_s, 2.52);
  EXPECT_EQ(r.frames[2].seq, 2);
  EXPECT_EQ(r.frames[2].values, (std::vector<double>{1.7, -2.75}));
}

TEST(LvmSource, TruncatedHeadersAreStartUpErrors) {
  const std::string text = kLvm;
  const std::string head = test::WriteFile("trunc1.lvm", text.substr(0, text.find("***End")));
  EXPECT_EQ(StartupError(head), head + ":8: truncated file header: no ***End_of_Header***");
  const std::string seg = test::WriteFile("trunc2.lvm", text.substr(0, text.find("Delta_X")));
  EXPECT_EQ(StartupError(seg), seg + ":13: truncated segment header: no ***End_of_Header***");
  const std::string empty = test::WriteFile("empty.lvm", "");
  EXPECT_EQ(StartupError(empty), empty + ":0: empty file: expected 'LabVIEW Measurement'");
}

TEST(LcmLogSource, ReadsRawFramesWithTheLoggedChannelNames) {
  const std::string path = test::ScratchDir() + "/raw.lcmlog";
  {
    lcm::LogFile log(path, "w");
    ASSERT_TRUE(log.good());
    auto write = [&log](const std::string& channel, const auto& msg, int64_t t) {
      std::vector<uint8_t> buf(msg.getEncodedSize());
      msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
      lcm::LogEvent ev;
      ev.timestamp = t;
      ev.channel = channel;
      ev.datalen = static_cast<int32_t>(buf.size());
      ev.data = buf.data();
      ASSERT_EQ(log.writeEvent(&ev), 0);
    };
    rocklab::raw_frame_t raw;
    raw.num_channels = 2;
    raw.seq = 7;
    raw.utime = 70000;
    raw.values = {0.25, -1.0};
    write("RL_RAW", raw, 1);  // before the config: still decoded
    rocklab::daq_config2_t config;
    config.num_channels = 2;
    config.channel_names = {"x", "y"};
    config.channel_units = {"m", "m"};
    config.channel_sensors = {"", ""};
    config.gain = {1, 1};
    config.offset = {0, 0};
    config.sample_rate_hz = 100;
    write("RL_DAQ_CONFIG", config, 2);
    raw.seq = 8;
    raw.utime = 80000;
    raw.num_channels = 1;  // wrong size: reported and skipped
    raw.values = {1};
    write("RL_RAW", raw, 3);
    raw.seq = 9;
    raw.utime = 90000;
    raw.num_channels = 2;
    raw.values = {2, 3};
    write("RL_RAW", raw, 4);
  }
  const Read r = ReadAll(path, 1.0);
  EXPECT_EQ(r.names, (std::vector<std::string>{"x", "y"}));
  ASSERT_EQ(r.frames.size(), 2u);
  EXPECT_EQ(r.frames[0].seq, 7);
  EXPECT_EQ(r.frames[0].utime(), 70000);
  EXPECT_EQ(r.frames[1].values, (std::vector<double>{2, 3}));
  ASSERT_EQ(r.problems.size(), 1u);
  EXPECT_EQ(r.problems[0], path + ":2: raw frame has 1 channels, the config names 2 (skipped)");
}

TEST(Reconstructor, ChannelTheRigNamesButTheFileLacksIsAStartUpError) {
  const RigConfig rig = LoadRigConfig(test::LabRigPath());
  // Oracle: the line of the channel's [[channel]] header in the rig file.
  std::ifstream in(test::LabRigPath());
  std::string text;
  int line = 0, header = 0;
  while (std::getline(in, text) && text != "name = \"low_L1_x\"") {
    ++line;
    if (text == "[[channel]]") header = line;
  }
  test::CollectSink sink;
  try {
    Processor proc(rig, {"mirror_s", "mirror_n"}, "in.csv", sink);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              test::LabRigPath() + ":" + std::to_string(header) +
                  ": channel 'low_L1_x' (sensor 'low.L1.x') is not in in.csv (its channels: 'mirror_s' "
                  "'mirror_n'); also missing: 'low_L1_z' 'low_L2_x' 'low_L2_z' 'high_H1_x' 'high_H1_z' "
                  "'high_H2_x' 'high_H2_z' 'oop_a' 'oop_b' 'table_disp' 'table_acc'");
  }
}

}  // namespace
}  // namespace rocklab::daq
