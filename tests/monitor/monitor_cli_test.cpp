// `rocklab monitor` through the binary: it prints the URL it serves, answers
// on it, exits 0 on SIGTERM and SIGINT, and refuses bad options with exit 2
// and a message naming the option. Oracle: the contract in the issue
// (`rocklab monitor: serving http://127.0.0.1:PORT/`, 127.0.0.1 by default).
#include <signal.h>

#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <httplib.h>
#include <nlohmann/json.hpp>

#include "tests/tools/run_cli.h"

namespace rocklab::monitor {
namespace {

// The monitor as a child process; its output in the test's scratch folder.
class MonitorProcess {
 public:
  explicit MonitorProcess(const std::vector<std::string>& args)
      : out_(test::ScratchDir("monitor_cli") + "/" + std::to_string(++count_) + ".out"),
        pid_(test::StartCli(args, out_, out_ + ".err")) {}
  ~MonitorProcess() {
    if (pid_ > 0) test::StopProcess(pid_, SIGKILL);
  }

  /// The line the monitor prints when it serves; empty when it prints none
  /// within 20 s (a bound against a hung test).
  std::string FirstLine() const { return test::WaitForLine(out_, "rocklab monitor: "); }

  /// Sends `signal` and returns the exit code (128 + signal if killed by one).
  int Stop(int signal) {
    const int code = test::StopProcess(pid_, signal);
    pid_ = -1;
    return code;
  }

 private:
  static inline int count_ = 0;
  std::string out_;
  pid_t pid_;
};

// "rocklab monitor: serving http://127.0.0.1:PORT/" -> PORT, 0 if not that.
int ServedPort(const std::string& line) {
  const std::string prefix = "rocklab monitor: serving http://127.0.0.1:";
  if (line.rfind(prefix, 0) != 0 || line.back() != '/') return 0;
  return std::stoi(line.substr(prefix.size()));
}

void ServesAndStopsOn(int signal) {
  MonitorProcess monitor({"monitor", "--lcm-url", "memq://", "--http", "127.0.0.1:0"});
  const std::string line = monitor.FirstLine();
  const int port = ServedPort(line);
  ASSERT_GT(port, 0) << "first line: '" << line << "'";
  httplib::Client client("127.0.0.1", port);
  const auto snapshot = client.Get("/api/snapshot");
  ASSERT_TRUE(snapshot);
  EXPECT_EQ(snapshot->status, 200);
  EXPECT_EQ(nlohmann::json::parse(snapshot->body).at("window_s").get<double>(), 60.0);
  const auto page = client.Get("/");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  EXPECT_EQ(monitor.Stop(signal), 0);
}

TEST(MonitorCommand, PrintsItsUrlServesAndExitsZeroOnSigterm) { ServesAndStopsOn(SIGTERM); }
TEST(MonitorCommand, ExitsZeroOnSigint) { ServesAndStopsOn(SIGINT); }

TEST(MonitorCommand, WindowOptionReachesTheSnapshot) {
  MonitorProcess monitor({"monitor", "--lcm-url", "memq://", "--http", "127.0.0.1:0", "--window", "12.5"});
  const int port = ServedPort(monitor.FirstLine());
  ASSERT_GT(port, 0);
  httplib::Client client("127.0.0.1", port);
  const auto snapshot = client.Get("/api/snapshot");
  ASSERT_TRUE(snapshot);
  EXPECT_EQ(nlohmann::json::parse(snapshot->body).at("window_s").get<double>(), 12.5);
  EXPECT_EQ(monitor.Stop(SIGTERM), 0);
}

TEST(MonitorCommand, BadOptionsExitTwoNamingTheOption) {
  struct Case {
    std::vector<std::string> args;
    std::string says;
  };
  const std::vector<Case> cases = {
      {{"--http", "8080"}, "--http"},
      {{"--http", "127.0.0.1:"}, "--http"},
      {{"--http", "127.0.0.1:99999"}, "--http"},
      {{"--http", "127.0.0.1:80a"}, "--http"},
      {{"--http", "203.0.113.7:0"}, "--http"},  // not an address of this host: cannot bind
      {{"--window", "0"}, "--window"},
      {{"--window", "-3"}, "--window"},
      {{"--lcm-url", "nonsense://"}, "--lcm-url"},
  };
  for (const Case& c : cases) {
    std::vector<std::string> args{"monitor"};
    args.insert(args.end(), c.args.begin(), c.args.end());
    if (c.says != "--lcm-url") args.insert(args.end(), {"--lcm-url", "memq://"});
    const test::CliResult r = test::RunCli(args);
    EXPECT_EQ(r.exit_code, 2) << c.args[1] << "\n" << r.err;
    EXPECT_NE(r.err.find(c.says), std::string::npos) << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;  // no URL printed when it does not serve
  }
}

TEST(MonitorCommand, PortInUseExitsTwoNamingIt) {
  MonitorProcess first({"monitor", "--lcm-url", "memq://", "--http", "127.0.0.1:0"});
  const int port = ServedPort(first.FirstLine());
  ASSERT_GT(port, 0);
  const test::CliResult r = test::RunCli(
      {"monitor", "--lcm-url", "memq://", "--http", "127.0.0.1:" + std::to_string(port)});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("127.0.0.1:" + std::to_string(port)), std::string::npos) << r.err;
  EXPECT_EQ(first.Stop(SIGTERM), 0);
}

}  // namespace
}  // namespace rocklab::monitor
