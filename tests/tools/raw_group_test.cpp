// RL_RAW on its own udpm group and port (common/bus_urls.h), through the
// binary in a private network namespace (ttl=0, lo only): while `rocklab
// daq` or `rocklab replay` runs, a subscriber of the main group receives no
// RL_RAW but the rest, and `rocklab record` (both buses by default) writes
// every RL_RAW and every other message into one log; `--raw-url same` puts
// RL_RAW back on the main group; a bad --raw-url is refused naming the option.
// Oracle: the publishers' own counts (the daq's "N frames read, M messages
// published" and replay's per-channel summary), compared exactly: at 1 kHz
// on lo with 4-16 MiB socket buffers nothing is lost, and the recorder's
// summary must say 0 dropped (a loss would show, not pass unseen).
#include <signal.h>

#include <gtest/gtest.h>

#include <lcm/lcm-cpp.hpp>

#include <atomic>
#include <cstdio>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/skip.h"
#include "tests/tools/run_cli.h"
#include "tests/tools/udpm_netns.h"
#include "tests/source_paths.h"

namespace rocklab::test {
namespace {

using ::rocklab::test::kLabRig;  // tests/source_paths.h
// 1 s at 1 kHz (1001 rows).
const std::string kFreeRocking = std::string(ROCKLAB_SOURCE_DIR) + "/data/samples/free_rocking.csv";

// Counts, per channel, what an LCM instance on the main group receives, on
// a thread of its own, until destroyed.
class MainGroupListener {
 public:
  MainGroupListener() : lcm_(std::string(kUdpmUrl) + "&recv_buf_size=4194304") {
    lcm::Subscription* sub = lcm_.subscribeFunction(".*", &MainGroupListener::OnMessage, this);
    if (sub != nullptr) sub->setQueueCapacity(1 << 20);
    thread_ = std::thread([this] {
      while (!stop_.load()) lcm_.handleTimeout(20);
    });
  }
  ~MainGroupListener() {
    stop_.store(true);
    thread_.join();
  }
  bool good() { return lcm_.good(); }
  std::int64_t Count(const std::string& channel) {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = counts_.find(channel);
    return it == counts_.end() ? 0 : it->second;
  }
  /// TEST_PROBE "sync" messages seen: StopRecorder publishes them after the
  /// publisher ended, so one here means the main group's earlier datagrams
  /// were all handled (one socket, in order).
  std::int64_t syncs() {
    std::lock_guard<std::mutex> lock(mutex_);
    return syncs_;
  }

