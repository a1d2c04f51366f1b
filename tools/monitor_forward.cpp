// The rocklab command's monitor::MonitorServer: the same class as
// monitor/server.cpp, forwarding to the monitor plugin
// (tools/monitor_plugin.h), opened when a server is made. Linked into the
// command as an object of its own, these definitions come before the
// static library's, so the linker never takes server.o from the archive
// (ServerOptions::Validate is server_options.cpp's), and with --as-needed
// libmicrohttpd is not among the command's libraries
// (tests/tools/startup_test.cpp checks that). A symbol of server.cpp
// missing here would pull its object in and fail the link with a
// duplicate definition.
#include <memory>
#include <stdexcept>
#include <string>

#include "common/plugin.h"
#include "monitor/server.h"
#include "tools/monitor_plugin.h"

namespace rocklab {
namespace tools {

const MonitorCalls& MonitorPlugin() {
  std::string error;
  const MonitorCalls* calls =
      common::OpenPluginOnce<MonitorCalls>(kMonitorPluginFile, kMonitorPluginEntry, kMonitorPluginVersion, error);
  if (calls == nullptr) {
    const std::string package = kMonitorPluginPackage;
    const std::string path = common::PluginPath(kMonitorPluginFile);
    throw std::runtime_error(
        common::PluginInstalled(kMonitorPluginFile)
            ? "the monitor's HTTP server (plugin " + path + ") does not load: " + error +
                  " (apt-get install --reinstall " + package + ")"
            : "the monitor's HTTP server is the plugin " + path + ", which is missing: the package " +
                  package + " installs it (apt-get install --reinstall " + package + ")");
  }
  return *calls;
}

}  // namespace tools

namespace monitor {

struct MonitorServer::Impl {
  const tools::MonitorCalls& calls;
  void* server;  // the plugin's MonitorServer
};

MonitorServer::MonitorServer(const LiveState& state, const ServerOptions& options) {
  const tools::MonitorCalls& calls = tools::MonitorPlugin();
  impl_.reset(new Impl{calls, calls.open(state, options)});
}
MonitorServer::~MonitorServer() { impl_->calls.close(impl_->server); }
void MonitorServer::Start() { impl_->calls.start(impl_->server); }
void MonitorServer::Stop() { impl_->calls.stop(impl_->server); }
int MonitorServer::port() const { return impl_->calls.port(impl_->server); }
std::string MonitorServer::url() const { return impl_->calls.url(impl_->server); }

}  // namespace monitor
}  // namespace rocklab
