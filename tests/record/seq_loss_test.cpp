// Every rocklab channel's type carries `seq`, so a
// message lost anywhere on the bus is counted by whoever receives it: the
// recorder, `rocklab info`, the monitor and the report (and, through
// info/export, the Python module), and the seq is exported as a column.
// Older logs (model_state_t/2, comparison_t, event_t, health_t, daq_config_t:
// no seq) still read everywhere, with nothing counted for those channels.
//
// Oracle: the messages are made here, each channel numbered 0..19 by its
// sender and some numbers left out as if lost on the bus; the missing count
// of each channel is the number left out (RL_EVENT and RL_HEALTH: two
// senders interleaved, each numbering its own).
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>

#include "common/lcm_log.h"
#include "common/versions.h"
#include "export/export.h"
#include "export/info.h"
#include "monitor/live_state.h"
#include "record/recorder.h"
#include "report/report.h"
#include "rocklab/block_state_t.hpp"
#include "rocklab/raw_frame_t.hpp"
#include "rocklab/table_state_t.hpp"
#include "tests/scratch.h"

namespace rocklab {
namespace {

struct Sent {
  std::string channel;
  std::vector<std::uint8_t> bytes;
  std::int64_t utime{};
};

template <class Msg>
void Add(std::vector<Sent>& out, const std::string& channel, const Msg& m) {
  std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  out.push_back({channel, std::move(b), m.utime});
}

// The numbers left out, per channel (and sender).
const std::map<std::string, std::set<int>> kLost = {
    {"RL_RAW", {3}},          {"RL_THETA", {4, 5}},      {"RL_TABLE", {6, 7, 8}},
    {"RL_DAQ_CONFIG", {2}},   {"RL_MODEL_a", {10, 11, 12, 13}}, {"RL_COMPARE_a", {7}},
    {"RL_EVENT/daq", {1}},    {"RL_EVENT/model", {15, 16}},
    {"RL_HEALTH/daq", {5}},   {"RL_HEALTH/compare", {9}}};
// Missing per channel, and forward jumps (one per run of numbers left out).
const std::map<std::string, std::int64_t> kMissing = {
    {"RL_RAW", 1},     {"RL_THETA", 2},    {"RL_TABLE", 3}, {"RL_DAQ_CONFIG", 1},
    {"RL_MODEL_a", 4}, {"RL_COMPARE_a", 1}, {"RL_EVENT", 3}, {"RL_HEALTH", 2}};
const std::map<std::string, std::int64_t> kGaps = {
    {"RL_RAW", 1},     {"RL_THETA", 1},    {"RL_TABLE", 1}, {"RL_DAQ_CONFIG", 1},
    {"RL_MODEL_a", 1}, {"RL_COMPARE_a", 1}, {"RL_EVENT", 2}, {"RL_HEALTH", 2}};
// Channels whose type changed (no seq in an older log).
const std::set<std::string> kVersioned = {"RL_DAQ_CONFIG", "RL_MODEL_a", "RL_COMPARE_a", "RL_EVENT",
                                          "RL_HEALTH"};
constexpr int kPerStream = 20;

bool Lost(const std::string& stream, int k) {
  const auto it = kLost.find(stream);
  return it != kLost.end() && it->second.count(k) > 0;
}

// 1 kHz sample clock; each channel's k-th message at k ms, unless lost.
// `old_types`: the versioned channels in the older types (no seq).
std::vector<Sent> Stream(bool old_types) {
  std::vector<Sent> out;
  for (int k = 0; k < kPerStream; ++k) {
    const std::int64_t utime = 1'000'000 + 1000 * k;
    if (!Lost("RL_DAQ_CONFIG", k)) {
      rocklab::daq_config2_t c{};
      c.utime = utime;
      c.seq = k;
      c.rig_name = "rig";
      c.sample_rate_hz = 1000;
      c.num_channels = 1;
      c.channel_names = {"x"};
      c.channel_units = {"m"};
      c.channel_sensors = {"table_disp"};
      c.gain = {1};
      c.offset = {0};
      if (old_types) {
        rocklab::daq_config_t o{};
        o.utime = c.utime;
        o.rig_name = c.rig_name;
        o.sample_rate_hz = c.sample_rate_hz;
        o.num_channels = 1;
        o.channel_names = c.channel_names;
        o.channel_units = c.channel_units;
        o.channel_sensors = c.channel_sensors;
        o.gain = c.gain;
        o.offset = c.offset;
        Add(out, "RL_DAQ_CONFIG", o);
      } else {
        Add(out, "RL_DAQ_CONFIG", c);
      }
    }
    if (!Lost("RL_RAW", k)) {
      rocklab::raw_frame_t r{};
      r.utime = utime;
      r.seq = k;
      r.num_channels = 1;
      r.values = {0.001 * k};
      Add(out, "RL_RAW", r);
    }
    if (!Lost("RL_THETA", k)) {
      rocklab::block_state_t t{};
      t.utime = utime;
      t.seq = k;
      t.theta = 0.001 * k;
      Add(out, "RL_THETA", t);
    }
    if (!Lost("RL_TABLE", k)) {
      rocklab::table_state_t t{};
      t.utime = utime;
      t.seq = k;
      t.acceleration = 0.1;
      Add(out, "RL_TABLE", t);
    }
    if (!Lost("RL_MODEL_a", k)) {
      rocklab::model_state3_t m{};
      m.utime = utime;
      m.seq = k;
      m.name = "a";
      m.model = "housner";
      m.theta = 0.001 * k;
      m.alpha = 0.235;
      m.p = 3.884;
      m.mu = 0.937;
      if (old_types) {
        rocklab::model_state2_t o{};
        o.utime = m.utime;
        o.name = m.name;
        o.model = m.model;
        o.theta = m.theta;
        o.alpha = m.alpha;
        o.p = m.p;
        o.mu = m.mu;
        Add(out, "RL_MODEL_a", o);
      } else {
        Add(out, "RL_MODEL_a", m);
      }
    }
    if (!Lost("RL_COMPARE_a", k)) {
      rocklab::comparison2_t c{};
      c.utime = utime;
      c.seq = k;
      c.name = "a";
      c.samples = k;
      if (old_types) {
        rocklab::comparison_t o{};
        o.utime = c.utime;
        o.name = c.name;
        o.samples = c.samples;
        Add(out, "RL_COMPARE_a", o);
      } else {
        Add(out, "RL_COMPARE_a", c);
      }
    }
    for (const char* sender : {"daq", "model"}) {
      if (Lost(std::string("RL_EVENT/") + sender, k)) continue;
      rocklab::event2_t e{};
      e.utime = utime;
      e.seq = k;
      e.sender = sender;
      e.source = sender;
      e.kind = rocklab::event2_t::COMMENT;
      e.detail = "event";
      if (old_types) {
        rocklab::event_t o{};
        o.utime = e.utime;
        o.source = e.source;
        o.kind = e.kind;
        o.detail = e.detail;
        Add(out, "RL_EVENT", o);
      } else {
        Add(out, "RL_EVENT", e);
      }
    }
    for (const char* node : {"daq", "compare"}) {
      if (Lost(std::string("RL_HEALTH/") + node, k)) continue;
      rocklab::health2_t h{};
      h.utime = utime;
      h.seq = k;
      h.sender = node;
      h.node = node;
      h.state = "running";
      if (old_types) {
        rocklab::health_t o{};
        o.utime = h.utime;
        o.node = h.node;
        o.state = h.state;
        Add(out, "RL_HEALTH", o);
      } else {
        Add(out, "RL_HEALTH", h);
      }
    }
  }
  return out;
}

std::string WriteLog(const std::string& name, const std::vector<Sent>& sent) {
  const std::string path = test::ScratchDir("seq_loss") + "/" + name;
  common::LogWriter log(path);
  for (const Sent& s : sent) log.Write(s.channel, s.bytes.data(), s.bytes.size(), s.utime);
  EXPECT_TRUE(log.Close());
  return path;
}

std::int64_t Expected(const std::map<std::string, std::int64_t>& m, const std::string& channel, bool old_types) {
  if (old_types && kVersioned.count(channel) > 0) return -1;  // no seq: nothing to count
  return m.at(channel);
}

class SeqLoss : public ::testing::TestWithParam<bool> {};

TEST_P(SeqLoss, TheRecorderCountsTheLossOfEveryChannel) {
  const bool old_types = GetParam();
  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  record::RecorderOptions o;
  o.out_path = test::ScratchDir("seq_loss") + (old_types ? "/rec_old.lcm" : "/rec.lcm");
  record::Recorder rec(lcm, o);
  for (const Sent& s : Stream(old_types)) {
    lcm.publish(s.channel, s.bytes.data(), static_cast<unsigned>(s.bytes.size()));
    while (lcm.handleTimeout(0) > 0) {
    }
  }
  rec.Stop();
  const record::RecorderStats stats = rec.Stats();
  ASSERT_EQ(stats.channels.size(), kMissing.size());
  for (const record::ChannelStats& c : stats.channels) {
    const std::int64_t missing = Expected(kMissing, c.name, old_types);
    EXPECT_EQ(c.dropped, 0) << c.name;
    EXPECT_EQ(c.seq.any, missing >= 0) << c.name;
    EXPECT_EQ(c.seq.missing, std::max<std::int64_t>(missing, 0)) << c.name;
    EXPECT_EQ(c.seq.gaps, std::max<std::int64_t>(Expected(kGaps, c.name, old_types), 0)) << c.name;
    EXPECT_EQ(c.seq.back, 0) << c.name;  // two senders on one channel are not a step back
  }
}

TEST_P(SeqLoss, InfoCountsTheLossOfEveryChannelInALog) {
  const bool old_types = GetParam();
  const std::string path = WriteLog(old_types ? "old.lcm" : "new.lcm", Stream(old_types));
  const exporter::LogInfo info = exporter::ReadLogInfo(path);
  ASSERT_EQ(info.channels.size(), kMissing.size());
  for (const exporter::ChannelInfo& c : info.channels) {
    const std::int64_t missing = Expected(kMissing, c.name, old_types);
    EXPECT_EQ(c.undecodable, 0) << c.name;
    EXPECT_EQ(c.has_seq, missing >= 0) << c.name;
    EXPECT_EQ(c.seq_missing, std::max<std::int64_t>(missing, 0)) << c.name;
    EXPECT_EQ(c.seq_gaps, std::max<std::int64_t>(Expected(kGaps, c.name, old_types), 0)) << c.name;
    EXPECT_EQ(c.seq_back, 0) << c.name;
  }
  EXPECT_TRUE(info.has_config);
  EXPECT_EQ(info.rig, "rig");
  EXPECT_EQ(info.config_changes, 0);  // seq differs between configurations by design
  // The JSON says null where a type has no seq.
  const nlohmann::json j = exporter::ToJson(info);
  for (const nlohmann::json& c : j.at("channels")) {
    const std::string name = c.at("name").get<std::string>();
    const std::int64_t missing = Expected(kMissing, name, old_types);
    if (missing < 0) {
      EXPECT_TRUE(c.at("seq_missing").is_null()) << name;
    } else {
      EXPECT_EQ(c.at("seq_missing").get<std::int64_t>(), missing) << name;
    }
  }
}

TEST_P(SeqLoss, TheMonitorCountsTheLossOfEveryChannel) {
  const bool old_types = GetParam();
  monitor::LiveState live;
  for (const Sent& s : Stream(old_types)) live.Ingest(s.channel, s.bytes.data(), static_cast<int>(s.bytes.size()));
  const nlohmann::json counters = live.Snapshot().at("counters");
  for (const auto& [channel, missing] : kMissing) {
    EXPECT_EQ(counters.at("decode_errors").value(channel, std::int64_t{-1}), 0) << channel;
    const std::int64_t want = Expected(kMissing, channel, old_types);
    EXPECT_EQ(counters.at("seq_missing").value(channel, std::int64_t{-1}), want) << channel;
    EXPECT_EQ(counters.at("seq_gaps").value(channel, std::int64_t{-1}), Expected(kGaps, channel, old_types))
        << channel;
  }
  // The older types are shown all the same.
  const nlohmann::json snap = live.Snapshot();
  ASSERT_EQ(snap.at("variants").size(), 1u);
  EXPECT_EQ(counters.at("messages").at("RL_MODEL_a"), kPerStream - 4);
  EXPECT_FALSE(snap.at("variants")[0].at("theta").at("t").empty());
  EXPECT_FALSE(snap.at("variants")[0].at("latest").is_null());
  EXPECT_EQ(snap.at("health").size(), 2u);
  EXPECT_EQ(snap.at("config").at("rig_name"), "rig");
}

TEST_P(SeqLoss, TheReportSaysHowManyMessagesAreMissing) {
  const bool old_types = GetParam();
  const std::string path = WriteLog(old_types ? "old_report.lcm" : "new_report.lcm", Stream(old_types));
  const report::RecordReport r = report::ReadRecordLog(path);
  std::int64_t want = 0;
  for (const auto& [channel, missing] : kMissing) want += std::max<std::int64_t>(Expected(kMissing, channel, old_types), 0);
  EXPECT_EQ(r.seq_missing, want);
  EXPECT_EQ(r.decode_errors, 0);
  EXPECT_EQ(r.snapshot.at("variants").size(), 1u);
}

// The seq is a column of the export like every other field (after utime, as
// in the .lcm file); an older log's tables have none and keep their rows.
TEST_P(SeqLoss, ExportWritesTheSeqColumn) {
  const bool old_types = GetParam();
  const std::string dir = test::ScratchDir("seq_loss_export");
  const std::string path = WriteLog(old_types ? "old_export.lcm" : "new_export.lcm", Stream(old_types));
  const std::string out = dir + (old_types ? "/old.csv" : "/new.csv");
  {
    std::unique_ptr<exporter::TableSink> sink = exporter::OpenSink(out, false);
    const exporter::ExportSummary s = exporter::ExportLog(path, exporter::ExportOptions{}, *sink);
    EXPECT_EQ(s.undecodable, 0);
    EXPECT_EQ(s.unknown_type, 0);
    sink->Close();
  }
  for (const char* channel : {"RL_MODEL_a", "RL_COMPARE_a", "RL_EVENT", "RL_HEALTH", "RL_DAQ_CONFIG"}) {
    std::ifstream in(dir + (old_types ? "/old_" : "/new_") + channel + ".csv");
    std::string header, line;
    ASSERT_TRUE(std::getline(in, header)) << channel;
    int rows = 0;
    while (std::getline(in, line)) rows += !line.empty() && line[0] != '#';
    const bool has_seq = header.find(",seq,") != std::string::npos;
    EXPECT_EQ(has_seq, !old_types) << channel << ": " << header;
    EXPECT_GT(rows, 0) << channel;
  }
}

// Loss told from disorder, the same in every reader (docs/channels.md "Loss
// and disorder"). Oracle: RL_THETA numbered 0..299 with 5 lost (20, 40, 41,
// 60, 61 gone), 10 and 11 swapped, 100 sent after 200, 70 sent twice and
// one extra message numbered a million ahead: 5 missing in 3 runs, 2 late,
// 1 duplicate, 1 wild. The old rule counted 106 to 1 000 005 missing here.
std::vector<Sent> DisorderedTheta() {
  std::vector<std::int64_t> order;
  for (std::int64_t k = 0; k < 300; ++k) {
    if (k == 20 || k == 40 || k == 41 || k == 60 || k == 61 || k == 100) continue;
    order.push_back(k);
    if (k == 70) order.push_back(70);
    if (k == 150) order.push_back(150 + 1'000'000);
    if (k == 200) order.push_back(100);
  }
  std::swap(order[10], order[11]);
  std::vector<Sent> out;
  for (std::int64_t k : order) {
    rocklab::block_state_t t{};
    t.utime = 1'000'000 + 1000 * (k % 1'000'000);
    t.seq = k;
    t.theta = 0.001;
    Add(out, "RL_THETA", t);
  }
  return out;
}

template <class Counts>
void ExpectDisorderCounts(const Counts& c, const char* who) {
  EXPECT_EQ(c.missing, 5) << who;
  EXPECT_EQ(c.gaps, 3) << who;
  EXPECT_EQ(c.late, 2) << who;
  EXPECT_EQ(c.duplicates, 1) << who;
  EXPECT_EQ(c.wild, 1) << who;
  EXPECT_EQ(c.restarts, 0) << who;
}

TEST(SeqLoss, DisorderIsNotLossInEveryReader) {
  const std::vector<Sent> sent = DisorderedTheta();
  {  // the recorder
    lcm::LCM lcm("memq://");
    ASSERT_TRUE(lcm.good());
    record::RecorderOptions o;
    o.out_path = test::ScratchDir("seq_loss") + "/disorder_rec.lcm";
    record::Recorder rec(lcm, o);
    for (const Sent& s : sent) {
      lcm.publish(s.channel, s.bytes.data(), static_cast<unsigned>(s.bytes.size()));
      while (lcm.handleTimeout(0) > 0) {
      }
    }
    rec.Stop();
    const record::RecorderStats stats = rec.Stats();
    ASSERT_EQ(stats.channels.size(), 1u);
    ExpectDisorderCounts(stats.channels[0].seq, "record");
    const nlohmann::json j = nlohmann::json::parse(record::SummaryJson(stats));
    EXPECT_EQ(j.at("seq_missing"), 5);
    EXPECT_EQ(j.at("channels")[0].at("seq_late"), 2);
    EXPECT_EQ(j.at("channels")[0].at("seq_wild"), 1);
  }
  {  // info
    const exporter::LogInfo info = exporter::ReadLogInfo(WriteLog("disorder.lcm", sent));
    ASSERT_EQ(info.channels.size(), 1u);
    const exporter::ChannelInfo& c = info.channels[0];
    EXPECT_EQ(c.seq_missing, 5);
    EXPECT_EQ(c.seq_gaps, 3);
    EXPECT_EQ(c.seq_late, 2);
    EXPECT_EQ(c.seq_duplicates, 1);
    EXPECT_EQ(c.seq_wild, 1);
    EXPECT_EQ(exporter::ToJson(info).at("channels")[0].at("seq_duplicates"), 1);
  }
  {  // the monitor
    monitor::LiveState live;
    for (const Sent& s : sent) live.Ingest(s.channel, s.bytes.data(), static_cast<int>(s.bytes.size()));
    const nlohmann::json counters = live.Snapshot().at("counters");
    EXPECT_EQ(counters.at("seq_missing").at("RL_THETA"), 5);
    EXPECT_EQ(counters.at("seq_gaps").at("RL_THETA"), 3);
    EXPECT_EQ(counters.at("seq_disorder").at("RL_THETA").at("late"), 2);
    EXPECT_EQ(counters.at("seq_disorder").at("RL_THETA").at("wild"), 1);
  }
}

INSTANTIATE_TEST_SUITE_P(CurrentAndOlderTypes, SeqLoss, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& p) { return p.param ? "OlderTypes" : "CurrentTypes"; });

}  // namespace
}  // namespace rocklab
