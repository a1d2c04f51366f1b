// Latency of a live input, from the write of a sample's line to the DAQ
// node's RL_RAW, RL_THETA and RL_TABLE of that sample (host steady clock):
//   build/daq/bench/rocklab_live_latency data/rigs/lab_rig.toml tcp 10
//   build/daq/bench/rocklab_live_latency data/rigs/lab_rig.toml follow 10
// A writer thread produces CSV lines at the rig's sample rate (a TCP server
// on 127.0.0.1, or a file appended to and flushed line by line); the DaqNode
// reads it (tcp:// or --follow) on a DirectBus in this process, so the
// figures are the source's and the node's, without an LCM hop (udpm adds
// ~25 us per hop, DESIGN.md). RL_THETA and RL_TABLE leave together, after
// the longer of the differentiators' delays (docs/acquisition.md,
// Derivatives: 5 ms for the lab rig, which has an accelerometer; 50 ms
// without one): their latency is that plus the transport's.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "common/bus.h"
#include "common/direct_bus.h"
#include "daq/daq_node.h"
#include "daq/rig_config.h"
#include "daq/rig_simulator.h"
#include "rocklab/block_state_t.hpp"
#include "rocklab/raw_frame_t.hpp"
#include "rocklab/table_state_t.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using rocklab::daq::RigConfig;

double Us(Clock::duration d) { return std::chrono::duration<double, std::micro>(d).count(); }

void Print(const char* what, std::vector<double> us) {
  if (us.empty()) {
    std::printf("%s: no samples\n", what);
    return;
  }
  std::sort(us.begin(), us.end());
  auto at = [&us](double q) { return us[static_cast<size_t>(q * static_cast<double>(us.size() - 1))]; };
  std::printf("%-22s n=%zu  p50 %.0f us  p90 %.0f us  p99 %.0f us  max %.0f us\n", what, us.size(), at(0.5),
              at(0.9), at(0.99), us.back());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s RIG.toml tcp|follow [SECONDS]\n", argv[0]);
    return 2;
  }
  const RigConfig rig = rocklab::daq::LoadRigConfig(argv[1]);
  const std::string mode = argv[2];
  const double seconds = argc > 3 ? std::atof(argv[3]) : 10.0;
  const double rate = rig.sample_rate_hz;
  const int n = static_cast<int>(seconds * rate);

  // The lines: the rig simulator's channels at rest with noise.
  rocklab::daq::RigSimulator sim(rig, rocklab::daq::SimulatorNoise::Typical(), 5);
  std::vector<std::string> lines;
  std::string header = "time";
  for (const auto& c : sim.channel_names()) header += "," + c;
  lines.push_back(header + "\n");
  std::vector<double> raw;
  for (int k = 0; k < n; ++k) {
    rocklab::daq::TrueMotion rest;
    rest.time_s = k / rate;
    sim.Raw(rest, raw);
    std::string line = std::to_string(k / rate);
    char buf[32];
    for (double v : raw) {
      std::snprintf(buf, sizeof buf, ",%.9g", v);
      line += buf;
    }
    lines.push_back(line + "\n");
  }
  std::vector<Clock::time_point> written(static_cast<size_t>(n));
  std::atomic<int> written_count{0};
  std::atomic<bool> writer_done{false};  // after it, RL_THETA comes from the end-of-input flush

  std::string input;
  std::thread writer;
  int listener = -1;
  const std::string file = "/tmp/rocklab_live_latency_" + std::to_string(::getpid()) + ".csv";
  auto produce = [&](auto&& write_line) {
    const auto start = Clock::now();
    for (int k = 0; k < n; ++k) {
      std::this_thread::sleep_until(start + std::chrono::microseconds(static_cast<int64_t>(k * 1e6 / rate)));
      written[static_cast<size_t>(k)] = Clock::now();
      written_count = k + 1;
      if (!write_line(lines[static_cast<size_t>(k) + 1])) break;
    }
    writer_done = true;
  };
  if (mode == "tcp") {
    listener = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof addr;
    if (::bind(listener, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 || ::listen(listener, 1) != 0 ||
        ::getsockname(listener, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
      std::perror("listen");
      return 1;
    }
    input = "tcp://127.0.0.1:" + std::to_string(ntohs(addr.sin_port));
    writer = std::thread([&] {
      const int fd = ::accept(listener, nullptr, nullptr);
      if (fd < 0) return;
      ::send(fd, lines[0].data(), lines[0].size(), MSG_NOSIGNAL);
      produce([fd](const std::string& l) {
        return ::send(fd, l.data(), l.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(l.size());
      });
      ::close(fd);
    });
  } else {
    std::ofstream(file) << lines[0];
    input = file;
    writer = std::thread([&] {
      std::ofstream out(file, std::ios::app);
      produce([&out](const std::string& l) { return static_cast<bool>(out << l << std::flush); });
    });
  }

  std::vector<double> raw_us, theta_us, table_us;
  raw_us.reserve(static_cast<size_t>(n));
  theta_us.reserve(static_cast<size_t>(n));
  table_us.reserve(static_cast<size_t>(n));
  rocklab::common::DirectBus bus;
  const rocklab::common::Subscription sub1 = bus.Subscribe<rocklab::raw_frame_t>("RL_RAW", [&](const std::string&, const rocklab::raw_frame_t& m) {
    if (m.seq >= 0 && m.seq < written_count.load()) raw_us.push_back(Us(Clock::now() - written[static_cast<size_t>(m.seq)]));
  });
  const rocklab::common::Subscription sub2 = bus.Subscribe<rocklab::block_state_t>("RL_THETA", [&](const std::string&, const rocklab::block_state_t& m) {
    if (!writer_done.load() && m.seq >= 0 && m.seq < written_count.load()) theta_us.push_back(Us(Clock::now() - written[static_cast<size_t>(m.seq)]));
  });
  const rocklab::common::Subscription sub3 = bus.Subscribe<rocklab::table_state_t>("RL_TABLE", [&](const std::string&, const rocklab::table_state_t& m) {
    if (!writer_done.load() && m.seq >= 0 && m.seq < written_count.load()) table_us.push_back(Us(Clock::now() - written[static_cast<size_t>(m.seq)]));
  });
  rocklab::daq::DaqNodeConfig config;
  config.rig = rig;
  config.input = input;
  config.follow = mode != "tcp";
  config.idle_timeout_s = 1.0;
  std::atomic<bool> stop{false};
  config.stop = &stop;
  rocklab::daq::DaqNode node(config, bus);
  node.Run(stop);
  writer.join();
  if (listener >= 0) ::close(listener);
  if (mode != "tcp") std::remove(file.c_str());
  std::printf("%s input, %d samples at %g Hz (%g s), %lld frames read\n", mode.c_str(), n, rate, seconds,
              static_cast<long long>(node.stats().frames_read));
  Print("write -> RL_RAW", raw_us);
  Print("write -> RL_THETA", theta_us);
  Print("write -> RL_TABLE", table_us);
  return 0;
}
