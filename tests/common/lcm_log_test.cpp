// The one LCM log reader and writer: the format as liblcm writes it, stamps
// that never go back, file order for logs whose stamps do, the window, and
// damaged regions (a flipped sync bit, an impossible length, a cut tail)
// skipped, counted and reported with their offsets.
#include "common/lcm_log.h"
#include "tests/scratch.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

namespace rocklab::common {
namespace {

std::string Scratch(const std::string& name) {
  const std::filesystem::path dir = test::ScratchDir("lcm_log_test");
  return (dir / name).string();
}

// Event k: channel "CH<k % 3>", payload "payload-<k>", stamp stamps[k].
std::string Payload(int k) { return "payload-" + std::to_string(k); }

std::string WriteWithLiblcm(const std::string& name, const std::vector<std::int64_t>& stamps) {
  const std::string path = Scratch(name);
  lcm::LogFile log(path, "w");
  for (std::size_t k = 0; k < stamps.size(); ++k) {
    const std::string payload = Payload(static_cast<int>(k));
    lcm::LogEvent ev{};
    ev.eventnum = static_cast<std::int64_t>(k);
    ev.timestamp = stamps[k];
    ev.channel = "CH" + std::to_string(k % 3);
    ev.datalen = static_cast<std::int32_t>(payload.size());
    ev.data = const_cast<char*>(payload.data());
    EXPECT_EQ(log.writeEvent(&ev), 0);
  }
  return path;
}

std::vector<std::int64_t> Ramp(int n, std::int64_t step_us = 1000) {
  std::vector<std::int64_t> t(n);
  for (int k = 0; k < n; ++k) t[k] = 5'000'000 + step_us * k;
  return t;
}

std::vector<LogEvent> ReadAll(LogReader& reader) {
  std::vector<LogEvent> out;
  LogEvent ev;
  while (reader.Next(ev)) out.push_back(ev);
  return out;
}

// Offsets of each event in a liblcm log of the events above: 28-byte header,
// 3-byte channel, payload.
std::int64_t OffsetOf(int k) {
  std::int64_t at = 0;
  for (int i = 0; i < k; ++i) at += 28 + 3 + static_cast<std::int64_t>(Payload(i).size());
  return at;
}

void FlipByte(const std::string& path, std::int64_t offset, unsigned char mask) {
  std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
  f.seekg(offset);
  char c = 0;
  f.read(&c, 1);
  c = static_cast<char>(static_cast<unsigned char>(c) ^ mask);
  f.seekp(offset);
  f.write(&c, 1);
}

// Oracle: liblcm's own writer and reader: every event, in order, unchanged.
TEST(LcmLog, ReadsWhatLiblcmWrites) {
  const std::string path = WriteWithLiblcm("liblcm.lcm", Ramp(50));
  LogReader reader(path);
  const auto events = ReadAll(reader);
  ASSERT_EQ(events.size(), 50u);
  for (int k = 0; k < 50; ++k) {
    EXPECT_EQ(events[k].number, k);
    EXPECT_EQ(events[k].timestamp_us, 5'000'000 + 1000 * k);
    EXPECT_EQ(events[k].channel, "CH" + std::to_string(k % 3));
    EXPECT_EQ(std::string(events[k].data.begin(), events[k].data.end()), Payload(k));
    EXPECT_EQ(events[k].offset, OffsetOf(k));
  }
  EXPECT_EQ(reader.counts().damaged_regions, 0);
}

// Oracle: liblcm reads what LogWriter writes; stamps asked to go back are
// raised to the previous one (and counted), payloads unchanged.
TEST(LcmLog, WriterStampsNeverGoBackAndLiblcmReadsThem) {
  const std::string path = Scratch("writer.lcm");
  {
    LogWriter w(path);
    const std::int64_t asked[] = {100, 300, 200, 400, 50, 500};
    for (int k = 0; k < 6; ++k) {
      const std::string p = Payload(k);
      ASSERT_TRUE(w.Write("CH", p.data(), p.size(), asked[k]));
    }
    EXPECT_EQ(w.raised_stamps(), 2);
    EXPECT_TRUE(w.Close());
  }
  lcm::LogFile log(path, "r");
  const std::int64_t expected[] = {100, 300, 300, 400, 400, 500};
  int k = 0;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    ASSERT_LT(k, 6);
    EXPECT_EQ(ev->eventnum, k);
    EXPECT_EQ(ev->timestamp, expected[k]);
    EXPECT_EQ(std::string(static_cast<const char*>(ev->data), ev->datalen), Payload(k));
    ++k;
  }
  EXPECT_EQ(k, 6);
}

// Oracle: the stamps go back (as in rocklab logs written before the writer
// kept them in order): the window holds exactly the events stamped in it, in
// file order, none skipped (a bisection on the stamps would skip some).
TEST(LcmLog, WindowOfALogWhoseStampsGoBackIsReadInFileOrder) {
  // Even events on the clock, odd events 45 ms behind it.
  std::vector<std::int64_t> t(400);
  for (int k = 0; k < 400; ++k) t[k] = 1'000'000 + 1000 * k - (k % 2 ? 45'000 : 0);
  const std::string path = WriteWithLiblcm("unsorted.lcm", t);
  LogReaderOptions o;
  o.start_s = 0.1;
  o.end_s = 0.2;
  LogReader reader(path, o);
  std::vector<std::int64_t> expected;
  for (int k = 0; k < 400; ++k) {
    if (t[k] >= 1'100'000 && t[k] <= 1'200'000) expected.push_back(k);
  }
  std::vector<std::int64_t> got;
  for (const LogEvent& ev : ReadAll(reader)) got.push_back(ev.number);
  EXPECT_EQ(got, expected);
  EXPECT_EQ(reader.counts().delivered, static_cast<std::int64_t>(expected.size()));

  // Rewind: the same window again, from its first event.
  reader.Rewind();
  got.clear();
  for (const LogEvent& ev : ReadAll(reader)) got.push_back(ev.number);
  EXPECT_EQ(got, expected);
}

// Oracle: the channel regex matches whole names; NextEventTimeUs is the
// stamp of the event Next returns.
TEST(LcmLog, ChannelFilterAndNextEventTime) {
  const std::string path = WriteWithLiblcm("filter.lcm", Ramp(30));
  LogReaderOptions o;
  o.channels = "CH1";
  LogReader reader(path, o);
  EXPECT_EQ(reader.NextEventTimeUs(), 5'001'000);
  LogEvent ev;
  ASSERT_TRUE(reader.Next(ev));
  EXPECT_EQ(ev.number, 1);
  int n = 1;
  while (reader.Next(ev)) ++n;
  EXPECT_EQ(n, 10);
  EXPECT_EQ(reader.NextEventTimeUs(), INT64_MAX);
  EXPECT_EQ(reader.counts().filtered, 20);
}

// Oracle: one flipped bit in event 20's sync word loses event 20 only; the
// problem names its offset and size, once, even when read twice.
TEST(LcmLog, FlippedSyncBitSkipsOneEventAndReportsItsOffset) {
  const std::string path = WriteWithLiblcm("flip.lcm", Ramp(60));
  FlipByte(path, OffsetOf(20) + 1, 0x04);
  std::vector<LogProblem> problems;
  LogReaderOptions o;
  o.on_problem = [&problems](const LogProblem& p) { problems.push_back(p); };
  LogReader reader(path, o);
  const auto events = ReadAll(reader);
  ASSERT_EQ(events.size(), 59u);
  EXPECT_EQ(events[19].number, 19);
  EXPECT_EQ(events[20].number, 21);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_EQ(problems[0].offset, OffsetOf(20));
  EXPECT_EQ(problems[0].bytes, OffsetOf(21) - OffsetOf(20));
  EXPECT_EQ(problems[0].events, 1);
  EXPECT_NE(ToString(problems[0]).find("flip.lcm: damaged region at byte offset " +
                                       std::to_string(OffsetOf(20))),
            std::string::npos)
      << ToString(problems[0]);
  reader.Rewind();
  EXPECT_EQ(ReadAll(reader).size(), 59u);
  EXPECT_EQ(problems.size(), 1u);
  EXPECT_EQ(reader.counts().damaged_regions, 1);
  EXPECT_EQ(reader.counts().damaged_events, 1);
}

// Oracle: a data length of 2^31 - 1 (hostile or flipped) is damage, not an
// allocation; the events after it are read.
TEST(LcmLog, ImpossibleLengthIsDamageAndTheRestIsRead) {
  const std::string path = WriteWithLiblcm("length.lcm", Ramp(30));
  FlipByte(path, OffsetOf(10) + 24, 0x7f);  // data length's top byte
  std::vector<LogProblem> problems;
  LogReaderOptions o;
  o.on_problem = [&problems](const LogProblem& p) { problems.push_back(p); };
  LogReader reader(path, o);
  const auto events = ReadAll(reader);
  ASSERT_EQ(events.size(), 29u);
  EXPECT_EQ(events[10].number, 11);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_EQ(problems[0].offset, OffsetOf(10));
  EXPECT_NE(problems[0].what.find("impossible data length"), std::string::npos) << problems[0].what;
}

// Oracle: a log cut in the middle of event 29 (of 30): 29 events, one region
// from that event's offset to the end of the file.
TEST(LcmLog, CutTailIsReportedAndEverythingBeforeItRead) {
  const std::string path = WriteWithLiblcm("cut.lcm", Ramp(30));
  std::filesystem::resize_file(path, static_cast<std::uintmax_t>(OffsetOf(29) + 20));
  std::vector<LogProblem> problems;
  LogReaderOptions o;
  o.on_problem = [&problems](const LogProblem& p) { problems.push_back(p); };
  LogReader reader(path, o);
  EXPECT_EQ(ReadAll(reader).size(), 29u);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_EQ(problems[0].offset, OffsetOf(29));
  EXPECT_EQ(problems[0].bytes, 20);
  EXPECT_EQ(problems[0].events, 1);
}

// Oracle: garbage at the start: the first good event's number says how many
// were lost; a file of no event at all does not open.
TEST(LcmLog, DamageAtTheStartAndFilesThatAreNotLogs) {
  const std::string path = WriteWithLiblcm("start.lcm", Ramp(10));
  FlipByte(path, 0, 0xff);
  std::vector<LogProblem> problems;
  LogReaderOptions o;
  o.on_problem = [&problems](const LogProblem& p) { problems.push_back(p); };
  LogReader reader(path, o);
  EXPECT_EQ(reader.first_timestamp_us(), 5'001'000);
  EXPECT_EQ(ReadAll(reader).size(), 9u);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_EQ(problems[0].offset, 0);
  EXPECT_EQ(problems[0].events, 1);

  const std::string text = Scratch("text.csv");
  std::ofstream(text) << "time,theta\n0,0\n";
  EXPECT_THROW(LogReader{text}, std::runtime_error);
  EXPECT_THROW(LogReader{Scratch("missing.lcm")}, std::runtime_error);
  EXPECT_FALSE(StartsWithLcmSync(text));
  EXPECT_TRUE(StartsWithLcmSync(WriteWithLiblcm("sync.lcm", Ramp(2))));
}

// Oracle: /dev/full refuses every write (ENOSPC). 3000
// events of 1 KiB (3 MB, three buffer flushes and the close) are all lost
// and all counted as lost: write_errors() equals the events written to it,
// events() is 0, and the reason is kept.
TEST(LcmLog, WriterOnAFullDiskCountsEveryLostEvent) {
  LogWriter w("/dev/full");
  const std::string payload(1024, 'x');
  int refused = 0;
  for (int k = 0; k < 3000; ++k) refused += !w.Write("CH", payload.data(), payload.size(), k);
  EXPECT_FALSE(w.Close());
  EXPECT_EQ(w.write_errors(), 3000);
  EXPECT_EQ(w.events(), 0);
  EXPECT_GE(refused, 2);  // each failed flush says so to the caller
  EXPECT_NE(w.error().find("space"), std::string::npos) << w.error();
}

}  // namespace
}  // namespace rocklab::common
