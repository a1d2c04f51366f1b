#include "tools/pipeline.h"

namespace rocklab::tools {

void AddCompareOptions(CLI::App& cmd, compare::CompareNodeConfig& c) {
  cmd.add_option("--compare-rate", c.publish_rate_hz, "RL_COMPARE_* rate, sample-clock Hz")
      ->capture_default_str();
  cmd.add_option("--window", c.comparator.window_s, "sliding RMS window, s")->capture_default_str();
  cmd.add_option("--stale", c.stale_after_s, "seconds without input before a stale event")
      ->capture_default_str();
}

}  // namespace rocklab::tools
