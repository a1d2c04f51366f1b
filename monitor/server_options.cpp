// ServerOptions::Validate, apart from the server (server.cpp): the rocklab
// command checks the options without the server, which it opens from the
// monitor plugin (tools/monitor_plugin.h) and so does not link.
#include <cmath>
#include <stdexcept>
#include <string>

#include "monitor/server.h"

namespace rocklab::monitor {

void ServerOptions::Validate() const {
  auto check = [](bool ok, const char* name, const char* range) {
    if (!ok) {
      throw std::invalid_argument(std::string("monitor server option ") + name + " out of range (" +
                                  range + ")");
    }
  };
  check(!host.empty(), "host", "not empty");
  check(port >= 0 && port <= 65535, "port", "0 .. 65535");
  check(std::isfinite(push_period_s) && push_period_s > 0 && push_period_s <= 60, "push_period_s",
        "(0, 60] s");
  check(std::isfinite(idle_timeout_s) && idle_timeout_s >= 1 && idle_timeout_s <= 3600, "idle_timeout_s",
        "[1, 3600] s");
  check(std::isfinite(keepalive_period_s) && keepalive_period_s > 0 && keepalive_period_s < idle_timeout_s,
        "keepalive_period_s", "(0, idle_timeout_s) s");
  check(max_streams >= 1 && max_streams <= 1024, "max_streams", "1 .. 1024");
  check(max_streams_per_host >= 1 && max_streams_per_host <= 1024, "max_streams_per_host", "1 .. 1024");
  check(std::isfinite(stream_stall_s) && stream_stall_s > 0 && stream_stall_s <= 3600, "stream_stall_s",
        "(0, 3600] s");
  check(std::isfinite(header_timeout_s) && header_timeout_s >= 1 && header_timeout_s <= 60, "header_timeout_s",
        "[1, 60] s");
  check(max_connections >= 1 && max_connections <= 4096, "max_connections", "1 .. 4096");
  check(max_streams <= max_connections, "max_streams", "<= max_connections");
  check(max_connections_per_host >= 1 && max_connections_per_host <= max_connections, "max_connections_per_host",
        "1 .. max_connections");
  check(max_header_bytes >= 1024 && max_header_bytes <= 65536, "max_header_bytes", "1024 .. 65536 bytes");
}

}  // namespace rocklab::monitor
