// Hostile and damaged input to the text sources and the acquisition pipeline
// (docs/reliability.md). Oracles: the fixture each test writes
// (what a correct reader makes of it is known row by row) and the promises
// of daq/source.h and daq/sequence_checker.h: nothing read is lost without a
// counter, a read error is an error naming the file, a message quotes at
// most a bounded, escaped excerpt of the input.
#include <sys/stat.h>

#include <cmath>
#include <ios>
#include <sstream>
#include <stdexcept>
#include <streambuf>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "daq/processor.h"
#include "daq/sequence_checker.h"
#include "daq/source.h"
#include "common/text.h"
#include "rocklab/event2_t.hpp"
#include "tests/daq/daq_test_util.h"

namespace rocklab::daq {
namespace {

// One mirror channel "s" at `rate_hz`.
RigConfig MirrorRig(double rate_hz) {
  std::ostringstream text;
  text << "name = \"r\"\nsample_rate_hz = " << rate_hz
       << "\n[block]\nwidth_m = 0.2\nheight_m = 0.8\n[mirror]\nlever_m = 1.0\n"
          "[[channel]]\nname = \"s\"\nsensor = \"mirror.s\"\n";
  return ParseRigConfig(text.str(), "rig.toml");
}

struct Outcome {
  std::vector<std::string> names;
  std::vector<Frame> frames;
  std::vector<std::string> problems;  // the source's
  SourceStats stats;
  SequenceCounts sequence;
  ProcessorCounts counts;
  test::CollectSink sink;
  std::string error;  // what Next() threw, if it did
};

// Reads `path` through a Processor of `rig` to the end.
void ReadThrough(const RigConfig& rig, const std::string& path, Outcome& r) {
  SourceOptions opt;
  opt.sample_rate_hz = rig.sample_rate_hz;
  opt.on_problem = [&r](const Problem& p) { r.problems.push_back(ToString(p)); };
  auto source = OpenSource(path, opt);
  r.names = source->channel_names();
  Processor proc(rig, source->channel_names(), path, r.sink);
  Frame f;
  try {
    while (source->Next(f) == ReadStatus::kFrame) {
      r.frames.push_back(f);
      proc.Process(f);
    }
  } catch (const std::runtime_error& e) {
    r.error = e.what();
  }
  proc.Finish();
  r.stats = source->stats();
  r.sequence = proc.sequence();
  r.counts = proc.counts();
}

// Rows "t,value" at `rate_hz` for k in each [from, to).
std::string Rows(double rate_hz, std::vector<std::pair<int, int>> ranges) {
  std::ostringstream out;
  out.precision(17);
  for (auto [from, to] : ranges) {
    for (int k = from; k < to; ++k) out << k / rate_hz << "," << 0.001 * k << "\n";
  }
  return out.str();
}

// Item 4: the BOM glued itself to "time", which then became a channel, time
// became row / rate and a 50-sample gap vanished.
TEST(HostileInput, ByteOrderMarkDoesNotHideTheTimeColumn) {
  const RigConfig rig = MirrorRig(100);
  const std::string path = test::WriteFile("bom.csv", "\xEF\xBB\xBFtime,s\n" + Rows(100, {{0, 20}, {70, 90}}));
  Outcome r;
  ReadThrough(rig, path, r);
  EXPECT_EQ(r.names, (std::vector<std::string>{"s"}));
  ASSERT_EQ(r.frames.size(), 40u);
  EXPECT_EQ(r.frames[20].seq, 70);
  EXPECT_DOUBLE_EQ(r.frames[20].time_s, 0.70);
  EXPECT_EQ(r.sequence.gaps, 1);
  EXPECT_EQ(r.sequence.missing, 50);
  EXPECT_TRUE(r.error.empty()) << r.error;
}

// A stream that gives `good` bytes and then fails as a disk would
// (basic_filebuf throws from underflow on a read error).
class FailingBuf : public std::streambuf {
 public:
  explicit FailingBuf(std::string good) : good_(std::move(good)) {
    setg(good_.data(), good_.data(), good_.data() + good_.size());
  }

 protected:
  int_type underflow() override { throw std::ios_base::failure("mock read error: Input/output error"); }

 private:
  std::string good_;
};

class FailingStream : public std::istream {
 public:
  explicit FailingStream(std::string good) : std::istream(nullptr), buf_(std::move(good)) { rdbuf(&buf_); }

