// `rocklab spy`: LCM's lcm-spy, started with the java command rocklab
// builds, decodes every rocklab channel of a replay. Runs headless under
// Xvfb, inside a private network namespace (udpm on lo, ttl=0: DESIGN.md).
//
// What it proves, and how:
// 1. `rocklab spy` itself starts lcm-spy on Debian's Java 17 (no -Xincgc,
//    the jars found from the installed packages): its JVM prints lcm-spy's
//    "Found N LCM types" line with N = the number of .lcm files, and is
//    still running (a window open, receiving) when the test stops it.
// 2. lcm-spy decodes the channels: a small Java probe (SpyTableProbe.java)
//    runs lcm-spy in the same JVM with the same class path and options
//    (taken from `rocklab spy --print-command`) and reads lcm-spy's own
//    channel table, the one it draws: for every channel of the replay, the
//    Type column is the rocklab type (lcm-spy's fingerprint lookup, "??"
//    when unknown), Num Msgs > 0 and Undecodable = 0.
// Oracle: the channel -> type table of docs/channels.md.
// Without Java, Xvfb or a namespace the test skips saying why; under
// CI=true it fails instead.
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "tests/skip.h"
#include "tests/tools/run_cli.h"
#include "tests/tools/udpm_netns.h"
#include "tests/source_paths.h"

namespace rocklab::tools {
namespace {

using ::rocklab::test::kSource;  // tests/source_paths.h

// Every channel of the replay and its rocklab type (docs/channels.md).
const std::map<std::string, std::string> kExpected = {
    {"RL_DAQ_CONFIG", "daq_config2_t"},       {"RL_RAW", "raw_frame_t"},
    {"RL_TABLE", "table_state_t"},           {"RL_THETA", "block_state_t"},
    {"RL_MODEL_fitted", "model_state3_t"},   {"RL_MODEL_theory", "model_state3_t"},
    {"RL_COMPARE_fitted", "comparison2_t"},   {"RL_COMPARE_theory", "comparison2_t"},
    {"RL_HEALTH", "health2_t"}};

std::vector<std::string> Split(const std::string& line, char sep) {
  std::vector<std::string> out;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, sep)) out.push_back(field);
  return out;
}

