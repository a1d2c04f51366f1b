#pragma once
/// @file
/// The monitor's HTTP server (cpp-httplib): serves the embedded page
/// (monitor/assets.h) and the LiveState as JSON, read-only.
///
/// Routes (GET and HEAD only; any other method gets 405):
///   /, /index.html, /app.js, ...  the embedded assets, nothing else (404)
///   /api/snapshot                 LiveState::Snapshot() as JSON
///   /api/events                   Server-Sent Events: a full snapshot first,
///                                 then LiveState::UpdateSince(cursor) every
///                                 push period while something changed
/// There is no file system behind the server: a path is looked up as is in
/// the embedded table, so traversal attempts and directories find nothing.
///
/// Threading: cpp-httplib's listening thread and worker pool; each event
/// stream holds one worker (hence max_streams). Stop() ends the streams
/// within a push period, stops listening and joins.

#include <cstddef>
#include <memory>
#include <string>

#include "monitor/live_state.h"

namespace rocklab::monitor {

struct ServerOptions {
  std::string host{"127.0.0.1"};  ///< address to bind; 127.0.0.1 unless told otherwise
  int port{8080};                 ///< 0 picks a free port; 0..65535
  double push_period_s{0.1};      ///< event-stream update period, s; > 0 (10 Hz)
  double keepalive_period_s{5.0}; ///< comment line on a quiet stream, s; > 0
  std::size_t max_streams{8};     ///< concurrent event streams; more get 503
  /// @throws std::invalid_argument naming the option.
  void Validate() const;
};

class MonitorServer {
 public:
  /// Binds host:port (not yet serving).
  /// @param state read by the HTTP threads; not owned, must outlive the server.
  /// @throws std::invalid_argument for invalid options, std::runtime_error
  ///         naming host:port when it cannot bind.
  MonitorServer(const LiveState& state, const ServerOptions& options);
  /// Stops and joins.
  ~MonitorServer();
  MonitorServer(const MonitorServer&) = delete;
  MonitorServer& operator=(const MonitorServer&) = delete;

  /// Serves on a background thread.
  void Start();
  /// Ends the event streams, stops listening, joins. Idempotent.
  void Stop();

  int port() const;        ///< the bound port (the free one picked for port 0)
  std::string url() const; ///< "http://HOST:PORT/"

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rocklab::monitor