 private:
  FailingBuf buf_;
};

// Item 5: a read error was taken for the end of the file (rows lost, exit 0).
TEST(HostileInput, ReadErrorIsAnErrorNamingTheFileNotTheEnd) {
  SourceOptions opt;
  opt.sample_rate_hz = 100;
  std::vector<std::string> problems;
  opt.on_problem = [&problems](const Problem& p) { problems.push_back(ToString(p)); };
  auto source = OpenCsvStream(std::make_unique<FailingStream>("time,s\n0.00,1\n0.01,2\n0.02,"), "disk.csv", opt);
  Frame f;
  int frames = 0;
  ReadStatus status;
  while ((status = source->Next(f)) == ReadStatus::kFrame) ++frames;  // never throws (source.h)
  EXPECT_EQ(status, ReadStatus::kError) << "the read error ended the file quietly after " << frames << " frames";
  EXPECT_EQ(frames, 2);
  EXPECT_EQ(source->error().rfind("disk.csv: read error after line 3 (mock read error", 0), 0u) << source->error();
  ASSERT_EQ(problems.size(), 1u);  // and through the problem callback, with its location
  EXPECT_EQ(problems[0].rfind("disk.csv:3: read error after line 3 (mock read error", 0), 0u) << problems[0];
  EXPECT_EQ(source->Next(f), ReadStatus::kError);  // and it stays so
  opt.on_problem = nullptr;
  // A real one: read(2) of a directory fails with EISDIR.
  const std::string dir = test::ScratchDir() + "/directory.csv";
  ::mkdir(dir.c_str(), 0700);
  try {
    auto d = OpenSource(dir, opt);
    ADD_FAILURE() << "a directory opened as a CSV file";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()).rfind(dir + ": read error after line 0", 0), 0u) << e.what();
  }
}

// Item 5, the way it was met: a line too long for the memory. Lines are cut
// at 1 MiB: the row is skipped and counted, the rows around it are read.
TEST(HostileInput, OverlongLineIsASkippedRowNotTheEnd) {
  const RigConfig rig = MirrorRig(100);
  const std::string path =
      test::WriteFile("long.csv", "time,s\n" + Rows(100, {{0, 5}}) + "0.05," + std::string(3 << 20, '7') + "\n" +
                                      Rows(100, {{6, 10}}));
  Outcome r;
  ReadThrough(rig, path, r);
  EXPECT_EQ(r.frames.size(), 9u);
  EXPECT_EQ(r.stats.rows, 10);
  EXPECT_EQ(r.stats.bad_rows, 1);
  ASSERT_EQ(r.problems.size(), 1u);
  EXPECT_EQ(r.problems[0], path + ":7: row longer than 1048576 bytes (row skipped)");
  EXPECT_EQ(r.sequence.missing, 1);  // the skipped row's sample, counted as a gap
}

// Item 6: one bad timestamp threw away the rest of the record (1000000
// samples missing, then 229 rows out of order: 71 of 300 reconstructed).
TEST(HostileInput, IsolatedBadTimestampIsWithdrawnAndTheRestKept) {
  const RigConfig rig = MirrorRig(1000);
  std::string rows = Rows(1000, {{0, 70}}) + "1000.070,0.07\n" + Rows(1000, {{71, 300}});
  const std::string path = test::WriteFile("jump.csv", "time,s\n" + rows);
  Outcome r;
  ReadThrough(rig, path, r);
  EXPECT_EQ(r.frames.size(), 300u);
  EXPECT_EQ(r.sequence.bad_timestamps, 1);
  EXPECT_EQ(r.sequence.gaps, 1);  // the bad row's own sample (70) is missing
  EXPECT_EQ(r.sequence.missing, 1);
  EXPECT_EQ(r.sequence.out_of_order, 0);
  EXPECT_EQ(r.counts.reconstructed, 299);
  EXPECT_EQ(r.counts.rejected, 1);
  EXPECT_EQ(r.sink.block.size(), 299u);  // every good row, the bad one not
  for (const BlockState& s : r.sink.block) EXPECT_LT(s.time_s, 1.0);
  bool told = false;
  for (const std::string& p : r.sink.problem_text) {
    told = told || p.find(":73: the frame before (t = 1000.07 s) had a bad timestamp") != std::string::npos;
  }
  EXPECT_TRUE(told);
}

// A first time of 1e308 is out of range (it overflowed the microseconds and
// left 1 row): the row is refused with a clear message, the rest is kept.
TEST(HostileInput, FirstTimeOf1e308IsRefusedClearly) {
  const RigConfig rig = MirrorRig(1000);
  const std::string path = test::WriteFile("huge.csv", "time,s\n1e308,0\n" + Rows(1000, {{0, 299}}));
  Outcome r;
  ReadThrough(rig, path, r);
  EXPECT_EQ(r.frames.size(), 299u);
  EXPECT_EQ(r.stats.bad_rows, 1);
  ASSERT_FALSE(r.problems.empty());
  EXPECT_EQ(r.problems[0], path + ":2: time 1e+308 s is outside [-1e12, 1e12] s (row skipped)");
  EXPECT_EQ(r.sequence.gaps, 0);
  EXPECT_EQ(r.sink.block.size(), 299u);
}

// A bad first time within range: kReanchorRun rows behind it in order move
// the reference; the rows before are counted out of order, not lost silently.
TEST(HostileInput, BadFirstTimeIsLeftAfterARunOfGoodRows) {
  const RigConfig rig = MirrorRig(1000);
  const std::string path = test::WriteFile("first.csv", "time,s\n1000,0\n" + Rows(1000, {{1, 300}}));
  Outcome r;
  ReadThrough(rig, path, r);
  EXPECT_EQ(r.sequence.reanchors, 1);
  EXPECT_EQ(r.sequence.out_of_order, SequenceChecker::kReanchorRun - 1);
  EXPECT_EQ(r.counts.rejected, SequenceChecker::kReanchorRun - 1);
  // The first row, and every row from the one that re-anchored.
  EXPECT_EQ(r.sink.block.size(), 1u + 299u - (SequenceChecker::kReanchorRun - 1));
}

