#pragma once
/// @file
/// systemd's notify protocol, written here (a datagram to $NOTIFY_SOCKET)
/// rather than linked from libsystemd: READY=1 when a node is up, WATCHDOG=1
/// from its heartbeat, STOPPING=1 at shutdown. Outside systemd
/// ($NOTIFY_SOCKET unset) every call is a no-op. Never throws.

namespace rocklab::common {

/// Sends `state` (e.g. "READY=1") to $NOTIFY_SOCKET; false when unset or
/// the send failed.
bool NotifySystemd(const char* state);

/// "WATCHDOG=1", at most once every 0.5 s (a heartbeat may come faster; the
/// watchdog interval in the units is 30 s). Called from the nodes' RL_HEALTH.
void NotifyWatchdog();

}  // namespace rocklab::common
