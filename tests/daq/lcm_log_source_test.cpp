// The DAQ's LCM-log source on hostile and damaged logs: a frame whose
// channel count the payload cannot hold is a bad row (no allocation of it),
// a damaged region is a problem with its byte offset and a count, and every
// good frame is read.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "common/lcm_log.h"
#include "daq/source.h"
#include "rocklab/raw_frame_t.hpp"
#include "tests/scratch.h"

namespace rocklab::daq {
namespace {

// Frames 0..3 on RL_RAW with two values each; frame 1's num_channels is
// rewritten to 2^31 - 1; returns each event's file offset.
std::vector<std::int64_t> WriteLog(const std::string& path) {
  common::LogWriter log(path);
  std::vector<std::int64_t> offsets;
  std::int64_t at = 0;
  for (int k = 0; k < 4; ++k) {
    rocklab::raw_frame_t m{};
    m.utime = 1000 * k;
    m.seq = k;
    m.num_channels = 2;
    m.values = {0.1 * k, 0.2 * k};
    std::vector<std::uint8_t> b(m.getEncodedSize());
    m.encode(b.data(), 0, static_cast<int>(b.size()));
    if (k == 1) b[24] = 0x7f, b[25] = b[26] = b[27] = 0xff;
    offsets.push_back(at);
    at += 28 + 6 + static_cast<std::int64_t>(b.size());
    log.Write("RL_RAW", b.data(), b.size(), m.utime);
  }
  return offsets;
}

// Oracle: the four frames written: 0 and 2 are read, 1 is a bad row, 3 is
// lost in a damaged region at its offset (its sync word flipped).
TEST(LcmLogSource, HostileCountIsABadRowAndDamageIsReportedWithItsOffset) {
  const std::filesystem::path dir = rocklab::test::ScratchDir("lcm_log_source_test");
  const std::string path = (dir / "raw.lcm").string();
  const std::vector<std::int64_t> offsets = WriteLog(path);
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(offsets[3]);
    f.put(static_cast<char>(0xEC));
  }
  std::vector<std::string> problems;
  SourceOptions o;
  o.sample_rate_hz = 1000;
  o.fallback_channel_names = {"a", "b"};
  o.on_problem = [&problems](const Problem& p) { problems.push_back(ToString(p)); };
  auto source = OpenLcmLogSource(path, o);
  Frame frame;
  std::vector<std::int64_t> seqs;
  while (source->Next(frame) == ReadStatus::kFrame) seqs.push_back(frame.seq);
  EXPECT_EQ(seqs, (std::vector<std::int64_t>{0, 2}));
  EXPECT_EQ(source->stats().bad_rows, 1);
  EXPECT_EQ(source->stats().damaged_regions, 1);
  EXPECT_EQ(source->stats().damaged_events, 1);
  ASSERT_EQ(problems.size(), 2u);
  EXPECT_NE(problems[1].find("damaged LCM log region at byte offset " + std::to_string(offsets[3])),
            std::string::npos)
      << problems[1];
}

}  // namespace
}  // namespace rocklab::daq
