#pragma once
/// @file
/// The loop of a node (the named loggers and the host clock are
/// common/logger_clock.h).
///
/// Every node has one shape:
///   class XNode {
///    public:
///     XNode(XNodeConfig config, common::Bus& bus);  // subscribes; throws on bad config
///     void Run(const std::atomic<bool>& stop);      // RunNodeLoop, then Finish
///     void Finish();                                // last messages, RL_HEALTH "stopped"
///   };
/// and its shutdown order written above the class. On a DirectBus (`rocklab
/// run`) nobody calls Run for the subscribing nodes: the source node's Run
/// drives them through the bus, and the command calls their Finish.

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
