#include "tests/tools/udpm_netns.h"

#include <sched.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <thread>

#include <lcm/lcm-cpp.hpp>

#include "tests/tools/run_cli.h"

namespace rocklab::test {

std::string EnterPrivateNetwork() {
  if (unshare(CLONE_NEWNET) != 0) {
    return std::string("no private network namespace: unshare(CLONE_NEWNET): ") +
           std::strerror(errno) + " (needs root or CAP_SYS_ADMIN)";
  }
  if (std::system("ip link set lo up && ip link set lo multicast on && "
                  "ip route add 224.0.0.0/4 dev lo") != 0) {
    return "cannot route multicast on lo in the new namespace (ip from iproute2)";
  }
  return "";
}

pid_t StartRecorder(const std::string& log_path, const std::string& channels) {
  // LCM anchors a subscription regex as ^...$: the outer parentheses keep
  // the alternation inside.
  ::unlink(log_path.c_str());
  const pid_t pid = StartCli({"record", log_path, "--force", "--lcm-url", kUdpmUrl, "--channels",
                              "((" + channels + ")|TEST_PROBE)"},
                             log_path + ".out", log_path + ".err");
  lcm::LCM probe(kUdpmUrl);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (probe.good() && std::chrono::steady_clock::now() < deadline) {
    probe.publish("TEST_PROBE", "probe", 5);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    struct stat st {};
    if (::stat(log_path.c_str(), &st) == 0 && st.st_size > 0) return pid;
    int status = 0;
    if (waitpid(pid, &status, WNOHANG) == pid) return -1;  // the recorder died
  }
  StopProcess(pid, SIGKILL, 5.0);
  return -1;
}

namespace {
bool LogHasSyncProbe(const std::string& log_path) {
  lcm::LogFile log(log_path, "r");
  if (!log.good()) return false;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {  // a partly written last event ends it
    if (ev->channel == "TEST_PROBE" && ev->datalen == 4 &&
        std::string(static_cast<const char*>(ev->data), 4) == "sync") {
      return true;
    }
  }
  return false;
}
}  // namespace

int StopRecorder(pid_t recorder, const std::string& log_path) {
  lcm::LCM probe(kUdpmUrl);
  bool synced = false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!synced && probe.good() && std::chrono::steady_clock::now() < deadline) {
    probe.publish("TEST_PROBE", "sync", 4);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    synced = LogHasSyncProbe(log_path);
  }
  const int code = StopProcess(recorder, SIGINT);
  return synced ? code : -1;
}

}  // namespace rocklab::test
