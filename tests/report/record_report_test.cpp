// report::ReadRecordLog as a library: a log's measured theta and table peaks
// into the report, and a damaged log read past its damage with the region
// listed (file offset) and counted.
#include "report/report.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "common/lcm_log.h"
#include "rocklab/block_state_t.hpp"
#include "rocklab/comparison2_t.hpp"
#include "rocklab/table_state_t.hpp"
#include "tests/scratch.h"

namespace rocklab::report {
namespace {

// 200 samples at 1 kHz: RL_THETA theta = 0.01 sin(10 t) rad and RL_TABLE
// with acceleration 2 cos(10 t) m/s^2, displacement 1 mm. Returns the file
// offset of every event.
std::vector<std::int64_t> WriteRecord(const std::string& path) {
  std::vector<std::int64_t> offsets;
  common::LogWriter log(path);
  std::int64_t at = 0;
  auto put = [&](const std::string& channel, const auto& msg) {
    std::vector<std::uint8_t> buf(msg.getEncodedSize());
    msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
    offsets.push_back(at);
    at += 28 + static_cast<std::int64_t>(channel.size() + buf.size());
    log.Write(channel, buf.data(), buf.size(), msg.utime);
  };
  for (int k = 0; k < 200; ++k) {
    const double t = 1e-3 * k;
    rocklab::block_state_t th{};
    th.utime = 1000 * k;
    th.seq = k;
    th.theta = 0.01 * std::sin(10 * t);
    put("RL_THETA", th);
    rocklab::table_state_t tb{};
    tb.utime = 1000 * k;
    tb.seq = k;
    tb.acceleration = 2 * std::cos(10 * t);
    tb.displacement = 1e-3;
    put("RL_TABLE", tb);
  }
  return offsets;
}

std::string Scratch(const std::string& name) {
  const std::filesystem::path dir = test::ScratchDir("record_report_test");
  return (dir / name).string();
}

// Oracle: the messages written: 400 events, peak |acceleration| 2 m/s^2 (at
// t = 0), peak displacement 1 mm, no damage.
TEST(RecordReport, ReadsEveryEventOfTheLog) {
  const std::string path = Scratch("clean.lcm");
  WriteRecord(path);
  const RecordReport r = ReadRecordLog(path);
  EXPECT_EQ(r.events, 400);
  EXPECT_EQ(r.table.samples, 200);
  EXPECT_DOUBLE_EQ(r.table.accel_mps2, 2.0);
  EXPECT_DOUBLE_EQ(r.table.disp_m, 1e-3);
  EXPECT_EQ(r.damaged_regions, 0);
  EXPECT_TRUE(r.problems.empty());
  EXPECT_FALSE(r.snapshot.at("measured").at("t").empty());
}

// Oracle: the RL_COMPARE messages written: one variant
// whose comparison has no matched crossing (NaN timing and peak errors, as
// the comparator publishes them) and one with a matched crossing. The first
// caption line says so and the page's JSON holds null, not 0.
TEST(RecordReport, AComparisonWithoutAMatchedCrossingIsSaidNotZero) {
  const std::string path = Scratch("no_match.lcm");
  {
    common::LogWriter log(path);
    for (int k = 0; k < 50; ++k) {
      rocklab::block_state_t th{};
      th.utime = 1000 * k;
      th.seq = k;
      th.theta = 0.01;
      std::vector<std::uint8_t> buf(static_cast<std::size_t>(th.getEncodedSize()));
      th.encode(buf.data(), 0, static_cast<int>(buf.size()));
      log.Write("RL_THETA", buf.data(), buf.size(), th.utime);
      for (const char* name : {"none", "some"}) {
        rocklab::comparison2_t c{};
        c.utime = 1000 * k;
        c.name = name;
        c.nrms = 0.25;
        const bool matched = std::string(name) == "some";
        c.peak_error = matched ? 1e-3 : std::nan("");
        c.impact_timing_error = matched ? 2e-3 : std::nan("");
        c.samples = k + 1;
        buf.resize(static_cast<std::size_t>(c.getEncodedSize()));
        c.encode(buf.data(), 0, static_cast<int>(buf.size()));
        log.Write(std::string("RL_COMPARE_") + name, buf.data(), buf.size(), c.utime);
      }
    }
  }
  const RecordReport r = ReadRecordLog(path);
  const std::vector<std::string> lines = CaptionLines(r);
  ASSERT_GE(lines.size(), 2u);
  EXPECT_NE(lines[0].find("none: "), std::string::npos) << lines[0];
  EXPECT_NE(lines[0].find("no zero crossing matched"), std::string::npos) << lines[0];
  EXPECT_NE(lines[1].find("some: "), std::string::npos) << lines[1];
  EXPECT_EQ(lines[1].find("no zero crossing matched"), std::string::npos) << lines[1];
  for (const auto& v : r.snapshot.at("variants")) {
    const auto& latest = v.at("latest");
    EXPECT_EQ(latest.at("impact_timing_error").is_null(), v.at("name") == "none") << latest.dump();
    EXPECT_EQ(latest.at("peak_error").is_null(), v.at("name") == "none") << latest.dump();
  }
}

// Oracle: one flipped sync bit loses exactly that event (an RL_TABLE, the
// 100th event); the region is listed with its offset and the rest is read.
TEST(RecordReport, DamagedLogIsReadPastItsDamageAndTheRegionListed) {
  const std::string path = Scratch("damaged.lcm");
  const std::vector<std::int64_t> offsets = WriteRecord(path);
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(offsets[101] + 3);
    f.put(static_cast<char>(0x01 ^ 0x80));
  }
  const RecordReport r = ReadRecordLog(path);
  EXPECT_EQ(r.events, 399);
  EXPECT_EQ(r.table.samples, 199);
  EXPECT_EQ(r.damaged_regions, 1);
  EXPECT_EQ(r.damaged_events, 1);
  ASSERT_EQ(r.problems.size(), 1u);
  EXPECT_NE(r.problems[0].find("damaged region at byte offset " + std::to_string(offsets[101])),
            std::string::npos)
      << r.problems[0];
}

TEST(RecordReport, NotALogIsAnInputError) {
  const std::string path = Scratch("text.csv");
  std::ofstream(path) << "time,theta\n0,0\n";
  EXPECT_THROW(ReadRecordLog(path), ReportInputError);
}

}  // namespace
}  // namespace rocklab::report
