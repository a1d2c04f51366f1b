// `rocklab daq` as a service: --config (every option a key, flags override,
// errors with file, line and key), --check, --log rotation (no event lost or
// duplicated across files), and the systemd notify protocol (READY=1,
// WATCHDOG=1 from the heartbeat while a live input is silent, STOPPING=1).
// Oracle: the input file's frames (every one in exactly one log file, in
// order), the messages the test names, the datagrams the unit would get.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <thread>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/lcm_log.h"
#include "daq/rig_config.h"
#include "daq/rig_simulator.h"
#include "daq/source.h"
#include "tests/daq/notify_socket.h"
#include "rocklab/health2_t.hpp"
#include "rocklab/raw_frame_t.hpp"
#include "tests/daq/daq_test_util.h"
#include "tests/sha256sum.h"
#include "tests/tools/run_cli.h"

namespace rocklab::daq {
namespace {

// 1 s of the lab rig at 1 kHz.
std::string RawCsv(const std::string& name) {
  const RigConfig rig = LoadRigConfig(test::LabRigPath());
  const std::string path = test::ScratchDir() + "/" + name;
  RigSimulator sim(rig, SimulatorNoise::Typical(), 3);
  RawFileWriter out(path, RawFileWriter::Format::kCsv, sim.channel_names(), rig.sample_rate_hz);
  std::vector<double> raw;
  for (int k = 0; k < 1000; ++k) {
    TrueMotion m;
    m.time_s = k / 1000.0;
    m.theta = 0.001 * std::sin(6.0 * m.time_s);
    if (sim.Raw(m, raw)) out.Write(m.time_s, raw);
  }
  out.Close();
  return path;
}

std::string Config(const std::string& name, const std::string& text) {
  return test::WriteFile(name, text);
}

// Every option from the file (paths relative to it), one flag overriding
// its key, and the log rotated every 0.2 s of sample clock: the files
// together hold every RL_RAW frame once, in order, event numbers going on.
TEST(DaqService, ConfigFileWithAFlagOverrideAndRotatedLog) {
  const std::string raw_path = RawCsv("svc_raw.csv");
  std::vector<int64_t> want;  // the input's frames (the simulator drops a few, as a rig does)
  {
    SourceOptions opt;
    opt.sample_rate_hz = 1000.0;
    auto source = OpenSource(raw_path, opt);
    Frame f;
    while (source->Next(f) == ReadStatus::kFrame) want.push_back(f.seq);
  }
  const std::string config = Config("svc.toml",
                                    "rig = \"" + test::LabRigPath() + "\"\n"
                                    "input = \"svc_raw.csv\"\n"
                                    "max = true\n"
                                    "prefix = \"FILE_\"\n"
                                    "lcm-url = \"memq://\"\n"
                                    "log = \"svc.lcm\"\n"
                                    "rotate-seconds = 0.2\n");
  const rocklab::test::CliResult r = rocklab::test::RunCli({"daq", "--config", config, "--prefix", "CLI_"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("daq: " + std::to_string(want.size()) + " frames read"), std::string::npos) << r.err;
  std::vector<std::string> files;
  for (int i = 0;; ++i) {
    char name[64];
    std::snprintf(name, sizeof name, "/svc.%04d.lcm", i);
    if (!std::ifstream(test::ScratchDir() + name)) break;
    files.push_back(test::ScratchDir() + name);
  }
  ASSERT_GE(files.size(), 5u) << "1 s of sample clock in files of 0.2 s";
  int64_t next_event = 0, raw = 0, events = 0;
  for (const auto& f : files) {
    common::LogReader reader(f);
    common::LogEvent ev;
    while (reader.Next(ev)) {
      ++events;
      EXPECT_EQ(ev.number, next_event++) << f;
      EXPECT_NE(ev.channel.rfind("CLI_", 0), std::string::npos) << "the flag overrides the key: " << ev.channel;
      if (ev.channel != "CLI_RAW") continue;
      rocklab::raw_frame_t m;
      ASSERT_GE(m.decode(ev.data.data(), 0, static_cast<int>(ev.data.size())), 0);
      if (raw < static_cast<int64_t>(want.size())) {
        EXPECT_EQ(m.seq, want[static_cast<size_t>(raw)]) << f;
      }
      ++raw;
    }
  }
  EXPECT_EQ(raw, static_cast<int64_t>(want.size()));
  // Each file's provenance beside it (FILE.provenance.csv): the rig and the
  // input with their sizes and SHA-256 (oracle: coreutils' sha256sum), the
  // rig's name, and the file's own events (as read above).
  const std::string rig_hash = rocklab::test::Sha256sum(test::LabRigPath()),
                    raw_hash = rocklab::test::Sha256sum(raw_path);
  ASSERT_EQ(rig_hash.size() + raw_hash.size(), 128u);
  int64_t first_event = 0;
  for (const auto& f : files) {
    const std::string sidecar = rocklab::test::ReadFile(f + ".provenance.csv");
    EXPECT_EQ(sidecar.rfind("key,value\n", 0), 0u) << f;
    EXPECT_NE(sidecar.find(" (" + std::to_string(std::ifstream(test::LabRigPath(), std::ios::ate).tellg()) +
                           " bytes, sha256 " + rig_hash + ")\""),
              std::string::npos)
        << sidecar;
    EXPECT_NE(sidecar.find("svc_raw.csv (" + std::to_string(std::ifstream(raw_path, std::ios::ate).tellg()) +
                           " bytes, sha256 " + raw_hash + ")\""),
              std::string::npos)
        << sidecar;
    EXPECT_NE(sidecar.find("\"rig\",\"lab-table-A, calibration 2026-11-01-A\""), std::string::npos) << sidecar;
    EXPECT_NE(sidecar.find("\"first_event\",\"" + std::to_string(first_event) + "\""), std::string::npos) << sidecar;
    common::LogReader reader(f);
    common::LogEvent ev;
    int64_t n = 0;
    while (reader.Next(ev)) ++n;
    EXPECT_NE(sidecar.find("\"events\",\"" + std::to_string(n) + "\""), std::string::npos) << sidecar;
    first_event += n;
  }
  EXPECT_NE(r.err.find("--log: " + std::to_string(events) + " events in " + std::to_string(files.size()) + " files"),
            std::string::npos)
      << r.err;
}

// Errors name the file, the line and the key; exit 2.
TEST(DaqService, ConfigErrorsNameFileLineAndKey) {
  const std::string unknown = Config("unknown.toml", "rig = \"r.toml\"\n\nspeeed = 2\n");
  rocklab::test::CliResult r = rocklab::test::RunCli({"daq", "--config", unknown});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(unknown + ":3: key 'speeed' is not an option of rocklab daq"), std::string::npos) << r.err;
  const std::string type = Config("type.toml", "speed = \"fast\"\n");
  r = rocklab::test::RunCli({"daq", "--config", type});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(type + ":1: key 'speed' must be a number"), std::string::npos) << r.err;
  const std::string syntax = Config("syntax.toml", "rig = \n");
  r = rocklab::test::RunCli({"daq", "--config", syntax});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(syntax + ":1: "), std::string::npos) << r.err;
}

