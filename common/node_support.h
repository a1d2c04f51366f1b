#pragma once
/// @file
/// The loop of a node (the named loggers and the host clock are
/// common/logger_clock.h).
///
/// The nodes' shape (constructor subscribes, Run loops, Finish sends the
/// last messages) and where each node differs: docs/architecture.md, "The
/// four nodes share a shape".

#include <atomic>
#include <functional>
#include <string>

#include "common/logger_clock.h"  // NamedLogger, HostNowS: kept here for the includes that had them

namespace rocklab::common {

class Bus;

/// The loop of every subscribing node: handles `bus` with a 100 ms timeout
/// until `stop`, calling `periodic` after every wait, so health and stale
/// checks run when nothing arrives. Then it dispatches what arrived before
/// the stop (a node stopping on SIGINT/SIGTERM handles it): it waits up to
/// `quiet_ms` for each next message (datagrams already in the socket but
/// not yet in LCM's queue), and stops after `drain_max` messages (messages
/// still arriving must not keep it from stopping) or at a bus error.
/// Under systemd it sends READY=1 on entry, WATCHDOG=1 after every
/// `periodic` (rate-limited; common/sd_notify.h) and STOPPING=1 at the stop.
/// @return false when the bus failed before the stop (logged to `log_name`).
bool RunNodeLoop(Bus& bus, const std::atomic<bool>& stop, const std::function<void()>& periodic,
                 int drain_max, const std::string& log_name, int quiet_ms = 20);

}  // namespace rocklab::common
