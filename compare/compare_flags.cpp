#include "compare/compare_flags.h"

#include <map>
#include <string>

#include <CLI/CLI.hpp>

namespace rocklab::compare {

void AddCompareOptions(CLI::App& cmd, CompareNodeConfig& c) {
  cmd.add_option("--compare-rate", c.publish_rate_hz, "RL_COMPARE_* rate, sample-clock Hz")
      ->capture_default_str();
  cmd.add_option("--window", c.comparator.window_s, "sliding RMS window, s")->capture_default_str();
  cmd.add_option("--mode-rest", c.mode_rest_rad,
                 "an assembly's measured mode: |relative angle| at most this is a closed interface, rad")
      ->capture_default_str();
  cmd.add_option("--stale", c.stale_after_s, "seconds without input before a stale event")
      ->capture_default_str();
  const std::map<std::string, StaleClock> clocks{{"host", StaleClock::kHost},
                                                 {"sample", StaleClock::kSample}};
  cmd.add_option("--stale-clock", c.stale_clock,
                 "clock of --stale: host (live) or sample (offline, e.g. behind replay --max; "
                 "run --max always uses sample)")
      ->transform(CLI::CheckedTransformer(clocks, CLI::ignore_case));
}

}  // namespace rocklab::compare
