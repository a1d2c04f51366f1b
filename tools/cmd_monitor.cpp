// rocklab monitor: the live theory-versus-experiment page.
//
// Threading model: the main thread subscribes the RL_ channels and loops on
// lcm.handleTimeout, each message going into the LiveState (decoded there,
// under its mutex); cpp-httplib's threads serve the page, the snapshot and
// the event streams, reading the LiveState. Nothing is published.
//
// Shutdown (SIGINT/SIGTERM set the stop flag, polled every 100 ms): the LCM
// loop ends, the server ends its event streams, stops listening and joins;
// exit 0.
#include <atomic>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "monitor/live_state.h"
#include "monitor/server.h"
#include "tools/cli.h"

namespace rocklab::tools {
namespace {

// Messages LCM may queue for the monitor while an HTTP thread holds the
// state (LCM's default is 30: a full snapshot takes milliseconds, during
// which a 1 kHz pipeline sends several hundred messages).
constexpr int kQueueCapacity = 100000;

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

class Feeder {
 public:
  explicit Feeder(monitor::LiveState& state) : state_(state) {}
  void OnMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    state_.Ingest(channel, rbuf->data, static_cast<int>(rbuf->data_size));  // never throws
  }

 private:
  monitor::LiveState& state_;
};

int RunMonitor(const MonitorCommand& c) {
  Require(c.window_s > 0 && c.window_s <= 24 * 3600, "--window", "in (0, 86400] s", c.window_s);
  monitor::ServerOptions server_options;
  ParseHttp(c.http, server_options);
  monitor::LiveOptions live;
  live.window_s = c.window_s;
  monitor::LiveState state(live);

  const std::string url = SubscriberUrl(c.lcm_url);
  lcm::LCM lcm(url);
  if (!lcm.good()) throw UsageError("--lcm-url: cannot open LCM at '" + url + "'");
  const std::atomic<bool>& stop = InstallStopSignals();

  std::unique_ptr<monitor::MonitorServer> server;
  try {
    server = std::make_unique<monitor::MonitorServer>(state, server_options);
  } catch (const std::exception& e) {
    throw UsageError(std::string("--http: ") + e.what());
  }
  Feeder feeder(state);
  lcm::Subscription* sub = lcm.subscribe(live.channel_prefix + ".*", &Feeder::OnMessage, &feeder);
  sub->setQueueCapacity(kQueueCapacity);
  server->Start();
  std::printf("rocklab monitor: serving %s\n", server->url().c_str());
  std::fflush(stdout);

  int exit_code = 0;
  while (!stop.load()) {
    if (lcm.handleTimeout(100) < 0 && !stop.load()) {  // a stop signal interrupts it
      std::fprintf(stderr, "rocklab monitor: LCM receive failed\n");
      exit_code = kFailureExit;
      break;
    }
  }
  lcm.unsubscribe(sub);
  server->Stop();
  return exit_code;
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
