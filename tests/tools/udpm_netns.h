#pragma once
// udpm:// tests: a private network namespace per test process, `rocklab
// record` recording in it, and stopping the processes a test started (DESIGN.md,
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

/// Starts `rocklab record --force` on kUdpmUrl writing `log_path`,
/// recording the channels that match `channels` (an LCM channel regex;
/// TEST_PROBE is added). Returns once it records (it publishes TEST_PROBE
/// messages until the log file grows; the recorder flushes within 100 ms),
/// or -1 when it does not within 10 s. Its own output goes to
/// `log_path`.out and .err.
pid_t StartRecorder(const std::string& log_path, const std::string& channels = ".*");

/// Stops a recorder of StartRecorder once it has written what was published
/// before this call: publishes TEST_PROBE "sync" messages until one is in
/// the log (the recorder writes in arrival order), then SIGINT. Returns the
/// recorder's exit code, or -1 when no probe reached the log within 10 s
/// (the recorder is then stopped all the same).
int StopRecorder(pid_t recorder, const std::string& log_path);


}  // namespace rocklab::test
