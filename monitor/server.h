#pragma once
/// @file
/// The monitor's HTTP server (libmicrohttpd, event-driven): serves the
/// embedded page (monitor/assets.h) and the LiveState as JSON, read-only.
///
/// Routes (GET and HEAD only; another HTTP method gets 405, a token that is
/// no HTTP method 400):
///   /, /index.html, /app.js, ...  the embedded assets, nothing else (404)
///   /api/snapshot                 LiveState::Snapshot() as JSON
///   /api/events                   Server-Sent Events: a full snapshot first,
///                                 then LiveState::UpdateSince(cursor) every
///                                 push period while something changed
/// There is no file system behind the server: a path is looked up as is (not
/// even percent-decoded) in the embedded table, so traversal attempts and
/// directories find nothing.
///
/// Under load (docs/reliability.md): one polling thread serves every
/// connection, so idle or slow clients cost a socket and a bounded buffer,
/// never a thread. At most max_connections are open (more are refused at
/// accept), at most max_connections_per_host from one address, so a few
/// hosts cannot take every slot; a request's line and headers must arrive
/// whole within header_timeout_s of the connection (or of the previous
/// answer on it), however slowly they trickle, else the connection is
/// closed; they must fit in max_header_bytes (else 431 and the connection
/// closes); a connection on which nothing moves for idle_timeout_s (a
/// client that reads nothing of its answer) is closed. Event streams: at
/// most max_streams, max_streams_per_host from one address; a stream whose
/// client has stopped reading (its output blocked for stream_stall_s) is
/// dropped when another asks for its slot. Why libmicrohttpd and not a
/// thread per connection, with the measured loads: docs/reliability.md.
///
/// Threading: libmicrohttpd's polling thread runs every callback; a ticker
/// thread resumes the event streams (suspended between pushes) once per push
/// period. Stop() ends the streams (each gets its last chunk), stops
/// listening, stops the polling thread and joins both.

#include <cstddef>
#include <memory>
#include <string>

#include "monitor/live_state.h"

namespace rocklab::monitor {

struct ServerOptions {
  std::string host{"127.0.0.1"};  ///< address to bind; 127.0.0.1 unless told otherwise
  int port{8080};                 ///< 0 picks a free port; 0..65535
  double push_period_s{0.1};      ///< event-stream update period, s; > 0 (10 Hz)
  double keepalive_period_s{5.0}; ///< comment line on a quiet stream, s; > 0, < idle_timeout_s
  std::size_t max_streams{8};     ///< concurrent event streams; more get 503
  /// Event streams from one address at most (max_streams if more); more get
  /// 503. 1 .. 1024.
  std::size_t max_streams_per_host{2};
  /// A stream whose output has been blocked this long (its client reads
  /// nothing) gives its slot to a new stream that asks, s; > 0.
  double stream_stall_s{2.0};
  /// Open connections at most (idle, reading, streaming); more are refused.
  /// 1 .. 4096, and kept 64 below the process's open-file limit.
  std::size_t max_connections{1024};
  /// Open connections from one address at most, so that a few hosts cannot
  /// take every slot (16 hosts to fill the default 1024); 1 .. max_connections.
  std::size_t max_connections_per_host{64};
  /// The request line and headers must be complete this long after the
  /// connection opened (or its previous answer ended), s; a deadline, not
  /// reset by a byte. 1 .. 60.
  double header_timeout_s{8.0};
  /// A connection with no traffic for this long is closed, s; 1 .. 3600.
  double idle_timeout_s{10.0};
  /// Request line and headers of one request (with their CRLFs and the
  /// empty line), bytes; more gets 431 and a close. 1024 .. 65536.
  std::size_t max_header_bytes{8192};
  /// @throws std::invalid_argument naming the option.
  void Validate() const;
};

class MonitorServer {
 public:
  /// Binds host:port (not yet serving).
  /// @param state read by the HTTP thread; not owned, must outlive the server.
  /// @throws std::invalid_argument for invalid options, std::runtime_error
  ///         naming host:port when it cannot bind.
  MonitorServer(const LiveState& state, const ServerOptions& options);
  /// Stops and joins.
  ~MonitorServer();
  MonitorServer(const MonitorServer&) = delete;
  MonitorServer& operator=(const MonitorServer&) = delete;

  /// Serves on a background thread.
  /// @throws std::runtime_error when libmicrohttpd cannot start.
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
