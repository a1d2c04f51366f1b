// Live inputs under the faults a lab meets: a row cut by a
// dropped connection or by the idle timeout, a followed file rewritten in
// place, a header that never finishes, and the DAQ node's heartbeat to
// systemd and RL_HEALTH while it waits for its header.
// Oracle: the writer's own rows (each whole row is one frame with its
// values, each cut row one bad row and no frame), the datagrams systemd
// would get, the RL_HEALTH states the node publishes. Waits are on
// conditions with generous deadlines, never fixed sleeps.
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "common/bus.h"
#include "daq/daq_node.h"
#include "daq/source.h"
#include "rocklab/health2_t.hpp"
#include "tests/daq/daq_test_util.h"
#include "tests/daq/loopback_tcp.h"
#include "tests/daq/notify_socket.h"

namespace rocklab::daq {
namespace {

using test::Listen;
using test::SendAll;

constexpr double kFaultsRateHz = 200.0;

std::string FaultRow(int k, int a) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%.3f,%d,%.2f\n", k / kFaultsRateHz, a, 0.25 * k + 0.5);
  return buf;
}

struct FaultsGot {
  std::vector<Frame> frames;
  std::vector<std::string> problems;
  SourceStats stats;
  ReadStatus last{};
};

SourceOptions Options(std::vector<std::string>* problems, double idle_s) {
  SourceOptions opt;
  opt.sample_rate_hz = kFaultsRateHz;
  opt.idle_timeout_s = idle_s;
  opt.on_problem = [problems](const Problem& p) { problems->push_back(ToString(p)); };
  return opt;
}

// Reads until the source ends, or until it has `until_frames` frames.
void ReadFaults(Source& source, FaultsGot& g, std::size_t until_frames = SIZE_MAX) {
  Frame f;
  while (g.frames.size() < until_frames) {
    const ReadStatus s = source.Next(f);
    if (s == ReadStatus::kFrame) g.frames.push_back(f);
    if (s == ReadStatus::kEnd || s == ReadStatus::kError) {
      g.last = s;
      break;
    }
  }
  g.stats = source.stats();
}

bool AnyContains(const std::vector<std::string>& lines, const std::string& part) {
  for (const auto& l : lines) {
    if (l.find(part) != std::string::npos) return true;
  }
  return false;
}

// The first connection ends in the middle of row 50's
// last field ("...,13" of "...,13.00"): parsed, it would pass for a value
// nobody measured. The second connection sends rows 51..99.
// Oracle: rows 0..49 and 51..99 as sent; row 50 is one bad row, no frame.
TEST(LiveFaults, TcpRowCutByADroppedConnectionIsCountedNotPublished) {
  int port = 0;
  const int listener = Listen(port);
  ASSERT_GE(listener, 0);
  std::thread server([listener] {
    for (int connection = 0; connection < 2; ++connection) {
      const int fd = ::accept(listener, nullptr, nullptr);
      if (fd < 0) return;
      std::string text = "time,a,b\n";
      if (connection == 0) {
        for (int k = 0; k < 50; ++k) text += FaultRow(k, k);
        const std::string cut = FaultRow(50, 50);
        text += cut.substr(0, cut.size() - 4);  // "0.250,50,13" of "0.250,50,13.00\n"
      } else {
        for (int k = 51; k < 100; ++k) text += FaultRow(k, k);
      }
      SendAll(fd, text);
      ::close(fd);
    }
    ::close(listener);
  });
  std::vector<std::string> problems;
  auto source = OpenTcpSource("127.0.0.1:" + std::to_string(port), Options(&problems, 0.6));
  FaultsGot got;
  ReadFaults(*source, got);
  server.join();
  ASSERT_EQ(got.frames.size(), 99u);
  for (const Frame& f : got.frames) {
    EXPECT_NE(f.values[0], 50) << "the cut row was published";
    EXPECT_EQ(f.values[1], 0.25 * f.values[0] + 0.5) << "row " << f.values[0];
  }
  EXPECT_EQ(got.stats.bad_rows, 1);
  EXPECT_EQ(got.stats.restarts, 1);
  EXPECT_TRUE(AnyContains(problems, "cut")) << (problems.empty() ? "" : problems[0]);
}

// --follow: the last line never gets its '\n' before the
// idle timeout ends the input.
// Oracle: the 10 whole rows are frames; the unfinished one is a bad row.
TEST(LiveFaults, FollowedLastLineUnfinishedAtTheIdleTimeoutIsCounted) {
  const std::string path = test::ScratchDir() + "/unfinished.csv";
  {
    std::ofstream out(path);
    out << "time,a,b\n";
    for (int k = 0; k < 10; ++k) out << FaultRow(k, k);
    out << FaultRow(10, 10).substr(0, 9);  // "0.050,10," : the row's last field never came
  }
  std::vector<std::string> problems;
  SourceOptions opt = Options(&problems, 0.3);
  opt.follow = true;
  auto source = OpenCsvSource(path, opt);
  FaultsGot got;
  ReadFaults(*source, got);
  EXPECT_EQ(got.last, ReadStatus::kEnd);
  ASSERT_EQ(got.frames.size(), 10u);
  EXPECT_EQ(got.frames.back().values[0], 9);
  EXPECT_EQ(got.stats.bad_rows, 1);
  EXPECT_EQ(got.stats.rows, 11);
}

// The acquisition program restarting its test: the followed file is written
// again from its start in one write, (a) over the old bytes without ever
// being shorter than what was read (pwrite at 0: only the first bytes say
// so), (b) truncated and rewritten (O_TRUNC then one write).
// Oracle: the first test's 50 rows, then every row of the second test in
// order (its values 1000 + k), one restart counted, nothing spliced.
void RewriteInOneWrite(bool truncate) {
  const std::string path = test::ScratchDir() + (truncate ? "/rewritten_trunc.csv" : "/rewritten.csv");
  {
    std::ofstream out(path);
    out << "time,a,b\n";
    for (int k = 0; k < 50; ++k) out << FaultRow(k, k);
  }
  std::vector<std::string> problems;
  SourceOptions opt = Options(&problems, 0.5);
  opt.follow = true;
  auto source = OpenCsvSource(path, opt);
  FaultsGot got;
  ReadFaults(*source, got, 50);  // the reader is at the old file's end
  ASSERT_EQ(got.frames.size(), 50u);
  std::string second = "time,a,b\n";
  for (int k = 0; k < 150; ++k) second += FaultRow(k, 1000 + k);
  const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC | (truncate ? O_TRUNC : 0));
  ASSERT_GE(fd, 0);
  ASSERT_EQ(::pwrite(fd, second.data(), second.size(), 0), static_cast<ssize_t>(second.size()));
  ::close(fd);
  ReadFaults(*source, got);
  EXPECT_EQ(got.last, ReadStatus::kEnd);
  ASSERT_EQ(got.frames.size(), 200u) << (problems.empty() ? "" : problems.back());
  for (int k = 0; k < 150; ++k) {
    ASSERT_EQ(got.frames[50 + k].values[0], 1000 + k) << "row " << k << " of the second test";
    ASSERT_EQ(got.frames[50 + k].seq, 50 + k);  // its samples follow the first test's
  }
  EXPECT_EQ(got.stats.restarts, 1);
  EXPECT_EQ(got.stats.bad_rows, 0);
  EXPECT_TRUE(AnyContains(problems, "input restarted")) << (problems.empty() ? "" : problems[0]);
}

