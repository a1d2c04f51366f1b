// The comparator's command-line flags (compare/compare_flags.h).
// Oracle: the values parsed land in the CompareNodeConfig fields the flags'
// help names; --stale-clock takes host or sample in any case and nothing
// else.
#include "compare/compare_flags.h"

#include <gtest/gtest.h>

#include <CLI/CLI.hpp>

#include <algorithm>
#include <string>
#include <vector>

namespace rocklab::compare {
namespace {

void Parse(CLI::App& app, std::vector<std::string> args) {
  std::reverse(args.begin(), args.end());  // CLI11 takes them last first
  app.parse(args);
}

TEST(CompareFlags, FillTheConfig) {
  CLI::App app;
  CompareNodeConfig c;
  AddCompareOptions(app, c);
  Parse(app, {"--compare-rate", "25", "--window", "3.5", "--stale", "0.75", "--stale-clock", "SAMPLE",
              "--mode-rest", "0.004"});
  EXPECT_DOUBLE_EQ(c.mode_rest_rad, 0.004);
  EXPECT_DOUBLE_EQ(c.publish_rate_hz, 25.0);
  EXPECT_DOUBLE_EQ(c.comparator.window_s, 3.5);
  EXPECT_DOUBLE_EQ(c.stale_after_s, 0.75);
  EXPECT_EQ(c.stale_clock, StaleClock::kSample);
}

TEST(CompareFlags, UnknownStaleClockIsRefused) {
  CLI::App app;
  CompareNodeConfig c;
  AddCompareOptions(app, c);
  EXPECT_THROW(Parse(app, {"--stale-clock", "wall"}), CLI::ValidationError);
}

}  // namespace
}  // namespace rocklab::compare
