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
#include "rocklab/block_state2_t.hpp"
#include "rocklab/block_state_t.hpp"
#include "rocklab/comparison2_t.hpp"
#include "rocklab/comparison3_t.hpp"
#include "rocklab/model_state4_t.hpp"
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

// Oracle: the messages written, a two-body assembly: RL_THETA (body 0),
// RL_BODIES, an assembly variant's RL_MODEL_stack and RL_COMPAREBODIES_stack
// (rms 1e-3 and 2e-3 rad, modes agreeing 0.6). The figure gets a panel for
// body 1 (the theta panel above is body 0's) with the experiment's and the
// variant's curve; the caption a line per body and the mode agreement. The
// single block of WriteRecord gets no body panel.
TEST(RecordReport, AnAssemblyGetsAPanelAndACaptionLinePerBody) {
  const std::string path = Scratch("bodies.lcm");
  {
    common::LogWriter log(path);
    auto put = [&](const std::string& channel, const auto& msg) {
      std::vector<std::uint8_t> buf(static_cast<std::size_t>(msg.getEncodedSize()));
      msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
      log.Write(channel, buf.data(), buf.size(), msg.utime);
    };
    for (int k = 0; k < 100; ++k) {
      const double lower = 0.01 * std::sin(1e-2 * k), upper = 2 * lower;
      rocklab::block_state_t th{};
      th.utime = 1000 * k;
      th.seq = k;
      th.theta = lower;
      put("RL_THETA", th);
      rocklab::block_state2_t b{};
      b.utime = th.utime;
      b.seq = k;
      b.nbodies = 2;
      b.theta = {lower, upper};
      b.theta_dot = b.theta_mirror = b.theta_camera = b.sliding = b.jump = b.twist = b.out_of_plane = {0, 0};
      b.leds_used = {4, 4};
      b.flags = {0, 0};
      put("RL_BODIES", b);
      rocklab::model_state4_t m{};
      m.utime = th.utime;
      m.seq = k;
      m.name = "stack";
      m.model = "housner";
      m.nbodies = 2;
      m.theta = {lower + 1e-3, upper - 2e-3};
      m.theta_dot = m.chi = m.psi = m.alpha = m.p = m.mu = {0, 0};
      m.regime = {1, 1};
      m.mode = "RC";
      put("RL_MODEL_stack", m);
    }
    rocklab::comparison3_t c{};
    c.utime = 99000;
    c.seq = 0;
    c.name = "stack";
    c.nbodies = 2;
    c.error = c.rms_window = c.peak_error = c.impact_timing_error = c.correlation = {0, 0};
    c.rms_total = {1e-3, 2e-3};
    c.nrms = {0.1, 0.1};
    c.valid = {1, 1};
    c.mode_model = "RC";
    c.mode_measured = "RR";
    c.mode_rest_rad = 2e-3;
    c.mode_agreement = 0.6;
    c.mode_samples = 100;
    put("RL_COMPAREBODIES_stack", c);
  }
  const RecordReport r = ReadRecordLog(path);
  EXPECT_EQ(r.decode_errors, 0);
  const ThetaFigure figure = ReportFigure(r);
  ASSERT_EQ(figure.body_panels(), 1u);
  const std::string script = figure.Script("out.svg", FigureFormat::kSvg, 900, 700);
  EXPECT_NE(script.find("set ylabel 'theta, body 1 (degrees)'"), std::string::npos) << script;
  EXPECT_NE(script.find("$p0c0 using 1:2"), std::string::npos);  // the experiment's body 1
  EXPECT_NE(script.find("$p0c1 using 1:2"), std::string::npos);  // the variant's
  EXPECT_NE(script.find("unset multiplot"), std::string::npos);
  const std::vector<std::string> lines = CaptionLines(r);
  auto has = [&](const std::string& text) {
    for (const std::string& l : lines) {
      if (l.find(text) != std::string::npos) return true;
    }
    return false;
  };
  EXPECT_TRUE(has("stack body 0: rms 0.001 rad, nrms 0.1"));
  EXPECT_TRUE(has("stack body 1: rms 0.002 rad, nrms 0.1"));
  EXPECT_TRUE(has("stack: modes agree 60.0 % of the time (rest below 0.002 rad)"));

  const std::string single_path = Scratch("single_for_bodies.lcm");
  WriteRecord(single_path);
  const ThetaFigure single = ReportFigure(ReadRecordLog(single_path));
  EXPECT_EQ(single.body_panels(), 0u);
  EXPECT_EQ(single.Script("out.svg", FigureFormat::kSvg, 900, 700).find("$p0c0"), std::string::npos);
}

TEST(RecordReport, NotALogIsAnInputError) {
  const std::string path = Scratch("text.csv");
  std::ofstream(path) << "time,theta\n0,0\n";
  EXPECT_THROW(ReadRecordLog(path), ReportInputError);
}

}  // namespace
}  // namespace rocklab::report
