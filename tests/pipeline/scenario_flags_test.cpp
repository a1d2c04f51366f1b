// The scenario's command-line flags (pipeline/scenario_flags.h).
// Oracle: the values parsed land in the ScenarioOptions fields the flags'
// help names; required flags are required; unset flags keep the defaults of
// ScenarioOptions.
#include "pipeline/scenario_flags.h"

#include <gtest/gtest.h>

#include <CLI/CLI.hpp>

#include <algorithm>
#include <string>
#include <vector>

namespace rocklab::pipeline {
namespace {

TEST(ScenarioFlags, FillTheOptions) {
  CLI::App app;
  ScenarioOptions o;
  AddScenarioOptions(app, o);
  std::vector<std::string> args{"--alpha",      "0.235", "--p",        "3.884", "--mu",
                                "0.937",        "--duration", "2",     "--rate", "500",
                                "--excitation", "sine:amp=0.006,freq=2,duration=1",
                                "--excitation", "hanning:amp=0.01,freq=3,duration=1",
                                "--model",      "complex", "--theta0", "0.01"};
  std::reverse(args.begin(), args.end());  // CLI11 takes them last first
  app.parse(args);
  EXPECT_EQ(o.model, "complex");
  EXPECT_DOUBLE_EQ(o.alpha, 0.235);
  EXPECT_DOUBLE_EQ(o.p, 3.884);
  EXPECT_DOUBLE_EQ(o.mu, 0.937);
  EXPECT_DOUBLE_EQ(o.theta0, 0.01);
  EXPECT_DOUBLE_EQ(o.duration_s, 2.0);
  EXPECT_DOUBLE_EQ(o.rate_hz, 500.0);
  ASSERT_EQ(o.excitations.size(), 2u);
  EXPECT_EQ(o.excitations[1], "hanning:amp=0.01,freq=3,duration=1");
  const ScenarioOptions defaults;
  EXPECT_DOUBLE_EQ(o.l, defaults.l);
  EXPECT_DOUBLE_EQ(o.rtol, defaults.rtol);
  EXPECT_DOUBLE_EQ(o.complex_handoff, defaults.complex_handoff);
}

TEST(ScenarioFlags, AlphaIsRequired) {
  CLI::App app;
  ScenarioOptions o;
  AddScenarioOptions(app, o);
  std::vector<std::string> args{"--p", "3.884", "--mu", "0.937", "--duration", "2", "--rate", "500"};
  std::reverse(args.begin(), args.end());
  EXPECT_THROW(app.parse(args), CLI::RequiredError);
}

}  // namespace
}  // namespace rocklab::pipeline
