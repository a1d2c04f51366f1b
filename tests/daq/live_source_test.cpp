// Live sources read while a writer (a thread of the test) produces the file
// or the stream at its sample rate: --follow of a CSV and of an LVM (a
// partial last line, new segments, the file replaced) and tcp:// (a server
// that drops the connection, loses samples and comes back).
// Oracle: the writer's own rows: every row written is one frame, in order,
// with its time and values; samples not sent across a reconnection are
// counted from the time column. Waits are on conditions (the writer's
// progress, the source's idle timeout), never fixed sleeps.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "daq/source.h"
#include "tests/daq/daq_test_util.h"
#include "tests/daq/loopback_tcp.h"

namespace rocklab::daq {
namespace {

using test::Listen;
using test::SendAll;

constexpr double kRateHz = 200.0;

// Sleeps until `k` samples after `start` at kRateHz (the writer's sample
// clock; pacing a producer, not a wait in an assertion).
void PaceTo(std::chrono::steady_clock::time_point start, int k) {
  std::this_thread::sleep_until(start + std::chrono::microseconds(static_cast<int64_t>(k * 1e6 / kRateHz)));
}

std::string Row(int k) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%.3f,%d,%.2f\n", k / kRateHz, k, 0.25 * k);
  return buf;
}

struct Got {
  std::vector<Frame> frames;
  std::vector<std::string> problems;
  SourceStats stats;
  ReadStatus last{};
};

// Reads until the source ends. With `stop`, sets it once a frame's first
// value is `last` (the writer's last row): the source then ends at once, so
// the end of a paced writer's stream is a condition, not an idle timeout
// that a writer descheduled on a loaded machine could hit mid-stream (the
// idle timeout is then only a backstop, kBackstopIdleS).
Got ReadUntilEnd(Source& source, std::atomic<bool>* stop = nullptr, double last = 0) {
  Got g;
  Frame f;
  while (true) {
    const ReadStatus s = source.Next(f);
    if (s == ReadStatus::kFrame) {
      g.frames.push_back(f);
      if (stop != nullptr && !f.values.empty() && f.values[0] == last) stop->store(true);
    }
    if (s == ReadStatus::kEnd || s == ReadStatus::kError) {
      g.last = s;
      break;
    }
  }
  g.stats = source.stats();
  return g;
}

// The idle timeout of the tests whose writer is paced: a deadline for a
// test gone wrong (the last row never comes), never the expected end.
constexpr double kBackstopIdleS = 30.0;

SourceOptions LiveOptions(Got* sink, double idle_s, const std::atomic<bool>* stop = nullptr) {
  SourceOptions opt;
  opt.sample_rate_hz = kRateHz;
  opt.idle_timeout_s = idle_s;
  opt.stop = stop;
  opt.on_problem = [sink](const Problem& p) { sink->problems.push_back(ToString(p)); };
  return opt;
}

// A CSV written row by row at 200 Hz, each row in two writes (the reader sees
// partial lines), then replaced by a new file (written aside, renamed over:
// what a logger's rotation does) whose time continues.
TEST(LiveSources, FollowedCsvGrowsIsReplacedAndLosesNothing) {
  const std::string path = test::ScratchDir() + "/follow.csv";
  std::ofstream(path) << "time,a,b\n" << Row(0);
  constexpr int kFirst = 120, kTotal = 240;
  Got problems;
  std::atomic<bool> stop{false};
  SourceOptions opt = LiveOptions(&problems, kBackstopIdleS, &stop);
  opt.follow = true;
  auto source = OpenCsvSource(path, opt);
  ASSERT_TRUE(source->live());
  std::thread writer([&] {
    const auto start = std::chrono::steady_clock::now();
    {
      std::ofstream out(path, std::ios::app);
      for (int k = 1; k < kFirst; ++k) {
        PaceTo(start, k);
        const std::string row = Row(k);
        out << row.substr(0, 4) << std::flush;  // a partial line first
        out << row.substr(4) << std::flush;
      }
    }
    const std::string aside = path + ".new";
    {
      std::ofstream out(aside);
      out << "time,a,b\n" << Row(kFirst) << std::flush;
    }
    std::rename(aside.c_str(), path.c_str());
    std::ofstream out(path, std::ios::app);
    for (int k = kFirst + 1; k < kTotal; ++k) {
      PaceTo(start, k);
      out << Row(k) << std::flush;
    }
  });
  const Got got = ReadUntilEnd(*source, &stop, kTotal - 1);
  writer.join();
  EXPECT_EQ(got.last, ReadStatus::kEnd);
  ASSERT_EQ(got.frames.size(), static_cast<size_t>(kTotal)) << (problems.problems.empty() ? "" : problems.problems[0]);
  for (int k = 0; k < kTotal; ++k) {
    ASSERT_EQ(got.frames[k].seq, k);
    ASSERT_EQ(got.frames[k].values[0], k);
    ASSERT_EQ(got.frames[k].values[1], 0.25 * k);
  }
  EXPECT_EQ(got.stats.restarts, 1);
  EXPECT_EQ(got.stats.restart_lost, 0);
  EXPECT_EQ(got.stats.bad_rows, 0);
}

// Oracle: the idle timeout's definition, "no byte for idle_timeout_s": a
// reader that was itself not running for longer than that (a loaded machine
// descheduling it) still reads what was written meanwhile before it ends.
// Rows written at once, then the reader starts 3 timeouts later: every row
// comes out, and only then the end.
TEST(LiveSources, AReaderLateByMoreThanTheIdleTimeoutStillReadsWhatWasWritten) {
  const std::string path = test::ScratchDir() + "/late.csv";
  std::ofstream(path) << "time,a,b\n" << Row(0);
  constexpr int kRows = 50;
  constexpr double kIdleS = 0.1;
  Got problems;
  SourceOptions opt = LiveOptions(&problems, kIdleS);
  opt.follow = true;
  auto source = OpenCsvSource(path, opt);
  {
    std::ofstream out(path, std::ios::app);
    for (int k = 1; k < kRows; ++k) out << Row(k);
  }
  // lint: sleep-ok: a lower bound of host time (the reader late by 3 timeouts; load only lengthens it)
  std::this_thread::sleep_for(std::chrono::duration<double>(3 * kIdleS));
  const Got got = ReadUntilEnd(*source);
  EXPECT_EQ(got.last, ReadStatus::kEnd);
  ASSERT_EQ(got.frames.size(), static_cast<size_t>(kRows));
  for (int k = 0; k < kRows; ++k) ASSERT_EQ(got.frames[k].values[0], k);
}

// An LVM written as LabVIEW appends segments (each with its header), then
// the file replaced by a new one with its own file header.
TEST(LiveSources, FollowedLvmTakesNewSegmentsAndAReplacedFile) {
  const std::string path = test::ScratchDir() + "/follow.lvm";
  const std::string file_header =
      "LabVIEW Measurement\t\nSeparator\tTab\nDecimal_Separator\t,\nX_Columns\tNo\n***End_of_Header***\t\n\n";
  auto segment = [](int first, int n) {
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "Channels\t1\nSamples\t%d\nX0\t%d,000\nDelta_X\t0,005\n***End_of_Header***\nX_Value\ta\tComment\n",
                  n, first / 200);
    return std::string(buf);
  };
  // Segments of 200 rows (1 s each, X0 = 0, 1, 2 s); 3 segments, the third in a replaced file.
  std::ofstream(path) << file_header << segment(0, 200);
  Got problems;
  std::atomic<bool> stop{false};
  SourceOptions opt = LiveOptions(&problems, kBackstopIdleS, &stop);
  opt.follow = true;
  auto source = OpenLvmSource(path, opt);
  std::thread writer([&] {
    const auto start = std::chrono::steady_clock::now();
    std::ofstream out(path, std::ios::app);
    for (int k = 0; k < 400; ++k) {
      PaceTo(start, k);
      if (k == 200) out << segment(200, 200);
      out << "\t" << k << ",5\n" << std::flush;
    }
    out.close();
    const std::string aside = path + ".new";
    std::ofstream(aside) << file_header << segment(400, 100);
    std::rename(aside.c_str(), path.c_str());
    std::ofstream more(path, std::ios::app);
    for (int k = 400; k < 500; ++k) {
      PaceTo(start, k);
      more << "\t" << k << ",5\n" << std::flush;
    }
  });
  const Got got = ReadUntilEnd(*source, &stop, 499.5);
  writer.join();
  ASSERT_EQ(got.frames.size(), 500u) << (problems.problems.empty() ? "" : problems.problems[0]);
  for (int k = 0; k < 500; ++k) {
    ASSERT_EQ(got.frames[k].seq, k);
    ASSERT_EQ(got.frames[k].values[0], k + 0.5);
    ASSERT_NEAR(got.frames[k].time_s, k * 0.005, 1e-9);  // X0 + j Delta_X: a few ulp of 2.5 s
  }
  EXPECT_EQ(got.stats.restarts, 1);
  EXPECT_EQ(got.stats.bad_rows, 0);
}