TEST(LiveFaults, FollowedFileOverwrittenFromItsStartStartsANewSegment) { RewriteInOneWrite(false); }
TEST(LiveFaults, FollowedFileTruncatedAndRewrittenStartsANewSegment) { RewriteInOneWrite(true); }

// A header line that never gets its '\n' (the peer stalls
// mid-header) until the idle timeout, over tcp:// and --follow.
// Oracle: the open fails saying the header is incomplete, not that a rig
// channel is missing from a header cut short.
TEST(LiveFaults, HalfSentHeaderAtTheIdleTimeoutIsAnIncompleteHeader) {
  int port = 0;
  const int listener = Listen(port);
  ASSERT_GE(listener, 0);
  std::atomic<bool> done{false};
  std::thread server([listener, &done] {
    const int fd = ::accept(listener, nullptr, nullptr);
    if (fd < 0) return;
    SendAll(fd, "time,mirror_s,mirr");
    while (!done.load()) std::this_thread::sleep_for(std::chrono::milliseconds(10));  // keeps it open
    ::close(fd);
  });
  std::vector<std::string> problems;
  try {
    OpenTcpSource("127.0.0.1:" + std::to_string(port), Options(&problems, 0.4));
    ADD_FAILURE() << "a cut header was taken as the header";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("incomplete header"), std::string::npos) << e.what();
  }
  done = true;
  server.join();
  ::close(listener);

  const std::string path = test::WriteFile("half_header.csv", "time,mirror_s,mirr");
  SourceOptions opt = Options(&problems, 0.3);
  opt.follow = true;
  try {
    OpenCsvSource(path, opt);
    ADD_FAILURE() << "a cut header was taken as the header";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("incomplete header"), std::string::npos) << e.what();
  }
}

