// lib/rocklab/plugins/rocklab-monitor.so: monitor::MonitorServer (and with it
// libmicrohttpd) behind tools/monitor_plugin.h's table, so that the rocklab
// command maps libmicrohttpd and gnutls only in `rocklab monitor`.
#include <string>

#include "common/logger_clock.h"
#include "monitor/server.h"
#include "tools/monitor_plugin.h"

namespace rocklab::tools {
namespace {

monitor::MonitorServer& Server(void* server) { return *static_cast<monitor::MonitorServer*>(server); }
const monitor::MonitorServer& Server(const void* server) {
  return *static_cast<const monitor::MonitorServer*>(server);
}

void* Open(const monitor::LiveState& state, const monitor::ServerOptions& options) {
  return new monitor::MonitorServer(state, options);
}
void Close(void* server) { delete static_cast<monitor::MonitorServer*>(server); }
void Start(void* server) { Server(server).Start(); }
void Stop(void* server) { Server(server).Stop(); }
int Port(const void* server) { return Server(server).port(); }
std::string Url(const void* server) { return Server(server).url(); }

const MonitorCalls kCalls{kMonitorPluginVersion, &Open, &Close, &Start, &Stop, &Port, &Url};

}  // namespace
}  // namespace rocklab::tools

extern "C" __attribute__((visibility("default"))) const rocklab::tools::MonitorCalls* rocklab_monitor_plugin() {
  rocklab::common::LoadLogLevels();  // this plugin's spdlog registry
  return &rocklab::tools::kCalls;
}
