#pragma once
// udpm:// tests: a private network namespace per test process, lcm-logger
// recording in it, and stopping the processes a test started (DESIGN.md,
// "Networking in tests"). Nothing here sends outside the namespace's lo.
// Link with run_cli.cpp.

#include <sys/types.h>

#include <string>

#include "tests/tools/run_cli.h"  // StartCli, StopProcess

namespace rocklab::test {

/// LCM's default multicast group with ttl=0, for every udpm test.
inline constexpr const char* kUdpmUrl = "udpm://239.255.76.67:7667?ttl=0";

/// Moves the calling thread, and every thread and process it starts from
/// then on, into a new network namespace with lo up and 224.0.0.0/4 routed
/// on it. Returns "" when done, else the reason it could not (the test then
/// GTEST_SKIPs with it). Call it before creating any udpm LCM instance.
std::string EnterPrivateNetwork();

/// Starts lcm-logger -f on kUdpmUrl (with a 4 MB socket buffer) writing
/// `log_path`, recording the channels that match `channels` (an LCM
/// channel regex; TEST_PROBE is added), at real-time priority (chrt -f 10)
/// when allowed. LCM 1.3.1 queues 30 messages per subscription and
/// lcm-logger cannot raise that: a logger that waits 10 ms for a loaded CPU
/// loses packets of a 3-message-per-ms stream, so record only what the test
/// reads. Returns once the logger records (it publishes TEST_PROBE messages
/// until the log file grows; lcm-logger flushes every 100 ms), or -1 when it
/// does not within 10 s. Its own output goes to `log_path`.out and .err.
pid_t StartLcmLogger(const std::string& log_path, const std::string& channels = ".*");

/// Stops a logger of StartLcmLogger once it has written what was published
/// before this call: publishes TEST_PROBE "sync" messages until one is in
/// the log (lcm-logger handles messages in arrival order), then SIGINT.
/// Returns the logger's exit code, or -1 when no probe reached the log
/// within 10 s (the logger is then stopped all the same).
int StopLcmLogger(pid_t logger, const std::string& log_path);


}  // namespace rocklab::test