TEST(SequenceChecker, IsolatedJumpAndRunsAreCountedNotFatal) {
  SequenceChecker c;
  EXPECT_EQ(c.Check(0, 0), SequenceStatus::kFirst);
  EXPECT_EQ(c.Check(1, 1000), SequenceStatus::kInOrder);
  EXPECT_EQ(c.Check(1'000'000, 1'000'000'000), SequenceStatus::kGap);
  EXPECT_EQ(c.Check(2, 2000), SequenceStatus::kReanchored);
  EXPECT_TRUE(c.last_was_bad());
  EXPECT_EQ(c.Check(3, 3000), SequenceStatus::kInOrder);
  EXPECT_EQ(c.counts().gaps, 0);
  EXPECT_EQ(c.counts().missing, 0);
  EXPECT_EQ(c.counts().bad_timestamps, 1);
  // A real gap stays a gap: the frames after it continue from it.
  EXPECT_EQ(c.Check(10, 10000), SequenceStatus::kGap);
  EXPECT_EQ(c.Check(11, 11000), SequenceStatus::kInOrder);
  EXPECT_EQ(c.counts().missing, 6);
  // A single frame from the past is out of order and moves nothing.
  EXPECT_EQ(c.Check(5, 5000), SequenceStatus::kOutOfOrder);
  EXPECT_EQ(c.Check(12, 12000), SequenceStatus::kInOrder);
  // Sequence numbers from the wire at the ends of int64: counted, no overflow.
  EXPECT_EQ(c.Check(INT64_MAX, INT64_MAX), SequenceStatus::kGap);
  EXPECT_EQ(c.Check(INT64_MIN, INT64_MIN), SequenceStatus::kOutOfOrder);
  EXPECT_GT(c.counts().missing, 0);
}

// Item 10: exit 0 when every row was bad.
TEST(HostileInput, EveryRowBadIsAnError) {
  SourceOptions opt;
  opt.sample_rate_hz = 100;
  auto source = OpenSource(test::WriteFile("allbad.csv", "time,s\nx,1\n0.1\n\n,2\n"), opt);
  Frame f;
  ReadStatus status;
  while ((status = source->Next(f)) == ReadStatus::kFrame) {
  }
  EXPECT_EQ(status, ReadStatus::kError);
  EXPECT_NE(source->error().find("allbad.csv: none of the 3 data rows could be used"), std::string::npos)
      << source->error();
}

// Item 10: a NUL cut messages short; a 50 MB field was echoed whole; raw
// binary reached the terminal. Oracle: common::Quote's contract.
TEST(HostileInput, MessagesQuoteABoundedEscapedExcerpt) {
  std::string field = "12";
  field += '\0';
  field += "\x1b[2J\xff";
  field += std::string(100000, 'z');
  const std::string path = test::WriteFile("binary.csv", "time,s\n0.00," + field + "\n0.01,1\n");
  Outcome r;
  ReadThrough(MirrorRig(100), path, r);
  EXPECT_EQ(r.error, "");
  ASSERT_EQ(r.problems.size(), 1u);
  const std::string& m = r.problems[0];
  EXPECT_LT(m.size(), path.size() + 200) << m;
  for (unsigned char c : m) EXPECT_TRUE(c >= 0x20 && c < 0x7f) << "byte " << int(c) << " in " << m;
  EXPECT_NE(m.find("column 's': '12\\x00\\x1b[2J\\xffzzz"), std::string::npos) << m;
  EXPECT_NE(m.find("' ... [99960 bytes more] is not a number"), std::string::npos) << m;
  EXPECT_EQ(common::Quote("it's"), "'it\\'s'");
  EXPECT_EQ(common::Quote(std::string_view("a\0b", 3)), "'a\\x00b'");
}

// Item 10: `Samples 1e300` was converted to int64 (undefined behaviour).
TEST(HostileInput, LvmSamplesOutOfRangeIsAWarning) {
  const std::string path = test::WriteFile(
      "samples.lvm",
      "LabVIEW Measurement\t\nSeparator\tTab\n***End_of_Header***\n\nChannels\t1\nSamples\t1e300\n"
      "Delta_X\t0.01\n***End_of_Header***\nX_Value\ts\tComment\n0\t1\n0.01\t2\n");
  Outcome r;
  ReadThrough(MirrorRig(100), path, r);
  EXPECT_EQ(r.error, "");
  EXPECT_EQ(r.frames.size(), 2u);
  EXPECT_EQ(r.stats.warnings, 1);
  ASSERT_EQ(r.problems.size(), 1u);
  EXPECT_EQ(r.problems[0], path + ":6: Samples '1e300' is not a row count in [0, 1e15] (ignored)");
}

}  // namespace
}  // namespace rocklab::daq
