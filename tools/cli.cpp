#include "tools/cli.h"

#include <csignal>
#include <cstdlib>

namespace rocklab::tools {

namespace {
std::atomic<bool> g_stop{false};
extern "C" void OnStopSignal(int) { g_stop.store(true); }
}  // namespace

std::string SubscriberUrl(const std::string& url) {
  std::string out = url;
  if (out.empty()) {
    const char* env = std::getenv("LCM_DEFAULT_URL");
    out = env != nullptr && *env != '\0' ? env : "udpm://239.255.76.67:7667?ttl=0";
  }
  if (out.rfind("udpm://", 0) != 0 || out.find("recv_buf_size=") != std::string::npos) return out;
  return out + (out.find('?') == std::string::npos ? "?" : "&") + "recv_buf_size=4194304";
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
