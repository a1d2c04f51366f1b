// Log replay: payloads byte for byte and in order, channel filter, time
// window, loop, pacing, and errors naming the file; `replay --rig --input`:
// a raw file through the DAQ stage, and the usage errors of the two forms.
#include "pipeline/log_replay.h"

#include <signal.h>

#include <gtest/gtest.h>

#include <lcm/lcm-cpp.hpp>

#include <chrono>
#include <memory>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <thread>
#include <utility>
#include <vector>

#include "common/direct_bus.h"
#include "rocklab/event2_t.hpp"
#include "tests/skip.h"
#include "tests/tools/run_cli.h"
#include "tests/tools/udpm_netns.h"
#include "tests/source_paths.h"

namespace rocklab::pipeline {
namespace {

// A log of 30 events, 10 ms apart, cycling over three channels; payload k
// is the 4 bytes "evNN".
std::string WriteLog(const std::string& name) {
  const std::string path = test::ScratchDir("replay") + "/" + name;
  lcm::LogFile log(path, "w");
  const char* channels[] = {"RL_THETA", "RL_TABLE", "OTHER"};
  for (int k = 0; k < 30; ++k) {
    char payload[8];
    std::snprintf(payload, sizeof payload, "ev%02d", k);
    lcm::LogEvent ev{};
    ev.timestamp = 1'000'000'000 + 10'000 * k;
    ev.channel = channels[k % 3];
    ev.datalen = 4;
    ev.data = payload;
    log.writeEvent(&ev);
  }
  return path;
}

std::vector<std::string> Play(const std::string& path, const ReplayOptions& o, ReplayCounts* counts) {
  common::DirectBus bus;
  std::vector<std::string> got;
  const common::Subscription tap = bus.SubscribeRaw(".*", [&got](const std::string& channel, const void* data, int size) {
    got.push_back(channel + ":" + std::string(static_cast<const char*>(data), size));
  });
  std::atomic<bool> stop{false};
  *counts = ReplayLog(path, o, bus, stop);
  return got;
}

// Sets `stop` when the n-th event is published on `bus` (a DirectBus
// delivers on the publisher's thread: the replay sees the stop before its
// next event). A condition, not a sleep.
// The subscription lasts as long as the returned handle.
common::Subscription StopAtEvent(common::DirectBus& bus, std::atomic<bool>& stop, std::int64_t n) {
  auto count = std::make_shared<std::int64_t>(0);  // shared: owned by the handler
  return bus.SubscribeRaw(".*", [count, &stop, n](const std::string&, const void*, int) {
    if (++*count >= n) stop.store(true);
  });
}

// Oracle: the log as written: every event, in order, payload unchanged.
TEST(Replay, MaxSpeedRepublishesEverythingInOrder) {
  ReplayOptions o;
  o.max_speed = true;
  ReplayCounts n;
  const auto got = Play(WriteLog("all.lcm"), o, &n);
  ASSERT_EQ(got.size(), 30u);
  EXPECT_EQ(got.front(), "RL_THETA:ev00");
  EXPECT_EQ(got[1], "RL_TABLE:ev01");
  EXPECT_EQ(got.back(), "OTHER:ev29");
  EXPECT_EQ(n.published, 30);
  EXPECT_EQ(n.per_channel.at("RL_TABLE"), 10);
}

// Oracle: the regex matches whole channel names; the window is [start, end]
// in s after the first event: 50 ms .. 150 ms holds events 5 .. 15.
TEST(Replay, FilterAndWindow) {
  ReplayOptions o;
  o.max_speed = true;
  o.channels = "RL_.*";
  o.start_s = 0.05;
  o.end_s = 0.15;
  ReplayCounts n;
  const auto got = Play(WriteLog("window.lcm"), o, &n);
  EXPECT_EQ(n.read, 11);
  ASSERT_FALSE(got.empty());
  EXPECT_EQ(got.front(), "RL_THETA:ev06");  // ev05 is on OTHER
  EXPECT_EQ(got.back(), "RL_THETA:ev15");
  for (const auto& g : got) EXPECT_EQ(g.rfind("RL_", 0), 0u) << g;
  EXPECT_EQ(n.filtered + n.published, n.read);
}

// Oracle: looping plays the window again from its start until stopped.
TEST(Replay, LoopPlaysAgainUntilStopped) {
  ReplayOptions o;
  o.max_speed = true;
  o.loop = true;
  o.end_s = 0.045;  // events 0..4
  common::DirectBus lcm;
  std::atomic<bool> stop{false};
  // The stop comes with the first event of the fourth pass (5 events a
  // pass), not after a fixed time: the DirectBus delivers on the replay's
  // own thread, so the count is exact however loaded the machine is.
  const common::Subscription stopper = StopAtEvent(lcm, stop, 3 * 5 + 1);
  const ReplayCounts n = ReplayLog(WriteLog("loop.lcm"), o, lcm, stop);
  EXPECT_EQ(n.passes, 4);
  EXPECT_EQ(n.published, 16);
}

// Oracle: the pace: 290 ms of log at speed 2 cannot take less than 145 ms
// (only a lower bound: a loaded machine may take longer).
TEST(Replay, SpeedFactorPacesByTheLogTimestamps) {
  ReplayOptions o;
  o.speed = 2.0;
  ReplayCounts n;
  const auto t0 = std::chrono::steady_clock::now();
  Play(WriteLog("paced.lcm"), o, &n);
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(n.published, 30);
  EXPECT_GE(elapsed, 0.145);
}

TEST(Replay, BadInputsNameTheProblem) {
  const test::CliResult missing = test::RunCli({"replay", "scratch/no-such.lcm", "--max"});
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find("no-such.lcm"), std::string::npos) << missing.err;
  const test::CliResult both = test::RunCli({"replay", "x.lcm", "--max", "--speed", "2"});
  EXPECT_EQ(both.exit_code, 2);
  EXPECT_NE(both.err.find("--max"), std::string::npos) << both.err;
  const test::CliResult regex = test::RunCli({"replay", WriteLog("r.lcm"), "--channels", "(", "--max"});
  EXPECT_EQ(regex.exit_code, 2);
  EXPECT_NE(regex.err.find("--channels"), std::string::npos) << regex.err;
  const test::CliResult speed = test::RunCli({"replay", WriteLog("s.lcm"), "--speed", "0"});
  EXPECT_EQ(speed.exit_code, 2);
  EXPECT_NE(speed.err.find("--speed"), std::string::npos) << speed.err;
}

// A log as `rocklab run --log` wrote them before its stamps kept in order:
// RL_HEALTH "starting" stamped 0, the one start-of-test RL_DAQ_CONFIG, then
// 5 s of 1 kHz RL_RAW (sample k stamped k ms), each followed by the RL_THETA
// of 45 samples earlier (the differentiators' delay): the stamps go back
// after every RL_RAW. Payloads are the sample number as text.
std::string WriteDemoLikeLog(const std::string& name, int samples = 5000) {
  const std::string path = test::ScratchDir("replay") + "/" + name;
  lcm::LogFile log(path, "w");
  std::int64_t number = 0;
  auto put = [&](const char* channel, std::int64_t stamp, const std::string& payload) {
    lcm::LogEvent ev{};
    ev.eventnum = number++;
    ev.timestamp = stamp;
    ev.channel = channel;
    ev.datalen = static_cast<std::int32_t>(payload.size());
    ev.data = const_cast<char*>(payload.data());
    log.writeEvent(&ev);
  };
  put("RL_HEALTH", 0, "starting");
  put("RL_DAQ_CONFIG", 0, "config");
  for (int k = 0; k < samples; ++k) {
    put("RL_RAW", 1000LL * k, std::to_string(k));
    if (k >= 45) put("RL_THETA", 1000LL * (k - 45), std::to_string(k - 45));
  }
  return path;
}

// Oracle: the count of events written (2 + 5000 + 4955): every one is
// published, the start-of-test RL_DAQ_CONFIG first among the data.
TEST(Replay, EveryEventOfALogWhoseStampsGoBack) {
  ReplayOptions o;
  o.max_speed = true;
  common::DirectBus lcm;
  std::atomic<bool> stop{false};
  const ReplayCounts n = ReplayLog(WriteDemoLikeLog("demo_like.lcm"), o, lcm, stop);
  EXPECT_EQ(n.published, 2 + 5000 + 4955);
  EXPECT_EQ(n.per_channel.at("RL_DAQ_CONFIG"), 1);
  EXPECT_EQ(n.per_channel.at("RL_HEALTH"), 1);
  EXPECT_EQ(n.per_channel.at("RL_RAW"), 5000);
  EXPECT_EQ(n.damaged_regions, 0);
}

// Oracle: the window [2 s, 3 s] holds RL_RAW 2000 to 3000, both ends
// included: 1001 of them, and RL_THETA of the same stamps (also 1001).
TEST(Replay, WindowReturnsEveryRawFrameOfIt) {
  ReplayOptions o;
  o.max_speed = true;
  o.start_s = 2;
  o.end_s = 3;
  common::DirectBus lcm;
  std::atomic<bool> stop{false};
  const ReplayCounts n = ReplayLog(WriteDemoLikeLog("window_2_3.lcm"), o, lcm, stop);
  EXPECT_EQ(n.per_channel.at("RL_RAW"), 1001);
  EXPECT_EQ(n.per_channel.at("RL_THETA"), 1001);
  EXPECT_EQ(n.published, 2002);
}

// Oracle: every pass plays the whole log again, so each publishes the
// start-of-test RL_DAQ_CONFIG (the last, stopped pass may not reach it).
TEST(Replay, EveryLoopPassPublishesTheStartOfTestConfig) {
  ReplayOptions o;
  o.max_speed = true;
  o.loop = true;
  common::DirectBus lcm;
  std::atomic<bool> stop{false};
  const common::Subscription stopper = StopAtEvent(lcm, stop, 3 * (2 + 200 + 155) + 1);  // the first event of the fourth pass
  const ReplayCounts n = ReplayLog(WriteDemoLikeLog("loop_config.lcm", 200), o, lcm, stop);
  ASSERT_GE(n.passes, 3);
  EXPECT_GE(n.per_channel.at("RL_DAQ_CONFIG"), n.passes - 1);
  EXPECT_LE(n.per_channel.at("RL_DAQ_CONFIG"), n.passes);
  EXPECT_GE(n.published, static_cast<std::int64_t>(n.passes - 1) * (2 + 200 + 155));
}

// Oracle: one flipped sync bit (event 20's first byte) and a tail cut 10
// bytes into the last event lose exactly those two events; both regions
// are reported with their offsets, and the CLI exits 1 after publishing the
// rest.
TEST(Replay, FlippedSyncBitAndCutTailAreReportedAndTheRestPublished) {
  const std::string path = WriteLog("damaged.lcm");
  // Every event of WriteLog: 28-byte header, channel, 4-byte payload.
  std::int64_t offset20 = 0, offset29 = 0, at = 0;
  const char* channels[] = {"RL_THETA", "RL_TABLE", "OTHER"};
  for (int k = 0; k < 30; ++k) {
    if (k == 20) offset20 = at;
    if (k == 29) offset29 = at;
    at += 28 + static_cast<std::int64_t>(std::strlen(channels[k % 3])) + 4;
  }
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(offset20);
    f.put(static_cast<char>(0xED ^ 0x01));
  }
  std::filesystem::resize_file(path, static_cast<std::uintmax_t>(offset29 + 10));
  ReplayOptions o;
  o.max_speed = true;
  common::DirectBus lcm;
  std::atomic<bool> stop{false};
  std::vector<std::string> problems;
  const ReplayCounts n =
      ReplayLog(path, o, lcm, stop, [&](const std::string& p) { problems.push_back(p); });
  EXPECT_EQ(n.published, 28);
  EXPECT_EQ(n.damaged_regions, 2);
  EXPECT_EQ(n.damaged_events, 2);
  ASSERT_EQ(problems.size(), 2u);
  EXPECT_NE(problems[0].find("damaged region at byte offset " + std::to_string(offset20)),
            std::string::npos) << problems[0];
  EXPECT_NE(problems[1].find("damaged region at byte offset " + std::to_string(offset29)),
            std::string::npos) << problems[1];