 private:
  static void OnMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel, MainGroupListener* self) {
    std::lock_guard<std::mutex> lock(self->mutex_);
    ++self->counts_[channel];
    if (channel == "TEST_PROBE" && rbuf->data_size == 4 &&
        std::string(static_cast<const char*>(rbuf->data), 4) == "sync") {
      ++self->syncs_;
    }
  }
  lcm::LCM lcm_;
  std::mutex mutex_;
  std::map<std::string, std::int64_t> counts_;
  std::int64_t syncs_{0};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

std::map<std::string, std::int64_t> LogCounts(const std::string& path) {
  std::map<std::string, std::int64_t> n;
  lcm::LogFile log(path, "r");
  while (log.good()) {
    const lcm::LogEvent* ev = log.readNextEvent();
    if (ev == nullptr) break;
    if (ev->channel != "TEST_PROBE") ++n[ev->channel];
  }
  return n;
}

std::int64_t Sum(const std::map<std::string, std::int64_t>& counts) {
  std::int64_t total = 0;
  for (const auto& [channel, n] : counts) total += n;
  return total;
}

struct DaqSummary {
  long long frames{-1}, published{-1}, failed{-1};
};

// "<what>: N frames read, M messages published (F failed), ..." in `err`.
DaqSummary ParseDaqSummary(const std::string& err, const std::string& what) {
  DaqSummary s;
  const auto at = err.find(what + ": ");
  if (at != std::string::npos) {
    std::sscanf(err.c_str() + at + what.size() + 2, "%lld frames read, %lld messages published (%lld failed)",
                &s.frames, &s.published, &s.failed);
  }
  return s;
}

// The recorder's summary line "rocklab record: E events written (R received, D dropped)".
long long RecorderDropped(const std::string& err) {
  long long written = -1, received = -1, dropped = -1;
  const auto at = err.find("rocklab record: ");
  const auto line = err.find(" events written", at);
  if (at == std::string::npos || line == std::string::npos) return -1;
  const auto start = err.rfind("rocklab record: ", line);
  std::sscanf(err.c_str() + start, "rocklab record: %lld events written (%lld received, %lld dropped)", &written,
              &received, &dropped);
  return dropped;
}

struct Recorded {
  std::map<std::string, std::int64_t> logged;  ///< per channel, TEST_PROBE left out
  std::int64_t main_raw{-1}, main_theta{-1};   ///< what the main-group listener got
  std::string err;                             ///< the publisher's stderr
  std::string recorder_err;
};

// Records (both buses) while `publisher` runs to its end, with a listener on
// the main group. `name` names the scratch files.
Recorded RecordWhile(const std::vector<std::string>& publisher, const std::string& name) {
  Recorded r;
  const std::string dir = ScratchDir("raw_group");
  const std::string log = dir + "/" + name + ".lcm";
  MainGroupListener listener;
  EXPECT_TRUE(listener.good());
  const pid_t recorder = StartRecorder(log);
  EXPECT_GT(recorder, 0) << "rocklab record did not start";
  if (recorder <= 0) return r;
  const pid_t pid = StartCli(publisher, dir + "/" + name + ".out", dir + "/" + name + ".err");
  EXPECT_EQ(StopProcess(pid, 0, 60.0), 0);  // the input ends by itself (1 s of data)
  EXPECT_EQ(StopRecorder(recorder, log), 0);
  EXPECT_TRUE(WaitUntil([&] { return listener.syncs() > 0; }, 10.0)) << "the listener saw no sync probe";
  r.logged = LogCounts(log);
  r.main_raw = listener.Count("RL_RAW");
  r.main_theta = listener.Count("RL_THETA");
  r.err = ReadFile(dir + "/" + name + ".err");
  r.recorder_err = ReadFile(log + ".err");
  EXPECT_EQ(RecorderDropped(r.recorder_err), 0) << r.recorder_err;
  return r;
}

TEST(RawGroup, DaqSendsRawFramesOffTheMainGroupAndRecordGetsEverything) {
  const std::string why = EnterPrivateNetwork();
  if (!why.empty()) ROCKLAB_SKIP(why);

  // Default: RL_RAW on udpm://239.255.76.68:7668?ttl=0.
  const Recorded split = RecordWhile(
      {"daq", "--rig", kLabRig, "--input", kFreeRocking, "--speed", "1", "--lcm-url", kUdpmUrl}, "daq");
  const DaqSummary s = ParseDaqSummary(split.err, "daq");
  ASSERT_GT(s.frames, 900) << split.err;
  EXPECT_EQ(s.failed, 0) << split.err;
  EXPECT_EQ(split.main_raw, 0) << "a main-group subscriber received RL_RAW";
  EXPECT_GT(split.main_theta, 0) << "the main-group subscriber received nothing at all";
  ASSERT_TRUE(split.logged.count("RL_RAW")) << split.recorder_err;
  EXPECT_EQ(split.logged.at("RL_RAW"), s.frames) << split.recorder_err;
  EXPECT_EQ(Sum(split.logged), s.published) << split.recorder_err;
  EXPECT_GT(split.logged.count("RL_THETA") ? split.logged.at("RL_THETA") : 0, 900);

  // --raw-url same: RL_RAW back on the main group, recorded all the same.
  const Recorded same = RecordWhile({"daq", "--rig", kLabRig, "--input", kFreeRocking, "--speed", "1", "--lcm-url",
                                kUdpmUrl, "--raw-url", "same"},
                               "daq_same");
  const DaqSummary t = ParseDaqSummary(same.err, "daq");
  ASSERT_GT(t.frames, 900) << same.err;
  EXPECT_GT(same.main_raw, 0) << "--raw-url same: no RL_RAW on the main group";
  EXPECT_EQ(same.logged.count("RL_RAW") ? same.logged.at("RL_RAW") : 0, t.frames) << same.recorder_err;
  EXPECT_EQ(Sum(same.logged), t.published) << same.recorder_err;
}

// A recorded log replayed: RL_RAW goes to its own group as the daq sends it.
TEST(RawGroup, ReplaySendsRawFramesOffTheMainGroup) {
  const std::string why = EnterPrivateNetwork();
  if (!why.empty()) ROCKLAB_SKIP(why);
  const std::string dir = ScratchDir("raw_group");
  const std::string source = dir + "/replay_source.lcm";
  const CliResult made = RunCli({"daq", "--rig", kLabRig, "--input", kFreeRocking, "--max", "--lcm-url",
                                 "memq://", "--log", source});
  ASSERT_EQ(made.exit_code, 0) << made.err;

  const Recorded r = RecordWhile({"replay", source, "--speed", "1", "--lcm-url", kUdpmUrl}, "replay");
  // "  RL_RAW    1001" lines of replay's summary.
  std::map<std::string, std::int64_t> replayed;
  std::istringstream lines(r.err);
  for (std::string line; std::getline(lines, line);) {
    std::istringstream words(line);
    std::string channel;
    long long n = -1;
    if (line.rfind("  ", 0) == 0 && (words >> channel >> n)) replayed[channel] = n;
  }
  ASSERT_GT(replayed["RL_RAW"], 900) << r.err;
  EXPECT_EQ(r.main_raw, 0) << "a main-group subscriber received RL_RAW";
  EXPECT_GT(r.main_theta, 0);
  EXPECT_EQ(r.logged, replayed) << r.err << r.recorder_err;
}

// Refused before any raw bus opens, naming the option (exit 2). The main
// bus is memq:// (nothing joins a group), in a private namespace all the same.
TEST(RawGroup, BadRawUrlIsRefusedNamingTheOption) {
  const std::string why = EnterPrivateNetwork();
  if (!why.empty()) ROCKLAB_SKIP(why);
  const std::string log = ScratchDir("raw_group") + "/bad.lcm";
  const std::vector<std::vector<std::string>> commands = {
      {"daq", "--rig", kLabRig, "--input", kFreeRocking, "--max", "--lcm-url", "memq://", "--raw-url", "bogus"},
      {"daq", "--rig", kLabRig, "--input", kFreeRocking, "--check", "--raw-url", "udpm://10.1.2.3:7667"},
      {"replay", kFreeRocking, "--lcm-url", "memq://", "--raw-url", "bogus"},
      {"replay", "--rig", kLabRig, "--input", kFreeRocking, "--max", "--lcm-url", "memq://", "--raw-url",
       "udpm://239.1.1.1:99999"},
      {"record", log, "--force", "--lcm-url", "memq://", "--raw-url", "bogus"},
      {"daq", "--rig", kLabRig, "--input", kFreeRocking, "--check", "--lcm-url", "udpm://239.1.1.1:7000",
       "--raw-url", "udpm://239.1.1.2:7000"},  // the main port, another group
  };
  for (const auto& args : commands) {
    const CliResult r = RunCli(args);
    std::string line;
    for (const auto& a : args) line += a + " ";
    EXPECT_EQ(r.exit_code, 2) << line << "\n" << r.err;
    EXPECT_NE(r.err.find("--raw-url"), std::string::npos) << line << "\n" << r.err;
  }
}

}  // namespace
}  // namespace rocklab::test
