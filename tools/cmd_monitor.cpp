// rocklab monitor: the live theory-versus-experiment page: a
// monitor::MonitorNode on an LcmBus (threading and shutdown order are
// written in monitor/monitor_node.h), its HTTP server from the monitor
// plugin (tools/monitor_plugin.h). SIGINT/SIGTERM set the stop flag;
// exit 0 (1 when the bus failed or the plugin does not load).
#include <atomic>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>

#include "common/lcm_bus.h"
#include "monitor/monitor_node.h"
#include "pipeline/pipeline.h"
#include "tools/cli.h"
#include "tools/monitor_plugin.h"

namespace rocklab::tools {
namespace {

struct MonitorCommand {
  std::string lcm_url;
  std::string http{"127.0.0.1:8080"};
  double window_s{60.0};
};

// "HOST:PORT" or "[V6]:PORT" -> host and port.
void ParseHttp(const std::string& text, monitor::ServerOptions& o) {
  const std::size_t colon = text.rfind(':');
  auto bad = [&text] {
    return UsageError("--http must be HOST:PORT (e.g. 127.0.0.1:8080, port 0 picks a free one), got '" +
                      text + "'");
  };
  if (colon == std::string::npos || colon == 0 || colon + 1 == text.size()) throw bad();
  std::string host = text.substr(0, colon);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  const std::string port = text.substr(colon + 1);
  if (host.empty() || port.size() > 5 || port.find_first_not_of("0123456789") != std::string::npos) {
    throw bad();
  }
  o.host = host;
  o.port = std::stoi(port);
  if (o.port > 65535) throw bad();
}

int RunMonitor(const MonitorCommand& c) {
  Require(c.window_s > 0 && c.window_s <= 24 * 3600, "--window", "in (0, 86400] s", c.window_s);
  monitor::MonitorNodeConfig config;
  ParseHttp(c.http, config.server);
  config.live.window_s = c.window_s;
  MonitorPlugin();  // a missing plugin is no --http error: it fails here (exit 1), naming the package
  const std::unique_ptr<common::LcmBus> bus = pipeline::OpenLcmBus(SubscriberUrl(c.lcm_url));
  const std::atomic<bool>& stop = InstallStopSignals();
  std::unique_ptr<monitor::MonitorNode> node;
  try {
    node = std::make_unique<monitor::MonitorNode>(config, *bus);
  } catch (const std::exception& e) {
    throw UsageError(std::string("--http: ") + e.what());
  }
  node->Start();
  std::printf("rocklab monitor: serving %s\n", node->url().c_str());
  std::fflush(stdout);
  if (!node->Run(stop)) {
    std::fprintf(stderr, "rocklab monitor: LCM receive failed\n");
    return kFailureExit;
  }
  return 0;
}

}  // namespace

void RegisterMonitor(CLI::App& app, CommandRun& run) {
  auto c = std::make_shared<MonitorCommand>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand("monitor", "live theory-versus-experiment page in the browser");
  cmd->add_option("--lcm-url", c->lcm_url, "LCM URL (default: LCM_DEFAULT_URL or LCM's own)");
  cmd->add_option("--http", c->http, "HOST:PORT to serve on; port 0 picks a free one")
      ->capture_default_str();
  cmd->add_option("--window", c->window_s, "seconds of sample clock shown")->capture_default_str();
  cmd->callback([c, &run] { run = [c] { return RunMonitor(*c); }; });
}

}  // namespace rocklab::tools
