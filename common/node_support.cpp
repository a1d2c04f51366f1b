#include "common/node_support.h"

#include <chrono>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

namespace rocklab::common {

std::shared_ptr<spdlog::logger> NamedLogger(const std::string& name) {
  if (auto existing = spdlog::get(name)) return existing;
  try {
    return spdlog::stderr_color_mt(name);
  } catch (const spdlog::spdlog_ex&) {  // another thread registered it first
    return spdlog::get(name);
  }
}

double HostNowS() {
  using namespace std::chrono;
  return duration<double>(steady_clock::now().time_since_epoch()).count();
}

int DispatchQueued(lcm::LCM& lcm, int max_messages, int quiet_ms) {
  int dispatched = 0;
  while (dispatched < max_messages && lcm.handleTimeout(quiet_ms) > 0) ++dispatched;
  return dispatched;
}

}  // namespace rocklab::common
