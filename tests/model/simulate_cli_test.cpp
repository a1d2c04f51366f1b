// `rocklab simulate` as a user runs it: the command that aborted
// on a forcing ending while the block rocks exits 0, and --json reports the
// equations' share and the solver's work.
#include <gtest/gtest.h>

#include <string>

#include <nlohmann/json.hpp>

#include "tests/tools/run_cli.h"

namespace rocklab::test {
namespace {

// Oracle: a command that once failed (exit 1, "CVode failed with flag -3" before)
// exits 0 and writes 12 s at 200 Hz; the JSON's keys as documented in the
// docs/commands.md (`simulate --json`): eq10_fraction 0 for Housner, 1 for the complex model at its
// defaults, between 0 and 1 with the opt-in hand-off (whose use is echoed).
TEST(CliSimulate, MotionEndingWhileRockingAndJson) {
  const std::string dir = ScratchDir("simulate_json");
  const std::vector<std::string> common{"simulate", "--alpha", "0.168", "--p", "3.767", "--mu", "0.942",
                                        "--excitation", "sine:amp=0.006,freq=5,duration=5.05,start=0",
                                        "--duration", "12", "--rate", "200", "--json"};
  for (const char* model : {"housner", "complex"}) {
    std::vector<std::string> args = common;
    args.insert(args.end(), {"--model", model, "--out", dir + "/x.csv"});
    const CliResult r = RunCli(args);
    ASSERT_EQ(r.exit_code, 0) << model << ": " << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j.at("samples").get<int>(), 2401);
    EXPECT_EQ(j.at("eq10_fraction").get<double>(), std::string(model) == "complex" ? 1.0 : 0.0) << model;
    EXPECT_GT(j.at("steps").get<long>(), 0);
    EXPECT_GT(j.at("rhs_evals").get<long>(), j.at("steps").get<long>());
    EXPECT_GE(j.at("error_test_fails").get<long>(), 0);
    EXPECT_EQ(j.at("restarts").get<long>(), 1) << model;  // at 5.05 s
    EXPECT_GT(j.at("impacts").get<int>(), 20);
  }
  std::vector<std::string> args = common;
  args.insert(args.end(), {"--model", "complex", "--l", "3e-4", "--complex-handoff", "16", "--out",
                           dir + "/y.csv"});
  const CliResult r = RunCli(args);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("complex_handoff").get<double>(), 16.0);
  EXPECT_GT(j.at("eq10_fraction").get<double>(), 0.0);
  EXPECT_LT(j.at("eq10_fraction").get<double>(), 1.0);

  const CliResult bad = RunCli({"simulate", "--alpha", "0.168", "--p", "3.767", "--mu", "0.942",
                                "--duration", "1", "--rate", "10", "--model", "complex",
                                "--complex-handoff", "-1", "--out", dir + "/z.csv"});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("--complex-handoff"), std::string::npos) << bad.err;
}

// Oracle: the contract of --rtol (docs/commands.md): it reaches the model
// (a looser tolerance takes fewer steps: figure 8's 12 s at 1e-6 against
// the default 1e-10: 4062 against 7700 steps measured, asserted below
// 0.7 of them), and a value outside (0, 1e-3] exits 2 naming it.
TEST(CliSimulate, RtolReachesTheModelAndIsChecked) {
  const std::string dir = ScratchDir("simulate_rtol");
  const std::vector<std::string> common{"simulate", "--alpha", "0.168", "--p", "3.767", "--mu", "0.942",
                                        "--excitation", "sine:amp=0.006,freq=5,duration=12,start=0",
                                        "--duration", "12", "--rate", "100", "--json", "--out", dir + "/x.csv"};
  long steps[2] = {};
  int i = 0;
  for (const char* rtol : {"1e-10", "1e-6"}) {
    std::vector<std::string> args = common;
    args.insert(args.end(), {"--rtol", rtol});
    const CliResult r = RunCli(args);
    ASSERT_EQ(r.exit_code, 0) << rtol << ": " << r.err;
    steps[i++] = nlohmann::json::parse(r.out).at("steps").get<long>();
  }
  EXPECT_LT(steps[1], 0.7 * steps[0]) << steps[0] << " steps at 1e-10, " << steps[1] << " at 1e-6";
  std::vector<std::string> args = common;
  args.insert(args.end(), {"--rtol", "0"});
  const CliResult bad = RunCli(args);
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("--rtol"), std::string::npos) << bad.err;
}

// Oracle: the same contract on the other commands that integrate: fit
// (the trajectory method's model), model and run (every variant); 0 exits
// 2 naming --rtol before anything runs.
TEST(CliSimulate, RtolIsCheckedOnEveryCommandThatIntegrates) {
  const std::string src = ROCKLAB_SOURCE_DIR;
  const std::string rig = src + "/data/rigs/block1_rig.toml";
  const std::vector<std::vector<std::string>> commands{
      {"fit", "--input", src + "/data/samples/free_rocking.csv", "--width", "0.247", "--height", "1.0", "--rtol", "0"},
      {"model", "--rig", rig, "--rtol", "0"},
      {"run", "--rig", rig, "--input", src + "/data/samples/fig7_block1.csv", "--max", "--rtol", "0"}};
  for (const auto& args : commands) {
    const CliResult r = RunCli(args);
    EXPECT_EQ(r.exit_code, 2) << args[0] << ": " << r.err;
    EXPECT_NE(r.err.find("--rtol"), std::string::npos) << args[0] << ": " << r.err;
  }
}

}  // namespace
}  // namespace rocklab::test
