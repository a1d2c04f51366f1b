#pragma once
// The monitor's HTTP server plugin (lib/rocklab/plugins/rocklab-monitor.so,
// in the rocklab package): monitor::MonitorServer with libmicrohttpd, whose
// gnutls closure (9 shared objects, ~1.5 ms of CPU at every start:
// docs/performance.md, Start-up) only `rocklab monitor` needs. The command
// does not link it: tools/monitor_forward.cpp defines MonitorServer for it,
// forwarding to this table, and `monitor` opens the plugin before it binds.
// Everything else that links rocklab::monitor (the tests, a program using
// the -dev package) has the real server.

#include <string>

#include "monitor/live_state.h"
#include "monitor/server.h"

namespace rocklab::tools {

/// The plugin's entry: `extern "C" const MonitorCalls* rocklab_monitor_plugin()`.
inline constexpr const char* kMonitorPluginEntry = "rocklab_monitor_plugin";
inline constexpr const char* kMonitorPluginFile = "rocklab-monitor.so";
/// The Debian package that installs it (cmake/RocklabPackage.cmake).
inline constexpr const char* kMonitorPluginPackage = "rocklab";
/// MonitorCalls::version of this build; a plugin with another is refused.
inline constexpr int kMonitorPluginVersion = 1;

/// The plugin's monitor::MonitorServer, behind an opaque pointer (the
/// command's MonitorServer is the forwarding class of the same name).
struct MonitorCalls {
  int version;
  /// A new server bound to options.host:port (MonitorServer's constructor,
  /// and its exceptions); freed by close.
  void* (*open)(const monitor::LiveState& state, const monitor::ServerOptions& options);
  void (*close)(void* server);  ///< stops, joins and frees
  void (*start)(void* server);
  void (*stop)(void* server);
  int (*port)(const void* server);
  std::string (*url)(const void* server);
};

/// The plugin's calls, opened at the first call (then kept).
/// @throws std::runtime_error naming the file and the package to reinstall
///   when it is missing or does not load.
const MonitorCalls& MonitorPlugin();

}  // namespace rocklab::tools
