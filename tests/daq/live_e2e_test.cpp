// `rocklab daq` on live inputs, end to end: a writer (this test) produces a
// followed CSV, a TCP stream or LCM raw frames at the rig's sample rate
// while `rocklab daq` publishes on udpm; `rocklab record` records RL_RAW and
// RL_THETA. Everything runs in a private network namespace on lo with ttl=0
// (DESIGN.md); TCP is on 127.0.0.1 inside it. The daq ends on its
// --idle-timeout once the writer stops.
// Oracle: the writer's frames: RL_RAW in the log has every one of them,
// same seq, utime and values; RL_THETA has one per frame.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cmath>
#include <fstream>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include "common/lcm_log.h"
#include "daq/rig_config.h"
#include "daq/rig_simulator.h"
#include "daq/source.h"
#include "rocklab/raw_frame_t.hpp"
#include "tests/daq/daq_test_util.h"
#include "tests/skip.h"
#include "tests/tools/log_count.h"
#include "tests/tools/udpm_netns.h"

namespace rocklab::daq {
namespace {

// 0.5 s of the lab rig at 1 kHz, as CSV lines (header first).
std::vector<std::string> RawLines(const RigConfig& rig) {
  const std::string path = test::ScratchDir() + "/e2e_source.csv";
  RigSimulator sim(rig, SimulatorNoise::Typical(), 23);
  RawFileWriter out(path, RawFileWriter::Format::kCsv, sim.channel_names(), rig.sample_rate_hz);
  std::vector<double> raw;
  for (int k = 0; k < 500; ++k) {
    const double t = k / rig.sample_rate_hz;
    TrueMotion m;
    m.time_s = t;
    m.theta = 0.002 * std::sin(2 * M_PI * 2 * t);
    if (sim.Raw(m, raw)) out.Write(t, raw);
  }
  out.Close();
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line + "\n");
  return lines;
}

std::vector<Frame> FramesOf(const std::string& path, const RigConfig& rig, const std::string& channel = "RL_RAW") {
  SourceOptions opt;
  opt.sample_rate_hz = rig.sample_rate_hz;
  opt.raw_channel = channel;
  for (const auto& c : rig.channels) opt.fallback_channel_names.push_back(c.name);
  auto source = OpenSource(path, opt);
  std::vector<Frame> frames;
  Frame f;
  while (source->Next(f) == ReadStatus::kFrame) frames.push_back(f);
  return frames;
}

int64_t CountChannel(const std::string& log, const std::string& channel) {
  common::LogReader reader(log);
  common::LogEvent ev;
  int64_t n = 0;
  while (reader.Next(ev)) n += ev.channel == channel;
  return n;
}

void Pace(std::chrono::steady_clock::time_point start, size_t k) {
  std::this_thread::sleep_until(start + std::chrono::microseconds(static_cast<int64_t>(k * 1000)));
}

enum class Kind { kFollow, kTcp, kLcm };

// In the namespace: recorder, writer, `rocklab daq`; 0 = pass, 77 = skip.
int Child(Kind kind) {
  const std::string why = rocklab::test::EnterPrivateNetwork();
  if (!why.empty()) {
    std::cerr << why << "\n";
    return 77;
  }
  const RigConfig rig = LoadRigConfig(test::LabRigPath());
  const std::vector<std::string> lines = RawLines(rig);
  const std::string want_path = test::ScratchDir() + "/e2e_source.csv";
  const std::string dir = test::ScratchDir();
  const std::string log = dir + "/e2e.lcm";
  const pid_t recorder = rocklab::test::StartRecorder(log, "RL_RAW|RL_THETA|RL_HEALTH");
  if (recorder < 0) return 1;

  // The daq is stopped by SIGINT once the recorder holds an RL_RAW for
  // every frame written (a condition; RL_THETA lags by the derivative's
  // half window, 5 frames, until the stop flushes them). Its idle timeout
  // is only a backstop for a test gone wrong, never the expected end (a
  // writer descheduled on a loaded machine for longer than a short
  // timeout would end the stream).
  const size_t frames_written = FramesOf(want_path, rig).size();
  std::vector<std::string> args = {"daq", "--rig", test::LabRigPath(), "--lcm-url", rocklab::test::kUdpmUrl,
                                   "--idle-timeout", "60"};
  std::thread writer;
  int listener = -1;
  if (kind == Kind::kFollow) {
    const std::string followed = dir + "/e2e_followed.csv";
    std::ofstream(followed) << lines[0];
    args.insert(args.end(), {"--input", followed, "--follow"});
    writer = std::thread([lines, followed] {
      std::ofstream out(followed, std::ios::app);
      const auto start = std::chrono::steady_clock::now();
      for (size_t k = 1; k < lines.size(); ++k) {
        Pace(start, k);
        out << lines[k] << std::flush;
      }
    });
  } else if (kind == Kind::kTcp) {
    listener = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t n = sizeof addr;
    if (::bind(listener, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 || ::listen(listener, 1) != 0 ||
        ::getsockname(listener, reinterpret_cast<sockaddr*>(&addr), &n) != 0) {
      return 1;
    }
    args.insert(args.end(), {"--input", "tcp://127.0.0.1:" + std::to_string(ntohs(addr.sin_port))});
    writer = std::thread([lines, listener] {
      const int fd = ::accept(listener, nullptr, nullptr);
      if (fd < 0) return;
      const auto start = std::chrono::steady_clock::now();
      for (size_t k = 0; k < lines.size(); ++k) {
        Pace(start, k);
        if (::send(fd, lines[k].data(), lines[k].size(), MSG_NOSIGNAL) != static_cast<ssize_t>(lines[k].size())) break;
      }
      ::close(fd);
    });
  } else {
    args.insert(args.end(), {"--input", "lcm://ACQ_RAW"});
  }
  const pid_t daq = rocklab::test::StartCli(args, dir + "/e2e_daq.out", dir + "/e2e_daq.err");
  if (kind == Kind::kLcm) {
    // The acquisition program: raw_frame_t on ACQ_RAW once the daq listens
    // (its first RL_HEALTH, "starting", is in the recorder's log).
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    lcm::LCM lcm(rocklab::test::kUdpmUrl);
    // The daq subscribes in its constructor, before its first heartbeat
    // (RL_HEALTH "starting", every second while nothing arrives): once the
    // recorder has one, frames published now reach it.
    while (std::chrono::steady_clock::now() < deadline) {
      if (CountChannel(log, "RL_HEALTH") > 0) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));  // polling a condition
    }
    const std::vector<Frame> frames = FramesOf(want_path, rig);
    rocklab::raw_frame_t msg;
    const auto start = std::chrono::steady_clock::now();
    for (size_t k = 0; k < frames.size(); ++k) {
      Pace(start, k);
      msg.utime = frames[k].utime();
      msg.seq = frames[k].seq;
      msg.num_channels = static_cast<int32_t>(frames[k].values.size());
      msg.values = frames[k].values;
      lcm.publish("ACQ_RAW", &msg);
    }
  }
  if (writer.joinable()) writer.join();
  if (!rocklab::test::WaitUntil(
          [&] { return rocklab::test::CountLogEvents(log, "RL_RAW") >= static_cast<int64_t>(frames_written); })) {
    std::cerr << "the recorder's log has " << rocklab::test::CountLogEvents(log, "RL_RAW") << " RL_RAW after 60 s for "
              << frames_written << " frames written\n";
  }
  const int daq_exit = rocklab::test::StopProcess(daq, SIGINT, 30.0);
  if (listener >= 0) ::close(listener);
  if (rocklab::test::StopRecorder(recorder, log) != 0) return 1;
  if (daq_exit != 0) {
    std::cerr << "rocklab daq exited " << daq_exit << ": " << rocklab::test::ReadFile(dir + "/e2e_daq.err");
    return 1;
  }
  const std::vector<Frame> want = FramesOf(want_path, rig);
  const std::vector<Frame> got = FramesOf(log, rig);
  if (got.size() != want.size()) {
    std::cerr << "RL_RAW has " << got.size() << " frames, the writer wrote " << want.size() << "\n"
              << rocklab::test::ReadFile(dir + "/e2e_daq.err");
    return 1;
  }
  for (size_t i = 0; i < want.size(); ++i) {
    bool same = got[i].seq == want[i].seq && got[i].utime() == want[i].utime();
    for (size_t k = 0; same && k < want[i].values.size(); ++k) {
      same = got[i].values[k] == want[i].values[k] || (std::isnan(got[i].values[k]) && std::isnan(want[i].values[k]));
    }
    if (!same) {
      std::cerr << "frame " << i << " differs\n";
      return 1;
    }
  }
  const int64_t theta = CountChannel(log, "RL_THETA");
  if (theta != static_cast<int64_t>(want.size())) {
    std::cerr << "RL_THETA has " << theta << " messages for " << want.size() << " frames\n";
    return 1;
  }
  return 0;
}

void RunInChild(Kind kind) {
  std::cout.flush();
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) _exit(Child(kind));
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  if (WEXITSTATUS(status) == 77) ROCKLAB_SKIP("no private network namespace (needs root): udpm test skipped");
  EXPECT_EQ(WEXITSTATUS(status), 0) << "see the child's messages above";
}

TEST(LiveEndToEnd, FollowedCsvFramesOutEqualFramesIn) { RunInChild(Kind::kFollow); }
TEST(LiveEndToEnd, TcpStreamFramesOutEqualFramesIn) { RunInChild(Kind::kTcp); }
TEST(LiveEndToEnd, LcmChannelFramesOutEqualFramesIn) { RunInChild(Kind::kLcm); }

}  // namespace
}  // namespace rocklab::daq
