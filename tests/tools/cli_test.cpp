// The `rocklab` command line as a user runs it: the documented outputs and
// every bad-input case of params and simulate (one-line message naming the
// option, exit code 2).
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <ostream>
#include <cmath>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tests/tools/run_cli.h"

namespace rocklab::test {
namespace {

int CountLines(const std::string& text) {
  return static_cast<int>(std::count(text.begin(), text.end(), '\n'));
}

std::string FirstLine(const std::string& text) { return text.substr(0, text.find('\n')); }

// Oracle: the paper's Table 1 (rows 1-3 with the corrections of docs/errata.md item
// 1: p in rad/s), printed to 3 decimals: agreement to half a unit of the last
// printed digit.
TEST(CliParams, JsonReproducesTable1Row1) {
  const CliResult r = RunCli({"params", "--width", "0.247", "--height", "1.0", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_NEAR(j.at("alpha").get<double>(), 0.242, 5e-4);
  EXPECT_NEAR(j.at("p").get<double>(), 3.780, 5e-4);
  EXPECT_NEAR(j.at("mu").get<double>(), 0.914, 5e-4);
  EXPECT_EQ(j.at("units").at("p"), "rad/s");
}

TEST(CliParams, TextNamesEveryQuantity) {
  const CliResult r = RunCli({"params", "--width", "0.246", "--height", "0.5", "--chamfer", "0.042"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* word : {"alpha", "rad/s", "mu", "mu_housner"}) {
    EXPECT_NE(r.out.find(word), std::string::npos) << word << " missing in\n" << r.out;
  }
}

// Oracle: the contract of the issue: CSV header `time,theta,theta_dot`, one
// row per 1/rate from 0 to duration inclusive; events header `time,kind`.
TEST(CliSimulate, WritesTheDocumentedFiles) {
  const std::string dir = ScratchDir("simulate");
  const CliResult r = RunCli({"simulate", "--model", "housner", "--alpha", "0.235", "--p", "3.884",
                              "--mu", "0.937", "--theta0", "0.1175", "--duration", "2", "--rate",
                              "100", "--out", dir + "/theta.csv", "--events", dir + "/events.csv",
                              "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string csv = ReadFile(dir + "/theta.csv");
  EXPECT_EQ(FirstLine(csv), "time,theta,theta_dot");
  EXPECT_EQ(CountLines(csv), 1 + 201);
  const std::string events = ReadFile(dir + "/events.csv");
  EXPECT_EQ(FirstLine(events), "time,kind");
  EXPECT_NE(events.find(",impact"), std::string::npos);
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("samples").get<int>(), 201);
  EXPECT_GE(j.at("impacts").get<int>(), 2);
  // Free rocking from theta0: the peak is the start.
  EXPECT_NEAR(j.at("peak_abs_theta").get<double>(), 0.1175, 1e-12);
}

TEST(CliSimulate, ExcitationLiftsTheBlockAndAccelFileIsRead) {
  const std::string dir = ScratchDir("simulate_accel");
  // A constant table acceleration of 3 m/s^2 from 0.1 s: above g tan(0.235) =
  // 2.35 m/s^2, so the block lifts (towards theta < 0, docs/errata.md item 5).
  WriteFile(dir + "/accel.csv", "time,accel\n0,0\n0.1,0\n0.1001,3\n2,3\n");
  const CliResult r = RunCli({"simulate", "--alpha", "0.235", "--p", "3.884", "--mu", "0.937",
                              "--accel", dir + "/accel.csv", "--duration", "0.5", "--rate", "100",
                              "--out", dir + "/theta.csv", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_FALSE(j.at("uplift_time").is_null());
  EXPECT_NEAR(j.at("uplift_time").get<double>(), 0.1, 2e-4);
}

struct BadCase {
  std::vector<std::string> args;
  std::string must_name;  // the option or key the message must name
};

// Shows the command line in test names and failure messages.
void PrintTo(const BadCase& c, std::ostream* os) {
  for (const std::string& a : c.args) *os << a << ' ';
}

std::string BadCaseName(const ::testing::TestParamInfo<BadCase>& info) {
  std::string name = std::to_string(info.index) + "_";
  for (char ch : info.param.must_name) name += std::isalnum(static_cast<unsigned char>(ch)) ? ch : '_';
  return name;
}

class CliBadInput : public ::testing::TestWithParam<BadCase> {};

TEST_P(CliBadInput, OneLineNamingTheOptionExitCode2) {
  const BadCase& c = GetParam();
  const CliResult r = RunCli(c.args);
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_EQ(CountLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find(c.must_name), std::string::npos)
      << "message does not name " << c.must_name << ": " << r.err;
}

std::vector<std::string> Sim(std::vector<std::string> changes) {
  // A valid simulate command line, with `changes` (option, value pairs or
  // lone flags) replacing or adding to it.
  std::vector<std::pair<std::string, std::string>> base = {
      {"--alpha", "0.235"}, {"--p", "3.884"},   {"--mu", "0.937"},
      {"--duration", "1"},  {"--rate", "100"},  {"--out", "scratch/bad.csv"}};
  for (std::size_t i = 0; i < changes.size(); i += 2) {
    const std::string& key = changes[i];
    const std::string value = i + 1 < changes.size() ? changes[i + 1] : "";
    auto it = std::find_if(base.begin(), base.end(), [&](auto& kv) { return kv.first == key; });
    if (it != base.end()) {
      it->second = value;
    } else {
      base.emplace_back(key, value);
    }
  }
  std::vector<std::string> args = {"simulate"};
  for (auto& [k, v] : base) {
    args.push_back(k);
    if (!v.empty()) args.push_back(v);
  }
  return args;
}

INSTANTIATE_TEST_SUITE_P(
    Params, CliBadInput,
    ::testing::Values(
        BadCase{{"params", "--width", "0", "--height", "1"}, "--width"},
        BadCase{{"params", "--width", "-0.2", "--height", "1"}, "--width"},
        BadCase{{"params", "--width", "0.2", "--height", "abc"}, "--height"},
        BadCase{{"params", "--width", "0.2"}, "--height"},
        BadCase{{"params", "--width", "0.2", "--height", "1", "--chamfer", "0.2"}, "--chamfer"},
        BadCase{{"params", "--width", "0.2", "--height", "1", "--depth", "3"}, "--depth"},
        BadCase{{"params", "--width"}, "--width"}),
    BadCaseName);

INSTANTIATE_TEST_SUITE_P(
    Simulate, CliBadInput,
    ::testing::Values(
        BadCase{Sim({"--alpha", "0"}), "--alpha"},
        BadCase{Sim({"--alpha", "1.6"}), "--alpha"},
        BadCase{Sim({"--alpha", "-0.1"}), "--alpha"},
        BadCase{Sim({"--alpha", "nan"}), "--alpha"},
        BadCase{Sim({"--alpha", "abc"}), "--alpha"},
        BadCase{Sim({"--p", "0"}), "--p"},
        BadCase{Sim({"--p", "-3"}), "--p"},
        BadCase{Sim({"--mu", "0"}), "--mu"},
        BadCase{Sim({"--mu", "1.01"}), "--mu"},
        BadCase{Sim({"--mu", "0.9x"}), "--mu"},
        BadCase{Sim({"--duration", "-1"}), "--duration"},
        BadCase{Sim({"--rate", "0"}), "--rate"},
        BadCase{Sim({"--theta0", "2"}), "--theta0"},
        BadCase{Sim({"--l", "0"}), "--l"},
        BadCase{Sim({"--model", "newmark"}), "--model"},
        BadCase{Sim({"--frobnicate", "1"}), "--frobnicate"},
        BadCase{{"simulate", "--alpha", "0.2", "--p", "3", "--mu", "0.9", "--duration", "1",
                 "--rate", "10"},
                "--out"},
        BadCase{{"simulate", "--alpha", "0.2", "--p", "3", "--mu", "0.9", "--duration", "1",
                 "--rate", "10", "--out", "scratch/x.csv", "--alpha"},
                "--alpha"},
        BadCase{Sim({"--excitation", "sine:amp=0.006,frq=5,duration=2"}), "frq"},
        BadCase{Sim({"--excitation", "square:amp=0.006,freq=5,duration=2"}), "square"},
        BadCase{Sim({"--excitation", "sine:amp=x,freq=5,duration=2"}), "amp"},
        BadCase{Sim({"--excitation", "sine:amp=0.006,freq=-5,duration=2"}), "freq"},
        BadCase{Sim({"--accel", "scratch/does-not-exist.csv"}), "does-not-exist.csv"},
        BadCase{Sim({"--out", "/nonexistent-dir/x.csv"}), "/nonexistent-dir/x.csv"},
        // export checks its output's folder before the work, as report does.
        BadCase{{"export", "scratch/does-not-exist.lcm", "--out", "/nonexistent-dir/x.h5"}, "/nonexistent-dir"},
        BadCase{{"frobnicate"}, "frobnicate"}),
    BadCaseName);

// A malformed acceleration record names the file and line.
TEST(CliSimulate, BadAccelRecordNamesFileAndLine) {
  const std::string dir = ScratchDir("bad_accel");
  struct Case {
    std::string text;
    std::string line;
  };
  for (const Case& c : {Case{"time,accel\n0,0\n0.1,abc\n", ":3"},
                        Case{"time,accel\n0,0\n0.1\n", ":3"},
                        Case{"time,accel\n0,0\n0.2,1\n0.1,1\n", ":4"},
                        Case{"time,accel\n0,0\n0.1,nan\n", ":3"},
                        Case{"t,a\n0,0\n0.1,1\n", ":1"},
                        Case{"", "accel.csv"}}) {
    WriteFile(dir + "/accel.csv", c.text);
    const CliResult r = RunCli(Sim({"--accel", dir + "/accel.csv"}));
    EXPECT_EQ(r.exit_code, 2) << c.text;
    EXPECT_EQ(CountLines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find("accel.csv" + (c.line.front() == ':' ? c.line : "")), std::string::npos)
        << "for input:\n" << c.text << "got: " << r.err;
  }
}

// Bare `rocklab` and `rocklab help`: the command list, one line each.
// Oracle: every command's name starts a line, with its description.
TEST(CliHelp, CommandListOnBareRocklabAndHelp) {
  const CliResult bare = RunCli({});
  EXPECT_EQ(bare.exit_code, 2);
  const CliResult help = RunCli({"help"});
  ASSERT_EQ(help.exit_code, 0) << help.err;
  EXPECT_EQ(bare.err, help.out);
  for (const char* line : {"\n  simulate ", "\n  sweep-plot ", "\n  info ", "\n  export ", "\n  params "}) {
    EXPECT_NE(help.out.find(line), std::string::npos) << line << " missing in\n" << help.out;
  }
  EXPECT_NE(help.out.find("rocklab help COMMAND"), std::string::npos);
}

TEST(CliHelp, HelpCommandIsTheCommandsHelp) {
  const CliResult help = RunCli({"help", "simulate"});
  ASSERT_EQ(help.exit_code, 0) << help.err;
  const CliResult dash = RunCli({"simulate", "--help"});
  ASSERT_EQ(dash.exit_code, 0) << dash.err;
  EXPECT_NE(help.out.find("rocklab simulate"), std::string::npos) << help.out;
  EXPECT_NE(help.out.find("--duration"), std::string::npos) << help.out;
  for (const char* word : {"--alpha", "--accel", "--out"}) {
    EXPECT_NE(dash.out.find(word), std::string::npos) << word;
  }
}

// Typos: the message names what was typed as unknown and the nearest
// known name; one line, exit 2.
TEST(CliHelp, DidYouMean) {
  struct Case {
    std::vector<std::string> args;
    std::string says;
  };
  for (const Case& c : {Case{{"simulat"}, "unknown command 'simulat' (did you mean simulate?)"},
                        Case{{"sweepplot", "x.csv"}, "(did you mean sweep-plot?)"},
                        Case{{"help", "simulat"}, "(did you mean simulate?)"},
                        Case{Sim({"--duraton", "5"}), "unknown option --duraton (did you mean --duration?)"},
                        Case{Sim({"--alpah", "0.2"}), "unknown option --alpah (did you mean --alpha?)"},
                        Case{Sim({"--rate=100", "", "--ratee=5"}), "unknown option --ratee (did you mean --rate?)"},
                        Case{{"sweep-plot", "r.csv", "--outdir", "x"}, "(did you mean --out-dir?)"},
                        Case{Sim({"--frobnicate", "1"}), "unknown option --frobnicate; "},
                        // Swapped neighbours are one edit (issue 36's typos).
                        Case{Sim({"--otu", "x.csv"}), "unknown option --otu (did you mean --out?)"},
                        Case{{"report", "x.lcm", "--sgv", "x.svg"}, "unknown option --sgv (did you mean --svg?)"},
                        // A value that is not of the option's type names the
                        // command, the option, the value and the type.
                        Case{Sim({"--alpha", "abc"}), "simulate: --alpha: 'abc' is not a number"},
                        Case{{"fit", "x.csv", "--walkers", "many"}, "fit: --walkers: 'many' is not an integer"}}) {
    const CliResult r = RunCli(c.args);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(CountLines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find(c.says), std::string::npos) << r.err;
  }
  // help takes one command: more is said as such, not as an unknown command.
  const CliResult extra = RunCli({"help", "simulate", "x"});
  EXPECT_EQ(extra.exit_code, 2);
  EXPECT_NE(extra.err.find("takes one command"), std::string::npos) << extra.err;
  EXPECT_EQ(extra.err.find("unknown command"), std::string::npos) << extra.err;
  // A misspelt required option is reported as unknown, not as missing.
  std::vector<std::string> args = Sim({});
  for (auto& a : args) a = a == "--duration" ? "--duraton" : a;
  const CliResult r = RunCli(args);
  EXPECT_EQ(r.err.find("is required"), std::string::npos) << r.err;
}

// `--out -` is standard output (issue 36: it created a file named `-`),
// the summary then on stderr; the rows are those of a file written by the
// same command (oracle: that file, byte for byte).
TEST(CliConventions, OutDashIsStandardOutput) {
  std::vector<std::string> args = Sim({"--excitation", "sine:amp=0.02,freq=2,duration=1", "--out", "-"});
  const CliResult r = RunCli(args);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out.rfind("time,theta,theta_dot\n", 0), 0u) << r.out.substr(0, 80);
  EXPECT_NE(r.err.find("101 rows written to standard output"), std::string::npos) << r.err;
  for (auto& a : args) a = a == "-" ? "scratch/dash.csv" : a;
  ASSERT_EQ(RunCli(args).exit_code, 0);
  std::ifstream f("scratch/dash.csv", std::ios::binary);
  const std::string file((std::istreambuf_iterator<char>(f)), {});
  EXPECT_EQ(r.out, file);
  const CliResult both = RunCli(Sim({"--out", "-", "--events", "-"}));
  EXPECT_EQ(both.exit_code, 2) << both.err;
}

// The main input is positional in reconstruct, fit, run and daq, with
// --input kept as an alias (issue 36: positional in 8 commands, --input in 5).
TEST(CliConventions, InputIsPositionalWithInputAsAlias) {
  const std::string raw = ROCKLAB_SOURCE_DIR "/data/samples/fig7_block1.csv";
  const std::string rig = ROCKLAB_SOURCE_DIR "/data/rigs/block1_rig.toml";
  const CliResult a = RunCli({"reconstruct", raw, "--rig", rig, "--out", "-"});
  const CliResult b = RunCli({"reconstruct", "--input", raw, "--rig", rig, "--out", "-"});
  ASSERT_EQ(a.exit_code, 0) << a.err;
  EXPECT_EQ(a.out, b.out);
  EXPECT_GT(a.out.size(), 100000u);
  for (const char* command : {"fit", "run", "daq"}) {
    const CliResult help = RunCli({command, "--help"});
    EXPECT_NE(help.out.find("Positionals:\n  input"), std::string::npos) << command << ": " << help.out;
  }
}

// simulate --accel: without --duration, the record's end + 10 s (as sweep).
// Oracle: a record ending at 0.5 s at --rate 100 gives (0.5 + 10) * 100 + 1 rows.
TEST(CliSimulate, AccelRecordSetsTheDefaultDuration) {
  const std::string dir = ScratchDir("simulate_accel_duration");
  WriteFile(dir + "/accel.csv", "time,accel\n0,0\n0.25,0.01\n0.5,0\n");
  const CliResult r = RunCli({"simulate", "--alpha", "0.235", "--p", "3.884", "--mu", "0.937", "--accel",
                              dir + "/accel.csv", "--rate", "100", "--out", dir + "/theta.csv", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out).at("samples").get<int>(), 1051);
  const CliResult none = RunCli({"simulate", "--alpha", "0.235", "--p", "3.884", "--mu", "0.937", "--rate", "100",
                                 "--out", dir + "/theta.csv"});
  EXPECT_EQ(none.exit_code, 2);
  EXPECT_NE(none.err.find("--duration"), std::string::npos) << none.err;
}

}  // namespace
}  // namespace rocklab::test
