#pragma once
/// @file
/// What the nodes share: one named stderr logger per module, the host's
/// monotonic clock (rates, timeouts and health periods only: message times
/// come from the acquisition sample clock), and the end of a subscriber loop.

#include <memory>
#include <string>

#include <lcm/lcm-cpp.hpp>
#include <spdlog/logger.h>

namespace rocklab::common {

/// The logger named `name` from spdlog's registry, created on stderr (stdout
/// carries the commands' own output) the first time it is asked for. Safe
/// when two threads ask for a new name at once.
std::shared_ptr<spdlog::logger> NamedLogger(const std::string& name);

/// Seconds of the host's monotonic clock (std::chrono::steady_clock), s.
double HostNowS();

/// Dispatches what LCM has received for `lcm`'s subscriptions and not yet
/// handed out: a node stopping on SIGINT/SIGTERM handles everything that
/// arrived before the signal. It waits up to `quiet_ms` for each next message
/// (datagrams already in the socket but not yet in LCM's queue, LCM's receive
/// thread being a little behind), so it returns `quiet_ms` after the last
/// one; after `max_messages` (messages still arriving must not keep it from
/// stopping); or at the first LCM error.
/// @return the messages dispatched.
int DispatchQueued(lcm::LCM& lcm, int max_messages, int quiet_ms = 20);

}  // namespace rocklab::common
