#pragma once
// Counting the events of an LCM log that a process is still writing: what a
// test waits on instead of sleeping (with test::WaitUntil of run_cli.h).

#include <cstdint>
#include <string>

#include <lcm/lcm-cpp.hpp>

namespace rocklab::test {

/// Events on `channel` in the log at `path` so far; a partly written last
/// event ends the count (it is counted on a later call). 0 while the file
/// does not exist.
inline std::int64_t CountLogEvents(const std::string& path, const std::string& channel) {
  lcm::LogFile log(path, "r");
  if (!log.good()) return 0;
  std::int64_t n = 0;
  while (const lcm::LogEvent* ev = log.readNextEvent()) n += ev->channel == channel ? 1 : 0;
  return n;
}

}  // namespace rocklab::test