// Waits for Xvfb's socket of display `n`.
bool WaitForDisplay(int n, double timeout_s) {
  const std::string socket = "/tmp/.X11-unix/X" + std::to_string(n);
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  struct stat st {};
  while (std::chrono::steady_clock::now() < end) {
    if (::stat(socket.c_str(), &st) == 0) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return false;
}

TEST(RocklabSpy, DecodesEveryChannelOfAReplayUnderXvfb) {
  const std::string probe_dir = ROCKLAB_SPY_PROBE_DIR;
  if (probe_dir.empty()) ROCKLAB_SKIP("the build found no javac or lcm.jar (no probe built)");
  if (::access("/usr/bin/Xvfb", X_OK) != 0) ROCKLAB_SKIP("no /usr/bin/Xvfb (Debian: xvfb)");

  // The record: rocklab run --log of the bundled figure-7 test, two variants.
  const std::string dir = test::ScratchDir("spy");
  const std::string log = dir + "/fig7.lcm";
  const test::CliResult made = test::RunCli(
      {"run", "--rig", kSource + "/data/rigs/block1_rig.toml", "--input",
       kSource + "/data/samples/fig7_block1.csv", "--max", "--variant",
       "fitted:complex:alpha=0.235,p=3.884,mu=0.937", "--variant", "theory:housner:theoretical",
       "--log", log});
  ASSERT_EQ(made.exit_code, 0) << made.err;

  // The command rocklab runs (printed, not run: no display needed).
  const test::CliResult printed = test::RunCli({"spy", "--lcm-url", test::kUdpmUrl, "--print-command"});
  ASSERT_EQ(printed.exit_code, 0) << printed.err;
  std::string command_line = printed.out;
  while (!command_line.empty() && command_line.back() == '\n') command_line.pop_back();
  // Arguments are shell-quoted where needed ('...'; the URL's '?'); none
  // holds a space or a quote here, so a split on spaces reads them back.
  std::vector<std::string> java = Split(command_line, ' ');
  for (std::string& arg : java) {
    if (arg.size() >= 2 && arg.front() == '\'' && arg.back() == '\'') arg = arg.substr(1, arg.size() - 2);
    ASSERT_EQ(arg.find('\''), std::string::npos) << command_line;
  }
  ASSERT_GE(java.size(), 4u) << command_line;
  EXPECT_EQ(java[0], "java");
  EXPECT_EQ(command_line.find("-Xincgc"), std::string::npos) << command_line;  // Java 17 refuses it
  EXPECT_NE(command_line.find("jchart2d"), std::string::npos) << command_line;
  EXPECT_NE(command_line.find("rocklab_lcmtypes.jar"), std::string::npos) << command_line;

  std::size_t lcm_files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kSource + "/lcm_types")) {
    lcm_files += entry.path().extension() == ".lcm";
  }

  const std::string why = test::EnterPrivateNetwork();
  if (!why.empty()) ROCKLAB_SKIP(why);

  const int display = 50 + static_cast<int>(::getpid() % 400);
  const std::string display_name = ":" + std::to_string(display);
  const pid_t xvfb = test::StartProcess({"Xvfb", display_name, "-nolisten", "tcp", "-screen", "0",
                                         "1280x800x24"},
                                        dir + "/xvfb.out", dir + "/xvfb.err");
  ASSERT_GT(xvfb, 0);
  ASSERT_TRUE(WaitForDisplay(display, 20)) << test::ReadFile(dir + "/xvfb.err");
  ASSERT_EQ(::setenv("DISPLAY", display_name.c_str(), 1), 0);

  // The replay loops at 1x for as long as the spies listen; RL_RAW on the
  // main group too (--raw-url same), so that one spy sees every rocklab type.
  const pid_t replay = test::StartCli({"replay", log, "--speed", "1", "--loop", "--lcm-url",
                                       test::kUdpmUrl, "--raw-url", "same"},
                                      dir + "/replay.out", dir + "/replay.err");
  ASSERT_GT(replay, 0);

  // 1. `rocklab spy` as a user starts it.
  const pid_t spy = test::StartCli({"spy", "--lcm-url", test::kUdpmUrl}, dir + "/spy.out",
                                   dir + "/spy.err");
  ASSERT_GT(spy, 0);
  // It must still be running once the probe below has seen every channel
  // (a condition, not a fixed sleep): it is stopped after the probe.
  const std::string found = test::WaitForLine(dir + "/spy.out", "Found ", 40);
  EXPECT_EQ(found, "Found " + std::to_string(lcm_files) + " LCM types")
      << "stdout: " << test::ReadFile(dir + "/spy.out") << "\nstderr: " << test::ReadFile(dir + "/spy.err");

  // 2. lcm-spy's own channel table, read by the probe in the same JVM.
  for (std::size_t i = 0; i < java.size(); ++i) {
    if (java[i] == "-cp" && i + 1 < java.size()) java[i + 1] += ":" + probe_dir;
  }
  ASSERT_EQ(java.back().rfind("--lcm-url=", 0), 0u) << command_line;
  const auto main_class = java.end() - 2;
  ASSERT_EQ(*main_class, "lcm.spy.Spy") << command_line;
  *main_class = "SpyTableProbe";
  // The probe prints the table once every expected channel has a message
  // (RL_DAQ_CONFIG comes once per replay pass), or at a generous deadline.
  std::string expect_list;
  for (const auto& entry : kExpected) expect_list += (expect_list.empty() ? "" : ",") + entry.first;
  java.insert(java.begin() + 1, "-Dprobe.seconds=90");
  java.insert(java.begin() + 1, "-Dprobe.expect=" + expect_list);
  const pid_t probe = test::StartProcess(java, dir + "/probe.out", dir + "/probe.err");
  ASSERT_GT(probe, 0);
  const int probe_exit = test::StopProcess(probe, 0, 120);
  const int spy_exit = test::StopProcess(spy, SIGTERM, 10);
  EXPECT_EQ(spy_exit, 128 + SIGTERM) << "lcm-spy was not running when stopped; stderr: "
                                      << test::ReadFile(dir + "/spy.err");
  test::StopProcess(replay, SIGINT, 10);
  test::StopProcess(xvfb, SIGTERM, 10);
  const std::string table = test::ReadFile(dir + "/probe.out");
  ASSERT_EQ(probe_exit, 0) << table << test::ReadFile(dir + "/probe.err");

  std::vector<std::string> columns;
  std::map<std::string, std::map<std::string, std::string>> rows;  // channel -> column -> text
  std::istringstream lines(table);
  for (std::string line; std::getline(lines, line);) {
    std::vector<std::string> f = Split(line, '\t');
    if (f.empty()) continue;
    if (f[0] == "COLUMNS") columns.assign(f.begin() + 1, f.end());
    if (f[0] != "ROW" || f.size() != columns.size() + 1) continue;
    for (std::size_t c = 0; c < columns.size(); ++c) rows[f[1]][columns[c]] = f[c + 1];
  }
  ASSERT_FALSE(rows.empty()) << table;
  for (const auto& [channel, type] : kExpected) {
    SCOPED_TRACE(channel);
    ASSERT_TRUE(rows.count(channel)) << table;
    const auto& row = rows.at(channel);
    EXPECT_EQ(row.at("Type"), type) << table;
    EXPECT_GT(std::stol(row.at("Num Msgs")), 0) << table;
    EXPECT_EQ(row.at("Undecodable"), "0") << table;
  }
  // Every row (RL_EVENT too, when the replay reached one) has a known type.
  for (const auto& [channel, row] : rows) {
    EXPECT_EQ(row.at("Type").rfind("??", 0), std::string::npos) << channel << ": " << table;
  }
}

}  // namespace
}  // namespace rocklab::tools