// --check: what would be read, exit 0; a rig channel the input lacks, exit 2.
TEST(DaqService, CheckPrintsWhatWouldBeReadOrFails) {
  const std::string raw = RawCsv("check_raw.csv");
  const std::string config = Config("check.toml", "rig = \"" + test::LabRigPath() + "\"\ninput = \"" + raw +
                                                      "\"\nlog = \"check.lcm\"\nrotate-size = 1000000\n");
  rocklab::test::CliResult r = rocklab::test::RunCli({"daq", "--config", config, "--check"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("input: " + raw + ", sample rate 1000 Hz, channels: mirror_s"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("a new file every 1000000 bytes"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\nok\n"), std::string::npos);
  EXPECT_FALSE(std::ifstream(test::ScratchDir() + "/check.0000.lcm")) << "--check writes nothing";
  const std::string short_csv = test::WriteFile("short.csv", "time,mirror_s\n0,1\n");
  r = rocklab::test::RunCli({"daq", "--config", config, "--input", short_csv, "--check"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("has no column"), std::string::npos) << r.err;
  r = rocklab::test::RunCli({"daq", "--rig", test::LabRigPath(), "--input", "lcm://RL_RAW", "--check"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("must name a channel other than RL_RAW"), std::string::npos) << r.err;
}

// A TCP port on 127.0.0.1 that was free a moment ago (0 when none could
// be bound).
int FreeLoopbackPort() {
  const int probe = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t n = sizeof addr;
  int port = 0;
  if (::bind(probe, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0 &&
      ::getsockname(probe, reinterpret_cast<sockaddr*>(&addr), &n) == 0) {
    port = ntohs(addr.sin_port);
  }
  ::close(probe);
  return port;
}

// Starts the command with $NOTIFY_SOCKET set to `notify` (its output in
// NAME.out / NAME.err of the scratch folder).
pid_t StartNotified(const test::NotifySocket& notify, const std::vector<std::string>& args,
                    const std::string& name) {
  ::setenv("NOTIFY_SOCKET", notify.path.c_str(), 1);
  const pid_t pid = rocklab::test::StartCli(args, test::ScratchDir() + "/" + name + ".out",
                                            test::ScratchDir() + "/" + name + ".err");
  ::unsetenv("NOTIFY_SOCKET");
  return pid;
}

// SIGTERM (systemctl stop) ends a live input: a followed file once it is
// read (READY=1 says the node runs), an LCM channel with nothing on it, and
// a TCP listener still waiting for its first connection; all exit 0.
TEST(DaqService, SigtermEndsLiveInputs) {
  const std::string raw = RawCsv("term_raw.csv");
  {
    test::NotifySocket notify;
    const pid_t daq = StartNotified(notify, {"daq", "--rig", test::LabRigPath(), "--input", raw, "--follow", "--lcm-url",
                                    "memq://"},
                                   "term_follow");
    EXPECT_EQ(notify.Next(), "READY=1");
    EXPECT_EQ(rocklab::test::StopProcess(daq, SIGTERM, 20.0), 0);
    EXPECT_NE(rocklab::test::ReadFile(test::ScratchDir() + "/term_follow.err").find("stopped by signal"),
              std::string::npos);
  }
  {
    test::NotifySocket notify;  // lcm://: SIGTERM interrupts LCM's wait
    const pid_t daq = StartNotified(notify, {"daq", "--rig", test::LabRigPath(), "--input", "lcm://ACQ_RAW", "--lcm-url",
                                    "memq://"},
                                   "term_lcm");
    EXPECT_EQ(notify.Next(), "READY=1");
    EXPECT_EQ(rocklab::test::StopProcess(daq, SIGTERM, 20.0), 0)
        << rocklab::test::ReadFile(test::ScratchDir() + "/term_lcm.err");
    EXPECT_NE(rocklab::test::ReadFile(test::ScratchDir() + "/term_lcm.err").find("stopped by signal"),
              std::string::npos);
  }
  const int port = FreeLoopbackPort();
  ASSERT_GT(port, 0);
  const std::string err = test::ScratchDir() + "/term_tcp.err";
  const pid_t daq = rocklab::test::StartCli({"daq", "--rig", test::LabRigPath(), "--input",
                                             "tcp-listen://127.0.0.1:" + std::to_string(port), "--lcm-url", "memq://"},
                                            test::ScratchDir() + "/term_tcp.out", err);
  // Listening once a connection succeeds (closed at once: no header yet).
  bool connected = false;
  for (int attempt = 0; attempt < 500 && !connected; ++attempt) {
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    addr.sin_port = htons(static_cast<uint16_t>(port));
    connected = ::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
    ::close(fd);
    if (!connected) std::this_thread::sleep_for(std::chrono::milliseconds(20));  // polling a condition
  }
  ASSERT_TRUE(connected);
  EXPECT_EQ(rocklab::test::StopProcess(daq, SIGTERM, 20.0), 0) << rocklab::test::ReadFile(err);
  EXPECT_NE(rocklab::test::ReadFile(err).find("stopped by signal before tcp-listen://"), std::string::npos)
      << rocklab::test::ReadFile(err);
}

// The notify protocol as systemd sees it: a datagram socket in
// $NOTIFY_SOCKET. A followed file that stays silent: READY=1, then
// WATCHDOG=1 from the heartbeat while nothing arrives, then STOPPING=1 at the
// idle timeout.
TEST(DaqService, NotifiesSystemdReadyWatchdogAndStopping) {
  const std::string raw = RawCsv("notify_raw.csv");
  test::NotifySocket notify;
  const pid_t daq = StartNotified(notify, {"daq", "--rig", test::LabRigPath(), "--input", raw, "--follow",
                                           "--idle-timeout", "2.5", "--lcm-url", "memq://"},
                                  "notify");
  std::vector<std::string> got;
  for (std::string d = notify.Next(); !d.empty(); d = notify.Next()) {
    got.push_back(d);
    if (d == "STOPPING=1") break;
  }
  EXPECT_EQ(rocklab::test::StopProcess(daq, 0, 20.0), 0) << rocklab::test::ReadFile(test::ScratchDir() + "/notify.err");
  ASSERT_FALSE(got.empty());
  EXPECT_EQ(got.front(), "READY=1");
  EXPECT_EQ(got.back(), "STOPPING=1");
  int watchdogs = 0;
  for (const auto& g : got) watchdogs += g == "WATCHDOG=1";
  EXPECT_GE(watchdogs, 2) << "a heartbeat a second for 2.5 s of silence";
}

}  // namespace

// A daemon stopped (SIGTERM) while its TCP listener still waits for the
// first header: systemd still hears STOPPING=1, as from a node that ran,
// and its --log holds the RL_HEALTH "waiting for header" heartbeats it sent
// (written at the stop, stamped 0: there is no sample time).
TEST(DaqService, StoppedBeforeTheHeaderSaysStoppingAndLogsItsHeartbeats) {
  const int port = FreeLoopbackPort();
  ASSERT_GT(port, 0);
  const std::string log = test::ScratchDir() + "/before_header.lcm";
  std::remove(log.c_str());
  test::NotifySocket notify("before_header.sock");
  const pid_t daq = StartNotified(notify, {"daq", "--rig", test::LabRigPath(), "--input",
                                           "tcp-listen://127.0.0.1:" + std::to_string(port), "--lcm-url", "memq://",
                                           "--log", log},
                                  "before_header");
  EXPECT_EQ(notify.Next(), "READY=1");
  EXPECT_EQ(notify.Next(), "WATCHDOG=1");  // the first heartbeat went out
  ASSERT_EQ(::kill(daq, SIGTERM), 0);
  bool stopping = false;
  while (!stopping) {
    const std::string d = notify.Next();  // "" at the timeout
    if (d.empty()) break;
    stopping = d == "STOPPING=1";
  }
  EXPECT_TRUE(stopping);
  EXPECT_EQ(rocklab::test::StopProcess(daq, 0, 20.0), 0)
      << rocklab::test::ReadFile(test::ScratchDir() + "/before_header.err");
  const std::string err = rocklab::test::ReadFile(test::ScratchDir() + "/before_header.err");
  EXPECT_NE(err.find("stopped by signal before tcp-listen://"), std::string::npos) << err;
  int waiting = 0;
  common::LogReader reader(log);
  common::LogEvent ev;
  while (reader.Next(ev)) {
    rocklab::health2_t h;
    if (ev.channel == "RL_HEALTH" && h.decode(ev.data.data(), 0, static_cast<int>(ev.data.size())) >= 0 &&
        h.state == "waiting for header") {
      ++waiting;
    }
  }
  EXPECT_GE(waiting, 1) << err;
}

}  // namespace rocklab::daq
