#pragma once
/// @file
/// The monitor node: every RL_ channel into a LiveState, served as the live
/// theory-versus-experiment page.
///
/// Threading: the thread that calls Run handles the bus, each message going
/// into the LiveState (decoded there, under its mutex); the server's
/// libmicrohttpd thread serves the page, the snapshot and the event streams,
/// reading the LiveState (monitor/server.h).
/// Nothing is published.
///
/// Shutdown order (Run): the stop flag ends the bus loop (polled every
/// 100 ms) and what arrived before it is ingested; the server ends its event
/// streams, stops listening and joins; the destructor unsubscribes.

#include <atomic>
#include <memory>
#include <string>

#include "common/bus.h"
#include "monitor/live_state.h"
#include "monitor/server.h"

namespace rocklab::monitor {

struct MonitorNodeConfig {
  LiveOptions live;
  ServerOptions server;
  /// Messages the bus may queue for the monitor while an HTTP thread holds
  /// the state (LCM's default is 30: a full snapshot takes milliseconds,
  /// during which a 1 kHz pipeline sends several hundred messages). >= 1.
  int queue_capacity{100000};
  /// @throws std::invalid_argument naming the option.
  void Validate() const;
};

class MonitorNode {
 public:
  /// Binds the server (not yet serving) and subscribes `<prefix>.*` on `bus`
  /// (not owned; must outlive the node).
  /// @throws std::invalid_argument for invalid options, std::runtime_error
  ///         naming host:port when the server cannot bind.
  MonitorNode(const MonitorNodeConfig& config, common::Bus& bus);
  ~MonitorNode();
  MonitorNode(const MonitorNode&) = delete;
  MonitorNode& operator=(const MonitorNode&) = delete;

  /// Starts serving on the server's threads (url() is then live). Idempotent.
  void Start();
  /// Start, then loops on the bus until `stop`, then stops the server.
  /// @return false when the bus failed (the page was served until then).
  bool Run(const std::atomic<bool>& stop);

  std::string url() const;  ///< "http://HOST:PORT/"
  const LiveState& state() const { return state_; }

 private:
  MonitorNodeConfig config_;
  common::Bus& bus_;  // not owned
  LiveState state_;
  std::unique_ptr<MonitorServer> server_;
  common::Subscription subscription_;
  bool started_{};
};

}  // namespace rocklab::monitor