// The acquisition PC's side as the LabVIEW recipe does it: on every
// connection the header line, then one line per sample at 200 Hz. It drops
// the first connection after sample 99; samples 100..129 are acquired while
// nobody is connected (lost); the second connection starts at 130.
TEST(LiveSources, TcpReconnectsAndCountsTheSamplesLostMeanwhile) {
  int port = 0;
  const int listener = Listen(port);
  ASSERT_GE(listener, 0);
  Got problems;
  std::atomic<bool> stop{false};
  SourceOptions opt = LiveOptions(&problems, kBackstopIdleS, &stop);
  std::thread server([&] {
    const auto start = std::chrono::steady_clock::now();
    for (int connection = 0; connection < 2; ++connection) {
      const int fd = ::accept(listener, nullptr, nullptr);
      if (fd < 0) return;
      SendAll(fd, "time,a,b\n");
      const int first = connection == 0 ? 0 : 130, last = connection == 0 ? 100 : 200;
      for (int k = first; k < last; ++k) {
        PaceTo(start, k);
        SendAll(fd, Row(k));
      }
      ::close(fd);
    }
    ::close(listener);
  });
  auto source = OpenTcpSource("127.0.0.1:" + std::to_string(port), opt);
  const Got got = ReadUntilEnd(*source, &stop, 199);
  server.join();
  ASSERT_EQ(got.frames.size(), 170u) << (problems.problems.empty() ? "" : problems.problems[0]);
  EXPECT_EQ(got.frames[99].seq, 99);
  EXPECT_EQ(got.frames[100].seq, 130);  // the gap shows in the sequence numbers
  EXPECT_EQ(got.frames[169].values[0], 199);
  EXPECT_EQ(got.stats.restarts, 1);
  EXPECT_EQ(got.stats.restart_lost, 30);
  EXPECT_EQ(got.stats.bad_rows, 0);
}

