// Log replay: payloads byte for byte and in order, channel filter, time
// window, loop, pacing, and errors naming the file.
#include "tools/log_replay.h"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "tests/tools/run_cli.h"

namespace rocklab::tools {
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

struct Catch {
  void On(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    got.push_back(channel + ":" + std::string(static_cast<const char*>(rbuf->data), rbuf->data_size));
  }
  std::vector<std::string> got;
};

std::vector<std::string> Play(const std::string& path, const ReplayOptions& o, ReplayCounts* counts) {
  lcm::LCM lcm("memq://");
  Catch c;
  lcm.subscribe(".*", &Catch::On, &c);
  std::atomic<bool> stop{false};
  *counts = ReplayLog(path, o, lcm, stop);
  while (lcm.handleTimeout(0) > 0) {
  }
  return c.got;
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
  lcm::LCM lcm("memq://");
  std::atomic<bool> stop{false};
  std::thread stopper([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    stop.store(true);
  });
  const ReplayCounts n = ReplayLog(WriteLog("loop.lcm"), o, lcm, stop);
  stopper.join();
  EXPECT_GE(n.passes, 3);
  EXPECT_GE(n.published, 10);
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

}  // namespace
}  // namespace rocklab::tools