  const test::CliResult r = test::RunCli({"replay", path, "--max", "--lcm-url", "memq://"});
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("damaged region at byte offset " + std::to_string(offset20)),
            std::string::npos) << r.err;
  EXPECT_NE(r.err.find("replayed 28 events"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("2 regions skipped"), std::string::npos) << r.err;
}

using ::rocklab::test::kLabRig;  // tests/source_paths.h
const std::string kFreeRocking = std::string(ROCKLAB_SOURCE_DIR) + "/data/samples/free_rocking.csv";

// Oracle: the CLI's error convention (tools/cli.h): exit 2, one line naming
// what is wrong; the LOG form's options are refused with --rig.
TEST(ReplayRaw, LogAndRawFormsDoNotMix) {
  const std::string log = WriteLog("mix.lcm");
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"replay", log, "--rig", kLabRig, "--input", kFreeRocking},
       "replay: give either LOG.lcm (a recorded log) or --rig RIG.toml --input RAW (a raw file "
       "through the DAQ stage), not both"},
      {{"replay", "--max"},
       "replay: give LOG.lcm (a recorded log) or --rig RIG.toml --input RAW (a raw file through "
       "the DAQ stage)"},
      {{"replay", "--rig", kLabRig}, "replay: --rig needs --input RAW (CSV, LVM or LCM log)"},
      {{"replay", "--input", kFreeRocking}, "replay: --input needs --rig RIG.toml"},
      {{"replay", "--rig", kLabRig, "--input", kFreeRocking, "--loop"},
       "replay: --loop applies to LOG.lcm only, not to --rig --input (the DAQ stage plays the "
       "whole raw file)"},
      {{"replay", "--rig", kLabRig, "--input", kFreeRocking, "--channels", "RL_RAW"},
       "replay: --channels applies to LOG.lcm only, not to --rig --input (the DAQ stage plays "
       "the whole raw file)"},
      {{"replay", "--rig", kLabRig, "--input", kFreeRocking, "--speed", "0"},
       "--speed must be > 0, got 0"},
      {{"replay", "--rig", kLabRig, "--input", "/nonexistent.csv", "--max"},
       "/nonexistent.csv: cannot open the input file"},
  };
  for (const auto& [args, message] : cases) {
    const test::CliResult r = test::RunCli(args);
    EXPECT_EQ(r.exit_code, 2) << args.back();
    EXPECT_EQ(r.err, "rocklab: " + message + "\n");
  }
}

