#include "tools/cli.h"

#include <csignal>

#include "common/bus_urls.h"

namespace rocklab::tools {

namespace {
std::atomic<bool> g_stop{false};
extern "C" void OnStopSignal(int) { g_stop.store(true); }
}  // namespace

std::string SubscriberUrl(const std::string& url) {
  const std::string out = common::ResolveLcmUrl(url);
  if (out.rfind("udpm://", 0) != 0 || out.find("recv_buf_size=") != std::string::npos) return out;
  return out + (out.find('?') == std::string::npos ? "?" : "&") + "recv_buf_size=4194304";
}

CLI::Option* AddRawUrlOption(CLI::App& cmd, std::string& raw_url) {
  return cmd.add_option("--raw-url", raw_url,
                        "LCM URL of RL_RAW (default: --lcm-url's udpm group and port + 1, else the same bus; "
                        "'same': the main bus)");
}

const std::atomic<bool>& InstallStopSignals() {
  static_assert(std::atomic<bool>::is_always_lock_free, "set from a signal handler");
  struct sigaction sa {};
  sa.sa_handler = OnStopSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  std::signal(SIGPIPE, SIG_IGN);
  return g_stop;
}

}  // namespace rocklab::tools
