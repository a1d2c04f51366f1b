#pragma once
/// @file
/// Re-publishes a recorded LCM log, paced by the log's event timestamps at a
/// speed factor or as fast as possible, with a channel filter, a time window
/// and looping (what lcm-logplayer lacks). Payloads go out byte for byte, so
/// what downstream nodes compute does not depend on the speed. The log is
/// read in file order by common::LogReader: every event of the window is
/// published, also in logs whose stamps go back (an event stamped before an
/// earlier one goes out at once); damaged regions are skipped, counted and
/// reported with their file offsets.

#include <atomic>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <string>

#include "common/bus.h"

namespace rocklab::pipeline {

struct ReplayOptions {
  double speed{1.0};          ///< 1 = recorded pace; > 0
  bool max_speed{false};      ///< ignore the pace: publish as fast as possible
  std::string channels{".*"}; ///< ECMAScript regex, matched against the whole channel name
  bool loop{false};           ///< start again at the end (until stopped)
  double start_s{0.0};        ///< window start, s after the log's first event; >= 0
  /// window end, s after the first event, > start_s; infinity (the
  /// default): to the end. A negative end is refused.
  double end_s{std::numeric_limits<double>::infinity()};
  /// @throws std::invalid_argument naming the option.
  void Validate() const;
};

struct ReplayCounts {
  std::int64_t read{};       ///< events read in the window
  std::int64_t published{};  ///< events published
  std::int64_t filtered{};   ///< events left out by the channel filter
  std::int64_t failed{};     ///< publish calls that failed
  int passes{};              ///< times the window was played
  std::int64_t damaged_regions{};  ///< damaged regions skipped (each counted once)
  std::int64_t damaged_bytes{};    ///< bytes in them
  std::int64_t damaged_events{};   ///< events lost in them
  std::map<std::string, std::int64_t> per_channel;  ///< published, per channel
};

/// Plays `log_path` onto `bus` until the window ends (or forever with loop)
/// or `stop` is set. Each damaged region goes to `on_problem` (once) as
/// common::ToString(LogProblem) text; empty: counted only.
/// @throws std::runtime_error naming the file when it cannot be read.
ReplayCounts ReplayLog(const std::string& log_path, const ReplayOptions& options, common::Bus& bus,
                       const std::atomic<bool>& stop,
                       const std::function<void(const std::string&)>& on_problem = {});

}  // namespace rocklab::pipeline