// A bus that keeps the RL_HEALTH states published (from any thread).
class HealthBus final : public common::Bus {
 public:
  using Bus::Publish;
  bool Publish(const std::string& channel, const void* data, int size) override {
    if (channel != "RL_HEALTH") return true;
    rocklab::health2_t h;
    if (h.decode(data, 0, size) < 0) return false;
    std::lock_guard<std::mutex> lock(mutex_);
    states_.push_back(h.state);
    return true;
  }
  common::Subscription SubscribeRaw(const std::string&, RawHandler, int) override { return {}; }
  int HandleTimeout(int) override { return 0; }
  std::vector<std::string> states() {
    std::lock_guard<std::mutex> lock(mutex_);
    return states_;
  }

 private:
  std::mutex mutex_;
  std::vector<std::string> states_;
};

// `daq` on tcp-listen://, tcp:// and --follow, nothing
// arriving: the unit is Type=notify with a watchdog, so the node must say
// READY=1 once it listens (or has its file open), then WATCHDOG=1 and
// RL_HEALTH "waiting for header" while no header comes.
// Oracle: the datagrams on $NOTIFY_SOCKET and the RL_HEALTH states, before
// any header was sent; the stop then ends the wait.
void WaitsWithAHeartbeat(const std::string& input, bool follow) {
  test::NotifySocket notify("wait_notify.sock", 20);
  ::setenv("NOTIFY_SOCKET", notify.path.c_str(), 1);

  DaqNodeConfig config;
  config.rig = LoadRigConfig(test::LabRigPath());
  config.input = input;
  config.follow = follow;
  config.health_period_s = 0.2;
  std::atomic<bool> stop{false};
  config.stop = &stop;
  HealthBus bus;
  std::string open_error;
  std::thread node([&] {
    try {
      DaqNode n(config, bus);
      n.Run(stop);
    } catch (const std::exception& e) {
      open_error = e.what();
    }
  });
  bool ready = false, watchdog = false;
  while (!(ready && watchdog)) {
    const std::string d = notify.Next();
    if (d.empty()) break;
    ready = ready || d == "READY=1";
    watchdog = watchdog || (ready && d == "WATCHDOG=1");
  }
  bool waiting = false;
  for (int i = 0; i < 1000 && !waiting; ++i) {  // at most 20 s
    for (const auto& s : bus.states()) waiting = waiting || s == "waiting for header";
    if (!waiting) std::this_thread::sleep_for(std::chrono::milliseconds(20));  // polling a condition
  }
  stop = true;
  node.join();
  ::unsetenv("NOTIFY_SOCKET");
  EXPECT_TRUE(ready) << input;
  EXPECT_TRUE(watchdog) << input << ": no WATCHDOG=1 after READY=1";
  EXPECT_TRUE(waiting) << input << ": no RL_HEALTH \"waiting for header\"";
  EXPECT_NE(open_error.find("no header"), std::string::npos) << open_error;
}

TEST(LiveFaults, DaqWaitingForATcpListenHeaderNotifiesAndSendsHealth) {
  int port = 0;
  const int probe = Listen(port);  // a free port, closed: the node listens there
  ASSERT_GE(probe, 0);
  ::close(probe);
  WaitsWithAHeartbeat("tcp-listen://127.0.0.1:" + std::to_string(port), false);
}

TEST(LiveFaults, DaqWaitingForATcpServerNotifiesAndSendsHealth) {
  int port = 0;
  const int listener = Listen(port);  // accepts, never sends
  ASSERT_GE(listener, 0);
  WaitsWithAHeartbeat("tcp://127.0.0.1:" + std::to_string(port), false);
  ::close(listener);
}

TEST(LiveFaults, DaqWaitingForAFollowedFilesHeaderNotifiesAndSendsHealth) {
  WaitsWithAHeartbeat(test::WriteFile("empty_follow.csv", ""), true);
}

}  // namespace
}  // namespace rocklab::daq