// Oracle: the file's 1001 data rows (1 s at 1 kHz, samples 0 to 1000, none
// dropped), all sent through the DAQ stage.
TEST(ReplayRaw, SendsEveryFrameOfTheRawFileThroughTheDaqStage) {
  const test::CliResult r = test::RunCli(
      {"replay", "--rig", kLabRig, "--input", kFreeRocking, "--max", "--lcm-url", "memq://"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("replay: 1001 frames read"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("(0 failed), 0 gaps (0 samples missing)"), std::string::npos) << r.err;
}

// The DAQ's messages of a log, in order: (channel, payload). RL_HEALTH
// (host-clock rates) and the test's probes are left out; RL_EVENT only
// from the DAQ.
std::vector<std::pair<std::string, std::string>> DaqMessages(const std::string& path) {
  lcm::LogFile log(path, "r");
  EXPECT_TRUE(log.good()) << path;
  std::vector<std::pair<std::string, std::string>> out;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    std::string data(static_cast<const char*>(ev->data), ev->datalen);
    bool keep = ev->channel == "RL_DAQ_CONFIG" || ev->channel == "RL_RAW" ||
                ev->channel == "RL_TABLE" || ev->channel == "RL_THETA";
    if (ev->channel == "RL_EVENT") {
      rocklab::event2_t e;
      keep = e.decode(ev->data, 0, ev->datalen) >= 0 && e.source == "daq";
    }
    if (keep) out.emplace_back(ev->channel, std::move(data));
  }
  return out;
}

// `rocklab replay --rig --input` over udpm in a private network namespace,
// recorded by rocklab record. Oracle: the DAQ's messages of `rocklab run --log`
// on the same file (the same DaqNode, stages in one process), byte for byte
// and in order: every message carries the sample clock, never the host's.
// At the sample clock's pace (--speed 1). RL_RAW goes on its own udpm group
// (common/bus_urls.h), so the order holds within each bus: RL_RAW in order,
// and every other channel in order; how the two interleave is receipt order.
TEST(ReplayRaw, PublishesWhatTheDaqStageOfRunPublishes) {
  const std::string dir = test::ScratchDir("replay_raw");
  const std::string run_log = dir + "/run.lcm";
  const test::CliResult run = test::RunCli(
      {"run", "--rig", kLabRig, "--input", kFreeRocking, "--max", "--log", run_log});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::string why = test::EnterPrivateNetwork();
  if (!why.empty()) ROCKLAB_SKIP(why);
  const std::string log = dir + "/replay.lcm";
  const pid_t logger = test::StartRecorder(log);
  ASSERT_GT(logger, 0) << test::ReadFile(log + ".err");
  const pid_t replay = test::StartCli({"replay", "--rig", kLabRig, "--input", kFreeRocking,
                                       "--speed", "1", "--lcm-url", test::kUdpmUrl},
                                      dir + "/replay.out", dir + "/replay.err");
  EXPECT_EQ(test::StopProcess(replay, 0), 0) << test::ReadFile(dir + "/replay.err");
  EXPECT_EQ(test::StopRecorder(logger, log), 0);

  const auto want = DaqMessages(run_log);
  const auto got = DaqMessages(log);
  ASSERT_GT(want.size(), 3000u);  // RL_RAW, RL_THETA, RL_TABLE for ~1000 frames
  ASSERT_EQ(got.size(), want.size());
  for (const bool raw_bus : {true, false}) {
    std::vector<std::pair<std::string, std::string>> w, g;
    for (const auto& m : want) {
      if ((m.first == "RL_RAW") == raw_bus) w.push_back(m);
    }
    for (const auto& m : got) {
      if ((m.first == "RL_RAW") == raw_bus) g.push_back(m);
    }
    ASSERT_EQ(g.size(), w.size()) << (raw_bus ? "RL_RAW" : "the main bus");
    for (std::size_t i = 0; i < w.size(); ++i) {
      ASSERT_EQ(g[i].first, w[i].first) << "message " << i << (raw_bus ? " of RL_RAW" : " of the main bus");
      ASSERT_EQ(g[i].second, w[i].second) << "message " << i << " on " << w[i].first;
    }
  }
}

}  // namespace
}  // namespace rocklab::pipeline