// tcp-listen://: the DAQ listens and the acquisition PC connects (LabVIEW's
// TCP Open Connection), twice, with 20 samples acquired in between unsent.
TEST(LiveSources, TcpListenTakesTheAcquisitionPcsConnections) {
  int port = 0;
  const int probe = Listen(port);  // a free port: bound, closed, then the source listens there
  ASSERT_GE(probe, 0);
  ::close(probe);
  Got problems;
  std::atomic<bool> stop{false};
  SourceOptions opt = LiveOptions(&problems, kBackstopIdleS, &stop);
  std::thread client([port] {
    const auto start = std::chrono::steady_clock::now();
    for (int connection = 0; connection < 2; ++connection) {
      int fd = -1;
      while (fd < 0 && std::chrono::steady_clock::now() - start < std::chrono::seconds(10)) {
        fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
        sockaddr_in addr{};
        addr.sin_family = AF_INET;
        addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        addr.sin_port = htons(static_cast<uint16_t>(port));
        if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
          ::close(fd);
          fd = -1;
          std::this_thread::sleep_for(std::chrono::milliseconds(10));  // retry until the source listens
        }
      }
      if (fd < 0) return;
      SendAll(fd, "time,a,b\n");
      const int first = connection == 0 ? 0 : 60, last = connection == 0 ? 40 : 100;
      for (int k = first; k < last; ++k) {
        PaceTo(start, k);
        SendAll(fd, Row(k));
      }
      ::close(fd);
    }
  });
  auto source = OpenTcpSource("127.0.0.1:" + std::to_string(port), opt, true);
  const Got got = ReadUntilEnd(*source, &stop, 99);
  client.join();
  ASSERT_EQ(got.frames.size(), 80u) << (problems.problems.empty() ? "" : problems.problems[0]);
  EXPECT_EQ(got.frames[40].seq, 60);
  EXPECT_EQ(got.stats.restarts, 1);
  EXPECT_EQ(got.stats.restart_lost, 20);
}

// Nothing listening and a stop: the wait for the header ends with a clear
// error naming the address, not a hang.
TEST(LiveSources, TcpWithoutAServerEndsOnTheIdleTimeout) {
  int port = 0;
  const int listener = Listen(port);  // bound, then closed: nobody listens there
  ASSERT_GE(listener, 0);
  ::close(listener);
  Got problems;
  SourceOptions opt = LiveOptions(&problems, 0.3);
  try {
    OpenTcpSource("127.0.0.1:" + std::to_string(port), opt);
    FAIL() << "opened without a header";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("tcp://127.0.0.1:" + std::to_string(port) + ":0: no header line arrived"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(OpenTcpSource("no-port", opt), std::invalid_argument);
  EXPECT_THROW(OpenTcpSource("host:99999", opt), std::invalid_argument);
}

}  // namespace
}  // namespace rocklab::daq
